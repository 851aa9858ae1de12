// Stage 3, emit: one invocation per Gaussian writes a (key, splat index) pair for every tile it
// touches, at the offset the prefix sum gave it. Key = (depth bits, tile id) as (low, high)
// words: sorting it orders by tile, then by depth; the stable sort keeps index order on ties.
// Pairs past the capacity are not written: the host sees the total, grows the buffers and
// renders the frame again.
#version 460
#include "common.glsl"

layout(local_size_x = LINEAR_WORKGROUP) in;

layout(push_constant) uniform Push {
    FrameParamsRef frame;
    ProjectedSplats splats;
    U32s offsets;       // exclusive prefix sum of tiles touched
    UVec2s keys;
    U32s values;
} pc;

void main() {
    uint i = linear_index();
    FrameParams f = pc.frame.p;
    if (i >= f.scene.x) {
        return;
    }
    uvec4 rect = pc.splats.v[i].rect;
    if (rect.z <= rect.x || rect.w <= rect.y) {
        return;
    }
    ProjectedSplat p = pc.splats.v[i];
    uint depth_bits = floatBitsToUint(p.depth);
    float q_max = footprint_q_max(p.opacity);
    uint capacity = f.scene.w;
    uint slot = pc.offsets.v[i];
    for (uint y = rect.y; y < rect.w; ++y) {
        for (uint x = rect.x; x < rect.z; ++x) {
            if (!footprint_touches_tile(p.uv, p.conic, q_max, x, y)) {
                continue;
            }
            if (slot < capacity) {
                pc.keys.v[slot] = uvec2(depth_bits, y * f.size.z + x);
                pc.values.v[slot] = i;
            }
            ++slot;
        }
    }
}
