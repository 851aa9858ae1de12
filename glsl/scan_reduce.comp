// Prefix sum, upsweep: each workgroup sums one block of SCAN_BLOCK elements into `partials`.
#version 460
#include "common.glsl"
#define WG_SCAN_SIZE SCAN_WORKGROUP
#include "workgroup_scan.glsl"

layout(local_size_x = SCAN_WORKGROUP) in;

layout(push_constant) uniform Push {
    U32s data;
    U32s count;     // count.v[0] = elements at this level
    U32s partials;  // out: one sum per block
} pc;

void main() {
    uint n = pc.count.v[0];
    uint base = gl_WorkGroupID.x * SCAN_BLOCK + workgroup_scan_rank() * SCAN_ITEMS;
    uint sum = 0u;
    for (uint k = 0u; k < SCAN_ITEMS; ++k) {
        if (base + k < n) {
            sum += pc.data.v[base + k];
        }
    }
    uint total;
    workgroup_exclusive_scan(sum, total);
    if (gl_LocalInvocationID.x == 0u) {
        pc.partials.v[gl_WorkGroupID.x] = total;
    }
}
