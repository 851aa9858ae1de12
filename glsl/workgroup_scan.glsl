// Exclusive prefix sum across one workgroup: a subgroup scan, then one invocation scans the
// subgroups' totals in shared memory. The order it sums in is (subgroup, lane), which Vulkan
// does not tie to gl_LocalInvocationIndex: callers lay out their data by
// workgroup_scan_rank(), so the result is right at any subgroup size and any mapping of
// invocations to subgroups. Needs the subgroup size to be at least MIN_SUBGROUP_SIZE and the
// workgroup to be made of full subgroups (WG_SCAN_SIZE a multiple of the subgroup size).
// Every invocation must call it, in uniform control flow.
//
// (A Hillis-Steele scan over the whole workgroup in shared memory, with no subgroup operations,
// made the frame's prefix sum 2-3x as slow on lavapipe, where every shared-memory access runs
// lane by lane.)
#ifndef WG_SCAN_SIZE
#error "define WG_SCAN_SIZE (the workgroup size) before including workgroup_scan.glsl"
#endif
#extension GL_KHR_shader_subgroup_arithmetic : require
#extension GL_KHR_shader_subgroup_basic : require

// Totals of the subgroups, then their exclusive scan; the last slot holds the grand total.
shared uint wg_scan_sums[WG_SCAN_SIZE / MIN_SUBGROUP_SIZE + 1u];

// The calling invocation's position in the scan's order, 0 .. WG_SCAN_SIZE - 1.
uint workgroup_scan_rank() {
    return gl_SubgroupID * gl_SubgroupSize + gl_SubgroupInvocationID;
}

// Returns the sum of `value` over invocations of smaller workgroup_scan_rank(); `total`
// receives the sum over the whole workgroup.
uint workgroup_exclusive_scan(uint value, out uint total) {
    const uint total_slot = WG_SCAN_SIZE / MIN_SUBGROUP_SIZE;
    uint before = subgroupExclusiveAdd(value);
    uint subgroup_total = subgroupAdd(value);
    if (subgroupElect()) {
        wg_scan_sums[gl_SubgroupID] = subgroup_total;
    }
    barrier();
    if (gl_LocalInvocationIndex == 0u) {
        uint running = 0u;
        for (uint s = 0u; s < gl_NumSubgroups; ++s) {
            uint t = wg_scan_sums[s];
            wg_scan_sums[s] = running;
            running += t;
        }
        wg_scan_sums[total_slot] = running;
    }
    barrier();
    uint result = wg_scan_sums[gl_SubgroupID] + before;
    total = wg_scan_sums[total_slot];
    barrier(); // the sums may be reused by the next call
    return result;
}
