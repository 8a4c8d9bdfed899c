// tests/check.h — comparing batch values with reference values against a
// round-off tolerance k·u·scale (see tests/reference.h, "Round-off scales").
#pragma once

#include <gtest/gtest.h>

#include <array>
#include <cmath>
#include <cstdio>
#include <string>

#include "host/core/advanced.h"
#include "reference.h"

namespace manyrods::testing {

// Records the worst err/(u·scale) over many comparisons and fails every
// comparison whose ratio exceeds k (or is not a number).
class Checker {
 public:
  Checker(std::string what, double u, double k) : what_(std::move(what)), u_(u), k_(k) {}
  ~Checker() {
    std::printf("  [%-34s] %5d values, worst err/(u*scale) = %8.3g (limit %g) at %s\n", what_.c_str(), count_,
                worst_, k_, worst_at_.c_str());
  }
  void vec(const ref::V3& got, const ref::V3& want, double scale, const std::string& at) {
    scalar((got - want).cwiseAbs().maxCoeff(), scale, at);
  }
  void num(double got, double want, double scale, const std::string& at) {
    scalar(std::abs(got - want), scale, at);
  }
  double worst() const { return worst_; }

 private:
  void scalar(double err, double scale, const std::string& at) {
    ++count_;
    const double ratio = err == 0 ? 0 : err / (u_ * scale);
    if (!(ratio <= worst_)) {
      worst_ = ratio;
      worst_at_ = at;
    }
    if (!(ratio <= k_))
      ADD_FAILURE() << what_ << " at " << at << ": |batch - reference| = " << err << " > " << k_
                    << " * u * scale = " << k_ * u_ * scale << " (scale " << scale << ")";
  }
  std::string what_;
  double u_, k_;
  double worst_ = 0;
  std::string worst_at_ = "-";
  int count_ = 0;
};

template <class T>
ref::V3 get3(const std::array<Array<T>, 3>& a, int k) {
  return ref::V3(double(a[0][k]), double(a[1][k]), double(a[2][k]));
}
template <class T>
ref::V3 get3(const T* const a[3], int k) {
  return ref::V3(double(a[0][k]), double(a[1][k]), double(a[2][k]));
}
template <class T>
ref::M3 get_frame(const RodBatch<T>& b, int k) {
  ref::M3 q;
  for (int i = 0; i < 3; ++i)
    for (int j = 0; j < 3; ++j) q(i, j) = double(b.state.elem_Q[3 * i + j][k]);
  return q;
}

// generalized_forces into freshly allocated [3][slots] arrays.
template <class T>
struct ForceArrays {
  std::array<Array<T>, 3> force, couple;
  explicit ForceArrays(int slots) {
    for (int d = 0; d < 3; ++d) {
      force[d].resize(slots, T(0));
      couple[d].resize(slots, T(0));
    }
  }
  std::array<T*, 3> force_ptr() { return {force[0].data(), force[1].data(), force[2].data()}; }
  std::array<T*, 3> couple_ptr() { return {couple[0].data(), couple[1].data(), couple[2].data()}; }
};

template <Terms kT, class T>
ForceArrays<T> batch_forces(RodBatch<T>& b, const Exec& ex = {}) {
  ForceArrays<T> f(b.slots());
  const std::array<T*, 3> fp = f.force_ptr(), cp = f.couple_ptr();
  T* const force[3] = {fp[0], fp[1], fp[2]};
  T* const couple[3] = {cp[0], cp[1], cp[2]};
  generalized_forces<kT>(b, force, couple, ex);
  return f;
}

inline std::string where(const char* what, int rod, int index) {
  return std::string(what) + " " + std::to_string(index) + " of rod " + std::to_string(rod);
}

}  // namespace manyrods::testing
