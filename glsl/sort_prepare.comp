// Radix sort, step 0: clamp the key count to the buffers' capacity and derive the indirect
// dispatch arguments of the passes.
#version 460
#extension GL_EXT_control_flow_attributes : require
#include "common.glsl"
#include "sort_common.glsl"

layout(local_size_x = 1) in;

layout(push_constant) uniform Push {
    U32s count;         // count.v[0] = keys to sort (may exceed the capacity)
    SortInfoRef info;   // out
    uint capacity;
    uint hist_per_block; // histogram entries per block in the layout
    uint min_block;     // keys per block (workgroup) of the layout, at the least
    uint max_block;     // at the most: min_block times a power of two
    uint segment_min;   // segment sorts of this many keys or more (0: never)
    uint pad;
} pc;

void main() {
    uint n = min(pc.count.v[0], pc.capacity);
    // Blocks grow while at least SORT_PARALLEL_BLOCKS are left: a CPU driver's threads share
    // them, and every run pays a fixed cost (see SORT_PARALLEL_BLOCKS in constants.rs).
    uint block = pc.min_block;
    while (block < pc.max_block && div_ceil(n, 2u * block) >= SORT_PARALLEL_BLOCKS) {
        block *= 2u;
    }
    uint blocks = div_ceil(n, block);
    pc.info.s.num_keys = n;
    pc.info.s.num_blocks = blocks;
    pc.info.s.block_keys = block;
    pc.info.s.hist_len = blocks * pc.hist_per_block;
    pc.info.s.block_args = uvec4(blocks, 1u, 1u, 0u);
    pc.info.s.linear_args = uvec4(linear_grid(n), 0u);
    pc.info.s.segmented = pc.segment_min != 0u && n >= pc.segment_min ? 1u : 0u;
    pc.info.s.seg_runs = 0u;
    [[unroll]] for (uint k = 0u; k < 3u; ++k) {
        pc.info.s.pass_args[k] = pc.info.s.block_args;
    }
    pc.info.s.local_args = uvec4(0u, 1u, 1u, 0u);
}
