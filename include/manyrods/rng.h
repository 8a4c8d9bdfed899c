// manyrods/rng.h — uniform random numbers that are the same on every platform
// (splitmix64; the std:: distributions are not), for scene placement and
// random sweeps.
#pragma once

#include <cstdint>

namespace manyrods {

struct Rng {
  std::uint64_t s;
  // uniform in [0, 1)
  double next() {
    std::uint64_t z = (s += 0x9E3779B97F4A7C15ull);
    z = (z ^ (z >> 30)) * 0xBF58476D1CE4E5B9ull;
    z = (z ^ (z >> 27)) * 0x94D049BB133111EBull;
    z ^= z >> 31;
    return double(z >> 11) * 0x1.0p-53;
  }
};

}  // namespace manyrods
