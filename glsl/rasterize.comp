// Stage 6, rasterize (SPEC section 4): one workgroup per 16x16 tile, one invocation per pixel.
// The tile's splats, sorted front to back, are staged through shared memory in batches of
// RASTER_WORKGROUP; each pixel composites them until its transmittance runs out, and the
// workgroup stops once every pixel is done.
//
// One dispatch walks at most RASTER_CHUNK entries of each tile list (lavapipe ends an
// invocation after 65,535 loop iterations). Longer lists take several rounds; between rounds
// the per-pixel state (colour, transmittance, done) lives in `state`.
#version 460
#include "common.glsl"

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
    uint round_index;
    uint flags;
} pc;

shared vec2 batch_uv[RASTER_WORKGROUP];
shared vec4 batch_conic_opacity[RASTER_WORKGROUP];
shared vec3 batch_color[RASTER_WORKGROUP];
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
            batch_color[lid] = p.color;
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
            float alpha = min(0.99, co.w * exp(power));
            if (alpha < 1.0 / 255.0) {
                continue;
            }
            float next_T = T * (1.0 - alpha);
            if (next_T < 1e-4) {
                done = true;
                atomicAdd(pixels_done, 1u);
                break;
            }
            color += alpha * T * batch_color[k];
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
