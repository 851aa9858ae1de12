// Radix sort, pass step 1: histogram of one digit per block of SORT_BLOCK keys, stored
// digit-major (hist[digit * num_blocks + block]) so that one exclusive scan of the whole
// histogram gives every (digit, block) its first output position.
#version 460
#include "common.glsl"
#include "sort_common.glsl"

layout(local_size_x = SORT_WORKGROUP) in;

layout(push_constant) uniform Push {
    UVec2s keys;
    SortInfoRef info;
    U32s hist;
    uint shift;
} pc;

shared uint block_hist[SORT_RADIX];

void main() {
    uint lid = gl_LocalInvocationID.x;
    if (lid < SORT_RADIX) {
        block_hist[lid] = 0u;
    }
    barrier();
    uint n = pc.info.s.num_keys;
    uint base = gl_WorkGroupID.x * SORT_BLOCK;
    // Counting does not depend on order, so read coalesced and count with shared atomics.
    for (uint k = 0u; k < SORT_ITEMS; ++k) {
        uint i = base + k * SORT_WORKGROUP + lid;
        if (i < n) {
            atomicAdd(block_hist[key_digit(pc.keys.v[i], pc.shift)], 1u);
        }
    }
    barrier();
    if (lid < SORT_RADIX) {
        pc.hist.v[lid * pc.info.s.num_blocks + gl_WorkGroupID.x] = block_hist[lid];
    }
}
