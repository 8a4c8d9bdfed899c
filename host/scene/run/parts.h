// host/scene/run/parts.h — a run's output in parts (include/manyrods/runner.h
// "Checkpoints in parts"; host/scene/run/output_parts.cpp): the scene
// library's own, not API.
#pragma once

#include <cstdint>
#include <string>
#include <vector>

#include "manyrods/h5io.h"

namespace manyrods::scene {

std::string parts_dir(const std::string& output);
std::string part_path(const std::string& output, int k);  // k = 1, 2, …
// The complete parts, in order (SceneError if one is missing); with
// remove_unfinished, the .tmp of a part that was being written is removed.
std::vector<std::string> list_parts(const std::string& output, bool remove_unfinished = false);
// Writes the parts' frames, in order, and `last` (the last part's
// checkpoint) and the last part's /observables into `output`, then removes the
// parts; returns the frames.
std::int64_t merge_parts(const std::vector<std::string>& parts, const std::string& output, const h5::Layout& layout,
                         const h5::RunInfo& info, const h5::Checkpoint& last);

}  // namespace manyrods::scene
