// Background pass fragment shader body (see background.frag / background_cube.frag).
#include "shrefract/gpu_layout.h"
#include "environment_select.glsl"

layout(location = 0) in vec3 inDirection;
layout(location = 0) out vec4 outColor;

void main() {
  // Level 0: the background is measured against the CPU reference's level 0 lookups, and a camera
  // ray spans less than an environment texel at the views and maps in use (docs/technique.md).
  outColor = vec4(lookupEnvironment(inDirection, 0.0), 1.0);
}
