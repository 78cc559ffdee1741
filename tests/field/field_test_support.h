// What the .shrf tests share (tests/field/*_test.cpp): byte access to a serialized file, and small
// synthetic fields of every encoding whose bytes the tests cut, flip and relabel.
#pragma once

#include <shrefract/field.h>

#include <gtest/gtest.h>

#include <cstddef>
#include <cstdint>
#include <string>
#include <vector>

namespace shrefract::fieldtest {

// An independent CRC-32 (bitwise, no table) so the tests check the spec, not the implementation.
uint32_t referenceCrc32(const uint8_t* data, size_t size);

// Little-endian values at byte `at` of a file.
uint32_t getU32(const std::vector<uint8_t>& b, size_t at);
uint64_t getU64(const std::vector<uint8_t>& b, size_t at);
void putU32(std::vector<uint8_t>& b, size_t at, uint32_t v);
void putU64(std::vector<uint8_t>& b, size_t at, uint64_t v);
// Recomputes the trailing checksum after a test edits the bytes on purpose.
void resign(std::vector<uint8_t>& b);
// Offset of the payload of the section with `tag`.
size_t sectionPayload(const std::vector<uint8_t>& b, const char* tag);

// A small synthetic field: 8x4 atlas, order 2 (9 layers), 3 gutter texels, 2 empty texels.
inline constexpr uint32_t kWidth = 8, kHeight = 4, kOrder = 2, kLayers = 9;
inline constexpr float kConstantLayer0Channel1 = 0.25f;  // a zero-range (layer, channel)

struct Variant {
  uint32_t channels;
  Quantization quantization;
};

// The coefficients makeField encodes: layer-major, `channels` values a texel.
std::vector<float> syntheticCoefficients(uint32_t channels);
Field makeField(Variant variant);

// makeField's atlas with a Table (N = 3) or Pca (N = 3, K = 5) encoding, optionally with throughput.
// jumpDistance: a 12x12 table (the smallest decoded jump-aware) with the jump distance channel.
// sampleFrameExits: the exits read in each sample's frame. clustered: a clustered Pca field.
Field makeEncodedField(Encoding encoding, Quantization q, bool throughput, bool jumpDistance = false,
                       bool sampleFrameExits = false, bool clustered = false);

// makeField's atlas as a Volume field over a grid of varied distance levels and normals: a 12^3
// grid, 2^3 bricks of which the last ones lie partly beyond it: voxels with x >= 8 beyond
// the band outside, those with y >= 8 (and x < 8) beyond it inside, the others varied; its bricks
// (1, *, *) are entries outside, (0, 1, *) inside, and (0, 0, 0) and (0, 0, 1) stored.
inline constexpr uint32_t kVolumeFieldSize = 12;

std::vector<uint32_t> volumeFieldVoxels();  // the grid's voxels, dense
Field makeVolumeField(Quantization q, bool throughput);

// Floats as their bits, so that comparisons are exact (NaN, -0 and subnormals included).
std::vector<uint32_t> bits(const std::vector<float>& v);
uint32_t bits(float v);
uint64_t bits(double v);
// Field for field, floats compared bit for bit.
void expectSameField(const Field& a, const Field& b);
Result<Field> parse(const std::vector<uint8_t>& bytes, const std::string& name);
bool contains(const std::string& haystack, const std::string& needle);

// The bytes at the end of ENCD, for files of the layouts before this version: what each version
// from 6 on appended for a field that is not clustered and has no volume.
// What version 6 appends to ENCD for a field that is not clustered: the flag, an empty array of
// indices, the clusters asked for and an empty array of binary16 tables.
inline constexpr uint64_t kClusteredBytes = 4 + 8 + 4 + 8;

// What version 7 appends after them: how an SH field was fitted.
inline constexpr uint64_t kShFitBytes = 4;

// What version 8 appends after it for a field that is not a Volume field: the grid's size, origin
// and spacing, an empty array of voxels, the size asked for and whether the volume was tried; and
// what version 9 appends after them: empty arrays of bricks and of their voxels.
inline constexpr uint64_t kVolumeV8Bytes = 4 + 12 + 4 + 8 + 4 + 4;

inline constexpr uint64_t kBrickBytes = 8 + 8;

inline constexpr uint64_t kVolumeBytes = kVolumeV8Bytes + kBrickBytes;

// The file without the last `bytes` of ENCD, labelled `version`.
std::vector<uint8_t> withShorterEncoding(const Field& f, uint64_t bytes, uint32_t version);

}  // namespace shrefract::fieldtest
