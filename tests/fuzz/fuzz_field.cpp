// libFuzzer target: the `.shrf` reader (parseField) on arbitrary bytes.
//
// Beyond "no crash, no leak, no undefined behaviour" (the sanitizers), a file that parses must
// keep the reader's promises, and a violation aborts (a finding):
//  - it passes validateField and survives serializeField -> parseField bit for bit;
//  - its decode is finite: the CPU reference of the decompression (reference::decodeTexel) gives no
//    NaN or Inf for any texel, from eyes in front, behind, far away and at a sample's position
//    (eyes within 1e22 of the origin: see kMaxFrameMagnitude in field.h).
#include <shrefract/cpu_reference.h>
#include <shrefract/field.h>

#include <cmath>
#include <cstdint>
#include <cstdio>
#include <cstdlib>
#include <vector>

namespace {

[[noreturn]] void finding(const char* what) {
  std::fprintf(stderr, "fuzz_field: %s\n", what);
  std::abort();
}

uint32_t crc32(const uint8_t* data, size_t size) {
  uint32_t crc = 0xFFFFFFFFu;
  for (size_t i = 0; i < size; ++i) {
    crc ^= data[i];
    for (int k = 0; k < 8; ++k) crc = (crc >> 1) ^ (0xEDB88320u & (0u - (crc & 1u)));
  }
  return ~crc;
}

void checkParsed(const uint8_t* data, size_t size) {
  auto parsed = shrefract::parseField(data, size, "fuzz.shrf");
  if (!parsed) {
    if (parsed.error().message.empty()) finding("error without a message");
    return;
  }
  const shrefract::Field& field = parsed.value();
  if (!shrefract::validateField(field)) finding("parseField accepted a field that validateField rejects");
  const std::vector<uint8_t> again = shrefract::serializeField(field);
  auto reparsed = shrefract::parseField(again.data(), again.size(), "again.shrf");
  if (!reparsed) finding("a parsed field does not parse after serializeField");
  if (shrefract::serializeField(reparsed.value()) != again) finding("serialize -> parse -> serialize differs");

  // Decode every texel (bounded: the work is texels x basis functions, or for a Volume field its
  // trace's interfaces, each marched in at most kVolumeMaxSteps steps) from a few eyes.
  const uint64_t work = field.encoding == shrefract::Encoding::Volume
                            ? field.texelCount() * (uint64_t(field.settings.maxBounces) + 1) * 256
                            : field.texelCount() * field.basisCount();
  if (work > (uint64_t(1) << 20)) return;
  std::vector<shrefract::reference::Vec3> eyes = {{0.0f, 0.0f, 5.0f}, {0.0f, 0.0f, -5.0f}, {3e4f, -2e4f, 1e4f}};
  for (uint64_t t = 0; t < field.texelCount(); ++t) {
    if (field.texelKinds[t] == shrefract::kTexelSample) {
      // The eye on the first sample (exactly, for an orthonormal frame): M_s (eye, 1) = 0, the
      // zero direction that the decompression turns into +z.
      const float* m = &field.frames[t * 12];
      shrefract::reference::Vec3 eye{0.0f, 0.0f, 0.0f};
      for (int r = 0; r < 3; ++r)
        for (int k = 0; k < 3; ++k) eye[size_t(k)] -= m[4 * r + 3] * m[4 * r + k];
      // The promise holds for eyes within 1e22 of the origin (kMaxFrameMagnitude, field.h).
      if (std::fabs(eye[0]) <= 1e22f && std::fabs(eye[1]) <= 1e22f && std::fabs(eye[2]) <= 1e22f) eyes.push_back(eye);
      break;
    }
  }
  for (const auto& eye : eyes)
    for (uint64_t t = 0; t < field.texelCount(); ++t) {
      const shrefract::reference::Vec4 v = shrefract::reference::decodeTexel(field, t, eye);
      for (float x : v)
        if (!std::isfinite(x)) finding("a texel decodes to NaN or Inf");
    }
}

}  // namespace

// Each input is parsed as it is, and again with its frame repaired (fileSize set to the size, the
// CRC-32 recomputed): random mutations almost never keep the checksum, and without the repair the
// fuzzer would not get past it to the sections.
extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  checkParsed(data, size);
  if (size >= 20) {
    std::vector<uint8_t> repaired(data, data + size);
    for (int k = 0; k < 8; ++k) repaired[8 + size_t(k)] = uint8_t(uint64_t(size) >> (8 * k));
    const uint32_t crc = crc32(repaired.data(), size - 4);
    for (int k = 0; k < 4; ++k) repaired[size - 4 + size_t(k)] = uint8_t(crc >> (8 * k));
    checkParsed(repaired.data(), repaired.size());
  }
  return 0;
}
