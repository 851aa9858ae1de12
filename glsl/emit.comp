// Stage 4, emit (see emit_body.glsl).
#version 460
#include "emit_body.glsl"
