#include <gtest/gtest.h>

#include "host/core/advanced.h"

using namespace manyrods;

TEST(Smoke, BuildsAndSteps) {
  RodSpec s = RodSpec::straight({0, 0, 0}, {0, 0, 1}, {1, 0, 0}, 0.3, 10);
  s.section = Section::rectangle(0.01, 0.01);
  s.material = {1000, 1e6, 0.3};
  s.clamped_root = true;
  auto b = build_batch<double>({s}, {0, -9.81, 0});
  for (int i = 0; i < 100; ++i) step(b, 1e-5);
  EXPECT_FALSE(find_non_finite(b).found);
}
