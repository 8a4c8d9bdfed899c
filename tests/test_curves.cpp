// tests/test_curves.cpp — grooms in (include/manyrods/curves.h, docs/scenes.md
// "Grooms from curves"): a helix read from USD ASCII becomes a rod whose rest
// curvature is the helix's to the discretization's order and which is
// unstressed as read; the USD export reads back as the rods it wrote; OBJ
// polylines and the HDF5 layout; cubic bases; bad curves are errors that
// name the curve.
#include <gtest/gtest.h>

#include <cmath>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <numbers>
#include <string>
#include <vector>

#include "host/core/advanced.h"
#include "manyrods/any_batch.h"
#include "manyrods/curves.h"
#include "manyrods/scene.h"
#include "manyrods/usd.h"

using namespace manyrods;
using namespace manyrods::scene;

namespace {

std::string work_dir() {
  const auto d = std::filesystem::temp_directory_path() /
                 ("manyrods-curves-" + std::to_string(::testing::UnitTest::GetInstance()->random_seed()) + "-" +
                  ::testing::UnitTest::GetInstance()->current_test_info()->name());
  std::filesystem::create_directories(d);
  return d.string() + "/";
}

std::string write(const std::string& path, const std::string& text) {
  std::ofstream(path) << text;
  return path;
}

std::string fmt(double x) {
  char b[32];
  std::snprintf(b, sizeof b, "%.17g", x);
  return b;
}

// A linear BasisCurves prim of the given curves, widths per vertex.
std::string usda(const std::vector<std::vector<Vec3>>& curves, double width, const std::string& extra = "") {
  std::string counts, points, widths;
  for (const auto& c : curves) {
    counts += (counts.empty() ? "" : ", ") + std::to_string(c.size());
    for (const Vec3& p : c) {
      points += (points.empty() ? "(" : ", (") + fmt(p[0]) + ", " + fmt(p[1]) + ", " + fmt(p[2]) + ")";
      widths += (widths.empty() ? "" : ", ") + fmt(width);
    }
  }
  return "#usda 1.0\n(\n    upAxis = \"Z\"\n)\n\ndef Xform \"groom\"\n{\n    def BasisCurves \"hair\"\n    {\n" + extra +
         "        uniform token type = \"linear\"\n        int[] curveVertexCounts = [" + counts +
         "]\n        point3f[] points = [" + points + "]\n        float[] widths = [" + widths +
         "] (\n            interpolation = \"vertex\"\n        )\n    }\n}\n";
}

std::string scene_with(const std::string& rods) {
  return "[simulation]\ndt = 1e-6\nduration = 0.001\ngravity = [0.0, 0.0, 0.0]\n[[rods]]\n"
         "material = { density = 1000.0, youngs_modulus = 1e6, poisson_ratio = 0.5 }\n" +
         rods;
}

// A helix of radius a and pitch 2πc about z, sampled finely: curvature
// κ = a/(a² + c²).
std::vector<Vec3> helix(double a, double c, double turns, int samples) {
  std::vector<Vec3> p;
  for (int i = 0; i <= samples; ++i) {
    const double t = 2 * std::numbers::pi * turns * i / samples;
    p.push_back({a * std::cos(t), a * std::sin(t), c * t});
  }
  return p;
}

TEST(Curves, HelixBecomesARodWithTheHelixRestCurvature) {
  const std::string dir = work_dir();
  const double a = 0.01, c = 0.005, kappa = a / (a * a + c * c);
  write(dir + "helix.usda", usda({helix(a, c, 2, 2000)}, 2e-3));
  const Scene s = parse_scene(scene_with("from_curves = { file = \"helix.usda\", elements = 64 }\n"), dir + "s.toml");
  ASSERT_EQ(s.rods.size(), 1u);
  // the curves file is one of the scene's inputs (no command writes over it)
  EXPECT_EQ(s.inputs, std::vector<std::string>{dir + "helix.usda"});
  const RodSpec& r = s.rods[0];
  ASSERT_EQ(r.elements(), 64);
  EXPECT_NEAR(r.section.a, 1e-3, 1e-15);  // widths are diameters (the mean of 2001 of them)
  EXPECT_TRUE(r.clamped_root);          // the first point clamped, as the group's root says
  // The rod's node spacing h is equal arc length; the rest curvature at a
  // node from the frames' turning angle φ = κh over the Voronoi length (the
  // chord 2 sin(κh/2)/κ) is κ (κh/2)/sin(κh/2): relative error (κh)²/24 on a
  // circle. Allow (κh)²/4 for the helix's torsion and the fine polyline.
  const double h = 2 * 2 * std::numbers::pi * std::hypot(a, c) / 64;
  const RodBatch<double> b = build_scene_batch<double>(s);
  for (int j = 0; j + 1 < 64; ++j) {
    SCOPED_TRACE("voronoi " + std::to_string(j));
    const int k = b.vor_index(0, j);
    const double k1 = b.model.vor_rest_curvature[0][k], k2 = b.model.vor_rest_curvature[1][k],
                 k3 = b.model.vor_rest_curvature[2][k];
    EXPECT_NEAR(std::hypot(k1, k2), kappa, kappa * (kappa * h) * (kappa * h) / 4);
    // parallel-transport frames do not twist: no rest twist
    EXPECT_NEAR(k3, 0.0, 1e-9 * kappa);
  }
  // unstressed as read: the elastic energy is round-off of the helix's bending energy
  const Energies e = energies(b);
  const double EI = 1e6 * std::numbers::pi * std::pow(1e-3, 4) / 4, L = 64 * h;
  EXPECT_LT(e.elastic, 1e-12 * 0.5 * EI * kappa * kappa * L);
}

TEST(Curves, TheUsdExportReadsBackAsTheRodsItWrote) {
  const std::string dir = work_dir();
  const std::string text =
      "[simulation]\ndt = \"auto\"\nduration = 0.01\ngravity = [0.0, 0.0, -9.81]\n"
      "[[rods]]\nname = \"hair\"\ncount = 3\nelements = 12\nlength = 0.1\nrest_curvature = [20.0, 0.0, 5.0]\n"
      "placement = { kind = \"grid\", columns = 3, spacing = [0.01, 0.01] }\n"
      "section = { shape = \"circle\", radius = 1e-4 }\nstiff = true\n"
      "damping = { tau_shear = 1e-3, tau_extension = 1e-3 }\n"
      "material = { density = 1300.0, youngs_modulus = 3.9e9, poisson_ratio = 0.3 }\n";
  AnyBatch src = AnyBatch::from_scene(parse_scene(text, dir + "src.toml"));
  src.step(src.scene_dt(), 20);  // bent a little by gravity: not the built shape
  src.save(dir + "src.h5");
  manyrods::usd::export_usd(dir + "src.h5", dir + "groom.usda");
  const std::vector<Curve> curves = read_curves(dir + "groom.usda");
  ASSERT_EQ(curves.size(), 3u);
  const RodBatch<double>& sb = src.f64();
  for (int r = 0; r < 3; ++r) {
    ASSERT_EQ(curves[std::size_t(r)].points.size(), 13u);
    EXPECT_DOUBLE_EQ(curves[std::size_t(r)].width, 2e-4);
    for (int i = 0; i <= 12; ++i)
      for (int d = 0; d < 3; ++d) {  // point3f: the export rounds to float, half an ulp 2^-24 |x|
        const double x = sb.state.node_x[d][src.node_slot(r, i)];
        EXPECT_NEAR(curves[std::size_t(r)].points[std::size_t(i)][d], x, std::ldexp(std::abs(x), -24) * 1.01)
            << "rod " << r << " node " << i;
      }
  }
  // and a scene grows the groom from it: one rod per curve, points kept, radius from the widths
  const Scene s = parse_scene(
      scene_with("from_curves = { file = \"groom.usda\" }\nstiff = true\ndamping = { tau_shear = 1e-3, tau_extension = 1e-3 }\n"),
      dir + "grown.toml");
  ASSERT_EQ(s.rods.size(), 3u);
  for (int r = 0; r < 3; ++r) {
    EXPECT_EQ(s.rods[std::size_t(r)].elements(), 12);
    EXPECT_DOUBLE_EQ(s.rods[std::size_t(r)].section.a, 1e-4);
    EXPECT_TRUE(s.rods[std::size_t(r)].stiff_implicit);
    EXPECT_EQ(s.rods[std::size_t(r)].nodes[5], curves[std::size_t(r)].points[5]);
  }
  AnyBatch grown = AnyBatch::from_scene(s);
  grown.step(1e-6, 10);
  EXPECT_TRUE(std::isfinite(grown.energies().total()));
}

TEST(Curves, ObjPolylinesAndTheHdf5Layout) {
  const std::string dir = work_dir();
  write(dir + "lines.obj",
        "# two guide hairs\no guides\nv 0 0 0\nv 0 0 0.01\nv 0.001 0 0.02\nv 0.01 0 0\nv 0.01 0 0.01\nv 0.01 0.001 0.02\n"
        "v 0.01 0.002 0.03\nl 1 2 3\nl 4 5 6 7\n");
  const std::vector<Curve> c = read_curves(dir + "lines.obj");
  ASSERT_EQ(c.size(), 2u);
  EXPECT_EQ(c[1].points.size(), 4u);
  EXPECT_NEAR(c[1].points[3][1], 0.002, 1e-9);
  EXPECT_LT(c[0].width, 0);  // OBJ has no widths: the group's section is needed
  EXPECT_NE(c[1].label.find("line 1"), std::string::npos);
  try {
    (void)parse_scene(scene_with("from_curves = { file = \"lines.obj\", elements = 4 }\n"), dir + "s.toml");
    FAIL() << "no section and no widths";
  } catch (const SceneError& e) {
    EXPECT_NE(std::string(e.what()).find("give the group a section"), std::string::npos) << e.what();
  }
  const Scene s = parse_scene(
      scene_with("from_curves = { file = \"lines.obj\", elements = 4, scale = 10.0 }\n"
                 "section = { shape = \"circle\", radius = 1e-4 }\n"),
      dir + "s.toml");
  ASSERT_EQ(s.rods.size(), 2u);
  EXPECT_EQ(s.rods[1].elements(), 4);
  EXPECT_NEAR(s.rods[1].nodes[4][2], 0.3, 1e-7);  // scaled ×10
  EXPECT_DOUBLE_EQ(s.rods[1].section.a, 1e-4);

  // HDF5: what write_h5_curves writes reads back exactly
  std::vector<Curve> w = c;
  w[0].width = 1e-4;
  w[1].width = 2e-4;
  write_h5_curves(dir + "curves.h5", w);
  const std::vector<Curve> back = read_curves(dir + "curves.h5");
  ASSERT_EQ(back.size(), 2u);
  for (std::size_t i = 0; i < 2; ++i) {
    EXPECT_EQ(back[i].points, w[i].points);
    EXPECT_EQ(back[i].width, w[i].width);
  }
}

TEST(Curves, CubicBasesAreEvaluated) {
  const std::string dir = work_dir();
  // catmullRom through points on a circle passes through the inner control points
  std::vector<Vec3> cv;
  for (int i = 0; i < 8; ++i) cv.push_back({0.05 * std::cos(0.4 * i), 0.05 * std::sin(0.4 * i), 0.0});
  std::string text = usda({cv}, 1e-3);
  text.replace(text.find("uniform token type = \"linear\""), 29,
               "uniform token type = \"cubic\"\n        uniform token basis = \"catmullRom\"");
  write(dir + "cr.usda", text);
  const std::vector<Curve> c = read_curves(dir + "cr.usda");
  ASSERT_EQ(c.size(), 1u);
  EXPECT_TRUE(c[0].evaluated);
  ASSERT_EQ(c[0].points.size(), 5u * 16 + 1);  // 8 points, nonperiodic: 5 segments
  for (int g = 0; g <= 5; ++g)
    for (int d = 0; d < 3; ++d) EXPECT_NEAR(c[0].points[std::size_t(16 * g)][d], cv[std::size_t(g + 1)][d], 1e-15);
  // points sampled on the spline lie near the circle: Catmull–Rom's error on a
  // circle of 0.4 rad steps is O(θ⁴) of the radius
  for (const Vec3& p : c[0].points) EXPECT_NEAR(std::hypot(p[0], p[1]), 0.05, 0.05 * std::pow(0.4, 4));
  // a cubic curve must be resampled
  try {
    (void)parse_scene(scene_with("from_curves = { file = \"cr.usda\" }\n"), dir + "s.toml");
    FAIL();
  } catch (const SceneError& e) {
    EXPECT_NE(std::string(e.what()).find("give `elements`"), std::string::npos) << e.what();
  }
  // the USD fallback basis is bezier: 8 points is not 3k + 1
  text = usda({cv}, 1e-3);
  text.replace(text.find("uniform token type = \"linear\""), 29, "");
  write(dir + "bz.usda", text);
  try {
    (void)read_curves(dir + "bz.usda");
    FAIL();
  } catch (const InputError& e) {
    EXPECT_NE(std::string(e.what()).find("3k + 1"), std::string::npos) << e.what();
  }
}

TEST(Curves, BadCurvesAreErrorsThatNameTheCurve) {
  const std::string dir = work_dir();
  const std::vector<Vec3> good = {{0, 0, 0}, {0, 0, 0.01}, {0, 0, 0.02}};
  auto error_of = [&](const std::string& file_text, const std::string& ext = ".usda") {
    write(dir + "bad" + ext, file_text);
    try {
      (void)parse_scene(scene_with("from_curves = { file = \"bad" + ext + "\", elements = 4 }\n"), dir + "s.toml");
    } catch (const SceneError& e) {
      return std::string(e.what());
    }
    return std::string("no error");
  };
  auto has = [](const std::string& msg, const std::string& part) {
    return msg.find(part) != std::string::npos ? ::testing::AssertionSuccess()
                                               : ::testing::AssertionFailure() << "'" << part << "' not in: " << msg;
  };
  std::string m = error_of(usda({good, {{0.1, 0, 0}}}, 1e-3));
  EXPECT_TRUE(has(m, "s.toml:5: rods.0 rod 1: ")) << "the group's line, the group and the rod";
  EXPECT_TRUE(has(m, "BasisCurves \"hair\" curve 1"));
  EXPECT_TRUE(has(m, "1 point(s); a rod needs at least 2"));
  m = error_of(usda({good, {{0.1, 0, 0}, {0.1, 0, 0.01}, {0.1, 0, 0.01}, {0.1, 0, 0.02}}}, 1e-3));
  EXPECT_TRUE(has(m, "curve 1"));
  EXPECT_TRUE(has(m, "points 1 and 2 coincide"));
  std::string t = usda({good, good}, 1e-3);
  t.replace(t.find("(0, 0, 0.01)"), 12, "(0, nan, 0.01)");
  m = error_of(t);
  EXPECT_TRUE(has(m, "curve 0"));
  EXPECT_TRUE(has(m, "point 1 is not finite"));
  t = usda({good}, 1e-3);
  t.replace(t.find("float[] widths = [") + 18, 0, "1, ");
  EXPECT_TRUE(has(error_of(t), "widths: 4 values for 1 curves of 3 points"));
  t = usda({good}, 1e-3, "        uniform token wrap = \"periodic\"\n");
  EXPECT_TRUE(has(error_of(t), "periodic (closed) curves are not rods"));
  t = usda({good}, 1e-3);
  t.replace(t.find("curveVertexCounts = [3]"), 23, "curveVertexCounts = [4]");
  EXPECT_TRUE(has(error_of(t), "add up to 4 points, points has 3"));
  EXPECT_TRUE(has(error_of("#usda 1.0\ndef Xform \"x\"\n{\n}\n"), "no BasisCurves prim"));
  EXPECT_TRUE(has(error_of("PXR-USDC binary", ".usdc"), "binary USD is read through OpenUSD: from Python with usd-core installed"));
  EXPECT_TRUE(has(error_of("v 0 0 0\n", ".obj"), "no polylines"));
  EXPECT_TRUE(has(error_of("not hdf5", ".h5"), "not an HDF5 file"));
  m = error_of(usda({good}, 1e-3));
  EXPECT_EQ(m, "no error");
  // placement keys do not go with from_curves
  try {
    (void)parse_scene(scene_with("count = 3\nfrom_curves = { file = \"bad.usda\" }\n"), dir + "s.toml");
    FAIL();
  } catch (const SceneError& e) {
    EXPECT_TRUE(has(e.what(), "rods.0.count"));
    EXPECT_TRUE(has(e.what(), "does not go with from_curves"));
  }
  try {
    (void)parse_scene(scene_with("from_curves = { file = \"missing.usda\" }\n"), dir + "s.toml");
    FAIL();
  } catch (const SceneError& e) {
    EXPECT_TRUE(has(e.what(), "missing.usda: cannot read the curve file"));
  }
}

}  // namespace

TEST(Curves, APreloadedGroomFromCurvesStaysWhereItWasModelledAndOneWithoutSags) {
  // docs/validation.md "1f Gravity preload". A groom modelled in a curl:
  // 32 curly human hairs (10 cm, r = 40 µm, E = 3.9 GPa, stiff, damped),
  // rooted on the lower half of a head and pointing away from it, written
  // as curves and grown back with from_curves, so that the shape as read
  // is the rest shape. Stepped 1 s at 1/2000 s under gravity with the
  // head as a collider. With preload = true the groom as modelled is its
  // equilibrium and stays: asserted drift below 1e-3 L (the requirement;
  // measured ~1e-12 L, the step's round-off). Without, the strands sag
  // and swing: asserted above 0.05 L (measured ~1 L). (20 cm hairs held up
  // on the top of a head are beyond their buckling load under their own
  // weight: preloaded, they are in an unstable equilibrium and fall away;
  // docs/model.md "Gravity preload".)
  const std::string dir = work_dir();
  const std::string common =
      "[simulation]\ndt = 5e-4\nduration = 1.0\nintegrator = \"position_verlet\"\nprecision = \"double\"\n"
      "output_interval = 0.1\ngravity = [0.0, 0.0, -9.81]\n"
      "[[colliders]]\nname = \"head\"\nkind = \"sphere\"\ncenter = [0.0, 0.0, 0.0]\nradius = 0.0895\n"
      "friction = { static = 0.4, kinetic = 0.3 }\n"
      "[[rods]]\nname = \"hair\"\nroot = \"clamped\"\nstiff = true\nsection = { shape = \"circle\", radius = 40e-6 }\n"
      "material = { density = 1300.0, youngs_modulus = 3.9e9, poisson_ratio = 0.3 }\n"
      "damping = { tau_shear = 1e-3, tau_extension = 1e-3 }\n";
  const Scene modelled = parse_scene(
      common + "count = 32\nelements = 32\nlength = 0.1\nrest_curvature = [15.0, 0.0, 5.0]\n"
               "placement = { kind = \"sphere\", center = [0.0, 0.0, 0.0], radius = 0.09, cap_angle = 60.0, "
               "axis = [0.0, 0.0, -1.0], seed = 1 }\n",
      dir + "modelled.toml");
  const AnyBatch m = AnyBatch::from_scene(modelled);
  std::vector<Curve> curves(32);
  for (int r = 0; r < 32; ++r)
    for (int j = 0; j <= 32; ++j) curves[std::size_t(r)].points.push_back(m.f64().position(r, j));
  write_h5_curves(dir + "groom.h5", curves);
  auto drift = [&](bool preload) {
    const Scene s = parse_scene(common + "from_curves = { file = \"groom.h5\" }\n" + (preload ? "preload = true\n" : ""),
                                dir + "grown.toml");
    AnyBatch a = AnyBatch::from_scene(s);
    a.step(5e-4, 2000);
    double worst = 0;
    for (int r = 0; r < 32; ++r)
      for (int j = 0; j <= 32; ++j) {
        const Vec3 x = a.f64().position(r, j), x0 = curves[std::size_t(r)].points[std::size_t(j)];
        worst = std::max(worst, std::hypot(x[0] - x0[0], x[1] - x0[1], x[2] - x0[2]));
      }
    return worst / 0.1;
  };
  const double with = drift(true), without = drift(false);
  std::printf("groom from curves over 1 s: drift %.3e L preloaded, %.3e L not\n", with, without);
  EXPECT_LT(with, 1e-3);
  EXPECT_GT(without, 0.05);
}

TEST(Curves, WidthsPerPointTaperTheStrand) {
  // A strand whose widths fall linearly from 2e-4 m at the root to 1e-4 m
  // at the tip, per vertex, in USD and in the HDF5 layout: the rod's
  // section is the mean width's circle, scaled per element by its mean
  // width over that (RodSpec::section_scale); resampled, the widths follow
  // the arc length. Exact for a linear taper (to round-off).
  const std::string dir = work_dir();
  std::vector<Vec3> line;
  std::vector<double> w;
  for (int i = 0; i <= 10; ++i) line.push_back({0, 0, 0.01 * i}), w.push_back(2e-4 - 1e-5 * i);
  std::string points, widths;
  for (int i = 0; i <= 10; ++i) {
    points += (i ? ", (" : "(") + fmt(line[std::size_t(i)][0]) + ", " + fmt(line[std::size_t(i)][1]) + ", " +
              fmt(line[std::size_t(i)][2]) + ")";
    widths += (i ? ", " : "") + fmt(w[std::size_t(i)]);
  }
  write(dir + "taper.usda", "#usda 1.0\ndef BasisCurves \"hair\"\n{\n    uniform token type = \"linear\"\n"
                            "    int[] curveVertexCounts = [11]\n    point3f[] points = [" + points +
                            "]\n    float[] widths = [" + widths + "] (\n        interpolation = \"vertex\"\n    )\n}\n");
  Curve h;
  h.points = line;
  h.point_widths = w;
  h.width = 1.5e-4;
  write_h5_curves(dir + "taper.h5", {h});
  for (const std::string file : {"taper.usda", "taper.h5"}) {
    SCOPED_TRACE(file);
    const std::vector<Curve> c = read_curves(dir + file);
    ASSERT_EQ(c.size(), 1u);
    ASSERT_EQ(c[0].point_widths.size(), 11u);
    EXPECT_NEAR(c[0].width, 1.5e-4, 1e-12);
    for (const int elements : {0, 5}) {
      const RodSpec r = rod_from_curve(c[0], elements);
      const int n = r.elements();
      ASSERT_EQ(int(r.section_scale.size()), n);
      EXPECT_NEAR(r.section.a, 0.75e-4, 1e-12);  // (float widths in USD: 1e-12 m is their rounding, and more)
      for (int e = 0; e < n; ++e)  // the width at the element's midpoint over the mean
        EXPECT_NEAR(r.section_scale[std::size_t(e)] * 1.5e-4, 2e-4 - 1e-4 * (e + 0.5) / n, 1e-11) << e;
    }
  }
  // a group's own section makes it uniform again; its taper key tapers it along the curve
  const Scene own = parse_scene(scene_with("from_curves = { file = \"taper.h5\" }\nsection = { shape = \"circle\", "
                                           "radius = 1e-4 }\n"),
                                dir + "own.toml");
  EXPECT_TRUE(own.rods[0].section_scale.empty());
  const Scene tapered = parse_scene(
      scene_with("from_curves = { file = \"taper.h5\" }\nsection = { shape = \"circle\", taper = { root = 3e-4, tip = 1e-4 } }\n"),
      dir + "tapered.toml");
  ASSERT_EQ(tapered.rods[0].section_scale.size(), 10u);
  EXPECT_EQ(tapered.rods[0].section.a, 3e-4);
  EXPECT_NEAR(tapered.rods[0].section_scale[9], (3e-4 - 2e-4 * 0.95) / 3e-4, 1e-14);
}
