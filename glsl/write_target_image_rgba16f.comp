// Stage 8, write target, into a storage image of format rgba16f (see write_target_body.glsl).
#version 460
#define TARGET_IMAGE_FORMAT rgba16f
#include "write_target_body.glsl"
