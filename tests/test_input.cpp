// tests/test_input.cpp — bad input is rejected at the boundary with an
// InputError whose message names the rod (index and name) and the field.
//
// Each case corrupts one field of a rod placed at index 2 (named "hair") of a
// four-rod vector whose other rods are valid, so the rod index in the
// message is checked. build_batch throws before it returns anything, so no
// half-built batch can escape; the tests check the exception only.
#include <gtest/gtest.h>

#include <cmath>
#include <functional>
#include <limits>
#include <string>
#include <vector>

#include "cases.h"
#include "host/core/advanced.h"

using namespace manyrods;

namespace {

constexpr double kNaN = std::numeric_limits<double>::quiet_NaN();
constexpr double kInf = std::numeric_limits<double>::infinity();
constexpr int kN = 6;  // elements of every test rod

RodSpec good(const std::string& name) {
  RodSpec s = cases::seed_cantilever(kN, Damping::shear_extension(0.01, 0.02));
  s.name = name;
  return s;
}

// Runs f, expects an InputError whose message contains every needle.
template <class F>
void expect_input_error(F&& f, const std::vector<std::string>& needles, const std::string& label) {
  SCOPED_TRACE(label);
  try {
    f();
    ADD_FAILURE() << "no InputError for: " << label;
  } catch (const InputError& e) {
    const std::string w = e.what();
    for (const std::string& n : needles)
      EXPECT_NE(w.find(n), std::string::npos) << "message lacks \"" << n << "\": " << w;
  } catch (const std::exception& e) {
    ADD_FAILURE() << "wrong exception type for " << label << ": " << e.what();
  }
}

// The corrupted rod at index 2 of four; both precisions must reject it.
void expect_rod_rejected(const std::function<void(RodSpec&)>& corrupt, std::vector<std::string> fields,
                         const std::string& label) {
  RodSpec bad = good("hair");
  corrupt(bad);
  std::vector<RodSpec> rods = {good("root"), good("middle"), bad, good("after")};
  fields.push_back("rod 2 ('hair')");
  expect_input_error([&] { (void)build_batch<double>(rods); }, fields, label + " [double]");
  expect_input_error([&] { (void)build_batch<float>(rods); }, fields, label + " [float]");
}

Mat3 identity() { return {1, 0, 0, 0, 1, 0, 0, 0, 1}; }

}  // namespace

TEST(Input, ValidRodsBuild) {
  std::vector<RodSpec> rods = {good("root"), good("middle"), good("hair"), good("after")};
  EXPECT_NO_THROW((void)build_batch<double>(rods));
  EXPECT_NO_THROW((void)build_batch<float>(rods));
  // Boundary values that are valid.
  auto ok = [](const std::function<void(RodSpec&)>& f, const std::string& label) {
    RodSpec s = good("edge");
    f(s);
    EXPECT_NO_THROW((void)build_batch<double>({good("root"), s})) << label;
  };
  ok([](RodSpec& s) { s.material.poisson_ratio = 0.5; s.damping = Damping::shear_bulk(0.01, 0.02); }, "nu = 1/2");
  ok([](RodSpec& s) { s.material.poisson_ratio = -0.99; }, "nu = -0.99");
  ok([](RodSpec& s) { s.material.poisson_ratio = 0; }, "nu = 0");
  ok([](RodSpec& s) { s.section = Section::hollow_circle(0.01, 0); }, "hollow, inner radius 0");
  ok([](RodSpec& s) { s.damping = Damping::shear_bulk(0, 0); }, "zero damping");
  ok([](RodSpec& s) { s.damping = Damping::viscosities(0, 0); }, "zero viscosities");
  ok([](RodSpec& s) {
       s.material.poisson_ratio = kNaN;
       s.material.shear_modulus = s.material.youngs_modulus / 3;  // nu = 1/2
       s.damping = Damping::viscosities(100, 100);
     },
     "G = E/3");
  ok([](RodSpec& s) { s.frames[1][0] += 1e-9; }, "frame off by 1e-9 (tolerance 1e-6)");
  ok([](RodSpec& s) {
       s.nodes.resize(2);
       s.frames.resize(1);
     },
     "one element");
}

TEST(Input, Material) {
  for (double v : {0.0, -1.0, kNaN, kInf, -kInf}) {
    expect_rod_rejected([v](RodSpec& s) { s.material.youngs_modulus = v; }, {"material.youngs_modulus"},
                        "E = " + std::to_string(v));
    expect_rod_rejected([v](RodSpec& s) { s.material.density = v; }, {"material.density"},
                        "density = " + std::to_string(v));
  }
  for (double nu : {-1.0, -1.5, 0.6, 0.5000001, kInf, -kInf})
    expect_rod_rejected([nu](RodSpec& s) { s.material.poisson_ratio = nu; }, {"material.poisson_ratio"},
                        "nu = " + std::to_string(nu));
  // NaN is "not given" for poisson_ratio; with no shear modulus either, the
  // message names both.
  expect_rod_rejected([](RodSpec& s) { s.material.poisson_ratio = kNaN; }, {"poisson_ratio", "shear_modulus"},
                      "nu = NaN, no G");
  expect_rod_rejected([](RodSpec& s) { s.material.shear_modulus = 3e5; }, {"poisson_ratio", "shear_modulus"},
                      "both nu and G");
  // G < E/3 implies nu > 1/2; G ≤ 0 or not finite is invalid.
  for (double g_over_e : {0.25, 0.3, 0.0, -0.4, kInf}) {
    expect_rod_rejected(
        [g_over_e](RodSpec& s) {
          s.material.poisson_ratio = kNaN;
          s.material.shear_modulus = g_over_e * s.material.youngs_modulus;
        },
        {"material.shear_modulus"}, "G/E = " + std::to_string(g_over_e));
  }
}

TEST(Input, Section) {
  for (double v : {0.0, -0.01, kNaN, kInf}) {
    const std::string tag = " = " + std::to_string(v);
    expect_rod_rejected([v](RodSpec& s) { s.section = Section::circle(v); }, {"section.radius"}, "radius" + tag);
    expect_rod_rejected([v](RodSpec& s) { s.section = Section::ellipse(v, 0.01); }, {"section.semi_axes[0]"},
                        "semi axis 1" + tag);
    expect_rod_rejected([v](RodSpec& s) { s.section = Section::ellipse(0.01, v); }, {"section.semi_axes[1]"},
                        "semi axis 2" + tag);
    expect_rod_rejected([v](RodSpec& s) { s.section = Section::rectangle(v, 0.01); }, {"section.width"},
                        "width" + tag);
    expect_rod_rejected([v](RodSpec& s) { s.section = Section::rectangle(0.01, v); }, {"section.height"},
                        "height" + tag);
    expect_rod_rejected([v](RodSpec& s) { s.section = Section::hollow_circle(v, 0.001); },
                        {"section.outer_radius"}, "outer radius" + tag);
  }
  for (double v : {-0.001, kNaN, kInf, 0.01, 0.02})  // negative, not finite, ≥ outer radius 0.01
    expect_rod_rejected([v](RodSpec& s) { s.section = Section::hollow_circle(0.01, v); },
                        {"section.inner_radius"}, "inner radius = " + std::to_string(v));
  expect_rod_rejected([](RodSpec& s) { s.section.shape = static_cast<Shape>(17); }, {"section.shape"},
                      "unknown shape");
  // Cowper's ellipse formula out of (0, 1] (flat ellipse, ν < 0).
  expect_rod_rejected(
      [](RodSpec& s) {
        s.section = Section::ellipse(0.001, 0.01);
        s.material.poisson_ratio = -0.5;
      },
      {"section", "shear"}, "auxetic flat ellipse");
}

TEST(Input, Damping) {
  struct Form {
    std::string field;
    std::function<Damping(double)> make;
  };
  const std::vector<Form> forms = {
      {"damping.tau_shear", [](double v) { return Damping::shear_bulk(v, 0.01); }},
      {"damping.tau_bulk", [](double v) { return Damping::shear_bulk(0.01, v); }},
      {"damping.tau_shear", [](double v) { return Damping::shear_extension(v, 0.05); }},
      {"damping.tau_extension", [](double v) { return Damping::shear_extension(0.01, v); }},
      {"damping.shear_viscosity", [](double v) { return Damping::viscosities(v, 10.0); }},
      {"damping.bulk_viscosity", [](double v) { return Damping::viscosities(10.0, v); }},
  };
  for (const Form& f : forms)
    for (double v : {-1e-3, -kInf, kNaN, kInf})
      expect_rod_rejected([&](RodSpec& s) { s.damping = f.make(v); }, {f.field},
                          f.field + " = " + std::to_string(v));
  // τE < 2(1+ν)τS/3: negative bulk viscosity.
  expect_rod_rejected([](RodSpec& s) { s.damping = Damping::shear_extension(0.1, 0.05); },
                      {"damping.tau_extension", "negative bulk"}, "negative bulk");
  // ν = 1/2 with τE ≠ τS.
  expect_rod_rejected(
      [](RodSpec& s) {
        s.material.poisson_ratio = 0.5;
        s.damping = Damping::shear_extension(0.01, 0.02);
      },
      {"damping.tau_extension"}, "nu = 1/2, tau_E != tau_S");
  expect_rod_rejected([](RodSpec& s) { s.damping.form = static_cast<Damping::Form>(9); }, {"damping"},
                      "unknown form");
}

TEST(Input, Geometry) {
  // Zero elements.
  expect_rod_rejected(
      [](RodSpec& s) {
        s.nodes.resize(1);
        s.frames.clear();
      },
      {"elements"}, "zero elements");
  // Non-finite node coordinates.
  for (double v : {kNaN, kInf, -kInf})
    expect_rod_rejected([v](RodSpec& s) { s.nodes[3][1] = v; }, {"nodes[3]"}, "nodes[3] = " + std::to_string(v));
  // Coincident nodes: element 2 has zero length.
  expect_rod_rejected([](RodSpec& s) { s.nodes[3] = s.nodes[2]; }, {"nodes[3]", "nodes[2]", "zero length"},
                      "coincident nodes");
  // Sizes.
  expect_rod_rejected([](RodSpec& s) { s.nodes.push_back({0, 0, 1}); }, {"nodes"}, "n + 2 nodes");
  expect_rod_rejected([](RodSpec& s) { s.nodes.pop_back(); }, {"nodes"}, "n nodes");
  expect_rod_rejected([](RodSpec& s) { s.rest_curvature.assign(kN, Vec3{0, 0, 0}); }, {"rest_curvature"},
                      "rest_curvature [n]");
  expect_rod_rejected([](RodSpec& s) { s.rest_strain.assign(kN + 1, Vec3{0, 0, 1}); }, {"rest_strain"},
                      "rest_strain [n+1]");
  expect_rod_rejected([](RodSpec& s) { s.velocities.assign(kN, Vec3{0, 0, 0}); }, {"velocities"},
                      "velocities [n]");
  expect_rod_rejected([](RodSpec& s) { s.angular_velocities.assign(kN + 1, Vec3{0, 0, 0}); },
                      {"angular_velocities"}, "angular_velocities [n+1]");
  // Non-finite rest shape and initial motion.
  for (double v : {kNaN, kInf}) {
    const std::string tag = " = " + std::to_string(v);
    expect_rod_rejected(
        [v](RodSpec& s) {
          s.rest_curvature.assign(kN - 1, Vec3{0, 0, 0});
          s.rest_curvature[4][0] = v;
        },
        {"rest_curvature[4]"}, "rest_curvature" + tag);
    expect_rod_rejected(
        [v](RodSpec& s) {
          s.rest_strain.assign(kN, Vec3{0, 0, 1});
          s.rest_strain[1][2] = v;
        },
        {"rest_strain[1]"}, "rest_strain" + tag);
    expect_rod_rejected(
        [v](RodSpec& s) {
          s.velocities.assign(kN + 1, Vec3{0, 0, 0});
          s.velocities[5][2] = v;
        },
        {"velocities[5]"}, "velocities" + tag);
    expect_rod_rejected(
        [v](RodSpec& s) {
          s.angular_velocities.assign(kN, Vec3{0, 0, 0});
          s.angular_velocities[2][1] = v;
        },
        {"angular_velocities[2]"}, "angular_velocities" + tag);
    expect_rod_rejected([v](RodSpec& s) { s.frames[2][4] = v; }, {"frames[2]"}, "frames" + tag);
    expect_rod_rejected(
        [v](RodSpec& s) {
          s.root_frame = identity();
          (*s.root_frame)[8] = v;
        },
        {"root_frame"}, "root_frame" + tag);
  }
  // shear_stretch_scale must be finite and > 0.
  for (double v : {0.0, -1.0, kNaN, kInf})
    expect_rod_rejected([v](RodSpec& s) { s.shear_stretch_scale = v; }, {"shear_stretch_scale"},
                        "shear_stretch_scale = " + std::to_string(v));
}

TEST(Input, Frames) {
  // Not orthonormal: d1 stretched by 1 %, or d1 tilted towards d3.
  expect_rod_rejected([](RodSpec& s) { s.frames[1][0] = 1.01; }, {"frames[1]", "orthonormal"}, "stretched d1");
  expect_rod_rejected([](RodSpec& s) { s.frames[4][2] = 0.1; }, {"frames[4]", "orthonormal"}, "skewed d1");
  expect_rod_rejected([](RodSpec& s) { s.frames[0] = Mat3{0, 0, 0, 0, 0, 0, 0, 0, 0}; },
                      {"frames[0]", "orthonormal"}, "zero frame");
  // Left-handed: d1 and d2 swapped (orthonormal, det = −1).
  expect_rod_rejected([](RodSpec& s) { s.frames[3] = Mat3{0, 1, 0, 1, 0, 0, 0, 0, 1}; },
                      {"frames[3]", "left-handed"}, "left-handed frame");
  expect_rod_rejected([](RodSpec& s) { s.root_frame = Mat3{0, 1, 0, 1, 0, 0, 0, 0, 1}; },
                      {"root_frame", "left-handed"}, "left-handed root frame");
  expect_rod_rejected([](RodSpec& s) { s.root_frame = Mat3{2, 0, 0, 0, 1, 0, 0, 0, 1}; },
                      {"root_frame", "orthonormal"}, "non-orthonormal root frame");
}

// RodSpec::straight validates its arguments (there is no rod index or name
// yet, so the message names the argument).
TEST(Input, StraightFactory) {
  const Vec3 o{0, 0, 0}, z{0, 0, 1}, x{1, 0, 0};
  for (double L : {0.0, -0.3, kNaN, kInf})
    expect_input_error([&] { (void)RodSpec::straight(o, z, x, L, 10); }, {"length"}, "length " + std::to_string(L));
  for (int n : {0, -3})
    expect_input_error([&] { (void)RodSpec::straight(o, z, x, 0.3, n); }, {"elements"},
                       "elements " + std::to_string(n));
  for (double v : {kNaN, kInf}) {
    expect_input_error([&] { (void)RodSpec::straight({0, v, 0}, z, x, 0.3, 10); }, {"start"}, "start");
    expect_input_error([&] { (void)RodSpec::straight(o, {0, v, 1}, x, 0.3, 10); }, {"direction"}, "direction");
    expect_input_error([&] { (void)RodSpec::straight(o, z, {v, 0, 0}, 0.3, 10); }, {"normal"}, "normal");
  }
  expect_input_error([&] { (void)RodSpec::straight(o, {0, 0, 0}, x, 0.3, 10); }, {"direction"}, "zero direction");
  expect_input_error([&] { (void)RodSpec::straight(o, z, {0, 0, 2}, 0.3, 10); }, {"normal", "parallel"},
                     "normal parallel to direction");
}

// Gravity (batch-wide) and the per-rod load setters.
TEST(Input, GravityAndLoads) {
  const std::vector<RodSpec> rods = {good("root"), good("middle"), good("hair")};
  for (double v : {kNaN, kInf})
    expect_input_error([&] { (void)build_batch<double>(rods, {0, v, 0}); }, {"gravity"}, "gravity");

  RodBatch<double> b = build_batch<double>(rods);
  EXPECT_NO_THROW(b.set_node_force(2, 3, {0, 1, 0}));
  EXPECT_NO_THROW(b.set_element_couple(2, 3, {0, 1, 0}));
  for (double v : {kNaN, kInf}) {
    expect_input_error([&] { b.set_node_force(2, 3, {0, v, 0}); }, {"rod 2 ('hair')", "node_force[3]"},
                       "node force");
    expect_input_error([&] { b.set_element_couple(2, 4, {v, 0, 0}); }, {"rod 2 ('hair')", "element_couple[4]"},
                       "element couple");
    expect_input_error([&] { b.set_gravity({v, 0, 0}); }, {"gravity"}, "set_gravity");
  }
  for (double v : {kNaN, kInf}) {
    expect_input_error([&] { b.set_velocity(1, 2, {0, 0, v}); }, {"rod 1 ('middle')", "velocity[2]"}, "velocity");
    expect_input_error([&] { b.set_angular_velocity(1, 5, {0, v, 0}); },
                       {"rod 1 ('middle')", "angular_velocity[5]"}, "angular velocity");
  }
  // Out-of-range indices are rejected rather than writing past the rod.
  expect_input_error([&] { b.set_velocity(0, -1, {0, 1, 0}); }, {"rod 0 ('root')", "velocity[-1]"}, "node -1");
  expect_input_error([&] { b.set_angular_velocity(0, kN, {0, 1, 0}); }, {"rod 0 ('root')", "angular_velocity[6]"},
                     "element n");
  expect_input_error([&] { b.set_node_force(3, 0, {0, 1, 0}); }, {"node_force", "rod 3"}, "rod index 3 of 3");
  expect_input_error([&] { b.set_node_force(-1, 0, {0, 1, 0}); }, {"node_force", "rod -1"}, "rod index -1");
  expect_input_error([&] { b.set_node_force(2, kN + 1, {0, 1, 0}); }, {"rod 2 ('hair')", "node_force[7]"},
                     "node n+1");
  expect_input_error([&] { b.set_element_couple(2, kN, {0, 1, 0}); }, {"rod 2 ('hair')", "element_couple[6]"},
                     "element n");
  // The rejected calls wrote nothing.
  for (int r = 0; r < 3; ++r)
    for (int j = 0; j <= kN; ++j)
      for (int d = 0; d < 3; ++d) {
        const double want = (r == 2 && j == 3 && d == 1) ? 1.0 : 0.0;
        EXPECT_EQ(b.loads.node_force[d][b.node_index(r, j)], want) << r << " " << j << " " << d;
        EXPECT_EQ(b.state.node_v[d][b.node_index(r, j)], 0.0) << r << " " << j << " " << d;
      }
}
