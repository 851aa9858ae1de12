// Radix sort, count step, CPU-driver layout (SortLayout::LongRuns): SORT_LONG_RUN_WORKGROUP
// invocations of SORT_LONG_RUN_ITEMS keys each (see sort_count_body.glsl).
#version 460
#define SORT_WG SORT_LONG_RUN_WORKGROUP
#define SORT_RUN SORT_LONG_RUN_ITEMS
#define SORT_COUNT_OWN_RUNS
#include "sort_count_body.glsl"
