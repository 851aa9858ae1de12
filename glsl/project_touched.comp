// Stage 1b, project's later rounds (images of more than TILE_RECT_CHUNK tiles only): counts
// the tiles a drawn splat reaches in cells [round_index * TILE_RECT_CHUNK, + TILE_RECT_CHUNK)
// of its tile rectangle and adds them to its tiles touched. Project counted the first
// TILE_RECT_CHUNK cells; splitting the count keeps each invocation under lavapipe's cap on
// loop iterations. It reads the splat as project stored it, with buffer loads on every
// device: the pass runs only for large images, and most of its invocations stop at once.
#version 460
#include "common.glsl"

layout(local_size_x = LINEAR_WORKGROUP) in;

layout(push_constant) uniform Push {
    FrameParamsRef frame;
    ProjectedSplats splats;
    U32s tiles_touched; // in and out
    U32s drawn;         // 1 for a drawn Gaussian
    uint round_index;
} pc;

void main() {
    FrameParams f = load_frame_params(pc.frame);
    uint i = linear_index();
    if (i >= f.scene.x || pc.drawn.v[i] == 0u) {
        return;
    }
    ProjectedSplat p = load_splat(pc.splats, i);
    uvec4 rect = splat_tile_rect(p.uv, p.radius, f.size.zw);
    uint cells = tile_rect_cells(rect);
    uint first = pc.round_index * TILE_RECT_CHUNK;
    if (first >= cells) {
        return;
    }
    uint end = min(cells, first + TILE_RECT_CHUNK);
    uint touched = count_touched_cells(p.uv, p.conic, footprint_q_max(p.opacity), rect, first,
                                       end);
    pc.tiles_touched.v[i] += touched;
}
