#version 460
// Flat shading with one fixed light: enough to see the box's faces. The output is linear; the
// host's R8G8B8A8_SRGB target encodes it, as it does for the engine's passes.

layout(push_constant) uniform Push {
  mat4 clipFromWorld;
  vec4 centerHalf;
  vec4 color;
} pc;

layout(location = 0) flat in vec3 inNormal;
layout(location = 0) out vec4 outColor;

void main() {
  vec3 light = normalize(vec3(0.4, 0.8, 0.6));
  float brightness = 0.6 + 0.4 * max(dot(inNormal, light), 0.0);
  outColor = vec4(pc.color.rgb * brightness, 1.0);
}
