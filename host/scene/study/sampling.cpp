// host/scene/study/sampling.cpp — sample designs and the normal distribution's CDF and
// quantile (include/manyrods/sampling.h).
#include "manyrods/sampling.h"

#include <algorithm>
#include <array>
#include <cmath>
#include <numbers>

#include "manyrods/rng.h"
#include "manyrods/scene.h"  // SceneError

namespace manyrods::scene {
namespace {

// Sobol' direction numbers (Joe & Kuo 2008, new-joe-kuo-6.21201) for
// dimensions 2 … 21: the primitive polynomial as an integer (its degree s is
// the bit length − 1, the leading and trailing coefficients are 1) and the
// initial values m_1 … m_s (odd, m_k < 2^k). Dimension 1 is the van der
// Corput sequence (all m_k = 1, no recurrence).
struct SobolDim {
  unsigned poly;
  std::array<unsigned, 7> m;
};
constexpr SobolDim kSobol[] = {
    {3, {1}},
    {7, {1, 3}},
    {11, {1, 3, 1}},
    {13, {1, 1, 1}},
    {19, {1, 1, 3, 3}},
    {25, {1, 3, 5, 13}},
    {37, {1, 1, 5, 5, 17}},
    {41, {1, 1, 5, 5, 5}},
    {47, {1, 1, 7, 11, 19}},
    {55, {1, 1, 5, 1, 1}},
    {59, {1, 1, 1, 3, 11}},
    {61, {1, 3, 5, 5, 31}},
    {67, {1, 3, 3, 9, 7, 49}},
    {91, {1, 1, 1, 15, 21, 21}},
    {97, {1, 3, 1, 13, 27, 49}},
    {103, {1, 1, 1, 15, 7, 5}},
    {109, {1, 3, 1, 15, 13, 25}},
    {115, {1, 1, 5, 5, 19, 61}},
    {131, {1, 3, 7, 11, 23, 15, 103}},
    {137, {1, 3, 7, 13, 13, 15, 69}},
};
constexpr int kSobolDims = 1 + int(sizeof(kSobol) / sizeof(kSobol[0]));
constexpr int kBits = 32;

// V_1 … V_32 of one dimension (V_k = m_k·2^(32−k) for k ≤ s, then the
// recurrence V_k = V_{k−s} ⊕ (V_{k−s} >> s) ⊕ ⊕_{j<s} a_j V_{k−j}).
std::array<std::uint32_t, kBits> sobol_directions(int dim) {
  std::array<std::uint32_t, kBits> v{};
  if (dim == 0) {
    for (int k = 0; k < kBits; ++k) v[k] = std::uint32_t(1) << (kBits - 1 - k);
    return v;
  }
  const SobolDim& d = kSobol[dim - 1];
  int s = 0;
  while ((d.poly >> (s + 1)) != 0) ++s;
  for (int k = 0; k < s; ++k) v[k] = std::uint32_t(d.m[k]) << (kBits - 1 - k);
  for (int k = s; k < kBits; ++k) {
    std::uint32_t x = v[k - s] ^ (v[k - s] >> s);
    for (int j = 1; j < s; ++j)
      if ((d.poly >> (s - j)) & 1u) x ^= v[k - j];
    v[k] = x;
  }
  return v;
}

std::uint32_t random_bits(Rng& rng) { return std::uint32_t(rng.next() * 4294967296.0); }

std::vector<std::vector<double>> sobol_points(const Design& des, int dims) {
  if (dims > kSobolDims)
    throw SceneError("--design sobol: at most " + std::to_string(kSobolDims) + " varied parameters (got " +
                     std::to_string(dims) + "); use lhs or mc");
  Rng rng{des.seed};
  std::vector<std::array<std::uint32_t, kBits>> v(dims);
  std::vector<std::uint32_t> shift(dims, 0);
  for (int d = 0; d < dims; ++d) {
    v[d] = sobol_directions(d);
    if (!des.scramble) continue;
    // linear matrix scramble: V_k ← L V_k with L lower triangular (bit 31
    // the top row), unit diagonal, random entries below it; then a
    // random digital shift
    std::array<std::uint32_t, kBits> rows{};  // row r of L, as the bits of the columns it combines
    for (int r = 0; r < kBits; ++r) {
      const std::uint32_t diag = std::uint32_t(1) << (kBits - 1 - r);
      const std::uint32_t above = r == 0 ? 0u : ~((diag << 1) - 1u);  // columns left of the diagonal (higher bits)
      rows[r] = diag | (random_bits(rng) & above);
    }
    for (int k = 0; k < kBits; ++k) {
      std::uint32_t out = 0;
      for (int r = 0; r < kBits; ++r)
        if (__builtin_parity(rows[r] & v[d][k])) out |= std::uint32_t(1) << (kBits - 1 - r);
      v[d][k] = out;
    }
    shift[d] = random_bits(rng);
  }
  std::vector<std::vector<double>> pts(static_cast<std::size_t>(des.samples), std::vector<double>(dims));
  std::vector<std::uint32_t> x(shift);
  for (int i = 0; i < des.samples; ++i) {
    if (i > 0) {
      const int c = __builtin_ctz(unsigned(i));  // Gray code: the bit that changes from point i − 1 to i
      for (int d = 0; d < dims; ++d) x[d] ^= v[d][c];
    }
    for (int d = 0; d < dims; ++d) pts[i][d] = (double(x[d]) + 0.5) * 0x1.0p-32;
  }
  return pts;
}

std::vector<std::vector<double>> lhs_points(const Design& des, int dims) {
  Rng rng{des.seed};
  const int n = des.samples;
  std::vector<std::vector<double>> pts(static_cast<std::size_t>(n), std::vector<double>(dims));
  std::vector<int> perm(static_cast<std::size_t>(n));
  for (int d = 0; d < dims; ++d) {
    for (int i = 0; i < n; ++i) perm[i] = i;
    for (int i = n - 1; i > 0; --i) std::swap(perm[i], perm[std::min(i, int(rng.next() * double(i + 1)))]);
    for (int i = 0; i < n; ++i) pts[i][d] = (double(perm[i]) + rng.next()) / double(n);
  }
  return pts;
}

}  // namespace

DesignKind parse_design(const std::string& name) {
  if (name == "grid") return DesignKind::grid;
  if (name == "mc") return DesignKind::mc;
  if (name == "lhs") return DesignKind::lhs;
  if (name == "sobol") return DesignKind::sobol;
  if (name == "saltelli") return DesignKind::saltelli;
  throw SceneError("--design " + name + ": expected grid, mc, lhs, sobol or saltelli");
}

const char* design_name(DesignKind k) {
  switch (k) {
    case DesignKind::grid: return "grid";
    case DesignKind::mc: return "mc";
    case DesignKind::lhs: return "lhs";
    case DesignKind::sobol: return "sobol";
    case DesignKind::saltelli: return "saltelli";
  }
  return "?";
}

Design make_design(const std::string& kind, int samples, std::uint64_t seed) {
  Design d{samples > 0 ? DesignKind::mc : DesignKind::grid, samples, seed};
  if (!kind.empty()) d.kind = parse_design(kind);
  if (d.kind == DesignKind::grid && samples > 0)
    throw SceneError("--design grid runs every combination of the --vary lists; --samples applies to mc, lhs, sobol, saltelli");
  if (d.kind != DesignKind::grid && samples < 1)
    throw SceneError(std::string("--design ") + design_name(d.kind) + " needs --samples N");
  return d;
}

std::vector<std::vector<double>> unit_points(const Design& des, int dims) {
  if (des.kind == DesignKind::grid) throw SceneError("the grid design has no unit points");
  if (des.samples < 1) throw SceneError(std::string("--design ") + design_name(des.kind) + ": give --samples N >= 1");
  if (dims < 1) throw SceneError("sweep: give at least one --vary");
  switch (des.kind) {
    case DesignKind::lhs: return lhs_points(des, dims);
    case DesignKind::sobol: return sobol_points(des, dims);
    case DesignKind::saltelli: {
      Design base = des;
      base.kind = 2 * dims <= kSobolDims ? DesignKind::sobol : DesignKind::mc;
      const auto ab = unit_points(base, 2 * dims);
      const std::size_t n = std::size_t(des.samples), d = std::size_t(dims);
      std::vector<std::vector<double>> pts;
      pts.reserve(n * (d + 2));
      for (const auto& p : ab) pts.emplace_back(p.begin(), p.begin() + std::ptrdiff_t(d));  // A
      for (const auto& p : ab) pts.emplace_back(p.begin() + std::ptrdiff_t(d), p.end());    // B
      for (std::size_t i = 0; i < d; ++i)
        for (std::size_t k = 0; k < n; ++k) {  // A_B^(i)
          pts.push_back(pts[k]);
          pts.back()[i] = pts[n + k][i];
        }
      return pts;
    }
    default: break;
  }
  // mc: point by point, parameter by parameter, from one stream (the order
  // of the random sweeps before designs existed: the same samples)
  Rng rng{des.seed};
  std::vector<std::vector<double>> pts(static_cast<std::size_t>(des.samples), std::vector<double>(dims));
  for (auto& p : pts)
    for (double& u : p) u = rng.next();
  return pts;
}

double normal_cdf(double x) { return 0.5 * std::erfc(-x / std::numbers::sqrt2); }

double normal_quantile(double p) {
  if (!(p > 0 && p < 1)) return p == 0 ? -HUGE_VAL : p == 1 ? HUGE_VAL : std::nan("");
  // Acklam's rational approximation (relative error below 1.2e-9) …
  static constexpr double a[] = {-3.969683028665376e+01, 2.209460984245205e+02, -2.759285104469687e+02,
                                 1.383577518672690e+02,  -3.066479806614716e+01, 2.506628277459239e+00};
  static constexpr double b[] = {-5.447609879822406e+01, 1.615858368580409e+02, -1.556989798598866e+02,
                                 6.680131188771972e+01,  -1.328068155288572e+01};
  static constexpr double c[] = {-7.784894002430293e-03, -3.223964580411365e-01, -2.400758277161838e+00,
                                 -2.549732539343734e+00, 4.374664141464968e+00,  2.938163982698783e+00};
  static constexpr double d[] = {7.784695709041462e-03, 3.224671290700398e-01, 2.445134137142996e+00,
                                 3.754408661907416e+00};
  constexpr double lo = 0.02425;
  double x;
  if (p < lo || p > 1 - lo) {
    const double q = std::sqrt(-2 * std::log(p < lo ? p : 1 - p));
    x = (((((c[0] * q + c[1]) * q + c[2]) * q + c[3]) * q + c[4]) * q + c[5]) /
        ((((d[0] * q + d[1]) * q + d[2]) * q + d[3]) * q + 1);
    if (p > 1 - lo) x = -x;
  } else {
    const double q = p - 0.5, r = q * q;
    x = (((((a[0] * r + a[1]) * r + a[2]) * r + a[3]) * r + a[4]) * r + a[5]) * q /
        (((((b[0] * r + b[1]) * r + b[2]) * r + b[3]) * r + b[4]) * r + 1);
  }
  // … and one Halley step on Φ(x) − p (cubic convergence: full precision)
  // (1 − p is exact for p ≥ ½, and the upper tail keeps its digits in erfc)
  const double err = p < 0.5 ? normal_cdf(x) - p : (1 - p) - 0.5 * std::erfc(x / std::numbers::sqrt2);
  const double u = err * std::sqrt(2 * std::numbers::pi) * std::exp(0.5 * x * x);
  return x - u / (1 + 0.5 * x * u);
}

}  // namespace manyrods::scene
