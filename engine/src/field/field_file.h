// What the parts of the .shrf format share (docs/field-format.md): the format's limits and layout,
// the checksum, little-endian loads and the words of its messages. Private to engine/src/field.
#pragma once

#include <shrefract/field.h>

#include <array>
#include <cstddef>
#include <cstdint>
#include <string>

namespace shrefract::fieldfile {

// Limits of the format (docs/field-format.md, "Limits"). They bound what a hostile file can ask for.
inline constexpr uint32_t kMaxAtlasSize = 16384;      // texels per side
inline constexpr uint32_t kMaxOrder = 32;             // SH order
inline constexpr uint32_t kMaxStringBytes = 65536;    // any length-prefixed string
inline constexpr uint32_t kSectionCount = 7;
// Largest magnitude of a Pca basis value. Direction channels (x, y, z): with |weights| <=
// kMaxCoefficientMagnitude and at most kMaxComponents functions every decoded sum stays below
// 1e15 * 8 * 1024 = 8.2e18, so the squared length of (x, y, z) stays below 2.1e38, finite in
// float. tau and throughput are clamped after decoding; a bound of 1e6 keeps their sums finite.
// Baked bases hold unit eigenvectors (direction entries within 1).
inline constexpr float kMaxBasisDirectionMagnitude = 8.0f;
inline constexpr float kMaxBasisMagnitude = 1e6f;
inline constexpr size_t kHeaderBytes = 40;
inline constexpr size_t kFrameBytes = 16;             // magic, version, file size: fixed in every version
inline constexpr size_t kSectionHeaderBytes = 12;     // tag, u64 payload length
inline constexpr size_t kChecksumBytes = 4;
inline constexpr size_t kSettingsFixedBytes = 164;
inline constexpr std::array<char, 4> kMagic{'S', 'H', 'R', 'F'};
// Smallest float magnitude that binary16 round-to-nearest-even turns into Inf (65504 + half a ulp).
inline constexpr float kHalfOverflow = 65520.0f;

struct SectionInfo {
  std::array<char, 4> tag;
  const char* label;  // as used in messages
};
inline constexpr std::array<SectionInfo, kSectionCount> kSections{{
    {{'S', 'E', 'T', 'S'}, "settings"},
    {{'M', 'D', 'I', 'A'}, "media"},
    {{'M', 'E', 'S', 'H'}, "mesh"},
    {{'A', 'T', 'L', 'S'}, "atlas"},
    {{'Q', 'T', 'B', 'L'}, "quantization"},
    {{'C', 'O', 'E', 'F'}, "coefficient"},
    {{'E', 'N', 'C', 'D'}, "encoding"},
}};

// CRC-32 (IEEE 802.3, reflected polynomial 0xEDB88320, init and final xor 0xFFFFFFFF): the
// checksum of zlib, PNG and gzip, so any tool can verify a file.
uint32_t crc32(const uint8_t* data, size_t size);

// Little-endian loads: a value may start at any byte, so it is assembled, never cast.
inline uint32_t loadU32(const uint8_t* p) {
  return static_cast<uint32_t>(p[0]) | (static_cast<uint32_t>(p[1]) << 8) | (static_cast<uint32_t>(p[2]) << 16) |
         (static_cast<uint32_t>(p[3]) << 24);
}

inline uint64_t loadU64(const uint8_t* p) {
  return static_cast<uint64_t>(loadU32(p)) | (static_cast<uint64_t>(loadU32(p + 4)) << 32);
}

// Words of messages: a float that reads back exactly, "0x0000abcd", raw bytes ("89 50 4e 47", for a
// magic or a tag that is not what it should be), "texel 9 (x 1, y 1)" and an errno's text.
std::string formatFloat(float value);
std::string hex32(uint32_t value);
std::string hexBytes(const uint8_t* p, size_t n);
std::string texelName(const Field& field, uint64_t texel);
std::string errnoMessage(int error);

}  // namespace shrefract::fieldfile
