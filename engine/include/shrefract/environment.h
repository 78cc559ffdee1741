// An environment map on the GPU: the distant surroundings that refracted and reflected rays see.
#pragma once

#include <shrefract/context.h>

#include <cstdint>
#include <memory>

namespace shrefract {

struct EnvironmentImpl;

struct LatLongEnvironmentDesc {
  uint32_t width = 0;            // 2:1 lat-long (equirectangular); see docs/environment-maps.md
  uint32_t height = 0;
  const float* rgba = nullptr;   // width*height*4 linear floats, row 0 = zenith; finite, >= 0
};

class Environment {
 public:
  // Creates the image and records its upload into `cmd` (a host command buffer in the recording
  // state, on the context's queue family). The image is ready for sampling once `cmd` has executed;
  // the staging buffer is retired through the context's deferred destruction.
  // On return the image is in SHADER_READ_ONLY_OPTIMAL (after `cmd` executes).
  static Result<std::unique_ptr<Environment>> createLatLong(Context& context, const LatLongEnvironmentDesc& desc,
                                                            VkCommandBuffer cmd);
  ~Environment();  // retires its resources through the context's deferred destruction
  Environment(const Environment&) = delete;
  Environment& operator=(const Environment&) = delete;

  EnvironmentImpl& impl() { return *impl_; }
  const EnvironmentImpl& impl() const { return *impl_; }

 private:
  explicit Environment(std::unique_ptr<EnvironmentImpl> impl);
  std::unique_ptr<EnvironmentImpl> impl_;
};

}  // namespace shrefract
