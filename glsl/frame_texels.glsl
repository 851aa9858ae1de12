// The frame's texel views: descriptor set 0 of the kernels that read through texel buffers on
// CPU drivers (project, depth order, emit, cutoff tiles, tile ranges, the strips rasterizer
// and write target; set 1 of write target's image kernels), one binding per buffer as
// stages::frame_texels_set_layout and FrameSlot::frame_texels_set (src/frame.rs) make them. A
// CPU driver (lavapipe) loads a texel as a gather, where a buffer load is a scalar loop over
// the lanes per 64-bit word. Every binding is declared here, in one place; a kernel reads only
// those it needs.
#ifndef RARA_FRAME_TEXELS_GLSL
#define RARA_FRAME_TEXELS_GLSL

#include "common.glsl"
#include "clip.glsl"

// The set's number: 0, except in the write-target kernels of image targets, whose set 0 holds
// the image.
#ifndef FRAME_TEXELS_SET
#define FRAME_TEXELS_SET 0
#endif

// RGBA32_UINT: the sorted pair values, four to a texel (entries 4 g to 4 g + 3 in texel g), so
// that the strips rasterizer's walk over the entries that miss its block gets four in a fetch.
layout(set = FRAME_TEXELS_SET, binding = 0) uniform utextureBuffer sorted_value_quads;
// RGBA32_UINT, 3 per splat.
layout(set = FRAME_TEXELS_SET, binding = 1) uniform utextureBuffer splat_texels;
// RGBA32_UINT, 3 per record.
layout(set = FRAME_TEXELS_SET, binding = 2) uniform utextureBuffer cutoff_texels;
// R32_UINT.
layout(set = FRAME_TEXELS_SET, binding = 3) uniform utextureBuffer depth_order;
// R32_UINT: each Gaussian's drawn slot (the scan of the drawn flags), then, after the depth
// order, each drawn Gaussian's first pair.
layout(set = FRAME_TEXELS_SET, binding = 4) uniform utextureBuffer slot_texels;
// R32_UINT.
layout(set = FRAME_TEXELS_SET, binding = 5) uniform utextureBuffer tiles_touched;
// R32_UINT.
layout(set = FRAME_TEXELS_SET, binding = 6) uniform utextureBuffer sorted_keys;
// R32_UINT, as emitted (where emit writes packed pairs, the key of pair k is texel 2 k).
layout(set = FRAME_TEXELS_SET, binding = 7) uniform utextureBuffer emitted_keys;
// RGBA32_UINT, one per pixel: the rasterizer's per-pixel state (C, T), as floats' bits.
layout(set = FRAME_TEXELS_SET, binding = 8) uniform utextureBuffer state_texels;
// RGBA32_UINT: the frame's ClipParams (clip.glsl), texel 3 + k holding plane k.
layout(set = FRAME_TEXELS_SET, binding = 9) uniform utextureBuffer clip_texels;
// RGBA32_UINT, 3 per Gaussian.
layout(set = FRAME_TEXELS_SET, binding = 10) uniform utextureBuffer gaussian_texels;
// The scene's SH coefficients, four to a texel: RGBA32_UINT for floats, RG32_UINT for half
// floats (sh.glsl).
layout(set = FRAME_TEXELS_SET, binding = 11) uniform utextureBuffer sh_texels;

// Projected splat i (load_splat in common.glsl, from its three texels; a kernel that does not
// use a texel's fields does not fetch it: compositing without depth or clip weight reads two).
ProjectedSplat texel_splat(uint i) {
    int t = int(i) * 3;
    return splat_from_blocks(texelFetch(splat_texels, t), texelFetch(splat_texels, t + 1),
                             texelFetch(splat_texels, t + 2));
}

// The scene's Gaussian i (load_gaussian in common.glsl, from its three texels).
Gaussian texel_gaussian(uint i) {
    int t = int(i) * 3;
    Gaussian g;
    g.pos_opacity = uintBitsToFloat(texelFetch(gaussian_texels, t));
    g.rot = uintBitsToFloat(texelFetch(gaussian_texels, t + 1));
    g.scale = uintBitsToFloat(texelFetch(gaussian_texels, t + 2));
    return g;
}

// Cutoff record k (load_cutoff_record in clip.glsl, from its three texels).
CutoffRecord texel_cutoff_record(uint k) {
    int t = int(k) * 3;
    return CutoffRecord(uintBitsToFloat(texelFetch(cutoff_texels, t)),
                        uintBitsToFloat(texelFetch(cutoff_texels, t + 1)),
                        uintBitsToFloat(texelFetch(cutoff_texels, t + 2)));
}

// Clip plane k of the frame's region (ClipParams.planes[k]).
vec4 texel_clip_plane(uint k) {
    return uintBitsToFloat(texelFetch(clip_texels, 3 + int(k)));
}

#endif
