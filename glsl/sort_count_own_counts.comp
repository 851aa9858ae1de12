// Radix sort count step, CPU-driver layout, over separate keys (the first pass).
#version 460
#define SORT_PAIRS_IN 0
#include "sort_count_own_counts_body.glsl"
