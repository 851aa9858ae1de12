#version 460
// Ray tracer BVH build, step 1 (SPEC section 7): each Gaussian's proxy box, and the bounds
// of the boxes' centres (for the Morton codes). A flat Gaussian's box holds its octagon
// (SPEC section 6: rho^2 = max(0, Q + 2 ln o), corners mu + rho (s_a cos r_a + s_b sin r_b));
// a volumetric one's the ellipsoid q <= 2 ln(255 o), half extent sqrt(q_max Sigma_jj) along
// axis j. A Gaussian that can never be hit (opacity under 1/255, no octagon) gets an empty
// box, still a leaf, which no ray enters. CPU twin: reference::raytrace::proxy_bounds.
#include "bvh_common.glsl"

layout(local_size_x = LINEAR_WORKGROUP) in;

layout(push_constant) uniform Push {
    Gaussians gaussians;
    BvhNodes boxes;         // out: one per Gaussian
    CoherentU32s bounds;    // in/out: centre bounds (float_order), set to (max, min) before
    uint count;
    float q;                // Q of the octagons
} pc;

shared vec3 wg_lo[LINEAR_WORKGROUP];
shared vec3 wg_hi[LINEAR_WORKGROUP];

void main() {
    uint i = linear_index();
    vec3 lo = vec3(1e30);
    vec3 hi = vec3(-1e30);
    bool live = false;
    if (i < pc.count) {
        Gaussian g = load_gaussian(pc.gaussians, i);
        vec3 mu = g.pos_opacity.xyz;
        float o = g.pos_opacity.w;
        vec3 s = g.scale.xyz;
        vec3 c0, c1, c2;
        quat_columns(g.rot, c0, c1, c2);
        uint axis = flat_axis(s);
        if (axis < 3u) {
            // r_a, r_b: the axes after the normal, cyclically.
            vec3 cols[3] = vec3[3](c0, c1, c2);
            float scales[3] = float[3](s.x, s.y, s.z);
            vec3 ra = cols[(axis + 1u) % 3u] * scales[(axis + 1u) % 3u];
            vec3 rb = cols[(axis + 2u) % 3u] * scales[(axis + 2u) % 3u];
            float rho2 = pc.q + 2.0 * log(o);
            if (rho2 > 0.0 && o > 0.0) {
                float rho = sqrt(rho2);
                const float h = 0.70710678118654752;
                const vec2 corners[8] = vec2[8](vec2(1.0, 0.0), vec2(h, h), vec2(0.0, 1.0),
                    vec2(-h, h), vec2(-1.0, 0.0), vec2(-h, -h), vec2(0.0, -1.0), vec2(h, -h));
                for (uint k = 0u; k < 8u; ++k) {
                    vec3 p = mu + rho * (corners[k].x * ra + corners[k].y * rb);
                    lo = min(lo, p);
                    hi = max(hi, p);
                }
                live = true;
            }
        } else {
            float q_max = 2.0 * log(255.0 * o);
            if (q_max > 0.0) {
                // Sigma_jj = sum_k (R_jk s_k)^2: row j of R S.
                vec3 m0 = c0 * s.x, m1 = c1 * s.y, m2 = c2 * s.z;
                vec3 ext = sqrt(q_max) * sqrt(m0 * m0 + m1 * m1 + m2 * m2);
                lo = mu - ext;
                hi = mu + ext;
                live = true;
            }
        }
        pc.boxes.v[i] = BvhNode(lo, 0u, hi, 0u);
    }
    // The centre bounds of the live boxes: a workgroup reduction, then one atomic per value.
    vec3 centre = 0.5 * (lo + hi);
    uint t = gl_LocalInvocationIndex;
    wg_lo[t] = live ? centre : vec3(1e30);
    wg_hi[t] = live ? centre : vec3(-1e30);
    barrier();
    for (uint stride = LINEAR_WORKGROUP / 2u; stride > 0u; stride /= 2u) {
        if (t < stride) {
            wg_lo[t] = min(wg_lo[t], wg_lo[t + stride]);
            wg_hi[t] = max(wg_hi[t], wg_hi[t + stride]);
        }
        barrier();
    }
    if (t == 0u && wg_lo[0].x <= wg_hi[0].x) {
        for (uint k = 0u; k < 3u; ++k) {
            atomicMin(pc.bounds.v[k], float_order(wg_lo[0][k]));
            atomicMax(pc.bounds.v[3u + k], float_order(wg_hi[0][k]));
        }
    }
}
