// Stage 1, project (SPEC sections 3 and 5): one invocation per Gaussian. Classifies it against
// the clip region (dropped / drawn / cutoff), culls, projects the 3D covariance to a 2D conic,
// finds the screen radius and the touched tiles, evaluates the SH colour, and writes the
// ProjectedSplat record, the number of tiles touched (0 = not drawn) that sizes the tile lists,
// and a drawn flag that the depth-order stage scans into each drawn Gaussian's sort slot. A
// drawn cutoff Gaussian also takes the next cutoff record index, stored in its splat, and is
// listed under it; cutoff_records_body.glsl then writes the records (CutoffRecord, for the
// rasterizer's per-pixel weight) in a dispatch over the list. Written here, a record's six
// 64-bit stores ran on a CPU driver, masked, in every SIMD vector of every frame (lavapipe,
// playbot at 640x480 under a plane, one thread, builds in turn: project under hard clipping
// 32.8-33.3 -> 30.6-31.1 ms, under rara 34.0-42.8 -> 31.9-33.8 ms with the records' pass).
//
// Included by project_deg<D> (SH of degree D in 32-bit floats) and project_deg<D>_sh16
// (SH_HALF: half floats, two to a uint).
#include "common.glsl"

// How many of the region's plane slots a Gaussian is classified against: none in frames
// without a clip region, the first for a region of at most one plane (a plane, a sphere), all
// MAX_CLIP_PLANES otherwise (the host's PlaneSlots). A CPU driver runs the classification of
// every slot, masked, for every Gaussian (lavapipe, playbot at 640x480, `bench --frames 6`,
// eight rounds in turn, project medians: unclipped 47.6 -> 40.0 ms, hard clipping by a plane
// 44.0 -> 39.4, rara 45.6 -> 41.1).
layout(constant_id = PROJECT_CLIP_SLOTS_CONSTANT_ID) const uint CLIP_PLANE_SLOTS =
    MAX_CLIP_PLANES;
#define CLIP_DISTANCE_PLANE_SLOTS CLIP_PLANE_SLOTS
#include "sh.glsl"     // (with SCENE_TEXELS, through frame_texels.glsl, includes clip.glsl)
#include "clip.glsl"

layout(local_size_x = LINEAR_WORKGROUP) in;

layout(push_constant) uniform Push {
    FrameParamsRef frame;
    Gaussians gaussians;
    ShCoefficients sh;
    ProjectedSplats splats;
    U32s tiles_touched;
    U32s drawn;         // out: 1 for a Gaussian that touches a tile, else 0 (scanned next)
    U32s counters;
    ClipParamsRef clip;
    U32s cutoff_gaussians;  // out: per cutoff record, its Gaussian (0 on other frames)
    U32s cutoff_regions;    // out, with several clipped objects: `region` per cutoff record
    CutoffRecords cutoffs;  // out, with PROJECT_LISTS_WRITES: the records (else 0)
    uint first;             // the Gaussians [first, end) this dispatch projects
    uint end;
    uint region;            // the index of `clip` among the frame's regions
    uint pad;
} pc;

#ifdef SCENE_TEXELS
// The scene's Gaussians, 3 texels each (the frame's texel views, frame_texels.glsl; CPU
// drivers: a gather instead of a scalar loop over the lanes per 64-bit word).
#include "frame_texels.glsl"

Gaussian fetch_gaussian(uint i) {
    return texel_gaussian(i);
}
#else
Gaussian fetch_gaussian(uint i) {
    return load_gaussian(pc.gaussians, i);
}
#endif

// What this kernel writes for the cutoff Gaussians (PROJECT_LISTS_*): nothing in frames
// without rara clipping, which have none; each one's record index and the Gaussian under it in
// rara frames; also the record's region with several clipped objects. A CPU driver runs every
// store and atomic of the listing, masked, in every SIMD vector whether or not a lane is
// cutoff, so each frame's kernel holds only what it writes (lavapipe, 640x480 unclipped,
// `render --repeat 8`, one thread, four rounds in turn: project playbot 55.9-58.0 -> 35.6-50.4
// ms, plant 8.8-13.1 -> 8.2-11.5 ms without the listing).
// PROJECT_LISTS_WRITES (the buffer-load kernels only, GPUs): the record itself instead of the
// list, in rara frames of one region (the cutoff-tiles kernels then bound the weights over the
// footprints themselves). A GPU stores a divergent branch's 48 bytes for the lanes that take
// it; the records' pass and its dispatch arguments were two more dispatches and barriers a
// frame, which on a GPU cost their latency whatever the work (the H200's depth sort: about
// 0.06 ms a pass at 114k and at 500k keys).
layout(constant_id = PROJECT_LISTS_CUTOFF_CONSTANT_ID) const uint LISTS_CUTOFF =
    PROJECT_LISTS_RECORDS;

#ifndef SCENE_TEXELS
shared uint wg_cutoff_count;
shared uint wg_cutoff_base;
#endif

// Lists cutoff Gaussian i under record `index`: the Gaussian for the records' pass and, with
// several clipped objects, which region the record is weighted by (the rasterizer's
// OBJECT_CLIPS kernels read it); with PROJECT_LISTS_WRITES (GPUs), the record itself, of the
// Gaussian seen from `eye` (fetched again, from the cache). The splat names the record itself.
void list_cutoff(uint i, uint index, vec3 eye) {
    if (LISTS_CUTOFF == PROJECT_LISTS_WRITES) {
        store_cutoff_record(pc.cutoffs, index, gaussian_cutoff_record(fetch_gaussian(i), eye));
        return;
    }
    pc.cutoff_gaussians.v[index] = i;
    if (LISTS_CUTOFF == PROJECT_LISTS_REGIONS) {
        pc.cutoff_regions.v[index] = pc.region;
    }
}

// Projects Gaussian i and writes its splat, tiles touched and drawn flag; returns true when it
// is drawn as cutoff. One exit for every Gaussian, drawn or not: each store in a branch is, on
// a CPU driver, a scalar loop over the lanes that runs, masked, in every SIMD vector whether or
// not a lane takes the branch, and the five early exits that each wrote a Gaussian that draws
// nothing (tiles touched, drawn flag, the splat's radius) ran twenty such loops a vector.
// Lanes past an exit go on computing under the others' mask, on values that nothing stores.
bool project(FrameParams f, ClipParams clip, uint i) {
    Gaussian g = fetch_gaussian(i);
    vec3 mu = g.pos_opacity.xyz;
    uint kind = CLIP_PLANE_SLOTS == PROJECT_CLIP_NONE ? CLASS_DRAWN
                                                     : clip_classify(clip, mu, g.scale.xyz);
    vec3 rel = mu - f.cam_pos.xyz;
    vec3 t = vec3(dot(f.world_to_cam0.xyz, rel), dot(f.world_to_cam1.xyz, rel),
                  dot(f.world_to_cam2.xyz, rel));
    bool in_front = kind != CLASS_DROPPED && t.z > 0.2;
    float fx = f.focal.x, fy = f.focal.y;
    float W = float(f.size.x), H = float(f.size.y);
    float lim_x = 1.3 * (W / (2.0 * fx));
    float lim_y = 1.3 * (H / (2.0 * fy));
    float xc = clamp(t.x / t.z, -lim_x, lim_x) * t.z;
    float yc = clamp(t.y / t.z, -lim_y, lim_y) * t.z;
    // Rows of J R_wc (2x3), in world coordinates.
    vec3 j0 = (fx / t.z) * f.world_to_cam0.xyz - (fx * xc / (t.z * t.z)) * f.world_to_cam2.xyz;
    vec3 j1 = (fy / t.z) * f.world_to_cam1.xyz - (fy * yc / (t.z * t.z)) * f.world_to_cam2.xyz;
    // Sigma = M M^T with M = R S, so v^T Sigma w = (M^T v) . (M^T w) and M^T v = S R^T v.
    vec3 r0, r1, r2;
    quat_rows(g.rot, r0, r1, r2);
    vec3 s = g.scale.xyz;
    vec3 m0 = s * vec3(dot(vec3(r0.x, r1.x, r2.x), j0), dot(vec3(r0.y, r1.y, r2.y), j0),
                       dot(vec3(r0.z, r1.z, r2.z), j0));
    vec3 m1 = s * vec3(dot(vec3(r0.x, r1.x, r2.x), j1), dot(vec3(r0.y, r1.y, r2.y), j1),
                       dot(vec3(r0.z, r1.z, r2.z), j1));
    // The footprint bound (MAX_FOOTPRINT_SIGMA_PX, constants.rs), tested before any square:
    // past it a, c and det would overflow or lose every digit. Written so that NaN fails it.
    vec3 m_abs = max(abs(m0), abs(m1));
    float m_max = max(m_abs.x, max(m_abs.y, m_abs.z));
    bool bounded = m_max <= float(MAX_FOOTPRINT_SIGMA_PX);
    if (in_front && !bounded) {
        atomicAdd(pc.counters.v[COUNTER_OVERSIZED], 1u);
    }
    float aa = dot(m0, m0), cc = dot(m1, m1);
    float a = aa + 0.3;
    float b = dot(m0, m1);
    float c = cc + 0.3;
    // det = a c - b^2 (SPEC section 3) by Lagrange's identity, |m0 x m1|^2 + 0.3 (|m0|^2 +
    // |m1|^2) + 0.09: the same number without the cancellation that leaves a c - b^2 with no
    // correct digit for a long needle (a c ~ 1e16 against det ~ 1e8), and never <= 0.
    vec3 m_cross = cross(m0, m1);
    float det = dot(m_cross, m_cross) + 0.3 * (aa + cc) + 0.09;
    bool projected = in_front && bounded && det > 0.0;
    vec3 conic = vec3(c, -b, a) / det;
    float mid = 0.5 * (a + c);
    float lambda = mid + sqrt(max(0.1, mid * mid - det));
    float radius = ceil(3.0 * sqrt(lambda));
    vec2 uv = vec2(fx * t.x / t.z + f.focal.z, fy * t.y / t.z + f.focal.w);
    // Tiles of the 3-sigma rectangle that the splat's visible footprint reaches (common.glsl);
    // a splat below 1/255 opacity draws nowhere. Only the first TILE_RECT_CHUNK cells are
    // counted here (lavapipe's loop cap): project_touched.comp counts the rest of a larger
    // rectangle in later rounds, so such a splat is drawn even if none of those first cells
    // is reached (and then may end with no tile at all, which draws nothing).
    radius = projected ? radius : SKIPPED_RADIUS;   // an empty rectangle past an exit
    uvec4 rect = splat_tile_rect(uv, radius, f.size.zw);
    uint cells = tile_rect_cells(rect);
    float opacity = g.pos_opacity.w;
    bool visible = projected && opacity >= 1.0 / 255.0;
    uint touched = 0u;
    if (visible) {
        touched = count_touched_cells(uv, conic, footprint_q_max(opacity), rect, 0u,
                                      min(cells, TILE_RECT_CHUNK));
    }
    bool drawn = touched > 0u || (visible && cells > TILE_RECT_CHUNK);
    vec3 color = vec3(0.0);
    if (drawn) {
        vec3 dir = normalize(rel);
        uint sh_stride = f.scene.z;
        color = eval_sh(pc.sh, i * sh_stride, dir);
    }

    // A Gaussian that draws nothing: zeros and SKIPPED_RADIUS, which empties its rectangle.
    ProjectedSplat p;
    p.uv = drawn ? uv : vec2(0.0);
    p.depth = drawn ? t.z : 0.0;
    p.opacity = drawn ? opacity : 0.0;
    p.conic = drawn ? conic : vec3(0.0);
    p.cutoff = NO_CUTOFF;
#ifdef SCENE_TEXELS
    // The texel kernels (CPU drivers) pack record indices by one global atomic per cutoff
    // Gaussian, a loop over the vector's cutoff lanes there, where the GPU kernels' workgroup
    // aggregation (main) costs three barriers, at which a workgroup's 32 SIMD vectors take
    // turns (lavapipe, render --repeat 10, three runs each in turn: project 47.0 -> 42.0 ms on
    // playbot, 10.7 -> 9.4 ms on plant, also under rara). The index goes out with the splat's
    // own stores rather than in a store of its own, masked in every SIMD vector (lavapipe,
    // playbot at 640x480 under a plane, `render --repeat 3`, one thread, eight rounds in turn:
    // project 32.2-32.7 -> 31.5 ms at best, 30.8-31.2 without the region's store, which only
    // frames of several clipped objects now build; hard clipping's 29.2-29.6).
    if (LISTS_CUTOFF != PROJECT_LISTS_NONE && drawn && kind == CLASS_CUTOFF) {
        p.cutoff = atomicAdd(pc.counters.v[COUNTER_CUTOFF], 1u);
        list_cutoff(i, p.cutoff, f.cam_pos.xyz);
    }
#endif
    p.color = color;
    p.radius = drawn ? radius : SKIPPED_RADIUS;
    store_splat(pc.splats, i, p);
    pc.tiles_touched.v[i] = touched;
    pc.drawn.v[i] = drawn ? 1u : 0u;
    return drawn && kind == CLASS_CUTOFF;
}

void main() {
    // Loaded before any branch, so once per SIMD vector on a CPU driver (load_clip_params in
    // clip.glsl). lavapipe, playbot at 640x480: project 119 -> 94 ms for the frame parameters.
    FrameParams f = load_frame_params(pc.frame);
    ClipParams clip = load_clip_params(pc.clip);
    // Several objects with clip regions of their own (SPEC section 9) are projected one
    // dispatch per object, each with its region in pc.clip: per-Gaussian regions would load
    // the parameters per lane, a scalar loop over the lanes per word on a CPU driver.
    uint i = pc.first + linear_index();
#ifdef SCENE_TEXELS
    // project lists a cutoff Gaussian itself.
    if (i < pc.end) {
        project(f, clip, i);
    }
#else
    uint lid = gl_LocalInvocationIndex;
    bool cutoff = i < pc.end && project(f, clip, i);
    if (LISTS_CUTOFF == PROJECT_LISTS_NONE) {
        return;   // uniform: a constant
    }
    if (lid == 0u) {
        wg_cutoff_count = 0u;
    }
    barrier();
    // Record indices are packed: a slot within the workgroup, then one global atomic per
    // workgroup for the base.
    uint slot = cutoff ? atomicAdd(wg_cutoff_count, 1u) : 0u;
    barrier();
    if (lid == 0u) {
        if (wg_cutoff_count > 0u) {
            wg_cutoff_base = atomicAdd(pc.counters.v[COUNTER_CUTOFF], wg_cutoff_count);
        }
    }
    barrier();
    if (cutoff) {
        uint index = wg_cutoff_base + slot;
        pc.splats.v[i].cutoff = index;
        list_cutoff(i, index, f.cam_pos.xyz);
    }
#endif
}
