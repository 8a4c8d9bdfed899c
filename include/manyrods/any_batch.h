// include/manyrods/any_batch.h — one batch of either precision with the
// compile-time Terms it steps with, chosen at run time: the object the
// Python module and the C API hold (library manyrods::scene).
//
// A batch comes from a scene (its file's rods, initial state, contact,
// fluid, step and integrator) or from rods built in code (one group per
// rod; Kelvin–Voigt compiled in when some rod is damped, gravity when it is
// not zero). Every call dispatches to the library's instantiation for the
// batch's precision and Terms (include/manyrods/scene.h "Terms dispatch"), so
// an AnyBatch steps exactly as `manyrods run` does: the same state bit for
// bit.
#pragma once

#include <cstdint>
#include <functional>
#include <memory>
#include <optional>
#include <string>
#include <variant>
#include <vector>

#include "manyrods/batch.h"
#include "manyrods/h5io.h"
#include "manyrods/scene.h"
#include "manyrods/stable_dt.h"
#include "manyrods/statics.h"
#include "manyrods/step.h"

namespace manyrods::scene {

class AnyBatch {
 public:
  // The scene's batch (build_scene_batch, initial state applied), in the
  // scene's precision or the given one.
  static AnyBatch from_scene(Scene s, std::optional<Precision> precision = {});
  // Rods built in code (InputError naming the rod for invalid ones).
  static AnyBatch from_rods(std::vector<RodSpec> rods, Precision precision, const Vec3& gravity = {0, 0, 0},
                            Integrator integrator = Integrator::position_verlet);

  bool float32() const { return batch_.index() == 0; }
  RodBatch<float>& f32() { return std::get<0>(batch_); }
  RodBatch<double>& f64() { return std::get<1>(batch_); }
  const RodBatch<float>& f32() const { return std::get<0>(batch_); }
  const RodBatch<double>& f64() const { return std::get<1>(batch_); }
  // f(RodBatch<T>&) for the batch's T.
  template <class F>
  decltype(auto) visit(F&& f) {
    return std::visit(std::forward<F>(f), batch_);
  }
  template <class F>
  decltype(auto) visit(F&& f) const {
    return std::visit(std::forward<F>(f), batch_);
  }

  const Scene& scene() const { return *scene_; }  // code-built rods: a scene of one group per rod
  bool from_file() const { return from_file_; }
  const StepChoice& choice() const { return choice_; }
  // The scene's step (scene_dt: its dt or "auto", frame-aligned, checked
  // against the stable limit); for rods built in code 0.9 × stable_dt().elastic.
  double scene_dt() const;

  // `count` steps of length dt (advance_scene: NonFiniteError names the
  // first bad step). keep_going, when given, is asked between chunks of
  // steps whether to go on; a chunk is a multiple of 64 steps (the
  // non-finite check cadence, so the result does not depend on the chunks),
  // starts at 64 and doubles while a chunk takes under `check_s` seconds of
  // wall time, so the question comes about every check_s whatever the batch
  // size. Returns the steps done. InputError for dt ≤ 0 or not finite,
  // count < 0, threads < 1, and for a dt above the stable limit (check_dt)
  // unless force_dt or the scene's simulation.force_dt.
  std::int64_t step(double dt, std::int64_t count, int threads = 1, const std::function<bool()>& keep_going = {},
                    double check_s = 0.1, bool force_dt = false);
  // The step-size guard of `manyrods run` (docs/scenes.md "The step-size
  // guard"): InputError when dt exceeds stable_dt().elastic, with the limit
  // and the safe value (0.9 × the limit). The limit is computed at the
  // first check and again only when a longer step comes.
  void check_dt(double dt) const;
  Energies energies(int rod = -1) const;
  StableDt stable_dt() const;
  // Static equilibrium from the current state (scene_solve_static; double
  // batches, InputError for float). With opt.hold_time the driven holds go
  // to their pose at that time, and a converged solve sets the batch's time
  // to it. A result without equilibrium leaves the rods where the solve
  // stopped; static_failure says why in words.
  StaticResult solve_static(const StaticOptions& opt = {});
  std::string static_failure(const StaticResult& r) const;
  // Nothing for a converged result; otherwise throws, in static_failure's
  // words, InputError for a rod that is a mechanism under its loads (bad
  // input) and StaticError when Newton found no equilibrium.
  void check_static(const StaticResult& r) const;
  // Gravity preload again (scene_preload): the rest shapes of the rods with
  // preload (RodSpec::preload, a group's preload = true; the batch's build
  // solved them for the rods as built) solved so that the rods as they are
  // now stand in equilibrium under the loads as they are now (set loads
  // first). Solved in double precision (a float batch's state is copied
  // into a double one). InputError in preload_failure's words for a rod
  // with no such rest shape, or whose rest shape is an unstable
  // equilibrium (every rest shape left as it was).
  PreloadResult preload();
  // What each hold exerts on its rod now (scene_hold_reactions; double batches).
  std::vector<HoldReaction> hold_reactions() const;
  std::uint64_t state_hash() const;

  double time() const;
  std::int64_t steps() const;
  int slots() const;
  int rod_count() const;
  int elements(int rod) const;  // InputError for a rod out of range
  int node_slot(int rod, int node) const { return offset(rod) + 1 + node; }
  int element_slot(int rod, int element) const { return offset(rod) + 1 + element; }
  std::int64_t node_count() const;  // all rods' nodes (element_count + rod_count)

  // Host motions (motion = "host" in a scene, HostMotion in a rod built in
  // code; include/manyrods/drive.h), by index in the order they first
  // appear: the host moves them between steps. find_driver: InputError
  // naming the known ones. set_driver_pose: from the pose at time() to
  // `pose` at time `until` ≥ time() (HostMotion::set_target; InputError for
  // a bad index, pose or time).
  int driver_count() const { return int(host_motions_.size()); }
  const std::string& driver_name(int driver) const { return host_motions_.at(std::size_t(driver))->name(); }
  int find_driver(const std::string& name) const;
  // pivot: the body point the pose turns about (HostMotion::set_target: x ↦
  // R (x − pivot) + pivot + translation), whose image moves on a straight line during the
  // move (HostMotion::set_target; the pose itself already says where it ends).
  void set_driver_pose(int driver, const Pose& pose, double until, const Vec3& pivot = {0, 0, 0});

  // A manyrods output file (include/manyrods/h5io.h) with this state as its
  // one frame and its checkpoint (a scene's batch: `manyrods run --restart`
  // continues it). h5::H5Error when it cannot be written. With `holds`,
  // the file also has /holds and /static (a static equilibrium's reactions,
  // include/manyrods/h5io.h Holds).
  void save(const std::string& path, const h5::Holds* holds = nullptr) const;
  // The reactions of hold_reactions() and a static solve's result as the
  // file's /holds and /static (r null: the residuals NaN, the counts 0).
  h5::Holds holds_record(const StaticResult* r = nullptr) const;

 private:
  AnyBatch() = default;
  int offset(int rod) const;
  std::variant<RodBatch<float>, RodBatch<double>> batch_;
  std::shared_ptr<const Scene> scene_;
  StepChoice choice_;
  bool from_file_ = false;
  mutable double checked_dt_ = 0;  // the longest step check_dt has passed
  std::vector<std::shared_ptr<HostMotion>> host_motions_;  // this batch's own (not the Scene's)
};

// The scene's rods (double precision, initial state applied) in static
// equilibrium with every driven hold at its pose at time `at` (s, ≥ 0;
// AnyBatch::solve_static), the batch's time set to `at`: what `manyrods
// static` writes and `manyrods run --from-static` starts from. SceneError
// naming the scene for what the static solve does not take and for a rod
// that is a mechanism under its loads; StaticError when Newton finds no
// equilibrium (both in AnyBatch::static_failure's words).
AnyBatch static_equilibrium(const Scene& s, double at, StaticResult* result = nullptr, const StaticOptions& opt = {});

}  // namespace manyrods::scene
