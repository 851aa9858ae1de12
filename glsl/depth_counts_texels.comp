// Stage 2, depth order, last step: the tiles touched in depth order, reading through the
// frame's texel views (CPU drivers); see depth_counts_body.glsl.
#version 460
#define FRAME_TEXELS
#include "depth_counts_body.glsl"
