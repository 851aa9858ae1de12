// Stage 2, depth order, first step: the depth keys (see depth_keys_body.glsl).
#version 460
#include "depth_keys_body.glsl"
