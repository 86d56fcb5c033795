#pragma once
// The renderer's random numbers: splitmix64 (Steele, Lea, Flood 2014) is tiny
// and well mixed, and its output is fixed by its definition
// (std::normal_distribution's is not), so dot patterns, noise and fixed
// patterns are the same on every platform and compiler.
#include <cstdint>

namespace collide::vision::detail {

inline std::uint64_t splitmix64(std::uint64_t& state) {
  std::uint64_t z = (state += 0x9e3779b97f4a7c15ULL);
  z = (z ^ (z >> 30)) * 0xbf58476d1ce4e5b9ULL;
  z = (z ^ (z >> 27)) * 0x94d049bb133111ebULL;
  return z ^ (z >> 31);
}

/// Uniform in [0, 1) with 53 random bits.
inline double uniform01(std::uint64_t& state) {
  return static_cast<double>(splitmix64(state) >> 11) * 0x1.0p-53;
}

}  // namespace collide::vision::detail
