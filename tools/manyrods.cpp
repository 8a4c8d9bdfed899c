// tools/manyrods.cpp — the command-line tool (issue 6; docs/scenes.md).
//
//   manyrods run scene.toml -o out.h5 [--threads N] [--until T] [--duration T]
//   manyrods run --restart checkpoint.h5 -o out.h5 [--duration T] [--csv F]   (a run or a sweep)
//   manyrods sweep scene.toml --vary KEY=lo:hi:n [--vary ...] [--samples N --seed S] [--until T] -o sweep.h5 [--csv F]
//   manyrods export out.h5 --usd out.usda [--every K]
//   manyrods plot out.h5 [--out-dir DIR]
//
// Exit status: 0 done, 1 the simulation failed (non-finite state) or a tool
// failed, 2 bad input (scene, options, HDF5 file), 130 interrupted by Ctrl-C
// (the output is then a valid file with the frames so far and a checkpoint).
#include <omp.h>
#include <unistd.h>

#include <CLI/CLI.hpp>
#include <algorithm>
#include <cmath>
#include <csignal>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <map>
#include <sstream>

#include "host/h5io.h"
#include "host/runner.h"
#include "host/scene.h"
#include "host/sweep.h"

using namespace manyrods;
using namespace manyrods::scene;
namespace fs = std::filesystem;

namespace {

volatile std::sig_atomic_t g_interrupt = 0;

extern "C" void on_sigint(int) {
  g_interrupt = 1;
  std::signal(SIGINT, SIG_DFL);  // a second Ctrl-C ends the program at once
}

int default_threads() { return std::max(1, omp_get_max_threads()); }

void summary_line(const RunResult& r, const std::string& out) {
  std::fprintf(stderr,
               "manyrods: %s: t = %.6g s after %lld steps (dt = %.4g s), %lld frames, %lld elements, "
               "%.3g element-steps/s, %.3g s wall -> %s\n",
               r.interrupted ? "stopped" : "done", r.time, (long long)r.steps, r.dt, (long long)r.frames,
               (long long)r.elements, r.element_steps_per_s, r.wall_s, out.c_str());
}

std::string read_file(const std::string& path) {
  std::ifstream in(path, std::ios::binary);
  if (!in) throw SceneError(path + ": cannot read the scene file");
  std::stringstream ss;
  ss << in.rdbuf();
  return ss.str();
}

// ---- export: USD ASCII BasisCurves ---------------------------------------------

std::string usd_name(const std::string& s, int index) {
  std::string n = "group_" + std::to_string(index) + "_";
  for (char c : s) n += std::isalnum(static_cast<unsigned char>(c)) ? c : '_';
  return n;
}

// A string literal of the USD text format: \ and " escaped, controls dropped.
std::string usd_string(const std::string& s) {
  std::string q;
  for (char c : s) {
    if (c == '\\' || c == '"') q += '\\';
    if (static_cast<unsigned char>(c) >= 0x20) q += c;
  }
  return q;
}

int export_usd(const std::string& in, const std::string& usd, int every) {
  const h5::Reader rd(in);
  const h5::Output& o = rd.output();
  if (rd.frames() == 0) throw h5::H5Error(in + ": no frames to export");
  const int rods = int(o.node_offsets.size()) - 1;
  int groups = 0;
  for (int g : o.rod_group) groups = std::max(groups, g + 1);
  std::vector<std::string> names = o.group_names;
  names.resize(std::size_t(groups));
  // time code = frame index; timeCodesPerSecond = 1 / (the frame interval),
  // so the animation plays in simulated real time (only the run's last frame
  // can be closer to the one before; it keeps its index)
  const double fps = rd.frames() > 1 && o.time[1] > o.time[0] ? 1 / (o.time[1] - o.time[0]) : 1;
  std::vector<std::int64_t> frames;
  for (std::int64_t f = 0; f < rd.frames(); f += every) frames.push_back(f);
  if (frames.back() != rd.frames() - 1) frames.push_back(rd.frames() - 1);
  const std::string tmp = usd + ".tmp";
  {
    std::vector<std::vector<double>> pos(frames.size());
    for (std::size_t k = 0; k < frames.size(); ++k) {
      rd.read_positions(frames[k], pos[k]);
      for (double x : pos[k])  // USD cannot hold them (and "-nan" does not parse)
        if (!std::isfinite(x))
          throw h5::H5Error(in + ": frame " + std::to_string(frames[k]) + " has non-finite positions");
    }
    std::ofstream out(tmp);
    if (!out) throw h5::H5Error(usd + ": cannot write");
    out.precision(9);
    out << "#usda 1.0\n(\n    defaultPrim = \"manyrods\"\n    doc = \"manyrods export of " << usd_string(in) << "\"\n"
        << "    metersPerUnit = 1\n    upAxis = \"Z\"\n"
        << "    startTimeCode = " << frames.front() << "\n    endTimeCode = " << frames.back()
        << "\n    timeCodesPerSecond = " << fps << "\n    framesPerSecond = " << fps << "\n)\n\n";
    out << "def Xform \"manyrods\"\n{\n";
    for (int g = 0; g < groups; ++g) {
      std::vector<int> members;
      for (int r = 0; r < rods; ++r)
        if (o.rod_group[r] == g) members.push_back(r);
      if (members.empty()) continue;
      out << "    def BasisCurves \"" << usd_name(names[g], g) << "\"\n    {\n";
      out << "        uniform token type = \"linear\"\n        uniform token wrap = \"nonperiodic\"\n";
      out << "        int[] curveVertexCounts = [";
      for (std::size_t i = 0; i < members.size(); ++i)
        out << (i ? ", " : "") << o.node_offsets[members[i] + 1] - o.node_offsets[members[i]];
      out << "]\n        float[] widths = [";
      bool first = true;
      for (int r : members)
        for (std::int64_t j = o.node_offsets[r]; j < o.node_offsets[r + 1]; ++j) {
          out << (first ? "" : ", ") << o.rod_width[r];
          first = false;
        }
      out << "] (\n            interpolation = \"vertex\"\n        )\n";
      // extent (the schema asks for it wherever the points change): the
      // points' box padded by half the widest section, per time sample
      double pad = 0;
      for (int r : members) pad = std::max(pad, 0.5 * o.rod_width[r]);
      out << "        float3[] extent.timeSamples = {\n";
      for (std::size_t k = 0; k < frames.size(); ++k) {
        double lo[3] = {HUGE_VAL, HUGE_VAL, HUGE_VAL}, hi[3] = {-HUGE_VAL, -HUGE_VAL, -HUGE_VAL};
        for (int r : members)
          for (std::int64_t j = o.node_offsets[r]; j < o.node_offsets[r + 1]; ++j)
            for (int d = 0; d < 3; ++d) {
              lo[d] = std::min(lo[d], pos[k][3 * j + d]);
              hi[d] = std::max(hi[d], pos[k][3 * j + d]);
            }
        out << "            " << frames[k] << ": [(" << float(lo[0] - pad) << ", " << float(lo[1] - pad) << ", "
            << float(lo[2] - pad) << "), (" << float(hi[0] + pad) << ", " << float(hi[1] + pad) << ", "
            << float(hi[2] + pad) << ")],\n";
      }
      out << "        }\n";
      out << "        point3f[] points.timeSamples = {\n";
      for (std::size_t k = 0; k < frames.size(); ++k) {
        out << "            " << frames[k] << ": [";
        bool f1 = true;
        for (int r : members)
          for (std::int64_t j = o.node_offsets[r]; j < o.node_offsets[r + 1]; ++j) {
            const double* p = &pos[k][3 * j];
            out << (f1 ? "" : ", ") << '(' << float(p[0]) << ", " << float(p[1]) << ", " << float(p[2])
                << ')';
            f1 = false;
          }
        out << "],\n";
      }
      out << "        }\n    }\n";
    }
    out << "}\n";
    if (!out) throw h5::H5Error(usd + ": error writing");
  }
  fs::rename(tmp, usd);
  std::fprintf(stderr, "manyrods: %zu frames of %d rods -> %s\n", frames.size(), rods, usd.c_str());
  return 0;
}

// ---- plot: gnuplot PNGs --------------------------------------------------------

std::string quote(const std::string& s) {
  std::string q = "'";
  for (char c : s) q += c == '\'' ? std::string("''") : std::string(1, c);
  return q + "'";
}

int plot(const std::string& in, std::string dir) {
  const h5::Reader rd(in);
  const h5::Output& o = rd.output();
  if (dir.empty()) dir = fs::path(in).replace_extension("").string() + "_plots";
  fs::create_directories(dir);
  const int rods = int(o.node_offsets.size()) - 1;
  // tip trajectories of up to 6 rods spread over the batch
  std::vector<int> shown;
  const int nshow = std::min(rods, 6);
  for (int i = 0; i < nshow; ++i)
    shown.push_back(nshow == 1 ? 0 : int(std::llround(double(i) * (rods - 1) / (nshow - 1))));
  const std::string tips = dir + "/tips.dat", energy = dir + "/energy.dat";
  {
    std::ofstream t(tips);
    t.precision(10);
    std::vector<double> pos;
    for (std::int64_t f = 0; f < rd.frames(); ++f) {
      rd.read_positions(f, pos);
      t << o.time[f];
      for (int r : shown) {
        const std::int64_t j = o.node_offsets[r + 1] - 1;
        t << ' ' << pos[3 * j] << ' ' << pos[3 * j + 1] << ' ' << pos[3 * j + 2];
      }
      t << '\n';
    }
    std::ofstream e(energy);
    e.precision(12);
    for (std::int64_t f = 0; f < rd.frames(); ++f) {
      const h5::EnergyRow& r = o.energy[f];
      const double mech = r.kinetic + r.elastic + r.potential;
      e << o.time[f] << ' ' << r.kinetic << ' ' << r.elastic << ' ' << r.potential << ' ' << mech << ' '
        << r.dissipated << ' ' << mech + r.dissipated << '\n';
    }
  }
  std::ostringstream gp;
  gp << "set terminal pngcairo size 1200,900\nset grid\nset key outside right\n";
  gp << "set output " << quote(dir + "/tips.png") << "\nset multiplot layout 3,1 title 'tip trajectories'\n";
  const char* axis[3] = {"x", "y", "z"};
  for (int a = 0; a < 3; ++a) {
    gp << "set xlabel 'time (s)'\nset ylabel 'tip " << axis[a] << " (m)'\nplot ";
    for (std::size_t i = 0; i < shown.size(); ++i)
      gp << (i ? ", " : "") << quote(tips) << " using 1:" << 2 + 3 * i + a << " with lines title 'rod "
         << shown[i] << "'";
    gp << "\n";
  }
  gp << "unset multiplot\n";
  gp << "set output " << quote(dir + "/energy.png")
     << "\nset title 'energy budget (dissipated = integral of 2 D_v dt)'\n"
     << "set xlabel 'time (s)'\nset ylabel 'energy (J)'\nplot " << quote(energy)
     << " using 1:2 with lines title 'kinetic', '' using 1:3 with lines title 'elastic', '' using 1:4 with "
        "lines title "
        "'potential', '' using 1:5 with lines lw 2 title 'mechanical', '' using 1:6 with lines title "
        "'dissipated (KV)', "
        "'' using 1:7 with lines dt 2 lw 2 title 'mechanical + dissipated'\n";
  std::vector<std::string> made = {dir + "/tips.png", dir + "/energy.png"};
  if (o.has_sweep && !o.sweep_parameters.empty()) {
    const std::string sweep = dir + "/sweep.dat";
    std::ofstream s(sweep);
    s.precision(12);
    const std::size_t n = o.sweep_parameters[0].values.size();
    for (std::size_t i = 0; i < n; ++i) {
      s << o.sweep_parameters[0].values[i];
      for (const h5::Column& c : o.sweep_summary)
        s << ' ' << (std::isfinite(c.values[i]) ? c.values[i] : NAN);
      s << '\n';
    }
    s.close();
    for (std::size_t c = 0; c < o.sweep_summary.size(); ++c) {
      const std::string png = dir + "/sweep_" + o.sweep_summary[c].name + ".png";
      gp << "set output " << quote(png) << "\nset title 'sweep'\nset xlabel "
         << quote(o.sweep_parameters[0].name) << "\nset ylabel " << quote(o.sweep_summary[c].name)
         << "\nplot " << quote(sweep) << " using 1:" << c + 2 << " with linespoints title "
         << quote(o.sweep_summary[c].name) << "\n";
      made.push_back(png);
    }
  }
  const std::string script = dir + "/plots.gp";
  {
    std::ofstream f(script);
    f << gp.str();
  }
  const std::string cmd = "gnuplot " + quote(script);
  const std::string log = dir + "/gnuplot.log";
  const int rc = std::system((cmd + " 2> " + quote(log)).c_str());
  if (rc != 0) {
    std::fprintf(stderr,
                 "manyrods plot: gnuplot failed (exit %d); is gnuplot installed? script: %s, messages: %s\n",
                 rc, script.c_str(), log.c_str());
    return 1;
  }
  for (const std::string& m : made) std::fprintf(stderr, "manyrods: wrote %s\n", m.c_str());
  return 0;
}

// A sweep (new, or continued from its file's checkpoint) into opt.output,
// with the per-variation summary in /sweep and in `csv` (default: the
// output with .csv).
int run_sweep(const Sweep& sw, RunOptions opt, std::string csv, const h5::Checkpoint* restart) {
  if (csv.empty()) csv = fs::path(opt.output).replace_extension(".csv").string();
  opt.probes = sw.probes;
  const std::vector<h5::Column> params = sweep_parameters(sw);
  std::vector<h5::Column> summary;
  opt.before_finish = [&](h5::Writer& w, const std::vector<ProbeRecord>& rec) {
    summary = sweep_summary(sw, rec);
    std::vector<std::int32_t> first(sw.first_rod.begin(), sw.first_rod.end() - 1);
    w.write_sweep(params, summary, first);
  };
  std::fprintf(stderr, "manyrods sweep: %zu variations, %zu rods in one batch%s\n", sw.points.size(),
               sw.scene.rods.size(), restart ? " (continued)" : "");
  const RunResult r = run_scene(sw.scene, opt, restart);
  write_csv(csv, params, summary);
  summary_line(r, opt.output);
  std::fprintf(stderr, "manyrods: sweep summary -> %s\n", csv.c_str());
  return g_interrupt ? 130 : 0;
}

}  // namespace

int main(int argc, char** argv) {
  // (CLI11's PositiveNumber prints the whole range up to DBL_MAX)
  auto number_check = [](bool strict) {
    return CLI::Validator(
        [strict](std::string& s) {
          try {
            std::size_t used = 0;
            const double v = std::stod(s, &used);
            if (used == s.size() && std::isfinite(v) && (strict ? v > 0 : v >= 0)) return std::string();
          } catch (const std::exception&) {
          }
          return std::string(strict ? "must be a number > 0" : "must be a number >= 0") + ", got '" + s + "'";
        },
        strict ? "NUMBER>0" : "NUMBER>=0");
  };
  const CLI::Validator positive = number_check(true), non_negative = number_check(false);
  CLI::App app{"manyrods: many Cosserat rods with Kelvin-Voigt damping (scenes: docs/scenes.md)"};
  app.require_subcommand(1);

  std::string scene_path, output, restart, csv, usd, plot_dir, input;
  int threads = default_threads(), samples = 0, every = 1;
  double until = -1, duration = -1;
  std::uint64_t seed = 0;
  bool progress = isatty(2), no_progress = false, force_progress = false;
  std::vector<std::string> vary;

  CLI::App* run = app.add_subcommand("run", "run a scene into an HDF5 file");
  run->add_option("scene", scene_path, "scene file (TOML)");
  run->add_option("-o,--output", output, "output HDF5 file")->required();
  run->add_option("--restart", restart, "continue the run whose output (checkpoint) is this file");
  run->add_option("--threads", threads, "OpenMP threads (results do not depend on it)")->check(positive);
  run->add_option("--until", until,
                  "stop at this simulated time (s); the file keeps a checkpoint to --restart from")
      ->check(non_negative);
  run->add_option("--duration", duration, "override [simulation] duration (s)")->check(positive);
  run->add_option("--csv", csv, "restarting a sweep: summary CSV (default: the output with .csv)");
  run->add_flag("--no-progress", no_progress,
                "no progress line on stderr (default: shown when stderr is a terminal)");
  run->add_flag("--progress", force_progress, "progress line on stderr even when it is not a terminal");

  CLI::App* sweep = app.add_subcommand("sweep", "run every variation of a scene as rods of one batch");
  sweep->add_option("scene", scene_path, "scene file (TOML)")->required();
  sweep
      ->add_option("--vary", vary,
                   "KEY=lo:hi:n | KEY=lo:hi | KEY=v1,v2,.. (e.g. rods.0.damping.tau_extension=0.01:0.1:64)")
      ->required()
      ->allow_extra_args(false)  // one KEY=SPEC per --vary (repeat it), so a scene after it stays positional
      ->multi_option_policy(CLI::MultiOptionPolicy::TakeAll);
  sweep->add_option("--samples", samples, "random sampling: number of variations")->check(non_negative);
  sweep->add_option("--seed", seed, "random sampling: seed");
  sweep->add_option("-o,--output", output, "output HDF5 file")->required();
  sweep->add_option("--csv", csv, "summary CSV (default: the output with .csv)");
  sweep->add_option("--threads", threads, "OpenMP threads")->check(positive);
  sweep->add_option("--duration", duration, "override [simulation] duration (s)")->check(positive);
  sweep
      ->add_option("--until", until,
                   "stop at this simulated time (s); the file keeps a checkpoint to continue with run --restart")
      ->check(non_negative);
  sweep->add_flag("--no-progress", no_progress,
                  "no progress line on stderr (default: shown when stderr is a terminal)");
  sweep->add_flag("--progress", force_progress, "progress line on stderr even when it is not a terminal");

  CLI::App* exp = app.add_subcommand("export", "export an output file (USD ASCII BasisCurves)");
  exp->add_option("input", input, "manyrods HDF5 output")->required();
  exp->add_option("--usd", usd, "USD ASCII file to write (.usda)")->required();
  exp->add_option("--every", every, "export every k-th frame")->check(positive);

  CLI::App* plt = app.add_subcommand("plot", "PNG plots of an output file with gnuplot");
  plt->add_option("input", input, "manyrods HDF5 output")->required();
  plt->add_option("--out-dir", plot_dir, "directory for the PNGs (default: <input>_plots)");

  try {
    app.parse(argc, argv);
  } catch (const CLI::ParseError& e) {
    return app.exit(e) == 0 ? 0 : 2;
  }
  if (force_progress) progress = true;
  if (no_progress) progress = false;

  try {
    if (run->parsed()) {
      if (restart.empty() == scene_path.empty()) {
        std::fprintf(stderr, "manyrods run: give a scene file, or --restart FILE (not both)\n");
        return 2;
      }
      if (!csv.empty() && restart.empty()) {
        std::fprintf(stderr, "manyrods run: --csv applies only to continuing a sweep (--restart sweep.h5)\n");
        return 2;
      }
      RunOptions opt;
      opt.output = output;
      opt.threads = threads;
      opt.until = until;
      opt.duration = duration;
      opt.progress = progress;
      opt.interrupt = &g_interrupt;
      std::signal(SIGINT, on_sigint);
      RunResult r;
      if (!restart.empty()) {
        const h5::Checkpoint c = h5::read_checkpoint(restart);
        if (c.from_sweep) {  // a sweep continued: the same variations, its records go on
          const Sweep sw = sweep_of_checkpoint(c, restart);
          return run_sweep(sw, opt, csv, &c);
        }
        if (!csv.empty()) {
          std::fprintf(stderr, "manyrods run: --csv applies only to continuing a sweep; %s is a run\n",
                       restart.c_str());
          return 2;
        }
        const Scene s = parse_scene(c.scene_text, restart + ":/scene");
        r = run_scene(s, opt, &c);
      } else {
        const Scene s = load_scene(scene_path);
        r = run_scene(s, opt);
      }
      summary_line(r, output);
      return g_interrupt ? 130 : 0;
    }
    if (sweep->parsed()) {
      std::vector<Vary> vs;
      for (const std::string& v : vary) vs.push_back(parse_vary(v));
      const Sweep sw = make_sweep(read_file(scene_path), scene_path, vs, samples, seed);
      RunOptions opt;
      opt.output = output;
      opt.threads = threads;
      opt.until = until;
      opt.duration = duration;
      opt.progress = progress;
      opt.interrupt = &g_interrupt;
      std::signal(SIGINT, on_sigint);
      return run_sweep(sw, opt, csv, nullptr);
    }
    if (exp->parsed()) return export_usd(input, usd, every);
    if (plt->parsed()) return plot(input, plot_dir);
  } catch (const SceneError& e) {
    std::fprintf(stderr, "manyrods: error: %s\n", e.what());
    return 2;
  } catch (const h5::H5Error& e) {
    std::fprintf(stderr, "manyrods: error: %s\n", e.what());
    return 2;
  } catch (const NonFiniteError& e) {
    std::fprintf(
        stderr,
        "manyrods: the simulation failed: %s\n(no output written; a smaller dt or dt = \"auto\" may help)\n",
        e.what());
    return 1;
  } catch (const std::bad_alloc&) {
    std::fprintf(stderr, "manyrods: error: out of memory\n");
    return 2;
  } catch (const std::exception& e) {
    std::fprintf(stderr, "manyrods: error: %s\n", e.what());
    return 1;
  }
  return 0;
}
