// Shared by the encoding tests: angles and statistics, the sample frame as the field stores it,
// closed forms, and small bakes of built-in scenes.
#pragma once

#include <shrefract/field_decode.h>
#include <shrefract/bake/bake.h>
#include <shrefract/bake/layout.h>
#include <shrefract/bake/table_fit.h>
#include <shrefract/trace/tracer.h>

#include <glm/ext/vector_double3.hpp>
#include <glm/geometric.hpp>

#include <gtest/gtest.h>

#include <algorithm>
#include <array>
#include <chrono>
#include <cmath>
#include <cstdint>
#include <cstdio>
#include <map>
#include <memory>
#include <optional>
#include <string>
#include <utility>
#include <vector>

namespace shrefract::bake::encoding_test {


constexpr double kPi = 3.14159265358979323846;
constexpr double kDegrees = 180.0 / kPi;

// Angle in degrees between two directions (need not be unit), accurate for small angles.
inline double angleDegrees(glm::dvec3 a, glm::dvec3 b) {
  return std::atan2(glm::length(glm::cross(a, b)), glm::dot(a, b)) * kDegrees;
}

inline double mean(const std::vector<double>& v) {
  double sum = 0.0;
  for (double x : v) sum += x;
  return v.empty() ? 0.0 : sum / double(v.size());
}
inline double percentile(std::vector<double> v, double p) {
  if (v.empty()) return 0.0;
  std::sort(v.begin(), v.end());
  return v[std::min(v.size() - 1, static_cast<size_t>(p * double(v.size())))];
}
inline double maximum(const std::vector<double>& v) { return v.empty() ? 0.0 : *std::max_element(v.begin(), v.end()); }

// SplitMix64: directions that do not depend on the standard library's distributions.
struct Random {
  uint64_t state;
  double next() {
    uint64_t z = (state += 0x9e3779b97f4a7c15ull);
    z = (z ^ (z >> 30)) * 0xbf58476d1ce4e5b9ull;
    z = (z ^ (z >> 27)) * 0x94d049bb133111ebull;
    return double((z ^ (z >> 31)) >> 11) * (1.0 / 9007199254740992.0);
  }
};

// Local direction, cosine-weighted (as often as a view direction covers the screen) over the cap
// z >= minZ.
inline glm::dvec3 cosineDirection(Random& rng, double minZ) {
  const double u = rng.next(), phi = 2.0 * kPi * rng.next();
  const double z = std::sqrt(minZ * minZ + (1.0 - minZ * minZ) * u), r = std::sqrt(std::max(0.0, 1.0 - z * z));
  return {r * std::cos(phi), r * std::sin(phi), z};
}

// --- the sample frame, as the field stores it ----------------------------------------------------

// Rows of M_s = [R | -R p]: R's rows are the local axes, z the normal.
struct StoredFrame {
  glm::dvec3 x, y, normal, position;
  // The local view direction w (toward the eye) as the world-space direction of travel.
  glm::dvec3 incident(glm::dvec3 w) const { return -(w.x * x + w.y * y + w.z * normal); }
};
inline StoredFrame storedFrame(const Field& field, uint64_t texel) {
  const float* m = &field.frames[texel * 12];
  StoredFrame f;
  f.x = {m[0], m[1], m[2]};
  f.y = {m[4], m[5], m[6]};
  f.normal = {m[8], m[9], m[10]};
  f.position = -(double(m[3]) * f.x + double(m[7]) * f.y + double(m[11]) * f.normal);
  return f;
}

// The decoded channels of a sample at a local direction.
inline std::vector<double> decode(const Field& field, uint64_t texel, glm::dvec3 w) {
  std::vector<float> out(field.channels);
  evaluateSample(field, texel, {float(w.x), float(w.y), float(w.z)}, out.data());
  return std::vector<double>(out.begin(), out.end());
}
inline glm::dvec3 decodedExit(const Field& field, uint64_t texel, glm::dvec3 w) {
  const std::vector<double> v = decode(field, texel, w);
  return {v[0], v[1], v[2]};
}

// --- closed forms ----------------------------------------------------------------------------------

// Refraction of unit d at a unit normal n facing the ray (dot(d, n) < 0), eta = n_from / n_to.
inline std::optional<glm::dvec3> refract(glm::dvec3 d, glm::dvec3 n, double eta) {
  const double cosI = -glm::dot(d, n);
  const double sin2T = eta * eta * std::max(0.0, 1.0 - cosI * cosI);
  if (sin2T >= 1.0) return std::nullopt;
  return glm::normalize(eta * d + (eta * cosI - std::sqrt(1.0 - sin2T)) * n);
}

// Unpolarized Fresnel reflectance, the textbook form.
inline double fresnelR(double n1, double n2, double cosI) {
  const double sinT = n1 / n2 * std::sqrt(std::max(0.0, 1.0 - cosI * cosI));
  if (sinT >= 1.0) return 1.0;
  const double cosT = std::sqrt(1.0 - sinT * sinT);
  const double rs = (n1 * cosI - n2 * cosT) / (n1 * cosI + n2 * cosT);
  const double rp = (n2 * cosI - n1 * cosT) / (n2 * cosI + n1 * cosT);
  return 0.5 * (rs * rs + rp * rp);
}

// The twice-refracted path through an ideal sphere: it enters where the sphere's normal is the
// direction of `point` from the centre, refracts, crosses the chord and refracts out. Below about
// 82 degrees of incidence (n = 1.5) both refractions are the highest-energy branches.
inline glm::dvec3 idealSphereExit(glm::dvec3 point, glm::dvec3 incident, glm::dvec3 centre, double radius, double ior) {
  const glm::dvec3 n = glm::normalize(point - centre);
  const glm::dvec3 entry = centre + radius * n;
  const glm::dvec3 inside = *refract(incident, n, 1.0 / ior);
  const glm::dvec3 exit = entry - 2.0 * glm::dot(inside, entry - centre) * inside;
  const std::optional<glm::dvec3> out = refract(inside, -glm::normalize(exit - centre), ior);
  return out ? *out : inside;
}

// --- bakes ---------------------------------------------------------------------------------------

inline BakeSettings settingsFor(Encoding encoding, uint32_t parameter, Quantization q = Quantization::U8) {
  BakeSettings s;
  s.encoding = encoding;
  s.quantization = q;
  if (encoding == Encoding::Sh) s.order = parameter;
  if (encoding == Encoding::Table) s.tableSize = parameter;
  if (encoding == Encoding::Pca) s.tableSize = 16, s.components = parameter;
  s.threads = 2;
  return s;
}

// The same SH setting fitted by least squares instead of the robust fit (the default).
inline BakeSettings leastSquares(BakeSettings s) {
  s.shFit = ShFit::LeastSquares;
  return s;
}

// The same table or Pca setting traced at the table's nodes (DirectionSampling::Nodes).
inline BakeSettings atNodes(BakeSettings s) {
  s.directionSampling = DirectionSampling::Nodes;
  return s;
}

inline std::string label(const BakeRecord& s) {
  const bool nodes = s.directionSampling == DirectionSampling::Nodes;
  const std::string q = std::string(s.quantization == Quantization::U8 ? " u8" : " f16") + (nodes ? " nodes" : "") +
                        (nodes && !s.jumpDistance ? " no jump distance" : "") +
                        (s.exitFrame == ExitFrame::Auto ? "" : std::string(" ") + toString(s.exitFrame) + " exits");
  if (s.encoding == Encoding::Sh)
    return "sh " + std::to_string(s.order) + q + (s.shFit == ShFit::Robust ? "" : " least squares");
  if (s.encoding == Encoding::Table) return "table " + std::to_string(s.tableSize) + q;
  return "pca " + std::to_string(s.components) + (s.tableSize == 16 ? "" : " n" + std::to_string(s.tableSize)) + q;
}

inline Scene builtin(const std::string& name, int tessellation) {
  auto scene = makeBuiltinScene(name, {.tessellation = tessellation});
  EXPECT_TRUE(scene.ok()) << (scene.ok() ? "" : scene.error().message);
  return scene.ok() ? std::move(scene).value() : Scene{};
}

inline Field bake(const Scene& scene, BakeSettings s, const std::string& source) {
  BakeOptions options;
  s.source = source;
  options.settings = s;
  options.heldOutDirections = 0;  // the tests measure on their own
  const auto start = std::chrono::steady_clock::now();
  auto field = bakeField(scene, options);
  EXPECT_TRUE(field.ok()) << label(s) << ": " << (field.ok() ? "" : field.error().message);
  std::printf("  (bake %s %s: %.2f s)\n", source.c_str(), label(s).c_str(),
              std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count());
  return field.ok() ? std::move(field).value() : Field{};
}

// A scene, the split layout the bake builds for it (same budget, so the same texels) and a
// tracer: the surface point of every sample texel, for exact paths at any direction.
struct Baseline {
  Scene scene;
  SampleAtlas atlas;
  std::unique_ptr<Tracer> tracer;
};

inline std::unique_ptr<Baseline> makeBaseline(Scene scene, uint64_t sampleBudget) {
  auto b = std::make_unique<Baseline>();
  b->scene = std::move(scene);
  LayoutOptions lo;
  lo.sampleBudget = sampleBudget;
  auto atlas = buildSplitLayout(b->scene, lo);
  EXPECT_TRUE(atlas.ok()) << (atlas.ok() ? "" : atlas.error().message);
  if (atlas.ok()) b->atlas = std::move(atlas).value();
  auto tracer = Tracer::create(b->scene);
  EXPECT_TRUE(tracer.ok()) << (tracer.ok() ? "" : tracer.error().message);
  if (tracer.ok()) b->tracer = std::move(tracer).value();
  return b;
}

// Every `stride`-th sample texel of a field.
inline std::vector<uint64_t> sampleTexels(const Field& field, size_t stride) {
  std::vector<uint64_t> texels;
  size_t seen = 0;
  for (uint64_t t = 0; t < field.texelCount(); ++t)
    if (field.texelKinds[t] == kTexelSample && seen++ % stride == 0) texels.push_back(t);
  return texels;
}

// The layout's surface point of a texel, checked against the frame the field stores for it.
inline SurfacePoint surfacePoint(const Field& field, const SampleAtlas& atlas, uint64_t texel) {
  EXPECT_EQ(field.width, atlas.width);
  EXPECT_EQ(field.height, atlas.height);
  EXPECT_NE(atlas.texelSample[texel], kNoSample) << "texel " << texel;
  const SurfacePoint p = atlas.samples[atlas.texelSample[texel]];
  const StoredFrame f = storedFrame(field, texel);
  EXPECT_LT(glm::length(f.normal - glm::dvec3(p.shadingNormal)), 1e-6) << "texel " << texel;
  EXPECT_LT(glm::length(f.position - glm::dvec3(p.position)), 1e-5) << "texel " << texel;
  return p;
}

}  // namespace shrefract::bake::encoding_test
