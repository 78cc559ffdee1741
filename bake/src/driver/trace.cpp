// Tracing: every grid direction of a shard's samples traced (threads), fitted by SampleEncoder,
// and the held-out and grid checks recorded; the parts gathered in sample order.
#include "driver/bake_driver.h"

#include "splitmix.h"

#include <algorithm>
#include <atomic>
#include <cmath>
#include <cstdint>
#include <mutex>
#include <thread>

namespace shrefract::bake::detail {

namespace {

// The jump distance channel of one sample (jump_distance.h): the nodes as traced, bisections traced
// at the same point. Stored in grid cells times kJumpDistanceScale / (N - 1) (gpu_layout.h).
void storeJumpDistances(const Tracer& tracer, const SurfacePoint& point, const LocalFrame& frame, uint32_t n,
                        const std::vector<glm::vec3>& incidents, const std::vector<PathResult>& paths,
                        const TraceSettings& ts, uint32_t channels, float* values, uint64_t& rays) {
  std::vector<TracedView> nodes(paths.size());
  for (size_t d = 0; d < paths.size(); ++d) nodes[d] = {paths[d].exitDirection, incidents[d], paths[d].trapped};
  const std::vector<float> cells = jumpDistances(n, nodes, [&](float x, float y) {
    const glm::vec3 incident = -localToWorld(frame, glm::vec3(nodeDirection(x, y, n)));
    const PathResult path = tracer.traceFromSurface(point, incident, ts);
    rays += path.rays;
    return TracedView{path.exitDirection, incident};
  });
  const float unit = gpu::kJumpDistanceScale / float(n - 1);
  for (size_t d = 0; d < cells.size(); ++d) values[d * channels + channels - 1] = cells[d] * unit;
}

// What the workers of traceAndFit share. Each sample writes only its own slots of part's arrays.
struct ShardTrace {
  const BakePlan& plan;
  const Tracer& tracer;
  const SampleEncoder& encoder;
  Shard shard;
  uint32_t held;
  TraceSettings traceSettings;
  ChannelLayout layout;
  std::vector<size_t> gridSlot;  // local sample -> its slot of part.gridExits, SIZE_MAX for none
  BakePart& part;
};

// One worker's buffers (reused from sample to sample), counters and thread times.
struct TraceWorker {
  std::vector<float> values;
  std::vector<glm::vec3> incidents;
  std::vector<PathResult> paths;
  uint64_t rays = 0, pathCount = 0, trapped = 0;
  double traceSeconds = 0.0, fitSeconds = 0.0;
  TraceWorker(uint32_t nd, uint32_t channels) : values(size_t(nd) * channels), incidents(nd), paths(nd) {}
};

// The shard's samples on the grid-check lattice get consecutive slots of part.gridExits.
std::vector<size_t> gridCheckSlots(Shard shard, size_t count, size_t& slots) {
  std::vector<size_t> gridSlot(count, SIZE_MAX);
  slots = 0;
  for (size_t k = 0; k < count; ++k)
    if ((shard.index + k * shard.count) % kGridCheckStride == 0) gridSlot[k] = slots++;
  return gridSlot;
}

// Traces every grid direction of local sample k into w.values, and its exits into part.gridExits
// where the sample is on the grid-check lattice.
void traceGridDirections(const ShardTrace& t, size_t k, const SurfacePoint& point, const LocalFrame& frame,
                         TraceWorker& w) {
  const DirectionGrid& grid = t.plan.grid;
  const uint32_t nd = static_cast<uint32_t>(grid.directions.size()), channels = t.plan.channels;
  // The eye looks along -w: the incident ray travels toward the surface.
  for (uint32_t d = 0; d < nd; ++d) w.incidents[d] = -localToWorld(frame, glm::vec3(grid.directions[d]));
  t.tracer.traceFromSurface(point, w.incidents, t.traceSettings, w.paths);
  for (uint32_t d = 0; d < nd; ++d) {
    const PathResult& path = w.paths[d];
    w.rays += path.rays;
    w.pathCount += 1;
    w.trapped += path.trapped ? 1u : 0u;
    t.layout.store(path, frame, &w.values[size_t(d) * channels]);
    if (t.gridSlot[k] != SIZE_MAX)
      for (int c = 0; c < 3; ++c) t.part.gridExits[(t.gridSlot[k] * nd + d) * 3 + size_t(c)] = path.exitDirection[c];
  }
}

// Traces the held-out directions of local sample k (global sample s) into part.heldOut.
void traceHeldOut(const ShardTrace& t, size_t k, uint64_t s, const SurfacePoint& point, const LocalFrame& frame,
                  TraceWorker& w) {
  uint64_t rng = 0x5348524546ull ^ (s * 0x9e3779b97f4a7c15ull);
  for (uint32_t h = 0; h < t.held; ++h) {
    // Uniform over the hemisphere, away from the exact horizon.
    const float z = 0.02f + 0.98f * unitFloat(rng);
    const float phi = 6.28318530718f * unitFloat(rng);
    const float r = std::sqrt(std::max(0.0f, 1.0f - z * z));
    const glm::vec3 dir(r * std::cos(phi), r * std::sin(phi), z);
    const PathResult path = t.tracer.traceFromSurface(point, -localToWorld(frame, dir), t.traceSettings);
    w.rays += path.rays;
    w.pathCount += 1;
    float* slot = &t.part.heldOut[(k * t.held + h) * 6];
    for (int c = 0; c < 3; ++c) slot[c] = dir[c], slot[3 + c] = path.exitDirection[c];
  }
}

// Traces, fits and checks local sample k, timing the tracing and the fit apart.
void traceSample(const ShardTrace& t, size_t k, TraceWorker& w) {
  const BakeSettings& settings = t.plan.settings;
  const uint64_t s = t.shard.index + uint64_t(k) * t.shard.count;
  const auto sampleStart = Clock::now();
  const SurfacePoint& point = t.plan.atlas.samples[s];
  const LocalFrame frame = frameAt(point);
  traceGridDirections(t, k, point, frame, w);
  if (settings.jumpDistance)
    storeJumpDistances(t.tracer, point, frame, settings.tableSize, w.incidents, w.paths, t.traceSettings,
                       t.plan.channels, w.values.data(), w.rays);
  const auto fitStart = Clock::now();
  t.encoder.fit(w.values.data(), &t.part.coefficients[k * t.encoder.stride()]);
  const auto heldOutStart = Clock::now();
  traceHeldOut(t, k, s, point, frame, w);
  const auto sampleEnd = Clock::now();
  w.fitSeconds += std::chrono::duration<double>(heldOutStart - fitStart).count();
  w.traceSeconds += std::chrono::duration<double>((fitStart - sampleStart) + (sampleEnd - heldOutStart)).count();
}

// Traces every grid direction of the shard's samples (threads), fits each sample with `encoder`,
// and records what the checks need: part.coefficients, heldOut, gridExits, the counters and the
// thread times. Local sample k is sample shard.index + k * shard.count.
void traceAndFit(const BakePlan& plan, const SampleEncoder& encoder, const BakeOptions& options, Shard shard,
                 Clock::time_point start, BakePart& part) {
  const size_t count = shardSampleCount(plan.atlas.samples.size(), shard);
  const uint32_t nd = static_cast<uint32_t>(plan.grid.directions.size());
  const uint32_t held = options.heldOutDirections, channels = plan.channels;
  size_t slots = 0;
  std::vector<size_t> gridSlot = gridCheckSlots(shard, count, slots);
  part.coefficients.assign(count * encoder.stride(), 0.0f);
  part.heldOut.assign(count * held * 6, 0.0f);
  part.gridExits.assign(slots * nd * 3, 0.0f);
  // The traced channels; the jump distance, when stored, is the last one (storeJumpDistances).
  const ChannelLayout layout =
      ChannelLayout::of(channels - (plan.settings.jumpDistance ? 1u : 0u), plan.settings);
  const ShardTrace trace{plan, *plan.tracer, encoder, shard, held, traceSettingsOf(plan.settings),
                         layout, std::move(gridSlot), part};

  std::atomic<size_t> next{0};
  std::atomic<uint64_t> done{0}, raysSoFar{0};
  std::mutex totalsMutex;
  constexpr size_t kChunk = 8;
  auto worker = [&]() {
    TraceWorker w(nd, channels);
    for (;;) {
      const size_t begin = next.fetch_add(kChunk);
      if (begin >= count) break;
      const size_t end = std::min(count, begin + kChunk);
      const uint64_t raysBefore = w.rays;
      for (size_t k = begin; k < end; ++k) traceSample(trace, k, w);
      raysSoFar.fetch_add(w.rays - raysBefore);
      done.fetch_add(end - begin);
    }
    const std::lock_guard<std::mutex> lock(totalsMutex);
    part.rays += w.rays;
    part.paths += w.pathCount;
    part.trappedPaths += w.trapped;
    part.timings.threadTraceSeconds += w.traceSeconds;
    part.timings.threadFitSeconds += w.fitSeconds;
  };
  std::vector<std::thread> pool;
  for (uint32_t t = 1; t < plan.settings.threads; ++t) pool.emplace_back(worker);
  std::thread mainWorker(worker);
  while (done.load() < count) {
    if (options.progress) options.progress({done.load(), count, raysSoFar.load(), secondsSince(start)});
    std::this_thread::sleep_for(std::chrono::milliseconds(100));
  }
  mainWorker.join();
  for (auto& t : pool) t.join();
  if (options.progress) options.progress({count, count, raysSoFar.load(), secondsSince(start)});
}

}  // namespace

// Traces and fits the shard's samples of a planned bake.
Result<BakePart> tracePart(const BakePlan& plan, const BakeOptions& options, Shard shard, Clock::time_point start) {
  auto encoder = SampleEncoder::create(plan.grid, plan.settings, plan.channels);
  if (!encoder) return encoder.error();
  BakePart part;
  part.settings = plan.settings;
  part.heldOutDirections = options.heldOutDirections;
  part.shard = shard;
  part.sampleCount = plan.atlas.samples.size();
  part.sceneHash = plan.sceneHash;
  part.channels = plan.channels;
  part.directions = static_cast<uint32_t>(plan.grid.directions.size());
  part.stride = encoder->stride();
  const auto traceStart = Clock::now();
  traceAndFit(plan, encoder.value(), options, shard, start, part);
  part.timings.traceWallSeconds = secondsSince(traceStart);
  part.timings.bakeSeconds = secondsSince(start);
  part.timings.peakMemoryBytes = peakResidentBytes();
  return part;
}

Gathered gatherParts(std::vector<BakePart>& parts, size_t stride, uint32_t nd, uint32_t held) {
  const size_t n = parts.front().sampleCount;
  Gathered g;
  if (parts.size() == 1) g.coeffs = std::move(parts.front().coefficients);  // already in sample order
  else g.coeffs.assign(n * stride, 0.0f);
  g.checks.heldDirections.assign(n * held, glm::vec3(0.0f));
  g.checks.heldExits.assign(n * held, glm::vec3(0.0f));
  g.checks.gridExits.assign((n + kGridCheckStride - 1) / kGridCheckStride * nd, glm::vec3(0.0f));
  for (BakePart& part : parts) {
    size_t slot = 0;
    for (size_t k = 0, s = part.shard.index; s < n; ++k, s += part.shard.count) {
      if (parts.size() > 1)
        std::copy_n(&part.coefficients[k * stride], stride, &g.coeffs[s * stride]);
      for (uint32_t h = 0; h < held; ++h) {
        const float* v = &part.heldOut[(k * held + h) * 6];
        g.checks.heldDirections[s * held + h] = glm::vec3(v[0], v[1], v[2]);
        g.checks.heldExits[s * held + h] = glm::vec3(v[3], v[4], v[5]);
      }
      if (s % kGridCheckStride != 0) continue;
      for (uint32_t d = 0; d < nd; ++d) {
        const float* v = &part.gridExits[(slot * nd + d) * 3];
        g.checks.gridExits[s / kGridCheckStride * nd + d] = glm::vec3(v[0], v[1], v[2]);
      }
      ++slot;
    }
    part.coefficients = {};
    part.heldOut = {};
    part.gridExits = {};
  }
  return g;
}

}  // namespace shrefract::bake::detail
