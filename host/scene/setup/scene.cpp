// host/scene/setup/scene.cpp — parsing and validating TOML scenes (include/manyrods/scene.h,
// docs/scenes.md). toml++ keeps the source position of every node, so each
// error names file, line, column and the key path.
#include "manyrods/scene.h"

#include "manyrods/mesh.h"
#include "manyrods/curves.h"

#include "manyrods/isa.h"
#include "manyrods/rng.h"

#include <toml++/toml.h>

#include <Eigen/Dense>
#include <cmath>
#include <filesystem>
#include <fstream>
#include <limits>
#include <map>
#include <memory>
#include <numbers>
#include <set>
#include <sstream>

namespace manyrods::scene {
namespace {

using E3 = Eigen::Vector3d;

E3 to_e(const Vec3& v) { return {v[0], v[1], v[2]}; }
Vec3 from_e(const E3& v) { return {v[0], v[1], v[2]}; }

std::string num(double v) {
  std::ostringstream os;
  os.precision(10);
  os << v;
  return os.str();
}

// Context of one scene being parsed.
struct Ctx {
  std::string source;
  std::set<const toml::node*> overridden;  // nodes set by --vary (no source position)
  // motion = "host" tables by name, one HostMotion per name (Scene::host_motions)
  mutable std::vector<std::shared_ptr<HostMotion>> host_motions;
  // the files a scene reads besides itself (Scene::inputs)
  mutable std::vector<std::string> inputs;

  std::string where(const toml::node& n) const {
    const auto& b = n.source().begin;
    if (overridden.count(&n) || b.line == 0) return source + ": ";
    return source + ":" + std::to_string(b.line) + ":" + std::to_string(b.column) + ": ";
  }
  std::string tag(const toml::node& n) const { return overridden.count(&n) ? " (set by --vary)" : ""; }
  [[noreturn]] void fail(const toml::node& n, const std::string& path, const std::string& msg) const {
    throw SceneError(where(n) + path + tag(n) + ": " + msg);
  }
};

const char* type_name(const toml::node& n) {
  switch (n.type()) {
    case toml::node_type::table:
      return "a table";
    case toml::node_type::array:
      return "an array";
    case toml::node_type::string:
      return "a string";
    case toml::node_type::integer:
      return "an integer";
    case toml::node_type::floating_point:
      return "a float";
    case toml::node_type::boolean:
      return "a boolean";
    default:
      return "a date/time";
  }
}

// A table with a fixed set of allowed keys.
struct Table {
  const Ctx& ctx;
  const toml::table& t;
  std::string path;  // "rods.0.material"

  Table(const Ctx& c, const toml::table& tbl, std::string p, std::initializer_list<const char*> allowed)
      : Table(c, tbl, std::move(p), std::vector<const char*>(allowed)) {}
  Table(const Ctx& c, const toml::table& tbl, std::string p, const std::vector<const char*>& allowed)
      : ctx(c), t(tbl), path(std::move(p)) {
    for (auto&& [k, v] : t) {
      bool ok = false;
      for (const char* a : allowed) ok = ok || k.str() == a;
      if (!ok) {
        std::string list;
        for (const char* a : allowed) list += std::string(list.empty() ? "" : ", ") + a;
        const auto& b = k.source().begin;
        const std::string loc =
            b.line ? ctx.source + ":" + std::to_string(b.line) + ":" + std::to_string(b.column) + ": "
                   : ctx.where(v);
        throw SceneError(loc + key(std::string(k.str())) + ": unknown key (allowed here: " + list + ")");
      }
    }
  }
  std::string key(const std::string& k) const { return path.empty() ? k : path + "." + k; }
  bool has(const char* k) const { return t.contains(k); }
  const toml::node* get(const char* k) const { return t.get(k); }
  [[noreturn]] void missing(const char* k, const std::string& why = "") const {
    throw SceneError(ctx.where(t) + key(k) + ": missing" + (why.empty() ? " (required)" : " (" + why + ")"));
  }
  [[noreturn]] void fail(const char* k, const std::string& msg) const { ctx.fail(*t.get(k), key(k), msg); }

  double number(const char* k) const {
    const toml::node* n = get(k);
    if (!n) missing(k);
    return as_number(*n, key(k));
  }
  double number(const char* k, double dflt) const { return has(k) ? number(k) : dflt; }
  double as_number(const toml::node& n, const std::string& p) const {
    if (!n.is_number()) ctx.fail(n, p, std::string("must be a number, got ") + type_name(n));
    const double v = *n.value<double>();
    if (!std::isfinite(v)) ctx.fail(n, p, "must be finite (got " + num(v) + ")");
    return v;
  }
  double positive(const char* k) const {
    const double v = number(k);
    if (!(v > 0)) fail(k, "must be > 0 (got " + num(v) + ")");
    return v;
  }
  double non_negative(const char* k) const {
    const double v = number(k);
    if (!(v >= 0)) fail(k, "must be >= 0 (got " + num(v) + ")");
    return v;
  }
  std::int64_t integer(const char* k, std::int64_t lo, std::int64_t hi) const {
    const toml::node* n = get(k);
    if (!n) missing(k);
    if (!n->is_integer()) fail(k, std::string("must be an integer, got ") + type_name(*n));
    const std::int64_t v = *n->value<std::int64_t>();
    if (v < lo || v > hi)
      fail(k, "must be in [" + std::to_string(lo) + ", " + std::to_string(hi) + "] (got " +
                  std::to_string(v) + ")");
    return v;
  }
  std::string string(const char* k, std::initializer_list<const char*> choices) const {
    const toml::node* n = get(k);
    if (!n) missing(k);
    if (!n->is_string()) fail(k, std::string("must be a string, got ") + type_name(*n));
    const std::string v = n->as_string()->get();
    std::string list;
    for (const char* c : choices) {
      if (v == c) return v;
      list += std::string(list.empty() ? "" : ", ") + "\"" + c + "\"";
    }
    fail(k, "\"" + v + "\" is not one of " + list);
  }
  std::string text(const char* k) const {
    const toml::node* n = get(k);
    if (!n) missing(k);
    if (!n->is_string()) fail(k, std::string("must be a string, got ") + type_name(*n));
    return n->as_string()->get();
  }
  bool boolean(const char* k, bool dflt) const {
    const toml::node* n = get(k);
    if (!n) return dflt;
    if (!n->is_boolean()) fail(k, std::string("must be true or false, got ") + type_name(*n));
    return *n->value<bool>();
  }
  Vec3 vec3_of(const toml::node& n, const std::string& p) const {
    const toml::array* a = n.as_array();
    if (!a) ctx.fail(n, p, std::string("must be an array of 3 numbers, got ") + type_name(n));
    if (a->size() != 3) ctx.fail(n, p, "must have 3 entries (got " + std::to_string(a->size()) + ")");
    Vec3 v;
    for (int i = 0; i < 3; ++i) v[i] = as_number(*a->get(i), p + "." + std::to_string(i));
    return v;
  }
  Vec3 vec3(const char* k) const {
    const toml::node* n = get(k);
    if (!n) missing(k);
    return vec3_of(*n, key(k));
  }
  Vec3 vec3(const char* k, const Vec3& dflt) const { return has(k) ? vec3(k) : dflt; }
  Vec3 nonzero_vec3(const char* k, const Vec3& dflt) const {
    const Vec3 v = vec3(k, dflt);
    if (!(to_e(v).norm() > 0)) fail(k, "must not be the zero vector");
    return v;
  }
  Table sub(const char* k, std::initializer_list<const char*> allowed) const {
    return sub(k, std::vector<const char*>(allowed));
  }
  Table sub(const char* k, const std::vector<const char*>& allowed) const {
    const toml::node* n = get(k);
    if (!n) missing(k);
    if (!n->is_table()) fail(k, std::string("must be a table, got ") + type_name(*n));
    return Table(ctx, *n->as_table(), key(k), allowed);
  }
};

// ---- [simulation] ------------------------------------------------------------

Simulation parse_simulation(const Table& root) {
  const Table t = root.sub("simulation", {"dt", "dt_safety", "duration", "integrator", "precision",
                                          "output_interval", "gravity", "output_directors", "validity"});
  Simulation s;
  if (!t.has("dt")) t.missing("dt", "a time step in seconds, or \"auto\"");
  const toml::node& dt = *t.get("dt");
  if (dt.is_string()) {
    if (dt.as_string()->get() != "auto") t.fail("dt", "must be a number of seconds or \"auto\"");
    s.dt_auto = true;
  } else {
    s.dt_auto = false;
    s.dt = t.number("dt");
    if (!(s.dt > 0)) t.fail("dt", "must be > 0 (got " + num(s.dt) + "), or \"auto\"");
  }
  if (t.has("dt_safety")) {
    if (!s.dt_auto) t.fail("dt_safety", "only used with dt = \"auto\"");
    s.dt_safety = t.number("dt_safety");
    if (!(s.dt_safety > 0 && s.dt_safety <= 1.5))
      t.fail("dt_safety", "must be in (0, 1.5] (got " + num(s.dt_safety) + ")");
  }
  s.duration = t.positive("duration");
  s.output_interval = t.has("output_interval") ? t.positive("output_interval") : s.duration / 100;
  if (t.has("integrator"))
    s.integrator = t.string("integrator", {"position_verlet", "pefrl"}) == "pefrl"
                       ? Integrator::pefrl
                       : Integrator::position_verlet;
  if (t.has("precision"))
    s.precision =
        t.string("precision", {"double", "float"}) == "float" ? Precision::float32 : Precision::float64;
  s.gravity = t.vec3("gravity", {0, 0, 0});
  s.output_directors = t.boolean("output_directors", true);
  if (t.has("validity")) {
    const Table v = t.sub("validity", {"strain", "stretch", "energy_growth", "on_violation"});
    if (v.has("strain")) s.validity.strain = v.positive("strain");
    if (v.has("stretch")) s.validity.stretch = v.positive("stretch");
    if (v.has("energy_growth")) s.validity.energy_growth = v.positive("energy_growth");
    if (v.has("on_violation")) s.validity.error = v.string("on_violation", {"warn", "error"}) == "error";
  }
  return s;
}

// ---- [[rods]] ----------------------------------------------------------------

// root, tip = "clamped" | "pinned" | "free" | a table { kind = "clamped" |
// "pinned", motion = …, the motion's keys } (a held end, static or on a
// rigid motion, include/manyrods/drive.h; angles in degrees); interior nodes
// in [[rods.constraints]] tables { node = k, kind, motion, … }.
struct Root {
  std::optional<HoldKind> hold = HoldKind::clamped;  // nullopt: free
  std::shared_ptr<const RootMotion> motion;
};
// A hold's name in a scene file ("free": nullopt).
std::optional<HoldKind> hold_named(const std::string& kind) {
  if (kind == "free") return std::nullopt;
  return kind == "pinned" ? HoldKind::pinned : HoldKind::clamped;
}

// `base` plus the keys a hold's table has besides its motion's.
std::vector<const char*> with_keys(std::initializer_list<const char*> base, const std::vector<const char*>& extra) {
  std::vector<const char*> v(base);
  v.insert(v.end(), extra.begin(), extra.end());
  return v;
}

// Every key a motion table may have, whatever its kind (parse_motion checks
// each kind's own): for a hold's table before its motion is parsed.
const std::vector<const char*> kMotionKeys = {
    "motion", "translation_amplitude", "rotation_axis", "rotation_amplitude", "frequency", "phase",
    "ramp_time", "pivot", "times", "translations", "rotations", "translation", "rotation", "start_time",
    "duration", "profile", "name"};
std::vector<const char*> with_motion_keys(std::initializer_list<const char*> base) { return with_keys(base, kMotionKeys); }

constexpr double kDeg = std::numbers::pi / 180;  // degrees to radians

// motion = "host": tables with the same `name` share one HostMotion.
std::shared_ptr<const RootMotion> parse_host_motion(const Table& g, const char* key,
                                                    const std::vector<const char*>& extra) {
  const Table m = g.sub(key, with_keys({"motion", "name"}, extra));
  if (!m.has("name")) m.missing("name", "a host motion is named (the host sets its pose by this name)");
  const std::string name = m.text("name");
  if (name.empty()) m.fail("name", "must not be empty");
  for (const auto& h : g.ctx.host_motions)
    if (h->name() == name) return h;
  return g.ctx.host_motions.emplace_back(std::make_shared<HostMotion>(name));
}

// motion = "ramp" (RampMotion).
std::shared_ptr<const RootMotion> parse_ramp_motion(const Table& g, const char* key,
                                                    const std::vector<const char*>& extra) {
  const Table m = g.sub(key, with_keys({"motion", "translation", "rotation_axis", "rotation", "start_time",
                                        "duration", "profile", "pivot"},
                                       extra));
  auto r = std::make_shared<RampMotion>();
  r->translation = m.vec3("translation", {0, 0, 0});
  r->rotation = m.number("rotation", 0) * kDeg;
  if (m.has("rotation_axis"))
    r->axis = m.nonzero_vec3("rotation_axis", {0, 0, 1});
  else if (r->rotation != 0)
    m.missing("rotation_axis", "needed when rotation is not 0");
  r->start_time = m.number("start_time", 0);
  r->duration = m.positive("duration");
  r->smooth = m.has("profile") && m.string("profile", {"linear", "smooth"}) == "smooth";
  r->pivot = m.vec3("pivot", {0, 0, 0});
  return r;
}

// motion = "oscillate" (OscillatingMotion).
std::shared_ptr<const RootMotion> parse_oscillating_motion(const Table& g, const char* key,
                                                           const std::vector<const char*>& extra) {
  const Table m = g.sub(key, with_keys({"motion", "translation_amplitude", "rotation_axis", "rotation_amplitude",
                                        "frequency", "phase", "ramp_time", "pivot"},
                                       extra));
  auto o = std::make_shared<OscillatingMotion>();
  o->translation_amplitude = m.vec3("translation_amplitude", {0, 0, 0});
  o->rotation_amplitude = m.number("rotation_amplitude", 0) * kDeg;
  if (m.has("rotation_axis"))
    o->axis = m.nonzero_vec3("rotation_axis", {0, 0, 1});
  else if (o->rotation_amplitude != 0)
    m.missing("rotation_axis", "needed when rotation_amplitude is not 0");
  o->frequency = m.positive("frequency");
  o->phase = m.number("phase", 0) * kDeg;
  o->ramp_time = m.has("ramp_time") ? m.non_negative("ramp_time") : 0.0;
  o->pivot = m.vec3("pivot", {0, 0, 0});
  return o;
}

// motion = "keyframes" (KeyframedMotion): times, translations and optional
// rotations, each entry checked with its own line.
std::shared_ptr<const RootMotion> parse_keyframed_motion(const Table& g, const char* key,
                                                         const std::vector<const char*>& extra) {
  const Table m = g.sub(key, with_keys({"motion", "times", "translations", "rotations", "pivot"}, extra));
  auto k = std::make_shared<KeyframedMotion>();
  auto list = [&](const char* lk) -> const toml::array& {
    const toml::node* a = m.get(lk);
    if (!a) m.missing(lk);
    if (!a->is_array() || a->as_array()->empty()) m.fail(lk, "must be a non-empty array");
    return *a->as_array();
  };
  const toml::array& times = list("times");
  for (std::size_t i = 0; i < times.size(); ++i) {
    const std::string p = m.key("times") + "." + std::to_string(i);
    k->times.push_back(m.as_number(*times.get(i), p));
    if (i > 0 && !(k->times[i] > k->times[i - 1]))
      g.ctx.fail(*times.get(i), p, "times must increase strictly (got " + num(k->times[i]) + " after " +
                                       num(k->times[i - 1]) + ")");
  }
  const toml::array& tr = list("translations");
  if (tr.size() != times.size())
    m.fail("translations", "needs one [x, y, z] per time (" + std::to_string(times.size()) + "), got " +
                               std::to_string(tr.size()));
  for (std::size_t i = 0; i < tr.size(); ++i)
    k->translations.push_back(m.vec3_of(*tr.get(i), m.key("translations") + "." + std::to_string(i)));
  if (m.has("rotations")) {
    const toml::array& ro = list("rotations");
    if (ro.size() != times.size())
      m.fail("rotations", "needs one [axis x, y, z, angle in degrees] per time (" +
                              std::to_string(times.size()) + "), got " + std::to_string(ro.size()));
    for (std::size_t i = 0; i < ro.size(); ++i) {
      const std::string p = m.key("rotations") + "." + std::to_string(i);
      const toml::array* a = ro.get(i)->as_array();
      if (!a || a->size() != 4)
        g.ctx.fail(*ro.get(i), p, "must be [axis x, axis y, axis z, angle in degrees]");
      std::array<double, 4> q;
      for (int j = 0; j < 4; ++j) q[j] = m.as_number(*a->get(j), p + "." + std::to_string(j));
      if (q[3] != 0 && !(std::hypot(q[0], q[1], q[2]) > 0))
        g.ctx.fail(*ro.get(i), p, "a non-zero angle needs a non-zero axis");
      q[3] *= kDeg;
      k->rotations.push_back(q);
    }
  }
  k->pivot = m.vec3("pivot", {0, 0, 0});
  return k;  // checked above, entry by entry with its line (KeyframedMotion::validate's checks)
}

// A rigid motion table (motion = "oscillate" | "keyframes" | "ramp" | "host";
// angles in degrees), as a driven hold's table and a collider's `motion`.
// `extra`: the other keys the table may have (a hold's kind, node).
std::shared_ptr<const RootMotion> parse_motion(const Table& g, const char* key,
                                               const std::vector<const char*>& extra = {}) {
  const toml::node* n = g.get(key);
  const toml::table& t = *n->as_table();
  const std::string kind = t.contains("motion") && t.get("motion")->is_string()
                               ? t.get("motion")->as_string()->get()
                               : std::string();
  if (kind == "host") return parse_host_motion(g, key, extra);
  if (kind == "ramp") return parse_ramp_motion(g, key, extra);
  if (kind == "oscillate") return parse_oscillating_motion(g, key, extra);
  if (kind == "keyframes") return parse_keyframed_motion(g, key, extra);
  const toml::node* mk = t.get("motion");
  if (!mk)
    g.ctx.fail(*n, g.key(std::string(key) + ".motion"),
               "missing: a motion needs motion = \"oscillate\", \"keyframes\", \"ramp\" or \"host\"");
  g.ctx.fail(*mk, g.key(std::string(key) + ".motion"),
             mk->is_string() ? "\"" + kind + "\" is not one of \"oscillate\", \"keyframes\", \"ramp\", \"host\""
                             : std::string("must be a string, got ") + type_name(*mk));
}

// A held end or node: `key` is "root" or "tip" (a string or a table), or
// an entry of [[rods.constraints]] (a table; `extra` holds its "node").
// `dflt`: what an absent key means.
Root parse_hold_table(const Table& g, const char* key, const std::vector<const char*>& extra) {
  Root r;
  const toml::table& t = *g.get(key)->as_table();
  std::vector<const char*> keys = extra;
  keys.push_back("kind");
  if (t.contains("kind")) {
    std::vector<const char*> all = with_motion_keys({"kind"});
    all.insert(all.end(), extra.begin(), extra.end());
    const Table k(g.ctx, t, g.key(key), all);
    r.hold = hold_named(k.string("kind", {"clamped", "pinned"}));
  }
  bool motion_keys = t.contains("motion");
  for (auto&& [k, v] : t) {
    bool hold_key = false;
    for (const char* a : keys) hold_key = hold_key || k.str() == a;
    motion_keys = motion_keys || !hold_key;
  }
  if (motion_keys)
    r.motion = parse_motion(g, key, keys);  // (names a missing `motion`)
  else
    (void)g.sub(key, keys);  // a static hold: only its kind (and node)
  if (r.motion) {
    try {
      r.motion->validate();
    } catch (const InputError& e) {
      g.fail(key, e.what());
    }
  }
  return r;
}

Root parse_end(const Table& g, const char* key, bool dflt_clamped) {
  Root r;
  r.hold = dflt_clamped ? std::optional(HoldKind::clamped) : std::nullopt;
  if (!g.has(key)) return r;
  const toml::node* n = g.get(key);
  if (n->is_string()) {
    r.hold = hold_named(g.string(key, {"clamped", "pinned", "free"}));
    return r;
  }
  if (!n->is_table())
    g.fail(key, std::string("must be \"clamped\", \"pinned\", \"free\" or a table { kind = \"clamped\" | "
                            "\"pinned\", motion = \"oscillate\" | \"keyframes\" | \"ramp\" | \"host\", … }, got ") +
                    type_name(*n));
  return parse_hold_table(g, key, {});
}

// ---- [fluid] (include/manyrods/fluid.h) ------------------------------------------

void parse_fluid(const Table& top, Scene& sc) {
  bool drag = false;
  for (const RodSpec& r : sc.rods) drag = drag || r.drag.any();
  sc.has_fluid = drag || top.has("fluid");
  if (sc.has_fluid && sc.sim.integrator == Integrator::pefrl)
    throw SceneError(sc.source + ": " + (top.has("fluid") ? "fluid" : "rods.*.drag") +
                     ": a fluid needs integrator = \"position_verlet\" (PEFRL's backward kicks would amplify the drag)");
  if (!top.has("fluid")) {
    for (std::size_t gi = 0; gi < sc.groups.size(); ++gi) {
      const Drag& d = sc.rods[sc.groups[gi].first_rod].drag;
      if (d.cd_normal > 0 || d.cd_tangential > 0)
        throw SceneError(sc.source + ":" + std::to_string(sc.groups[gi].line) + ": rods." + std::to_string(gi) +
                         ".drag: cd_normal and cd_tangential (quadratic drag) need a [fluid] table with density > 0");
    }
    return;
  }
  const Table f = top.sub("fluid", {"density", "velocity", "times", "velocities", "turbulence"});
  Fluid& fl = sc.fluid;
  fl.density = f.has("density") ? f.non_negative("density") : 0.0;
  fl.velocity = f.vec3("velocity", {0, 0, 0});
  if (f.has("times") != f.has("velocities"))
    f.fail(f.has("times") ? "times" : "velocities", "give times and velocities together (a time table of the mean velocity)");
  if (f.has("times")) {
    if (f.has("velocity")) f.fail("velocity", "give either velocity or a time table (times, velocities), not both");
    const toml::array* ta = f.get("times")->as_array();
    const toml::array* va = f.get("velocities")->as_array();
    if (!ta || ta->empty()) f.fail("times", "must be a non-empty array of times in seconds");
    if (!va || va->size() != ta->size())
      f.fail("velocities", "needs one [x, y, z] per time (" + std::to_string(ta->size()) + ")");
    for (std::size_t i = 0; i < ta->size(); ++i) {
      const std::string pth = f.key("times") + "." + std::to_string(i);
      fl.times.push_back(f.as_number(*ta->get(i), pth));
      if (i > 0 && !(fl.times[i] > fl.times[i - 1]))
        f.ctx.fail(*ta->get(i), pth, "times must increase strictly (got " + num(fl.times[i]) + " after " +
                                         num(fl.times[i - 1]) + ")");
      fl.velocities.push_back(f.vec3_of(*va->get(i), f.key("velocities") + "." + std::to_string(i)));
    }
  }
  if (f.has("turbulence")) {
    const Table t = f.sub("turbulence", {"intensity", "length_scale", "time_scale", "modes", "seed"});
    Turbulence& tu = fl.turbulence;
    tu.intensity = t.non_negative("intensity");
    tu.length_scale = t.positive("length_scale");
    tu.time_scale = t.positive("time_scale");
    tu.modes = t.has("modes") ? int(t.integer("modes", 1, 256)) : 16;
    tu.seed = t.has("seed") ? std::uint64_t(t.integer("seed", 0, std::numeric_limits<std::int64_t>::max())) : 1;
  }
  for (std::size_t gi = 0; gi < sc.groups.size(); ++gi) {
    const Drag& d = sc.rods[sc.groups[gi].first_rod].drag;
    if ((d.cd_normal > 0 || d.cd_tangential > 0) && !(fl.density > 0)) {
      const std::string msg = "rods." + std::to_string(gi) +
                              ".drag has quadratic coefficients (cd_normal, cd_tangential), which need density > 0";
      if (f.has("density")) f.fail("density", msg);
      throw SceneError(f.ctx.where(f.t) + "fluid.density: missing (" + msg + ")");
    }
  }
}

// ---- friction, [[colliders]], [contact] (docs/contact.md) ----------------------

Friction parse_friction(const Table& g) {
  const Table f = g.sub("friction", {"static", "kinetic", "static_axial", "kinetic_axial"});
  Friction r;
  r.static_coefficient = f.non_negative("static");
  r.kinetic_coefficient = f.non_negative("kinetic");
  if (r.kinetic_coefficient > r.static_coefficient)
    f.fail("kinetic", "must not exceed static (" + num(r.static_coefficient) + "), got " + num(r.kinetic_coefficient));
  if (f.has("static_axial") != f.has("kinetic_axial"))
    f.fail(f.has("static_axial") ? "static_axial" : "kinetic_axial", "give static_axial and kinetic_axial together");
  if (f.has("static_axial")) {
    r.static_axial = f.non_negative("static_axial");
    r.kinetic_axial = f.non_negative("kinetic_axial");
    if (r.kinetic_axial > r.static_axial)
      f.fail("kinetic_axial", "must not exceed static_axial (" + num(r.static_axial) + ")");
  }
  return r;
}

// A file the scene names (an OBJ mesh, a curves file): relative to the scene
// file's directory unless absolute; recorded as one of its inputs.
std::string input_file(const Ctx& ctx, const std::string& file) {
  std::string full = file;
  if (file.empty() || file[0] != '/') {
    const std::size_t i = ctx.source.find_last_of('/');
    full = (i == std::string::npos ? std::string() : ctx.source.substr(0, i + 1)) + file;
  }
  ctx.inputs.push_back(full);
  return full;
}

// What every collider kind has: name, friction, motion.
void parse_collider_common(const Table& t, Collider& c) {
  c.name = t.has("name") ? t.text("name") : t.path;
  if (t.has("friction")) c.friction = parse_friction(t);
  if (!t.has("motion")) return;
  if (!t.get("motion")->is_table())
    t.fail("motion", std::string("must be a table with motion = \"oscillate\", \"keyframes\", \"ramp\" or \"host\", got ") +
                         type_name(*t.get("motion")));
  c.motion = parse_motion(t, "motion");
  try {
    c.motion->validate();
  } catch (const InputError& e) {
    t.fail("motion", e.what());
  }
}

Collider parse_collider(const Ctx& ctx, const toml::table& ct, std::size_t i) {
  const std::string path = "colliders." + std::to_string(i);
  const toml::node* kn = ct.get("kind");
  if (!kn) throw SceneError(ctx.where(ct) + path + ".kind: missing (\"plane\", \"sphere\", \"capsule\" or \"mesh\")");
  const std::string kind = kn->is_string() ? kn->as_string()->get() : std::string();
  Collider c;
  if (kind == "plane") {
    const Table t(ctx, ct, path, {"name", "kind", "point", "normal", "friction", "motion"});
    c.kind = ColliderKind::plane;
    c.point = t.vec3("point", {0, 0, 0});
    c.normal = t.nonzero_vec3("normal", {0, 0, 1});
    parse_collider_common(t, c);
  } else if (kind == "sphere") {
    const Table t(ctx, ct, path, {"name", "kind", "center", "radius", "friction", "motion"});
    c.kind = ColliderKind::sphere;
    c.center = t.vec3("center", {0, 0, 0});
    c.radius = t.positive("radius");
    parse_collider_common(t, c);
  } else if (kind == "capsule") {
    const Table t(ctx, ct, path, {"name", "kind", "a", "b", "radius", "friction", "motion"});
    c.kind = ColliderKind::capsule;
    c.a = t.vec3("a");
    c.b = t.vec3("b");
    c.radius = t.positive("radius");
    parse_collider_common(t, c);
  } else if (kind == "mesh") {
    const Table t(ctx, ct, path, {"name", "kind", "file", "resolution", "friction", "motion"});
    c.kind = ColliderKind::mesh;
    const std::string file = t.text("file");
    const int res = int(t.has("resolution") ? t.integer("resolution", 8, 512) : 64);
    const std::string full = input_file(ctx, file);
    try {
      c.grid = load_mesh_grid(full, res);
    } catch (const InputError& e) {
      t.fail("file", e.what());
    }
    parse_collider_common(t, c);
  } else {
    ctx.fail(*kn, path + ".kind", "must be one of \"plane\", \"sphere\", \"capsule\", \"mesh\"");
  }
  return c;
}

void parse_contact(const Ctx& ctx, const Table& top, Scene& sc) {
  if (const toml::node* cn = top.get("colliders")) {
    const toml::array* a = cn->as_array();
    if (!a || !a->is_array_of_tables()) ctx.fail(*cn, "colliders", "must be one or more [[colliders]] tables");
    for (std::size_t i = 0; i < a->size(); ++i) sc.contact.colliders.push_back(parse_collider(ctx, *a->get(i)->as_table(), i));
  }
  if (top.has("contact")) {
    const Table t = top.sub("contact", {"rod_rod", "self", "friction", "hardness", "damping_ratio", "skin", "capacity",
                                        "max_capacity"});
    sc.contact.rod_rod = t.boolean("rod_rod", false);
    sc.contact.self = t.boolean("self", false);
    if (t.has("friction")) sc.contact.friction = parse_friction(t);
    if (t.has("hardness")) sc.contact.hardness = t.positive("hardness");
    if (t.has("damping_ratio")) sc.contact.damping_ratio = t.non_negative("damping_ratio");
    if (t.has("skin")) sc.contact.skin = t.non_negative("skin");
    if (t.has("capacity")) sc.contact.capacity = int(t.integer("capacity", 1, 1 << 20));
    if (t.has("max_capacity")) sc.contact.max_capacity = int(t.integer("max_capacity", 1, 1 << 20));
    if (sc.contact.max_capacity < sc.contact.capacity)
      t.fail(t.has("max_capacity") ? "max_capacity" : "capacity",
             "max_capacity (" + std::to_string(sc.contact.max_capacity) + ") must be >= capacity (" +
                 std::to_string(sc.contact.capacity) + "): the lists start at capacity and grow up to max_capacity");
  }
  sc.has_contact = !sc.contact.colliders.empty() || sc.contact.rod_rod || sc.contact.self;
  if (sc.has_contact && sc.sim.integrator != Integrator::position_verlet)
    throw SceneError(sc.source + ": simulation.integrator: contact ([[colliders]], [contact]) is stepped by "
                                 "Position Verlet only: use integrator = \"position_verlet\"");
}

// ---- [[observables]] (include/manyrods/observables.h) -------------------------

// An observable's reduction over time: exactly one of at, reduce, first_above,
// first_below.
void parse_observable_reduction(const Table& t, Observable& ob) {
  using R = Observable::Reduce;
  int given = 0;
  for (const char* k : {"at", "reduce", "first_above", "first_below"}) given += t.has(k) ? 1 : 0;
  if (given != 1)
    throw SceneError(t.ctx.where(t.t) + t.path + ": give exactly one of at = time(s), reduce = \"max\"|\"min\"|"
                                                 "\"max_abs\"|\"final\", first_above = value, first_below = value");
  if (t.has("at")) {
    ob.reduce = R::at;
    const toml::node& an = *t.get("at");
    if (const toml::array* a = an.as_array()) {
      if (a->empty()) t.fail("at", "give at least one time");
      for (std::size_t k = 0; k < a->size(); ++k)
        ob.times.push_back(t.as_number(*a->get(k), t.key("at") + "." + std::to_string(k)));
    } else {
      ob.times.push_back(t.number("at"));
    }
    for (std::size_t k = 0; k < ob.times.size(); ++k) {
      if (!(ob.times[k] >= 0)) t.fail("at", "times must be >= 0 (got " + num(ob.times[k]) + ")");
      for (std::size_t j = 0; j < k; ++j)
        if (ob.times[j] == ob.times[k]) t.fail("at", "time " + num(ob.times[k]) + " is given twice");
    }
  } else if (t.has("reduce")) {
    const std::string r = t.string("reduce", {"max", "min", "max_abs", "final"});
    ob.reduce = r == "max" ? R::max : r == "min" ? R::min : r == "max_abs" ? R::max_abs : R::final;
  } else {
    ob.reduce = t.has("first_above") ? R::first_above : R::first_below;
    ob.threshold = t.number(t.has("first_above") ? "first_above" : "first_below");
  }
}

Observable parse_observable(const Ctx& ctx, const toml::table& ot, std::size_t i, const Scene& sc) {
  using Q = Observable::Quantity;
  const Table t(ctx, ot, "observables." + std::to_string(i),
                {"name", "quantity", "rod", "node", "component", "at", "reduce", "first_above", "first_below"});
  Observable ob;
  ob.name = t.text("name");
  if (ob.name.empty() || ob.name.find_first_not_of("abcdefghijklmnopqrstuvwxyzABCDEFGHIJKLMNOPQRSTUVWXYZ0123456789_.-") !=
                             std::string::npos)
    t.fail("name", "\"" + ob.name + "\": use letters, digits, '_', '.' and '-' (it names a summary column)");
  const std::string q = t.string("quantity", {"position", "displacement", "strain", "energy", "contacts", "penetration"});
  ob.quantity = q == "position"       ? Q::position
                : q == "displacement" ? Q::displacement
                : q == "strain"       ? Q::strain
                : q == "energy"       ? Q::energy
                : q == "contacts"     ? Q::contacts
                                      : Q::penetration;
  const bool at_node = ob.quantity == Q::position || ob.quantity == Q::displacement;
  const int rods = int(sc.rods.size());
  // rod: an index, or "all" for the quantities summed or maximised over rods
  ob.rod = at_node ? 0 : -1;
  if (const toml::node* rn = t.get("rod")) {
    if (rn->is_string() && rn->as_string()->get() == "all" && !at_node) ob.rod = -1;
    else if (rn->is_integer()) ob.rod = int(t.integer("rod", 0, rods - 1));
    else t.fail("rod", at_node ? "must be a rod index (0 to " + std::to_string(rods - 1) + ")"
                               : "must be a rod index (0 to " + std::to_string(rods - 1) + ") or \"all\"");
  }
  if (at_node) {
    const int nodes = int(sc.rods[std::size_t(ob.rod)].nodes.size());
    if (t.has("node")) ob.node = int(t.integer("node", -nodes, nodes - 1));  // (negative: counted from the end when read)
    if (ob.quantity == Q::position && !t.has("component")) t.missing("component", "\"x\", \"y\", \"z\" or \"norm\"");
    if (t.has("component")) {
      const std::string c = t.string("component", {"x", "y", "z", "norm"});
      ob.component = c == "x" ? 0 : c == "y" ? 1 : c == "z" ? 2 : Observable::norm;
    }
  } else {
    if (t.has("node")) t.fail("node", "applies to a position or displacement only");
    if (ob.quantity == Q::energy) {
      if (!t.has("component")) t.missing("component", "\"kinetic\", \"elastic\", \"potential\", \"total\" or \"dissipated\"");
      const std::string c = t.string("component", {"kinetic", "elastic", "potential", "total", "dissipated"});
      ob.component = c == "kinetic"     ? Observable::kinetic
                     : c == "elastic"   ? Observable::elastic
                     : c == "potential" ? Observable::potential
                     : c == "total"     ? Observable::total
                                        : Observable::dissipated;
      if (ob.component == Observable::dissipated && ob.rod >= 0)
        t.fail("component", "\"dissipated\" is integrated over all rods (of a sweep's variation): give rod = \"all\"");
    } else if (t.has("component")) {
      t.fail("component", "applies to a position, displacement or energy only");
    }
    if ((ob.quantity == Q::contacts || ob.quantity == Q::penetration) && !sc.has_contact)
      t.fail("quantity", "\"" + q + "\" needs contact ([[colliders]] or [contact])");
  }
  parse_observable_reduction(t, ob);
  return ob;
}

void parse_observables(const Ctx& ctx, const Table& top, Scene& sc) {
  const toml::node* on = top.get("observables");
  if (!on) return;
  const toml::array* a = on->as_array();
  if (!a || !a->is_array_of_tables()) ctx.fail(*on, "observables", "must be one or more [[observables]] tables");
  for (std::size_t i = 0; i < a->size(); ++i) sc.observables.push_back(parse_observable(ctx, *a->get(i)->as_table(), i, sc));
  const std::vector<std::string> cols = observable_columns(sc.observables);
  for (std::size_t i = 0; i < cols.size(); ++i)
    for (std::size_t j = 0; j < i; ++j)
      if (cols[i] == cols[j]) throw SceneError(sc.source + ": observables: two observables give the column \"" + cols[i] + "\"");
}

struct Placement {
  std::vector<Vec3> starts, directions, normals;  // [count]
};

// A unit vector perpendicular to d (d unit).
E3 perpendicular(const E3& d, const E3& hint) {
  E3 p = hint - hint.dot(d) * d;
  if (p.norm() < 1e-6)
    p = (std::abs(d.x()) < 0.9 ? E3::UnitX() : E3::UnitY()) - d * (std::abs(d.x()) < 0.9 ? d.x() : d.y());
  return p.normalized();
}

// placement.kind = "grid": roots in rows of `columns` (⌈√count⌉ by default),
// spaced [s1, s2] along two axes across the direction (or the given axes).
Placement parse_grid_placement(const Table& g, const toml::table& pt, int count, const Vec3& start,
                               const Vec3& direction, const Vec3& normal) {
  Placement p;
  const Table t(g.ctx, pt, g.key("placement"), {"kind", "spacing", "columns", "axes"});
  const toml::node* sn = t.get("spacing");
  if (!sn) t.missing("spacing", "[s1, s2] in m");
  const toml::array* sa = sn->as_array();
  if (!sa || sa->size() != 2) t.fail("spacing", "must be an array of 2 numbers [s1, s2]");
  double sp[2];
  for (int i = 0; i < 2; ++i) {
    sp[i] = t.as_number(*sa->get(i), t.key("spacing") + "." + std::to_string(i));
    if (!(sp[i] > 0)) g.ctx.fail(*sa->get(i), t.key("spacing") + "." + std::to_string(i), "must be > 0");
  }
  const int side = int(std::ceil(std::sqrt(double(count))));
  const int columns = t.has("columns") ? int(t.integer("columns", 1, 1 << 30)) : side;
  const E3 d = to_e(direction).normalized();
  E3 u = perpendicular(d, to_e(normal)), v = d.cross(u);
  if (t.has("axes")) {
    const toml::array* aa = t.get("axes")->as_array();
    if (!aa || aa->size() != 2)
      t.fail("axes", "must be an array of two vectors [[ux, uy, uz], [vx, vy, vz]]");
    u = to_e(t.vec3_of(*aa->get(0), t.key("axes.0")));
    v = to_e(t.vec3_of(*aa->get(1), t.key("axes.1")));
    if (!(u.norm() > 0) || !(v.norm() > 0) || u.normalized().cross(v.normalized()).norm() < 1e-6)
      t.fail("axes", "must be two non-zero, non-parallel vectors");
    u.normalize();
    v.normalize();
  }
  for (int i = 0; i < count; ++i) {
    p.starts.push_back(from_e(to_e(start) + (i % columns) * sp[0] * u + (i / columns) * sp[1] * v));
    p.directions.push_back(direction);
    p.normals.push_back(normal);
  }
  return p;
}

// placement.kind = "sphere": roots uniform at random (seeded) on a cap of the
// sphere, each rod along the sphere's outward normal there.
Placement parse_sphere_placement(const Table& g, const toml::table& pt, int count) {
  Placement p;
  const Table t(g.ctx, pt, g.key("placement"), {"kind", "center", "radius", "cap_angle", "axis", "seed"});
  for (const char* k : {"start", "direction", "normal"})
    if (g.has(k))
      g.fail(k,
             "not used with placement.kind = \"sphere\": roots lie on the sphere and rods grow along its "
             "outward normal");
  const E3 c = to_e(t.vec3("center"));
  const double r = t.positive("radius");
  const double cap = t.number("cap_angle", 90);
  if (!(cap > 0 && cap <= 180)) t.fail("cap_angle", "must be in (0, 180] degrees (got " + num(cap) + ")");
  const E3 axis = to_e(t.nonzero_vec3("axis", {0, 0, 1})).normalized();
  Rng rng{
      std::uint64_t(t.has("seed") ? t.integer("seed", 0, std::numeric_limits<std::int64_t>::max()) : 0)};
  const E3 e1 = perpendicular(axis, E3::UnitX()), e2 = axis.cross(e1);
  const double cmin = std::cos(cap * std::numbers::pi / 180);
  for (int i = 0; i < count; ++i) {
    // uniform on the cap: cos θ uniform in [cos cap, 1], φ uniform
    const double ct = 1 - rng.next() * (1 - cmin), phi = 2 * std::numbers::pi * rng.next();
    const double st = std::sqrt(std::max(0.0, 1 - ct * ct));
    const E3 n = ct * axis + st * (std::cos(phi) * e1 + std::sin(phi) * e2);
    p.starts.push_back(from_e(c + r * n));
    p.directions.push_back(from_e(n));
    p.normals.push_back(from_e(perpendicular(n, axis.cross(n).norm() > 1e-6 ? axis.cross(n) : e1)));
  }
  return p;
}

// placement.kind = "list": one start per rod, all with the group's direction and normal.
Placement parse_list_placement(const Table& g, const toml::table& pt, int count, const Vec3& direction,
                               const Vec3& normal) {
  Placement p;
  const Table t(g.ctx, pt, g.key("placement"), {"kind", "starts"});
  const toml::node* sn = t.get("starts");
  if (!sn) t.missing("starts", "[[x, y, z], ...], one per rod");
  const toml::array* sa = sn->as_array();
  if (!sa) t.fail("starts", "must be an array of [x, y, z]");
  if (int(sa->size()) != count)
    t.fail("starts", "has " + std::to_string(sa->size()) + " entries, count = " + std::to_string(count));
  for (int i = 0; i < count; ++i) {
    p.starts.push_back(t.vec3_of(*sa->get(i), t.key("starts") + "." + std::to_string(i)));
    p.directions.push_back(direction);
    p.normals.push_back(normal);
  }
  return p;
}

// A group's placement = { kind = "grid" | "sphere" | "list", … }: each rod's
// start, direction and normal (one rod at start without it).
Placement parse_placement(const Table& g, int count, const Vec3& start, const Vec3& direction,
                          const Vec3& normal) {
  if (!g.has("placement")) {
    if (count > 1)
      g.missing("placement", "count > 1 needs a placement: kind = \"grid\", \"sphere\" or \"list\"");
    Placement p;
    p.starts = {start};
    p.directions = {direction};
    p.normals = {normal};
    return p;
  }
  const toml::node* pn = g.get("placement");
  if (!pn->is_table()) g.fail("placement", std::string("must be a table, got ") + type_name(*pn));
  const toml::table& pt = *pn->as_table();
  const toml::node* kn = pt.get("kind");
  if (!kn)
    Table(g.ctx, pt, g.key("placement"),
          {"kind", "spacing", "columns", "axes", "center", "radius", "cap_angle", "axis", "seed", "starts"})
        .missing("kind", "\"grid\", \"sphere\" or \"list\"");
  if (!kn->is_string())
    g.ctx.fail(*kn, g.key("placement.kind"), std::string("must be a string, got ") + type_name(*kn));
  const std::string kind = kn->as_string()->get();
  if (kind == "grid") return parse_grid_placement(g, pt, count, start, direction, normal);
  if (kind == "sphere") return parse_sphere_placement(g, pt, count);
  if (kind == "list") return parse_list_placement(g, pt, count, direction, normal);
  g.ctx.fail(*kn, g.key("placement.kind"), "\"" + kind + "\" is not one of \"grid\", \"sphere\", \"list\"");
}

// A circle's `taper = { root = r0, tip = r1 }` (m): the radius runs linearly
// along the rod's arc length from r0 to r1 (taper: the pair, else unset).
Section parse_section(const Table& g, double* width, std::optional<std::array<double, 2>>* taper) {
  const toml::node* n = g.get("section");
  if (!n) g.missing("section");
  if (!n->is_table()) g.fail("section", std::string("must be a table, got ") + type_name(*n));
  const toml::table& st = *n->as_table();
  const toml::node* sh = st.get("shape");
  const std::string path = g.key("section");
  if (!sh)
    throw SceneError(g.ctx.where(st) + path +
                     ".shape: missing (\"circle\", \"ellipse\", \"rectangle\" or \"hollow_circle\")");
  if (!sh->is_string()) g.ctx.fail(*sh, path + ".shape", "must be a string");
  const std::string shape = sh->as_string()->get();
  if (shape == "circle") {
    const Table t(g.ctx, st, path, {"shape", "radius", "taper"});
    if (t.has("taper")) {
      if (t.has("radius")) t.fail("taper", "gives the radius at the root and the tip: leave out radius");
      const Table tt = t.sub("taper", {"root", "tip"});
      *taper = std::array<double, 2>{tt.positive("root"), tt.positive("tip")};
      *width = 2 * std::max((**taper)[0], (**taper)[1]);
      return Section::circle((**taper)[0]);
    }
    *width = 2 * t.positive("radius");
    return Section::circle(t.positive("radius"));
  }
  if (shape == "ellipse") {
    const Table t(g.ctx, st, path, {"shape", "semi_axes", "taper"});
    if (t.has("taper")) t.fail("taper", "tapers circle sections only (give shape = \"circle\")");
    const toml::node* a = t.get("semi_axes");
    if (!a) t.missing("semi_axes", "[a, b] in m");
    const toml::array* arr = a->as_array();
    if (!arr || arr->size() != 2) t.fail("semi_axes", "must be an array of 2 numbers [a, b]");
    double v[2];
    for (int i = 0; i < 2; ++i) {
      v[i] = t.as_number(*arr->get(i), t.key("semi_axes") + "." + std::to_string(i));
      if (!(v[i] > 0))
        g.ctx.fail(*arr->get(i), t.key("semi_axes") + "." + std::to_string(i),
                   "must be > 0 (got " + num(v[i]) + ")");
    }
    *width = 2 * std::max(v[0], v[1]);
    return Section::ellipse(v[0], v[1]);
  }
  if (shape == "rectangle") {
    const Table t(g.ctx, st, path, {"shape", "width", "height", "taper"});
    if (t.has("taper")) t.fail("taper", "tapers circle sections only (give shape = \"circle\")");
    *width = std::max(t.positive("width"), t.positive("height"));
    return Section::rectangle(t.positive("width"), t.positive("height"));
  }
  if (shape == "hollow_circle") {
    const Table t(g.ctx, st, path, {"shape", "outer_radius", "inner_radius", "taper"});
    if (t.has("taper")) t.fail("taper", "tapers circle sections only (give shape = \"circle\")");
    const double ro = t.positive("outer_radius"), ri = t.non_negative("inner_radius");
    if (!(ri < ro)) t.fail("inner_radius", "must be < outer_radius = " + num(ro) + " (got " + num(ri) + ")");
    *width = 2 * ro;
    return Section::hollow_circle(ro, ri);
  }
  g.ctx.fail(*sh, path + ".shape",
             "\"" + shape + "\" is not one of \"circle\", \"ellipse\", \"rectangle\", \"hollow_circle\"");
}

Material parse_material(const Table& g) {
  const Table t = g.sub("material", {"density", "youngs_modulus", "poisson_ratio", "shear_modulus"});
  Material m;
  m.density = t.positive("density");
  m.youngs_modulus = t.positive("youngs_modulus");
  if (t.has("poisson_ratio") && t.has("shear_modulus"))
    t.fail("shear_modulus", "give poisson_ratio or shear_modulus, not both");
  if (!t.has("poisson_ratio") && !t.has("shear_modulus"))
    t.missing("poisson_ratio", "give poisson_ratio or shear_modulus");
  if (t.has("poisson_ratio")) {
    m.poisson_ratio = t.number("poisson_ratio");
    if (!(m.poisson_ratio > -1 && m.poisson_ratio <= 0.5))
      t.fail("poisson_ratio", "must be in (-1, 0.5] (got " + num(m.poisson_ratio) + ")");
  } else {
    m.shear_modulus = t.positive("shear_modulus");
    const double nu = m.youngs_modulus / (2 * m.shear_modulus) - 1;
    if (!(nu > -1 && nu <= 0.5))
      t.fail("shear_modulus", "implies a Poisson ratio E/(2G) - 1 = " + num(nu) + " outside (-1, 0.5]");
  }
  return m;
}

Damping parse_damping(const Table& g) {
  if (!g.has("damping")) return Damping::none();
  const Table t =
      g.sub("damping", {"tau_shear", "tau_bulk", "tau_extension", "shear_viscosity", "bulk_viscosity"});
  const bool ts = t.has("tau_shear"), tb = t.has("tau_bulk"), te = t.has("tau_extension");
  const bool eta = t.has("shear_viscosity"), zeta = t.has("bulk_viscosity");
  const char* forms =
      "give tau_shear with tau_bulk or tau_extension (s), or shear_viscosity with bulk_viscosity (Pa s)";
  if (eta || zeta) {
    if (ts || tb || te)
      throw SceneError(g.ctx.where(t.t) + t.path + ": viscosities and retardation times given together; " +
                       forms);
    if (!eta) t.missing("shear_viscosity", forms);
    if (!zeta) t.missing("bulk_viscosity", forms);
    return Damping::viscosities(t.non_negative("shear_viscosity"), t.non_negative("bulk_viscosity"));
  }
  if (!ts) t.missing("tau_shear", forms);
  if (tb == te) {
    if (tb)
      throw SceneError(g.ctx.where(t.t) + t.path + ": tau_bulk and tau_extension given together; " + forms);
    t.missing("tau_extension", forms);
  }
  if (tb) return Damping::shear_bulk(t.non_negative("tau_shear"), t.non_negative("tau_bulk"));
  return Damping::shear_extension(t.non_negative("tau_shear"), t.non_negative("tau_extension"));
}

// A rod whose material curvature is the constant U0 (1/m) at every joint:
// Q_{e+1} = exp(−[U0 l]×) Q_e, x_{e+1} = x_e + l d3_e, so that the library's
// discrete curvature −log(Q_{e+1} Q_eᵀ)/D̂ equals U0 and the rod is built
// unstressed in that shape (a helix in general).
RodSpec curved_rod(const Vec3& start, const Vec3& direction, const Vec3& normal, double length, int n,
                   const Vec3& u0) {
  const RodSpec straight = RodSpec::straight(start, direction, normal, length, n);
  const double l = length / n;
  Eigen::Matrix3d q;
  for (int i = 0; i < 9; ++i) q(i / 3, i % 3) = straight.frames[0][i];
  const E3 w = -to_e(u0) * l;
  const Eigen::Matrix3d step = w.norm() > 0 ? Eigen::AngleAxisd(w.norm(), w.normalized()).toRotationMatrix()
                                            : Eigen::Matrix3d::Identity();
  std::vector<Vec3> nodes{start};
  std::vector<Mat3> frames;
  for (int e = 0; e < n; ++e) {
    Mat3 f;
    for (int i = 0; i < 9; ++i) f[i] = q(i / 3, i % 3);
    frames.push_back(f);
    const E3 d3 = q.row(2).transpose();
    nodes.push_back(from_e(to_e(nodes.back()) + l * d3));
    q = step * q;
  }
  return RodSpec::polyline(std::move(nodes), std::move(frames));
}

// Sets a numeric value at a dotted key path ("rods.0.damping.tau_extension",
// "rods.1.tip_force.0"), creating the last key of a table if absent.
void apply_override(toml::table& root, const Override& o, Ctx& ctx) {
  std::vector<std::string> parts;
  std::stringstream ss(o.key);
  for (std::string p; std::getline(ss, p, '.');) parts.push_back(p);
  auto bad = [&](const std::string& msg) { throw SceneError(ctx.source + ": --vary " + o.key + ": " + msg); };
  if (parts.size() < 2) bad("expected a key path like rods.0.damping.tau_extension");
  if (parts[0] == "simulation")
    bad("[simulation] keys cannot be varied (every variation shares one batch and one dt)");
  if (parts[0] != "rods") bad("only rods.<group>.<key> paths can be varied");
  toml::node* cur = &root;
  for (std::size_t i = 0; i < parts.size(); ++i) {
    const bool last = i + 1 == parts.size();
    const std::string& p = parts[i];
    // keys the schema reads as integers (elsewhere an integer in the file,
    // `youngs_modulus = 1000000`, is a number that may take any value: a
    // whole value stays an integer, another becomes a float, which the
    // schema then refuses where it needs an integer, naming the key)
    const bool integer_key = p == "count" || p == "elements" || p == "columns" || p == "seed";
    if (toml::table* t = cur->as_table()) {
      toml::node* next = t->get(p);
      if (!next) {
        if (!last) bad("no key '" + p + "' in the scene");
        if (integer_key && o.value == std::floor(o.value) && std::abs(o.value) < 9e18)
          t->insert_or_assign(p, std::int64_t(o.value));
        else
          t->insert_or_assign(p, o.value);
        ctx.overridden.insert(t->get(p));
        return;
      }
      if (last) {
        if (next->is_integer() && (integer_key || (o.value == std::floor(o.value) && std::abs(o.value) < 9e18))) {
          if (o.value != std::floor(o.value))
            bad("'" + p + "' is an integer, value " + num(o.value) + " is not");
          t->insert_or_assign(p, std::int64_t(o.value));
        } else if (next->is_number()) {
          t->insert_or_assign(p, o.value);
        } else {
          bad("'" + p + "' is " + type_name(*next) + ", not a number");
        }
        ctx.overridden.insert(t->get(p));
        return;
      }
      cur = next;
    } else if (toml::array* a = cur->as_array()) {
      char* end = nullptr;
      const long idx = std::strtol(p.c_str(), &end, 10);
      if (*end || idx < 0 || idx >= long(a->size()))
        bad("index '" + p + "' out of range (array has " + std::to_string(a->size()) + " entries)");
      if (last) {
        toml::node* e = a->get(std::size_t(idx));
        if (!e->is_number()) bad("entry " + p + " is " + type_name(*e) + ", not a number");
        if (e->is_integer() && o.value == std::floor(o.value) && std::abs(o.value) < 9e18) {
          a->replace(a->cbegin() + idx, std::int64_t(o.value));
        } else {
          a->replace(a->cbegin() + idx, o.value);
        }
        ctx.overridden.insert(a->get(std::size_t(idx)));
        return;
      }
      cur = a->get(std::size_t(idx));
    } else {
      bad("'" + parts[i - 1] + "' is not a table or array");
    }
  }
}

std::uint64_t bytes_for(std::int64_t slots, std::int64_t elements, Precision p) {
  // The arrays of the field list (include/manyrods/fields.h), the implicit
  // viscous workspace (36 + 6 arrays per slot at most: one segment per
  // thread) and the int flags, per slot; plus the double-precision RodSpec
  // (nodes, frames) while building.
  const bool is_float = p == Precision::float32;
  const std::uint64_t t = is_float ? 4 : 8;
  const std::uint64_t arrays = std::uint64_t(fields::model_arrays() + fields::state_arrays(is_float) +
                                             fields::scratch_arrays() + fields::loads_arrays() + 36 + 6);
  return std::uint64_t(slots) * (arrays * t + 4) + std::uint64_t(elements) * 128;
}

// A [[rods]] group as parsed, before its rods are expanded.
struct Pending {
  RodGroup g;
  Placement place;
  Vec3 start, direction, normal;
  double length;
  int elements;
  Vec3 u0;
  bool curved, stiff = false, preload = false;
  std::optional<std::array<double, 2>> taper;  // section.taper: root and tip radius (m)
  std::optional<HoldKind> root_hold, tip_hold;  // nullopt: free
  std::shared_ptr<const RootMotion> tip_motion;
  std::vector<NodeHold> holds;  // [[rods.constraints]]
  Drag drag;
  double scale;
  Section section;
  Material material;
  Damping damping;
  const toml::table* table;
  std::shared_ptr<const RootMotion> motion;  // driven root: shared by the group's rods
  // from_curves (include/manyrods/curves.h): one rod per curve, `curve_elements`
  // each (0: the curve's own points), the section from the widths unless the
  // group gives one; the exact slot and element totals for the size check
  std::vector<Curve> curves;
  int curve_elements = 0;
  bool section_from_widths = false;
  std::int64_t curve_slots = 0, curve_element_total = 0;
};

toml::table parse_toml(std::string_view text, const std::string& source) {
  try {
    return toml::parse(text, source);
  } catch (const toml::parse_error& e) {
    const auto& b = e.source().begin;
    throw SceneError(source + ":" + std::to_string(b.line) + ":" + std::to_string(b.column) +
                     ": TOML syntax error: " + std::string(e.description()));
  }
}

// Memory and index range before anything large is allocated.
void check_size(const std::string& source, std::int64_t slots, std::int64_t elements, Precision precision) {
  if (slots + 64 > std::int64_t(std::numeric_limits<int>::max()))
    throw SceneError(source + ": the scene has " + std::to_string(elements) +
                     " elements in all; a batch holds at most about 2.1e9 slots (int index)");
  const std::uint64_t need = bytes_for(slots, elements, precision);
  const std::uint64_t memory = physical_memory();
  if (memory > 0 && need > memory)
    throw SceneError(source + ": the scene needs about " + num(double(need) / 1e9) + " GB (" +
                     std::to_string(elements) + " elements), more than this machine's " +
                     num(double(memory) / 1e9) + " GB of memory");
}

// The root and the tip (free, clamped, pinned, each possibly driven), the
// interior constraints and the tip loads of a group.
void parse_group_ends(const Table& g, Pending& p) {
  const Root root = parse_end(g, "root", true);
  p.root_hold = root.hold;
  p.motion = root.motion;
  const Root tip = parse_end(g, "tip", false);
  p.tip_hold = tip.hold;
  p.tip_motion = tip.motion;
  if (const toml::node* cn = g.get("constraints")) {
    const toml::array* a = cn->as_array();
    if (!a || !a->is_array_of_tables())
      g.fail("constraints", "must be one or more [[rods.constraints]] tables { node = k, kind = \"clamped\" | \"pinned\", motion = … }");
    for (std::size_t i = 0; i < a->size(); ++i) {
      const toml::table& ct = *a->get(i)->as_table();
      const std::string path = g.key("constraints." + std::to_string(i));
      // a one-entry wrapper, so that the hold's keys are read as "constraints.i.<key>"
      toml::table wrap;
      wrap.insert(std::to_string(i), ct);
      const Table w(g.ctx, wrap, g.key("constraints"), {std::to_string(i).c_str()});
      const std::string idx = std::to_string(i);
      const Table c(g.ctx, ct, path, with_motion_keys({"node", "kind"}));
      NodeHold h;
      h.node = int(c.integer("node", 0, std::numeric_limits<int>::max()));
      if (h.node == 0) c.fail("node", "node 0 is the root: hold it with the group's root key");
      if (h.node >= p.elements)
        c.fail("node", h.node == p.elements ? "node " + std::to_string(h.node) + " is the tip: hold it with the group's tip key"
                                            : "node " + std::to_string(h.node) + " does not exist (the rods have nodes 0 … " +
                                                  std::to_string(p.elements) + ")");
      for (const NodeHold& o : p.holds)
        if (o.node == h.node) c.fail("node", "node " + std::to_string(h.node) + " has two constraints (one per node)");
      if (!c.has("kind")) c.missing("kind", "\"clamped\" or \"pinned\"");
      // the hold itself: kind and motion, read from the wrapper under its index
      const Root r = parse_hold_table(w, idx.c_str(), {"node"});
      h.kind = *r.hold;
      h.motion = r.motion;
      p.holds.push_back(h);
    }
  }
  p.g.tip_force = g.vec3("tip_force", {0, 0, 0});
  if (p.tip_hold && to_e(p.g.tip_force).norm() > 0)
    g.fail("tip_force", std::string("acts on the tip node, which tip = \"") +
                            (*p.tip_hold == HoldKind::clamped ? "clamped" : "pinned") +
                            "\" holds fixed");
  if (g.has("initial_tip_force")) {
    if (p.root_hold != HoldKind::clamped)
      g.fail("initial_tip_force", "needs root = \"clamped\" (a free rod has no static equilibrium under a tip force)");
    if (p.tip_hold) g.fail("initial_tip_force", "needs tip = \"free\" (a held tip carries no tip load)");
    if (!p.holds.empty()) g.fail("initial_tip_force", "needs a rod without [[rods.constraints]]");
    p.g.has_initial_tip_force = true;
    p.g.initial_tip_force = g.vec3("initial_tip_force");
  }
}

// A group's drag = { normal, tangential, cd_normal, cd_tangential, buoyancy }
// (include/manyrods/fluid.h; acts in the scene's [fluid]).
Drag parse_drag(const Table& g) {
  Drag d;
  if (!g.has("drag")) return d;
  const Table t = g.sub("drag", {"normal", "tangential", "cd_normal", "cd_tangential", "buoyancy"});
  d.normal = t.has("normal") ? t.non_negative("normal") : 0.0;
  d.tangential = t.has("tangential") ? t.non_negative("tangential") : 0.0;
  d.cd_normal = t.has("cd_normal") ? t.non_negative("cd_normal") : 0.0;
  d.cd_tangential = t.has("cd_tangential") ? t.non_negative("cd_tangential") : 0.0;
  d.buoyancy = t.boolean("buoyancy", true);
  return d;
}

// from_curves = { file, elements, scale }: the group's rods from guide
// curves (include/manyrods/curves.h; docs/scenes.md "Grooms from curves").
// The keys that place generated rods do not go with it; the section comes
// from the file's widths when the group gives none.
void parse_curves(const Table& g, Pending& p) {
  for (const char* k : {"count", "elements", "length", "start", "direction", "normal", "placement", "rest_curvature"})
    if (g.has(k))
      g.fail(k, "does not go with from_curves (the curves give the rods' number, shape and rest shape; "
                "from_curves.elements resamples them)");
  const toml::node* n = g.get("from_curves");
  if (!n->is_table()) g.fail("from_curves", "must be a table { file = \"groom.usda\", elements = 32 }");
  const Table t = g.sub("from_curves", {"file", "elements", "scale"});
  if (!t.has("file")) t.missing("file", "a .usda, .obj or .h5 file of curves, relative to the scene file");
  const std::string file = t.text("file");
  p.curve_elements = t.has("elements") ? int(t.integer("elements", 0, 1 << 30)) : 0;
  const double scale = t.has("scale") ? t.positive("scale") : 1.0;
  const std::string full = input_file(g.ctx, file);
  try {
    p.curves = read_curves(full);
  } catch (const InputError& e) {
    t.fail("file", e.what());
  }
  p.section_from_widths = !g.has("section");
  int fewest = std::numeric_limits<int>::max();
  for (Curve& c : p.curves) {
    for (Vec3& x : c.points)
      for (double& v : x) v *= scale;
    if (c.width > 0) c.width *= scale;
    if (p.section_from_widths && !(c.width > 0))
      t.fail("file", c.label + ": no widths in the file: give the group a section");
    const int e = p.curve_elements > 0 ? p.curve_elements : std::max(1, int(c.points.size()) - 1);
    fewest = std::min(fewest, e);
    p.curve_slots += e + 2;
    p.curve_element_total += e;
    if (p.section_from_widths) p.g.width = std::max(p.g.width, c.width);
  }
  if (p.curves.size() > std::size_t(std::numeric_limits<int>::max())) t.fail("file", "too many curves");
  p.g.count = int(p.curves.size());
  p.elements = fewest;  // interior holds must exist on every rod
  if (p.section_from_widths) p.section = Section::circle(0.5 * p.curves[0].width);
}

// One [[rods]] table, every key validated in the order of docs/scenes.md;
// the group's material and damping resolved (so that a library InputError
// names this group). The placement is made by the caller after the size
// check.
Pending parse_group(const Table& g, const toml::table& gt, std::size_t gi, const Simulation& sim) {
  Pending p;
  p.table = &gt;
  p.g.name = g.has("name") ? g.text("name") : "rods." + std::to_string(gi);
  p.g.line = int(gt.source().begin.line);
  if (g.has("from_curves")) {
    parse_curves(g, p);
  } else {
    p.g.count = int(g.has("count") ? g.integer("count", 1, std::numeric_limits<int>::max()) : 1);
    p.elements = int(g.integer("elements", 1, 1 << 30));
    p.length = g.positive("length");
    p.start = g.vec3("start", {0, 0, 0});
    p.direction = g.nonzero_vec3("direction", {0, 0, 1});
    p.normal = g.nonzero_vec3("normal", {1, 0, 0});
    const auto parallel = [&] {
      return to_e(p.direction).normalized().cross(to_e(p.normal).normalized()).norm() < 1e-9;
    };
    if (!g.has("normal") && parallel()) p.normal = RodSpec::normal_across(p.direction);  // a rod along x
    if (parallel()) g.fail("normal", "normal must not be parallel to direction");
  }
  if (!p.section_from_widths) p.section = parse_section(g, &p.g.width, &p.taper);
  p.material = parse_material(g);
  p.damping = parse_damping(g);
  p.u0 = p.curves.empty() ? g.vec3("rest_curvature", {0, 0, 0}) : Vec3{0, 0, 0};
  p.curved = to_e(p.u0).norm() > 0;
  parse_group_ends(g, p);
  p.drag = parse_drag(g);
  p.scale = g.has("shear_stretch_scale") ? g.positive("shear_stretch_scale") : 1.0;
  p.stiff = g.boolean("stiff", false);
  p.preload = g.boolean("preload", false);
  if (p.preload && p.g.has_initial_tip_force)
    g.fail("preload", "takes the rods as built as the equilibrium; initial_tip_force moves them from it: give one of the two");
  if (g.has("friction")) {
    p.g.has_friction = true;
    p.g.friction = parse_friction(g);
  }
  if (p.stiff && sim.integrator != Integrator::position_verlet)
    g.fail("stiff", "stiff rods (shear, stretch and twist implicit) need integrator = \"position_verlet\"");
  if (g.has("terms")) {
    const Table t = g.sub("terms", {"shear", "stretch", "bend", "twist", "kelvin_voigt", "gravity"});
    p.g.terms = {t.boolean("shear", true), t.boolean("stretch", true),      t.boolean("bend", true),
                 t.boolean("twist", true), t.boolean("kelvin_voigt", true), t.boolean("gravity", true)};
  }
  try {
    const ElasticConstants c = resolve_material(p.material);
    (void)section_properties(p.section, c.nu);
    (void)resolve_damping(p.damping, c);
  } catch (const InputError& e) {
    g.fail(g.has("damping") ? "damping" : "material", e.what());
  }
  return p;
}

// A linear taper from radius r0 at the root to r1 at the tip, along the
// rod's arc length: each element's section scale r(s)/r0 at its midpoint.
std::vector<double> taper_scale(const RodSpec& r, double r0, double r1) {
  std::vector<double> s(std::size_t(r.elements() + 1), 0.0);
  for (int e = 0; e < r.elements(); ++e)
    s[std::size_t(e + 1)] = s[std::size_t(e)] + (to_e(r.nodes[std::size_t(e + 1)]) - to_e(r.nodes[std::size_t(e)])).norm();
  std::vector<double> f(std::size_t(r.elements()));
  for (int e = 0; e < r.elements(); ++e) {
    const double mid = 0.5 * (s[std::size_t(e)] + s[std::size_t(e + 1)]) / s.back();
    f[std::size_t(e)] = (r0 + (r1 - r0) * mid) / r0;
  }
  return f;
}

// The group's rods, appended to the scene.
void expand_group(Scene& sc, Pending& p, std::size_t gi) {
  p.g.first_rod = int(sc.rods.size());
  for (int i = 0; i < p.g.count; ++i) {
    RodSpec r;
    try {
      if (!p.curves.empty()) {
        r = rod_from_curve(p.curves[std::size_t(i)], p.curve_elements);
        if (!p.section_from_widths) {  // the group's section, uniform (or its own taper, below)
          r.section = p.section;
          r.section_scale.clear();
        }
      } else
      r = p.curved ? curved_rod(p.place.starts[i], p.place.directions[i], p.place.normals[i], p.length, p.elements,
                                p.u0)
                   : RodSpec::straight(p.place.starts[i], p.place.directions[i], p.place.normals[i], p.length,
                                       p.elements);
    } catch (const InputError& e) {
      throw SceneError(sc.source + ":" + std::to_string(p.g.line) + ": rods." + std::to_string(gi) + " rod " +
                       std::to_string(i) + ": " + e.what());
    }
    r.name = p.g.name + "[" + std::to_string(i) + "]";
    if (p.curves.empty()) r.section = p.section;
    r.material = p.material;
    r.damping = p.g.terms.kelvin_voigt ? p.damping : Damping::none();
    r.shear_stretch_scale = p.scale;
    set_end_hold(r, RodEnd::root, p.root_hold);
    set_end_hold(r, RodEnd::tip, p.tip_hold);
    r.root_motion = p.motion;
    r.tip_motion = p.tip_motion;
    r.holds = p.holds;
    r.drag = p.drag;
    r.stiff_implicit = p.stiff;
    r.preload = p.preload;
    if (p.taper) r.section_scale = taper_scale(r, (*p.taper)[0], (*p.taper)[1]);
    sc.rods.push_back(std::move(r));
    sc.rod_group.push_back(int(gi));
  }
  sc.groups.push_back(p.g);
}

}  // namespace

Scene parse_scene(std::string_view text, const std::string& source, const std::vector<Override>& overrides) {
  Ctx ctx{source, {}, {}, {}};
  toml::table root = parse_toml(text, source);
  for (const Override& o : overrides) apply_override(root, o, ctx);

  Scene sc;
  sc.source = source;
  sc.text = std::string(text);
  const Table top(ctx, root, "", {"title", "simulation", "rods", "colliders", "contact", "fluid", "observables"});
  if (top.has("title")) (void)top.text("title");
  if (!top.has("simulation")) throw SceneError(source + ": simulation: missing table [simulation]");
  sc.sim = parse_simulation(top);

  const toml::node* rn = top.get("rods");
  if (!rn) throw SceneError(source + ": rods: missing (at least one [[rods]] group)");
  const toml::array* groups = rn->as_array();
  if (!groups || groups->empty() || !groups->is_array_of_tables())
    ctx.fail(*rn, "rods", "must be one or more [[rods]] tables");

  std::vector<Pending> pending;
  std::int64_t slots = 0, elements = 0;
  for (std::size_t gi = 0; gi < groups->size(); ++gi) {
    const toml::table& gt = *groups->get(gi)->as_table();
    const Table g(ctx, gt, "rods." + std::to_string(gi),
                  {"name", "count", "elements", "length", "start", "direction", "normal", "placement",
                   "section", "material", "damping", "rest_curvature", "root", "tip", "tip_force",
                   "initial_tip_force", "terms", "shear_stretch_scale", "stiff", "friction", "constraints",
                   "drag", "from_curves", "preload"});
    Pending p = parse_group(g, gt, gi, sc.sim);
    slots += p.curves.empty() ? std::int64_t(p.g.count) * (p.elements + 2) : p.curve_slots;
    elements += p.curves.empty() ? std::int64_t(p.g.count) * p.elements : p.curve_element_total;
    check_size(source, slots, elements, sc.sim.precision);  // before the placement allocates per-rod vectors
    if (p.curves.empty()) p.place = parse_placement(g, p.g.count, p.start, p.direction, p.normal);
    pending.push_back(std::move(p));
  }
  for (std::size_t gi = 0; gi < pending.size(); ++gi) expand_group(sc, pending[gi], gi);
  parse_contact(ctx, top, sc);
  parse_fluid(top, sc);
  parse_observables(ctx, top, sc);
  for (std::size_t r = 0; r < sc.rods.size() && sc.has_contact; ++r) {
    const RodGroup& g = sc.groups[sc.rod_group[r]];
    sc.contact.rod_friction.push_back(g.friction);
    sc.contact.rod_has_friction.push_back(g.has_friction ? 1 : 0);
  }
  sc.host_motions = std::move(ctx.host_motions);
  std::error_code ec;
  if (std::filesystem::is_regular_file(source, ec)) sc.inputs.push_back(source);
  sc.inputs.insert(sc.inputs.end(), ctx.inputs.begin(), ctx.inputs.end());
  return sc;
}

Scene load_scene(const std::string& path) {
  std::error_code ec;
  if (std::filesystem::exists(path, ec) && !std::filesystem::is_regular_file(path, ec))
    throw SceneError(path + ": cannot read the scene file (not a regular file)");
  if (std::filesystem::exists(path, ec) && std::filesystem::file_size(path, ec) > (std::uintmax_t(1) << 26))
    throw SceneError(path + ": the scene file is larger than 64 MB (a scene is a short text; rod geometry comes from the placement)");
  std::ifstream in(path, std::ios::binary);
  if (!in) throw SceneError(path + ": cannot read the scene file");
  std::stringstream ss;
  ss << in.rdbuf();
  return parse_scene(ss.str(), path);
}

std::uint64_t estimated_batch_bytes(const Scene& s) {
  std::int64_t slots = 0, elements = 0;
  for (const RodSpec& r : s.rods) {
    slots += r.elements() + 2;
    elements += r.elements();
  }
  return bytes_for(slots, elements, s.sim.precision);
}

void check_batch_size(const Scene& s) {
  const std::uint64_t need = estimated_batch_bytes(s);
  const std::uint64_t memory = physical_memory();
  if (memory > 0 && need > memory)
    throw SceneError(s.source + ": the batch needs about " + num(double(need) / 1e9) +
                     " GB, more than this machine's " + num(double(memory) / 1e9) + " GB of memory");
}

}  // namespace manyrods::scene
