// Stage 7, rasterize (SPEC section 4): one workgroup per 16x16 tile. Each pixel composites the
// tile's splats, sorted front to back, until its transmittance runs out.
//
// PIXELS_PER_INVOCATION (P) and COLUMNS_PER_INVOCATION (C) set how pixels map to invocations:
// invocation (x, y) owns the C x P pixels (x C + c, y P + r), c < C, r < P: C columns of a
// strip of P rows. The kernels rasterize* (P = C = 1, for GPUs: 256 threads per tile) and
// rasterize_strips* (for CPU drivers such as lavapipe) include this file.
// On lavapipe every load of a splat is paid once per SIMD vector of 8 invocations, so sharing
// it among more pixels pays: on plant 16 rows measured fastest of 1, 2, 4, 8, 16, and then 2
// columns (8 invocations per tile, one SIMD vector) cut the unclipped rasterize time by a
// further 20-25 % (268-283 -> 200-215 ms).
//
// TILE_BLOCKS (the strips kernels: P = 8, C = 1): a SIMD vector of 8 invocations per 8x8 block
// of the tile, four per tile, each walking the tile's list on its own. A CPU driver composites
// every entry of a list for every pixel of its vector, under a mask where the splat misses
// them; a vector here passes over the entries whose footprint misses its block (emit marks the
// blocks each pair reaches, PAIR_BLOCKS_SHIFT) in a loop that fetches four entries' handles a
// pass (advance_to_block), and stops when its own 64 pixels are done. lavapipe, render --repeat 3 at 640x480, unclipped:
// rasterize playbot 0.61x, plant 0.79x of the whole tile in one vector (2 columns x 16 rows);
// images the same but for a few pixels off by 1.
//
// How the splats are read (SPLAT_TEXELS selects):
// - The GPU kernels stage them through shared memory in batches of RASTER_BATCH, each
//   invocation loading a few, and the workgroup stops once every pixel is done.
// - The strips kernels (SPLAT_TEXELS) fetch each splat from uniform texel buffers of the sorted
//   pair values, the projected splats and the cutoff records (descriptor set 0). Mesa's
//   gallivm turns a load from shared memory or a storage buffer into a scalar loop over the
//   lanes that moves each lane's value into the vector through the stack (a stalled store
//   forward per lane and component), but a texel fetch into unmasked scalar loads gathered in
//   registers. Every lane of a vector fetches the same splat, from the cache. lavapipe, plant at
//   640x480, `render --repeat 10`: rasterize 131-137 -> 60-94 ms unclipped, 91 -> 42 ms hard
//   clipped and 125 -> 63-88 ms under rara (a plane at d = 0.05), the same images. Each
//   invocation stops once its own pixels are done, so the strips kernels need no shared memory
//   and no barrier.
//
// One dispatch walks at most RASTER_CHUNK entries of each tile list (lavapipe ends an
// invocation after 65,535 loop iterations in total; the loops over r are unrolled, and the rara
// variants take at most 3 passes per entry, see RASTER_CHUNK in src/constants.rs).
// Longer lists take several rounds; between rounds, and for the write-target stage after the
// last, the per-pixel state (colour, transmittance, done) lives in `state`.
//
// RaRa clipping: with mode rara each pixel first intersects its ray with the clip region (at
// most two intervals of t); a cutoff splat's opacity is then scaled by its weight along that
// ray (clip.glsl), from its cutoff record (the splat carries the record's index). The pairs
// that take this path carry PAIR_WEIGHTED in their value: emit sets it on every pair of a
// cutoff splat, and cutoff_tiles clears it where the weight is 1 at every pixel of the
// tile. The other pairs take the plain path.
// CUTOFF_WEIGHT selects the variant: 0 (no rara clipping: none of that code), CLIP_WEIGHT_MASS
// + 1 or CLIP_WEIGHT_LENGTH + 1.
// CPU drivers run both sides of every branch under a mask, so code that a frame does not need
// must not be in its kernel at all.
//
// Depth (SPEC section 9; the *_depth variants define DEPTH): each pixel takes the view depth of
// the engine's surface from `depth_limit` (depth_prepare.comp wrote it; 0: no depth test) and
// composites only the splats in front of it; since a tile's splats come in ascending depth, the
// pixel is done at the first one behind. Each pixel also keeps the depth outputs' sums in
// `depth_state` between rounds: the median depth (the splat at which 1 - T first reaches 0.5,
// +inf until then) and sum(alpha T z), which write_depth divides by sum(alpha T) = 1 - T.
//
// A cutoff splat's record is loaded by each invocation on its own (six 64-bit words, or three
// texels in the strips kernels). The strips kernels used to load it across the subgroup, one or two words per lane, and broadcast
// them; that needed every lane at the load, so the rara loops then ran while any lane of the
// subgroup had an open pixel (subgroupAny). On lavapipe that vote is a scalar loop over the
// lanes for every splat, and it cost more than it saved: plant at 640x480 under a plane,
// rasterize 145 -> 126 ms without it (0.87x), the same image.
#extension GL_EXT_control_flow_attributes : require
#include "common.glsl"
#include "clip.glsl"

#define P PIXELS_PER_INVOCATION
#ifndef COLUMNS_PER_INVOCATION
#define COLUMNS_PER_INVOCATION 1
#endif
#define C COLUMNS_PER_INVOCATION
// The invocation's pixels: px_*[c * P + r].
#define NPX (C * P)
#define TILE_PIXELS (TILE_SIZE * TILE_SIZE)
#define RASTER_BATCH TILE_PIXELS
#ifdef TILE_BLOCKS
// One SIMD vector of BLOCK_SIZE / C invocations per BLOCK_SIZE x BLOCK_SIZE block of the tile
// (P = BLOCK_SIZE): invocation (x, y) takes columns x C .. of block y.
layout(local_size_x = BLOCK_SIZE / C, local_size_y = 4) in;
#else
#define STRIPS (TILE_SIZE / P)
#define INVOCATIONS ((TILE_SIZE / C) * STRIPS)
layout(local_size_x = TILE_SIZE / C, local_size_y = STRIPS) in;
#endif

// Whether this dispatch writes the caller's RGBA8 buffer target (its address in pc.state), over
// the frame's background, in place of the per-pixel state: the host builds the strips kernels
// with it true for frames of one round without depth (Renderer::record), which then have no
// write-target pass. On a CPU driver every store to a buffer is a scalar loop over the lanes:
// the state took four words per pixel, read back by write target, which stored one more.
layout(constant_id = RASTER_WRITES_TARGET_CONSTANT_ID) const bool WRITES_TARGET = false;

// Whether every ray has at most one bounded end of its visible set (MassEnds in clip.glsl), as
// under a region of one plane: the host builds the mass kernels with it true for such frames
// (stages::rasterize::MassEnds). The weight then takes that end alone, without the loop over
// the ends, its choice between a pixel's two ends and the write-back of the C x P weights that
// a CPU driver runs under the loop's mask every pass. lavapipe, plant at 640x480 under the
// plane 0,0.2588,-0.9659,0.0996 with every pair weighted (--trace-all, RARA_CUTOFF_TILES=off),
// three rounds in turn, rasterize 42.5 / 42.6 / 46.3 -> 38.8 / 44.3 / 38.9 ms (with the fma
// in end_mass and normal_cdf); the same image.
layout(constant_id = RASTER_MASS_ONE_END_CONSTANT_ID) const bool MASS_ONE_END = false;

#define ROUND_FIRST 1u
// The dispatch walks a list of tiles (tile_lists.comp), workgroup x taking tiles.v[x], rather
// than the grid of tiles.
#define ROUND_TILE_LIST 2u

layout(push_constant) uniform Push {
    FrameParamsRef frame;
    ProjectedSplats splats;
    U32s values;        // splat index of each sorted pair
    UVec2s ranges;      // [start, end) per tile
    Vec4s state;        // per pixel (rgb, T), T negated once the pixel is done
    U32s counters;
    ClipParamsRef clip;
    CutoffRecords cutoffs;
    U32s tiles;         // with ROUND_TILE_LIST: the tile ids to walk
    Vec4s depth_state;  // with DEPTH: per pixel (median depth, sum alpha T z, 0, 0)
    F32s depth_limit;   // with DEPTH: per pixel the engine's view depth (0: no depth test)
    U32s cutoff_regions;  // with OBJECT_CLIPS: per cutoff record, its region in `clip`
    uint round_index;
    uint flags;
    uint row_stride;    // without ROUND_TILE_LIST: the grid's rows of tiles in spread_item order
    uint pad;
} pc;

// A splat as the compositing loop takes it: conic and opacity, centre, colour and, with rara
// clipping, its cutoff record index.
struct Staged {
    vec4 co;
    vec2 uv;
    vec3 rgb;
    uint cutoff;
#ifdef DEPTH
    float depth;
#endif
};

#ifdef SPLAT_TEXELS
#include "frame_texels.glsl"

// Cutoff record i.
CutoffRecord fetch_cutoff_record(uint i) {
    return texel_cutoff_record(i);
}

// Entry k of the pairs from `base`, as a handle for the loops below: the pair's value (the
// splat index, with PAIR_WEIGHTED when the pair takes the clip weight).
uint entry_handle(uint base, uint k) {
    return texelFetch(sorted_value_quads, int((base + k) >> 2u))[(base + k) & 3u];
}

// Whether the entry takes the clip weight.
bool handle_weighted(uint h) {
    return (h & PAIR_WEIGHTED) != 0u;
}

// The entry's splat.
Staged handle_splat(uint h) {
    ProjectedSplat p = texel_splat(h & PAIR_INDEX_MASK);
    Staged s;
    s.co = vec4(p.conic, p.opacity);
    s.uv = p.uv;
    s.rgb = p.color;
    s.cutoff = p.cutoff;
#ifdef DEPTH
    s.depth = p.depth;
#endif
    return s;
}

// Splat k of the entries from `base`.
Staged splat_at(uint base, uint k) {
    return handle_splat(entry_handle(base, k));
}

#ifdef TILE_BLOCKS
// This invocation's block's bit in a pair's value.
uint block_bit;

// Moves k (and its handle h) on to the first entry after k, of [0, count), whose footprint
// reaches this invocation's block; false, with k = count, when none does. Every lane of a
// SIMD vector takes the same block, so the loop is uniform: a CPU driver runs one cheap pass
// per texel of four entries passed over instead of compositing them under an empty mask.
// A pass fetches the handles four at a time, the texel of sorted_value_quads that holds the
// next entry, and takes the first of its entries from there on that reaches the block, so
// the common case, the next entry reaches it, takes one pass of a do-while and one fetch; a
// CPU driver runs a loop's body at least once even when no lane enters it, so a test before
// the loop would cost a whole pass too. Each texel fetch is a gather on such a driver, as
// costly for four handles as for one: the form before, two handles a pass from the R32 view,
// paid two fetches for the common case and a pass per two entries passed over.
bool advance_to_block(uint base, uint count, inout uint k, inout uint h) {
    if (k + 1u >= count) {  // k = ~0u before the first entry
        k = count;
        return false;
    }
    // Absolute indices into the sorted pairs: the pass looks at [at, end) within its texel.
    uint at = base + k + 1u;
    uint end = base + count;
    bool found;
    do {
        uint quad = at >> 2u;
        uvec4 handles = texelFetch(sorted_value_quads, int(quad));
        uint next = (quad + 1u) << 2u;
        found = false;
        [[unroll]] for (int j = 3; j >= 0; --j) {
            uint entry = (quad << 2u) + uint(j);
            bool reaches = (handles[j] & block_bit) != 0u && entry >= at && entry < end;
            h = reaches ? handles[j] : h;
            next = reaches ? entry : next;
            found = found || reaches;
        }
        at = next;
    } while (!found && at < end);
    k = found ? at - base : count;
    return found;
}
#endif
#else
// A staged splat is 9 words. With RARA_INT64 the first 8 go in one 32-byte element of
// 64-bit words, the blue and the record index in a second array: a CPU driver reads shared
// memory with one scalar loop over the lanes per load, however wide, so this is two loops per
// splat and SIMD vector (it was three, vec4 + vec2 + vec3, plus one for a cutoff splat's
// record index). Inside the loop each lane's value goes into the vector component by
// component, through the stack, so the tail is one 64-bit word rather than a uvec2: five
// such inserts per lane instead of six. Without 64-bit integers the same words go in two
// uvec4 arrays and a uvec2 one, the layout any GPU reads as fast. Staging a cutoff splat's
// 48-byte record too would cost a masked copy per pair on such a driver, cutoff or not, so
// the record is read when the splat is composited.
#ifdef RARA_INT64
shared u64vec4 batch_words[RASTER_BATCH];  // (conic.xy) (conic.z, opacity) (uv) (red, green)
shared uint64_t batch_tail[RASTER_BATCH];  // (blue bits, cutoff record index)
#else
shared uvec4 batch_conic[RASTER_BATCH];    // conic.xyz, opacity
shared uvec4 batch_uv_rg[RASTER_BATCH];    // uv, red, green
shared uvec2 batch_tail[RASTER_BATCH];     // blue bits, cutoff record index
#endif
#ifdef DEPTH
shared float batch_depth[RASTER_BATCH];
#endif

// Staged splat k of the batch. Staging negates a weighted pair's opacity (handle_weighted).
Staged splat_at(uint base, uint k) {
#ifdef RARA_INT64
    u64vec4 w = batch_words[k];
    uvec4 conic = uvec4(unpackUint2x32(w.x), unpackUint2x32(w.y));
    uvec4 uv_rg = uvec4(unpackUint2x32(w.z), unpackUint2x32(w.w));
    uvec2 tail = unpackUint2x32(batch_tail[k]);
#else
    uvec4 conic = batch_conic[k];
    uvec4 uv_rg = batch_uv_rg[k];
    uvec2 tail = batch_tail[k];
#endif
    Staged s;
    s.co = uintBitsToFloat(conic);
    s.co.w = abs(s.co.w);
    s.uv = uintBitsToFloat(uv_rg.xy);
    s.rgb = vec3(uintBitsToFloat(uv_rg.zw), uintBitsToFloat(tail.x));
    s.cutoff = tail.y;
#ifdef DEPTH
    s.depth = batch_depth[k];
#endif
    return s;
}

void stage(uint slot, vec4 co, vec2 uv, vec3 color, uint cutoff, float depth) {
#ifdef DEPTH
    batch_depth[slot] = depth;
#endif
#ifdef RARA_INT64
    batch_words[slot] = u64vec4(packUint2x32(floatBitsToUint(co.xy)),
                                packUint2x32(floatBitsToUint(co.zw)),
                                packUint2x32(floatBitsToUint(uv)),
                                packUint2x32(floatBitsToUint(color.rg)));
    batch_tail[slot] = packUint2x32(uvec2(floatBitsToUint(color.b), cutoff));
#else
    batch_conic[slot] = floatBitsToUint(co);
    batch_uv_rg[slot] = uvec4(floatBitsToUint(uv), floatBitsToUint(color.rg));
    batch_tail[slot] = uvec2(floatBitsToUint(color.b), cutoff);
#endif
}

// Cutoff record i.
CutoffRecord fetch_cutoff_record(uint i) {
    return load_cutoff_record(pc.cutoffs, i);
}

// Entry k of the batch, as a handle for the loops below: its slot.
uint entry_handle(uint base, uint k) {
    return k;
}

// Whether the entry takes the clip weight: the sign of its staged opacity.
bool handle_weighted(uint h) {
#ifdef RARA_INT64
    return (unpackUint2x32(batch_words[h].y).y & 0x80000000u) != 0u;
#else
    return (batch_conic[h].w & 0x80000000u) != 0u;
#endif
}

// The entry's splat.
Staged handle_splat(uint h) {
    return splat_at(0u, h);
}

shared uint pixels_done;
#endif

// The invocation's strip: first pixel, and per pixel the compositing state and, for rara,
// the ray (SPEC section 2) and its visible intervals: as ends for the mass weight (MassEnds in
// clip.glsl; strip_end_count is the most ends a ray of the strip has, at least 1), as
// (lo0, hi0, lo1, hi1) for the length weight.
uvec2 first_pixel;
vec3 px_color[NPX];
// The transmittance, negated once the pixel is done (as in `state`). An open pixel's T is
// >= 1e-4, so compositing a splat over a done one (T < 0) always "finishes" it again, adds
// nothing and keeps T: the sign is the done flag at no cost per pixel and splat. A separate
// flag took three operations more per pixel and splat and eight more vectors of live state.
float px_T[NPX];
#ifdef DEPTH
float px_limit[NPX];    // the engine's view depth (+inf without a depth test)
float px_median[NPX];   // the median depth so far (+inf until 1 - T reaches 0.5)
float px_zsum[NPX];     // sum of alpha T z over the composited splats
#endif
#if CUTOFF_WEIGHT != 0
// The ray of pixel (c, r) of the strip is eye + t (ray0 + c ray_across + r ray_step), not
// normalised (the weights do not depend on the scale of t): three vectors instead of C x P keep
// the strip's state in registers.
vec3 ray0;
vec3 ray_across;
vec3 ray_step;
#if CUTOFF_WEIGHT == CLIP_WEIGHT_MASS + 1
vec4 px_ends[NPX];
float px_mass_base[NPX];
uint strip_end_count;
#else
vec4 px_spans[NPX];
float band2;
#endif
#ifdef OBJECT_CLIPS
// Several objects, each clipped by a region of its own (SPEC section 9): pc.clip is the array
// of the objects' regions in world space, and each cutoff record's region is in
// pc.cutoff_regions. The visible intervals above are those of region strip_region (none yet:
// ~0u), worked out again when a cutoff splat of another region comes.
vec3 strip_eye;
uint strip_region;
#endif
#endif

#if CUTOFF_WEIGHT != 0
void strip_spans(vec3 eye, ClipParamsRef clip);
#endif
#ifdef OBJECT_CLIPS
// Region `region` of the frame's array of regions.
ClipParamsRef region_clip(uint region) {
    return ClipParamsRef(address_item(Address(pc.clip), region, CLIP_PARAMS_BYTES));
}
#endif

#ifndef SPLAT_TEXELS
// Done pixels of the strip as of the last count (done_count).
uint strip_done;

// How many of the strip's pixels are done.
uint done_count() {
    uint n = 0u;
    [[unroll]] for (uint i = 0u; i < NPX; ++i) {
        n += px_T[i] < 0.0 ? 1u : 0u;
    }
    return n;
}
#endif

// Composites splat s over the strip (SPEC section 4); `cutoff` applies its clip weight, which
// `weight_floor` bounds from below: 0 for a weighted entry, 1 for a plain one composited in a
// weighted pass (composite_run), whose weight is then 1 at no cost beyond the weighted entry's.
// Returns whether any pixel of the strip is still open after it.
bool composite(Staged s, bool cutoff, float weight_floor) {
    vec4 co = s.co;
    vec2 uv = s.uv;
    vec3 rgb = s.rgb;
    float T_max = -1.0;
#if CUTOFF_WEIGHT != 0
    CutoffRecord rec;
    if (cutoff) {
        rec = fetch_cutoff_record(s.cutoff);
#ifdef OBJECT_CLIPS
        // Every lane composites the same splat: a uniform branch.
        uint region = pc.cutoff_regions.v[s.cutoff];
        if (region != strip_region) {
            strip_region = region;
            strip_spans(strip_eye, region_clip(region));
        }
#endif
    }
#endif
#if CUTOFF_WEIGHT == CLIP_WEIGHT_MASS + 1
    // All C x P weights at once: the loop over the ends is outside the loops over the pixels
    // (one loop, not one per pixel or column), and a do-while, which a CPU driver leaves after
    // its last taken iteration. One loop per column would take up to six iterations per entry
    // with two-ended rays, past lavapipe's loop cap for a full round of RASTER_CHUNK entries;
    // a version written that way also put 15 pixels of a real-scene clip test off by up to 81
    // on lavapipe, even with one-ended rays (not understood; this form matches the reference).
    float weight[NPX];
    if (cutoff) {
        WhitenedStrip strips[C];
        [[unroll]] for (uint c = 0u; c < C; ++c) {
            strips[c] = whitened_strip(rec, ray0 + float(c) * ray_across, ray_step);
        }
        if (MASS_ONE_END) {
            [[unroll]] for (uint i = 0u; i < NPX; ++i) {
                weight[i] = px_mass_base[i] + end_mass(strips[i / P], float(i % P), px_ends[i].xy);
            }
        } else {
            [[unroll]] for (uint i = 0u; i < NPX; ++i) {
                weight[i] = px_mass_base[i];
            }
            uint e = 0u;
            do {
                [[unroll]] for (uint i = 0u; i < NPX; ++i) {
                    vec4 ends = px_ends[i];
                    weight[i] += end_mass(strips[i / P], float(i % P),
                                          e == 0u ? ends.xy : ends.zw);
                }
                ++e;
            } while (e < strip_end_count);
        }
    }
#endif
    [[unroll]] for (uint c = 0u; c < C; ++c) {
        // The exponent -0.5 (cx dx^2 + cz dy^2) - cy dx dy down column c (dx fixed,
        // dy = dy0 - r) is a quadratic in r, worked out once per splat and column, in base 2
        // for exp2: power(r) log2(e) = q.x + r (q.y + r q.z).
        vec2 d0 = uv - vec2(first_pixel + uvec2(c, 0u));
        vec3 q = 1.4426950408889634 * vec3(
            -0.5 * (co.x * d0.x * d0.x + co.z * d0.y * d0.y) - co.y * d0.x * d0.y,
            co.z * d0.y + co.y * d0.x,
            -0.5 * co.z);
#if CUTOFF_WEIGHT == CLIP_WEIGHT_LENGTH + 1
        WhitenedStrip strip;
        if (cutoff) {
            strip = whitened_strip(rec, ray0 + float(c) * ray_across, ray_step);
        }
#endif
        [[unroll]] for (uint r = 0u; r < P; ++r) {
            uint i = c * P + r;
            // Branch-free: a CPU driver runs every branch under a mask anyway, and the masks
            // of `continue`s cost more than the selects (lavapipe, plant at 640x480:
            // rasterize 0.86-0.91x unclipped, the same image).
            float T = px_T[i];
            // power <= 0 everywhere for the positive definite conic (SPEC section 3), so
            // SPEC section 4's "skip when power > 0" only ever catches rounding: the form
            // below, evaluated from the strip's first pixel, can come out a hair over 0 next to
            // the centre, where the reference's direct formula gives a hair under. There
            // alpha comes out a few ulps over o instead of the splat being skipped. A
            // min(power2, 0) kept alpha <= o, but gallivm's min (NaN-aware) cost 2-3 % of
            // the frame (lavapipe, unclipped 1280x960, three rounds in turn: plant
            // 83.5-86.7 -> 81.2-81.8 ms, playbot 167.8-184.2 -> 164.8-177.8; the same images).
            float power2 = fma(float(r), fma(float(r), q.z, q.y), q.x);
            float alpha = co.w * exp2(power2);
#ifdef DEPTH
            // Behind the engine's surface: this splat and every later one are hidden.
            T = s.depth >= px_limit[i] ? -abs(T) : T;
#endif
#if CUTOFF_WEIGHT == CLIP_WEIGHT_MASS + 1
            // The mass weights are worked out above whatever the pixel, so the weight scales
            // alpha before the threshold's test, which then needs no second test under a mask:
            // alpha < 1/255 stays under it for w <= 1, as the reference's test first, weight
            // after, gives. `cutoff` is a constant in each of the loops that call this. Under
            // one plane a ray's weight is one normal CDF, already in [0, 1] (MassEnds).
            if (cutoff) {
                alpha *= MASS_ONE_END ? max(weight[i], weight_floor)
                                      : clamp(weight[i], weight_floor, 1.0);
            }
#endif
            bool use = alpha >= 1.0 / 255.0;
#if CUTOFF_WEIGHT == CLIP_WEIGHT_LENGTH + 1
            // Only the weight can take alpha back under the threshold (min(0.99, .) cannot);
            // a GPU skips the weight where w <= 1 cannot lift alpha over it.
            if (cutoff && use) {
                alpha *= max(cutoff_weight_length(strip, float(r), px_spans[i], band2),
                             weight_floor);
                use = alpha >= 1.0 / 255.0;
            }
#endif
            // a = 0 for a splat the pixel skips: then next_T = T, which is >= 1e-4 for an
            // open pixel (T only ever takes a next_T that is), so `finish` holds only for a
            // used splat or a done pixel (T < 0).
            float a = use ? min(0.99, alpha) : 0.0;
            float next_T = fma(-a, T, T);
            bool finish = next_T < 1e-4;
            float w = finish ? 0.0 : a * T;   // alpha T of an added splat, else 0
            px_color[i] = fma(vec3(w), rgb, px_color[i]);
#ifdef DEPTH
            px_zsum[i] += w * s.depth;
            px_median[i] = w > 0.0 && next_T <= 0.5 && isinf(px_median[i]) ? s.depth
                                                                           : px_median[i];
#endif
            px_T[i] = finish ? -abs(T) : next_T;
            T_max = max(T_max, px_T[i]);
        }
    }
    return T_max > 0.0;
}

#if CUTOFF_WEIGHT != 0
// Sets the visible intervals of the strip's rays (px_ends or px_spans; clip.glsl). The loop
// over the planes is outside the loop over the strip: on lavapipe, P loops here (one per pixel)
// made the whole rara kernel 1.9x slower on a frame with no cutoff splat (plant: 547 against
// 290 ms of rasterize for the plain kernel; 307 ms with the one loop).
void strip_spans(vec3 eye, ClipParamsRef clip) {
    uvec4 config = clip.p.config;
    float lo[NPX];
    float hi[NPX];
    [[unroll]] for (uint i = 0u; i < NPX; ++i) {
        lo[i] = -UNBOUNDED;
        hi[i] = UNBOUNDED;
    }
    if ((config.z & CLIP_FLAG_SPHERE) != 0u) {
        vec4 sphere = clip.p.sphere;
        [[unroll]] for (uint c = 0u; c < C; ++c) {
            [[unroll]] for (uint r = 0u; r < P; ++r) {
                vec3 dir = ray0 + float(c) * ray_across + float(r) * ray_step;
                vec2 chord = clip_span_in_sphere(sphere, eye, dir);
                lo[c * P + r] = chord.x;
                hi[c * P + r] = chord.y;
            }
        }
    } else {
        for (uint k = 0u; k < config.w; ++k) {
            vec4 pl = clip.p.planes[k];
            [[unroll]] for (uint c = 0u; c < C; ++c) {
                [[unroll]] for (uint r = 0u; r < P; ++r) {
                    vec3 dir = ray0 + float(c) * ray_across + float(r) * ray_step;
                    clip_span_cut_by_plane(pl, eye, dir, lo[c * P + r], hi[c * P + r]);
                }
            }
        }
    }
#if CUTOFF_WEIGHT == CLIP_WEIGHT_MASS + 1
    strip_end_count = 1u;
#endif
    [[unroll]] for (uint i = 0u; i < NPX; ++i) {
        vec4 spans = clip_visible_spans(config.z, lo[i], hi[i]);
#if CUTOFF_WEIGHT == CLIP_WEIGHT_MASS + 1
        MassEnds m = clip_mass_ends(spans);
        px_ends[i] = m.ends;
        px_mass_base[i] = m.base;
        strip_end_count = max(strip_end_count, m.count);
#else
        px_spans[i] = spans;
#endif
    }
}
#endif

// The first entry of [0, count) to composite, in k with its handle in h (with TILE_BLOCKS, the
// first whose footprint reaches this invocation's block); false when there is none.
bool first_entry(uint base, uint count, out uint k, out uint h) {
#ifdef TILE_BLOCKS
    k = ~0u;
    h = 0u;
    return advance_to_block(base, count, k, h);
#else
    k = 0u;
    if (count == 0u) {
        return false;
    }
    h = entry_handle(base, 0u);
    return true;
#endif
}

// Moves k and h on to the next entry to composite after k (as first_entry); false, with
// k = count, when the list ran out.
bool next_entry(uint base, uint count, inout uint k, inout uint h) {
#ifdef TILE_BLOCKS
    return advance_to_block(base, count, k, h);
#else
    if (++k == count) {
        return false;
    }
    h = entry_handle(base, k);
    return true;
#endif
}

#ifdef SPLAT_TEXELS
// For the loops that composite two entries a pass (CPU drivers; see composite_entries): the
// splat of entry k (handle h) as `first`, then k and h moved on to the next entry, whose splat
// is `second`. Returns whether the second is to be composited: it exists and, unless
// `any_kind`, it is of the run's kind (weighted or not, handle_weighted). Otherwise it stays in
// h for the caller and `second` is idle: opacity 0, so compositing it changes no pixel, and
// the first's cutoff record index, since a plain entry's NO_CUTOFF indexes no record. When
// the list ran out, h stays, so `second` is the first splat again (a depth test then marks
// nothing new).
bool fetch_two(uint base, uint count, bool any_kind, bool weighted, inout uint k, inout uint h,
               out Staged first, out Staged second) {
    first = handle_splat(h);
    bool found = next_entry(base, count, k, h);
    bool have_second = found && (any_kind || handle_weighted(h) == weighted);
    second = handle_splat(h);
    second.co.w = have_second ? second.co.w : 0.0;
    second.cutoff = have_second ? second.cutoff : first.cutoff;
    return have_second;
}
#endif

#if CUTOFF_WEIGHT != 0
// Composites the run of plain (weighted false) or weighted entries that starts with entry k,
// whose handle is h, over the strip, and leaves in k and h the entry after the run. On CPU
// drivers a weighted run also takes the plain entry that follows any of its entries, at
// weight 1, as the second of a pass. Returns whether any pixel of the strip is still open.
bool composite_run(uint base, uint count, bool weighted, inout uint k, inout uint h) {
    bool open;
#ifdef SPLAT_TEXELS
    // Two entries a pass on CPU drivers, as composite_entries' plain loop (fetch_two). A
    // weighted run's idle second still pays the weight, yet the weighted runs gained too
    // (lavapipe, bench --modes hard,rara at 640x480, five rounds on plant and two on biker in
    // turn, the plain runs two a pass in both builds: rara / hard per pair 1.117 - 1.188 ->
    // 1.108 - 1.131 on plant, 1.090 / 1.119 -> 1.062 / 1.068 on biker; the same images).
    do {
        Staged first, second;
        bool have_second = fetch_two(base, count, weighted, weighted, k, h, first, second);
        // A weighted pass takes a plain second entry too, at weight 1 (weight_floor): it would
        // otherwise be idle, the weight paid for nothing, and the plain entry left for a pass
        // of its own. A plain entry's record index is NO_CUTOFF; the first's stands in.
        // lavapipe, plant at 640x480 under the plane 0,0.2588,-0.9659,0.0996, instructions
        // per frame (callgrind): weighted kernel 217.5M -> 213.7M, frame 661.3M -> 656.4M;
        // the same images. Pairing the entries two by two whatever their kinds (a pass
        // weighted when either is, so no plain pass is left idle before a weighted entry
        // either) counted 656.9M: the four carried handles cost what the idle passes did.
        bool plain_second = weighted && have_second && !handle_weighted(h);
        second.cutoff = plain_second ? first.cutoff : second.cutoff;
        composite(first, weighted, 0.0);
        open = composite(second, weighted, plain_second ? 1.0 : 0.0);
        if (!open || !have_second || !next_entry(base, count, k, h)) {
            break;
        }
    } while (handle_weighted(h) == weighted);
#else
    do {
        open = composite(handle_splat(h), weighted, 0.0);
        if (!open || !next_entry(base, count, k, h)) {
            break;
        }
    } while (handle_weighted(h) == weighted);
#endif
    return open;
}
#endif

// Composites splats [0, count) of splat_at(base, .) over the strip, in order, until every
// pixel of the strip is done.
void composite_entries(uint base, uint count) {
#if CUTOFF_WEIGHT == 0 && defined(TILE_BLOCKS)
    uint k, h;
    if (!first_entry(base, count, k, h)) {
        return;
    }
    // Two entries a pass: both found and fetched first (fetch_two), then composited one after
    // the other. A CPU driver keeps the strip's state (colour and T of NPX pixels) in
    // variables that every pass of a loop writes back under the loop's mask; two entries a
    // pass halve that traffic. lavapipe, playbot at 640x480, bench, three rounds in turn, the
    // same image: rasterize 141.4/145.0/154.1 -> 120.2/126.2/123.1 ms. Finding the second
    // entry after the first was composited (state live across the walk's loop) made it 1.5x
    // slower than one a pass, and four entries or the handles alone fetched first were slower
    // than two.
    bool more;
    do {
        Staged first, second;
        bool have_second = fetch_two(base, count, true, false, k, h, first, second);
        composite(first, false, 0.0);
        more = composite(second, false, 0.0) && have_second && next_entry(base, count, k, h);
    } while (more);
#elif CUTOFF_WEIGHT == 0
    for (uint k = 0u; k < count; ++k) {
        if (!composite(splat_at(base, k), false, 0.0)) {
            break;
        }
    }
#else
    // Runs of plain entries and runs of weighted ones each go through a loop of their own, so
    // that the weight code runs once per weighted entry rather than for every entry: CPU
    // drivers execute an if's body under a mask whatever the condition, but leave a loop once
    // no lane continues it (lavapipe, plant at 640x480 with almost no cutoff splats: rasterize
    // 105 -> 96 ms against a do-while over a predicated body; 95 ms with the plain loop alone).
    // Each run's loop is a do-while that composites the entry in hand and looks at the next
    // one at the end of its body. Such a driver tests for live lanes only at the end of a
    // loop's body, so a loop that found the run's end at its top would run one more whole
    // body, under an empty mask, per run: a weighted entry between plain ones cost its own
    // weight, a second one and a plain splat's compositing.
    // The loops carry the next entry's handle, one word, and fetch its splat at the top of the
    // body. Carrying the fetched splat instead (ten words, every one a masked move on a CPU
    // driver) cost 1-2 % more (lavapipe, one thread, biker at 1280x960 under a plane:
    // rasterize 96.5-97.9 against 98.4-101.4 ms).
    uint k, h;
    if (!first_entry(base, count, k, h)) {
        return;
    }
    bool open = true;
    do {
        if (!handle_weighted(h)) {
            open = composite_run(base, count, false, k, h);
        }
        // Here h is a weighted entry, unless the list or the pixels ran out.
        if (open && k < count) {
            open = composite_run(base, count, true, k, h);
        }
    } while (open && k < count);
#endif
}

void main() {
    FrameParams f = load_frame_params(pc.frame);
    uint lid = gl_LocalInvocationIndex;
    // Rows of tiles in spread order keep each CPU-driver thread's share of the grid spread
    // over the image (a whole row at a time, for the splats that neighbouring tiles share in
    // the cache; single tiles spread made playbot's rasterize slower than rows).
    uint id = spread_item(gl_WorkGroupID.y, f.size.w, pc.row_stride) * f.size.z
            + gl_WorkGroupID.x;
    if ((pc.flags & ROUND_TILE_LIST) != 0u) {
        id = pc.tiles.v[gl_WorkGroupID.x];  // tile_lists.comp wrote them in a spread order
    }
    uvec2 tile = uvec2(id % f.size.z, id / f.size.z);
#ifdef TILE_BLOCKS
    uint block = gl_LocalInvocationID.y;
    block_bit = 1u << (PAIR_BLOCKS_SHIFT + block);
    first_pixel = tile * TILE_SIZE + uvec2((block & 1u) * BLOCK_SIZE + gl_LocalInvocationID.x * C,
                                           (block >> 1u) * BLOCK_SIZE);
#else
    first_pixel = tile * TILE_SIZE + uvec2(gl_LocalInvocationID.x * C, gl_LocalInvocationID.y * P);
#endif
#if CUTOFF_WEIGHT == CLIP_WEIGHT_LENGTH + 1
    band2 = pc.clip.p.band.y;
#endif

#if CUTOFF_WEIGHT != 0
    ray0 = pixel_ray(f, vec2(first_pixel));
    ray_across = pixel_ray_across(f);
    ray_step = pixel_ray_down(f);
#endif
    [[unroll]] for (uint i = 0u; i < NPX; ++i) {
        uvec2 pixel = first_pixel + uvec2(i / P, i % P);
        bool inside = pixel.x < f.size.x && pixel.y < f.size.y;
        px_color[i] = vec3(0.0);
        px_T[i] = inside ? 1.0 : -1.0;
        // A kernel that writes the target runs in frames of one round: never a state to load.
        // (A CPU driver runs this load, two scalar loops over the lanes, under a mask even in a
        // first round: the specialization constant takes it out of those kernels.)
        if (!WRITES_TARGET && (pc.flags & ROUND_FIRST) == 0u && inside) {
            vec4 s = load_vec4_item(pc.state, pixel.y * f.size.x + pixel.x);
            px_color[i] = s.rgb;
            px_T[i] = s.a;
        }
#ifdef DEPTH
        uint at = inside ? pixel.y * f.size.x + pixel.x : 0u;
        px_limit[i] = !address_is_null(Address(pc.depth_limit)) && inside ? pc.depth_limit.v[at]
                                                                 : uintBitsToFloat(0x7f800000u);
        px_median[i] = uintBitsToFloat(0x7f800000u);
        px_zsum[i] = 0.0;
        if ((pc.flags & ROUND_FIRST) == 0u && inside) {
            vec4 d = load_vec4_item(pc.depth_state, at);
            px_median[i] = d.x;
            px_zsum[i] = d.y;
        }
#endif
    }
#if CUTOFF_WEIGHT != 0 && defined(OBJECT_CLIPS)
    strip_eye = f.cam_pos.xyz;
    strip_region = ~0u;
#elif CUTOFF_WEIGHT != 0
    strip_spans(f.cam_pos.xyz, pc.clip);
#endif

    uvec2 range = pc.ranges.v[tile.y * f.size.z + tile.x];
    uint start = min(range.x + pc.round_index * RASTER_CHUNK, range.y);
    uint end = min(start + RASTER_CHUNK, range.y);
    if (lid == 0u && pc.round_index == 0u) {
        atomicMax(pc.counters.v[COUNTER_MAX_TILE_LEN], range.y - range.x);
    }
#ifdef SPLAT_TEXELS
    composite_entries(start, end - start);
#else
    strip_done = done_count();
    if (lid == 0u) {
        pixels_done = 0u;
    }
    barrier();
    if (strip_done > 0u) {
        atomicAdd(pixels_done, strip_done);
    }

    for (uint batch = start; batch < end; batch += RASTER_BATCH) {
        barrier();
        if (pixels_done == TILE_PIXELS) {
            break;
        }
        // Staging takes as many rounds as the batch needs, not all RASTER_BATCH / INVOCATIONS:
        // a CPU driver pays every load of an unrolled round, masked or not, and most tiles'
        // last (or only) batch is short (plant at 640x480: rasterize 2-3 % faster unclipped).
        uint count = min(RASTER_BATCH, end - batch);
        uint staging_rounds = (count + INVOCATIONS - 1u) / INVOCATIONS;
        uint j = 0u;
        do {
            uint slot = j * INVOCATIONS + lid;
            uint entry = batch + slot;
            if (entry < end) {
                uint value = pc.values.v[entry];
                ProjectedSplat p = load_splat(pc.splats, value & PAIR_INDEX_MASK);
#if CUTOFF_WEIGHT != 0
                // The sign of the staged opacity marks a weighted pair (handle_weighted).
                bool weighted = (value & PAIR_WEIGHTED) != 0u;
                stage(slot, vec4(p.conic, weighted ? -p.opacity : p.opacity), p.uv, p.color,
                      p.cutoff, p.depth);
#else
                stage(slot, vec4(p.conic, p.opacity), p.uv, p.color, 0u, p.depth);
#endif
            }
            ++j;
        } while (j < staging_rounds);
        barrier();
        composite_entries(batch, count);
        // Counted once per batch rather than as pixels finish: two instructions per pixel and
        // splat fewer.
        uint now_done = done_count();
        if (now_done > strip_done) {
            atomicAdd(pixels_done, now_done - strip_done);
            strip_done = now_done;
        }
    }
#endif

    if (WRITES_TARGET) {
        U32s target = U32s(Address(pc.state));
        vec4 background = vec4(f.background.rgb, 1.0);   // as write target's
        [[unroll]] for (uint i = 0u; i < NPX; ++i) {
            uvec2 pixel = first_pixel + uvec2(i / P, i % P);
            if (pixel.x < f.size.x && pixel.y < f.size.y) {
                target.v[pixel.y * f.size.x + pixel.x] =
                    pack_rgba8_nearest(state_over(vec4(px_color[i], px_T[i]), background));
            }
        }
        return;
    }
    [[unroll]] for (uint i = 0u; i < NPX; ++i) {
        uvec2 pixel = first_pixel + uvec2(i / P, i % P);
        if (pixel.x >= f.size.x || pixel.y >= f.size.y) {
            continue;
        }
        store_vec4_item(pc.state, pixel.y * f.size.x + pixel.x,
                        vec4(px_color[i], px_T[i]));
#ifdef DEPTH
        store_vec4_item(pc.depth_state, pixel.y * f.size.x + pixel.x,
                        vec4(px_median[i], px_zsum[i], 0.0, 0.0));
#endif
    }
}
