// Image files through OpenImageIO (kept out of every header), sRGB handling, atomic writes, and
// the lat-long mapping.
#include <shrefract/assets/image.h>

#include <OpenImageIO/imageio.h>

#include <glm/common.hpp>
#include <glm/geometric.hpp>
#include <glm/gtc/constants.hpp>

#include <unistd.h>

#include <algorithm>
#include <cctype>
#include <cmath>
#include <cstdint>
#include <cstdlib>
#include <filesystem>
#include <memory>
#include <string>
#include <system_error>
#include <utility>
#include <vector>

namespace shrefract::bake {
namespace {

// Largest finite half-float value: EXR half channels overflow to Inf above it.
constexpr float kHalfMax = 65504.0f;

std::string lowercase(std::string s) {
  std::transform(s.begin(), s.end(), s.begin(),
                 [](unsigned char c) { return static_cast<char>(std::tolower(c)); });
  return s;
}

// OpenImageIO messages can span lines; one line reads better inside ours.
std::string oneLine(std::string message) {
  std::replace(message.begin(), message.end(), '\n', ' ');
  while (!message.empty() && message.back() == ' ') message.pop_back();
  return message.empty() ? "unknown error" : message;
}

float srgbToLinear(float c) {
  return c <= 0.04045f ? c / 12.92f : std::pow((c + 0.055f) / 1.055f, 2.4f);
}

float linearToSrgb(float c) {
  return c <= 0.0031308f ? c * 12.92f : 1.055f * std::pow(c, 1.0f / 2.4f) - 0.055f;
}

// How the RGB of an integer-format file is encoded.
struct Transfer {
  enum Kind { Linear, Srgb, Gamma } kind = Srgb;
  float gamma = 1.0f;
};

Transfer transferOf(const OIIO::ImageSpec& spec) {
  if (spec.format.is_floating_point()) {
    return {Transfer::Linear, 1.0f};
  }
  const std::string space = lowercase(spec.get_string_attribute("oiio:ColorSpace"));
  if (space.find("linear") != std::string::npos || space == "scene_linear" || space == "raw") {
    return {Transfer::Linear, 1.0f};
  }
  if (space.rfind("gamma", 0) == 0) {  // "GammaCorrected2.2", "Gamma1.8"
    float gamma = spec.get_float_attribute("oiio:Gamma", 0.0f);
    if (!(gamma > 0.0f)) {
      const size_t digits = space.find_first_of("0123456789");
      gamma = digits == std::string::npos ? 2.2f : std::strtof(space.c_str() + digits, nullptr);
    }
    if (std::isfinite(gamma) && gamma > 0.0f) {
      return {Transfer::Gamma, gamma};
    }
  }
  return {Transfer::Srgb, 1.0f};  // "sRGB", none, or unknown: the usual meaning of 8-bit images
}

float decode(const Transfer& t, float c) {
  switch (t.kind) {
    case Transfer::Linear: return c;
    case Transfer::Gamma: return std::pow(c, t.gamma);
    case Transfer::Srgb: return srgbToLinear(c);
  }
  return c;
}

const char* channelName(size_t c) {
  static const char* const kNames[] = {"R", "G", "B", "A"};
  return kNames[c];
}

// Removes a file on scope exit unless released.
class TempFileGuard {
 public:
  explicit TempFileGuard(std::filesystem::path path) : path_(std::move(path)) {}
  ~TempFileGuard() {
    if (!path_.empty()) {
      std::error_code ignored;
      std::filesystem::remove(path_, ignored);
    }
  }
  TempFileGuard(const TempFileGuard&) = delete;
  TempFileGuard& operator=(const TempFileGuard&) = delete;
  void release() { path_.clear(); }

 private:
  std::filesystem::path path_;
};

}  // namespace

namespace {

// Pixels as stored (up to 4 channels, as floats), after the checks that need no pixel.
Result<std::vector<float>> readPixels(const std::string& path, OIIO::ImageInput& input, size_t channels) {
  const OIIO::ImageSpec& spec = input.spec();
  std::vector<float> pixels(size_t(spec.width) * size_t(spec.height) * channels);
  if (!input.read_image(0, 0, 0, static_cast<int>(channels), OIIO::TypeDesc::FLOAT, pixels.data())) {
    // OpenImageIO's PFM and some other readers fail on short pixel data without a message.
    const std::string raw = input.geterror();
    const std::string message = raw.empty() ? "the pixel data is truncated or corrupt" : oneLine(raw);
    input.close();
    return makeError(ErrorCode::CorruptData, path + ": cannot read: " + message);
  }
  input.close();
  return pixels;
}

// Linear RGBA from the stored channels (grey and grey + alpha spread to RGB), rejecting NaN, Inf
// and negative values.
Result<Image> toLinearRgba(const std::string& path, const std::vector<float>& pixels, size_t width, size_t height,
                           size_t channels, Transfer transfer) {
  Image image;
  image.width = static_cast<uint32_t>(width);
  image.height = static_cast<uint32_t>(height);
  image.rgba.resize(width * height * 4);
  for (size_t p = 0; p < width * height; ++p) {
    const float* in = &pixels[p * channels];
    float* out = &image.rgba[p * 4];
    if (channels <= 2) {
      out[0] = out[1] = out[2] = decode(transfer, in[0]);
      out[3] = channels == 2 ? in[1] : 1.0f;
    } else {
      for (size_t c = 0; c < 3; ++c) out[c] = decode(transfer, in[c]);
      out[3] = channels == 4 ? in[3] : 1.0f;
    }
    for (size_t c = 0; c < 4; ++c) {
      if (!std::isfinite(out[c]) || out[c] < 0.0f) {
        return makeError(ErrorCode::CorruptData,
                         path + ": pixel (" + std::to_string(p % width) + "," +
                             std::to_string(p / width) + ") channel " + channelName(c) + " is " +
                             std::to_string(out[c]) + " (NaN, Inf and negative values are rejected)");
      }
    }
  }
  return image;
}

}  // namespace

Result<Image> loadImage(const std::string& path) {
  std::error_code ec;
  if (!std::filesystem::exists(path, ec)) {
    return makeError(ErrorCode::Io, path + ": cannot open: no such file");
  }
  if (std::filesystem::is_directory(path, ec)) {
    return makeError(ErrorCode::Io, path + ": cannot open: is a directory");
  }
  // Keep alpha as stored: without this hint OpenImageIO premultiplies PNG colour by alpha.
  OIIO::ImageSpec config;
  config.attribute("oiio:UnassociatedAlpha", 1);
  std::unique_ptr<OIIO::ImageInput> input = OIIO::ImageInput::open(path, &config);
  if (!input) {
    return makeError(ErrorCode::CorruptData, path + ": cannot open: " + oneLine(OIIO::geterror()));
  }
  const OIIO::ImageSpec spec = input->spec();
  if (spec.deep) {
    input->close();
    return makeError(ErrorCode::Unsupported, path + ": deep images are not supported");
  }
  if (spec.width <= 0 || spec.height <= 0 || spec.depth != 1 || spec.nchannels <= 0) {
    input->close();
    return makeError(ErrorCode::CorruptData,
                     path + ": unusable size " + std::to_string(spec.width) + "x" +
                         std::to_string(spec.height) + "x" + std::to_string(spec.depth) + ", " +
                         std::to_string(spec.nchannels) + " channels");
  }
  const size_t channels = static_cast<size_t>(std::min(spec.nchannels, 4));
  Result<std::vector<float>> pixels = readPixels(path, *input, channels);
  if (!pixels.ok()) {
    return pixels.error();
  }
  return toLinearRgba(path, pixels.value(), static_cast<size_t>(spec.width), static_cast<size_t>(spec.height),
                      channels, transferOf(spec));
}

Result<Image> loadEnvironment(const std::string& path) {
  Result<Image> image = loadImage(path);
  if (!image.ok()) {
    return image;
  }
  if (image->width != 2 * image->height) {
    return makeError(ErrorCode::InvalidArgument,
                     path + ": size " + std::to_string(image->width) + "x" +
                         std::to_string(image->height) +
                         " is not a lat-long environment (width must be 2 x height)");
  }
  return image;
}

namespace {

// Every value finite (and within half range for a half EXR); sets `opaque` when every alpha is 1.
Result<void> checkWritable(const std::string& path, const Image& image, bool halfExr, bool& opaque) {
  opaque = true;
  for (size_t i = 0; i < image.rgba.size(); ++i) {
    const float v = image.rgba[i];
    if (!std::isfinite(v)) {
      const size_t p = i / 4;
      return makeError(ErrorCode::InvalidArgument,
                       path + ": pixel (" + std::to_string(p % image.width) + "," +
                           std::to_string(p / image.width) + ") channel " + channelName(i % 4) +
                           " is not finite; nothing written");
    }
    if (halfExr && std::fabs(v) > kHalfMax) {
      const size_t p = i / 4;
      return makeError(ErrorCode::InvalidArgument,
                       path + ": pixel (" + std::to_string(p % image.width) + "," +
                           std::to_string(p / image.width) + ") value " + std::to_string(v) +
                           " overflows half float; write ExrPixelType::Float");
    }
    if (i % 4 == 3 && v != 1.0f) {
      opaque = false;
    }
  }
  return {};
}

// 8-bit sRGB PNG, RGB when opaque; false when OpenImageIO fails (its message is on `output`).
bool writePng(OIIO::ImageOutput& output, const std::string& file, const Image& image, bool opaque) {
  const size_t pixelCount = static_cast<size_t>(image.width) * image.height;
  const size_t channels = opaque ? 3 : 4;
  std::vector<uint8_t> bytes(pixelCount * channels);
  for (size_t p = 0; p < pixelCount; ++p) {
    for (size_t c = 0; c < channels; ++c) {
      float v = std::clamp(image.rgba[p * 4 + c], 0.0f, 1.0f);
      if (c < 3) v = linearToSrgb(v);
      bytes[p * channels + c] = static_cast<uint8_t>(std::lround(v * 255.0f));
    }
  }
  OIIO::ImageSpec spec(static_cast<int>(image.width), static_cast<int>(image.height), static_cast<int>(channels),
                       OIIO::TypeDesc::UINT8);
  spec.attribute("oiio:ColorSpace", "sRGB");
  spec.attribute("oiio:UnassociatedAlpha", 1);  // our alpha is straight: store it as is
  return output.open(file, spec) && output.write_image(OIIO::TypeDesc::UINT8, bytes.data());
}

// Linear RGBA EXR (zip), half or float.
bool writeExr(OIIO::ImageOutput& output, const std::string& file, const Image& image, ExrPixelType pixelType) {
  const OIIO::TypeDesc type = pixelType == ExrPixelType::Half ? OIIO::TypeDesc::HALF : OIIO::TypeDesc::FLOAT;
  OIIO::ImageSpec spec(static_cast<int>(image.width), static_cast<int>(image.height), 4, type);
  spec.attribute("compression", "zip");
  return output.open(file, spec) && output.write_image(OIIO::TypeDesc::FLOAT, image.rgba.data());
}

}  // namespace

Result<void> writeImage(const std::string& path, const Image& image,
                        const ImageWriteOptions& options) {
  const std::filesystem::path target(path);
  const std::string extension = lowercase(target.extension().string());
  const bool png = extension == ".png";
  const bool exr = extension == ".exr";
  if (!png && !exr) {
    return makeError(ErrorCode::InvalidArgument,
                     path + ": unknown image extension '" + target.extension().string() +
                         "' (use .png or .exr)");
  }
  const size_t pixelCount = static_cast<size_t>(image.width) * image.height;
  if (image.width == 0 || image.height == 0 || image.rgba.size() != pixelCount * 4) {
    return makeError(ErrorCode::InvalidArgument,
                     path + ": image " + std::to_string(image.width) + "x" +
                         std::to_string(image.height) + " has " + std::to_string(image.rgba.size()) +
                         " floats, expected " + std::to_string(pixelCount * 4));
  }
  bool opaque = true;
  if (auto r = checkWritable(path, image, exr && options.exrPixelType == ExrPixelType::Half, opaque); !r) {
    return r;
  }

  // Written beside the target and renamed over it, so that a failed write leaves no partial file
  // and never clobbers an existing one.
  const std::filesystem::path temp =
      target.parent_path() / (target.stem().string() + ".tmp" + std::to_string(::getpid()) +
                              target.extension().string());
  TempFileGuard guard(temp);
  std::unique_ptr<OIIO::ImageOutput> output = OIIO::ImageOutput::create(temp.string());
  if (!output) {
    return makeError(ErrorCode::Io, path + ": cannot write: " + oneLine(OIIO::geterror()));
  }
  bool written = png ? writePng(*output, temp.string(), image, opaque)
                     : writeExr(*output, temp.string(), image, options.exrPixelType);
  // close() flushes; a failure there (disk full) is a failed write too.
  written = output->close() && written;
  if (!written) {
    return makeError(ErrorCode::Io, path + ": cannot write: " + oneLine(output->geterror()));
  }
  output.reset();

  std::error_code ec;
  std::filesystem::rename(temp, target, ec);
  if (ec) {
    return makeError(ErrorCode::Io, path + ": cannot write: rename from " + temp.string() +
                                        " failed: " + ec.message());
  }
  guard.release();
  return {};
}

glm::vec2 directionToLatLong(glm::vec3 direction) {
  const glm::vec3 d = glm::normalize(direction);
  const float u = 0.5f + std::atan2(d.x, -d.z) / glm::two_pi<float>();
  const float v = std::acos(std::clamp(d.y, -1.0f, 1.0f)) / glm::pi<float>();
  return {std::clamp(u, 0.0f, 1.0f), std::clamp(v, 0.0f, 1.0f)};
}

glm::vec3 latLongToDirection(glm::vec2 uv) {
  const float phi = (uv.x - 0.5f) * glm::two_pi<float>();
  const float theta = uv.y * glm::pi<float>();
  const float sinTheta = std::sin(theta);
  return {sinTheta * std::sin(phi), std::cos(theta), -sinTheta * std::cos(phi)};
}

glm::vec3 sampleLatLong(const Image& image, glm::vec3 direction) {
  const glm::vec2 uv = directionToLatLong(direction);
  const int w = static_cast<int>(image.width);
  const int h = static_cast<int>(image.height);
  // Continuous pixel coordinates: pixel centres sit on integers.
  const float x = uv.x * static_cast<float>(w) - 0.5f;
  const float y = uv.y * static_cast<float>(h) - 0.5f;
  const float x0f = std::floor(x);
  const float y0f = std::floor(y);
  const float fx = x - x0f;
  const float fy = y - y0f;
  const int x0 = static_cast<int>(x0f);
  const int y0 = static_cast<int>(y0f);
  const auto wrapX = [w](int xi) { return ((xi % w) + w) % w; };
  const auto clampY = [h](int yi) { return std::clamp(yi, 0, h - 1); };
  const auto texel = [&](int xi, int yi) {
    const size_t i = 4 * (static_cast<size_t>(clampY(yi)) * image.width + static_cast<size_t>(wrapX(xi)));
    return glm::vec3(image.rgba[i], image.rgba[i + 1], image.rgba[i + 2]);
  };
  const glm::vec3 top = glm::mix(texel(x0, y0), texel(x0 + 1, y0), fx);
  const glm::vec3 bottom = glm::mix(texel(x0, y0 + 1), texel(x0 + 1, y0 + 1), fx);
  return glm::mix(top, bottom, fy);
}

}  // namespace shrefract::bake
