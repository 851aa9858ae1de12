// Stage 2, depth order, first step: the depth keys, reading through the frame's texel views
// (CPU drivers); see depth_keys_body.glsl.
#version 460
#define FRAME_TEXELS
#include "depth_keys_body.glsl"
