// Mixed scenes (SPEC section 8, issue 33), shared by the ray tree's kernel (mixed_spawn.comp)
// and the ray tracer's MIXED variants (trace_body.glsl): the scene's parameters, the triangles
// and their BVH, the watertight ray-triangle test and the lights. Host twins:
// src/mixed/triangles.rs (the same BVH, built on the host, and the same test in f64) and
// src/reference/mixed.rs.
#ifndef RARA_MIXED_COMMON_GLSL
#define RARA_MIXED_COMMON_GLSL

#include "common.glsl"
#include "clip.glsl"

#define MATERIAL_DIFFUSE 0u
#define MATERIAL_MIRROR 1u
#define MATERIAL_GLASS 2u
#define MESH_LEAF_BIT 0x80000000u
#define NO_TRIANGLE 0xffffffffu
// Where a secondary ray's meshes start beyond its origin point.
#define SECONDARY_OFFSET 1e-4

// The flags of a ray the tracer runs (MixedRay.info.x).
#define MIXED_RAY_NONE 1u    // no ray this generation: the pixel keeps its start state
#define MIXED_RAY_CULL 2u    // drops what section 3 culls (camera rays)
#define MIXED_RAY_SHADOW 4u  // a shadow ray: no colour, no mesh shadows

// A BVH node (GpuMeshNode): inner (a, b) = children; leaf a = first | MESH_LEAF_BIT, b = count.
struct MeshNode {
    vec3 lo;
    uint a;
    vec3 hi;
    uint b;
};
layout(buffer_reference, std430, buffer_reference_align = 16) readonly buffer MeshNodes { MeshNode v[]; };

// A triangle as the intersection test reads it (GpuTriangle): its vertices, w unused.
struct MeshTriangle {
    vec4 v0;
    vec4 v1;
    vec4 v2;
};
layout(buffer_reference, std430, buffer_reference_align = 16) readonly buffer MeshTriangles { MeshTriangle v[]; };

// What a hit on a triangle is shaded with (GpuShading), apart from MeshTriangle so that BVH
// walks load only the vertices: vertex normals with u0, v0, u1 in their w; then (v1, u2, v2,
// the material's index as float bits).
struct MeshShading {
    vec4 n0;
    vec4 n1;
    vec4 n2;
    vec4 rest;
};
layout(buffer_reference, std430, buffer_reference_align = 16) readonly buffer MeshShadings { MeshShading v[]; };

// A material (GpuMaterial, src/mixed/material.rs): colour rgb (diffuse albedo, mirror
// reflectance) and the surface (MATERIAL_*) in w; emission rgb and glass's IOR in w; the
// base colour texture: first texel (NO_TEXTURE: none), width, height, wraps (u | v << 2).
struct MeshMaterial {
    vec4 colour;
    vec4 emission;
    uvec4 texture;
};
layout(buffer_reference, std430, buffer_reference_align = 16) readonly buffer MeshMaterials { MeshMaterial v[]; };
#define NO_TEXTURE 0xffffffffu
#define WRAP_REPEAT 0u
#define WRAP_CLAMP 1u
#define WRAP_MIRRORED 2u

// The scene (GpuMixedParams).
struct MixedParams {
    uvec4 counts;       // triangles, mesh nodes, lights, splat objects
    vec4 ambient;       // rgb, shadow strength
    vec4 background;    // rgb, max depth
    uvec4 objects;      // address (lo, hi) of the splat objects' first Gaussians, a word
                        // each in order (a buffer of their own: every invocation loads these
                        // parameters whole), unused, unused
    vec4 light_at[MIXED_MAX_LIGHTS];        // point: position, w 0; directional: travel direction, w 1
    vec4 light_intensity[MIXED_MAX_LIGHTS]; // rgb
    uvec4 refs;         // addresses (lo, hi): triangles, nodes
    uvec4 refs2;        // addresses (lo, hi): the rays of this generation (MixedRay), the clips
    uvec4 occluders;    // addresses (lo, hi): the opaque triangles alone, their nodes
    uvec4 occluder_counts;  // the opaque triangles, their nodes
    uvec4 lists;        // per tracer batch, this generation's rays: address (lo, hi), the
                        // batch's rays (the list's stride), unused
    uvec4 surfaces;     // addresses (lo, hi): the triangles' MeshShading, the MeshMaterials
    uvec4 texels;       // address (lo, hi) of every texture's RGBA8 texels, materials, unused
};
layout(buffer_reference, std430, buffer_reference_align = 16) readonly buffer MixedParamsRef { MixedParams p; };

Address mixed_address(uvec2 lo_hi) {
    return address_of_words(lo_hi);
}

// The axis of v's largest component, the first on a tie (largest_axis in triangles.rs).
uint largest_axis(vec3 v) {
    return (v.x >= v.y && v.x >= v.z) ? 0u : (v.y >= v.z ? 1u : 2u);
}

// 1 / d with no infinite component (0 * inf in a slab test is NaN).
vec3 safe_inverse(vec3 d) {
    return 1.0 / (sign(d) * max(abs(d), vec3(1e-20)) + vec3(equal(d, vec3(0.0))) * 1e-20);
}

// Woop, Benthin and Wald (2013): the ray o + t d against triangle (v0, v1, v2), t in
// (t_lo, t_hi). Returns (t, barycentric weights of v0, v1, v2 in yzw), t = -1 for none. Every
// edge function is formed in the ray's sheared frame from the same operands by the two
// triangles that share the edge, so a ray through it hits at least one (no crack).
vec4 triangle_hit(vec3 o, vec3 d, vec3 v0, vec3 v1, vec3 v2, float t_lo, float t_hi) {
    uint kz = largest_axis(abs(d));
    uint kx = (kz + 1u) % 3u;
    uint ky = (kx + 1u) % 3u;
    if (d[kz] < 0.0) {
        uint k = kx;
        kx = ky;
        ky = k;
    }
    float sx = d[kx] / d[kz];
    float sy = d[ky] / d[kz];
    float sz = 1.0 / d[kz];
    vec3 a = v0 - o;
    vec3 b = v1 - o;
    vec3 c = v2 - o;
    float ax = a[kx] - sx * a[kz];
    float ay = a[ky] - sy * a[kz];
    float bx = b[kx] - sx * b[kz];
    float by = b[ky] - sy * b[kz];
    float cx = c[kx] - sx * c[kz];
    float cy = c[ky] - sy * c[kz];
    float u = cx * by - cy * bx;
    float v = ax * cy - ay * cx;
    float w = bx * ay - by * ax;
    if ((u < 0.0 || v < 0.0 || w < 0.0) && (u > 0.0 || v > 0.0 || w > 0.0)) {
        return vec4(-1.0);
    }
    float det = u + v + w;
    if (det == 0.0) {
        return vec4(-1.0);
    }
    float t = (u * sz * a[kz] + v * sz * b[kz] + w * sz * c[kz]) / det;
    if (!(t > t_lo && t < t_hi)) {
        return vec4(-1.0);
    }
    return vec4(t, vec3(u, v, w) / det);
}

// The nearest triangle on o + t d with t in (t_lo, t_hi) (ties: the lower index), or with
// `any_opaque` whether a diffuse or mirror one lies there (glass lets shadow rays through:
// those queries walk the occluders' BVH, which holds the opaque triangles alone). Returns the
// triangle (NO_TRIANGLE for none; an index into the occluders with `any_opaque`) and its (t,
// barycentrics) in `hit`; counts the nodes visited into `visits` (the caller's loop budget).
uint mesh_hit(MixedParams m, vec3 o, vec3 d, float t_lo, float t_hi, bool any_opaque,
              out vec4 hit, inout uint visits) {
    hit = vec4(-1.0);
    uint best = NO_TRIANGLE;
    if ((any_opaque ? m.occluder_counts.x : m.counts.x) == 0u) {
        return best;
    }
    MeshNodes nodes = MeshNodes(mixed_address(any_opaque ? m.occluders.zw : m.refs.zw));
    MeshTriangles tris = MeshTriangles(mixed_address(any_opaque ? m.occluders.xy : m.refs.xy));
    vec3 inv = safe_inverse(d);
    uint stack[MIXED_MESH_STACK];
    uint sp = 1u;
    stack[0] = 0u;
    float limit = t_hi;
    while (sp > 0u) {
        ++visits;
        MeshNode node = nodes.v[stack[--sp]];
        vec3 a0 = (node.lo - o) * inv;
        vec3 a1 = (node.hi - o) * inv;
        vec3 tmin = min(a0, a1);
        vec3 tmax = max(a0, a1);
        float t_in = max(tmin.x, max(tmin.y, tmin.z));
        float t_out = min(tmax.x, min(tmax.y, tmax.z));
        float slack = 1e-4 * (1.0 + abs(t_out));
        if (!(t_in <= t_out + slack && t_out + slack > t_lo && t_in - slack < limit)) {
            continue;
        }
        if ((node.a & MESH_LEAF_BIT) != 0u) {
            uint first = node.a & ~MESH_LEAF_BIT;
            for (uint k = first; k < first + node.b; ++k) {
                MeshTriangle tri = tris.v[k];
                vec4 h = triangle_hit(o, d, tri.v0.xyz, tri.v1.xyz, tri.v2.xyz, t_lo, t_hi);
                if (h.x >= 0.0 && (best == NO_TRIANGLE || h.x < limit || (h.x == hit.x && k < best))) {
                    best = k;
                    hit = h;
                    limit = h.x;
                    if (any_opaque) {
                        return best;
                    }
                }
            }
        } else if (sp + 2u <= uint(MIXED_MESH_STACK)) {
            stack[sp++] = node.b;
            stack[sp++] = node.a;
        }
    }
    return best;
}

// Toward light l from p: the unit direction, the distance (UNBOUNDED for a directional
// light) and the light arriving unshadowed (intensity over the squared distance).
void toward_light(MixedParams m, uint l, vec3 p, out vec3 dir, out float dist, out vec3 light) {
    vec4 at = m.light_at[l];
    if (at.w == 0.0) {
        vec3 v = at.xyz - p;
        dist = length(v);
        dir = v / dist;
        light = m.light_intensity[l].rgb / (dist * dist);
    } else {
        dir = -at.xyz;
        dist = UNBOUNDED;
        light = m.light_intensity[l].rgb;
    }
}

// A Gaussian's shadow factor at p (section 8): per light 1 - strength (1 - T_mesh), T_mesh 0
// when an opaque mesh lies between p and the light; their mean. 1 without lights or meshes.
float shadow_factor(MixedParams m, vec3 p, inout uint visits) {
    if (m.counts.z == 0u || m.occluder_counts.x == 0u) {
        return 1.0;
    }
    float sum = 0.0;
    for (uint l = 0u; l < m.counts.z; ++l) {
        vec3 dir;
        float dist;
        vec3 light;
        toward_light(m, l, p, dir, dist, light);
        vec4 h;
        bool blocked = mesh_hit(m, p, dir, SECONDARY_OFFSET, dist, true, h, visits) != NO_TRIANGLE;
        sum += 1.0 - m.ambient.w * (blocked ? 1.0 : 0.0);
    }
    return sum / float(m.counts.z);
}

// The splat object Gaussian g belongs to: the last whose first Gaussian is at most g (the
// firsts do not decrease; an empty object shares its successor's), found in halves.
uint object_of(MixedParams m, uint g) {
    U32s firsts = U32s(mixed_address(m.objects.xy));
    uint lo = 0u;           // firsts[lo] <= g (object 0 starts at Gaussian 0)
    uint hi = m.counts.w;   // every object from hi on starts past g
    while (hi - lo > 1u) {
        uint mid = (lo + hi) / 2u;
        if (firsts.v[mid] <= g) {
            lo = mid;
        } else {
            hi = mid;
        }
    }
    return lo;
}

#endif
