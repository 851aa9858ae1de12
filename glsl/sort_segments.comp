// Radix sort, after the first pass of a segmented sort (CPU-driver layout,
// SortLayout::OwnCounts; see sort_own_counts.glsl): the first pass sorted the keys by their top
// digit, and each of its buckets is now sorted on its own by the other digits, least
// significant first, so that the work on a bucket stays in the cache instead of streaming the
// whole output through it in every pass. This kernel lists the buckets and chooses how:
// - where no bucket holds more than local_max_keys keys, sort_local_* give every bucket
//   to one invocation, which sorts it by all the other digits in turn (local_args);
// - otherwise the passes after the first run as before, count, scan and scatter, over runs
//   that never straddle a bucket: each bucket is cut into runs of
//   SORT_OWN_MIN_ITEMS keys (its last one shorter), and run r of a bucket whose runs are
//   numbered from q on, R in all, counts digit d into histogram entry
//   SORT_OWN_RADIX q + d R + (r - q), so the histogram's scan orders by bucket, digit and run,
//   which is where a stable sort of each bucket puts them. A workgroup's stores then stay
//   within a few buckets' share of the output.
//
// One invocation: one loop over the SORT_OWN_RADIX buckets and the runs, at most
// num_keys / SORT_OWN_MIN_ITEMS + 2 SORT_OWN_RADIX passes (4,608 for the largest sort that
// fits a texel view on lavapipe), far under lavapipe's cap of 65,535 loop iterations. (Nested
// loops, one over the buckets and one over a bucket's runs, lost every bucket after the first
// on lavapipe.)
#version 460
#extension GL_EXT_control_flow_attributes : require
#include "common.glsl"
#include "sort_common.glsl"

layout(local_size_x = 1) in;

layout(push_constant) uniform Push {
    SortInfoRef info;
    U32s hist;          // the first pass's scanned histogram
    SortRuns table;     // out: the buckets, then the runs of the passes after the first
    uint passes;        // the sort's radix passes, 2 to 4
    uint local_passes;  // of the passes after the first, how many sort_local_* can make
    uint local_max_keys; // the largest bucket it takes (stages::sort::local_max_keys)
} pc;

void main() {
    if (pc.info.s.segmented == 0u) {
        return;
    }
    uint n = pc.info.s.num_keys;
    // The first pass's runs, one histogram column each: entry d * columns is where its
    // bucket d starts (every bucket's first key comes from that pass's run 0 or later).
    uint columns = pc.info.s.num_blocks * SORT_OWN_WORKGROUP;
    uint r = 0u;            // runs listed
    uint b = 0u;            // the bucket being cut
    uint start = 0u;        // bucket b's keys: [start, end)
    uint end = pc.hist.v[columns];
    uint first_run = 0u;    // bucket b's first run
    uint largest = 0u;      // keys in the largest bucket
    while (b < SORT_OWN_RADIX) {
        uint first = start + (r - first_run) * SORT_OWN_MIN_ITEMS;
        if (first < end) {
            uint bucket_runs = div_ceil(end - start, SORT_OWN_MIN_ITEMS);
            pc.table.v[SORT_OWN_RADIX + r] =
                uvec4(first, min(first + SORT_OWN_MIN_ITEMS, end),
                      SORT_OWN_RADIX * first_run + (r - first_run), bucket_runs);
            ++r;
        } else {
            pc.table.v[b] = uvec4(start, end, 0u, 0u);
            largest = max(largest, end - start);
            ++b;
            start = end;
            end = n;
            if (b + 1u < SORT_OWN_RADIX) {
                end = pc.hist.v[(b + 1u) * columns];
            }
            first_run = r;
        }
    }
    // Passes 1 .. local_passes are sort_local_*'s where every bucket is small enough; the
    // others sort the buckets in runs.
    bool local = pc.local_passes > 0u && largest <= pc.local_max_keys;
    uint first_in_runs = local ? 1u + pc.local_passes : 1u;
    pc.info.s.local_args = uvec4(local ? SORT_OWN_RADIX / SORT_OWN_WORKGROUP : 0u, 1u, 1u, 0u);
    uvec4 runs_args = uvec4(div_ceil(r, SORT_OWN_WORKGROUP), 1u, 1u, 0u);
    [[unroll]] for (uint k = 0u; k < 3u; ++k) {
        pc.info.s.pass_args[k] = 1u + k >= first_in_runs ? runs_args : uvec4(0u, 1u, 1u, 0u);
    }
    bool any_runs = first_in_runs < pc.passes;
    pc.info.s.seg_runs = r;
    pc.info.s.hist_len = any_runs ? r * SORT_OWN_RADIX : 0u;
}
