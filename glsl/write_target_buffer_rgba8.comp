// Stage 8, write target, into an rgba8 buffer reached by device address (see
// write_target_body.glsl).
#version 460
#define TARGET_BUFFER_FORMAT BUFFER_RGBA8
#include "write_target_body.glsl"
