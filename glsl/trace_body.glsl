// The ray tracer (SPEC section 7, issue 32): one invocation per pixel walks the BVH
// (bvh_common.glsl) and composites its hits front to back, each hit's alpha times its clip
// weight (ray_hits.glsl, the hit model both paths share). CPU twins: src/reference/raytrace.rs
// (BVH), src/reference/tiled.rs (tile lists), src/reference/ray_hits.rs (the hit model).
//
// k-closest hits: a traversal pass collects, in a sorted buffer of TRACE_K entries, the K
// hits after the last one composited in (t, index) order (so no hit is missed or repeated,
// equal t included); the ray then composites them in order and, when the buffer was full,
// traces again from the last one. A pass culls a node whose box ends before the last hit or,
// with the buffer full, starts after its worst entry.
//
// lavapipe stops an invocation after 65,535 loop iterations in all (docs: PLATFORM.md), and a
// ray can need far more node visits than that. So the frame runs in rounds: a round gives each
// ray at most `budget` steps (a node visit or a composited hit) and leaves the whole state of
// a ray it did not finish in buffers (the stack, the k-buffer, colour and transmittance, the
// last hit, its counts), and appends the ray to the next round's list. Round r > 0 runs over
// that list only, its size set by trace_args.comp from the count (an indirect dispatch), so
// the SIMD lanes of a CPU driver and a GPU's warps are refilled with live rays each round
// instead of idling beside finished ones. Nothing waits on another invocation.
//
// With TILED (SPEC section 11, camera rays without a BVH): a pass walks the pixel's tile list
// (tiled_bounds.comp, tiled_emit.comp, the pair sort) instead of the tree: the Gaussians by
// their key, the least view depth of any hit of theirs, so a pass whose buffer is full ends at
// the first entry whose key lies past the buffer's farthest hit: nothing from there on can
// precede it. The next pass starts at the first entry whose hit the last one left out (a hit
// it found no room for; for one a nearer hit pushed out of the full buffer, the pass's first
// hit, at or before it), and takes, as a BVH pass does, the K hits after the last one
// composited. So the hits are composited in section 7's (t, index) order with any K, and no
// hit is ever forced out of order (section 11's forced count is 0 by construction); the cost
// of a small K is entries walked again, counted as visits. Rays run tile by tile (ray r is
// pixel r % 256 of tile r / 256), so neighbouring lanes walk the same list.
//
// Included by trace_deg<D> (SH of degree D in 32-bit floats) and trace_deg<D>_sh16.
// With SCENE_TEXELS (CPU drivers) the BVH, the Gaussians and their coefficients are read
// through texel views (a gather, where a buffer load is a scalar loop over the SIMD lanes per
// 64-bit word): the Gaussians and coefficients at bindings 10 and 11 of frame_texels.glsl, the
// nodes at binding 12, two RGBA32_UINT texels each (RayTracer's set layout).
#extension GL_KHR_shader_subgroup_vote : require
#include "bvh_common.glsl"
#include "sh.glsl"
#include "clip.glsl"
#if defined(SCENE_TEXELS) && !defined(TILED)
layout(set = 0, binding = 12) uniform utextureBuffer bvh_texels;
#endif
// With TILED and SCENE_TEXELS the set is the rasterizer's frame set (frame_texels.glsl, which
// sh.glsl includes): the tile lists' Gaussians four to a texel (sorted_value_quads) and the
// Gaussians' records (splat_texels, three texels each, the record's first 16 bytes in the
// first) beside the Gaussians and their coefficients.
// With MIXED (mixed scenes, SPEC section 8): each pixel's ray of this generation comes from
// the ray tree (mixed_spawn.comp) with its origin, direction, the t range of its Gaussians and
// the (colour, T) it starts from; a hit's clip is its splat object's; a composited Gaussian is
// darkened where a mesh shadows it; a ray that its Gaussians end stores its T negated.
#ifdef MIXED
#include "mixed_common.glsl"
#endif

#ifndef TILED
// Node i as its two 16-byte words.
void load_node(BvhTree nodes, uint i, out uvec4 w0, out uvec4 w1) {
#ifdef SCENE_TEXELS
    w0 = texelFetch(bvh_texels, int(2u * i));
    w1 = texelFetch(bvh_texels, int(2u * i + 1u));
#else
    Address at = address_item(Address(nodes), i, 32u);
    w0 = load_uvec4(at);
    w1 = load_uvec4(address_plus(at, 16u));
#endif
}
#endif

// Gaussian i of the scene.
Gaussian trace_gaussian(Gaussians gaussians, uint i) {
#ifdef SCENE_TEXELS
    return texel_gaussian(i);
#else
    return load_gaussian(gaussians, i);
#endif
}

layout(local_size_x = LINEAR_WORKGROUP) in;

#ifndef TRACE_K
#define TRACE_K 16
#endif
#define NO_LEAF 0xffffffffu
#define NO_NODE 0xffffffffu

// Ray flags.
#define RAY_DONE 1u
#define RAY_CAPPED 2u
#define RAY_COMPOSITING 4u
#define RAY_HAS_LAST 8u
#define RAY_ENDED 16u   // its Gaussians ended it (opacity, or the hit cap)

// Counter slots: TRACE_COUNTER_* (src/constants.rs). Sums of counts that can pass 2^32 on a
// large frame (node visits) are a low word and a carry word. Per-ray histograms of finished
// rays follow the counters, TRACE_HIST_BINS bins each (the last bin holds that many or more):
// hits composited, hits found, traversal passes.
#define HIST_WALKED uint(TRACE_COUNTER_WORDS)
#define HIST_FOUND (HIST_WALKED + uint(TRACE_HIST_BINS))
#define HIST_PASSES (HIST_FOUND + uint(TRACE_HIST_BINS))

// A ray's state between rounds, three 16-byte words at ray * 48 (GpuRayState): (colour,
// transmittance); (last hit's index, hits walked, flags, stack pointer | k count << 8 | k
// position << 16); (last hit's t as float bits, hits found, passes, node visits).

// The camera and image (GpuTraceParams).
struct TraceParams {
    vec4 eye;           // camera centre, w unused
    vec4 right;         // rotation columns: x right, y down, z forward (world)
    vec4 down;
    vec4 forward;
    vec4 focal;         // fx, fy, cx, cy
    uvec4 size;         // W, H, Gaussians, SH floats per Gaussian
    vec4 options;       // Q, max hits (as float), unused, unused
    uvec4 mixed;        // MIXED: the MixedParams' address (lo, hi); else the depth test's
                        // per-pixel view depth (lo, hi; 0: no depth test)
    uvec4 lists;        // TILED: the tile ranges' address (lo, hi), the sorted pairs' Gaussians
    uvec4 records;      // TILED: the records' address (lo, hi; tiled_bounds.comp), tiles across
    uvec4 depth_out;    // the depth output's per-pixel (median, sum alpha T z, 0, 0) address
                        // (lo, hi; 0: none), which write_depth turns into the caller's target
    uvec4 objects;      // without MIXED, objects with clip regions of their own: the regions'
                        // address (lo, hi; ClipParams each; 0: the frame's one clip), each
                        // Gaussian's region index's address (lo, hi)
};
layout(buffer_reference, std430, buffer_reference_align = 16) buffer TraceParamsRef { TraceParams p; };

layout(push_constant) uniform Push {
    TraceParamsRef params;
    Gaussians gaussians;
    ShCoefficients sh;
    BvhTree nodes;
    U32s rays;          // per ray of the batch its state, 12 words
    U32s stacks;        // TRACE_STACK entries per ray, entry k of ray r at k * stride + r
                        // (TILED: entry 0 the next list position, 1 the next pass's start, 2
                        // the list position of this pass's first hit)
    U32s kbuf;          // TRACE_K per ray, three sections of stride * TRACE_K words: t (float
                        // bits), Gaussian, alpha (float bits; TILED: unused, found again)
    Vec4s state;        // out: per pixel (premultiplied colour, transmittance)
    U32s counters;      // TRACE_* slots, then the HIST_* bins from word TRACE_COUNTER_WORDS
    U32s lists;         // two lists of the batch's live rays, `stride` entries each
    U32s live;          // per round, the rays of the batch it left live (its list's length)
    ClipParamsRef clip;
    uint round;         // 0: every ray of the batch, set up; r > 0: those round r - 1 left live
    uint budget;        // steps per ray in this round
    uint ray_base;      // the batch's first ray (pixel index)
    uint batch_rays;    // its rays
    uint stride;        // the per-ray buffers' rays (the largest batch)
    uint pad;
} pc;

#include "ray_hits.glsl"

// (t, index) strictly before (t2, index2).
bool before(float t, uint i, float t2, uint i2) {
    return t < t2 || (t == t2 && i < i2);
}

// Adds v to the 64-bit sum in counters lo, lo + 1: the add that wraps the low word carries.
void add_wide(uint lo, uint v) {
    uint old = atomicAdd(pc.counters.v[lo], v);
    if (old + v < old) {
        atomicAdd(pc.counters.v[lo + 1u], 1u);
    }
}

void main() {
    TraceParams f = pc.params.p;
    uint w = f.size.x;
    // The push constants the loops use, read once: gallivm reads a push constant in a loop
    // again on every iteration, as a load per SIMD lane (Mesa 22 has no loop-invariant code
    // motion), which was a fifth of a node visit (PERFORMANCE.md).
    uint stride = pc.stride;
    uint budget = pc.budget;
    U32s stacks = pc.stacks;
    BvhTree nodes = pc.nodes;
    uint item = linear_index();
    // The ray's index in its batch (`local`, which the per-ray buffers are indexed by) and in
    // the image (`ray`).
    uint local;
    if (pc.round == 0u) {
        if (item >= pc.batch_rays) {
            return;
        }
#ifdef MIXED
        // The batch's rays of this generation, as the ray tree listed them (mixed_spawn.comp;
        // pc.batch_rays is their count), so a pixel without a ray costs nothing.
        MixedParams listing = MixedParamsRef(mixed_address(pc.params.p.mixed.xy)).p;
        local = U32s(mixed_address(listing.lists.xy)).v[(pc.ray_base / stride) * stride + item];
#else
        local = item;
#endif
    } else {
        if (item >= pc.live.v[pc.round - 1u]) {
            return;
        }
        local = pc.lists.v[((pc.round - 1u) & 1u) * stride + item];
    }
    uint ray = pc.ray_base + local;
#ifdef TILED
    // Tile by tile: ray r is pixel r % 256 of tile r / 256 (the rays of tiles' pixels past the
    // image's edge do nothing).
    uint tiles_across = f.records.z;
    uint tile = ray / (TILE_SIZE * TILE_SIZE);
    uint within = ray % (TILE_SIZE * TILE_SIZE);
    uvec2 px = uvec2((tile % tiles_across) * TILE_SIZE + within % TILE_SIZE,
                     (tile / tiles_across) * TILE_SIZE + within / TILE_SIZE);
    if (px.x >= w || px.y >= f.size.y) {
        return;
    }
    uint pixel = px.y * w + px.x;
#else
    uvec2 px = uvec2(ray % w, ray / w);
    uint pixel = ray;
#endif
    Address state_at = address_item(Address(pc.rays), local, 48u);
    // The k-buffer's three sections (t, index, alpha) of 4 TRACE_K bytes per ray each.
    Address k_t = address_item(Address(pc.kbuf), local, 4u * uint(TRACE_K));
    Address k_index = address_item(k_t, stride, 4u * uint(TRACE_K));
    Address k_alpha = address_item(k_t, stride, 8u * uint(TRACE_K));
    vec4 colour_t;
    uvec4 info;
    uvec4 more;
    if (pc.round == 0u) {
        colour_t = vec4(0.0, 0.0, 0.0, 1.0);
        info = uvec4(0u, 0u, 0u, 1u);   // one node on the stack: the root
        more = uvec4(0u);
        stacks.v[local] = 0u;
    } else {
        colour_t = load_vec4(state_at);
        info = load_uvec4(address_plus(state_at, 16u));
        more = load_uvec4(address_plus(state_at, 32u));
    }
    // The pixel's ray (SPEC section 2).
    vec3 e = f.eye.xyz;
    vec3 d = camera_ray_direction(f.right.xyz, f.down.xyz, f.forward.xyz, f.focal, px);
    // The Gaussians' stretch of the ray, and whether it culls as a camera ray does.
    float t_lo = 0.0;
    float t_hi = UNBOUNDED;
    bool cull = true;
    bool shade = false;
#ifdef MIXED
    MixedParams mixed = MixedParamsRef(mixed_address(f.mixed.xy)).p;
    Address ray_at = address_item(mixed_address(mixed.refs2.xy), ray, 64u);
    {
        vec4 r0 = load_vec4(ray_at);
        vec4 r1 = load_vec4(address_plus(ray_at, 16u));
        uint ray_flags = load_uvec4(address_plus(ray_at, 48u)).x;
        e = r0.xyz;
        t_lo = r0.w;
        d = r1.xyz;
        t_hi = r1.w;
        cull = (ray_flags & MIXED_RAY_CULL) != 0u;
        shade = (ray_flags & MIXED_RAY_SHADOW) == 0u && mixed.occluder_counts.x > 0u && mixed.counts.z > 0u;
        if (pc.round == 0u) {
            colour_t = load_vec4(address_plus(ray_at, 32u));
        }
        if ((ray_flags & MIXED_RAY_NONE) != 0u) {
            info.z |= RAY_DONE;
        }
    }
    vec2 depth = vec2(0.0);  // a mixed scene's rays have no depth output
#else
    // The depth test against an engine's depth (SPEC section 9), as the view depth per pixel
    // that the depth prepare pass left at f.mixed.zw (0: none). A hit at t lies at view depth
    // t (d . forward) and is composited only in front of the engine's surface: gaussian_hit
    // takes t < t_hi, so nothing at the surface or behind it is found, and the ray ends there.
    Address depth_limit = address_of_words(f.mixed.zw);
    if (!address_is_null(depth_limit)) {
        t_hi = F32s(depth_limit).v[pixel] / dot(d, f.forward.xyz);
    }
    // The depth output's (median, sum alpha T z), carried between rounds in its buffer.
    Address depth_out = address_of_words(f.depth_out.xy);
    vec2 depth = vec2(uintBitsToFloat(0x7f800000u), 0.0);
    if (!address_is_null(depth_out) && pc.round != 0u) {
        depth = load_vec4_item(Vec4s(depth_out), pixel).xy;
    }
#endif
    // A hit's view depth is t along.
    float along = dot(d, f.forward.xyz);
    // No zero component: 0 * inf in the slab test would be NaN and lose the box.
    vec3 inv_d = 1.0 / (sign(d) * max(abs(d), vec3(1e-20)) + vec3(equal(d, vec3(0.0))) * 1e-20);
    // The ray's visible intervals, once (clip.glsl).
    // (With MIXED, pc.clip is splat object 0's; the others' follow it.)
    ClipParams clip = load_clip_params(pc.clip);
    vec4 spans = ray_spans(clip, e, d);
    uint max_hits = uint(f.options.y);
    uint leaves = f.size.z - 1u;

    uint flags = info.z;
    if (f.size.z == 0u) {
        flags |= RAY_DONE;  // no Gaussians, no tree: the background
    }
    uint sp = info.w & 0xffu;
    // The node the traversal visits next, if not the stack's top (saved on the stack between
    // rounds).
    uint node = NO_NODE;
    uint k_count = (info.w >> 8u) & 0xffu;
    uint k_pos = (info.w >> 16u) & 0xffu;
    uint walked = info.y;
    uint last_index = info.x;
    float last_t = uintBitsToFloat(more.x);
    uint found = more.y;
    uint passes = more.z;
    uint visits = more.w;
    vec3 colour = colour_t.rgb;
    float T = colour_t.a;
    // The k-buffer, always whole: its entries are read and written by constant index only,
    // so they stay in registers (a dynamic index sends an array to memory on lavapipe).
    float kt[TRACE_K];
    uint ki[TRACE_K];
    float ka[TRACE_K];
#ifdef TILED
    // The tile's list, where this ray is in it, and where the next pass starts (NO_NODE: at
    // the list's end).
    uvec2 list = UVec2s(address_of_words(f.lists.xy)).v[tile];
    U32s list_gaussians = U32s(address_of_words(f.lists.zw));
    Address records = address_of_words(f.records.xy);
    uint pos = pc.round == 0u ? list.x : stacks.v[local];
    uint restart = pc.round == 0u ? NO_NODE : stacks.v[stride + local];
    // The list position of this pass's first hit: a hit pushed out of the full buffer lies
    // at or after it.
    uint pass_first = pc.round == 0u ? NO_NODE : stacks.v[2u * stride + local];
#endif
    if (pc.round != 0u) {
        [[unroll]] for (uint q = 0u; q < uint(TRACE_K) / 4u; ++q) {
            uvec4 t4 = load_uvec4(address_item(k_t, q, 16u));
            uvec4 i4 = load_uvec4(address_item(k_index, q, 16u));
#ifndef TILED
            uvec4 a4 = load_uvec4(address_item(k_alpha, q, 16u));
#endif
            [[unroll]] for (uint c = 0u; c < 4u; ++c) {
                kt[4u * q + c] = uintBitsToFloat(t4[c]);
                ki[4u * q + c] = i4[c];
#ifndef TILED
                ka[4u * q + c] = uintBitsToFloat(a4[c]);
#endif
            }
        }
    } else {
        [[unroll]] for (uint k = 0u; k < uint(TRACE_K); ++k) {
            kt[k] = 0.0;
            ki[k] = 0u;
            ka[k] = 0.0;
        }
    }
    uint found_now = 0u;
    uint visits_now = 0u;
    uint tests_now = 0u;    // Gaussians tested for a hit
    bool overflowed = false;
    uint steps = 0u;
#ifdef TILED
    // A pass walks the list from `pos`; each entry's hit joins the buffer of the K nearest
    // hits after the last one composited. With the buffer full, the pass ends at the first
    // entry whose key lies past the buffer's farthest hit (nothing from there on can precede
    // it), and then composites the buffer in order. A hit it found no room for, or one a
    // nearer hit pushed out, is left to the next pass, which starts at the first entry whose
    // hit was left out; a pass that left nothing out ends the ray.
    while ((flags & RAY_DONE) == 0u && steps < budget) {
        while ((flags & RAY_COMPOSITING) == 0u && steps < budget) {
            ++steps;
            uint g = NO_LEAF;
            bool inside = false;
            if (pos < list.y) {
                // The Gaussian's silhouette rectangle (pixels, inclusive) and key.
#ifdef SCENE_TEXELS
                g = texelFetch(sorted_value_quads, int(pos >> 2u))[pos & 3u];
                uvec4 record = texelFetch(splat_texels, int(3u * g));
#else
                g = list_gaussians.v[pos];
                uvec4 record = load_uvec4(address_item(records, g, 48u));
#endif
                float key = uintBitsToFloat(record.z);
                inside = px.x >= (record.x & 0xffffu) && px.x <= (record.x >> 16u)
                      && px.y >= (record.y & 0xffffu) && px.y <= (record.y >> 16u);
                if (key >= t_hi * along) {
                    // No hit from here on is taken, in this pass or a later one.
                    g = NO_LEAF;
                } else if (k_count == uint(TRACE_K) && key > kt[TRACE_K - 1] * along) {
                    // None from here on precedes the buffer's farthest hit: the next pass
                    // starts here at the latest.
                    restart = min(restart, pos);
                    g = NO_LEAF;
                }
            }
            if (g == NO_LEAF) {
                // The pass is over: composite what it found.
                pos = list.y;
                flags |= RAY_COMPOSITING;
                k_pos = 0u;
                ++passes;
            } else if (subgroupAny(inside) && inside) {
                // Only a pixel inside the silhouette's rectangle can hit it (most of a tile's
                // pixels are not): the lanes that are test together.
                ++visits_now;
                ++tests_now;
                vec2 hit = gaussian_hit(f, g, e, d, cull, t_lo, t_hi);
                bool after = (flags & RAY_HAS_LAST) == 0u || before(last_t, last_index, hit.x, g);
                bool room = k_count < uint(TRACE_K) || before(hit.x, g, kt[TRACE_K - 1], ki[TRACE_K - 1]);
                if (hit.y > 0.0 && after && !room) {
                    restart = min(restart, pos);  // left out: found again by a later pass
                }
                if (hit.y > 0.0 && after && room) {
                    ++found_now;
                    if (k_count == uint(TRACE_K)) {
                        // The farthest is pushed out: a later pass finds it again.
                        restart = min(restart, pass_first);
                    }
                    pass_first = min(pass_first, pos);
                    // The buffer holds (t, Gaussian) alone, the least state a step carries (a
                    // CPU driver keeps it all live through the walk): a hit's alpha is found
                    // again when it is composited.
                    uint p0 = min(k_count, uint(TRACE_K - 1));
                    k_count = min(k_count + 1u, uint(TRACE_K));
                    [[unroll]] for (uint k = 0u; k < uint(TRACE_K); ++k) {
                        if (k == p0) {
                            kt[k] = hit.x;
                            ki[k] = g;
                        }
                    }
                    [[unroll]] for (int k = TRACE_K - 1; k > 0; --k) {
                        if (uint(k) <= p0 && before(kt[k], ki[k], kt[k - 1], ki[k - 1])) {
                            float tt = kt[k]; kt[k] = kt[k - 1]; kt[k - 1] = tt;
                            uint ti = ki[k]; ki[k] = ki[k - 1]; ki[k - 1] = ti;
                        }
                    }
                }
                ++pos;
            } else {
                ++pos;
            }
        }
        bool compositing = (flags & RAY_COMPOSITING) != 0u && (flags & RAY_DONE) == 0u;
        while (subgroupAny(compositing) && compositing && steps < budget) {
            ++steps;
            // Compositing the pass's hits in order (SPEC section 4's rule).
            if (k_pos == k_count) {
                if (restart == NO_NODE) {
                    flags |= RAY_DONE;  // the pass left nothing out
                } else {
                    // The next pass: from the first entry whose hit this one left out.
                    flags &= ~RAY_COMPOSITING;
                    k_count = 0u;
                    pos = restart;
                    restart = NO_NODE;
                    pass_first = NO_NODE;
                }
            } else if (walked == max_hits) {
                flags |= RAY_DONE | RAY_CAPPED | RAY_ENDED;
            } else {
                ++walked;
                // Entry k_pos by fixed indices (selects), not a dynamic index into the arrays.
                uint g = 0u;
                float hit_t = 0.0;
                [[unroll]] for (uint k = 0u; k < uint(TRACE_K); ++k) {
                    bool at = k == k_pos;
                    g = at ? ki[k] : g;
                    hit_t = at ? kt[k] : hit_t;
                }
                float alpha = gaussian_hit(f, g, e, d, cull, t_lo, t_hi).y
                            * hit_clip_weight(f, clip, spans, g, hit_t, e, d);
                last_t = hit_t;
                last_index = g;
                flags |= RAY_HAS_LAST;
                ++k_pos;
                add_hit(f, g, alpha, e, d, hit_t, along, colour, T, flags, depth, steps, shade
                        MIXED_ARGS);
            }
            compositing = (flags & RAY_COMPOSITING) != 0u && (flags & RAY_DONE) == 0u;
        }
    }
#else
    while ((flags & RAY_DONE) == 0u && steps < budget) {
        // A step is a node visit (or the end of a pass) or a composited hit. A CPU driver
        // runs every branch under a mask and every loop body at least once, so the loops nest
        // by how often their work is needed, each run by the lanes that need it together: an
        // iteration of this loop is a pass; in it, the traversal tests one leaf per iteration,
        // and between two leaves runs over inner nodes alone (Aila and Laine's
        // "while-while"); then the pass's hits are composited (PERFORMANCE.md).
        while ((flags & RAY_COMPOSITING) == 0u && steps < budget) {
            uint leaf = NO_LEAF;
            while ((flags & RAY_COMPOSITING) == 0u && leaf == NO_LEAF && steps < budget) {
                ++steps;
                // The node to visit: the near child the last visit went on to, else the stack's
                // top (so a descent costs one stack write, for the far child, and no read).
                if (node == NO_NODE && sp > 0u) {
                    --sp;
                    node = stacks.v[sp * stride + local];
                }
                if (node == NO_NODE) {
                    // The pass is over: composite what it found.
                    flags |= RAY_COMPOSITING;
                    k_pos = 0u;
                    ++passes;
                    if (k_count == 0u) {
                        flags |= RAY_DONE;
                    }
                } else {
                    ++visits_now;
                    uvec4 w0, w1;
                    load_node(nodes, node, w0, w1);
                    vec3 lo = uintBitsToFloat(w0.xyz);
                    vec3 hi = uintBitsToFloat(w1.xyz);
                    vec3 a0 = (lo - e) * inv_d;
                    vec3 a1 = (hi - e) * inv_d;
                    vec3 tmin = min(a0, a1);
                    vec3 tmax = max(a0, a1);
                    float t_in = max(max(tmin.x, max(tmin.y, tmin.z)), 0.0);
                    float t_out = min(tmax.x, min(tmax.y, tmax.z));
                    float slack = 1e-4 * (1.0 + abs(t_out));
                    bool enters = t_in <= t_out + slack && lo.x <= hi.x;
                    // Hits inside lie within the box's stretch of the ray.
                    if ((flags & RAY_HAS_LAST) != 0u && t_out + slack < last_t) {
                        enters = false;
                    }
                    if (k_count == uint(TRACE_K) && t_in - slack > kt[TRACE_K - 1]) {
                        enters = false;
                    }
                    if (t_in - slack > t_hi || t_out + slack < t_lo) {
                        enters = false;
                    }
                    bool inner = node < leaves;
                    node = NO_NODE;
                    if (enters && !inner) {
                        leaf = w0.w;
                    } else if (enters && sp < uint(TRACE_STACK)) {
                        // The child the ray meets first on the split's axis is visited first, so
                        // the buffer fills front to back and the far child is culled by its
                        // worst entry.
                        uint axis = w1.w >> BVH_AXIS_SHIFT;
                        uint right = w1.w & BVH_CHILD_MASK;
                        bool right_first = axis < 3u && d[min(axis, 2u)] < 0.0;
                        stacks.v[sp * stride + local] = right_first ? w0.w : right;
                        ++sp;
                        node = right_first ? right : w0.w;
                    } else if (enters) {
                        // Cannot happen (depth <= 63 keeps at most 63 entries): counted, never
                        // silent (after the loop: an atomic in it costs every iteration a loop
                        // over the lanes on gallivm, taken or not).
                        overflowed = true;
                    }
                }
            }
            if (subgroupAny(leaf != NO_LEAF) && leaf != NO_LEAF) {
                ++tests_now;
                uint g = leaf;
                vec2 hit = gaussian_hit(f, g, e, d, cull, t_lo, t_hi);
                bool after = (flags & RAY_HAS_LAST) == 0u || before(last_t, last_index, hit.x, g);
                bool room = k_count < uint(TRACE_K) || before(hit.x, g, kt[TRACE_K - 1], ki[TRACE_K - 1]);
                if (hit.y > 0.0 && after && room) {
                    ++found_now;
                    // Sorted insertion: the new entry takes the last slot (the worst's, when the
                    // buffer is full) and moves down past every larger one. Unrolled, with fixed
                    // indices: no loop iterations against the cap, the arrays stay in registers.
                    uint p0 = min(k_count, uint(TRACE_K - 1));
                    k_count = min(k_count + 1u, uint(TRACE_K));
                    [[unroll]] for (uint k = 0u; k < uint(TRACE_K); ++k) {
                        if (k == p0) {
                            kt[k] = hit.x;
                            ki[k] = g;
                            ka[k] = hit.y;
                        }
                    }
                    [[unroll]] for (int k = TRACE_K - 1; k > 0; --k) {
                        if (uint(k) <= p0 && before(kt[k], ki[k], kt[k - 1], ki[k - 1])) {
                            float tt = kt[k]; kt[k] = kt[k - 1]; kt[k - 1] = tt;
                            uint ti = ki[k]; ki[k] = ki[k - 1]; ki[k - 1] = ti;
                            float ta = ka[k]; ka[k] = ka[k - 1]; ka[k - 1] = ta;
                        }
                    }
                }
            }
        }
        bool compositing = (flags & RAY_COMPOSITING) != 0u && (flags & RAY_DONE) == 0u;
        while (subgroupAny(compositing) && compositing && steps < budget) {
            ++steps;
            // Compositing the pass's hits in order (SPEC section 4's rule).
            if (k_pos == k_count) {
                if (k_count < uint(TRACE_K)) {
                    flags |= RAY_DONE;  // the pass found every hit there was
                } else {
                    flags &= ~RAY_COMPOSITING;
                    k_count = 0u;
                    node = 0u;
                }
            } else if (walked == max_hits) {
                flags |= RAY_DONE | RAY_CAPPED | RAY_ENDED;
            } else {
                ++walked;
                // Entry k_pos by fixed indices (selects), not a dynamic index into the arrays.
                uint g = 0u;
                float hit_t = 0.0;
                float hit_alpha = 0.0;
                [[unroll]] for (uint k = 0u; k < uint(TRACE_K); ++k) {
                    bool at = k == k_pos;
                    g = at ? ki[k] : g;
                    hit_t = at ? kt[k] : hit_t;
                    hit_alpha = at ? ka[k] : hit_alpha;
                }
#ifdef MIXED
                float weight;
                uint object = object_of(mixed, g);
                if (object == 0u) {
                    weight = clip_weight(clip, spans, g, hit_t, e, d);
                } else {
                    weight = region_clip_weight(mixed_address(mixed.refs2.zw), object, g, hit_t,
                                                e, d);
                }
                float alpha = hit_alpha * weight;
#else
                float alpha = hit_alpha * hit_clip_weight(f, clip, spans, g, hit_t, e, d);
#endif
                last_t = hit_t;
                last_index = g;
                flags |= RAY_HAS_LAST;
                ++k_pos;
                add_hit(f, g, alpha, e, d, hit_t, along, colour, T, flags, depth, steps, shade
                        MIXED_ARGS);
            }
            compositing = (flags & RAY_COMPOSITING) != 0u && (flags & RAY_DONE) == 0u;
        }
    }
#endif
    found += found_now;
    visits += visits_now;
    if (found_now > 0u) {
        atomicAdd(pc.counters.v[TRACE_COUNTER_FOUND], found_now);
    }
    add_wide(TRACE_COUNTER_VISITS_LO, visits_now);
    add_wide(TRACE_COUNTER_TESTS_LO, tests_now);
    if (overflowed) {
        atomicAdd(pc.counters.v[TRACE_COUNTER_OVERFLOW], 1u);
    }
    // The pixel's (C, T) after every round, so that a frame cut short by its rounds still
    // shows what its rays composited so far.
#ifdef MIXED
    store_vec4_item(pc.state, ray, vec4(colour, (flags & RAY_ENDED) != 0u ? -T : T));
#else
    store_vec4_item(pc.state, pixel, vec4(colour, T));
    if (!address_is_null(depth_out)) {
        store_vec4_item(Vec4s(depth_out), pixel, vec4(depth, 0.0, 0.0));
    }
#endif
    if ((flags & RAY_DONE) != 0u) {
        atomicAdd(pc.counters.v[TRACE_COUNTER_WALKED], walked);
        atomicAdd(pc.counters.v[TRACE_COUNTER_PASSES], passes);
        if ((flags & RAY_CAPPED) != 0u) {
            atomicAdd(pc.counters.v[TRACE_COUNTER_CAPPED], 1u);
        }
        atomicAdd(pc.counters.v[HIST_WALKED + min(walked, uint(TRACE_HIST_BINS) - 1u)], 1u);
        atomicAdd(pc.counters.v[HIST_FOUND + min(found, uint(TRACE_HIST_BINS) - 1u)], 1u);
        atomicAdd(pc.counters.v[HIST_PASSES + min(passes, uint(TRACE_HIST_BINS) - 1u)], 1u);
        return;
    }
    // Still live: onto the next round's list, with its state (the node it was going on to
    // back on its stack).
#ifdef TILED
    stacks.v[local] = pos;
    stacks.v[stride + local] = restart;
    stacks.v[2u * stride + local] = pass_first;
#else
    if (node != NO_NODE) {
        stacks.v[sp * stride + local] = node;
        ++sp;
    }
#endif
    uint at = atomicAdd(pc.live.v[pc.round], 1u);
    pc.lists.v[(pc.round & 1u) * stride + at] = local;
    store_vec4(state_at, vec4(colour, T));
    store_uvec4(address_plus(state_at, 16u), uvec4(last_index, walked, flags, sp | (k_count << 8u) | (k_pos << 16u)));
    store_uvec4(address_plus(state_at, 32u), uvec4(floatBitsToUint(last_t), found, passes, visits));
    [[unroll]] for (uint q = 0u; q < uint(TRACE_K) / 4u; ++q) {
        store_uvec4(address_item(k_t, q, 16u),
                    floatBitsToUint(vec4(kt[4u * q], kt[4u * q + 1u], kt[4u * q + 2u], kt[4u * q + 3u])));
        store_uvec4(address_item(k_index, q, 16u),
                    uvec4(ki[4u * q], ki[4u * q + 1u], ki[4u * q + 2u], ki[4u * q + 3u]));
#ifndef TILED
        store_uvec4(address_item(k_alpha, q, 16u),
                    floatBitsToUint(vec4(ka[4u * q], ka[4u * q + 1u], ka[4u * q + 2u], ka[4u * q + 3u])));
#endif

    }
}
