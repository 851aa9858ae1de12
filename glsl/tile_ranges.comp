// Stage 6, tile ranges: one invocation per sorted pair marks where each tile's list starts and
// ends (ranges[tile] = [start, end), zero-filled beforehand for empty tiles). Keys of
// tile_count and above (pairs cutoff_tiles.comp found to add nothing) sort after every tile and
// belong to none.
#version 460
#include "common.glsl"
#include "sort_common.glsl"

layout(local_size_x = LINEAR_WORKGROUP) in;

layout(push_constant) uniform Push {
    U32s keys;          // sorted tile ids
    SortInfoRef info;   // num_keys
    UVec2s ranges;
    uint tile_count;
} pc;

void main() {
    uint i = linear_index();
    uint n = pc.info.s.num_keys;
    if (i >= n) {
        return;
    }
    uint tile = pc.keys.v[i];
    if (tile >= pc.tile_count) {
        return;
    }
    if (i == 0u || pc.keys.v[i - 1u] != tile) {
        pc.ranges.v[tile].x = i;
    }
    if (i + 1u == n || pc.keys.v[i + 1u] != tile) {
        pc.ranges.v[tile].y = i + 1u;
    }
}
