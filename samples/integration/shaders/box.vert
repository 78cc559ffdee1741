#version 460
// The host's own opaque geometry: an axis-aligned box generated from gl_VertexIndex (36 vertices,
// 6 faces of 2 triangles), so the sample needs no vertex buffer. Faces wind counter-clockwise seen
// from outside, the same convention as shrefract's meshes, because the host uses the engine's
// projection (Vulkan clip space, y down) with VK_FRONT_FACE_COUNTER_CLOCKWISE and back-face culling.

layout(push_constant) uniform Push {
  mat4 clipFromWorld;  // the same matrix the engine derives from shrefract::Camera
  vec4 centerHalf;     // xyz: box centre in world space, w: half the edge length
  vec4 color;          // linear RGB
} pc;

layout(location = 0) flat out vec3 outNormal;

const vec3 kNormals[6] = vec3[](vec3(1, 0, 0), vec3(-1, 0, 0), vec3(0, 1, 0), vec3(0, -1, 0), vec3(0, 0, 1),
                                vec3(0, 0, -1));
const vec2 kQuad[6] = vec2[](vec2(-1, -1), vec2(1, -1), vec2(1, 1), vec2(-1, -1), vec2(1, 1), vec2(-1, 1));

void main() {
  vec3 n = kNormals[gl_VertexIndex / 6];
  // u x v = n, so a counter-clockwise quad in (u, v) is counter-clockwise seen from outside.
  vec3 u = n.yzx;
  vec3 v = cross(n, u);
  vec2 q = kQuad[gl_VertexIndex % 6];
  vec3 corner = n + q.x * u + q.y * v;  // in [-1, 1]^3
  outNormal = n;
  gl_Position = pc.clipFromWorld * vec4(pc.centerHalf.xyz + pc.centerHalf.w * corner, 1.0);
}
