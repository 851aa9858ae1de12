// Radix sort, CPU-driver layout (SortLayout::OwnCounts, sort_{count,scatter}_own_counts.comp):
// every invocation owns a run of SORT_OWN_ITEMS consecutive keys (SORT_OWN_WORKGROUP runs make
// one block) and counts the SORT_OWN_RADIX digits of its run in a histogram of its own in
// shared memory. A CPU driver runs a workgroup on one thread, lane by lane for indexed memory,
// so a private counter costs one load and one store per key: no atomics, no compare per digit
// (the GPU layout's register counters cost SORT_RADIX compares per key, fine at 4 bits, too
// many at 8), and 8-bit digits halve the passes.
//
// The histogram has one column per run, hist[digit * runs + run] (runs = SORT_OWN_WORKGROUP
// per block, the last block's empty runs counting nothing), so its exclusive scan gives every
// run its first output position for every digit: the scatter neither counts again nor talks
// to the other invocations, and runs in order keep the sort stable.
#extension GL_EXT_control_flow_attributes : require
#include "common.glsl"
#include "sort_common.glsl"

#if SORT_OWN_ITEMS % 4 != 0
#error "SORT_OWN_ITEMS must be a multiple of 4: runs are read four at a time"
#endif

layout(local_size_x = SORT_OWN_WORKGROUP) in;

// The pass's input keys and values, four to a texel (descriptor set 0: SortBuffers' texel
// views of the pass's source buffers). A CPU driver loads a texel as a gather, where a buffer
// load is a scalar loop over the lanes per 64-bit word (lavapipe, bench --sort 2000000, two
// runs in turn: 205-210 -> 162 ms).
layout(set = 0, binding = 0) uniform utextureBuffer keys_in_texels;
layout(set = 0, binding = 1) uniform utextureBuffer values_in_texels;

// own_counts[digit * SORT_OWN_WORKGROUP + invocation]: the invocation's keys of that digit
// (count), or its next output position for the digit (scatter).
shared uint own_counts[SORT_OWN_RADIX * SORT_OWN_WORKGROUP];

// This invocation's run of keys: [first, end), empty past the key count n.
uvec2 own_run(uint n) {
    uint first = gl_GlobalInvocationID.x * SORT_OWN_ITEMS;
    return uvec2(first, max(first, min(first + SORT_OWN_ITEMS, n)));
}

// Slot of `digit` in this invocation's column of own_counts.
uint own_slot(uint digit) {
    return digit * SORT_OWN_WORKGROUP + gl_LocalInvocationIndex;
}

// Index of (digit, this invocation's run) in the histogram of num_blocks blocks.
uint hist_index(uint digit, uint num_blocks) {
    return digit * (num_blocks * SORT_OWN_WORKGROUP) + gl_GlobalInvocationID.x;
}
