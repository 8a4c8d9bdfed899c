// advance() (host/core/step/integrators.h): many steps with a watch for non-finite states.
// A state that goes non-finite stops the run with a NonFiniteError that
// names the first rod (index and name), node or element, the step and the
// simulated time — checked here against an independent step-by-step run.
#include <gtest/gtest.h>

#include <cmath>
#include <cstring>
#include <string>

#include "cases.h"

using namespace manyrods;
using namespace manyrods::cases;

namespace {

// Rod 0: the seed cantilever (n = 10). Rod 1: the same rod 1000× stiffer
// (E = 1 GPa), named, so a step that suits rod 0 is ≈ 16× above rod 1's
// stable step (stable dt ∝ 1/√E). Gravity perturbs both from rest.
RodBatch<double> two_rods() {
  RodSpec soft = seed_cantilever(10);
  soft.name = "soft";
  RodSpec stiff = seed_cantilever(10);
  stiff.name = "stiff wire";
  stiff.material.youngs_modulus = 1e9;
  return build_batch<double>({soft, stiff}, {0, 0, -9.81});
}

bool finite_state(const RodBatch<double>& b) { return !find_non_finite(b).found; }

bool same_state(const State<double>& a, const State<double>& b) {
  auto same = [](const auto& x, const auto& y) {
    for (std::size_t i = 0; i < x.size(); ++i)
      if (std::memcmp(x[i].data(), y[i].data(), x[i].size() * sizeof(double)) != 0) return false;
    return true;
  };
  return same(a.node_x, b.node_x) && same(a.node_v, b.node_v) && same(a.elem_Q, b.elem_Q) &&
         same(a.elem_w, b.elem_w) && a.steps == b.steps && a.time == b.time;
}

}  // namespace

TEST(Advance, SameResultAsStepLoop) {
  // advance() only adds checks and a copy of the state: bit-identical to
  // calling step() (200 steps: three checks at 64 and one after the last).
  RodBatch<double> a = two_rods(), b = two_rods();
  const double dt = 0.5 * stable_dt(a).elastic;  // stable for both rods
  advance(a, dt, 200);
  for (int i = 0; i < 200; ++i) step(b, dt);
  EXPECT_TRUE(same_state(a.state, b.state));
  EXPECT_EQ(a.state.steps, 200);
  // PEFRL likewise.
  advance<kAllTerms, Viscous::implicit, Integrator::pefrl>(a, dt, 70);
  for (int i = 0; i < 70; ++i) step_pefrl(b, dt);
  EXPECT_TRUE(same_state(a.state, b.state));
}

TEST(Advance, NonFiniteStateStopsWithRodElementStepAndTime) {
  RodBatch<double> b = two_rods();
  RodBatch<double> probe = two_rods();
  const StableDt soft = stable_dt(build_batch<double>({seed_cantilever(10)}));
  const double dt = 0.5 * soft.elastic;
  ASSERT_GT(dt, 10 * stable_dt(b).elastic);  // rod 1 far above its stable step
  bool thrown = false;
  try {
    advance(b, dt, 100000);
  } catch (const NonFiniteError& e) {
    thrown = true;
    std::printf("%s\n", e.what());
    // The first rod to go non-finite is the stiff one, named in the message.
    EXPECT_EQ(e.where.rod, 1);
    const std::string msg = e.what();
    EXPECT_NE(msg.find("rod 1 ('stiff wire', 10 elements)"), std::string::npos) << msg;
    EXPECT_NE(msg.find(e.where.field + " " + std::to_string(e.where.index)), std::string::npos) << msg;
    EXPECT_NE(msg.find("step " + std::to_string(e.step)), std::string::npos) << msg;
    EXPECT_NE(msg.find("t = "), std::string::npos) << msg;
    // Step and time are the batch's, left at the first non-finite step.
    EXPECT_EQ(e.step, b.state.steps);
    EXPECT_EQ(e.time, b.state.time);
    EXPECT_NEAR(e.time, e.step * dt, 1e-9 * e.step * dt);
    EXPECT_FALSE(finite_state(b));
    EXPECT_LT(e.step, 100000);
    // An independent run: finite after e.step − 1 steps, not after e.step,
    // and the first non-finite entry is the one reported (the replay in
    // advance() locates the exact step, not just the 64-step window).
    for (std::int64_t i = 0; i + 1 < e.step; ++i) step(probe, dt);
    EXPECT_TRUE(finite_state(probe)) << "finite one step earlier";
    step(probe, dt);
    const NonFinite nf = find_non_finite(probe);
    ASSERT_TRUE(nf.found);
    EXPECT_EQ(nf.rod, e.where.rod);
    EXPECT_EQ(nf.field, e.where.field);
    EXPECT_EQ(nf.index, e.where.index);
    EXPECT_TRUE(same_state(probe.state, b.state));
    // Found by the replay, not on the 64-step check grid.
    EXPECT_NE(e.step % 64, 0);
  }
  EXPECT_TRUE(thrown) << "stepping 16× above the stable step must go non-finite";
}

TEST(Advance, NonFiniteWithPefrlAndAnyCheckInterval) {
  // The step found does not depend on the check interval.
  std::int64_t first = -1;
  for (int every : {1, 7, 64, 1000}) {
    RodBatch<double> b = two_rods();
    const double dt = 0.5 * stable_dt(build_batch<double>({seed_cantilever(10)})).elastic;
    try {
      advance<kAllTerms, Viscous::implicit, Integrator::pefrl>(b, dt, 100000, Exec{}, AdvanceOptions{every});
      ADD_FAILURE() << "no NonFiniteError";
    } catch (const NonFiniteError& e) {
      EXPECT_EQ(e.where.rod, 1);
      if (first < 0) first = e.step;
      EXPECT_EQ(e.step, first) << "check_every " << every;
    }
  }
}

TEST(Advance, NonFiniteInitialStateAndBadArguments) {
  RodBatch<double> b = two_rods();
  b.state.elem_w[2][b.elem_index(0, 3)] = NAN;
  try {
    advance(b, 1e-6, 10);
    ADD_FAILURE() << "no NonFiniteError";
  } catch (const NonFiniteError& e) {
    EXPECT_EQ(e.step, 0);
    EXPECT_EQ(e.where.rod, 0);
    EXPECT_EQ(e.where.field, "element");
    EXPECT_EQ(e.where.index, 3);
  }
  RodBatch<double> c = two_rods();
  EXPECT_THROW(advance(c, 1e-6, -1), std::invalid_argument);
  EXPECT_THROW(advance(c, 1e-6, 10, Exec{}, AdvanceOptions{0}), std::invalid_argument);
}

TEST(Advance, FloatBatch) {
  // The float instantiation: same as its step loop, and a float rod far
  // above its stable step is caught too.
  auto a = build_batch<float>({seed_cantilever(10)}, {0, 0, -9.81});
  auto b = a;
  const float dt = 0.5f * float(stable_dt(a).elastic);
  advance(a, dt, 100);
  for (int i = 0; i < 100; ++i) step(b, dt);
  for (int d = 0; d < 3; ++d)
    EXPECT_EQ(std::memcmp(a.state.node_x[d].data(), b.state.node_x[d].data(), a.slots() * sizeof(float)), 0);
  auto c = build_batch<float>({seed_cantilever(10)}, {0, 0, -9.81});
  EXPECT_THROW(advance(c, 40 * dt, 100000), NonFiniteError);
}
