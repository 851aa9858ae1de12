// Stage 4, emit: one invocation per drawn Gaussian, in depth order, writes a (tile id, splat
// index) pair for every tile it touches, at the offset the prefix sum gave it. The pairs come
// out in (depth, index) order, so the stable sort by tile id leaves every tile's list in that
// order. Pairs past the capacity are not written: the host sees the total, grows the buffers
// and renders the frame again.
#version 460
#include "common.glsl"

layout(local_size_x = LINEAR_WORKGROUP) in;

layout(push_constant) uniform Push {
    FrameParamsRef frame;
    ProjectedSplats splats;
    U32s drawn;         // drawn.v[0] = drawn Gaussians
    U32s order;         // Gaussian indices in depth order
    U32s offsets;       // exclusive prefix sum of tiles touched, in depth order
    U32s keys;          // out: tile ids
    U32s values;        // out: splat indices
} pc;

void main() {
    uint j = linear_index();
    if (j >= pc.drawn.v[0]) {
        return;
    }
    FrameParams f = load_frame_params(pc.frame);
    uint i = pc.order.v[j];
    ProjectedSplat p = load_splat(pc.splats, i);
    uvec4 rect = p.rect;
    float q_max = footprint_q_max(p.opacity);
    uint capacity = f.scene.w;
    uint slot = pc.offsets.v[j];
    for (uint y = rect.y; y < rect.w; ++y) {
        for (uint x = rect.x; x < rect.z; ++x) {
            if (!footprint_touches_tile(p.uv, p.conic, q_max, x, y)) {
                continue;
            }
            if (slot < capacity) {
                pc.keys.v[slot] = y * f.size.z + x;
                pc.values.v[slot] = i;
            }
            ++slot;
        }
    }
}
