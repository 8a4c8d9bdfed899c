// host/core/model/material.cpp — section properties, elastic constants, and the
// Kelvin–Voigt parameter forms, validated at the boundary.
#include <algorithm>
#include "manyrods/material.h"

#include <cmath>
#include <numbers>
#include <sstream>

namespace manyrods {
namespace {

[[noreturn]] void fail(const std::string& field, double value, const std::string& why) {
  std::ostringstream os;
  os.precision(17);
  os << field << " = " << value << ": " << why;
  throw InputError(os.str());
}

void require_positive(const std::string& field, double v) {
  if (!std::isfinite(v)) fail(field, v, "must be a finite number");
  if (!(v > 0)) fail(field, v, "must be > 0");
}

void require_non_negative(const std::string& field, double v) {
  if (!std::isfinite(v)) fail(field, v, "must be a finite number");
  if (v < 0) fail(field, v, "must be >= 0");
}

// Cowper (1966) shear coefficient of an ellipse, shear along the semi-axis a.
double cowper_ellipse(double a, double b, double nu) {
  const double a2 = a * a, b2 = b * b;
  return 12 * (1 + nu) * a2 * (3 * a2 + b2) /
         ((40 + 37 * nu) * a2 * a2 + (16 + 10 * nu) * a2 * b2 + nu * b2 * b2);
}

// Saint-Venant torsion constant of a rectangle (series solution).
double rectangle_torsion_constant(double w, double h) {
  const double L = std::max(w, h), s = std::min(w, h);
  double sum = 0;
  for (int n = 1; n < 200; n += 2) sum += std::tanh(n * std::numbers::pi * L / (2 * s)) / std::pow(n, 5);
  return L * s * s * s / 3 * (1 - 192 / std::pow(std::numbers::pi, 5) * (s / L) * sum);
}

}  // namespace

double contact_radius(const Section& sec) {
  switch (sec.shape) {
    case Shape::ellipse: return std::max(sec.a, sec.b);
    case Shape::rectangle: return 0.5 * std::hypot(sec.a, sec.b);
    default: return sec.a;  // circle, hollow circle: the outer radius
  }
}

SectionProperties section_properties(const Section& sec, double nu) {
  const double pi = std::numbers::pi;
  SectionProperties p{};
  switch (sec.shape) {
    case Shape::circle: {
      require_positive("section.radius", sec.a);
      const double r = sec.a;
      p.area = pi * r * r;
      p.I1 = p.I2 = pi * r * r * r * r / 4;
      p.torsion_constant = pi * r * r * r * r / 2;
      p.shear_factor1 = p.shear_factor2 = 6 * (1 + nu) / (7 + 6 * nu);
      break;
    }
    case Shape::ellipse: {
      require_positive("section.semi_axes[0]", sec.a);
      require_positive("section.semi_axes[1]", sec.b);
      const double a = sec.a, b = sec.b;  // along d1, d2
      p.area = pi * a * b;
      p.I1 = pi * a * b * b * b / 4;  // ∫ξ2² dA
      p.I2 = pi * a * a * a * b / 4;  // ∫ξ1² dA
      p.torsion_constant = pi * a * a * a * b * b * b / (a * a + b * b);
      p.shear_factor1 = cowper_ellipse(a, b, nu);
      p.shear_factor2 = cowper_ellipse(b, a, nu);
      break;
    }
    case Shape::rectangle: {
      require_positive("section.width", sec.a);
      require_positive("section.height", sec.b);
      const double w = sec.a, h = sec.b;  // along d1, d2
      p.area = w * h;
      p.I1 = w * h * h * h / 12;
      p.I2 = h * w * w * w / 12;
      p.torsion_constant = rectangle_torsion_constant(w, h);
      p.shear_factor1 = p.shear_factor2 = 10 * (1 + nu) / (12 + 11 * nu);
      break;
    }
    case Shape::hollow_circle: {
      require_positive("section.outer_radius", sec.a);
      require_non_negative("section.inner_radius", sec.b);
      if (!(sec.b < sec.a)) fail("section.inner_radius", sec.b, "must be < outer_radius");
      const double ro = sec.a, ri = sec.b, m2 = (ri / ro) * (ri / ro);
      p.area = pi * (ro * ro - ri * ri);
      p.I1 = p.I2 = pi * (ro * ro * ro * ro - ri * ri * ri * ri) / 4;
      p.torsion_constant = 2 * p.I1;
      const double q = (1 + m2) * (1 + m2);
      p.shear_factor1 = p.shear_factor2 =
          6 * (1 + nu) * q / ((7 + 6 * nu) * q + (20 + 12 * nu) * m2);
      break;
    }
    default:
      throw InputError("section.shape: unknown shape");
  }
  // 0 < κα ≤ 1 (docs/model.md "Cross sections"). Cowper's ellipse formula leaves that range (its
  // denominator changes sign) for flat ellipses of auxetic materials, e.g.
  // ν = −0.5 with a semi-axis ratio below about 0.3; a negative shear
  // stiffness would follow silently, so such input is rejected.
  for (const double k : {p.shear_factor1, p.shear_factor2})
    if (!(k > 0 && k <= 1))
      fail("section.shear_factor", k,
           "Cowper's shear correction factor for this section with material.poisson_ratio = " +
               std::to_string(nu) + " lies outside (0, 1] (flat ellipse, poisson_ratio < 0)");
  p.I3 = p.I1 + p.I2;
  return p;
}

ElasticConstants resolve_material(const Material& m) {
  require_positive("material.density", m.density);
  require_positive("material.youngs_modulus", m.youngs_modulus);
  const bool has_nu = !std::isnan(m.poisson_ratio), has_g = !std::isnan(m.shear_modulus);
  if (has_nu == has_g)
    throw InputError("material: give exactly one of poisson_ratio and shear_modulus");
  ElasticConstants c{m.density, m.youngs_modulus, 0, 0};
  if (has_nu) {
    c.nu = m.poisson_ratio;
    if (!std::isfinite(c.nu) || !(c.nu > -1 && c.nu <= 0.5))
      fail("material.poisson_ratio", c.nu, "must lie in (-1, 0.5]");
    c.G = c.E / (2 * (1 + c.nu));
  } else {
    require_positive("material.shear_modulus", m.shear_modulus);
    c.G = m.shear_modulus;
    c.nu = c.E / (2 * c.G) - 1;
    if (!(c.nu > -1 && c.nu <= 0.5 + 1e-12))
      fail("material.shear_modulus", c.G,
           "implies poisson_ratio = E/(2G) - 1 = " + std::to_string(c.nu) + " outside (-1, 0.5]");
    c.nu = std::min(c.nu, 0.5);
  }
  return c;
}

RetardationTimes resolve_damping(const Damping& d, const ElasticConstants& c) {
  const double nu = c.nu, one_m_2nu = 1 - 2 * nu;
  RetardationTimes t;
  switch (d.form) {
    case Damping::Form::none:
      return t;
    case Damping::Form::shear_bulk:
      require_non_negative("damping.tau_shear", d.p1);
      require_non_negative("damping.tau_bulk", d.p2);
      t.shear = d.p1;
      t.bulk = d.p2;
      t.extension = (one_m_2nu * t.bulk + 2 * (1 + nu) * t.shear) / 3;
      return t;
    case Damping::Form::shear_extension: {
      require_non_negative("damping.tau_shear", d.p1);
      require_non_negative("damping.tau_extension", d.p2);
      t.shear = d.p1;
      t.extension = d.p2;
      const double tau_e_min = 2 * (1 + nu) * t.shear / 3;  // τE at τB = 0
      if (one_m_2nu < 1e-12) {  // ν = ½: τE = τS whatever τB
        if (std::abs(t.extension - t.shear) > 1e-12 * std::max(t.shear, t.extension))
          fail("damping.tau_extension", t.extension,
               "must equal tau_shear when poisson_ratio = 0.5 (incompressible: tau_E = tau_S)");
        t.bulk = std::numeric_limits<double>::quiet_NaN();
        return t;
      }
      if (t.extension < tau_e_min * (1 - 1e-12))
        fail("damping.tau_extension", t.extension,
             "implies a negative bulk viscosity (tau_B < 0): tau_extension must be >= "
             "2(1+nu)/3 * tau_shear = " + std::to_string(tau_e_min));
      t.bulk = std::max(0.0, (3 * t.extension - 2 * (1 + nu) * t.shear) / one_m_2nu);
      return t;
    }
    case Damping::Form::viscosities: {
      require_non_negative("damping.shear_viscosity", d.p1);
      require_non_negative("damping.bulk_viscosity", d.p2);
      t.shear = d.p1 / c.G;
      // K = E/(3(1−2ν)) → ∞ at ν = ½, where τB = ζ/K = 0.
      t.bulk = one_m_2nu < 1e-12 ? 0.0 : d.p2 * 3 * one_m_2nu / c.E;
      t.extension = (one_m_2nu * t.bulk + 2 * (1 + nu) * t.shear) / 3;
      return t;
    }
  }
  throw InputError("damping: unknown form");
}

}  // namespace manyrods
