// RaRa clipping (SPEC section 5), shared by project (classification, side records) and
// rasterize (per-pixel weights). Host twin: src/clip.rs, which explains the whitened-frame
// maths; keep the two in step.
#ifndef RARA_CLIP_GLSL
#define RARA_CLIP_GLSL

#extension GL_EXT_control_flow_attributes : require
#include "common.glsl"

// The clip region and mode of a frame (GpuClipParams on the host).
struct ClipParams {
    uvec4 config;       // mode, weight, flags, plane count
    vec4 band;          // band, band^2, unused, unused
    vec4 sphere;        // centre xyz, radius
    vec4 planes[MAX_CLIP_PLANES]; // (n, d): visible where n.x + d >= 0
};
layout(buffer_reference, std430, buffer_reference_align = 16) buffer ClipParamsRef { ClipParams p; };

// What a cutoff Gaussian carries (GpuCutoffRecord): rows of M = S^-1 R^T in xyz and
// o' = M (eye - mu) in the three w. A flat Gaussian (one scale 0, SPEC section 6), for which
// M does not exist, carries (n, n.(eye - mu)), (eye - mu, 0) and a zero m2, which marks it
// (M's rows are never zero).
struct CutoffRecord {
    vec4 m0;
    vec4 m1;
    vec4 m2;
};
layout(buffer_reference, std430, buffer_reference_align = 16) buffer CutoffRecords { CutoffRecord v[]; };

// Address of record i (48 bytes each), and the record moved as 16-byte words (load_vec4 in
// common.glsl).
Address cutoff_record_address(CutoffRecords records, uint i) {
    return address_item(Address(records), i, 48u);
}

CutoffRecord load_cutoff_record(CutoffRecords records, uint i) {
    Address a = cutoff_record_address(records, i);
    return CutoffRecord(load_vec4(a), load_vec4(address_plus(a, 16u)),
                        load_vec4(address_plus(a, 32u)));
}

void store_cutoff_record(CutoffRecords records, uint i, CutoffRecord rec) {
    Address a = cutoff_record_address(records, i);
    store_vec4(a, rec.m0);
    store_vec4(address_plus(a, 16u), rec.m1);
    store_vec4(address_plus(a, 32u), rec.m2);
}

// Whether rec is a flat Gaussian's record.
bool cutoff_record_is_flat(CutoffRecord rec) {
    return rec.m2.xyz == vec3(0.0);
}

// The record of a flat Gaussian with unit normal n, at rel = mu - eye.
CutoffRecord flat_cutoff_record(vec3 n, vec3 rel) {
    return CutoffRecord(vec4(n, -dot(n, rel)), vec4(-rel, 0.0), vec4(0.0));
}

// The record of a Gaussian with three nonzero scales s, local axes (the columns of R) c0..c2,
// at rel = mu - eye: M = S^-1 R^T, row k column k of R over s_k, and o' = M (eye - mu) = -M rel.
CutoffRecord volume_cutoff_record(vec3 c0, vec3 c1, vec3 c2, vec3 s, vec3 rel) {
    vec3 w0 = c0 / s.x;
    vec3 w1 = c1 / s.y;
    vec3 w2 = c2 / s.z;
    return CutoffRecord(vec4(w0, -dot(w0, rel)), vec4(w1, -dot(w1, rel)),
                        vec4(w2, -dot(w2, rel)));
}

// The cutoff record of Gaussian g seen from eye: a flat one's (SPEC section 6: the normal is
// the first axis of R whose scale is 0) or a volume one's.
CutoffRecord gaussian_cutoff_record(Gaussian g, vec3 eye) {
    vec3 r0, r1, r2;
    quat_rows(g.rot, r0, r1, r2);
    vec3 c0 = vec3(r0.x, r1.x, r2.x);
    vec3 c1 = vec3(r0.y, r1.y, r2.y);
    vec3 c2 = vec3(r0.z, r1.z, r2.z);
    vec3 s = g.scale.xyz;
    vec3 rel = g.pos_opacity.xyz - eye;
    uint axis = flat_axis(s);
    if (axis < 3u) {
        return flat_cutoff_record(axis == 0u ? c0 : (axis == 1u ? c1 : c2), rel);
    }
    return volume_cutoff_record(c0, c1, c2, s, rel);
}

// Whether a frame may hold flat Gaussians (SPEC section 6), whose cutoff records and weights
// take branches of their own: a specialization constant, false in the rasterize kernels of
// frames without any (FLAT_SPLATS_CONSTANT_ID; stages::rasterize), so that a CPU driver, which
// runs both sides of every branch under a mask, does not run the flat side for volume splats.
layout(constant_id = FLAT_SPLATS_CONSTANT_ID) const bool FLAT_SPLATS = true;

// Below this |n.d| / |d| a ray counts as parallel to a flat Gaussian's plane (SPEC section 6;
// FLAT_PARALLEL_EPSILON in src/clip.rs).
#define FLAT_PARALLEL_EPSILON 1e-7

#define CLASS_DROPPED 0u
#define CLASS_DRAWN 1u
#define CLASS_CUTOFF 2u

// Unbounded end of a ray interval: finite so no inf - inf, far enough that Phi is 0 or 1.
#define UNBOUNDED 1e30

// The whole ClipParams, at constant offsets from `ref`. Call it at the top of main(), before any
// branch or return: Mesa's gallivm then loads each word once per SIMD vector (the address is
// a push constant), where under a mask it runs a scalar loop over the lanes per word.
ClipParams load_clip_params(ClipParamsRef ref) {
    Address a = Address(ref);
    ClipParams c;
    c.config = load_uvec4(a);
    c.band = load_vec4(address_plus(a, 16u));
    c.sphere = load_vec4(address_plus(a, 32u));
    [[unroll]] for (uint k = 0u; k < MAX_CLIP_PLANES; ++k) {
        c.planes[k] = load_vec4(address_plus(a, 48u + 16u * k));
    }
    return c;
}

// How many plane slots clip_signed_distance visits: all of them unless the includer bounds
// them (project's CLIP_PLANE_SLOTS, a specialization constant).
#ifndef CLIP_DISTANCE_PLANE_SLOTS
#define CLIP_DISTANCE_PLANE_SLOTS MAX_CLIP_PLANES
#endif

// Signed distance of a centre to the visible set, positive inside. The planes are all
// visited, the unused ones ignored: a dynamic index would cost a CPU driver a scalar loop
// over the lanes per plane.
float clip_signed_distance(ClipParams clip, vec3 p) {
    uvec4 config = clip.config;
    float s;
    if ((config.z & CLIP_FLAG_SPHERE) != 0u) {
        vec4 sphere = clip.sphere;
        s = sphere.w - length(p - sphere.xyz);
    } else {
        s = UNBOUNDED;
        [[unroll]] for (uint k = 0u; k < CLIP_DISTANCE_PLANE_SLOTS; ++k) {
            vec4 pl = clip.planes[k];
            s = k < config.w ? min(s, dot(pl.xyz, p) + pl.w) : s;
        }
    }
    return (config.z & CLIP_FLAG_INVERT) != 0u ? -s : s;
}

// CLASS_DROPPED, CLASS_DRAWN or CLASS_CUTOFF for a Gaussian with centre mu and standard
// deviations scale.
uint clip_classify(ClipParams clip, vec3 mu, vec3 scale) {
    uvec4 config = clip.config;
    if (config.x == CLIP_MODE_NONE) {
        return CLASS_DRAWN;
    }
    float s = clip_signed_distance(clip, mu);
    if (config.x == CLIP_MODE_HARD) {
        return s >= 0.0 ? CLASS_DRAWN : CLASS_DROPPED;
    }
    float r = clip.band.x * max(scale.x, max(scale.y, scale.z));
    if (s < -r) {
        return CLASS_DROPPED;
    }
    if (s > r && (config.z & CLIP_FLAG_TRACE_ALL) == 0u) {
        return CLASS_DRAWN;
    }
    return CLASS_CUTOFF;
}

// The ray eye + t dir (all real t) is visible where lo <= t <= hi inside the region. dir need
// not be of unit length: the weights depend only on the ray, not on how t is scaled along it.
// The rasterizer works out a strip of rays at once: it starts from the whole line
// (-UNBOUNDED, UNBOUNDED), narrows it by each plane (clip_span_cut_by_plane) or replaces it by
// the sphere's chord (clip_span_in_sphere), and turns the result into the visible intervals
// (clip_visible_spans).

// Narrows (lo, hi) to the part of the ray where pl = (n, d) has n.x + d >= 0.
void clip_span_cut_by_plane(vec4 pl, vec3 eye, vec3 dir, inout float lo, inout float hi) {
    float nd = dot(pl.xyz, dir);
    float ne = dot(pl.xyz, eye) + pl.w;
    if (nd > 0.0) {
        lo = max(lo, -ne / nd);
    } else if (nd < 0.0) {
        hi = min(hi, -ne / nd);
    } else if (ne < 0.0) {
        lo = 0.0;
        hi = 0.0;
    }
}

// The chord (lo, hi) of the ray inside sphere (centre, radius); empty (0, 0) if it misses.
vec2 clip_span_in_sphere(vec4 sphere, vec3 eye, vec3 dir) {
    // |oc + t dir|^2 = r^2; dir need not be of unit length.
    vec3 oc = eye - sphere.xyz;
    float a = dot(dir, dir);
    float b = dot(oc, dir);
    float disc = b * b - a * (dot(oc, oc) - sphere.w * sphere.w);
    if (disc > 0.0) {
        float h = sqrt(disc);
        return vec2((-b - h) / a, (-b + h) / a);
    }
    return vec2(0.0);
}

// The visible part of a ray whose part inside the region is (lo, hi), as two intervals
// (lo0, hi0, lo1, hi1); an unused or empty interval is (0, 0). flags: the region's config.z.
vec4 clip_visible_spans(uint flags, float lo, float hi) {
    bool empty = lo >= hi;
    if ((flags & CLIP_FLAG_INVERT) == 0u) {
        return empty ? vec4(0.0) : vec4(lo, hi, 0.0, 0.0);
    }
    return empty ? vec4(-UNBOUNDED, UNBOUNDED, 0.0, 0.0) : vec4(-UNBOUNDED, lo, hi, UNBOUNDED);
}

// Standard normal CDF: Abramowitz-Stegun 7.1.28 erf on |x| (erfc = 1 / p^16 with a
// polynomial p of degree 6; absolute error under 1e-6 in float), reflected so that
// Phi(x) + Phi(-x) = 1. No exp, which a CPU driver evaluates as a polynomial of its own; p^16
// overflows to infinity, and the tail to 0, where Phi is 0 or 1 in float. Host twin:
// normal_cdf in src/clip.rs. The polynomials here and in end_mass are written as fma: a CPU
// driver keeps `a + b * c` a multiply and an add (gallivm, per pixel and weighted splat).
float normal_cdf(float x) {
    float z = abs(x) * 0.70710678118654752;
    float p = fma(z, fma(z, fma(z, fma(z, fma(z, fma(z, 0.0000430638, 0.0002765672),
                                                     0.0001520143), 0.0092705272),
                                 0.0422820123), 0.0705230784), 1.0);
    p *= p;
    p *= p;
    p *= p;
    p *= p;
    float tail = 0.5 / p;
    return x >= 0.0 ? 1.0 - tail : tail;
}

// A cutoff Gaussian seen along a strip of rays eye + t dir(r), dir(r) = dir0 + r step, in its
// whitened frame: d'(r) = M dir(r) = d0 + r ds, so a(r) = |d'(r)|^2, o'.d'(r) and o' x d'(r)
// are polynomials in r. The rasterizer works them out once per splat for its strip of pixels
// instead of a 3x3 product per pixel; a single ray is the strip's r = 0. src/clip.rs
// (CutoffRay::weight) computes the same per ray: t* = -(o'.d')/a.
//
// A flat Gaussian's strip (is_flat = true) holds instead what its plane crossing needs:
// n.d(r) = a.x + r a.y, n.(eye - mu) = od.x, d(r).(eye - mu) = c0.x + r c0.y and
// |d(r)|^2 = c1.x + r (c1.y + r c1.z) (flat_hit_t).
struct WhitenedStrip {
    vec3 a;     // a(r) = a.x + r (a.y + r a.z)
    vec2 od;    // o'.d'(r) = od.x + r od.y
    vec3 c0;    // o' x d'(r) = c0 + r c1 (the length weight only)
    vec3 c1;
    bool is_flat;
};

WhitenedStrip whitened_strip(CutoffRecord rec, vec3 dir0, vec3 step) {
    if (FLAT_SPLATS && cutoff_record_is_flat(rec)) {
        vec3 n = rec.m0.xyz;
        vec3 eo = rec.m1.xyz;
        return WhitenedStrip(vec3(dot(n, dir0), dot(n, step), 0.0), vec2(rec.m0.w, 0.0),
                             vec3(dot(dir0, eo), dot(step, eo), 0.0),
                             vec3(dot(dir0, dir0), 2.0 * dot(dir0, step), dot(step, step)),
                             true);
    }
    vec3 d0 = vec3(dot(rec.m0.xyz, dir0), dot(rec.m1.xyz, dir0), dot(rec.m2.xyz, dir0));
    vec3 ds = vec3(dot(rec.m0.xyz, step), dot(rec.m1.xyz, step), dot(rec.m2.xyz, step));
    vec3 o = vec3(rec.m0.w, rec.m1.w, rec.m2.w);
    WhitenedStrip s;
    s.a = vec3(dot(d0, d0), 2.0 * dot(d0, ds), dot(ds, ds));
    s.od = vec2(dot(o, d0), dot(o, ds));
    s.c0 = cross(o, d0);
    s.c1 = cross(o, ds);
    s.is_flat = false;
    return s;
}

// Where ray r of a flat Gaussian's strip s meets its plane, t_hit = n.(mu - eye) / n.d, or
// for a ray parallel to it the closest approach to mu, d.(mu - eye) / |d|^2 (SPEC section 6).
float flat_hit_t(WhitenedStrip s, float r) {
    float nd = s.a.x + r * s.a.y;
    float dd = s.c1.x + r * (s.c1.y + r * s.c1.z);
    return abs(nd) >= FLAT_PARALLEL_EPSILON * sqrt(dd) ? -s.od.x / nd
                                                       : -(s.c0.x + r * s.c0.y) / dd;
}

// a(r) = |d'(r)|^2 on ray r of the strip s.
float strip_a(WhitenedStrip s, float r) {
    return fma(r, fma(r, s.a.z, s.a.y), s.a.x);
}

// o'.d'(r) on ray r of the strip s.
float strip_od(WhitenedStrip s, float r) {
    return fma(r, s.od.y, s.od.x);
}

// Weight `mass`: the probability mass of the Gaussian along the ray that lies in the visible
// intervals. The density along the ray is N(t*, 1/a); an interval (lo, hi) holds
// Phi(u(hi)) - Phi(u(lo)) of it, with u(t) = (t - t*) sqrt(a) = (t a + o'.d') / sqrt(a). Since
// -Phi(x) = Phi(-x) - 1, the visible mass is `base` plus Phi(sign u(t)) over the visible set's
// bounded ends t, sign +1 for an upper end and -1 for a lower one; `base` counts 1 for every
// unbounded upper end and -1 for every bounded lower end. A ray has at most two bounded ends
// (one interval has two; an inverted region's outer ends are unbounded). An end a ray does not
// have is (-UNBOUNDED, +1), whose Phi is 0 to within 1e-23. On a CPU driver, where both sides of
// a branch cost, this evaluates Phi as often as the strip has bounded ends (once for a plane)
// rather than twice per interval.
struct MassEnds {
    vec4 ends;      // (t0, sign0, t1, sign1)
    float base;
    uint count;     // bounded ends, 0 to 2
};

// Adds end = (t, sign) to m.
void mass_add_end(inout MassEnds m, vec2 end) {
    m.ends = m.count == 0u ? vec4(end, m.ends.zw) : vec4(m.ends.xy, end);
    m.count += 1u;
}

// Adds the visible interval span = (lo, hi) to m; an empty one adds nothing.
void mass_add_span(inout MassEnds m, vec2 span) {
    if (span.x >= span.y) {
        return;
    }
    if (span.y >= UNBOUNDED) {
        m.base += 1.0;
    } else {
        mass_add_end(m, vec2(span.y, 1.0));
    }
    if (span.x > -UNBOUNDED) {
        m.base -= 1.0;
        mass_add_end(m, vec2(span.x, -1.0));
    }
}

// The ends of the visible intervals spans (clip_visible_spans) for the mass weight.
MassEnds clip_mass_ends(vec4 spans) {
    MassEnds m;
    m.ends = vec4(-UNBOUNDED, 1.0, -UNBOUNDED, 1.0);
    m.base = 0.0;
    m.count = 0u;
    mass_add_span(m, spans.xy);
    mass_add_span(m, spans.zw);
    return m;
}

// Phi(sign u(t)) of end = (t, sign) on ray r of the strip s (see MassEnds).
// A flat Gaussian is a point mass at flat_hit_t: its Phi is a step, so the sum over the ends
// is 1 where that point is visible and 0 elsewhere.
float end_mass(WhitenedStrip s, float r, vec2 end) {
    if (FLAT_SPLATS && s.is_flat) {
        return end.y * (end.x - flat_hit_t(s, r)) >= 0.0 ? 1.0 : 0.0;
    }
    float a = strip_a(s, r);
    float od = strip_od(s, r);
    return normal_cdf(end.y * fma(end.x, a, od) / sqrt(a));
}

// Weight `length` on ray r of the strip s: the visible fraction of the chord through the band
// ellipsoid (q <= band2); for a ray that misses it, whether the ray's closest point is visible.
// A flat Gaussian's weight is whether its point on the ray (flat_hit_t) is visible.
float cutoff_weight_length(WhitenedStrip s, float r, vec4 spans, float band2) {
    float t_star;
    bool on_chord = false;
    float a = strip_a(s, r);
    vec3 c = s.c0 + r * s.c1;
    if (FLAT_SPLATS && s.is_flat) {
        t_star = flat_hit_t(s, r);
    } else {
        t_star = -strip_od(s, r) / a;
        on_chord = dot(c, c) / a < band2;
    }
    if (!on_chord) {
        bool seen = (spans.x <= t_star && t_star <= spans.y && spans.x < spans.y)
                 || (spans.z <= t_star && t_star <= spans.w && spans.z < spans.w);
        return seen ? 1.0 : 0.0;
    }
    float q_min = dot(c, c) / a;
    float half_chord = sqrt((band2 - q_min) / a);
    float t1 = t_star - half_chord;
    float t2 = t_star + half_chord;
    float inside = max(min(t2, spans.y) - max(t1, spans.x), 0.0)
                 + max(min(t2, spans.w) - max(t1, spans.z), 0.0);
    return clamp(inside / (t2 - t1), 0.0, 1.0);
}

// Per-tile classes of a cutoff splat's pairs (cutoff_tiles). Across one 16x16 tile a cutoff
// splat is often drawn with weight 1 at every pixel, or adds nothing at any (plant at 640x480:
// 23-47 % and 24-41 % of its cutoff pairs), yet the rasterizer pays the per-pixel weight for
// every pixel of every cutoff pair. This stage therefore bounds the weight over the tile's rays and
// the splat's alpha over the tile's pixels: a FULL pair is drawn as a plain splat (its value
// loses PAIR_WEIGHTED), an EMPTY pair leaves every tile list (its key is the tile count,
// which sorts after every tile), and only a PARTIAL pair takes the weight path.
#define TILE_CLASS_PARTIAL 0u
#define TILE_CLASS_FULL 1u
#define TILE_CLASS_EMPTY 2u

// Plane k of the region at `clip`. The texel kernels (SPLAT_TEXELS: CPU drivers) fetch it from
// the frame's texel views, a gather, where a load through the region's address in a branch or
// after an early return is a scalar loop over the lanes per word; the region is then the
// frame's one (frame_texels.glsl), which every caller with SPLAT_TEXELS has.
#ifdef SPLAT_TEXELS
vec4 texel_clip_plane(uint k);  // frame_texels.glsl, which the texel kernels include
#endif
vec4 region_plane(ClipParamsRef clip, uint k) {
#ifdef SPLAT_TEXELS
    return texel_clip_plane(k);
#else
    return clip.p.planes[k];
#endif
}

// A FULL pair's alpha differs from the weighted one by at most this at any pixel (128x below
// the 8-bit output's half step, and far below the weight's own 1/255 skip threshold).
#define TILE_FULL_TOLERANCE (1.0 / 65536.0)

// Bounds (u_lo, u_hi) over the rays eye + t dir of a tile, dir in the convex hull of the four
// corner rays dirs[k] (in order around the tile), of the argument u of the mass a half-space
// pl = (n, d) leaves visible, Phi(u) (see clip_mass_ends: for one plane the visible mass is
// Phi(u) with u = (t* - t_p) sqrt(a) sign(n.dir)). (-UNBOUNDED, UNBOUNDED) when the plane is
// seen edge-on within the tile.
//
// u does not depend on the scale of dir, so each ray is scaled to n.dir = 1; in the Gaussian's
// whitened frame its direction is then q = M dir, on the plane m.q = 1 with m = M^-T n, and
// with h = n.eye + d (t_p = -h):
//   u(q) = (h |q|^2 - o'.q) / |q|.
// The tile's rays fill the convex quadrilateral spanned by the corners' q. The numerator is a
// quadratic with the isotropic Hessian 2h I: its bound on one side is exact at a corner, and
// on the other comes from its tangent plane at the corners' centroid (below). The division by
// |q| is bounded by |q| <= the largest corner's |q| (|q| is convex) and |q| >= 1/|m| (the
// plane's distance from the origin); slack (below) covers rounding.
// The tangent plane took the place of the exact extremes (each edge's stationary point and the
// plane's, with a test of whether that lies inside): lavapipe, biker 1280x960 under a plane,
// one thread, cutoff tiles 4.5-5.2 -> 3.8-4.1 ms, with 0.7 % more partial pairs (14,619 ->
// 14,723 of 56,664) and the same image.
vec2 tile_plane_u_range(CutoffRecord rec, vec4 pl, vec3 eye, vec3 dirs[4]) {
    vec3 o = vec3(rec.m0.w, rec.m1.w, rec.m2.w);
    float h = dot(pl.xyz, eye) + pl.w;
    vec3 q[4];
    float nd_lo = UNBOUNDED;
    float nd_hi = -UNBOUNDED;
    for (uint k = 0u; k < 4u; ++k) {
        float nd = dot(pl.xyz, dirs[k]);
        nd_lo = min(nd_lo, nd);
        nd_hi = max(nd_hi, nd);
        vec3 d = dirs[k] / nd;
        q[k] = vec3(dot(rec.m0.xyz, d), dot(rec.m1.xyz, d), dot(rec.m2.xyz, d));
    }
    if (!(nd_lo > 0.0 || nd_hi < 0.0)) {
        return vec2(-UNBOUNDED, UNBOUNDED);
    }
    // With c the corners' centroid, f(q) = f(c) + g.(q - c) + h |q - c|^2 exactly, where
    // g = 2h c - o'. Over the quadrilateral the linear part is extreme at a corner and the last
    // term only raises f (h > 0) or lowers it (h < 0): so the corners give f's exact maximum
    // for h >= 0 (a convex function peaks at a vertex) and its exact minimum for h <= 0, and
    // the linear part bounds the other side, loose by at most |h| max |q - c|^2.
    vec3 c = 0.25 * (q[0] + q[1] + q[2] + q[3]);
    vec3 g = 2.0 * h * c - o;
    float f_c = h * dot(c, c) - dot(o, c);
    float corner_lo = UNBOUNDED;
    float corner_hi = -UNBOUNDED;
    float linear_lo = UNBOUNDED;
    float linear_hi = -UNBOUNDED;
    float qq_hi = 0.0;
    for (uint k = 0u; k < 4u; ++k) {
        float aa = dot(q[k], q[k]);
        float f_k = h * aa - dot(o, q[k]);
        float linear = dot(g, q[k] - c);
        corner_lo = min(corner_lo, f_k);
        corner_hi = max(corner_hi, f_k);
        linear_lo = min(linear_lo, linear);
        linear_hi = max(linear_hi, linear);
        qq_hi = max(qq_hi, aa);
    }
    float f_lo = h >= 0.0 ? f_c + linear_lo : corner_lo;
    float f_hi = h >= 0.0 ? corner_hi : f_c + linear_hi;
    // m = M^-T n = S R^T n: with rows M_j = (R^T)_j / s_j, m_j = (M_j . n) / |M_j|^2.
    vec3 m = vec3(dot(rec.m0.xyz, pl.xyz) / dot(rec.m0.xyz, rec.m0.xyz),
                  dot(rec.m1.xyz, pl.xyz) / dot(rec.m1.xyz, rec.m1.xyz),
                  dot(rec.m2.xyz, pl.xyz) / dot(rec.m2.xyz, rec.m2.xyz));
    float mm = dot(m, m);
    float q_lo = inversesqrt(mm);
    float q_hi = sqrt(qq_hi);
    // f is a difference of terms up to |h| |q|^2 and |o'| |q|: allow for their rounding, here
    // and in the rasterizer's own per-pixel u.
    float slack = 1e-6 * (abs(h) * qq_hi + length(o) * q_hi) / q_lo;
    return vec2(f_lo / (f_lo >= 0.0 ? q_hi : q_lo) - slack,
                f_hi / (f_hi >= 0.0 ? q_lo : q_hi) + slack);
}

// The eigenvalues (smaller, larger) of the symmetric 2x2 matrix [[s.x, s.y], [s.y, s.z]].
vec2 symmetric2_eigenvalues(vec3 s) {
    float mid = 0.5 * (s.x + s.z);
    float rad = sqrt(0.25 * (s.x - s.z) * (s.x - s.z) + s.y * s.y);
    return vec2(mid - rad, mid + rad);
}

// Bounds (u_lo, u_hi) of tile_plane_u_range's u over the rays through the splat's footprint
// ellipse, (p - uv)^T K (p - uv) <= q_max for the conic K, rather than a box of them: the
// box's corners lie outside the ellipse, and the weight there often differs from the weight
// anywhere the splat draws. For a ray d(p) (not normalised; affine in the pixel p),
// u = N / (|n.d| sqrt(a)) with N = h a - (n.d) (o'.d'), a = |d'|^2, d' = M d(p). With
// p = uv + L v over the unit disc (L L^T = q_max K^-1), d' = d'_c + W v, so n.d and o'.d' are
// affine in v and a and N quadratics: each is bounded by its centre value, plus or minus its
// gradient's length, plus its 2x2 Hessian's extreme eigenvalues, and u by interval division.
// dir_c is the ray through uv, across and down the rays' steps per pixel in x and y.
// Counted exactly on plant at 1280x960 under a plane, 32 % of the pairs the box's bounds left
// partial add nothing to any pixel or see weight 1 wherever they draw; this bound, taken with
// the box's, turns a tenth of them plain or empty (27,661 -> 24,918 partial pairs; biker
// 14,731 -> 13,441, playbot 23,748 -> 22,339), the same images. It depends on the splat
// only, so cutoff_records works it out once per record.
vec2 ellipse_plane_u_range(CutoffRecord rec, vec4 pl, vec3 eye, vec3 dir_c, vec3 across,
                           vec3 down, vec3 conic, float q_max) {
    float det = conic.x * conic.z - conic.y * conic.y;
    float q = max(q_max, 0.0);
    // L (lower triangular) of q K^-1 = q / det [[C, -B], [-B, A]].
    float l11 = sqrt(q * conic.z / det);
    float l21 = -q * conic.y / (det * l11);
    float l22 = sqrt(q / conic.z);
    mat3 m = transpose(mat3(rec.m0.xyz, rec.m1.xyz, rec.m2.xyz));   // rows m0, m1, m2
    vec3 o = vec3(rec.m0.w, rec.m1.w, rec.m2.w);
    // The ray's change along the disc's two axes: d(uv + L v) = dir_c + v.x step1 + v.y step2.
    vec3 step1 = l11 * across + l21 * down;
    vec3 step2 = l22 * down;
    vec3 dc = m * dir_c;
    vec3 w1 = m * step1;
    vec3 w2 = m * step2;
    vec3 n = pl.xyz;
    float h = dot(n, eye) + pl.w;
    // n.d = nd_c + e.v
    float nd_c = dot(n, dir_c);
    vec2 e = vec2(dot(n, step1), dot(n, step2));
    float e_len = length(e);
    float nd_lo = nd_c - e_len;
    float nd_hi = nd_c + e_len;
    if (!(nd_lo > 0.0 || nd_hi < 0.0)) {
        return vec2(-UNBOUNDED, UNBOUNDED);
    }
    float and_lo = min(abs(nd_lo), abs(nd_hi));
    float and_hi = max(abs(nd_lo), abs(nd_hi));
    // o'.d' = od_c + k.v; a = a_c + 2 g_a.v + v^T G v.
    float od_c = dot(o, dc);
    vec2 k = vec2(dot(o, w1), dot(o, w2));
    float a_c = dot(dc, dc);
    vec2 g_a = vec2(dot(w1, dc), dot(w2, dc));
    vec3 gram = vec3(dot(w1, w1), dot(w1, w2), dot(w2, w2));   // G = [[x, y], [y, z]]
    // |d'| within |d'_c| +- the largest singular value of W.
    float sigma = sqrt(max(symmetric2_eigenvalues(gram).y, 0.0));
    float len_c = sqrt(a_c);
    float sa_lo = max(len_c - sigma, 0.0);
    float sa_hi = len_c + sigma;
    // N = h a - nd od = N_c + g.v + v^T H v.
    float n_c = h * a_c - nd_c * od_c;
    vec2 g = 2.0 * h * g_a - nd_c * k - od_c * e;
    vec2 h_eigen = symmetric2_eigenvalues(
        h * gram - vec3(e.x * k.x, 0.5 * (e.x * k.y + e.y * k.x), e.y * k.y));
    float g_len = length(g);
    float n_lo = n_c - g_len + min(h_eigen.x, 0.0);
    float n_hi = n_c + g_len + max(h_eigen.y, 0.0);
    float den_lo = and_lo * sa_lo;
    float den_hi = and_hi * sa_hi;
    if (!(den_hi > 0.0)) {  // no direction to speak of (a degenerate record): no bound
        return vec2(-UNBOUNDED, UNBOUNDED);
    }
    // Rounding: N is a difference of terms up to |h| a and |nd| |o'.d'|, worked out here and
    // per pixel by the rasterizer.
    float od_hi = abs(od_c) + length(k);
    float slack_n = 1e-5 * (abs(h) * sa_hi * sa_hi + and_hi * od_hi);
    n_lo -= slack_n;
    n_hi += slack_n;
    float u_lo = n_lo >= 0.0 ? n_lo / den_hi : (den_lo > 0.0 ? n_lo / den_lo : -UNBOUNDED);
    float u_hi = n_hi <= 0.0 ? n_hi / den_hi : (den_lo > 0.0 ? n_hi / den_lo : UNBOUNDED);
    return vec2(u_lo, u_hi);
}

// Bounds over a tile's rays of the mass a cutoff splat keeps, gathered plane by plane from
// tile_plane_u_range. Along any ray the mass inside the intersection K of the half-spaces is
// at most that of each half-space, min_k Phi(u_hi,k), and the mass outside K at most the sum
// of the masses outside each, sum_k Phi(-u_lo,k).
struct TileMassBounds {
    float u_keep;   // min_k u_hi,k
    float lost;     // sum_k Phi(-u_lo,k)
};

TileMassBounds tile_mass_bounds_none() {
    return TileMassBounds(UNBOUNDED, 0.0);
}

// Adds a plane's bounds u = (u_lo, u_hi) (tile_plane_u_range).
void tile_mass_bounds_add(inout TileMassBounds b, vec2 u) {
    b.u_keep = min(b.u_keep, u.y);
    b.lost += normal_cdf(-u.x);
}

// The bounds of cutoff splat p (record rec) over its whole footprint ellipse, plane by plane
// of the `planes` of `clip` (ellipse_plane_u_range). They depend on the splat only, so each
// splat's are worked out once a frame: by cutoff_records_body.glsl on CPU drivers, by the
// cutoff-tiles kernels on GPUs (where project writes the records and the frame has no
// records' pass). A flat splat's classes do not use them: none.
// `planes` is clip's config.w, loaded by the caller at the top of its main(): on lavapipe,
// that word loaded here gave wrong bounds in the balanced cutoff-tiles kernel, whose lanes
// each bound another splat there (with or without a branch around the call, before or after
// its barriers; its classes then drew plain pairs that a box's other planes cut), and right
// ones in the same kernel's pair loop and in the records' pass. Not understood; loaded at the
// top, every case of cutoff_tile_classes_change_no_pixel agrees across the layouts.
// The planes come through region_plane: in the records' pass on CPU drivers a load through
// `clip` after the caller's early return was a scalar loop over the lanes per word (lavapipe,
// plant 640x480, `bench --modes rara`, seven rounds in turn: the records' pass 0.9 -> 0.7 ms
// with the texel fetch, medians).
TileMassBounds footprint_mass_bounds(FrameParams f, ClipParamsRef clip, uint planes,
                                     CutoffRecord rec, ProjectedSplat p) {
    TileMassBounds bounds = tile_mass_bounds_none();
    if (cutoff_record_is_flat(rec)) {
        return bounds;
    }
    vec3 dir_c = pixel_ray(f, p.uv);
    float q_max = footprint_q_max(p.opacity);
    for (uint k = 0u; k < planes; ++k) {
        tile_mass_bounds_add(bounds,
                             ellipse_plane_u_range(rec, region_plane(clip, k), f.cam_pos.xyz,
                                                   dir_c, pixel_ray_across(f),
                                                   pixel_ray_down(f), p.conic, q_max));
    }
    return bounds;
}

// TILE_CLASS_* of a cutoff splat's pair with a tile, from the bounds over every plane of the
// region (flags: ClipParams.config.z; an inverted region swaps inside and outside);
// peak_alpha bounds o exp(power) over the tile's pixels.
uint cutoff_tile_class(uint flags, TileMassBounds b, float peak_alpha) {
    float inside_max = normal_cdf(b.u_keep);
    float outside_max = min(b.lost, 1.0);
    bool invert = (flags & CLIP_FLAG_INVERT) != 0u;
    float weight_max = invert ? outside_max : inside_max;
    float deficit_max = invert ? inside_max : outside_max;
    // The rasterizer skips alpha w < 1/255; a 1 % margin covers rounding.
    if (peak_alpha * weight_max < 0.99 / 255.0) {
        return TILE_CLASS_EMPTY;
    }
    if (peak_alpha * deficit_max <= TILE_FULL_TOLERANCE) {
        return TILE_CLASS_FULL;
    }
    return TILE_CLASS_PARTIAL;
}

// The class of every pair of cutoff splat p (record rec) at once, from its bounds over the
// whole footprint ellipse (footprint_mass_bounds) and its opacity, which bounds its alpha
// everywhere; TILE_CLASS_PARTIAL leaves each pair to its tile. A pair's own bounds are the
// tighter of the ellipse's and its tile's, and its peak alpha at most the opacity, so a pair of
// a splat decided whole would take the same class in its tile, or else empty there (alpha
// below 1/255, or no pixel centre in its box), which a plain pair draws as nothing too. A flat
// splat's ellipse bounds are none: left to the tiles (flat_tile_class).
uint cutoff_splat_class(uint flags, CutoffRecord rec, TileMassBounds ellipse, float opacity) {
    if (cutoff_record_is_flat(rec)) {
        return TILE_CLASS_PARTIAL;
    }
    return cutoff_tile_class(flags, ellipse, opacity);
}

// The `lost` of a cutoff record's stored ellipse bounds (cutoff_records_body.glsl) whose splat was
// decided whole (CUTOFF_WHOLE_*): emit wrote no pair range for it, and cutoff_tiles passes it
// by. A mass lost is never negative.
#define CUTOFF_BOUNDS_DECIDED -1.0

#endif
