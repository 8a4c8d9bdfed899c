// tests/test_scene.cpp — TOML scenes (include/manyrods/scene.h, docs/scenes.md): the
// example scenes load into the rods they describe, every kind of bad input
// is an error naming file, line, column and key, term switches and rest
// curvature do what the docs say, and --vary overrides reach the rods.
#include <gtest/gtest.h>

#include <cmath>
#include <numbers>
#include <string>
#include <vector>

#include "cases.h"
#include "host/scene/setup/static_cache.h"
#include "manyrods/mesh.h"
#include "manyrods/scene.h"
#include "host/core/advanced.h"

using namespace manyrods;
using namespace manyrods::scene;

namespace {

const std::string kScenes = MANYRODS_SCENES;

// A valid one-group scene; `rods_extra` is appended inside [[rods]] (after
// line 12), `sim_extra` inside [simulation] (after line 3).
std::string scene_text(const std::string& rods_extra = "", const std::string& sim_extra = "") {
  return "[simulation]\n"       // 1
         "dt = 1e-4\n"          // 2
         "duration = 0.01\n" +  // 3
         sim_extra +
         "\n"
         "[[rods]]\n"
         "name = \"beam\"\n"
         "elements = 6\n"
         "length = 0.3\n"
         "section = { shape = \"rectangle\", width = 0.01, height = 0.01 }\n"
         "material = { density = 1000.0, youngs_modulus = 1.0e6, poisson_ratio = 0.3 }\n"
         "damping = { tau_shear = 0.01, tau_extension = 0.02 }\n" +
         rods_extra;
}

// Parses `text` as "bad.toml" and expects a SceneError containing every needle.
void expect_error(const std::string& text, const std::vector<std::string>& needles,
                  const std::vector<Override>& ov = {}) {
  try {
    (void)parse_scene(text, "bad.toml", ov);
    ADD_FAILURE() << "no SceneError for:\n" << text;
  } catch (const SceneError& e) {
    const std::string msg = e.what();
    for (const std::string& n : needles)
      EXPECT_NE(msg.find(n), std::string::npos) << "'" << n << "' not in: " << msg;
  }
}

double norm(const Vec3& v) { return std::sqrt(v[0] * v[0] + v[1] * v[1] + v[2] * v[2]); }

}  // namespace

TEST(Scene, SeedCantileverExampleMatchesTheApiRod) {
  const Scene s = load_scene(kScenes + "/seed_cantilever.toml");
  ASSERT_EQ(s.rods.size(), 1u);
  const RodSpec& r = s.rods[0];
  const RodSpec ref = cases::seed_cantilever(50, Damping::shear_extension(0.02, 0.02));
  EXPECT_EQ(r.elements(), 50);
  EXPECT_TRUE(r.clamped_root);
  EXPECT_EQ(r.section.shape, Shape::rectangle);
  EXPECT_EQ(r.section.a, ref.section.a);
  EXPECT_EQ(r.material.youngs_modulus, ref.material.youngs_modulus);
  EXPECT_EQ(r.material.density, ref.material.density);
  EXPECT_EQ(r.material.poisson_ratio, ref.material.poisson_ratio);
  EXPECT_EQ(r.damping.form, Damping::Form::shear_extension);
  EXPECT_EQ(r.damping.p1, 0.02);
  EXPECT_EQ(r.damping.p2, 0.02);
  for (int j = 0; j <= 50; ++j)
    for (int a = 0; a < 3; ++a) EXPECT_NEAR(r.nodes[j][a], ref.nodes[j][a], 1e-15);
  EXPECT_TRUE(s.sim.dt_auto);
  EXPECT_EQ(s.sim.duration, 30.0);
  EXPECT_TRUE(s.groups[0].has_initial_tip_force);

  // The initial state is the static equilibrium under the tip force, the
  // same as solve_static on the API rod (the set-up of the elastica case 1b).
  const RodBatch<double> b = build_scene_batch<double>(s);
  RodBatch<double> api = build_batch<double>({ref});
  api.set_node_force(0, 50, {0.05, 0, 0});
  ASSERT_TRUE(solve_static(api).converged);
  for (int j = 0; j <= 50; ++j)
    for (int a = 0; a < 3; ++a) EXPECT_NEAR(b.position(0, j)[a], api.position(0, j)[a], 1e-12);
  EXPECT_GT(b.position(0, 50)[0], 0.1);  // really deflected
  // released: no load remains on the tip
  EXPECT_EQ(b.loads.node_force[0][b.node_index(0, 50)], 0.0);
}

TEST(Scene, HairGroomRootsLieOnTheScalpAndGrowOutward) {
  const Scene s = load_scene(kScenes + "/hair_groom.toml");
  ASSERT_EQ(s.groups.size(), 1u);
  ASSERT_EQ(int(s.rods.size()), s.groups[0].count);
  EXPECT_EQ(s.sim.precision, Precision::float64);  // stiff rods: double (README "Not yet here")
  const double cap = std::cos(70.0 * std::numbers::pi / 180);
  for (const RodSpec& r : s.rods) {
    const Vec3& x0 = r.nodes[0];
    EXPECT_NEAR(norm(x0), 0.09, 1e-12);    // on the sphere (center 0)
    EXPECT_GE(x0[2] / 0.09, cap - 1e-12);  // inside the 70° cap around +z
    const Mat3& q = r.frames[0];           // d3 = row 2 = outward normal
    EXPECT_NEAR(q[6] * x0[0] + q[7] * x0[1] + q[8] * x0[2], 0.09, 1e-9);
    EXPECT_EQ(r.section.a, 40e-6);
    EXPECT_TRUE(r.clamped_root);
    EXPECT_TRUE(r.stiff_implicit);  // stiff = true: frame-rate steps
  }
  // scattered, not stacked: distinct roots
  EXPECT_GT(
      norm({s.rods[0].nodes[0][0] - s.rods[1].nodes[0][0], s.rods[0].nodes[0][1] - s.rods[1].nodes[0][1],
            s.rods[0].nodes[0][2] - s.rods[1].nodes[0][2]}),
      1e-4);
}

TEST(Scene, CableBundleIsAGrid) {
  const Scene s = load_scene(kScenes + "/cable_bundle.toml");
  ASSERT_EQ(s.rods.size(), 16u);
  for (int i = 0; i < 16; ++i) {
    const Vec3& x0 = s.rods[i].nodes[0];
    EXPECT_NEAR(x0[0], 0, 1e-15);
    EXPECT_NEAR(x0[1], 0.02 * (i % 4), 1e-15);  // axes = [[0,1,0],[0,0,1]], columns = 4
    EXPECT_NEAR(x0[2], 0.02 * (i / 4), 1e-15);
    EXPECT_NEAR(s.rods[i].nodes.back()[0], 1.0, 1e-12);  // along +x, length 1
  }
  EXPECT_EQ(s.rods[0].section.shape, Shape::hollow_circle);
  EXPECT_EQ(s.rods[0].damping.form, Damping::Form::viscosities);
  EXPECT_TRUE(step_choice(s).gravity);
  EXPECT_TRUE(step_choice(s).kelvin_voigt);
}

TEST(Scene, ListPlacementAndDefaults) {
  const Scene s =
      parse_scene(scene_text("count = 2\nplacement = { kind = \"list\", starts = [[0,0,0],[1,2,3]] }\n"
                             "root = \"free\"\ntip_force = [0.0, 0.5, 0.0]\n"),
                  "ok.toml");
  ASSERT_EQ(s.rods.size(), 2u);
  EXPECT_EQ(s.rods[1].nodes[0], (Vec3{1, 2, 3}));
  EXPECT_FALSE(s.rods[0].clamped_root);
  EXPECT_FALSE(s.sim.dt_auto);
  EXPECT_EQ(s.sim.dt, 1e-4);
  EXPECT_EQ(s.sim.output_interval, 0.01 / 100);  // default: duration / 100
  EXPECT_EQ(s.sim.integrator, Integrator::position_verlet);
  const RodBatch<double> b = build_scene_batch<double>(s);
  EXPECT_EQ(b.loads.node_force[1][b.node_index(1, 6)], 0.5);  // dead load on the tip node
  EXPECT_EQ(b.loads.node_force[1][b.node_index(1, 5)], 0.0);
}

TEST(Scene, RestCurvatureBuildsTheRodUnstressedInThatShape) {
  const Vec3 u0{30, -10, 5};
  const Scene s = parse_scene(scene_text("rest_curvature = [30.0, -10.0, 5.0]\n"), "curly.toml");
  const RodBatch<double> b = build_scene_batch<double>(s);
  const ModelView<double> m = b.model_view();
  const ConstStateView<double> st = b.state_view();
  for (int j = 0; j + 1 < 6; ++j) {  // the library's discrete curvature = the requested U0
    const vec3<double> k = voronoi_strain(b.vor_index(0, j), m, st).kappa;
    EXPECT_NEAR(k.x, u0[0], 1e-9);
    EXPECT_NEAR(k.y, u0[1], 1e-9);
    EXPECT_NEAR(k.z, u0[2], 1e-9);
  }
  EXPECT_NEAR(energies(b).elastic, 0, 1e-20);  // built in its rest shape
  // and it is not straight
  EXPECT_GT(std::abs(b.position(0, 6)[0]) + std::abs(b.position(0, 6)[1]), 0.01);
}

// A term switched off by zeroing its stiffness (the scene's way) steps like
// the compile-time switch of include/manyrods/terms.h.
TEST(Scene, TermSwitchedOffByZeroStiffnessEqualsTheCompileTimeSwitch) {
  const std::string extra =
      "root = \"clamped\"\ntip_force = [0.02, 0.01, 0.0]\n[rods.terms]\nbend = false\ntwist = false\n";
  const Scene s = parse_scene(scene_text(extra), "terms.toml");
  RodBatch<double> a = build_scene_batch<double>(s);
  for (int e = 0; e < 6; ++e) EXPECT_EQ(a.model.vor_stiffness[0][a.vor_index(0, std::min(e, 4))], 0.0);
  EXPECT_EQ(a.model.vor_stiffness[2][a.root_vor_index(0)], 0.0);
  EXPECT_GT(a.model.elem_stiffness[0][a.elem_index(0, 0)], 0.0);  // shear stays on
  RodBatch<double> b = build_batch<double>({s.rods[0]});
  b.set_node_force(0, 6, {0.02, 0.01, 0});
  constexpr Terms kNoBendTwist = [] {
    Terms t;
    t.bend = false;
    t.twist = false;
    return t;
  }();
  for (int i = 0; i < 200; ++i) {
    step(a, 1e-4);
    step<kNoBendTwist>(b, 1e-4);
  }
  double diff = 0, scale = 0;
  for (int j = 0; j <= 6; ++j)
    for (int d = 0; d < 3; ++d) {
      diff = std::max(diff, std::abs(a.position(0, j)[d] - b.position(0, j)[d]));
      scale = std::max(scale, std::abs(b.position(0, j)[d] - s.rods[0].nodes[j][d]));
    }
  EXPECT_GT(scale, 1e-4);        // it moved
  EXPECT_LE(diff, 1e-12 * 0.3);  // round-off of the summation order only
}

TEST(Scene, KelvinVoigtOffAndGravitySwitches) {
  const Scene s = parse_scene(
      scene_text("[rods.terms]\nkelvin_voigt = false\ngravity = false\n", "gravity = [0.0, 0.0, -9.81]\n"),
      "terms.toml");
  EXPECT_EQ(s.rods[0].damping.form, Damping::Form::none);
  const StepChoice c = step_choice(s);
  EXPECT_FALSE(c.kelvin_voigt);
  EXPECT_FALSE(c.gravity);
  const Scene g =
      parse_scene(scene_text("", "gravity = [0.0, 0.0, -9.81]\nintegrator = \"pefrl\"\n"), "g.toml");
  EXPECT_TRUE(step_choice(g).gravity);
  EXPECT_TRUE(step_choice(g).kelvin_voigt);
  EXPECT_EQ(step_choice(g).integrator, Integrator::pefrl);
}

TEST(Scene, GravityPerGroup) {
  // Two groups, the second without gravity: the batch carries gravity as
  // dead node loads m_j g on the first group. Its rod moves as in a scene of
  // that group alone (the compile-time gravity term), the other stays put.
  const std::string sim = "gravity = [0.0, -9.81, 0.0]\n";
  const Scene one = parse_scene(scene_text("", sim), "one.toml");
  const Scene two = parse_scene(scene_text("[[rods]]\nelements = 6\nlength = 0.3\nstart = [0.5, 0.0, 0.0]\n"
                                           "section = { shape = \"rectangle\", width = 0.01, height = 0.01 }\n"
                                           "material = { density = 1000.0, youngs_modulus = 1.0e6, poisson_ratio = 0.3 }\n"
                                           "[rods.terms]\ngravity = false\n",
                                           sim),
                                "two.toml");
  EXPECT_TRUE(step_choice(one).gravity);
  EXPECT_FALSE(step_choice(two).gravity);
  RodBatch<double> a = build_scene_batch<double>(one), b = build_scene_batch<double>(two);
  const double dt = scene_dt(one, a);
  advance_scene(a, step_choice(one), dt, 500, {});
  advance_scene(b, step_choice(two), dt, 500, {});
  double diff = 0, sag = 0, still = 0;
  for (int j = 0; j <= 6; ++j)
    for (int d = 0; d < 3; ++d) {
      diff = std::max(diff, std::abs(a.position(0, j)[d] - b.position(0, j)[d]));
      sag = std::max(sag, std::abs(a.position(0, j)[d] - one.rods[0].nodes[j][d]));
      still = std::max(still, std::abs(b.position(1, j)[d] - two.rods[1].nodes[j][d]));
    }
  EXPECT_GT(sag, 1e-3);  // it fell
  // g as m⁻¹(m g) instead of g: one rounding per node and step
  EXPECT_LE(diff, 500 * 1e-15 * 0.3);
  EXPECT_LT(still, 1e-12 * 0.3);  // at rest up to the round-off of its rest strains (1e-17 m measured)
  // the potential energy counts the gravity loads: the same total energy
  const Energies ea = scene_energies(a, step_choice(one), 0), eb = scene_energies(b, step_choice(two), 0);
  EXPECT_NEAR(ea.total(), eb.total(), 1e-9 * std::abs(ea.potential));
}

TEST(Scene, StaticStatesAreSolvedOnceAndTakenFromTheCache) {
  // Three rods pre-loaded by a tip force (three static solves: a rod's key
  // holds its nodes, so the two alike rods placed apart are two); a second
  // batch with the cache takes all three from it (hits) and starts in the
  // same state, bit for bit, as one solved without it.
  const std::string text = R"([simulation]
dt = "auto"
duration = 0.1
output_interval = 0.05
[[rods]]
name = "a"
count = 2
elements = 8
length = 0.3
placement = { kind = "grid", spacing = [0.05, 0.05] }
initial_tip_force = [0.01, 0.0, 0.0]
section = { shape = "rectangle", width = 0.01, height = 0.01 }
material = { density = 1000.0, youngs_modulus = 1.0e6, poisson_ratio = 0.3 }
[[rods]]
name = "b"
elements = 8
length = 0.3
start = [0.5, 0.0, 0.0]
initial_tip_force = [0.02, 0.0, 0.0]
section = { shape = "rectangle", width = 0.01, height = 0.01 }
material = { density = 1000.0, youngs_modulus = 1.0e6, poisson_ratio = 0.3 }
)";
  const Scene s = parse_scene(text, "cache.toml");
  StaticCache cache;
  const RodBatch<double> plain = build_scene_batch<double>(s);
  const RodBatch<double> first = build_scene_batch<double>(s, true, &cache);
  EXPECT_EQ(cache.hits(), 0u);
  const RodBatch<double> second = build_scene_batch<double>(s, true, &cache);
  EXPECT_EQ(cache.hits(), 3u);
  for (const RodBatch<double>* b : {&first, &second}) {
    EXPECT_EQ(state_hash(*b), state_hash(plain));
    for (int r = 0; r < 3; ++r)
      for (int j = 0; j <= 8; ++j) EXPECT_EQ(b->position(r, j), plain.position(r, j));
  }
  EXPECT_GT(std::abs(plain.position(2, 8)[0] - s.rods[2].nodes[8][0]), 0.01);  // (deflected)
}

TEST(Scene, StepAboveTheStableLimitIsRefusedUnlessForced) {
  // The seed beam at 6 elements: stable_dt ≈ 3e-4 s. dt = 1e-4 is taken as
  // given; 1e-2 is refused (SceneError with the limit), and taken when forced.
  Scene ok = parse_scene(scene_text(), "ok.toml");
  const RodBatch<double> a = build_scene_batch<double>(ok);
  const double limit = stable_dt(a).elastic;
  ASSERT_GT(limit, 1e-4);
  EXPECT_EQ(scene_dt(ok, a), 1e-4);
  std::string text = scene_text("", "output_interval = 0.01\n");  // (a whole number of forced steps)
  text.replace(text.find("dt = 1e-4"), 9, "dt = 1e-2");
  Scene big = parse_scene(text, "big.toml");
  try {
    (void)scene_dt(big, a);
    FAIL() << "dt = 1e-2 s (" << 1e-2 / limit << " x the limit) was accepted";
  } catch (const SceneError& e) {
    EXPECT_NE(std::string(e.what()).find("big.toml: simulation.dt = 0.01 s"), std::string::npos) << e.what();
    EXPECT_NE(std::string(e.what()).find("stable limit"), std::string::npos) << e.what();
  }
  big.sim.force_dt = true;
  EXPECT_EQ(scene_dt(big, a), 1e-2);
}

TEST(Scene, DrivenRoots) {
  const Scene s = parse_scene(
      scene_text("count = 3\nplacement = { kind = \"grid\", spacing = [0.05, 0.05] }\n"
                 "root = { motion = \"oscillate\", translation_amplitude = [0.01, 0.0, 0.0], rotation_axis = "
                 "[0.0, 1.0, 0.0], rotation_amplitude = 30.0, frequency = 2.0, phase = 90.0, pivot = [0.0, 0.0, 0.1] }\n"
                 "[[rods]]\nelements = 4\nlength = 0.2\n"
                 "section = { shape = \"circle\", radius = 0.002 }\n"
                 "material = { density = 1000.0, youngs_modulus = 1.0e6, poisson_ratio = 0.3 }\n"
                 "[rods.root]\nmotion = \"keyframes\"\ntimes = [0.0, 1.0]\n"
                 "translations = [[0.0, 0.0, 0.0], [0.0, 0.2, 0.0]]\n"
                 "rotations = [[0.0, 0.0, 1.0, 0.0], [0.0, 0.0, 2.0, 90.0]]\n"),
      "driven.toml");
  ASSERT_EQ(s.rods.size(), 4u);
  // one motion per group, shared by its rods; the rods are clamped
  EXPECT_EQ(s.rods[0].root_motion, s.rods[2].root_motion);
  EXPECT_NE(s.rods[0].root_motion, s.rods[3].root_motion);
  for (const RodSpec& r : s.rods) EXPECT_TRUE(r.clamped_root && r.root_motion);
  const auto* o = dynamic_cast<const OscillatingMotion*>(s.rods[0].root_motion.get());
  ASSERT_NE(o, nullptr);
  EXPECT_NEAR(o->rotation_amplitude, std::numbers::pi / 6, 1e-15);  // degrees in the file
  EXPECT_NEAR(o->phase, std::numbers::pi / 2, 1e-15);
  EXPECT_EQ(o->frequency, 2.0);
  EXPECT_EQ(o->pivot[2], 0.1);
  EXPECT_EQ(o->ramp_time, 0.0);
  // keyframes: halfway, half the translation and 45° about e3
  const Pose p = s.rods[3].root_motion->at(0.5);
  EXPECT_NEAR(p.translation[1], 0.1, 1e-15);
  EXPECT_NEAR(p.rotation[0], std::cos(std::numbers::pi / 4), 1e-15);
  EXPECT_NEAR(p.rotation[3], std::sin(std::numbers::pi / 4), 1e-15);  // R e1 = (cos, sin, 0)
  // the batch moves the roots: after 0.5 s the keyframed root is at +0.1 e2
  RodBatch<double> b = build_scene_batch<double>(s);
  const double dt = 1e-4;
  advance_scene(b, step_choice(s), dt, 5000, {});
  const Vec3 root = b.position(3, 0);
  EXPECT_NEAR(root[1], s.rods[3].nodes[0][1] + 0.1, 1e-12);
}

TEST(Scene, OverridesReachTheRods) {
  const Scene s =
      parse_scene(scene_text(), "v.toml",
                  {{"rods.0.damping.tau_extension", 0.05}, {"rods.0.elements", 9}, {"rods.0.length", 0.5}});
  EXPECT_EQ(s.rods[0].damping.p2, 0.05);
  EXPECT_EQ(s.rods[0].elements(), 9);
  EXPECT_NEAR(s.rods[0].nodes.back()[2], 0.5, 1e-15);
  // an absent integer key is added as an integer (a whole value) …
  const Scene c = parse_scene(scene_text("placement = { kind = \"grid\", spacing = [0.1, 0.1] }\n"), "v.toml",
                              {{"rods.0.count", 4}});
  EXPECT_EQ(c.rods.size(), 4u);
  expect_error(scene_text(), {"--vary rods.0.elements", "integer"}, {{"rods.0.elements", 2.5}});
  expect_error(scene_text(), {"--vary rods.0.nosuch.key", "no key 'nosuch'"}, {{"rods.0.nosuch.key", 1}});
  expect_error(scene_text(), {"simulation", "cannot be varied"}, {{"simulation.dt", 1}});
  expect_error(scene_text(), {"rods.3", "out of range"}, {{"rods.3.length", 1}});
  // a value that is out of range is caught by the schema, named as set by --vary
  expect_error(scene_text(), {"rods.0.material.youngs_modulus (set by --vary)", "must be > 0"},
               {{"rods.0.material.youngs_modulus", -5}});
  // a key that does not belong there
  expect_error(scene_text(),
               {"bad.toml:11:11: rods.0.damping: viscosities and retardation times given together"},
               {{"rods.0.damping.bulk_viscosity", 1}});
}

// ---- bad input: each names file, line, column and key ------------------------

TEST(SceneErrors, UnknownKeys) {
  expect_error(scene_text("", "dtt = 3\n"),
               {"bad.toml:4:1: simulation.dtt: unknown key", "allowed here: dt,"});
  expect_error(scene_text("colour = \"red\"\n"), {"bad.toml:12:1: rods.0.colour: unknown key"});
  expect_error(scene_text("[rods.terms]\nbending = false\n"),
               {"bad.toml:13:1: rods.0.terms.bending: unknown key"});
  expect_error(
      "[simulation]\ndt = 1e-4\nduration = 1.0\n[[rods]]\nelements = 3\nlength = 1.0\n"
      "section = { shape = \"circle\", radius = 0.01, width = 2.0 }\n"
      "material = { density = 1.0, youngs_modulus = 1.0, poisson_ratio = 0.3 }\n",
      {"bad.toml:7:", "rods.0.section.width: unknown key"});
  expect_error(scene_text() + "[extra]\nx = 1\n", {"bad.toml:12:", "extra: unknown key"});
}

TEST(SceneErrors, WrongTypes) {
  expect_error(scene_text("count = \"ten\"\n"),
               {"bad.toml:12:9: rods.0.count: must be an integer, got a string"});
  expect_error(scene_text("count = 2.0\n"), {"bad.toml:12:9: rods.0.count: must be an integer, got a float"});
  expect_error(scene_text("start = [0.0, 1.0]\n"), {"bad.toml:12:9: rods.0.start: must have 3 entries"});
  expect_error(scene_text("start = [0.0, \"a\", 1.0]\n"),
               {"bad.toml:12:", "rods.0.start.1: must be a number, got a string"});
  expect_error(
      scene_text("", "integrator = \"euler\"\n"),
      {"bad.toml:4:14: simulation.integrator: \"euler\" is not one of \"position_verlet\", \"pefrl\""});
  expect_error(scene_text("", "precision = 32\n"), {"bad.toml:4:", "simulation.precision: must be a string"});
  expect_error(scene_text("[rods.terms]\nshear = 1\n"),
               {"bad.toml:13:9: rods.0.terms.shear: must be true or false"});
  expect_error(scene_text("root = \"hinged\"\n"), {"bad.toml:12:", "rods.0.root: \"hinged\" is not one of"});
}

TEST(SceneErrors, OutOfRangeValues) {
  std::string t = scene_text();
  auto replace = [](std::string s, const std::string& from, const std::string& to) {
    s.replace(s.find(from), from.size(), to);
    return s;
  };
  expect_error(replace(t, "elements = 6", "elements = 0"),
               {"bad.toml:7:12: rods.0.elements: must be in [1,", "(got 0)"});
  expect_error(replace(t, "youngs_modulus = 1.0e6", "youngs_modulus = -1.0e6"),
               {"bad.toml:10:", "rods.0.material.youngs_modulus: must be > 0 (got -1000000)"});
  expect_error(replace(t, "density = 1000.0", "density = nan"),
               {"bad.toml:10:", "rods.0.material.density: must be finite"});
  expect_error(replace(t, "length = 0.3", "length = inf"), {"bad.toml:8:10: rods.0.length: must be finite"});
  expect_error(replace(t, "dt = 1e-4", "dt = 0"), {"bad.toml:2:6: simulation.dt: must be > 0 (got 0)"});
  expect_error(replace(t, "dt = 1e-4", "dt = \"fast\""),
               {"bad.toml:2:6: simulation.dt: must be a number of seconds or \"auto\""});
  expect_error(replace(t, "duration = 0.01", "duration = -1.0"),
               {"bad.toml:3:", "simulation.duration: must be > 0"});
  expect_error(replace(t, "poisson_ratio = 0.3", "poisson_ratio = 0.7"),
               {"bad.toml:10:", "rods.0.material.poisson_ratio: must be in (-1, 0.5]"});
  expect_error(replace(t, "tau_shear = 0.01", "tau_shear = -0.01"),
               {"bad.toml:11:", "rods.0.damping.tau_shear: must be >= 0"});
  expect_error(replace(t, "width = 0.01", "width = 0.0"),
               {"bad.toml:9:", "rods.0.section.width: must be > 0"});
  expect_error(scene_text("[rods.terms]\ngravity = false\n", "dt_safety = 0.5\n"),
               {"bad.toml:4:", "simulation.dt_safety: only used with dt = \"auto\""});
  expect_error(scene_text("normal = [0.0, 0.0, 2.0]\n"),
               {"bad.toml:12:", "rods.0.normal: normal must not be parallel"});
  expect_error(scene_text("direction = [0.0, 0.0, 0.0]\n"),
               {"bad.toml:12:", "rods.0.direction: must not be the zero vector"});
}

TEST(SceneErrors, InconsistentOrMissing) {
  const std::string head = "[simulation]\ndt = 1e-4\nduration = 1.0\n[[rods]]\nelements = 3\nlength = 1.0\n";
  const std::string mat = "material = { density = 1.0, youngs_modulus = 1.0, poisson_ratio = 0.3 }\n";
  const std::string sec = "section = { shape = \"circle\", radius = 0.01 }\n";
  expect_error(head + mat, {"bad.toml:4:1: rods.0.section: missing (required)"});
  expect_error(head + sec, {"bad.toml:4:1: rods.0.material: missing (required)"});
  expect_error("[[rods]]\nelements = 3\n", {"bad.toml: simulation: missing table [simulation]"});
  expect_error("[simulation]\ndt = 1e-4\nduration = 1.0\n", {"bad.toml: rods: missing"});
  expect_error(
      head + sec +
          "material = { density = 1.0, youngs_modulus = 1.0, poisson_ratio = 0.3, shear_modulus = 0.4 }\n",
      {"bad.toml:8:", "rods.0.material.shear_modulus: give poisson_ratio or shear_modulus, not both"});
  expect_error(
      head + sec + "material = { density = 1.0, youngs_modulus = 1.0 }\n",
      {"bad.toml:8:", "rods.0.material.poisson_ratio: missing (give poisson_ratio or shear_modulus)"});
  expect_error(head + sec + mat + "count = 3\n",
               {"bad.toml:4:1: rods.0.placement: missing (count > 1 needs a placement"});
  expect_error(
      head + mat + "section = { shape = \"hollow_circle\", outer_radius = 0.01, inner_radius = 0.01 }\n",
      {"bad.toml:8:", "rods.0.section.inner_radius: must be < outer_radius"});
  expect_error(head + sec + mat + "root = \"driven\"\n",
               {"bad.toml:9:", "rods.0.root: \"driven\" is not one of \"clamped\", \"pinned\", \"free\""});
  // driven roots
  expect_error(head + sec + mat + "root = { frequency = 2.0 }\n",
               {"bad.toml:9:", "rods.0.root.motion: missing"});
  expect_error(head + sec + mat + "root = { motion = \"spin\" }\n",
               {"bad.toml:9:", "rods.0.root.motion: \"spin\" is not one of \"oscillate\", \"keyframes\""});
  expect_error(head + sec + mat + "root = { motion = \"oscillate\", frequency = 2.0, rotation_amplitude = 10.0 }\n",
               {"bad.toml:9:", "rods.0.root.rotation_axis: missing"});
  expect_error(head + sec + mat + "root = { motion = \"oscillate\", frequency = -2.0 }\n",
               {"bad.toml:9:", "rods.0.root.frequency: must be > 0"});
  expect_error(head + sec + mat + "root = { motion = \"oscillate\", frequency = 2.0, ramp_time = -1.0 }\n",
               {"bad.toml:9:", "rods.0.root.ramp_time: must be >= 0"});
  expect_error(head + sec + mat + "root = { motion = \"oscillate\", frequency = 2.0, amplitude = 1.0 }\n",
               {"bad.toml:9:", "rods.0.root.amplitude: unknown key"});
  expect_error(head + sec + mat +
                   "root = { motion = \"keyframes\", times = [0.0, 0.5, 0.5], translations = [[0.0, 0.0, 0.0], "
                   "[0.1, 0.0, 0.0], [0.0, 0.0, 0.0]] }\n",
               {"bad.toml:9:", "rods.0.root.times.2: times must increase strictly"});
  expect_error(head + sec + mat +
                   "root = { motion = \"keyframes\", times = [0.0, 1.0], translations = [[0.0, 0.0, 0.0]] }\n",
               {"bad.toml:9:", "rods.0.root.translations: needs one [x, y, z] per time (2), got 1"});
  expect_error(head + sec + mat +
                   "root = { motion = \"keyframes\", times = [0.0, 1.0], translations = [[0.0, 0.0, 0.0], "
                   "[0.0, 0.0, 0.0]], rotations = [[0.0, 0.0, 1.0], [0.0, 0.0, 1.0, 30.0]] }\n",
               {"bad.toml:9:", "rods.0.root.rotations.0: must be [axis x, axis y, axis z, angle in degrees]"});
  expect_error(head + sec + mat +
                   "root = { motion = \"keyframes\", times = [0.0, 1.0], translations = [[0.0, 0.0, 0.0], "
                   "[0.0, 0.0, 0.0]], rotations = [[0.0, 0.0, 0.0, 0.0], [0.0, 0.0, 0.0, 30.0]] }\n",
               {"bad.toml:9:", "rods.0.root.rotations.1: a non-zero angle needs a non-zero axis"});
  expect_error(head + sec + mat + "damping = { tau_shear = 0.01 }\n",
               {"bad.toml:9:", "rods.0.damping.tau_extension: missing"});
  // (τS, τE) implying a negative bulk viscosity: the library's InputError, placed at the damping table
  expect_error(head + sec + mat + "damping = { tau_shear = 0.1, tau_extension = 0.01 }\n",
               {"bad.toml:9:", "rods.0.damping:", "bulk"});
  expect_error(head + sec + mat + "root = \"free\"\ninitial_tip_force = [1.0, 0.0, 0.0]\n",
               {"bad.toml:10:", "rods.0.initial_tip_force: needs root = \"clamped\""});
  expect_error(head + sec + mat + "preload = true\ninitial_tip_force = [1.0, 0.0, 0.0]\n",
               {"bad.toml:", "rods.0.preload: takes the rods as built as the equilibrium"});
  expect_error(head + sec + mat + "preload = 1\n", {"bad.toml:9:", "rods.0.preload"});
  expect_error(head + "section = { shape = \"circle\", radius = 0.01, taper = { root = 0.01, tip = 0.005 } }\n" + mat,
               {"bad.toml:", "rods.0.section.taper: gives the radius at the root and the tip: leave out radius"});
  expect_error(head + "section = { shape = \"rectangle\", width = 0.01, height = 0.01, taper = { root = 0.01, tip = 0.005 } }\n" + mat,
               {"bad.toml:", "rods.0.section.taper: tapers circle sections only"});
  expect_error(head + "section = { shape = \"circle\", taper = { root = 0.01, tip = 0.0 } }\n" + mat,
               {"bad.toml:", "rods.0.section.taper.tip"});
  // TOML syntax
  expect_error("[simulation]\ndt = 1e-4\nduration = \n", {"bad.toml:3:", "TOML syntax error"});
}

TEST(SceneErrors, ImpossibleMemoryRequest) {
  const std::string many = "count = 10000000\nplacement = { kind = \"grid\", spacing = [0.01, 0.01] }\n";
  // 10^7 rods of 100 elements fit the int slot index but not this machine (about 870 GB)
  expect_error(scene_text(many), {"bad.toml: the scene needs about", "GB", "more than this machine's"},
               {{"rods.0.elements", 100}});
  // 10^7 rods of 300 elements: past the library's int slot index
  expect_error(scene_text(many), {"bad.toml: the scene has 3000000000 elements", "int index"},
               {{"rods.0.elements", 300}});
}

TEST(SceneErrors, UnreadableFile) {
  try {
    (void)load_scene("/nonexistent/dir/scene.toml");
    ADD_FAILURE() << "no error";
  } catch (const SceneError& e) {
    EXPECT_NE(std::string(e.what()).find("/nonexistent/dir/scene.toml: cannot read"), std::string::npos)
        << e.what();
  }
}

// ---- contact keys (docs/scenes.md "Contact", docs/contact.md) -----------------------
TEST(Scene, ContactScenesLoadAndStartOutsideTheirColliders) {
  for (const char* f : {"hair_groom.toml", "hair_turn.toml", "cable_pile.toml"}) {
    const Scene s = load_scene(kScenes + "/" + f);
    ASSERT_TRUE(s.has_contact) << f;
    EXPECT_TRUE(s.contact.rod_rod) << f;
    EXPECT_EQ(s.contact.colliders.size(), 1u) << f;
    EXPECT_NO_THROW((void)build_scene_batch<double>(s)) << f;  // no rod starts inside a collider
    const StepChoice c = step_choice(s);
    EXPECT_TRUE(c.colliders && c.rod_contact) << f;
  }
  const Scene turn = load_scene(kScenes + "/hair_turn.toml");
  ASSERT_TRUE(turn.contact.colliders[0].motion);  // the head turns with the scalp
  const Pose p = turn.contact.colliders[0].motion->at(1.0), q = turn.rods[0].root_motion->at(1.0);
  for (int i = 0; i < 9; ++i) EXPECT_EQ(p.rotation[i], q.rotation[i]);
}

TEST(Scene, ContactKeysReachTheSpec) {
  const Scene s = parse_scene(scene_text("friction = { static = 0.5, kinetic = 0.25 }\n") +
                                  "\n[[colliders]]\nkind = \"capsule\"\na = [0.0, 0.1, 0.0]\nb = [0.0, 0.1, 0.3]\n"
                                  "radius = 0.02\nfriction = { static = 0.2, kinetic = 0.1, static_axial = 0.6, "
                                  "kinetic_axial = 0.5 }\n\n[contact]\nself = true\nhardness = 3.0\n"
                                  "damping_ratio = 0.1\ncapacity = 8\n",
                              "ok.toml");
  ASSERT_EQ(s.contact.colliders.size(), 1u);
  EXPECT_EQ(s.contact.colliders[0].kind, ColliderKind::capsule);
  EXPECT_EQ(s.contact.colliders[0].friction.kinetic_axial, 0.5);
  EXPECT_TRUE(s.contact.self);
  EXPECT_FALSE(s.contact.rod_rod);
  EXPECT_EQ(s.contact.hardness, 3.0);
  EXPECT_EQ(s.contact.capacity, 8);
  EXPECT_EQ(s.contact.max_capacity, 4096);  // the default
  ASSERT_EQ(s.contact.rod_friction.size(), 1u);
  EXPECT_TRUE(s.contact.rod_has_friction[0]);
  EXPECT_EQ(s.contact.rod_friction[0].kinetic_coefficient, 0.25);
}

TEST(SceneErrors, ContactKeys) {
  const std::string base = scene_text();
  expect_error(base + "\n[[colliders]]\nkind = \"torus\"\n", {"bad.toml:", "colliders.0.kind", "\"sphere\""});
  expect_error(base + "\n[[colliders]]\nkind = \"sphere\"\nradius = -1.0\n", {"colliders.0.radius", "must be > 0"});
  expect_error(base + "\n[[colliders]]\nkind = \"plane\"\nfriction = { static = -0.1, kinetic = 0.0 }\n",
               {"colliders.0.friction.static", ">= 0"});
  expect_error(base + "\n[[colliders]]\nkind = \"plane\"\nfriction = { static = 0.1, kinetic = 0.3 }\n",
               {"colliders.0.friction.kinetic", "must not exceed static"});
  expect_error(base + "\n[[colliders]]\nkind = \"sphere\"\nradius = 0.1\ncentre = [0.0, 0.0, 0.0]\n",
               {"colliders.0.centre", "unknown key"});
  expect_error(base + "\n[[colliders]]\nkind = \"mesh\"\nfile = \"no-such-head.obj\"\n",
               {"colliders.0.file", "no-such-head.obj"});
  expect_error(base + "\n[contact]\ncapacity = 0\n", {"contact.capacity"});
  // a rod along x: without a normal one across it is chosen; a given one along it is an error
  const Scene along_x = parse_scene(scene_text("direction = [1.0, 0.0, 0.0]\n"), "x.toml");
  EXPECT_NEAR(along_x.rods[0].frames[0][3 * 0 + 1], 1.0, 1e-15);  // d1 = +y
  expect_error(scene_text("direction = [1.0, 0.0, 0.0]\nnormal = [2.0, 0.0, 0.0]\n"),
               {"rods.0.normal", "must not be parallel to direction"});
  expect_error(base + "\n[contact]\ncapacity = 128\nmax_capacity = 100\n",
               {"contact.max_capacity", "must be >= capacity (128)"});
  expect_error(base + "\n[contact]\ncapacity = 8192\n", {"contact.capacity", "must be >= capacity (8192)"});
  expect_error(scene_text("", "integrator = \"pefrl\"\n") + "\n[contact]\nrod_rod = true\n",
               {"Position Verlet only"});
  // a rod that starts inside a collider: named with its node, at build time
  const Scene in = parse_scene(base + "\n[[colliders]]\nname = \"ball\"\nkind = \"sphere\"\ncenter = [0.0, 0.0, 0.15]\n"
                                      "radius = 0.05\n",
                               "inside.toml");
  try {
    (void)build_scene_batch<double>(in);
    ADD_FAILURE() << "no error for a rod inside a collider";
  } catch (const SceneError& e) {
    const std::string m = e.what();
    EXPECT_NE(m.find("inside.toml: contact: rod 0 ('beam[0]') node"), std::string::npos) << m;
    EXPECT_NE(m.find("collider 0 ('ball'), sphere"), std::string::npos) << m;
  }
}

// ---- mesh colliders (include/manyrods/mesh.h) ------------------------------------------
TEST(Scene, MeshColliderIsASignedDistanceGridOfTheObj) {
  const auto g = load_mesh_grid(std::string(MANYRODS_TEST_DATA) + "/head.obj", 64);
  ASSERT_TRUE(g);
  EXPECT_EQ(g->triangles.size(), 3u * 320u);
  {  // the OBJ is one of the scene's inputs (no command writes over it)
    const std::string obj = std::string(MANYRODS_TEST_DATA) + "/head.obj";
    const Scene s = parse_scene(scene_text() + "\n[[colliders]]\nkind = \"mesh\"\nfile = \"" + obj +
                                    "\"\nresolution = 16\n",
                                "mesh.toml");
    EXPECT_EQ(s.inputs, std::vector<std::string>{obj});
  }
  // an ellipsoid with semi-axes 0.075, 0.09, 0.1 m, faceted (an icosphere
  // subdivided twice: its flat faces lie inside the ellipsoid by up to
  // ~2 % of the radius): φ at the centre ≈ −(smallest semi-axis), outside
  // points positive by their distance to the surface, to the facets and the
  // grid's trilinear error (spacing 3.2 mm)
  ColliderFrame<double> f;
  f.kind = int(ColliderKind::mesh);
  f.phi = g->phi.data();
  f.nx = g->n[0];
  f.ny = g->n[1];
  f.nz = g->n[2];
  for (int d = 0; d < 3; ++d) f.origin[d] = g->origin[d];
  f.spacing = g->spacing;
  vec3<double> grad;
  EXPECT_NEAR(grid_distance(f, {0, 0, 0}, grad), -0.075, 0.004);
  EXPECT_NEAR(grid_distance(f, {0, 0, 0.105}, grad), 0.005, 0.002);  // (the grid reaches 3 cells, 9.5 mm, past the mesh)
  EXPECT_GT(grad.z, 0.8);  // outwards, |∇φ| ≈ 1
  EXPECT_LT(grad.z, 1.2);
  EXPECT_NEAR(grid_distance(f, {0.08, 0, 0}, grad), 0.005, 0.002);
  EXPECT_GT(grad.x, 0);
  EXPECT_GT(grid_distance(f, {1, 0, 0}, grad), 1e20);  // outside the grid: no contact
}

TEST(SceneErrors, MeshFiles) {
  const std::string base = scene_text();
  expect_error(base + "\n[[colliders]]\nkind = \"mesh\"\nfile = \"" + std::string(MANYRODS_TEST_DATA) +
                   "/open.obj\"\n",
               {"colliders.0.file", "open.obj", "open mesh"});
  expect_error(base + "\n[[colliders]]\nkind = \"mesh\"\nfile = \"" + std::string(MANYRODS_TEST_DATA) +
                   "/head.obj\"\nresolution = 4\n",
               {"colliders.0.resolution", "[8, 512]"});
}

TEST(Scene, RodDroppedOnAMeshHeadStaysOutside) {
  // a rod falling onto the top of the head (the mesh above): it lands and
  // stays outside, its overlap at most what the law allows (docs/contact.md)
  const std::string text = "[simulation]\ndt = 1e-4\nduration = 0.15\ngravity = [0.0, 0.0, -9.81]\n"
                           "[[colliders]]\nname = \"head\"\nkind = \"mesh\"\nfile = \"" +
                           std::string(MANYRODS_TEST_DATA) +
                           "/head.obj\"\n[[rods]]\nname = \"strand\"\nelements = 10\nlength = 0.06\n"
                           "start = [-0.03, 0.0, 0.11]\ndirection = [1.0, 0.0, 0.0]\nnormal = [0.0, 0.0, 1.0]\n"
                           "root = \"free\"\nsection = { shape = \"circle\", radius = 0.002 }\n"
                           "material = { density = 1000.0, youngs_modulus = 1.0e6, poisson_ratio = 0.3 }\n"
                           "damping = { tau_shear = 0.005, tau_extension = 0.005 }\n";
  const Scene s = parse_scene(text, "mesh.toml");
  RodBatch<double> b = build_scene_batch<double>(s);
  advance_scene(b, step_choice(s), 1e-4, 1500, Exec{1});
  const ContactStats cs = contact_stats(b);
  EXPECT_GT(cs.contacts, 0);  // it lies on the head
  EXPECT_LT(cs.max_penetration, 0.1 * 0.002);
  for (int j = 0; j <= b.elements(0); ++j) EXPECT_GT(b.position(0, j)[2], 0.09);  // on top, not through
}

// A thin rod (r = 0.5 mm, undamped) thrown at v onto a thin mesh wall: a
// closed box 6 cm × 6 cm × `thick`, its top at z = 0, as a signed-distance
// grid of `resolution` nodes along 6 cm, at the rod's stable step. Returns
// the lowest its centreline came over the wall, less r (tunnelling: below
// −thick).
struct WallThrow {
  double lowest, h, cell;
};
WallThrow throw_onto_wall(double v, double thick, int resolution) {
  const double r = 0.5e-3, a = 0.03;
  const std::string obj = ::testing::TempDir() + "thin_wall.obj";
  {
    std::FILE* f = std::fopen(obj.c_str(), "w");
    for (int i = 0; i < 8; ++i)
      std::fprintf(f, "v %g %g %g\n", (i & 1) ? a : -a, (i & 2) ? a : -a, (i & 4) ? 0.0 : -thick);
    // outward faces of the box (corners: bit 0 x, bit 1 y, bit 2 z)
    std::fputs("f 1 3 4 2\nf 5 6 8 7\nf 1 2 6 5\nf 3 7 8 4\nf 1 5 7 3\nf 2 4 8 6\n", f);
    std::fclose(f);
  }
  Collider wall;
  wall.kind = ColliderKind::mesh;
  wall.grid = load_mesh_grid(obj, resolution);
  RodSpec s = RodSpec::straight({-0.02, 0, 0.005}, {1, 0, 0}, {0, 0, 1}, 0.04, 20);
  s.name = "thread";
  s.section = Section::circle(r);
  s.material = {1000, 1e6, 0.3};
  RodBatch<double> b = build_batch<double>({s}, {0, 0, 0});
  for (int i = 0; i <= b.elements(0); ++i) b.set_velocity(0, i, {0, 0, -v});
  ContactSpec spec;
  spec.colliders = {wall};
  set_contact(b, spec);
  WallThrow t{1e9, 0.9 * stable_dt<kNoKelvinVoigt>(b).elastic, wall.grid->spacing};
  const int steps = int(std::ceil(0.01 / v / t.h)) + 20;  // to 5 mm below the wall's top
  for (int i = 0; i < steps; ++i) {
    step<kColliders>(b, t.h);
    for (int n = 0; n <= b.elements(0); ++n) t.lowest = std::min(t.lowest, b.position(0, n)[2] - r);
  }
  return t;
}

TEST(Scene, AThinFastRodNeverTunnelsThroughAThinMeshWall) {
  // A wall half the thread's radius thick (a quarter of the grid's cell) or
  // 4 radii thick, grids of 0.95 and 0.47 mm cells, at the thread's stable
  // step (2e-5 s): up to 30 m/s (0.6 mm, 0.6 diameters, a step) the
  // thread stops on the wall's top, its overlap at most the law's impact
  // bound v h/(1 + Ω²) = v h/17 (docs/contact.md "The contact law"; the
  // grid's distance to a face is exact). Independent reference: the law's
  // bound, not a recorded run.
  for (int res : {64, 128})
    for (double thick : {0.25e-3, 2e-3})
      for (double v : {1.0, 10.0, 30.0}) {
        const WallThrow t = throw_onto_wall(v, thick, res);
        std::printf("wall %.2g mm, cell %.3g mm, %g m/s, h %.3g s: deepest %.3g mm\n", thick * 1e3, t.cell * 1e3, v,
                    t.h, -t.lowest * 1e3);
        EXPECT_GT(t.lowest, -v * t.h / 17 - 1e-12) << "wall " << thick << " m, " << res << " nodes, " << v << " m/s";
      }
  // The limit (docs/contact.md "Limitations"): the grid reaches 3 cells
  // past the mesh, and a thread that crosses that margin in one step starts
  // it outside the grid, where there is no contact. At 100 m/s (2 mm a
  // step) it is caught by the 0.95 mm grid (2.9 mm margin); at 300 m/s
  // (6 mm a step) the 0.47 mm grid (1.4 mm margin) lets it through.
  const WallThrow caught = throw_onto_wall(100, 0.25e-3, 64);
  EXPECT_GT(caught.lowest, -100 * caught.h / 17);
  const WallThrow through = throw_onto_wall(300, 0.25e-3, 128);
  EXPECT_LT(through.lowest, -0.25e-3 - 2 * 0.5e-3);  // its centreline below the wall
}

TEST(Scene, HeldEndsConstraintsAndFluid) {
  // root and tip kinds, a driven tip on a ramp, interior constraints, drag
  // and a [fluid] with a time table and turbulence
  const Scene s = parse_scene(
      scene_text("root = \"pinned\"\n"
                 "tip = { kind = \"clamped\", motion = \"ramp\", translation = [0.0, 0.0, -0.05], rotation_axis = "
                 "[0.0, 0.0, 1.0], rotation = 720.0, duration = 2.0, profile = \"smooth\" }\n"
                 "drag = { normal = 0.5, tangential = 0.25, cd_normal = 1.2 }\n"
                 "[[rods.constraints]]\nnode = 2\nkind = \"pinned\"\n"
                 "[[rods.constraints]]\nnode = 4\nkind = \"clamped\"\nmotion = \"oscillate\"\n"
                 "translation_amplitude = [0.01, 0.0, 0.0]\nfrequency = 1.0\n"
                 "[fluid]\ndensity = 1.2\ntimes = [0.0, 1.0]\nvelocities = [[0.0, 0.0, 0.0], [2.0, 0.0, 0.0]]\n"
                 "turbulence = { intensity = 0.3, length_scale = 0.2, time_scale = 0.5, modes = 8, seed = 5 }\n"),
      "held.toml");
  ASSERT_EQ(s.rods.size(), 1u);
  const RodSpec& r = s.rods[0];
  EXPECT_TRUE(r.pinned_root && !r.clamped_root && !r.root_motion);
  EXPECT_TRUE(r.clamped_tip && r.tip_motion);
  const auto* ramp = dynamic_cast<const RampMotion*>(r.tip_motion.get());
  ASSERT_NE(ramp, nullptr);
  EXPECT_NEAR(ramp->rotation, 4 * std::numbers::pi, 1e-14);  // degrees in the file
  EXPECT_TRUE(ramp->smooth);
  ASSERT_EQ(r.holds.size(), 2u);
  EXPECT_EQ(r.holds[0].node, 2);
  EXPECT_EQ(r.holds[0].kind, HoldKind::pinned);
  EXPECT_EQ(r.holds[0].motion, nullptr);
  EXPECT_EQ(r.holds[1].kind, HoldKind::clamped);
  EXPECT_NE(r.holds[1].motion, nullptr);
  EXPECT_EQ(r.drag.normal, 0.5);
  EXPECT_EQ(r.drag.cd_normal, 1.2);
  EXPECT_TRUE(s.has_fluid);
  EXPECT_EQ(s.fluid.turbulence.modes, 8);
  EXPECT_EQ(s.fluid.mean_velocity(0.5)[0], 1.0);
  // the batch holds what the scene says: the tip turns 2 turns over 2 s
  RodBatch<double> b = build_scene_batch<double>(s);
  EXPECT_TRUE(b.any_fluid());
  EXPECT_EQ(b.driven.size(), 2u);
  advance_scene(b, step_choice(s), 1e-4, 100, {});
  EXPECT_TRUE(!find_non_finite(b).found);
  EXPECT_EQ(b.model.node_inv_mass[b.node_index(0, 0)], 0.0);
  EXPECT_EQ(b.model.node_inv_mass[b.node_index(0, 2)], 0.0);
  EXPECT_EQ(b.model.elem_inv_inertia[0][b.elem_index(0, 3)], 0.0);  // node 4's clamp holds elements 3 and 4
  EXPECT_EQ(b.model.elem_inv_inertia[0][b.elem_index(0, 4)], 0.0);
}

TEST(SceneErrors, BadConstraintsAndFluids) {
  const std::string c = "[[rods.constraints]]\n";
  expect_error(scene_text(c + "node = 6\nkind = \"pinned\"\n"),
               {"bad.toml:", "rods.0.constraints.0.node: node 6 is the tip: hold it with the group's tip key"});
  expect_error(scene_text(c + "node = 9\nkind = \"pinned\"\n"),
               {"rods.0.constraints.0.node: node 9 does not exist (the rods have nodes 0 … 6)"});
  expect_error(scene_text(c + "node = 0\nkind = \"pinned\"\n"), {"rods.0.constraints.0.node: node 0 is the root"});
  expect_error(scene_text(c + "node = 3\nkind = \"pinned\"\n" + c + "node = 3\nkind = \"clamped\"\n"),
               {"rods.0.constraints.1.node: node 3 has two constraints (one per node)"});
  expect_error(scene_text(c + "node = 3\n"), {"rods.0.constraints.0.kind: missing"});
  expect_error(scene_text(c + "node = 3\nkind = \"welded\"\n"),
               {"rods.0.constraints.0.kind: \"welded\" is not one of \"clamped\", \"pinned\""});
  expect_error(scene_text("drag = { normal = -1.0 }\n"), {"rods.0.drag.normal: must be >= 0 (got -1)"});
  expect_error(scene_text("drag = { cd_normal = 1.0 }\n"),
               {"rods.0.drag: cd_normal and cd_tangential (quadratic drag) need a [fluid] table with density > 0"});
  expect_error(scene_text("drag = { normal = 1.0 }\n[fluid]\ntimes = [0.0, 1.0]\n"),
               {"fluid.times: give times and velocities together"});
  expect_error(scene_text("[fluid]\nturbulence = { intensity = 1.0, length_scale = 0.1, time_scale = 1.0, modes = 999 }\n"),
               {"fluid.turbulence.modes: must be in [1, 256] (got 999)"});
  expect_error(scene_text("drag = { cd_normal = 1.0 }\n[fluid]\nvelocity = [1.0, 0.0, 0.0]\n"),
               {"fluid.density: missing (rods.0.drag has quadratic coefficients"});
  expect_error(scene_text("drag = { normal = 1.0 }\n", "integrator = \"pefrl\"\n"),
               {"rods.*.drag: a fluid needs integrator = \"position_verlet\""});
  expect_error(scene_text("tip = \"pinned\"\ntip_force = [0.0, 0.0, 1.0]\n"),
               {"rods.0.tip_force: acts on the tip node, which tip = \"pinned\" holds fixed"});
  expect_error(scene_text("tip = { kind = \"pinned\", motion = \"ramp\", translation = [0.0, 0.0, 1.0] }\n"),
               {"rods.0.tip.duration: missing"});
  // a stiff rod held at both ends with one end driven: accepted (its solve
  // keeps the driven tip's velocity; tests/test_constraints.cpp)
  const Scene st = parse_scene(scene_text("stiff = true\nroot = \"clamped\"\ntip = { kind = \"pinned\", motion = "
                                          "\"ramp\", translation = [0.0, 0.0, 0.01], duration = 1.0 }\n"),
                               "stiff.toml");
  EXPECT_EQ(build_scene_batch<double>(st).rods.at(0).prescribed, true);
}

TEST(Scene, ATaperedSectionScalesEachElementsStiffnessMassAndContactRadius) {
  // section = { shape = "circle", taper = { root, tip } }: the radius runs
  // linearly from root to tip along the rod; element e gets the radius at
  // its midpoint: EA × f², EI × f⁴ (a joint: its elements' mean), the
  // contact radius × f (exact: f is linear in e).
  const Scene s = parse_scene(
      "[simulation]\ndt = 1e-5\nduration = 0.01\n[[rods]]\nelements = 4\nlength = 1.0\n"
      "section = { shape = \"circle\", taper = { root = 0.02, tip = 0.01 } }\n"
      "material = { density = 1000.0, youngs_modulus = 1e6, poisson_ratio = 0.5 }\n"
      "[[colliders]]\nkind = \"plane\"\npoint = [0.0, 0.0, -1.0]\nnormal = [0.0, 0.0, 1.0]\n",
      "taper.toml");
  const RodSpec& r = s.rods[0];
  ASSERT_EQ(r.section_scale.size(), 4u);
  EXPECT_EQ(r.section.a, 0.02);
  EXPECT_EQ(s.groups[0].width, 0.04);
  const RodBatch<double> b = build_scene_batch<double>(s);
  for (int e = 0; e < 4; ++e) {
    const double f = (0.02 - 0.01 * (e + 0.5) / 4) / 0.02;
    EXPECT_NEAR(r.section_scale[std::size_t(e)], f, 1e-15);
    const int k = b.elem_index(0, e);
    EXPECT_NEAR(b.model.elem_stiffness[2][k], 1e6 * std::numbers::pi * 0.02 * 0.02 * f * f, 1e-9);
    EXPECT_NEAR(b.contact.elem_radius[k], 0.02 * f, 1e-15);
  }
  const double f0 = 0.9375, f1 = 0.8125;  // elements 0 and 1
  EXPECT_NEAR(b.model.vor_stiffness[0][b.elem_index(0, 1)],
              1e6 * std::numbers::pi * std::pow(0.02, 4) / 4 * (std::pow(f0, 4) + std::pow(f1, 4)) / 2, 1e-12);
}
