// Several objects (SPEC section 9): one object's Gaussians transformed into the frame's merged
// scene, one invocation per Gaussian. world = t + s (R x); rotation r q; scale s x; the SH of
// bands 1 to 3 multiplied band by band by the object's rotation matrices D (computed on the
// host, src/objects.rs); opacity kept. Coefficients past the object's SH degree are zero in
// the merged scene. Every operation is `precise` and in the order of the CPU twin
// (ObjectTransform::apply), so the merged scene is the host's bit for bit.
#version 460
#include "common.glsl"

layout(local_size_x = 256) in;

// Per object: the rotation's rows (w unused), (translation, scale), the rotation (w, x, y, z),
// then the 83 floats of the SH rotation (band 1 3x3, band 2 5x5, band 3 7x7, rows first).
layout(buffer_reference, std430, buffer_reference_align = 16) buffer ObjectParams {
    vec4 rows[3];
    vec4 translation_scale;
    vec4 rotation;
    float d[83];
};

layout(push_constant) uniform Push {
    Gaussians src;      // the object's Gaussians
    F32s src_sh;        // its SH coefficients (f32), src_coeffs per channel
    Gaussians dst;      // the merged scene's Gaussians
    F32s dst_sh;        // its SH coefficients (f32), dst_coeffs per channel
    ObjectParams params;
    uint count;         // the object's Gaussians
    uint base;          // its first Gaussian in the merged scene
    uint src_coeffs;
    uint dst_coeffs;
} pc;

void main() {
    uint i = gl_GlobalInvocationID.x;
    if (i >= pc.count) {
        return;
    }
    Gaussian g = pc.src.v[i];
    vec4 ts = pc.params.translation_scale;
    float s = ts.w;
    vec3 m = g.pos_opacity.xyz;
    precise vec3 r;
    r.x = pc.params.rows[0].x * m.x + pc.params.rows[0].y * m.y + pc.params.rows[0].z * m.z;
    r.y = pc.params.rows[1].x * m.x + pc.params.rows[1].y * m.y + pc.params.rows[1].z * m.z;
    r.z = pc.params.rows[2].x * m.x + pc.params.rows[2].y * m.y + pc.params.rows[2].z * m.z;
    precise vec3 world;
    world.x = s * r.x + ts.x;
    world.y = s * r.y + ts.y;
    world.z = s * r.z + ts.z;
    vec4 rq = pc.params.rotation;   // (w, x, y, z)
    vec4 q = g.rot;
    precise vec4 out_q;
    out_q.x = rq.x * q.x - rq.y * q.y - rq.z * q.z - rq.w * q.w;
    out_q.y = rq.x * q.y + rq.y * q.x + rq.z * q.w - rq.w * q.z;
    out_q.z = rq.x * q.z - rq.y * q.w + rq.z * q.x + rq.w * q.y;
    out_q.w = rq.x * q.w + rq.y * q.z - rq.z * q.y + rq.w * q.x;
    precise vec3 scale;
    scale.x = s * g.scale.x;
    scale.y = s * g.scale.y;
    scale.z = s * g.scale.z;
    Gaussian o;
    o.pos_opacity = vec4(world, g.pos_opacity.w);
    o.rot = out_q;
    o.scale = vec4(scale, 0.0);
    pc.dst.v[pc.base + i] = o;

    uint src_at = 3u * pc.src_coeffs * i;
    uint dst_at = 3u * pc.dst_coeffs * (pc.base + i);
    for (uint c = 0u; c < 3u; ++c) {
        pc.dst_sh.v[dst_at + c] = pc.src_sh.v[src_at + c];
    }
    // Band l (first coefficient f, n = 2l + 1 of them, its matrix at d[at]).
    uint firsts[3] = uint[](1u, 4u, 9u);
    uint sizes[3] = uint[](3u, 5u, 7u);
    uint ats[3] = uint[](0u, 9u, 34u);
    for (uint band = 0u; band < 3u; ++band) {
        uint f = firsts[band];
        uint n = sizes[band];
        if (f + n > pc.dst_coeffs) {
            break;
        }
        bool present = f + n <= pc.src_coeffs;
        for (uint c = 0u; c < 3u; ++c) {
            for (uint row = 0u; row < n; ++row) {
                precise float v = 0.0;
                if (present) {
                    for (uint k = 0u; k < n; ++k) {
                        v = v + pc.params.d[ats[band] + row * n + k] *
                                    pc.src_sh.v[src_at + 3u * (f + k) + c];
                    }
                }
                pc.dst_sh.v[dst_at + 3u * (f + row) + c] = v;
            }
        }
    }
}
