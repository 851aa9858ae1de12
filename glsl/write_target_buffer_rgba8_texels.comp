// Stage 8, write target, into an rgba8 buffer reached by device address, reading the
// state through the frame's texel view (CPU drivers; see write_target_body.glsl).
#version 460
#define TARGET_BUFFER_FORMAT BUFFER_RGBA8
#define STATE_TEXELS
#include "write_target_body.glsl"
