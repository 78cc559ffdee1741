// CPU renderers the SH field is measured against, on the same cameras and environments as
// `shrefract render`:
//  - Exact: per pixel, the true highest-energy path from the eye (with parallax), plus the front
//    Fresnel reflection: what the field approximates.
//  - FullTree: every Fresnel branch at every interface to a depth, weighted by energy: what the
//    highest-energy pruning costs.
//  - SingleInterface: one Snell bend at the front surface, then the environment: what engines
//    usually ship as a glass shader.
// Shading matches the engine: F * env(reflected) + (1 - F) * env(exit) * exp2(-tau * k).
#pragma once

#include <shrefract/bake/image.h>
#include <shrefract/bake/scene.h>
#include <shrefract/bake/tracer.h>
#include <shrefract/renderer.h>

#include <glm/vec3.hpp>

#include <cstdint>
#include <vector>

namespace shrefract::bake {

enum class ReferenceMode { Exact, FullTree, SingleInterface };

struct ReferenceOptions {
  ReferenceMode mode = ReferenceMode::Exact;
  uint32_t width = 640;
  uint32_t height = 480;
  Camera camera;                 // same convention as the engine (renderer.h)
  float absorptionScale = 1.0f;  // k
  bool reflection = true;        // add the front Fresnel reflection
  float exposure = 1.0f;
  uint32_t maxBounces = 16;      // Exact; FullTree uses treeDepth
  uint32_t treeDepth = 6;
  uint32_t threads = 0;          // 0: all hardware threads
};

struct ReferenceImage {
  Image color;                        // linear RGBA, alpha 1
  std::vector<glm::vec3> directions;  // per pixel: the transmitted exit direction (zero off the object)
  std::vector<uint8_t> mask;          // per pixel: 1 where the eye ray hits the object
  uint64_t rays = 0;
  double seconds = 0.0;
};

// The world-space direction of the ray through the centre of pixel (x, y), matching the engine's
// projection (Vulkan clip space, y down).
glm::vec3 pixelDirection(const Camera& camera, uint32_t width, uint32_t height, uint32_t x, uint32_t y);

Result<ReferenceImage> renderReference(const Tracer& tracer, const Scene& scene, const Image& environment,
                                       const ReferenceOptions& options);

}  // namespace shrefract::bake
