#include <shrefract/bake/jump_distance.h>
#include <shrefract/field.h>
#include <shrefract/field_decode.h>
#include <shrefract/gpu_layout.h>

#include <algorithm>
#include <cmath>
#include <limits>

#include <glm/geometric.hpp>
#include <glm/vec2.hpp>

namespace shrefract::bake {
namespace {

float cosine(glm::vec3 a, glm::vec3 b) {
  const float l = glm::length(a) * glm::length(b);
  return l > gpu::kMinDirectionLength2 ? glm::dot(a, b) / l : 1.0f;  // a zero exit agrees with all, as in the decode
}

// Node `from`'s exit moved to a view whose straight-through direction is `straight`: the corner
// estimate of the decode (field_decode.cpp interpolateCorners).
glm::vec3 movedExit(const TracedView& from, glm::vec3 straight) { return from.exit + (straight - from.straight); }

// Where between nodes a (t = 0) and b (t = 1) the exit jumps, by bisection.
float crossing(const TracedView& a, const TracedView& b, glm::vec2 at, glm::vec2 step,
               const std::function<TracedView(float, float)>& trace) {
  float lo = 0.0f, hi = 1.0f;
  for (int i = 0; i < kJumpBisections; ++i) {
    const float t = 0.5f * (lo + hi);
    const glm::vec2 p = at + t * step;
    const TracedView v = trace(p.x, p.y);
    const bool sideA = cosine(v.exit, movedExit(a, v.straight)) >= cosine(v.exit, movedExit(b, v.straight));
    (sideA ? lo : hi) = t;
  }
  return 0.5f * (lo + hi);
}

}  // namespace

std::vector<float> jumpDistances(uint32_t n, std::span<const TracedView> nodes,
                                 const std::function<TracedView(float x, float y)>& trace) {
  constexpr float kNone = std::numeric_limits<float>::infinity();
  const JumpCosines cosines = jumpCosines(n);
  const float split = 0.5f * (cosines.full + cosines.none);
  // Nearest crossing along the node's row (x) and column (y), either way.
  std::vector<float> alongX(size_t(n) * n, kNone), alongY(size_t(n) * n, kNone);
  for (uint32_t j = 0; j < n; ++j)
    for (uint32_t i = 0; i < n; ++i)
      for (int axis = 0; axis < 2; ++axis) {
        if ((axis == 0 ? i : j) + 1 >= n) continue;
        const uint32_t a = j * n + i, b = axis == 0 ? a + 1 : a + n;
        if (nodes[a].trapped || nodes[b].trapped) continue;
        if (cosine(nodes[a].exit, movedExit(nodes[b], nodes[a].straight)) >= split) continue;
        const glm::vec2 step = axis == 0 ? glm::vec2(1.0f, 0.0f) : glm::vec2(0.0f, 1.0f);
        const float t = crossing(nodes[a], nodes[b], glm::vec2(float(i), float(j)), step, trace);
        std::vector<float>& along = axis == 0 ? alongX : alongY;
        along[a] = std::min(along[a], t);
        along[b] = std::min(along[b], 1.0f - t);
      }
  std::vector<float> out(size_t(n) * n);
  for (size_t d = 0; d < out.size(); ++d) {
    const float tx = alongX[d], ty = alongY[d];
    const float both = tx < kNone && ty < kNone ? tx * ty / std::sqrt(tx * tx + ty * ty) : std::min(tx, ty);
    out[d] = std::min(both, gpu::kJumpDistanceMaxCells);
  }
  return out;
}

}  // namespace shrefract::bake
