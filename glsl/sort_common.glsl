// Radix sort of (uvec2 key, uint value) pairs: layout of the sort's scratch buffer and the digit
// extraction shared by its kernels. Keys are 64-bit as (low word, high word).
#ifndef RARA_SORT_COMMON_GLSL
#define RARA_SORT_COMMON_GLSL

// Scratch header, followed (at SORT_HIST_OFFSET bytes) by the block histograms.
struct SortInfo {
    uint num_keys;      // min(count, capacity)
    uint num_blocks;    // div_ceil(num_keys, SORT_BLOCK)
    uint hist_len;      // SORT_RADIX * num_blocks, the length of the histogram scan
    uint pad;
    uvec4 block_args;   // indirect dispatch: one workgroup per block
    uvec4 linear_args;  // indirect dispatch: one invocation per key, LINEAR_WORKGROUP wide
};
layout(buffer_reference, std430, buffer_reference_align = 16) buffer SortInfoRef { SortInfo s; };

uint key_digit(uvec2 key, uint shift) {
    uint word = shift < 32u ? key.x : key.y;
    return (word >> (shift & 31u)) & (SORT_RADIX - 1u);
}

#endif
