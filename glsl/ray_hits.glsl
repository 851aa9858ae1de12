// Section 7's hit model, shared by every way the ray tracer finds hits (the BVH walk and the
// tile lists of SPEC section 11, trace_body.glsl; the mixed scenes' rays): a Gaussian's hit on
// a ray (gaussian_hit: the octagon crossing, or 3DGRT's maximum response), its clip weight
// (clip_weight, over the ray's visible spans from ray_spans; hit_clip_weight picks the clip:
// the frame's, or the hit's object's) and the composite of one hit
// (add_hit, SPEC section 4's rule, with mixed scenes' shadows). CPU twin: src/reference/ray_hits.rs, the same functions;
// sharing them is what makes the paths agree to the bit.
//
// Included by trace_body.glsl after what these read: the push constants `pc` (the Gaussians
// and their coefficients), TraceParams, trace_gaussian (bvh_common.glsl, or the texel views),
// clip.glsl and sh.glsl.

// The clip weight of hit (t, Gaussian g) on the ray e + t d whose visible intervals are spans
// (SPEC section 7): hard keeps g when its centre is visible; rara gives a flat g 1 where its
// crossing point is visible (no band, no classification) and a volumetric one section 5's
// classification and, when cutoff, its mass or length weight on this ray.
float clip_weight(ClipParams clip, vec4 spans, uint g, float t, vec3 e, vec3 d) {
    uvec4 config = clip.config;
    if (config.x == CLIP_MODE_NONE) {
        return 1.0;
    }
    Gaussian gs = trace_gaussian(pc.gaussians, g);
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

// The visible intervals of the ray e + t d under `clip` (clip.glsl).
vec4 ray_spans(ClipParams clip, vec3 e, vec3 d) {
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
    return clip_visible_spans(clip.config.z, span_lo, span_hi);
}

// Gaussian i's hit on the ray e + t d (unit d) with t in [t_lo, t_hi): (t, alpha), alpha 0
// for none (SPEC section 7). `cull`: a camera ray, which skips what section 3 culls.
vec2 gaussian_hit(TraceParams f, uint i, vec3 e, vec3 d, bool cull, float t_lo, float t_hi) {
    Gaussian g = trace_gaussian(pc.gaussians, i);
    vec3 mu = g.pos_opacity.xyz;
    float o = g.pos_opacity.w;
    if (cull && dot(f.forward.xyz, mu - f.eye.xyz) <= 0.2) {
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
        if (!(t > 0.0) || !(t >= t_lo && t < t_hi)) {
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
    if (!(t > 0.0) || !(q <= q_max) || !(t >= t_lo && t < t_hi)) {
        return vec2(0.0);
    }
    return vec2(t, min(0.99, o * exp(-0.5 * q)));
}

// The clip weight of hit (t, Gaussian g) under region `region` of the array at `regions`
// (ClipParams each): an object's own (Renderer::record_objects), or a mixed scene's splat
// object's. The region's visible spans on the ray are found here, once per composited hit.
float region_clip_weight(Address regions, uint region, uint g, float t, vec3 e, vec3 d) {
    ClipParams own = load_clip_params(ClipParamsRef(address_item(regions, region,
                                                                  CLIP_PARAMS_BYTES)));
    return clip_weight(own, ray_spans(own, e, d), g, t, e, d);
}

#ifndef MIXED
// The clip weight of hit (t, Gaussian g): under the frame's clip (`clip`, whose visible
// intervals on this ray are `spans`), or, in a frame of objects with clip regions of their own
// (Renderer::record_objects; TraceParams.objects), under the region of g's object.
float hit_clip_weight(TraceParams f, ClipParams clip, vec4 spans, uint g, float t, vec3 e,
                      vec3 d) {
    Address regions = address_of_words(f.objects.xy);
    if (address_is_null(regions)) {
        return clip_weight(clip, spans, g, t, e, d);
    }
    return region_clip_weight(regions, U32s(address_of_words(f.objects.zw)).v[g], g, t, e, d);
}
#endif

// Composites hit g at t on the ray e + t d, of `alpha` (its clip weight in), by SPEC section
// 4's rule: skipped below 1/255; ends the ray where T would fall below 1e-4; else adds g's
// colour and lowers T. With the depth output, a composited hit of view depth z = t along adds
// alpha T z to `depth.y`, and sets `depth.x` (the median) where 1 - T first reaches 0.5 (SPEC
// sections 9 and 11). With MIXED and `shade`, the colour is darkened where a mesh shadows the
// Gaussian's point on the ray from the lights (section 8); the shadow queries' node visits
// count as steps.
#ifdef MIXED
#define MIXED_PARAMS , MixedParams mixed
#define MIXED_ARGS , mixed
#else
#define MIXED_PARAMS
#define MIXED_ARGS
#endif
void add_hit(TraceParams f, uint g, float alpha, vec3 e, vec3 d, float t, float along,
             inout vec3 colour, inout float T, inout uint flags, inout vec2 depth,
             inout uint steps, bool shade MIXED_PARAMS) {
    if (alpha >= 1.0 / 255.0) {
        float next_t = T * (1.0 - alpha);
        if (next_t < 1e-4) {
            flags |= RAY_DONE | RAY_ENDED;
        } else {
            vec3 mu = trace_gaussian(pc.gaussians, g).pos_opacity.xyz;
            vec3 c = eval_sh(pc.sh, g * f.size.w, normalize(mu - e));
#ifdef MIXED
            if (shade) {
                uint mesh_visits = 0u;
                c = shadow_factor(mixed, e + t * d, mesh_visits) * c;
                steps += mesh_visits;
            }
#endif
            colour += alpha * T * c;
            float z = t * along;
            depth.y += alpha * T * z;
            depth.x = next_t <= 0.5 && isinf(depth.x) ? z : depth.x;
            T = next_t;
        }
    }
}
