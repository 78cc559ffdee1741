// The raster pass: the environment as background and refractive objects over it, drawn with
// dynamic rendering into attachments the host provides.
//
// Contract for recordBackground()/recordObjects():
//  - the host has begun dynamic rendering (vkCmdBeginRendering) on `cmd` with one color attachment
//    of RendererCreateInfo::colorFormat and, if depthFormat is not UNDEFINED, a depth attachment of
//    that format (depth test LESS, cleared to 1.0);
//  - the host has set viewport and scissor (dynamic state) to the region to draw;
//  - the engine binds its own pipelines, descriptor sets, vertex/index buffers and push constants;
//    on return the host must rebind its own state before drawing.
//  - the background is drawn at the far plane without writing depth; objects write depth.
#pragma once

#include <shrefract/context.h>
#include <shrefract/environment.h>

#include <array>
#include <cstdint>
#include <memory>
#include <vector>

namespace shrefract {

struct Camera {
  std::array<float, 3> eye{0.0f, 0.0f, 4.0f};
  std::array<float, 3> target{0.0f, 0.0f, 0.0f};
  std::array<float, 3> up{0.0f, 1.0f, 0.0f};
  float verticalFovDegrees = 45.0f;
  float nearPlane = 0.01f;
  float farPlane = 1000.0f;
};

// A triangle mesh in world space with per-vertex unit normals and (optional) field texture
// coordinates. Static: fields are baked in world space.
struct MeshDesc {
  const float* positions = nullptr;  // vertexCount * 3
  const float* normals = nullptr;    // vertexCount * 3
  const float* fieldUvs = nullptr;   // vertexCount * 2, or nullptr
  uint32_t vertexCount = 0;
  const uint32_t* indices = nullptr;  // triangle list, indexCount / 3 triangles
  uint32_t indexCount = 0;
};

// Run-time shading parameters of an object; cheap to change every frame.
struct ObjectShading {
  float ior = 1.5f;                         // front-surface IOR (reflection and single-interface)
  float absorptionScale = 1.0f;             // k in exp2(-tau * k)
  std::array<float, 3> tint{1.0f, 1.0f, 1.0f};  // attenuation colour
  bool reflection = true;                   // add the front-surface Fresnel reflection
};

struct ObjectImpl;

class Object {
 public:
  // Creates the vertex and index buffers and records their upload into `cmd` (see Environment).
  static Result<std::unique_ptr<Object>> create(Context& context, const MeshDesc& mesh, VkCommandBuffer cmd);
  ~Object();
  Object(const Object&) = delete;
  Object& operator=(const Object&) = delete;

  ObjectShading shading;
  ObjectImpl& impl() { return *impl_; }

 private:
  explicit Object(std::unique_ptr<ObjectImpl> impl);
  std::unique_ptr<ObjectImpl> impl_;
};

enum class ShadingMode : uint32_t {
  SingleInterface = 0,  // one Snell bend at the front surface (what engines usually ship)
};

struct RendererCreateInfo {
  VkFormat colorFormat = VK_FORMAT_R16G16B16A16_SFLOAT;
  VkFormat depthFormat = VK_FORMAT_D32_SFLOAT;  // VK_FORMAT_UNDEFINED: no depth attachment
  float exposure = 1.0f;
};

struct RendererImpl;

class Renderer {
 public:
  static Result<std::unique_ptr<Renderer>> create(Context& context, const RendererCreateInfo& info);
  ~Renderer();
  Renderer(const Renderer&) = delete;
  Renderer& operator=(const Renderer&) = delete;

  // `extent` is the size of the host's viewport, for the camera's aspect ratio.
  void recordBackground(VkCommandBuffer cmd, const Environment& environment, const Camera& camera,
                        VkExtent2D extent);
  void recordObjects(VkCommandBuffer cmd, const Environment& environment, const Camera& camera, VkExtent2D extent,
                     const std::vector<Object*>& objects, ShadingMode mode = ShadingMode::SingleInterface);

 private:
  explicit Renderer(std::unique_ptr<RendererImpl> impl);
  std::unique_ptr<RendererImpl> impl_;
};

}  // namespace shrefract
