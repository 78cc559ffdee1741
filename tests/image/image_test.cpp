// Images: the lat-long convention, PNG/EXR/HDR round trips, error reporting, atomic writes and the
// procedural environment.
#include <shrefract/assets/image.h>

#include <glm/geometric.hpp>
#include <glm/gtc/constants.hpp>

#include <gtest/gtest.h>

#include <unistd.h>

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <filesystem>
#include <fstream>
#include <string>
#include <vector>

namespace shrefract::bake {
namespace {

namespace fs = std::filesystem;

// A fresh directory per test, removed afterwards.
class ImageFiles : public ::testing::Test {
 protected:
  void SetUp() override {
    const auto* info = ::testing::UnitTest::GetInstance()->current_test_info();
    dir_ = fs::temp_directory_path() /
           ("shrefract_image_test_" + std::to_string(::getpid()) + "_" + info->name());
    fs::remove_all(dir_);
    fs::create_directories(dir_);
  }
  void TearDown() override { fs::remove_all(dir_); }
  std::string file(const std::string& name) const { return (dir_ / name).string(); }
  size_t filesInDir() const {
    return static_cast<size_t>(std::distance(fs::directory_iterator(dir_), fs::directory_iterator()));
  }

  fs::path dir_;
};

Image gradientImage(uint32_t w, uint32_t h, bool withAlpha) {
  Image image{w, h, std::vector<float>(size_t{w} * h * 4)};
  for (uint32_t y = 0; y < h; ++y) {
    for (uint32_t x = 0; x < w; ++x) {
      float* p = &image.rgba[4 * (size_t{y} * w + x)];
      p[0] = static_cast<float>(x) / static_cast<float>(w - 1);
      p[1] = static_cast<float>(y) / static_cast<float>(h - 1);
      p[2] = static_cast<float>((x * 7 + y * 3) % 11) / 10.0f;
      p[3] = withAlpha ? static_cast<float>((x + y) % 5) / 4.0f : 1.0f;
    }
  }
  return image;
}

float toSrgb(float c) {
  c = std::clamp(c, 0.0f, 1.0f);
  return c <= 0.0031308f ? c * 12.92f : 1.055f * std::pow(c, 1.0f / 2.4f) - 0.055f;
}

bool contains(const std::string& haystack, const std::string& needle) {
  return haystack.find(needle) != std::string::npos;
}

void writeBytes(const std::string& path, const std::vector<char>& bytes) {
  std::ofstream out(path, std::ios::binary);
  out.write(bytes.data(), static_cast<std::streamsize>(bytes.size()));
}

std::vector<char> readBytes(const std::string& path) {
  std::ifstream in(path, std::ios::binary);
  return std::vector<char>(std::istreambuf_iterator<char>(in), std::istreambuf_iterator<char>());
}

// --- lat-long convention -------------------------------------------------------------------------

TEST(LatLong, DocumentedAxes) {
  auto near = [](glm::vec2 a, glm::vec2 b) { return glm::length(a - b) < 1e-6f; };
  EXPECT_TRUE(near(directionToLatLong({0, 0, -1}), {0.5f, 0.5f}));
  EXPECT_TRUE(near(directionToLatLong({1, 0, 0}), {0.75f, 0.5f}));
  EXPECT_TRUE(near(directionToLatLong({-1, 0, 0}), {0.25f, 0.5f}));
  EXPECT_NEAR(directionToLatLong({0, 1, 0}).y, 0.0f, 1e-6f);   // zenith: top row
  EXPECT_NEAR(directionToLatLong({0, -1, 0}).y, 1.0f, 1e-6f);  // nadir: bottom row
  const float seam = directionToLatLong({0, 0, 1}).x;          // +Z: the seam
  EXPECT_TRUE(std::abs(seam) < 1e-6f || std::abs(seam - 1.0f) < 1e-6f);
  // u increases toward +X at the centre; the length of the direction does not matter.
  EXPECT_GT(directionToLatLong({0.1f, 0, -1}).x, 0.5f);
  EXPECT_TRUE(near(directionToLatLong({0, 0, -5}), {0.5f, 0.5f}));
  EXPECT_LT(glm::length(latLongToDirection({0.5f, 0.5f}) - glm::vec3(0, 0, -1)), 1e-6f);
  EXPECT_LT(glm::length(latLongToDirection({0.75f, 0.5f}) - glm::vec3(1, 0, 0)), 1e-6f);
}

TEST(LatLong, RoundTripsManyDirectionsIncludingPoles) {
  std::vector<glm::vec3> dirs = {{0, 1, 0}, {0, -1, 0}, {1e-7f, 1, 0}, {0, -1, 1e-7f},
                                 {1, 0, 0}, {-1, 0, 0}, {0, 0, 1},    {0, 0, -1}};
  // A Fibonacci sphere: 2000 directions spread evenly.
  const int n = 2000;
  for (int i = 0; i < n; ++i) {
    const float y = 1.0f - 2.0f * (static_cast<float>(i) + 0.5f) / static_cast<float>(n);
    const float r = std::sqrt(1.0f - y * y);
    const float a = 2.39996323f * static_cast<float>(i);
    dirs.push_back({r * std::cos(a), y, r * std::sin(a)});
  }
  for (const glm::vec3& d : dirs) {
    const glm::vec2 uv = directionToLatLong(d);
    ASSERT_GE(uv.x, 0.0f);
    ASSERT_LE(uv.x, 1.0f);
    ASSERT_GE(uv.y, 0.0f);
    ASSERT_LE(uv.y, 1.0f);
    // float trig: about 1e-6 per step; acos near the poles loses up to ~3e-4 in v.
    EXPECT_LT(glm::length(latLongToDirection(uv) - glm::normalize(d)), 1e-3f)
        << d.x << " " << d.y << " " << d.z;
  }
  for (int j = 0; j < 32; ++j) {
    for (int i = 0; i < 64; ++i) {
      const glm::vec2 uv((static_cast<float>(i) + 0.5f) / 64.0f, (static_cast<float>(j) + 0.5f) / 32.0f);
      EXPECT_LT(glm::length(directionToLatLong(latLongToDirection(uv)) - uv), 1e-5f);
    }
  }
}

TEST(LatLong, BilinearSampleAtPixelCentreIsThatPixel) {
  const Image image = gradientImage(64, 32, false);
  for (uint32_t j : {0u, 1u, 15u, 31u}) {
    for (uint32_t i : {0u, 5u, 32u, 63u}) {
      const glm::vec2 uv((static_cast<float>(i) + 0.5f) / 64.0f, (static_cast<float>(j) + 0.5f) / 32.0f);
      const glm::vec3 s = sampleLatLong(image, latLongToDirection(uv));
      const float* p = &image.rgba[4 * (size_t{j} * 64 + i)];
      // The direction round trip moves the sample ~1e-5 pixel; neighbours differ by <= 1.
      EXPECT_NEAR(s.x, p[0], 1e-4f) << i << "," << j;
      EXPECT_NEAR(s.y, p[1], 1e-4f) << i << "," << j;
      EXPECT_NEAR(s.z, p[2], 1e-4f) << i << "," << j;
    }
  }
}

TEST(LatLong, BilinearWrapsInUAndClampsInV) {
  Image image{4, 2, std::vector<float>(4 * 2 * 4, 0.0f)};
  // Column 0 is 1, column 3 is 3: halfway between them across the seam is 2.
  for (uint32_t y = 0; y < 2; ++y) {
    image.rgba[4 * (y * 4 + 0)] = 1.0f;
    image.rgba[4 * (y * 4 + 3)] = 3.0f;
  }
  EXPECT_NEAR(sampleLatLong(image, latLongToDirection({0.0f, 0.5f})).x, 2.0f, 1e-4f);
  EXPECT_NEAR(sampleLatLong(image, latLongToDirection({0.999999f, 0.5f})).x, 2.0f, 1e-4f);
  // Above the first row's centres: clamped to row 0.
  EXPECT_NEAR(sampleLatLong(image, latLongToDirection({0.125f, 0.01f})).x, 1.0f, 1e-4f);
}

// --- files ---------------------------------------------------------------------------------------

TEST_F(ImageFiles, ExrRoundTripWithinHalfPrecision) {
  Image image = gradientImage(17, 9, true);
  image.rgba[0] = 1234.5f;  // HDR values survive
  const std::string path = file("round.exr");
  ASSERT_TRUE(writeImage(path, image).ok());
  const Result<Image> back = loadImage(path);
  ASSERT_TRUE(back.ok()) << back.error().message;
  ASSERT_EQ(back->width, 17u);
  ASSERT_EQ(back->height, 9u);
  for (size_t i = 0; i < image.rgba.size(); ++i) {
    // Half: 11 significant bits, relative error <= 2^-11.
    EXPECT_NEAR(back->rgba[i], image.rgba[i], std::abs(image.rgba[i]) / 2048.0f + 1e-7f) << i;
  }
  EXPECT_EQ(filesInDir(), 1u);  // no temporary file left
}

TEST_F(ImageFiles, ExrFloatIsExactAndHalfOverflowIsRejected) {
  Image image = gradientImage(8, 4, false);
  image.rgba[5] = 1e6f;
  const std::string path = file("big.exr");
  const Result<void> half = writeImage(path, image);
  ASSERT_FALSE(half.ok());
  EXPECT_TRUE(contains(half.error().message, path));
  EXPECT_FALSE(fs::exists(path));
  ASSERT_TRUE(writeImage(path, image, {.exrPixelType = ExrPixelType::Float}).ok());
  const Result<Image> back = loadImage(path);
  ASSERT_TRUE(back.ok()) << back.error().message;
  EXPECT_EQ(back->rgba, image.rgba);
}

TEST_F(ImageFiles, PngRoundTripWithinOneStepAfterSrgb) {
  for (bool alpha : {false, true}) {
    const Image image = gradientImage(31, 13, alpha);
    const std::string path = file(alpha ? "rgba.png" : "rgb.png");
    ASSERT_TRUE(writeImage(path, image).ok());
    const Result<Image> back = loadImage(path);
    ASSERT_TRUE(back.ok()) << back.error().message;
    ASSERT_EQ(back->width, 31u);
    ASSERT_EQ(back->height, 13u);
    for (size_t i = 0; i < image.rgba.size(); ++i) {
      if (i % 4 == 3) {
        EXPECT_NEAR(back->rgba[i], image.rgba[i], 0.5f / 255.0f + 1e-6f);  // alpha: linear 8-bit
      } else {
        EXPECT_NEAR(toSrgb(back->rgba[i]), toSrgb(image.rgba[i]), 1.0f / 255.0f) << i;
      }
    }
  }
}

TEST_F(ImageFiles, PngClampsOutOfRangeValues) {
  Image image = gradientImage(4, 2, false);
  image.rgba[0] = 7.0f;
  image.rgba[1] = -3.0f;
  const std::string path = file("clamped.png");
  ASSERT_TRUE(writeImage(path, image).ok());
  const Result<Image> back = loadImage(path);
  ASSERT_TRUE(back.ok()) << back.error().message;
  EXPECT_FLOAT_EQ(back->rgba[0], 1.0f);
  EXPECT_FLOAT_EQ(back->rgba[1], 0.0f);
}

TEST_F(ImageFiles, GreyscaleEightBitIsDecodedFromSrgb) {
  // Binary PGM written by hand: one channel, 8 bits, no colour-space metadata: assumed sRGB.
  const std::string path = file("grey.pgm");
  std::vector<char> bytes;
  const std::string header = "P5\n4 2\n255\n";
  bytes.assign(header.begin(), header.end());
  for (int v : {0, 64, 128, 255, 255, 188, 10, 1}) bytes.push_back(static_cast<char>(v));
  writeBytes(path, bytes);
  const Result<Image> image = loadImage(path);
  ASSERT_TRUE(image.ok()) << image.error().message;
  ASSERT_EQ(image->width, 4u);
  ASSERT_EQ(image->height, 2u);
  const float grey128 = std::pow((128.0f / 255.0f + 0.055f) / 1.055f, 2.4f);  // sRGB decode
  EXPECT_NEAR(image->rgba[4 * 2 + 0], grey128, 1e-5f);
  EXPECT_NEAR(image->rgba[4 * 2 + 1], grey128, 1e-5f);
  EXPECT_NEAR(image->rgba[4 * 2 + 2], grey128, 1e-5f);
  EXPECT_EQ(image->rgba[4 * 2 + 3], 1.0f);
  EXPECT_EQ(image->rgba[4 * 3 + 0], 1.0f);
}

TEST_F(ImageFiles, RadianceHdrIsLinear) {
  // Radiance RGBE, flat (width < 8 is never run-length encoded): mantissas with exponent 129
  // (scale 2^(129-136) = 1/128) give exactly 1.0, 0.5 and 2.0.
  const std::string path = file("tiny.hdr");
  const std::string header = "#?RADIANCE\nFORMAT=32-bit_rle_rgbe\n\n-Y 1 +X 2\n";
  std::vector<char> bytes(header.begin(), header.end());
  for (int v : {128, 64, 128, 129}) bytes.push_back(static_cast<char>(v));  // (1, 0.5, 1)
  for (int v : {128, 128, 128, 130}) bytes.push_back(static_cast<char>(v)); // (2, 2, 2)
  writeBytes(path, bytes);
  const Result<Image> image = loadImage(path);
  ASSERT_TRUE(image.ok()) << image.error().message;
  ASSERT_EQ(image->width, 2u);
  ASSERT_EQ(image->height, 1u);
  // OIIO decodes RGBE as (m + 0.5) * 2^(e - 136); allow that half-step.
  EXPECT_NEAR(image->rgba[0], 1.0f, 0.01f);
  EXPECT_NEAR(image->rgba[1], 0.5f, 0.01f);
  EXPECT_NEAR(image->rgba[4], 2.0f, 0.02f);
  EXPECT_EQ(image->rgba[3], 1.0f);
}

TEST_F(ImageFiles, MissingFileNamesTheFile) {
  const std::string path = file("does-not-exist.exr");
  const Result<Image> image = loadImage(path);
  ASSERT_FALSE(image.ok());
  EXPECT_EQ(image.error().code, ErrorCode::Io);
  EXPECT_TRUE(contains(image.error().message, path + ": cannot open")) << image.error().message;
}

TEST_F(ImageFiles, GarbageFileNamesTheFile) {
  for (const char* name : {"garbage.png", "garbage.exr", "garbage.hdr", "garbage.jpg"}) {
    const std::string path = file(name);
    const std::string text = "this is not an image, just some text that is long enough";
    writeBytes(path, std::vector<char>(text.begin(), text.end()));
    const Result<Image> image = loadImage(path);
    ASSERT_FALSE(image.ok()) << name;
    EXPECT_TRUE(contains(image.error().message, path)) << image.error().message;
  }
}

TEST_F(ImageFiles, TruncatedFilesAreRejected) {
  const Image image = proceduralEnvironment(64);
  for (const char* name : {"cut.png", "cut.exr"}) {
    const std::string path = file(name);
    ASSERT_TRUE(writeImage(path, image).ok());
    std::vector<char> bytes = readBytes(path);
    ASSERT_GT(bytes.size(), 100u);
    bytes.resize(bytes.size() / 2);
    writeBytes(path, bytes);
    const Result<Image> loaded = loadImage(path);
    ASSERT_FALSE(loaded.ok()) << name;
    EXPECT_EQ(loaded.error().code, ErrorCode::CorruptData);
    EXPECT_TRUE(contains(loaded.error().message, path)) << loaded.error().message;
  }
}

TEST_F(ImageFiles, NegativePixelIsRejectedWithItsPosition) {
  Image image = gradientImage(8, 4, false);
  image.rgba[4 * (2 * 8 + 5) + 1] = -0.25f;  // pixel (5,2), green
  const std::string path = file("negative.exr");
  ASSERT_TRUE(writeImage(path, image).ok());  // negative is finite: writable
  const Result<Image> loaded = loadImage(path);
  ASSERT_FALSE(loaded.ok());
  EXPECT_EQ(loaded.error().code, ErrorCode::CorruptData);
  EXPECT_TRUE(contains(loaded.error().message, path)) << loaded.error().message;
  EXPECT_TRUE(contains(loaded.error().message, "(5,2)")) << loaded.error().message;
}

TEST_F(ImageFiles, NanImageIsNotWritten) {
  for (const char* name : {"nan.exr", "nan.png"}) {
    Image image = gradientImage(8, 4, false);
    image.rgba[4 * (3 * 8 + 1) + 2] = std::nanf("");
    const std::string path = file(name);
    const Result<void> written = writeImage(path, image);
    ASSERT_FALSE(written.ok()) << name;
    EXPECT_TRUE(contains(written.error().message, path)) << written.error().message;
    EXPECT_TRUE(contains(written.error().message, "(1,3)")) << written.error().message;
  }
  Image inf = gradientImage(8, 4, false);
  inf.rgba[0] = INFINITY;
  EXPECT_FALSE(writeImage(file("inf.exr"), inf).ok());
  EXPECT_EQ(filesInDir(), 0u);  // neither the file nor a temporary one
}

TEST_F(ImageFiles, UnknownExtensionAndBadImagesAreRejected) {
  const Image image = gradientImage(8, 4, false);
  const Result<void> tga = writeImage(file("picture.tga"), image);
  ASSERT_FALSE(tga.ok());
  EXPECT_TRUE(contains(tga.error().message, file("picture.tga")));
  EXPECT_FALSE(writeImage(file("noextension"), image).ok());
  Image broken = image;
  broken.rgba.pop_back();
  EXPECT_FALSE(writeImage(file("broken.exr"), broken).ok());
  EXPECT_FALSE(writeImage(file("empty.exr"), Image{}).ok());
  EXPECT_FALSE(writeImage(file("missing-dir/x.exr"), image).ok());
  EXPECT_EQ(filesInDir(), 0u);
}

TEST_F(ImageFiles, WriteReplacesAnExistingFile) {
  const std::string path = file("replace.exr");
  ASSERT_TRUE(writeImage(path, gradientImage(8, 4, false)).ok());
  ASSERT_TRUE(writeImage(path, gradientImage(16, 8, false)).ok());
  const Result<Image> back = loadImage(path);
  ASSERT_TRUE(back.ok());
  EXPECT_EQ(back->width, 16u);
  EXPECT_EQ(filesInDir(), 1u);
}

TEST_F(ImageFiles, LoadEnvironmentRequiresTwoToOne) {
  const std::string square = file("square.exr");
  ASSERT_TRUE(writeImage(square, gradientImage(8, 8, false)).ok());
  const Result<Image> env = loadEnvironment(square);
  ASSERT_FALSE(env.ok());
  EXPECT_TRUE(contains(env.error().message, square)) << env.error().message;
  EXPECT_TRUE(contains(env.error().message, "8x8")) << env.error().message;

  const std::string latLong = file("latlong.exr");
  ASSERT_TRUE(writeImage(latLong, gradientImage(16, 8, false)).ok());
  EXPECT_TRUE(loadEnvironment(latLong).ok());
}

// --- procedural environment ----------------------------------------------------------------------

TEST(ProceduralEnvironment, FiniteNonNegativeWithAFewVeryBrightPixels) {
  const Image env = proceduralEnvironment(512);
  ASSERT_EQ(env.width, 512u);
  ASSERT_EQ(env.height, 256u);
  ASSERT_EQ(env.rgba.size(), size_t{512} * 256 * 4);
  size_t bright = 0;
  float brightest = 0.0f;
  for (size_t p = 0; p < size_t{512} * 256; ++p) {
    for (size_t c = 0; c < 4; ++c) {
      ASSERT_TRUE(std::isfinite(env.rgba[p * 4 + c]));
      ASSERT_GE(env.rgba[p * 4 + c], 0.0f);
    }
    EXPECT_EQ(env.rgba[p * 4 + 3], 1.0f);
    const float m = std::max({env.rgba[p * 4], env.rgba[p * 4 + 1], env.rgba[p * 4 + 2]});
    brightest = std::max(brightest, m);
    if (m > 40.0f) ++bright;
  }
  EXPECT_GE(bright, 3u);                           // at least one pixel per light
  EXPECT_LT(bright, size_t{512} * 256 / 1000);     // and small
  EXPECT_GT(brightest, 150.0f);                    // the 200 light has a fully covered pixel
  EXPECT_LE(brightest, 200.0f);
  // Lights are in the upper hemisphere: the lower half stays below the checker's brightest colour.
  for (size_t p = size_t{512} * 128; p < size_t{512} * 256; ++p) {
    ASSERT_LE(env.rgba[p * 4], 1.0f);
  }
}

TEST(ProceduralEnvironment, GroundCheckerDiffersFromSky) {
  const Image env = proceduralEnvironment(256);
  const glm::vec3 up = sampleLatLong(env, {0, 1, 0});
  const glm::vec3 sky = sampleLatLong(env, glm::normalize(glm::vec3(0.3f, 0.5f, 0.8f)));
  const glm::vec3 down = sampleLatLong(env, {0.0f, -1.0f, 0.0f});
  // Sky is blue (b > r); straight down lies on a checker corner; 45 degrees down, inside squares.
  EXPECT_GT(up.z, up.x);
  EXPECT_GT(sky.z, sky.x);
  EXPECT_GT(glm::length(up - down), 0.1f);
  // Two neighbouring squares on the ground plane y = -1: (0.5, -1, -1.5) and (1.5, -1, -1.5).
  const glm::vec3 a = sampleLatLong(env, glm::normalize(glm::vec3(0.5f, -1.0f, -1.5f)));
  const glm::vec3 b = sampleLatLong(env, glm::normalize(glm::vec3(1.5f, -1.0f, -1.5f)));
  EXPECT_GT(std::abs(a.x - b.x), 0.4f) << a.x << " vs " << b.x;
  EXPECT_GT(glm::length(a - sky), 0.1f);
}

TEST(ProceduralEnvironment, IsDeterministicAndRoundsWidth) {
  EXPECT_EQ(proceduralEnvironment(64).rgba, proceduralEnvironment(64).rgba);
  const Image odd = proceduralEnvironment(65);
  EXPECT_EQ(odd.width, 64u);
  EXPECT_EQ(odd.height, 32u);
  EXPECT_EQ(proceduralEnvironment(1).width, 8u);
}

}  // namespace
}  // namespace shrefract::bake
