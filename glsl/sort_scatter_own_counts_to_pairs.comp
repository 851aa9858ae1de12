// Radix sort scatter step, CPU-driver layout: separate keys and values in, packed pairs out (the
// first of several passes).
#version 460
#define SORT_PAIRS_IN 0
#define SORT_PAIRS_OUT 1
#include "sort_scatter_own_counts_body.glsl"
