// stable_dt (host/stable_dt.h) against the exact linear limit 2/ω_max of the
// eigenproblem (tests/linear.h), and a check that it really is stable.
#include <gtest/gtest.h>

#include "cases.h"
#include "linear.h"

using namespace manyrods;
using namespace manyrods::cases;
using namespace manyrods::testing;

TEST(StableDt, GershgorinBoundIsBelowAndWithinTwoOfTheLinearLimit) {
  for (int n : {10, 50, 100}) {
    auto b = build_batch<double>({seed_cantilever(n, Damping::shear_extension(0.02, 0.02))});
    const double exact = 2 / modes(linearize(b, 0)).omega.maxCoeff();
    const StableDt est = stable_dt(b);
    std::printf("n %d: estimate %.4g s, linear limit %.4g s, explicit viscous %.4g s\n", n, est.elastic,
                exact, est.explicit_viscous);
    // Gershgorin bounds ω_max² from above: the estimate never exceeds the
    // limit (up to the 1e-9 accuracy of the finite-difference eigenproblem).
    EXPECT_LE(est.elastic, exact * (1 + 1e-9));
    EXPECT_GE(est.elastic, exact / 2);
    // The explicit viscous limit 2/(τ ω_max²) is far below (DESIGN §3).
    EXPECT_LT(est.explicit_viscous, est.elastic / 100);
  }
}
