// include/manyrods/manyrods.h — the library's front door: building rods and
// batches, stepping them, energies, stable steps and statics.
//
// manyrods: many Cosserat rods with Kelvin–Voigt damping, structure-of-arrays
// storage and per-index kernels. Units are SI (m, kg, s, N, Pa) everywhere.
// docs/architecture.md is the map of the code; docs/model.md the physics.
//
//   manyrods/material.h   sections, materials, Kelvin–Voigt parameters
//   manyrods/drive.h      driven roots (rigid motions of a rod's clamp)
//   manyrods/batch.h      RodSpec, RodBatch, build_batch, state_hash
//   manyrods/fields.h     the structure-of-arrays field list
//   manyrods/terms.h      compile-time term switches
//   manyrods/step.h       step, step_n, step_pefrl, advance, energies
//   manyrods/profile.h    per-stage timing
//   manyrods/stable_dt.h  the largest stable step
//   manyrods/statics.h    static equilibrium
//   manyrods/strain.h     the largest strain of a rod (the validity range)
// Scenes, runs, sweeps and files (TOML, HDF5, USD) are in manyrods/scene.h,
// the library manyrods::scene.
#pragma once

#include "manyrods/batch.h"
#include "manyrods/contact.h"
#include "manyrods/drive.h"
#include "manyrods/material.h"
#include "manyrods/profile.h"
#include "manyrods/stable_dt.h"
#include "manyrods/strain.h"
#include "manyrods/statics.h"
#include "manyrods/step.h"
#include "manyrods/terms.h"
