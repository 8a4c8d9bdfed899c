// include/manyrods/mesh.h — a mesh collider's signed-distance grid from a
// Wavefront OBJ file (host/scene/io/mesh_grid.cpp builds it; the collider that holds
// it and the kernel that samples it: include/manyrods/contact.h,
// kernels/contact.h grid_distance).
#pragma once

#include <memory>
#include <string>

#include "manyrods/contact.h"

namespace manyrods {

// A closed triangle mesh from a Wavefront OBJ file as a signed-distance grid
// (negative inside) with `resolution` nodes along its longest side, in
// 8..512, plus a margin of 3 cells on every side. Accepts OBJ with triangles
// or polygons (fanned), closed (every edge shared by exactly two faces) and
// consistently oriented, outward or inward (an inward mesh is flipped).
// InputError starting with the path (and naming the face, line or edge, with
// OBJ's 1-based numbers) otherwise.
std::shared_ptr<const DistanceGrid> load_mesh_grid(const std::string& path, int resolution);

}  // namespace manyrods
