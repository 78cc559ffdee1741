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

// Expects no message in `log`: call it after the harness is destroyed, so that what the layer
// reports while the device and instance go (leaked objects) counts too.
inline void expectNoMessages(const harness::MessageLog& log) {
  EXPECT_EQ(log.count(), 0u) << "validation messages were reported (teardown included)";
  for (const auto& m : log.messages()) ADD_FAILURE() << "validation: " << m;
}

// Destroys the harness (device, then instance) and expects no message from its whole life.
inline void expectNoMessagesThroughDestruction(std::unique_ptr<harness::Harness>& h) {
  if (!h) return;
  const auto log = h->messageLog();
  h.reset();
  expectNoMessages(*log);
}

// The same for an owner of a harness (offscreen::Session: it destroys its engine objects first).
template <class Owner>
  requires requires(Owner& o) { o.harness->messageLog(); }
void expectNoMessagesThroughDestruction(std::unique_ptr<Owner>& owner) {
  if (!owner || !owner->harness) return;
  const auto log = owner->harness->messageLog();
  owner.reset();
  expectNoMessages(*log);
}

}  // namespace shrefract::testing
