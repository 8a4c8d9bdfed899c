// tests/fuzz/fuzz_targets.h — what the fuzzers feed untrusted bytes to: the
// scene parser and the HDF5 readers (restart, export, plot all read through
// h5::read_checkpoint and h5::Reader). Each returns normally for any input:
// a parsed scene or file, or the documented error (SceneError, H5Error); any
// other exception, a crash, a hang or a sanitizer report is a finding.
// Used by the libFuzzer executables (fuzz_scene.cpp, fuzz_h5.cpp; built by
// tools/run-fuzz with clang) and by the suite's corpus run
// (tests/test_fuzz_corpus.cpp).
#pragma once

#include <unistd.h>

#include <cstdint>
#include <cstdio>
#include <string>
#include <vector>

#include "manyrods/h5io.h"
#include "manyrods/scene.h"

namespace manyrods::fuzz {

inline void scene_text(const std::uint8_t* data, std::size_t size) {
  const std::string text(reinterpret_cast<const char*>(data), size);
  try {
    const scene::Scene s = scene::parse_scene(text, "fuzz.toml");
    (void)s;
  } catch (const scene::SceneError&) {
  }
}

// The bytes as an HDF5 file (a file per process), read as a restart and as
// an export or plot would read it.
inline void h5_file(const std::uint8_t* data, std::size_t size) {
  static const std::string path = "/tmp/manyrods-fuzz-" + std::to_string(getpid()) + ".h5";
  if (std::FILE* f = std::fopen(path.c_str(), "wb")) {
    if (size > 0) std::fwrite(data, 1, size, f);
    std::fclose(f);
  }
  try {
    (void)h5::read_checkpoint(path);
  } catch (const h5::H5Error&) {
  }
  try {
    const h5::Reader r(path);
    std::vector<double> x;
    for (std::int64_t k = 0; k < r.frames() && k < 4; ++k) {
      r.read_positions(k, x);
      if (r.has_directors()) r.read_directors(k, x);
    }
  } catch (const h5::H5Error&) {
  }
}

}  // namespace manyrods::fuzz
