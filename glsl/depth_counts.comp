// Stage 2, depth order (last step): the tiles touched of each drawn Gaussian, in depth order,
// for the prefix sum that gives each one its first (tile, splat) pair. Emitting the pairs in
// depth order lets the pair sort order by tile alone (a few bits) instead of by tile and depth
// (32 more bits), since a stable sort keeps each tile's pairs in depth order.
#version 460
#include "common.glsl"

layout(local_size_x = LINEAR_WORKGROUP) in;

layout(push_constant) uniform Push {
    U32s drawn;         // drawn.v[0] = drawn Gaussians
    U32s order;         // Gaussian indices in depth order
    U32s tiles_touched; // per Gaussian
    U32s counts;        // out: tiles touched, in depth order
} pc;

void main() {
    uint i = linear_index();
    if (i >= pc.drawn.v[0]) {
        return;
    }
    pc.counts.v[i] = pc.tiles_touched.v[pc.order.v[i]];
}
