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

// Device addresses, and the two forms of the kernels. Every kernel is built twice (build.rs):
// portable, with addresses as a uvec2 (low word, high word) added with a carry
// (GL_EXT_buffer_reference_uvec2), for devices without shaderInt64 (SwiftShader, many mobile
// GPUs); and with RARA_INT64, for devices that have it, where an address is a uint64_t and
// the 64-bit words below move memory in fewer operations on a CPU driver. The host picks the
// form per device (ComputePipeline::new, DeviceInfo::shader_int64). Both forms read and write
// the same bytes: a Pair64 word is (x, y) in memory order either way.
#ifdef RARA_INT64
#extension GL_EXT_shader_explicit_arithmetic_types_int64 : require
#define Address uint64_t
#define Pair64 uint64_t
#else
#extension GL_EXT_buffer_reference_uvec2 : require
#define Address uvec2
#define Pair64 uvec2
#endif

// a + bytes.
Address address_plus(Address a, uint bytes) {
#ifdef RARA_INT64
    return a + uint64_t(bytes);
#else
    uint carry;
    uint lo = uaddCarry(a.x, bytes, carry);
    return uvec2(lo, a.y + carry);
#endif
}

// a + i * stride bytes, exact for any i and stride.
Address address_item(Address a, uint i, uint stride) {
#ifdef RARA_INT64
    return a + uint64_t(i) * uint64_t(stride);
#else
    uint hi, lo, carry;
    umulExtended(i, stride, hi, lo);
    lo = uaddCarry(a.x, lo, carry);
    return uvec2(lo, a.y + hi + carry);
#endif
}

// Whether a is the null address (a buffer the host left out).
bool address_is_null(Address a) {
#ifdef RARA_INT64
    return a == 0ul;
#else
    return a == uvec2(0u);
#endif
}

// An address from its (low, high) words, as the host packs one into a uvec4.
Address address_of_words(uvec2 lo_hi) {
#ifdef RARA_INT64
    return packUint2x32(lo_hi);
#else
    return lo_hi;
#endif
}

// Two 32-bit words as one Pair64 (x first in memory), and back.
Pair64 pair64(uvec2 w) {
#ifdef RARA_INT64
    return packUint2x32(w);
#else
    return w;
#endif
}

uvec2 pair64_words(Pair64 p) {
#ifdef RARA_INT64
    return unpackUint2x32(p);
#else
    return p;
#endif
}

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

// What the project stage leaves for the later stages, 48 bytes per Gaussian. The tile
// rectangle is not stored: splat_tile_rect derives it from uv and radius, bit for bit as
// project did (16 bytes less per Gaussian than keeping it). In memory the colour is packed
// into two words (pack_splat_color) so that what compositing reads, uv, opacity, conic and
// colour, fits the first two of the three 16-byte blocks (splat_block).
struct ProjectedSplat {
    vec2 uv;            // image coordinates of the centre (SPEC section 2)
    float depth;        // view-space z, > 0.2
    float opacity;
    vec3 conic;         // inverse 2D covariance (A, B, C)
    uint cutoff;        // index of the cutoff side record (and CUTOFF_WHOLE_*), or NO_CUTOFF
                        // (w = 1 everywhere)
    vec3 color;
    float radius;       // 3-sigma radius in pixels (an integer); SKIPPED_RADIUS if not drawn
};
// The same in memory (the host's GpuProjectedSplat), colour packed (pack_splat_color). Kernels
// read and write whole splats with load_splat and store_splat, single fields through this.
struct ProjectedSplatWords {
    vec2 uv;
    float opacity;
    uint color0;
    vec3 conic;
    uint color1;
    float depth;
    uint cutoff;
    float radius;
    uint pad;
};
layout(buffer_reference, std430, buffer_reference_align = 16) buffer ProjectedSplats { ProjectedSplatWords v[]; };

#define NO_CUTOFF 0xffffffffu
// A cutoff splat whose weight the records' pass found the same at every pixel its footprint
// reaches (cutoff_records_body.glsl, in frames that classify cutoff pairs by tile) keeps its record
// index with one of these bits: weight 1 throughout (emit writes plain pairs) or 0 throughout
// (emit keys its pairs past every tile, as cutoff_tiles does an empty pair's). Either way its
// pairs skip the cutoff-tiles pass. Record indices stay below 2^30: a ProjectedSplat is 48
// bytes, and no buffer holds 2^30 of them.
#define CUTOFF_WHOLE_FULL 0x80000000u
#define CUTOFF_WHOLE_EMPTY 0x40000000u
#define CUTOFF_WHOLE_BITS (CUTOFF_WHOLE_FULL | CUTOFF_WHOLE_EMPTY)
// The radius of a Gaussian that project skipped: its tile rectangle is empty.
#define SKIPPED_RADIUS -1.0

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

// 16-byte loads and stores. With RARA_INT64 as two 64-bit words: a CPU driver (Mesa's
// gallivm) turns each component of a buffer-reference load or store into a scalar loop over
// the SIMD lanes, so a vec4 costs four loops and the same 16 bytes as two 64-bit words cost two
// (plant at 640x480: the project pass 39 -> 31 ms from its frame and Gaussian loads alone). A
// GPU loads the two words as it would the vec4. `address` must be 16-byte aligned
// (vk::Buffer::new aligns every buffer rara allocates to 16 bytes; engine targets are never
// read this way).
#ifdef RARA_INT64
layout(buffer_reference, std430, buffer_reference_align = 16) buffer Words16 { u64vec2 w; };
#else
layout(buffer_reference, std430, buffer_reference_align = 16) buffer Words16 { uvec4 w; };
#endif
// 8-byte words: sorted pairs (key, value), and other pairs of 32-bit words stored as one.
layout(buffer_reference, std430, buffer_reference_align = 8) buffer Pairs64 { Pair64 v[]; };

uvec4 load_uvec4(Address address) {
#ifdef RARA_INT64
    u64vec2 w = Words16(address).w;
    return uvec4(unpackUint2x32(w.x), unpackUint2x32(w.y));
#else
    return Words16(address).w;
#endif
}

vec4 load_vec4(Address address) {
    return uintBitsToFloat(load_uvec4(address));
}

void store_uvec4(Address address, uvec4 v) {
#ifdef RARA_INT64
    Words16(address).w = u64vec2(packUint2x32(v.xy), packUint2x32(v.zw));
#else
    Words16(address).w = v;
#endif
}

void store_vec4(Address address, vec4 v) {
    store_uvec4(address, floatBitsToUint(v));
}

// Words first .. first + 3 of a u32 array (first a multiple of 4).
uvec4 load_u32x4(U32s words, uint first) {
    return load_uvec4(address_item(Address(words), first, 4u));
}

// Item i of a vec4 array.
vec4 load_vec4_item(Vec4s items, uint i) {
    return load_vec4(address_item(Address(items), i, 16u));
}

void store_vec4_item(Vec4s items, uint i, vec4 v) {
    store_vec4(address_item(Address(items), i, 16u), v);
}

FrameParams load_frame_params(FrameParamsRef ref) {
    Address a = Address(ref);
    FrameParams f;
    f.world_to_cam0 = load_vec4(a);
    f.world_to_cam1 = load_vec4(address_plus(a, 16u));
    f.world_to_cam2 = load_vec4(address_plus(a, 32u));
    f.cam_pos = load_vec4(address_plus(a, 48u));
    f.focal = load_vec4(address_plus(a, 64u));
    f.background = load_vec4(address_plus(a, 80u));
    f.size = load_uvec4(address_plus(a, 96u));
    f.scene = load_uvec4(address_plus(a, 112u));
    return f;
}

Gaussian load_gaussian(Gaussians gaussians, uint i) {
    Address a = address_item(Address(gaussians), i, 48u);
    Gaussian g;
    g.pos_opacity = load_vec4(a);
    g.rot = load_vec4(address_plus(a, 16u));
    g.scale = load_vec4(address_plus(a, 32u));
    return g;
}

// The splat colour's packing: each channel (>= 0, as SH evaluation leaves it) as 21 bits, a
// float of 5 exponent bits (2^-15 up to 2^16, below that 0) and 16 mantissa bits rounded to
// nearest, relative error at most 2^-17 (a hundredth of an 8-bit step at 1.0). Red in bits
// 0-20 and green's low 11 bits in bits 21-31 of the first word; blue in bits 0-20 and
// green's high 10 bits in 21-30 of the second. Why: the strips rasterizer fetches each splat as
// texels, a gather per texel on a CPU driver, and the nine words it composites with (uv,
// opacity, conic, colour) in full floats need three texels; packed they take two, and the
// depth, cutoff record and radius, which the unclipped and hard-clipped kernels never read,
// the third. Host twin: GpuProjectedSplat::color (src/gpu_types.rs).
#define SPLAT_COLOR_BIAS (111u << 16)   // float exponent 112 (2^-15) -> 5-bit exponent 1
#define SPLAT_COLOR_MAX ((142u << 16) | 0xffffu)  // largest: exponent 142 (2^15), all ones

uint pack_color_channel(float c) {
    uint v = (floatBitsToUint(max(c, 0.0)) + 0x40u) >> 7u;  // 8 + 16 bits, rounded
    return v < (112u << 16) ? 0u : min(v, SPLAT_COLOR_MAX) - SPLAT_COLOR_BIAS;
}

float unpack_color_channel(uint v) {
    return v == 0u ? 0.0 : uintBitsToFloat((v + SPLAT_COLOR_BIAS) << 7u);
}

uvec2 pack_splat_color(vec3 c) {
    uint r = pack_color_channel(c.r), g = pack_color_channel(c.g), b = pack_color_channel(c.b);
    return uvec2(r | (g << 21u), b | ((g >> 11u) << 21u));
}

vec3 unpack_splat_color(uvec2 w) {
    uint g = (w.x >> 21u) | ((w.y >> 21u) << 11u);
    return vec3(unpack_color_channel(w.x & 0x1fffffu), unpack_color_channel(g),
                unpack_color_channel(w.y & 0x1fffffu));
}

// Byte offset of ProjectedSplat i's word block k (16 bytes each: uv, opacity, colour word 0 |
// conic, colour word 1 | depth, cutoff, radius, 0).
Address splat_block(ProjectedSplats splats, uint i, uint k) {
    return address_plus(address_item(Address(splats), i, 48u), k * 16u);
}

// ProjectedSplat from its three blocks (splat_block).
ProjectedSplat splat_from_blocks(uvec4 b0, uvec4 b1, uvec4 b2) {
    ProjectedSplat p;
    p.uv = uintBitsToFloat(b0.xy);
    p.opacity = uintBitsToFloat(b0.z);
    p.conic = uintBitsToFloat(b1.xyz);
    p.color = unpack_splat_color(uvec2(b0.w, b1.w));
    p.depth = uintBitsToFloat(b2.x);
    p.cutoff = b2.y;
    p.radius = uintBitsToFloat(b2.z);
    return p;
}

ProjectedSplat load_splat(ProjectedSplats splats, uint i) {
    return splat_from_blocks(load_uvec4(splat_block(splats, i, 0u)),
                             load_uvec4(splat_block(splats, i, 1u)),
                             load_uvec4(splat_block(splats, i, 2u)));
}

void store_splat(ProjectedSplats splats, uint i, ProjectedSplat p) {
    uvec2 color = pack_splat_color(p.color);
    store_uvec4(splat_block(splats, i, 0u),
                uvec4(floatBitsToUint(p.uv), floatBitsToUint(p.opacity), color.x));
    store_uvec4(splat_block(splats, i, 1u), uvec4(floatBitsToUint(p.conic), color.y));
    store_uvec4(splat_block(splats, i, 2u), uvec4(floatBitsToUint(p.depth), p.cutoff,
                                                  floatBitsToUint(p.radius), 0u));
}

// World-space direction of the ray through pixel centre `pixel` (SPEC section 2): camera-space
// ((i - cx)/fx, (j - cy)/fy, 1) turned to world, not normalised.
vec3 pixel_ray(FrameParams f, vec2 pixel) {
    vec2 c = (pixel - f.focal.zw) / f.focal.xy;
    return c.x * f.world_to_cam0.xyz + c.y * f.world_to_cam1.xyz + f.world_to_cam2.xyz;
}

// How pixel_ray changes from one pixel to the next across a row (+x) and down a column (+y).
vec3 pixel_ray_across(FrameParams f) {
    return f.world_to_cam0.xyz / f.focal.x;
}

vec3 pixel_ray_down(FrameParams f) {
    return f.world_to_cam1.xyz / f.focal.y;
}

// Indirect dispatch arguments with a 16-byte stride (x, y, z, unused).
layout(buffer_reference, std430, buffer_reference_align = 16) buffer DispatchArgs { uvec4 v[]; };

uint div_ceil(uint a, uint b) { return (a + b - 1u) / b; }

// Rotation matrix of a normalised quaternion (w, x, y, z), as rows.
void quat_rows(vec4 q, out vec3 r0, out vec3 r1, out vec3 r2) {
    float w = q.x, x = q.y, y = q.z, z = q.w;
    r0 = vec3(1.0 - 2.0 * (y * y + z * z), 2.0 * (x * y - w * z), 2.0 * (x * z + w * y));
    r1 = vec3(2.0 * (x * y + w * z), 1.0 - 2.0 * (x * x + z * z), 2.0 * (y * z - w * x));
    r2 = vec3(2.0 * (x * z - w * y), 2.0 * (y * z + w * x), 1.0 - 2.0 * (x * x + y * y));
}

// The same matrix's columns (its local axes in world coordinates).
void quat_columns(vec4 q, out vec3 c0, out vec3 c1, out vec3 c2) {
    vec3 r0, r1, r2;
    quat_rows(q, r0, r1, r2);
    c0 = vec3(r0.x, r1.x, r2.x);
    c1 = vec3(r0.y, r1.y, r2.y);
    c2 = vec3(r0.z, r1.z, r2.z);
}

// The normal axis of a flat Gaussian (SPEC section 6): the first whose scale is 0, or 3 for a
// Gaussian with three nonzero scales.
uint flat_axis(vec3 s) {
    return s.x == 0.0 ? 0u : (s.y == 0.0 ? 1u : (s.z == 0.0 ? 2u : 3u));
}

// Workgroup grid of a linear kernel over `items` (the host's `stages::linear_grid`): rows of
// at most LINEAR_GRID_X workgroups, since only 65,535 per dimension are guaranteed.
uvec3 linear_grid(uint items) {
    uint groups = div_ceil(items, LINEAR_WORKGROUP);
    return uvec3(min(groups, LINEAR_GRID_X), div_ceil(groups, LINEAR_GRID_X), 1u);
}

// The item of this invocation in a linear_grid dispatch.
uint linear_index() {
    return (gl_WorkGroupID.y * gl_NumWorkGroups.x + gl_WorkGroupID.x) * LINEAR_WORKGROUP
        + gl_LocalInvocationIndex;
}

// Tight per-tile footprints. A splat adds to a pixel only where alpha = o exp(-q/2) >= 1/255,
// q = A dx^2 + 2B dx dy + C dy^2, i.e. where q <= 2 ln(255 o). A tile of the SPEC's 3-sigma
// rectangle whose pixels all lie outside that ellipse would skip the splat at every pixel, so
// leaving it out of the tile's list changes no pixel. The bound has a small margin so that float
// rounding never drops a tile the rasterizer would draw into. Host twin:
// reference::project::footprint_touches_tile.
float footprint_q_max(float opacity) {
    return 2.0 * log(255.0 * opacity) * 1.0001 + 1e-3;
}

// The minimum of q(p - uv) over the pixel centres of the square box whose first centre is
// `corner` and which spans `span` pixels more each way: 0 when uv lies in the box, else found
// on the box's edges.
float footprint_q_min_in_box(vec2 uv, vec3 conic, vec2 corner, float span) {
    vec2 lo = corner - uv;
    vec2 hi = lo + span;
    if (lo.x <= 0.0 && hi.x >= 0.0 && lo.y <= 0.0 && hi.y >= 0.0) {
        return 0.0;
    }
    float q_min = 1e30;
    // Edges x = lo.x and x = hi.x: q is smallest at dy = -B dx / C, clamped to the edge.
    for (int e = 0; e < 2; ++e) {
        float dx = e == 0 ? lo.x : hi.x;
        float dy = clamp(-conic.y * dx / conic.z, lo.y, hi.y);
        q_min = min(q_min, conic.x * dx * dx + 2.0 * conic.y * dx * dy + conic.z * dy * dy);
        float dy2 = e == 0 ? lo.y : hi.y;
        float dx2 = clamp(-conic.y * dy2 / conic.x, lo.x, hi.x);
        q_min = min(q_min, conic.x * dx2 * dx2 + 2.0 * conic.y * dx2 * dy2 + conic.z * dy2 * dy2);
    }
    return q_min;
}

// The minimum of q(p - uv) over the pixel centres of tile (tx, ty).
float footprint_q_min_in_tile(vec2 uv, vec3 conic, uint tx, uint ty) {
    return footprint_q_min_in_box(uv, conic, vec2(tx * TILE_SIZE, ty * TILE_SIZE),
                                  float(TILE_SIZE - 1u));
}

// The ellipse q(d) <= q_max (d = p - uv) within a band of pixel-centre rows, d.y in [lo_y, hi_y]:
// (x_lo, x_hi) of the d.x its part in the band spans, widened against rounding; empty
// (x_lo > x_hi) where the band misses the ellipse; unbounded (+-1e30) for a conic with
// det < 1e-2 AC, whose det has lost its digits. A box of pixel centres that spans the band's
// whole height meets the ellipse iff its x-range meets this one (both convex). With
// Q = q_max and det = AC - B^2 the ellipse's edges are x(dy) = (-B dy +- sqrt(A Q - det dy^2))
// / A, concave and convex in dy, so their extremes over the band lie at
// dy = -+B sqrt(Q / (det C)) (where the whole ellipse has its rightmost and leftmost points)
// clamped into it: two square roots per band, where the minimum of q over a box's edges
// (footprint_q_min_in_box) takes four divisions per box. A block reached by mistake costs a
// masked pass, not a pixel. Host twin: reference::project::footprint_x_range_in_band.
vec2 footprint_x_range_in_band(vec3 conic, float q_max, float lo_y, float hi_y) {
    float a = conic.x, b = conic.y, c = conic.z;
    float det = a * c - b * b;
    float q = max(q_max, 0.0);
    float b_s = b * sqrt(q / (det * c));
    float dy_extent = sqrt(q * a / det) * 1.001 + 1e-3;
    float dy_right = clamp(-b_s, lo_y, hi_y);
    float dy_left = clamp(b_s, lo_y, hi_y);
    float x_hi = (sqrt(max(a * q - det * dy_right * dy_right, 0.0)) - b * dy_right) / a;
    float x_lo = (-sqrt(max(a * q - det * dy_left * dy_left, 0.0)) - b * dy_left) / a;
    float pad = 1e-3 * (1.0 + x_hi - x_lo);
    bool in_band = lo_y <= dy_extent && hi_y >= -dy_extent;
    vec2 range = in_band ? vec2(x_lo - pad, x_hi + pad) : vec2(1e30, -1e30);
    return det >= 1e-2 * a * c ? range : vec2(-1e30, 1e30);   // NaN: unbounded too
}

// Whether the ellipse q(p - uv) <= q_max reaches the pixel centres of tile (tx, ty). (The band
// test of footprint_blocks, one band per tile, was no faster here: docs/PERFORMANCE.md.)
bool footprint_touches_tile(vec2 uv, vec3 conic, float q_max, uint tx, uint ty) {
    return footprint_q_min_in_tile(uv, conic, tx, ty) <= q_max;
}

// The block bits of a pair in tile (tx, ty) (PAIR_BLOCKS_SHIFT): which of the tile's four
// BLOCK_SIZE x BLOCK_SIZE blocks of pixel centres the ellipse q(p - uv) <= q_max reaches, a
// row of blocks at a time (footprint_x_range_in_band).
// Host twin: reference::project::footprint_blocks.
uint footprint_blocks(vec2 uv, vec3 conic, float q_max, uint tx, uint ty) {
    uint bits = 0u;
    for (uint row = 0u; row < 2u; ++row) {
        float lo_y = float(ty * TILE_SIZE + row * BLOCK_SIZE) - uv.y;
        vec2 range = footprint_x_range_in_band(conic, q_max, lo_y, lo_y + float(BLOCK_SIZE - 1u));
        for (uint column = 0u; column < 2u; ++column) {
            float lo_x = float(tx * TILE_SIZE + column * BLOCK_SIZE) - uv.x;
            bool reached = range.x <= lo_x + float(BLOCK_SIZE - 1u) && range.y >= lo_x;
            bits |= reached ? 1u << (PAIR_BLOCKS_SHIFT + row * 2u + column) : 0u;
        }
    }
    return bits;
}

// Half extents (x, y) of the ellipse q(p - uv) <= q_max's bounding box, sqrt(q_max C / det)
// and sqrt(q_max A / det), widened by 0.1 % and a thousandth of a pixel so that rounding never
// cuts off a pixel the rasterizer would draw.
vec2 footprint_half_extent(vec3 conic, float q_max) {
    float det = conic.x * conic.z - conic.y * conic.y;
    return sqrt(max(q_max, 0.0) * vec2(conic.z, conic.x) / det) * 1.001 + 1e-3;
}

// The box (x0, y0, x1, y1) of the pixel centres of tile (tx, ty) that the ellipse
// q(p - uv) <= q_max may reach: the tile's pixel box cut to the ellipse's bounding box
// (footprint_half_extent). Empty (x0 > x1 or y0 > y1) when no pixel centre of the tile lies
// in that bounding box.
vec4 footprint_pixel_box_in_tile(vec2 uv, vec3 conic, float q_max, uint tx, uint ty) {
    vec2 lo = vec2(tx * TILE_SIZE, ty * TILE_SIZE);
    vec2 hi = lo + float(TILE_SIZE - 1u);
    vec2 half_extent = footprint_half_extent(conic, q_max);
    return vec4(max(lo, ceil(uv - half_extent)), min(hi, floor(uv + half_extent)));
}

// The tiles [x0, x1) x [y0, y1) as (x0, y0, x1, y1) of the square of half side `radius`
// pixels around uv, in a grid of `grid` tiles: clamp(int(v), 0, g) of SPEC section 3, clamped
// before the conversion, so the same tiles wherever int(v) is defined, and defined for a centre
// far off screen too (int() of a float beyond the int range is undefined in GLSL). Project
// computes it and every later reader derives it again from the stored uv and radius: the same
// operations on the same floats (the division by the power-of-two tile size is exact), so the
// same rectangle. Empty for SKIPPED_RADIUS. Host twin: reference::project::tile_rect.
uvec4 splat_tile_rect(vec2 uv, float radius, uvec2 grid) {
    if (!(radius >= 0.0)) {
        return uvec4(0u);
    }
    // precise: no compiler may fuse or reorder these operations differently in two kernels.
    precise float tile = float(TILE_SIZE);
    vec2 g = vec2(grid);
    precise vec2 lo = clamp((uv - radius) / tile, vec2(0.0), g);
    precise vec2 hi = clamp((uv + radius + tile - 1.0) / tile, vec2(0.0), g);
    return uvec4(uvec2(lo), uvec2(hi));
}

// Cells of a tile rectangle (x0, y0, x1, y1), numbered row by row from (x0, y0).
uint tile_rect_cells(uvec4 rect) {
    uint columns = rect.z > rect.x ? rect.z - rect.x : 0u;
    return rect.w > rect.y ? columns * (rect.w - rect.y) : 0u;
}

// Tile (x, y) of cell k of a tile rectangle (of at least one column: no division by zero).
uvec2 tile_rect_cell(uvec4 rect, uint k) {
    uint columns = rect.z > rect.x ? rect.z - rect.x : 1u;
    return uvec2(rect.x + k % columns, rect.y + k / columns);
}

// The shape of the ellipse q(p - uv) <= q_max that footprint_row_columns needs, per splat.
// With q = A dx^2 + 2B dx dy + C dy^2 and det = AC - B^2, the ellipse's row at dy spans
// dx = -B dy / A +- sqrt(q_max / A - det dy^2 / A^2): inside the band |dx + B dy / A| <=
// sqrt(q_max / A) and within |dy| <= sqrt(q_max A / det).
struct FootprintRows {
    vec2 uv;
    float b_a;          // B / A
    float half_width;   // sqrt(q_max / A)
    float dy_extent;    // the ellipse's half height (footprint_half_extent)
    float pad;          // pixels added on both sides against rounding
    bool ellipse;       // false: a degenerate conic, whose rows span the whole rectangle
};

FootprintRows footprint_rows(vec2 uv, vec3 conic, float q_max) {
    float a = conic.x, b = conic.y, c = conic.z;
    float det = a * c - b * b;
    float q = max(q_max, 0.0);
    FootprintRows r;
    r.uv = uv;
    r.ellipse = det > 0.0 && a > 0.0 && c > 0.0;
    r.b_a = b / a;
    r.half_width = sqrt(q / a);
    r.dy_extent = footprint_half_extent(conic, q_max).y;
    r.pad = 1.0 + 1e-3 * (r.half_width + abs(r.b_a) * r.dy_extent);
    return r;
}

// Columns [x0, x1) of tile row ty, cut to the rectangle's, that the ellipse may reach: those
// whose pixel-centre box meets the band |dx + B dy / A| <= sqrt(q_max / A) over the row's
// pixel-centre rows, widened by FootprintRows.pad; empty (x0 = x1) where the rows miss the
// ellipse's height. A superset of the columns footprint_touches_tile passes (that test, on
// the same continuous box, is the exact one). The band is a little wider than the ellipse's
// own rows near its top and bottom, and costs no square root per row: the exact row span
// (two square roots) made emit's walk 17 against 16.5 ms and project's 11.3 against 10.6
// (biker at 1280x960, three runs each in turn).
uvec2 footprint_row_columns(FootprintRows r, uvec4 rect, uint ty) {
    float band_lo = float(ty * TILE_SIZE) - r.uv.y;
    float band_hi = band_lo + float(TILE_SIZE - 1u);
    float centre_lo = -r.b_a * band_lo, centre_hi = -r.b_a * band_hi;
    float x_lo = min(centre_lo, centre_hi) - r.half_width;
    float x_hi = max(centre_lo, centre_hi) + r.half_width;
    // Tile tx's pixel centres span x = TILE_SIZE tx .. TILE_SIZE tx + TILE_SIZE - 1.
    float first = floor((r.uv.x + x_lo - r.pad - float(TILE_SIZE - 1u)) / float(TILE_SIZE));
    float end = floor((r.uv.x + x_hi + r.pad) / float(TILE_SIZE)) + 1.0;
    vec2 columns = clamp(vec2(first, end), vec2(rect.x), vec2(rect.z));
    bool misses = band_lo > r.dy_extent || band_hi < -r.dy_extent;
    uvec2 span = misses ? uvec2(rect.x) : uvec2(columns.x, max(columns.x, columns.y));
    return r.ellipse ? span : rect.xz;
}

// A walk over the cells of a tile rectangle that a splat's footprint may reach, for the
// loops that count (project) or write (emit) the tiles it touches: row by row, over each
// row's candidate columns (footprint_row_columns) only, each then tested exactly with
// footprint_touches_tile. The rectangle is the 3-sigma square of the largest axis; a thin or
// faint splat reaches a fraction of it. A SIMD vector of a CPU driver runs a loop for as
// long as any of its lanes does: on biker at 1280x960 the vectors' longest rectangles sum to
// 3.4 times their most touched tiles. Cells are numbered as in tile_rect_cell, and a round of
// cells [first, end) walks at most end - first steps: one per candidate, or one for a row
// without any.
struct FootprintWalk {
    uvec2 xy;       // the cell
    uint row_end;   // end of its row's candidate columns; xy.x >= row_end: none left
};

FootprintWalk footprint_walk_start(FootprintRows r, uvec4 rect, uint first) {
    uvec2 xy = tile_rect_cell(rect, first);
    uvec2 columns = footprint_row_columns(r, rect, xy.y);
    return FootprintWalk(uvec2(max(xy.x, columns.x), xy.y), columns.y);
}

// The walk's cell number in its rectangle (row by row from (x0, y0)); past a row's last
// column it is the next row's first.
uint footprint_walk_cell(uvec4 rect, FootprintWalk w) {
    return (w.xy.y - rect.y) * (rect.z - rect.x) + (w.xy.x - rect.x);
}

// Whether the walk's cell is one of its row's candidates.
bool footprint_walk_on_candidate(FootprintWalk w) {
    return w.xy.x < w.row_end;
}

// The walk's next candidate: along the row, else the next row's first.
void footprint_walk_next(inout FootprintWalk w, FootprintRows r, uvec4 rect) {
    w.xy.x += 1u;
    if (w.xy.x >= w.row_end) {
        w.xy.y += 1u;
        uvec2 columns = footprint_row_columns(r, rect, w.xy.y);
        w.xy.x = columns.x;
        w.row_end = columns.y;
    }
}

// How many of cells [first, end) of `rect` the ellipse q(p - uv) <= q_max reaches. Callers
// keep end - first <= TILE_RECT_CHUNK (lavapipe's loop cap).
uint count_touched_cells(vec2 uv, vec3 conic, float q_max, uvec4 rect, uint first, uint end) {
    uint touched = 0u;
    FootprintRows rows = footprint_rows(uv, conic, q_max);
    FootprintWalk w = footprint_walk_start(rows, rect, first);
    while (footprint_walk_cell(rect, w) < end) {
        touched += footprint_walk_on_candidate(w)
                && footprint_touches_tile(uv, conic, q_max, w.xy.x, w.xy.y) ? 1u : 0u;
        footprint_walk_next(w, rows, rect);
    }
    return touched;
}

// The rasterizer's per-pixel state s = (C, T), T negated once the pixel was done, composited
// over `under` (premultiplied alpha): (C + T under.rgb, (1 - T) + T under.a). write_target and
// the rasterizer kernels that write the target themselves (WRITES_TARGET) share it.
// Pixel `px`'s camera ray direction (SPEC section 2) from the camera's axes and
// focal = (fx, fy, cx, cy). `precise`: no fused multiply-add, so the ray tracer and the mixed
// scenes' tree (two kernels, compiled apart) trace the same ray to the bit.
vec3 camera_ray_direction(vec3 right, vec3 down, vec3 forward, vec4 focal, uvec2 px) {
    precise vec3 d = right * ((float(px.x) - focal.z) / focal.x)
                   + down * ((float(px.y) - focal.w) / focal.y) + forward;
    return normalize(d);
}

// `precise`: no fused multiply-add, so every kernel that ends a pixel this way (and the
// mixed scenes' tree, `mixed_spawn`) rounds the same, as the CPU reference does.
vec4 state_over(vec4 s, vec4 under) {
    float T = abs(s.a);
    precise vec4 over = vec4(s.rgb + T * under.rgb, (1.0 - T) + T * under.a);
    return over;
}

// c as an RGBA8 texel, each channel clamped to [0, 1] and rounded to nearest, as the CPU
// reference does (SPEC section 4).
uint pack_rgba8_nearest(vec4 c) {
    // `precise`: c * 255 rounded before the + 0.5, as on the host (`reference::rasterize::
    // to_rgba8`), never one fused multiply-add, which rounds a channel near a level's middle
    // the other way.
    precise vec4 scaled = clamp(c, 0.0, 1.0) * 255.0 + 0.5;
    uvec4 b = uvec4(floor(scaled));
    return b.r | (b.g << 8) | (b.b << 16) | (b.a << 24);
}

// Item `i` of [0, n) in the order that spreads consecutive items over the whole range:
// i * stride mod n, a permutation when stride and n are coprime (the host's
// `stages::spread_stride`). llvmpipe hands each of its threads one contiguous share of a
// dispatch's workgroups (lp_cs_tpool: num_iters / num_threads each, no stealing), so a
// dispatch whose costly items gather in one part of the range (the tiles of an object in the
// lower half of the image) keeps one thread busy while the others wait. stride 1: the items in
// order (GPUs, which schedule workgroups as they free up).
uint spread_item(uint i, uint n, uint stride) {
    uint m = max(n, 1u);
#ifdef RARA_INT64
    return uint((uint64_t(i) * uint64_t(stride)) % uint64_t(m));
#else
    uint hi, lo;
    umulExtended(i, stride, hi, lo);
    if (hi == 0u) {
        return lo % m;
    }
    // (hi 2^32 + lo) mod m a bit of lo at a time (r <- 2 r + bit, mod m), in 32-bit words: r < m,
    // so 2 r - m < m, which the wrapped difference gives exactly when 2 r overflows.
    uint r = hi % m;
    for (int b = 31; b >= 0; --b) {
        uint twice = r << 1u;
        r = (r >= 0x80000000u || twice >= m) ? twice - m : twice;
        r += (lo >> uint(b)) & 1u;
        r = r == m ? 0u : r;
    }
    return r;
#endif
}

#endif
