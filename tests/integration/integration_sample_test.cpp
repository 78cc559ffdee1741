// samples/integration against the installed package, as a game engine would build it: install this
// build into a temporary prefix, configure and build the sample with find_package(shrefract), run
// it with and without the glass, and check its images:
//  - the red box in front of the glass is exactly the same in both (the glass is depth-tested
//    against it and loses);
//  - the green box behind the glass is partly covered by the glass and partly visible around it;
//  - the glass region differs from the background it refracts, and nothing outside it changes.
// Zero validation messages in both runs (the sample exits 1 otherwise), and in two runs that fail
// part-way. Skips (77) without a device.
#include <gtest/gtest.h>

#include <algorithm>
#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <string>
#include <vector>

#include "gpu_test_support.h"
#include "viewer/run_command.h"

namespace shrefract::testing {
namespace {

namespace fs = std::filesystem;

struct Ppm {
  uint32_t width = 0, height = 0;
  std::vector<uint8_t> rgb;
  const uint8_t* at(uint32_t x, uint32_t y) const { return &rgb[(size_t(y) * width + x) * 3]; }
};

// Binary PPM (P6, maxval 255) as the sample writes it: header tokens separated by single spaces
// or newlines, no comments.
Ppm readPpm(const fs::path& path) {
  Ppm image;
  std::ifstream in(path, std::ios::binary);
  std::string magic;
  unsigned maxval = 0;
  in >> magic >> image.width >> image.height >> maxval;
  in.get();  // the single whitespace after maxval
  if (!in || magic != "P6" || maxval != 255) return Ppm{};
  image.rgb.resize(size_t(image.width) * image.height * 3);
  in.read(reinterpret_cast<char*>(image.rgb.data()), static_cast<std::streamsize>(image.rgb.size()));
  if (!in) return Ppm{};
  return image;
}

// Box colours after flat shading (brightness 0.6..1.0) and sRGB encoding: red is about (190..235,
// 70..80, 60..70), green about (75..80, 180..225, 95..100). Nothing in the sample's environment
// (blue sky, grey ground) comes close, so a ratio of two is a safe classification.
bool isRed(const uint8_t* p) { return p[0] >= 100 && p[0] > 2 * p[1] && p[0] > 2 * p[2]; }
bool isGreen(const uint8_t* p) { return p[1] >= 100 && p[1] > 2 * p[0] && p[1] > 2 * p[2]; }
int difference(const uint8_t* a, const uint8_t* b) {
  return std::abs(a[0] - b[0]) + std::abs(a[1] - b[1]) + std::abs(a[2] - b[2]);
}

TEST(IntegrationSample, BuildsAgainstTheInstalledPackageAndDrawsGlassBetweenBoxes) {
  {
    auto probe = harnessOrSkip();  // exits 77 when no Vulkan device exists
    ASSERT_NE(probe, nullptr);
  }
  const fs::path work = SHREFRACT_INTEGRATION_WORK_DIR;
  fs::remove_all(work);
  fs::create_directories(work);
  const std::string cmake = shellQuote(SHREFRACT_CMAKE_COMMAND);
  const fs::path prefix = work / "prefix", build = work / "build";

  CommandResult r = runCommand(cmake + " --install " + shellQuote(SHREFRACT_BUILD_DIR) + " --prefix " +
                               shellQuote(prefix.string()));
  ASSERT_EQ(r.exitCode, 0) << "install failed:\n" << r.output;
  // The parent build's compiler and flags, so that the sample links with the installed static
  // library however it was built (e.g. the sanitizers preset).
  r = runCommand(cmake + " -S " + shellQuote(SHREFRACT_INTEGRATION_SOURCE_DIR) + " -B " + shellQuote(build.string()) +
                 " -G " + shellQuote(SHREFRACT_CMAKE_GENERATOR) + " -DCMAKE_BUILD_TYPE=Release" +
                 " -DCMAKE_PREFIX_PATH=" + shellQuote(prefix.string()) +
                 " -DCMAKE_CXX_COMPILER=" + shellQuote(SHREFRACT_CXX_COMPILER) +
                 " -DCMAKE_CXX_FLAGS=" + shellQuote(SHREFRACT_CXX_FLAGS) +
                 " -DCMAKE_EXE_LINKER_FLAGS=" + shellQuote(SHREFRACT_EXE_LINKER_FLAGS));
  ASSERT_EQ(r.exitCode, 0) << "configuring samples/integration failed:\n" << r.output;
  r = runCommand(cmake + " --build " + shellQuote(build.string()));
  ASSERT_EQ(r.exitCode, 0) << "building samples/integration failed:\n" << r.output;

  const std::string sample = shellQuote((build / "shrefract_integration").string());
  const fs::path withGlass = work / "glass.ppm", without = work / "no_glass.ppm";
  for (const auto& [args, image] : {std::pair<std::string, fs::path>{"", withGlass}, {" --no-glass", without}}) {
    r = runCommand(sample + " " + shellQuote(image.string()) + args);
    if (r.exitCode == kSkipCode) {
      std::fprintf(stderr, "SKIPPED: no Vulkan device for the sample: %s\n", r.output.c_str());
      std::exit(kSkipCode);
    }
    ASSERT_EQ(r.exitCode, 0) << r.output;
    EXPECT_NE(r.output.find("0 validation messages"), std::string::npos) << r.output;
    EXPECT_EQ(r.output.find("[vulkan validation]"), std::string::npos) << r.output;
  }

  // A step that fails part-way (the field file is missing; the output cannot be written, after the
  // frames) exits 1 with one line naming it, and everything created before it is destroyed: no
  // validation message (the layer reports objects left to vkDestroyDevice as leaks).
  const std::string missingField = (work / "missing.shrf").string();
  const std::string unwritable = (work / "no_such_folder" / "out.ppm").string();
  for (const auto& [args, named] : {std::pair<std::string, std::string>{shellQuote((work / "x.ppm").string()) +
                                                                             " --field " + shellQuote(missingField),
                                                                         missingField},
                                    {shellQuote(unwritable), unwritable}}) {
    r = runCommand(sample + " " + args);
    EXPECT_EQ(r.exitCode, 1) << r.output;
    EXPECT_NE(r.output.find(named), std::string::npos) << r.output;
    EXPECT_EQ(r.output.find("[vulkan validation]"), std::string::npos) << r.output;
    EXPECT_EQ(std::count(r.output.begin(), r.output.end(), '\n'), 1) << r.output;
  }
  EXPECT_FALSE(fs::exists(work / "x.ppm"));

  const Ppm glass = readPpm(withGlass), plain = readPpm(without);
  ASSERT_EQ(glass.width, 320u) << "unreadable or wrongly sized " << withGlass;
  ASSERT_EQ(glass.height, 240u);
  ASSERT_EQ(plain.width, glass.width);
  ASSERT_EQ(plain.height, glass.height);

  size_t redPlain = 0, redGlass = 0, redChanged = 0, greenPlain = 0, greenGlass = 0, changed = 0;
  for (uint32_t y = 0; y < glass.height; ++y)
    for (uint32_t x = 0; x < glass.width; ++x) {
      const uint8_t* g = glass.at(x, y);
      const uint8_t* p = plain.at(x, y);
      if (isRed(p)) {
        ++redPlain;
        if (difference(g, p) > 3) ++redChanged;  // 3: one step per channel of rounding
      }
      redGlass += isRed(g);
      greenPlain += isGreen(p);
      greenGlass += isGreen(g);
      changed += difference(g, p) > 24;  // 24: well beyond rounding, clearly a different colour
    }
  const size_t pixels = size_t(glass.width) * glass.height;
  // The front box: thousands of pixels, untouched by the glass behind it.
  EXPECT_GT(redPlain, 2000u);
  EXPECT_EQ(redChanged, 0u) << "the glass was drawn over the box in front of it (depth interplay)";
  EXPECT_EQ(redGlass, redPlain);
  // The back box: partly behind the glass (covered), partly beside it (still visible).
  EXPECT_GT(greenPlain, 1500u);
  EXPECT_LT(greenGlass, greenPlain * 9 / 10) << "the glass does not cover the box behind it";
  EXPECT_GT(greenGlass, greenPlain / 5) << "the box behind the glass vanished entirely";
  // The glass region (about 17% of the frame, less what the red box hides) changes; its centre does.
  EXPECT_GT(double(changed) / double(pixels), 0.08);
  EXPECT_LT(double(changed) / double(pixels), 0.35);
  EXPECT_GT(difference(glass.at(160, 120), plain.at(160, 120)), 24) << "the lens centre looks like the background";
  // Away from the glass nothing changes: the corners are identical.
  for (auto [x0, y0] : {std::pair<uint32_t, uint32_t>{0, 0}, {310, 0}, {0, 230}, {310, 230}})
    for (uint32_t y = y0; y < y0 + 10; ++y)
      for (uint32_t x = x0; x < x0 + 10; ++x) ASSERT_LE(difference(glass.at(x, y), plain.at(x, y)), 3) << x << "," << y;
}

}  // namespace
}  // namespace shrefract::testing
