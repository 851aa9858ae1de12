// Stage 4, emit, for rara clipping by planes with the mass weight: cutoff splats' pairs are
// classified per tile by the next stage (see emit_body.glsl, cutoff_tiles.comp).
#version 460
#define RECORD_CUTOFF_PAIRS
#include "emit_body.glsl"
