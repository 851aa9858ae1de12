// Stage 4b, cutoff tiles (rara clipping by planes with the mass weight): classifies the cutoff
// splats' pairs, which emit_rara wrote at cutoff_pairs, by tile (cutoff_tile_class in
// clip.glsl). A pair whose weight is 1 at every pixel of its tile loses the PAIR_WEIGHTED that
// emit gave it, and the rasterizer draws it there as a plain splat; a pair that adds nothing
// to any pixel of its tile gets the key `tile count`, which the sort puts after every tile and the
// tile-ranges stage leaves out. Either way the pair keeps its slot, so the counts of the earlier
// stages stay exact. Only the cutoff splats' workgroups do any work (Dispatch, below).
// The weight's bounds are the tighter of each pair's over the footprint's box in its tile and
// the splat's over its whole footprint ellipse (footprint_mass_bounds in clip.glsl: stored by
// cutoff_records_body.glsl on CPU drivers, worked out here once per splat on GPUs). Where the
// ellipse's bounds decide every pair of a splat (cutoff_splat_class), the records' pass marked
// the splat and emit wrote its pairs as decided (CPU drivers): such a record has no pairs here.
// On GPUs the kernel decides them itself and sets each pair's class without its tile's bounds.
// Dispatch: indirect over the cutoff records on CPU drivers (the records' pass writes the
// arguments); on GPUs, where project writes the records and there is no such pass, directly
// over every Gaussian, the workgroups past the records leaving at once: a GPU starts and ends
// an empty workgroup in a moment, where a pass to write the arguments costs a dispatch and a
// barrier.
//
// Each workgroup takes LINEAR_WORKGROUP cutoff splats and shares their pairs out: every pass of
// an invocation's loop classifies one pair, and an invocation whose splat has no pair left takes
// the workgroup's next splat (next_record). With one splat per invocation, a SIMD vector looped
// as long as its splat with the most tiles: on biker and plant at 1280x960 under a plane, the
// vectors took twice as many steps as there were pairs (195,592 for 96,700; 165,192 for 82,278).
// lavapipe, one thread, builds in turn: cutoff tiles 11.4-13.3 -> 9.7-10.3 ms (biker) and
// 9.8-11.4 -> 7.7-8.1 ms (plant), less than half off since the step that takes a splat runs
// masked in every pass on a CPU driver.
//
// BALANCED_PAIRS (cutoff_tiles_balanced, GPUs): on a GPU the invocation that took the largest
// splat still walked its pairs alone, and the pass lasted that long (an H200, plant under a
// plane: 0.1, 0.4, 0.8 ms at 640x480, 1280x960, 1920x1080, the largest splat's tiles growing
// with the pixels). So the workgroup scans its splats' pair counts and its invocations take
// the pairs in turn, each finding its pair's splat by a search over the scan.
//
// Loop cap: lavapipe ends an invocation after 65,535 loop iterations. On a CPU driver one SIMD
// vector takes the workgroup's splats until none is left, so each invocation stops after
// CUTOFF_TILES_LOOP_BUDGET / (1 + planes) passes (its loop and the loop over the planes). The
// pairs left then stay unclassified, which draws them exactly at the partial pairs' cost: in
// the texel kernel, whose workgroup is that one vector, those of the splats not yet begun too
// (a workgroup's LINEAR_WORKGROUP splats would need more than 8 x 32,768 / 2 pairs under one
// plane, 512 tiles a splat); in the others, a workgroup's other invocations take those.
//
// SPLAT_TEXELS (cutoff_tiles_texels, CPU drivers): the splats, the cutoff records, the
// tiles touched, the emitted keys and the clip planes are read through the frame's texel views,
// which a CPU driver loads as gathers, where a buffer load is a scalar loop over the lanes per
// 64-bit word.
//
// PACKED_PAIRS (cutoff_tiles_packed_texels): emit wrote each pair as one 64-bit word in `keys`
// (emit_body.glsl), the key in word 2 slot and the value in word 2 slot + 1.
#include "common.glsl"
#include "clip.glsl"

#ifdef SPLAT_TEXELS
#include "frame_texels.glsl"
#endif

// Each workgroup takes the LINEAR_WORKGROUP cutoff records from LINEAR_WORKGROUP times its
// index (the dispatch arguments over the records are shared with cutoff_records). The texel
// kernel (CPU drivers) does it with one SIMD vector of invocations: a CPU driver runs a
// workgroup's vectors one after the other between barriers, so its first vector took every
// record through next_record, and the 31 others of a workgroup of LINEAR_WORKGROUP each ran a
// masked pass of the loop for nothing (lavapipe, under the plane 0,0.2588,-0.9659,0.0996,
// `render --repeat 3`, eight rounds in turn, best / median: cutoff tiles plant 640x480 3.65 /
// 4.52 -> 3.42 / 3.94 ms on one thread and 2.14 / 2.42 -> 1.77 / 2.17 on two, biker 1280x960
// 4.09 / 4.81 -> 3.55 / 4.11 on one; the same classes and images).
#ifdef SPLAT_TEXELS
#define CUTOFF_TILES_INVOCATIONS 8
#else
#define CUTOFF_TILES_INVOCATIONS LINEAR_WORKGROUP
#endif
layout(local_size_x = CUTOFF_TILES_INVOCATIONS) in;

layout(push_constant) uniform Push {
    FrameParamsRef frame;
    ProjectedSplats splats;
    U32s tiles_touched;
    U32s counters;
    Pairs64 cutoff_pairs;      // per cutoff record: (first pair, splat index), packed
    ClipParamsRef clip;
    CutoffRecords cutoffs;
    U32s keys;              // in and out: tile ids, in emit's order (PACKED_PAIRS: the pairs)
    U32s values;            // in and out: splat indices (PACKED_PAIRS: unused)
    // Out, with the tile lists (CPU drivers; else 0): per tile, set where a pair stays
    // weighted, and at [tile count] when pairs were left unclassified (tile_lists.comp).
    U32s tile_flags;
    // Per cutoff record, the splat's TileMassBounds over its footprint ellipse (u_keep, lost;
    // cutoff_records_body.glsl), or 0: none.
    Pairs64 cutoff_bounds;
} pc;

// The region's planes come through region_plane (clip.glsl): the texel kernel fetches them,
// a gather on a CPU driver. A load through pc.clip in the loop over the pairs is a scalar loop
// over the lanes per word there; copied into a local ClipParams before the loop (as project
// does, where every plane is visited), the dynamic index made lavapipe's pass 1.8x slower
// (plant at 640x480 under rara: 5.8 -> 10.6 ms). The texel fetch took a third off (plant at
// 1280x960, one thread: 14.2-14.7 -> 9.4-9.9 ms; 8.0 ms with the one plane loaded before any
// branch, as a lower bound).

// Below this |n.d| / |d| at a corner ray, a flat splat's plane is too close to edge-on across
// the tile for flat_tile_class (well above FLAT_PARALLEL_EPSILON: see there).
#define FLAT_TILE_MIN_COS 1e-3

// TILE_CLASS_* of a flat splat's pair (SPEC section 6: its weight at a pixel is whether the
// pixel ray's crossing with its plane is visible), from the tile's corner rays dirs[k] and the
// region's planes. While every corner ray meets the plane from the same side, n.d / |d| >= c
// over their whole convex hull (n.d is linear, |d| at most the corners' combination), so no
// pixel of the tile takes the parallel rule, and the crossings fill the convex quadrilateral
// spanned by the corners' crossings (a projective image of the tile's). A half-space then holds
// all of it when it holds the four corners, and none of it when it holds none of them; the
// intersection K holds all of it when every half-space does, and none when one holds none.
// slack covers the rasterizer's own rounding of the crossing and of the planes' spans.
uint flat_tile_class(CutoffRecord rec, vec3 eye, vec3 dirs[4], uint planes, uint flags) {
    vec3 n = rec.m0.xyz;
    float ne = rec.m0.w;    // n.(eye - mu)
    vec3 p[4];
    float cos_lo = UNBOUNDED;
    float cos_hi = -UNBOUNDED;
    float reach = 0.0;
    for (uint k = 0u; k < 4u; ++k) {
        float nd = dot(n, dirs[k]);
        float c = nd / length(dirs[k]);
        cos_lo = min(cos_lo, c);
        cos_hi = max(cos_hi, c);
        p[k] = eye - (ne / nd) * dirs[k];
        reach = max(reach, length(p[k] - eye));
    }
    if (!(cos_lo > FLAT_TILE_MIN_COS || cos_hi < -FLAT_TILE_MIN_COS)) {
        return TILE_CLASS_PARTIAL;
    }
    bool inside_all = true;
    bool outside_some = false;
    for (uint plane = 0u; plane < planes; ++plane) {
        vec4 pl = region_plane(pc.clip, plane);
        float slack = 1e-4 * (abs(dot(pl.xyz, eye) + pl.w) + reach);
        bool all_in = true;
        bool all_out = true;
        for (uint k = 0u; k < 4u; ++k) {
            float side = dot(pl.xyz, p[k]) + pl.w;
            all_in = all_in && side > slack;
            all_out = all_out && side < -slack;
        }
        inside_all = inside_all && all_in;
        outside_some = outside_some || all_out;
    }
    bool invert = (flags & CLIP_FLAG_INVERT) != 0u;
    if (invert ? inside_all : outside_some) {
        return TILE_CLASS_EMPTY;
    }
    return (invert ? outside_some : inside_all) ? TILE_CLASS_FULL : TILE_CLASS_PARTIAL;
}

// The words of the key and the value of the pair at `slot`.
#ifdef PACKED_PAIRS
#define PAIR_KEY(slot) pc.keys.v[2u * (slot)]
#define PAIR_VALUE(slot) pc.keys.v[2u * (slot) + 1u]
#define EMITTED_KEY_TEXEL(slot) int(2u * (slot))
#else
#define PAIR_KEY(slot) pc.keys.v[slot]
#define PAIR_VALUE(slot) pc.values.v[slot]
#define EMITTED_KEY_TEXEL(slot) int(slot)
#endif

// Pair counts of what one pair's classification did, summed per invocation.
struct PairTally {
    uint weight_one;
    uint empty;
};

// Classifies the pair at `slot` of cutoff splat `p` (record `rec`): rewrites its key (empty) or
// its value (weight 1) and flags its tile where it stays weighted. `whole`, the splat's class
// over its whole footprint (cutoff_splat_class), is the pair's unless TILE_CLASS_PARTIAL.
void classify_pair(FrameParams f, uvec4 config, ProjectedSplat p, CutoffRecord rec,
                   TileMassBounds ellipse, uint whole, uint slot, uint tile_count,
                   bool tile_lists, inout PairTally tally) {
    if (whole == TILE_CLASS_EMPTY) {
        PAIR_KEY(slot) = tile_count;
        ++tally.empty;
        return;
    }
    if (whole == TILE_CLASS_FULL) {
        PAIR_VALUE(slot) &= ~PAIR_WEIGHTED;
        ++tally.weight_one;
        return;
    }
#ifdef SPLAT_TEXELS
    uint tile = texelFetch(emitted_keys, EMITTED_KEY_TEXEL(slot)).x;
#else
    uint tile = PAIR_KEY(slot);
#endif
    uvec2 xy = uvec2(tile % f.size.z, tile / f.size.z);
    // The rays through the corners of the tile's pixels that the splat can reach (alpha
    // >= 1/255 needs q <= footprint_q_max), in order around them: the weight elsewhere in
    // the tile changes no pixel, and a footprint that covers part of the tile often sees
    // only weight 1 or 0 where the tile as a whole sees both.
    vec4 box = footprint_pixel_box_in_tile(p.uv, p.conic, footprint_q_max(p.opacity),
                                           xy.x, xy.y);
    vec3 dirs[4] = vec3[4](pixel_ray(f, box.xy), pixel_ray(f, box.zy),
                           pixel_ray(f, box.zw), pixel_ray(f, box.xw));
    float q_min = footprint_q_min_in_tile(p.uv, p.conic, xy.x, xy.y);
    float peak_alpha = p.opacity * exp(-0.5 * q_min);
    // A flat splat's weight is a step along its plane (SPEC section 6): the mass
    // bounds, worked out in the whitened frame it does not have, give way to
    // flat_tile_class.
    bool flat_splat = FLAT_SPLATS && cutoff_record_is_flat(rec);
    TileMassBounds bounds = tile_mass_bounds_none();
    uint bounded_planes = flat_splat ? 0u : config.w;
    for (uint plane = 0u; plane < bounded_planes; ++plane) {
        tile_mass_bounds_add(bounds, tile_plane_u_range(rec, region_plane(pc.clip, plane),
                                                        f.cam_pos.xyz, dirs));
    }
    // The same bounds over the footprint ellipse, which the records' pass worked out for the
    // splat (cutoff_records_body.glsl): each is an upper bound, so the smaller holds.
    bounds.u_keep = min(bounds.u_keep, ellipse.u_keep);
    bounds.lost = min(bounds.lost, ellipse.lost);
    uint tile_class;
    if (flat_splat) {
        tile_class = peak_alpha < 0.99 / 255.0
                   ? TILE_CLASS_EMPTY
                   : flat_tile_class(rec, f.cam_pos.xyz, dirs, config.w, config.z);
    } else {
        tile_class = cutoff_tile_class(config.z, bounds, peak_alpha);
    }
    // No pixel centre of the tile in the footprint's bounding box: nothing to draw.
    tile_class = box.x > box.z || box.y > box.w ? TILE_CLASS_EMPTY : tile_class;
    if (tile_class == TILE_CLASS_EMPTY) {
        PAIR_KEY(slot) = tile_count;
        ++tally.empty;
    } else if (tile_class == TILE_CLASS_FULL) {
        PAIR_VALUE(slot) &= ~PAIR_WEIGHTED;   // keeps the block bits
        ++tally.weight_one;
    } else if (tile_lists) {
        pc.tile_flags.v[tile] = 1u;
    }
}

// The range of cutoff record k's pairs, [slot, end), and its splat's index; no pairs for a
// splat the records' pass decided whole (CUTOFF_BOUNDS_DECIDED), for which emit wrote no range
// (the entry still holds project's list there).
void cutoff_pairs(FrameParams f, uint k, out uint slot, out uint end, out uint splat) {
    if (!address_is_null(Address(pc.cutoff_bounds))
            && uintBitsToFloat(pair64_words(pc.cutoff_bounds.v[k]).y)
                   == CUTOFF_BOUNDS_DECIDED) {
        slot = 0u;
        end = 0u;
        splat = 0u;
        return;
    }
    uvec2 first = pair64_words(pc.cutoff_pairs.v[k]);
    splat = first.y;
#ifdef SPLAT_TEXELS
    uint touched = texelFetch(tiles_touched, int(splat)).x;
#else
    uint touched = pc.tiles_touched.v[splat];
#endif
    slot = first.x;
    end = max(first.x, min(first.x + touched, f.scene.w));
}

// Cutoff record k and its splat (index `splat`).
void cutoff_splat(uint k, uint splat, out ProjectedSplat p, out CutoffRecord rec) {
#ifdef SPLAT_TEXELS
    p = texel_splat(splat);
    rec = texel_cutoff_record(k);
#else
    p = load_splat(pc.splats, splat);
    rec = load_cutoff_record(pc.cutoffs, k);
#endif
}

// The bounds of cutoff record k's splat p over its footprint ellipse (footprint_mass_bounds in
// clip.glsl): on CPU drivers the records' pass stored them (pc.cutoff_bounds); on GPUs, whose
// project writes the records and whose frames have no records' pass, the kernel works them
// out, once per splat.
TileMassBounds cutoff_ellipse_bounds(FrameParams f, uint planes, uint k, ProjectedSplat p,
                                     CutoffRecord rec) {
#ifdef SPLAT_TEXELS
    if (!address_is_null(Address(pc.cutoff_bounds))) {
        vec2 b = uintBitsToFloat(pair64_words(pc.cutoff_bounds.v[k]));
        return TileMassBounds(b.x, b.y);
    }
    return tile_mass_bounds_none();
#else
    return footprint_mass_bounds(f, pc.clip, planes, rec, p);
#endif
}

#ifdef BALANCED_PAIRS
#define WG_SCAN_SIZE LINEAR_WORKGROUP
#include "workgroup_scan.glsl"

// Steps of the search for a pair's record: log2(LINEAR_WORKGROUP).
#define CUTOFF_TILES_SEARCH_STEPS 8u
#if LINEAR_WORKGROUP != 256
#error "CUTOFF_TILES_SEARCH_STEPS is log2(LINEAR_WORKGROUP)"
#endif

// Per cutoff record of the workgroup, by scan rank: its first pair, its splat, the sum of
// the pair counts of the records before it (the workgroup's total past the records it has),
// and its splat's bounds over the footprint ellipse (u_keep, lost).
shared uint record_first_pair[LINEAR_WORKGROUP];
shared uint record_splat[LINEAR_WORKGROUP];
shared uint record_pairs_before[LINEAR_WORKGROUP];
shared float record_u_keep[LINEAR_WORKGROUP];
shared float record_lost[LINEAR_WORKGROUP];
shared uint record_class[LINEAR_WORKGROUP];   // cutoff_splat_class

void main() {
    uint group_first = linear_index() - gl_LocalInvocationIndex;
    uint cutoff_count = pc.counters.v[COUNTER_CUTOFF];
    // The dispatch covers every Gaussian (the frame has no records' pass to write indirect
    // arguments over the cutoff records): the workgroups past them leave at once, all their
    // invocations alike, before they load anything else.
    if (group_first >= cutoff_count) {
        return;
    }
    FrameParams f = load_frame_params(pc.frame);
    uvec4 config = pc.clip.p.config;
    uint group_end = min(group_first + LINEAR_WORKGROUP, cutoff_count);
    uint records = group_end - group_first;
    uint tile_count = f.size.z * f.size.w;
    bool tile_lists = !address_is_null(Address(pc.tile_flags));
    // Each invocation counts the pairs of one record, in scan order.
    uint rank = workgroup_scan_rank();
    uint slot = 0u;
    uint end = 0u;
    uint splat = 0u;
    if (rank < records) {
        cutoff_pairs(f, group_first + rank, slot, end, splat);
    }
    uint total;
    uint before = workgroup_exclusive_scan(end - slot, total);
    record_first_pair[rank] = slot;
    record_splat[rank] = splat;
    record_pairs_before[rank] = rank < records ? before : total;
    // And works out its splat's bounds over the footprint ellipse, which every pair of the
    // splat takes.
    if (rank < records) {
        ProjectedSplat p;
        CutoffRecord rec;
        cutoff_splat(group_first + rank, splat, p, rec);
        TileMassBounds b = cutoff_ellipse_bounds(f, config.w, group_first + rank, p, rec);
        record_u_keep[rank] = b.u_keep;
        record_lost[rank] = b.lost;
        uint whole = cutoff_splat_class(config.z, rec, b, p.opacity);
        record_class[rank] = whole;
        if (whole != TILE_CLASS_PARTIAL) {
            atomicAdd(pc.counters.v[COUNTER_CUTOFF_WHOLE], 1u);
        }
    }
    barrier();
    // Pair j of the workgroup's records belongs to the last record whose pairs start at or
    // before it: a binary search over the ranks, and the invocations take the pairs in turn.
    // So a splat over many tiles shares them out instead of one invocation walking them all
    // (the pass took as long as the cutoff splat with the most tiles).
    PairTally tally = PairTally(0u, 0u);
    // Loop cap: a pass is this loop's iteration, the search's (if a driver keeps its loop)
    // and the planes'.
    uint passes_left = CUTOFF_TILES_LOOP_BUDGET / (1u + CUTOFF_TILES_SEARCH_STEPS + config.w);
    uint j = gl_LocalInvocationIndex;
    for (; j < total && passes_left > 0u; j += LINEAR_WORKGROUP, --passes_left) {
        // The last rank whose pairs start at or before j (record_pairs_before grows with the
        // rank, and is 0 at rank 0): steps of LINEAR_WORKGROUP / 2, / 4, ... 1.
        uint lo = 0u;
        [[unroll]] for (uint step = LINEAR_WORKGROUP / 2u; step > 0u; step >>= 1u) {
            if (record_pairs_before[lo + step] <= j) {
                lo += step;
            }
        }
        ProjectedSplat p;
        CutoffRecord rec;
        cutoff_splat(group_first + lo, record_splat[lo], p, rec);
        TileMassBounds ellipse = TileMassBounds(record_u_keep[lo], record_lost[lo]);
        classify_pair(f, config, p, rec, ellipse, record_class[lo],
                      record_first_pair[lo] + (j - record_pairs_before[lo]), tile_count,
                      tile_lists, tally);
    }
    // Out of passes (lavapipe's loop cap): the pairs left stay unclassified, weighted.
    if (tile_lists && j < total) {
        pc.tile_flags.v[tile_count] = 1u;
    }
    if (end > slot) {
        atomicAdd(pc.counters.v[COUNTER_CUTOFF_PAIRS], end - slot);
    }
    if (tally.weight_one + tally.empty > 0u) {
        atomicAdd(pc.counters.v[COUNTER_CUTOFF_PAIRS_WEIGHT_ONE], tally.weight_one);
        atomicAdd(pc.counters.v[COUNTER_CUTOFF_PAIRS_EMPTY], tally.empty);
    }
}
#else
// The next cutoff record of the workgroup's LINEAR_WORKGROUP to take.
shared uint next_record;

void main() {
    // Before any branch: once per SIMD vector on a CPU driver (load_clip_params in clip.glsl).
    FrameParams f = load_frame_params(pc.frame);
    uvec4 config = pc.clip.p.config;
    uint group_first = linear_index() - gl_LocalInvocationIndex;
    uint cutoff_count = pc.counters.v[COUNTER_CUTOFF];
    // On GPUs the dispatch covers every Gaussian (as in the balanced kernel's main): the
    // workgroups past the cutoff records leave at once.
    if (group_first >= cutoff_count) {
        return;
    }
    uint group_end = min(group_first + LINEAR_WORKGROUP, cutoff_count);
    if (gl_LocalInvocationIndex == 0u) {
        next_record = group_first;
    }
    barrier();
    uint tile_count = f.size.z * f.size.w;
    uint slot = 0u;
    uint end = 0u;
    ProjectedSplat p;
    CutoffRecord rec;
    TileMassBounds ellipse;
    uint whole = TILE_CLASS_PARTIAL;
    uint pairs = 0u;
    PairTally tally = PairTally(0u, 0u);
    bool live = true;
    uint passes_left = CUTOFF_TILES_LOOP_BUDGET / (1u + config.w);
    bool tile_lists = !address_is_null(Address(pc.tile_flags));
    do {
        if (slot == end) {
            uint k = atomicAdd(next_record, 1u);
            live = k < group_end;
            if (live) {
                uint splat;
                cutoff_pairs(f, k, slot, end, splat);
                cutoff_splat(k, splat, p, rec);
                ellipse = cutoff_ellipse_bounds(f, config.w, k, p, rec);
#ifndef SPLAT_TEXELS
                // The records' pass decides splats whole where there is one (CPU drivers),
                // and then leaves this kernel none: worked out again per record, the step
                // that takes one, masked in every pass there, would pay for it.
                whole = cutoff_splat_class(config.z, rec, ellipse, p.opacity);
                if (whole != TILE_CLASS_PARTIAL) {
                    atomicAdd(pc.counters.v[COUNTER_CUTOFF_WHOLE], 1u);
                }
#endif
                pairs += end - slot;
            }
        }
        if (live && slot < end) {
            classify_pair(f, config, p, rec, ellipse, whole, slot, tile_count, tile_lists,
                          tally);
            ++slot;
        }
        --passes_left;
    } while (live && passes_left > 0u);
    // Out of passes with a splat in hand: pairs may stay unclassified, weighted, in any tile.
    if (tile_lists && live && passes_left == 0u) {
        pc.tile_flags.v[tile_count] = 1u;
    }
    if (pairs > 0u) {
        atomicAdd(pc.counters.v[COUNTER_CUTOFF_PAIRS], pairs);
        atomicAdd(pc.counters.v[COUNTER_CUTOFF_PAIRS_WEIGHT_ONE], tally.weight_one);
        atomicAdd(pc.counters.v[COUNTER_CUTOFF_PAIRS_EMPTY], tally.empty);
    }
}
#endif
