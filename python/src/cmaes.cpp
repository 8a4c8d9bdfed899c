// python/src/cmaes.cpp — manyrods.CmaEs: the CMA evolution strategy that
// `manyrods calibrate` runs (host/scene/study/cmaes.h), ask/tell, for
// objectives written in Python (a generation's candidates as one
// Scene.sweep) and for checking it against Python's `cma`.
#include <cmath>
#include <cstdint>
#include <string>
#include <vector>

#include "bindings.h"
#include "study/cmaes.h"

namespace manyrods_python {

void bind_cmaes(nb::module_& m) {
  using manyrods::scene::CmaEs;
  nb::class_<CmaEs>(m, "CmaEs",
                    "CMA-ES (Hansen 2016's default parameters, positive weights; `manyrods calibrate`'s optimizer): "
                    "ask() gives a generation's candidates, tell(x, f) their objective values (smaller is better; "
                    "inf for a failed one). The random numbers come from the seed alone.")
      .def(
          "__init__",
          [](CmaEs* self, const std::vector<double>& mean, double sigma, int population, std::uint64_t seed) {
            if (mean.empty()) throw manyrods::InputError("CmaEs: mean: needs at least one coordinate");
            for (double v : mean)
              if (!std::isfinite(v)) throw manyrods::InputError("CmaEs: mean: not finite");
            if (!(sigma > 0) || !std::isfinite(sigma)) throw manyrods::InputError("CmaEs: sigma: must be > 0 and finite");
            if (population < 0 || population == 1) throw manyrods::InputError("CmaEs: population: 0 (the default) or >= 2");
            new (self) CmaEs(int(mean.size()), mean, sigma, population, seed);
          },
          "mean"_a, "sigma"_a, nb::kw_only(), "population"_a = 0, "seed"_a = 0,
          "Start at mean (a list) with step sigma; population 0: 4 + 3 ln n, at least 8")
      .def("ask", &CmaEs::ask, "A generation's candidates: a list of population lists")
      .def(
          "tell",
          [](CmaEs& es, const std::vector<std::vector<double>>& x, const std::vector<double>& f) {
            const std::size_t n = es.mean().size();
            if (x.size() != std::size_t(es.lambda()) || f.size() != x.size())
              throw manyrods::InputError("CmaEs.tell: needs the " + std::to_string(es.lambda()) +
                                         " candidates of the last ask() and as many values");
            for (const auto& p : x)
              if (p.size() != n) throw manyrods::InputError("CmaEs.tell: a candidate of " + std::to_string(p.size()) +
                                                            " coordinates, the search has " + std::to_string(n));
            es.tell(x, f);
          },
          "x"_a, "f"_a, "The candidates as evaluated (possibly moved back into a feasible region) and their values")
      .def_prop_ro("mean", &CmaEs::mean)
      .def_prop_ro("step", &CmaEs::step, "sigma, the step size")
      .def_prop_ro("max_axis", &CmaEs::max_axis, "the longest axis of C (step * max_axis: the search's spread)")
      .def_prop_ro("population", &CmaEs::lambda)
      .def_prop_ro(
          "parameters",
          [](const CmaEs& es) {
            const CmaEs::Parameters p = es.parameters();
            nb::dict d;
            d["weights"] = p.weights;
            d["mueff"] = p.mueff, d["cs"] = p.cs, d["damps"] = p.ds, d["cc"] = p.cc, d["c1"] = p.c1, d["cmu"] = p.cmu;
            return d;
          },
          "The strategy's parameters: weights, mueff, cs, damps, cc, c1, cmu");
}

}  // namespace manyrods_python
