// Stage 6, tile ranges, reading the sorted keys through the frame's texel views (CPU
// drivers); see tile_ranges_body.glsl.
#version 460
#define FRAME_TEXELS
#include "tile_ranges_body.glsl"
