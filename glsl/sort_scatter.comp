// Radix sort, pass step 3: stable scatter of one block. Each invocation owns SORT_ITEMS
// consecutive keys and one counter per digit; an exclusive scan of those counters (digit-major,
// then invocation order) ranks every key among the block's keys of its digit without atomics,
// so keys of equal digit keep their order and the sort is stable at any subgroup size.
#version 460
#extension GL_EXT_control_flow_attributes : require
#include "common.glsl"
#include "sort_common.glsl"
#define WG_SCAN_SIZE SORT_WORKGROUP
#include "workgroup_scan.glsl"

layout(local_size_x = SORT_WORKGROUP) in;

layout(push_constant) uniform Push {
    UVec2s keys_in;
    U32s values_in;
    UVec2s keys_out;
    U32s values_out;
    SortInfoRef info;
    U32s hist;          // scanned histogram: first output position of (digit, block)
    uint shift;
} pc;

// rank[digit * SORT_WORKGROUP + invocation]
shared uint rank[SORT_RADIX * SORT_WORKGROUP];
// Output position of a key = digit_base[digit] + its rank.
shared uint digit_base[SORT_RADIX];

#define ENTRIES_PER_THREAD (SORT_RADIX * SORT_WORKGROUP / SORT_WORKGROUP)

void main() {
    uint lid = gl_LocalInvocationID.x;
    uint n = pc.info.s.num_keys;
    uint num_blocks = pc.info.s.num_blocks;
    uint base = gl_WorkGroupID.x * SORT_BLOCK + lid * SORT_ITEMS;

    // The invocation's keys and per-digit counters live in registers (unrolled loops, compares
    // instead of indexed memory), which suits CPU drivers and costs GPUs nothing.
    uvec2 keys[SORT_ITEMS];
    uint counts[SORT_RADIX];
    [[unroll]] for (uint d = 0u; d < SORT_RADIX; ++d) {
        counts[d] = 0u;
    }
    [[unroll]] for (uint k = 0u; k < SORT_ITEMS; ++k) {
        keys[k] = base + k < n ? pc.keys_in.v[base + k] : uvec2(0u);
        uint digit = key_digit(keys[k], pc.shift);
        [[unroll]] for (uint d = 0u; d < SORT_RADIX; ++d) {
            counts[d] += (digit == d && base + k < n) ? 1u : 0u;
        }
    }
    [[unroll]] for (uint d = 0u; d < SORT_RADIX; ++d) {
        rank[d * SORT_WORKGROUP + lid] = counts[d];
    }
    barrier();

    // Exclusive scan of the whole rank array: each invocation scans a run of
    // ENTRIES_PER_THREAD consecutive entries, and the workgroup scan joins the runs.
    uint first = lid * ENTRIES_PER_THREAD;
    uint run = 0u;
    for (uint e = 0u; e < ENTRIES_PER_THREAD; ++e) {
        run += rank[first + e];
    }
    uint total;
    uint running = workgroup_exclusive_scan(run, total);
    for (uint e = 0u; e < ENTRIES_PER_THREAD; ++e) {
        uint c = rank[first + e];
        rank[first + e] = running;
        running += c;
    }
    barrier();
    // rank[d * WG] counts the block's keys of smaller digits: take it out of the global position.
    if (lid < SORT_RADIX) {
        digit_base[lid] = pc.hist.v[lid * num_blocks + gl_WorkGroupID.x] - rank[lid * SORT_WORKGROUP];
    }
    barrier();
    // Next output position of each digit for this invocation.
    [[unroll]] for (uint d = 0u; d < SORT_RADIX; ++d) {
        counts[d] = digit_base[d] + rank[d * SORT_WORKGROUP + lid];
    }

    [[unroll]] for (uint k = 0u; k < SORT_ITEMS; ++k) {
        uint i = base + k;
        if (i < n) {
            uint digit = key_digit(keys[k], pc.shift);
            uint dst = 0u;
            [[unroll]] for (uint d = 0u; d < SORT_RADIX; ++d) {
                if (digit == d) {
                    dst = counts[d];
                    counts[d] += 1u;
                }
            }
            pc.keys_out.v[dst] = keys[k];
            pc.values_out.v[dst] = pc.values_in.v[i];
        }
    }
}
