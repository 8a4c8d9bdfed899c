// host/usd.cpp — USD ASCII export of a run (include/manyrods/usd.h).
#include "manyrods/usd.h"

#include <algorithm>
#include <cctype>
#include <cmath>
#include <cstdint>
#include <filesystem>
#include <fstream>
#include <ostream>
#include <vector>

#include "manyrods/h5io.h"

namespace manyrods::usd {
namespace {

using Frames = std::vector<std::vector<double>>;  // [samples][3 × nodes] positions

std::string prim_name(const std::string& s, int index) {
  std::string n = "group_" + std::to_string(index) + "_";
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
    for (std::int64_t j = o.node_offsets[r]; j < o.node_offsets[r + 1]; ++j) {
      out << (first ? "" : ", ") << o.rod_width[r];
      first = false;
    }
  out << "] (\n            interpolation = \"vertex\"\n        )\n";
}

// extent (the schema asks for it wherever the points change): the points'
// box padded by half the widest section, per time sample.
void write_extent(std::ostream& out, const h5::Output& o, const std::vector<int>& members,
                  const std::vector<std::int64_t>& frames, const Frames& pos) {
  double pad = 0;
  for (int r : members) pad = std::max(pad, 0.5 * o.rod_width[r]);
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

}  // namespace

ExportResult export_usd(const std::string& in, const std::string& usd, int every) {
  if (every < 1) throw h5::H5Error(usd + ": every = " + std::to_string(every) + " (must be >= 1)");
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
    out << "}\n";
    if (!out) throw h5::H5Error(usd + ": error writing");
  }
  std::filesystem::rename(tmp, usd);
  return {frames.size(), rods};
}

}  // namespace manyrods::usd
