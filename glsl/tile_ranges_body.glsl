// Stage 6, tile ranges: one invocation per sorted pair marks where each tile's list starts and
// ends (ranges[tile] = [start, end), zero-filled beforehand for empty tiles). Keys of
// tile_count and above (pairs cutoff_tiles found to add nothing) sort after every tile and
// belong to none.
//
// Included by tile_ranges and tile_ranges_texels (FRAME_TEXELS: CPU drivers, the reads
// through the frame's texel views, src/stages/mod.rs).
#include "common.glsl"
#include "sort_common.glsl"

layout(local_size_x = LINEAR_WORKGROUP) in;

layout(push_constant) uniform Push {
    U32s keys;          // sorted tile ids
    SortInfoRef info;   // num_keys
    UVec2s ranges;
    uint tile_count;
} pc;

#ifdef FRAME_TEXELS
#include "frame_texels.glsl"

// Sorted key i (i < num_keys).
uint key(uint i) {
    return texelFetch(sorted_keys, int(i)).x;
}
#else
uint key(uint i) {
    return pc.keys.v[i];
}
#endif

void main() {
    uint i = linear_index();
    uint n = pc.info.s.num_keys;
    if (i >= n) {
        return;
    }
    uint tile = key(i);
    if (tile >= pc.tile_count) {
        return;
    }
    // The neighbours are read unconditionally (clamped): a CPU driver would run both sides
    // of the || anyway, and so loads them once each.
    uint before = key(i == 0u ? 0u : i - 1u);
    uint after = key(min(i + 1u, n - 1u));
    if (i == 0u || before != tile) {
        pc.ranges.v[tile].x = i;
    }
    if (i + 1u == n || after != tile) {
        pc.ranges.v[tile].y = i + 1u;
    }
}
