// Stage 8, write target, into a storage image of format rgba8 (see write_target_body.glsl).
#version 460
#define TARGET_IMAGE_FORMAT rgba8
#include "write_target_body.glsl"
