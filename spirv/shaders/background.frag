#version 460
// The environment seen through the camera: lat-long encoding.
#extension GL_GOOGLE_include_directive : require
#include "background_body.glsl"
