// Stage 7, rasterize, GPU layout, rara clipping with the length weight
// (see rasterize_body.glsl).
#version 460
#define PIXELS_PER_INVOCATION 1
#define CUTOFF_WEIGHT CLIP_WEIGHT_LENGTH + 1
#include "rasterize_body.glsl"
