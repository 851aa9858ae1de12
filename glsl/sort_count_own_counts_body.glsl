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
    uvec2 run = own_run(pc.info.s.num_keys, pc.info.s.block_keys);
    for (uint d = 0u; d < SORT_OWN_RADIX; ++d) {
        own_counts[d] = 0u;
    }
    // The run's whole groups of four keys without a test per key, then its last 0-3 keys one
    // by one: gallivm runs a key's work under a mask whether the test passes or not (lavapipe,
    // bench --sort 2000000 with LP_NUM_THREADS=1, three runs in turn: 150-154 -> 127-132 ms).
    uint whole = run.x + ((run.y - run.x) & ~3u);
    for (uint i = run.x; i < whole; i += 4u) {
        uvec4 four = load_four_keys(i);
        [[unroll]] for (uint j = 0u; j < 4u; ++j) {
            own_counts[key_digit(four[j], pc.shift, pc.digit_mask)] += 1u;
        }
    }
    for (uint i = whole; i < run.y; ++i) {
        own_counts[key_digit(load_four_keys(i & ~3u)[i & 3u], pc.shift, pc.digit_mask)] += 1u;
    }
    uint num_blocks = pc.info.s.num_blocks;
    for (uint d = 0u; d < SORT_OWN_RADIX; ++d) {
        pc.hist.v[hist_index(d, num_blocks)] = own_counts[d];
    }
}
