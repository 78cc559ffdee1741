// The GPU tests that render through offscreen/ (a harness with an engine context on it): one
// fixture, so that every such test skips and counts validation messages the same way.
#pragma once

#include <gtest/gtest.h>

#include <memory>

#include "gpu_test_support.h"
#include "offscreen/offscreen.h"

namespace shrefract::testing {

// An offscreen session (validation on), or the process exits with kSkipCode when no Vulkan device
// exists; null after a test failure for any other error.
inline std::unique_ptr<offscreen::Session> sessionOrSkip() {
  harness::HarnessFailure failure = harness::HarnessFailure::None;
  return createdOrSkip(offscreen::createSession(harness::HarnessOptions{}, &failure), failure, "session");
}

// A session for each test; the test fails on any validation message of its whole life (the
// teardown of the device and instance included).
class SessionTest : public ::testing::Test {
 protected:
  void SetUp() override {
    session = sessionOrSkip();
    ASSERT_TRUE(session);
  }
  void TearDown() override { expectNoMessagesThroughDestruction(session); }
  std::unique_ptr<offscreen::Session> session;
};

}  // namespace shrefract::testing
