// Stage 8, write target, into a storage image of format rgba32f (see write_target_body.glsl).
#version 460
#define TARGET_IMAGE_FORMAT rgba32f
#include "write_target_body.glsl"
