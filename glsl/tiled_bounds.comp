#version 460
// Section 7 in tiles (SPEC section 11), stage 1, bounds: one invocation per Gaussian finds
// the tiles whose pixel rays may cross its proxy (the bounding rectangle of the proxy's
// silhouette, exact for the pinhole up to a margin: a looser bound is allowed, never a
// tighter one) and its key, the least view depth of any hit of it from the eye. CPU twin:
// src/reference/tiled.rs (silhouette_tiles, depth_key).
//
// It writes what the rasterizer's project stage would, so that the depth order, the prefix
// sum, the pair sort and the tile ranges run unchanged: per Gaussian its tiles touched and its
// listed flag (for the depth order's scan), and in its 48-byte splat record the key where the
// depth lies (word 8, which the depth sort reads). Words 0-3 of the record are what the
// tracer reads of a listed Gaussian in one 16-byte load (TiledRecord): the pixels inside the
// silhouette's rectangle (x0 | x1 << 16, y0 | y1 << 16, inclusive, within the image), which
// spare most of a tile's pixels the hit test, and the key; tiled_emit derives the tiles from
// them. A Gaussian that no camera ray can hit (section 3's culling, an empty proxy, a
// silhouette off the image) touches no tile.
//
// The key is a depth, not section 11's ray parameter k_g = |mu - e| - rho_g: on one ray view
// depth orders hits as t does (depth = t (d . forward), d . forward > 0 inside the image), and
// this key is tighter than the ball's (docs/ARCHITECTURE.md, "Section 7 in tiles"). Negative
// keys are clamped to 0 (no hit lies behind the camera), so the keys' bits order as they do.
#include "common.glsl"

layout(local_size_x = LINEAR_WORKGROUP) in;

layout(push_constant) uniform Push {
    FrameParamsRef frame;
    Gaussians gaussians;
    U32s splat_words;   // out: the ProjectedSplat records as words, 12 per Gaussian
    U32s tiles_touched; // out: per Gaussian
    U32s listed;        // out: per Gaussian, 1 when it touches a tile (the depth order's scan)
    float q;            // Q of the flat Gaussians' octagons (SPEC section 6)
    uint pad;
} pc;

// Words of a ProjectedSplat record (ProjectedSplatWords in common.glsl).
#define SPLAT_WORDS 12u
#define SPLAT_WORD_DEPTH 8u

// A relative margin on keys and silhouettes: the kernels' f32 rounding stays far inside it,
// and a looser bound only lists a Gaussian in a tile more or composites a hit later.
#define BOUND_MARGIN 1e-3

// The pixels [lo, hi] along one image axis of `pixels` pixels in [u_lo, u_hi] (widened by
// the margin); lo > hi when none.
uvec2 pixel_span(float u_lo, float u_hi, uint pixels) {
    float pad = 0.5 + BOUND_MARGIN * max(abs(u_lo), abs(u_hi));
    float lo = max(ceil(u_lo - pad), 0.0);
    float hi = min(floor(u_hi + pad), float(pixels) - 1.0);
    if (!(lo <= hi)) {
        return uvec2(1u, 0u);
    }
    return uvec2(lo, hi);
}

void main() {
    FrameParams f = load_frame_params(pc.frame);
    uint i = linear_index();
    if (i >= f.scene.x) {
        return;
    }
    Gaussian g = load_gaussian(pc.gaussians, i);
    vec3 mu = g.pos_opacity.xyz;
    float o = g.pos_opacity.w;
    vec3 s = g.scale.xyz;
    vec3 eye = f.cam_pos.xyz;
    vec3 right = f.world_to_cam0.xyz;
    vec3 down = f.world_to_cam1.xyz;
    vec3 forward = f.world_to_cam2.xyz;
    vec2 focal = f.focal.xy;
    vec2 centre = f.focal.zw;
    uvec2 grid = f.size.zw;
    // Section 3's culling, as the tracer's camera rays apply it (gaussian_hit in
    // trace_body.glsl tests it again, so this side only has to be no stricter).
    bool live = dot(forward, mu - eye) > 0.2;
    bool unbounded = false;
    vec2 u_range = vec2(1.0, 0.0);
    vec2 v_range = vec2(1.0, 0.0);
    float key = 0.0;
    vec3 c0, c1, c2;
    quat_columns(g.rot, c0, c1, c2);
    uint axis = flat_axis(s);
    if (live && axis < 3u) {
        // The octagon (SPEC section 6): corners at radius rho on the in-plane axes scaled by
        // their scales; its silhouette is its corners' hull, its nearest depth a corner's.
        vec3 cols[3] = vec3[3](c0, c1, c2);
        float scales[3] = float[3](s.x, s.y, s.z);
        vec3 ra = cols[(axis + 1u) % 3u] * scales[(axis + 1u) % 3u];
        vec3 rb = cols[(axis + 2u) % 3u] * scales[(axis + 2u) % 3u];
        float rho2 = pc.q + 2.0 * log(o);
        live = rho2 > 0.0;
        float rho = sqrt(max(rho2, 0.0)) * (1.0 + BOUND_MARGIN);
        float nearest = 1e30;
        float h = 0.70710678118654752;
        vec2 corners[8] = vec2[8](vec2(1.0, 0.0), vec2(h, h), vec2(0.0, 1.0), vec2(-h, h),
                                  vec2(-1.0, 0.0), vec2(-h, -h), vec2(0.0, -1.0), vec2(h, -h));
        for (uint k = 0u; k < 8u; ++k) {
            vec3 p = mu + rho * (corners[k].x * ra + corners[k].y * rb) - eye;
            vec3 c = vec3(dot(right, p), dot(down, p), dot(forward, p));
            nearest = min(nearest, c.z);
            if (!(c.z > 0.0)) {
                unbounded = true;
            } else {
                vec2 uv = centre + focal * c.xy / c.z;
                u_range = k == 0u ? uv.xx : vec2(min(u_range.x, uv.x), max(u_range.y, uv.x));
                v_range = k == 0u ? uv.yy : vec2(min(v_range.x, uv.y), max(v_range.y, uv.y));
            }
        }
        key = nearest - BOUND_MARGIN * (1.0 + abs(nearest));
    } else if (live) {
        // The ellipsoid q <= q_max = 2 ln(255 o) (SPEC section 7's proxy).
        float q_max = 2.0 * log(255.0 * o);
        live = q_max > 0.0;
        q_max = max(q_max, 0.0) * (1.0 + BOUND_MARGIN);
        // Its axes in the camera's frame, scaled: Sigma q_max = (R S)(R S)^T q_max.
        vec3 a0 = vec3(dot(right, c0), dot(down, c0), dot(forward, c0)) * s.x;
        vec3 a1 = vec3(dot(right, c1), dot(down, c1), dot(forward, c1)) * s.y;
        vec3 a2 = vec3(dot(right, c2), dot(down, c2), dot(forward, c2)) * s.z;
        // sigma[r][c] = sum_k a_k[r] a_k[c] q_max.
        vec3 sxx = vec3(a0.x, a1.x, a2.x);
        vec3 syy = vec3(a0.y, a1.y, a2.y);
        vec3 szz = vec3(a0.z, a1.z, a2.z);
        float s_xx = dot(sxx, sxx) * q_max;
        float s_yy = dot(syy, syy) * q_max;
        float s_zz = dot(szz, szz) * q_max;
        float s_xz = dot(sxx, szz) * q_max;
        float s_yz = dot(syy, szz) * q_max;
        vec3 to_mu = mu - eye;
        vec3 m = vec3(dot(right, to_mu), dot(down, to_mu), dot(forward, to_mu));
        float a = m.z * m.z - s_zz;
        if (!(a > 0.0)) {
            unbounded = true; // the ellipsoid reaches the camera's plane
        } else {
            // The column planes through the eye tangent to it (reference::tiled::silhouette):
            // a w^2 - 2 f b w + f^2 c <= 0, with the discriminant b^2 - a c expanded so that
            // its large terms (m_c m_z)^2 cancel exactly instead of in f32.
            float bu = m.x * m.z - s_xz;
            float du = s_xz * s_xz - 2.0 * m.x * m.z * s_xz + m.z * m.z * s_xx + s_zz * m.x * m.x
                     - s_zz * s_xx;
            float bv = m.y * m.z - s_yz;
            float dv = s_yz * s_yz - 2.0 * m.y * m.z * s_yz + m.z * m.z * s_yy + s_zz * m.y * m.y
                     - s_zz * s_yy;
            if (du >= 0.0 && dv >= 0.0) {
                float ru = sqrt(du);
                float rv = sqrt(dv);
                u_range = centre.x + focal.x * vec2(bu - ru, bu + ru) / a;
                v_range = centre.y + focal.y * vec2(bv - rv, bv + rv) / a;
            } else {
                live = false;
            }
        }
        // The key (reference::tiled::depth_key): in the whitened frame x' = S^-1 R^T (x - mu)
        // the proxy is the ball |x'|^2 <= q_max and a ray's maximum response lies on the sphere
        // with diameter [0, e']; view depth is z0 + gv . x' there, so the nearest depth of a
        // hit is the least of gv . x' over that sphere's cap inside the ball.
        vec3 gv = vec3(dot(forward, c0) * s.x, dot(forward, c1) * s.y, dot(forward, c2) * s.z);
        vec3 to_eye = eye - mu;
        vec3 e_w = vec3(dot(to_eye, c0) / s.x, dot(to_eye, c1) / s.y, dot(to_eye, c2) / s.z);
        float z0 = -dot(forward, to_eye);
        float g_len = length(gv);
        float e_len2 = dot(e_w, e_w);
        float proxy_front = -sqrt(q_max) * g_len;
        float lowest = proxy_front;
        if (g_len > 0.0 && e_len2 > 0.0) {
            vec3 c = 0.5 * e_w;
            float radius = 0.5 * sqrt(e_len2);
            vec3 on_sphere = c - radius * gv / g_len;
            if (dot(on_sphere, on_sphere) <= q_max) {
                lowest = dot(gv, c) - radius * g_len;
            } else {
                vec3 n = e_w / sqrt(e_len2);
                float rim_radius2 = q_max * (1.0 - q_max / e_len2);
                vec3 g_in_plane = gv - dot(gv, n) * n;
                lowest = dot(gv, e_w) * q_max / e_len2 - sqrt(max(rim_radius2, 0.0)) * length(g_in_plane);
            }
        }
        lowest = max(lowest, proxy_front);
        float size = abs(z0) + sqrt(q_max) * g_len + 0.5 * sqrt(e_len2) * g_len;
        key = z0 + lowest - BOUND_MARGIN * (1.0 + size);
    }
    // Pixels (x0, y0, x1, y1), inclusive.
    uvec4 pixels = uvec4(1u, 1u, 0u, 0u);
    if (live && unbounded) {
        pixels = uvec4(0u, 0u, f.size.xy - 1u);
    } else if (live) {
        uvec2 x = pixel_span(u_range.x, u_range.y, f.size.x);
        uvec2 y = pixel_span(v_range.x, v_range.y, f.size.y);
        if (x.x <= x.y && y.x <= y.y) {
            pixels = uvec4(x.x, y.x, x.y, y.y);
        }
    }
    uint touched = 0u;
    if (pixels.x <= pixels.z && pixels.y <= pixels.w) {
        uvec4 tiles = uvec4(pixels.xy / TILE_SIZE, pixels.zw / TILE_SIZE + 1u);
        touched = tile_rect_cells(tiles);
    }
    pc.tiles_touched.v[i] = touched;
    pc.listed.v[i] = touched > 0u ? 1u : 0u;
    uint key_bits = floatBitsToUint(key > 0.0 ? key : 0.0);
    Address record = address_item(Address(pc.splat_words), i, 4u * SPLAT_WORDS);
    store_uvec4(record, uvec4(pixels.x | (pixels.z << 16u), pixels.y | (pixels.w << 16u), key_bits, 0u));
    pc.splat_words.v[i * SPLAT_WORDS + SPLAT_WORD_DEPTH] = key_bits;
}
