// Radix sort scatter step, CPU-driver layout: separate keys and values in, packed pairs out,
// written through the pass's bound storage buffer (see SORT_OUT_BOUND in
// sort_scatter_own_counts_body.glsl).
#version 460
#define SORT_PAIRS_IN 0
#define SORT_PAIRS_OUT 1
#define SORT_OUT_BOUND 1
#include "sort_scatter_own_counts_body.glsl"
