// SplitMix64: the bake's deterministic pseudo-random sequence (held-out directions, the Pca
// subspace iteration's start block). Internal to the bake.
#pragma once

#include <cstdint>

namespace shrefract::bake {

inline uint64_t splitmix(uint64_t& state) {
  uint64_t z = (state += 0x9e3779b97f4a7c15ull);
  z = (z ^ (z >> 30)) * 0xbf58476d1ce4e5b9ull;
  z = (z ^ (z >> 27)) * 0x94d049bb133111ebull;
  return z ^ (z >> 31);
}

}  // namespace shrefract::bake
