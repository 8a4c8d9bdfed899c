// python/src/cmaes.cpp — manyrods.CmaEs: the CMA evolution strategy that
// `manyrods calibrate` runs (include/manyrods/cmaes.h), ask/tell, for
// objectives written in Python (a generation's candidates as one
// Scene.sweep) and for checking it against Python's `cma`.
#include <cstdint>
#include <vector>

#include "bindings.h"
#include "manyrods/cmaes.h"

namespace manyrods_python {

void bind_cmaes(nb::module_& m) {
  using manyrods::scene::CmaEsOptimizer;
  nb::class_<CmaEsOptimizer>(m, "CmaEs",
                             "CMA-ES (Hansen 2016's default parameters, positive weights; `manyrods calibrate`'s "
                             "optimizer): ask() gives a generation's candidates, tell(x, f) their objective values "
                             "(smaller is better; inf or nan for a failed one). The random numbers come from the seed "
                             "alone.")
      .def(nb::init<const std::vector<double>&, double, int, std::uint64_t>(), "mean"_a, "sigma"_a, nb::kw_only(),
           "population"_a = 0, "seed"_a = 0, "Start at mean (a list) with step sigma; population 0: 4 + 3 ln n, at least 8")
      .def("ask", &CmaEsOptimizer::ask, "A generation's candidates: a list of population lists")
      .def("tell", &CmaEsOptimizer::tell, "x"_a, "f"_a,
           "The candidates as evaluated (possibly moved back into a feasible region) and their values")
      .def_prop_ro("mean", &CmaEsOptimizer::mean)
      .def_prop_ro("step", &CmaEsOptimizer::step, "sigma, the step size")
      .def_prop_ro("max_axis", &CmaEsOptimizer::max_axis, "the longest axis of C (step * max_axis: the search's spread)")
      .def_prop_ro("population", &CmaEsOptimizer::population)
      .def_prop_ro(
          "parameters",
          [](const CmaEsOptimizer& es) {
            const CmaEsOptimizer::Parameters p = es.parameters();
            nb::dict d;
            d["weights"] = p.weights;
            d["negative_weights"] = p.negative_weights;
            d["mueff"] = p.mueff, d["cs"] = p.cs, d["damps"] = p.damps, d["cc"] = p.cc, d["c1"] = p.c1, d["cmu"] = p.cmu;
            return d;
          },
          "The strategy's parameters: weights, negative_weights, mueff, cs, damps, cc, c1, cmu");
}

}  // namespace manyrods_python
