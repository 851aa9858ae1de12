// Stage 8, write target, into a storage image of format rgba32f, reading the state through the
// frame's texel view (CPU drivers; see write_target_body.glsl).
#version 460
#define TARGET_IMAGE_FORMAT rgba32f
#define STATE_TEXELS
#include "write_target_body.glsl"
