#version 460
#extension GL_GOOGLE_include_directive : require
#define SHR_ENV_CUBE 1
#include "object_volume_body.glsl"
