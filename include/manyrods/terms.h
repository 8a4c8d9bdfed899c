// include/manyrods/terms.h — which physical terms a step includes
// (docs/model.md; docs/architecture.md "Adding a term").
//
// Terms is a structural type used as a template argument: a term that is off
// is removed at compile time, so a scene pays nothing for it. "Off" means the
// term contributes no force or couple (its stiffness and viscosity act as
// zero); it is not a constraint. Switching shear or stretch off therefore
// removes a restoring force — the inextensible/unshearable limit is a
// different model (see README, "Stiff rods").
#pragma once

// (terms_mask is also used in CUDA device code, kernels/cuda_check.cu)
#if defined(__CUDACC__)
#define MANYRODS_TERMS_HD __host__ __device__
#else
#define MANYRODS_TERMS_HD
#endif

namespace manyrods {

struct Terms {
  bool shear = true;         // σ1, σ2: transverse shear force
  bool stretch = true;       // σ3: axial force
  bool bend = true;          // κ1, κ2: bending moment
  bool twist = true;         // κ3: twisting moment
  bool kelvin_voigt = true;  // viscous parts of force and moment (seed eq. 1)
  bool gravity = true;       // node mass · g
  bool loads = true;         // user point forces (nodes) and couples (elements)
  // Contact (include/manyrods/contact.h): off unless a scene has it, so that
  // a step without contact compiles without the contact stage.
  bool colliders = false;    // rods against the batch's colliders
  bool rod_contact = false;  // rod–rod and self contact (no temporal blocking: docs/contact.md)
};

inline constexpr Terms kAllTerms{};

// Terms as a bit mask (bit 0 shear … bit 6 loads, 7 colliders, 8 rod_contact), for places that cannot take
// a class-type template argument (CUDA __global__ templates).
MANYRODS_TERMS_HD constexpr unsigned terms_mask(Terms t) {
  return unsigned(t.shear) | unsigned(t.stretch) << 1 | unsigned(t.bend) << 2 |
         unsigned(t.twist) << 3 | unsigned(t.kelvin_voigt) << 4 | unsigned(t.gravity) << 5 |
         unsigned(t.loads) << 6 | unsigned(t.colliders) << 7 | unsigned(t.rod_contact) << 8;
}
MANYRODS_TERMS_HD constexpr Terms terms_from_mask(unsigned m) {
  return {bool(m & 1), bool(m & 2), bool(m & 4), bool(m & 8), bool(m & 16), bool(m & 32),
          bool(m & 64), bool(m & 128), bool(m & 256)};
}

}  // namespace manyrods
