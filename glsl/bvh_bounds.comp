#version 460
// Ray tracer BVH build, step 4: the nodes' boxes, bottom up. One invocation per leaf writes
// the leaf's box (its Gaussian's proxy) and climbs: at each inner node it counts itself in
// with an atomic; the first of the two children's walkers to arrive stops there, the second
// (which then knows both children's boxes are written) writes the union and climbs on. So no
// invocation ever waits for another, and every node is written once. The depth is at most 63
// (delta grows by at least one per level, from 0 up to 62), far inside lavapipe's loop cap.
//
// The order comes from the arrival atomic's acquire/release semantics (the Vulkan memory
// model): with memoryBarrierBuffer() around a plain atomicAdd instead, lavapipe dropped the
// climb of a walker that went on after others had stopped (the barrier in divergent control
// flow), and a root came out unwritten.
#pragma use_vulkan_memory_model
#extension GL_KHR_memory_scope_semantics : require
#include "bvh_common.glsl"

layout(local_size_x = LINEAR_WORKGROUP) in;

layout(push_constant) uniform Push {
    BvhNodes boxes;         // proxies, per Gaussian
    U32s order;             // the Gaussians in Morton order (the sort's values)
    BvhNodes nodes;         // in: children of inner nodes; out: boxes
    U32s parents;
    CoherentU32s arrivals;  // per inner node, zero-filled beforehand
    uint count;
} pc;

void main() {
    uint k = linear_index();
    if (k >= pc.count) {
        return;
    }
    uint leaves = pc.count - 1u;
    uint node = leaves + k;
    BvhNode b = pc.boxes.v[pc.order.v[k]];
    // The walker carries its node's box; only the sibling's comes from memory. The loop ends by
    // its condition, not a return from inside it (an early return under a divergent mask lost
    // the climb of the walkers still going on lavapipe).
    vec3 lo = b.lo;
    vec3 hi = b.hi;
    pc.nodes.v[node] = BvhNode(lo, pc.order.v[k], hi, 0u);
    bool climbing = true;
    for (uint level = 0u; climbing && level < 64u; ++level) {
        uint parent = pc.parents.v[node];
        climbing = parent != BVH_NO_PARENT;
        if (climbing) {
            // Release: our node's box is written before our arrival; acquire: the sibling's
            // walker wrote its box before its arrival.
            climbing = atomicAdd(pc.arrivals.v[parent], 1u, gl_ScopeQueueFamily,
                                 gl_StorageSemanticsBuffer, gl_SemanticsAcquireRelease) != 0u;
        }
        if (climbing) {
            uint left = pc.nodes.v[parent].left;
            uint right = pc.nodes.v[parent].right & BVH_CHILD_MASK;
            uint sibling = left == node ? right : left;
            lo = min(lo, pc.nodes.v[sibling].lo);
            hi = max(hi, pc.nodes.v[sibling].hi);
            pc.nodes.v[parent].lo = lo;
            pc.nodes.v[parent].hi = hi;
            node = parent;
        }
    }
}
