// Prefix sum, CPU-driver layout, step 2 (see scan_runs.glsl): one invocation turns the runs'
// sums into their exclusive scan, in place, and can store the grand total. A run covers
// SCAN_RUN elements, so this serial loop is that much shorter than the scan.
#version 460
#include "scan_runs.glsl"

layout(local_size_x = 1) in;

#define SCAN_WRITE_TOTAL 2u

layout(push_constant) uniform Push {
    U32s sums;      // in: one sum per run; out: their exclusive scan (16-byte aligned)
    U32s count;     // count.v[0] = elements to scan
    U32s total;     // total.v[0] = grand total (SCAN_WRITE_TOTAL)
    uint flags;
} pc;

void main() {
    uint runs = div_ceil(pc.count.v[0], SCAN_RUN);
    uint running = 0u;
    uint r = 0u;
    for (; r + 4u <= runs; r += 4u) {
        uvec4 v = load_u32x4(pc.sums, r);
        uvec4 scanned;
        scanned.x = running;
        scanned.y = scanned.x + v.x;
        scanned.z = scanned.y + v.y;
        scanned.w = scanned.z + v.z;
        running = scanned.w + v.w;
        store_uvec4(address_item(Address(pc.sums), r, 4u), scanned);
    }
    for (; r < runs; ++r) {
        uint t = pc.sums.v[r];
        pc.sums.v[r] = running;
        running += t;
    }
    if ((pc.flags & SCAN_WRITE_TOTAL) != 0u) {
        pc.total.v[0] = running;
    }
}
