// host/core/model/drive.cpp — the root motions of include/manyrods/drive.h.
#include "manyrods/drive.h"

#include <Eigen/Geometry>
#include <algorithm>
#include <cmath>
#include <numbers>
#include <string>

#include "manyrods/material.h"

namespace manyrods {
namespace {

using E3 = Eigen::Vector3d;
using EM3 = Eigen::Matrix3d;

E3 to_eigen(const Vec3& v) { return {v[0], v[1], v[2]}; }

// p ↦ R (p − pivot) + pivot + d
Pose about_pivot(const EM3& r, const E3& d, const Vec3& pivot) {
  const E3 c = to_eigen(pivot);
  const E3 t = c - r * c + d;
  Pose p;
  for (int i = 0; i < 3; ++i) {
    for (int j = 0; j < 3; ++j) p.rotation[3 * i + j] = r(i, j);
    p.translation[i] = t[i];
  }
  return p;
}

Eigen::Quaterniond key_rotation(const std::array<double, 4>& r) {
  const E3 axis(r[0], r[1], r[2]);
  if (r[3] == 0 || axis.norm() == 0) return Eigen::Quaterniond::Identity();
  return Eigen::Quaterniond(Eigen::AngleAxisd(r[3], axis.normalized()));
}

}  // namespace

void OscillatingMotion::validate() const {
  auto bad = [](const std::string& what) { throw InputError("root motion: " + what); };
  for (double v : translation_amplitude)
    if (!std::isfinite(v)) bad("translation_amplitude is not finite");
  for (double v : pivot)
    if (!std::isfinite(v)) bad("pivot is not finite");
  if (!std::isfinite(rotation_amplitude)) bad("rotation_amplitude is not finite");
  if (rotation_amplitude != 0 && !(to_eigen(axis).norm() > 0 && std::isfinite(to_eigen(axis).norm())))
    bad("axis must be a finite non-zero vector when rotation_amplitude is not 0");
  if (!std::isfinite(frequency) || frequency < 0) bad("frequency must be a finite number >= 0");
  if (!std::isfinite(phase)) bad("phase is not finite");
  if (!std::isfinite(ramp_time) || ramp_time < 0) bad("ramp_time must be a finite number >= 0");
}

Pose OscillatingMotion::at(double t) const {
  double s = std::sin(2 * std::numbers::pi * frequency * t + phase);
  if (ramp_time > 0 && t < ramp_time) {
    const double x = std::max(t, 0.0) / ramp_time;
    s *= x * x * (3 - 2 * x);
  }
  const E3 axis_e = to_eigen(axis);
  const EM3 r = rotation_amplitude != 0
                    ? Eigen::AngleAxisd(rotation_amplitude * s, axis_e.normalized()).toRotationMatrix()
                    : EM3::Identity();
  return about_pivot(r, s * to_eigen(translation_amplitude), pivot);
}

void KeyframedMotion::validate() const {
  auto bad = [](const std::string& what) { throw InputError("root motion: " + what); };
  if (times.empty()) bad("keyframes need at least one time");
  if (translations.size() != times.size())
    bad("translations: " + std::to_string(translations.size()) + " given, one per time (" +
        std::to_string(times.size()) + ") needed");
  if (!rotations.empty() && rotations.size() != times.size())
    bad("rotations: " + std::to_string(rotations.size()) + " given, one per time (" + std::to_string(times.size()) +
        ") needed");
  for (std::size_t i = 0; i < times.size(); ++i) {
    if (!std::isfinite(times[i])) bad("times[" + std::to_string(i) + "] is not finite");
    if (i > 0 && !(times[i] > times[i - 1]))
      bad("times[" + std::to_string(i) + "] = " + std::to_string(times[i]) + ": times must increase strictly");
    for (double v : translations[i])
      if (!std::isfinite(v)) bad("translations[" + std::to_string(i) + "] is not finite");
  }
  for (std::size_t i = 0; i < rotations.size(); ++i) {
    for (double v : rotations[i])
      if (!std::isfinite(v)) bad("rotations[" + std::to_string(i) + "] is not finite");
    if (rotations[i][3] != 0 && E3(rotations[i][0], rotations[i][1], rotations[i][2]).norm() == 0)
      bad("rotations[" + std::to_string(i) + "]: a non-zero angle needs a non-zero axis");
  }
  for (double v : pivot)
    if (!std::isfinite(v)) bad("pivot is not finite");
}

Pose KeyframedMotion::at(double t) const {
  const std::size_t n = times.size();
  std::size_t i = 0;  // t in [times[i], times[i+1]), clamped at both ends
  double a = 0;
  if (t <= times.front()) {
    i = 0;
  } else if (t >= times.back()) {
    i = n - 1;
  } else {
    i = std::size_t(std::upper_bound(times.begin(), times.end(), t) - times.begin()) - 1;
    a = (t - times[i]) / (times[i + 1] - times[i]);
  }
  const std::size_t j = i + 1 < n ? i + 1 : i;
  const E3 d = (1 - a) * to_eigen(translations[i]) + a * to_eigen(translations[j]);
  EM3 r = EM3::Identity();
  if (!rotations.empty()) r = key_rotation(rotations[i]).slerp(a, key_rotation(rotations[j])).toRotationMatrix();
  return about_pivot(r, d, pivot);
}

void RampMotion::validate() const {
  auto bad = [](const std::string& what) { throw InputError("motion: " + what); };
  for (double v : translation)
    if (!std::isfinite(v)) bad("translation is not finite");
  for (double v : pivot)
    if (!std::isfinite(v)) bad("pivot is not finite");
  if (!std::isfinite(rotation)) bad("rotation is not finite");
  if (rotation != 0 && !(to_eigen(axis).norm() > 0 && std::isfinite(to_eigen(axis).norm())))
    bad("axis must be a finite non-zero vector when rotation is not 0");
  if (!std::isfinite(start_time)) bad("start_time is not finite");
  if (!std::isfinite(duration) || !(duration > 0)) bad("duration must be a finite number > 0");
}

Pose RampMotion::at(double t) const {
  double s = std::clamp((t - start_time) / duration, 0.0, 1.0);
  if (smooth) s = s * s * (3 - 2 * s);
  const EM3 r = rotation != 0 ? Eigen::AngleAxisd(rotation * s, to_eigen(axis).normalized()).toRotationMatrix()
                              : EM3::Identity();
  return about_pivot(r, s * to_eigen(translation), pivot);
}

Pose HostMotion::at(double t) const {
  if (t <= t0_) return p0_;
  if (t >= t1_) return p1_;
  const double a = (t - t0_) / (t1_ - t0_);
  const Eigen::Quaterniond q0(Eigen::Map<const Eigen::Matrix<double, 3, 3, Eigen::RowMajor>>(p0_.rotation.data()));
  const Eigen::Quaterniond q1(Eigen::Map<const Eigen::Matrix<double, 3, 3, Eigen::RowMajor>>(p1_.rotation.data()));
  const EM3 r = q0.slerp(a, q1).toRotationMatrix();
  // the pivot's image X = R c + T on the line from its image at t0 to the
  // one at t1; T = X − R c (c = 0: T linear)
  const E3 c = to_eigen(pivot_);
  const E3 x0 = EM3(Eigen::Map<const Eigen::Matrix<double, 3, 3, Eigen::RowMajor>>(p0_.rotation.data())) * c +
                to_eigen(p0_.translation);
  const E3 x1 = EM3(Eigen::Map<const Eigen::Matrix<double, 3, 3, Eigen::RowMajor>>(p1_.rotation.data())) * c +
                to_eigen(p1_.translation);
  const E3 tr = (1 - a) * x0 + a * x1 - r * c;
  Pose p;
  for (int i = 0; i < 3; ++i) {
    for (int j = 0; j < 3; ++j) p.rotation[3 * i + j] = r(i, j);
    p.translation[i] = tr[i];
  }
  return p;
}

void HostMotion::set_target(double now, const Pose& target, double until, const Vec3& pivot) {
  auto bad = [&](const std::string& what) { throw InputError("driver \"" + name_ + "\": " + what); };
  for (double v : pivot)
    if (!std::isfinite(v)) bad("the pivot is not finite");
  for (double v : target.rotation)
    if (!std::isfinite(v)) bad("the rotation is not finite");
  for (double v : target.translation)
    if (!std::isfinite(v)) bad("the translation is not finite");
  const Eigen::Map<const Eigen::Matrix<double, 3, 3, Eigen::RowMajor>> r(target.rotation.data());
  const double off = (r * r.transpose() - EM3::Identity()).cwiseAbs().maxCoeff();
  if (off > 1e-6 || r.determinant() < 0)
    bad("the rotation is not a proper rotation (|R R^T - I| = " + std::to_string(off) +
        " (at most 1e-6), det = " + std::to_string(r.determinant()) + " (must be 1))");
  if (!std::isfinite(now) || !std::isfinite(until) || until < now)
    bad("the time " + std::to_string(until) + " is before the batch's time " + std::to_string(now));
  // about the pivot: x ↦ R (x − c) + c + t = R x + (t + (c − R c))
  Pose t = target;
  for (int i = 0; i < 3; ++i)
    t.translation[i] =
        target.translation[i] + (pivot[i] - (target.rotation[3 * i] * pivot[0] + target.rotation[3 * i + 1] * pivot[1] +
                                             target.rotation[3 * i + 2] * pivot[2]));
  // re-orthonormalized, so that at() stays a rotation to round-off
  const EM3 q = Eigen::Quaterniond(EM3(r)).normalized().toRotationMatrix();
  for (int i = 0; i < 3; ++i)
    for (int j = 0; j < 3; ++j) t.rotation[3 * i + j] = q(i, j);
  p0_ = until > now ? at(now) : t;
  p1_ = t;
  t0_ = now;
  t1_ = until;
  pivot_ = pivot;
}

RootStep root_step(const RootMotion& motion, double t, double h) {
  RootStep s{motion.at(t), motion.at(t + h), {0, 0, 0}};
  EM3 r0, r1;
  for (int i = 0; i < 3; ++i)
    for (int j = 0; j < 3; ++j) {
      r0(i, j) = s.start.rotation[3 * i + j];
      r1(i, j) = s.end.rotation[3 * i + j];
    }
  const Eigen::AngleAxisd turn(r1 * r0.transpose());
  const E3 w = turn.angle() / h * turn.axis();
  s.omega = {w[0], w[1], w[2]};
  return s;
}

}  // namespace manyrods
