// host/scene/io/state_bytes.h — a batch's State as the raw bytes of an HDF5
// checkpoint (include/manyrods/h5io.h Checkpoint) and back, and the frame
// layout of a batch's output file: shared by the scene runner
// (host/scene/run/runner.cpp) and AnyBatch::save (host/scene/run/any_batch.cpp).
#pragma once

#include <cstring>
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
  l.rod_group = std::move(rod_group);
  l.rod_width = std::move(rod_width);
  l.group_names = std::move(group_names);
  return l;
}

}  // namespace manyrods::scene::detail
