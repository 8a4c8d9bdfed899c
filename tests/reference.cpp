// tests/reference.cpp — see reference.h for the equations and conventions.
#include "reference.h"

#include <cmath>

namespace manyrods::ref {

namespace {

double max_abs(const V3& a) { return a.cwiseAbs().maxCoeff(); }

// A Voronoi point joining element a (−1: the clamp frame) and element a+1.
struct Joint {
  int a;
  double D;
  V3 U0, CM, tauM;
};

std::vector<Joint> joints(const Rod& rod) {
  std::vector<Joint> js;
  if (rod.clamped) js.push_back({-1, rod.D_root, rod.U0_root, rod.CM_root, rod.tauM_root});
  for (int j = 0; j + 1 < rod.elements(); ++j) js.push_back({j, rod.D[j], rod.U0[j], rod.CM[j], rod.tauM[j]});
  return js;
}

void drift(Rod& s, double h) {
  for (std::size_t k = 0; k < s.x.size(); ++k) {
    if (k == 0 && s.clamped) continue;  // the clamped node never moves
    s.x[k] += h * s.v[k];
  }
  for (int e = 0; e < s.elements(); ++e) s.Q[e] = rotation_exp(-h * s.w[e]) * s.Q[e];
}

}  // namespace

M3 skew(const V3& a) {
  M3 s;
  s << 0, -a.z(), a.y(), a.z(), 0, -a.x(), -a.y(), a.x(), 0;
  return s;
}

M3 rotation_exp(const V3& w) {
  const double theta = w.norm();
  if (theta == 0) return M3::Identity();
  return Eigen::AngleAxisd(theta, w / theta).toRotationMatrix();
}

V3 rotation_log(const M3& r) {
  const Eigen::AngleAxisd aa(r);  // angle in [0, π]
  return aa.angle() * aa.axis();
}

M3 inverse_right_jacobian(const V3& psi) {
  const double theta = psi.norm();
  // γ = 1/θ² − (1 + cos θ)/(2 θ sin θ), written with (1 + cos θ)/sin θ =
  // 1/tan(θ/2) so that it stays finite up to θ = π. The cancellation at small
  // θ costs u/θ² in γ, which multiplies [ψ]×² = O(θ²): an error of order u in
  // J_r⁻¹ for every θ. Below θ = 1e-4 the series 1/12 + θ²/720 (next term
  // θ⁴/30240 < 4e-21) avoids 0/0.
  const double gamma = theta < 1e-4 ? 1.0 / 12 + theta * theta / 720
                                    : 1 / (theta * theta) - 1 / (2 * theta * std::tan(theta / 2));
  const M3 s = skew(psi);
  return M3::Identity() + 0.5 * s + gamma * s * s;
}

Rod with_terms(const Rod& rod, Terms t) {
  Rod r = rod;
  auto gate = [&](V3& c, bool on12, bool on3) {
    if (!on12) c.x() = c.y() = 0;
    if (!on3) c.z() = 0;
  };
  for (auto& c : r.CF) gate(c, t.shear, t.stretch);
  for (auto& c : r.CM) gate(c, t.bend, t.twist);
  gate(r.CM_root, t.bend, t.twist);
  if (!t.kelvin_voigt) {
    for (auto& a : r.tauF) a.setZero();
    for (auto& a : r.tauM) a.setZero();
    r.tauM_root.setZero();
  }
  if (!t.gravity) r.g.setZero();
  if (!t.loads) {
    for (auto& f : r.f_ext) f.setZero();
    for (auto& c : r.c_ext) c.setZero();
  }
  return r;
}

Evaluation evaluate(const Rod& rod0, Terms terms, bool positions_rounded) {
  const Rod rod = with_terms(rod0, terms);
  const int n = rod.elements();
  const double rnd = positions_rounded ? 1 : 0;
  Evaluation ev;
  ev.sigma.resize(n);
  ev.sigma_rate.resize(n);
  ev.n.resize(n);
  ev.sigma_scale.resize(n);
  ev.sigma_rate_scale.resize(n);
  ev.n_scale.resize(n);
  std::vector<V3> Qe(n);
  std::vector<double> Qe_scale(n);

  // ---- elements
  for (int e = 0; e < n; ++e) {
    const M3& Q = rod.Q[e];
    const V3 E = rod.x[e + 1] - rod.x[e];
    Qe[e] = Q * E;
    Qe_scale[e] = E.norm() + rnd * (rod.x[e].norm() + rod.x[e + 1].norm());
    const double l = rod.l0[e];
    ev.sigma[e] = Qe[e] / l - rod.V0[e];
    ev.sigma_scale[e] = Qe_scale[e] / l + rod.V0[e].norm();
    const V3 dv = rod.v[e + 1] - rod.v[e];
    ev.sigma_rate[e] = (Q * dv - rod.w[e].cross(Qe[e])) / l;
    const double dv_scale = dv.norm() + rnd * (rod.v[e].norm() + rod.v[e + 1].norm());
    ev.sigma_rate_scale[e] = (dv_scale + rod.w[e].norm() * Qe_scale[e]) / l;
    const V3 visc = rod.CF[e].cwiseProduct(rod.tauF[e]);
    ev.n[e] = rod.CF[e].cwiseProduct(ev.sigma[e]) + visc.cwiseProduct(ev.sigma_rate[e]);
    ev.n_scale[e] = max_abs(rod.CF[e]) * ev.sigma_scale[e] + max_abs(visc) * ev.sigma_rate_scale[e];
  }

  // ---- Voronoi points (joints)
  const std::vector<Joint> js = joints(rod);
  std::vector<V3> jon_a(js.size(), V3::Zero()), jon_b(js.size(), V3::Zero());
  std::vector<double> jcouple_scale(js.size(), 0);
  ev.kappa.resize(std::max(n - 1, 0));
  ev.kappa_rate.resize(std::max(n - 1, 0));
  ev.m.resize(std::max(n - 1, 0));
  ev.kxm.resize(std::max(n - 1, 0));
  ev.on_a.resize(std::max(n - 1, 0));
  ev.on_b.resize(std::max(n - 1, 0));
  ev.joint_couple_scale.resize(std::max(n - 1, 0));
  ev.kappa_scale.resize(std::max(n - 1, 0));
  ev.kappa_rate_scale.resize(std::max(n - 1, 0));
  ev.m_scale.resize(std::max(n - 1, 0));
  for (std::size_t i = 0; i < js.size(); ++i) {
    const Joint& j = js[i];
    const int b = j.a + 1;
    const M3 Qa = j.a < 0 ? rod.Q_clamp : rod.Q[j.a];
    const V3 wa = j.a < 0 ? V3::Zero() : rod.w[j.a];
    const M3& Qb = rod.Q[b];
    const V3& wb = rod.w[b];
    const M3 R = Qb * Qa.transpose();
    const V3 psi = rotation_log(R);
    const double theta = psi.norm();
    const V3 kappa = -psi / j.D;
    const V3 d = R.transpose() * wb - wa;
    const M3 jr_inv = inverse_right_jacobian(psi);
    const V3 kappa_rate = jr_inv * d / j.D;
    // Scales. R's entries are O(1) sums of three products; the log map
    // amplifies their error by at most |J_r⁻¹| ≤ π/2 (θ ≤ π), and the angle
    // itself carries θ·u: ψ_scale = 4 + θ. J_r⁻¹'s norm is at most
    // 1 + θ/2 + γθ²; a perturbation δψ of ψ changes J_r⁻¹ d by O(|d| δψ).
    const double psi_scale = 4 + theta;
    const double gamma =
        theta < 1e-4 ? 1.0 / 12 : 1 / (theta * theta) - 1 / (2 * theta * std::tan(theta / 2));
    const double jr_scale = 1 + theta / 2 + gamma * theta * theta;
    const double kappa_scale = psi_scale / j.D + j.U0.norm();
    const double kappa_rate_scale = (jr_scale * (wa.norm() + wb.norm()) + d.norm() * psi_scale) / j.D;
    const V3 visc = j.CM.cwiseProduct(j.tauM);
    const V3 m = j.CM.cwiseProduct(kappa - j.U0) + visc.cwiseProduct(kappa_rate);
    const double m_scale = max_abs(j.CM) * kappa_scale + max_abs(visc) * kappa_rate_scale;
    const V3 kxm = j.D * kappa.cross(m);
    // the joint's couples on its two elements (see reference.h)
    jon_a[i] = jr_inv.transpose() * m;
    jon_b[i] = -(jr_inv * m);
    // J_r⁻¹ has norm ≤ jr_scale and changes by O(δψ) when ψ does
    jcouple_scale[i] = jr_scale * m_scale + m.norm() * psi_scale;
    if (j.a < 0) {
      ev.root_kappa = kappa;
      ev.root_kappa_rate = kappa_rate;
      ev.root_m = m;
      ev.root_kxm = kxm;
      ev.root_on_a = jon_a[i];
      ev.root_on_b = jon_b[i];
      ev.root_kappa_scale = kappa_scale;
      ev.root_kappa_rate_scale = kappa_rate_scale;
      ev.root_m_scale = m_scale;
      ev.root_joint_couple_scale = jcouple_scale[i];
    } else {
      ev.kappa[j.a] = kappa;
      ev.kappa_rate[j.a] = kappa_rate;
      ev.m[j.a] = m;
      ev.kxm[j.a] = kxm;
      ev.on_a[j.a] = jon_a[i];
      ev.on_b[j.a] = jon_b[i];
      ev.kappa_scale[j.a] = kappa_scale;
      ev.kappa_rate_scale[j.a] = kappa_rate_scale;
      ev.m_scale[j.a] = m_scale;
      ev.joint_couple_scale[j.a] = jcouple_scale[i];
    }
  }

  // ---- node forces (lab): Qᵀn of the element on the tip side minus that of
  // the element on the root side, plus gravity and the point force.
  ev.force.assign(n + 1, V3::Zero());
  ev.force_scale.assign(n + 1, 0);
  for (int k = 0; k <= n; ++k) {
    V3 f = rod.mass[k] * rod.g + rod.f_ext[k];
    double s = rod.mass[k] * rod.g.norm() + rod.f_ext[k].norm();
    if (k < n) {
      f += rod.Q[k].transpose() * ev.n[k];
      s += ev.n_scale[k];
    }
    if (k > 0) {
      f -= rod.Q[k - 1].transpose() * ev.n[k - 1];
      s += ev.n_scale[k - 1];
    }
    ev.force[k] = f;
    ev.force_scale[k] = s;
  }

  // ---- element couples (material)
  ev.couple.assign(n, V3::Zero());
  ev.inertial_couple.assign(n, V3::Zero());
  ev.applied_couple.assign(n, V3::Zero());
  ev.couple_scale.assign(n, 0);
  // joint index on the root side / tip side of element e, −1 if none
  const int root_offset = rod.clamped ? 1 : 0;  // js[i] with a = e−1 sits at i = e − 1 + root_offset
  for (int e = 0; e < n; ++e) {
    const int jr = (e > 0 || rod.clamped) ? e - 1 + root_offset : -1;
    const int jt = (e + 1 < n) ? e + root_offset : -1;
    V3 c = V3::Zero();
    double s = 0;
    if (jt >= 0) {  // e is element a of the joint on its tip side
      c += jon_a[jt];
      s += jcouple_scale[jt];
    }
    if (jr >= 0) {  // e is element b of the joint on its root side
      c += jon_b[jr];
      s += jcouple_scale[jr];
    }
    c += Qe[e].cross(ev.n[e]);
    s += Qe_scale[e] * ev.n[e].norm() + Qe[e].norm() * ev.n_scale[e];
    c += rod.Q[e] * rod.c_ext[e];
    s += rod.c_ext[e].norm();
    ev.applied_couple[e] = c;
    const V3& w = rod.w[e];
    ev.inertial_couple[e] = rod.J[e].cwiseProduct(w).cross(w);
    s += 2 * max_abs(rod.J[e]) * w.squaredNorm();
    ev.couple[e] = c + ev.inertial_couple[e];
    ev.couple_scale[e] = s;
  }
  return ev;
}

Energies energies(const Rod& rod0, Terms terms) {
  const Rod rod = with_terms(rod0, terms);
  const Evaluation ev = evaluate(rod0, terms);
  const int n = rod.elements();
  Energies en;
  for (int k = 0; k <= n; ++k) {
    en.kinetic += 0.5 * rod.mass[k] * rod.v[k].squaredNorm();
    const V3 f = rod.mass[k] * rod.g + rod.f_ext[k];
    en.potential -= f.dot(rod.x[k]);
    en.potential_scale += (rod.mass[k] * rod.g.norm() + rod.f_ext[k].norm()) * rod.x[k].norm();
  }
  for (int e = 0; e < n; ++e) {
    const V3& w = rod.w[e];
    en.kinetic += 0.5 * w.dot(rod.J[e].cwiseProduct(w));
    const double l = rod.l0[e];
    const V3& s = ev.sigma[e];
    en.elastic += 0.5 * l * s.dot(rod.CF[e].cwiseProduct(s));
    en.elastic_scale += l * max_abs(rod.CF[e]) * s.norm() * ev.sigma_scale[e];
    const V3& sr = ev.sigma_rate[e];
    const V3 visc = rod.CF[e].cwiseProduct(rod.tauF[e]);
    en.dissipation += l * sr.dot(visc.cwiseProduct(sr));
    en.dissipation_scale += 2 * l * max_abs(visc) * sr.norm() * ev.sigma_rate_scale[e];
  }
  auto joint = [&](double D, const V3& U0, const V3& CM, const V3& tauM, const V3& kappa,
                   const V3& kappa_rate, double kappa_scale, double kappa_rate_scale) {
    const V3 dk = kappa - U0;
    en.elastic += 0.5 * D * dk.dot(CM.cwiseProduct(dk));
    en.elastic_scale += D * max_abs(CM) * dk.norm() * kappa_scale;
    const V3 visc = CM.cwiseProduct(tauM);
    en.dissipation += D * kappa_rate.dot(visc.cwiseProduct(kappa_rate));
    en.dissipation_scale += 2 * D * max_abs(visc) * kappa_rate.norm() * kappa_rate_scale;
  };
  for (int j = 0; j + 1 < n; ++j)
    joint(rod.D[j], rod.U0[j], rod.CM[j], rod.tauM[j], ev.kappa[j], ev.kappa_rate[j], ev.kappa_scale[j],
          ev.kappa_rate_scale[j]);
  if (rod.clamped)
    joint(rod.D_root, rod.U0_root, rod.CM_root, rod.tauM_root, ev.root_kappa, ev.root_kappa_rate,
          ev.root_kappa_scale, ev.root_kappa_rate_scale);
  en.kinetic_scale = en.kinetic;  // a sum of non-negative terms
  return en;
}

Rod step(const Rod& rod, double h, Terms terms, int euler_evaluations) {
  Rod s = rod;
  drift(s, 0.5 * h);
  const Evaluation ev = evaluate(s, terms);
  for (std::size_t k = 0; k < s.x.size(); ++k) {
    if (k == 0 && s.clamped) continue;
    s.v[k] += (h / s.mass[k]) * ev.force[k];
  }
  for (int e = 0; e < s.elements(); ++e) {
    // implicit midpoint for (Jω)×ω: ω⁺ = Φ(ω⁺), Φ(w) = ω + h J⁻¹(C + (Jω̄)×ω̄), ω̄ = (ω + w)/2
    const V3 J = s.J[e], w0 = s.w[e], C = ev.applied_couple[e];
    auto phi = [&](const V3& w) {
      const V3 wb = 0.5 * (w0 + w);
      return V3(w0 + h * (C + J.cwiseProduct(wb).cross(wb)).cwiseQuotient(J));
    };
    V3 w = w0;
    if (euler_evaluations >= 0) {
      for (int i = 0; i < euler_evaluations; ++i) w = phi(w);
    } else {
      for (int i = 0; i < 200; ++i) {
        const V3 next = phi(w);
        const bool done = (next - w).norm() <= 1e-16 * next.norm();
        w = next;
        if (done) break;
      }
    }
    s.w[e] = w;
  }
  drift(s, 0.5 * h);
  return s;
}

}  // namespace manyrods::ref
