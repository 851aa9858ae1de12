// Depth test, first step (SPEC section 9): the engine's depth buffer, one invocation per pixel,
// turned into view depth (the camera-space z of section 2) by the engine's projection, into
// the frame's per-pixel limit that the *_depth rasterizers test each splat against.
//
// The engine's depth d is Vulkan's, in [0, 1], of a perspective projection with planes near and
// far: z = near far / (far - d (far - near)), or with reversed depth (1 at near, 0 at far)
// z = near far / (near + d (far - near)); with an infinite far plane z = near / (1 - d), and
// reversed z = near / d. A pixel still at the cleared value (1, or 0 when reversed) holds no
// surface: its limit is +infinity, so no splat is hidden there.
//
// DEPTH_SOURCE_IMAGE (depth_prepare_image): the engine's depth image, sampled (set 0, binding 0,
// a sampled image; texelFetch, which needs no sampler, reads the depth of any depth format,
// normalised). Else
// (depth_prepare_buffer) a buffer of f32 depths, one per pixel, rows of the frame's width.
#include "common.glsl"
#ifdef DEPTH_SOURCE_IMAGE
#extension GL_EXT_samplerless_texture_functions : require
#endif

layout(local_size_x = TILE_SIZE, local_size_y = TILE_SIZE) in;

#define DEPTH_REVERSED 1u
#define DEPTH_INFINITE 2u

layout(push_constant) uniform Push {
    F32s source;        // the engine's depths (buffer source only)
    F32s limit;         // out: per pixel view depth
    uvec2 size;         // W, H
    float near_plane;
    float far_plane;
    uint flags;         // DEPTH_REVERSED | DEPTH_INFINITE
    uint padding;
} pc;

#ifdef DEPTH_SOURCE_IMAGE
layout(set = 0, binding = 0) uniform texture2D engine_depth;
#endif

void main() {
    uvec2 p = gl_GlobalInvocationID.xy;
    if (p.x >= pc.size.x || p.y >= pc.size.y) {
        return;
    }
    uint index = p.y * pc.size.x + p.x;
#ifdef DEPTH_SOURCE_IMAGE
    float d = texelFetch(engine_depth, ivec2(p), 0).r;
#else
    float d = pc.source.v[index];
#endif
    bool reversed = (pc.flags & DEPTH_REVERSED) != 0u;
    float n = pc.near_plane;
    float f = pc.far_plane;
    float z;
    if ((pc.flags & DEPTH_INFINITE) != 0u) {
        z = reversed ? n / d : n / (1.0 - d);
    } else {
        z = reversed ? n * f / (n + d * (f - n)) : n * f / (f - d * (f - n));
    }
    bool cleared = reversed ? d <= 0.0 : d >= 1.0;
    pc.limit.v[index] = cleared ? uintBitsToFloat(0x7f800000u) : z;
}
