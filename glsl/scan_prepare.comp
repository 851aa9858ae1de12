// Prefix sum, step 0: from the element count (known only on the GPU) derive the size of every
// level of the reduce-then-scan hierarchy and the indirect dispatch arguments of its passes.
#version 460
#include "common.glsl"

layout(local_size_x = 1) in;

layout(push_constant) uniform Push {
    U32s count;         // count.v[0] = number of elements to scan
    U32s level_sizes;   // out: n of levels 0..3
    DispatchArgs args;  // out: workgroups per level
} pc;

void main() {
    uint n = pc.count.v[0];
    for (uint level = 0u; level < 4u; ++level) {
        pc.level_sizes.v[level] = n;
        uint groups = div_ceil(n, SCAN_BLOCK);
        pc.args.v[level] = uvec4(groups, 1u, 1u, 0u);
        n = groups;
    }
}
