// Stage 8, write target, into a buffer reached by device address (see write_target_body.glsl).
#version 460
#include "write_target_body.glsl"
