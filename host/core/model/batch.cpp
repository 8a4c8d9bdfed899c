// host/core/model/batch.cpp — rod construction, validation and the slot layout
// (include/manyrods/batch.h explains the layout).
#include "manyrods/batch.h"

#include <algorithm>
#include <Eigen/Dense>
#include <cmath>
#include <cstring>
#include <sstream>
#include <unordered_map>

#include "host/core/model/view_of.h"
#include "host/core/step/implicit_plan.h"
#include "kernels/views.h"

namespace manyrods {
namespace {

using E3 = Eigen::Vector3d;
using EM3 = Eigen::Matrix3d;

E3 to_eigen(const Vec3& v) { return {v[0], v[1], v[2]}; }
Vec3 from_eigen(const E3& v) { return {v[0], v[1], v[2]}; }
EM3 to_eigen(const Mat3& m) {
  EM3 r;
  for (int i = 0; i < 3; ++i)
    for (int j = 0; j < 3; ++j) r(i, j) = m[3 * i + j];
  return r;
}
Mat3 from_eigen(const EM3& m) {
  Mat3 r;
  for (int i = 0; i < 3; ++i)
    for (int j = 0; j < 3; ++j) r[3 * i + j] = m(i, j);
  return r;
}

[[noreturn]] void fail(const std::string& what) { throw InputError(what); }

std::string vec_str(const Vec3& v) {
  std::ostringstream os;
  os.precision(17);
  os << "[" << v[0] << ", " << v[1] << ", " << v[2] << "]";
  return os.str();
}

bool finite(const Vec3& v) { return std::isfinite(v[0]) && std::isfinite(v[1]) && std::isfinite(v[2]); }

// −log(Q_b Q_aᵀ)/D̂ in double (the rest curvature of a given geometry).
E3 discrete_curvature(const EM3& qa, const EM3& qb, double d) {
  const Eigen::AngleAxisd aa(qb * qa.transpose());
  return -aa.angle() * aa.axis() / d;
}

void validate_frame(const Mat3& q, const std::string& field) {
  for (double v : q)
    if (!std::isfinite(v)) fail(field + ": frame has a non-finite entry");
  const EM3 m = to_eigen(q);
  const double err = (m * m.transpose() - EM3::Identity()).norm();
  if (err > 1e-6) {
    std::ostringstream os;
    os << field << ": frame is not orthonormal (|Q Qᵀ - I| = " << err << ", tolerance 1e-6)";
    fail(os.str());
  }
  if (m.determinant() < 0) fail(field + ": frame is left-handed (det < 0)");
}

void validate_rod(const RodSpec& s) {
  const int n = s.elements();
  if (n < 1) fail("elements = " + std::to_string(n) + ": a rod needs at least 1 element");
  if (static_cast<int>(s.nodes.size()) != n + 1)
    fail("nodes: " + std::to_string(s.nodes.size()) + " given, " + std::to_string(n + 1) +
         " needed for " + std::to_string(n) + " elements");
  for (int j = 0; j <= n; ++j)
    if (!finite(s.nodes[j]))
      fail("nodes[" + std::to_string(j) + "] = " + vec_str(s.nodes[j]) + ": not finite");
  for (int e = 0; e < n; ++e) {
    const double l = (to_eigen(s.nodes[e + 1]) - to_eigen(s.nodes[e])).norm();
    if (!(l > 0))
      fail("nodes[" + std::to_string(e + 1) + "] = " + vec_str(s.nodes[e + 1]) + ": coincides with nodes[" +
           std::to_string(e) + "] (element " + std::to_string(e) + " has zero length)");
    validate_frame(s.frames[e], "frames[" + std::to_string(e) + "]");
  }
  if (s.root_frame) validate_frame(*s.root_frame, "root_frame");
  if (s.tip_frame) validate_frame(*s.tip_frame, "tip_frame");
  if (s.clamped_root && s.pinned_root) fail("root: clamped_root and pinned_root both set (choose one)");
  if (s.clamped_tip && s.pinned_tip) fail("tip: clamped_tip and pinned_tip both set (choose one)");
  if (s.tip_frame && !s.clamped_tip) fail("tip_frame: given for a tip that is not clamped (set clamped_tip)");
  if (s.root_motion && !s.clamped_root && !s.pinned_root)
    fail("root_motion: a driven root must be held (set clamped_root or pinned_root)");
  if (s.tip_motion && !s.clamped_tip && !s.pinned_tip)
    fail("tip_motion: a driven tip must be held (set clamped_tip or pinned_tip)");
  if (s.root_motion) s.root_motion->validate();
  if (s.tip_motion) s.tip_motion->validate();
  std::vector<char> held(std::size_t(n + 1), 0);
  held[0] = s.clamped_root || s.pinned_root;
  held[n] = s.clamped_tip || s.pinned_tip;
  for (std::size_t i = 0; i < s.holds.size(); ++i) {
    const NodeHold& h = s.holds[i];
    const std::string at = "holds[" + std::to_string(i) + "]: node " + std::to_string(h.node);
    if (h.node == 0) fail(at + " is the root (hold it with clamped_root or pinned_root)");
    if (h.node == n) fail(at + " is the tip (hold it with clamped_tip or pinned_tip)");
    if (h.node < 0 || h.node > n)
      fail(at + " does not exist (the rod has nodes 0 … " + std::to_string(n) + ")");
    if (held[h.node]) fail(at + " is held twice (one constraint per node)");
    held[h.node] = 1;
    if (h.motion) h.motion->validate();
  }
  validate_drag(s.drag);
  if (!std::isfinite(s.shear_stretch_scale) || !(s.shear_stretch_scale > 0))
    fail("shear_stretch_scale = " + std::to_string(s.shear_stretch_scale) + ": must be a finite number > 0");
  auto check_vectors = [](const std::vector<Vec3>& v, std::size_t need, const char* name) {
    if (v.empty()) return;
    if (v.size() != need)
      fail(std::string(name) + ": " + std::to_string(v.size()) + " given, " +
           std::to_string(need) + " needed");
    for (std::size_t i = 0; i < v.size(); ++i)
      if (!finite(v[i])) fail(std::string(name) + "[" + std::to_string(i) + "] = " + vec_str(v[i]) + ": not finite");
  };
  if (!s.section_scale.empty()) {
    if (s.section_scale.size() != std::size_t(n))
      fail("section_scale: " + std::to_string(s.section_scale.size()) + " given, " + std::to_string(n) +
           " needed (one per element)");
    for (std::size_t i = 0; i < s.section_scale.size(); ++i)
      if (!(std::isfinite(s.section_scale[i]) && s.section_scale[i] > 0))
        fail("section_scale[" + std::to_string(i) + "] = " + std::to_string(s.section_scale[i]) +
             ": must be a finite number > 0");
  }
  check_vectors(s.rest_curvature, n - 1, "rest_curvature");
  check_vectors(s.rest_strain, n, "rest_strain");
  check_vectors(s.velocities, n + 1, "velocities");
  check_vectors(s.angular_velocities, n, "angular_velocities");
}

}  // namespace

RodSpec RodSpec::straight(const Vec3& start, const Vec3& direction, const Vec3& normal,
                          double length, int elements) {
  if (elements < 1) fail("elements = " + std::to_string(elements) + ": a rod needs at least 1 element");
  if (!std::isfinite(length) || !(length > 0))
    fail("length = " + std::to_string(length) + ": must be a finite number > 0");
  if (!finite(start)) fail("start = " + vec_str(start) + ": not finite");
  const E3 d = to_eigen(direction);
  if (!finite(direction) || !(d.norm() > 0)) fail("direction = " + vec_str(direction) + ": must be a finite non-zero vector");
  const E3 d3 = d.normalized();
  E3 d1 = to_eigen(normal);
  if (!finite(normal)) fail("normal = " + vec_str(normal) + ": not finite");
  d1 -= d1.dot(d3) * d3;
  if (!(d1.norm() > 1e-12 * std::max(1.0, to_eigen(normal).norm())))
    fail("normal = " + vec_str(normal) + ": must not be parallel to direction");
  d1.normalize();
  const E3 d2 = d3.cross(d1);
  EM3 q;
  q.row(0) = d1;
  q.row(1) = d2;
  q.row(2) = d3;
  RodSpec s;
  s.nodes.resize(elements + 1);
  for (int j = 0; j <= elements; ++j)
    s.nodes[j] = from_eigen(E3(to_eigen(start) + (length * j / elements) * d3));
  s.frames.assign(elements, from_eigen(q));
  return s;
}

RodSpec RodSpec::polyline(std::vector<Vec3> nodes, std::vector<Mat3> frames) {
  RodSpec s;
  s.nodes = std::move(nodes);
  s.frames = std::move(frames);
  return s;
}

Vec3 RodSpec::normal_across(const Vec3& direction) {
  int a = 0;
  for (int i = 1; i < 3; ++i)
    if (std::abs(direction[i]) < std::abs(direction[a])) a = i;
  Vec3 n{0, 0, 0};
  n[a] = 1;
  return n;
}

std::vector<Mat3> RodSpec::parallel_transport_frames(const std::vector<Vec3>& nodes,
                                                     const Vec3& first_normal) {
  std::vector<Mat3> frames;
  if (nodes.size() < 2) return frames;
  for (std::size_t e = 0; e + 1 < nodes.size(); ++e)
    if (!((to_eigen(nodes[e + 1]) - to_eigen(nodes[e])).norm() > 0))
      fail("nodes " + std::to_string(e) + " and " + std::to_string(e + 1) + " coincide at " + vec_str(nodes[e]) +
           ": element " + std::to_string(e) + " has no length");
  E3 t_prev = (to_eigen(nodes[1]) - to_eigen(nodes[0])).normalized();
  if (!finite(first_normal)) fail("first_normal = " + vec_str(first_normal) + ": not finite");
  const bool chosen = to_eigen(first_normal).norm() == 0;
  E3 d1 = to_eigen(chosen ? normal_across(from_eigen(t_prev)) : first_normal);
  if (!((d1 - d1.dot(t_prev) * t_prev).norm() > 1e-9 * d1.norm()))
    fail("first_normal = " + vec_str(first_normal) + " is parallel to the first element (along " +
         vec_str(from_eigen(t_prev)) + "): give a normal across the rod, or (0, 0, 0) to have one chosen");
  for (std::size_t e = 0; e + 1 < nodes.size(); ++e) {
    const E3 t = (to_eigen(nodes[e + 1]) - to_eigen(nodes[e])).normalized();
    // rotate d1 by the minimal rotation taking t_prev to t
    const E3 axis = t_prev.cross(t);
    const double s = axis.norm(), c = t_prev.dot(t);
    if (s > 1e-15) d1 = Eigen::AngleAxisd(std::atan2(s, c), axis / s) * d1;
    d1 -= d1.dot(t) * t;
    d1.normalize();
    EM3 q;
    q.row(0) = d1;
    q.row(1) = t.cross(d1);
    q.row(2) = t;
    frames.push_back(from_eigen(q));
    t_prev = t;
  }
  return frames;
}

namespace {

// The field list (include/manyrods/fields.h) applied to the storage.
template <class T, class Fill>
void allocate_field(Array<T>& a, std::size_t slots, Fill fill) {
  a.resize(slots, T(fill(0)));
}
template <class T, std::size_t N, class Fill>
void allocate_field(std::array<Array<T>, N>& a, std::size_t slots, Fill fill) {
  Array<T>::resize_components(a, slots, [&](int i) { return T(fill(i)); });
}
template <class T>
std::size_t field_bytes(const Array<T>& a) {
  return a.size() ? a.bytes() : 0;
}
template <class T, std::size_t N>
std::size_t field_bytes(const std::array<Array<T>, N>& a) {
  std::size_t b = 0;
  for (const auto& x : a) b += field_bytes(x);
  return b;
}

}  // namespace

template <class T>
void RodBatch<T>::allocate(int slots, std::int64_t elements) {
  slots_ = slots;
  element_count_ = elements;
  const std::size_t S = static_cast<std::size_t>(slots);
#define MANYRODS_ALLOCATE(group, name, n, fill, float_only, doc) \
  if (!(float_only) || sizeof(T) == 4) allocate_field(group.name, S, [](int i) { return (void)i, (fill); });
#define MANYRODS_ALLOCATE_MODEL(...) MANYRODS_ALLOCATE(model, __VA_ARGS__)
#define MANYRODS_ALLOCATE_STATE(...) MANYRODS_ALLOCATE(state, __VA_ARGS__)
#define MANYRODS_ALLOCATE_SCRATCH(...) MANYRODS_ALLOCATE(scratch, __VA_ARGS__)
#define MANYRODS_ALLOCATE_LOADS(...) MANYRODS_ALLOCATE(loads, __VA_ARGS__)
  MANYRODS_MODEL_FIELDS(MANYRODS_ALLOCATE_MODEL)
  MANYRODS_STATE_FIELDS(MANYRODS_ALLOCATE_STATE)
  MANYRODS_SCRATCH_FIELDS(MANYRODS_ALLOCATE_SCRATCH)
  MANYRODS_LOADS_FIELDS(MANYRODS_ALLOCATE_LOADS)
#undef MANYRODS_ALLOCATE_MODEL
#undef MANYRODS_ALLOCATE_STATE
#undef MANYRODS_ALLOCATE_SCRATCH
#undef MANYRODS_ALLOCATE_LOADS
#undef MANYRODS_ALLOCATE
  workspace->flags.resize(S, 0);
}

template <class T>
Vec3 RodBatch<T>::position(int r, int j) const {
  const int k = node_index(r, j);
  return {double(state.node_x[0][k]), double(state.node_x[1][k]), double(state.node_x[2][k])};
}
template <class T>
Vec3 RodBatch<T>::velocity(int r, int j) const {
  const int k = node_index(r, j);
  return {double(state.node_v[0][k]), double(state.node_v[1][k]), double(state.node_v[2][k])};
}
template <class T>
Mat3 RodBatch<T>::frame(int r, int e) const {
  const int k = elem_index(r, e);
  Mat3 q;
  for (int i = 0; i < 9; ++i) q[i] = double(state.elem_Q[i][k]);
  return q;
}
template <class T>
Vec3 RodBatch<T>::angular_velocity(int r, int e) const {
  const int k = elem_index(r, e);
  return {double(state.elem_w[0][k]), double(state.elem_w[1][k]), double(state.elem_w[2][k])};
}
// "rod r ('name'): field[i] = [..]: why", as build_batch words its errors.
template <class T>
static void check_value(const RodBatch<T>& b, int r, int i, int count, const char* field, const Vec3& v) {
  if (r < 0 || r >= b.rod_count())
    fail(std::string(field) + ": rod " + std::to_string(r) + " out of range (batch has " +
         std::to_string(b.rod_count()) + " rods)");
  const std::string at = "rod " + std::to_string(r) + " ('" + b.rods[r].name + "'): " + field + "[" +
                         std::to_string(i) + "]";
  if (i < 0 || i >= count) fail(at + ": index out of range [0, " + std::to_string(count) + ")");
  if (!finite(v)) fail(at + " = " + vec_str(v) + ": not finite");
}
template <class T>
void RodBatch<T>::set_velocity(int r, int j, const Vec3& v) {
  check_value(*this, r, j, r >= 0 && r < rod_count() ? elements(r) + 1 : 0, "velocity", v);
  const int k = node_index(r, j);
  if (model.node_inv_mass[k] == T(0)) return;  // clamped node stays at rest
  for (int d = 0; d < 3; ++d) state.node_v[d][k] = T(v[d]);
}
template <class T>
void RodBatch<T>::set_angular_velocity(int r, int e, const Vec3& w) {
  check_value(*this, r, e, r >= 0 && r < rod_count() ? elements(r) : 0, "angular_velocity", w);
  const int k = elem_index(r, e);
  for (int d = 0; d < 3; ++d) state.elem_w[d][k] = T(w[d]);
}
template <class T>
void RodBatch<T>::set_node_force(int r, int j, const Vec3& f) {
  check_value(*this, r, j, r >= 0 && r < rod_count() ? elements(r) + 1 : 0, "node_force", f);
  const int k = node_index(r, j);
  for (int d = 0; d < 3; ++d) loads.node_force[d][k] = T(f[d]);
}
template <class T>
void RodBatch<T>::set_element_couple(int r, int e, const Vec3& c) {
  check_value(*this, r, e, r >= 0 && r < rod_count() ? elements(r) : 0, "element_couple", c);
  const int k = elem_index(r, e);
  for (int d = 0; d < 3; ++d) loads.elem_couple[d][k] = T(c[d]);
}
template <class T>
void RodBatch<T>::set_gravity(const Vec3& g) {
  if (!finite(g)) fail("gravity = " + vec_str(g) + ": not finite");
  model.gravity = {T(g[0]), T(g[1]), T(g[2])};
}

template <class T>
std::size_t RodBatch<T>::bytes() const {
  std::size_t b = 0;
#define MANYRODS_BYTES(group, name, n, fill, float_only, doc) b += field_bytes(group.name);
#define MANYRODS_BYTES_MODEL(...) MANYRODS_BYTES(model, __VA_ARGS__)
#define MANYRODS_BYTES_STATE(...) MANYRODS_BYTES(state, __VA_ARGS__)
#define MANYRODS_BYTES_SCRATCH(...) MANYRODS_BYTES(scratch, __VA_ARGS__)
#define MANYRODS_BYTES_LOADS(...) MANYRODS_BYTES(loads, __VA_ARGS__)
  MANYRODS_MODEL_FIELDS(MANYRODS_BYTES_MODEL)
  MANYRODS_STATE_FIELDS(MANYRODS_BYTES_STATE)
  MANYRODS_SCRATCH_FIELDS(MANYRODS_BYTES_SCRATCH)
  MANYRODS_LOADS_FIELDS(MANYRODS_BYTES_LOADS)
#undef MANYRODS_BYTES_MODEL
#undef MANYRODS_BYTES_STATE
#undef MANYRODS_BYTES_SCRATCH
#undef MANYRODS_BYTES_LOADS
#undef MANYRODS_BYTES
  b += field_bytes(workspace->visc_G) + field_bytes(workspace->visc_g) + field_bytes(workspace->visc_L) +
       field_bytes(workspace->visc_wide);
  return b;
}

#define MANYRODS_VIEW_OF(group, name, n, fill, float_only, doc) view_of(v.name, group.name);
template <class T>
ModelView<T> RodBatch<T>::model_view() const {
  ModelView<T> v{};
#define MANYRODS_VIEW_OF_MODEL(...) MANYRODS_VIEW_OF(model, __VA_ARGS__)
  MANYRODS_MODEL_FIELDS(MANYRODS_VIEW_OF_MODEL)
#undef MANYRODS_VIEW_OF_MODEL
  v.gravity = {model.gravity[0], model.gravity[1], model.gravity[2]};
  return v;
}
template <class T>
StateView<T> RodBatch<T>::state_view() {
  StateView<T> v{};
#define MANYRODS_VIEW_OF_STATE(...) MANYRODS_VIEW_OF(state, __VA_ARGS__)
  MANYRODS_STATE_FIELDS(MANYRODS_VIEW_OF_STATE)
  return v;
}
template <class T>
ConstStateView<T> RodBatch<T>::state_view() const {
  ConstStateView<T> v{};
  MANYRODS_STATE_FIELDS(MANYRODS_VIEW_OF_STATE)
#undef MANYRODS_VIEW_OF_STATE
  return v;
}
template <class T>
ScratchView<T> RodBatch<T>::scratch_view() {
  ScratchView<T> v{};
#define MANYRODS_VIEW_OF_SCRATCH(...) MANYRODS_VIEW_OF(scratch, __VA_ARGS__)
  MANYRODS_SCRATCH_FIELDS(MANYRODS_VIEW_OF_SCRATCH)
  return v;
}
template <class T>
ConstScratchView<T> RodBatch<T>::scratch_view() const {
  ConstScratchView<T> v{};
  MANYRODS_SCRATCH_FIELDS(MANYRODS_VIEW_OF_SCRATCH)
#undef MANYRODS_VIEW_OF_SCRATCH
  return v;
}
template <class T>
LoadsView<T> RodBatch<T>::loads_view() const {
  LoadsView<T> v{};
#define MANYRODS_VIEW_OF_LOADS(...) MANYRODS_VIEW_OF(loads, __VA_ARGS__)
  MANYRODS_LOADS_FIELDS(MANYRODS_VIEW_OF_LOADS)
#undef MANYRODS_VIEW_OF_LOADS
  return v;
}
#undef MANYRODS_VIEW_OF

template <class T>
void RodBatch<T>::reserve_implicit_scratch(int threads, int min_cells) {
  int cells = min_cells;
  for (const Segment& r : segments) cells = std::max(cells, r.end - r.begin);
  threads = std::max(threads, 1);
  StepWorkspace<T>& w = *workspace;
  const std::size_t partition = std::max(w.solve_plan[0].partition_values, w.solve_plan[1].partition_values);
  if (w.visc_partition.size() < partition) w.visc_partition.resize(partition, T(0));
  if (cells <= w.visc_cells && threads <= w.visc_threads) return;
  w.visc_cells = std::max(cells, w.visc_cells);
  w.visc_threads = std::max(threads, w.visc_threads);
  const std::size_t n = std::size_t(w.visc_cells) * std::size_t(w.visc_threads);
  for (auto& a : w.visc_G) a.resize(n, T(0));
  for (auto& a : w.visc_g) a.resize(n, T(0));
  for (auto& a : w.visc_L) a.resize(n, T(0));
  if (sizeof(T) < sizeof(double) && any_stiff_)
    for (auto& a : w.visc_wide) a.resize(n, 0.0);
}

template <class T>
ImplicitScratchView<T> RodBatch<T>::implicit_scratch_view(int thread, int cell_offset) {
  StepWorkspace<T>& w = *workspace;
  const std::size_t at = std::size_t(thread) * std::size_t(w.visc_cells) + std::size_t(cell_offset);
  ImplicitScratchView<T> v{};
  for (int i = 0; i < 36; ++i) v.G[i] = w.visc_G[i].data() + at;
  for (int i = 0; i < 6; ++i) v.g[i] = w.visc_g[i].data() + at;
  for (int i = 0; i < 21; ++i) v.L[i] = w.visc_L[i].data() + at;
  return v;
}

template <class T>
ImplicitScratchView<double> RodBatch<T>::wide_implicit_scratch_view(int thread) {
  StepWorkspace<T>& w = *workspace;
  const std::size_t at = std::size_t(thread) * std::size_t(w.visc_cells);
  ImplicitScratchView<double> v{};
  for (int i = 0; i < 36; ++i) v.G[i] = w.visc_wide[i].data() + at;
  for (int i = 0; i < 6; ++i) v.g[i] = w.visc_wide[36 + i].data() + at;
  for (int i = 0; i < 21; ++i) v.L[i] = w.visc_wide[42 + i].data() + at;
  return v;
}

template <class T>
std::int64_t RodBatch<T>::partitioned_elements() const {
  const SolvePlan& plan = workspace->solve_plan[1];
  std::int64_t n = 0;
  for (const SolveGroup& g : plan.groups)
    if (g.parts > 0) n += rods[std::size_t(plan.rods[std::size_t(g.first)])].elements;
  return n;
}

template <class T>
WorkspaceHandle<T>::WorkspaceHandle() : p_(std::make_unique<StepWorkspace<T>>()) {}
template <class T>
WorkspaceHandle<T>::~WorkspaceHandle() = default;
template <class T>
WorkspaceHandle<T>::WorkspaceHandle(const WorkspaceHandle& o) : p_(std::make_unique<StepWorkspace<T>>(*o.p_)) {}
template <class T>
WorkspaceHandle<T>::WorkspaceHandle(WorkspaceHandle&& o) noexcept : p_(std::move(o.p_)) {}
template <class T>
WorkspaceHandle<T>& WorkspaceHandle<T>::operator=(const WorkspaceHandle& o) {
  if (this != &o) *p_ = *o.p_;
  return *this;
}
template <class T>
WorkspaceHandle<T>& WorkspaceHandle<T>::operator=(WorkspaceHandle&& o) noexcept {
  p_ = std::move(o.p_);
  return *this;
}

namespace {

// A rod's description checked and resolved (material, section, damping);
// errors name the rod.
RodInfo resolve_rod(const RodSpec& s, int r) {
  RodInfo info;
  info.name = s.name;
  info.elements = s.elements();
  info.clamped_root = s.clamped_root;
  info.clamped_tip = s.clamped_tip;
  info.stiff_implicit = s.stiff_implicit;
  info.preload = s.preload;
  info.section_scale = s.section_scale;
  info.drag = s.drag;
  int held = int(s.holds.size()) + (s.clamped_root || s.pinned_root) + (s.clamped_tip || s.pinned_tip);
  int driven = (s.root_motion != nullptr) + (s.tip_motion != nullptr);
  for (const NodeHold& h : s.holds) driven += h.motion != nullptr;
  info.driven = driven > 0;
  // the implicit solve runs relative to the reference hold's rigid motion (a
  // driven root; else a stiff rod's only hold, driven, at its tip): every
  // other held unknown keeps its prescribed velocity, moved to the right-hand
  // side of the solve (kernels/viscous_implicit_lanes.h kLift)
  info.driven_reference =
      s.root_motion != nullptr || (s.stiff_implicit && driven == 1 && held == 1 && s.holds.empty());
  info.prescribed = driven > 0 && held > (info.driven_reference ? 1 : 0);
  try {
    validate_rod(s);
    info.elastic = resolve_material(s.material);
    info.section = section_properties(s.section, info.elastic.nu);
    info.contact_radius = contact_radius(s.section);
    info.tau = resolve_damping(s.damping, info.elastic);
    info.damped = info.tau.shear > 0 || info.tau.extension > 0;
  } catch (const InputError& e) {
    throw InputError("rod " + std::to_string(r) + " ('" + s.name + "'): " + e.what());
  }
  return info;
}

// Segments (batch.h): rods are packed into 64-aligned runs of at most
// kSegmentSlots slots, with at least one spare slot at the end of each (the
// tip ghost element reads the node after it), so that no kernel of one
// segment touches a slot another segment writes. Stiff and other rods never
// share a segment (their kicks differ, kernels/integrate.h). Fills rods and
// segments; returns the slot count.
std::int64_t lay_out(const std::vector<RodSpec>& specs, std::vector<RodInfo>& rods, std::vector<Segment>& segments) {
  std::int64_t slots = 0;
  auto round_up = [](std::int64_t x) { return (x + kGuard - 1) / kGuard * kGuard; };
  Segment seg;
  auto close_segment = [&](int next_rod) {
    if (next_rod > seg.rod_begin) {
      seg.rod_end = next_rod;
      seg.end = static_cast<int>(round_up(slots + 1));
      segments.push_back(seg);
      slots = seg.end;
    }
    seg = Segment{static_cast<int>(slots), 0, next_rod, 0, true};
  };
  for (std::size_t r = 0; r < specs.size(); ++r) {
    const RodSpec& s = specs[r];
    RodInfo info = resolve_rod(s, int(r));
    const std::int64_t size = std::int64_t(std::max(info.elements, 0)) + 2;
    const bool big = size + 1 > kSegmentSlots;
    const bool other_kind = int(r) > seg.rod_begin && seg.stiff != s.stiff_implicit;
    if (big || other_kind || slots + size + 1 - seg.begin > kSegmentSlots) close_segment(int(r));
    if (big) seg.fused = false;
    seg.stiff = s.stiff_implicit;
    info.offset = static_cast<int>(slots);
    slots += info.elements + 2;
    if (slots > (std::int64_t(1) << 31) - 4 * kSegmentSlots)
      fail("batch: " + std::to_string(slots) + " slots exceed the 32-bit index range");
    rods.push_back(std::move(info));
    if (big) close_segment(int(r) + 1);
  }
  close_segment(int(specs.size()));
  return segments.empty() ? kGuard : slots;
}

// Driven holds: one entry per held node on a motion (per rod: root,
// interior nodes in order, tip), one motion per distinct pointer; each
// segment's range of them.
template <class T>
void collect_driven(RodBatch<T>& b, const std::vector<RodSpec>& specs) {
  std::unordered_map<const RootMotion*, int> motion_index;
  auto motion = [&](const std::shared_ptr<const RootMotion>& m) {
    const auto [it, added] = motion_index.try_emplace(m.get(), int(b.motions.size()));
    if (added) b.motions.push_back(m);
    return it->second;
  };
  for (std::size_t r = 0; r < specs.size(); ++r) {
    const RodSpec& s = specs[r];
    const RodInfo& info = b.rods[r];
    const int n = s.elements(), o = info.offset;
    const std::size_t first = b.driven.size();
    if (s.root_motion) {
      DrivenHold d{int(r), motion(s.root_motion), o + 1, {o, -1}, s.nodes[0]};
      d.q0[0] = s.root_frame ? *s.root_frame : s.frames[0];
      b.driven.push_back(d);
    }
    std::vector<NodeHold> holds = s.holds;
    std::sort(holds.begin(), holds.end(), [](const NodeHold& x, const NodeHold& y) { return x.node < y.node; });
    for (const NodeHold& h : holds) {
      if (!h.motion) continue;
      DrivenHold d{int(r), motion(h.motion), o + 1 + h.node, {-1, -1}, s.nodes[h.node]};
      if (h.kind == HoldKind::clamped) {
        d.frame[0] = o + h.node;  // elements node − 1 and node
        d.frame[1] = o + 1 + h.node;
        d.q0[0] = s.frames[h.node - 1];
        d.q0[1] = s.frames[h.node];
      }
      b.driven.push_back(d);
    }
    if (s.tip_motion) {
      DrivenHold d{int(r), motion(s.tip_motion), o + 1 + n, {o + n + 1, -1}, s.nodes[n]};
      d.q0[0] = s.tip_frame ? *s.tip_frame : s.frames[n - 1];
      b.driven.push_back(d);
    }
    // the reference of the implicit solve (RodInfo::driven_reference): the
    // rod's first driven hold, its root or its only one
    if (b.driven.size() > first && info.driven_reference) b.driven[first].reference = true;
  }
  for (Segment& seg : b.segments) {
    auto by_rod = [](const DrivenHold& d, int rod) { return d.rod < rod; };
    seg.driven_begin = int(std::lower_bound(b.driven.begin(), b.driven.end(), seg.rod_begin, by_rod) - b.driven.begin());
    seg.driven_end = int(std::lower_bound(b.driven.begin(), b.driven.end(), seg.rod_end, by_rod) - b.driven.begin());
  }
  b.workspace->driven_root_velocity.assign(kHoldSaved * b.driven.size(), T(0));
}

// One rod's given geometry: element lengths and frames.
struct RodGeometry {
  std::vector<double> length;
  std::vector<EM3> frame;
  explicit RodGeometry(const RodSpec& s) : length(std::size_t(s.elements())), frame(std::size_t(s.elements())) {
    for (int e = 0; e < s.elements(); ++e) {
      length[e] = (to_eigen(s.nodes[e + 1]) - to_eigen(s.nodes[e])).norm();
      frame[e] = to_eigen(s.frames[e]);
    }
  }
};

// Nodes: lumped masses (a held node has no inverse mass), positions and
// velocities, and the still root ghost node.
template <class T>
void fill_nodes(RodBatch<T>& b, const RodSpec& s, const RodInfo& info, const RodGeometry& g) {
  const int n = info.elements, o = info.offset;
  const double rho = info.elastic.density, area = info.section.area;
  for (int j = 0; j <= n; ++j) {
    const int k = o + 1 + j;
    double mass = 0;  // (a tapered element's area: × f²)
    if (j > 0) mass += 0.5 * rho * area * info.scale(j - 1) * info.scale(j - 1) * g.length[j - 1];
    if (j < n) mass += 0.5 * rho * area * info.scale(j) * info.scale(j) * g.length[j];
    b.model.node_mass[k] = T(mass);
    bool held = (j == 0 && (s.clamped_root || s.pinned_root)) || (j == n && (s.clamped_tip || s.pinned_tip));
    for (const NodeHold& h : s.holds) held = held || h.node == j;
    b.model.node_inv_mass[k] = held ? T(0) : T(1 / mass);
    for (int d = 0; d < 3; ++d) {
      b.state.node_x[d][k] = T(s.nodes[j][d]);
      b.state.node_v[d][k] = (s.velocities.empty() || held) ? T(0) : T(s.velocities[j][d]);
    }
  }
  for (int d = 0; d < 3; ++d) b.state.node_x[d][o] = T(s.nodes[0][d]);  // root ghost node: finite, still
}

// Elements: rest length and strain, C_F, retardation times, inertia, frames
// and angular velocities; the root ghost holds the clamp frame, the tip
// ghost the tip's clamp frame (a copy of the last frame unless given).
template <class T>
void fill_elements(RodBatch<T>& b, const RodSpec& s, const RodInfo& info, const RodGeometry& g) {
  const int n = info.elements, o = info.offset;
  const ElasticConstants& c = info.elastic;
  const SectionProperties& p = info.section;
  const double f = s.shear_stretch_scale;
  const Vec3 cf = {f * p.shear_factor1 * c.G * p.area, f * p.shear_factor2 * c.G * p.area, f * c.E * p.area};
  const Vec3 J = {p.I1, p.I2, p.I3}, tau = {info.tau.shear, info.tau.shear, info.tau.extension};
  for (int e = 0; e < n; ++e) {
    const int k = o + 1 + e;
    const double len = g.length[e];
    const double f2 = info.scale(e) * info.scale(e), f4 = f2 * f2;  // tapered: area × f², I × f⁴
    b.model.elem_rest_length[k] = T(len);
    const E3 v0 = s.rest_strain.empty() ? E3(g.frame[e] * (to_eigen(s.nodes[e + 1]) - to_eigen(s.nodes[e])) / len)
                                        : to_eigen(s.rest_strain[e]);
    for (int d = 0; d < 3; ++d) {
      b.model.elem_stiffness[d][k] = T(cf[d] * f2);
      b.model.elem_rest_strain[d][k] = T(v0[d]);
      b.model.elem_tau[d][k] = T(tau[d]);
      b.model.elem_inertia[d][k] = T(c.density * len * J[d] * f4);
      b.model.elem_inv_inertia[d][k] = T(1 / (c.density * len * J[d] * f4));
      b.state.elem_w[d][k] = s.angular_velocities.empty() ? T(0) : T(s.angular_velocities[e][d]);
    }
    for (int i = 0; i < 9; ++i) b.state.elem_Q[i][k] = T(s.frames[e][i]);
  }
  // a clamped interior node holds the frames of the elements on either side
  for (const NodeHold& h : s.holds)
    if (h.kind == HoldKind::clamped)
      for (const int k : {o + h.node, o + 1 + h.node})
        for (int d = 0; d < 3; ++d) {
          b.model.elem_inv_inertia[d][k] = T(0);
          b.state.elem_w[d][k] = T(0);
        }
  const Mat3 root = s.root_frame ? *s.root_frame : s.frames[0];
  const Mat3 tip = s.tip_frame ? *s.tip_frame : s.frames[n - 1];
  for (int i = 0; i < 9; ++i) {
    b.state.elem_Q[i][o] = T(root[i]);
    b.state.elem_Q[i][o + n + 1] = T(tip[i]);
  }
}

// Voronoi points: interior j joins elements j and j+1 (slot o+2+j); the root
// one ties element 0 to the clamp frame of a clamped rod (zero stiffness for
// a free root), the tip one element n−1 to the clamp frame of a clamped tip;
// rest curvature from the given frames unless given.
template <class T>
void fill_joints(RodBatch<T>& b, const RodSpec& s, const RodInfo& info, const RodGeometry& g) {
  const int n = info.elements, o = info.offset;
  const ElasticConstants& c = info.elastic;
  const Vec3 cm = {c.E * info.section.I1, c.E * info.section.I2, c.G * info.section.torsion_constant};
  const Vec3 tau = {info.tau.extension, info.tau.extension, info.tau.shear};
  // a tapered rod's joint: the length-weighted mean of its elements' C_M
  // (the bending energy ∫ EI κ² over the joint's half elements), i.e. × f⁴
  auto f4 = [&](int e) { return std::pow(info.scale(e), 4); };
  auto set_vor = [&](int k, double d_hat, const E3& u0, double scale) {
    b.model.vor_rest_length[k] = T(d_hat);
    for (int d = 0; d < 3; ++d) {
      b.model.vor_stiffness[d][k] = T(cm[d] * scale);
      b.model.vor_rest_curvature[d][k] = T(u0[d]);
      b.model.vor_tau[d][k] = T(tau[d]);
    }
  };
  for (int j = 0; j + 1 < n; ++j) {
    const double d_hat = 0.5 * (g.length[j] + g.length[j + 1]);
    const E3 u0 = s.rest_curvature.empty() ? discrete_curvature(g.frame[j], g.frame[j + 1], d_hat)
                                           : to_eigen(s.rest_curvature[j]);
    set_vor(o + 2 + j, d_hat, u0, (g.length[j] * f4(j) + g.length[j + 1] * f4(j + 1)) / (2 * d_hat));
  }
  if (s.clamped_root) {
    const double d_hat = 0.5 * g.length[0];
    const Mat3 root = s.root_frame ? *s.root_frame : s.frames[0];
    set_vor(o + 1, d_hat, discrete_curvature(to_eigen(root), g.frame[0], d_hat), f4(0));
  } else {
    b.model.vor_rest_length[o + 1] = T(0.5 * g.length[0]);
  }
  if (s.clamped_tip) {
    const double d_hat = 0.5 * g.length[n - 1];
    const Mat3 tip = s.tip_frame ? *s.tip_frame : s.frames[n - 1];
    set_vor(o + n + 1, d_hat, discrete_curvature(g.frame[n - 1], to_eigen(tip), d_hat), f4(n - 1));
  } else {
    b.model.vor_rest_length[o + n + 1] = T(0.5 * g.length[n - 1]);
  }
}

}  // namespace

template <class T>
RodBatch<T> build_batch(const std::vector<RodSpec>& specs, const Vec3& gravity) {
  RodBatch<T> b;
  b.set_gravity(gravity);
  const std::int64_t slots = lay_out(specs, b.rods, b.segments);
  std::int64_t elements = 0;
  for (const RodInfo& r : b.rods) {
    elements += r.elements;
    b.any_stiff_ = b.any_stiff_ || r.stiff_implicit;
  }
  collect_driven(b, specs);
  b.allocate(static_cast<int>(slots), elements);
  // the implicit-solve plan, for the buffer reserve_implicit_scratch gives
  // (a segment's worth of cells per thread)
  int buffer_cells = 0;
  for (const Segment& seg : b.segments) buffer_cells = std::max(buffer_cells, seg.end - seg.begin);
  build_solve_plans(b.workspace->solve_plan, b.segments, b.rods, kImplicitLanes<T>, buffer_cells);
  for (std::size_t r = 0; r < specs.size(); ++r) {
    const RodGeometry g(specs[r]);
    fill_nodes(b, specs[r], b.rods[r], g);
    fill_elements(b, specs[r], b.rods[r], g);
    fill_joints(b, specs[r], b.rods[r], g);
  }
  return b;
}

template <class T>
std::uint64_t state_hash(const RodBatch<T>& b) {
  std::uint64_t h = 14695981039346656037ull;  // FNV-1a 64-bit offset basis
  auto mix = [&](T v) {
    unsigned char bytes[sizeof(T)];
    std::memcpy(bytes, &v, sizeof(T));
    for (unsigned char c : bytes) h = (h ^ c) * 1099511628211ull;  // FNV prime
  };
  for (int r = 0; r < b.rod_count(); ++r) {
    for (int j = 0; j <= b.elements(r); ++j) {
      const int k = b.node_index(r, j);
      for (int d = 0; d < 3; ++d) {
        mix(b.state.node_x[d][k]);
        mix(b.state.node_v[d][k]);
      }
      if constexpr (sizeof(T) == 4)  // float: the positions' carried round-off too
        for (int d = 0; d < 3; ++d) mix(b.state.node_xc[d][k]);
    }
    for (int e = 0; e < b.elements(r); ++e) {
      const int k = b.elem_index(r, e);
      for (int i = 0; i < 9; ++i) mix(b.state.elem_Q[i][k]);
      for (int d = 0; d < 3; ++d) mix(b.state.elem_w[d][k]);
    }
  }
  return h;
}

template class WorkspaceHandle<float>;
template class WorkspaceHandle<double>;
template class RodBatch<float>;
template class RodBatch<double>;
template RodBatch<float> build_batch<float>(const std::vector<RodSpec>&, const Vec3&);
template RodBatch<double> build_batch<double>(const std::vector<RodSpec>&, const Vec3&);
template std::uint64_t state_hash<float>(const RodBatch<float>&);
template std::uint64_t state_hash<double>(const RodBatch<double>&);

}  // namespace manyrods
