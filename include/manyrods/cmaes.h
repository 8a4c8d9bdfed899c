// include/manyrods/cmaes.h — the CMA evolution strategy of `manyrods calibrate`
// (host/scene/study/cmaes.h: Hansen 2016's default parameters, positive
// weights), ask/tell, for objectives of one's own: a generation's candidates
// can be one sweep batch (include/manyrods/sweep.h make_sweep), as
// calibrate's are. The random numbers come from the seed alone, so a search
// is reproducible.
#pragma once

#include <cstdint>
#include <memory>
#include <string>
#include <vector>

namespace manyrods::scene {

class CmaEsOptimizer {
 public:
  // Starts at `mean` with step `sigma`; population 0: 4 + ⌊3 ln n⌋, at
  // least 8. InputError for an empty or non-finite mean, sigma ≤ 0 or not
  // finite, a population of 1 or below 0.
  CmaEsOptimizer(const std::vector<double>& mean, double sigma, int population = 0, std::uint64_t seed = 0);
  ~CmaEsOptimizer();
  CmaEsOptimizer(CmaEsOptimizer&&) noexcept;
  CmaEsOptimizer& operator=(CmaEsOptimizer&&) noexcept;

  // A generation's candidates (population points).
  std::vector<std::vector<double>> ask();
  // The candidates as evaluated (possibly moved back into a feasible
  // region) and their values, smaller better (+inf or NaN: a failed one).
  // InputError for the wrong number of candidates or coordinates, or a
  // candidate that is not finite.
  void tell(const std::vector<std::vector<double>>& x, const std::vector<double>& f);

  std::vector<double> mean() const;
  double step() const;      // σ
  double max_axis() const;  // the longest axis of C: σ · max_axis is the search's spread
  int population() const;
  // The strategy's parameters (for checks against other implementations).
  struct Parameters {
    std::vector<double> weights;           // w_1 … w_μ (positive: the mean's recombination)
    std::vector<double> negative_weights;  // w_{μ+1} … w_λ (≤ 0: the active covariance update)
    double mueff = 0, cs = 0, damps = 0, cc = 0, c1 = 0, cmu = 0;
  };
  Parameters parameters() const;

 private:
  struct Impl;
  std::unique_ptr<Impl> impl_;
};

}  // namespace manyrods::scene
