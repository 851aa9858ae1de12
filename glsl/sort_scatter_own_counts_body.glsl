// Radix sort, scatter step, CPU-driver layout (SortLayout::OwnCounts; see
// sort_own_counts.glsl): each invocation takes its run's first output position per digit from
// the scanned histogram and writes its keys in order. Stable, with no atomics, barriers or
// subgroup operations. Included by sort_scatter_own_counts*, which set SORT_PAIRS_IN and
// SORT_PAIRS_OUT.
#include "sort_own_counts.glsl"

// SORT_OUT_BOUND (the *_bound kernels, packed pairs out): the pairs are written through
// the storage buffer at binding 3 of the pass's set (SortTexels), not through the buffer
// reference keys_out. gallivm stores either one lane at a time, but a bound buffer's lane loop
// takes a 32-bit index into one base pointer where a reference takes a 64-bit address per lane,
// which the loop moves through the stack lane by lane: 3 vector spills per lane instead of 5
// (lavapipe, bench --sort 2000000, six runs in turn: median 70.5 -> 58.9 ms, faster in 5 of
// 6). The host uses them where the buffer fits maxStorageBufferRange.
#ifndef SORT_OUT_BOUND
#define SORT_OUT_BOUND 0
#endif
#if SORT_OUT_BOUND
#if !SORT_PAIRS_OUT
#error "SORT_OUT_BOUND writes packed pairs"
#endif
layout(set = 0, binding = 3, std430) restrict writeonly buffer PairsOut {
    Pair64 pairs_out[];
};
#endif

#ifndef SORT_PAIRS_OUT
#error "define SORT_PAIRS_OUT: 1 to write packed pairs, 0 for separate keys and values"
#endif

layout(push_constant) uniform Push {
    U32s keys_in;       // unused: read through the texel views
    U32s values_in;     // unused: read through the texel views
    U32s keys_out;      // or the packed pairs, with SORT_PAIRS_OUT
    U32s values_out;    // unused with SORT_PAIRS_OUT
    SortInfoRef info;
    U32s hist;          // scanned histogram: first output position of (digit, run)
    uint shift;
    uint digit_mask;
    SortRuns runs;      // segmented sorts: sort_segments.comp's table of buckets and runs
    uint seg_shift;     // segmented sorts: the pass's digit
    uint seg_digit_mask;
    uint from_table;    // 1 in the passes after the first: segmented sorts take the runs table
} pc;

// The pass's digit (pass_digit), set by main.
uvec2 digit;

// Writes the run's next key of `key`'s digit, with its value, at the digit's next output
// position.
void scatter_pair(uint key, uint value) {
    uint d = key_digit(key, digit.x, digit.y);
    uint dst = own_counts[d];
    own_counts[d] = dst + 1u;
#if SORT_PAIRS_OUT
    // One 64-bit store: gallivm writes each component of a store in a loop of its own over
    // the lanes, so a pair costs one loop instead of two.
#if SORT_OUT_BOUND
    pairs_out[dst] = pair64(uvec2(key, value));
#else
    Pairs64(pc.keys_out).v[dst] = pair64(uvec2(key, value));
#endif
#else
    pc.keys_out.v[dst] = key;
    pc.values_out.v[dst] = value;
#endif
}

void main() {
    bool from_table = pc.from_table != 0u && pc.info.s.segmented != 0u;
    uvec4 run = own_run(pc.info, pc.runs, from_table);
    if (run.z == NO_RUN) {
        return;
    }
    digit = pass_digit(pc.info, uvec2(pc.shift, pc.digit_mask),
                       uvec2(pc.seg_shift, pc.seg_digit_mask));
    for (uint d = 0u; d < SORT_OWN_RADIX; ++d) {
        own_counts[d] = pc.hist.v[run.z + d * run.w];
    }
    // In order: the run's first 0-3 keys one by one (a segmented pass's run starts where its
    // bucket does, anywhere), its whole groups of four keys without a test per key, then its
    // last 0-3 keys one by one: gallivm runs a key's work under a mask whether the test passes
    // or not (lavapipe, bench --sort 2000000 with LP_NUM_THREADS=1, three runs in turn:
    // 150-154 -> 127-132 ms).
    uvec2 groups = groups_of_four(run.xy);
    uint aligned = groups.x;
    uint whole = groups.y;
    for (uint i = run.x; i < aligned; ++i) {
        uvec4 keys, values;
        load_four(i & ~3u, keys, values);
        scatter_pair(keys[i & 3u], values[i & 3u]);
    }
    for (uint i = aligned; i < whole; i += 4u) {
        uvec4 keys, values;
        load_four(i, keys, values);
        [[unroll]] for (uint j = 0u; j < 4u; ++j) {
            scatter_pair(keys[j], values[j]);
        }
    }
    for (uint i = whole; i < run.y; ++i) {
        uvec4 keys, values;
        load_four(i & ~3u, keys, values);
        scatter_pair(keys[i & 3u], values[i & 3u]);
    }
}
