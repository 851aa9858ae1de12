// Radix sort, CPU-driver layout (SortLayout::OwnCounts, sort_{count,scatter}_own_counts.comp):
// SORT_OWN_WORKGROUP invocations of SORT_OWN_ITEMS consecutive keys each make one block of
// SORT_BLOCK keys, and every invocation counts the SORT_OWN_RADIX digits of its run in a
// histogram of its own in shared memory. A CPU driver runs a workgroup on one thread, lane by
// lane for indexed memory, so a private counter costs one load and one store per key: no
// atomics, no compare per digit (the GPU layout's register counters cost SORT_RADIX compares
// per key, fine at 4 bits, too many at 8), and 8-bit digits halve the passes.
#extension GL_EXT_control_flow_attributes : require
#include "common.glsl"
#include "sort_common.glsl"

#if SORT_OWN_ITEMS % 4 != 0
#error "SORT_OWN_ITEMS must be a multiple of 4: runs are read four keys at a time"
#endif

layout(local_size_x = SORT_OWN_WORKGROUP) in;

// own_counts[digit * SORT_OWN_WORKGROUP + invocation]: the invocation's keys of that digit,
// then (scatter) its next output position for the digit.
shared uint own_counts[SORT_OWN_RADIX * SORT_OWN_WORKGROUP];

// Counts the digits of keys [first, end) into this invocation's column of own_counts, reading
// four keys at a time (a group that starts below `end` stays inside the buffer, which holds a
// multiple of 4 keys: RadixSort::buffers).
void count_own_run(U32s keys, uint first, uint end, uint shift, uint digit_mask) {
    uint lid = gl_LocalInvocationIndex;
    for (uint d = 0u; d < SORT_OWN_RADIX; ++d) {
        own_counts[d * SORT_OWN_WORKGROUP + lid] = 0u;
    }
    for (uint i = first; i < end; i += 4u) {
        uvec4 four = load_u32x4(keys, i);
        [[unroll]] for (uint j = 0u; j < 4u; ++j) {
            if (i + j < end) {
                uint slot = key_digit(four[j], shift, digit_mask) * SORT_OWN_WORKGROUP + lid;
                own_counts[slot] += 1u;
            }
        }
    }
}

// The run of keys of this invocation: [first, end), empty past the key count n.
uvec2 own_run(uint n) {
    uint first = gl_WorkGroupID.x * SORT_OWN_BLOCK + gl_LocalInvocationIndex * SORT_OWN_ITEMS;
    return uvec2(first, max(first, min(first + SORT_OWN_ITEMS, n)));
}
