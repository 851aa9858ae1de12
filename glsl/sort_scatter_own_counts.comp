// Radix sort scatter step, CPU-driver layout: separate keys and values in and out (a sort of one
// pass).
#version 460
#define SORT_PAIRS_IN 0
#define SORT_PAIRS_OUT 0
#include "sort_scatter_own_counts_body.glsl"
