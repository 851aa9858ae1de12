// Radix sort of (uint key, uint value) pairs: layout of the sort's scratch buffer and the digit
// extraction shared by its kernels.
#ifndef RARA_SORT_COMMON_GLSL
#define RARA_SORT_COMMON_GLSL

// Scratch header, followed (at SORT_HIST_OFFSET bytes) by the block histograms.
struct SortInfo {
    uint num_keys;      // min(count, capacity)
    uint num_blocks;    // div_ceil(num_keys, block_keys)
    uint hist_len;      // entries per block (the layout's) * num_blocks: the histogram scan
    uint block_keys;    // keys per block, as sort_prepare.comp chose them
    uvec4 block_args;   // indirect dispatch: one workgroup per block
    uvec4 linear_args;  // indirect dispatch: one invocation per key, LINEAR_WORKGROUP wide
    // Segmented sorts (CPU-driver layout, sort_segments.comp): the first pass sorts by the top
    // digit, and the passes after it sort each of its buckets on its own by the other digits,
    // least significant first.
    uint segmented;     // 1 for a segmented sort
    uint seg_runs;      // runs of the passes that sort the buckets in runs (SortRuns below)
    uvec2 seg_pad;
    uvec4 pass_args[3]; // indirect dispatch of passes 1, 2, 3: a workgroup per SORT_OWN_WORKGROUP
                        // runs of a segmented sort, none for a pass that sort_local_*
                        // made, block_args where the sort is not segmented
    uvec4 local_args;   // indirect dispatch of sort_local_*: a workgroup per
                        // SORT_OWN_WORKGROUP buckets where every bucket is small enough
};
layout(buffer_reference, std430, buffer_reference_align = 16) buffer SortInfoRef { SortInfo s; };

// The digit of `key` at bit `shift`; `digit_mask` is the radix - 1 except in a last pass that
// reaches past the key bits being sorted, whose bits above them it leaves out.
uint key_digit(uint key, uint shift, uint digit_mask) {
    return (key >> shift) & digit_mask;
}

// Keys [range.x, range.y) as the own-counts and local kernels walk them, four at a time from a
// texel of four (or two of two) where they can: (aligned, whole), the keys [range.x, aligned)
// before the first multiple of 4 (0-3 keys), the whole groups of four [aligned, whole), and
// the last 0-3 keys [whole, range.y).
uvec2 groups_of_four(uvec2 range) {
    uint aligned = min((range.x + 3u) & ~3u, range.y);
    return uvec2(aligned, aligned + ((range.y - aligned) & ~3u));
}

// A segmented sort's table (sort_segments.comp): its SORT_OWN_RADIX buckets, keys [x, y) each,
// then from entry SORT_OWN_RADIX on the runs of its passes after the first, a uvec4 each:
// keys [x, y) of one bucket, whose count of digit d goes to hist[z + d w].
layout(buffer_reference, std430, buffer_reference_align = 16) buffer SortRuns { uvec4 v[]; };

#endif
