// Stage 7, rasterize, CPU-driver layout (strips of 2 columns x 16 rows, splats fetched from
// texel buffers), rara clipping with the length weight (see rasterize_body.glsl).
#version 460
#define PIXELS_PER_INVOCATION 16
#define COLUMNS_PER_INVOCATION 2
#define CUTOFF_WEIGHT CLIP_WEIGHT_LENGTH + 1
#define SPLAT_TEXELS
#include "rasterize_body.glsl"
