// host/scene/study/cmaes.h — the CMA evolution strategy, (μ/μ_w, λ) with
// rank-one and active rank-μ updates and cumulative step-size adaptation,
// after Hansen (2016), "The CMA Evolution Strategy: A Tutorial"
// (arXiv:1604.00772), its default parameters (Table 1, α_cov = 2):
//   λ = 4 + ⌊3 ln n⌋, μ = ⌊λ/2⌋, w'_i = ln((λ+1)/2) − ln i (i = 1 … λ)
//   μ_eff = (Σ_{i≤μ} w'_i)²/Σ_{i≤μ} w'_i², μ⁻_eff the same over i > μ
//   c_σ = (μ_eff + 2)/(n + μ_eff + 5), d_σ = 1 + 2 max(0, √((μ_eff−1)/(n+1)) − 1) + c_σ
//   c_c = (4 + μ_eff/n)/(n + 4 + 2μ_eff/n), c_1 = 2/((n + 1.3)² + μ_eff)
//   c_μ = min(1 − c_1, 2(μ_eff − 2 + 1/μ_eff)/((n + 2)² + μ_eff))
//   w_i = w'_i/Σ_{j≤μ} w'_j (i ≤ μ: positive, sum 1), and for i > μ (negative)
//   w_i = min(1 + c_1/c_μ, 1 + 2μ⁻_eff/(μ_eff + 2), (1 − c_1 − c_μ)/(n c_μ)) w'_i/Σ_{j>μ}|w'_j|
// Generation: y_k = B D z_k (z ~ N(0, I), C = B D² Bᵀ), x_k = m + σ y_k; then,
// with y_{i:λ} the steps ranked by objective,
//   m ← m + σ y_w, y_w = Σ_{i≤μ} w_i y_{i:λ} (the μ best)
//   p_σ ← (1 − c_σ) p_σ + √(c_σ(2 − c_σ)μ_eff) C^{−½} y_w
//   h_σ = [|p_σ|/√(1 − (1 − c_σ)^{2(g+1)}) < (1.4 + 2/(n+1)) E|N(0,I)|]
//   p_c ← (1 − c_c) p_c + h_σ √(c_c(2 − c_c)μ_eff) y_w
//   C ← (1 + c_1 δ − c_1 − c_μ Σ_i w_i) C + c_1 p_c p_cᵀ + c_μ Σ_{i≤λ} w°_i y_{i:λ} y_{i:λ}ᵀ
//       δ = (1 − h_σ) c_c(2 − c_c), w°_i = w_i (i ≤ μ), w_i n/|C^{−½} y_{i:λ}|² (i > μ)
//   σ ← σ exp((c_σ/d_σ)(|p_σ|/E|N(0,I)| − 1))
// The negative weights (the "active" update) shrink C along the worst
// candidates' steps; their sum is capped so that C stays positive definite
// (the third bound), and w°'s normalisation keeps a long unlucky step from
// dominating. The normal numbers come from manyrods/rng.h through the normal
// quantile (the same on every platform); ties in the ranking keep the
// candidates' order (a stable sort), so a run is reproducible for a seed. A
// failed candidate (objective not finite; NaN ranks as +inf) gets no
// weight, positive or negative: among the μ best, the others' positive
// weights are renormalised (and μ_eff the paths use with them); among the
// rest its negative weight is dropped (the others' are not scaled up). A
// generation in which every candidate failed changes nothing (the next one
// draws afresh).
//
// save/restore write and read the whole state as text (hexadecimal
// floating point: exact), so that a search stopped after a generation and
// restored goes on bit for bit as one that never stopped.
//
// Reads and writes: its own state only.
#pragma once

#include <Eigen/Dense>
#include <algorithm>
#include <cinttypes>
#include <cmath>
#include <cstdint>
#include <cstdio>
#include <cstdlib>
#include <numeric>
#include <string>
#include <vector>

#include "manyrods/rng.h"
#include "manyrods/sampling.h"

namespace manyrods::scene {

class CmaEs {
 public:
  // n dimensions, the start mean and step size, λ (≤ 0: the default, at
  // least 8), the seed
  CmaEs(int n, const std::vector<double>& mean, double sigma, int lambda, std::uint64_t seed)
      : n_(n), lambda_(lambda > 0 ? lambda : std::max(8, 4 + int(std::floor(3 * std::log(double(n)))))),
        sigma_(sigma), rng_{seed} {
    m_ = Eigen::Map<const Eigen::VectorXd>(mean.data(), n);
    mu_ = lambda_ / 2;
    Eigen::VectorXd raw(lambda_);
    for (int i = 0; i < lambda_; ++i) raw[i] = std::log((lambda_ + 1) / 2.0) - std::log(double(i + 1));
    w_ = raw.head(mu_) / raw.head(mu_).sum();
    mueff_ = 1 / w_.squaredNorm();
    const double nd = n;
    cs_ = (mueff_ + 2) / (nd + mueff_ + 5);
    ds_ = 1 + 2 * std::max(0.0, std::sqrt((mueff_ - 1) / (nd + 1)) - 1) + cs_;
    cc_ = (4 + mueff_ / nd) / (nd + 4 + 2 * mueff_ / nd);
    c1_ = 2 / ((nd + 1.3) * (nd + 1.3) + mueff_);
    cmu_ = std::min(1 - c1_, 2 * (mueff_ - 2 + 1 / mueff_) / ((nd + 2) * (nd + 2) + mueff_));
    chin_ = std::sqrt(nd) * (1 - 1 / (4 * nd) + 1 / (21 * nd * nd));
    // the negative weights of the ranks after μ (a zero one in the middle where λ is odd)
    wneg_ = Eigen::VectorXd::Zero(lambda_ - mu_);
    const Eigen::VectorXd tail = raw.tail(lambda_ - mu_);
    const double tail_sum = -tail.sum();
    if (tail_sum > 0 && cmu_ > 0) {
      const double mueff_minus = tail.sum() * tail.sum() / tail.squaredNorm();
      const double cap = std::min({1 + c1_ / cmu_, 1 + 2 * mueff_minus / (mueff_ + 2), (1 - c1_ - cmu_) / (nd * cmu_)});
      if (cap > 0) wneg_ = cap * tail / tail_sum;
    }
    C_ = Eigen::MatrixXd::Identity(n, n);
    B_ = C_, D_ = Eigen::VectorXd::Ones(n);
    ps_ = pc_ = Eigen::VectorXd::Zero(n);
  }

  // The strategy's parameters (the formulas above), for checks against
  // other implementations.
  struct Parameters {
    std::vector<double> weights;           // w_1 … w_μ
    std::vector<double> negative_weights;  // w_{μ+1} … w_λ
    double mueff, cs, ds, cc, c1, cmu;
  };
  Parameters parameters() const {
    return {std::vector<double>(w_.data(), w_.data() + mu_), std::vector<double>(wneg_.data(), wneg_.data() + wneg_.size()),
            mueff_, cs_, ds_, cc_, c1_, cmu_};
  }

  int lambda() const { return lambda_; }
  double step() const { return sigma_; }
  // the longest axis of the search distribution (√ of C's largest eigenvalue)
  double max_axis() const { return D_.maxCoeff(); }
  std::vector<double> mean() const { return {m_.data(), m_.data() + n_}; }

  // The state between generations (after tell, or the start) as text, and
  // back: restore returns false where the text is not a state of a search
  // of this n and λ.
  std::string save() const {
    std::string out;
    char buf[64];
    auto num = [&](double x) {
      std::snprintf(buf, sizeof buf, " %a", x);
      out += buf;
    };
    std::snprintf(buf, sizeof buf, "cmaes %d %d %d %" PRIu64, n_, lambda_, gen_, rng_.s);
    out += buf;
    num(sigma_);
    for (const Eigen::VectorXd* v : {&m_, &ps_, &pc_})
      for (int i = 0; i < n_; ++i) num((*v)[i]);
    for (int i = 0; i < n_; ++i)
      for (int j = 0; j < n_; ++j) num(C_(i, j));
    return out;
  }
  bool restore(const std::string& text) {
    const char* p = text.c_str();
    int n = 0, lambda = 0, gen = 0, used = 0;
    std::uint64_t s = 0;
    if (std::sscanf(p, "cmaes %d %d %d %" SCNu64 "%n", &n, &lambda, &gen, &s, &used) != 4 || n != n_ ||
        lambda != lambda_ || gen < 0)
      return false;
    p += used;
    auto num = [&](double& x) {
      char* end = nullptr;
      x = std::strtod(p, &end);
      if (end == p) return false;
      p = end;
      return true;
    };
    double sigma = 0;
    Eigen::VectorXd m(n_), ps(n_), pc(n_);
    Eigen::MatrixXd C(n_, n_);
    if (!num(sigma)) return false;
    for (Eigen::VectorXd* v : {&m, &ps, &pc})
      for (int i = 0; i < n_; ++i)
        if (!num((*v)[i])) return false;
    for (int i = 0; i < n_; ++i)
      for (int j = 0; j < n_; ++j)
        if (!num(C(i, j))) return false;
    if (!(sigma > 0) || !std::isfinite(sigma) || !m.allFinite() || !C.allFinite() || !ps.allFinite() || !pc.allFinite())
      return false;
    gen_ = gen, rng_.s = s, sigma_ = sigma, m_ = m, ps_ = ps, pc_ = pc, C_ = C;
    decompose();
    return true;
  }

  // λ candidates
  std::vector<std::vector<double>> ask() {
    y_.assign(std::size_t(lambda_), Eigen::VectorXd(n_));
    std::vector<std::vector<double>> out(static_cast<std::size_t>(lambda_), std::vector<double>(static_cast<std::size_t>(n_)));
    for (int k = 0; k < lambda_; ++k) {
      Eigen::VectorXd z(n_);
      for (int i = 0; i < n_; ++i) z[i] = normal_quantile(rng_.next() + 0x1.0p-54);
      y_[std::size_t(k)] = B_ * D_.asDiagonal() * z;
      const Eigen::VectorXd x = m_ + sigma_ * y_[std::size_t(k)];
      for (int i = 0; i < n_; ++i) out[std::size_t(k)][std::size_t(i)] = x[i];
    }
    return out;
  }

  // The candidates as evaluated (x: possibly moved back into the feasible
  // box, which then replaces the sample) and their objective values
  // (smaller is better; +inf for a failed one).
  void tell(const std::vector<std::vector<double>>& x, const std::vector<double>& f) {
    y_.resize(std::size_t(lambda_));  // (rebuilt from x below: a tell without its ask is a tell of those points)
    // (NaN ranks as +inf: a failed candidate; a strict weak order for the sort)
    auto value = [&](int k) { return std::isnan(f[std::size_t(k)]) ? HUGE_VAL : f[std::size_t(k)]; };
    std::vector<int> order(static_cast<std::size_t>(lambda_));
    std::iota(order.begin(), order.end(), 0);
    std::stable_sort(order.begin(), order.end(), [&](int a, int b) { return value(a) < value(b); });
    // the steps taken (a repaired candidate's, its length under C limited to
    // √n + 2n/(n + 2) as for injected solutions, Hansen 2011, so that a
    // reflection far off the distribution does not blow up the paths)
    const Eigen::MatrixXd Cinvsqrt = B_ * D_.cwiseInverse().asDiagonal() * B_.transpose();
    const double longest = std::sqrt(double(n_)) + 2.0 * n_ / (n_ + 2.0);
    for (int k = 0; k < lambda_; ++k) {
      Eigen::VectorXd& y = y_[std::size_t(k)];
      y = (Eigen::Map<const Eigen::VectorXd>(x[std::size_t(k)].data(), n_) - m_) / sigma_;
      const double len = (Cinvsqrt * y).norm();
      if (len > longest) y *= longest / len;
    }
    // the weights of the μ best; a failed candidate (f not finite) among
    // them gets none, the others' renormalised (its step is a random draw,
    // not a direction towards anything better)
    Eigen::VectorXd w = w_;
    for (int i = 0; i < mu_; ++i)
      if (!std::isfinite(f[std::size_t(order[std::size_t(i)])])) w[i] = 0;
    if (!(w.sum() > 0)) {  // none ran: nothing learnt, the next generation draws afresh from the same distribution
      ++gen_;
      return;
    }
    double mueff = mueff_;  // (of the weights used: the paths' normalisation)
    if (w != w_) {
      w /= w.sum();
      mueff = 1 / w.squaredNorm();
    }
    Eigen::VectorXd yw = Eigen::VectorXd::Zero(n_);
    for (int i = 0; i < mu_; ++i) yw += w[i] * y_[std::size_t(order[std::size_t(i)])];
    m_ += sigma_ * yw;
    ps_ = (1 - cs_) * ps_ + std::sqrt(cs_ * (2 - cs_) * mueff) * (Cinvsqrt * yw);
    ++gen_;
    const double hs_norm = ps_.norm() / std::sqrt(1 - std::pow(1 - cs_, 2.0 * gen_));
    const bool hs = hs_norm < (1.4 + 2 / (n_ + 1.0)) * chin_;
    pc_ = (1 - cc_) * pc_ + (hs ? std::sqrt(cc_ * (2 - cc_) * mueff) : 0.0) * yw;
    Eigen::MatrixXd rank_mu = Eigen::MatrixXd::Zero(n_, n_);
    double wsum = 0;  // Σ w_i over the weights used, positive and negative
    for (int i = 0; i < mu_; ++i) {
      const Eigen::VectorXd& y = y_[std::size_t(order[std::size_t(i)])];
      rank_mu += w[i] * y * y.transpose();
      wsum += w[i];
    }
    for (int i = mu_; i < lambda_; ++i) {  // the active part
      const int k = order[std::size_t(i)];
      const double wi = wneg_[i - mu_];
      if (wi == 0 || !std::isfinite(f[std::size_t(k)])) continue;
      const Eigen::VectorXd& y = y_[std::size_t(k)];
      const double len2 = (Cinvsqrt * y).squaredNorm();
      if (!(len2 > 0)) continue;
      rank_mu += (wi * n_ / len2) * y * y.transpose();
      wsum += wi;
    }
    C_ = (1 - c1_ - cmu_ * wsum) * C_ + c1_ * (pc_ * pc_.transpose() + (hs ? 0.0 : cc_ * (2 - cc_)) * C_) +
         cmu_ * rank_mu;
    sigma_ *= std::exp((cs_ / ds_) * (ps_.norm() / chin_ - 1));
    // (symmetrised against round-off)
    C_ = 0.5 * (C_ + C_.transpose());
    decompose();
  }

 private:
  // C = B D² Bᵀ
  void decompose() {
    Eigen::SelfAdjointEigenSolver<Eigen::MatrixXd> eig(C_);
    B_ = eig.eigenvectors();
    D_ = eig.eigenvalues().cwiseMax(1e-300).cwiseSqrt();
  }

  int n_, lambda_, mu_ = 0, gen_ = 0;
  double sigma_, mueff_ = 0, cs_ = 0, ds_ = 0, cc_ = 0, c1_ = 0, cmu_ = 0, chin_ = 0;
  Rng rng_;
  Eigen::VectorXd m_, w_, wneg_, ps_, pc_, D_;
  Eigen::MatrixXd C_, B_;
  std::vector<Eigen::VectorXd> y_;
};

// x folded back into [0, 1] by reflection at its ends (periodic with
// period 2), the bound handling of a box-constrained search.
inline double reflect_unit(double x) {
  double r = std::fmod(std::abs(x), 2.0);
  return r > 1 ? 2 - r : r;
}

}  // namespace manyrods::scene
