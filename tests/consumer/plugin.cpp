// A host application's plug-in (a shared object) that steps a rod.
#include "manyrods/manyrods.h"

int plugin_tip_after_steps(int steps, double* tip_z) {
  using namespace manyrods;
  RodSpec rod = RodSpec::straight({0, 0, 0}, {1, 0, 0}, {0, 0, 1}, 0.3, 10);
  rod.section = Section::circle(0.005);
  rod.material = {1000, 1e6, 0.3};
  rod.clamped_root = true;
  RodBatch<float> b = build_batch<float>({rod}, {0, 0, -9.81});
  step_n(b, float(0.5 * stable_dt(b).elastic), steps);
  *tip_z = b.position(0, 10)[2];
  return 0;
}
