// tests/test_isa.cpp — the builds of the step for several instruction sets
// (include/manyrods/isa.h): every path this CPU runs steps the same batches
// as the baseline, within round-off, and says whether it agrees bit for bit.
//
// The batches are test_golden's (damped seed cantilevers, a damped stiff
// hair, a driven root; Position Verlet as step_n blocks, and PEFRL) plus one
// with contact (cantilevers bending onto a plane and against each other),
// in double and float. The bound is test_golden's: 10 ulps of T relative to
// L per step, accumulated linearly (these damped rods do not amplify a
// perturbation). Paths differ where the compiler fuses a·b + c into one
// rounding (x86-64-v2 has no FMA) and where a loop runs over 2, 4, 8 or 16
// lanes with a scalar remainder (same operations, same bits); so v3 and v4
// may agree bit for bit and v2 cannot be expected to. The test prints which.
#include <gtest/gtest.h>

#include <cstdio>
#include <cstdlib>
#include <limits>
#include <memory>
#include <stdexcept>
#include <string>
#include <vector>

#include "cases.h"
#include "manyrods/contact.h"
#include "manyrods/isa.h"
#include "manyrods/manyrods.h"

using namespace manyrods;

namespace {

// Selects "auto" again when a test ends, whatever happened.
struct RestoreAuto {
  ~RestoreAuto() { select_step_path("auto"); }
};

struct Run {
  std::uint64_t hash;
  std::vector<Vec3> nodes;  // every node of every rod
  int steps;
};

template <class T>
Run run(const std::string& what) {
  std::vector<RodSpec> specs = cases::golden_rods(what != "pefrl");
  if (what == "contact") {  // side by side, 3 cm apart in y, bending (−e1) onto a plane at x = −2 cm
    specs.resize(2);
    specs[1] = cases::seed_cantilever(20, Damping::shear_extension(0.02, 0.02));
    for (Vec3& x : specs[1].nodes) x[1] += 0.03;
  }
  RodBatch<T> b = build_batch<T>(specs, {-9.81, 0, -4});
  const T dt = T(0.5 * stable_dt(b).elastic);
  int steps = 200;
  if (what == "verlet") {
    for (int block = 0; block < 4; ++block) step_n(b, dt, 50, Exec{2});
  } else if (what == "pefrl") {
    steps = 100;
    for (int i = 0; i < steps; ++i) step_pefrl(b, dt, Exec{2});
  } else {
    ContactSpec spec;
    Collider plane;
    plane.name = "wall";
    plane.kind = ColliderKind::plane;
    plane.point = {-0.02, 0, 0};
    plane.normal = {1, 0, 0};
    spec.colliders = {plane};
    spec.rod_rod = true;
    set_contact(b, spec);
    steps = 2000;
    for (int block = 0; block < 4; ++block) step_n<kAllContact>(b, dt, steps / 4, Exec{2});
    EXPECT_GT(contact_stats(b).contacts, 0) << "the contact batch should touch the wall";
  }
  Run out{state_hash(b), {}, steps};
  for (int r = 0; r < b.rod_count(); ++r)
    for (int i = 0; i <= b.elements(r); ++i) out.nodes.push_back(b.position(r, i));
  return out;
}

template <class T>
void agree(const std::string& what) {
  RestoreAuto restore;
  select_step_path("baseline");
  const Run base = run<T>(what);
  const char* type = sizeof(T) == 4 ? "float" : "double";
  for (const StepPath& p : step_paths()) {
    if (!p.supported) {
      std::printf("  %s/%s on %s: not on this CPU\n", what.c_str(), type, p.name.c_str());
      continue;
    }
    select_step_path(p.name);
    ASSERT_EQ(active_step_path(), p.name);
    const Run got = run<T>(what);
    ASSERT_EQ(got.nodes.size(), base.nodes.size());
    const double tol = base.steps * 10 * double(std::numeric_limits<T>::epsilon()) * cases::kL;
    double worst = 0;
    for (std::size_t i = 0; i < got.nodes.size(); ++i) worst = std::max(worst, cases::distance(got.nodes[i], base.nodes[i]));
    EXPECT_LE(worst, tol) << what << "/" << type << " on " << p.name << " against the baseline";
    std::printf("  %s/%s on %s (%s): %s, largest node distance %.3g m (bound %.3g m), hash %016llx\n", what.c_str(),
                type, p.name.c_str(), p.target.c_str(), got.hash == base.hash ? "bit-identical" : "differs in the last bits",
                worst, tol, static_cast<unsigned long long>(got.hash));
  }
}

// A build with the baseline path only (MANYRODS_ISA empty, the default)
// has nothing to compare it with: those tests say "skipped", not passed.
// tools/run-isa-check builds the portable library with the levels.
#define MANYRODS_SKIP_WITHOUT_PATHS()                                                               \
  if (step_paths().size() < 2)                                                                      \
  GTEST_SKIP() << "this build has the baseline step path only (MANYRODS_ISA is empty): nothing to " \
                  "compare it with; tools/run-isa-check builds one with x86-64-v2, v3 and v4"

}  // namespace

TEST(StepPaths, BaselineFirstAndOneActive) {
  const std::vector<StepPath> paths = step_paths();
  ASSERT_FALSE(paths.empty());
  EXPECT_EQ(paths[0].name, "baseline");
  EXPECT_TRUE(paths[0].supported);
  int active = 0;
  for (const StepPath& p : paths) {
    active += p.active;
    if (p.active) {
      EXPECT_EQ(p.name, active_step_path());
    }
    std::printf("  %-10s %-18s %s%s\n", p.name.c_str(), p.target.c_str(), p.supported ? "runs here" : "not on this CPU",
                p.active ? ", active" : "");
  }
  EXPECT_EQ(active, 1);
}

TEST(StepPaths, EveryPathAgreesWithTheBaselineVerlet) {
  MANYRODS_SKIP_WITHOUT_PATHS();
  agree<double>("verlet");
  agree<float>("verlet");
}
TEST(StepPaths, EveryPathAgreesWithTheBaselinePefrl) {
  MANYRODS_SKIP_WITHOUT_PATHS();
  agree<double>("pefrl");
  agree<float>("pefrl");
}
TEST(StepPaths, EveryPathAgreesWithTheBaselineContact) {
  MANYRODS_SKIP_WITHOUT_PATHS();
  agree<double>("contact");
  agree<float>("contact");
}

TEST(StepPaths, UnknownAndUnsupportedNamesAreErrors) {
  RestoreAuto restore;
  const std::string before = active_step_path();
  try {
    select_step_path("x86-64-v9");
    FAIL() << "no error for an unknown path";
  } catch (const std::invalid_argument& e) {
    EXPECT_NE(std::string(e.what()).find("'x86-64-v9': not a step path of this build (step paths: baseline"),
              std::string::npos)
        << e.what();
  }
  EXPECT_EQ(active_step_path(), before) << "a failed selection must not change the path";
  for (const StepPath& p : step_paths())
    if (!p.supported) {
      EXPECT_THROW(select_step_path(p.name), std::invalid_argument) << p.name;
    }
}

#ifdef MANYRODS_CLI
// MANYRODS_ISA forces a path for a whole process (here the command-line tool,
// which prints the path it steps with); a bad value is a clear error.
namespace {
int cli(const std::string& env, std::string& out) {
  const std::string log = ::testing::TempDir() + "isa_cli.txt";
  const std::string scene = std::string(MANYRODS_SCENES) + "/seed_cantilever.toml";
  const std::string cmd = env + " '" + MANYRODS_CLI + "' run '" + scene + "' --duration 0.01 --no-progress -o '" +
                          ::testing::TempDir() + "isa_cli.h5' > '" + log + "' 2>&1";
  const int rc = std::system(cmd.c_str());
  out.clear();
  if (FILE* f = std::fopen(log.c_str(), "r")) {
    char buf[4096];
    for (std::size_t n; (n = std::fread(buf, 1, sizeof buf, f)) > 0;) out.append(buf, n);
    std::fclose(f);
  }
  return rc;
}
}  // namespace

TEST(StepPaths, EnvironmentVariableForcesAPath) {
  std::string out;
  for (const StepPath& p : step_paths()) {
    if (!p.supported) continue;
    ASSERT_EQ(cli("MANYRODS_ISA=" + p.name, out), 0) << out;
    EXPECT_NE(out.find("step path " + p.name), std::string::npos) << out;
  }
  EXPECT_NE(cli("MANYRODS_ISA=avx1024", out), 0) << out;
  EXPECT_NE(out.find("MANYRODS_ISA='avx1024': not a step path of this build"), std::string::npos) << out;
}
#endif
