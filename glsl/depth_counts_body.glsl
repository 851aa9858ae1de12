// Stage 2, depth order (last step): the tiles touched of each drawn Gaussian, in depth order,
// for the prefix sum that gives each one its first (tile, splat) pair. Emitting the pairs in
// depth order lets the pair sort order by tile alone (a few bits) instead of by tile and depth
// (32 more bits), since a stable sort keeps each tile's pairs in depth order.
//
// Included by depth_counts and depth_counts_texels (FRAME_TEXELS: CPU drivers, the reads
// through the frame's texel views, src/stages/mod.rs).
#include "common.glsl"

layout(local_size_x = LINEAR_WORKGROUP) in;

layout(push_constant) uniform Push {
    U32s drawn;         // drawn.v[0] = drawn Gaussians
    U32s order;         // Gaussian indices in depth order
    U32s tiles_touched; // per Gaussian
    U32s counts;        // out: tiles touched, in depth order
} pc;

#ifdef FRAME_TEXELS
#include "frame_texels.glsl"
#endif

void main() {
    uint i = linear_index();
    if (i >= pc.drawn.v[0]) {
        return;
    }
#ifdef FRAME_TEXELS
    pc.counts.v[i] = texelFetch(tiles_touched, int(texelFetch(depth_order, int(i)).x)).x;
#else
    pc.counts.v[i] = pc.tiles_touched.v[pc.order.v[i]];
#endif
}
