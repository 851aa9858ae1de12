// Radix sort, the passes after the first of a segmented sort whose buckets are all small
// (CPU-driver layout; sort_segments.comp chose it): each invocation sorts one bucket of the
// first pass by the other LOCAL_PASSES digits, least significant first: it counts the bucket's
// keys by all of them in one loop, then scans and scatters them digit by digit, with counters
// of its own (private arrays, see own_counts in sort_own_counts.glsl). A bucket, and the part
// of the other buffer it is scattered to, stay in the cache through its passes; the passes of a
// sort over all the keys each stream the whole input through the cache twice (count, then
// scatter) and the output once. The pairs ping-pong between the sort's two buffers as the
// passes of a plain sort would, so the result is where theirs would be: local pass k reads
// buffer (k+1) % 2 and writes buffer k % 2, each invocation only its bucket's part of each.
// Every pass writes packed pairs through the bound storage buffers (SORT_OUT_BOUND in
// sort_scatter_own_counts_body.glsl). Separate keys and values, a sort's result in the other
// form, are not written here: a key takes 4 bytes of the buffer, where other invocations could
// still be reading packed pairs of their own buckets, so a sort of separate keys and values
// leaves its last pass to the kernels that sort the buckets in runs. Only 2 or 3 passes are
// worth the kernel (stages::sort::local_passes): their bucket stays in the cache from one pass
// to the next.
//
// A pass reads through the texel views what the pass before wrote through the storage
// buffers, in the same dispatch: a CPU driver sees the stores at once, a GPU's texture cache
// need not, so segmented sorts run on CPU devices only (RadixSort::with_layout).
//
// Loop cap: an invocation's loops take 256 iterations over its counters, one per group of
// four keys and up to 7 more to count the bucket, then per pass 256 over the counters, one per
// group of four keys and up to 8 more to scatter it; sort_segments.comp gives this kernel only
// buckets that keep within SORT_LOCAL_LOOP_BUDGET = 58,000 iterations, under lavapipe's cap of
// 65,535 (stages::sort::local_max_keys: 56,945 keys for 3 passes).
#extension GL_EXT_control_flow_attributes : require
#include "common.glsl"
#include "sort_common.glsl"

#if LOCAL_PASSES < 2 || LOCAL_PASSES > 3
#error "LOCAL_PASSES is 2 or 3: of the 3 digits after the top one of a 32-bit key"
#endif

layout(local_size_x = SORT_OWN_WORKGROUP) in;

// Set 0 is the sort's set for buffer 1 (SortTexels::sets[1]): it reads buffer 1's packed pairs
// and binds buffer 0 for writing; set 1 the other way round. The pairs are stored as uvec2 in
// both kernel forms: on lavapipe this kernel's pass took 14.6-16.1 ms so against 20.7-22.6 ms
// with one 64-bit store per pair (`bench --sort 2000000`, three rounds in turn), where the
// scatter of the other passes gains a little from the 64-bit store (docs/PERFORMANCE.md).
layout(set = 0, binding = 2) uniform utextureBuffer pairs_in_1;
layout(set = 0, binding = 3, std430) restrict writeonly buffer PairsOut0 {
    uvec2 pairs_out_0[];
};
layout(set = 1, binding = 2) uniform utextureBuffer pairs_in_0;
layout(set = 1, binding = 3, std430) restrict writeonly buffer PairsOut1 {
    uvec2 pairs_out_1[];
};

layout(push_constant) uniform Push {
    SortRuns table;     // the buckets, entries 0 .. SORT_OWN_RADIX - 1
} pc;

// The invocation's counters, one per value of each digit it sorts by, then each pass's next
// output position per value (see own_counts in sort_own_counts.glsl). A bucket's counts of
// every digit are taken in one loop over it, since they do not depend on the keys' order.
uint counts[LOCAL_PASSES][SORT_OWN_RADIX];

// Pairs i and i + 1 (i even) of the buffer a pass reads: (key, value, key, value). `from1` is
// a constant once the pass is inlined, so one of the fetches is left.
uvec4 two_pairs(bool from1, uint i) {
    return from1 ? texelFetch(pairs_in_1, int(i / 2u)) : texelFetch(pairs_in_0, int(i / 2u));
}

// Keys i .. i + 3 (i a multiple of 4) and their values.
void load_four(bool from1, uint i, out uvec4 keys, out uvec4 values) {
    uvec4 a = two_pairs(from1, i);
    uvec4 b = two_pairs(from1, i + 2u);
    keys = uvec4(a.x, a.z, b.x, b.z);
    values = uvec4(a.y, a.w, b.y, b.w);
}

// Pair i.
uvec2 load_one(bool from1, uint i) {
    uvec4 two = two_pairs(from1, i & ~1u);
    return (i & 1u) == 0u ? two.xy : two.zw;
}

// Writes `key` with its value at the next position of its digit k (at `shift`).
void scatter_pair(uint k, bool from1, uint shift, uint key, uint value) {
    uint d = key_digit(key, shift, SORT_OWN_RADIX - 1u);
    uint dst = counts[k][d];
    counts[k][d] = dst + 1u;
    if (from1) {
        pairs_out_0[dst] = uvec2(key, value);
    } else {
        pairs_out_1[dst] = uvec2(key, value);
    }
}

// Counts the keys [range.x, range.y) of buffer 1 by each digit the passes sort by.
void count_digits(uvec2 range) {
    for (uint d = 0u; d < SORT_OWN_RADIX; ++d) {
        [[unroll]] for (uint k = 0u; k < LOCAL_PASSES; ++k) {
            counts[k][d] = 0u;
        }
    }
    // Whole groups of four keys without a test per key, the first and last 0-3 one by one
    // (a bucket starts anywhere), as in sort_count_own_counts_body.glsl.
    uvec2 groups = groups_of_four(range);
    uint aligned = groups.x;
    uint whole = groups.y;
    uint head = aligned - range.x;
    for (uint i = aligned; i < whole; i += 4u) {
        uvec4 keys, values;
        load_four(true, i, keys, values);
        [[unroll]] for (uint j = 0u; j < 4u; ++j) {
            [[unroll]] for (uint k = 0u; k < LOCAL_PASSES; ++k) {
                counts[k][key_digit(keys[j], k * SORT_OWN_RADIX_BITS, SORT_OWN_RADIX - 1u)] += 1u;
            }
        }
    }
    for (uint n = 0u; n < head + (range.y - whole); ++n) {
        uint key = load_one(true, n < head ? range.x + n : whole + (n - head)).x;
        [[unroll]] for (uint k = 0u; k < LOCAL_PASSES; ++k) {
            counts[k][key_digit(key, k * SORT_OWN_RADIX_BITS, SORT_OWN_RADIX - 1u)] += 1u;
        }
    }
}

// Pass k over the bucket's keys [range.x, range.y), by digit k: from buffer 1 to buffer 0
// (`from1`, even k) or back.
void local_pass(uint k, bool from1, uvec2 range) {
    uint shift = k * SORT_OWN_RADIX_BITS;
    // Each digit value's first position: the bucket's start plus the keys of the smaller ones.
    uint next = range.x;
    for (uint d = 0u; d < SORT_OWN_RADIX; ++d) {
        uint c = counts[k][d];
        counts[k][d] = next;
        next += c;
    }
    // In order, which keeps the sort stable: the first keys, the groups of four, the last.
    uvec2 groups = groups_of_four(range);
    uint aligned = groups.x;
    uint whole = groups.y;
    for (uint i = range.x; i < aligned; ++i) {
        uvec2 pair = load_one(from1, i);
        scatter_pair(k, from1, shift, pair.x, pair.y);
    }
    for (uint i = aligned; i < whole; i += 4u) {
        uvec4 keys, values;
        load_four(from1, i, keys, values);
        [[unroll]] for (uint j = 0u; j < 4u; ++j) {
            scatter_pair(k, from1, shift, keys[j], values[j]);
        }
    }
    for (uint i = whole; i < range.y; ++i) {
        uvec2 pair = load_one(from1, i);
        scatter_pair(k, from1, shift, pair.x, pair.y);
    }
}

void main() {
    uvec2 range = pc.table.v[gl_GlobalInvocationID.x].xy;
    count_digits(range);
    local_pass(0u, true, range);
    local_pass(1u, false, range);
#if LOCAL_PASSES == 3
    local_pass(2u, true, range);
#endif
}
