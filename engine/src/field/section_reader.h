// The reader of one .shrf section's payload: it never trusts a length, checking every count against
// the bytes that remain before anything is allocated for it. Private to engine/src/field.
#pragma once

#include <bit>
#include <cstddef>
#include <cstdint>
#include <string>
#include <vector>

#include "field/field_file.h"

namespace shrefract::fieldfile {

// Reads one section's payload. Errors are sticky: after the first failure every read returns zero
// and allocates nothing, so a section parser checks failed() once at the end.
class SectionReader {
 public:
  SectionReader(const uint8_t* data, size_t size, const std::string& name, const char* section)
      : data_(data), size_(size), name_(name), section_(section) {}

  bool failed() const { return failed_; }
  const std::string& message() const { return message_; }
  size_t remaining() const { return size_ - pos_; }
  size_t consumed() const { return pos_; }

  void fail(const std::string& problem) {
    if (failed_) return;
    failed_ = true;
    message_ = name_ + ": " + problem;
  }

  // Whether `bytes` more bytes are there; fails with a truncation message naming `what` if not.
  bool need(uint64_t bytes, const char* what) {
    if (failed_) return false;
    if (bytes > remaining()) {
      fail(std::string("truncated: ") + section_ + " section: " + what + " needs " + std::to_string(bytes) +
           " bytes, " + std::to_string(remaining()) + " left");
      return false;
    }
    return true;
  }

  uint32_t u32(const char* what) {
    if (!need(4, what)) return 0;
    const uint32_t v = loadU32(data_ + pos_);
    pos_ += 4;
    return v;
  }
  uint64_t u64(const char* what) {
    if (!need(8, what)) return 0;
    const uint64_t v = loadU64(data_ + pos_);
    pos_ += 8;
    return v;
  }
  float f32(const char* what) { return std::bit_cast<float>(u32(what)); }
  double f64(const char* what) { return std::bit_cast<double>(u64(what)); }

  void string(std::string& out, const char* what) {
    const uint32_t length = u32(what);
    if (failed_) return;
    if (length > kMaxStringBytes) {
      fail(std::string(section_) + " section: " + what + " is " + std::to_string(length) + " bytes, over the cap of " +
           std::to_string(kMaxStringBytes));
      return;
    }
    if (!need(length, what)) return;
    out.assign(reinterpret_cast<const char*>(data_ + pos_), length);
    pos_ += length;
  }

  // Array: u64 element count, then the elements. The count is checked against the remaining
  // bytes before anything is allocated.
  template <class T, class Decode>
  void array(std::vector<T>& out, size_t elementBytes, const char* what, Decode decode) {
    const uint64_t count = u64(what);
    if (failed_) return;
    if (count > remaining() / elementBytes) {
      fail(std::string("truncated: ") + section_ + " section: " + what + " (" + std::to_string(count) +
           " elements) needs " + std::to_string(count) + " x " + std::to_string(elementBytes) + " bytes, " +
           std::to_string(remaining()) + " left");
      return;
    }
    out.resize(static_cast<size_t>(count));
    const uint8_t* p = data_ + pos_;
    for (size_t i = 0; i < out.size(); ++i) out[i] = decode(p + i * elementBytes);
    pos_ += static_cast<size_t>(count) * elementBytes;
  }
  void arrayU8(std::vector<uint8_t>& out, const char* what) {
    array(out, 1, what, [](const uint8_t* p) { return p[0]; });
  }
  void arrayU16(std::vector<uint16_t>& out, const char* what) {
    array(out, 2, what, [](const uint8_t* p) {
      return static_cast<uint16_t>(static_cast<uint32_t>(p[0]) | (static_cast<uint32_t>(p[1]) << 8));
    });
  }
  void arrayU32(std::vector<uint32_t>& out, const char* what) { array(out, 4, what, loadU32); }
  void arrayF32(std::vector<float>& out, const char* what) {
    array(out, 4, what, [](const uint8_t* p) { return std::bit_cast<float>(loadU32(p)); });
  }

 private:
  const uint8_t* data_;
  size_t size_;
  size_t pos_ = 0;
  const std::string& name_;
  const char* section_;
  bool failed_ = false;
  std::string message_;
};

}  // namespace shrefract::fieldfile
