// host/scene/io/usd.cpp — USD ASCII export of a run (include/manyrods/usd.h).
#include "manyrods/usd.h"

#include <algorithm>
#include <cctype>
#include <cmath>
#include <cstdint>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <ostream>
#include <vector>

#include "manyrods/h5io.h"
#include "manyrods/runner.h"
#include "manyrods/scene.h"

namespace manyrods::usd {
namespace {

using Frames = std::vector<std::vector<double>>;  // [samples][3 × nodes] positions

std::string prim_name(const std::string& s, int index, const char* kind = "group_") {
  std::string n = kind + std::to_string(index) + "_";
  for (char c : s) n += std::isalnum(static_cast<unsigned char>(c)) ? c : '_';
  return n;
}

// A string literal of the USD text format: \ and " escaped, controls dropped.
std::string usd_string(const std::string& s) {
  std::string q;
  for (char c : s) {
    if (c == '\\' || c == '"') q += '\\';
    if (static_cast<unsigned char>(c) >= 0x20) q += c;
  }
  return q;
}

// The frames to write and their positions; refuses non-finite ones (USD
// cannot hold them, and "-nan" does not parse) before a file is opened.
Frames read_frames(const h5::Reader& rd, const std::string& in, const std::vector<std::int64_t>& frames) {
  Frames pos(frames.size());
  for (std::size_t k = 0; k < frames.size(); ++k) {
    rd.read_positions(frames[k], pos[k]);
    for (double x : pos[k])
      if (!std::isfinite(x))
        throw h5::H5Error(in + ": frame " + std::to_string(frames[k]) + " has non-finite positions");
  }
  return pos;
}

void write_stage_header(std::ostream& out, const std::string& in, std::int64_t first, std::int64_t last, double fps) {
  out << "#usda 1.0\n(\n    defaultPrim = \"manyrods\"\n    doc = \"manyrods export of " << usd_string(in) << "\"\n"
      << "    metersPerUnit = 1\n    upAxis = \"Z\"\n"
      << "    startTimeCode = " << first << "\n    endTimeCode = " << last
      << "\n    timeCodesPerSecond = " << fps << "\n    framesPerSecond = " << fps << "\n)\n\n";
}

// curveVertexCounts and per-vertex widths of the group's rods.
void write_topology(std::ostream& out, const h5::Output& o, const std::vector<int>& members) {
  out << "        uniform token type = \"linear\"\n        uniform token wrap = \"nonperiodic\"\n";
  out << "        int[] curveVertexCounts = [";
  for (std::size_t i = 0; i < members.size(); ++i)
    out << (i ? ", " : "") << o.node_offsets[members[i] + 1] - o.node_offsets[members[i]];
  out << "]\n        float[] widths = [";
  bool first = true;
  for (int r : members)
    for (std::int64_t j = o.node_offsets[r]; j < o.node_offsets[r + 1]; ++j) {  // (a tapered rod: its node's own)
      out << (first ? "" : ", ") << (o.node_width.empty() ? o.rod_width[r] : o.node_width[std::size_t(j)]);
      first = false;
    }
  out << "] (\n            interpolation = \"vertex\"\n        )\n";
}

// extent (the schema asks for it wherever the points change): the points'
// box padded by half the widest section, per time sample.
void write_extent(std::ostream& out, const h5::Output& o, const std::vector<int>& members,
                  const std::vector<std::int64_t>& frames, const Frames& pos) {
  double pad = 0;  // (OpenUSD pads by half the widest width)
  for (int r : members)
    if (o.node_width.empty())
      pad = std::max(pad, 0.5 * o.rod_width[r]);
    else
      for (std::int64_t j = o.node_offsets[r]; j < o.node_offsets[r + 1]; ++j) pad = std::max(pad, 0.5 * o.node_width[std::size_t(j)]);
  out << "        float3[] extent.timeSamples = {\n";
  for (std::size_t k = 0; k < frames.size(); ++k) {
    double lo[3] = {HUGE_VAL, HUGE_VAL, HUGE_VAL}, hi[3] = {-HUGE_VAL, -HUGE_VAL, -HUGE_VAL};
    for (int r : members)
      for (std::int64_t j = o.node_offsets[r]; j < o.node_offsets[r + 1]; ++j)
        for (int d = 0; d < 3; ++d) {
          lo[d] = std::min(lo[d], pos[k][3 * j + d]);
          hi[d] = std::max(hi[d], pos[k][3 * j + d]);
        }
    out << "            " << frames[k] << ": [(" << float(lo[0] - pad) << ", " << float(lo[1] - pad) << ", "
        << float(lo[2] - pad) << "), (" << float(hi[0] + pad) << ", " << float(hi[1] + pad) << ", "
        << float(hi[2] + pad) << ")],\n";
  }
  out << "        }\n";
}

void write_points(std::ostream& out, const h5::Output& o, const std::vector<int>& members,
                  const std::vector<std::int64_t>& frames, const Frames& pos) {
  out << "        point3f[] points.timeSamples = {\n";
  for (std::size_t k = 0; k < frames.size(); ++k) {
    out << "            " << frames[k] << ": [";
    bool first = true;
    for (int r : members)
      for (std::int64_t j = o.node_offsets[r]; j < o.node_offsets[r + 1]; ++j) {
        const double* p = &pos[k][3 * j];
        out << (first ? "" : ", ") << '(' << float(p[0]) << ", " << float(p[1]) << ", " << float(p[2]) << ')';
        first = false;
      }
    out << "],\n";
  }
  out << "        }\n";
}

// ---- colliders (docs/contact.md): each a prim under /manyrods/colliders, its
// body-frame shape under an Xform that carries the collider's motion ----------

// p' = R p + c as a USD matrix (row vectors: rows are R's columns, then c).
void write_matrix(std::ostream& out, const Pose& p) {
  const Mat3& r = p.rotation;
  out << "( (" << r[0] << ", " << r[3] << ", " << r[6] << ", 0), (" << r[1] << ", " << r[4] << ", " << r[7]
      << ", 0), (" << r[2] << ", " << r[5] << ", " << r[8] << ", 0), (" << p.translation[0] << ", "
      << p.translation[1] << ", " << p.translation[2] << ", 1) )";
}

// Unit vectors u, v with (u, v, n) right-handed.
void plane_axes(const Vec3& n, Vec3& u, Vec3& v) {
  const double len = std::hypot(n[0], n[1], n[2]);
  const Vec3 nn{n[0] / len, n[1] / len, n[2] / len};
  const Vec3 a = std::abs(nn[0]) < 0.9 ? Vec3{1, 0, 0} : Vec3{0, 1, 0};
  u = {a[1] * nn[2] - a[2] * nn[1], a[2] * nn[0] - a[0] * nn[2], a[0] * nn[1] - a[1] * nn[0]};
  const double ul = std::hypot(u[0], u[1], u[2]);
  for (double& x : u) x /= ul;
  v = {nn[1] * u[2] - nn[2] * u[1], nn[2] * u[0] - nn[0] * u[2], nn[0] * u[1] - nn[1] * u[0]};
}

std::string p3(const Vec3& x) {
  char buf[96];
  std::snprintf(buf, sizeof buf, "(%.9g, %.9g, %.9g)", x[0], x[1], x[2]);
  return buf;
}

void write_shape(std::ostream& out, const Collider& c, double half_size) {
  switch (c.kind) {
    case ColliderKind::sphere:
      out << "            def Sphere \"shape\"\n            {\n                double radius = " << c.radius
          << "\n                double3 xformOp:translate = " << p3(c.center)
          << "\n                uniform token[] xformOpOrder = [\"xformOp:translate\"]\n            }\n";
      break;
    case ColliderKind::capsule: {
      const Vec3 d{c.b[0] - c.a[0], c.b[1] - c.a[1], c.b[2] - c.a[2]};
      const double h = std::hypot(d[0], d[1], d[2]);
      const Vec3 mid{0.5 * (c.a[0] + c.b[0]), 0.5 * (c.a[1] + c.b[1]), 0.5 * (c.a[2] + c.b[2])};
      // the rotation taking +z to d: axis z × d, angle acos(d_z/h), as a quaternion
      double q[4] = {1, 0, 0, 0};
      if (h > 0) {
        const Vec3 ax{-d[1], d[0], 0};
        const double s = std::hypot(ax[0], ax[1]), ang = std::atan2(s, d[2]);
        if (s > 0) q[0] = std::cos(ang / 2), q[1] = std::sin(ang / 2) * ax[0] / s, q[2] = std::sin(ang / 2) * ax[1] / s;
        else if (d[2] < 0) q[0] = 0, q[1] = 1;
      }
      out << "            def Capsule \"shape\"\n            {\n                uniform token axis = \"Z\"\n"
          << "                double height = " << h << "\n                double radius = " << c.radius
          << "\n                double3 xformOp:translate = " << p3(mid) << "\n                quatf xformOp:orient = ("
          << q[0] << ", " << q[1] << ", " << q[2] << ", " << q[3]
          << ")\n                uniform token[] xformOpOrder = [\"xformOp:translate\", \"xformOp:orient\"]\n            }\n";
      break;
    }
    case ColliderKind::plane: {
      Vec3 u, v;
      plane_axes(c.normal, u, v);
      out << "            def Mesh \"shape\"\n            {\n                int[] faceVertexCounts = [4]\n"
          << "                int[] faceVertexIndices = [0, 1, 2, 3]\n                point3f[] points = [";
      const double su[4] = {-1, 1, 1, -1}, sv[4] = {-1, -1, 1, 1};
      for (int i = 0; i < 4; ++i) {
        Vec3 x;
        for (int d = 0; d < 3; ++d) x[d] = c.point[d] + half_size * (su[i] * u[d] + sv[i] * v[d]);
        out << (i ? ", " : "") << p3(x);
      }
      out << "]\n                uniform token subdivisionScheme = \"none\"\n            }\n";
      break;
    }
    case ColliderKind::mesh: {
      const DistanceGrid& g = *c.grid;
      out << "            def Mesh \"shape\"\n            {\n                int[] faceVertexCounts = [";
      for (std::size_t i = 0; i < g.triangles.size() / 3; ++i) out << (i ? ", 3" : "3");
      out << "]\n                int[] faceVertexIndices = [";
      for (std::size_t i = 0; i < g.triangles.size(); ++i) out << (i ? ", " : "") << g.triangles[i];
      out << "]\n                point3f[] points = [";
      for (std::size_t i = 0; i < g.vertices.size(); ++i) out << (i ? ", " : "") << p3(g.vertices[i]);
      out << "]\n                uniform token subdivisionScheme = \"none\"\n            }\n";
      break;
    }
  }
}

// The scene's colliders, their motion sampled at the exported frames.
void write_colliders(std::ostream& out, const h5::Output& o, const std::vector<std::int64_t>& frames,
                     const Frames& pos) {
  if (o.scene_text.find("colliders") == std::string::npos) return;
  scene::Scene sc;
  try {
    sc = scene::parse_scene(o.scene_text, o.scene_source);
  } catch (const std::exception&) {
    return;  // a scene that no longer parses here (a mesh file moved): the rods alone
  }
  if (sc.contact.colliders.empty()) return;
  double half = 1;  // planes: a square twice the rods' extent in the first frame
  if (!pos.empty() && !pos[0].empty()) {
    double lo = HUGE_VAL, hi = -HUGE_VAL;
    for (double x : pos[0]) lo = std::min(lo, x), hi = std::max(hi, x);
    half = std::max(1e-3, hi - lo);
  }
  out << "    def Xform \"colliders\"\n    {\n";
  for (std::size_t i = 0; i < sc.contact.colliders.size(); ++i) {
    const Collider& c = sc.contact.colliders[i];
    out << "        def Xform \"" << prim_name(c.name, int(i), "collider") << "\"\n        {\n";
    if (c.motion) {
      out << "            matrix4d xformOp:transform.timeSamples = {\n";
      for (std::int64_t f : frames) {
        out << "                " << f << ": ";
        write_matrix(out, c.motion->at(o.time[std::size_t(f)]));
        out << ",\n";
      }
      out << "            }\n            uniform token[] xformOpOrder = [\"xformOp:transform\"]\n";
    }
    write_shape(out, c, half);
    out << "        }\n";
  }
  out << "    }\n";
}

}  // namespace

ExportResult export_usd(const std::string& in, const std::string& usd, int every) {
  if (every < 1) throw h5::H5Error(usd + ": every = " + std::to_string(every) + " (must be >= 1)");
  scene::check_extension(usd, {".usda", ".usd"}, "--usd", "USD ASCII (BasisCurves)");
  scene::check_not_input(usd, {in}, "--usd");
  const h5::Reader rd(in);
  const h5::Output& o = rd.output();
  if (rd.frames() == 0) throw h5::H5Error(in + ": no frames to export");
  const int rods = int(o.node_offsets.size()) - 1;
  int groups = 0;
  for (int g : o.rod_group) groups = std::max(groups, g + 1);
  std::vector<std::string> names = o.group_names;
  names.resize(std::size_t(groups));
  // (only the run's last frame can be closer to the one before; it keeps its index)
  const double fps = rd.frames() > 1 && o.time[1] > o.time[0] ? 1 / (o.time[1] - o.time[0]) : 1;
  std::vector<std::int64_t> frames;
  for (std::int64_t f = 0; f < rd.frames(); f += every) frames.push_back(f);
  if (frames.back() != rd.frames() - 1) frames.push_back(rd.frames() - 1);
  const Frames pos = read_frames(rd, in, frames);
  const std::string tmp = usd + ".tmp";
  {
    std::ofstream out(tmp);
    if (!out) throw h5::H5Error(usd + ": cannot write");
    out.precision(9);
    write_stage_header(out, in, frames.front(), frames.back(), fps);
    out << "def Xform \"manyrods\"\n{\n";
    for (int g = 0; g < groups; ++g) {
      std::vector<int> members;
      for (int r = 0; r < rods; ++r)
        if (o.rod_group[r] == g) members.push_back(r);
      if (members.empty()) continue;
      out << "    def BasisCurves \"" << prim_name(names[g], g) << "\"\n    {\n";
      write_topology(out, o, members);
      write_extent(out, o, members, frames, pos);
      write_points(out, o, members, frames, pos);
      out << "    }\n";
    }
    write_colliders(out, o, frames, pos);
    out << "}\n";
    if (!out) throw h5::H5Error(usd + ": error writing");
  }
  std::filesystem::rename(tmp, usd);
  return {frames.size(), rods};
}

}  // namespace manyrods::usd
