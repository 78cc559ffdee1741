// One colour model (docs/scenes.md, "Colour model"): the built-in glass of water, absorption off,
// under a white sky, without the front reflection, rendered in the four modes: exact, full tree and
// single interface on the CPU, single interface and the baked field on the GPU (lavapipe). With
// no absorption and a white environment every transmitted path carries the same colour, so the
// object's mean colour, normalized by its green channel, must be the glass's tint in every mode.
#include <gtest/gtest.h>
#include <shrefract/bake/bake.h>
#include <shrefract/trace/reference_render.h>
#include <shrefract/assets/scene.h>
#include <shrefract/trace/tracer.h>

#include <array>
#include <cstdio>
#include <string>

#include "gpu_test_support.h"
#include "offscreen/offscreen.h"
#include "session_test_support.h"

namespace shrefract {
namespace {

constexpr uint32_t kWidth = 64, kHeight = 48;
// The field's tint is one colour per object (the front medium's, frontMediumColor): where the eye
// sees the water's surface the other modes tint by water instead. From this camera that part is
// small; the bound is what it leaves plus the modes' sampling noise.
constexpr float kChromaTolerance = 0.01f;

using Chroma = std::array<float, 2>;  // mean red / mean green, mean blue / mean green

Chroma chroma(const bake::Image& image, const std::vector<uint8_t>& mask) {
  double sum[3] = {0, 0, 0};
  for (size_t p = 0; p < mask.size(); ++p)
    if (mask[p])
      for (int k = 0; k < 3; ++k) sum[k] += double(image.rgba[p * 4 + size_t(k)]);
  return {float(sum[0] / sum[1]), float(sum[2] / sum[1])};
}

TEST(ColourModel, GlassOfWaterHasOneTintInEveryMode) {
  bake::BuiltinSceneOptions so;
  so.absorptionOverride = 0.0f;
  auto scene = bake::makeBuiltinScene("glass-of-water", so);
  ASSERT_TRUE(scene.ok()) << scene.error().message;
  bake::Image white{64, 32, std::vector<float>(64 * 32 * 4, 1.0f)};
  const Camera camera = offscreen::defaultCamera(scene.value());

  auto tracer = bake::Tracer::create(scene.value());
  ASSERT_TRUE(tracer.ok()) << tracer.error().message;
  std::vector<uint8_t> mask;
  std::vector<std::pair<std::string, Chroma>> modes;
  for (bake::ReferenceMode mode :
       {bake::ReferenceMode::Exact, bake::ReferenceMode::FullTree, bake::ReferenceMode::SingleInterface}) {
    bake::ReferenceOptions ro;
    ro.mode = mode;
    ro.width = kWidth;
    ro.height = kHeight;
    ro.camera = camera;
    ro.reflection = false;
    ro.treeDepth = 6;
    auto image = bake::renderReference(*tracer.value(), scene.value(), white, ro);
    ASSERT_TRUE(image.ok()) << image.error().message;
    if (mask.empty()) mask = image.value().mask;
    const char* names[] = {"exact", "full tree", "single interface (CPU)"};
    modes.push_back({names[int(mode)], chroma(image.value().color, mask)});
  }

  auto session = testing::sessionOrSkip();
  ASSERT_TRUE(session);
  auto env = offscreen::uploadEnvironment(*session, white);
  ASSERT_TRUE(env.ok()) << env.error().message;
  offscreen::FrameSettings frame;
  frame.width = kWidth;
  frame.height = kHeight;
  frame.camera = camera;
  {
    auto objects = offscreen::uploadScene(*session, scene.value());
    ASSERT_TRUE(objects.ok()) << objects.error().message;
    std::vector<Object*> list;
    for (auto& o : objects.value()) {
      o->shading.reflection = false;
      list.push_back(o.get());
    }
    frame.mode = ShadingMode::SingleInterface;
    auto image = offscreen::renderFrame(*session, *env.value(), list, frame);
    ASSERT_TRUE(image.ok()) << image.error().message;
    modes.push_back({"single interface (GPU)", chroma(image.value(), mask)});
  }
  bake::BakeOptions bo;
  bo.settings.order = 2;
  bo.settings.directionsTheta = 8;
  bo.settings.directionsPhi = 16;
  bo.settings.sampleBudget = 6000;
  bo.heldOutDirections = 0;
  auto field = bake::bakeField(scene.value(), bo);
  ASSERT_TRUE(field.ok()) << field.error().message;
  auto object = offscreen::uploadField(*session, field.value());
  ASSERT_TRUE(object.ok()) << object.error().message;
  object.value()->shading.reflection = false;
  frame.mode = ShadingMode::Field;
  auto image = offscreen::renderFrame(*session, *env.value(), {object.value().get()}, frame);
  ASSERT_TRUE(image.ok()) << image.error().message;
  modes.push_back({"field", chroma(image.value(), mask)});
  object.value().reset();
  env.value().reset();
  testing::expectNoMessagesThroughDestruction(session);

  const auto glass = scene.value().media[1].color;
  const Chroma expected{glass.x / glass.y, glass.z / glass.y};
  for (const auto& [name, c] : modes) {
    std::printf("%-24s R/G %.4f  B/G %.4f  (glass tint %.4f %.4f)\n", name.c_str(), double(c[0]), double(c[1]),
                double(expected[0]), double(expected[1]));
    EXPECT_NEAR(c[0], expected[0], kChromaTolerance) << name;
    EXPECT_NEAR(c[1], expected[1], kChromaTolerance) << name;
  }
}

}  // namespace
}  // namespace shrefract
