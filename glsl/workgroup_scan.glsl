// Exclusive prefix sum across one workgroup, in shared memory (Hillis-Steele). It makes no
// assumption about the subgroup size or how invocations map to subgroups, so it is correct on
// lavapipe (8 wide), NVIDIA (32) and AMD (32/64) alike. Every invocation must call it.
#ifndef WG_SCAN_SIZE
#error "define WG_SCAN_SIZE (the workgroup size) before including workgroup_scan.glsl"
#endif

shared uint wg_scan_buf[2][WG_SCAN_SIZE];

// Returns the sum of `value` over invocations with a smaller local index; `total` receives the
// sum over the whole workgroup.
uint workgroup_exclusive_scan(uint value, out uint total) {
    uint lid = gl_LocalInvocationIndex;
    uint src = 0u;
    wg_scan_buf[0][lid] = value;
    barrier();
    for (uint offset = 1u; offset < WG_SCAN_SIZE; offset <<= 1u) {
        uint v = wg_scan_buf[src][lid];
        if (lid >= offset) {
            v += wg_scan_buf[src][lid - offset];
        }
        wg_scan_buf[1u - src][lid] = v;
        src = 1u - src;
        barrier();
    }
    uint inclusive = wg_scan_buf[src][lid];
    total = wg_scan_buf[src][WG_SCAN_SIZE - 1u];
    barrier(); // the buffer may be reused by the next call
    return inclusive - value;
}
