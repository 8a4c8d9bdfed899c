// tests/test_observables.cpp — scene-declared observables
// (include/manyrods/observables.h, docs/scenes.md "Observables"): each
// reduction against the same quantity read independently from the frames of
// a run sampled at every step; the default sampling within the resolution
// the header states; a restarted run and a sweep's columns bit for bit;
// contact counts; bad tables.
#include <gtest/gtest.h>

#include <unistd.h>

#include <algorithm>
#include <cmath>
#include <filesystem>
#include <numbers>
#include <string>
#include <vector>

#include "manyrods/h5io.h"
#include "manyrods/observables.h"
#include "manyrods/runner.h"
#include "manyrods/sweep.h"

using namespace manyrods;
using namespace manyrods::scene;
namespace fs = std::filesystem;

namespace {

const fs::path& dir() {
  static const fs::path d = [] {
    const fs::path p = fs::temp_directory_path() / ("manyrods_test_observables_" + std::to_string(::getpid()));
    fs::create_directories(p);
    return p;
  }();
  return d;
}
std::string path(const std::string& name) { return (dir() / name).string(); }

// removes the files at the end
struct Cleanup : ::testing::Environment {
  void TearDown() override {
    std::error_code ec;
    fs::remove_all(dir(), ec);
  }
};
const auto* const cleanup = ::testing::AddGlobalTestEnvironment(new Cleanup);

// The seed cantilever's section and material at 10 elements, released
// from a 5 mN tip force (5.4 cm, 18 % of its length, at the tip), dt fixed.
std::string cantilever(double dt, double duration, double interval, const std::string& observables,
                       const std::string& extra = "") {
  return "[simulation]\ndt = " + std::to_string(dt) + "\nduration = " + std::to_string(duration) +
         "\noutput_interval = " + std::to_string(interval) + "\n" + extra +
         "\n[[rods]]\nname = \"beam\"\nelements = 10\nlength = 0.3\n"
         "initial_tip_force = [0.005, 0.0, 0.0]\n"
         "section = { shape = \"rectangle\", width = 0.01, height = 0.01 }\n"
         "material = { density = 1000.0, youngs_modulus = 1.0e6, poisson_ratio = 0.3 }\n"
         "damping = { tau_shear = 0.02, tau_extension = 0.02 }\n" +
         observables;
}

const std::string kObservables = R"(
[[observables]]
name = "tip_x"
quantity = "position"
component = "x"
at = [0.1, 0.5]

[[observables]]
name = "tip_x_min"
quantity = "displacement"
component = "x"
reduce = "min"

[[observables]]
name = "tip_moved_max"
quantity = "displacement"
reduce = "max"

[[observables]]
name = "mid_z_final"
quantity = "position"
node = 5
component = "z"
reduce = "final"

[[observables]]
name = "t_zero"
quantity = "displacement"
component = "x"
first_below = 0.0

[[observables]]
name = "kinetic_max"
quantity = "energy"
component = "kinetic"
reduce = "max"

[[observables]]
name = "total_final"
quantity = "energy"
component = "total"
reduce = "final"

[[observables]]
name = "dissipated"
quantity = "energy"
component = "dissipated"
reduce = "final"
)";

double value(const std::vector<h5::Column>& cols, const std::string& name) {
  for (const h5::Column& c : cols)
    if (c.name == name) return c.values.at(0);
  ADD_FAILURE() << "no column " << name;
  return NAN;
}

struct Frames {
  std::vector<double> t, tip_x, tip_moved, mid_z;  // the tip's x, |x − x_scene|, node 5's z
};

Frames read_frames(const std::string& file, const Scene& s) {
  const h5::Reader r(file);
  Frames f;
  std::vector<double> x;
  const Vec3 tip0 = s.rods[0].nodes.back();
  for (std::int64_t k = 0; k < r.frames(); ++k) {
    r.read_positions(k, x);
    const double* tip = &x[3 * 10];
    f.t.push_back(r.output().time[std::size_t(k)]);
    f.tip_x.push_back(tip[0]);
    f.tip_moved.push_back(std::hypot(tip[0] - tip0[0], tip[1] - tip0[1], tip[2] - tip0[2]));
    f.mid_z.push_back(x[3 * 5 + 2]);
  }
  return f;
}

// The first time u falls to 0, linear between the frames that bracket it.
double first_zero(const std::vector<double>& t, const std::vector<double>& u) {
  for (std::size_t k = 1; k < u.size(); ++k)
    if (u[k] <= 0) return t[k - 1] + u[k - 1] / (u[k - 1] - u[k]) * (t[k] - t[k - 1]);
  return NAN;
}

RunResult run(const Scene& s, const std::string& out, double until = -1, const h5::Checkpoint* restart = nullptr) {
  RunOptions o;
  o.output = path(out);
  o.until = until;
  return run_scene(s, o, restart);
}

}  // namespace

// Sampled at every step (a frame every step: every step is a sample point),
// each observable equals the same quantity read from the frames and the
// energy record, to round-off.
TEST(Observables, EveryReductionEqualsTheFramesOfARunSampledEveryStep) {
  const double dt = 2e-4;
  const Scene s = parse_scene(cantilever(dt, 1.0, dt, kObservables), "every_step.toml");
  const RunResult r = run(s, "every_step.h5");
  ASSERT_EQ(r.observables.size(), 9u);
  EXPECT_EQ(r.observables[0].name, "tip_x@0.1");
  EXPECT_EQ(r.observables[1].name, "tip_x@0.5");
  const Frames f = read_frames(path("every_step.h5"), s);
  ASSERT_EQ(f.t.size(), 5001u);
  const std::vector<double> disp_x = [&] {
    std::vector<double> d;
    for (double x : f.tip_x) d.push_back(x - s.rods[0].nodes.back()[0]);
    return d;
  }();
  EXPECT_EQ(value(r.observables, "tip_x@0.1"), f.tip_x[500]);
  EXPECT_EQ(value(r.observables, "tip_x@0.5"), f.tip_x[2500]);
  EXPECT_EQ(value(r.observables, "tip_x_min"), *std::min_element(disp_x.begin(), disp_x.end()));
  EXPECT_DOUBLE_EQ(value(r.observables, "tip_moved_max"), *std::max_element(f.tip_moved.begin(), f.tip_moved.end()));
  EXPECT_EQ(value(r.observables, "mid_z_final"), f.mid_z.back());
  EXPECT_NEAR(value(r.observables, "t_zero"), first_zero(f.t, disp_x), 1e-12);
  // energies: summed rod by rod here, over the batch in /energy
  const h5::Reader rd(path("every_step.h5"));
  double kmax = 0;
  for (const h5::EnergyRow& e : rd.output().energy) kmax = std::max(kmax, e.kinetic);
  const h5::EnergyRow& last = rd.output().energy.back();
  EXPECT_NEAR(value(r.observables, "kinetic_max"), kmax, 1e-12 * kmax);
  EXPECT_NEAR(value(r.observables, "total_final"), last.kinetic + last.elastic + last.potential, 1e-12 * kmax);
  EXPECT_NEAR(value(r.observables, "dissipated"), last.dissipated, 1e-12 * kmax);
  // the physics: released from rest at +x, the tip first passes its
  // equilibrium near a quarter period of the first mode (1.763 s, ζ = 0.0357:
  // the damped oscillator's (π/2 + ζ)/ω_d = 0.4508 s; the higher modes
  // of the released static shape and the 10-element discretisation move it
  // by under 1 %)
  const double w = 2 * std::numbers::pi / 1.763, zeta = 0.0357;
  EXPECT_NEAR(value(r.observables, "t_zero"), (std::numbers::pi / 2 + zeta) / (w * std::sqrt(1 - zeta * zeta)), 0.0045);
  // /observables in the file
  EXPECT_EQ(rd.output().observables.size(), r.observables.size());
  EXPECT_EQ(value(rd.output().observables, "t_zero"), value(r.observables, "t_zero"));
}

// At the default sampling (every 64 steps) the maximum and the crossing
// time are within the resolution the header states of the every-step
// values: A ω² h²/8 for the extremum, h² ω/8 for a zero crossing of a
// harmonic signal (linear interpolation's error, |u''| h²/8 over |u'| = Aω,
// with u'' of the first mode vanishing at the crossing: the bound is taken
// with |u''| ≤ A ω²). `at` times are sampled exactly.
TEST(Observables, DefaultSamplingIsWithinItsStatedResolution) {
  const double dt = 2e-4;
  const Scene fine = parse_scene(cantilever(dt, 1.0, dt, kObservables), "fine.toml");
  const Scene coarse = parse_scene(cantilever(dt, 1.0, 0.25, kObservables), "coarse.toml");
  const RunResult a = run(fine, "fine.h5"), b = run(coarse, "coarse.h5");
  EXPECT_EQ(value(a.observables, "tip_x@0.1"), value(b.observables, "tip_x@0.1"));
  EXPECT_EQ(value(a.observables, "tip_x@0.5"), value(b.observables, "tip_x@0.5"));
  EXPECT_EQ(value(a.observables, "mid_z_final"), value(b.observables, "mid_z_final"));
  const double h = 64 * dt, w = 2 * std::numbers::pi / 1.763;
  const double amp = -value(a.observables, "tip_x_min");
  EXPECT_LE(value(b.observables, "tip_x_min"), value(a.observables, "tip_x_min") + amp * w * w * h * h / 8 * 1.0001);
  EXPECT_GE(value(b.observables, "tip_x_min"), value(a.observables, "tip_x_min"));  // a sample of the same run
  EXPECT_NEAR(value(b.observables, "t_zero"), value(a.observables, "t_zero"), h * h * w / 8);
}

// Stopped at --until and continued from the checkpoint, a run gives the
// uninterrupted run's observables bit for bit (the checkpoint carries them,
// and the crossing's previous sample).
TEST(Observables, ARestartedRunGivesTheUninterruptedValues) {
  const std::string text = cantilever(2e-4, 1.0, 0.05, kObservables);
  const Scene s = parse_scene(text, "restart.toml");
  const RunResult whole = run(s, "whole.h5");
  const RunResult part = run(s, "part.h5", 0.3);  // before the zero crossing, between `at` times
  ASSERT_TRUE(part.interrupted);
  const h5::Checkpoint c = h5::read_checkpoint(path("part.h5"));
  const Scene again = parse_scene(c.scene_text, c.scene_source);
  const RunResult rest = run(again, "rest.h5", -1, &c);
  ASSERT_EQ(rest.observables.size(), whole.observables.size());
  for (std::size_t k = 0; k < whole.observables.size(); ++k)
    EXPECT_EQ(rest.observables[k].values, whole.observables[k].values) << whole.observables[k].name;
  EXPECT_NE(value(part.observables, "dissipated"), value(whole.observables, "dissipated"));
}

// In a sweep each variation gets the observables as summary columns (then
// statistics), equal where they measure what a built-in column measures.
TEST(Observables, SweepColumnsAgreeWithTheBuiltInSummary) {
  const std::string obs = R"(
[[observables]]
name = "moved_max"
quantity = "displacement"
reduce = "max"
[[observables]]
name = "strain_max"
quantity = "strain"
reduce = "max"
[[observables]]
name = "heat"
quantity = "energy"
component = "dissipated"
reduce = "final"
[[observables]]
name = "t_zero"
quantity = "displacement"
component = "x"
first_below = 0.0
)";
  const std::string text = cantilever(1e-4, 0.8, 0.05, obs);
  const Sweep sw = make_sweep(text, "sweep.toml", {parse_vary("rods.0.material.youngs_modulus=0.5e6,1e6,2e6")},
                              make_design("", 0, 0));
  RunOptions o;
  o.output = path("sweep.h5");
  const SweepRun r = run_sweep(sw, o);
  auto col = [&](const std::string& n) {
    for (const h5::Column& c : r.summary)
      if (c.name == n) return c.values;
    ADD_FAILURE() << "no column " << n;
    return std::vector<double>{};
  };
  EXPECT_EQ(col("moved_max"), col("tip_deflection_max_m"));
  EXPECT_EQ(col("strain_max"), col("max_strain"));
  EXPECT_EQ(col("heat"), col("dissipated_J"));
  // the crossing time scales as the period, E^(−1/2) at a fixed ζ-free
  // part; with τ fixed ζ = τω/2 grows with E and delays it by Δζ/ω:
  // (π/2 + ζ)/ω_d, to the 1 % of the higher modes
  const std::vector<double> tz = col("t_zero");
  ASSERT_EQ(tz.size(), 3u);
  for (int i = 0; i < 3; ++i) {
    const double E = 0.5e6 * std::pow(2.0, i), w = 2 * std::numbers::pi / 1.763 * std::sqrt(E / 1e6);
    const double zeta = 0.02 * w / 2;
    EXPECT_NEAR(tz[std::size_t(i)] * w / (std::numbers::pi / 2 + zeta), 1.0, 0.01) << "E = " << E;
  }
  bool has_stats = false;
  for (const h5::Column& c : r.statistics) has_stats = has_stats || c.name == "t_zero";
  EXPECT_TRUE(has_stats);
  const h5::Reader rd(path("sweep.h5"));
  EXPECT_EQ(rd.output().sweep_summary.back().name, "t_zero");
  // the sweep's scene run with its probes alone (a calibration's candidates):
  // the same probes, bit for bit, and no /sweep tables written
  RunOptions bare = o;
  bare.output = path("sweep_bare.h5");
  bare.probes = sw.probes;
  const RunResult q = run_scene(sw.scene, bare);
  ASSERT_EQ(q.probes.size(), r.run.probes.size());
  for (std::size_t i = 0; i < q.probes.size(); ++i)
    EXPECT_EQ(observed_values(q.probes[i].observed), observed_values(r.run.probes[i].observed));
  EXPECT_TRUE(h5::Reader(path("sweep_bare.h5")).output().sweep_summary.empty());
}

// Contacts and the deepest overlap of a rod dropped on a floor, against
// the frames' /contact record at the end.
TEST(Observables, ContactCountsMatchTheContactRecord) {
  const std::string text = R"([simulation]
dt = 1e-4
duration = 0.3
output_interval = 0.05
gravity = [0.0, 0.0, -9.81]
[[rods]]
name = "cable"
elements = 20
length = 0.4
start = [0.0, 0.0, 0.02]
direction = [1.0, 0.0, 0.0]
normal = [0.0, 0.0, 1.0]
section = { shape = "circle", radius = 0.005 }
material = { density = 1000.0, youngs_modulus = 1.0e6, poisson_ratio = 0.5 }
damping = { tau_shear = 0.01, tau_extension = 0.01 }
[[colliders]]
name = "floor"
kind = "plane"
point = [0.0, 0.0, 0.0]
normal = [0.0, 0.0, 1.0]
[[observables]]
name = "touching"
quantity = "contacts"
reduce = "final"
[[observables]]
name = "touching_max"
quantity = "contacts"
rod = 0
reduce = "max"
[[observables]]
name = "overlap"
quantity = "penetration"
reduce = "final"
[[observables]]
name = "landed"
quantity = "contacts"
first_above = 1
)";
  const Scene s = parse_scene(text, "drop.toml");
  const RunResult r = run(s, "drop.h5");
  const h5::Reader rd(path("drop.h5"));
  const h5::EnergyRow& last = rd.output().energy.back();
  EXPECT_EQ(value(r.observables, "touching"), last.contacts);
  EXPECT_EQ(value(r.observables, "overlap"), last.max_penetration);
  EXPECT_GE(value(r.observables, "touching_max"), value(r.observables, "touching"));
  EXPECT_GT(value(r.observables, "touching"), 0);
  // dropped from 2 cm less its 5 mm radius: free fall lands at √(2·0.015/g) = 0.0553 s
  EXPECT_NEAR(value(r.observables, "landed"), std::sqrt(2 * 0.015 / 9.81), 64 * 1e-4);
}

TEST(Observables, BadTablesGiveClearErrors) {
  const std::string base = cantilever(1e-4, 1.0, 0.1, "");
  auto error = [&](const std::string& obs) {
    try {
      parse_scene(base + "[[observables]]\n" + obs, "bad.toml");
    } catch (const SceneError& e) {
      return std::string(e.what());
    }
    return std::string("(no error)");
  };
  auto expect_has = [](const std::string& s, const std::string& needle) {
    EXPECT_NE(s.find(needle), std::string::npos) << "'" << needle << "' not in: " << s;
  };
  expect_has(error("name = \"a\"\nquantity = \"speed\"\nreduce = \"max\"\n"),
             "observables.0.quantity: \"speed\" is not one of");
  expect_has(error("name = \"a\"\nquantity = \"position\"\nreduce = \"max\"\n"),
             "observables.0.component: missing (\"x\", \"y\", \"z\" or \"norm\")");
  expect_has(error("name = \"a\"\nquantity = \"position\"\ncomponent = \"x\"\nrod = 1\nreduce = \"max\"\n"),
             "observables.0.rod: must be in [0, 0]");
  expect_has(error("name = \"a\"\nquantity = \"position\"\ncomponent = \"x\"\nnode = 11\nreduce = \"max\"\n"),
             "observables.0.node: must be in [-11, 10]");
  expect_has(error("name = \"a\"\nquantity = \"strain\"\nreduce = \"max\"\nat = 0.5\n"), "give exactly one of at");
  expect_has(error("name = \"a\"\nquantity = \"strain\"\n"), "give exactly one of at");
  expect_has(error("name = \"a\"\nquantity = \"strain\"\nat = [0.5, -1.0]\n"), "times must be >= 0");
  expect_has(error("name = \"a\"\nquantity = \"strain\"\nat = [0.5, 0.5]\n"), "is given twice");
  expect_has(error("name = \"a\"\nquantity = \"energy\"\ncomponent = \"dissipated\"\nrod = 0\nreduce = \"final\"\n"),
             "give rod = \"all\"");
  expect_has(error("name = \"a\"\nquantity = \"contacts\"\nreduce = \"max\"\n"), "needs contact");
  expect_has(error("name = \"a b\"\nquantity = \"strain\"\nreduce = \"max\"\n"), "use letters, digits");
  expect_has(error("name = \"a\"\nquantity = \"strain\"\nnode = 2\nreduce = \"max\"\n"),
             "observables.0.node: applies to a position or displacement only");
  expect_has(error("name = \"a\"\nquantity = \"strain\"\nreduce = \"max\"\nwhen = 2\n"), "unknown key");
  expect_has(error("name = \"a\"\nquantity = \"strain\"\nreduce = \"max\"\n[[observables]]\nname = \"a\"\n"
                   "quantity = \"strain\"\nreduce = \"min\"\n"),
             "two observables give the column \"a\"");
  // a sweep refuses a column that a built-in one or a parameter has
  try {
    make_sweep(base + "[[observables]]\nname = \"max_strain\"\nquantity = \"strain\"\nreduce = \"max\"\n", "s.toml",
               {parse_vary("rods.0.length=0.2,0.3")}, make_design("", 0, 0));
    ADD_FAILURE() << "no error";
  } catch (const SceneError& e) {
    expect_has(e.what(), "\"max_strain\" is the name of a summary column already");
  }
}
