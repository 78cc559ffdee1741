#version 460
#extension GL_GOOGLE_include_directive : require
#include "shrefract/gpu_layout.h"
#include "shrefract/environment.glsl"

layout(set = 0, binding = kBindingEnvironment) uniform sampler2D environmentMap;
layout(location = 0) in vec3 inDirection;
layout(location = 0) out vec4 outColor;

void main() {
  outColor = vec4(sampleEnvironment(environmentMap, inDirection), 1.0);
}
