// Stage 7, rasterize, for the tiles without pairs in a frame whose rasterizer writes the
// caller's RGBA8 buffer target itself (CPU drivers; tile_lists.comp lists those tiles): one
// workgroup per listed tile writes the background into its pixels, what the rasterizer writes
// for a pixel with nothing composited (state_over of C = 0, T = 1), without the rasterizer's
// compositing pass, which a CPU driver runs once on every tile, empty or not.
#version 460
#include "common.glsl"

layout(local_size_x = TILE_SIZE, local_size_y = TILE_SIZE) in;

layout(push_constant) uniform Push {
    FrameParamsRef frame;
    U32s target;    // the RGBA8 buffer, rows tightly packed
    U32s tiles;     // the ids of the tiles to fill, one per workgroup
} pc;

void main() {
    FrameParams f = load_frame_params(pc.frame);
    uint id = pc.tiles.v[gl_WorkGroupID.x];
    uvec2 pixel = uvec2(id % f.size.z, id / f.size.z) * TILE_SIZE + gl_LocalInvocationID.xy;
    if (pixel.x < f.size.x && pixel.y < f.size.y) {
        vec4 background = vec4(f.background.rgb, 1.0);   // as write target's
        pc.target.v[pixel.y * f.size.x + pixel.x] =
            pack_rgba8_nearest(state_over(vec4(0.0, 0.0, 0.0, 1.0), background));
    }
}
