// tests/fuzz/fuzz_scene.cpp — libFuzzer entry for the scene parser (tools/run-fuzz).
#include "fuzz_targets.h"

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  manyrods::fuzz::scene_text(data, size);
  return 0;
}
