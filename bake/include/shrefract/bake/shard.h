// Sharded bakes: each process traces a deterministic share of the samples into a part; a merge
// joins the parts and does the steps that need every sample (the Pca basis, spatial smoothing,
// the frequency window, u8 scale and bias, the error statistics) once. Every per-sample result
// depends only on the sample's index, and the merge runs the very steps bakeField runs, so the
// merged field is byte-identical to the single-process bake's except for the timing statistics
// (bakeSeconds, traceSeconds, fitSeconds, raysPerSecond, peakMemoryBytes) and settings.threads
// (the largest of the parts'), both informational. docs/performance.md, "Sharded and distributed
// bakes".
#pragma once

#include <shrefract/bake/bake.h>
#include <shrefract/assets/scene.h>
#include <shrefract/bake/bake_settings.h>
#include <shrefract/field.h>
#include <shrefract/result.h>

#include <cstdint>
#include <string>
#include <vector>

namespace shrefract::bake {

// Shard `index` of `count` holds the samples s with s % count == index: interleaved, so that every
// shard gets samples from all over the surface and the shards cost about the same.
struct Shard {
  uint32_t index = 0;
  uint32_t count = 1;
};
inline constexpr uint32_t kMaxShards = 65536;

// "i/N" with 0 <= i < N <= kMaxShards. Errors name the text.
Result<Shard> parseShard(const std::string& text);

// Wall and thread times of one part, and the process's peak resident memory.
struct PartTimings {
  double bakeSeconds = 0.0;         // from the start of the part's bake to the end of its tracing
  double traceWallSeconds = 0.0;    // the parallel trace-and-fit phase
  double threadTraceSeconds = 0.0;  // thread time in it spent tracing ...
  double threadFitSeconds = 0.0;    // ... and fitting
  uint64_t peakMemoryBytes = 0;
};

// One shard's per-sample results in float, before any step that needs all samples.
struct BakePart {
  std::string name;  // where it came from, for messages (not stored)
  // Normalized, after the --max-error / --max-bytes-per-sample choices; threads as this part used.
  BakeSettings settings;
  uint32_t heldOutDirections = 0;
  Shard shard;
  uint64_t sampleCount = 0;  // samples of the whole bake, every shard's
  uint64_t sceneHash = 0;    // the scene's layout and media (merge checks it against the scene)
  uint32_t channels = 0;
  uint32_t directions = 0;
  uint64_t stride = 0;       // floats per sample in `coefficients` (Pca: its table, before the basis)
  uint64_t rays = 0, paths = 0, trappedPaths = 0;
  PartTimings timings;
  // For the shard's samples in ascending order:
  std::vector<float> coefficients;  // stride floats each
  std::vector<float> heldOut;       // heldOutDirections x (local direction xyz, exit direction xyz) each
  std::vector<float> gridExits;     // directions x exit xyz for each sample on the grid-check lattice
};

// Samples whose index is a multiple of this keep their traced exits at every grid direction, for
// the fit statistic (fitRmsDegrees); parts carry them.
inline constexpr size_t kGridCheckStride = 16;

// The samples of `shard` among `sampleCount`.
uint64_t shardSampleCount(uint64_t sampleCount, Shard shard);

// Bakes one shard: the layout and the --max-error / --max-bytes-per-sample choices as bakeField
// makes them (every shard makes them alike), then only the shard's samples are traced and fitted.
Result<BakePart> bakePart(const Scene& scene, const BakeOptions& options, Shard shard);

// Checks that parts belong together: the same settings (threads aside), held-out count, scene and
// sample count, and every shard index of the same count exactly once. Errors are one line naming
// the part at fault.
Result<void> checkParts(const std::vector<BakePart>& parts);

// Joins the parts of one bake into its field (checkParts first). `scene` must be the one they were
// baked from (loaded from parts[0].settings.source): its layout is rebuilt and checked against
// the parts' sceneHash. `stage` and `note` as BakeOptions's: the merge makes the choices that follow
// the tracing (the exit frame, components or clusters), and says them as the bake does.
Result<Field> mergeParts(const Scene& scene, std::vector<BakePart> parts,
                         const std::function<void(const std::string&)>& stage = {},
                         const std::function<void(const std::string&)>& note = {});

// The part file (.shrfpart): magic, version, payload size, FNV-1a checksum, payload (little
// endian). parsePart checks all of it, sizes against the header's counts and that every float is
// finite; errors name `name`.
std::vector<uint8_t> serializePart(const BakePart& part);
Result<BakePart> parsePart(const uint8_t* data, size_t size, const std::string& name);
Result<BakePart> readPart(const std::string& path);
// Atomic: a temporary file in the same directory, then rename; nothing remains on failure.
Result<void> writePart(const std::string& path, const BakePart& part);

}  // namespace shrefract::bake
