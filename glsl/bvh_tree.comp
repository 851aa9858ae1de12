#version 460
// Ray tracer BVH build, step 3: Karras' (2012) radix tree over the sorted Morton codes, one
// invocation per inner node, each on its own (no node waits for another). delta(i, j) is the
// length of the common prefix of codes i and j, extended by their indices where the codes are
// equal (so every key is distinct), -1 outside [0, n). Node i's range runs from i in the
// direction d where delta grows; its far end is found by an exponential then a binary search,
// its split by a binary search for the last key sharing more than the range's prefix with i.
// Both searches take at most 32 steps. Writes each node's children (left, right, with the
// split's axis) and every child's parent. CPU twin: raytrace::bvh::karras_tree.
#include "bvh_common.glsl"

layout(local_size_x = LINEAR_WORKGROUP) in;

layout(push_constant) uniform Push {
    U32s codes;         // sorted Morton codes
    BvhNodes nodes;     // out: left, right of the inner nodes
    U32s parents;       // out: per node (2n - 1), BVH_NO_PARENT for the root
    uint count;         // n, at least 2
} pc;

int delta(int i, int j) {
    int n = int(pc.count);
    if (j < 0 || j >= n) {
        return -1;
    }
    uint a = pc.codes.v[i];
    uint b = pc.codes.v[j];
    if (a == b) {
        return 32 + (31 - findMSB(uint(i) ^ uint(j)));
    }
    return 31 - findMSB(a ^ b);
}

void main() {
    uint node = linear_index();
    int n = int(pc.count);
    if (node >= pc.count - 1u) {
        return;
    }
    int i = int(node);
    int d = delta(i, i + 1) - delta(i, i - 1) >= 0 ? 1 : -1;
    int delta_min = delta(i, i - d);
    int l_max = 2;
    for (uint k = 0u; k < 32u && delta(i, i + l_max * d) > delta_min; ++k) {
        l_max *= 2;
    }
    int l = 0;
    for (int t = l_max / 2; t >= 1; t /= 2) {
        if (delta(i, i + (l + t) * d) > delta_min) {
            l += t;
        }
    }
    int j = i + l * d;
    int delta_node = delta(i, j);
    int s = 0;
    int step = l;
    for (uint k = 0u; k < 32u; ++k) {
        step = (step + 1) / 2;
        if (delta(i, i + (s + step) * d) > delta_node) {
            s += step;
        }
        if (step <= 1) {
            break;
        }
    }
    int gamma = i + s * d + min(d, 0);
    uint leaves = uint(n - 1);
    uint left = min(i, j) == gamma ? leaves + uint(gamma) : uint(gamma);
    uint right = max(i, j) == gamma + 1 ? leaves + uint(gamma + 1) : uint(gamma + 1);
    // The split is at the first bit where the range's codes differ: bit 31 - delta_node of a
    // code whose bits 29, 26, ... are x, 28, 25, ... y and 27, 24, ... z (bvh_morton.comp).
    int bit = 31 - delta_node;
    uint axis = bit >= 0 && bit < 30 ? uint(2 - bit % 3) : 3u;
    pc.nodes.v[node].left = left;
    pc.nodes.v[node].right = right | (axis << BVH_AXIS_SHIFT);
    pc.parents.v[left] = node;
    pc.parents.v[right] = node;
    if (node == 0u) {
        pc.parents.v[0] = BVH_NO_PARENT;
    }
}
