// Radix sort, CPU-driver layout (SortLayout::OwnCounts, sort_{count,scatter}_own_counts*):
// every invocation owns a run of consecutive keys (SORT_OWN_WORKGROUP runs make one block;
// see own_run) and counts the SORT_OWN_RADIX digits of its run in a histogram of its own
// (own_counts below). A CPU driver runs a workgroup on one thread, so a private counter costs
// one gather and one masked store per key: no atomics, no compare per digit (the GPU layout's
// register counters cost SORT_RADIX compares per key, fine at 4 bits, too many at 8), and
// 8-bit digits halve the passes.
//
// The histogram has one column per run, hist[digit * runs + run] (runs = SORT_OWN_WORKGROUP
// per block, the last block's empty runs counting nothing), so its exclusive scan gives every
// run its first output position for every digit: the scatter neither counts again nor talks
// to the other invocations, and runs in order keep the sort stable.
//
// Between passes the pairs travel packed, (key, value) as one 64-bit word: the first of
// several passes reads separate keys and values and writes packed pairs, the last reads
// packed pairs and writes separate keys and values (the sort's result), the ones between
// read and write packed pairs; a sort of packed pairs (RadixSort::record_form) reads and
// writes them in every pass. gallivm writes every component of a store in a loop of its
// own over the lanes, so a scattered pair costs one such loop instead of two (lavapipe,
// bench --sort 2000000, builds in turn: 87-94 -> 64-84 ms; 58-70 -> 49-50 ms in a quieter
// hour).
#extension GL_EXT_control_flow_attributes : require
#include "common.glsl"
#include "sort_common.glsl"

#if SORT_OWN_MIN_ITEMS % 4 != 0
#error "SORT_OWN_MIN_ITEMS must be a multiple of 4: runs are read four at a time"
#endif

layout(local_size_x = SORT_OWN_WORKGROUP) in;

#ifndef SORT_PAIRS_IN
#error "define SORT_PAIRS_IN: 1 if the pass reads packed pairs, 0 for separate keys and values"
#endif

// The pass's input (descriptor set 0: SortBuffers' texel views of the pass's source buffers):
// separate keys and values, four to a texel, or packed pairs (key, value), two to a texel
// (see load_four). A CPU driver loads a texel as a
// gather, where a buffer load is a scalar loop over the lanes per 64-bit word (lavapipe,
// bench --sort 2000000, two runs in turn: 205-210 -> 162 ms).
layout(set = 0, binding = 0) uniform utextureBuffer keys_in_texels;
layout(set = 0, binding = 1) uniform utextureBuffer values_in_texels;
layout(set = 0, binding = 2) uniform utextureBuffer pairs_in_texels;

// Keys i .. i + 3 of the pass's input (i a multiple of 4) and their values. The buffers hold a
// multiple of 4 pairs, so a group that starts below the key count stays inside them.
void load_four(uint i, out uvec4 keys, out uvec4 values) {
#if SORT_PAIRS_IN
    uvec4 a = texelFetch(pairs_in_texels, int(i / 2u));
    uvec4 b = texelFetch(pairs_in_texels, int(i / 2u + 1u));
    keys = uvec4(a.x, a.z, b.x, b.z);
    values = uvec4(a.y, a.w, b.y, b.w);
#else
    keys = texelFetch(keys_in_texels, int(i / 4u));
    values = texelFetch(values_in_texels, int(i / 4u));
#endif
}

// Keys i .. i + 3 of the pass's input, as load_four (the compiler drops the values' fetch
// where they are unused).
uvec4 load_four_keys(uint i) {
    uvec4 keys, values;
    load_four(i, keys, values);
    return keys;
}

// The invocation's counters, one per digit: the run's keys of that digit (count) or its next
// output position for the digit (scatter). A private array: gallivm keeps a workgroup's
// copies on the thread's stack, digit-major, and runs an indexed load as a gather and an
// indexed store as a load, select and store per lane, straight-line code. An indexed
// store to shared memory, a storage buffer or an image is instead a loop over the lanes with
// a branch per lane. lavapipe, bench --sort 2000000, count step per pass 5.5 -> 3.1 ms,
// scatter step 20-21 -> 17.5 ms, against the counters in a storage texel buffer (which in
// turn beat shared memory: 160-164 -> 111-114 ms for the whole sort).
uint own_counts[SORT_OWN_RADIX];

// This invocation's run of the pass: keys [x, y), and its column of the histogram, whose
// entry for digit d is hist[z + d w]. Passes of a segmented sort after its first take their
// runs from the table of sort_segments.comp (`from_table`), where a dispatch's last workgroup
// may have invocations past the last run: they get z = NO_RUN and must return. Otherwise a
// block's runs share it evenly: SORT_OWN_MIN_ITEMS keys each or a power-of-two multiple of
// that, as sort_prepare.comp chose, empty past num_keys, one column per run in order.
#define NO_RUN 0xffffffffu
uvec4 own_run(SortInfoRef info, SortRuns runs, bool from_table) {
    uint r = gl_GlobalInvocationID.x;
    if (from_table) {
        return r < info.s.seg_runs ? runs.v[SORT_OWN_RADIX + r] : uvec4(0u, 0u, NO_RUN, 0u);
    }
    uint run_keys = info.s.block_keys / SORT_OWN_WORKGROUP;
    uint first = r * run_keys;
    uint end = max(first, min(first + run_keys, info.s.num_keys));
    return uvec4(first, end, r, info.s.num_blocks * SORT_OWN_WORKGROUP);
}

// The digit a pass sorts by, (shift, mask) for key_digit: a segmented sort's passes take the
// top digit first (`segmented`), the others the least significant first (`plain`).
uvec2 pass_digit(SortInfoRef info, uvec2 plain, uvec2 segmented) {
    return info.s.segmented != 0u ? segmented : plain;
}
