// The writer of the .shrf bytes: little-endian values, length-prefixed strings and arrays, and
// sections whose length is patched in once their payload is written. Private to engine/src/field.
#pragma once

#include <array>
#include <bit>
#include <cstddef>
#include <cstdint>
#include <string>
#include <vector>

namespace shrefract::fieldfile {

class ByteWriter {
 public:
  void u8(uint8_t v) { bytes_.push_back(v); }
  void u16(uint16_t v) {
    u8(static_cast<uint8_t>(v & 0xFFu));
    u8(static_cast<uint8_t>(v >> 8));
  }
  void u32(uint32_t v) {
    for (int k = 0; k < 4; ++k) u8(static_cast<uint8_t>((v >> (8 * k)) & 0xFFu));
  }
  void u64(uint64_t v) {
    for (int k = 0; k < 8; ++k) u8(static_cast<uint8_t>((v >> (8 * k)) & 0xFFu));
  }
  void f32(float v) { u32(std::bit_cast<uint32_t>(v)); }
  void f64(double v) { u64(std::bit_cast<uint64_t>(v)); }
  void tag(const std::array<char, 4>& t) {
    for (char c : t) u8(static_cast<uint8_t>(c));
  }
  void string(const std::string& s) {
    u32(static_cast<uint32_t>(s.size()));
    bytes_.insert(bytes_.end(), s.begin(), s.end());
  }
  void arrayU8(const std::vector<uint8_t>& v) {
    u64(v.size());
    bytes_.insert(bytes_.end(), v.begin(), v.end());
  }
  void arrayU16(const std::vector<uint16_t>& v) {
    u64(v.size());
    for (uint16_t x : v) u16(x);
  }
  void arrayU32(const std::vector<uint32_t>& v) {
    u64(v.size());
    for (uint32_t x : v) u32(x);
  }
  void arrayF32(const std::vector<float>& v) {
    u64(v.size());
    for (float x : v) f32(x);
  }

  // Sections: beginSection writes the tag and a placeholder length that endSection patches.
  void beginSection(const std::array<char, 4>& t) {
    tag(t);
    sectionStart_ = bytes_.size();
    u64(0);
  }
  void endSection() { patchU64(sectionStart_, bytes_.size() - sectionStart_ - 8); }

  void patchU64(size_t at, uint64_t v) {
    for (int k = 0; k < 8; ++k) bytes_[at + static_cast<size_t>(k)] = static_cast<uint8_t>((v >> (8 * k)) & 0xFFu);
  }
  std::vector<uint8_t>& bytes() { return bytes_; }

 private:
  std::vector<uint8_t> bytes_;
  size_t sectionStart_ = 0;
};

}  // namespace shrefract::fieldfile
