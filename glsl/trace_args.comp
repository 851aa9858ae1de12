#version 460
// The ray tracer's rounds (trace_body.glsl): the workgroups of round r, from the rays round
// r - 1 left live, as indirect dispatch arguments (zero workgroups once every ray is done).
// One invocation.
#include "common.glsl"

layout(local_size_x = 1) in;

layout(push_constant) uniform Push {
    U32s live;          // per round, the rays it left live
    DispatchArgs args;  // out: per round, its workgroups
    uint round;         // r >= 1
    uint pad;
} pc;

void main() {
    pc.args.v[pc.round] = uvec4(linear_grid(pc.live.v[pc.round - 1u]), 0u);
}
