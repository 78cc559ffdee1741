#version 460
#extension GL_GOOGLE_include_directive : require
#include "object_volume_body.glsl"
