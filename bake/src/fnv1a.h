// FNV-1a, 64 bits: the part file's checksum (part_format.cpp) and the scene fingerprint that a
// merge checks its parts against (driver/plan.cpp). Internal to the bake.
#pragma once

#include <cstddef>
#include <cstdint>
#include <vector>

namespace shrefract::bake {

class Fnv1a {
 public:
  // The bytes of `count` values: fields one by one where a struct may have padding.
  template <class T>
  void add(const T* data, size_t count) {
    const auto* bytes = reinterpret_cast<const unsigned char*>(data);
    for (size_t i = 0; i < count * sizeof(T); ++i) hash_ = (hash_ ^ bytes[i]) * 0x100000001b3ull;
  }
  // The size, then the values.
  template <class T>
  void add(const std::vector<T>& v) {
    const uint64_t n = v.size();
    add(&n, 1);
    add(v.data(), v.size());
  }
  uint64_t value() const { return hash_; }

 private:
  uint64_t hash_ = 0xcbf29ce484222325ull;
};

}  // namespace shrefract::bake
