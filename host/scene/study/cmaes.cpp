// host/scene/study/cmaes.cpp — include/manyrods/cmaes.h: the public face of
// the CMA-ES (study/cmaes.h), its arguments checked.
#include "manyrods/cmaes.h"

#include <cmath>
#include <string>

#include "manyrods/material.h"
#include "study/cmaes.h"

namespace manyrods::scene {

struct CmaEsOptimizer::Impl {
  CmaEs es;
};

CmaEsOptimizer::CmaEsOptimizer(const std::vector<double>& mean, double sigma, int population, std::uint64_t seed) {
  if (mean.empty()) throw InputError("CmaEs: mean: needs at least one coordinate");
  for (double v : mean)
    if (!std::isfinite(v)) throw InputError("CmaEs: mean: not finite");
  if (!(sigma > 0) || !std::isfinite(sigma)) throw InputError("CmaEs: sigma: must be > 0 and finite");
  if (population < 0 || population == 1) throw InputError("CmaEs: population: 0 (the default) or >= 2");
  impl_ = std::make_unique<Impl>(Impl{CmaEs(int(mean.size()), mean, sigma, population, seed)});
}
CmaEsOptimizer::~CmaEsOptimizer() = default;
CmaEsOptimizer::CmaEsOptimizer(CmaEsOptimizer&&) noexcept = default;
CmaEsOptimizer& CmaEsOptimizer::operator=(CmaEsOptimizer&&) noexcept = default;

std::vector<std::vector<double>> CmaEsOptimizer::ask() { return impl_->es.ask(); }

void CmaEsOptimizer::tell(const std::vector<std::vector<double>>& x, const std::vector<double>& f) {
  const std::size_t n = impl_->es.mean().size(), lambda = std::size_t(impl_->es.lambda());
  if (x.size() != lambda || f.size() != lambda)
    throw InputError("CmaEs.tell: needs the " + std::to_string(lambda) + " candidates of the last ask() and as many values");
  for (const std::vector<double>& p : x) {
    if (p.size() != n)
      throw InputError("CmaEs.tell: a candidate of " + std::to_string(p.size()) + " coordinates, the search has " +
                       std::to_string(n));
    for (double v : p)
      if (!std::isfinite(v)) throw InputError("CmaEs.tell: a candidate is not finite");
  }
  impl_->es.tell(x, f);
}

std::vector<double> CmaEsOptimizer::mean() const { return impl_->es.mean(); }
double CmaEsOptimizer::step() const { return impl_->es.step(); }
double CmaEsOptimizer::max_axis() const { return impl_->es.max_axis(); }
int CmaEsOptimizer::population() const { return impl_->es.lambda(); }

CmaEsOptimizer::Parameters CmaEsOptimizer::parameters() const {
  const CmaEs::Parameters p = impl_->es.parameters();
  return {p.weights, p.negative_weights, p.mueff, p.cs, p.ds, p.cc, p.c1, p.cmu};
}

}  // namespace manyrods::scene
