#version 460
// The indirect dispatch arguments of a linear kernel (linear_grid) over a count only the GPU
// knows, in one invocation: the ray tracer's round r (trace_body.glsl) over the rays round
// r - 1 left live (zero workgroups once every ray is done), and, after project, the
// cutoff-records and cutoff-tiles stages over the frame's cutoff splats (cutoff_records_body.glsl,
// cutoff_tiles_body.glsl). A kernel of its own, not a branch of a kernel over many items: a
// CPU driver would run that branch's loads and stores, masked, in every SIMD vector (emit,
// which wrote the cutoff-tiles arguments from its first invocation: lavapipe, playbot at
// 640x480 under a plane, one thread, emit 29.4-30.1 -> 27.2-27.3 ms).
#include "common.glsl"

layout(local_size_x = 1) in;

layout(push_constant) uniform Push {
    U32s count;         // count.v[0]: the items
    DispatchArgs args;  // out: args.v[0]
} pc;

void main() {
    pc.args.v[0] = uvec4(linear_grid(pc.count.v[0]), 0u);
}
