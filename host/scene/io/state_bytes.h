// host/scene/io/state_bytes.h — a batch's State as the raw bytes of an HDF5
// checkpoint (include/manyrods/h5io.h Checkpoint) and back, and the frame
// layout of a batch's output file: shared by the scene runner
// (host/scene/run/runner.cpp) and AnyBatch::save (host/scene/run/any_batch.cpp).
#pragma once

#include <cmath>
#include <cstring>
#include <string>
#include <type_traits>
#include <vector>

#include "manyrods/batch.h"
#include "manyrods/h5io.h"

namespace manyrods::scene::detail {

// A state field (one array or one per component) as raw bytes and back.
template <class T>
std::size_t field_size(const Array<T>& a) {
  return a.size() * sizeof(T);
}
template <class T, std::size_t N>
std::size_t field_size(const std::array<Array<T>, N>& a) {
  return N * a[0].size() * sizeof(T);
}
template <class T>
void to_bytes(const Array<T>& a, std::vector<unsigned char>& out) {
  const auto* p = reinterpret_cast<const unsigned char*>(a.data());
  out.assign(p, p + a.size() * sizeof(T));
}
template <class T>
void from_bytes(Array<T>& a, const std::vector<unsigned char>& in) {
  std::memcpy(a.data(), in.data(), a.size() * sizeof(T));
}
template <class T, std::size_t N>
void to_bytes(const std::array<Array<T>, N>& a, std::vector<unsigned char>& out) {
  out.clear();
  for (const Array<T>& x : a) {
    const auto* p = reinterpret_cast<const unsigned char*>(x.data());
    out.insert(out.end(), p, p + x.size() * sizeof(T));
  }
}
template <class T, std::size_t N>
void from_bytes(std::array<Array<T>, N>& a, const std::vector<unsigned char>& in) {
  std::size_t off = 0;
  for (Array<T>& x : a) {
    std::memcpy(x.data(), in.data() + off, x.size() * sizeof(T));
    off += x.size() * sizeof(T);
  }
}

// The batch's part of a checkpoint: precision, slots, time, steps, every
// State field (MANYRODS_STATE_FIELDS) and the contact work.
template <class T>
void save_state(const RodBatch<T>& b, h5::Checkpoint& c) {
  c.float32 = std::is_same_v<T, float>;
  c.slots = b.slots();
  c.time = b.state.time;
  c.steps = b.state.steps;
#define MANYRODS_SAVE(name, n, fill, float_only, doc) \
  if (field_size(b.state.name) > 0) to_bytes(b.state.name, c.name);
  MANYRODS_STATE_FIELDS(MANYRODS_SAVE)
#undef MANYRODS_SAVE
  if (b.contact.on) to_bytes(b.contact.work, c.contact_work);
  c.contact_impulses.clear();
  for (std::size_t r = 0; r < b.contact.solve_impulses.size(); ++r)
    for (const SolveImpulse<T>& e : b.contact.solve_impulses[r])
      c.contact_impulses.insert(c.contact_impulses.end(),
                                {double(r), double(e.k), double(e.collider), double(e.k2), double(e.kb),
                                 double(e.partner), double(e.s), double(e.n[0]), double(e.n[1]), double(e.n[2]), double(e.p[0]),
                                 double(e.p[1]), double(e.p[2])});
}

// A checkpoint's contact impulses (h5::Checkpoint::contact_impulses) into
// the batch's ContactData::solve_impulses; what is wrong with them (to
// follow "the checkpoint's "; then nothing is changed), or "".
template <class T>
std::string restore_contact_impulses(RodBatch<T>& b, const std::vector<double>& rows) {
  constexpr std::size_t cols = h5::Checkpoint::kContactImpulseColumns;
  if (rows.empty()) return "";
  if (!b.contact.on) return "contact_impulses belong to a scene with contact; this scene has none";
  if (rows.size() % cols != 0) return "contact_impulses are not whole rows of " + std::to_string(cols);
  std::vector<std::vector<SolveImpulse<T>>> out(std::size_t(b.rod_count()));
  const int slots = b.slots(), colliders = int(b.contact.spec.colliders.size());
  for (std::size_t i = 0; i < rows.size() / cols; ++i) {
    const double* v = rows.data() + i * cols;
    auto whole = [](double x, double lo, double hi) { return x == std::floor(x) && x >= lo && x < hi; };
    const bool ok = whole(v[0], 0, b.rod_count()) && whole(v[1], 0, slots) && whole(v[2], -1, colliders) &&
                    whole(v[3], -1, slots) && whole(v[4], -1, slots) && whole(v[5], -1, b.rod_count());
    bool finite = true;
    for (std::size_t j = 6; j < cols; ++j) finite = finite && std::isfinite(v[j]);
    finite = finite && v[6] >= 0 && v[6] <= 1;
    if (!ok || !finite)
      return "contact_impulses row " + std::to_string(i) + " is not a contact of this batch (rod " +
             std::to_string(v[0]) + ", slot " + std::to_string(v[1]) + ") or not finite, or its point is not on the element";
    SolveImpulse<T> e;
    e.k = int(v[1]), e.collider = int(v[2]), e.k2 = int(v[3]), e.kb = int(v[4]), e.partner = int(v[5]);
    e.s = T(v[6]);
    for (int d = 0; d < 3; ++d) e.n[d] = T(v[7 + d]), e.p[d] = T(v[10 + d]);
    out[std::size_t(v[0])].push_back(e);
  }
  b.contact.solve_impulses = std::move(out);
  return "";
}

// The frame layout of an output file of this batch: rod r in group
// rod_group[r] of group_names, with section width rod_width[r].
template <class T>
h5::Layout frame_layout(const RodBatch<T>& b, std::vector<std::int32_t> rod_group, std::vector<double> rod_width,
                        std::vector<std::string> group_names, bool directors, bool contact) {
  h5::Layout l;
  l.float32 = std::is_same_v<T, float>;
  l.directors = directors;
  l.contact = contact;
  l.node_offsets.push_back(0);
  l.element_offsets.push_back(0);
  for (int r = 0; r < b.rod_count(); ++r) {
    l.node_offsets.push_back(l.node_offsets.back() + b.elements(r) + 1);
    l.element_offsets.push_back(l.element_offsets.back() + b.elements(r));
  }
  // tapered rods: each node's width, its elements' mean (2 × the element's
  // contact radius, the circle's diameter), the others' rod_width
  bool tapered = false;
  for (const RodInfo& r : b.rods) tapered = tapered || !r.section_scale.empty();
  if (tapered)
    for (int r = 0; r < b.rod_count(); ++r) {
      const RodInfo& info = b.rods[std::size_t(r)];
      for (int j = 0; j <= info.elements; ++j) {
        if (info.section_scale.empty()) {
          l.node_width.push_back(rod_width[std::size_t(r)]);
          continue;
        }
        const int e0 = std::max(0, j - 1), e1 = std::min(info.elements - 1, j);
        l.node_width.push_back(info.element_radius(e0) + info.element_radius(e1));
      }
    }
  l.rod_group = std::move(rod_group);
  l.rod_width = std::move(rod_width);
  l.group_names = std::move(group_names);
  return l;
}

}  // namespace manyrods::scene::detail
