// include/manyrods/drive.h — driven roots: a clamped root that follows a
// prescribed rigid motion (a head that turns, a shaker table, an animated
// attachment point).
//
// A RootMotion gives a rigid pose P(t) = (R(t), c(t)) mapping a point p to
// R(t) p + c(t). A rod whose RodSpec::root_motion is set is clamped at the
// image of its given root under P(t): node 0 at R(t) x₀ + c(t), the clamp
// frame's directors at R(t) d_i (rows: Q(t) = Q₀ R(t)ᵀ), where x₀, Q₀ are the
// root and clamp frame the rod was built with. Many rods can share one motion
// (a scalp): each segment of the batch evaluates it at both ends of a step
// (of each drift for PEFRL) for all of its rods. The motion must turn by
// less than π within one step: the angular velocity is taken from the
// relative rotation of the step's two poses, whose angle is only known
// modulo 2π (a step that coarse cannot follow the motion anyway).
//
// How the step uses it (host/core/step/root_motion.h apply_root_motion): at the start of each
// Position Verlet step, t → t + h, node 0 is put at x(t) and given the mean velocity
// (x(t + h) − x(t))/h, and the clamp frame is put at Q(t) with the constant
// angular velocity that turns it into Q(t + h) over the step. The drifts then
// carry the root exactly to the pose at t + h (the drift's rotation is exact
// for constant ω) while the rod sees the root at second-order accurate
// positions inside the step: Position Verlet stays second order with a
// driven root. PEFRL does the same drift by drift (the root is put at the
// pose of each stage's time), and stays fourth order (tests/test_drive.cpp
// measures both: 2.00 and 4.01). In the implicit solve the root's
// velocities are prescribed unknowns, handled by solving for the velocities
// relative to the root's rigid motion (kernels/viscous_implicit.h
// rigid_shift). The motion does work on the rod: with a driven root the
// energy budget has a source.
#pragma once

#include <array>
#include <string>
#include <vector>

namespace manyrods {

using Vec3 = std::array<double, 3>;
using Mat3 = std::array<double, 9>;  // row-major

// p ↦ rotation · p + translation (rotation: a proper rotation matrix).
struct Pose {
  Mat3 rotation{1, 0, 0, 0, 1, 0, 0, 0, 1};
  Vec3 translation{0, 0, 0};
};

class RootMotion {
 public:
  virtual ~RootMotion() = default;
  // The pose at time t (s). Called for the ends of every step (or PEFRL
  // drift), possibly from several threads at once: must be thread-safe and
  // deterministic.
  virtual Pose at(double t) const = 0;
  // Throws InputError naming the first bad parameter (build_batch calls it).
  virtual void validate() const {}
};

// Oscillation about a pivot: translation a·s(t) and a rotation by θ·s(t)
// about `axis` through `pivot`, s(t) = e(t)·sin(2πft + φ) (θ in radians; a
// shaker, a nodding head). The pose at t = 0 is the identity for φ = 0, but
// the velocity is not zero there: the rods, built at rest, are jerked into
// motion. ramp_time > 0 fades the motion in with e(t) = smoothstep(t/ramp_time)
// (3x² − 2x³: the pose and its velocity start at zero); e = 1 after it.
struct OscillatingMotion : RootMotion {
  Vec3 translation_amplitude{0, 0, 0};  // m
  Vec3 axis{0, 0, 1};                   // any length > 0 when rotation_amplitude ≠ 0
  double rotation_amplitude = 0;        // rad
  double frequency = 0;                 // Hz
  double phase = 0;                     // rad
  double ramp_time = 0;                 // s, ≥ 0
  Vec3 pivot{0, 0, 0};                  // m
  Pose at(double t) const override;
  // Throws InputError naming the first bad field.
  void validate() const override;
};

// Key poses interpolated as USD and Alembic time samples are: translations
// linearly, rotations along the shortest arc (slerp, constant angular
// velocity between keys), about `pivot`; held constant before the first key
// and after the last. rotations[i] = {axis x, y, z, angle in rad}.
struct KeyframedMotion : RootMotion {
  std::vector<double> times;  // s, strictly increasing
  std::vector<Vec3> translations;
  std::vector<std::array<double, 4>> rotations;  // empty = no rotation
  Vec3 pivot{0, 0, 0};
  Pose at(double t) const override;
  // Throws InputError naming the first bad entry.
  void validate() const override;
};

// A ramp: translation d·s(t) and a rotation by θ·s(t) about `axis` through
// `pivot`, s(t) rising from 0 at start_time to 1 at start_time + duration
// (linearly, or with smoothstep 3x² − 2x³ when `smooth`), constant outside.
// θ may be any number of turns: a rod's tip pushed towards its root and
// twisted about the rod's axis (helical buckling), a slow compression.
struct RampMotion : RootMotion {
  Vec3 translation{0, 0, 0};  // m
  Vec3 axis{0, 0, 1};         // any length > 0 when rotation ≠ 0
  double rotation = 0;        // rad
  double start_time = 0;      // s
  double duration = 1;        // s, > 0
  bool smooth = false;
  Vec3 pivot{0, 0, 0};        // m
  Pose at(double t) const override;
  // Throws InputError naming the first bad field.
  void validate() const override;
};

// A motion the host application sets as it goes (an animation package's
// head, a game's hand, a collider it animates), by name: a scene's
// `motion = "host"` (docs/scenes.md "Host-driven motion"), the C API's
// mr_batch_set_driver_pose, the Python module's Batch.set_driver_pose.
// set_target(now, target, until, pivot) moves it from where it is at `now`
// (at(now)) to `target` turned about the body point `pivot` at `until` (the
// pose x ↦ R (x − pivot) + pivot + translation; pivot 0: target itself):
// the rotation along the shortest arc (constant angular velocity) and the
// pivot's image on a straight line (so a head turned about its neck keeps
// the neck in place during the move; pivot 0: the translation linearly),
// held there after `until`;
// until = now jumps (a teleport: the step sees an infinite velocity, so only
// for a first placement). It starts at the identity pose. set_target must
// not run while a step evaluates at() (the host sets poses between steps).
class HostMotion : public RootMotion {
 public:
  explicit HostMotion(std::string name) : name_(std::move(name)) {}
  const std::string& name() const { return name_; }
  Pose at(double t) const override;
  // InputError for a non-finite or improper rotation (det ≠ 1, not
  // orthonormal within 1e-6), a non-finite translation or pivot, until < now.
  void set_target(double now, const Pose& target, double until, const Vec3& pivot = {0, 0, 0});

 private:
  std::string name_;
  double t0_ = 0, t1_ = 0;
  Pose p0_, p1_;
  Vec3 pivot_{0, 0, 0};
};

// A motion over one step [t, t + h] (host/core/step/root_motion.h apply_root_motion): the
// poses at both ends and the constant lab angular velocity Ω that turns one
// into the other, exp(h [Ω]×) = R(t + h) R(t)ᵀ.
struct RootStep {
  Pose start, end;
  Vec3 omega{0, 0, 0};  // rad/s
};
RootStep root_step(const RootMotion& motion, double t, double h);

}  // namespace manyrods
