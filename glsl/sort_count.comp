// Radix sort, count step, GPU layout (SortLayout::ShortRuns): histogram of one digit per block
// of SORT_BLOCK keys, stored digit-major (hist[digit * num_blocks + block]) so that one
// exclusive scan of the whole histogram gives every (digit, block) its first output position.
// SORT_WORKGROUP invocations count SORT_ITEMS keys each.
#version 460
#define SORT_WG SORT_WORKGROUP
#define SORT_RUN SORT_ITEMS
#extension GL_EXT_control_flow_attributes : require
#extension GL_KHR_shader_subgroup_arithmetic : require
#extension GL_KHR_shader_subgroup_basic : require
#include "common.glsl"
#include "sort_common.glsl"

layout(local_size_x = SORT_WG) in;

layout(push_constant) uniform Push {
    U32s keys;
    SortInfoRef info;
    U32s hist;
    uint shift;
    uint digit_mask;
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
    // Count in registers (one counter per digit, unrolled compares: no per-key memory traffic
    // beyond the key), then add the subgroup's sums into shared memory, one atomic per digit
    // and subgroup. Counting does not depend on order, so keys are read coalesced (key
    // k * SORT_WG + lid).
    uint counts[SORT_RADIX];
    [[unroll]] for (uint d = 0u; d < SORT_RADIX; ++d) {
        counts[d] = 0u;
    }
    [[unroll]] for (uint k = 0u; k < SORT_RUN; ++k) {
        uint i = base + k * SORT_WG + lid;
        if (i < n) {
            uint digit = key_digit(pc.keys.v[i], pc.shift, pc.digit_mask);
            [[unroll]] for (uint d = 0u; d < SORT_RADIX; ++d) {
                counts[d] += digit == d ? 1u : 0u;
            }
        }
    }
    [[unroll]] for (uint d = 0u; d < SORT_RADIX; ++d) {
        uint sum = subgroupAdd(counts[d]);
        if (subgroupElect() && sum > 0u) {
            atomicAdd(block_hist[d], sum);
        }
    }
    barrier();
    if (lid < SORT_RADIX) {
        pc.hist.v[lid * pc.info.s.num_blocks + gl_WorkGroupID.x] = block_hist[lid];
    }
}
