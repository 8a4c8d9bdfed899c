// include/manyrods/material.h — cross sections, elastic material and
// Kelvin–Voigt parameters (seed: Linn, Lang & Tuganov, Mech. Sci. 4, 2013).
//
// Units are SI throughout manyrods: m, kg, s, N, Pa, Pa·s.
//
// Retardation times (seed eq. 4–6), ν Poisson's ratio, K = E/(3(1 − 2ν)):
//   τS = η/G (shear),  τB = ζ/K (bulk),
//   τE = [(1 − 2ν) τB + 2(1 + ν) τS] / 3 (extension),  η_E = E τE.
// A rod's viscous law uses τS for shear and torsion and τE for stretch and
// bending: V_F = C_F diag(τS, τS, τE), V_M = C_M diag(τE, τE, τS).
#pragma once

#include <limits>
#include <stdexcept>
#include <string>

namespace manyrods {

// Every invalid input raises InputError; what() names the rod and the field.
struct InputError : std::invalid_argument {
  using std::invalid_argument::invalid_argument;
};

enum class Shape { circle, ellipse, rectangle, hollow_circle };

// Principal axes of the section are d1 and d2.
struct Section {
  Shape shape = Shape::circle;
  double a = 0;  // circle: radius; ellipse: semi-axis along d1; rectangle: width along d1;
                 // hollow circle: outer radius
  double b = 0;  // ellipse: semi-axis along d2; rectangle: height along d2; hollow: inner radius

  static Section circle(double radius) { return {Shape::circle, radius, radius}; }
  static Section ellipse(double semi_axis_1, double semi_axis_2) {
    return {Shape::ellipse, semi_axis_1, semi_axis_2};
  }
  static Section rectangle(double width_1, double height_2) {
    return {Shape::rectangle, width_1, height_2};
  }
  static Section hollow_circle(double outer_radius, double inner_radius) {
    return {Shape::hollow_circle, outer_radius, inner_radius};
  }
};

// I1 = ∫ξ2² dA resists bending about d1, I2 = ∫ξ1² dA about d2, I3 = I1 + I2
// (polar moment, rotary inertia), J_T ≤ I3 the torsion constant (G·J_T is the
// torsional stiffness), κ1, κ2 ≤ 1 the shear correction factors for shear
// along d1 and d2 (Cowper 1966, which depend on ν).
struct SectionProperties {
  double area, I1, I2, I3, torsion_constant, shear_factor1, shear_factor2;
};

SectionProperties section_properties(const Section& section, double poisson_ratio);

// The radius of the circle that holds the section (its own radius for a
// circle; ellipse: the larger semi-axis; rectangle: half the diagonal):
// contact treats every rod as the tube it sweeps (include/manyrods/contact.h).
double contact_radius(const Section& section);

// Give poisson_ratio OR shear_modulus (G = E / (2(1 + ν))).
struct Material {
  double density = 0;          // kg/m³
  double youngs_modulus = 0;   // Pa
  double poisson_ratio = std::numeric_limits<double>::quiet_NaN();
  double shear_modulus = std::numeric_limits<double>::quiet_NaN();  // Pa
};

struct ElasticConstants {
  double density, E, G, nu;
};

ElasticConstants resolve_material(const Material& material);

// Kelvin–Voigt parameters in one of three equivalent forms.
struct Damping {
  enum class Form { none, shear_bulk, shear_extension, viscosities };
  Form form = Form::none;
  double p1 = 0, p2 = 0;

  static Damping none() { return {}; }
  // retardation times τS and τB (s)
  static Damping shear_bulk(double tau_shear, double tau_bulk) {
    return {Form::shear_bulk, tau_shear, tau_bulk};
  }
  // retardation times τS and τE (s); τB follows and must not be negative
  static Damping shear_extension(double tau_shear, double tau_extension) {
    return {Form::shear_extension, tau_shear, tau_extension};
  }
  // shear viscosity η and bulk viscosity ζ (Pa·s)
  static Damping viscosities(double shear_viscosity, double bulk_viscosity) {
    return {Form::viscosities, shear_viscosity, bulk_viscosity};
  }
};

// All three retardation times; bulk is NaN where it is undetermined
// (ν = ½ with the (τS, τE) form: incompressible, bulk viscosity irrelevant).
struct RetardationTimes {
  double shear = 0, extension = 0, bulk = 0;
  double extensional_viscosity(const ElasticConstants& c) const { return c.E * extension; }
};

RetardationTimes resolve_damping(const Damping& damping, const ElasticConstants& c);

}  // namespace manyrods
