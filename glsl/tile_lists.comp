// Stage 4c, tile lists (CPU drivers, rara clipping by planes with the mass weight): one
// invocation per tile puts the tile's id in one of two lists, the tiles that hold a weighted
// pair (cutoff_tiles flagged them) and the rest, and counts it into that list's indirect
// dispatch. The rasterizer then runs its weighted kernel over the first list and its plain
// kernel over the second.
//
// Why: a CPU driver runs every branch under a mask, and a loop's body at least once, so the
// weighted kernel pays one weighted compositing body per tile list whether or not the tile has
// a weighted pair (its loop over a run of weighted entries is entered once, under an empty
// mask, after the last plain run). lavapipe, one thread, biker at 1280x960 with nothing cutoff
// (a plane far away): rasterize 159-164 ms for the weighted kernel against 146-153 ms for the
// plain one, the same image.
//
// cutoff_tiles sets flags[tile] for every tile where it leaves a pair weighted, and
// flags[tile_count] when it left pairs unclassified (its loop budget ran out): every tile then
// goes in the weighted list. The lists come out in an order spread over the image
// (spread_item), which balances the rasterizer's threads on a CPU driver.
#version 460
#include "common.glsl"

layout(local_size_x = LINEAR_WORKGROUP) in;

layout(push_constant) uniform Push {
    U32s flags;         // per tile, then one for the whole grid
    U32s weighted_args; // out: the weighted list's dispatch (x, y, z), x counted here
    U32s plain_args;    // out: the plain list's dispatch
    U32s weighted;      // out: ids of the tiles with a weighted pair, in no particular order
    U32s plain;         // out: ids of the other tiles
    U32s counters;      // out: COUNTER_WEIGHTED_TILES
    uint tile_count;
    uint row_stride;    // the rows of tiles taken in spread_item order
    uint columns;       // tiles per row
    uint pad;
} pc;

void main() {
    // The rows of tiles in spread_item order, so that each contiguous share of a list, which a
    // CPU driver's thread takes on its own in the rasterizer's dispatch, holds tiles from all
    // over the image.
    uint i = linear_index();
    if (i >= pc.tile_count) {
        return;
    }
    uint rows = pc.tile_count / pc.columns;
    uint tile = spread_item(i / pc.columns, rows, pc.row_stride) * pc.columns + i % pc.columns;
    bool weighted = pc.flags.v[tile] != 0u || pc.flags.v[pc.tile_count] != 0u;
    if (weighted) {
        pc.weighted.v[atomicAdd(pc.weighted_args.v[0], 1u)] = tile;
        atomicAdd(pc.counters.v[COUNTER_WEIGHTED_TILES], 1u);
    } else {
        pc.plain.v[atomicAdd(pc.plain_args.v[0], 1u)] = tile;
    }
}
