// Radix sort scatter step, CPU-driver layout: packed pairs in and out (the passes between the
// first and the last, and every pass of a sort of packed pairs).
#version 460
#define SORT_PAIRS_IN 1
#define SORT_PAIRS_OUT 1
#include "sort_scatter_own_counts_body.glsl"
