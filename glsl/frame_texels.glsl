// The frame's texel views: descriptor set 0 of the kernels that read through texel buffers on
// CPU drivers (project, depth order, emit, cutoff tiles, tile ranges and the strips
// rasterizer), one binding per buffer as stages::frame_texels_set_layout and
// FrameSlot::frame_texels_set (src/frame.rs) make them. A CPU driver (lavapipe) loads a texel
// as a gather, where a buffer load is a scalar loop over the lanes per 64-bit word. Every
// binding is declared here, in one place; a kernel reads only those it needs.
#ifndef RARA_FRAME_TEXELS_GLSL
#define RARA_FRAME_TEXELS_GLSL

#include "common.glsl"
#include "clip.glsl"

layout(set = 0, binding = 0) uniform utextureBuffer sorted_values;   // R32_UINT, per pair
layout(set = 0, binding = 1) uniform utextureBuffer splat_texels;    // RGBA32_UINT, 4 per splat
layout(set = 0, binding = 2) uniform utextureBuffer cutoff_texels;   // RGBA32_UINT, 3 per record
layout(set = 0, binding = 3) uniform utextureBuffer depth_order;     // R32_UINT
// R32_UINT: each Gaussian's drawn slot (the scan of the drawn flags), then, after the depth
// order, each drawn Gaussian's first pair.
layout(set = 0, binding = 4) uniform utextureBuffer slot_texels;
layout(set = 0, binding = 5) uniform utextureBuffer tiles_touched;   // R32_UINT
layout(set = 0, binding = 6) uniform utextureBuffer sorted_keys;     // R32_UINT
layout(set = 0, binding = 7) uniform utextureBuffer emitted_keys;    // R32_UINT, as emitted
layout(set = 0, binding = 8) uniform utextureBuffer gaussian_texels; // RGBA32_UINT, 3 per Gaussian
// The scene's SH coefficients, four to a texel: RGBA32_UINT for floats, RG32_UINT for half
// floats (sh.glsl).
layout(set = 0, binding = 9) uniform utextureBuffer sh_texels;

// Projected splat i (load_splat in common.glsl, from its four texels; a kernel that does not
// use a texel's fields does not fetch it).
ProjectedSplat texel_splat(uint i) {
    int t = int(i) * 4;
    uvec4 b0 = texelFetch(splat_texels, t);
    uvec4 b1 = texelFetch(splat_texels, t + 1);
    uvec4 b2 = texelFetch(splat_texels, t + 2);
    ProjectedSplat p;
    p.uv = uintBitsToFloat(b0.xy);
    p.depth = uintBitsToFloat(b0.z);
    p.opacity = uintBitsToFloat(b0.w);
    p.conic = uintBitsToFloat(b1.xyz);
    p.cutoff = b1.w;
    p.color = uintBitsToFloat(b2.xyz);
    p.pad = b2.w;
    p.rect = texelFetch(splat_texels, t + 3);
    return p;
}

// Cutoff record k (load_cutoff_record in clip.glsl, from its three texels).
CutoffRecord texel_cutoff_record(uint k) {
    int t = int(k) * 3;
    return CutoffRecord(uintBitsToFloat(texelFetch(cutoff_texels, t)),
                        uintBitsToFloat(texelFetch(cutoff_texels, t + 1)),
                        uintBitsToFloat(texelFetch(cutoff_texels, t + 2)));
}

#endif
