// Prefix sum, CPU-driver layout (ScanLayout::Runs, scan_runs_*): every invocation owns a
// run of SCAN_RUN consecutive elements. It sums them (scan_runs_reduce), one invocation scans
// the runs' sums in order (scan_runs_top), and each invocation then scans its run again from
// its run's offset (scan_runs_down). No shared memory, barriers or subgroup operations: a CPU
// driver runs those lane by lane, and a 256-invocation workgroup of the block layout as 32
// SIMD vectors that take turns at every barrier. Elements move four at a time, as two 64-bit
// words (load_u32x4, store_uvec4 in common.glsl), so `data` must be 16-byte aligned.
#include "common.glsl"

// This invocation's run of the n elements: [first, end), empty past n.
uvec2 scan_run(uint n) {
    uint first = min(gl_GlobalInvocationID.x * SCAN_RUN, n);
    return uvec2(first, min(first + SCAN_RUN, n));
}
