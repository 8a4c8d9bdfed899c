// host/scene/io/mesh_grid.cpp — a mesh collider's signed-distance grid from a
// Wavefront OBJ file (load_mesh_grid, include/manyrods/mesh.h): read the
// file (tinyobjloader) and fan its faces into triangles, check that the mesh
// is closed and consistently oriented, turn it outward, and sample φ at the
// nodes of a regular grid around it: the exact distance to the nearest
// triangle (found with an AABB tree), negative inside (the generalized
// winding number). kernels/contact.h grid_distance samples the grid
// trilinearly; outside its nodes there is no contact, hence the margin.
//
// Cost. Building the tree: O(T log T) for T triangles. Each of the N nodes
// asks it for its nearest triangle: O(log T) near the surface, more deep
// inside a round mesh, where many triangles are about equally near. The
// winding number costs O(T) (one solid angle per triangle, ~35 ns) and is
// evaluated only where the surface passes between a node and its earlier
// neighbours (about 0.6–1 per surface cell, A / h² for a surface of area A;
// the other nodes inherit their side, see node_inside). Measured (-O2, two
// threads): 320 triangles at resolution 64, 0.2 s; 1280, 0.5 s; 20480 at
// 64, 5 s, and at 128, 21 s (9 s distances, 12 s for 3·10⁴ winding numbers).
// Brute force (every triangle at every node) would be N T: 10¹⁰–10¹¹ here.
// A fast winding number (Barill et al. 2018) would be the next step.
#include <tiny_obj_loader.h>

#include <Eigen/Dense>
#include <algorithm>
#include <array>
#include <cctype>
#include <cerrno>
#include <cmath>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <limits>
#include <map>
#include <numbers>
#include <sstream>
#include <utility>
#include <vector>

#include "manyrods/material.h"
#include "manyrods/mesh.h"

namespace manyrods {
namespace {

using E3 = Eigen::Vector3d;

constexpr int margin = 3;  // cells of grid beyond the mesh's bounding box, on every side
constexpr int min_resolution = 8, max_resolution = 512;

// The mesh as triangles (0-based vertex numbers) and, per triangle, the OBJ
// face (1-based, in the file's order) it was fanned from.
struct Mesh {
  std::vector<E3> v;
  std::vector<std::array<int, 3>> t;
  std::vector<int> face;
};

struct Box {
  E3 lo = E3::Constant(std::numeric_limits<double>::infinity());
  E3 hi = -E3::Constant(std::numeric_limits<double>::infinity());
  void grow(const E3& p) {
    lo = lo.cwiseMin(p);
    hi = hi.cwiseMax(p);
  }
  // squared distance from p to the box (0 inside)
  double distance2(const E3& p) const { return (lo - p).cwiseMax(p - hi).cwiseMax(0.0).squaredNorm(); }
  bool contains(const E3& p) const { return (p.array() >= lo.array()).all() && (p.array() <= hi.array()).all(); }
};

[[noreturn]] void fail(const std::string& path, const std::string& what) { throw InputError(path + ": " + what); }

std::string vertex_label(int i) { return std::to_string(i + 1); }  // OBJ numbers vertices from 1

// ---- reading ------------------------------------------------------------------

std::string read_text(const std::string& path) {
  std::error_code ec;
  if (std::filesystem::is_directory(path, ec)) fail(path, "cannot be read (it is a directory)");
  // a regular file of sane size (not a device or a pipe that never ends)
  if (std::filesystem::exists(path, ec) && !std::filesystem::is_regular_file(path, ec))
    fail(path, "cannot be read (not a regular file)");
  if (std::filesystem::exists(path, ec) && std::filesystem::file_size(path, ec) > (std::uintmax_t(1) << 31))
    fail(path, "is larger than 2 GB: not a head or body mesh for a signed-distance grid");
  std::ifstream in(path, std::ios::binary);
  if (!in) fail(path, std::string("cannot be read (") + std::strerror(errno) + ")");
  std::ostringstream os;
  os << in.rdbuf();
  if (in.bad()) fail(path, "cannot be read (read error)");
  return os.str();
}

std::string trimmed(std::string s) {
  while (!s.empty() && std::isspace(static_cast<unsigned char>(s.back()))) s.pop_back();
  return s;
}

// The 1-based line of the first face ("f ...") with fewer than 3 vertices;
// 0 if none. (tinyobjloader drops such faces with a warning that does not
// say where.)
int short_face_line(const std::string& text) {
  std::istringstream in(text);
  std::string line;
  for (int no = 1; std::getline(in, line); ++no) {
    std::istringstream words(line);
    std::string w;
    if (!(words >> w) || w != "f") continue;
    int n = 0;
    while (words >> w && w[0] != '#') ++n;
    if (n < 3) return no;
  }
  return 0;
}

// Appends OBJ face `face` (its vertex numbers, 0-based) fanned into
// triangles (v0, v_j, v_{j+1}), j = 1 … n−2; checks its vertex numbers.
void add_face(const std::string& path, const std::vector<int>& vs, int face, Mesh& m) {
  const int nv = int(m.v.size());
  for (std::size_t i = 0; i < vs.size(); ++i) {
    if (vs[i] >= nv)
      fail(path, "face " + std::to_string(face) + " uses vertex " + vertex_label(vs[i]) + ", but the file has " +
                     std::to_string(nv) + " vertices");
    if (vs[i] < 0)
      fail(path, "face " + std::to_string(face) + " has a relative vertex number reaching before the first vertex");
    for (std::size_t j = 0; j < i; ++j)
      if (vs[j] == vs[i]) fail(path, "face " + std::to_string(face) + " uses vertex " + vertex_label(vs[i]) + " twice");
  }
  for (std::size_t j = 1; j + 1 < vs.size(); ++j) {
    m.t.push_back({vs[0], vs[j], vs[j + 1]});
    m.face.push_back(face);
  }
}

Mesh read_obj(const std::string& path) {
  const std::string text = read_text(path);
  tinyobj::ObjReaderConfig config;
  config.triangulate = false;  // fanned here, so that every triangle knows its face
  config.vertex_color = false;
  tinyobj::ObjReader reader;
  if (!reader.ParseFromString(text, "", config))  // (ignores mtllib: materials are not needed)
    fail(path, "not an OBJ file that tinyobjloader parses: " + trimmed(reader.Error()));
  if (reader.Warning().find("Degenerated face") != std::string::npos) {
    const int line = short_face_line(text);
    fail(path, (line > 0 ? "line " + std::to_string(line) + ": " : std::string()) + "a face with fewer than 3 vertices");
  }
  Mesh m;
  const std::vector<tinyobj::real_t>& xyz = reader.GetAttrib().vertices;
  for (std::size_t i = 0; i + 2 < xyz.size(); i += 3) {
    const E3 p(xyz[i], xyz[i + 1], xyz[i + 2]);
    if (!p.allFinite()) fail(path, "vertex " + vertex_label(int(i / 3)) + " is not finite");
    m.v.push_back(p);
  }
  int face = 0;
  std::vector<int> vs;
  for (const tinyobj::shape_t& s : reader.GetShapes()) {
    std::size_t total = 0;  // (tinyobjloader counts a face's vertices in a byte)
    for (const unsigned char count : s.mesh.num_face_vertices) total += count;
    if (total != s.mesh.indices.size()) fail(path, "a face with more than 255 vertices (split it)");
    std::size_t at = 0;
    for (const unsigned char count : s.mesh.num_face_vertices) {
      vs.clear();
      for (unsigned j = 0; j < count; ++j) vs.push_back(s.mesh.indices[at + j].vertex_index);
      at += count;
      ++face;
      if (count < 3) fail(path, "face " + std::to_string(face) + " has fewer than 3 vertices");
      add_face(path, vs, face, m);
    }
  }
  if (m.t.empty()) fail(path, "has no faces (a closed triangle mesh needs 'f' lines)");
  return m;
}

// ---- topology and orientation ---------------------------------------------------

// A closed, consistently oriented mesh uses every edge {a, b} in exactly two
// triangles, once as a → b and once as b → a. The first offending edge in
// the file's face order is named.
void check_closed(const std::string& path, const Mesh& m) {
  struct Use {
    int count = 0, forward = 0;  // triangles using the edge; of them, running it low → high vertex number
    int face[2] = {0, 0};        // the first two faces using it
  };
  std::map<std::pair<int, int>, Use> edges;
  auto for_each_edge = [&](auto&& f) {
    for (std::size_t t = 0; t < m.t.size(); ++t)
      for (int e = 0; e < 3; ++e) f(m.t[t][e], m.t[t][(e + 1) % 3], m.face[t]);
  };
  for_each_edge([&](int a, int b, int face) {
    Use& u = edges[{std::min(a, b), std::max(a, b)}];
    if (u.count < 2) u.face[u.count] = face;
    ++u.count;
    if (a < b) ++u.forward;
  });
  const auto edge_label = [](int a, int b) { return vertex_label(a) + " and " + vertex_label(b); };
  for_each_edge([&](int a, int b, int face) {
    const Use& u = edges.at({std::min(a, b), std::max(a, b)});
    if (u.count == 1)
      fail(path, "open mesh: the edge between vertices " + edge_label(a, b) + " is used by face " + std::to_string(face) +
                     " only; a closed mesh shares every edge between two faces");
    if (u.count > 2)
      fail(path, "open mesh: the edge between vertices " + edge_label(a, b) + " is used by " + std::to_string(u.count) +
                     " faces (" + std::to_string(u.face[0]) + ", " + std::to_string(u.face[1]) +
                     ", ...); a closed mesh shares every edge between exactly two faces");
  });
  for_each_edge([&](int a, int b, int) {
    const Use& u = edges.at({std::min(a, b), std::max(a, b)});
    if (u.forward != 1) {
      const int from = u.forward == 2 ? std::min(a, b) : std::max(a, b), to = a + b - from;
      fail(path, "inconsistently oriented: faces " + std::to_string(u.face[0]) + " and " + std::to_string(u.face[1]) +
                     " both run the edge from vertex " + vertex_label(from) + " to vertex " + vertex_label(to) +
                     " (neighbouring faces must list their shared edge in opposite directions)");
    }
  });
}

Box bounding_box(const Mesh& m) {
  Box b;
  for (const auto& t : m.t)
    for (int c : t) b.grow(m.v[c]);
  return b;
}

// Makes the triangles wind outward (counter-clockwise seen from outside): the
// enclosed volume V = Σ a·(b × c) / 6 (corners relative to the box's centre)
// is then positive. A mesh enclosing no volume is an error.
void orient_outward(const std::string& path, Mesh& m, const Box& box) {
  const E3 o = 0.5 * (box.lo + box.hi);
  double six_v = 0;
  for (const auto& t : m.t) six_v += (m.v[t[0]] - o).dot((m.v[t[1]] - o).cross(m.v[t[2]] - o));
  const double L = (box.hi - box.lo).maxCoeff();
  if (!(std::abs(six_v) > 1e-12 * L * L * L)) fail(path, "the mesh encloses no volume");
  if (six_v < 0)
    for (auto& t : m.t) std::swap(t[1], t[2]);
}

// ---- distance ---------------------------------------------------------------------

E3 closest_on_segment(const E3& p, const E3& a, const E3& b) {
  const E3 ab = b - a;
  const double ll = ab.squaredNorm();
  const double s = ll > 0 ? std::clamp((p - a).dot(ab) / ll, 0.0, 1.0) : 0.0;
  return a + s * ab;
}

// The point of triangle abc nearest p (Ericson, Real-Time Collision Detection
// §5.1.5): find the Voronoi region of p — a vertex, an edge or the face —
// from the dot products d1…d6 of the edges with p's offsets from the corners,
// and the barycentric numerators va, vb, vc (cross products projected on the
// normal); in the face region the point is a + ab vb/(va+vb+vc) + ac vc/(va+vb+vc).
E3 closest_on_triangle(const E3& p, const E3& a, const E3& b, const E3& c) {
  const E3 ab = b - a, ac = c - a, ap = p - a;
  if (ab.cross(ac).squaredNorm() == 0) {  // no area: the nearest of its sides
    const E3 q[3] = {closest_on_segment(p, a, b), closest_on_segment(p, b, c), closest_on_segment(p, c, a)};
    int best = 0;
    for (int i = 1; i < 3; ++i)
      if ((q[i] - p).squaredNorm() < (q[best] - p).squaredNorm()) best = i;
    return q[best];
  }
  const double d1 = ab.dot(ap), d2 = ac.dot(ap);
  if (d1 <= 0 && d2 <= 0) return a;
  const E3 bp = p - b;
  const double d3 = ab.dot(bp), d4 = ac.dot(bp);
  if (d3 >= 0 && d4 <= d3) return b;
  const double vc = d1 * d4 - d3 * d2;
  if (vc <= 0 && d1 >= 0 && d3 <= 0) return a + (d1 / (d1 - d3)) * ab;
  const E3 cp = p - c;
  const double d5 = ab.dot(cp), d6 = ac.dot(cp);
  if (d6 >= 0 && d5 <= d6) return c;
  const double vb = d5 * d2 - d1 * d6;
  if (vb <= 0 && d2 >= 0 && d6 <= 0) return a + (d2 / (d2 - d6)) * ac;
  const double va = d3 * d6 - d5 * d4;
  if (va <= 0 && d4 - d3 >= 0 && d5 - d6 >= 0) return b + ((d4 - d3) / ((d4 - d3) + (d5 - d6))) * (c - b);
  const double inv = 1 / (va + vb + vc);
  return a + (vb * inv) * ab + (vc * inv) * ac;
}

// A bounding-volume tree over the triangles (axis-aligned boxes, split at the
// median centroid along the longest side) for nearest-triangle queries.
class Tree {
 public:
  explicit Tree(const Mesh& m) : m_(m), order_(m.t.size()) {
    for (std::size_t i = 0; i < order_.size(); ++i) order_[i] = int(i);
    nodes_.reserve(2 * order_.size() / leaf_size + 2);
    build(0, int(order_.size()));
  }

  // The distance from p to the nearest triangle: depth first, the nearer
  // child first, skipping boxes no nearer than the best so far.
  double distance(const E3& p) const {
    double best = std::numeric_limits<double>::infinity();
    int stack[128], top = 0;
    stack[top++] = 0;
    while (top > 0) {
      const Node& n = nodes_[stack[--top]];
      if (n.box.distance2(p) >= best) continue;
      if (n.count > 0) {
        for (int i = n.first; i < n.first + n.count; ++i) {
          const auto& t = m_.t[order_[i]];
          best = std::min(best, (closest_on_triangle(p, m_.v[t[0]], m_.v[t[1]], m_.v[t[2]]) - p).squaredNorm());
        }
        continue;
      }
      const bool left_nearer = nodes_[n.left].box.distance2(p) <= nodes_[n.right].box.distance2(p);
      stack[top++] = left_nearer ? n.right : n.left;
      stack[top++] = left_nearer ? n.left : n.right;
    }
    return std::sqrt(best);
  }

 private:
  static constexpr int leaf_size = 4;
  struct Node {
    Box box;
    int left = -1, right = -1;  // children (inner node)
    int first = 0, count = 0;   // order_[first, first + count) (leaf: count > 0)
  };

  E3 centroid(int t) const { return (m_.v[m_.t[t][0]] + m_.v[m_.t[t][1]] + m_.v[m_.t[t][2]]) / 3; }

  // The node over order_[first, first + count); returns its index. The depth
  // is ⌈log₂(T / leaf_size)⌉ + 1, far below the query's stack of 128.
  int build(int first, int count) {
    const int id = int(nodes_.size());
    nodes_.emplace_back();
    Box box, centres;
    for (int i = first; i < first + count; ++i) {
      for (int c : m_.t[order_[i]]) box.grow(m_.v[c]);
      centres.grow(centroid(order_[i]));
    }
    nodes_[id].box = box;
    if (count <= leaf_size) {
      nodes_[id].first = first;
      nodes_[id].count = count;
      return id;
    }
    int axis = 0;
    (centres.hi - centres.lo).maxCoeff(&axis);
    const int half = count / 2;
    std::nth_element(order_.begin() + first, order_.begin() + first + half, order_.begin() + first + count,
                     [&](int a, int b) { return centroid(a)[axis] < centroid(b)[axis]; });
    const int left = build(first, half);
    const int right = build(first + half, count - half);
    nodes_[id].left = left;
    nodes_[id].right = right;
    return id;
  }

  const Mesh& m_;
  std::vector<int> order_;
  std::vector<Node> nodes_;
};

// ---- sign -------------------------------------------------------------------------

// The generalized winding number of the mesh about p, w = Σ Ω_t / 4π with Ω_t
// the signed solid angle of triangle t seen from p (Van Oosterom & Strackee
// 1983): with A, B, C its corners relative to p and a, b, c their lengths,
//   tan(Ω/2) = A·(B × C) / (abc + (A·B) c + (B·C) a + (C·A) b).
// For a closed mesh w is 1 inside (wound outward; −1 wound inward) and 0
// outside, and varies smoothly only within roundoff of the surface.
double winding_number(const Mesh& m, const E3& p) {
  double sum = 0;
  for (const auto& t : m.t) {
    const E3 A = m.v[t[0]] - p, B = m.v[t[1]] - p, C = m.v[t[2]] - p;
    const double a = A.norm(), b = B.norm(), c = C.norm();
    const double num = A.dot(B.cross(C));
    const double den = a * b * c + A.dot(B) * c + B.dot(C) * a + C.dot(A) * b;
    sum += 2 * std::atan2(num, den);
  }
  return sum / (4 * std::numbers::pi);
}

// ---- the grid -----------------------------------------------------------------------

// Nodes: spacing h = (the box's longest side) / (resolution − 1); per axis
// enough cells to cover the box plus `margin` on each side, the box centred.
struct Layout {
  E3 origin;
  double h = 0;
  int n[3] = {0, 0, 0};
  E3 node(int i, int j, int k) const { return origin + h * E3(double(i), double(j), double(k)); }
};

Layout layout(const Box& box, int resolution) {
  Layout g;
  const E3 size = box.hi - box.lo, centre = 0.5 * (box.lo + box.hi);
  g.h = size.maxCoeff() / (resolution - 1);
  for (int d = 0; d < 3; ++d) {
    const int cells = int(std::ceil(size[d] / g.h - 1e-9)) + 2 * margin;  // (the longest side: resolution − 1)
    g.n[d] = cells + 1;
    g.origin[d] = centre[d] - 0.5 * cells * g.h;
  }
  return g;
}

// Whether node (i, j) of a slice, at p and distance d from the surface, is
// inside. Outside the mesh's box it is not. A neighbour q already done in
// this slice (i−1 or j−1, one spacing h away), at distance d_q, lends its
// side when d_q + d > h: the open balls of radii d_q about q and d about p
// hold no surface and together cover the segment qp, which so crosses none.
// A node within 10⁻⁶ h of the surface lends nothing: its side may be a guess
// within roundoff (harmless to its own φ ≈ 0, not to others'). Otherwise the
// winding number decides, |w| > ½: once or so where the surface passes
// between two nodes.
bool node_inside(const Mesh& m, const Box& box, const Layout& g, const std::vector<double>& dist,
                 const std::vector<char>& inside, int i, int j, const E3& p, double d) {
  if (!box.contains(p)) return false;
  const double reach = g.h * (1 + 1e-9), sure = 1e-6 * g.h;
  const int at = j * g.n[0] + i;
  const auto lends = [&](int q) { return dist[q] > sure && dist[q] + d > reach; };
  if (i > 0 && lends(at - 1)) return inside[at - 1];
  if (j > 0 && lends(at - g.n[0])) return inside[at - g.n[0]];
  return std::abs(winding_number(m, p)) > 0.5;
}

// φ on z-slice k, row by row (x fastest), into phi[(k ny + j) nx + i].
void sample_slice(const Mesh& m, const Tree& tree, const Box& box, const Layout& g, int k, float* phi) {
  const int nx = g.n[0], ny = g.n[1];
  std::vector<double> dist(std::size_t(nx) * ny);
  std::vector<char> inside(dist.size());
  for (int j = 0; j < ny; ++j)
    for (int i = 0; i < nx; ++i) {
      const int at = j * nx + i;
      const E3 p = g.node(i, j, k);
      dist[at] = tree.distance(p);
      inside[at] = node_inside(m, box, g, dist, inside, i, j, p, dist[at]);
      phi[std::size_t(k) * nx * ny + at] = float(inside[at] ? -dist[at] : dist[at]);
    }
}

}  // namespace

std::shared_ptr<const DistanceGrid> load_mesh_grid(const std::string& path, int resolution) {
  if (resolution < min_resolution || resolution > max_resolution)
    fail(path, "resolution must be in " + std::to_string(min_resolution) + ".." + std::to_string(max_resolution) +
                   " nodes along the longest side (got " + std::to_string(resolution) + ")");
  Mesh m = read_obj(path);
  check_closed(path, m);
  const Box box = bounding_box(m);
  orient_outward(path, m, box);
  const Layout g = layout(box, resolution);
  const Tree tree(m);

  auto grid = std::make_shared<DistanceGrid>();
  grid->origin = {g.origin[0], g.origin[1], g.origin[2]};
  grid->spacing = g.h;
  for (int d = 0; d < 3; ++d) grid->n[d] = g.n[d];
  grid->phi.resize(std::size_t(g.n[0]) * g.n[1] * g.n[2]);
  // Each slice is written by one iteration, in a fixed order: φ does not
  // depend on the number of threads.
#pragma omp parallel for schedule(dynamic, 1)
  for (int k = 0; k < g.n[2]; ++k) sample_slice(m, tree, box, g, k, grid->phi.data());

  for (const E3& p : m.v) grid->vertices.push_back({p[0], p[1], p[2]});
  for (const auto& t : m.t) grid->triangles.insert(grid->triangles.end(), t.begin(), t.end());
  return grid;
}

}  // namespace manyrods
