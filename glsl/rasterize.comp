// Stage 6, rasterize, GPU layout: one invocation per pixel (see rasterize_body.glsl).
#version 460
#define PIXELS_PER_INVOCATION 1
#include "rasterize_body.glsl"
