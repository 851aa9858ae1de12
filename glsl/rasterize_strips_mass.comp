// Stage 7, rasterize, CPU-driver layout, rara clipping with the mass weight
// (see rasterize_body.glsl).
#version 460
#define PIXELS_PER_INVOCATION 16
#define CUTOFF_WEIGHT CLIP_WEIGHT_MASS + 1
#include "rasterize_body.glsl"
