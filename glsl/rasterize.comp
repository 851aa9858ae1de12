// Stage 6, rasterize (SPEC section 4): one workgroup per 16x16 tile, one invocation per pixel.
// The tile's splats, sorted front to back, are staged through shared memory in batches of
// RASTER_WORKGROUP; each pixel composites them until its transmittance runs out, and the
// workgroup stops once every pixel is done.
//
// One dispatch walks at most RASTER_CHUNK entries of each tile list (lavapipe ends an
// invocation after 65,535 loop iterations). Longer lists take several rounds; between rounds
// the per-pixel state (colour, transmittance, done) lives in `state`.
//
// RaRa clipping: with mode rara each pixel first intersects its ray with the clip region (at
// most two intervals of t); a cutoff splat's opacity is then scaled by its weight along that
// ray (clip.glsl), staged with the batch. Splats that are not cutoff take the plain path.
#version 460
#include "common.glsl"
#include "clip.glsl"

layout(local_size_x = TILE_SIZE, local_size_y = TILE_SIZE) in;

#define ROUND_FIRST 1u
#define ROUND_LAST 2u

layout(push_constant) uniform Push {
    FrameParamsRef frame;
    ProjectedSplats splats;
    U32s values;        // splat index of each sorted pair
    UVec2s ranges;      // [start, end) per tile
    Vec4s state;        // per pixel (rgb, T), T negated once the pixel is done
    U32s image;         // rgba8 per pixel
    U32s counters;
    ClipParamsRef clip;
    CutoffRecords cutoffs;
    uint round_index;
    uint flags;
} pc;

shared vec2 batch_uv[RASTER_WORKGROUP];
shared vec4 batch_conic_opacity[RASTER_WORKGROUP];
shared vec4 batch_color_cutoff[RASTER_WORKGROUP];   // rgb, w = 1 for a cutoff splat
shared CutoffRecord batch_cutoff[RASTER_WORKGROUP];
shared uint pixels_done;

uint pack_rgba8(vec3 c) {
    uvec3 b = uvec3(floor(clamp(c, 0.0, 1.0) * 255.0 + 0.5));
    return b.r | (b.g << 8) | (b.b << 16) | (255u << 24);
}

void main() {
    FrameParams f = pc.frame.p;
    uint lid = gl_LocalInvocationIndex;
    uvec2 tile = gl_WorkGroupID.xy;
    uvec2 pixel = tile * TILE_SIZE + gl_LocalInvocationID.xy;
    bool inside = pixel.x < f.size.x && pixel.y < f.size.y;
    uint pixel_index = pixel.y * f.size.x + pixel.x;
    vec2 pixf = vec2(pixel);

    // The pixel's ray (SPEC section 2) and its visible intervals, for cutoff weights.
    uvec4 clip_config = pc.clip.p.config;
    bool rara = clip_config.x == CLIP_MODE_RARA;
    float band2 = pc.clip.p.band.y;
    vec3 ray_dir = vec3(0.0);
    vec4 spans = vec4(0.0);
    if (rara) {
        vec2 c = (pixf - f.focal.zw) / f.focal.xy;
        ray_dir = normalize(c.x * f.world_to_cam0.xyz + c.y * f.world_to_cam1.xyz
                            + f.world_to_cam2.xyz);
        spans = clip_ray_spans(pc.clip, f.cam_pos.xyz, ray_dir);
    }

    uvec2 range = pc.ranges.v[tile.y * f.size.z + tile.x];
    uint start = min(range.x + pc.round_index * RASTER_CHUNK, range.y);
    uint end = min(start + RASTER_CHUNK, range.y);
    if (lid == 0u) {
        pixels_done = 0u;
        if (pc.round_index == 0u) {
            atomicMax(pc.counters.v[COUNTER_MAX_TILE_LEN], range.y - range.x);
        }
    }

    vec3 color = vec3(0.0);
    float T = 1.0;
    bool done = !inside;
    if ((pc.flags & ROUND_FIRST) == 0u && inside) {
        vec4 s = pc.state.v[pixel_index];
        color = s.rgb;
        T = abs(s.a);
        done = s.a < 0.0;
    }
    barrier();
    if (done) {
        atomicAdd(pixels_done, 1u);
    }

    for (uint batch = start; batch < end; batch += RASTER_WORKGROUP) {
        barrier();
        if (pixels_done == RASTER_WORKGROUP) {
            break;
        }
        uint entry = batch + lid;
        if (entry < end) {
            uint s = pc.values.v[entry];
            ProjectedSplat p = pc.splats.v[s];
            batch_uv[lid] = p.uv;
            batch_conic_opacity[lid] = vec4(p.conic, p.opacity);
            bool cutoff = p.cutoff != NO_CUTOFF;
            batch_color_cutoff[lid] = vec4(p.color, cutoff ? 1.0 : 0.0);
            if (cutoff) {
                batch_cutoff[lid] = pc.cutoffs.v[p.cutoff];
            }
        }
        barrier();
        uint count = min(RASTER_WORKGROUP, end - batch);
        for (uint k = 0u; k < count && !done; ++k) {
            vec2 d = batch_uv[k] - pixf;
            vec4 co = batch_conic_opacity[k];
            float power = -0.5 * (co.x * d.x * d.x + co.z * d.y * d.y) - co.y * d.x * d.y;
            if (power > 0.0) {
                continue;
            }
            float alpha = co.w * exp(power);
            if (alpha < 1.0 / 255.0) {
                continue; // w <= 1 cannot lift it over the threshold
            }
            vec4 color_cutoff = batch_color_cutoff[k];
            if (color_cutoff.w != 0.0) {
                alpha *= cutoff_weight(batch_cutoff[k], ray_dir, spans, clip_config.y, band2);
            }
            alpha = min(0.99, alpha);
            if (alpha < 1.0 / 255.0) {
                continue;
            }
            float next_T = T * (1.0 - alpha);
            if (next_T < 1e-4) {
                done = true;
                atomicAdd(pixels_done, 1u);
                break;
            }
            color += alpha * T * color_cutoff.rgb;
            T = next_T;
        }
    }

    if (!inside) {
        return;
    }
    if ((pc.flags & ROUND_LAST) != 0u) {
        pc.image.v[pixel_index] = pack_rgba8(color + T * f.background.rgb);
    } else {
        pc.state.v[pixel_index] = vec4(color, done ? -T : T);
    }
}
