// Stage 4b, cutoff tiles, reading the splats, the cutoff records, the tiles touched and the
// emitted keys through the frame's texel views (CPU drivers; see cutoff_tiles_body.glsl).
#version 460
#define SPLAT_TEXELS
#include "cutoff_tiles_body.glsl"
