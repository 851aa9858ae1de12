// Radix sort, scatter step, CPU-driver layout (SortLayout::OwnCounts; see
// sort_own_counts.glsl). Each invocation counts its run again, one invocation per digit turns
// the block's counts into output positions (the block's first position for the digit from
// the scanned histogram, then the invocations in order), and each invocation writes its run
// in order: stable, with no atomics and no subgroup operations.
#version 460
#include "sort_own_counts.glsl"

layout(push_constant) uniform Push {
    U32s keys_in;
    U32s values_in;
    U32s keys_out;
    U32s values_out;
    SortInfoRef info;
    U32s hist;          // scanned histogram: first output position of (digit, block)
    uint shift;
    uint digit_mask;
} pc;

void main() {
    uint lid = gl_LocalInvocationIndex;
    uvec2 run = own_run(pc.info.s.num_keys);
    count_own_run(pc.keys_in, run.x, run.y, pc.shift, pc.digit_mask);
    barrier();
    uint num_blocks = pc.info.s.num_blocks;
    for (uint d = lid; d < SORT_OWN_RADIX; d += SORT_OWN_WORKGROUP) {
        uint running = pc.hist.v[d * num_blocks + gl_WorkGroupID.x];
        [[unroll]] for (uint l = 0u; l < SORT_OWN_WORKGROUP; ++l) {
            uint count = own_counts[d * SORT_OWN_WORKGROUP + l];
            own_counts[d * SORT_OWN_WORKGROUP + l] = running;
            running += count;
        }
    }
    barrier();
    for (uint i = run.x; i < run.y; i += 4u) {
        uvec4 keys = load_u32x4(pc.keys_in, i);
        uvec4 values = load_u32x4(pc.values_in, i);
        [[unroll]] for (uint j = 0u; j < 4u; ++j) {
            if (i + j < run.y) {
                uint slot = key_digit(keys[j], pc.shift, pc.digit_mask) * SORT_OWN_WORKGROUP + lid;
                uint dst = own_counts[slot];
                own_counts[slot] = dst + 1u;
                pc.keys_out.v[dst] = keys[j];
                pc.values_out.v[dst] = values[j];
            }
        }
    }
}
