// Stage 4b, cutoff tiles, reading through buffer loads (GPUs; see cutoff_tiles_body.glsl).
#version 460
#include "cutoff_tiles_body.glsl"
