// host/core/step/profile.cpp — per-stage timing (include/manyrods/profile.h).
#include "manyrods/profile.h"

namespace manyrods {

const char* stage_name(Stage s) {
  switch (s) {
    case Stage::root_motion: return "root_motion";
    case Stage::drift: return "drift";
    case Stage::resultants: return "resultants";
    case Stage::kick: return "kick";
    case Stage::fluid: return "fluid";
    case Stage::implicit_solve: return "implicit_solve";
    case Stage::contact_solve: return "contact_solve";
    case Stage::broad_phase: return "broad_phase";
    case Stage::contact: return "contact";
    case Stage::renormalize: return "renormalize";
    case Stage::count: break;
  }
  return "?";
}

double StageTimes::total() const {
  double t = 0;
  for (double s : seconds) t += s;
  return t;
}

StageTimes& StageTimes::operator+=(const StageTimes& o) {
  for (int i = 0; i < kStageCount; ++i) {
    seconds[i] += o.seconds[i];
    calls[i] += o.calls[i];
  }
  return *this;
}

void Profile::reserve(int threads) {
  if (threads < 1) threads = 1;
  if (threads > int(per_thread_.size())) per_thread_.resize(std::size_t(threads));
}

StageTimes Profile::total() const {
  StageTimes t;
  for (const StageTimes& s : per_thread_) t += s;
  return t;
}

void Profile::clear() {
  for (StageTimes& s : per_thread_) s = StageTimes{};
}

}  // namespace manyrods
