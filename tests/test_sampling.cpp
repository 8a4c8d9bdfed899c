// Sample designs and distributions of Monte Carlo sweeps
// (include/manyrods/sampling.h, include/manyrods/sweep.h): the normal
// quantile to full precision, the Sobol' sequence against its published
// values and its net property after scrambling, Latin-hypercube
// stratification, the --vary distributions' inverse CDFs, and reproducibility.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <limits>
#include <numeric>
#include <vector>

#include "manyrods/scene.h"
#include "manyrods/h5io.h"
#include "manyrods/sweep.h"

using namespace manyrods::scene;
namespace h5 = manyrods::h5;

namespace {

// Points of dimension d of a design that fall in [k/m, (k+1)/m), for every k.
std::vector<int> strata(const std::vector<std::vector<double>>& p, int d, int m, int count) {
  std::vector<int> n(std::size_t(m), 0);
  for (int i = 0; i < count; ++i) ++n[std::size_t(p[i][d] * m)];
  return n;
}

}  // namespace

TEST(Sampling, NormalQuantileIsExactToRoundOff) {
  // reference quantiles (the standard normal table to 16 digits)
  EXPECT_EQ(normal_quantile(0.5), 0.0);
  EXPECT_NEAR(normal_quantile(0.975), 1.959963984540054, 4e-16 * 2);
  EXPECT_NEAR(normal_quantile(0.8413447460685429), 1.0, 4e-15);
  EXPECT_NEAR(normal_quantile(1e-10), -6.361340902404056, 6.4e-15);
  EXPECT_NEAR(normal_quantile(1 - 1e-10), 6.361340902404056, 1e-6);  // 1 − 1e-10 itself is rounded (1.1e-16 of 1)
  // the round trip through Φ (erfc, independent of the approximation),
  // across both tails and the centre: Φ(x̂) = p to the condition of Φ at x,
  // |x Φ'(x)/Φ(x)| ≈ x², times the rounding of x̂ (ε), plus a few ulps of
  // erfc: (x² + 4) ε relative to min(p, 1 − p)
  constexpr double eps = std::numeric_limits<double>::epsilon();
  for (double p : {1e-300, 1e-100, 1e-20, 1e-8, 0.001, 0.02425, 0.1, 0.3, 0.5, 0.7, 0.9, 0.97575, 0.999, 1 - 1e-8}) {
    const double x = normal_quantile(p);
    const double back = p < 0.5 ? normal_cdf(x) : 1 - 0.5 * std::erfc(x / std::sqrt(2.0));
    EXPECT_NEAR(back, p, (x * x + 4) * eps * std::min(p, 1 - p)) << p;
  }
  EXPECT_TRUE(std::isinf(normal_quantile(0.0)) && normal_quantile(0.0) < 0);
  EXPECT_TRUE(std::isnan(normal_quantile(-0.1)));
}

TEST(Sampling, SobolMatchesTheClassicSequenceAndStaysANetScrambled) {
  // Unscrambled: the Gray-code-ordered sequence of Joe & Kuo's direction
  // numbers (points 1–3 of dimensions 1–8, as SciPy's qmc.Sobol and the
  // original tables give them), at the centres of their 2⁻³² cells.
  const auto plain = unit_points({DesignKind::sobol, 1024, 0, false}, 21);
  const double row2[8] = {0.75, 0.25, 0.25, 0.25, 0.75, 0.75, 0.25, 0.75};
  const double row4[8] = {0.375, 0.375, 0.625, 0.875, 0.375, 0.125, 0.375, 0.875};
  const double row13[8] = {0.8125, 0.6875, 0.8125, 0.0625, 0.4375, 0.9375, 0.5625, 0.5625};
  for (int d = 0; d < 8; ++d) {
    EXPECT_EQ(plain[1][d], 0.5 + 0x1.0p-33);
    EXPECT_EQ(plain[2][d], row2[d] + 0x1.0p-33);
    EXPECT_EQ(plain[4][d], row4[d] + 0x1.0p-33);
    EXPECT_EQ(plain[13][d], row13[d] + 0x1.0p-33);
  }
  // dimension 21, the last with direction numbers (x⁷ + x³ + 1, m = 1, 3,
  // 7, 13, 13, 15, 69): its points 1–7 (as in SciPy's qmc.Sobol)
  const double dim21[7] = {0.5, 0.25, 0.75, 0.125, 0.625, 0.375, 0.875};
  for (int i = 0; i < 7; ++i) EXPECT_EQ(plain[i + 1][20], dim21[i] + 0x1.0p-33);
  // Scrambled (linear matrix scramble + digital shift keep the net
  // property): the first 2^m points of every dimension hold one point in
  // each of the 2^m intervals, and dimensions 1 and 2 form a (0, m, 2)-net:
  // every elementary box of area 2^-m holds exactly one point.
  for (std::uint64_t seed : {1ull, 2ull}) {
    const auto p = unit_points({DesignKind::sobol, 256, seed}, 21);
    for (int d = 0; d < 21; ++d) {
      const auto n = strata(p, d, 256, 256);
      EXPECT_EQ(*std::min_element(n.begin(), n.end()), 1) << "dimension " << d;
      for (double u : std::vector<double>{p[0][d], p[255][d]}) EXPECT_TRUE(u > 0 && u < 1);
    }
    for (int a = 0; a <= 8; ++a) {
      std::vector<int> box(256, 0);
      for (int i = 0; i < 256; ++i) ++box[std::size_t(int(p[i][0] * (1 << a)) * (256 >> a) + int(p[i][1] * (256 >> a)))];
      EXPECT_EQ(*std::min_element(box.begin(), box.end()), 1) << "boxes 2^-" << a << " x 2^-" << 8 - a;
    }
  }
  EXPECT_NE(unit_points({DesignKind::sobol, 16, 1}, 2), unit_points({DesignKind::sobol, 16, 2}, 2));
  EXPECT_THROW(unit_points({DesignKind::sobol, 16, 1}, 22), SceneError);
}

TEST(Sampling, LatinHypercubeHoldsOnePointPerStratum) {
  const auto p = unit_points({DesignKind::lhs, 100, 5}, 3);
  for (int d = 0; d < 3; ++d) {
    const auto n = strata(p, d, 100, 100);
    EXPECT_EQ(*std::min_element(n.begin(), n.end()), 1);
    EXPECT_EQ(*std::max_element(n.begin(), n.end()), 1);
  }
  EXPECT_EQ(p, unit_points({DesignKind::lhs, 100, 5}, 3));
  EXPECT_NE(p, unit_points({DesignKind::lhs, 100, 6}, 3));
}

TEST(Sampling, MonteCarloKeepsTheRandomSweepsSamples) {
  // the mc design is the random sampling that sweeps used before designs:
  // point by point, parameter by parameter, from one splitmix64 stream
  const auto p = unit_points({DesignKind::mc, 3, 7}, 2);
  const auto old = sweep_points({parse_vary("a=0:1"), parse_vary("b=0:1")}, 3, 7);
  EXPECT_EQ(p, old);
}

TEST(Sampling, DistributionsMapUnitPointsByTheirInverseCdf) {
  const Vary u = parse_vary("k=uniform:2:4"), n = parse_vary("k=normal:1:0.5"),
             t = parse_vary("k=normal:1:0.5:0.8:1.5"), l = parse_vary("k=lognormal:1e6:0.2"),
             w = parse_vary("k=1@1,2@3"), e = parse_vary("k=5,6,7,8");
  EXPECT_EQ(u.at(0.25), 2.5);
  EXPECT_NEAR(n.at(0.975), 1 + 0.5 * 1.959963984540054, 1e-15);
  EXPECT_NEAR(l.at(0.5), 1e6, 1e-9);
  EXPECT_NEAR(l.at(0.975), 1e6 * std::exp(0.2 * 1.959963984540054), 1e-8);
  EXPECT_NEAR(t.at(1e-12), 0.8, 1e-9);
  EXPECT_NEAR(t.at(1 - 1e-12), 1.5, 1e-9);
  EXPECT_NEAR(t.at(0.5), 1 + 0.5 * normal_quantile(0.5 * (normal_cdf(-0.4) + normal_cdf(1.0))), 1e-15);
  EXPECT_EQ(w.at(0.24), 1);
  EXPECT_EQ(w.at(0.26), 2);
  EXPECT_EQ(e.at(0.49), 6);
  // a Latin hypercube of 400 points gives each weighted value its share to
  // one point (the strata are the points)
  const auto pts = sweep_points({w}, Design{DesignKind::lhs, 400, 3});
  const auto twos = std::count_if(pts.begin(), pts.end(), [](const auto& r) { return r[0] == 2; });
  EXPECT_NEAR(double(twos), 300, 1);
  // the log-normal's log is normal with σ: 1,024 scrambled Sobol' points,
  // one in each 1/1024 of the unit interval (quasi-Monte Carlo: the sample
  // moments err by about 1/N of the spread, more from the unbounded tails
  // of Φ⁻¹: 2/N asserted, relative to σ = 0.2 for the std)
  const auto q = sweep_points({l}, Design{DesignKind::sobol, 1024, 9});
  double mean = 0, var = 0;
  for (const auto& r : q) mean += std::log(r[0]) / 1024;
  for (const auto& r : q) var += (std::log(r[0]) - mean) * (std::log(r[0]) - mean) / 1023;
  EXPECT_NEAR(mean, std::log(1e6), 0.2 * 2e-3);
  EXPECT_NEAR(std::sqrt(var), 0.2, 0.2 * 2e-3);
}

TEST(Sampling, BadSpecsAndDesignsAreErrors) {
  for (const char* bad : {"k=normal:1", "k=normal:1:0", "k=normal:1:1:2:1", "k=normal:0:1:50:60",
                          "k=lognormal:-1:0.2", "k=lognormal:1:0", "k=uniform:3:1", "k=1@2,3", "k=1@-1,2@1",
                          "k=uniform:a:1"})
    EXPECT_THROW(parse_vary(bad), SceneError) << bad;
  // distributions and weights need a sampled design
  EXPECT_THROW(sweep_points({parse_vary("k=normal:1:1")}, Design{}), SceneError);
  EXPECT_THROW(sweep_points({parse_vary("k=1@1,2@1")}, Design{}), SceneError);
  EXPECT_THROW(parse_design("halton"), SceneError);
  EXPECT_THROW(unit_points({DesignKind::lhs, 0, 1}, 1), SceneError);
}

TEST(Sampling, SweepStatisticsOfASummaryColumn) {
  // values with two NaN (variations without the observable): the statistics
  // of the 8 finite ones, quantiles as numpy.quantile's default (type 7)
  const double nan = std::numeric_limits<double>::quiet_NaN();
  const auto st = sweep_statistics({{"x", {3, 1, nan, 4, 1, 5, 9, nan, 2, 6}}});
  ASSERT_EQ(st.size(), 1u);
  const auto& names = sweep_statistic_names();
  auto get = [&](const std::string& n) {
    return st[0].values[std::size_t(std::find(names.begin(), names.end(), n) - names.begin())];
  };
  EXPECT_EQ(get("n"), 8);
  EXPECT_EQ(get("nan"), 2);
  EXPECT_DOUBLE_EQ(get("mean"), 3.875);
  EXPECT_DOUBLE_EQ(get("std"), 2.748376143938713);
  EXPECT_DOUBLE_EQ(get("mean_se"), 2.748376143938713 / std::sqrt(8.0));
  EXPECT_DOUBLE_EQ(get("mean_ci95_hi") - get("mean"), 1.959963984540054 * get("mean_se"));
  const double q[7] = {1, 1, 1.75, 3.5, 5.25, 7.95, 9};
  const char* qn[7] = {"min", "q05", "q25", "median", "q75", "q95", "max"};
  for (int i = 0; i < 7; ++i) EXPECT_DOUBLE_EQ(get(qn[i]), q[i]) << qn[i];
  // one finite value: no spread; none: all NaN but the counts
  const auto one = sweep_statistics({{"y", {nan, 2.5}}});
  EXPECT_EQ(one[0].values[2], 2.5);
  EXPECT_TRUE(std::isnan(one[0].values[3]));
  const auto none = sweep_statistics({{"z", {nan}}});
  EXPECT_EQ(none[0].values[0], 0);
  EXPECT_TRUE(std::isnan(none[0].values[2]));
}

TEST(Sampling, SobolIndicesOfAnAdditiveFunction) {
  // f = x₁ + 2 x₂ + 0·x₃ on the unit cube: V = 1/12 + 4/12, so
  // S₁ = ST₁ = 1/5, S₂ = ST₂ = 4/5, S₃ = ST₃ = 0 (no interactions). The
  // saltelli design of N = 1,024 base points (scrambled Sobol'): the
  // estimators are means of smooth functions over a quasi-random set,
  // accurate to about 1/N; 5/N asserted.
  const int n = 1024, d = 3;
  const auto p = unit_points({DesignKind::saltelli, n, 7}, d);
  ASSERT_EQ(p.size(), std::size_t(n * (d + 2)));
  h5::Column f{"f", {}};
  for (const auto& x : p) f.values.push_back(x[0] + 2 * x[1]);
  // the layout: A_B^(i) is A with column i from B
  for (int k = 0; k < n; ++k) {
    EXPECT_EQ(p[2 * n + k][0], p[n + k][0]);
    EXPECT_EQ(p[2 * n + k][1], p[k][1]);
  }
  const auto s = sweep_sensitivity({f}, n, d);
  const double want[3] = {0.2, 0.8, 0.0};
  for (int i = 0; i < d; ++i) {
    EXPECT_NEAR(s[0].values[i], want[i], 5.0 / n) << "S" << i + 1;
    EXPECT_NEAR(s[0].values[d + i], want[i], 5.0 / n) << "ST" << i + 1;
  }
  EXPECT_EQ(sensitivity_names({"a", "b"}), (std::vector<std::string>{"S1 a", "S1 b", "ST a", "ST b"}));
  // a column of another length (not this design's) gets NaN
  EXPECT_TRUE(std::isnan(sweep_sensitivity({{"g", {1, 2}}}, n, d)[0].values[0]));
}
