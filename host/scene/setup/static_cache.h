// host/scene/setup/static_cache.h — static initial states solved once and
// reused by later batches of a chunked sweep (host/scene/study/sweep.cpp):
// the scene library's own, not API.
#pragma once

#include <cstddef>
#include <memory>
#include <string>
#include <vector>

#include "manyrods/h5io.h"
#include "manyrods/runner.h"
#include "manyrods/scene.h"

namespace manyrods::scene {

// Static initial states already solved, to be reused by later batches (a
// chunked sweep's dt pass solves every variation's; its chunks' runs take
// them from here): each distinct rod and load (its full description, as
// two 64-bit hashes) with its node positions and frames, up to max_bytes
// of them (beyond that, states are solved again). Thread-safe.
class StaticCache {
 public:
  explicit StaticCache(std::size_t max_bytes = std::size_t(1) << 30);
  ~StaticCache();
  StaticCache(const StaticCache&) = delete;
  StaticCache& operator=(const StaticCache&) = delete;
  struct State {
    std::vector<double> x, q;  // node positions [3][n + 1], frames [9][n + 1]
  };
  bool find(const std::string& key, State& out) const;
  void put(const std::string& key, const State& s);
  std::size_t hits() const;

 private:
  struct Impl;
  std::unique_ptr<Impl> impl_;
};

// build_scene_batch, the static states taken from `cache` where it has
// them and put there (cache null: none).
template <class T>
RodBatch<T> build_scene_batch(const Scene& s, bool initial_state, StaticCache* cache);

// run_scene, its batch built with `cache`.
RunResult run_scene(const Scene& s, const RunOptions& opt, const h5::Checkpoint* restart, StaticCache* cache);

}  // namespace manyrods::scene
