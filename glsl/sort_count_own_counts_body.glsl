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
    SortRuns runs;      // segmented sorts: sort_segments.comp's table of buckets and runs
    uint seg_shift;     // segmented sorts: the pass's digit
    uint seg_digit_mask;
    uint from_table;    // 1 in the passes after the first: segmented sorts take the runs table
} pc;

void main() {
    bool from_table = pc.from_table != 0u && pc.info.s.segmented != 0u;
    uvec4 run = own_run(pc.info, pc.runs, from_table);
    if (run.z == NO_RUN) {
        return;
    }
    uvec2 digit = pass_digit(pc.info, uvec2(pc.shift, pc.digit_mask),
                             uvec2(pc.seg_shift, pc.seg_digit_mask));
    for (uint d = 0u; d < SORT_OWN_RADIX; ++d) {
        own_counts[d] = 0u;
    }
    // The run's whole groups of four keys without a test per key, then its first and last
    // 0-3 keys one by one, in one loop since counts do not care for order (a segmented pass's
    // run starts where its bucket does, anywhere):
    // gallivm runs a key's work under a mask whether the test passes or not (lavapipe,
    // bench --sort 2000000 with LP_NUM_THREADS=1, three runs in turn: 150-154 -> 127-132 ms).
    uvec2 groups = groups_of_four(run.xy);
    uint aligned = groups.x;
    uint whole = groups.y;
    uint head = aligned - run.x;
    for (uint i = aligned; i < whole; i += 4u) {
        uvec4 four = load_four_keys(i);
        [[unroll]] for (uint j = 0u; j < 4u; ++j) {
            own_counts[key_digit(four[j], digit.x, digit.y)] += 1u;
        }
    }
    for (uint k = 0u; k < head + (run.y - whole); ++k) {
        uint i = k < head ? run.x + k : whole + (k - head);
        own_counts[key_digit(load_four_keys(i & ~3u)[i & 3u], digit.x, digit.y)] += 1u;
    }
    for (uint d = 0u; d < SORT_OWN_RADIX; ++d) {
        pc.hist.v[run.z + d * run.w] = own_counts[d];
    }
}
