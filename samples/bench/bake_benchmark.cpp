// Bake benchmark: the real bake against a bare Embree loop casting the same number of comparable
// rays (from the same sample points, along the same incident directions) on the same scene with
// the same threads, in the same run. Prints both rates and their ratio. Not a test: machines here
// are shared and noisy; the ratio is measured within one run.
//
// usage: shrefract_bake_benchmark [SCENE] [--samples N] [--directions RxC] [--order L] [--threads T]
//        SCENE defaults to ../shared/assets/bunny.glb; when it is missing the benchmark skips.
#include <embree3/rtcore.h>
#include <shrefract/bake/bake.h>
#include <shrefract/bake/fit.h>
#include <shrefract/assets/gltf_import.h>
#include <shrefract/bake/layout.h>
#include <shrefract/bake/sample_frame.h>

#include <atomic>
#include <chrono>
#include <cinttypes>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <filesystem>
#include <optional>
#include <string>
#include <thread>
#include <vector>

#include "cli/args.h"

using namespace shrefract;

namespace {

struct BareResult {
  uint64_t rays = 0;
  uint64_t hits = 0;
  double seconds = 0.0;
};

// The scene's surfaces as Embree triangle geometry, robust and built at high quality.
RTCScene buildRtcScene(RTCDevice device, const bake::Scene& scene) {
  RTCScene rtc = rtcNewScene(device);
  rtcSetSceneFlags(rtc, RTC_SCENE_FLAG_ROBUST);
  rtcSetSceneBuildQuality(rtc, RTC_BUILD_QUALITY_HIGH);
  for (const bake::Surface& s : scene.surfaces) {
    RTCGeometry g = rtcNewGeometry(device, RTC_GEOMETRY_TYPE_TRIANGLE);
    auto* v = static_cast<float*>(
        rtcSetNewGeometryBuffer(g, RTC_BUFFER_TYPE_VERTEX, 0, RTC_FORMAT_FLOAT3, 3 * sizeof(float), s.positions.size()));
    for (size_t i = 0; i < s.positions.size(); ++i) std::memcpy(&v[3 * i], &s.positions[i], 3 * sizeof(float));
    auto* idx = static_cast<uint32_t*>(rtcSetNewGeometryBuffer(g, RTC_BUFFER_TYPE_INDEX, 0, RTC_FORMAT_UINT3,
                                                               3 * sizeof(uint32_t), s.indices.size() / 3));
    std::memcpy(idx, s.indices.data(), s.indices.size() * sizeof(uint32_t));
    rtcCommitGeometry(g);
    rtcAttachGeometry(rtc, g);
    rtcReleaseGeometry(g);
  }
  rtcCommitScene(rtc);
  return rtc;
}

// One closest-hit query from `o` along `d`; true when it hits anything.
bool intersects(RTCScene rtc, const glm::vec3& o, const glm::vec3& d) {
  RTCIntersectContext context;
  rtcInitIntersectContext(&context);
  RTCRayHit q{};
  q.ray.org_x = o.x;
  q.ray.org_y = o.y;
  q.ray.org_z = o.z;
  q.ray.dir_x = d.x;
  q.ray.dir_y = d.y;
  q.ray.dir_z = d.z;
  q.ray.tnear = 0.0f;
  q.ray.tfar = 1e30f;
  q.ray.mask = ~0u;
  q.hit.geomID = RTC_INVALID_GEOMETRY_ID;
  rtcIntersect1(rtc, &context, &q);
  return q.hit.geomID != RTC_INVALID_GEOMETRY_ID;
}

// Casts rays [0, rays) on `threads` threads taking chunks from a shared counter; returns the hits.
uint64_t castRays(RTCScene rtc, const std::vector<bake::SurfacePoint>& samples,
                  const std::vector<bake::LocalFrame>& frames, const bake::DirectionGrid& grid, uint64_t rays,
                  uint32_t threads) {
  const uint64_t pairs = uint64_t(samples.size()) * grid.directions.size();
  std::atomic<uint64_t> next{0}, hits{0};
  auto worker = [&]() {
    uint64_t localHits = 0;
    constexpr uint64_t kChunk = 4096;
    for (;;) {
      const uint64_t begin = next.fetch_add(kChunk);
      if (begin >= rays) break;
      const uint64_t end = std::min(rays, begin + kChunk);
      for (uint64_t r = begin; r < end; ++r) {
        const uint64_t pair = r % pairs;
        const size_t s = pair / grid.directions.size();
        const glm::vec3 w(grid.directions[pair % grid.directions.size()]);
        const glm::vec3 d = -bake::localToWorld(frames[s], w);
        const glm::vec3 o = samples[s].position - samples[s].geometricNormal * 1e-5f;
        localHits += intersects(rtc, o, d);
      }
    }
    hits.fetch_add(localHits);
  };
  std::vector<std::thread> pool;
  for (uint32_t t = 1; t < threads; ++t) pool.emplace_back(worker);
  worker();
  for (auto& t : pool) t.join();
  return hits.load();
}

// One rtcIntersect1 per (sample, grid direction), cycling until `rays` queries are issued, with
// origins nudged inside along the normal as the tracer does.
BareResult bareLoop(const bake::Scene& scene, const std::vector<bake::SurfacePoint>& samples,
                    const bake::DirectionGrid& grid, uint64_t rays, uint32_t threads) {
  RTCDevice device = rtcNewDevice("ignore_config_files=1");
  RTCScene rtc = buildRtcScene(device, scene);
  std::vector<bake::LocalFrame> frames(samples.size());
  for (size_t s = 0; s < samples.size(); ++s) frames[s] = bake::frameAt(samples[s]);
  const auto start = std::chrono::steady_clock::now();
  const uint64_t hits = castRays(rtc, samples, frames, grid, rays, threads);
  BareResult out;
  out.seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
  out.rays = rays;
  out.hits = hits;
  rtcReleaseScene(rtc);
  rtcReleaseDevice(device);
  return out;
}

// Reads the flags into `path` and `settings`; returns the exit code when the command line is bad.
std::optional<int> parseArguments(int argc, char** argv, std::string& path, BakeSettings& settings) {
  using cli::ValueKind;
  const std::vector<cli::FlagSpec> flags = {
      {"samples", true, "sample budget", ValueKind::Integer, {1, cli::kUnbounded}},
      {"directions", true, "direction grid RxC", ValueKind::Size, {1, cli::kUnbounded}, {1, cli::kUnbounded}},
      {"order", true, "SH order", ValueKind::Integer, {0, cli::kUnbounded}},
      {"threads", true, "bake threads", ValueKind::Integer, {1, cli::kUnbounded}},
  };
  auto parsed = cli::Args::parseProgram("shrefract_bake_benchmark", argc, argv, flags);
  if (!parsed) {
    std::fprintf(stderr, "%s\n", parsed.error().message.c_str());
    return 2;
  }
  const cli::Args& args = parsed.value();
  if (args.has("help")) {
    std::printf("usage: shrefract_bake_benchmark [SCENE] [--samples N] [--directions RxC] [--order L] [--threads T]\n"
                "       SCENE defaults to ../shared/assets/bunny.glb; when it is missing the benchmark skips.\n");
    return 0;
  }
  if (auto samples = args.integer("samples"); samples.ok() && samples.value())
    settings.sampleBudget = static_cast<uint64_t>(*samples.value());
  args.read("order", settings.order);
  args.read("threads", settings.threads);
  args.read("directions", settings.directionsTheta, settings.directionsPhi);
  if (!args.positional().empty()) path = args.positional().back();
  return std::nullopt;
}

// A built-in scene or a glTF file into `scene`; returns the exit code when the benchmark stops
// here (0 with "SKIPPED:" for a missing file, 1 for one that does not load).
std::optional<int> loadScene(const std::string& path, std::unique_ptr<bake::Scene>& scene) {
  if (path.rfind("builtin:", 0) == 0) {
    auto s = bake::makeBuiltinScene(path.substr(8));
    if (!s) return std::fprintf(stderr, "%s\n", s.error().message.c_str()), 1;
    scene = std::make_unique<bake::Scene>(std::move(s).value());
  } else {
    if (!std::filesystem::exists(path)) {
      std::printf("SKIPPED: %s not found (the benchmark needs ../shared/assets)\n", path.c_str());
      return 0;
    }
    auto s = bake::importGltf(path);
    if (!s) return std::fprintf(stderr, "%s\n", s.error().message.c_str()), 1;
    scene = std::make_unique<bake::Scene>(std::move(s).value());
  }
  return std::nullopt;
}

// The bare loop on the bake's own sample points and directions, as many rays as the bake traced.
int compareBareLoop(const bake::Scene& scene, const BakeSettings& settings, const BakeStatistics& st) {
  bake::LayoutOptions lo;
  lo.sampleBudget = settings.sampleBudget;
  auto atlas = settings.layout == SampleLayout::Split ? bake::buildSplitLayout(scene, lo)
                                                      : bake::buildChartsLayout(scene, lo);
  if (!atlas) return std::fprintf(stderr, "%s\n", atlas.error().message.c_str()), 1;
  const bake::DirectionGrid grid = bake::makeHemisphereGrid(settings.directionsTheta, settings.directionsPhi);
  const BareResult bare = bareLoop(scene, atlas.value().samples, grid, st.rays, settings.threads);
  const double bareRate = double(bare.rays) / bare.seconds;
  std::printf("bare loop: %" PRIu64 " rtcIntersect1 rays (%.1f%% hit) in %.2f s = %.3f Mrays/s\n", bare.rays,
              100.0 * double(bare.hits) / double(bare.rays), bare.seconds, bareRate / 1e6);
  std::printf("ratio: bake trace time / bare loop time = %.3f (target <= 1.2); whole bake / bare loop = %.3f\n",
              st.traceSeconds / bare.seconds, st.bakeSeconds / bare.seconds);
  return 0;
}

}  // namespace

int main(int argc, char** argv) {
  std::string path = "../shared/assets/bunny.glb";
  BakeSettings settings;
  settings.order = 8;
  settings.sampleBudget = 35000;
  settings.layout = SampleLayout::Charts;  // the split layout's minimum on the bunny is one sample per vertex
  settings.threads = std::max(1u, std::thread::hardware_concurrency());
  if (auto exitCode = parseArguments(argc, argv, path, settings)) return *exitCode;
  std::unique_ptr<bake::Scene> scene;
  if (auto exitCode = loadScene(path, scene)) return *exitCode;
  settings.source = path;
  std::printf("bake benchmark: %s, %" PRIu64 " sample budget, %ux%u directions, order %u, %s layout, %u threads\n",
              path.c_str(), settings.sampleBudget, settings.directionsTheta, settings.directionsPhi, settings.order,
              toString(settings.layout), settings.threads);
  std::fflush(stdout);

  bake::BakeOptions options;
  options.settings = settings;
  options.heldOutDirections = 0;  // only the paths the field needs
  auto field = bake::bakeField(*scene, options);
  if (!field) return std::fprintf(stderr, "%s\n", field.error().message.c_str()), 1;
  const BakeStatistics& st = field.value().statistics;
  std::printf("bake:      %" PRIu64 " samples x %" PRIu64 " directions = %" PRIu64 " paths, %" PRIu64
              " rays in %.2f s trace (%.2f s total) = %.3f Mrays/s\n",
              st.uniqueSamples, st.directions, st.paths, st.rays, st.traceSeconds, st.bakeSeconds,
              st.raysPerSecond / 1e6);
  return compareBareLoop(*scene, settings, st);
}
