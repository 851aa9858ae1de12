// Stage 6, rasterize, CPU-driver layout: one invocation per 8-pixel column strip, so that each
// staged splat is loaded once for 8 pixels (see rasterize_body.glsl).
#version 460
#define PIXELS_PER_INVOCATION 8
#include "rasterize_body.glsl"
