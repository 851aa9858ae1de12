// Radix sort count step, CPU-driver layout, over packed pairs (every pass but the first of a sort
// of separate keys and values, and every pass of a sort of packed pairs).
#version 460
#define SORT_PAIRS_IN 1
#include "sort_count_own_counts_body.glsl"
