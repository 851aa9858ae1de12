// Radix sort count step, CPU-driver layout, over packed pairs (every pass after the first).
#version 460
#define SORT_PAIRS_IN 1
#include "sort_count_own_counts_body.glsl"
