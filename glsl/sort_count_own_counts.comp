// Radix sort, count step, CPU-driver layout (SortLayout::OwnCounts; see sort_own_counts.glsl
// and sort_count_body.glsl for the histogram's digit-major order).
#version 460
#include "sort_own_counts.glsl"

layout(push_constant) uniform Push {
    U32s keys;
    SortInfoRef info;
    U32s hist;
    uint shift;
    uint digit_mask;
} pc;

void main() {
    uvec2 run = own_run(pc.info.s.num_keys);
    count_own_run(pc.keys, run.x, run.y, pc.shift, pc.digit_mask);
    barrier();
    uint num_blocks = pc.info.s.num_blocks;
    for (uint d = gl_LocalInvocationIndex; d < SORT_OWN_RADIX; d += SORT_OWN_WORKGROUP) {
        uint sum = 0u;
        [[unroll]] for (uint l = 0u; l < SORT_OWN_WORKGROUP; ++l) {
            sum += own_counts[d * SORT_OWN_WORKGROUP + l];
        }
        pc.hist.v[d * num_blocks + gl_WorkGroupID.x] = sum;
    }
}
