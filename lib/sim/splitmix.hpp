// SplitMix64 (Steele, Lea and Flood 2014): the simulator's deterministic
// hash of seeds and indices, and the per-frame offsets into its noise tables.
// Same numbers on every machine and compiler, unlike std:: distributions.
#pragma once

#include <cstdint>

namespace harvest::sim {

inline uint64_t splitmix_hash(uint64_t x) {
  x += 0x9E3779B97F4A7C15ull;
  x = (x ^ (x >> 30)) * 0xBF58476D1CE4E5B9ull;
  x = (x ^ (x >> 27)) * 0x94D049BB133111EBull;
  return x ^ (x >> 31);
}

// The generator's next number; advances `state`.
inline uint64_t splitmix_next(uint64_t& state) {
  const uint64_t h = splitmix_hash(state);
  state += 0x9E3779B97F4A7C15ull;
  return h;
}

}  // namespace harvest::sim
