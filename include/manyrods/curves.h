// include/manyrods/curves.h — guide curves in (a groom from a content tool)
// and rods from them (library manyrods::scene; docs/scenes.md "Grooms from
// curves").
//
// Three formats, chosen by the file's extension:
//   .usda  USD ASCII: every BasisCurves prim (what the USD export of this
//          library, Houdini and Blender write): points (its default value,
//          else its earliest time sample), curveVertexCounts, widths or
//          primvars:widths (constant, uniform, vertex or varying), type,
//          basis and wrap with USD's fallbacks (cubic, bezier,
//          nonperiodic). Cubic curves (bezier, bspline, catmullRom;
//          nonperiodic or pinned) are evaluated, 16 points per segment;
//          periodic curves are refused (a closed loop is not a rod). The
//          prims' transforms are applied (xformOpOrder: translate, scale,
//          rotateX/Y/Z, rotateXYZ and the other orders, orient, transform,
//          !invert!, !resetXformStack!; parents' too; the earliest time
//          sample), widths scaled by the transform's mean scale.
//   .obj   Wavefront OBJ polylines: every `l` record (tinyobjloader), no widths.
//   .h5    HDF5, the layout docs/scenes.md gives: /curves/points [N, 3],
//          /curves/curve_vertex_counts [C], optionally /curves/widths [N],
//          [C] or [1].
// Every problem is an InputError that names the file and the curve.
#pragma once

#include <functional>
#include <string>
#include <string_view>
#include <vector>

#include "manyrods/batch.h"

namespace manyrods::scene {

struct Curve {
  std::string label;          // for messages: the file's prim or record and the curve's index
  std::vector<Vec3> points;   // a polyline (a cubic curve already evaluated)
  double width = -1;          // mean width (m) over the curve's widths; < 0: the file gives none
  // each point's width (m) when the file gives them per vertex (or per
  // segment end: varying), sampled along a cubic curve by its parameter;
  // empty: the mean only (constant or one per curve)
  std::vector<double> point_widths;
  bool evaluated = false;     // cubic: `points` sample the curve (not the file's own points)
};

std::vector<Curve> read_curves(const std::string& path);

// Binary USD (.usdc, .usdz, and .usd that is not text) is read through a
// converter to USD ASCII text, when one is set: the Python module sets one
// that uses OpenUSD's Python module (pxr, from usd-core) when it is
// installed. Without one, binary USD is an InputError saying how to
// convert it. The converter throws InputError naming the file it cannot
// convert.
using UsdConverter = std::function<std::string(const std::string& path)>;
void set_usd_converter(UsdConverter converter);
std::vector<Curve> read_usda_curves(std::string_view text, const std::string& source);
std::vector<Curve> read_obj_curves(const std::string& path);
std::vector<Curve> read_h5_curves(const std::string& path);

// Writes curves in the HDF5 layout above (points as the polylines, widths
// per curve when every curve has one). h5::H5Error when it cannot.
void write_h5_curves(const std::string& path, const std::vector<Curve>& curves);

// A rod along the curve: `elements` elements of equal arc length along the
// polyline (0: one element per segment, the curve's own points, refused for
// evaluated cubic curves), twist-free frames by parallel transport from the
// lab axis least aligned with the first segment, the resampled shape its
// rest shape (rest curvature and lengths from the curve: unstressed as
// read), radius width/2 when the curve has a width, and tapered
// (RodSpec::section_scale: each element's mean width over the curve's mean)
// when it has a width per point. InputError naming the
// curve for fewer than two points, a non-finite point, two consecutive
// points that coincide, or a curve shorter than 1e-12 m.
RodSpec rod_from_curve(const Curve& c, int elements);

}  // namespace manyrods::scene
