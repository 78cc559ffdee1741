// Skipping work in the engine: decompression is left out for an object whose eye has not
// moved since its last decompression, and objects outside the view frustum are neither decompressed
// nor drawn. Each case checks the counts the engine reports (Decompressor::lastStats,
// Renderer::lastDrawStats) and that the pixels match the path that skips nothing.
#include <gtest/gtest.h>
#include <shrefract/decompressor.h>

#include <algorithm>
#include <cmath>
#include <cstdio>

#include "engine/engine_test_support.h"
#include "engine/synthetic_field.h"
#include "offscreen/offscreen.h"
#include "session_test_support.h"

namespace shrefract {
namespace {


// A distortion image left alone must be bit-identical; one decompressed again from the same inputs
// runs the same shader on the same data, so it is identical too (0), but the comparison with the
// skipping path's frames allows for a driver that reorders float work between submissions.
constexpr float kSameInputsTolerance = 1e-6f;
// Rendered images: the skipping and non-skipping paths draw the same triangles from the same
// distortion images; any difference would be a bug, the bound only absorbs float noise.
constexpr float kImageTolerance = 1e-5f;

float maxDifference(const std::vector<float>& a, const std::vector<float>& b) {
  float worst = a.size() == b.size() ? 0.0f : INFINITY;
  for (size_t i = 0; i < std::min(a.size(), b.size()); ++i) worst = std::max(worst, std::fabs(a[i] - b[i]));
  return worst;
}

class SkipWork : public testing::SessionTest {
 protected:
  std::unique_ptr<Object> upload(const Field& field) {
    auto object = offscreen::uploadField(*session, field);
    EXPECT_TRUE(object.ok()) << object.error().message;
    return object.ok() ? std::move(object).value() : nullptr;
  }

  // Records one decompression for `eye` and returns what the decompressor reports.
  DecompressStats decompress(Decompressor& d, const std::array<float, 3>& eye, Object& object) {
    auto submitted = session->harness->submitAndWait([&](VkCommandBuffer cmd) {
      auto recorded = d.record(cmd, eye, {&object});
      EXPECT_TRUE(recorded.ok()) << recorded.error().message;
    });
    EXPECT_TRUE(submitted.ok()) << submitted.error().message;
    return d.lastStats();
  }

  std::vector<float> distortion(const Object& object) {
    auto read = testing::readDistortion(*session->harness, object);
    EXPECT_TRUE(read.ok()) << read.error().message;
    return read.ok() ? std::move(read).value() : std::vector<float>{};
  }

};

TEST_F(SkipWork, SameEyeIsNotDecompressedAgain) {
  testing::SyntheticFieldOptions options;
  options.order = 4;
  options.emptyAndGutters = true;  // a gutter pass too: two dispatches per decompression
  const Field field = testing::makeSyntheticField(options);
  auto object = upload(field);
  ASSERT_TRUE(object);
  auto decompressor = Decompressor::create(*session->context);
  ASSERT_TRUE(decompressor.ok());
  Decompressor& d = *decompressor.value();
  const std::array<float, 3> eyeA{0.3f, 0.8f, 3.0f}, eyeB{-2.5f, -0.4f, 1.0f};

  DecompressStats s = decompress(d, eyeA, *object);
  EXPECT_EQ(s.decompressed, 1u);
  EXPECT_EQ(s.unchanged, 0u);
  EXPECT_EQ(s.dispatches, 2u);
  const std::vector<float> first = distortion(*object);

  s = decompress(d, eyeA, *object);
  EXPECT_EQ(s.decompressed, 0u) << "same eye: nothing to decompress";
  EXPECT_EQ(s.unchanged, 1u);
  EXPECT_EQ(s.dispatches, 0u);
  const std::vector<float> second = distortion(*object);
  EXPECT_EQ(maxDifference(first, second), 0.0f) << "the skipped image must be left as it was";

  // The eye moves: decompressed again, and the image follows the eye.
  s = decompress(d, eyeB, *object);
  EXPECT_EQ(s.decompressed, 1u);
  const std::vector<float> moved = distortion(*object);
  EXPECT_GT(maxDifference(first, moved), 1e-2f) << "the decoded field does not follow the eye";

  // A decompressor that never skips gives the same image for eyeB.
  auto always = Decompressor::create(*session->context);
  ASSERT_TRUE(always.ok());
  always.value()->setSkipUnchanged(false);
  s = decompress(*always.value(), eyeB, *object);
  EXPECT_EQ(s.decompressed, 1u);
  const float noSkipDiff = maxDifference(moved, distortion(*object));
  EXPECT_LE(noSkipDiff, kSameInputsTolerance);

  // The record lives with the object, not the decompressor: back to eyeA is a move too.
  s = decompress(d, eyeA, *object);
  EXPECT_EQ(s.decompressed, 1u);
  EXPECT_LE(maxDifference(first, distortion(*object)), kSameInputsTolerance);

  // invalidateDistortion() forces the next decompression.
  object->invalidateDistortion();
  s = decompress(d, eyeA, *object);
  EXPECT_EQ(s.decompressed, 1u);
  EXPECT_EQ(s.unchanged, 0u);
  std::printf("same eye: 0 dispatches, image unchanged; moved eye: decompressed, max |diff| vs no-skip path %.3g\n",
              double(noSkipDiff));
}

// A Volume field is decoded in texture space by default; traced per fragment it has no image to
// write: the Decompressor leaves it out and says so; switched to its texture-space path, it is decoded again
// (the image was not kept up while unread), then skipped for an unchanged eye as any field.
TEST_F(SkipWork, VolumeTracedPerFragmentIsNotDecompressed) {
  testing::SyntheticFieldOptions options;
  options.encoding = Encoding::Volume;
  options.volumeSize = 24;
  const Field field = testing::makeSyntheticField(options);
  auto object = upload(field);
  ASSERT_TRUE(object);
  EXPECT_FALSE(object->tracesVolumePerFragment()) << "texture space is the default";
  ASSERT_TRUE(object->setTracesVolumePerFragment(true).ok());
  auto decompressor = Decompressor::create(*session->context);
  ASSERT_TRUE(decompressor.ok());
  Decompressor& d = *decompressor.value();
  const std::array<float, 3> eye{0.3f, 0.8f, 3.0f};
  DecompressStats s = decompress(d, eye, *object);
  EXPECT_EQ(s.decompressed, 0u);
  EXPECT_EQ(s.perFragment, 1u);
  EXPECT_EQ(s.dispatches, 0u);
  const std::vector<float> untouched = distortion(*object);
  EXPECT_TRUE(std::all_of(untouched.begin(), untouched.end(), [](float v) { return v == 0.0f; }))
      << "nothing may write the image of a field traced per fragment";
  ASSERT_TRUE(object->setTracesVolumePerFragment(false).ok());
  s = decompress(d, eye, *object);
  EXPECT_EQ(s.decompressed, 1u);
  EXPECT_EQ(s.perFragment, 0u);
  EXPECT_GT(maxDifference(untouched, distortion(*object)), 1e-2f);
  s = decompress(d, eye, *object);
  EXPECT_EQ(s.unchanged, 1u);
  ASSERT_TRUE(object->setTracesVolumePerFragment(true).ok());
  ASSERT_TRUE(object->setTracesVolumePerFragment(false).ok());
  EXPECT_EQ(decompress(d, eye, *object).decompressed, 1u) << "switched back: decoded again";
  // A field of another encoding has no such switch.
  auto sh = upload(testing::makeSyntheticField({}));
  ASSERT_TRUE(sh);
  EXPECT_FALSE(sh->tracesVolumePerFragment());
  EXPECT_EQ(sh->setTracesVolumePerFragment(true).error().code, ErrorCode::InvalidArgument);
}

TEST_F(SkipWork, StaticFramesMatchTheNonSkippingPath) {
  const bake::Image env = bake::proceduralEnvironment(128);
  auto gpuEnv = offscreen::uploadEnvironment(*session, env);
  ASSERT_TRUE(gpuEnv.ok()) << gpuEnv.error().message;
  testing::SyntheticFieldOptions options;
  options.order = 4;
  options.width = 48;
  options.height = 24;
  auto object = upload(testing::makeSyntheticField(options));
  ASSERT_TRUE(object);

  offscreen::FrameSettings frame;
  frame.width = 96;
  frame.height = 72;
  frame.camera.eye = {0.4f, 0.7f, 3.5f};
  frame.mode = ShadingMode::Field;
  frame.frames = 3;
  frame.skipWork = true;
  offscreen::FrameTimings skipping;
  auto skipped = offscreen::renderFrame(*session, *gpuEnv.value(), {object.get()}, frame, &skipping);
  ASSERT_TRUE(skipped.ok()) << skipped.error().message;
  // Frame 1 decompressed; frames 2 and 3 reused its image.
  EXPECT_EQ(skipping.decompress.decompressed, 0u);
  EXPECT_EQ(skipping.decompress.unchanged, 1u);
  EXPECT_EQ(skipping.decompress.dispatches, 0u);
  EXPECT_EQ(skipping.draw.drawn, 1u);

  frame.skipWork = false;
  offscreen::FrameTimings full;
  auto reference = offscreen::renderFrame(*session, *gpuEnv.value(), {object.get()}, frame, &full);
  ASSERT_TRUE(reference.ok()) << reference.error().message;
  EXPECT_EQ(full.decompress.decompressed, 1u) << "the non-skipping path decompresses every frame";
  const float diff = maxDifference(skipped.value().rgba, reference.value().rgba);
  EXPECT_LE(diff, kImageTolerance);
  std::printf("static eye, 3 frames: last frame decompressed %u, max |diff| vs non-skipping path %.3g\n",
              skipping.decompress.decompressed, double(diff));
}

TEST_F(SkipWork, ObjectsOutsideTheViewAreNeitherDecompressedNorDrawn) {
  const bake::Image env = bake::proceduralEnvironment(128);
  auto gpuEnv = offscreen::uploadEnvironment(*session, env);
  ASSERT_TRUE(gpuEnv.ok()) << gpuEnv.error().message;
  testing::SyntheticFieldOptions visible;
  visible.order = 2;
  visible.center = {0.0f, 0.0f, 0.0f};
  testing::SyntheticFieldOptions behind = visible;
  behind.center = {0.0f, 0.0f, 8.0f};  // behind the eye at z = 4, which looks toward -z
  behind.seed = 3;
  testing::SyntheticFieldOptions aside = visible;
  aside.center = {40.0f, 0.0f, 0.0f};  // far to the right, outside a 45 degree view
  aside.seed = 4;
  auto a = upload(testing::makeSyntheticField(visible));
  auto b = upload(testing::makeSyntheticField(behind));
  auto c = upload(testing::makeSyntheticField(aside));
  ASSERT_TRUE(a && b && c);
  const std::vector<Object*> objects{a.get(), b.get(), c.get()};

  offscreen::FrameSettings frame;
  frame.width = 96;
  frame.height = 72;
  frame.camera.eye = {0.0f, 0.0f, 4.0f};
  frame.camera.target = {0.0f, 0.0f, 0.0f};
  frame.camera.verticalFovDegrees = 45.0f;
  frame.mode = ShadingMode::Field;
  frame.skipWork = true;
  offscreen::FrameTimings culled;
  auto withCulling = offscreen::renderFrame(*session, *gpuEnv.value(), objects, frame, &culled);
  ASSERT_TRUE(withCulling.ok()) << withCulling.error().message;
  EXPECT_EQ(culled.decompress.decompressed, 1u);
  EXPECT_EQ(culled.decompress.culled, 2u);
  EXPECT_EQ(culled.decompress.dispatches, 1u) << "one decompression dispatch: the visible object's";
  EXPECT_EQ(culled.draw.drawn, 1u);
  EXPECT_EQ(culled.draw.culled, 2u);

  frame.skipWork = false;  // decompress and draw all three
  offscreen::FrameTimings all;
  auto withoutCulling = offscreen::renderFrame(*session, *gpuEnv.value(), objects, frame, &all);
  ASSERT_TRUE(withoutCulling.ok()) << withoutCulling.error().message;
  EXPECT_EQ(all.decompress.decompressed, 3u);
  EXPECT_EQ(all.draw.drawn, 3u);
  EXPECT_EQ(all.draw.culled, 0u);
  const float diff = maxDifference(withCulling.value().rgba, withoutCulling.value().rgba);
  EXPECT_LE(diff, kImageTolerance) << "culling must not change a pixel";

  // The second render decompressed all three for this eye. Turning the camera toward c from the
  // same eye brings c into view with its image already decoded for the eye: nothing to decompress.
  auto decompressor = Decompressor::create(*session->context);
  ASSERT_TRUE(decompressor.ok());
  Camera toward = frame.camera;
  toward.target = {40.0f, 0.0f, 0.0f};
  auto submitted = session->harness->submitAndWait([&](VkCommandBuffer cmd) {
    auto recorded = decompressor.value()->record(cmd, toward, VkExtent2D{96, 72}, objects);
    EXPECT_TRUE(recorded.ok());
  });
  ASSERT_TRUE(submitted.ok());
  const DecompressStats& turned = decompressor.value()->lastStats();
  EXPECT_EQ(turned.culled, 2u) << "a and b are now outside the view";
  EXPECT_EQ(turned.unchanged, 1u) << "c holds this eye's decompression already";
  EXPECT_EQ(turned.decompressed, 0u);
  std::printf("culling: %u decompressed, %u culled, %u drawn, %u culled from drawing; max |diff| vs no culling %.3g\n",
              culled.decompress.decompressed, culled.decompress.culled, culled.draw.drawn, culled.draw.culled,
              double(diff));
}

TEST_F(SkipWork, ObjectsCrossingTheFrustumAreKept) {
  // Boxes that cross a frustum plane, or contain the eye, are drawn.
  const bake::Image env = bake::proceduralEnvironment(64);
  auto gpuEnv = offscreen::uploadEnvironment(*session, env);
  ASSERT_TRUE(gpuEnv.ok());
  testing::SyntheticFieldOptions edge;
  edge.order = 1;
  edge.center = {1.9f, 0.0f, 0.0f};  // straddles the right plane (half-width 1.66 at distance 4)
  testing::SyntheticFieldOptions around = edge;
  around.center = {0.0f, 0.0f, 4.0f};  // the eye is inside its bounds
  around.radius = 2.0f;
  auto a = upload(testing::makeSyntheticField(edge));
  auto b = upload(testing::makeSyntheticField(around));
  ASSERT_TRUE(a && b);
  offscreen::FrameSettings frame;
  frame.width = 64;
  frame.height = 48;
  frame.camera.eye = {0.0f, 0.0f, 4.0f};
  frame.mode = ShadingMode::Field;
  frame.skipWork = true;
  offscreen::FrameTimings t;
  auto image = offscreen::renderFrame(*session, *gpuEnv.value(), {a.get(), b.get()}, frame, &t);
  ASSERT_TRUE(image.ok()) << image.error().message;
  EXPECT_EQ(t.draw.drawn, 2u);
  EXPECT_EQ(t.draw.culled, 0u);
  EXPECT_EQ(t.decompress.culled, 0u);
}

}  // namespace
}  // namespace shrefract
