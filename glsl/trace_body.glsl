// The ray tracer (SPEC section 7, issue 32): one invocation per pixel walks the BVH
// (bvh_common.glsl) and composites its hits front to back, each hit's alpha times its clip
// weight (clip_weight below). CPU twin: src/reference/raytrace.rs.
//
// k-closest hits: a traversal pass collects, in a sorted buffer of TRACE_K entries, the K
// hits after the last one composited in (t, index) order (so no hit is missed or repeated,
// equal t included); the ray then composites them in order and, when the buffer was full,
// traces again from the last one. A pass culls a node whose box ends before the last hit or,
// with the buffer full, starts after its worst entry.
//
// lavapipe stops an invocation after 65,535 loop iterations in all (docs: PLATFORM.md), and a
// ray can need far more node visits than that. So a dispatch gives each ray at most
// TRACE_BUDGET steps (a node visit or a composited hit) and leaves its whole state in buffers:
// the stack, the k-buffer, colour and transmittance, the last hit, its counts; the host
// dispatches again while rays are live. Nothing waits on another invocation.
//
// Included by trace_deg<D> (SH of degree D in 32-bit floats) and trace_deg<D>_sh16.
#include "bvh_common.glsl"
#include "sh.glsl"
#include "clip.glsl"

layout(local_size_x = LINEAR_WORKGROUP) in;

#define TRACE_K 16
#define TRACE_STACK 64
#define TRACE_BUDGET 8192u

// Ray flags.
#define RAY_DONE 1u
#define RAY_CAPPED 2u
#define RAY_COMPOSITING 4u
#define RAY_HAS_LAST 8u

// Counter slots.
#define TRACE_LIVE 0
#define TRACE_WALKED 1
#define TRACE_CAPPED 2
#define TRACE_HITS 3
#define TRACE_OVERFLOW 4

// A ray's state between dispatches (GpuRayState): colour and transmittance, the last hit's t,
// and (last hit's index, hits walked, flags, stack pointer | k count << 8 | k position << 16).
struct RayState {
    vec4 colour_t;
    vec4 last_t;
    uvec4 info;
};
layout(buffer_reference, std430, buffer_reference_align = 16) buffer RayStates { RayState v[]; };

// The camera and image (GpuTraceParams).
struct TraceParams {
    vec4 eye;           // camera centre, w unused
    vec4 right;         // rotation columns: x right, y down, z forward (world)
    vec4 down;
    vec4 forward;
    vec4 focal;         // fx, fy, cx, cy
    vec4 background;
    uvec4 size;         // W, H, Gaussians, SH floats per Gaussian
    vec4 options;       // Q, max hits (as float), unused, unused
};
layout(buffer_reference, std430, buffer_reference_align = 16) buffer TraceParamsRef { TraceParams p; };


layout(push_constant) uniform Push {
    TraceParamsRef params;
    Gaussians gaussians;
    ShCoefficients sh;
    BvhNodes nodes;
    RayStates rays;
    U32s stacks;        // TRACE_STACK per ray
    F32s k_t;           // TRACE_K per ray
    U32s k_index;
    F32s k_alpha;
    U32s pixels;        // out: RGBA8 per pixel
    U32s counters;      // TRACE_* slots
    ClipParamsRef clip;
    uint init;          // 1: set every ray up (first dispatch)
    uint pad;
} pc;

// The clip weight of hit (t, Gaussian g) on the ray e + t d whose visible intervals are spans
// (SPEC section 7): hard keeps g when its centre is visible; rara gives a flat g 1 where its
// crossing point is visible (no band, no classification) and a volumetric one section 5's
// classification and, when cutoff, its mass or length weight on this ray.
float clip_weight(ClipParams clip, vec4 spans, uint g, float t, vec3 e, vec3 d) {
    uvec4 config = clip.config;
    if (config.x == CLIP_MODE_NONE) {
        return 1.0;
    }
    Gaussian gs = load_gaussian(pc.gaussians, g);
    vec3 mu = gs.pos_opacity.xyz;
    if (config.x == CLIP_MODE_HARD) {
        return clip_signed_distance(clip, mu) >= 0.0 ? 1.0 : 0.0;
    }
    vec3 s = gs.scale.xyz;
    if (flat_axis(s) < 3u) {
        bool seen = (spans.x <= t && t <= spans.y && spans.x < spans.y)
                 || (spans.z <= t && t <= spans.w && spans.z < spans.w);
        return seen ? 1.0 : 0.0;
    }
    uint kind = clip_classify(clip, mu, s);
    if (kind != CLASS_CUTOFF) {
        return kind == CLASS_DRAWN ? 1.0 : 0.0;
    }
    // The cutoff record of the rasterizer (project_body.glsl): rows of M = S^-1 R^T and
    // o' = M (e - mu); one ray is a strip's r = 0.
    vec3 c0, c1, c2;
    quat_columns(gs.rot, c0, c1, c2);
    CutoffRecord rec = volume_cutoff_record(c0, c1, c2, s, mu - e);
    WhitenedStrip strip = whitened_strip(rec, d, vec3(0.0));
    if (config.y == CLIP_WEIGHT_LENGTH) {
        return cutoff_weight_length(strip, 0.0, spans, clip.band.y);
    }
    MassEnds m = clip_mass_ends(spans);
    float w = m.base;
    if (m.count > 0u) {
        w += end_mass(strip, 0.0, m.ends.xy);
    }
    if (m.count > 1u) {
        w += end_mass(strip, 0.0, m.ends.zw);
    }
    return clamp(w, 0.0, 1.0);
}

// Gaussian i's hit on the ray e + t d (unit d): (t, alpha), alpha 0 for none (SPEC section 7).
vec2 gaussian_hit(TraceParams f, uint i, vec3 e, vec3 d) {
    Gaussian g = load_gaussian(pc.gaussians, i);
    vec3 mu = g.pos_opacity.xyz;
    float o = g.pos_opacity.w;
    // Primary rays skip what section 3 culls.
    if (dot(f.forward.xyz, mu - e) <= 0.2) {
        return vec2(0.0);
    }
    vec3 s = g.scale.xyz;
    vec3 c0, c1, c2;
    quat_columns(g.rot, c0, c1, c2);
    uint axis = flat_axis(s);
    if (axis < 3u) {
        vec3 cols[3] = vec3[3](c0, c1, c2);
        float scales[3] = float[3](s.x, s.y, s.z);
        vec3 n = cols[axis];
        vec3 ra = cols[(axis + 1u) % 3u];
        vec3 rb = cols[(axis + 2u) % 3u];
        float sa = scales[(axis + 1u) % 3u];
        float sb = scales[(axis + 2u) % 3u];
        float nd = dot(n, d);
        float rho2 = f.options.x + 2.0 * log(o);
        if (abs(nd) < 1e-7 || !(rho2 > 0.0)) {
            return vec2(0.0);
        }
        float t = dot(n, mu - e) / nd;
        if (!(t > 0.0)) {
            return vec2(0.0);
        }
        vec3 p = e + t * d - mu;
        float a = dot(p, ra) / sa;
        float b = dot(p, rb) / sb;
        // Inside the octagon polygon: within the apothem rho cos(pi/8) along each edge normal.
        float apothem = sqrt(rho2) * 0.92387953251128674;
        bool inside = true;
        [[unroll]] for (uint k = 0u; k < 8u; ++k) {
            float phi = float(2u * k + 1u) * 0.39269908169872414;
            inside = inside && a * cos(phi) + b * sin(phi) <= apothem;
        }
        return inside ? vec2(t, min(0.99, o * exp(-0.5 * (a * a + b * b)))) : vec2(0.0);
    }
    // Maximum response: M = S^-1 R^T, A = |M d|^2, B = 2 (M d).(M (e - mu)), Cq = |M (e - mu)|^2.
    vec3 md = vec3(dot(c0, d) / s.x, dot(c1, d) / s.y, dot(c2, d) / s.z);
    vec3 eo = e - mu;
    vec3 mo = vec3(dot(c0, eo) / s.x, dot(c1, eo) / s.y, dot(c2, eo) / s.z);
    float aa = dot(md, md);
    float bb = 2.0 * dot(md, mo);
    float t = -bb / (2.0 * aa);
    // q = Cq - B^2/(4A) = |mo|^2 - (md.mo)^2/|md|^2 = |mo x md|^2 / |md|^2 (Lagrange's
    // identity): the difference of two large numbers for a thin Gaussian lost every digit in
    // f32 (plant: 13,150 pixels off by up to 59), the cross product keeps them.
    vec3 cr = cross(mo, md);
    float q = dot(cr, cr) / aa;
    float q_max = 2.0 * log(255.0 * o);
    if (!(t > 0.0) || !(q <= q_max)) {
        return vec2(0.0);
    }
    return vec2(t, min(0.99, o * exp(-0.5 * q)));
}

// (t, index) strictly before (t2, index2).
bool before(float t, uint i, float t2, uint i2) {
    return t < t2 || (t == t2 && i < i2);
}

void main() {
    TraceParams f = pc.params.p;
    uint ray = linear_index();
    uint w = f.size.x, h = f.size.y;
    if (ray >= w * h) {
        return;
    }
    uint stack_base = ray * uint(TRACE_STACK);
    uint k_base = ray * uint(TRACE_K);
    RayState st;
    if (pc.init != 0u) {
        st.colour_t = vec4(0.0, 0.0, 0.0, 1.0);
        st.last_t = vec4(0.0);
        st.info = uvec4(0u, 0u, 0u, 1u);   // one node on the stack: the root
        pc.stacks.v[stack_base] = 0u;
    } else {
        st = pc.rays.v[ray];
    }
    uint flags = st.info.z;
    if ((flags & RAY_DONE) != 0u) {
        return;
    }
    // The pixel's ray (SPEC section 2).
    uvec2 px = uvec2(ray % w, ray / w);
    vec3 e = f.eye.xyz;
    vec3 d = normalize(f.right.xyz * ((float(px.x) - f.focal.z) / f.focal.x)
                     + f.down.xyz * ((float(px.y) - f.focal.w) / f.focal.y) + f.forward.xyz);
    // No zero component: 0 * inf in the slab test would be NaN and lose the box.
    vec3 inv_d = 1.0 / (sign(d) * max(abs(d), vec3(1e-20)) + vec3(equal(d, vec3(0.0))) * 1e-20);
    // The ray's visible intervals, once (clip.glsl).
    ClipParams clip = load_clip_params(pc.clip);
    float span_lo = -UNBOUNDED;
    float span_hi = UNBOUNDED;
    if ((clip.config.z & CLIP_FLAG_SPHERE) != 0u) {
        vec2 chord = clip_span_in_sphere(clip.sphere, e, d);
        span_lo = chord.x;
        span_hi = chord.y;
    } else {
        [[unroll]] for (uint k = 0u; k < MAX_CLIP_PLANES; ++k) {
            if (k < clip.config.w) {
                clip_span_cut_by_plane(clip.planes[k], e, d, span_lo, span_hi);
            }
        }
    }
    vec4 spans = clip_visible_spans(clip.config.z, span_lo, span_hi);
    uint max_hits = uint(f.options.y);
    uint leaves = f.size.z - 1u;

    uint sp = st.info.w & 0xffu;
    uint k_count = (st.info.w >> 8u) & 0xffu;
    uint k_pos = (st.info.w >> 16u) & 0xffu;
    uint walked = st.info.y;
    uint last_index = st.info.x;
    float last_t = st.last_t.x;
    vec3 colour = st.colour_t.rgb;
    float T = st.colour_t.a;
    uint stack[TRACE_STACK];
    for (uint k = 0u; k < sp; ++k) {
        stack[k] = pc.stacks.v[stack_base + k];
    }
    float kt[TRACE_K];
    uint ki[TRACE_K];
    float ka[TRACE_K];
    for (uint k = 0u; k < k_count; ++k) {
        kt[k] = pc.k_t.v[k_base + k];
        ki[k] = pc.k_index.v[k_base + k];
        ka[k] = pc.k_alpha.v[k_base + k];
    }
    uint hits = 0u;
    uint steps = 0u;
    while ((flags & RAY_DONE) == 0u && steps < TRACE_BUDGET) {
        ++steps;
        if ((flags & RAY_COMPOSITING) == 0u) {
            if (sp == 0u) {
                // The pass is over: composite what it found.
                flags |= RAY_COMPOSITING;
                k_pos = 0u;
                if (k_count == 0u) {
                    flags |= RAY_DONE;
                }
                continue;
            }
            uint node = stack[--sp];
            BvhNode b = pc.nodes.v[node];
            vec3 a0 = (b.lo - e) * inv_d;
            vec3 a1 = (b.hi - e) * inv_d;
            vec3 tmin = min(a0, a1);
            vec3 tmax = max(a0, a1);
            float t_in = max(max(tmin.x, max(tmin.y, tmin.z)), 0.0);
            float t_out = min(tmax.x, min(tmax.y, tmax.z));
            float slack = 1e-4 * (1.0 + abs(t_out));
            bool enters = t_in <= t_out + slack;
            // Hits inside lie within the box's stretch of the ray.
            if ((flags & RAY_HAS_LAST) != 0u && t_out + slack < last_t) {
                enters = false;
            }
            if (k_count == uint(TRACE_K) && t_in - slack > kt[TRACE_K - 1]) {
                enters = false;
            }
            if (!enters || b.lo.x > b.hi.x) {
                continue;
            }
            if (node >= leaves) {
                uint g = b.left;
                vec2 hit = gaussian_hit(f, g, e, d);
                bool after = (flags & RAY_HAS_LAST) == 0u || before(last_t, last_index, hit.x, g);
                bool room = k_count < uint(TRACE_K) || before(hit.x, g, kt[TRACE_K - 1], ki[TRACE_K - 1]);
                if (hit.y > 0.0 && after && room) {
                    ++hits;
                    // Sorted insertion: the new entry takes the last slot (the worst's, when
                    // the buffer is full) and moves down past every larger one. Unrolled, with
                    // fixed indices: no loop iterations against the cap, the arrays stay in
                    // registers.
                    uint p0 = min(k_count, uint(TRACE_K - 1));
                    k_count = min(k_count + 1u, uint(TRACE_K));
                    [[unroll]] for (uint k = 0u; k < uint(TRACE_K); ++k) {
                        if (k == p0) {
                            kt[k] = hit.x;
                            ki[k] = g;
                            ka[k] = hit.y;
                        }
                    }
                    [[unroll]] for (int k = TRACE_K - 1; k > 0; --k) {
                        if (uint(k) <= p0 && before(kt[k], ki[k], kt[k - 1], ki[k - 1])) {
                            float tt = kt[k]; kt[k] = kt[k - 1]; kt[k - 1] = tt;
                            uint ti = ki[k]; ki[k] = ki[k - 1]; ki[k - 1] = ti;
                            float ta = ka[k]; ka[k] = ka[k - 1]; ka[k - 1] = ta;
                        }
                    }
                }
            } else if (sp + 2u <= uint(TRACE_STACK)) {
                stack[sp++] = b.right;
                stack[sp++] = b.left;
            } else {
                // Cannot happen (depth <= 63 keeps at most 64 entries): counted, never silent.
                atomicAdd(pc.counters.v[TRACE_OVERFLOW], 1u);
            }
            continue;
        }
        // Compositing the pass's hits in order (SPEC section 4's rule).
        if (k_pos == k_count) {
            if (k_count < uint(TRACE_K)) {
                flags |= RAY_DONE;  // the pass found every hit there was
            } else {
                flags &= ~RAY_COMPOSITING;
                k_count = 0u;
                sp = 1u;
                stack[0] = 0u;
            }
            continue;
        }
        if (walked == max_hits) {
            flags |= RAY_DONE | RAY_CAPPED;
            continue;
        }
        ++walked;
        // Entry k_pos by fixed indices (selects), not a dynamic index into the arrays.
        uint g = 0u;
        float hit_t = 0.0;
        float hit_alpha = 0.0;
        [[unroll]] for (uint k = 0u; k < uint(TRACE_K); ++k) {
            bool at = k == k_pos;
            g = at ? ki[k] : g;
            hit_t = at ? kt[k] : hit_t;
            hit_alpha = at ? ka[k] : hit_alpha;
        }
        float alpha = hit_alpha * clip_weight(clip, spans, g, hit_t, e, d);
        last_t = hit_t;
        last_index = g;
        flags |= RAY_HAS_LAST;
        ++k_pos;
        if (alpha < 1.0 / 255.0) {
            continue;
        }
        float next_t = T * (1.0 - alpha);
        if (next_t < 1e-4) {
            flags |= RAY_DONE;
            continue;
        }
        vec3 mu = load_gaussian(pc.gaussians, g).pos_opacity.xyz;
        colour += alpha * T * eval_sh(pc.sh, g * f.size.w, normalize(mu - e));
        T = next_t;
    }
    if (hits > 0u) {
        atomicAdd(pc.counters.v[TRACE_HITS], hits);
    }
    if ((flags & RAY_DONE) != 0u) {
        vec3 c = clamp(colour + T * f.background.rgb, 0.0, 1.0);
        uvec3 q = uvec3(round(c * 255.0));
        pc.pixels.v[ray] = q.r | (q.g << 8u) | (q.b << 16u) | (255u << 24u);
        atomicAdd(pc.counters.v[TRACE_WALKED], walked);
        if ((flags & RAY_CAPPED) != 0u) {
            atomicAdd(pc.counters.v[TRACE_CAPPED], 1u);
        }
    } else {
        atomicAdd(pc.counters.v[TRACE_LIVE], 1u);
    }
    st.colour_t = vec4(colour, T);
    st.last_t = vec4(last_t, 0.0, 0.0, 0.0);
    st.info = uvec4(last_index, walked, flags, sp | (k_count << 8u) | (k_pos << 16u));
    pc.rays.v[ray] = st;
    for (uint k = 0u; k < sp; ++k) {
        pc.stacks.v[stack_base + k] = stack[k];
    }
    for (uint k = 0u; k < k_count; ++k) {
        pc.k_t.v[k_base + k] = kt[k];
        pc.k_index.v[k_base + k] = ki[k];
        pc.k_alpha.v[k_base + k] = ka[k];
    }
}
