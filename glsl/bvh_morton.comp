#version 460
// Ray tracer BVH build, step 2: the 30-bit Morton code of each proxy box's centre within the
// centres' bounds (10 bits per axis), the sort's key, with the Gaussian's index as its value.
// An empty box gets 2^30, after every code, so the radix sort (31 key bits) puts it last.
#include "bvh_common.glsl"

layout(local_size_x = LINEAR_WORKGROUP) in;

layout(push_constant) uniform Push {
    BvhNodes boxes;
    U32s bounds;    // centre bounds (float_order)
    U32s keys;      // out: Morton codes
    U32s values;    // out: Gaussian indices
    uint count;
} pc;

// The 10 low bits of v spread to every third bit.
uint spread_bits(uint v) {
    v &= 0x3ffu;
    v = (v | (v << 16u)) & 0x030000ffu;
    v = (v | (v << 8u)) & 0x0300f00fu;
    v = (v | (v << 4u)) & 0x030c30c3u;
    v = (v | (v << 2u)) & 0x09249249u;
    return v;
}

void main() {
    uint i = linear_index();
    if (i >= pc.count) {
        return;
    }
    BvhNode b = pc.boxes.v[i];
    uint code = 1u << 30u;
    if (b.lo.x <= b.hi.x) {
        vec3 lo = vec3(order_float(pc.bounds.v[0]), order_float(pc.bounds.v[1]),
                       order_float(pc.bounds.v[2]));
        vec3 hi = vec3(order_float(pc.bounds.v[3]), order_float(pc.bounds.v[4]),
                       order_float(pc.bounds.v[5]));
        vec3 extent = max(hi - lo, vec3(1e-30));
        vec3 cell = clamp((0.5 * (b.lo + b.hi) - lo) / extent * 1024.0, 0.0, 1023.0);
        uvec3 c = uvec3(cell);
        code = (spread_bits(c.x) << 2u) | (spread_bits(c.y) << 1u) | spread_bits(c.z);
    }
    pc.keys.v[i] = code;
    pc.values.v[i] = i;
}
