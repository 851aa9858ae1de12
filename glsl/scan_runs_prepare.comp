// Prefix sum, CPU-driver layout, step 0 (see scan_runs.glsl): from the element count (known
// only on the GPU) the indirect dispatch arguments of the run passes: one invocation per run.
#version 460
#include "scan_runs.glsl"

layout(local_size_x = 1) in;

layout(push_constant) uniform Push {
    U32s count;         // count.v[0] = elements to scan
    DispatchArgs args;  // out: args.v[0], workgroups of the run passes
} pc;

void main() {
    uint runs = div_ceil(pc.count.v[0], SCAN_RUN);
    pc.args.v[0] = uvec4(div_ceil(runs, SCAN_RUN_WORKGROUP), 1u, 1u, 0u);
}
