// include/manyrods/profile.h — where a step's time goes: the wall time of
// each stage, summed over the calls and the threads that ran it.
//
// Pass a Profile in Exec::profile to step, step_n, step_pefrl or advance;
// each stage then reads a steady clock before and after it runs on a segment
// and adds the difference to the slot of the thread that ran it. Without a
// profile (the default) a stage costs one branch more. Times are
// thread-seconds: a stage that one thread runs on a segment counts its wall
// time; one that all threads run together (a segment too long to fuse,
// every PEFRL stage) counts its wall time times the thread count. Their
// total is the threads' busy time, not the wall time of the call. One
// Profile serves one call at a time.
#pragma once

#include <array>
#include <cstdint>
#include <vector>

namespace manyrods {

// The stages of a step, in the order docs/architecture.md "The step as
// stages" lists them.
enum class Stage {
  root_motion,     // driven holds (roots, tips, nodes) put on their motion (host/core/step/root_motion.h)
  drift,           // x += h v, Q ← exp(−h ω) Q (kernels/integrate.h)
  resultants,      // strains and resultants (kernels/strains.h, resultants.h, internal_forces.h)
  kick,            // v += h m⁻¹ F, ω += h J⁻¹ C (kernels/integrate.h)
  fluid,           // drag, buoyancy and wind, around the kick (kernels/fluid.h)
  implicit_solve,  // per-rod backward-Euler solve (kernels/viscous_implicit*.h)
  contact_solve,   // collider and self contacts of the rods the solve steps (kernels/contact_solve.h; partly inside the solve)
  broad_phase,     // rod–rod candidate lists, when they need rebuilding (host/core/step/broad_phase.cpp)
  contact,         // narrow phase: contact impulses and friction after the solve (kernels/contact.h)
  renormalize,     // float frames back to orthonormal (kernels/integrate.h)
  count
};
inline constexpr int kStageCount = int(Stage::count);

// The stage's name as `manyrods run --profile` and the benchmarks print it.
const char* stage_name(Stage s);

struct alignas(64) StageTimes {  // (one cache line per thread's slot)
  std::array<double, kStageCount> seconds{};
  std::array<std::int64_t, kStageCount> calls{};
  double total() const;
  StageTimes& operator+=(const StageTimes& o);
};

class Profile {
 public:
  // Slots for `threads` threads (kept if there are already as many).
  void reserve(int threads);
  void add(int thread, Stage s, double seconds) {
    per_thread_[std::size_t(thread)].seconds[std::size_t(s)] += seconds;
    per_thread_[std::size_t(thread)].calls[std::size_t(s)] += 1;
  }
  // Time measured inside stage `from` that belongs to stage `to`, a stage
  // fused into it (the solve's collider contacts): moved, one call of `to`.
  void move(int thread, Stage from, Stage to, double seconds) {
    per_thread_[std::size_t(thread)].seconds[std::size_t(from)] -= seconds;
    add(thread, to, seconds);
  }
  // Summed over the threads.
  StageTimes total() const;
  void clear();

 private:
  std::vector<StageTimes> per_thread_;
};

}  // namespace manyrods
