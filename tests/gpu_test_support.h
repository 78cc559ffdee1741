// GPU tests: create a harness on the device chosen by VK_DRIVER_FILES (lavapipe in ctest), skip
// loudly with ctest's skip code when no Vulkan device exists, fail on any validation message.
#pragma once

#include <gtest/gtest.h>
#include <shrefract/harness/harness.h>

#include <cstdio>
#include <cstdlib>
#include <memory>

namespace shrefract::testing {

// ctest's SKIP_RETURN_CODE for GPU tests (set in tests/CMakeLists.txt).
inline constexpr int kSkipCode = 77;

// Returns a harness, or exits the process with kSkipCode when no Vulkan device exists.
inline std::unique_ptr<harness::Harness> harnessOrSkip() {
  harness::HarnessFailure failure = harness::HarnessFailure::None;
  auto h = harness::Harness::create(harness::HarnessOptions{}, &failure);
  if (!h.ok()) {
    if (failure == harness::HarnessFailure::NoDevice) {
      std::fprintf(stderr, "SKIPPED: no Vulkan device: %s\n", h.error().message.c_str());
      std::fflush(stderr);
      std::exit(kSkipCode);
    }
    ADD_FAILURE() << "harness creation failed: " << h.error().message;
    return nullptr;
  }
  return std::move(h).value();
}

// Teardown check: every GPU test ends with zero validation/performance messages.
#define SHREFRACT_EXPECT_NO_VALIDATION_MESSAGES(h)                                      \
  do {                                                                                  \
    EXPECT_EQ((h).messageCount(), 0u) << "validation messages were reported";           \
    for (const auto& m : (h).messages()) ADD_FAILURE() << "validation: " << m;          \
  } while (0)

}  // namespace shrefract::testing
