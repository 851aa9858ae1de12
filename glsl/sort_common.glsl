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
};
layout(buffer_reference, std430, buffer_reference_align = 16) buffer SortInfoRef { SortInfo s; };

// The digit of `key` at bit `shift`; `digit_mask` is the radix - 1 except in a last pass that
// reaches past the key bits being sorted, whose bits above them it leaves out.
uint key_digit(uint key, uint shift, uint digit_mask) {
    return (key >> shift) & digit_mask;
}

#endif
