// Stage 4, emit, reading the depth order, the first pairs and the projected splats through the
// frame's texel views (CPU drivers; see emit_body.glsl).
#version 460
#define SPLAT_TEXELS
#include "emit_body.glsl"
