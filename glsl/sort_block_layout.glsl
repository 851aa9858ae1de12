// The block layout of the radix-sort pass kernels (count and scatter, included by both bodies):
// SORT_WG invocations of SORT_RUN consecutive keys each make one block of SORT_BLOCK keys. The
// sort_{count,scatter}[_long_runs].comp wrappers pick SORT_WG and SORT_RUN (one SortLayout).
#if !defined(SORT_WG) || !defined(SORT_RUN) || SORT_WG * SORT_RUN != SORT_BLOCK
#error "define SORT_WG (invocations) and SORT_RUN (keys each) with SORT_WG * SORT_RUN == SORT_BLOCK"
#endif
#if SORT_RUN % 4 != 0
#error "SORT_RUN must be a multiple of 4: the pass kernels read keys and values four at a time"
#endif

layout(local_size_x = SORT_WG) in;
