// Stage 7, rasterize, GPU layout (one invocation per pixel), no rara clipping
// (see rasterize_body.glsl).
#version 460
#define PIXELS_PER_INVOCATION 1
#define CUTOFF_WEIGHT 0
#include "rasterize_body.glsl"
