// Stage 4, emit: one invocation per drawn Gaussian, in depth order, writes a (tile id, splat
// index) pair for every tile it touches, at the offset the prefix sum gave it; a cutoff
// splat's pairs carry PAIR_WEIGHTED. The pairs come out in (depth, index) order, so the stable
// sort by tile id leaves every tile's list in that order. Pairs past the capacity are not
// written: the host sees the total, grows the buffers and renders the frame again.
//
// RECORD_CUTOFF_PAIRS (emit_rara, rara clipping by planes with the mass weight): each
// cutoff splat also records where its pairs start, for the cutoff-tiles stage (cutoff_tiles),
// which classifies those pairs by tile (its dispatch arguments are written after project).
// That work runs only for cutoff splats: done here, every invocation of a SIMD vector would
// pay it, masked, for every tile of its own (plant at 640x480: emit 13 -> 63 ms).
//
// A round (round_index) walks at most TILE_RECT_CHUNK cells of each splat's tile rectangle,
// for lavapipe's cap on an invocation's loop iterations; on an image of more than
// TILE_RECT_CHUNK tiles the host dispatches more rounds, and a splat whose rectangle goes on
// past the round leaves its next pair's slot in `progress` for the next.
// (The cutoff-tiles pass has a cap of its own: see cutoff_tiles_body.glsl.)
//
// PACKED_PAIRS (CPU drivers, whose sort takes packed pairs, RadixSort::sorts_packed): each
// pair goes out as one 64-bit word in `keys`, the tile id in its low half and the value in
// its high half, where the sort's later passes hand them on (PairForm::Packed). On a CPU driver
// every store to a buffer is a loop over the SIMD lanes: one store a pair instead of two.
#include "common.glsl"

layout(local_size_x = LINEAR_WORKGROUP) in;

#ifdef SPLAT_TEXELS
// The frame's texel views (src/stages/mod.rs, frame_texels_set_layout): on a CPU driver a
// texel fetch is a gather, where a buffer load is a scalar loop over the lanes per 64-bit
// word (lavapipe, render --repeat 10, runs in turn: emit 48 -> 31 ms on playbot at 640x480,
// 17.5 -> 11.9 ms on plant under rara; the same images).
#include "frame_texels.glsl"
#endif

layout(push_constant) uniform Push {
    FrameParamsRef frame;
    ProjectedSplats splats;
    U32s drawn;         // drawn.v[0] = drawn Gaussians
    U32s order;         // Gaussian indices in depth order
    U32s offsets;       // exclusive prefix sum of tiles touched, in depth order
    U32s keys;          // out: tile ids (PACKED_PAIRS: the pairs, a 64-bit word each)
    U32s values;        // out: splat indices (PACKED_PAIRS: unused)
    // RECORD_CUTOFF_PAIRS only, out: per cutoff record (first pair, splat index), packed.
    Pairs64 cutoff_pairs;
    U32s progress;      // in (rounds after the first) and out: per drawn splat, its next slot
    uint round_index;
} pc;

void main() {
    // Before any branch: once per SIMD vector on a CPU driver (load_clip_params in clip.glsl).
    FrameParams f = load_frame_params(pc.frame);
    uint j = linear_index();
    if (j >= pc.drawn.v[0]) {
        return;
    }
#ifdef SPLAT_TEXELS
    uint i = texelFetch(depth_order, int(j)).x;
    ProjectedSplat p = texel_splat(i);
    uint slot = texelFetch(slot_texels, int(j)).x;   // the first pair
#else
    uint i = pc.order.v[j];
    ProjectedSplat p = load_splat(pc.splats, i);
    uint slot = pc.offsets.v[j];
#endif
    uvec4 rect = splat_tile_rect(p.uv, p.radius, f.size.zw);
    float q_max = footprint_q_max(p.opacity);
    uint capacity = f.scene.w;
#ifdef RECORD_CUTOFF_PAIRS
    // A cutoff splat that the records' pass decided whole (CUTOFF_WHOLE_* in common.glsl) has
    // no pairs for cutoff_tiles: weight 1 throughout, they go out plain; weight 0, keyed past
    // every tile, which the sort puts last and the tile-ranges stage leaves out.
    uint whole = p.cutoff == NO_CUTOFF ? CUTOFF_WHOLE_FULL : p.cutoff & CUTOFF_WHOLE_BITS;
    if (whole == 0u && pc.round_index == 0u) {
        pc.cutoff_pairs.v[p.cutoff] = pair64(uvec2(slot, i)); // one 64-bit store
    }
    bool weighted = whole == 0u;
    uint key_past_tiles = whole == CUTOFF_WHOLE_EMPTY ? f.size.z * f.size.w : 0u;
#else
    bool weighted = p.cutoff != NO_CUTOFF;
    uint key_past_tiles = 0u;
#endif
    // One walk over the rect's candidate cells, row by row, as count_touched_cells
    // (common.glsl) in project. lavapipe, render --repeat 10, runs in turn, the same images:
    // emit 29.7 -> 27.3 ms on playbot, 16.3 -> 13.3 ms on biker (640x480, unclipped) for one
    // loop against a loop per row.
    uint cells = tile_rect_cells(rect);
    uint first_cell = pc.round_index * TILE_RECT_CHUNK;
    if (first_cell >= cells) {
        return;
    }
    uint end_cell = min(cells, first_cell + TILE_RECT_CHUNK);
    if (pc.round_index > 0u) {
        slot = pc.progress.v[j];
    }
    // A cutoff splat's pairs take the clip weight in the rasterizer (until cutoff_tiles
    // finds a tile where it is 1 throughout).
    uint value = weighted ? i | PAIR_WEIGHTED : i;
    FootprintRows rows = footprint_rows(p.uv, p.conic, q_max);
    FootprintWalk w = footprint_walk_start(rows, rect, first_cell);
    while (footprint_walk_cell(rect, w) < end_cell) {
        if (footprint_walk_on_candidate(w)
                && footprint_touches_tile(p.uv, p.conic, q_max, w.xy.x, w.xy.y)) {
            if (slot < capacity) {
                uint key = key_past_tiles != 0u ? key_past_tiles : w.xy.y * f.size.z + w.xy.x;
                uint pair_value = value | footprint_blocks(p.uv, p.conic, q_max, w.xy.x, w.xy.y);
#ifdef PACKED_PAIRS
                Pairs64(Address(pc.keys)).v[slot] = pair64(uvec2(key, pair_value));
#else
                pc.keys.v[slot] = key;
                pc.values.v[slot] = pair_value;
#endif
            }
            ++slot;
        }
        footprint_walk_next(w, rows, rect);
    }
    if (end_cell < cells) {
        pc.progress.v[j] = slot;
    }
}
