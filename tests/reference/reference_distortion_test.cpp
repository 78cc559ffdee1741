// The exact-at-the-texels distortion image and its CPU raster against the engine's reference
// render, and the image metrics.
#include "reference/reference_support.h"

namespace shrefract::bake {
namespace {

using namespace reference_test;

// --- exact paths at the sample texels ---------------------------------------------------------

// A small sphere field (split layout) and the layout it was baked from: buildSplitLayout with the
// bake's budget is deterministic, so its samples are the field's, with their surfaces and
// triangles.
struct SmallField {
  SphereSetup s = sphere(3);
  Field field;
  SampleAtlas atlas;
};

SmallField smallField() {
  SmallField f;
  BakeOptions bo;
  bo.settings.order = 1;
  bo.settings.directionsTheta = 4;
  bo.settings.directionsPhi = 8;
  bo.settings.sampleBudget = 1000;
  bo.settings.quantization = Quantization::F16;
  bo.settings.threads = 2;
  bo.heldOutDirections = 0;
  auto field = bakeField(f.s.scene, bo);
  EXPECT_TRUE(field.ok()) << (field.ok() ? "" : field.error().message);
  f.field = std::move(field).value();
  LayoutOptions lo;
  lo.sampleBudget = 1000;
  auto atlas = buildSplitLayout(f.s.scene, lo);
  EXPECT_TRUE(atlas.ok());
  f.atlas = std::move(atlas).value();
  return f;
}

// Every sample texel the eye sees holds the path traced from the layout's own sample point toward
// the eye, rounded to binary16: 1e-3 absorbs the binary16 rounding (2^-11) and the frame's float
// recovery of the point; the optical depth (the built-in glass absorbs) is in w, to binary16's
// relative precision. Left out: paths stopped by the bounce cap (their direction of travel at the
// cut depends on rounding), and samples facing away from the eye, traced along their horizon,
// where the triangle the tracer finds at a vertex and the layout's may lie on either side of the
// tangent ray (about a third differ there; counted, not checked). Gutter texels follow their rule
// on the rounded values.
TEST(ExactDistortion, SampleTexelsHoldTheExactPathAndGuttersTheirRule) {
  const SmallField f = smallField();
  ASSERT_EQ(f.atlas.width, f.field.width);
  ASSERT_EQ(f.atlas.texelKinds, f.field.texelKinds);
  const glm::vec3 eye(0.4f, 0.9f, 3.0f);
  ExactDistortionOptions eo;
  eo.threads = 2;
  auto exact = exactDistortion(*f.s.tracer, f.field, eye, eo);
  ASSERT_TRUE(exact.ok()) << exact.error().message;
  EXPECT_EQ(exact.value().unmatched, 0u);
  const auto& rgba = exact.value().image.rgba;
  TraceSettings ts;
  uint32_t samples = 0, checked = 0, absorbing = 0;
  for (uint64_t t = 0; t < f.field.texelCount(); ++t) {
    if (f.field.texelKinds[t] != kTexelSample) continue;
    ++samples;
    const SurfacePoint& point = f.atlas.samples[f.atlas.texelSample[t]];
    const LocalFrame frame = frameAt(point);
    const glm::vec3 w = worldToLocal(frame, eye - point.position);
    if (w.z <= 0.0f) continue;
    const PathResult path = f.s.tracer->traceFromSurface(point, -localToWorld(frame, glm::normalize(w)), ts);
    if (path.trapped) continue;
    for (int k = 0; k < 3; ++k) ASSERT_NEAR(rgba[t * 4 + size_t(k)], path.exitDirection[k], 1e-3f) << "texel " << t;
    const float tau = f.field.hasOpticalDepth() ? path.opticalDepth : 0.0f;
    ASSERT_NEAR(rgba[t * 4 + 3], tau, 1e-3f * std::max(1.0f, tau)) << "texel " << t;
    absorbing += tau > 0.0f ? 1 : 0;
    ++checked;
  }
  EXPECT_EQ(samples, exact.value().samples);
  EXPECT_GT(checked, samples / 4);
  EXPECT_GT(absorbing, checked / 2) << "the built-in glass absorbs: the optical depth must be stored";
  ASSERT_FALSE(f.field.gutters.empty());
  for (const GutterTexel& g : f.field.gutters)
    for (size_t c = 0; c < 4; ++c)
      ASSERT_EQ(rgba[size_t(g.target) * 4 + c],
                reference::roundToBinary16(rgba[size_t(g.a) * 4 + c] + rgba[size_t(g.b) * 4 + c] -
                                           rgba[size_t(g.c) * 4 + c]));
}

// A flat-shaded cube puts samples on its edges and corners, where the probe along the normal runs
// in the plane of the next face: every sample's surface point must still be found.
TEST(ExactDistortion, FindsTheSurfaceOfSamplesOnEdgesAndCorners) {
  auto scene = makeBuiltinScene("cube", {1, std::nullopt, std::nullopt});
  ASSERT_TRUE(scene.ok());
  auto tracer = Tracer::create(scene.value());
  ASSERT_TRUE(tracer.ok());
  BakeOptions bo;
  bo.settings.order = 1;
  bo.settings.directionsTheta = 4;
  bo.settings.directionsPhi = 8;
  bo.settings.sampleBudget = 600;
  bo.settings.threads = 2;
  bo.heldOutDirections = 0;
  auto field = bakeField(scene.value(), bo);
  ASSERT_TRUE(field.ok()) << field.error().message;
  ExactDistortionOptions eo;
  eo.threads = 2;
  auto exact = exactDistortion(*tracer.value(), field.value(), glm::vec3(1.0f, 2.0f, 5.0f), eo);
  ASSERT_TRUE(exact.ok());
  EXPECT_GT(exact.value().samples, 300u);
  EXPECT_EQ(exact.value().unmatched, 0u);
}

// renderDistortion tests only the triangles binned under a sample, in reference::render's order
// and operations: the images must agree exactly (tolerance 0: the same float and double
// operations on the same values), including which pixels show the object. With S = 2 it is the
// S = 1 render at twice the size, box-filtered (1e-6 for the summation order).
TEST(ExactDistortion, CpuRasterMatchesTheEnginesReferenceRender) {
  const SmallField f = smallField();
  Camera camera;
  camera.eye = {0.4f, 0.9f, 3.0f};
  camera.verticalFovDegrees = 40.0f;
  ExactDistortionOptions eo;
  eo.threads = 2;
  auto exact = exactDistortion(*f.s.tracer, f.field, glm::vec3(0.4f, 0.9f, 3.0f), eo);
  ASSERT_TRUE(exact.ok());
  constexpr uint32_t kW = 40, kH = 30;
  const reference::LatLongImage latLong{f.s.env.width, f.s.env.height, f.s.env.rgba.data()};
  reference::RenderObject object;
  object.mesh = &f.field.mesh;
  object.distortion = &exact.value().image;
  const reference::RenderedImage engine = reference::render({object}, latLong, camera, kW, kH);
  DistortionRenderOptions ro;
  ro.width = kW;
  ro.height = kH;
  ro.camera = camera;
  ro.threads = 2;
  auto ours = renderDistortion(f.field.mesh, exact.value().image, f.s.env, ro);
  ASSERT_TRUE(ours.ok()) << ours.error().message;
  uint32_t objectPixels = 0;
  for (size_t p = 0; p < size_t(kW) * kH; ++p) {
    ASSERT_EQ(ours.value().mask[p], engine.object[p] >= 0 ? 1 : 0) << "pixel " << p;
    objectPixels += ours.value().mask[p];
    for (size_t c = 0; c < 3; ++c) ASSERT_EQ(ours.value().color.rgba[p * 4 + c], engine.rgba[p * 4 + c]) << "pixel " << p;
  }
  EXPECT_GT(objectPixels, 100u);
  ro.samplesPerAxis = 2;
  auto super = renderDistortion(f.field.mesh, exact.value().image, f.s.env, ro);
  ro.samplesPerAxis = 1;
  ro.width = 2 * kW;
  ro.height = 2 * kH;
  auto big = renderDistortion(f.field.mesh, exact.value().image, f.s.env, ro);
  ASSERT_TRUE(super.ok() && big.ok());
  const Image reduced = boxFilter(big.value().color, 2);
  for (size_t k = 0; k < reduced.rgba.size(); ++k) ASSERT_NEAR(reduced.rgba[k], super.value().color.rgba[k], 1e-6f);
}

TEST(ImageMetrics, IdenticalAndDifferentImages) {
  Image a;
  a.width = 16;
  a.height = 16;
  a.rgba.assign(16 * 16 * 4, 0.5f);
  std::vector<uint8_t> mask(256, 1);
  std::vector<glm::vec3> dirs(256, glm::vec3(0, 0, 1));
  auto same = compareImages(a, a, mask, dirs, dirs);
  ASSERT_TRUE(same.ok());
  EXPECT_EQ(same->psnr, 100.0);
  EXPECT_NEAR(same->ssim, 1.0, 1e-9);
  EXPECT_EQ(same->maxAngleDegrees, 0.0);
  Image b = a;
  for (size_t i = 0; i < b.rgba.size(); i += 4) b.rgba[i] = 0.6f;
  std::vector<glm::vec3> tilted(256, glm::normalize(glm::vec3(1, 0, 1)));
  auto diff = compareImages(a, b, mask, dirs, tilted);
  ASSERT_TRUE(diff.ok());
  // MSE = 0.01 / 3 over RGB -> PSNR = 10 log10(300).
  EXPECT_NEAR(diff->psnr, 10.0 * std::log10(300.0), 1e-4);  // 0.6f - 0.5f is not exactly 0.1
  EXPECT_NEAR(diff->meanAngleDegrees, 45.0, 1e-4);
  EXPECT_FALSE(compareImages(a, b, std::vector<uint8_t>(3), {}, {}).ok());
}

}  // namespace
}  // namespace shrefract::bake
