// host/scene/setup/scene_run.cpp — building and stepping a scene's batch (include/manyrods/scene.h "the batch of a scene").
#include "manyrods/scene.h"
#include "manyrods/any_batch.h"
#include "setup/static_cache.h"

#include <algorithm>
#include <cmath>
#include <cstring>
#include <map>
#include <mutex>
#include <unordered_map>
#include <sstream>
#include <stdexcept>
#include <type_traits>

#include "manyrods/stable_dt.h"
#include "manyrods/statics.h"

namespace manyrods::scene {
namespace {

template <bool kKV, bool kGravity>
constexpr Terms terms_of() {
  Terms t;
  t.kelvin_voigt = kKV;
  t.gravity = kGravity;
  return t;
}

// Calls f.template operator()<kT>() with the compiled Terms
// (include/manyrods/step.h MANYRODS_PLAIN_TERMS, MANYRODS_CONTACT_TERMS:
// the list the library instantiates) equal to the choice's: its
// Kelvin–Voigt term and gravity, or with contact the library's contact
// Terms, which have gravity on (a batch without the gravity term has zero
// gravity then, give_contact).
template <class F>
decltype(auto) with_terms(const StepChoice& c, F&& f, bool contact = true) {
  Terms want;  // (every elastic term and the loads on, no contact)
  want.kelvin_voigt = c.kelvin_voigt;
  if (contact && (c.colliders || c.rod_contact)) {
    want.colliders = c.colliders;
    want.rod_contact = c.rod_contact;
  } else {
    want.gravity = c.gravity;
  }
#define MANYRODS_WITH_TERMS(unused, TERMS) \
  if (terms_mask(want) == terms_mask(TERMS)) return f.template operator()<TERMS>();
  MANYRODS_PLAIN_TERMS(MANYRODS_WITH_TERMS, _)
  MANYRODS_CONTACT_TERMS(MANYRODS_WITH_TERMS, _)
#undef MANYRODS_WITH_TERMS
  throw std::logic_error("with_terms: the library compiles no Terms for this choice");
}

// f.template operator()<kT>() with the choice's Terms less contact: the
// Terms the library instantiates its analyses for (stable_dt, statics;
// `false` alone would leave the contact instantiations referenced where the
// compiler does not fold them away).
template <class F>
decltype(auto) without_contact(const StepChoice& c, F&& f) {
  return with_terms(
      c,
      [&]<Terms kT>() {
        constexpr Terms k = [] {
          Terms t = kT;
          t.colliders = t.rod_contact = false;
          return t;
        }();
        return f.template operator()<k>();
      },
      false);
}

// Zeroes the stiffness of the terms a group switches off (see the header).
template <class T>
void apply_term_switches(RodBatch<T>& b, int rod, const TermSwitches& t) {
  const int n = b.elements(rod);
  for (int e = 0; e < n; ++e) {
    const int k = b.elem_index(rod, e);
    if (!t.shear) b.model.elem_stiffness[0][k] = b.model.elem_stiffness[1][k] = T(0);
    if (!t.stretch) b.model.elem_stiffness[2][k] = T(0);
  }
  for (int j = -1; j < n; ++j) {  // root joint, interior joints, tip joint
    const int k = j < 0 ? b.root_vor_index(rod) : b.vor_index(rod, j);
    if (!t.bend) b.model.vor_stiffness[0][k] = b.model.vor_stiffness[1][k] = T(0);
    if (!t.twist) b.model.vor_stiffness[2][k] = T(0);
  }
}

std::string static_key(const RodSpec& r, const RodGroup& g, const Vec3& gravity) {
  std::ostringstream os;
  os.precision(17);
  auto v3 = [&](const Vec3& v) { os << v[0] << ',' << v[1] << ',' << v[2] << ';'; };
  for (const Vec3& x : r.nodes) v3(x);
  for (const Mat3& q : r.frames)
    for (double x : q) os << x << ',';
  os << int(r.section.shape) << ',' << r.section.a << ',' << r.section.b << ',' << r.material.density << ','
     << r.material.youngs_modulus << ',' << r.material.poisson_ratio << ',' << r.material.shear_modulus << ','
     << r.shear_stretch_scale << ',' << r.clamped_root << ',' << r.clamped_tip << ';';
  for (double f : r.section_scale) os << f << ',';
  os << ';';
  const TermSwitches& t = g.terms;
  os << t.shear << t.stretch << t.bend << t.twist << t.gravity << ';';
  v3(g.initial_tip_force);
  v3(g.tip_force);
  v3(gravity);
  return os.str();
}

bool has_gravity(const Scene& s) {
  const Vec3& g = s.sim.gravity;
  return g[0] != 0 || g[1] != 0 || g[2] != 0;
}

}  // namespace

StepChoice step_choice(const Scene& s) {
  StepChoice c;
  c.integrator = s.sim.integrator;
  for (std::size_t i = 0; i < s.rods.size(); ++i)
    if (s.groups[s.rod_group[i]].terms.kelvin_voigt && s.rods[i].damping.form != Damping::Form::none) {
      // a damping form with all-zero parameters is still "off"
      if (s.rods[i].damping.p1 != 0 || s.rods[i].damping.p2 != 0) c.kelvin_voigt = true;
    }
  // the compile-time gravity term when every group has it; groups that
  // differ get gravity as dead node loads instead (give_group_terms_and_loads)
  c.gravity = has_gravity(s) && std::all_of(s.groups.begin(), s.groups.end(),
                                             [](const RodGroup& g) { return g.terms.gravity; });
  c.colliders = !s.contact.colliders.empty();
  c.rod_contact = s.contact.rod_rod || s.contact.self;
  return c;
}

// The scene's colliders and contact switches (after the initial state: a rod
// may not start inside a collider). The contact Terms have gravity on: a
// batch whose gravity is carried as dead loads gets zero gravity.
template <class T>
void give_contact(const Scene& s, const StepChoice& choice, RodBatch<T>& b) {
  if (!s.has_contact) return;
  if (!choice.gravity) b.set_gravity({0, 0, 0});
  try {
    set_contact(b, s.contact);
  } catch (const InputError& e) {
    throw SceneError(s.source + ": " + e.what());
  }
}

// The scene's fluid (drag, buoyancy, wind), when it has one.
template <class T>
void give_fluid(const Scene& s, RodBatch<T>& b) {
  if (!s.has_fluid) return;
  try {
    set_fluid(b, s.fluid);
  } catch (const InputError& e) {
    throw SceneError(s.source + ": " + e.what());
  }
}

struct StaticCache::Impl {
  std::size_t max_bytes, bytes = 0;
  mutable std::mutex m;
  mutable std::size_t hits = 0;
  std::unordered_map<std::string, State> states;  // by the key's two hashes
};

namespace {
// Two independent 64-bit hashes of a key (std::hash and FNV-1a), as 16 bytes.
std::string key_hash(const std::string& key) {
  std::uint64_t a = std::hash<std::string>{}(key), b = 14695981039346656037ull;
  for (unsigned char c : key) b = (b ^ c) * 1099511628211ull;
  std::string h(16, '\0');
  std::memcpy(h.data(), &a, 8);
  std::memcpy(h.data() + 8, &b, 8);
  return h;
}
}  // namespace

StaticCache::StaticCache(std::size_t max_bytes) : impl_(std::make_unique<Impl>()) { impl_->max_bytes = max_bytes; }
StaticCache::~StaticCache() = default;
bool StaticCache::find(const std::string& key, State& out) const {
  const std::string h = key_hash(key);
  const std::lock_guard<std::mutex> lock(impl_->m);
  const auto it = impl_->states.find(h);
  if (it == impl_->states.end()) return false;
  out = it->second;
  ++impl_->hits;
  return true;
}
void StaticCache::put(const std::string& key, const State& s) {
  const std::size_t bytes = 8 * (s.x.size() + s.q.size()) + 64;
  const std::lock_guard<std::mutex> lock(impl_->m);
  if (impl_->bytes + bytes > impl_->max_bytes) return;
  if (impl_->states.emplace(key_hash(key), s).second) impl_->bytes += bytes;
}
std::size_t StaticCache::hits() const {
  const std::lock_guard<std::mutex> lock(impl_->m);
  return impl_->hits;
}

namespace {

// The batch of the scene's rods (SceneError naming the scene on invalid rods).
template <class T>
RodBatch<T> batch_of_rods(const Scene& s) {
  try {
    return build_batch<T>(s.rods, s.sim.gravity);
  } catch (const InputError& e) {
    throw SceneError(s.source + ": " + e.what());
  } catch (const std::bad_alloc&) {
    throw SceneError(s.source + ": out of memory building the batch (about " +
                     std::to_string(estimated_batch_bytes(s) / 1000000) + " MB estimated)");
  }
}

// Each group's term switches and loads (tip force, gravity as a load) on its rods.
template <class T>
void give_group_terms_and_loads(const Scene& s, const StepChoice& choice, RodBatch<T>& b) {
  // Gravity per group: when groups differ, the batch has no gravity term and
  // the rods of groups with gravity carry it as a dead load m_j g on every
  // node (the same force; its potential is the dead loads' −f·x).
  const bool gravity_as_load = has_gravity(s) && !choice.gravity;
  for (int r = 0; r < b.rod_count(); ++r) {
    const RodGroup& g = s.groups[s.rod_group[r]];
    apply_term_switches(b, r, g.terms);
    const int n = b.elements(r);
    if (gravity_as_load && g.terms.gravity) {
      for (int j = 0; j <= n; ++j) {
        const double m = double(b.model.node_mass[b.node_index(r, j)]);
        const Vec3 tip = j == n ? g.tip_force : Vec3{0, 0, 0};
        b.set_node_force(r, j, {m * s.sim.gravity[0] + tip[0], m * s.sim.gravity[1] + tip[1],
                                m * s.sim.gravity[2] + tip[2]});
      }
    } else if (g.tip_force != Vec3{0, 0, 0}) {
      b.set_node_force(r, n, g.tip_force);
    }
  }
}

// The distinct (rod, load) keys of the rods with initial_tip_force.
struct StaticKeys {
  std::vector<std::string> keys;
  std::vector<int> key_rod;          // a rod of each key
  std::vector<std::size_t> rod_key;  // [rods]: its key, or -1
};

StaticKeys static_keys(const Scene& s, int rods) {
  StaticKeys k;
  std::map<std::string, std::size_t> key_index;
  k.rod_key.assign(std::size_t(rods), std::size_t(-1));
  for (int r = 0; r < rods; ++r) {
    const RodGroup& g = s.groups[s.rod_group[r]];
    if (!g.has_initial_tip_force) continue;
    const auto [it, fresh] = key_index.emplace(static_key(s.rods[r], g, s.sim.gravity), k.key_rod.size());
    if (fresh) {
      k.key_rod.push_back(r);
      k.keys.push_back(it->first);
    }
    k.rod_key[std::size_t(r)] = it->second;
  }
  return k;
}

struct Solved : StaticCache::State {  // (x, q: the tip ghost's frame too)
  std::string error;                   // empty: converged
};

// Rod r alone in its own batch, in static equilibrium under its group's
// initial_tip_force and tip_force (taken from the cache when it has the key).
void solve_static_rod(const Scene& s, int r, const std::string& key, StaticCache* cache, Solved& out) {
  const RodGroup& g = s.groups[s.rod_group[r]];
  if (cache && cache->find(key, out)) return;
  try {
    RodBatch<double> one = build_batch<double>({s.rods[r]}, s.sim.gravity);
    apply_term_switches(one, 0, g.terms);
    const int n = one.elements(0);
    Vec3 f;
    for (int a = 0; a < 3; ++a) f[a] = g.initial_tip_force[a] + g.tip_force[a];
    one.set_node_force(0, n, f);
    const StaticResult res = has_gravity(s) && g.terms.gravity ? solve_static<terms_of<false, true>()>(one)
                                                               : solve_static<terms_of<false, false>()>(one);
    if (!res.converged) out.error = "the static equilibrium under initial_tip_force did not converge";
    for (int a = 0; a < 3; ++a)
      for (int j = 0; j <= n; ++j) out.x.push_back(one.state.node_x[a][one.node_index(0, j)]);
    for (int i = 0; i < 9; ++i)
      for (int e = 0; e <= n; ++e) out.q.push_back(one.state.elem_Q[i][one.elem_index(0, e)]);
    if (cache && out.error.empty()) cache->put(key, out);
  } catch (const std::exception& e) {
    out.error = e.what();
  }
}

// One static equilibrium per key, solved in parallel (each rod alone in its
// own batch: the same numbers on any number of threads); SceneError naming
// the group of the first key that failed.
std::vector<Solved> solve_statics(const Scene& s, const StaticKeys& k, StaticCache* cache) {
  std::vector<Solved> solved(k.key_rod.size());
  // (every thread in the caller's floating-point mode: the same numbers on any thread count)
  parallel_tasks(k.key_rod.size(),
                 [&](std::size_t i) { solve_static_rod(s, k.key_rod[i], k.keys[i], cache, solved[i]); });
  for (std::size_t i = 0; i < k.key_rod.size(); ++i)
    if (!solved[i].error.empty()) {
      const RodGroup& g = s.groups[s.rod_group[k.key_rod[i]]];
      throw SceneError(s.source + ":" + std::to_string(g.line) + ": " + g.name + ": " + solved[i].error);
    }
  return solved;
}

// The solved states copied into the rods that share them.
template <class T>
void copy_static_states(const std::vector<Solved>& solved, const std::vector<std::size_t>& rod_key, RodBatch<T>& b) {
  for (int r = 0; r < b.rod_count(); ++r) {
    if (rod_key[std::size_t(r)] == std::size_t(-1)) continue;
    const Solved& one = solved[rod_key[std::size_t(r)]];
    const int n = b.elements(r);
    for (int a = 0; a < 3; ++a)
      for (int j = 0; j <= n; ++j) b.state.node_x[a][b.node_index(r, j)] = T(one.x[std::size_t(a * (n + 1) + j)]);
    // (e = n: the tip ghost element holds a copy of the last frame, batch.h)
    for (int i = 0; i < 9; ++i)
      for (int e = 0; e <= n; ++e) b.state.elem_Q[i][b.elem_index(r, e)] = T(one.q[std::size_t(i * (n + 1) + e)]);
  }
}

// The rest shapes of the groups with preload = true (scene_preload),
// solved in double precision on the rods as built: a float batch takes
// them from the scene's batch built in double. SceneError naming the rod,
// its group and line where none exists or where the equilibrium it makes
// is unstable.
template <class T>
void give_preload(const Scene& s, const StepChoice& choice, RodBatch<T>& b) {
  if (std::none_of(b.rods.begin(), b.rods.end(), [](const RodInfo& r) { return r.preload; })) return;
  if constexpr (std::is_same_v<T, double>) {
    const PreloadResult r = scene_preload(b, choice);
    if (!r.ok || r.unstable) throw SceneError(s.source + ": " + preload_failure(r, b, &s));
  } else {
    copy_rest_shape(build_scene_batch<double>(s, false), b);
  }
}

}  // namespace

template <class T>
RodBatch<T> build_scene_batch(const Scene& s, bool initial_state) {
  return build_scene_batch<T>(s, initial_state, nullptr);
}

template <class T>
RodBatch<T> build_scene_batch(const Scene& s, bool initial_state, StaticCache* cache) {
  check_batch_size(s);
  const StepChoice choice = step_choice(s);
  RodBatch<T> b = batch_of_rods<T>(s);
  give_group_terms_and_loads(s, choice, b);
  give_fluid(s, b);
  if (initial_state) {
    // The static equilibria, one per distinct (rod, load) key, then copied
    // into the rods that share it.
    const StaticKeys keys = static_keys(s, b.rod_count());
    copy_static_states(solve_statics(s, keys, cache), keys.rod_key, b);
  }
  give_contact(s, choice, b);
  give_preload(s, choice, b);
  return b;
}

// The largest step ≤ dt that divides the output interval into whole steps,
// so that frame k lies at step k·m, time k·interval (up to the round-off of
// summing the steps); dt itself when it divides it already (to 1e-9).
double frame_aligned_dt(double dt, double interval) {
  if (!(interval > 0) || !(dt > 0)) return dt;
  const double ratio = interval / dt;
  if (std::abs(ratio - std::round(ratio)) <= 1e-9 * ratio && std::round(ratio) >= 1) return dt;
  return interval / std::ceil(ratio);
}

template <class T>
double scene_dt(const Scene& s, const RodBatch<T>& b) {
  const StableDt sd = scene_stable_dt(b, step_choice(s));
  const bool finite = std::isfinite(sd.elastic) && sd.elastic > 0;
  const double automatic = sd.automatic();
  if (s.sim.dt_auto && !(std::isfinite(automatic) && automatic > 0))
    throw SceneError(s.source +
                     ": dt = \"auto\": stable_dt gives no finite step (no stiffness?); give dt in seconds");
  // stiff rods: dt = "auto" is their accuracy step (StableDt::accuracy), no stability limit
  const double dt = s.sim.dt_auto ? automatic * s.sim.dt_safety : s.sim.dt;
  if (finite && dt > sd.elastic && !s.sim.force_dt) {
    std::ostringstream os;
    os.precision(4);
    os << s.source << ": simulation." << (s.sim.dt_auto ? "dt_safety = " : "dt = ")
       << (s.sim.dt_auto ? s.sim.dt_safety : s.sim.dt) << (s.sim.dt_auto ? "" : " s")
       << ": the step " << dt << " s is " << dt / sd.elastic << " x this scene's stable limit " << sd.elastic
       << " s (stable_dt of what it integrates explicitly; stiff rods have no limit). Use dt = \"auto\" (0.9 x "
       << (automatic < sd.elastic ? "the stiff rods' accuracy step = " : "the limit = ") << 0.9 * automatic
       << " s), a dt at or below the limit, or --force-dt to run it anyway (Python: force_dt=True; docs/scenes.md "
          "\"The step-size guard\")";
    throw SceneError(os.str());
  }
  return frame_aligned_dt(dt, s.sim.output_interval);
}

template <class T>
void advance_scene(RodBatch<T>& b, const StepChoice& c, T dt, std::int64_t steps, const Exec& ex) {
  with_terms(c, [&]<Terms kT>() {
    if constexpr (kT.colliders || kT.rod_contact)
      advance<kT, Viscous::implicit, Integrator::position_verlet>(b, dt, steps, ex);
    else if (c.integrator == Integrator::pefrl)
      advance<kT, Viscous::implicit, Integrator::pefrl>(b, dt, steps, ex);
    else
      advance<kT, Viscous::implicit, Integrator::position_verlet>(b, dt, steps, ex);
  });
}

template <class T>
Energies scene_energies(const RodBatch<T>& b, const StepChoice& c, int rod) {
  return with_terms(c, [&]<Terms kT>() { return energies<kT>(b, rod); });
}

template <class T>
StableDt scene_stable_dt(const RodBatch<T>& b, const StepChoice& c) {
  // contact does not limit it: the same Terms without contact
  return without_contact(c, [&]<Terms k>() { return stable_dt<k>(b); });
}

namespace {

// "rod 3 ("hair[3]") of group "hair" (line 12)": a rod in words.
std::string rod_words(const RodBatch<double>& b, int rod, const Scene* s) {
  std::ostringstream os;
  os << "rod " << rod;
  const std::string& name = b.rods[std::size_t(rod)].name;
  if (!name.empty()) os << " (\"" << name << "\")";
  if (s && rod < int(s->rod_group.size())) {
    const RodGroup& g = s->groups[std::size_t(s->rod_group[std::size_t(rod)])];
    os << " of group \"" << g.name << "\" (line " << g.line << ")";
  }
  return os.str();
}

}  // namespace

StaticResult scene_solve_static(RodBatch<double>& b, const StepChoice& c, const StaticOptions& opt) {
  const double t = std::isfinite(opt.hold_time) ? opt.hold_time : b.state.time;
  if (!std::isnan(opt.hold_time) && !(opt.hold_time >= 0 && std::isfinite(opt.hold_time)))
    throw InputError("solve_static: the time of the holds' poses must be >= 0 and finite");
  if (b.fluid.on && (b.fluid.linear || b.fluid.quadratic)) {
    const Vec3 u = b.fluid.spec.mean_velocity(t);
    if (u[0] != 0 || u[1] != 0 || u[2] != 0 || !b.fluid.modes.empty())
      throw InputError("solve_static: the static solve takes a fluid's buoyancy, not its wind (drag on rods at rest "
                       "in a moving fluid): set the fluid's velocity and turbulence to zero, or run the dynamics");
  }
  return without_contact(c, [&]<Terms k>() { return solve_static<k>(b, opt); });
}

PreloadResult scene_preload(RodBatch<double>& b, const StepChoice& c) {
  return without_contact(c, [&]<Terms k>() { return preload_rest_shape<k>(b); });
}

std::string preload_failure(const PreloadResult& r, const RodBatch<double>& b, const Scene* s) {
  if (r.ok && r.unstable == 0) return "";
  std::ostringstream os;
  os.precision(3);
  if (r.ok) {
    os << rod_words(b, r.unstable_rod, s) << ": preload: the rod as built is an equilibrium, but an unstable one";
    if (std::isfinite(r.growth_rate))
      os << " (a small disturbance grows e-fold every " << 1 / r.growth_rate << " s)";
    os << ": it would fall away from it, as a real rod would (beyond its buckling load under its own weight, e.g. "
          "a long hair standing up or held out sideways, or a pre-curved rod free to roll between pins)";
    if (r.unstable > 1) os << "; " << r.unstable - 1 << " more preloaded rod(s) are unstable too";
    os << "; model it hanging or resting on a collider, shorten or stiffen it, or set preload = false";
    return os.str();
  }
  os.precision(4);
  os << rod_words(b, r.failed_rod, s) << ": preload: no rest shape makes the rod as built its static equilibrium "
     << "(a force of " << r.residual_force << " N at node " << r.failed_node
     << " is left that no strain of the rod carries): the loads move it as a whole (a free rod in gravity, a "
        "pendulum off its vertical); hold it (a clamped root), or set preload = false";
  return os.str();
}

std::vector<HoldReaction> scene_hold_reactions(const RodBatch<double>& b, const StepChoice& c) {
  return without_contact(c, [&]<Terms k>() { return hold_reactions<k>(b); });
}

std::string static_failure(const StaticResult& r, const RodBatch<double>& b, const Scene* s) {
  if (r.converged) return "";
  std::ostringstream os;
  os.precision(4);
  os << rod_words(b, r.failed_rod, s) << ": no static equilibrium: ";
  if (r.mechanism)
    os << "it is free to move under its loads (" << r.zero_modes
       << " motion(s) of zero stiffness along which the loads push, at load fraction " << r.load_reached
       << "; residual force " << r.residual_force << " N at node " << r.failed_node
       << "): hold it (a clamped root, a pinned tip), or take off the load that moves it";
  else
    os << "Newton's method did not converge beyond "
       << (r.holds_walk ? "a fraction " : "load fraction ") << r.load_reached
       << (r.holds_walk ? " of the driven holds' walk to their poses, under the full loads" : "") << " (residual force "
       << r.residual_force << " N at node " << r.failed_node << ", couple " << r.residual_couple
       << " N m): the equilibrium path snaps through or ends there";
  return os.str();
}

template <class T>
void start_from_static(const Scene& s, RodBatch<T>& b) {
  const AnyBatch a = static_equilibrium(s, 0);
  const RodBatch<double>& e = a.f64();
  for (int a = 0; a < 3; ++a)
    for (int k = 0; k < b.slots(); ++k) {
      b.state.node_x[a][k] = T(e.state.node_x[a][k]);
      b.state.node_v[a][k] = b.state.elem_w[a][k] = T(0);
      if constexpr (sizeof(T) == 4) b.state.node_xc[a][k] = T(0);
    }
  for (int i = 0; i < 9; ++i)
    for (int k = 0; k < b.slots(); ++k) b.state.elem_Q[i][k] = T(e.state.elem_Q[i][k]);
}

template <class T>
void gather_positions(const RodBatch<T>& b, std::vector<T>& out) {
  out.clear();
  for (int r = 0; r < b.rod_count(); ++r)
    for (int j = 0; j <= b.elements(r); ++j) {
      const int k = b.node_index(r, j);
      for (int a = 0; a < 3; ++a) out.push_back(b.state.node_x[a][k]);
    }
}

template <class T>
void gather_directors(const RodBatch<T>& b, std::vector<T>& out) {
  out.clear();
  for (int r = 0; r < b.rod_count(); ++r)
    for (int e = 0; e < b.elements(r); ++e) {
      const int k = b.elem_index(r, e);
      for (int i = 0; i < 9; ++i) out.push_back(b.state.elem_Q[i][k]);
    }
}

#define MANYRODS_SCENE_INSTANTIATE(T)                                                            \
  template RodBatch<T> build_scene_batch<T>(const Scene&, bool);                                 \
  template RodBatch<T> build_scene_batch<T>(const Scene&, bool, StaticCache*);                   \
  template double scene_dt<T>(const Scene&, const RodBatch<T>&);                                 \
  template void advance_scene<T>(RodBatch<T>&, const StepChoice&, T, std::int64_t, const Exec&); \
  template Energies scene_energies<T>(const RodBatch<T>&, const StepChoice&, int);               \
  template StableDt scene_stable_dt<T>(const RodBatch<T>&, const StepChoice&);                   \
  template void gather_positions<T>(const RodBatch<T>&, std::vector<T>&);                        \
  template void gather_directors<T>(const RodBatch<T>&, std::vector<T>&);                        \
  template void start_from_static<T>(const Scene&, RodBatch<T>&);
MANYRODS_SCENE_INSTANTIATE(float)
MANYRODS_SCENE_INSTANTIATE(double)

}  // namespace manyrods::scene
