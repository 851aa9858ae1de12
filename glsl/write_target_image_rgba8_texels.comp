// Stage 8, write target, into a storage image of format rgba8, reading the state through the
// frame's texel view (CPU drivers; see write_target_body.glsl).
#version 460
#define TARGET_IMAGE_FORMAT rgba8
#define STATE_TEXELS
#include "write_target_body.glsl"
