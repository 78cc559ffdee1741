// The checksum and the message words of field_file.h.
#include "field/field_file.h"

#include <cstdio>
#include <sstream>
#include <system_error>

namespace shrefract::fieldfile {
namespace {

constexpr std::array<uint32_t, 256> makeCrcTable() {
  std::array<uint32_t, 256> table{};
  for (uint32_t i = 0; i < 256; ++i) {
    uint32_t c = i;
    for (int k = 0; k < 8; ++k) c = (c & 1u) ? (0xEDB88320u ^ (c >> 1)) : (c >> 1);
    table[i] = c;
  }
  return table;
}
constexpr std::array<uint32_t, 256> kCrcTable = makeCrcTable();

}  // namespace

uint32_t crc32(const uint8_t* data, size_t size) {
  uint32_t c = 0xFFFFFFFFu;
  for (size_t i = 0; i < size; ++i) c = kCrcTable[(c ^ data[i]) & 0xFFu] ^ (c >> 8);
  return c ^ 0xFFFFFFFFu;
}

std::string formatFloat(float value) {
  std::ostringstream out;
  out.precision(9);
  out << value;
  return out.str();
}

std::string hex32(uint32_t value) {
  char buffer[11];
  std::snprintf(buffer, sizeof buffer, "0x%08x", static_cast<unsigned>(value));
  return buffer;
}

// "89 50 4e 47": raw bytes for messages about a magic or a tag that is not what it should be.
std::string hexBytes(const uint8_t* p, size_t n) {
  std::string out;
  for (size_t i = 0; i < n; ++i) {
    char buffer[4];
    std::snprintf(buffer, sizeof buffer, "%02x", static_cast<unsigned>(p[i]));
    if (i) out += ' ';
    out += buffer;
  }
  return out;
}

std::string texelName(const Field& field, uint64_t texel) {
  return "texel " + std::to_string(texel) + " (x " + std::to_string(texel % field.width) + ", y " +
         std::to_string(texel / field.width) + ")";
}

std::string errnoMessage(int error) { return std::generic_category().message(error); }

}  // namespace shrefract::fieldfile
