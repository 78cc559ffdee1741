// SplitMix64: the bake's deterministic pseudo-random sequence (held-out directions, the Pca
// subspace iteration's start block) and the directions drawn from it. Internal to the bake.
#pragma once

#include <glm/vec3.hpp>

#include <algorithm>
#include <cmath>
#include <cstdint>

namespace shrefract::bake {

inline uint64_t splitmix(uint64_t& state) {
  uint64_t z = (state += 0x9e3779b97f4a7c15ull);
  z = (z ^ (z >> 30)) * 0xbf58476d1ce4e5b9ull;
  z = (z ^ (z >> 27)) * 0x94d049bb133111ebull;
  return z ^ (z >> 31);
}

// A uniform float in [0, 1) from the sequence (24 bits).
inline float unitFloat(uint64_t& state) { return static_cast<float>(splitmix(state) >> 40) * (1.0f / 16777216.0f); }

// A view direction distributed as often as it covers the screen (cosine-weighted over the
// hemisphere about +z), kept away from the exact horizon: the error measure of the bake's choices.
inline glm::vec3 cosineWeightedDirection(uint64_t& rng) {
  const float u = unitFloat(rng), phi = 6.28318530718f * unitFloat(rng);
  const float z = std::max(0.02f, std::sqrt(u)), r = std::sqrt(std::max(0.0f, 1.0f - z * z));
  return {r * std::cos(phi), r * std::sin(phi), z};
}

}  // namespace shrefract::bake
