// host/scene/run/validity.h — the validity monitor of a scene run (docs/scenes.md "The
// validity monitor"): at every sample point it checks that the run stays
// where the model holds and the numbers mean something —
//   strain   the largest strain of a rod (max |σ| over its elements, max
//            |κ − U0|·width/2 over its joints) above Validity::strain: the
//            seed's linear Kelvin–Voigt law is a small-strain model;
//   stretch  an element stretched or sheared beyond Validity::stretch (|σ|);
//   energy   kinetic + elastic + potential − contact work above its value at
//            the start by Validity::energy_growth × the energy scale (the
//            largest kinetic + elastic energy seen, and at least Σ m g L over
//            the rods under gravity: never ~0 for rods at rest), in a scene
//            with no source of work (driven
//            roots, tip forces, moving colliders): an unstable or too coarse
//            step. Damping only lowers it; the dissipated energy is not
//            added back, because its sampled integral is biased where the
//            implicit solve overdamps (stiff rods, h τ ω² ≫ 1).
// The first violation of each kind is reported at once (rod, element or
// joint, time, value); summary() lists every kind seen. Cost: one strain
// evaluation per element and joint every 64 steps.
#pragma once

#include <cmath>
#include <cstdio>
#include <string>
#include <vector>

#include "manyrods/scene.h"

namespace manyrods::scene {

template <class T>
class ValidityMonitor {
 public:
  // e0: the energies where the run starts; a continued run passes the
  // reference it had (energy0(), scale(), kept in the checkpoint), so that
  // it judges as the uninterrupted run does
  ValidityMonitor(const Scene& s, const RodBatch<T>& b, const Energies& e0, double energy0 = NAN,
                  double scale = NAN)
      : s_(s), lim_(s.sim.validity) {
    e0_ = std::isnan(energy0) ? budget(e0) : energy0;
    scale_ = std::max(std::isnan(scale) ? e0.kinetic + e0.elastic : scale, weight_scale(b));
    source_ = !b.driven.empty() || b.any_fluid();  // (a fluid: buoyancy and wind do work)
    for (const RodGroup& g : s.groups)
      if (g.tip_force[0] != 0 || g.tip_force[1] != 0 || g.tip_force[2] != 0) source_ = true;
    for (const Collider& c : s.contact.colliders)
      if (c.motion) source_ = true;
  }

  // Checks the state at time t (energies e); messages of new kinds of
  // violation are appended to `out`.
  void check(const RodBatch<T>& b, const Energies& e, double t, std::vector<std::string>& out) {
    for (int r = 0; r < b.rod_count(); ++r) {
      const StrainPeak p = strain_peak(b, r, s_.groups[s_.rod_group[r]].width);
      if (!(p.value <= lim_.strain))
        note(kStrain, r, p.value, t,
             std::string(p.bending ? "joint " : "element ") + std::to_string(p.where) +
                 (p.bending ? " (bending/twist)" : " (stretch/shear)"),
             out, b);
      if (!(p.stretch <= lim_.stretch))
        note(kStretch, r, p.stretch, t, "element " + std::to_string(p.stretch_element), out, b);
    }
    scale_ = std::max(scale_, e.kinetic + e.elastic);
    const double gain = budget(e) - e0_;
    if (!source_ && scale_ > 0 && !(gain <= lim_.energy_growth * scale_))
      note(kEnergy, -1, gain / scale_, t, "", out, b);
  }

  double energy0() const { return e0_; }
  double scale() const { return scale_; }

  // One line per kind seen, e.g. "strain above 0.05 in 12 of 64 rods, worst
  // 0.31 (rod 3 'hair[3]' joint 5 at t = 0.4 s)".
  std::vector<std::string> summary(int rods) const {
    std::vector<std::string> lines;
    for (int k = 0; k < 3; ++k) {
      const Kind& x = kinds_[k];
      if (x.count == 0) continue;
      char buf[1024];
      if (k == kEnergy)
        std::snprintf(buf, sizeof buf, "energy grew without a source by up to %.3g x the energy scale (the largest "
                      "kinetic + elastic energy, at least m g L) (limit %.3g), first at t = %.6g s: too coarse or "
                      "unstable a step "
                      "(limit: simulation.validity.energy_growth)",
                      x.worst, lim_.energy_growth, x.first_time);
      else
        std::snprintf(buf, sizeof buf, "%s above %.3g in %d of %d rods, worst %.3g (%s at t = %.6g s): %s",
                      k == kStrain ? "strain" : "element stretch/shear", k == kStrain ? lim_.strain : lim_.stretch,
                      x.rods, rods, x.worst, x.worst_where.c_str(), x.worst_time,
                      k == kStrain ? "beyond the linear law's small strains (limit: simulation.validity.strain)"
                                   : "outside any rod model (limit: simulation.validity.stretch)");
      lines.push_back(buf);
    }
    return lines;
  }

 private:
  enum { kStrain = 0, kStretch = 1, kEnergy = 2 };
  struct Kind {
    std::int64_t count = 0;
    int rods = 0;
    double worst = 0, worst_time = 0, first_time = 0;
    std::string worst_where;
    std::vector<char> seen;  // [rods]
  };

  static double budget(const Energies& e) { return e.total() - e.contact_work; }

  // Σ over the rods of m g L (mass, |gravity|, rest length): the energy of a
  // rod's weight over its own length, the scale of a scene under gravity
  // whatever its motion (a rod at rest has kinetic + elastic energy ~0).
  static double weight_scale(const RodBatch<T>& b) {
    const double g = std::hypot(double(b.model.gravity[0]), double(b.model.gravity[1]), double(b.model.gravity[2]));
    double sum = 0;
    for (int r = 0; r < b.rod_count(); ++r) {
      double m = 0, l = 0;
      for (int i = 0; i <= b.elements(r); ++i) m += double(b.model.node_mass[b.node_index(r, i)]);
      for (int e = 0; e < b.elements(r); ++e) l += double(b.model.elem_rest_length[b.elem_index(r, e)]);
      sum += m * g * l;
    }
    return sum;
  }

  void note(int kind, int rod, double value, double t, const std::string& where, std::vector<std::string>& out,
            const RodBatch<T>& b) {
    Kind& k = kinds_[kind];
    const std::string at =
        rod < 0 ? std::string("the batch") : "rod " + std::to_string(rod) + " ('" + b.rods[rod].name + "') " + where;
    if (k.count == 0) {
      k.first_time = t;
      char buf[1024];
      // two lines: what the limit protects, then how to judge the run and
      // where the limit is set (docs/scenes.md "The validity monitor")
      if (kind == kEnergy)
        std::snprintf(buf, sizeof buf,
                      "validity: at t = %.6g s the energy has grown by %.3g x the energy scale (the largest kinetic + "
                      "elastic energy, at least m g L) (limit %.3g) with no source of work: the step is too coarse or "
                      "unstable\n"
                      "  to judge: rerun with half the step (halve dt_safety, or dt): if the growth shrinks, it was "
                      "the step; the limit is simulation.validity.energy_growth",
                      t, value, lim_.energy_growth);
      else if (kind == kStrain)
        std::snprintf(buf, sizeof buf,
                      "validity: at t = %.6g s %s has strain %.3g (limit %.3g): beyond the small strains of the "
                      "linear Kelvin-Voigt law (large rotations are fine, large strains are not)\n"
                      "  to judge: rerun with half the step (dt_safety) or more elements: a peak that goes away was "
                      "numerical; one that stays is real: if the material is linear that far, raise "
                      "simulation.validity.strain",
                      t, at.c_str(), value, lim_.strain);
      else
        std::snprintf(buf, sizeof buf,
                      "validity: at t = %.6g s %s has stretch/shear |sigma| %.3g (limit %.3g): an element this "
                      "deformed is outside any rod model (an unstable step, or contact forcing it)\n"
                      "  to judge: rerun with half the step (halve dt_safety; stiff = true for hair): if it goes away, "
                      "it was the step; the limit is simulation.validity.stretch",
                      t, at.c_str(), value, lim_.stretch);
      out.push_back(buf);
    }
    ++k.count;
    if (rod >= 0) {
      if (k.seen.empty()) k.seen.assign(std::size_t(b.rod_count()), 0);
      if (!k.seen[std::size_t(rod)]) {
        k.seen[std::size_t(rod)] = 1;
        ++k.rods;
      }
    }
    if (!(value <= k.worst)) {
      k.worst = value;
      k.worst_time = t;
      k.worst_where = at;
    }
  }

  const Scene& s_;
  Validity lim_;
  double e0_ = 0, scale_ = 0;
  bool source_ = false;
  Kind kinds_[3];
};

}  // namespace manyrods::scene
