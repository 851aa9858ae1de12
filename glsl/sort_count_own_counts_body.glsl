// Radix sort, count step, CPU-driver layout (SortLayout::OwnCounts; see sort_own_counts.glsl):
// each invocation counts the digits of its run and writes them to its column of the histogram.
// Included by sort_count_own_counts[_pairs].comp, which set SORT_PAIRS_IN.
#include "sort_own_counts.glsl"

layout(push_constant) uniform Push {
    U32s keys;          // unused: the keys are read through the texel views
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
    for (uint i = run.x; i < run.y; i += 4u) {
        uvec4 four = load_four_keys(i);
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
