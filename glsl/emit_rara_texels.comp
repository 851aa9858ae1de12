// Stage 4, emit for rara clipping by planes with the mass weight, reading the depth order, the
// first pairs and the projected splats through the frame's texel views (CPU drivers; see
// emit_body.glsl, cutoff_tiles.comp).
#version 460
#define RECORD_CUTOFF_PAIRS
#define SPLAT_TEXELS
#include "emit_body.glsl"
