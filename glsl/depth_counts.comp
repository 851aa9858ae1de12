// Stage 2, depth order, last step: the tiles touched in depth order (see depth_counts_body.glsl).
#version 460
#include "depth_counts_body.glsl"
