// Stage 1b, cutoff records (rara frames on CPU drivers; on GPUs only those of several clipped
// objects, the others' project writes the records itself, PROJECT_LISTS_WRITES): one
// invocation per cutoff record, dispatched indirectly over the frame's count
// (linear_args.comp). Writes the record of the Gaussian that project listed under it
// (gaussian_cutoff_record in clip.glsl), the side record the later stages weight the cutoff
// splat by. Project lists the Gaussians instead of writing the records: a CPU driver runs a
// branch's stores, masked, in every SIMD vector, and a record is six 64-bit stores; here every
// lane has one.
// In frames that classify cutoff pairs by tile it also bounds the splat's weight over its whole
// footprint ellipse (footprint_mass_bounds in clip.glsl), for cutoff_tiles to take with each
// pair's bound over its box: worked out there per pair, the same bound cost that pass 1.5-1.8
// ms on plant at 1280x960 (one thread), here 0.5 ms. Where those bounds decide every pair of
// the splat at once (cutoff_splat_class: weight 1 or nothing wherever it reaches), the splat
// is marked (CUTOFF_WHOLE_*) and its pairs never reach cutoff_tiles: emit writes them plain,
// or keyed past every tile. On plant and biker under a plane that is about two pairs in five
// of those cutoff_tiles classified; each used to pay the per-tile bounds there.
//
// Included by cutoff_records (buffer loads: GPUs, in frames of several clipped objects) and
// cutoff_records_texels (SPLAT_TEXELS: the Gaussians, the splats and the tiles touched read
// through the frame's texel views, which a CPU driver loads as gathers, where a buffer load is
// a scalar loop over the lanes per 64-bit word).
#include "common.glsl"
#include "clip.glsl"
#ifdef SPLAT_TEXELS
#include "frame_texels.glsl"
#endif

layout(local_size_x = LINEAR_WORKGROUP) in;

layout(push_constant) uniform Push {
    FrameParamsRef frame;
    Gaussians gaussians;
    U32s counters;
    U32s cutoff_gaussians;  // per cutoff record, its Gaussian (project)
    CutoffRecords cutoffs;  // out
    ProjectedSplats splats;
    ClipParamsRef clip;
    // Out, in frames whose cutoff pairs are classified by tile (else 0): per record, the
    // TileMassBounds (u_keep, lost) of its splat over the footprint ellipse, lost =
    // CUTOFF_BOUNDS_DECIDED for a splat decided whole.
    Pairs64 cutoff_bounds;
    U32s tiles_touched;     // the pairs of a splat decided whole, for the frame's counts
} pc;

#ifdef SPLAT_TEXELS
Gaussian fetch_gaussian(uint i) {
    return texel_gaussian(i);
}

ProjectedSplat fetch_splat(uint i) {
    return texel_splat(i);
}

uint fetch_tiles_touched(uint i) {
    return texelFetch(tiles_touched, int(i)).x;
}
#else
Gaussian fetch_gaussian(uint i) {
    return load_gaussian(pc.gaussians, i);
}

ProjectedSplat fetch_splat(uint i) {
    return load_splat(pc.splats, i);
}

uint fetch_tiles_touched(uint i) {
    return pc.tiles_touched.v[i];
}
#endif

void main() {
    FrameParams f = load_frame_params(pc.frame);
    // Before any branch (footprint_mass_bounds).
    uvec4 config = pc.clip.p.config;
    uint index = linear_index();
    if (index >= pc.counters.v[COUNTER_CUTOFF]) {
        return;
    }
    uint gaussian = pc.cutoff_gaussians.v[index];
    Gaussian g = fetch_gaussian(gaussian);
    CutoffRecord rec = gaussian_cutoff_record(g, f.cam_pos.xyz);
    store_cutoff_record(pc.cutoffs, index, rec);
    if (!address_is_null(Address(pc.cutoff_bounds))) {
        // The bounds over the splat's footprint ellipse, for cutoff_tiles to take with each
        // pair's bounds over its box: they do not depend on the tile.
        ProjectedSplat p = fetch_splat(gaussian);
        TileMassBounds bounds = footprint_mass_bounds(f, pc.clip, config.w, rec, p);
        uint whole = cutoff_splat_class(config.z, rec, bounds, p.opacity);
        if (whole != TILE_CLASS_PARTIAL) {
            // Every pair decided: the splat says so to emit, and its pairs count as the ones
            // cutoff_tiles classifies would.
            bool full = whole == TILE_CLASS_FULL;
            pc.splats.v[gaussian].cutoff =
                index | (full ? CUTOFF_WHOLE_FULL : CUTOFF_WHOLE_EMPTY);
            bounds.lost = CUTOFF_BOUNDS_DECIDED;
            uint pairs = fetch_tiles_touched(gaussian);
            atomicAdd(pc.counters.v[COUNTER_CUTOFF_WHOLE], 1u);
            atomicAdd(pc.counters.v[COUNTER_CUTOFF_PAIRS], pairs);
            atomicAdd(pc.counters.v[full ? COUNTER_CUTOFF_PAIRS_WEIGHT_ONE
                                         : COUNTER_CUTOFF_PAIRS_EMPTY], pairs);
        }
        pc.cutoff_bounds.v[index] =
            pair64(floatBitsToUint(vec2(bounds.u_keep, bounds.lost)));
    }
}
