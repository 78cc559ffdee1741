// Synchronization, proven by the validation layer's synchronization validation (on in every GPU
// test through HarnessOptions::synchronizationValidation):
//  - a host that records the field upload and the decompression into one command buffer (the case
//    where the upload barrier alone orders them) gets the CPU reference's image and no hazard;
//  - the check can fail: a recording with a deliberately missing barrier is reported, and so is an
//    object leaked past vkDestroyDevice, which is only seen after the harness is destroyed.
#include <gtest/gtest.h>
#include <shrefract/cpu_reference.h>
#include <shrefract/decompressor.h>

#include "engine/distortion_check.h"
#include "engine/synthetic_field.h"

namespace shrefract {
namespace {

harness::HarnessOptions quietOptions() {
  harness::HarnessOptions o;
  o.echoMessages = false;  // the planted faults below are expected to be reported
  return o;
}

TEST(Synchronization, UploadAndDecompressionInOneCommandBuffer) {
  auto h = testing::harnessOrSkip();
  ASSERT_TRUE(h);
  auto context = testing::createContext(*h);
  ASSERT_TRUE(context.ok()) << context.error().message;
  auto decompressor = Decompressor::create(*context.value());
  ASSERT_TRUE(decompressor.ok()) << decompressor.error().message;

  for (Encoding encoding : {Encoding::Sh, Encoding::Table, Encoding::Pca}) {
    SCOPED_TRACE(toString(encoding));
    testing::SyntheticFieldOptions options;
    options.encoding = encoding;
    options.order = 4;
    options.tableSize = 6;
    options.components = 5;
    options.quantization = Quantization::U8;
    options.channels = 4;
    options.emptyAndGutters = true;
    const Field field = testing::makeSyntheticField(options);
    ASSERT_TRUE(validateField(field).ok()) << validateField(field).error().message;

    const std::array<float, 3> eye{0.4f, -0.7f, 2.5f};
    std::unique_ptr<Object> object;
    Result<void> recorded;
    auto submitted = h->submitAndWait([&](VkCommandBuffer cmd) {
      auto created = Object::createFromField(*context.value(), field, cmd);
      if (!created) {
        recorded = created.error();
        return;
      }
      object = std::move(created).value();
      recorded = decompressor.value()->record(cmd, eye, {object.get()});
    });
    ASSERT_TRUE(submitted.ok()) << submitted.error().message;
    ASSERT_TRUE(recorded.ok()) << recorded.error().message;
    auto gpu = testing::readDistortion(*h, *object);
    ASSERT_TRUE(gpu.ok()) << gpu.error().message;
    testing::DistortionStats stats;
    testing::compareDistortion(field, gpu.value(), reference::decompress(field, eye),
                               {/*direction=*/1e-3f, /*tauRelative=*/1e-3f, /*gutter=*/3e-3f}, stats);
    EXPECT_GT(stats.samples, 0u);
    object.reset();
    context.value()->releaseDeferred();
  }
  decompressor.value().reset();
  context.value().reset();
  testing::expectNoMessagesThroughDestruction(h);
}

// Copy into a buffer, then copy out of it with no barrier between: a read-after-write hazard.
TEST(Synchronization, MissingBarrierIsReported) {
  auto created = harness::Harness::create(quietOptions());
  if (!created) GTEST_SKIP() << created.error().message;  // harnessOrSkip decides skips for the suite
  auto h = std::move(created).value();
  auto a = h->createHostBuffer(256, VK_BUFFER_USAGE_TRANSFER_SRC_BIT);
  auto b = h->createHostBuffer(256, VK_BUFFER_USAGE_TRANSFER_SRC_BIT | VK_BUFFER_USAGE_TRANSFER_DST_BIT);
  auto c = h->createHostBuffer(256, VK_BUFFER_USAGE_TRANSFER_DST_BIT);
  ASSERT_TRUE(a.ok() && b.ok() && c.ok());
  ASSERT_TRUE(h->submitAndWait([&](VkCommandBuffer cmd) {
                 const VkBufferCopy region{0, 0, 256};
                 vkCmdCopyBuffer(cmd, a.value().buffer, b.value().buffer, 1, &region);
                 vkCmdCopyBuffer(cmd, b.value().buffer, c.value().buffer, 1, &region);
               }).ok());
  EXPECT_GT(h->messageCount(), 0u) << "synchronization validation did not report the missing barrier";
  bool hazard = false;
  for (const auto& m : h->messages()) hazard = hazard || m.find("SYNC-HAZARD") != std::string::npos;
  EXPECT_TRUE(hazard);
  h->destroyBuffer(a.value());
  h->destroyBuffer(b.value());
  h->destroyBuffer(c.value());
}

// A buffer never destroyed is reported by vkDestroyDevice: after the harness is gone.
TEST(Synchronization, LeakIsReportedAtDestruction) {
  auto created = harness::Harness::create(quietOptions());
  if (!created) GTEST_SKIP() << created.error().message;
  auto h = std::move(created).value();
  VkBufferCreateInfo bci{VK_STRUCTURE_TYPE_BUFFER_CREATE_INFO};
  bci.size = 64;
  bci.usage = VK_BUFFER_USAGE_TRANSFER_DST_BIT;
  VkBuffer leaked = VK_NULL_HANDLE;
  ASSERT_EQ(vkCreateBuffer(h->device(), &bci, nullptr, &leaked), VK_SUCCESS);
  EXPECT_EQ(h->messageCount(), 0u);
  const auto log = h->messageLog();
  h.reset();
  EXPECT_GT(log->count(), 0u) << "the leaked buffer was not reported when the device was destroyed";
}

}  // namespace
}  // namespace shrefract
