#version 460
// Mixed scenes (SPEC section 8, issue 33): one generation of every pixel's ray tree. A pixel
// walks its tree depth first, one ray per generation: this kernel takes in what the ray
// tracer (trace_body.glsl, MIXED) made of the pixel's last ray, shades that ray's mesh hit
// (diffuse: ambient and a shadow ray per light; mirror and glass: child rays onto the pixel's
// stack), pops the next ray, finds its nearest mesh hit (or, for a shadow ray, whether an
// opaque mesh blocks it), and writes it for the tracer: its Gaussians up to the mesh, starting
// from the pixel's colour so far with its weight as transmittance. CPU twin:
// src/reference/mixed.rs, which states the rules this follows.
//
// No invocation waits on another; a generation is one dispatch. The host runs generations
// until no pixel has a ray left (the count in counters[MIXED_COUNTER_LIVE]).
#include "common.glsl"
#include "mixed_common.glsl"

layout(local_size_x = LINEAR_WORKGROUP) in;

// The camera: the first words of the tracer's TraceParams (GpuTraceParams).
struct SpawnCamera {
    vec4 eye;
    vec4 right;
    vec4 down;
    vec4 forward;
    vec4 focal;         // fx, fy, cx, cy
    uvec4 size;         // W, H, ...
};
layout(buffer_reference, std430, buffer_reference_align = 16) readonly buffer SpawnCameraRef { SpawnCamera p; };

layout(push_constant) uniform Push {
    MixedParamsRef mixed;
    SpawnCameraRef camera;
    Vec4s state;        // per pixel, the tracer's (colour, T) of the last ray (T < 0: ended)
    Vec4s acc;          // per pixel, its colour so far
    Vec4s cur;          // per pixel, its ray of this generation (TreeRay, 3 words)
    Vec4s cur_hit;      // per pixel, that ray's mesh hit (t, barycentrics)
    U32s cur_tri;       // per pixel, that ray's triangle (NO_TRIANGLE; BLOCKED for a blocked shadow ray)
    Vec4s stack;        // per pixel MIXED_STACK TreeRays, entry k of pixel p at 3 (k * pixels + p)
    U32s sp;            // per pixel, its stack's size
    U32s counters;      // MIXED_COUNTER_* slots
    U32s list_in;       // generation > 0: the pixels the last generation gave a ray
    U32s list_out;      // out: the pixels this generation gives a ray (counters[LIVE] of them)
    U32s batch_counts;  // out: per tracer batch, the rays it traces this generation (listed at
                        // MixedParams.lists, as indices in the batch)
    uint generation;    // 0: every pixel starts its camera ray
    uint pixels;
    uint count_in;      // generation > 0: pixels in list_in
    uint pad;
} pc;

#define KIND_CAMERA 0u
#define KIND_SECONDARY 1u
#define KIND_SHADOW 2u
#define KIND_NONE 3u
#define BLOCKED 0xfffffffeu

// A ray of the tree, three words: (virtual origin, t_start), (direction, t_end), (carry rgb,
// kind | depth << 2 | cull << 6 as a float). Carry: a shadow ray's light if unblocked, else
// the ray's RGB weight (1 for the camera ray; split_weight).
struct TreeRay {
    vec3 o;
    float t_start;
    vec3 d;
    float t_end;
    vec3 carry;
    uint kind;
    uint depth;
    bool cull;
};

void store_tree_ray(uint first, TreeRay r) {
    store_vec4_item(pc.stack, first, vec4(r.o, r.t_start));
    store_vec4_item(pc.stack, first + 1u, vec4(r.d, r.t_end));
    store_vec4_item(pc.stack, first + 2u, vec4(r.carry, float(r.kind | (r.depth << 2u) | (r.cull ? 64u : 0u))));
}

TreeRay tree_ray(Vec4s items, uint first) {
    vec4 w0 = load_vec4_item(items, first);
    vec4 w1 = load_vec4_item(items, first + 1u);
    vec4 w2 = load_vec4_item(items, first + 2u);
    uint packed = uint(w2.w);
    TreeRay r;
    r.o = w0.xyz;
    r.t_start = w0.w;
    r.d = w1.xyz;
    r.t_end = w1.w;
    r.carry = w2.rgb;
    r.kind = packed & 3u;
    r.depth = (packed >> 2u) & 15u;
    r.cull = (packed & 64u) != 0u;
    return r;
}

uint g_pixel;
uint g_sp;
vec3 g_acc;

void push(TreeRay r) {
    if (g_sp >= uint(MIXED_STACK)) {
        atomicAdd(pc.counters.v[MIXED_COUNTER_OVERFLOW], 1u);
        return;
    }
    store_tree_ray(3u * (g_sp * pc.pixels + g_pixel), r);
    ++g_sp;
}

// A ray's RGB weight as the T its Gaussians composite under (its largest channel) and its
// tint (the weight over that T; exactly 1 where every channel is the same, so that such a
// ray composites on into the pixel's colour as a ray-traced frame does, to the bit).
// split_weight in src/reference/mixed.rs.
float split_weight(vec3 w, out vec3 tint, out bool tinted) {
    float t = max(w.r, max(w.g, w.b));
    tinted = w.r != w.g || w.g != w.b;
    tint = tinted ? w / t : vec3(1.0);
    return t;
}

// Texel i of a row of n moved into [0, n) by wrap mode `mode` (Wrap::texel in
// src/mixed/material.rs; GLSL's % is undefined for negative operands, hence the two cases).
int wrap_texel(int i, int n, uint mode) {
    if (mode == WRAP_CLAMP) {
        return clamp(i, 0, n - 1);
    }
    int period = mode == WRAP_MIRRORED ? 2 * n : n;
    int k = i >= 0 ? i % period : period - 1 - ((-i - 1) % period);
    return (mode == WRAP_MIRRORED && k >= n) ? 2 * n - 1 - k : k;
}

vec3 srgb_to_linear(vec3 c) {
    return mix(c / 12.92, pow((c + 0.055) / 1.055, vec3(2.4)), greaterThan(c, vec3(0.04045)));
}

// Texel (i, j) of a texture, decoded to linear RGB.
vec3 texel(MixedParams m, uvec4 tex, int i, int j) {
    int w = int(tex.y);
    int h = int(tex.z);
    uint at = tex.x + uint(wrap_texel(j, h, tex.w >> 2u) * w + wrap_texel(i, w, tex.w & 3u));
    return srgb_to_linear(unpackUnorm4x8(U32s(mixed_address(m.texels.xy)).v[at]).rgb);
}

// A texture's linear RGB at uv: its four nearest texels decoded, blended bilinearly (glTF's
// conventions: Texture::sample in src/mixed/material.rs).
vec3 sample_texture(MixedParams m, uvec4 tex, vec2 uv) {
    vec2 x = uv * vec2(tex.yz) - 0.5;
    if (any(isnan(x)) || any(isinf(x))) {
        return vec3(0.0);
    }
    // Far past the image, a float has no fraction left to blend (the CPU twin goes on in
    // 64-bit integers; the same texels, up to 2^24 texels out).
    x = clamp(x, vec2(-16777216.0), vec2(16777216.0));
    vec2 x0 = floor(x);
    vec2 f = x - x0;
    int i = int(x0.x);
    int j = int(x0.y);
    vec3 top = mix(texel(m, tex, i, j), texel(m, tex, i + 1, j), f.x);
    vec3 bottom = mix(texel(m, tex, i, j + 1), texel(m, tex, i + 1, j + 1), f.x);
    return mix(top, bottom, f.y);
}

// A child of `ray` at its hit t along `dir` with RGB `weight`: pushed, or cut by the depth or
// weight limit (it takes the background).
void child(MixedParams m, TreeRay ray, float t, vec3 p, vec3 dir, vec3 weight, bool straight) {
    // A ray that goes straight on (glass of IOR 1) is the same ray going on, not a branch:
    // same depth, and no weight limit (section 4's rule stops it).
    uint depth = straight ? ray.depth : ray.depth + 1u;
    if (!straight && (depth > uint(m.background.w) || max(weight.r, max(weight.g, weight.b)) < 1.0 / 255.0)) {
        atomicAdd(pc.counters.v[MIXED_COUNTER_CUT], 1u);
        g_acc += weight * m.background.rgb;
        return;
    }
    TreeRay c;
    c.o = straight ? ray.o : p - t * dir;
    c.t_start = t;
    c.d = dir;
    c.t_end = UNBOUNDED;
    c.carry = weight;
    c.kind = KIND_SECONDARY;
    c.depth = depth;
    c.cull = straight ? ray.cull : false;
    push(c);
}

// The mesh hit of `ray` (triangle `tri`, (t, barycentrics) `hit`) reached with RGB weight w.
void shade(MixedParams m, TreeRay ray, uint tri, vec4 hit, vec3 w) {
    MeshTriangle tr = MeshTriangles(mixed_address(m.refs.xy)).v[tri];
    MeshShading sh = MeshShadings(mixed_address(m.surfaces.xy)).v[tri];
    MeshMaterial mat = MeshMaterials(mixed_address(m.surfaces.zw)).v[floatBitsToUint(sh.rest.w)];
    float t = hit.x;
    vec3 p = ray.o + t * ray.d;
    vec3 n = sh.n0.xyz * hit.y + sh.n1.xyz * hit.z + sh.n2.xyz * hit.w;
    float len = length(n);
    n = len > 1e-12 ? n / len : normalize(cross(tr.v1.xyz - tr.v0.xyz, tr.v2.xyz - tr.v0.xyz));
    vec3 facing = dot(n, ray.d) > 0.0 ? -n : n;
    uint kind = uint(mat.colour.w);
    g_acc += w * mat.emission.rgb;
    // The colour (albedo or reflectance) at the hit: the material's times its texture's.
    vec3 c = mat.colour.rgb;
    if (kind != MATERIAL_GLASS && mat.texture.x != NO_TEXTURE) {
        vec2 uv = vec2(sh.n0.w, sh.n1.w) * hit.y + vec2(sh.n2.w, sh.rest.x) * hit.z
                + sh.rest.yz * hit.w;
        c *= sample_texture(m, mat.texture, uv);
    }
    if (kind == MATERIAL_DIFFUSE) {
        g_acc += w * (c * m.ambient.rgb);
        for (uint l = 0u; l < m.counts.z; ++l) {
            vec3 dir;
            float dist;
            vec3 light;
            toward_light(m, l, p, dir, dist, light);
            float ndl = dot(facing, dir);
            if (ndl > 0.0) {
                TreeRay s;
                s.o = p;
                s.t_start = 0.0;
                s.d = dir;
                s.t_end = dist;
                s.carry = w * (c * (ndl * light));
                s.kind = KIND_SHADOW;
                s.depth = ray.depth;
                s.cull = false;
                push(s);
            }
        }
    } else if (kind == MATERIAL_MIRROR) {
        vec3 r = ray.d - 2.0 * dot(facing, ray.d) * facing;
        child(m, ray, t, p, r, w * c, false);
    } else {
        float eta = mat.emission.w;
        bool entering = dot(n, ray.d) < 0.0;
        float n1 = entering ? 1.0 : eta;
        float n2 = entering ? eta : 1.0;
        vec3 nn = entering ? n : -n;
        // The exact unpolarised Fresnel reflectance and Snell's refraction (fresnel() in
        // src/reference/mixed.rs); equal indices give exactly 0 and the ray itself.
        float cosi = -dot(nn, ray.d);
        float ratio = n1 / n2;
        float sin2t = ratio * ratio * (1.0 - cosi * cosi);
        vec3 r = ray.d - 2.0 * dot(nn, ray.d) * nn;
        if (sin2t >= 1.0) {
            child(m, ray, t, p, r, w, false);
        } else if (n1 == n2) {
            child(m, ray, t, p, r, vec3(0.0), false);
            child(m, ray, t, p, ray.d, w, true);
        } else {
            float cost = sqrt(1.0 - sin2t);
            float rs = (n1 * cosi - n2 * cost) / (n1 * cosi + n2 * cost);
            float rp = (n2 * cosi - n1 * cost) / (n2 * cosi + n1 * cost);
            float f = 0.5 * (rs * rs + rp * rp);
            child(m, ray, t, p, r, w * f, false);
            child(m, ray, t, p, ratio * ray.d + (ratio * cosi - cost) * nn, w * (1.0 - f), false);
        }
    }
}

// Lists pixel px's ray for the tracer, in its batch's list.
void list_for_tracer(MixedParams m, uint px) {
    uint per = m.lists.z;
    uint batch = px / per;
    uint at = atomicAdd(pc.batch_counts.v[batch], 1u);
    U32s(mixed_address(m.lists.xy)).v[batch * per + at] = px - batch * per;
}

void main() {
    // Generation 0 runs over every pixel; a later one over the pixels the one before gave a
    // ray (a list in no particular order), so a pixel whose tree is done costs nothing.
    uint item = linear_index();
    if (item >= (pc.generation == 0u ? pc.pixels : pc.count_in)) {
        return;
    }
    uint px = pc.generation == 0u ? item : pc.list_in.v[item];
    g_pixel = px;
    MixedParams m = pc.mixed.p;
    Address ray_at = address_item(mixed_address(m.refs2.xy), px, 64u);
    TreeRay ray;
    bool has_ray;
    if (pc.generation == 0u) {
        SpawnCamera cam = pc.camera.p;
        uint w = cam.size.x;
        g_acc = vec3(0.0);
        g_sp = 0u;
        ray.o = cam.eye.xyz;
        ray.d = camera_ray_direction(cam.right.xyz, cam.down.xyz, cam.forward.xyz, cam.focal,
                                     uvec2(px % w, px / w));
        ray.t_start = 0.0;
        ray.t_end = UNBOUNDED;
        ray.carry = vec3(1.0);
        ray.kind = KIND_CAMERA;
        ray.depth = 0u;
        ray.cull = true;
        has_ray = true;
    } else {
        g_acc = load_vec4_item(pc.acc, px).rgb;
        g_sp = pc.sp.v[px];
        TreeRay last = tree_ray(pc.cur, 3u * px);
        uint tri = pc.cur_tri.v[px];
        vec4 s = load_vec4_item(pc.state, px);
        if (last.kind == KIND_SHADOW) {
            if (tri != BLOCKED) {
                g_acc += last.carry * abs(s.w);
            }
        } else {
            // The tracer composited an untinted ray on from the pixel's colour, a tinted one
            // from 0 (split_weight): its colour joins the pixel's times the tint.
            vec3 tint;
            bool tinted;
            split_weight(last.carry, tint, tinted);
            vec3 colour = s.rgb;
            float t = abs(s.w);
            if (s.w < 0.0 || tri == NO_TRIANGLE) {
                // Over the background as write_target ends a ray-traced frame (state_over,
                // no fused multiply-add), so a scene without meshes is that frame to the bit.
                colour = state_over(s, vec4(m.background.rgb, 0.0)).rgb;
            }
            g_acc = tinted ? g_acc + tint * colour : colour;
            if (!(s.w < 0.0 || tri == NO_TRIANGLE)) {
                shade(m, last, tri, load_vec4_item(pc.cur_hit, px), tint * t);
            }
        }
        has_ray = g_sp > 0u;
        if (has_ray) {
            --g_sp;
            ray = tree_ray(pc.stack, 3u * (g_sp * pc.pixels + px));
        }
    }
    if (!has_ray) {
        ray.kind = KIND_NONE;
        store_uvec4(address_plus(ray_at, 48u), uvec4(MIXED_RAY_NONE, 0u, 0u, 0u));
    } else {
        pc.list_out.v[atomicAdd(pc.counters.v[MIXED_COUNTER_LIVE], 1u)] = px;
        uint slot = ray.kind == KIND_CAMERA ? MIXED_COUNTER_PRIMARY
                  : (ray.kind == KIND_SHADOW ? MIXED_COUNTER_SHADOW : MIXED_COUNTER_SECONDARY);
        atomicAdd(pc.counters.v[slot], 1u);
        uint visits = 0u;
        vec4 hit;
        uint tri;
        if (ray.kind == KIND_SHADOW) {
            bool blocked = mesh_hit(m, ray.o, ray.d, SECONDARY_OFFSET, ray.t_end, true, hit, visits) != NO_TRIANGLE;
            tri = blocked ? BLOCKED : NO_TRIANGLE;
            store_vec4(ray_at, vec4(ray.o, SECONDARY_OFFSET));
            store_vec4(address_plus(ray_at, 16u), vec4(ray.d, ray.t_end));
            store_vec4(address_plus(ray_at, 32u), vec4(0.0, 0.0, 0.0, 1.0));
            store_uvec4(address_plus(ray_at, 48u), uvec4(blocked ? MIXED_RAY_NONE : MIXED_RAY_SHADOW, 0u, 0u, 0u));
            if (!blocked) {
                list_for_tracer(m, px);
            }
        } else {
            float offset = ray.kind == KIND_CAMERA ? 0.0 : SECONDARY_OFFSET;
            tri = mesh_hit(m, ray.o, ray.d, ray.t_start + offset, UNBOUNDED, false, hit, visits);
            store_vec4(ray_at, vec4(ray.o, ray.t_start));
            store_vec4(address_plus(ray_at, 16u), vec4(ray.d, tri == NO_TRIANGLE ? UNBOUNDED : hit.x));
            vec3 tint;
            bool tinted;
            float t0 = split_weight(ray.carry, tint, tinted);
            store_vec4(address_plus(ray_at, 32u), vec4(tinted ? vec3(0.0) : g_acc, t0));
            store_uvec4(address_plus(ray_at, 48u), uvec4(ray.cull ? MIXED_RAY_CULL : 0u, 0u, 0u, 0u));
            list_for_tracer(m, px);
        }
        if (visits > uint(MIXED_MESH_VISITS_MAX)) {
            atomicAdd(pc.counters.v[MIXED_COUNTER_LONG_WALKS], 1u);
        }
        store_vec4_item(pc.cur_hit, px, hit);
        pc.cur_tri.v[px] = tri;
    }
    store_vec4_item(pc.cur, 3u * px, vec4(ray.o, ray.t_start));
    store_vec4_item(pc.cur, 3u * px + 1u, vec4(ray.d, ray.t_end));
    store_vec4_item(pc.cur, 3u * px + 2u, vec4(ray.carry, float(ray.kind | (ray.depth << 2u) | (ray.cull ? 64u : 0u))));
    store_vec4_item(pc.acc, px, vec4(g_acc, 0.0));
    pc.sp.v[px] = g_sp;
}
