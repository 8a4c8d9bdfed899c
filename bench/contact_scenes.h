// bench/contact_scenes.h — the contact benchmarks' batches
// (bench/bench_contact.cpp describes them; bench/state_hashes.cpp hashes
// their states): stiff hairs on a grid or a groom falling onto a head, and
// twisted fiber bundles, with the ContactSpec of each variant.
#pragma once

#include <cmath>
#include <numbers>
#include <string>
#include <vector>

#include "manyrods/contact.h"
#include "manyrods/manyrods.h"

namespace manyrods::bench {

// A stiff human hair (bench/scenes.h hair): 0.2 m, 32 elements, r = 40 µm,
// clamped at its root, shear, stretch and twist implicit.
inline RodSpec stiff_hair(const Vec3& root, const Vec3& dir, const Vec3& normal) {
  RodSpec s = RodSpec::straight(root, dir, normal, 0.2, 32);
  s.name = "hair";
  s.section = Section::circle(40e-6);
  s.material = {1300, 3.9e9, 0.3};
  s.damping = Damping::shear_extension(1e-3, 1e-3);
  s.clamped_root = true;
  s.stiff_implicit = true;
  return s;
}

inline std::vector<RodSpec> hair_grid() {
  std::vector<RodSpec> rods;
  for (int i = 0; i < 1024; ++i) {
    rods.push_back(stiff_hair({0, 0.0005 * (i % 32), 0.0005 * (i / 32)}, {1, 0, 0}, {0, 0, 1}));
  }
  return rods;
}

inline std::vector<RodSpec> groom() {
  const int count = 1000;
  const double R = 0.09, cap = 70 * std::numbers::pi / 180, golden = std::numbers::pi * (3 - std::sqrt(5.0));
  std::vector<RodSpec> rods;
  for (int i = 0; i < count; ++i) {
    const double z = 1 - (1 - std::cos(cap)) * (i + 0.5) / count, rho = std::sqrt(1 - z * z), phi = golden * i;
    const Vec3 n{rho * std::cos(phi), rho * std::sin(phi), z};
    // down the head (towards −z in the tangent plane), x at the crown
    Vec3 t{-n[0] * z, -n[1] * z, 1 - z * z};
    for (double& x : t) x = -x;
    const double tl = std::sqrt(t[0] * t[0] + t[1] * t[1] + t[2] * t[2]);
    if (tl < 1e-6) t = {1, 0, 0};
    else
      for (double& x : t) x /= tl;
    Vec3 d;
    for (int a = 0; a < 3; ++a) d[a] = n[a] + 0.6 * t[a];
    const double dl = std::sqrt(d[0] * d[0] + d[1] * d[1] + d[2] * d[2]);
    for (double& x : d) x /= dl;
    const Vec3 normal{d[1] * t[2] - d[2] * t[1], d[2] * t[0] - d[0] * t[2], d[0] * t[1] - d[1] * t[0]};
    rods.push_back(stiff_hair({R * n[0], R * n[1], R * n[2]}, d, normal));
  }
  return rods;
}

inline std::vector<RodSpec> twisted_bundle(int side) {
  const int n = 32;
  const double r = 0.25e-3, spacing = 2 * r * 1.15, L = 0.1, twist = 2 * std::numbers::pi / 0.2;
  std::vector<RodSpec> rods;
  for (int i = 0; i < side * side; ++i) {
    const double y0 = spacing * (i % side - 0.5 * (side - 1)), z0 = spacing * (i / side - 0.5 * (side - 1));
    std::vector<Vec3> nodes;
    for (int j = 0; j <= n; ++j) {
      const double s = L * j / n, a = twist * s;
      nodes.push_back({std::cos(a) * y0 - std::sin(a) * z0, std::sin(a) * y0 + std::cos(a) * z0, -s});
    }
    RodSpec f = RodSpec::polyline(nodes, RodSpec::parallel_transport_frames(nodes, {1, 0, 0}));
    f.name = "fiber";
    f.section = Section::circle(r);
    f.material = {1000, 1e7, 0.3};
    f.damping = Damping::shear_extension(1e-3, 1e-3);
    f.clamped_root = true;
    rods.push_back(f);
  }
  return rods;
}

inline ContactSpec contact_for(const std::string& scene, const std::string& variant) {
  ContactSpec c;
  if (variant == "off") return c;
  if (scene == "headstiff" || scene == "groom") {
    Collider head;
    head.name = "head";
    head.kind = ColliderKind::sphere;
    head.center = scene == "groom" ? std::array<double, 3>{0, 0, 0} : std::array<double, 3>{0.15, 0.008, -0.1};
    head.radius = scene == "groom" ? 0.0895 : 0.098;
    head.friction = {0.4, 0.3};
    c.colliders = {head};
  }
  c.rod_rod = variant == "head_rod" || variant == "rod";
  // hairs piling on the head: a tip whipping through them at several m/s
  // lists hundreds of candidates (docs/contact.md "Limitations")
  c.capacity = 512;
  c.friction = {0.3, 0.2};
  return c;
}

}  // namespace manyrods::bench
