// `shrefract view` end to end: the real binary under xvfb-run on lavapipe (a real X11 surface and
// swapchain), with --frames/--screenshot. Its screenshots are compared with the same frame drawn
// through the offscreen path in this process, and with the background alone, so a blank, wrongly
// framed or stale image fails. Every run must end with zero validation messages.
//
// Skips (exit 77, with a line saying why) when xvfb-run is missing or no Vulkan device exists.
// Inputs (environment, set by tests/CMakeLists.txt): SHREFRACT_TOOL, SHREFRACT_VIEWER_WORK_DIR.
#include <gtest/gtest.h>
#include <shrefract/assets/image.h>
#include <shrefract/assets/scene.h>
#include <shrefract/field.h>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <string>

#include "gpu_test_support.h"
#include "offscreen/offscreen.h"
#include "session_test_support.h"
#include "viewer/run_command.h"

namespace shrefract::testing {
namespace {

namespace fs = std::filesystem;

// The viewer writes its float target as 8-bit sRGB PNG: decoding that back costs at most half a
// step, below 0.005 in linear units over [0, 1]. Same device, same engine passes and same camera
// as the in-process reference, so anything beyond quantization is a real difference.
constexpr float kSameImageTolerance = 0.02f;
// Fraction of pixels allowed beyond it (none expected; a margin for rasterization tie-breaks).
constexpr double kSameImageOutliers = 0.005;
// "Differs from the background": a change that no quantization or filtering explains.
constexpr float kObjectDifference = 0.05f;

struct Paths {
  std::string tool;
  fs::path work;
};

Paths& paths() {
  static Paths p;
  return p;
}

std::string tool() { return shellQuote(paths().tool); }
std::string at(const char* name) { return (paths().work / name).string(); }

// Runs `shrefract view ARGS` under xvfb-run (-a picks a free display number). Debian's xvfb-run
// removes its temporary directory before it stops Xvfb, and that `rm -r` now and then fails: it
// then prints the line below and exits 5 in place of the command's status (seen once in CI-like
// runs, on the bad-flag case). That run says nothing about the viewer, so it is run again, at
// most twice.
CommandResult view(const std::string& args) {
  constexpr const char* kXvfbCleanupError = "xvfb-run: error: problem while cleaning up temporary directory";
  CommandResult r;
  for (int attempt = 0; attempt < 3; ++attempt) {
    r = runCommand("xvfb-run -a " + tool() + " view " + args);
    if (!(r.exitCode == 5 && r.output.find(kXvfbCleanupError) != std::string::npos)) break;
  }
  return r;
}

void expectCleanRun(const CommandResult& r) {
  EXPECT_EQ(r.exitCode, 0) << r.output;
  EXPECT_NE(r.output.find("0 validation messages"), std::string::npos) << r.output;
  EXPECT_EQ(r.output.find("[vulkan validation]"), std::string::npos) << r.output;
}

float channelDifference(const bake::Image& a, const bake::Image& b, size_t pixel) {
  float d = 0.0f;
  for (size_t c = 0; c < 3; ++c)
    d = std::max(d, std::fabs(std::clamp(a.rgba[pixel * 4 + c], 0.0f, 1.0f) - std::clamp(b.rgba[pixel * 4 + c], 0.0f, 1.0f)));
  return d;
}

// Fraction of pixels whose RGB (clamped to [0, 1]: what PNG keeps) differs by more than `tolerance`.
double fractionDifferent(const bake::Image& a, const bake::Image& b, float tolerance) {
  size_t count = 0;
  const size_t pixels = size_t(a.width) * a.height;
  for (size_t p = 0; p < pixels; ++p)
    if (channelDifference(a, b, p) > tolerance) ++count;
  return double(count) / double(pixels);
}

// The same statistic over a rectangle [x0, x1) x [y0, y1).
double fractionDifferentIn(const bake::Image& a, const bake::Image& b, float tolerance, uint32_t x0, uint32_t y0,
                           uint32_t x1, uint32_t y1) {
  size_t count = 0, total = 0;
  for (uint32_t y = y0; y < y1; ++y)
    for (uint32_t x = x0; x < x1; ++x, ++total)
      if (channelDifference(a, b, size_t(y) * a.width + x) > tolerance) ++count;
  return double(count) / double(std::max<size_t>(total, 1));
}

class ViewerTest : public ::testing::Test {
 protected:
  static void SetUpTestSuite() {
    const char* toolPath = std::getenv("SHREFRACT_TOOL");
    ASSERT_NE(toolPath, nullptr) << "SHREFRACT_TOOL is not set (tests/CMakeLists.txt sets it)";
    paths().tool = toolPath;
    if (!onPath("xvfb-run")) {
      std::fprintf(stderr, "SKIPPED: xvfb-run is not installed (Debian: xvfb and xauth; scripts/setup-debian.sh "
                           "installs them), so the viewer cannot open a window here\n");
      std::fflush(stderr);
      std::exit(kSkipCode);
    }
    auto created = testing::sessionOrSkip();
    if (!created) FAIL() << "no offscreen session";
    session_ = created.release();

    const char* work = std::getenv("SHREFRACT_VIEWER_WORK_DIR");
    paths().work = work ? fs::path(work) : fs::temp_directory_path() / "shrefract_viewer_test";
    fs::remove_all(paths().work);
    fs::create_directories(paths().work);
    // Tiny fields of the same sphere in both layouts (seconds to bake). Fitted by least squares:
    // its ringing is what makes one environment tap and four draw visibly apart at this size (the
    // robust fit's exits are smooth enough that 0.45 % of the pixels differ, under the taps test's
    // 1 %).
    for (const char* layout : {"split", "charts"}) {
      const std::string out = at(std::string(layout) == "split" ? "tiny.shrf" : "tiny_charts.shrf");
      const CommandResult bake = runCommand(tool() + " bake builtin:sphere -o " + shellQuote(out) + " --layout " +
                                            layout +
                                            " --order 2 --sh-fit least-squares --directions 8x16 --samples 300"
                                            " --tessellation 1 --threads 2 --held-out 0");
      ASSERT_EQ(bake.exitCode, 0) << bake.output;
    }
  }

  static void TearDownTestSuite() {
    if (session_) {
      const uint32_t messages = session_->harness->messageCount();
      EXPECT_EQ(messages, 0u) << "the in-process reference renders reported validation messages";
      delete session_;
      session_ = nullptr;
    }
  }

  // The frame the viewer shows first for `field`: its default camera (the mesh bounds framed with a
  // 40 degree field of view), drawn in `mode` (or only the background when `withObject` is false)
  // with `taps` taps per axis of each environment lookup and `msaa` samples per pixel (resolved).
  static bake::Image reference(const Field& field, const bake::Image& environment, ShadingMode mode, float absorption,
                               uint32_t width, uint32_t height, bool withObject = true,
                               uint32_t taps = RendererCreateInfo{}.environmentTapsPerAxis,
                               VkSampleCountFlagBits msaa = VK_SAMPLE_COUNT_1_BIT) {
    auto env = offscreen::uploadEnvironment(*session_, environment);
    EXPECT_TRUE(env.ok());
    auto object = offscreen::uploadField(*session_, field);
    EXPECT_TRUE(object.ok());
    if (!env.ok() || !object.ok()) return {};
    object.value()->shading.absorptionScale = absorption;
    offscreen::FrameSettings frame;
    frame.width = width;
    frame.height = height;
    std::array<float, 3> lo{}, hi{};
    offscreen::meshBounds(field.mesh, lo, hi);
    frame.camera = offscreen::frameBounds(lo, hi, 40.0f);
    frame.mode = mode;
    frame.environmentTapsPerAxis = taps;
    frame.msaaSamples = msaa;
    std::vector<Object*> objects;
    if (withObject) objects.push_back(object.value().get());
    auto image = offscreen::renderFrame(*session_, *env.value(), objects, frame);
    EXPECT_TRUE(image.ok()) << (image.ok() ? "" : image.error().message);
    return image.ok() ? std::move(image).value() : bake::Image{};
  }

  static Field readOrFail(const char* name) {
    auto field = readField(at(name));
    EXPECT_TRUE(field.ok()) << (field.ok() ? "" : field.error().message);
    return field.ok() ? std::move(field).value() : Field{};
  }

  static offscreen::Session* session_;
};

offscreen::Session* ViewerTest::session_ = nullptr;

TEST_F(ViewerTest, ScreenshotIsTheFieldOverItsEnvironment) {
  const uint32_t width = 160, height = 120;
  const CommandResult r =
      view(shellQuote(at("tiny.shrf")) + " --frames 5 --screenshot " + shellQuote(at("shot.png")) + " --size 160x120");
  expectCleanRun(r);
  EXPECT_NE(r.output.find("5 frames"), std::string::npos) << r.output;
  EXPECT_NE(r.output.find("GPU decompression"), std::string::npos) << "timings missing from the title: " << r.output;
  auto shot = bake::loadImage(at("shot.png"));
  ASSERT_TRUE(shot.ok()) << shot.error().message;
  ASSERT_EQ(shot->width, width);
  ASSERT_EQ(shot->height, height);

  const Field field = readOrFail("tiny.shrf");
  const bake::Image env = bake::proceduralEnvironment(1024);  // what --env builtin loads
  const bake::Image expected = reference(field, env, ShadingMode::Field, 1.0f, width, height);
  const bake::Image background = reference(field, env, ShadingMode::Field, 1.0f, width, height, false);
  ASSERT_EQ(expected.width, width);

  // The viewer draws what the offscreen path draws for the same camera.
  EXPECT_LE(fractionDifferent(shot.value(), expected, kSameImageTolerance), kSameImageOutliers);
  // The object is there: most of the centre differs from the background alone, the corners do not.
  const double centre = fractionDifferentIn(shot.value(), background, kObjectDifference, width * 2 / 5, height * 2 / 5,
                                            width * 3 / 5, height * 3 / 5);
  EXPECT_GT(centre, 0.5) << "the centre of the screenshot looks like the background: no object drawn";
  for (auto [x, y] : {std::pair<uint32_t, uint32_t>{0, 0}, {width - 8, 0}, {0, height - 8}, {width - 8, height - 8}})
    EXPECT_LE(fractionDifferentIn(shot.value(), background, kSameImageTolerance, x, y, x + 8, y + 8), 0.0)
        << "corner at " << x << "," << y << " differs from the background";
  // And the background itself is not blank.
  EXPECT_GT(fractionDifferentIn(background, bake::Image{width, height, std::vector<float>(size_t(width) * height * 4, 0.0f)},
                                kObjectDifference, 0, 0, width, height),
            0.9);
}

TEST_F(ViewerTest, KeysChangeOrderFieldAbsorptionEnvironmentAndMode) {
  // A second environment as a file: the procedural one, tinted, as a half-float EXR.
  bake::Image tinted = bake::proceduralEnvironment(128);
  for (size_t i = 0; i < tinted.rgba.size(); i += 4) tinted.rgba[i + 1] *= 0.5f;
  ASSERT_TRUE(bake::writeImage(at("tinted.exr"), tinted).ok());

  // Per frame: [ order 1, f the charts field, ] order 2, - absorption 0.5, e the next environment
  // (builtin, after --env tinted.exr), m single-interface, m back to field; then three plain frames.
  const CommandResult r = view(shellQuote(at("tiny.shrf")) + " --field2 " + shellQuote(at("tiny_charts.shrf")) +
                               " --env " + shellQuote(at("tinted.exr")) + " --keys '[f]-emm' --frames 10" +
                               " --screenshot " + shellQuote(at("keys.png")) + " --size 96x64");
  expectCleanRun(r);
  for (const char* part : {"tiny_charts.shrf [charts", "field L=2/2", "k=0.5", "env builtin", "GPU decompression"})
    EXPECT_NE(r.output.find(part), std::string::npos) << part << " not in the last title: " << r.output;

  // The last frame is the charts field at absorption 0.5 over the built-in environment, framed by
  // the first field's camera (both are the same sphere).
  auto shot = bake::loadImage(at("keys.png"));
  ASSERT_TRUE(shot.ok()) << shot.error().message;
  const Field split = readOrFail("tiny.shrf");
  Field charts = readOrFail("tiny_charts.shrf");
  std::array<float, 3> lo{}, hi{}, clo{}, chi{};
  offscreen::meshBounds(split.mesh, lo, hi);
  offscreen::meshBounds(charts.mesh, clo, chi);
  for (size_t k = 0; k < 3; ++k) ASSERT_NEAR(lo[k], clo[k], 1e-6f) << "the two fields frame differently";
  const bake::Image env = bake::proceduralEnvironment(1024);
  const bake::Image expected = reference(charts, env, ShadingMode::Field, 0.5f, 96, 64);
  EXPECT_LE(fractionDifferent(shot.value(), expected, kSameImageTolerance), kSameImageOutliers);
  // Absorption 0.5 is visibly not absorption 1 (so the key did reach the object).
  const bake::Image absorbing = reference(charts, env, ShadingMode::Field, 1.0f, 96, 64);
  EXPECT_GT(fractionDifferent(expected, absorbing, kSameImageTolerance), 0.01);
}

TEST_F(ViewerTest, TapsKeyAndFlagSetTheEnvironmentTaps) {
  // T, one press per frame: 4 -> 1 -> 2 -> 3 -> 4 -> 1 taps per axis, each press a new renderer
  // while earlier frames may still be in flight; the last frames draw with one tap, as --env-taps 1 does.
  const uint32_t width = 160, height = 120;
  const CommandResult keys = view(shellQuote(at("tiny.shrf")) + " --keys ttttt --frames 7 --screenshot " +
                                  shellQuote(at("taps_keys.png")) + " --size 160x120");
  expectCleanRun(keys);
  EXPECT_NE(keys.output.find("taps 1"), std::string::npos) << keys.output;
  const CommandResult flag = view(shellQuote(at("tiny.shrf")) + " --env-taps 1 --frames 2 --screenshot " +
                                  shellQuote(at("taps_flag.png")) + " --size 160x120");
  expectCleanRun(flag);
  EXPECT_NE(flag.output.find("taps 1"), std::string::npos) << flag.output;
  auto byKeys = bake::loadImage(at("taps_keys.png"));
  auto byFlag = bake::loadImage(at("taps_flag.png"));
  ASSERT_TRUE(byKeys.ok() && byFlag.ok());
  const Field field = readOrFail("tiny.shrf");
  const bake::Image env = bake::proceduralEnvironment(1024);
  const bake::Image one = reference(field, env, ShadingMode::Field, 1.0f, width, height, true, 1);
  // Against the default count, which a key or flag that did not arrive would leave.
  const uint32_t defaultTaps = RendererCreateInfo{}.environmentTapsPerAxis;
  const bake::Image byDefault = reference(field, env, ShadingMode::Field, 1.0f, width, height, true, defaultTaps);
  const double oneVsDefault = fractionDifferent(one, byDefault, kSameImageTolerance);
  std::printf("one tap against %u: %.4f of the pixels differ by more than %.2f\n", defaultTaps, oneVsDefault,
              double(kSameImageTolerance));
  ASSERT_GT(oneVsDefault, 2 * kSameImageOutliers) << "the tap counts draw alike here: the test would not see the key";
  EXPECT_LE(fractionDifferent(byKeys.value(), one, kSameImageTolerance), kSameImageOutliers);
  EXPECT_LE(fractionDifferent(byFlag.value(), one, kSameImageTolerance), kSameImageOutliers);
}

TEST_F(ViewerTest, MsaaFlagResolvesTheFrame) {
  // --msaa 4: the viewer's own multisampled targets, resolved before the screenshot, as the
  // offscreen library's 4x frame; the 1-sample frame differs from it on the silhouette (small
  // frame: the silhouette is then a larger share of the pixels, 1% at 160x120).
  const uint32_t width = 96, height = 72;
  const CommandResult r = view(shellQuote(at("tiny.shrf")) + " --msaa 4 --frames 2 --screenshot " +
                               shellQuote(at("msaa.png")) + " --size 96x72");
  expectCleanRun(r);
  auto shot = bake::loadImage(at("msaa.png"));
  ASSERT_TRUE(shot.ok());
  const Field field = readOrFail("tiny.shrf");
  const bake::Image env = bake::proceduralEnvironment(1024);
  const uint32_t taps = RendererCreateInfo{}.environmentTapsPerAxis;
  const bake::Image single = reference(field, env, ShadingMode::Field, 1.0f, width, height, true, taps);
  const bake::Image four = reference(field, env, ShadingMode::Field, 1.0f, width, height, true, taps, VK_SAMPLE_COUNT_4_BIT);
  const double apart = fractionDifferent(single, four, kSameImageTolerance);
  std::printf("1 against 4 samples per pixel: %.4f of the pixels differ by more than %.2f\n", apart,
              double(kSameImageTolerance));
  ASSERT_GT(apart, 2 * kSameImageOutliers) << "MSAA draws like one sample here: the test would not see the flag";
  EXPECT_LE(fractionDifferent(shot.value(), four, kSameImageTolerance), kSameImageOutliers);
}

TEST_F(ViewerTest, LowerOrdersAreUploadedAtRunTime) {
  // Down to order 0 and back up, one key per frame: each change builds a new engine object in the
  // frame's own command buffer while older frames may still use the previous one.
  const CommandResult r = view(shellQuote(at("tiny.shrf")) + " --keys '[[]]' --frames 6 --screenshot " +
                               shellQuote(at("orders.png")) + " --size 64x48");
  expectCleanRun(r);
  EXPECT_NE(r.output.find("field L=2/2"), std::string::npos) << r.output;
  const CommandResult low = view(shellQuote(at("tiny.shrf")) + " --order 0 --frames 2 --screenshot " +
                                 shellQuote(at("order0.png")) + " --size 64x48");
  expectCleanRun(low);
  EXPECT_NE(low.output.find("field L=0/2"), std::string::npos) << low.output;
  auto full = bake::loadImage(at("orders.png"));
  auto zero = bake::loadImage(at("order0.png"));
  ASSERT_TRUE(full.ok() && zero.ok());
  // Order 0 is a constant exit direction per texel: a different picture from order 2.
  EXPECT_GT(fractionDifferent(full.value(), zero.value(), kObjectDifference), 0.02);
}

TEST_F(ViewerTest, InstancesAreDrawnBesideTheField) {
  // I: two more instances of the field beside it; [ then rebuilds the field object at order 1 and
  // its instances with it, while earlier frames may still use the old ones.
  const CommandResult one = view(shellQuote(at("tiny.shrf")) + " --frames 2 --screenshot " +
                                 shellQuote(at("one.png")) + " --size 96x48 --fov 70");
  expectCleanRun(one);
  const CommandResult three = view(shellQuote(at("tiny.shrf")) + " --keys 'i[' --frames 4 --screenshot " +
                                   shellQuote(at("three.png")) + " --size 96x48 --fov 70");
  expectCleanRun(three);
  EXPECT_NE(three.output.find("3 instances"), std::string::npos) << three.output;
  auto a = bake::loadImage(at("one.png"));
  auto b = bake::loadImage(at("three.png"));
  ASSERT_TRUE(a.ok() && b.ok());
  // The instances stand where the single field showed only the environment.
  EXPECT_GT(fractionDifferent(a.value(), b.value(), kObjectDifference), 0.05);
}

TEST_F(ViewerTest, SceneIsShownSingleInterface) {
  const CommandResult r = view("builtin:sphere --tessellation 1 --keys m --frames 3 --screenshot " +
                               shellQuote(at("scene.png")) + " --size 96x64");
  expectCleanRun(r);
  EXPECT_NE(r.output.find("scene | single-interface"), std::string::npos) << r.output;
  auto shot = bake::loadImage(at("scene.png"));
  ASSERT_TRUE(shot.ok()) << shot.error().message;
  ASSERT_EQ(shot->width, 96u);
  ASSERT_EQ(shot->height, 64u);

  // The same scene through the offscreen path: its default camera, single-interface glass.
  bake::BuiltinSceneOptions sceneOptions;
  sceneOptions.tessellation = 1;
  auto scene = bake::makeBuiltinScene("sphere", sceneOptions);
  ASSERT_TRUE(scene.ok()) << scene.error().message;
  auto env = offscreen::uploadEnvironment(*session_, bake::proceduralEnvironment(1024));
  auto objects = offscreen::uploadScene(*session_, scene.value());
  ASSERT_TRUE(env.ok() && objects.ok());
  offscreen::FrameSettings frame;
  frame.width = 96;
  frame.height = 64;
  frame.camera = offscreen::defaultCamera(scene.value(), 40.0f);
  frame.mode = ShadingMode::SingleInterface;
  std::vector<Object*> drawList;
  for (auto& o : objects.value()) drawList.push_back(o.get());
  auto expected = offscreen::renderFrame(*session_, *env.value(), drawList, frame);
  auto background = offscreen::renderFrame(*session_, *env.value(), {}, frame);
  ASSERT_TRUE(expected.ok() && background.ok());
  EXPECT_LE(fractionDifferent(shot.value(), expected.value(), kSameImageTolerance), kSameImageOutliers);
  EXPECT_GT(fractionDifferentIn(shot.value(), background.value(), kObjectDifference, 38, 26, 58, 38), 0.5)
      << "the centre of the screenshot looks like the background: no object drawn";
}

TEST_F(ViewerTest, ErrorsAreOneLineWithNonZeroExit) {
  // No display: the window cannot open.
  CommandResult r = runCommand("env -u DISPLAY -u WAYLAND_DISPLAY " + tool() + " view " + shellQuote(at("tiny.shrf")) +
                               " --frames 1");
  EXPECT_EQ(r.exitCode, 1) << r.output;
  EXPECT_EQ(nonEmptyLines(r.output), 1) << r.output;
  EXPECT_NE(r.output.find("cannot open a window"), std::string::npos) << r.output;
  r = runCommand(tool() + " view " + shellQuote(at("missing.shrf")));
  EXPECT_EQ(r.exitCode, 1) << r.output;
  EXPECT_EQ(nonEmptyLines(r.output), 1) << r.output;
  EXPECT_NE(r.output.find("missing.shrf"), std::string::npos) << r.output;
  r = runCommand(tool() + " view " + shellQuote(at("tiny.shrf")) + " --env-taps 5");
  EXPECT_EQ(r.exitCode, 2) << r.output;
  EXPECT_NE(r.output.find("--env-taps"), std::string::npos) << r.output;
  r = runCommand(tool() + " view " + shellQuote(at("tiny.shrf")) + " --msaa 3");
  EXPECT_EQ(r.exitCode, 2) << r.output;
  EXPECT_EQ(nonEmptyLines(r.output), 1) << r.output;
  EXPECT_NE(r.output.find("--msaa"), std::string::npos) << r.output;
  // A count the device lacks (lavapipe offers 1 and 4; a GPU may offer 8, and then it runs).
  r = view(shellQuote(at("tiny.shrf")) + " --msaa 8 --frames 1");
  if (r.exitCode != 0) {
    EXPECT_EQ(r.exitCode, 2) << r.output;
    EXPECT_NE(r.output.find("--msaa 8"), std::string::npos) << r.output;
  }
  r = runCommand(tool() + " view " + shellQuote(at("tiny.shrf")) + " --keys x");
  EXPECT_EQ(r.exitCode, 2) << r.output;
  EXPECT_EQ(nonEmptyLines(r.output), 1) << r.output;
  r = runCommand(tool() + " view builtin:sphere --mode field");
  EXPECT_EQ(r.exitCode, 2) << r.output;
  r = runCommand(tool() + " view " + shellQuote(at("tiny.shrf")) + " --screenshot out.jpg");
  EXPECT_EQ(r.exitCode, 2) << r.output;
  // A device the machine does not have names the flag, as render does.
  r = view("builtin:sphere --tessellation 1 --frames 1 --device 1024");
  EXPECT_EQ(r.exitCode, 2) << r.output;
  EXPECT_EQ(nonEmptyLines(r.output), 1) << r.output;
  EXPECT_NE(r.output.find("--device 1024"), std::string::npos) << r.output;
}

}  // namespace
}  // namespace shrefract::testing
