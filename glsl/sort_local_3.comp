// Radix sort, 3 passes after the first of a segmented sort of small buckets, one invocation
// per bucket, by the 3 digits after the top one (see sort_local_body.glsl).
#version 460
#define LOCAL_PASSES 3
#include "sort_local_body.glsl"
