// Stage 7, rasterize, CPU-driver layout (16-pixel column strips), no rara clipping
// (see rasterize_body.glsl).
#version 460
#define PIXELS_PER_INVOCATION 16
#define CUTOFF_WEIGHT 0
#include "rasterize_body.glsl"
