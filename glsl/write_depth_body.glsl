// Depth output (SPEC section 9): the rasterizer's per-pixel depth sums into the caller's depth
// target, one invocation per pixel: `median` is the depth at which 1 - T first reached 0.5,
// `mean` is sum(alpha T z) / sum(alpha T), where sum(alpha T) over the composited splats is
// 1 - T; +infinity where no splat was composited (mean) or 1 - T never reached 0.5 (median).
// write_depth_image writes an R32_SFLOAT storage image (set 0, binding 0), write_depth_buffer
// f32 values in rows of the frame's width.
#include "common.glsl"

layout(local_size_x = TILE_SIZE, local_size_y = TILE_SIZE) in;

#define DEPTH_MEAN 1u

layout(push_constant) uniform Push {
    Vec4s state;        // per pixel (C, T), T negated once the pixel was done
    Vec4s depth_state;  // per pixel (median, sum alpha T z, 0, 0)
    F32s buffer_target; // the buffer target (0 for an image)
    uvec2 size;         // W, H
    uint flags;         // DEPTH_MEAN
    uint padding;
} pc;

#ifdef DEPTH_TARGET_IMAGE
layout(set = 0, binding = 0, r32f) uniform writeonly image2D target;
#endif

void main() {
    uvec2 p = gl_GlobalInvocationID.xy;
    if (p.x >= pc.size.x || p.y >= pc.size.y) {
        return;
    }
    uint index = p.y * pc.size.x + p.x;
    vec4 d = load_vec4_item(pc.depth_state, index);
    float z = d.x;
    if ((pc.flags & DEPTH_MEAN) != 0u) {
        float weight = 1.0 - abs(load_vec4_item(pc.state, index).a);
        z = weight > 0.0 ? d.y / weight : uintBitsToFloat(0x7f800000u);
    }
#ifdef DEPTH_TARGET_IMAGE
    imageStore(target, ivec2(p), vec4(z, 0.0, 0.0, 1.0));
#else
    pc.buffer_target.v[index] = z;
#endif
}
