#include <shrefract/trace/reference_render.h>
#include <shrefract/cpu_reference.h>

#include <algorithm>
#include <array>
#include <atomic>
#include <chrono>
#include <cmath>
#include <limits>
#include <optional>
#include <string>
#include <thread>

#include <glm/glm.hpp>
#include <glm/gtc/matrix_transform.hpp>

#include "reference/reference_common.h"

namespace shrefract::bake {

using namespace reference_detail;  // reference_common.h

namespace {

// The engine's thresholds (spirv/include/shrefract/gpu_layout.h, private to the engine; quoted in
// cpu_reference.h): a decoded direction shorter than this squared length is "none", and optical
// depth is clamped to the binary16 range.
constexpr float kMinDirectionLength2 = 1e-20f;
constexpr float kMaxOpticalDepth = 65504.0f;

Result<void> checkExactDistortionInput(const Field& field) {
  const uint64_t texels = field.texelCount();
  if (field.frames.size() != texels * 12 || field.texelKinds.size() != texels)
    return makeError(ErrorCode::InvalidArgument, "exact distortion: frames or texel kinds disagree with the atlas size");
  for (const GutterTexel& g : field.gutters)
    if (g.target >= texels || g.a >= texels || g.b >= texels || g.c >= texels)
      return makeError(ErrorCode::InvalidArgument, "exact distortion: a gutter rule names a texel outside the atlas");
  return {};
}

// A sample texel's frame (field.frames, 3x4 rows: the sample's tangent, bitangent and normal with
// the translation that takes world to local), as a surface point and the direction from `eye`.
struct SampleView {
  glm::vec3 axis[3];
  glm::vec3 position;
  glm::vec3 normal;
  glm::vec3 incident;
};

SampleView sampleView(const float* m, glm::vec3 eye) {
  SampleView v;
  v.axis[0] = {m[0], m[1], m[2]};
  v.axis[1] = {m[4], m[5], m[6]};
  v.axis[2] = {m[8], m[9], m[10]};
  v.position = -(v.axis[0] * m[3] + v.axis[1] * m[7] + v.axis[2] * m[11]);
  v.normal = glm::normalize(v.axis[2]);
  // The view direction the engine decodes for (reference::decodeTexel's operations).
  float w[3];
  for (int k = 0; k < 3; ++k) w[k] = m[4 * k] * eye[0] + m[4 * k + 1] * eye[1] + m[4 * k + 2] * eye[2] + m[4 * k + 3];
  w[2] = std::max(w[2], 0.0f);
  glm::vec3 local(w[0], w[1], w[2]);
  const float len2 = glm::dot(local, local);
  local = len2 > 0.0f ? local / std::sqrt(len2) : glm::vec3(0.0f, 0.0f, 1.0f);
  v.incident = -(v.axis[0] * local.x + v.axis[1] * local.y + v.axis[2] * local.z);
  return v;
}

// The scene surface a sample texel lies on: looked for from `lift` outside along its normal and
// accepted within `accept` of the recovered point. False where no hit is that close (the point
// then keeps the frame's normal and an out-of-range triangle, and the surface of the first hit).
bool findSampleSurface(const Tracer& tracer, const SampleView& v, float lift, float accept, SurfacePoint& point) {
  point.position = v.position;
  point.shadingNormal = v.normal;
  point.geometricNormal = v.normal;
  point.triangle = std::numeric_limits<uint32_t>::max();  // out of range: use the normal given
  // Straight down the normal first; a sample on an edge or corner of a flat-shaded mesh (a
  // cube's) lies in the plane of the face across it, where a ray along the edge can miss
  // both: then rays tilted a quarter toward the 8 tangent directions around the normal, one
  // of which crosses the sample's own face.
  static constexpr float kTilts[9][2] = {{0, 0}, {1, 0}, {-1, 0}, {0, 1}, {0, -1}, {1, 1}, {-1, 1}, {1, -1}, {-1, -1}};
  std::optional<SurfacePoint> found;  // the first hit within `accept`, else the first hit
  bool matched = false;
  for (int probe = 0; probe < 9 && !matched; ++probe) {
    const glm::vec3 tilt = 0.25f * (kTilts[probe][0] * v.axis[0] + kTilts[probe][1] * v.axis[1]);
    const std::optional<SurfacePoint> hit = tracer.firstHit(v.position + lift * v.normal, tilt - v.normal);
    if (!hit) continue;
    matched = glm::distance(hit->position, v.position) <= accept;
    if (matched || !found) found = hit;
  }
  if (found) point.surface = found->surface;
  if (matched) {
    point.triangle = found->triangle;
    point.geometricNormal = found->geometricNormal;
  }
  return matched;
}

// A texel of the distortion image from its traced path: the exit direction (scaled by the
// throughput if asked) and the optical depth, rounded as the engine stores them.
void storeExactTexel(const PathResult& path, bool throughput, bool depth, float* texel) {
  const glm::vec3 e = path.exitDirection;
  const float elen2 = glm::dot(e, e);
  if (elen2 > kMinDirectionLength2 && std::isfinite(elen2)) {
    const float scale = throughput ? std::clamp(path.energy, 0.0f, 1.0f) : 1.0f;
    for (int k = 0; k < 3; ++k) texel[k] = reference::roundToBinary16(e[k] / std::sqrt(elen2) * scale);
  }
  texel[3] = reference::roundToBinary16(depth ? std::clamp(path.opticalDepth, -kMaxOpticalDepth, kMaxOpticalDepth) : 0.0f);
}

// The gutter rules of reference::decompress: they read sample texels only, so order is free.
void applyGutters(const Field& field, std::vector<float>& rgba) {
  for (const GutterTexel& g : field.gutters)
    for (size_t c = 0; c < 4; ++c)
      rgba[size_t(g.target) * 4 + c] = reference::roundToBinary16(rgba[size_t(g.a) * 4 + c] + rgba[size_t(g.b) * 4 + c] -
                                                                   rgba[size_t(g.c) * 4 + c]);
}

}  // namespace

Result<ExactDistortion> exactDistortion(const Tracer& tracer, const Field& field, glm::vec3 eye,
                                        const ExactDistortionOptions& options) {
  if (auto r = checkExactDistortionInput(field); !r) return r.error();
  const uint64_t texels = field.texelCount();
  const auto start = Clock::now();
  ExactDistortion out;
  out.image.width = field.width;
  out.image.height = field.height;
  out.image.throughput = options.throughput;
  out.image.rgba.assign(size_t(texels) * 4, 0.0f);
  // The sample's surface is looked for from this far outside along its normal, and accepted within
  // 10 times that of the recovered point (the frame's float rounding is ~1e-7 of the extent).
  const float extent = std::max(tracer.sceneExtent(), 1e-30f);
  const float lift = 1e-4f * extent, accept = 1e-3f * extent;
  TraceSettings ts;
  ts.maxBounces = options.maxBounces;
  ts.pathRule = options.pathRule;
  const bool depth = field.hasOpticalDepth();

  std::atomic<uint64_t> next{0}, samples{0}, unmatched{0}, rays{0};
  constexpr uint64_t kChunk = 256;
  auto worker = [&]() {
    uint64_t localSamples = 0, localUnmatched = 0, localRays = 0;
    for (uint64_t begin; (begin = next.fetch_add(kChunk)) < texels;) {
      for (uint64_t t = begin; t < std::min(texels, begin + kChunk); ++t) {
        if (field.texelKinds[t] != kTexelSample) continue;
        ++localSamples;
        const SampleView view = sampleView(&field.frames[t * 12], eye);
        SurfacePoint point;
        if (!findSampleSurface(tracer, view, lift, accept, point)) ++localUnmatched;
        const PathResult path = tracer.traceFromSurface(point, view.incident, ts);
        localRays += path.rays + 1;
        storeExactTexel(path, options.throughput, depth, &out.image.rgba[t * 4]);
      }
    }
    samples.fetch_add(localSamples);
    unmatched.fetch_add(localUnmatched);
    rays.fetch_add(localRays);
  };
  std::vector<std::thread> pool;
  for (uint32_t t = 1; t < threadCount(options.threads); ++t) pool.emplace_back(worker);
  worker();
  for (auto& t : pool) t.join();
  applyGutters(field, out.image.rgba);
  out.samples = samples.load();
  out.unmatched = unmatched.load();
  out.rays = rays.load();
  out.seconds = std::chrono::duration<double>(Clock::now() - start).count();
  return out;
}

}  // namespace shrefract::bake
