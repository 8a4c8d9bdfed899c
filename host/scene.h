// host/scene.h — TOML scene files (issue 6; schema in docs/scenes.md).
//
// A scene is a [simulation] table and one or more [[rods]] groups. Loading
// validates every key once, at the boundary (STYLE.md "Host code"): unknown
// keys, wrong types and out-of-range values raise SceneError, whose message
// starts with "file:line:column: key.path:" (toml++ source regions), e.g.
//
//   hair.toml:14:18: rods.0.material.youngs_modulus: must be > 0 (got -3.9e9)
//
// Key paths use the `--vary` spelling of the command-line tool: the first
// [[rods]] table is `rods.0`. A parsed scene holds the expanded rods as
// RodSpec (double precision) plus what the library's RodSpec does not carry:
// the group of each rod, its tip force, its initial (static) state and its
// term switches.
#pragma once

#include <cstdint>
#include <stdexcept>
#include <string>
#include <string_view>
#include <vector>

#include "host/run.h"
#include "manyrods/batch.h"

namespace manyrods::scene {

// Every problem with a scene file (or a --vary override of one).
struct SceneError : std::runtime_error {
  using std::runtime_error::runtime_error;
};

enum class Precision { float64, float32 };

struct Simulation {
  bool dt_auto = true;  // dt = "auto": stable_dt(batch).elastic × dt_safety
  double dt = 0;        // s, when !dt_auto
  double dt_safety = 0.9;
  double duration = 0;         // s of simulated time
  double output_interval = 0;  // s of simulated time between frames (0: every step... see docs)
  Integrator integrator = Integrator::position_verlet;
  Precision precision = Precision::float64;
  Vec3 gravity{0, 0, 0};         // m/s²
  bool output_directors = true;  // write /element_directors frames
};

// Which terms a group's rods include (kernels/terms.h). shear, stretch, bend
// and twist are switched off by zeroing that stiffness in the rods' model
// (identical to the compile-time switch: an off term contributes no force);
// kelvin_voigt off = no damping for the group; gravity off = the group's rods
// feel no gravity (host/scene_run.h: the compile-time term when all groups
// have it, dead node loads otherwise).
struct TermSwitches {
  bool shear = true, stretch = true, bend = true, twist = true, kelvin_voigt = true, gravity = true;
};

struct RodGroup {
  std::string name;
  int count = 0;
  int first_rod = 0;  // index of its first rod in Scene::rods
  int line = 0;       // source line of its [[rods]] table
  TermSwitches terms;
  Vec3 tip_force{0, 0, 0};  // N, lab frame, dead load on the last node
  bool has_initial_tip_force = false;
  Vec3 initial_tip_force{0, 0, 0};  // start in static equilibrium under it, released at t = 0
  double width = 0;                 // largest section dimension (m), for USD widths and strains
};

struct Override {
  std::string key;  // e.g. "rods.0.damping.tau_extension"
  double value = 0;
};

struct Scene {
  std::string source;  // file name used in messages
  std::string text;    // the TOML text as read
  Simulation sim;
  std::vector<RodGroup> groups;
  std::vector<RodSpec> rods;   // expanded
  std::vector<int> rod_group;  // [rods] group index
};

// Parses and validates. `overrides` set numeric values by key path before
// validation (the sweep); their errors name the key and "--vary".
Scene parse_scene(std::string_view text, const std::string& source,
                  const std::vector<Override>& overrides = {});
// Reads the file (SceneError if it cannot be read) and parses it.
Scene load_scene(const std::string& path);

// Estimated bytes of a batch of these rods (model, state, scratch, loads and
// the implicit viscous workspace) in the given precision.
std::uint64_t estimated_batch_bytes(const Scene& s);
// Throws SceneError when the batch would not fit in this machine's memory
// or exceeds the library's int slot index.
void check_batch_size(const Scene& s);

}  // namespace manyrods::scene
