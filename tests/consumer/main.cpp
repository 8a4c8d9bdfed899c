// A user's program against the installed package: rods from the library
// API, a batch stepped with every public step function, and a scene file.
#include <cmath>
#include <cstdio>

#include "manyrods/manyrods.h"
#include "manyrods/scene.h"


int main(int argc, char** argv) {
  using namespace manyrods;
  RodSpec rod = RodSpec::straight({0, 0, 0}, {1, 0, 0}, {0, 0, 1}, 0.3, 20);
  rod.section = Section::rectangle(0.01, 0.01);
  rod.material = {1000, 1e6, 0.3};
  rod.damping = Damping::shear_extension(0.02, 0.02);
  rod.clamped_root = true;
  RodBatch<double> b = build_batch<double>({rod, rod}, {0, 0, -9.81});
  const double dt = 0.9 * stable_dt(b).elastic;
  step(b, dt);
  step_n(b, dt, 10, Exec{2});
  advance<kAllTerms, Viscous::implicit, Integrator::pefrl>(b, dt, 10);
  const Energies e = energies(b);
  RodBatch<double> st = build_batch<double>({rod}, {0, 0, -9.81});
  const StaticResult sr = solve_static(st);
  std::printf("t = %g s, E = %g J, static tip z = %g m (converged %d), hash %016llx\n", b.state.time, e.total(),
              st.position(0, 20)[2], int(sr.converged), (unsigned long long)state_hash(b));
  if (!(std::isfinite(e.total()) && sr.converged && st.position(0, 20)[2] < 0)) return 1;
  if (argc > 1) {  // a scene file: parse it and build its batch
    const scene::Scene s = scene::load_scene(argv[1]);
    RodBatch<double> sb = scene::build_scene_batch<double>(s);
    std::printf("scene %s: %d rods, %lld elements\n", argv[1], sb.rod_count(), (long long)sb.element_count());
  }
  return 0;
}
