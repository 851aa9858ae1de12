#version 460
// Section 7 in tiles (SPEC section 11), stage 2, emit: one invocation per listed Gaussian, in
// key order (the depth order's sort of tiled_bounds's keys, ties by index), writes a (tile id,
// Gaussian index) pair for every tile of its rectangle at the offset the prefix sum gave it.
// The stable pair sort by tile id then leaves every tile's list in (key, index) order, as
// section 11 walks it. Pairs past the capacity are not written: the host sees the total (the
// frame's intersection counter), grows the buffers and traces the frame again.
//
// A round walks at most TILE_RECT_CHUNK cells of a rectangle (lavapipe's cap on an
// invocation's loop iterations), as the rasterizer's emit does; a rectangle that goes on past
// the round leaves its next pair's slot in `progress` for the next.
#include "common.glsl"

layout(local_size_x = LINEAR_WORKGROUP) in;

layout(push_constant) uniform Push {
    FrameParamsRef frame;
    U32s splat_words;   // tiled_bounds's records: the silhouette's pixels in words 0, 1
    U32s listed;        // listed.v[0] = listed Gaussians
    U32s order;         // Gaussian indices in key order
    U32s offsets;       // exclusive prefix sum of tiles touched, in key order
    U32s tile_ids;      // out: tile ids
    U32s values;        // out: Gaussian indices
    U32s progress;      // in (rounds after the first) and out: per listed Gaussian, its next slot
    uint round_index;
    uint pad;
} pc;

void main() {
    FrameParams f = load_frame_params(pc.frame);
    uint j = linear_index();
    if (j >= pc.listed.v[0]) {
        return;
    }
    uint i = pc.order.v[j];
    uint w0 = pc.splat_words.v[12u * i];
    uint w1 = pc.splat_words.v[12u * i + 1u];
    uvec4 pixels = uvec4(w0 & 0xffffu, w1 & 0xffffu, w0 >> 16u, w1 >> 16u);
    uvec4 rect = uvec4(pixels.xy / TILE_SIZE, pixels.zw / TILE_SIZE + 1u);
    uint cells = tile_rect_cells(rect);
    uint first_cell = pc.round_index * TILE_RECT_CHUNK;
    if (first_cell >= cells) {
        return;
    }
    uint slot = pc.round_index == 0u ? pc.offsets.v[j] : pc.progress.v[j];
    uint end_cell = min(cells, first_cell + TILE_RECT_CHUNK);
    uint columns = rect.z - rect.x;
    uint capacity = f.scene.w;
    for (uint k = first_cell; k < end_cell; ++k) {
        if (slot < capacity) {
            pc.tile_ids.v[slot] = (rect.y + k / columns) * f.size.z + rect.x + k % columns;
            pc.values.v[slot] = i;
        }
        ++slot;
    }
    if (end_cell < cells) {
        pc.progress.v[j] = slot;
    }
}
