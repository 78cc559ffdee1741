// Images for the baker and the tools: loading and writing (OpenImageIO behind this header), the
// lat-long environment convention, a procedural environment for tests and demos, and the box
// filter that reduces supersampled renders.
//
// Lat-long convention (shared with the GPU shaders; docs/technique.md):
//   +Y is up. For a direction d,
//     u = 0.5 + atan2(d.x, -d.z) / (2 pi)      v = acos(clamp(d.y, -1, 1)) / pi
//   v = 0 is the top row (zenith, +Y), v = 1 the bottom row (nadir). The image centre
//   (u, v) = (0.5, 0.5) looks toward -Z, u increases toward +X there (u = 0.75 is +X, u = 0.25
//   is -X), and the seam u = 0 / u = 1 is +Z. Pixel (i, j) has its centre at
//   uv = ((i + 0.5) / width, (j + 0.5) / height). A lat-long image has width == 2 * height.
#pragma once

#include <shrefract/result.h>

#include <glm/vec2.hpp>
#include <glm/vec3.hpp>

#include <cstdint>
#include <string>
#include <vector>

namespace shrefract::bake {

// Linear RGBA, 32-bit float, row 0 at the top, rgba[4 * (y * width + x) + c]. Alpha is straight
// (colour not premultiplied), as PNG stores it.
struct Image {
  uint32_t width = 0;
  uint32_t height = 0;
  std::vector<float> rgba;
};

// Loads .hdr, .exr, .png, .jpg (anything OpenImageIO reads) as linear RGBA32F, first subimage.
// 1 channel: grey, alpha 1. 2: grey + alpha. 3: RGB, alpha 1. 4 or more: the first four.
// Integer formats (8- and 16-bit) are decoded from sRGB unless the file's colour-space metadata
// says linear (or names a gamma, which is applied); float formats are taken as linear. Alpha is
// never converted.
// Errors name the file: Io "<path>: cannot open: ..." when it is missing or unreadable,
// CorruptData when it cannot be decoded (garbage, truncated) or holds a NaN, Inf or negative value
// (the message gives the first bad pixel as (x,y) and its channel), Unsupported for deep images.
Result<Image> loadImage(const std::string& path);

// loadImage, then checks the lat-long shape (width == 2 * height); otherwise InvalidArgument naming
// the file and its size.
Result<Image> loadEnvironment(const std::string& path);

// Options for writeImage.
enum class ExrPixelType { Half, Float };
struct ImageWriteOptions {
  // EXR channel type. Half keeps 11 bits of mantissa and overflows above 65504: writeImage rejects
  // such images unless Float is chosen.
  ExrPixelType exrPixelType = ExrPixelType::Half;
};

// Writes by extension (case-insensitive):
//   .png  8-bit sRGB: RGB clamped to [0,1] and sRGB-encoded, alpha clamped and stored linearly;
//         RGB when every alpha is 1, RGBA otherwise.
//   .exr  linear RGBA, half (default) or float.
// Errors: InvalidArgument if the image's size and pixel count disagree, if it holds a NaN or Inf
// (no file is written) or if the extension is not one of the above, all naming the file; Io when
// the file cannot be written. The write is atomic: the pixels go to "<stem>.tmp<pid><ext>" in the
// same directory, which is renamed over `path` once complete and removed on failure.
Result<void> writeImage(const std::string& path, const Image& image,
                        const ImageWriteOptions& options = {});

// A deterministic lat-long environment (width x width / 2): a sky gradient from the horizon to the
// zenith, a sun-like disk, three small very bright lights (50, 100 and 200) in the upper
// hemisphere, and below the horizon a checkerboard on the plane y = -1 (unit squares in world x
// and z, seen from the origin) fading to a uniform ground colour toward the horizon. Each pixel
// averages 4x4 samples. `width` is rounded down to an even number, at least 8.
Image proceduralEnvironment(uint32_t width = 1024);

// Lat-long coordinates of a direction (any non-zero length; normalized inside): u, v in [0, 1].
glm::vec2 directionToLatLong(glm::vec3 direction);
// Unit direction for lat-long coordinates (inverse of directionToLatLong).
glm::vec3 latLongToDirection(glm::vec2 uv);

// Bilinear sample of the RGB of a lat-long image in `direction`, between pixel centres, wrapping
// in u and clamped in v (rows 0 and height - 1 extend to the poles). Precondition: the image is
// non-empty and rgba.size() == 4 * width * height.
glm::vec3 sampleLatLong(const Image& image, glm::vec3 direction);

// Largest samplesPerAxis of every supersampled renderer (the CPU references, offscreen's GPU
// frames): 64 samples per pixel.
inline constexpr uint32_t kMaxSamplesPerAxis = 8;

// The mean of every samplesPerAxis x samplesPerAxis block of `image` (its size must be a
// multiple of samplesPerAxis per axis; alpha averaged too), summed in row-major order within the
// block: how every supersampled image by the renderers and the tools is reduced.
Image boxFilter(const Image& image, uint32_t samplesPerAxis);

}  // namespace shrefract::bake
