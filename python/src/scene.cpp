// python/src/scene.cpp — manyrods._core: scenes, their runs and sweeps, and
// the module's readers (scene files and text, output files).
#include <algorithm>
#include <csignal>
#include <cstdint>
#include <filesystem>
#include <optional>
#include <string>
#include <string_view>
#include <variant>
#include <vector>

#include "bindings.h"
#include "manyrods/calibrate.h"
#include "manyrods/h5io.h"
#include "manyrods/runner.h"
#include "manyrods/sweep.h"

namespace manyrods_python {
namespace {

// ---- runs: options and results -----------------------------------------------

nb::dict run_result(const manyrods::scene::RunResult& r) {
  nb::dict d;
  d["dt"] = r.dt;
  d["steps"] = r.steps;
  d["time"] = r.time;
  d["frames"] = r.frames;
  d["elements"] = r.elements;
  d["interrupted"] = r.interrupted;
  d["wall_s"] = r.wall_s;
  d["element_steps_per_s"] = r.element_steps_per_s;
  d["state_hash"] = r.state_hash;
  d["validity"] = r.validity;
  nb::dict obs;  // a run's [[observables]], name -> value
  for (const auto& c : r.observables) obs[c.name.c_str()] = c.values[0];
  d["observables"] = obs;
  return d;
}

nb::dict columns(const std::vector<manyrods::h5::Column>& cols) {
  nb::dict d;
  for (const auto& c : cols) {
    auto* data = new double[c.values.size()];
    std::copy(c.values.begin(), c.values.end(), data);
    nb::capsule owner(data, [](void* q) noexcept { delete[] static_cast<double*>(q); });
    d[c.name.c_str()] = nb::cast(nb::ndarray<nb::numpy, double>(data, {c.values.size()}, owner));
  }
  return d;
}

volatile std::sig_atomic_t g_never = 0;  // RunOptions::interrupt for runs from Python

manyrods::scene::RunOptions run_options(const std::string& output, int threads, std::optional<double> duration,
                                        double checkpoint_every, bool progress) {
  manyrods::scene::RunOptions o;
  o.output = output;
  o.threads = threads;
  if (duration) o.duration = *duration;
  o.checkpoint_every = checkpoint_every;
  o.progress = progress;
  o.interrupt = &g_never;
  return o;
}

}  // namespace

// ---- scenes (include/manyrods/scene.h)

namespace {

// Scene.run: one run into an HDF5 file.
void bind_scene_run(nb::class_<Scene>& c) {
  c.def(
       "run",
       [](const Scene& s, const std::string& output, int threads, std::optional<double> duration,
          double checkpoint_every, bool progress, bool force_dt) {
         manyrods::scene::RunResult r;
         {
           nb::gil_scoped_release release;
           Scene forced;
           if (force_dt) {  // `manyrods run --force-dt`
             forced = s;
             forced.sim.force_dt = true;
           }
           r = manyrods::scene::run_scene(force_dt ? forced : s,
                                          run_options(output, threads, duration, checkpoint_every, progress));
         }
         return run_result(r);
       },
       "output"_a, nb::kw_only(), "threads"_a = 1, "duration"_a = nb::none(), "checkpoint_every"_a = 0.0,
       "progress"_a = false, "force_dt"_a = false,
       "Run the scene into an HDF5 file, as `manyrods run` does. A dt above the scene's stable limit raises "
       "ValueError (the step-size guard) unless force_dt=True (`--force-dt`)");
}

// Scene.sweep: a parameter sweep.
void bind_scene_sweep(nb::class_<Scene>& c) {
  c.def(
       "sweep",
       [](const Scene& s, const std::vector<std::string>& vary, const std::string& output, int samples,
          std::uint64_t seed, int threads, std::optional<double> duration, std::optional<std::string> design,
          const std::string& frames, bool force_dt) {
         if (frames != "ends" && frames != "all" && frames != "none")
           throw manyrods::scene::SceneError("sweep: frames = '" + frames + "': expected 'ends', 'all' or 'none'");
         std::vector<manyrods::scene::Vary> vs;
         for (const std::string& v : vary) vs.push_back(manyrods::scene::parse_vary(v));
         const manyrods::scene::Design des = manyrods::scene::make_design(design.value_or(""), samples, seed);
         manyrods::scene::SweepRun r;
         {
           nb::gil_scoped_release release;
           manyrods::scene::Sweep sw = manyrods::scene::make_sweep(s.text, s.source, vs, des);
           sw.scene.sim.force_dt = force_dt;  // `manyrods sweep --force-dt`
           manyrods::scene::RunOptions opt = run_options(output, threads, duration, 0, false);
           opt.frames = frames == "all"    ? manyrods::scene::RunOptions::Frames::all
                        : frames == "none" ? manyrods::scene::RunOptions::Frames::none
                                           : manyrods::scene::RunOptions::Frames::ends;
           r = manyrods::scene::run_sweep(sw, opt);
         }
         nb::dict d;
         d["parameters"] = columns(r.parameters);
         d["summary"] = columns(r.summary);
         d["statistics"] = columns(r.statistics);  // per observable, in the order of statistic_names
         d["statistic_names"] = manyrods::scene::sweep_statistic_names();
         if (!r.sensitivity.empty()) {  // saltelli: per observable, [S1 …, ST …] of the parameters
           d["sensitivity"] = columns(r.sensitivity);
           std::vector<std::string> keys;
           for (const auto& v : vs) keys.push_back(v.key);
           d["sensitivity_names"] = manyrods::scene::sensitivity_names(keys);
         }
         d["run"] = run_result(r.run);
         return d;
       },
       "vary"_a, "output"_a, nb::kw_only(), "samples"_a = 0, "seed"_a = 0, "threads"_a = 1,
       "duration"_a = nb::none(), "design"_a = nb::none(), "frames"_a = "ends", "force_dt"_a = false,
       "A parameter sweep (`manyrods sweep`): vary = ['rods.0.damping.tau_extension=0:0.05:5', "
       "'rods.0.material.youngs_modulus=lognormal:1e6:0.2', …], design = 'grid' | 'mc' | 'lhs' | 'sobol' "
       "(default: grid, or mc with samples), frames = 'ends' (first and last step), 'all' or 'none'; returns the "
       "parameters, the per-variation summary and its statistics as NumPy arrays; force_dt as in Scene.run");
}

// Scene.calibrate: fit parameters to measured node tracks.
void bind_scene_calibrate(nb::class_<Scene>& c) {
  c.def(
       "calibrate",
       [](const Scene& s, const std::variant<std::string, std::vector<std::string>>& data_arg,
          const std::vector<std::string>& fit, const std::string& output,
          std::optional<std::string> csv, std::uint64_t seed, int population, int generations, double tolerance,
          std::optional<double> sigma, int threads) {
         namespace sc = manyrods::scene;
         if (threads < 1) throw manyrods::InputError("threads: must be >= 1");
         std::vector<sc::FitParameter> fp;
         for (const std::string& f : fit) fp.push_back(sc::parse_fit(f));
         const std::vector<std::string> data = std::holds_alternative<std::string>(data_arg)
                                                   ? std::vector<std::string>{std::get<std::string>(data_arg)}
                                                   : std::get<std::vector<std::string>>(data_arg);
         std::vector<std::string> inputs = s.inputs;
         inputs.insert(inputs.end(), data.begin(), data.end());
         const std::string state = sc::check_calibration_outputs(output, csv.value_or(""), inputs, "output", "csv");
         sc::Calibration r;
         {
           nb::gil_scoped_release release;
           const sc::Measurements m = sc::read_measurements(data, s);
           sc::CalibrateOptions opt;
           opt.seed = seed, opt.population = population, opt.max_generations = generations;
           opt.tolerance = tolerance, opt.threads = threads, opt.interrupt = &g_never, opt.state = state;
           if (sigma) opt.sigma = *sigma;
           r = sc::calibrate(s.text, s.source, fp, m, opt);
           sc::run_best_fit(s.text, s.source, r, output, threads);
           if (csv) sc::write_calibration_csv(*csv, r);
           std::error_code ec;
           std::filesystem::remove(state, ec);
         }
         nb::dict d;
         nb::dict value, sd, determined;
         for (std::size_t j = 0; j < fp.size(); ++j) {
           value[fp[j].key.c_str()] = r.best[j];
           sd[fp[j].key.c_str()] = r.sigma[j];
           determined[fp[j].key.c_str()] = bool(r.determined[j]);
         }
         d["value"] = value;
         d["sigma"] = sd;
         d["determined"] = determined;
         d["misfit"] = r.misfit;
         d["samples"] = r.samples;
         d["sigma_given"] = r.sigma_given;
         d["generations"] = r.generations;
         d["evaluations"] = r.evaluations;
         d["converged"] = r.converged;
         d["resumed"] = r.resumed;
         d["lines"] = sc::calibration_lines(r);
         return d;
       },
       "data"_a, "fit"_a, "output"_a, nb::kw_only(), "csv"_a = nb::none(), "seed"_a = 0, "population"_a = 0,
       "generations"_a = 200, "tolerance"_a = 1e-7, "sigma"_a = nb::none(), "threads"_a = 1,
       "Fit parameters to measurements (`manyrods calibrate`): data = a file or a list of files, node tracks (a "
       "CSV time,track,x,y,z[,sigma], or a manyrods run output) and/or scalars of the scene's [[observables]] (a "
       "CSV observable,value,sigma); fit = ['rods.0.material.youngs_modulus=log:1e5:1e7', …]; CMA-ES, each "
       "generation one batch, its state kept in output + '.calibrate-state' until the results are written (a "
       "calibration stopped, called again with the same arguments, continues); writes the best fit's run to "
       "output (and csv); returns value, sigma (Laplace estimate; NaN where not determined), determined, misfit, "
       "generations, resumed, lines ('KEY = VALUE ± SIGMA')");
}

}  // namespace

void bind_scene(nb::module_& m) {
  nb::class_<Scene> c(m, "Scene", "A parsed, validated scene file");
  c.def_ro("source", &Scene::source)
      .def_ro("text", &Scene::text)
      .def_prop_ro("rod_count", [](const Scene& s) { return s.rods.size(); })
      .def_prop_ro("duration", [](const Scene& s) { return s.sim.duration; })
      .def_prop_ro("output_interval", [](const Scene& s) { return s.sim.output_interval; })
      .def_prop_ro("precision", [](const Scene& s) { return s.sim.precision == Precision::float32 ? "float" : "double"; })
      .def_prop_ro("rods", [](const Scene& s) { return s.rods; }, "The expanded rods (copies)")
      .def(
          "build_batch",
          [](const Scene& s, std::optional<std::string> precision, int threads) {
            if (threads < 1) throw manyrods::InputError("threads: must be >= 1");
            std::optional<Precision> p;
            if (precision) p = precision_of(*precision);
            return new PyBatch{AnyBatch::from_scene(s, p), threads};
          },
          "precision"_a = nb::none(), "threads"_a = 1,
          "The scene's batch (initial state applied), in its precision or the given one")
      .def(
          "solve_static",
          [](const Scene& s, double at, int threads) {
            if (threads < 1) throw manyrods::InputError("threads: must be >= 1");
            manyrods::StaticResult r;
            AnyBatch b = [&] {
              nb::gil_scoped_release release;
              return manyrods::scene::static_equilibrium(s, at, &r);
            }();
            return new PyBatch{std::move(b), threads};
          },
          "at"_a = 0.0, "threads"_a = 1,
          "The scene's rods in static equilibrium (what `manyrods static` solves): a double-precision Batch at time "
          "`at`, driven holds at their poses then; Batch.hold_reactions() gives the connector loads. ValueError for "
          "what the static solve does not take (contact, wind) and a rod that is a mechanism under its loads; "
          "manyrods.StaticError when Newton finds no equilibrium.");
  bind_scene_run(c);
  bind_scene_sweep(c);
  bind_scene_calibrate(c);
}

// ---- the module's functions: scene files and text, output files
void bind_io(nb::module_& m) {
  m.def("load_scene", &manyrods::scene::load_scene, "path"_a, "Read and validate a TOML scene file");
  m.def(
      "read_output",
      [](const std::string& path) {
        const manyrods::h5::Reader r(path);
        const manyrods::h5::Output& o = r.output();
        const std::size_t frames = std::size_t(r.frames()), nodes = std::size_t(o.nodes);
        auto* x = new std::vector<double>(frames * nodes * 3);
        nb::capsule owner(x, [](void* v) noexcept { delete static_cast<std::vector<double>*>(v); });
        std::vector<double> f;
        for (std::size_t k = 0; k < frames; ++k) {
          r.read_positions(std::int64_t(k), f);
          std::copy(f.begin(), f.end(), x->begin() + std::ptrdiff_t(k * nodes * 3));
        }
        nb::dict d;
        d["time"] = o.time;
        d["node_offsets"] = o.node_offsets;
        d["rod_group"] = o.rod_group;
        d["rod_width"] = o.rod_width;
        d["group_names"] = o.group_names;
        d["node_position"] = nb::ndarray<nb::numpy, double>(x->data(), {frames, nodes, 3}, owner);
        // the frames' energies, a list [frames] each, named as in /energy
        // (step.h MANYRODS_ENERGY_FIELDS by dataset name, then dissipated);
        // with contact also the frames' contact records
        nb::dict energy;
        const auto column = [&](double manyrods::h5::EnergyRow::* m) {
          std::vector<double> v;
          for (const manyrods::h5::EnergyRow& e : o.energy) v.push_back(e.*m);
          return v;
        };
#define MANYRODS_ENERGY_ITEM(name, dataset, unit, written, doc) \
  if (o.contact || std::string_view(#written) != "contact") energy[dataset] = column(&manyrods::h5::EnergyRow::name);
        MANYRODS_ENERGY_FIELDS(MANYRODS_ENERGY_ITEM)
#undef MANYRODS_ENERGY_ITEM
        energy["dissipated"] = column(&manyrods::h5::EnergyRow::dissipated);
        if (o.contact) {
          nb::dict contact;
          contact["count"] = column(&manyrods::h5::EnergyRow::contacts);
          contact["max_penetration"] = column(&manyrods::h5::EnergyRow::max_penetration);
          d["contact"] = contact;
        }
        d["energy"] = energy;
        return d;
      },
      "path"_a,
      "A manyrods output file's frames: time [frames], node_position [frames, nodes, 3] (m), node_offsets "
      "[rods + 1], rod_group, rod_width, group_names, energy (a dict of [frames] lists: kinetic, elastic, "
      "potential, dissipated (J), dissipation_rate (W), with contact contact_work (J)) and, with contact, "
      "contact (a dict of [frames] lists: count, max_penetration (m))");
  m.def("parse_scene",
        [](const std::string& text, const std::string& source) { return manyrods::scene::parse_scene(text, source); },
        "text"_a, "source"_a = "<string>", "Parse and validate a scene from TOML text");
}

}  // namespace manyrods_python
