// host/scene/run/bench.cpp — `manyrods bench`: timing a scene (include/manyrods/bench.h).
#include "manyrods/bench.h"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <memory>
#include <sstream>
#include <thread>

#include "manyrods/any_batch.h"
#include "manyrods/isa.h"
#include "manyrods/runner.h"

namespace manyrods::scene {
namespace {

using Clock = std::chrono::steady_clock;
double seconds_since(Clock::time_point t0) { return std::chrono::duration<double>(Clock::now() - t0).count(); }

std::string terms_text(const StepChoice& c) {
  std::string s;
  for (auto [on, name] : {std::pair{c.kelvin_voigt, "kelvin_voigt"}, std::pair{c.gravity, "gravity"},
                          std::pair{c.colliders, "colliders"}, std::pair{c.rod_contact, "rod_contact"}})
    if (on) s += s.empty() ? name : std::string(" ") + name;
  return s.empty() ? "elastic only" : s;
}

double median(std::vector<double> v) {
  std::sort(v.begin(), v.end());
  const std::size_t n = v.size();
  return n % 2 ? v[n / 2] : 0.5 * (v[n / 2 - 1] + v[n / 2]);
}

std::string json_escape(const std::string& s) {
  std::string o;
  for (char c : s) {
    if (c == '"' || c == '\\') o += '\\';
    if (static_cast<unsigned char>(c) < 0x20) {
      char buf[8];
      std::snprintf(buf, sizeof buf, "\\u%04x", c);
      o += buf;
      continue;
    }
    o += c;
  }
  return o;
}

}  // namespace

BenchResult bench_scene(const Scene& s, const BenchOptions& opt) {
  if (opt.threads < 1) throw InputError("bench: --threads must be >= 1 (got " + std::to_string(opt.threads) + ")");
  if (opt.repeats < 1) throw InputError("bench: --repeats must be >= 1 (got " + std::to_string(opt.repeats) + ")");
  if (opt.steps < 0) throw InputError("bench: --steps must be >= 0 (got " + std::to_string(opt.steps) + ")");
  if (opt.warmup < 0) throw InputError("bench: --warmup must be >= 0 (got " + std::to_string(opt.warmup) + ")");
  AnyBatch batch = AnyBatch::from_scene(s, opt.precision);
  BenchResult r;
  r.scene = s.source.empty() ? "scene" : std::filesystem::path(s.source).stem().string();
  r.precision = batch.float32() ? "float" : "double";
  r.terms = terms_text(batch.choice());
  r.integrator = batch.choice().integrator == Integrator::pefrl ? "pefrl" : "position_verlet";
  r.step_path = active_step_path();
  r.stiff_solve_float = batch.float32() && batch.visit([](const auto& b) { return b.any_stiff(); }) &&
                        !opt.stiff_solve_in_double;
  r.threads = opt.threads;
  r.rods = batch.rod_count();
  r.dt = batch.scene_dt();
  Profile profile;
  const auto advance = [&](std::int64_t n, Profile* p) {
    Exec ex{opt.threads, p};
    ex.stiff_solve_in_double = opt.stiff_solve_in_double;
    batch.visit([&](auto& b) {
      using T = typename std::remove_reference_t<decltype(b)>::value_type;
      advance_scene(b, batch.choice(), T(r.dt), n, ex);
    });
  };
  batch.visit([&](const auto& b) {
    r.elements = b.element_count();
  });
  // warm-up (first touch, the solve's buffers), which also sizes the runs
  r.warmup = opt.warmup > 0 ? opt.warmup : (opt.steps > 0 ? std::min<std::int64_t>(opt.steps, 64) : 64);
  const auto t0 = Clock::now();
  advance(r.warmup, nullptr);
  const double warm_s = std::max(seconds_since(t0), 1e-9);
  r.steps = opt.steps;
  if (r.steps == 0) {
    const double per_step = warm_s / double(r.warmup);
    r.steps = std::max<std::int64_t>(64, std::int64_t(std::llround(opt.target_s / per_step / 64)) * 64);
  }
  for (int i = 0; i < opt.repeats; ++i) {
    const auto t1 = Clock::now();
    advance(r.steps, nullptr);
    r.run_s.push_back(seconds_since(t1));
  }
  r.median_s = median(r.run_s);
  r.element_steps_per_s = double(r.elements) * double(r.steps) / r.median_s;
  r.sim_s_per_wall_s = double(r.steps) * r.dt / r.median_s;
  profile.reserve(opt.threads);
  advance(r.steps, &profile);
  r.stages = profile.total();
  r.state_hash = batch.state_hash();
  batch.visit([&](const auto& b) { r.bytes_per_element = double(b.bytes()) / double(std::max<std::int64_t>(1, r.elements)); });
  // counted FLOPs per element-step on the branch-free paths (bench/flop_count.cpp):
  // the elastic step, and with the rod-per-lane implicit solve; contact,
  // fluid and stiff terms are not counted
  // (a long rod's partitioned solve: 2,358 instead of 1,014)
  r.flops_per_element_step = 657;
  if (batch.choice().kelvin_voigt) {
    double partitioned = 0;  // elements of the rods solved in partitions
    batch.visit([&](const auto& b) { partitioned = double(b.partitioned_elements()); });
    const double share = partitioned / double(std::max<std::int64_t>(1, r.elements));
    r.flops_per_element_step += 1014 * (1 - share) + 2358 * share;
  }
  if (batch.choice().integrator == Integrator::pefrl) r.flops_per_element_step *= 4;  // four kicks and solves
  if (opt.ceilings) {
    r.peak_flops = batch.float32() ? peak_flops<float>(opt.threads) : peak_flops<double>(opt.threads);
    r.triad_bytes_per_s =
        batch.float32() ? triad_bandwidth<float>(opt.threads) : triad_bandwidth<double>(opt.threads);
  }
  return r;
}

std::string bench_report(const BenchResult& r) {
  std::ostringstream o;
  char line[512];
  std::snprintf(line, sizeof line,
                "scene %s: %lld rods, %lld elements, %s%s, %s, %s, dt = %.4g s, step path %s, %d thread%s\n",
                r.scene.c_str(), (long long)r.rods, (long long)r.elements, r.precision.c_str(),
                r.stiff_solve_float ? " (stiff rods solved in float)" : "", r.terms.c_str(), r.integrator.c_str(), r.dt,
                r.step_path.c_str(), r.threads, r.threads == 1 ? "" : "s");
  o << line;
  std::snprintf(line, sizeof line, "runs: %d of %lld steps after %lld warm-up steps; wall s:", int(r.run_s.size()),
                (long long)r.steps, (long long)r.warmup);
  o << line;
  for (double s : r.run_s) {
    std::snprintf(line, sizeof line, " %.4g", s);
    o << line;
  }
  std::snprintf(line, sizeof line,
                "\nmedian: %.4g s, %.4g element-steps/s, %.4g simulated s per wall s\n"
                "memory: %.1f bytes per element\n",
                r.median_s, r.element_steps_per_s, r.sim_s_per_wall_s, r.bytes_per_element);
  o << line;
  if (r.peak_flops > 0) {
    const double flops = r.element_steps_per_s * r.flops_per_element_step;
    const double bytes = r.element_steps_per_s * r.bytes_per_element;
    std::snprintf(line, sizeof line,
                  "machine (%d thread%s, %s): FMA peak %.4g GFLOP/s, STREAM triad %.4g GB/s\n"
                  "  ~%.0f FLOP per element-step (counted, elastic step%s; contact, fluid, stiff terms not counted): "
                  "%.3g GFLOP/s = %.1f %% of peak\n"
                  "  %.1f bytes per element once per step: %.3g GB/s = %.1f %% of the triad (blocked steps reuse "
                  "them from cache)\n",
                  r.threads, r.threads == 1 ? "" : "s", r.precision.c_str(), r.peak_flops / 1e9, r.triad_bytes_per_s / 1e9,
                  r.flops_per_element_step, r.terms.find("kelvin_voigt") != std::string::npos ? " + implicit solve" : "",
                  flops / 1e9, 100 * flops / r.peak_flops, r.bytes_per_element, bytes / 1e9,
                  100 * bytes / r.triad_bytes_per_s);
    o << line;
  }
  if (const std::string table = stage_report(r.stages); !table.empty())
    o << "profile (one more run, thread-seconds per stage):\n" << table;
  std::snprintf(line, sizeof line, "state hash %016llx\n", (unsigned long long)r.state_hash);
  o << line;
  return o.str();
}

std::string bench_json(const BenchResult& r, const std::string& date) {
  std::ostringstream o;
  o.precision(10);
  const std::string name = r.scene + "_" + r.precision + "/threads:" + std::to_string(r.threads);
  o << "{\n  \"context\": {\n    \"date\": \"" << json_escape(date) << "\",\n    \"executable\": \"manyrods bench\",\n"
    << "    \"num_cpus\": " << std::max(1u, std::thread::hardware_concurrency()) << ",\n"
    << "    \"library_build_type\": \"release\",\n    \"step_path\": \"" << json_escape(r.step_path) << "\",\n"
    << "    \"peak_flops\": " << r.peak_flops << ",\n    \"triad_bytes_per_second\": " << r.triad_bytes_per_s << "\n  },\n"
    << "  \"benchmarks\": [\n";
  // One entry: a run (aggregate null) or an aggregate. For stddev, as Google
  // Benchmark writes it, the time fields hold the deviation and there are no rates.
  const auto entry = [&](int index, const char* aggregate, double seconds) {
    const double ns_per_step = 1e9 * seconds / double(r.steps);
    o << "    {\"name\": \"" << json_escape(name) << (aggregate ? std::string("_") + aggregate : std::string()) << "\", "
      << "\"family_index\": 0, \"per_family_instance_index\": 0, \"run_name\": \"" << json_escape(name) << "\", "
      << "\"run_type\": \"" << (aggregate ? "aggregate" : "iteration") << "\", \"repetitions\": " << r.run_s.size() << ", ";
    if (aggregate)
      o << "\"aggregate_name\": \"" << aggregate << "\", \"aggregate_unit\": \"time\", ";
    else
      o << "\"repetition_index\": " << index << ", ";
    o << "\"threads\": " << r.threads << ", \"iterations\": " << r.steps << ", \"real_time\": " << ns_per_step
      << ", \"cpu_time\": " << ns_per_step << ", \"time_unit\": \"ns\"";
    if (aggregate && std::string(aggregate) == "stddev") {
      o << "}";
      return;
    }
    char h[20];
    std::snprintf(h, sizeof h, "%016llx", (unsigned long long)r.state_hash);
    o << ", \"items_per_second\": " << double(r.elements) * double(r.steps) / seconds << ", "
      << "\"sim_s_per_s\": " << double(r.steps) * r.dt / seconds << ", "
      << "\"bytes_per_element\": " << r.bytes_per_element << ", \"elements\": " << r.elements << ", "
      << "\"label\": \"" << json_escape(r.terms + ", " + r.integrator + ", path " + r.step_path) << ", state hash " << h
      << "\"}";
  };
  double mean = 0;
  for (double s : r.run_s) mean += s / double(r.run_s.size());
  double var = 0;
  for (double s : r.run_s) var += (s - mean) * (s - mean);
  const double sd = r.run_s.size() > 1 ? std::sqrt(var / double(r.run_s.size() - 1)) : 0;
  for (std::size_t i = 0; i < r.run_s.size(); ++i) {
    entry(int(i), nullptr, r.run_s[i]);
    o << ",\n";
  }
  entry(0, "mean", mean);
  o << ",\n";
  entry(0, "median", r.median_s);
  o << ",\n";
  entry(0, "stddev", sd);
  o << "\n  ]\n}\n";
  return o.str();
}

}  // namespace manyrods::scene
