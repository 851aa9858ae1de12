// Radix sort, scatter step, GPU layout (SortLayout::ShortRuns): stable scatter of one block.
// Each of SORT_WG invocations owns SORT_RUN consecutive keys and one counter per digit.
// A key's output position is the block's first position for its digit (scanned global
// histogram) + the keys of that digit in earlier subgroups (a short per-digit scan over the
// subgroups' totals) + those in earlier lanes of its subgroup (subgroupExclusiveAdd) + those
// before it in its own run. No atomics, so keys of equal digit keep their order: the sort is
// stable at any subgroup size of MIN_SUBGROUP_SIZE or more.
// (A full scan of a digit x invocation table in shared memory did the same job at 1.3x the cost
// of this kernel on lavapipe, whose shared-memory accesses run lane by lane.)
#version 460
#define SORT_WG SORT_WORKGROUP
#define SORT_RUN SORT_ITEMS
#if SORT_RUN % 4 != 0
#error "SORT_ITEMS must be a multiple of 4: keys and values are read four at a time"
#endif
#extension GL_EXT_control_flow_attributes : require
#extension GL_KHR_shader_subgroup_arithmetic : require
#extension GL_KHR_shader_subgroup_basic : require
#include "common.glsl"
#include "sort_common.glsl"

layout(local_size_x = SORT_WG) in;

layout(push_constant) uniform Push {
    U32s keys_in;
    U32s values_in;
    U32s keys_out;
    U32s values_out;
    SortInfoRef info;
    U32s hist;          // scanned histogram: first output position of (digit, block)
    uint shift;
    uint digit_mask;
} pc;

// Keys of each digit in each subgroup, then (after the per-digit scan over subgroups) the
// output position of the subgroup's first key of that digit: sg_base[digit * SG_SLOTS
// + subgroup].
#define SG_SLOTS (SORT_WG / MIN_SUBGROUP_SIZE)
shared uint sg_base[SORT_RADIX * SG_SLOTS];

void main() {
    uint n = pc.info.s.num_keys;
    uint num_blocks = pc.info.s.num_blocks;
    // Invocations own runs of keys in (subgroup, lane) order, not local-index order: the
    // ranks below are built from subgroup scans, and this keeps them in key order whatever the
    // subgroup size or the mapping of invocations to subgroups.
    uint chunk = gl_SubgroupID * gl_SubgroupSize + gl_SubgroupInvocationID;
    uint base = gl_WorkGroupID.x * SORT_BLOCK + chunk * SORT_RUN;

    // The invocation's keys and per-digit counters live in registers (unrolled loops, compares
    // instead of indexed memory), which suits CPU drivers and costs GPUs nothing.
    uint keys[SORT_RUN];
    uint counts[SORT_RADIX];
    [[unroll]] for (uint d = 0u; d < SORT_RADIX; ++d) {
        counts[d] = 0u;
    }
    // Keys four at a time (load_u32x4: half the lane loops of four scalar loads on a CPU
    // driver). A group that starts below n stays inside the buffers, which hold a multiple
    // of 4 keys (RadixSort::buffers); keys at n or beyond are never counted or written.
    [[unroll]] for (uint k = 0u; k < SORT_RUN; k += 4u) {
        uvec4 four = uvec4(0u);
        if (base + k < n) {
            four = load_u32x4(pc.keys_in, base + k);
        }
        keys[k] = four.x;
        keys[k + 1u] = four.y;
        keys[k + 2u] = four.z;
        keys[k + 3u] = four.w;
    }
    [[unroll]] for (uint k = 0u; k < SORT_RUN; ++k) {
        uint digit = key_digit(keys[k], pc.shift, pc.digit_mask);
        [[unroll]] for (uint d = 0u; d < SORT_RADIX; ++d) {
            counts[d] += (digit == d && base + k < n) ? 1u : 0u;
        }
    }
    // Rank within the subgroup: keys of the same digit in earlier lanes.
    [[unroll]] for (uint d = 0u; d < SORT_RADIX; ++d) {
        uint before = subgroupExclusiveAdd(counts[d]);
        uint total = subgroupAdd(counts[d]);
        if (subgroupElect()) {
            sg_base[d * SG_SLOTS + gl_SubgroupID] = total;
        }
        counts[d] = before;
    }
    barrier();
    // One invocation per digit scans that digit's counts over the subgroups, starting at the
    // block's first output position for the digit (the scanned global histogram).
    if (gl_LocalInvocationIndex < SORT_RADIX) {
        uint d = gl_LocalInvocationIndex;
        uint running = pc.hist.v[d * num_blocks + gl_WorkGroupID.x];
        for (uint sg = 0u; sg < gl_NumSubgroups; ++sg) {
            uint c = sg_base[d * SG_SLOTS + sg];
            sg_base[d * SG_SLOTS + sg] = running;
            running += c;
        }
    }
    barrier();
    // Next output position of each digit for this invocation.
    [[unroll]] for (uint d = 0u; d < SORT_RADIX; ++d) {
        counts[d] += sg_base[d * SG_SLOTS + gl_SubgroupID];
    }

    uvec4 values = uvec4(0u);
    [[unroll]] for (uint k = 0u; k < SORT_RUN; ++k) {
        uint i = base + k;
        if (k % 4u == 0u && i < n) {
            values = load_u32x4(pc.values_in, i);
        }
        if (i < n) {
            uint digit = key_digit(keys[k], pc.shift, pc.digit_mask);
            uint dst = 0u;
            [[unroll]] for (uint d = 0u; d < SORT_RADIX; ++d) {
                if (digit == d) {
                    dst = counts[d];
                    counts[d] += 1u;
                }
            }
            pc.keys_out.v[dst] = keys[k];
            pc.values_out.v[dst] = values[k % 4u];
        }
    }
}
