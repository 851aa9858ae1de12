// Radix sort, scatter step, GPU layout (SortLayout::ShortRuns): SORT_WORKGROUP invocations of
// SORT_ITEMS keys each (see sort_scatter_body.glsl).
#version 460
#define SORT_WG SORT_WORKGROUP
#define SORT_RUN SORT_ITEMS
#include "sort_scatter_body.glsl"
