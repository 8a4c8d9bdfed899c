// include/manyrods/usd.h — a run's frames as a USD ASCII file (.usda):
// one BasisCurves prim per rod group, linear curves with per-vertex widths
// (the section width), points and extent as time samples. Time codes are
// frame indices and timeCodesPerSecond is 1 / (the frame interval), so the
// animation plays in simulated real time. docs/scenes.md "USD export" says
// what Blender and other importers take from it.
#pragma once

#include <cstddef>
#include <string>

namespace manyrods::usd {

struct ExportResult {
  std::size_t frames = 0;  // time samples written
  int rods = 0;
};

// Writes the frames of the manyrods HDF5 output `h5_path` (every `every`-th
// frame and the last) to `usd_path`, through `usd_path`.tmp renamed at the
// end (an existing file is replaced only by a complete one). Throws
// h5::H5Error (include/manyrods/h5io.h) for an unreadable input, a run with
// no frames, non-finite positions (checked before anything is written) or a
// file that cannot be written; scene::SceneError, before anything is read,
// for a usd_path without .usda or .usd or that is the input itself.
ExportResult export_usd(const std::string& h5_path, const std::string& usd_path, int every = 1);

}  // namespace manyrods::usd
