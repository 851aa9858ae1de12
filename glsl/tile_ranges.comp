// Stage 6, tile ranges (see tile_ranges_body.glsl).
#version 460
#include "tile_ranges_body.glsl"
