// Prefix sum, CPU-driver layout, step 3 (see scan_runs.glsl): each invocation scans its run in
// place, starting from its run's offset.
#version 460
#include "scan_runs.glsl"

layout(local_size_x = SCAN_RUN_WORKGROUP) in;

layout(push_constant) uniform Push {
    U32s data;
    U32s count;     // count.v[0] = elements to scan
    U32s offsets;   // the exclusive scan of the runs' sums
} pc;

void main() {
    uint n = pc.count.v[0];
    uvec2 run = scan_run(n);
    if (run.x == run.y) {
        return;
    }
    uint running = pc.offsets.v[gl_GlobalInvocationID.x];
    uint i = run.x;
    for (; i + 4u <= run.y; i += 4u) {
        uvec4 v = load_u32x4(pc.data, i);
        uvec4 scanned;
        scanned.x = running;
        scanned.y = scanned.x + v.x;
        scanned.z = scanned.y + v.y;
        scanned.w = scanned.z + v.z;
        running = scanned.w + v.w;
        store_uvec4(address_item(Address(pc.data), i, 4u), scanned);
    }
    for (; i < run.y; ++i) {
        uint t = pc.data.v[i];
        pc.data.v[i] = running;
        running += t;
    }
}
