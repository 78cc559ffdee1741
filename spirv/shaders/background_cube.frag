#version 460
// The environment seen through the camera: cube-map encoding.
#extension GL_GOOGLE_include_directive : require
#define SHR_ENV_CUBE 1
#include "background_body.glsl"
