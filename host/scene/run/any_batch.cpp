// host/scene/run/any_batch.cpp — AnyBatch (include/manyrods/any_batch.h): a batch of
// either precision, stepped through the scene's Terms dispatch.
#include "manyrods/any_batch.h"

#include <algorithm>
#include <chrono>
#include <sstream>
#include <cmath>
#include <string>

#include "io/state_bytes.h"
#include "manyrods/h5io.h"
#include "manyrods/runner.h"

namespace manyrods::scene {
namespace {

// The largest dimension of a section (m): the USD width of a rod built in code.
double section_width(const Section& s) {
  switch (s.shape) {
    case Shape::rectangle: return std::max(s.a, s.b);
    case Shape::ellipse: return 2 * std::max(s.a, s.b);
    default: return 2 * s.a;
  }
}

// The batch gets host motions of its own (two batches of one scene are
// driven apart): one copy per name among s.host_motions and the HostMotions
// the rods and colliders use (rods built in code that name one driver share
// it), every hold and collider pointed at its copy.
std::vector<std::shared_ptr<HostMotion>> own_host_motions(Scene& s) {
  std::vector<std::shared_ptr<HostMotion>> copies;
  auto remap = [&](std::shared_ptr<const RootMotion>& m) {
    auto h = std::dynamic_pointer_cast<const HostMotion>(m);
    if (!h) return;
    if (h->name().empty()) throw InputError("a host motion (driver) needs a name, got \"\"");
    std::size_t i = 0;
    while (i < copies.size() && copies[i]->name() != h->name()) ++i;
    if (i == copies.size()) copies.push_back(std::make_shared<HostMotion>(*h));
    m = copies[i];
  };
  for (const auto& h : s.host_motions) {
    std::shared_ptr<const RootMotion> m = h;
    remap(m);
  }
  for (RodSpec& r : s.rods) {
    remap(r.root_motion);
    remap(r.tip_motion);
    for (NodeHold& h : r.holds) remap(h.motion);
  }
  for (Collider& c : s.contact.colliders) remap(c.motion);
  s.host_motions = copies;
  return copies;
}

}  // namespace

AnyBatch AnyBatch::from_scene(Scene s, std::optional<Precision> precision) {
  if (precision) s.sim.precision = *precision;
  AnyBatch a;
  a.from_file_ = true;
  a.choice_ = step_choice(s);
  a.host_motions_ = own_host_motions(s);
  if (s.sim.precision == Precision::float32) a.batch_.emplace<0>(build_scene_batch<float>(s));
  else a.batch_.emplace<1>(build_scene_batch<double>(s));
  a.scene_ = std::make_shared<const Scene>(std::move(s));
  return a;
}

AnyBatch AnyBatch::from_rods(std::vector<RodSpec> rods, Precision precision, const Vec3& gravity,
                             Integrator integrator) {
  if (rods.empty()) throw InputError("a batch needs at least one rod");
  for (double g : gravity)
    if (!std::isfinite(g)) throw InputError("gravity: must be finite");
  Scene s;
  s.source = "rods";
  s.sim.precision = precision;
  s.sim.gravity = gravity;
  s.sim.integrator = integrator;
  s.sim.dt_auto = true;
  for (std::size_t r = 0; r < rods.size(); ++r) {
    RodGroup g;
    g.name = rods[r].name.empty() ? "rod " + std::to_string(r) : rods[r].name;
    g.count = 1;
    g.first_rod = int(r);
    g.width = section_width(rods[r].section);
    s.groups.push_back(g);
    s.rod_group.push_back(int(r));
  }
  s.rods = std::move(rods);
  AnyBatch a;
  a.choice_ = step_choice(s);
  a.host_motions_ = own_host_motions(s);
  try {
    if (precision == Precision::float32) a.batch_.emplace<0>(build_scene_batch<float>(s));
    else a.batch_.emplace<1>(build_scene_batch<double>(s));
  } catch (const SceneError& e) {  // build_scene_batch prefixes the source: the rods' own message
    std::string m = e.what();
    if (m.rfind("rods: ", 0) == 0) m = m.substr(6);
    throw InputError(m);
  }
  a.scene_ = std::make_shared<const Scene>(std::move(s));
  return a;
}

int AnyBatch::find_driver(const std::string& name) const {
  for (std::size_t i = 0; i < host_motions_.size(); ++i)
    if (host_motions_[i]->name() == name) return int(i);
  std::string known;
  for (const auto& h : host_motions_) known += (known.empty() ? "\"" : ", \"") + h->name() + "\"";
  throw InputError("no driver named \"" + name + "\" (the batch's host motions: " +
                   (known.empty() ? std::string("none") : known) + ")");
}

void AnyBatch::set_driver_pose(int driver, const Pose& pose, double until, const Vec3& pivot) {
  if (driver < 0 || driver >= driver_count())
    throw InputError("driver " + std::to_string(driver) + " out of range (the batch has " +
                     std::to_string(driver_count()) + " host motions)");
  host_motions_[std::size_t(driver)]->set_target(time(), pose, until, pivot);
}

double AnyBatch::scene_dt() const {
  if (from_file_) return visit([&](const auto& b) { return manyrods::scene::scene_dt(*scene_, b); });
  return 0.9 * stable_dt().automatic();
}

void AnyBatch::check_dt(double dt) const {
  if (dt <= checked_dt_) return;
  const StableDt sd = stable_dt();
  if (std::isfinite(sd.elastic) && sd.elastic > 0 && dt > sd.elastic) {
    std::ostringstream os;
    os.precision(4);
    os << "step: dt = " << dt << " s is " << dt / sd.elastic << " x this batch's stable limit " << sd.elastic
       << " s (stable_dt of what it integrates explicitly; stiff rods have no limit); it would blow up. "
       << "Step at or below the limit (0.9 x the limit = " << 0.9 * sd.elastic
       << " s), or force the step to run it anyway (Python: force_dt=True; C: mr_batch_set_force_dt; "
          "docs/scenes.md \"The step-size guard\")";
    throw InputError(os.str());
  }
  checked_dt_ = dt;
}

std::int64_t AnyBatch::step(double dt, std::int64_t count, int threads, const std::function<bool()>& keep_going,
                            double check_s, bool force_dt) {
  if (!(dt > 0) || !std::isfinite(dt)) throw InputError("step: dt must be > 0 and finite (got " + std::to_string(dt) + ")");
  if (count < 0) throw InputError("step: count must be >= 0 (got " + std::to_string(count) + ")");
  if (threads < 1) throw InputError("step: threads must be >= 1 (got " + std::to_string(threads) + ")");
  if (!force_dt && !scene_->sim.force_dt) check_dt(dt);
  const Exec ex{threads, nullptr};
  const auto advance = [&](std::int64_t n) {
    visit([&](auto& b) {
      using T = typename std::remove_reference_t<decltype(b)>::value_type;
      advance_scene(b, choice_, T(dt), n, ex);
    });
  };
  if (!keep_going) {
    advance(count);
    return count;
  }
  // chunks of whole check intervals, doubled while one takes under check_s
  std::int64_t chunk = kSampleSteps, done = 0;
  while (done < count) {
    const std::int64_t n = std::min(chunk, count - done);
    const auto t0 = std::chrono::steady_clock::now();
    advance(n);
    done += n;
    const double took = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
    if (took < check_s && chunk < (std::int64_t{1} << 40)) chunk *= 2;
    if (done < count && !keep_going()) break;
  }
  return done;
}

Energies AnyBatch::energies(int rod) const {
  if (rod >= rod_count()) throw InputError("energies: rod " + std::to_string(rod) + " out of range (the batch has " +
                                           std::to_string(rod_count()) + ")");
  return visit([&](const auto& b) { return scene_energies(b, choice_, rod); });
}

StableDt AnyBatch::stable_dt() const {
  return visit([&](const auto& b) { return scene_stable_dt(b, choice_); });
}

StaticResult AnyBatch::solve_static(const StaticOptions& opt) {
  if (float32()) throw InputError("solve_static: needs a double-precision batch (precision = \"double\")");
  const StaticResult r = scene_solve_static(f64(), choice_, opt);
  if (r.converged && std::isfinite(opt.hold_time)) f64().state.time = opt.hold_time;
  return r;
}

PreloadResult AnyBatch::preload() {
  if (!float32()) {
    RodBatch<double>& b = f64();
    const auto strain = b.model.elem_rest_strain, curvature = b.model.vor_rest_curvature;
    auto put_back = [&] {
      b.model.elem_rest_strain = strain;
      b.model.vor_rest_curvature = curvature;
    };
    PreloadResult r;
    try {
      r = scene_preload(b, choice_);
    } catch (...) {
      put_back();
      throw;
    }
    if (!r.ok || r.unstable) {  // (an unstable rod's rest shape is the preload's: put the old ones back)
      put_back();
      throw InputError(preload_failure(r, b, scene_.get()));
    }
    return r;
  }
  // in double: the scene's batch with this state and these loads
  RodBatch<float>& b = f32();
  RodBatch<double> d = build_scene_batch<double>(*scene_, false);
  for (int k = 0; k < b.slots(); ++k) {
    for (int a = 0; a < 3; ++a) {
      d.state.node_x[a][k] = double(b.state.node_x[a][k]) + double(b.state.node_xc[a][k]);
      d.loads.node_force[a][k] = b.loads.node_force[a][k];
      d.loads.elem_couple[a][k] = b.loads.elem_couple[a][k];
    }
    for (int i = 0; i < 9; ++i) d.state.elem_Q[i][k] = b.state.elem_Q[i][k];
  }
  d.state.time = b.state.time;
  const PreloadResult r = scene_preload(d, choice_);
  if (!r.ok || r.unstable) throw InputError(preload_failure(r, d, scene_.get()));
  copy_rest_shape(d, b);
  return r;
}

std::string AnyBatch::static_failure(const StaticResult& r) const {
  if (float32()) return "";
  return scene::static_failure(r, f64(), scene_.get());
}

void AnyBatch::check_static(const StaticResult& r) const {
  if (r.converged) return;
  if (r.mechanism) throw InputError(static_failure(r));
  throw StaticError(static_failure(r));
}

std::vector<HoldReaction> AnyBatch::hold_reactions() const {
  if (float32()) throw InputError("hold_reactions: needs a double-precision batch (precision = \"double\")");
  return scene_hold_reactions(f64(), choice_);
}

h5::Holds AnyBatch::holds_record(const StaticResult* r) const {
  h5::Holds h;
  for (const HoldReaction& x : hold_reactions()) {
    h.rod.push_back(x.rod);
    h.node.push_back(x.node);
    h.clamped.push_back(x.clamped ? 1 : 0);
    h.force.insert(h.force.end(), x.force.begin(), x.force.end());
    h.moment.insert(h.moment.end(), x.moment.begin(), x.moment.end());
  }
  h.time = time();
  h.residual_force = r ? r->residual_force : NAN;
  h.residual_couple = r ? r->residual_couple : NAN;
  h.iterations = r ? r->iterations : 0;
  h.load_increments = r ? r->load_increments : 0;
  return h;
}

std::uint64_t AnyBatch::state_hash() const {
  return visit([](const auto& b) { return manyrods::state_hash(b); });
}

double AnyBatch::time() const {
  return visit([](const auto& b) { return b.state.time; });
}
std::int64_t AnyBatch::steps() const {
  return visit([](const auto& b) { return b.state.steps; });
}
int AnyBatch::slots() const {
  return visit([](const auto& b) { return b.slots(); });
}
int AnyBatch::rod_count() const {
  return visit([](const auto& b) { return b.rod_count(); });
}
std::int64_t AnyBatch::node_count() const {
  return visit([](const auto& b) { return b.element_count() + b.rod_count(); });
}
int AnyBatch::elements(int rod) const {
  if (rod < 0 || rod >= rod_count())
    throw InputError("rod " + std::to_string(rod) + " out of range (the batch has " + std::to_string(rod_count()) +
                     " rods)");
  return visit([&](const auto& b) { return b.elements(rod); });
}
int AnyBatch::offset(int rod) const {
  elements(rod);  // range check
  return visit([&](const auto& b) { return b.rods[rod].offset; });
}

void AnyBatch::save(const std::string& path, const h5::Holds* holds) const {
  visit([&](const auto& b) {
    using T = typename std::remove_cvref_t<decltype(b)>::value_type;
    const Scene& s = *scene_;
    std::vector<std::int32_t> group(s.rod_group.begin(), s.rod_group.end());
    std::vector<double> width;
    std::vector<std::string> names;
    for (int r = 0; r < b.rod_count(); ++r) width.push_back(s.groups[s.rod_group[r]].width);
    for (const RodGroup& g : s.groups) names.push_back(g.name);
    const h5::Layout layout = detail::frame_layout(b, std::move(group), std::move(width), std::move(names), true,
                                                   s.has_contact);
    const char* integrator = s.sim.integrator == Integrator::pefrl ? "pefrl" : "position_verlet";
    const double dt = from_file_ ? manyrods::scene::scene_dt(s, b) : 0.9 * scene_stable_dt(b, choice_).automatic();
    h5::Writer w(path, layout, {s.text, s.source, integrator, dt});
    std::vector<T> x, q;
    gather_positions(b, x);
    gather_directors(b, q);
    const Energies e = scene_energies(b, choice_);
    h5::EnergyRow row;
    static_cast<Energies&>(row) = e;
    w.append_frame(b.state.time, x.data(), q.data(), row);
    h5::Checkpoint c;
    detail::save_state(b, c);
    c.dt = dt;
    c.last_rate = e.dissipation;
    c.frames_written = 1;
    c.scene_text = s.text;
    c.scene_source = s.source;
    w.write_checkpoint(c);
    if (holds) w.write_holds(*holds);
    w.finish();
  });
}

AnyBatch static_equilibrium(const Scene& s, double at, StaticResult* result, const StaticOptions& options) {
  if (!(at >= 0) || !std::isfinite(at))
    throw SceneError(s.source + ": the static solve's time (--at) must be >= 0 and finite");
  AnyBatch b = AnyBatch::from_scene(s, Precision::float64);
  StaticOptions opt = options;
  opt.hold_time = at;
  StaticResult r;
  try {
    r = b.solve_static(opt);
    b.check_static(r);
  } catch (const InputError& e) {
    throw SceneError(s.source + ": " + e.what());
  } catch (const StaticError& e) {
    throw StaticError(s.source + ": " + e.what());
  }
  if (result) *result = r;
  return b;
}

}  // namespace manyrods::scene
