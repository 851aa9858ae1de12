// The BVH of the ray tracer (SPEC section 7, issue 32), shared by its build kernels
// (bvh_proxies, bvh_morton, bvh_tree, bvh_bounds). Host twin: src/raytrace/bvh.rs.
//
// The tree is Karras' (2012) radix tree over the Gaussians sorted by the Morton code of their
// proxy box's centre: n leaves and n - 1 inner nodes, node 0 the root, inner nodes
// [0, n - 1), leaf k (the k-th Gaussian in Morton order) at node n - 1 + k.
#ifndef RARA_BVH_COMMON_GLSL
#define RARA_BVH_COMMON_GLSL

#include "common.glsl"

// A node (or a proxy box): its box (lo, hi; empty when lo > hi) and, for an inner node, its
// children's node indices, for a leaf its Gaussian in `left`. An inner node's `right` also
// holds, in its top two bits, the axis its Morton split is on (0 x, 1 y, 2 z; 3 none: equal
// codes or the empty-box bit): the left child lies below the right one on it, so a ray visits
// first the child its direction meets first. The indices are uints of their own, never float
// bits: a CPU driver may flush such a float (a denormal) to zero.
struct BvhNode {
    vec3 lo;
    uint left;
    vec3 hi;
    uint right;
};
layout(buffer_reference, std430, buffer_reference_align = 16) coherent buffer BvhNodes { BvhNode v[]; };
layout(buffer_reference, std430, buffer_reference_align = 4) coherent buffer CoherentU32s { uint v[]; };
// The built tree as the ray tracer reads it: not coherent (the build wrote it in an earlier
// dispatch), so a GPU may cache it, and read only.
layout(buffer_reference, std430, buffer_reference_align = 16) readonly buffer BvhTree { BvhNode v[]; };

// Centre bounds of the proxies, as order-preserving uints of the floats (atomicMin/Max):
// v[0..3] the minimum, v[3..6] the maximum.
uint float_order(float f) {
    uint u = floatBitsToUint(f);
    return (u & 0x80000000u) != 0u ? ~u : (u | 0x80000000u);
}

float order_float(uint u) {
    return uintBitsToFloat((u & 0x80000000u) != 0u ? (u & 0x7fffffffu) : ~u);
}

#define BVH_NO_PARENT 0xffffffffu
#define BVH_AXIS_SHIFT 30u
#define BVH_CHILD_MASK 0x3fffffffu


#endif
