// Stage 8, write target, into an rgba16f buffer reached by device address (see
// write_target_body.glsl).
#version 460
#define TARGET_BUFFER_FORMAT BUFFER_RGBA16F
#include "write_target_body.glsl"
