#include <shrefract/bake/reference_render.h>
#include <shrefract/cpu_reference.h>

#include <algorithm>
#include <atomic>
#include <chrono>
#include <cmath>
#include <thread>

#include <glm/glm.hpp>
#include <glm/gtc/matrix_transform.hpp>

namespace shrefract::bake {
namespace {

glm::vec3 toVec(const std::array<float, 3>& a) { return {a[0], a[1], a[2]}; }

float fresnelDielectric(float cosI, float eta) {
  cosI = std::clamp(cosI, 0.0f, 1.0f);
  const float sin2T = eta * eta * std::max(0.0f, 1.0f - cosI * cosI);
  if (sin2T >= 1.0f) return 1.0f;
  const float cosT = std::sqrt(1.0f - sin2T);
  const float rs = (eta * cosI - cosT) / (eta * cosI + cosT);
  const float rp = (cosI - eta * cosT) / (cosI + eta * cosT);
  return 0.5f * (rs * rs + rp * rp);
}

}  // namespace

glm::vec3 pixelDirection(const Camera& camera, uint32_t width, uint32_t height, uint32_t x, uint32_t y) {
  const auto r = reference::pixelRay(camera, width, height, x, y);  // the engine's projection
  return glm::normalize(glm::vec3(r[0], r[1], r[2]));
}

Result<ReferenceImage> renderReference(const Tracer& tracer, const Scene& scene, const Image& env,
                                       const ReferenceOptions& o) {
  if (o.width == 0 || o.height == 0 || o.width > 16384 || o.height > 16384)
    return makeError(ErrorCode::InvalidArgument, "reference render: size must be 1..16384 per axis");
  if (env.width == 0 || env.rgba.size() != size_t(env.width) * env.height * 4)
    return makeError(ErrorCode::InvalidArgument, "reference render: empty environment");
  const auto start = std::chrono::steady_clock::now();
  ReferenceImage out;
  const size_t pixels = size_t(o.width) * o.height;
  out.color.width = o.width;
  out.color.height = o.height;
  out.color.rgba.assign(pixels * 4, 0.0f);
  out.directions.assign(pixels, glm::vec3(0.0f));
  out.mask.assign(pixels, 0);

  // The inverse projection of reference::pixelRay, computed once per image instead of per pixel.
  glm::mat4 proj = glm::perspectiveRH_ZO(glm::radians(o.camera.verticalFovDegrees), float(o.width) / float(o.height),
                                         o.camera.nearPlane, o.camera.farPlane);
  proj[1][1] *= -1.0f;
  glm::mat4 view = glm::lookAtRH(toVec(o.camera.eye), toVec(o.camera.target), toVec(o.camera.up));
  view[3] = glm::vec4(0.0f, 0.0f, 0.0f, 1.0f);
  const glm::mat4 dirFromClip = glm::inverse(proj * view);
  const glm::vec3 eye = toVec(o.camera.eye);
  TraceSettings ts;
  ts.maxBounces = o.mode == ReferenceMode::FullTree ? o.treeDepth : o.maxBounces;

  std::atomic<uint32_t> nextRow{0};
  std::atomic<uint64_t> rays{0};
  auto worker = [&]() {
    std::vector<PathResult> leaves;
    uint64_t localRays = 0;
    for (uint32_t y; (y = nextRow.fetch_add(1)) < o.height;) {
      for (uint32_t x = 0; x < o.width; ++x) {
        const size_t p = size_t(y) * o.width + x;
        const glm::vec2 ndc((float(x) + 0.5f) / float(o.width) * 2.0f - 1.0f,
                            (float(y) + 0.5f) / float(o.height) * 2.0f - 1.0f);
        const glm::vec3 d = glm::normalize(glm::vec3(dirFromClip * glm::vec4(ndc, 1.0f, 1.0f)));
        glm::vec3 color;
        const EyeRayResult hit = tracer.traceEyeRay(eye, d, ts);
        localRays += hit.rays;
        if (!hit.hit) {
          color = sampleLatLong(env, d);
        } else {
          out.mask[p] = 1;
          const Surface& s = scene.surfaces[hit.surface];
          const float eta = scene.media[s.outerMedium].ior / scene.media[s.innerMedium].ior;
          const glm::vec3 n = hit.shadingNormal;
          const float cosI = std::clamp(-glm::dot(d, n), 0.0f, 1.0f);
          float f = hit.frontFresnel;
          glm::vec3 transmitted(0.0f);
          if (o.mode == ReferenceMode::SingleInterface) {
            f = fresnelDielectric(cosI, eta);
            glm::vec3 t = glm::refract(d, n, eta);
            if (glm::dot(t, t) == 0.0f) t = hit.reflectedDirection;
            out.directions[p] = glm::normalize(t);
            transmitted = sampleLatLong(env, out.directions[p]);
          } else if (o.mode == ReferenceMode::Exact) {
            const PathResult& path = hit.transmitted;
            out.directions[p] = path.exitDirection;
            transmitted = sampleLatLong(env, path.exitDirection) * std::exp2(-path.opticalDepth * o.absorptionScale);
          } else {
            leaves.clear();
            SurfacePoint point;
            point.position = hit.position;
            point.shadingNormal = hit.shadingNormal;
            point.geometricNormal = hit.shadingNormal;
            point.surface = hit.surface;
            point.triangle = hit.triangle;
            tracer.traceTree(point, d, o.treeDepth, leaves);
            localRays += leaves.size();
            glm::vec3 sum(0.0f), dirSum(0.0f);
            for (const PathResult& leaf : leaves) {
              sum += leaf.energy * sampleLatLong(env, leaf.exitDirection) *
                     std::exp2(-leaf.opticalDepth * o.absorptionScale);
              dirSum += leaf.energy * leaf.exitDirection;
            }
            transmitted = sum;
            out.directions[p] = glm::dot(dirSum, dirSum) > 0.0f ? glm::normalize(dirSum) : hit.transmitted.exitDirection;
          }
          color = (1.0f - f) * transmitted;
          if (o.reflection) color += f * sampleLatLong(env, hit.reflectedDirection);
        }
        color *= o.exposure;
        for (int k = 0; k < 3; ++k) out.color.rgba[p * 4 + k] = std::isfinite(color[k]) ? color[k] : 0.0f;
        out.color.rgba[p * 4 + 3] = 1.0f;
      }
    }
    rays.fetch_add(localRays);
  };
  const uint32_t threads = o.threads ? o.threads : std::max(1u, std::thread::hardware_concurrency());
  std::vector<std::thread> pool;
  for (uint32_t t = 1; t < threads; ++t) pool.emplace_back(worker);
  worker();
  for (auto& t : pool) t.join();
  out.rays = rays.load();
  out.seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
  return out;
}

}  // namespace shrefract::bake
