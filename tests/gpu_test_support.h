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

// `created` (a harness, or an owner of one), or the process exits with kSkipCode when `failure`
// says no Vulkan device exists; null after a test failure (naming `what`) for any other error.
template <class T>
std::unique_ptr<T> createdOrSkip(Result<std::unique_ptr<T>> created, const harness::HarnessFailure& failure,
                                 const char* what) {
  if (created.ok()) return std::move(created).value();
  if (failure == harness::HarnessFailure::NoDevice) {
    std::fprintf(stderr, "SKIPPED: no Vulkan device: %s\n", created.error().message.c_str());
    std::fflush(stderr);
    std::exit(kSkipCode);
  }
  ADD_FAILURE() << what << " creation failed: " << created.error().message;
  return nullptr;
}

// Returns a harness, or exits the process with kSkipCode when no Vulkan device exists.
inline std::unique_ptr<harness::Harness> harnessOrSkip() {
  harness::HarnessFailure failure = harness::HarnessFailure::None;
  return createdOrSkip(harness::Harness::create(harness::HarnessOptions{}, &failure), failure, "harness");
}

// A test compute shader (tests/*.comp, embedded by the build) reading binding 0 and writing
// binding 1, both storage buffers, with `pushBytes` of push constants: the scaffold the GPU tests
// of shared GLSL functions run on. Destroys its objects with itself (before the harness).
class TestComputeShader {
 public:
  TestComputeShader(VkDevice device, const uint32_t* code, size_t codeBytes, uint32_t pushBytes,
                    VkBuffer input, VkBuffer output)
      : device_(device), pushBytes_(pushBytes) {
    VkShaderModuleCreateInfo smci{VK_STRUCTURE_TYPE_SHADER_MODULE_CREATE_INFO};
    smci.codeSize = codeBytes;
    smci.pCode = code;
    ok_ = vkCreateShaderModule(device, &smci, nullptr, &module_) == VK_SUCCESS;
    VkDescriptorSetLayoutBinding bindings[2] = {};
    for (uint32_t b = 0; b < 2; ++b) bindings[b] = {b, VK_DESCRIPTOR_TYPE_STORAGE_BUFFER, 1, VK_SHADER_STAGE_COMPUTE_BIT, nullptr};
    VkDescriptorSetLayoutCreateInfo dslci{VK_STRUCTURE_TYPE_DESCRIPTOR_SET_LAYOUT_CREATE_INFO};
    dslci.bindingCount = 2;
    dslci.pBindings = bindings;
    ok_ = ok_ && vkCreateDescriptorSetLayout(device, &dslci, nullptr, &setLayout_) == VK_SUCCESS;
    const VkPushConstantRange range{VK_SHADER_STAGE_COMPUTE_BIT, 0, pushBytes};
    VkPipelineLayoutCreateInfo plci{VK_STRUCTURE_TYPE_PIPELINE_LAYOUT_CREATE_INFO};
    plci.setLayoutCount = 1;
    plci.pSetLayouts = &setLayout_;
    plci.pushConstantRangeCount = 1;
    plci.pPushConstantRanges = &range;
    ok_ = ok_ && vkCreatePipelineLayout(device, &plci, nullptr, &layout_) == VK_SUCCESS;
    VkComputePipelineCreateInfo cpci{VK_STRUCTURE_TYPE_COMPUTE_PIPELINE_CREATE_INFO};
    cpci.stage = {VK_STRUCTURE_TYPE_PIPELINE_SHADER_STAGE_CREATE_INFO, nullptr, 0, VK_SHADER_STAGE_COMPUTE_BIT,
                  module_, "main", nullptr};
    cpci.layout = layout_;
    ok_ = ok_ && vkCreateComputePipelines(device, VK_NULL_HANDLE, 1, &cpci, nullptr, &pipeline_) == VK_SUCCESS;
    const VkDescriptorPoolSize poolSize{VK_DESCRIPTOR_TYPE_STORAGE_BUFFER, 2};
    VkDescriptorPoolCreateInfo dpci{VK_STRUCTURE_TYPE_DESCRIPTOR_POOL_CREATE_INFO};
    dpci.maxSets = 1;
    dpci.poolSizeCount = 1;
    dpci.pPoolSizes = &poolSize;
    ok_ = ok_ && vkCreateDescriptorPool(device, &dpci, nullptr, &pool_) == VK_SUCCESS;
    VkDescriptorSetAllocateInfo dsai{VK_STRUCTURE_TYPE_DESCRIPTOR_SET_ALLOCATE_INFO};
    dsai.descriptorPool = pool_;
    dsai.descriptorSetCount = 1;
    dsai.pSetLayouts = &setLayout_;
    ok_ = ok_ && vkAllocateDescriptorSets(device, &dsai, &set_) == VK_SUCCESS;
    if (!ok_) return;
    const VkDescriptorBufferInfo infos[2] = {{input, 0, VK_WHOLE_SIZE}, {output, 0, VK_WHOLE_SIZE}};
    VkWriteDescriptorSet writes[2] = {};
    for (uint32_t b = 0; b < 2; ++b) {
      writes[b] = {VK_STRUCTURE_TYPE_WRITE_DESCRIPTOR_SET};
      writes[b].dstSet = set_;
      writes[b].dstBinding = b;
      writes[b].descriptorCount = 1;
      writes[b].descriptorType = VK_DESCRIPTOR_TYPE_STORAGE_BUFFER;
      writes[b].pBufferInfo = &infos[b];
    }
    vkUpdateDescriptorSets(device, 2, writes, 0, nullptr);
  }
  ~TestComputeShader() {
    if (pool_) vkDestroyDescriptorPool(device_, pool_, nullptr);
    if (pipeline_) vkDestroyPipeline(device_, pipeline_, nullptr);
    if (layout_) vkDestroyPipelineLayout(device_, layout_, nullptr);
    if (setLayout_) vkDestroyDescriptorSetLayout(device_, setLayout_, nullptr);
    if (module_) vkDestroyShaderModule(device_, module_, nullptr);
  }
  TestComputeShader(const TestComputeShader&) = delete;
  TestComputeShader& operator=(const TestComputeShader&) = delete;

  bool ok() const { return ok_; }
  // Records `groups` workgroups with `push`, then makes the output visible to the host.
  void record(VkCommandBuffer cmd, const void* push, uint32_t groups) const {
    vkCmdBindPipeline(cmd, VK_PIPELINE_BIND_POINT_COMPUTE, pipeline_);
    vkCmdBindDescriptorSets(cmd, VK_PIPELINE_BIND_POINT_COMPUTE, layout_, 0, 1, &set_, 0, nullptr);
    vkCmdPushConstants(cmd, layout_, VK_SHADER_STAGE_COMPUTE_BIT, 0, pushBytes_, push);
    vkCmdDispatch(cmd, groups, 1, 1);
    VkMemoryBarrier toHost{VK_STRUCTURE_TYPE_MEMORY_BARRIER};
    toHost.srcAccessMask = VK_ACCESS_SHADER_WRITE_BIT;
    toHost.dstAccessMask = VK_ACCESS_HOST_READ_BIT;
    vkCmdPipelineBarrier(cmd, VK_PIPELINE_STAGE_COMPUTE_SHADER_BIT, VK_PIPELINE_STAGE_HOST_BIT, 0, 1, &toHost, 0,
                         nullptr, 0, nullptr);
  }

 private:
  VkDevice device_;
  uint32_t pushBytes_;
  bool ok_ = false;
  VkShaderModule module_ = VK_NULL_HANDLE;
  VkDescriptorSetLayout setLayout_ = VK_NULL_HANDLE;
  VkPipelineLayout layout_ = VK_NULL_HANDLE;
  VkPipeline pipeline_ = VK_NULL_HANDLE;
  VkDescriptorPool pool_ = VK_NULL_HANDLE;
  VkDescriptorSet set_ = VK_NULL_HANDLE;
};

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
