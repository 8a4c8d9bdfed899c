// bench/scenes.h — the benchmark scenes (bench/RESULTS.md), shared by the benchmark
// and the accuracy tools.
//   hairstiff: the same hair as stiff rods (RodSpec::stiff_implicit), stepped
//          at half its flexural stable_dt (≈ 2.8e-4 s instead of 2e-8 s)
//   hairturn: hairstiff on a turning head: every root driven by one
//          OscillatingMotion (±0.7 rad about e3 at 0.8 Hz), the cost of driven roots
//   hair:  10,000 rods × 32 elements, human hair (docs/validation.md hair geometry), clamped
//          roots on a grid, horizontal, gravity, Kelvin–Voigt
//   cable: 1,000 rods × 100 elements, seed cantilever material, Kelvin–Voigt
//   long:  1 rod × 10,000 elements (seed material, 10 m)
//   mixed: 5,000 rods with 8 … 256 elements
//   fibers: 1,000 rods × 32 elements, seed material, clamped, gravity — the
//          scene of the side-by-side runs with PyElastica (bench/RESULTS.md)
//   fibers_pinned: fibers pinned at both ends (no inverse mass at node 0
//          and n, frames free): what static holds cost
//   fibers_driven: fibers clamped at the root and at node 16, their tips
//          clamped on one oscillating motion: driven holds (with
//          Kelvin–Voigt, the scalar delta-form solve)
//   fibers_drag: fibers with linear drag in a still fluid
//   fibers_wind: fibers with linear and quadratic drag and buoyancy in a
//          wind of 5 m/s with a 16-mode turbulent part
#pragma once

#include <cstdint>
#include <cstring>
#include <memory>
#include <string>
#include <vector>

#include "host/core/advanced.h"

namespace manyrods::bench {

struct Scene {
  std::vector<RodSpec> rods;
  Vec3 gravity{0, 0, -9.81};
  bool has_fluid = false;
  Fluid fluid;
};

inline RodSpec hair_strand(double x, double y, bool kv) {
  RodSpec s = RodSpec::straight({x, y, 0}, {1, 0, 0}, {0, 0, 1}, 0.2, 32);
  s.name = "hair";
  s.section = Section::circle(40e-6);
  s.material = {1300, 3.9e9, 0.3};
  s.damping = kv ? Damping::shear_extension(1e-3, 1e-3) : Damping::none();
  s.clamped_root = true;
  return s;
}

inline RodSpec seed_rod(double x, double y, double length, int n, bool kv) {
  RodSpec s = RodSpec::straight({x, y, 0}, {1, 0, 0}, {0, 0, 1}, length, n);
  s.name = "cable";
  s.section = Section::rectangle(0.01, 0.01);
  s.material = {1000, 1e6, 0.3};
  s.damping = kv ? Damping::shear_extension(0.02, 0.02) : Damping::none();
  s.clamped_root = true;
  return s;
}

inline Scene make_scene(const std::string& name, bool kv, int rods_override = -1) {
  Scene sc;
  if (name == "hair" || name == "hairstiff" || name == "hairturn") {
    const int R = rods_override > 0 ? rods_override : 10000;
    std::shared_ptr<OscillatingMotion> head;
    if (name == "hairturn") {
      head = std::make_shared<OscillatingMotion>();
      head->rotation_amplitude = 0.7;
      head->frequency = 0.8;
    }
    for (int i = 0; i < R; ++i) {
      sc.rods.push_back(hair_strand(0.001 * (i % 100), 0.001 * (i / 100), kv));
      sc.rods.back().stiff_implicit = name != "hair";
      sc.rods.back().root_motion = head;
    }
  } else if (name == "cable") {
    const int R = rods_override > 0 ? rods_override : 1000;
    for (int i = 0; i < R; ++i) sc.rods.push_back(seed_rod(0.02 * (i % 32), 0.02 * (i / 32), 0.3, 100, kv));
  } else if (name.rfind("fibers", 0) == 0) {
    const int R = rods_override > 0 ? rods_override : 1000;
    std::shared_ptr<OscillatingMotion> tip;
    if (name == "fibers_driven") {
      tip = std::make_shared<OscillatingMotion>();
      tip->translation_amplitude = {0, 0.01, 0};
      tip->frequency = 2;
    }
    for (int i = 0; i < R; ++i) {
      sc.rods.push_back(seed_rod(0.02 * (i % 32), 0.02 * (i / 32), 0.3, 32, kv));
      RodSpec& r = sc.rods.back();
      if (name == "fibers_pinned") {
        r.clamped_root = false;
        r.pinned_root = r.pinned_tip = true;
      } else if (name == "fibers_driven") {
        r.holds.push_back({16, HoldKind::clamped, nullptr});
        r.clamped_tip = true;
        r.tip_motion = tip;
      } else if (name == "fibers_drag" || name == "fibers_wind") {
        r.drag.normal = 0.5;
        r.drag.tangential = 0.25;
        if (name == "fibers_wind") r.drag.cd_normal = 1.2;
      }
    }
    if (name == "fibers_drag" || name == "fibers_wind") sc.has_fluid = true;
    if (name == "fibers_wind") {
      sc.fluid.density = 1.2;
      sc.fluid.velocity = {0, 5, 0};
      sc.fluid.turbulence.intensity = 1;
      sc.fluid.turbulence.length_scale = 0.2;
      sc.fluid.turbulence.time_scale = 0.5;
    }
  } else if (name == "long") {
    sc.rods.push_back(seed_rod(0, 0, 10.0, 10000, kv));
  } else if (name == "longer") {
    sc.rods.push_back(seed_rod(0, 0, 100.0, 100000, kv));
  } else if (name == "mixed") {
    const int R = rods_override > 0 ? rods_override : 5000;
    for (int i = 0; i < R; ++i) {
      const int n = 8 + int((std::uint64_t(i) * 2654435761u) % 249);  // 8 … 256, spread
      sc.rods.push_back(seed_rod(0.02 * (i % 64), 0.02 * (i / 64), 0.3 * n / 100.0, n, kv));
    }
  }
  return sc;
}

// (the state hash the benchmarks print is the library's state_hash,
// include/manyrods/batch.h)

}  // namespace manyrods::bench
