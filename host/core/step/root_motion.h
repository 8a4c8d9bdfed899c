// host/core/step/root_motion.h — the driven holds of a segment (roots, tips, interior
// nodes on a rigid motion) put on their motion for one step or drift
// (include/manyrods/drive.h explains the scheme).
#pragma once

#include "kernels/views.h"
#include "manyrods/batch.h"

namespace manyrods {

// The driven holds of segment r at the start of a step (Position Verlet) or
// drift (PEFRL) [t, t + h]: the held node at x(t) with the mean velocity
// (x(t + h) − x(t))/h, each held frame (a root's or tip's clamp frame in its
// ghost element, the two elements of a clamped interior node) at Q(t) with
// the angular velocity that turns it into Q(t + h), so that the drifts end
// exactly at the pose of t + h (h < 0 for PEFRL's backward drifts). Each
// segment evaluates the motions it uses. Computed in double, stored in T.
// reads: driven holds, motions  writes: state of the held nodes and frames
template <class T>
void apply_motions(RodBatch<T>& b, const Segment& r, double t, double h) {
  const StateView<T> s = b.state_view();
  int last = -1;
  RootStep st;
  mat3<double> r0, r1;
  vec3<double> c0, c1, omega;
  auto mat = [](const Mat3& a) {
    mat3<double> m;
    for (int i = 0; i < 9; ++i) m.m[i] = a[i];
    return m;
  };
  auto vec = [](const Vec3& a) { return vec3<double>{a[0], a[1], a[2]}; };
  for (int i = r.driven_begin; i < r.driven_end; ++i) {
    const DrivenHold& d = b.driven[i];
    if (d.motion != last) {
      st = root_step(*b.motions[d.motion], t, h);
      last = d.motion;
      r0 = mat(st.start.rotation);
      r1 = mat(st.end.rotation);
      c0 = vec(st.start.translation);
      c1 = vec(st.end.translation);
      omega = vec(st.omega);
    }
    const int k = d.node;
    const vec3<double> x0 = mul_add(r0, vec(d.x0), c0), x1 = mul_add(r1, vec(d.x0), c1);
    store3(s.node_x, k, vec3<T>{T(x0.x), T(x0.y), T(x0.z)});
    const vec3<double> dx = x1 - x0;
    store3(s.node_v, k, vec3<T>{T(dx.x / h), T(dx.y / h), T(dx.z / h)});
    if constexpr (sizeof(T) == 4) store3(s.node_xc, k, vec3<T>{T(0), T(0), T(0)});
    for (int f = 0; f < 2; ++f) {
      const int g = d.frame[f];
      if (g < 0) continue;
      const mat3<double> q = mul_transpose(mat(d.q0[f]), r0);  // Q(t) = Q₀ R(t)ᵀ
      for (int j = 0; j < 9; ++j) s.elem_Q[j][g] = T(q.m[j]);
      const vec3<double> w = mul(q, omega);  // material components: ω = Q(t) Ω
      store3(s.elem_w, g, vec3<T>{T(w.x), T(w.y), T(w.z)});
    }
  }
}

}  // namespace manyrods
