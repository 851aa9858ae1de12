// Stage 2, depth order (first step): one invocation per Gaussian writes a (depth bits, index)
// pair for every drawn Gaussian (tiles touched > 0) at its slot among the drawn ones: the
// exclusive scan of project's drawn flags. The pairs are therefore packed in index order, and
// the stable depth sort that follows keeps index order on equal depths (SPEC: ties by index).
// Depths are > 0.2, so their float bits order like the floats.
//
// Included by depth_keys and depth_keys_texels (FRAME_TEXELS: CPU drivers, the reads
// through the frame's texel views, src/stages/mod.rs).
#include "common.glsl"

layout(local_size_x = LINEAR_WORKGROUP) in;

layout(push_constant) uniform Push {
    FrameParamsRef frame;
    ProjectedSplats splats;
    U32s tiles_touched;
    U32s slots;         // exclusive scan of the drawn flags
    U32s keys;          // out: depth bits
    U32s values;        // out: Gaussian index
} pc;

#ifdef FRAME_TEXELS
#include "frame_texels.glsl"
#endif

void main() {
    uint i = linear_index();
#ifdef FRAME_TEXELS
    if (i >= pc.frame.p.scene.x || texelFetch(tiles_touched, int(i)).x == 0u) {
        return;
    }
    uint slot = texelFetch(slot_texels, int(i)).x;
    uint depth = floatBitsToUint(texel_splat(i).depth);
#else
    if (i >= pc.frame.p.scene.x || pc.tiles_touched.v[i] == 0u) {
        return;
    }
    uint slot = pc.slots.v[i];
    uint depth = floatBitsToUint(pc.splats.v[i].depth);
#endif
    pc.keys.v[slot] = depth;
    pc.values.v[slot] = i;
}
