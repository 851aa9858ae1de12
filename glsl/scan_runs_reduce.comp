// Prefix sum, CPU-driver layout, step 1 (see scan_runs.glsl): each invocation sums its run.
#version 460
#include "scan_runs.glsl"

layout(local_size_x = SCAN_RUN_WORKGROUP) in;

layout(push_constant) uniform Push {
    U32s data;
    U32s count;     // count.v[0] = elements to scan
    U32s sums;      // out: one sum per run
} pc;

void main() {
    uint n = pc.count.v[0];
    uvec2 run = scan_run(n);
    if (run.x == run.y) {
        return;
    }
    uint sum = 0u;
    uint i = run.x;
    for (; i + 4u <= run.y; i += 4u) {
        uvec4 v = load_u32x4(pc.data, i);
        sum += (v.x + v.y) + (v.z + v.w);
    }
    for (; i < run.y; ++i) {
        sum += pc.data.v[i];
    }
    pc.sums.v[gl_GlobalInvocationID.x] = sum;
}
