// Radix sort, count step, CPU-driver layout (SortLayout::OwnCounts; see sort_own_counts.glsl):
// each invocation counts the digits of its run and writes them to its column of the histogram.
#version 460
#include "sort_own_counts.glsl"

layout(push_constant) uniform Push {
    U32s keys;          // unused: the keys are read through keys_in_texels
    SortInfoRef info;
    U32s hist;
    uint shift;
    uint digit_mask;
} pc;

void main() {
    uvec2 run = own_run(pc.info.s.num_keys);
    for (uint d = 0u; d < SORT_OWN_RADIX; ++d) {
        own_counts[d] = 0u;
    }
    // Four keys at a time: a group that starts below the run's end stays inside the buffer,
    // which holds a multiple of 4 keys (RadixSort::buffers).
    for (uint i = run.x; i < run.y; i += 4u) {
        uvec4 four = texelFetch(keys_in_texels, int(i / 4u));
        [[unroll]] for (uint j = 0u; j < 4u; ++j) {
            if (i + j < run.y) {
                own_counts[key_digit(four[j], pc.shift, pc.digit_mask)] += 1u;
            }
        }
    }
    uint num_blocks = pc.info.s.num_blocks;
    for (uint d = 0u; d < SORT_OWN_RADIX; ++d) {
        pc.hist.v[hist_index(d, num_blocks)] = own_counts[d];
    }
}
