// Stage 8, write target: turns the rasterizer's per-pixel state (premultiplied colour C and
// transmittance T) into the caller's target, one invocation per pixel:
//   background: out = (C + T bg.rgb, (1 - T) + T bg.a)
//   over:       out = (C + T dst.rgb, (1 - T) + T dst.a), dst = what the target holds
// i.e. the splats composited front to back, then "over" the background or the target
// (premultiplied alpha). The kernels write_target_image_<format> (a storage image at
// set 0, binding 0; GLSL needs its format to load it) and write_target_buffer_<format> (a
// buffer reached by device address, rows tightly packed) include this file. A buffer's format
// is a kernel of its own rather than a branch: a CPU driver runs every branch's loads and
// stores under a mask, each a scalar loop over the SIMD lanes (lavapipe, plant at 640x480:
// write target 10.4 -> 6.0 ms for the rgba8 buffer, the same image). With STATE_TEXELS
// (write_target_*_texels, CPU drivers) the state is read through the frame's texel view
// (binding 8 of frame_texels.glsl; set 1 of the image kernels, set 0 of the buffer kernels): a
// gather, where a buffer load is a loop over the lanes per 64-bit word (lavapipe, plant at
// 1280x960, builds in turn, four runs: 21.8-23.7 -> 9.9-13.1 ms; 5.3-5.8 -> 3.8-4.2 ms at
// 640x480; the same images).
#include "common.glsl"
#ifdef STATE_TEXELS
#ifdef TARGET_IMAGE_FORMAT
#define FRAME_TEXELS_SET 1
#endif
#include "frame_texels.glsl"
#endif

layout(local_size_x = TILE_SIZE, local_size_y = TILE_SIZE) in;

// Whether the kernel composites over what the target holds (true) or over the background: a
// specialization constant rather than a flag in the push constants, so that the background
// kernels hold no load of the target, which a CPU driver would run under a mask, a scalar
// loop over the lanes, whatever a flag said (lavapipe, plant at 1280x960, bench, three rounds
// in turn: write target 12.8 / 13.3 / 12.0 -> 11.5 / 12.0 / 11.2 ms, the same image).
layout(constant_id = TARGET_OVER_CONSTANT_ID) const bool COMPOSITE_OVER = true;

// Buffer formats (TARGET_BUFFER_FORMAT of the buffer kernels), as TargetFormat on the host.
#define BUFFER_RGBA8 0
#define BUFFER_RGBA16F 1
#define BUFFER_RGBA32F 2

layout(push_constant) uniform Push {
    Vec4s state;        // per pixel (C, T), T negated once the pixel was done; unused with
                        // STATE_TEXELS
    U32s buffer_target; // the buffer target (0 for an image)
    vec4 background;    // rgba, unless COMPOSITE_OVER
    uvec2 size;         // W, H
} pc;

#ifdef TARGET_IMAGE_FORMAT
layout(set = 0, binding = 0, TARGET_IMAGE_FORMAT) uniform image2D target;

vec4 load_target(uvec2 p, uint index) {
    return imageLoad(target, ivec2(p));
}

void store_target(uvec2 p, uint index, vec4 c) {
    imageStore(target, ivec2(p), c);
}
#elif TARGET_BUFFER_FORMAT == BUFFER_RGBA8
vec4 load_target(uvec2 p, uint index) {
    return unpackUnorm4x8(pc.buffer_target.v[index]);
}

void store_target(uvec2 p, uint index, vec4 c) {
    pc.buffer_target.v[index] = pack_rgba8_nearest(c);
}
#elif TARGET_BUFFER_FORMAT == BUFFER_RGBA16F
vec4 load_target(uvec2 p, uint index) {
    return vec4(unpackHalf2x16(pc.buffer_target.v[2u * index]),
                unpackHalf2x16(pc.buffer_target.v[2u * index + 1u]));
}

void store_target(uvec2 p, uint index, vec4 c) {
    pc.buffer_target.v[2u * index] = packHalf2x16(c.rg);
    pc.buffer_target.v[2u * index + 1u] = packHalf2x16(c.ba);
}
#else
vec4 load_target(uvec2 p, uint index) {
    return uintBitsToFloat(uvec4(pc.buffer_target.v[4u * index], pc.buffer_target.v[4u * index + 1u],
                                 pc.buffer_target.v[4u * index + 2u], pc.buffer_target.v[4u * index + 3u]));
}

void store_target(uvec2 p, uint index, vec4 c) {
    uvec4 u = floatBitsToUint(c);
    pc.buffer_target.v[4u * index] = u.x;
    pc.buffer_target.v[4u * index + 1u] = u.y;
    pc.buffer_target.v[4u * index + 2u] = u.z;
    pc.buffer_target.v[4u * index + 3u] = u.w;
}
#endif

void main() {
    uvec2 p = gl_GlobalInvocationID.xy;
    if (p.x >= pc.size.x || p.y >= pc.size.y) {
        return;
    }
    uint index = p.y * pc.size.x + p.x;
#ifdef STATE_TEXELS
    vec4 s = uintBitsToFloat(texelFetch(state_texels, int(index)));
#else
    vec4 s = load_vec4_item(pc.state, index);
#endif
    vec4 under = COMPOSITE_OVER ? load_target(p, index) : pc.background;
    store_target(p, index, state_over(s, under));
}
