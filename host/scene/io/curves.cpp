// host/scene/io/curves.cpp — reading guide curves (USD ASCII, OBJ, HDF5) and rods
// from them (include/manyrods/curves.h).
#include "manyrods/curves.h"

#include <hdf5.h>
#include <tiny_obj_loader.h>

#include <Eigen/Geometry>

#include <algorithm>
#include <array>
#include <cctype>
#include <cmath>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <limits>
#include <sstream>
#include <string>
#include <utility>
#include <vector>

#include "manyrods/h5io.h"
#include "manyrods/material.h"

namespace manyrods::scene {
namespace {

[[noreturn]] void fail(const std::string& source, const std::string& msg) { throw InputError(source + ": " + msg); }

// set_usd_converter's (none by default)
UsdConverter& usd_converter() {
  static UsdConverter c;
  return c;
}

std::string read_text(const std::string& path) {
  std::error_code ec;
  if (std::filesystem::is_directory(path, ec)) fail(path, "cannot read the curve file (a directory)");
  std::ifstream in(path, std::ios::binary);
  if (!in) fail(path, "cannot read the curve file");
  std::stringstream ss;
  ss << in.rdbuf();
  return ss.str();
}

// ---- USD ASCII ---------------------------------------------------------------
// A scanner over the layer's text that knows strings, comments and nesting;
// enough of the .usda grammar to find BasisCurves prims and read their
// array-valued attributes.

struct Usda {
  std::string_view s;
  std::string source;

  int line_of(std::size_t i) const { return 1 + int(std::count(s.begin(), s.begin() + std::ptrdiff_t(i), '\n')); }
  [[noreturn]] void error(std::size_t at, const std::string& msg) const {
    fail(source + ":" + std::to_string(line_of(std::min(at, s.size()))), msg);
  }
  static bool ident(char c) { return std::isalnum(static_cast<unsigned char>(c)) || c == '_' || c == ':' || c == '.'; }

  // past the string starting at i ("…", '…', triple-quoted), or the comment
  std::size_t skip_string(std::size_t i) const {
    const char q = s[i];
    if (s.substr(i, 3) == std::string(3, q)) {
      const std::size_t e = s.find(std::string(3, q), i + 3);
      if (e == std::string_view::npos) error(i, "an unterminated string");
      return e + 3;
    }
    for (std::size_t k = i + 1; k < s.size(); ++k) {
      if (s[k] == '\\') ++k;
      else if (s[k] == q) return k + 1;
      else if (s[k] == '\n') break;
    }
    error(i, "an unterminated string");
  }
  std::size_t skip_space(std::size_t i) const {
    while (i < s.size()) {
      if (std::isspace(static_cast<unsigned char>(s[i]))) ++i;
      else if (s[i] == '#') i = std::min(s.find('\n', i), s.size());
      else break;
    }
    return i;
  }
  // the bracket closing the one at i ((, [ or {), across strings and comments
  std::size_t matching(std::size_t i) const {
    int depth = 0;
    for (std::size_t k = i; k < s.size();) {
      const char c = s[k];
      if (c == '"' || c == '\'') { k = skip_string(k); continue; }
      if (c == '#') { k = std::min(s.find('\n', k), s.size()); continue; }
      if (c == '(' || c == '[' || c == '{') ++depth;
      if (c == ')' || c == ']' || c == '}') {
        if (--depth == 0) return k;
      }
      ++k;
    }
    error(i, std::string("an unclosed '") + s[i] + "'");
  }
  std::string quoted(std::size_t& i) const {
    if (i >= s.size() || (s[i] != '"' && s[i] != '\'')) error(i, "expected a quoted string");
    const std::size_t e = skip_string(i);
    const std::size_t w = s.substr(i, 3) == std::string(3, s[i]) ? 3 : 1;
    std::string v(s.substr(i + w, e - i - 2 * w));
    i = e;
    return v;
  }

  struct Prim {
    std::string name;
    std::size_t begin, end;  // body, inside the braces
    // the bodies of the prims it is nested in, outermost first (their
    // transforms apply to it)
    std::vector<std::pair<std::size_t, std::size_t>> parents;
  };
  // Every `def BasisCurves "name" (…) { … }`, nested ones too.
  void find_prims(std::size_t from, std::size_t to, std::vector<Prim>& out,
                  std::vector<std::pair<std::size_t, std::size_t>> parents = {}) const {
    for (std::size_t i = from; i < to;) {
      const char c = s[i];
      if (c == '"' || c == '\'') { i = skip_string(i); continue; }
      if (c == '#') { i = std::min(s.find('\n', i), s.size()); continue; }
      if (!ident(c) || (i > 0 && ident(s[i - 1]))) { ++i; continue; }
      std::size_t e = i;
      while (e < to && ident(s[e])) ++e;
      const std::string_view tok = s.substr(i, e - i);
      if (tok != "def" && tok != "over" && tok != "class") { i = e; continue; }
      std::size_t k = skip_space(e);
      std::string type;
      if (k < to && ident(s[k])) {
        std::size_t te = k;
        while (te < to && ident(s[te])) ++te;
        type = std::string(s.substr(k, te - k));
        k = skip_space(te);
      }
      const std::string name = quoted(k);
      k = skip_space(k);
      if (k < to && s[k] == '(') k = skip_space(matching(k) + 1);
      if (k >= to || s[k] != '{') error(k, "prim \"" + name + "\": expected '{'");
      const std::size_t close = matching(k);
      if (type == "BasisCurves") out.push_back({name, k + 1, close, parents});
      parents.emplace_back(k + 1, close);
      find_prims(k + 1, close, out, parents);
      parents.pop_back();
      i = close + 1;
    }
  }

  struct Attr {
    std::size_t at = std::string_view::npos;  // where its value starts
    bool samples = false;                      // a .timeSamples dictionary
    bool found() const { return at != std::string_view::npos; }
  };
  // Attribute `name` of the prim (its default, else its time samples), not
  // of the prims nested in it.
  Attr find_attr(const Prim& p, std::string_view name) const {
    Attr def, samples;
    for (std::size_t i = p.begin; i < p.end;) {
      const char c = s[i];
      if (c == '"' || c == '\'') { i = skip_string(i); continue; }
      if (c == '#') { i = std::min(s.find('\n', i), s.size()); continue; }
      if (!ident(c)) { ++i; continue; }
      std::size_t e = i;
      while (e < p.end && ident(s[e])) ++e;
      const std::string_view tok = s.substr(i, e - i);
      if (tok == "def" || tok == "over" || tok == "class") {  // a child prim: skip it whole
        const std::size_t b = s.find('{', e);
        i = b < p.end ? matching(b) + 1 : p.end;
        continue;
      }
      const std::size_t k = skip_space(e);
      if (k < p.end && s[k] == '=') {
        if (tok == name) def.at = skip_space(k + 1);
        else if (tok.size() == name.size() + 12 && tok.substr(0, name.size()) == name &&
                 tok.substr(name.size()) == ".timeSamples")
          samples = {skip_space(k + 1), true};
      }
      i = e;
    }
    return def.found() ? def : samples;
  }

  // The numbers of the array value at i ('[' … ']', tuples flattened), of a
  // tuple ('(' … ')', a matrix's rows flattened), or one number.
  std::vector<double> numbers(std::size_t& i) const {
    if (i < s.size() && s[i] != '[' && s[i] != '(') {
      const std::string tok(s.substr(i, std::min<std::size_t>(64, s.size() - i)));
      char* end = nullptr;
      const double x = std::strtod(tok.c_str(), &end);
      if (end == tok.c_str()) error(i, "expected an array '[' or a number");
      i += std::size_t(end - tok.c_str());
      return {x};
    }
    if (i >= s.size()) error(i, "expected an array '['");
    const std::size_t close = matching(i);
    std::vector<double> v;
    for (std::size_t k = i + 1; k < close;) {
      const char c = s[k];
      if (std::isspace(static_cast<unsigned char>(c)) || c == ',' || c == '(' || c == ')') { ++k; continue; }
      const std::string tok(s.substr(k, std::min<std::size_t>(64, close - k)));
      char* end = nullptr;
      const double x = std::strtod(tok.c_str(), &end);
      if (end == tok.c_str()) error(k, "not a number: '" + tok.substr(0, tok.find_first_of(",) \n")) + "'");
      v.push_back(x);
      k += std::size_t(end - tok.c_str());
    }
    i = close + 1;
    return v;
  }
  // The attribute's value: its default, or its earliest time sample.
  std::vector<double> values(const Attr& a, const std::string& what) const {
    std::size_t i = a.at;
    if (!a.samples) {
      if (s.substr(i, 4) == "None") error(i, what + " is None");
      return numbers(i);
    }
    if (i >= s.size() || s[i] != '{') error(i, what + ".timeSamples: expected '{'");
    const std::size_t close = matching(i);
    double best = std::numeric_limits<double>::infinity();
    std::vector<double> v;
    bool any = false;
    for (std::size_t k = skip_space(i + 1); k < close; k = skip_space(k)) {
      if (s[k] == ',') { ++k; continue; }
      const std::string tok(s.substr(k, std::min<std::size_t>(64, close - k)));
      char* end = nullptr;
      const double t = std::strtod(tok.c_str(), &end);
      if (end == tok.c_str()) error(k, what + ".timeSamples: expected a time");
      k = skip_space(k + std::size_t(end - tok.c_str()));
      if (k >= close || s[k] != ':') error(k, what + ".timeSamples: expected ':' after the time");
      k = skip_space(k + 1);
      if (s.substr(k, 4) == "None") { k += 4; continue; }
      if (t < best) {
        best = t;
        v = numbers(k);
        any = true;
      } else if (s[k] == '[' || s[k] == '(') {
        k = matching(k) + 1;
      } else {
        (void)numbers(k);
      }
    }
    if (!any) error(a.at, what + ".timeSamples: no sample");
    return v;
  }
  // The quoted strings of the array at i (a token[]).
  std::vector<std::string> tokens(std::size_t i) const {
    if (i >= s.size() || s[i] != '[') error(i, "expected an array of tokens '['");
    const std::size_t close = matching(i);
    std::vector<std::string> v;
    for (std::size_t k = skip_space(i + 1); k < close; k = skip_space(k)) {
      if (s[k] == ',') { ++k; continue; }
      v.push_back(quoted(k));
    }
    return v;
  }

  // The local transform of the prim whose body is [begin, end) (its
  // xformOpOrder applied in order, column vectors: M = Op_0 Op_1 …;
  // "!invert!" ops inverted), and whether it resets its parents' stack.
  Eigen::Affine3d local_transform(std::size_t begin, std::size_t end, const std::string& where, bool& reset) const {
    const Prim body{"", begin, end, {}};
    Eigen::Affine3d m = Eigen::Affine3d::Identity();
    reset = false;
    const Attr order = find_attr(body, "xformOpOrder");
    if (!order.found()) return m;
    for (std::string op : tokens(order.at)) {
      if (op == "!resetXformStack!") {
        reset = true;
        m.setIdentity();
        continue;
      }
      const bool invert = op.rfind("!invert!", 0) == 0;
      if (invert) op = op.substr(8);
      const Attr a = find_attr(body, op);
      if (!a.found()) error(order.at, where + ": xformOpOrder names " + op + ", which the prim does not have");
      const std::vector<double> v = values(a, where + " " + op);
      // the op's kind: xformOp:<kind>[:suffix]
      const std::string kind = op.substr(8, op.find(':', 8) == std::string::npos ? std::string::npos : op.find(':', 8) - 8);
      auto need = [&](std::size_t count) {
        if (v.size() != count)
          error(a.at, where + ": " + op + " has " + std::to_string(v.size()) + " numbers, " + std::to_string(count) +
                          " expected");
      };
      constexpr double kDeg = 3.14159265358979323846 / 180;
      auto axis = [](char c) { return c == 'X' ? Eigen::Vector3d::UnitX() : c == 'Y' ? Eigen::Vector3d::UnitY() : Eigen::Vector3d::UnitZ(); };
      Eigen::Affine3d t = Eigen::Affine3d::Identity();
      if (kind == "translate") {
        need(3);
        t.translate(Eigen::Vector3d(v[0], v[1], v[2]));
      } else if (kind == "scale") {
        need(3);
        t.scale(Eigen::Vector3d(v[0], v[1], v[2]));
      } else if (kind == "rotateX" || kind == "rotateY" || kind == "rotateZ") {
        need(1);
        t.rotate(Eigen::AngleAxisd(v[0] * kDeg, axis(kind[6])));
      } else if (kind.size() == 9 && kind.rfind("rotate", 0) == 0) {  // rotateXYZ …: the first axis turns first
        need(3);
        for (int j = 2; j >= 0; --j) {
          const char c = kind[std::size_t(6 + j)];
          t.rotate(Eigen::AngleAxisd(v[std::size_t(c - 'X')] * kDeg, axis(c)));
        }
      } else if (kind == "orient") {
        need(4);  // (real, i, j, k)
        t.rotate(Eigen::Quaterniond(v[0], v[1], v[2], v[3]).normalized());
      } else if (kind == "transform") {
        need(16);  // rows, row vectors: the transpose of ours
        Eigen::Matrix4d r;
        for (int row = 0; row < 4; ++row)
          for (int col = 0; col < 4; ++col) r(col, row) = v[std::size_t(4 * row + col)];
        t.matrix() = r;
      } else {
        error(a.at, where + ": " + op + ": an xformOp this reader does not apply (translate, scale, rotateX/Y/Z, "
                                        "rotateXYZ and the other orders, orient, transform)");
      }
      m = m * (invert ? t.inverse() : t);
    }
    return m;
  }

  // The prim's points' transform to the layer's world: its parents' and
  // its own (a !resetXformStack! drops what came before it).
  Eigen::Affine3d world_transform(const Prim& p, const std::string& where) const {
    Eigen::Affine3d m = Eigen::Affine3d::Identity();
    bool reset = false;
    for (const auto& [b, e] : p.parents) {
      const Eigen::Affine3d l = local_transform(b, e, where, reset);
      m = reset ? l : Eigen::Affine3d(m * l);
    }
    const Eigen::Affine3d l = local_transform(p.begin, p.end, where, reset);
    return reset ? l : Eigen::Affine3d(m * l);
  }

  std::string token(const Prim& p, std::string_view name, const std::string& fallback) const {
    const Attr a = find_attr(p, name);
    if (!a.found()) return fallback;
    std::size_t i = a.at;
    return quoted(i);
  }
};

using V3 = std::array<double, 3>;

// Cubic segment of four control points at parameter u (USD's bases).
V3 cubic(const std::string& basis, const V3& p0, const V3& p1, const V3& p2, const V3& p3, double u) {
  double w[4];
  const double u2 = u * u, u3 = u2 * u, m = 1 - u;
  if (basis == "bezier") {
    w[0] = m * m * m, w[1] = 3 * m * m * u, w[2] = 3 * m * u2, w[3] = u3;
  } else if (basis == "bspline") {
    w[0] = m * m * m / 6, w[1] = (3 * u3 - 6 * u2 + 4) / 6, w[2] = (-3 * u3 + 3 * u2 + 3 * u + 1) / 6, w[3] = u3 / 6;
  } else {  // catmullRom
    w[0] = 0.5 * (-u3 + 2 * u2 - u), w[1] = 0.5 * (3 * u3 - 5 * u2 + 2), w[2] = 0.5 * (-3 * u3 + 4 * u2 + u),
    w[3] = 0.5 * (u3 - u2);
  }
  V3 r{};
  for (int c = 0; c < 3; ++c) r[c] = w[0] * p0[c] + w[1] * p1[c] + w[2] * p2[c] + w[3] * p3[c];
  return r;
}

// The polyline of one cubic curve (control points cv), 16 points per segment.
std::vector<Vec3> evaluate(const std::vector<Vec3>& cv0, const std::string& basis, const std::string& wrap,
                           const std::string& label) {
  std::vector<Vec3> cv = cv0;
  const std::size_t n = cv.size();
  if (basis == "bezier") {
    if (n < 4 || (n - 1) % 3 != 0)
      throw InputError(label + ": a cubic bezier curve needs 3k + 1 points (got " + std::to_string(n) + ")");
  } else {
    if (wrap == "pinned" && n >= 2) {  // phantom end points: the curve starts and ends at the first and last
      Vec3 a, b;
      for (int c = 0; c < 3; ++c) {
        a[c] = 2 * cv[0][c] - cv[1][c];
        b[c] = 2 * cv[n - 1][c] - cv[n - 2][c];
      }
      cv.insert(cv.begin(), a);
      cv.push_back(b);
    }
    if (cv.size() < 4)
      throw InputError(label + ": a cubic " + basis + " curve needs at least 4 points (got " + std::to_string(n) + ")");
  }
  const std::size_t step = basis == "bezier" ? 3 : 1, segments = (cv.size() - 4) / step + 1;
  constexpr int kPer = 16;
  std::vector<Vec3> out;
  for (std::size_t g = 0; g < segments; ++g)
    for (int j = g == 0 ? 0 : 1; j <= kPer; ++j) {
      const std::size_t o = g * step;
      out.push_back(cubic(basis, cv[o], cv[o + 1], cv[o + 2], cv[o + 3], double(j) / kPer));
    }
  return out;
}

// Varying values of a cubic curve: one per segment end.
std::size_t varying_count(std::size_t points, const std::string& type, const std::string& basis,
                          const std::string& wrap) {
  if (type == "linear") return points;
  if (basis == "bezier") return points >= 4 ? (points - 1) / 3 + 1 : 0;
  const std::size_t cv = points + (wrap == "pinned" ? 2 : 0);
  return cv >= 4 ? cv - 3 + 1 : 0;
}

double mean(const std::vector<double>& v, std::size_t b, std::size_t e) {
  double s = 0;
  for (std::size_t i = b; i < e; ++i) s += v[i];
  return s / double(e - b);
}

// Curve c's mean width from a file's widths: constant (1 value), uniform
// (one per curve), vertex (one per point; the curve's are [o, o + n)); -1
// when the widths are none of these (the caller's other forms, or none).
double curve_width(const std::vector<double>& w, std::size_t curves, std::size_t points, std::size_t c,
                   std::size_t o, std::size_t n) {
  if (w.size() == 1) return w[0];
  if (w.size() == curves && w.size() != points) return w[c];
  if (w.size() == points && n > 0) return mean(w, o, o + n);
  return -1;
}

// `count` widths w[o, o + count) spread over `points` points by index (a
// cubic curve's samples follow its parameter, as its control points do).
std::vector<double> spread_widths(const std::vector<double>& w, std::size_t o, std::size_t count, std::size_t points) {
  std::vector<double> out(points);
  for (std::size_t i = 0; i < points; ++i) {
    const double t = points > 1 ? double(i) * double(count - 1) / double(points - 1) : 0.0;
    const std::size_t j = std::min(count - 1, std::size_t(t));
    const double a = t - double(j);
    out[i] = j + 1 < count ? (1 - a) * w[o + j] + a * w[o + j + 1] : w[o + j];
  }
  return out;
}

void check_width(const Curve& k) {
  if (!(k.width > 0 && std::isfinite(k.width)))
    throw InputError(k.label + ": widths must be finite and > 0 (mean " + std::to_string(k.width) + ")");
}

}  // namespace

std::vector<Curve> read_usda_curves(std::string_view text, const std::string& source) {
  const Usda u{text, source};
  if (text.substr(0, 5) != "#usda")
    fail(source, "not a USD ASCII layer (the first line must be \"#usda 1.0\"; binary .usdc is not read: convert it "
                 "with usdcat)");
  std::vector<Usda::Prim> prims;
  u.find_prims(0, text.size(), prims);
  if (prims.empty()) fail(source, "no BasisCurves prim");
  std::vector<Curve> out;
  for (const Usda::Prim& p : prims) {
    const std::string where = "BasisCurves \"" + p.name + "\"";
    const Usda::Attr pa = u.find_attr(p, "points"), ca = u.find_attr(p, "curveVertexCounts");
    if (!pa.found()) u.error(p.begin, where + ": no points");
    if (!ca.found()) u.error(p.begin, where + ": no curveVertexCounts");
    std::vector<double> xyz = u.values(pa, where + " points");
    const std::vector<double> counts = u.values(ca, where + " curveVertexCounts");
    if (xyz.size() % 3 != 0) u.error(pa.at, where + ": points: " + std::to_string(xyz.size()) + " numbers, not x y z triples");
    // the prim's transform and its parents' (xformOps): points to the
    // layer's world frame, widths by the transform's mean scale
    const Eigen::Affine3d world = u.world_transform(p, where);
    const double width_scale = std::cbrt(std::abs(world.linear().determinant()));
    if (!world.matrix().isIdentity(0))
      for (std::size_t i = 0; i + 2 < xyz.size(); i += 3) {
        const Eigen::Vector3d x = world * Eigen::Vector3d(xyz[i], xyz[i + 1], xyz[i + 2]);
        xyz[i] = x[0], xyz[i + 1] = x[1], xyz[i + 2] = x[2];
      }
    std::size_t total = 0;
    for (double c : counts) {
      if (!(c >= 0) || c != std::floor(c)) u.error(ca.at, where + ": curveVertexCounts: not a count: " + std::to_string(c));
      total += std::size_t(c);
    }
    if (total != xyz.size() / 3)
      u.error(ca.at, where + ": curveVertexCounts add up to " + std::to_string(total) + " points, points has " +
                         std::to_string(xyz.size() / 3));
    const std::string type = u.token(p, "type", "cubic"), basis = u.token(p, "basis", "bezier"),
                      wrap = u.token(p, "wrap", "nonperiodic");
    if (type != "linear" && type != "cubic") u.error(p.begin, where + ": type \"" + type + "\" is not linear or cubic");
    if (type == "cubic" && basis != "bezier" && basis != "bspline" && basis != "catmullRom")
      u.error(p.begin, where + ": basis \"" + basis + "\" is not bezier, bspline or catmullRom");
    if (wrap == "periodic") u.error(p.begin, where + ": periodic (closed) curves are not rods");
    if (wrap != "nonperiodic" && wrap != "pinned") u.error(p.begin, where + ": wrap \"" + wrap + "\" is not nonperiodic or pinned");
    Usda::Attr wa = u.find_attr(p, "widths");
    if (!wa.found()) wa = u.find_attr(p, "primvars:widths");
    std::vector<double> widths;
    if (wa.found()) widths = u.values(wa, where + " widths");
    for (double& w : widths) w *= width_scale;
    std::size_t varying_total = 0;
    for (double c : counts) varying_total += varying_count(std::size_t(c), type, basis, wrap);
    const std::size_t nw = widths.size();
    if (wa.found() && nw != 1 && nw != counts.size() && nw != total && nw != varying_total)
      u.error(wa.at, where + ": widths: " + std::to_string(nw) + " values for " + std::to_string(counts.size()) +
                         " curves of " + std::to_string(total) + " points (constant: 1, uniform: one per curve, vertex: "
                         "one per point, varying: " + std::to_string(varying_total) + ")");
    std::size_t o = 0, ov = 0;
    for (std::size_t c = 0; c < counts.size(); ++c) {
      const std::size_t n = std::size_t(counts[c]), nv = varying_count(n, type, basis, wrap);
      Curve k;
      k.label = source + ": " + where + " curve " + std::to_string(c) + " (curve " + std::to_string(out.size()) +
                " of the file)";
      std::vector<Vec3> pts(n);
      for (std::size_t i = 0; i < n; ++i) pts[i] = {xyz[3 * (o + i)], xyz[3 * (o + i) + 1], xyz[3 * (o + i) + 2]};
      if (wa.found()) {
        k.width = curve_width(widths, counts.size(), total, c, o, n);
        if (k.width == -1 && nw == varying_total && nv > 0) k.width = mean(widths, ov, ov + nv);
        check_width(k);
      }
      if (type == "cubic") {
        for (const Vec3& q : pts)
          for (double x : q)
            if (!std::isfinite(x)) throw InputError(k.label + ": a point is not finite");
        k.points = evaluate(pts, basis, wrap, k.label);
        k.evaluated = true;
      } else {
        k.points = std::move(pts);
      }
      // per-point widths (a tapered strand): vertex or varying
      if (wa.found() && nw == total && nw != counts.size() && n > 1)
        k.point_widths = spread_widths(widths, o, n, k.points.size());
      else if (wa.found() && nw == varying_total && nw != counts.size() && nv > 1)
        k.point_widths = spread_widths(widths, ov, nv, k.points.size());
      out.push_back(std::move(k));
      o += n;
      ov += nv;
    }
  }
  return out;
}

std::vector<Curve> read_obj_curves(const std::string& path) {
  const std::string text = read_text(path);
  tinyobj::ObjReaderConfig config;
  config.triangulate = false;
  config.vertex_color = false;
  tinyobj::ObjReader reader;
  if (!reader.ParseFromString(text, "", config))
    fail(path, "not an OBJ file that tinyobjloader parses: " + reader.Error());
  const std::vector<tinyobj::real_t>& xyz = reader.GetAttrib().vertices;
  const std::size_t nv = xyz.size() / 3;
  std::vector<Curve> out;
  for (const tinyobj::shape_t& s : reader.GetShapes()) {
    std::size_t at = 0;
    for (std::size_t l = 0; l < s.lines.num_line_vertices.size(); ++l) {
      const std::size_t n = std::size_t(s.lines.num_line_vertices[l]);
      Curve c;
      c.label = path + ": " + (s.name.empty() ? std::string() : "object \"" + s.name + "\" ") + "line " +
                std::to_string(l) + " (curve " + std::to_string(out.size()) + " of the file)";
      for (std::size_t i = 0; i < n; ++i) {
        const int v = s.lines.indices[at + i].vertex_index;
        if (v < 0 || std::size_t(v) >= nv)
          throw InputError(c.label + ": uses vertex " + std::to_string(v + 1) + ", the file has " + std::to_string(nv));
        c.points.push_back({xyz[3 * std::size_t(v)], xyz[3 * std::size_t(v) + 1], xyz[3 * std::size_t(v) + 2]});
      }
      at += n;
      out.push_back(std::move(c));
    }
  }
  if (out.empty()) fail(path, "no polylines (`l` records)");
  return out;
}

namespace {

struct H5 {
  hid_t id;
  herr_t (*close)(hid_t);
  ~H5() {
    if (id >= 0) close(id);
  }
};

std::vector<double> read_dataset(hid_t file, const char* name, const std::string& path, std::vector<hsize_t>& dims,
                                 bool required) {
  if (H5Lexists(file, name, H5P_DEFAULT) <= 0) {
    if (required) fail(path, std::string(name) + ": missing (the curve layout: docs/scenes.md \"Grooms from curves\")");
    dims.clear();
    return {};
  }
  const H5 d{H5Dopen2(file, name, H5P_DEFAULT), H5Dclose};
  if (d.id < 0) fail(path, std::string(name) + ": cannot open the dataset");
  const H5 sp{H5Dget_space(d.id), H5Sclose};
  const int rank = H5Sget_simple_extent_ndims(sp.id);
  if (rank < 1 || rank > 2) fail(path, std::string(name) + ": rank " + std::to_string(rank) + ", expected 1 or 2");
  dims.assign(std::size_t(rank), 0);
  H5Sget_simple_extent_dims(sp.id, dims.data(), nullptr);
  std::size_t n = 1;
  for (hsize_t x : dims) n *= std::size_t(x);
  if (n > (std::size_t(1) << 32)) fail(path, std::string(name) + ": too large");
  const H5 ty{H5Dget_type(d.id), H5Tclose};
  const H5T_class_t cls = H5Tget_class(ty.id);
  if (cls != H5T_FLOAT && cls != H5T_INTEGER) fail(path, std::string(name) + ": not numbers");
  std::vector<double> v(n);
  if (n > 0 && H5Dread(d.id, H5T_NATIVE_DOUBLE, H5S_ALL, H5S_ALL, H5P_DEFAULT, v.data()) < 0)
    fail(path, std::string(name) + ": cannot read it");
  return v;
}

}  // namespace

std::vector<Curve> read_h5_curves(const std::string& path) {
  H5Eset_auto2(H5E_DEFAULT, nullptr, nullptr);
  std::error_code ec;
  if (!std::filesystem::is_regular_file(path, ec)) fail(path, "cannot read the curve file");
  if (H5Fis_hdf5(path.c_str()) <= 0) fail(path, "not an HDF5 file");
  const H5 f{H5Fopen(path.c_str(), H5F_ACC_RDONLY, H5P_DEFAULT), H5Fclose};
  if (f.id < 0) fail(path, "cannot open the HDF5 file");
  if (H5Lexists(f.id, "curves", H5P_DEFAULT) <= 0) fail(path, "/curves: missing (docs/scenes.md \"Grooms from curves\")");
  std::vector<hsize_t> pd, cd, wd;
  const std::vector<double> xyz = read_dataset(f.id, "curves/points", path, pd, true);
  const std::vector<double> counts = read_dataset(f.id, "curves/curve_vertex_counts", path, cd, true);
  const std::vector<double> widths = read_dataset(f.id, "curves/widths", path, wd, false);
  if (pd.size() != 2 || pd[1] != 3) fail(path, "/curves/points: shape must be [N, 3]");
  if (cd.size() != 1) fail(path, "/curves/curve_vertex_counts: shape must be [C]");
  std::size_t total = 0;
  for (double c : counts) {
    if (!(c >= 0) || c != std::floor(c)) fail(path, "/curves/curve_vertex_counts: not a count: " + std::to_string(c));
    total += std::size_t(c);
  }
  if (total != pd[0])
    fail(path, "/curves/curve_vertex_counts add up to " + std::to_string(total) + " points, /curves/points has " +
                   std::to_string(pd[0]));
  const std::size_t nw = widths.size();
  if (!wd.empty() && (wd.size() != 1 || (nw != 1 && nw != counts.size() && nw != total)))
    fail(path, "/curves/widths: " + std::to_string(nw) + " values: 1, one per curve (" + std::to_string(counts.size()) +
                   ") or one per point (" + std::to_string(total) + ")");
  std::vector<Curve> out;
  std::size_t o = 0;
  for (std::size_t c = 0; c < counts.size(); ++c) {
    const std::size_t n = std::size_t(counts[c]);
    Curve k;
    k.label = path + ": curve " + std::to_string(c);
    for (std::size_t i = 0; i < n; ++i) k.points.push_back({xyz[3 * (o + i)], xyz[3 * (o + i) + 1], xyz[3 * (o + i) + 2]});
    if (nw > 0) {
      k.width = curve_width(widths, counts.size(), total, c, o, n);
      check_width(k);
      if (nw == total && nw != counts.size() && n > 1) k.point_widths.assign(widths.begin() + long(o), widths.begin() + long(o + n));
    }
    out.push_back(std::move(k));
    o += n;
  }
  if (out.empty()) fail(path, "/curves: no curves");
  return out;
}

void write_h5_curves(const std::string& path, const std::vector<Curve>& curves) {
  H5Eset_auto2(H5E_DEFAULT, nullptr, nullptr);
  auto bad = [&](const std::string& what) { throw h5::H5Error(path + ": " + what); };
  const H5 f{H5Fcreate(path.c_str(), H5F_ACC_TRUNC, H5P_DEFAULT, H5P_DEFAULT), H5Fclose};
  if (f.id < 0) bad("cannot create the file");
  const H5 g{H5Gcreate2(f.id, "curves", H5P_DEFAULT, H5P_DEFAULT, H5P_DEFAULT), H5Gclose};
  std::vector<double> xyz, widths;
  std::vector<long long> counts;
  bool all_widths = !curves.empty(), all_point_widths = !curves.empty();
  std::vector<double> point_widths;
  for (const Curve& c : curves) {
    counts.push_back((long long)c.points.size());
    for (const Vec3& p : c.points) xyz.insert(xyz.end(), p.begin(), p.end());
    all_widths = all_widths && c.width > 0;
    widths.push_back(c.width);
    all_point_widths = all_point_widths && c.point_widths.size() == c.points.size();
    point_widths.insert(point_widths.end(), c.point_widths.begin(), c.point_widths.end());
  }
  if (all_point_widths) widths = point_widths;  // one per point (a tapered groom)
  auto write = [&](const char* name, hid_t type, const void* data, std::vector<hsize_t> dims) {
    const H5 sp{H5Screate_simple(int(dims.size()), dims.data(), nullptr), H5Sclose};
    const H5 d{H5Dcreate2(g.id, name, type, sp.id, H5P_DEFAULT, H5P_DEFAULT, H5P_DEFAULT), H5Dclose};
    if (d.id < 0 || H5Dwrite(d.id, type, H5S_ALL, H5S_ALL, H5P_DEFAULT, data) < 0) bad(std::string("cannot write ") + name);
  };
  write("points", H5T_NATIVE_DOUBLE, xyz.data(), {hsize_t(xyz.size() / 3), 3});
  write("curve_vertex_counts", H5T_NATIVE_LLONG, counts.data(), {hsize_t(counts.size())});
  if (all_widths) write("widths", H5T_NATIVE_DOUBLE, widths.data(), {hsize_t(widths.size())});
}

std::vector<Curve> read_curves(const std::string& path) {
  const std::string ext = std::filesystem::path(path).extension().string();
  if (ext == ".usda") return read_usda_curves(read_text(path), path);
  if (ext == ".obj") return read_obj_curves(path);
  if (ext == ".h5" || ext == ".hdf5") return read_h5_curves(path);
  if (ext == ".usd" || ext == ".usdc" || ext == ".usdz") {
    if (ext == ".usd") {  // .usd may be text
      const std::string text = read_text(path);
      if (text.rfind("#usda", 0) == 0) return read_usda_curves(text, path);
    }
    const UsdConverter& convert = usd_converter();
    if (!convert)
      fail(path, "binary USD is read through OpenUSD: from Python with usd-core installed (pip install usd-core), "
                 "or convert it to USD ASCII first (usdcat " + std::filesystem::path(path).filename().string() +
                 " -o groom.usda) and give the .usda");
    return read_usda_curves(convert(path), path);
  }
  fail(path, "a curve file is .usda, .usd, .usdc, .usdz (binary USD through OpenUSD), .obj or .h5 (got \"" + ext + "\")");
}

void set_usd_converter(UsdConverter converter) { usd_converter() = std::move(converter); }

RodSpec rod_from_curve(const Curve& c, int elements) {
  const std::vector<Vec3>& p = c.points;
  if (p.size() < 2) throw InputError(c.label + ": " + std::to_string(p.size()) + " point(s); a rod needs at least 2");
  std::vector<double> s(p.size(), 0.0);  // arc length at each point
  for (std::size_t i = 0; i < p.size(); ++i) {
    for (double x : p[i])
      if (!std::isfinite(x)) throw InputError(c.label + ": point " + std::to_string(i) + " is not finite");
    if (i == 0) continue;
    const double d = std::hypot(p[i][0] - p[i - 1][0], p[i][1] - p[i - 1][1], p[i][2] - p[i - 1][2]);
    if (!(d > 0))
      throw InputError(c.label + ": points " + std::to_string(i - 1) + " and " + std::to_string(i) +
                       " coincide (repeated points make no element)");
    s[i] = s[i - 1] + d;
  }
  const double length = s.back();
  if (!(length > 1e-12)) throw InputError(c.label + ": the curve is shorter than 1e-12 m");
  if (elements < 0) throw InputError(c.label + ": elements must be >= 0 (0: keep the curve's points)");
  if (elements == 0 && c.evaluated)
    throw InputError(c.label + ": a cubic curve is resampled: give `elements` (its control points are not on it)");
  std::vector<Vec3> x;
  std::vector<double> w;  // the widths at x (a tapered curve)
  const bool tapered = c.point_widths.size() == p.size();
  if (elements == 0) {
    x = p;
    if (tapered) w = c.point_widths;
  } else {  // equal arc length along the polyline
    x.resize(std::size_t(elements) + 1);
    if (tapered) w.resize(std::size_t(elements) + 1);
    std::size_t k = 0;
    for (int i = 0; i <= elements; ++i) {
      const double t = length * double(i) / elements;
      while (k + 2 < p.size() && s[k + 1] < t) ++k;
      const double a = std::clamp((t - s[k]) / (s[k + 1] - s[k]), 0.0, 1.0);
      for (int d = 0; d < 3; ++d) x[std::size_t(i)][d] = (1 - a) * p[k][d] + a * p[k + 1][d];
      if (tapered) w[std::size_t(i)] = (1 - a) * c.point_widths[k] + a * c.point_widths[k + 1];
    }
    x.front() = p.front();
    x.back() = p.back();
  }
  if (tapered)
    for (std::size_t i = 0; i < w.size(); ++i)
      if (!(w[i] > 0 && std::isfinite(w[i])))
        throw InputError(c.label + ": width " + std::to_string(w[i]) + " at point " + std::to_string(i) +
                         ": widths must be finite and > 0");
  // the lab axis least aligned with the first element: d1 starts there, made orthogonal
  const Vec3 t{x[1][0] - x[0][0], x[1][1] - x[0][1], x[1][2] - x[0][2]};
  int a = 0;
  for (int i = 1; i < 3; ++i)
    if (std::abs(t[i]) < std::abs(t[a])) a = i;
  Vec3 n{0, 0, 0};
  n[a] = 1;
  std::vector<Mat3> q = RodSpec::parallel_transport_frames(x, n);
  RodSpec r = RodSpec::polyline(std::move(x), std::move(q));
  if (c.width > 0) r.section = Section::circle(0.5 * c.width);
  // tapered: each element's section scaled by its mean width over the curve's mean
  if (tapered && c.width > 0)
    for (std::size_t e = 0; e + 1 < w.size(); ++e) r.section_scale.push_back(0.5 * (w[e] + w[e + 1]) / c.width);
  return r;
}

}  // namespace manyrods::scene
