// Decoding one sample of a field on the CPU: the hemi-octahedral grid of the Table and Pca
// encodings and the linear sum every encoding reduces to (field_decode.h). The compute shaders mirror
// these operations (spirv/shaders), the bake measures its fits with them and the CPU reference
// (cpu_reference.cpp) builds on evaluateSample.
#include <shrefract/field_decode.h>
#include <shrefract/field.h>
#include <shrefract/gpu_layout.h>
#include <shrefract/sh.h>

#include <algorithm>
#include <cmath>
#include <numbers>
#include <vector>

namespace shrefract {

HemiOctCoordinates hemiOctFromDirection(float x, float y, float z) {
  z = std::max(z, 0.0f);
  const float l1 = std::fabs(x) + std::fabs(y) + z;
  if (!(l1 > 0.0f)) return {};  // no direction: the pole, as the SH path uses +z
  const float px = x / l1, py = y / l1;
  return {std::clamp((px + py + 1.0f) * 0.5f, 0.0f, 1.0f), std::clamp((px - py + 1.0f) * 0.5f, 0.0f, 1.0f)};
}

namespace {

// The point on the octahedron |x| + |y| + z = 1 at grid coordinates (x, y) of an n x n grid, which
// hemiOctDirectionAt normalizes.
std::array<float, 3> octahedronPoint(float x, float y, uint32_t n) {
  const float a = 2.0f * x / float(n - 1) - 1.0f;  // p.x + p.y
  const float b = 2.0f * y / float(n - 1) - 1.0f;  // p.x - p.y
  const float px = 0.5f * (a + b), py = 0.5f * (a - b);
  return {px, py, std::max(0.0f, 1.0f - std::fabs(px) - std::fabs(py))};
}

float pointLength(const std::array<float, 3>& p) { return std::sqrt(p[0] * p[0] + p[1] * p[1] + p[2] * p[2]); }

}  // namespace

std::array<float, 3> hemiOctDirection(uint32_t i, uint32_t j, uint32_t n) {
  return hemiOctDirectionAt(float(i), float(j), n);
}

std::array<float, 3> hemiOctDirectionAt(float x, float y, uint32_t n) {
  const std::array<float, 3> p = octahedronPoint(x, y, n);
  const float len = pointLength(p);
  return {p[0] / len, p[1] / len, p[2] / len};
}

HemiOctBilinear hemiOctBilinear(float x, float y, float z, uint32_t n) {
  const HemiOctCoordinates uv = hemiOctFromDirection(x, y, z);
  const float last = float(n - 1);
  const float fx = uv.u * last, fy = uv.v * last;
  // The cell's lower corner; the top row and column belong to the cell below them.
  const uint32_t i = std::min(static_cast<uint32_t>(fx), n - 2), j = std::min(static_cast<uint32_t>(fy), n - 2);
  const float tx = fx - float(i), ty = fy - float(j);
  HemiOctBilinear b;
  b.node = {j * n + i, j * n + i + 1, (j + 1) * n + i, (j + 1) * n + i + 1};
  b.weight = {(1.0f - tx) * (1.0f - ty), tx * (1.0f - ty), (1.0f - tx) * ty, tx * ty};
  return b;
}

JumpCosines jumpCosines(uint32_t n) {
  // Up to the reference size the angles chosen at 16x16; finer cells, whose corners differ less
  // where the exit is smooth, tell smaller jumps apart, down to the floors.
  const float scale = n > gpu::kJumpReferenceTableSize ? float(gpu::kJumpReferenceTableSize) / float(n) : 1.0f;
  const float radians = std::numbers::pi_v<float> / 180.0f;
  return {std::cos(std::max(gpu::kJumpFullDegrees * scale, gpu::kJumpFullMinDegrees) * radians),
          std::cos(std::max(gpu::kJumpNoneDegrees * scale, gpu::kJumpNoneMinDegrees) * radians)};
}

namespace {

// The length of node `node`'s point on the octahedron (1 at the pole and the horizon's vertices,
// 1/sqrt(3) at a face's centre).
float octahedronLength(uint32_t node, uint32_t n) { return pointLength(octahedronPoint(float(node % n), float(node / n), n)); }

// The exit of a path that goes straight through (a slab's): the view ray's own direction of travel
// for the local direction w toward the eye, in object space (rows: M_s as field.frames stores it)
// or, rows == nullptr, in the sample's frame (-w / |w|).
std::array<float, 3> straightThrough(const float* rows, float x, float y, float z) {
  const float l = std::sqrt(x * x + y * y + z * z);
  std::array<float, 3> d{};
  if (!(l > 0.0f)) return d;
  if (!rows) return {-x / l, -y / l, -z / l};
  for (int c = 0; c < 3; ++c) d[size_t(c)] = -(x * rows[c] + y * rows[4 + c] + z * rows[8 + c]) / l;
  return d;
}

// The coefficients (sum 1) that give a side's estimate at w from its corners' values: the plane
// fitted by least squares to the corners at their offsets from w in cells, weighted by
// kept_j keep_j^4 and with gpu::kJumpSideSlopeRidge on both slopes, evaluated at w (Cramer's
// rule for its constant term). With one corner it is that corner's value; with three or more,
// the plane through them: where the exit moves unlike a slab's (a prism's side face), the side's
// own corners give its slope instead of the straight-through correction alone.
std::array<float, 4> sideCoefficients(const HemiOctBilinear& b, const float* kept, const float* keep) {
  const float tx = b.weight[1] + b.weight[3], ty = b.weight[2] + b.weight[3];
  const float dx[4] = {-tx, 1.0f - tx, -tx, 1.0f - tx}, dy[4] = {-ty, -ty, 1.0f - ty, 1.0f - ty};
  float f[4], sx = 0.0f, sy = 0.0f, sxx = gpu::kJumpSideSlopeRidge, sxy = 0.0f, syy = gpu::kJumpSideSlopeRidge;
  for (int j = 0; j < 4; ++j) {
    const float k2 = keep[j] * keep[j];
    f[j] = kept[j] * (k2 * k2);
    sx += f[j] * dx[j];
    sy += f[j] * dy[j];
    sxx += f[j] * dx[j] * dx[j];
    sxy += f[j] * dx[j] * dy[j];
    syy += f[j] * dy[j] * dy[j];
  }
  const float minor = sxx * syy - sxy * sxy;
  std::array<float, 4> alpha{};
  float det = 0.0f;
  for (int j = 0; j < 4; ++j) {
    alpha[size_t(j)] = f[j] * (minor - sx * (dx[j] * syy - sxy * dy[j]) + sy * (dx[j] * sxy - sxx * dy[j]));
    det += alpha[size_t(j)];
  }
  for (float& a : alpha) a /= det;  // det >= f_m ridge^2 > 0: corner m is fully on its own side
  return alpha;
}

// The cell's corners blended, into out (the decoded channels). Node-sampled exits blend by
// b_j |o_j|, o_j the node's point on the octahedron, which the grid maps linearly inside each
// quadrant: the blend of the unit exits of a linear map of the direction (a slab's straight-through
// exit, a rotation, a constant) is then the exit at w itself inside a quadrant's cells, where plain
// bilinear weights err by up to 0.09 deg at N = 32. The other channels, and least-squares tables
// (fitted bilinearly), stay bilinear. Mirrored by decompress_table.comp blendCorners.
void blendCorners(const HemiOctBilinear& b, const EncodingShape& shape, const float (*v)[kMaxEncodedChannels],
                  float* out) {
  const uint32_t n = shape.tableSize, channels = shape.decodedChannels();
  float lengths[4] = {1.0f, 1.0f, 1.0f, 1.0f}, exitWeight[4], weighted = 0.0f;
  if (shape.jumpAware)
    for (int j = 0; j < 4; ++j) lengths[j] = octahedronLength(b.node[j], n);
  for (int j = 0; j < 4; ++j) weighted += b.weight[j] * lengths[j];
  for (int j = 0; j < 4; ++j) exitWeight[j] = b.weight[j] * lengths[j] / weighted;
  for (int j = 0; j < 4; ++j)
    for (uint32_t c = 0; c < channels; ++c) out[c] += (c < 3 ? exitWeight[j] : b.weight[j]) * v[j][c];
}

// Jump-aware interpolation of a cell's four corners (docs/encodings.md, "Jumps"). Bilinear
// interpolation across a jump of the exit direction makes a direction no path takes. Each corner
// estimates the exit at w as its own exit moved by the change of the straight-through direction
// from its node to w; seen from a corner m, a corner whose estimate is far from m's is discounted
// (fully beyond jumpCosines(n).none, linearly in the cosine from its .full) and the
// others' estimates give the side's value at w (sideCoefficients: the plane through them). The
// four views are averaged with weights w_m^p, which picks the side of the jump holding most of the weight, steeply but without a step (a step
// flickers as the eye moves). Where no corner is discounted this is plain bilinear
// interpolation; between the two the results are blended by min(1, kJumpBlendGain x the
// discounted weight), so the decode is continuous everywhere.
// With the jump distance channel the side is placed, not guessed: the corners' distances to the
// nearest jump, signed + for the corners of view m's side and - for the others, interpolate
// bilinearly to a function that is zero on the jump (exactly, for a straight jump), and view m
// counts by its bilinear weight where that function puts w on m's side (a ramp of
// kJumpDistanceSoftness cells across the jump) instead of by w_m^p. Mirrored by
// decompress_table.comp. out: the decoded channels (the jump distance is not one). eyeJump (when
// not null): the eye's distance from the cell's jump, the largest view's signed distance (the eye's
// own side counts it positive), clamped to 0..kJumpDistanceMaxCells; left as the caller set it (the
// cap, evaluateStored) where the field has no jump distance (gpu_layout.h kBindingJumpOut).
// rows: M_s for an object-space field (nullptr: plain bilinear), ignored for a sample-frame one.
void interpolateCorners(const HemiOctBilinear& b, const EncodingShape& shape, const float (*v)[kMaxEncodedChannels],
                        const float* rows, const std::array<float, 3>& w, float* out, float* eyeJump) {
  const uint32_t n = shape.tableSize, channels = shape.decodedChannels();
  blendCorners(b, shape, v, out);
  if (shape.sampleFrameExits) rows = nullptr;
  else if (!rows) return;
  if (!shape.jumpAware || n < gpu::kJumpMinTableSize) return;
  const std::array<float, 3> eye = straightThrough(rows, w[0], w[1], w[2]);
  float e[4][3];
  for (int j = 0; j < 4; ++j) {
    const std::array<float, 3> d = hemiOctDirection(b.node[j] % n, b.node[j] / n, n);
    const std::array<float, 3> node = straightThrough(rows, d[0], d[1], d[2]);
    for (int c = 0; c < 3; ++c) e[j][c] = v[j][c] + (eye[size_t(c)] - node[size_t(c)]);
  }
  // Each corner m in turn as the reference side: its agreeing corners' blended estimate, weighted
  // by w_m^p (p = kJumpDominancePower), so the side with the most weight wins without a step.
  const JumpCosines cosines = jumpCosines(n);
  float length[4], distance[4] = {}, estimate[kMaxFieldChannels] = {}, dominance = 0.0f, discounted = 0.0f;
  float nearest = -gpu::kJumpDistanceMaxCells;
  for (int j = 0; j < 4; ++j) length[j] = std::sqrt(e[j][0] * e[j][0] + e[j][1] * e[j][1] + e[j][2] * e[j][2]);
  if (shape.jumpDistance)
    for (int j = 0; j < 4; ++j)
      distance[j] = std::clamp(v[j][channels] * (float(n - 1) / gpu::kJumpDistanceScale), 0.0f,
                               gpu::kJumpDistanceMaxCells);
  for (int m = 0; m < 4; ++m) {
    float pm = shape.jumpDistance ? b.weight[m] : std::pow(b.weight[m], gpu::kJumpDominancePower);
    float keep[4], kept[4], signedDistance = 0.0f;
    for (int j = 0; j < 4; ++j) {
      const float dot = e[j][0] * e[m][0] + e[j][1] * e[m][1] + e[j][2] * e[m][2];
      const float cosine = length[j] * length[m] > gpu::kMinDirectionLength2 ? dot / (length[j] * length[m]) : 1.0f;
      keep[j] = std::clamp((cosine - cosines.none) / (cosines.full - cosines.none), 0.0f, 1.0f);
      kept[j] = b.weight[j] * keep[j];
      signedDistance += b.weight[j] * distance[j] * (2.0f * keep[j] - 1.0f);
    }
    // Every view's, weighted or not: the nearest distance stays continuous where a weight reaches 0.
    nearest = std::max(nearest, signedDistance);
    if (!(pm > 0.0f)) continue;
    if (shape.jumpDistance)
      pm *= std::clamp(0.5f + signedDistance / gpu::kJumpDistanceSoftness, 0.0f, 1.0f) + gpu::kJumpDistanceFloor;
    for (int j = 0; j < 4; ++j) discounted += pm * (b.weight[j] - kept[j]);
    const std::array<float, 4> alpha = sideCoefficients(b, kept, keep);
    for (uint32_t c = 0; c < channels; ++c) {
      float side = 0.0f;
      for (int j = 0; j < 4; ++j) side += alpha[size_t(j)] * (c < 3 ? e[j][c] : v[j][c]);
      estimate[c] += pm * side;
    }
    dominance += pm;
  }
  if (eyeJump && shape.jumpDistance) *eyeJump = std::clamp(nearest, 0.0f, gpu::kJumpDistanceMaxCells);
  const float blend = std::min(1.0f, gpu::kJumpBlendGain * discounted / dominance);
  if (!(blend > 0.0f)) return;
  for (uint32_t c = 0; c < channels; ++c) out[c] += blend * (estimate[c] / dominance - out[c]);
}

// evaluateCoefficients in the space the field stores its exits in.
void evaluateStored(const EncodingShape& shape, const float* a, const float* basis, const std::array<float, 3>& w,
                    float* out, const float* frameRows, float* eyeJump) {
  const uint32_t channels = shape.channels;  // encoded; Sh and Table fields without a jump distance decode all
  std::fill(out, out + shape.decodedChannels(), 0.0f);
  if (eyeJump) *eyeJump = gpu::kJumpDistanceMaxCells;
  // A Volume field has no coefficients to sum: evaluateSample traces it (traceVolumeSample).
  if (shape.encoding == Encoding::Volume) return;
  const float z = std::max(w[2], 0.0f);
  if (shape.encoding == Encoding::Sh) {
    const int order = static_cast<int>(shape.order);
    thread_local std::vector<float> y;
    y.resize(static_cast<size_t>(sh::basisCount(order)));
    sh::evaluate(order, w[0], w[1], z, y.data());
    for (uint32_t i = 0; i < shape.layerCount(); ++i)
      for (uint32_t c = 0; c < channels; ++c) out[c] += a[size_t(i) * channels + c] * y[i];
    return;
  }
  const uint32_t n = shape.tableSize;
  const HemiOctBilinear b = hemiOctBilinear(w[0], w[1], z, n);
  float corners[4][kMaxEncodedChannels] = {};
  if (shape.encoding == Encoding::Table) {
    for (int j = 0; j < 4; ++j)
      for (uint32_t c = 0; c < channels; ++c) corners[j][c] = a[size_t(b.node[j]) * channels + c];
  } else if (shape.clustered) {  // Pca, clustered: the sample's one function, whole
    const size_t nodes = size_t(n) * n;
    const size_t k = a[0] > 0.0f ? std::min(size_t(a[0]), size_t(shape.components) - 1) : 0;  // NaN: 0
    for (int j = 0; j < 4; ++j)
      for (uint32_t c = 0; c < channels; ++c) corners[j][c] = basis[(k * nodes + b.node[j]) * channels + c];
  } else {  // Pca: the weights times the basis functions at the cell's four nodes
    const size_t nodes = size_t(n) * n;
    for (int j = 0; j < 4; ++j)
      for (uint32_t k = 0; k < shape.components; ++k) {
        const float* f = &basis[(k * nodes + b.node[j]) * channels];
        for (uint32_t c = 0; c < channels; ++c) corners[j][c] += a[k] * f[c];
      }
  }
  interpolateCorners(b, shape, corners, frameRows, {w[0], w[1], z}, out, eyeJump);
}

}  // namespace

void evaluateCoefficients(const EncodingShape& shape, const float* a, const float* basis,
                          const std::array<float, 3>& w, float* out, const float* frameRows, float* eyeJump) {
  evaluateStored(shape, a, basis, w, out, frameRows, eyeJump);
  if (!shape.sampleFrameExits || !frameRows) return;
  // To object space: the rows of M_s are the frame's axes, so the inverse rotation is the transpose.
  const float x = out[0], y = out[1], z = out[2];
  for (int c = 0; c < 3; ++c) out[c] = x * frameRows[c] + y * frameRows[4 + c] + z * frameRows[8 + c];
}

namespace {
// The first `layers` layers of a sample, dequantized (dequantizeSample's layout).
void dequantizeLayers(const Field& field, uint64_t texel, uint32_t layers, std::vector<float>& out) {
  const uint32_t values = field.valuesPerLayer();
  out.resize(size_t(layers) * values);
  for (uint32_t i = 0; i < layers; ++i)
    for (uint32_t v = 0; v < values; ++v) out[size_t(i) * values + v] = fieldCoefficient(field, i, texel, v);
}
}  // namespace

void dequantizeSample(const Field& field, uint64_t texel, std::vector<float>& out) {
  dequantizeLayers(field, texel, field.layerCount(), out);
}

void evaluateSample(const Field& field, uint64_t texel, const std::array<float, 3>& w, float* out, uint32_t order,
                    float* eyeJump) {
  if (field.encoding == Encoding::Volume) {
    if (eyeJump) *eyeJump = gpu::kJumpDistanceMaxCells;  // exact paths: no table jump to place
    traceVolumeSample(field, &field.frames[texel * 12], w, out);
    return;
  }
  EncodingShape shape = field.shape();
  // A lower SH order reads only the first (order + 1)^2 layers, which lead the array: only those
  // are dequantized (this runs per texel in the CPU reference's decompression).
  if (shape.encoding == Encoding::Sh) shape.order = std::min(shape.order, order);
  thread_local std::vector<float> a;
  dequantizeLayers(field, texel, shape.layerCount(), a);
  evaluateCoefficients(shape, a.data(), field.basis.data(), w, out, &field.frames[texel * 12], eyeJump);
}

}  // namespace shrefract
