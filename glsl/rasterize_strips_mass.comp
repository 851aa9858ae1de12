// Stage 7, rasterize, CPU-driver layout (strips of 2 columns x 16 rows), rara clipping with
// the mass weight (see rasterize_body.glsl).
#version 460
#define PIXELS_PER_INVOCATION 16
#define COLUMNS_PER_INVOCATION 2
#define CUTOFF_WEIGHT CLIP_WEIGHT_MASS + 1
#define COOPERATIVE_RECORD
#include "rasterize_body.glsl"
