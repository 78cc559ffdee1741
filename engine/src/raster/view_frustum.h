// Camera matrices and view-frustum culling, shared by the raster pass and the decompression pass
// so that both leave out exactly the same objects.
#pragma once

#include <shrefract/renderer.h>

#include <array>

#include <glm/glm.hpp>

namespace shrefract {

// Vulkan clip space: y points down, depth in [0, 1].
glm::mat4 clipFromView(const Camera& camera, VkExtent2D extent);
glm::mat4 viewFromWorld(const Camera& camera);

// The six planes of clipFromWorld (Gribb and Hartmann): a world point p is inside the frustum
// when dot(plane, vec4(p, 1)) >= 0 for every plane. Vulkan depth range: 0 <= z <= w.
struct ViewFrustum {
  std::array<glm::vec4, 6> planes{};
};
ViewFrustum viewFrustum(const glm::mat4& clipFromWorld);

// True when the axis-aligned box lies entirely on the outer side of one of the planes: nothing
// of it can reach the viewport. Conservative (a box near a frustum corner may be kept), and a
// camera that yields non-finite planes (eye == target) culls nothing.
bool outsideFrustum(const ViewFrustum& frustum, const std::array<float, 3>& boxMin, const std::array<float, 3>& boxMax);

}  // namespace shrefract
