// Prefix sum, downsweep: exclusive scan of one block in place, offset by the scanned sum of the
// blocks before it (from the level above). The single workgroup of the top level can also
// store the grand total.
#version 460
#include "common.glsl"
#define WG_SCAN_SIZE SCAN_WORKGROUP
#include "workgroup_scan.glsl"

layout(local_size_x = SCAN_WORKGROUP) in;

#define SCAN_ADD_OFFSETS 1u
#define SCAN_WRITE_TOTAL 2u

layout(push_constant) uniform Push {
    U32s data;
    U32s count;     // count.v[0] = elements at this level
    U32s offsets;   // scanned block sums of this level (SCAN_ADD_OFFSETS)
    U32s total;     // total.v[0] = grand total (SCAN_WRITE_TOTAL)
    uint flags;
} pc;

void main() {
    uint n = pc.count.v[0];
    uint base = gl_WorkGroupID.x * SCAN_BLOCK + workgroup_scan_rank() * SCAN_ITEMS;
    uint items[SCAN_ITEMS];
    uint sum = 0u;
    for (uint k = 0u; k < SCAN_ITEMS; ++k) {
        items[k] = base + k < n ? pc.data.v[base + k] : 0u;
        sum += items[k];
    }
    uint total;
    uint running = workgroup_exclusive_scan(sum, total);
    if ((pc.flags & SCAN_ADD_OFFSETS) != 0u) {
        running += pc.offsets.v[gl_WorkGroupID.x];
    }
    for (uint k = 0u; k < SCAN_ITEMS; ++k) {
        if (base + k < n) {
            pc.data.v[base + k] = running;
        }
        running += items[k];
    }
    if ((pc.flags & SCAN_WRITE_TOTAL) != 0u && gl_LocalInvocationID.x == 0u) {
        pc.total.v[0] = total;
    }
}
