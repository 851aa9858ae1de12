// Shared by every kernel: extensions, buffer-reference types and the struct layouts that the
// host mirrors in src/gpu_types.rs (#[repr(C)], checked by a layout test).
//
// All buffers are reached through buffer device addresses passed in push constants: no
// descriptor sets, and no storage-buffer binding is ever subject to maxStorageBufferRange.
#ifndef RARA_COMMON_GLSL
#define RARA_COMMON_GLSL

#ifndef TILE_SIZE
#error "common.glsl needs the constants from src/constants.rs (build.rs passes them as macros)"
#endif

#extension GL_EXT_buffer_reference : require
#extension GL_EXT_buffer_reference2 : require

layout(buffer_reference, std430, buffer_reference_align = 4) buffer U32s { uint v[]; };
layout(buffer_reference, std430, buffer_reference_align = 4) buffer F32s { float v[]; };
layout(buffer_reference, std430, buffer_reference_align = 8) buffer UVec2s { uvec2 v[]; };
layout(buffer_reference, std430, buffer_reference_align = 16) buffer Vec4s { vec4 v[]; };

// A Gaussian as uploaded: activated values (SPEC section 1), 48 bytes.
struct Gaussian {
    vec4 pos_opacity;   // centre xyz, sigmoid(opacity)
    vec4 rot;           // normalised quaternion (w, x, y, z)
    vec4 scale;         // exp(scale_i) xyz, w unused
};
layout(buffer_reference, std430, buffer_reference_align = 16) buffer Gaussians { Gaussian v[]; };

// What the project stage leaves for the later stages, 64 bytes per Gaussian.
struct ProjectedSplat {
    vec2 uv;            // image coordinates of the centre (SPEC section 2)
    float depth;        // view-space z, > 0.2
    float opacity;
    vec3 conic;         // inverse 2D covariance (A, B, C)
    uint cutoff;        // index of the cutoff side record, or NO_CUTOFF (w = 1 everywhere)
    vec3 color;
    uint pad;
    uvec4 rect;         // touched tiles [x0, x1) x [y0, y1) as (x0, y0, x1, y1)
};
layout(buffer_reference, std430, buffer_reference_align = 16) buffer ProjectedSplats { ProjectedSplat v[]; };

#define NO_CUTOFF 0xffffffffu

// Per-frame parameters, written with vkCmdUpdateBuffer at the start of the frame's commands.
struct FrameParams {
    vec4 world_to_cam0; // rows of R_wc = rotation^T, w unused
    vec4 world_to_cam1;
    vec4 world_to_cam2;
    vec4 cam_pos;       // camera centre (world), w unused
    vec4 focal;         // fx, fy, W/2 - 0.5, H/2 - 0.5
    vec4 background;    // rgb, a unused
    uvec4 size;         // W, H, tiles x, tiles y
    uvec4 scene;        // Gaussians, SH degree, floats of SH per Gaussian, intersection capacity
};
layout(buffer_reference, std430, buffer_reference_align = 16) buffer FrameParamsRef { FrameParams p; };

// Indirect dispatch arguments with a 16-byte stride (x, y, z, unused).
layout(buffer_reference, std430, buffer_reference_align = 16) buffer DispatchArgs { uvec4 v[]; };

uint div_ceil(uint a, uint b) { return (a + b - 1u) / b; }

#endif
