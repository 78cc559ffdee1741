// Background pass fragment shader body (see background.frag / background_cube.frag).
#include "shrefract/gpu_layout.h"
#include "environment_select.glsl"

layout(location = 0) in vec3 inDirection;
layout(location = 0) out vec4 outColor;

void main() {
  outColor = vec4(lookupEnvironment(inDirection), 1.0);
}
