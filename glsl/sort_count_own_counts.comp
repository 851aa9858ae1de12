// Radix sort count step, CPU-driver layout, over separate keys (the first pass of a sort of
// separate keys and values).
#version 460
#define SORT_PAIRS_IN 0
#include "sort_count_own_counts_body.glsl"
