// Radix sort, scatter step, CPU-driver layout (SortLayout::OwnCounts; see
// sort_own_counts.glsl): each invocation takes its run's first output position per digit from
// the scanned histogram and writes its keys in order. Stable, with no atomics, barriers or
// subgroup operations.
#version 460
#include "sort_own_counts.glsl"

layout(push_constant) uniform Push {
    U32s keys_in;       // unused: read through keys_in_texels
    U32s values_in;     // unused: read through values_in_texels
    U32s keys_out;
    U32s values_out;
    SortInfoRef info;
    U32s hist;          // scanned histogram: first output position of (digit, run)
    uint shift;
    uint digit_mask;
} pc;

void main() {
    uvec2 run = own_run(pc.info.s.num_keys);
    uint num_blocks = pc.info.s.num_blocks;
    for (uint d = 0u; d < SORT_OWN_RADIX; ++d) {
        own_counts[d] = pc.hist.v[hist_index(d, num_blocks)];
    }
    for (uint i = run.x; i < run.y; i += 4u) {
        uvec4 keys = texelFetch(keys_in_texels, int(i / 4u));
        uvec4 values = texelFetch(values_in_texels, int(i / 4u));
        [[unroll]] for (uint j = 0u; j < 4u; ++j) {
            if (i + j < run.y) {
                uint digit = key_digit(keys[j], pc.shift, pc.digit_mask);
                uint dst = own_counts[digit];
                own_counts[digit] = dst + 1u;
                pc.keys_out.v[dst] = keys[j];
                pc.values_out.v[dst] = values[j];
            }
        }
    }
}
