// tests/fuzz/fuzz_h5.cpp — libFuzzer entry for the HDF5 readers (tools/run-fuzz).
#include "fuzz_targets.h"

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  manyrods::fuzz::h5_file(data, size);
  return 0;
}
