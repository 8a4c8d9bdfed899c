// include/manyrods/manyrods.h — everything a user needs.
//
// manyrods: many Cosserat rods with Kelvin–Voigt damping, structure-of-arrays
// storage and per-index kernels. Units are SI (m, kg, s, N, Pa) everywhere.
#pragma once

#include "kernels/terms.h"
#include "manyrods/batch.h"
#include "manyrods/material.h"
#include "host/stable_dt.h"
#include "manyrods/step.h"
