// The viewer's window-system-free parts: orbit camera math, key actions, and the host-side SH order
// truncation it uses for run-time order changes.
#include <gtest/gtest.h>
#include <shrefract/cpu_reference.h>
#include <shrefract/field.h>

#include <cmath>

#include "engine/synthetic_field.h"
#include "viewer/field_order.h"
#include "viewer/orbit_camera.h"
#include "viewer/view_state.h"

namespace shrefract::viewer {
namespace {

float distance(const std::array<float, 3>& a, const std::array<float, 3>& b) {
  const float dx = a[0] - b[0], dy = a[1] - b[1], dz = a[2] - b[2];
  return std::sqrt(dx * dx + dy * dy + dz * dz);
}

// Float round-off of a few trigonometric calls on values of order 10.
constexpr float kCameraTolerance = 1e-4f;

Camera startCamera() {
  Camera c;
  c.eye = {1.0f, 2.0f, 5.0f};
  c.target = {0.5f, -0.5f, 0.25f};
  c.verticalFovDegrees = 40.0f;
  c.nearPlane = 0.01f;
  c.farPlane = 60.0f;
  return c;
}

TEST(OrbitCamera, StartsAtTheGivenCamera) {
  const Camera start = startCamera();
  const OrbitCamera orbit(start);
  const Camera c = orbit.camera();
  for (size_t k = 0; k < 3; ++k) {
    EXPECT_NEAR(c.eye[k], start.eye[k], kCameraTolerance);
    EXPECT_NEAR(c.target[k], start.target[k], kCameraTolerance);
  }
  EXPECT_NEAR(c.nearPlane, start.nearPlane, 1e-6f);
  EXPECT_NEAR(c.farPlane, start.farPlane, kCameraTolerance);
}

TEST(OrbitCamera, OrbitKeepsDistanceAndTargetAndClampsPitch) {
  OrbitCamera orbit(startCamera());
  const float d0 = orbit.distance();
  orbit.orbit(123.0f, -45.0f, 600.0f);
  Camera c = orbit.camera();
  EXPECT_NEAR(distance(c.eye, c.target), d0, kCameraTolerance);
  EXPECT_NEAR(distance(c.target, startCamera().target), 0.0f, kCameraTolerance);
  // A drag of ten viewport heights would turn far past the pole: pitch stops at the limit.
  orbit.orbit(0.0f, 6000.0f, 600.0f);
  EXPECT_NEAR(orbit.pitchDegrees(), OrbitCamera::kMaxPitchDegrees, 1e-3f);
  orbit.orbit(0.0f, -12000.0f, 600.0f);
  EXPECT_NEAR(orbit.pitchDegrees(), -OrbitCamera::kMaxPitchDegrees, 1e-3f);
  // A horizontal drag across the full height turns by 180 degrees.
  OrbitCamera half(startCamera());
  const float yaw0 = half.yawDegrees();
  half.orbit(-600.0f, 0.0f, 600.0f);
  EXPECT_NEAR(std::fabs(std::remainder(half.yawDegrees() - yaw0, 360.0f)), 180.0f, 1e-2f);
  orbit.reset();
  c = orbit.camera();
  for (size_t k = 0; k < 3; ++k) EXPECT_NEAR(c.eye[k], startCamera().eye[k], kCameraTolerance);
}

TEST(OrbitCamera, PanMovesEyeAndTargetTogetherInTheViewPlane) {
  OrbitCamera orbit(startCamera());
  const Camera before = orbit.camera();
  orbit.pan(40.0f, -25.0f, 500.0f);
  const Camera after = orbit.camera();
  std::array<float, 3> shiftEye{}, shiftTarget{}, forward{};
  for (size_t k = 0; k < 3; ++k) {
    shiftEye[k] = after.eye[k] - before.eye[k];
    shiftTarget[k] = after.target[k] - before.target[k];
    forward[k] = before.target[k] - before.eye[k];
  }
  for (size_t k = 0; k < 3; ++k) EXPECT_NEAR(shiftEye[k], shiftTarget[k], kCameraTolerance);
  const float along = shiftTarget[0] * forward[0] + shiftTarget[1] * forward[1] + shiftTarget[2] * forward[2];
  EXPECT_NEAR(along, 0.0f, kCameraTolerance);  // no motion along the view direction
  // A point at the target's depth follows the cursor: 65 px of 500 at this distance and fov.
  const float expected = std::hypot(40.0f, 25.0f) * 2.0f * orbit.distance() *
                         std::tan(0.5f * 40.0f * 3.14159265f / 180.0f) / 500.0f;
  EXPECT_NEAR(distance(after.target, before.target), expected, kCameraTolerance);
}

TEST(OrbitCamera, ZoomScalesDistanceWithinItsRange) {
  OrbitCamera orbit(startCamera());
  const float d0 = orbit.distance();
  orbit.zoom(2.0f);
  EXPECT_NEAR(orbit.distance(), d0 / (OrbitCamera::kZoomStep * OrbitCamera::kZoomStep), 1e-4f);
  const Camera c = orbit.camera();
  EXPECT_NEAR(c.nearPlane / orbit.distance(), startCamera().nearPlane / d0, 1e-6f);  // planes follow
  orbit.zoom(1000.0f);
  EXPECT_NEAR(orbit.distance(), d0 / OrbitCamera::kZoomRange, 1e-4f);
  orbit.zoom(-2000.0f);
  EXPECT_NEAR(orbit.distance(), d0 * OrbitCamera::kZoomRange, 1e-2f);
}

ViewState twoFields() {
  ViewState s;
  s.fields = {{"a.shrf", 4, "split"}, {"b.shrf", 2, "charts"}};
  s.order = 4;
  s.environmentCount = 3;
  s.mode = ShadingMode::Field;
  return s;
}

TEST(ViewState, OrderStaysBetweenZeroAndTheBakedOrder) {
  ViewState s = twoFields();
  EXPECT_FALSE(apply(s, Action::OrderUp));  // already at the baked order
  for (int i = 0; i < 4; ++i) EXPECT_TRUE(apply(s, Action::OrderDown));
  EXPECT_EQ(s.order, 0u);
  EXPECT_FALSE(apply(s, Action::OrderDown));
  EXPECT_TRUE(apply(s, Action::OrderUp));
  EXPECT_EQ(s.order, 1u);
}

TEST(ViewState, ToggleFieldKeepsTheOrderWhereTheOtherFieldHasIt) {
  ViewState s = twoFields();
  EXPECT_TRUE(apply(s, Action::ToggleField));
  EXPECT_EQ(s.field, 1u);
  EXPECT_EQ(s.order, 2u);  // b was baked at order 2
  EXPECT_TRUE(apply(s, Action::OrderDown));
  EXPECT_TRUE(apply(s, Action::ToggleField));
  EXPECT_EQ(s.field, 0u);
  EXPECT_EQ(s.order, 1u);
  ViewState one = twoFields();
  one.fields.pop_back();
  EXPECT_FALSE(apply(one, Action::ToggleField));
}

TEST(ViewState, InstancesToggleForFieldsOnly) {
  ViewState s = twoFields();
  EXPECT_EQ(s.instances, 1u);
  EXPECT_TRUE(apply(s, Action::ToggleInstances));
  EXPECT_EQ(s.instances, ViewState::kInstances);
  EXPECT_NE(title(s, {"builtin"}, -1.0, -1.0, -1.0).find("3 instances"), std::string::npos);
  EXPECT_TRUE(apply(s, Action::ToggleInstances));
  EXPECT_EQ(s.instances, 1u);
  ViewState scene;
  EXPECT_FALSE(apply(scene, Action::ToggleInstances));
  EXPECT_EQ(actionForCharacter('i'), Action::ToggleInstances);
}

TEST(ViewState, AbsorptionHalvesToZeroAndDoublesBack) {
  ViewState s = twoFields();
  EXPECT_TRUE(apply(s, Action::AbsorptionDown));
  EXPECT_EQ(s.absorption, 0.5f);
  while (s.absorption > 0.0f) ASSERT_TRUE(apply(s, Action::AbsorptionDown));
  EXPECT_FALSE(apply(s, Action::AbsorptionDown));
  EXPECT_TRUE(apply(s, Action::AbsorptionUp));
  EXPECT_EQ(s.absorption, ViewState::kMinAbsorption);
  for (int i = 0; i < 40; ++i) apply(s, Action::AbsorptionUp);
  EXPECT_EQ(s.absorption, ViewState::kMaxAbsorption);
}

TEST(ViewState, EnvironmentsCycleAndScenesStaySingleInterface) {
  ViewState s = twoFields();
  for (size_t expected : {1u, 2u, 0u}) {
    EXPECT_TRUE(apply(s, Action::NextEnvironment));
    EXPECT_EQ(s.environment, expected);
  }
  EXPECT_TRUE(apply(s, Action::ToggleMode));
  EXPECT_EQ(s.mode, ShadingMode::SingleInterface);
  ViewState scene;
  scene.mode = ShadingMode::SingleInterface;
  EXPECT_FALSE(apply(scene, Action::ToggleMode));
  EXPECT_FALSE(apply(scene, Action::OrderUp));
  EXPECT_EQ(scene.mode, ShadingMode::SingleInterface);
  EXPECT_NE(title(scene, {"builtin"}, 1.0, -1.0, 0.5).find("scene | single-interface"), std::string::npos);
}

TEST(ViewState, TapsCycleThroughTheRendererRange) {
  ViewState s;
  EXPECT_EQ(s.environmentTaps, RendererCreateInfo{}.environmentTapsPerAxis);
  EXPECT_EQ(actionForCharacter('t'), Action::NextEnvironmentTaps);
  std::vector<uint32_t> seen;
  for (uint32_t i = 0; i < kMaxEnvironmentTapsPerAxis; ++i) {
    EXPECT_TRUE(apply(s, Action::NextEnvironmentTaps));
    seen.push_back(s.environmentTaps);
    EXPECT_GE(s.environmentTaps, 1u);
    EXPECT_LE(s.environmentTaps, kMaxEnvironmentTapsPerAxis);
  }
  // Every count once, back at the start (default 4: 1, 2, 3, 4).
  EXPECT_EQ(seen, (std::vector<uint32_t>{1, 2, 3, 4}));
  EXPECT_NE(title(s, {"builtin"}, -1.0, -1.0, -1.0).find("taps 4"), std::string::npos);
}

// P switches RendererCreateInfo::refineVolumePaths; the title says when it is off.
TEST(ViewState, PTogglesTheVolumeRefinement) {
  ViewState s;
  EXPECT_EQ(s.refineVolumePaths, RendererCreateInfo{}.refineVolumePaths);
  EXPECT_EQ(actionForCharacter('p'), Action::ToggleVolumeRefinement);
  EXPECT_TRUE(apply(s, Action::ToggleVolumeRefinement));
  EXPECT_FALSE(s.refineVolumePaths);
  EXPECT_NE(title(s, {"builtin"}, -1.0, -1.0, -1.0).find("volume 2x2"), std::string::npos);
  EXPECT_TRUE(apply(s, Action::ToggleVolumeRefinement));
  EXPECT_TRUE(s.refineVolumePaths);
  EXPECT_EQ(title(s, {"builtin"}, -1.0, -1.0, -1.0).find("volume 2x2"), std::string::npos);
}

TEST(ViewState, KeysMapToActionsAndTitleShowsTimings) {
  EXPECT_EQ(actionForCharacter('['), Action::OrderDown);
  EXPECT_EQ(actionForCharacter(']'), Action::OrderUp);
  EXPECT_EQ(actionForCharacter('+'), Action::AbsorptionUp);
  EXPECT_EQ(actionForCharacter('='), Action::AbsorptionUp);
  EXPECT_EQ(actionForCharacter('-'), Action::AbsorptionDown);
  EXPECT_EQ(actionForCharacter('e'), Action::NextEnvironment);
  EXPECT_EQ(actionForCharacter('m'), Action::ToggleMode);
  EXPECT_EQ(actionForCharacter('f'), Action::ToggleField);
  EXPECT_EQ(actionForCharacter('q'), Action::Quit);
  EXPECT_FALSE(actionForCharacter('x').has_value());
  const std::string t = title(twoFields(), {"builtin", "a.exr", "b.exr"}, 16.5, 0.25, 1.5);
  for (const char* part : {"a.shrf [split, F: other]", "field L=4/4", "k=1", "env builtin", "16.50 ms/frame",
                           "GPU decompression 0.250 ms, raster 1.500 ms"})
    EXPECT_NE(t.find(part), std::string::npos) << part << " not in: " << t;
}

class TruncateOrder : public ::testing::TestWithParam<Quantization> {};

TEST_P(TruncateOrder, KeepsTheLowBandsExactly) {
  testing::SyntheticFieldOptions o;
  o.order = 4;
  o.quantization = GetParam();
  o.emptyAndGutters = true;
  const Field field = testing::makeSyntheticField(o);
  ASSERT_TRUE(validateField(field).ok());
  for (uint32_t order = 0; order <= field.order; ++order) {
    auto truncated = truncateOrder(field, order);
    ASSERT_TRUE(truncated.ok()) << truncated.error().message;
    const Field& t = truncated.value();
    ASSERT_TRUE(validateField(t).ok()) << validateField(t).error().message;
    EXPECT_EQ(t.order, order);
    EXPECT_EQ(t.basisCount(), (order + 1) * (order + 1));
    for (uint32_t layer = 0; layer < t.basisCount(); ++layer)
      for (uint64_t texel = 0; texel < t.texelCount(); texel += 7)
        for (uint32_t c = 0; c < t.channels; ++c)
          ASSERT_EQ(fieldCoefficient(t, layer, texel, c), fieldCoefficient(field, layer, texel, c));
    EXPECT_EQ(t.gutters.size(), field.gutters.size());
    EXPECT_EQ(t.mesh.indices, field.mesh.indices);
  }
  // At the full order the decoded texels are the original ones, bit for bit.
  auto full = truncateOrder(field, field.order);
  ASSERT_TRUE(full.ok());
  const reference::Vec3 eye{0.3f, 0.8f, 3.0f};
  for (uint64_t texel = 0; texel < field.texelCount(); texel += 5)
    EXPECT_EQ(reference::decodeTexel(full.value(), texel, eye), reference::decodeTexel(field, texel, eye));
  auto raised = truncateOrder(field, field.order + 1);
  ASSERT_FALSE(raised.ok());
  EXPECT_EQ(raised.error().code, ErrorCode::InvalidArgument);
}

INSTANTIATE_TEST_SUITE_P(BothQuantizations, TruncateOrder, ::testing::Values(Quantization::U8, Quantization::F16));

// A field with the throughput channel keeps it (5 channels), and other encodings have no order.
TEST(TruncateOrderEncodings, KeepsThroughputAndRefusesOtherEncodings) {
  testing::SyntheticFieldOptions o;
  o.order = 3;
  o.throughput = true;
  o.channels = 5;
  const Field field = testing::makeSyntheticField(o);
  ASSERT_TRUE(validateField(field).ok()) << validateField(field).error().message;
  auto truncated = truncateOrder(field, 1);
  ASSERT_TRUE(truncated.ok()) << truncated.error().message;
  EXPECT_TRUE(truncated.value().throughput);
  EXPECT_TRUE(validateField(truncated.value()).ok()) << validateField(truncated.value()).error().message;

  testing::SyntheticFieldOptions t;
  t.order = 0;
  t.encoding = Encoding::Table;
  const Field table = testing::makeSyntheticField(t);
  ASSERT_TRUE(validateField(table).ok()) << validateField(table).error().message;
  auto refused = truncateOrder(table, 0);
  ASSERT_FALSE(refused.ok());
  EXPECT_EQ(refused.error().code, ErrorCode::InvalidArgument);
}

}  // namespace
}  // namespace shrefract::viewer
