// Radix sort scatter step, CPU-driver layout: packed pairs in, separate keys and values out (the
// last of several passes).
#version 460
#define SORT_PAIRS_IN 1
#define SORT_PAIRS_OUT 0
#include "sort_scatter_own_counts_body.glsl"
