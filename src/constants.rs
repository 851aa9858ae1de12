// Integer constants shared by the host and the GLSL kernels.
//
// This file is the single source of truth: `build.rs` includes it and passes every entry of
// [`SHADER_DEFINES`] to the shader compiler as a macro, so the kernels and the host code that
// sizes their dispatches and buffers cannot drift apart.

/// Side of a square screen tile in pixels (SPEC section 3).
pub const TILE_SIZE: u32 = 16;
/// Threads per workgroup of the rasterizer: one per pixel of a tile.
pub const RASTER_WORKGROUP: u32 = TILE_SIZE * TILE_SIZE;
/// Most tile-list entries one rasterizer round walks per tile. lavapipe stops an invocation's
/// loops after 65,535 iterations in total. The rara rasterizer's loops take up to 4 passes per
/// entry: a cutoff splat takes its pass of the cutoff loop, up to two of the ends of its
/// visible interval and, in the strips kernels, one of the loop that passes over the entries
/// missing the invocation's block (at most one pass per entry it passes over); a plain and a cutoff
/// splat in turn take seven between them (those, one of the plain loop and its block loop,
/// one of the outer loop), and each loop at most one empty pass per batch walked; the
/// pixel-per-invocation layout's staging adds one per batch of 256 entries. So longer lists are
/// split over several rounds (dispatches) that carry the per-pixel state in a buffer;
/// 12,288 x 4 = 49,152 keeps a margin under the cap.
pub const RASTER_CHUNK: u32 = 12288;
/// Most cells of a splat's tile rectangle one invocation walks per round, for the same cap:
/// project counting the tiles a splat touches, emit writing its pairs. A splat that covers
/// more of a large image (from 2,896 x 2,896 pixels up) takes several rounds (dispatches),
/// each carrying on where the last stopped.
pub const TILE_RECT_CHUNK: u32 = 32768;
/// Most loop iterations one invocation of the cutoff-tiles kernel takes, for the same cap: it
/// classifies pairs until this over (1 + clip planes) passes are spent, and leaves the pairs
/// after them unclassified, which draws them exactly at the partial pairs' cost. A CPU driver's
/// SIMD vector of 8 invocations reaches it only past about 131,000 pairs (one plane) for the
/// workgroup's 256 cutoff splats.
pub const CUTOFF_TILES_LOOP_BUDGET: u32 = 32768;
/// Threads per workgroup of the one-item-per-thread kernels (project, emit, tile ranges).
pub const LINEAR_WORKGROUP: u32 = 256;

/// Most workgroups a linear kernel (project, emit, tile ranges) dispatches along X. Vulkan
/// guarantees only 65,535 (`maxComputeWorkGroupCount[0]`, lavapipe's value), so longer
/// dispatches become a 2D grid of rows of this many workgroups: 16.7M items per row.
pub const LINEAR_GRID_X: u32 = 65535;
/// Threads per workgroup of the prefix-sum kernels.
pub const SCAN_WORKGROUP: u32 = 256;
/// Elements each prefix-sum thread handles; a scan block is `SCAN_WORKGROUP * SCAN_ITEMS`.
pub const SCAN_ITEMS: u32 = 4;
/// Elements one scan workgroup handles.
pub const SCAN_BLOCK: u32 = SCAN_WORKGROUP * SCAN_ITEMS;
/// Recursion depth of the prefix sum: it scans up to `SCAN_BLOCK^SCAN_LEVELS` elements.
pub const SCAN_LEVELS: u32 = 3;
/// Consecutive elements each thread of the CPU-driver prefix sum (`ScanLayout::Runs`) sums
/// and then scans on its own (a multiple of 4: read four at a time).
pub const SCAN_RUN: u32 = 512;
/// Threads per workgroup of the CPU-driver prefix sum (one SIMD vector on lavapipe).
pub const SCAN_RUN_WORKGROUP: u32 = 8;
/// Most elements the CPU-driver prefix sum scans (67,108,864): one invocation scans the runs'
/// sums four at a time, and that loop stays at half of lavapipe's cap of 65,535 loop
/// iterations per invocation (32,768 rounds).
pub const SCAN_RUNS_MAX: u64 = SCAN_RUN as u64 * 4 * 32768;
const _: () = assert!(SCAN_RUN % 4 == 0);
const _: () =
    assert!(SCAN_RUNS_MAX / SCAN_RUN as u64 <= SCAN_RUN_WORKGROUP as u64 * LINEAR_GRID_X as u64);

/// Most Gaussians a scene may have: the prefix sum over them dispatches one workgroup per
/// `SCAN_BLOCK` elements along X (67,107,840).
pub const MAX_GAUSSIANS: u64 = SCAN_BLOCK as u64 * LINEAR_GRID_X as u64;
const _: () = assert!(MAX_GAUSSIANS <= PAIR_WEIGHTED as u64);
const _: () = assert!(MAX_GAUSSIANS <= SCAN_RUNS_MAX);
/// Bits per radix-sort digit in the GPU layout (`SortLayout::ShortRuns`).
pub const SORT_RADIX_BITS: u32 = 4;
/// Buckets per radix-sort digit in the GPU layout.
pub const SORT_RADIX: u32 = 1 << SORT_RADIX_BITS;
/// Keys one radix-sort workgroup handles in the GPU layout (`SortLayout::ShortRuns`).
pub const SORT_BLOCK: u32 = 4096;
/// Threads per workgroup of the radix-sort count and scatter kernels in the GPU layout
/// (`SortLayout::ShortRuns`).
pub const SORT_WORKGROUP: u32 = 256;
/// Consecutive keys each sort thread owns within its block in the GPU layout (the scatter
/// keeps their order, which makes the sort stable).
pub const SORT_ITEMS: u32 = SORT_BLOCK / SORT_WORKGROUP;
/// Bits per radix-sort digit in the CPU-driver layout (`SortLayout::OwnCounts`).
pub const SORT_OWN_RADIX_BITS: u32 = 8;
/// Buckets per radix-sort digit in the CPU-driver layout.
pub const SORT_OWN_RADIX: u32 = 1 << SORT_OWN_RADIX_BITS;
/// Threads per sort workgroup in the CPU-driver layout (one SIMD vector on lavapipe); each
/// keeps its run's histogram in a private array (1 KiB per thread).
pub const SORT_OWN_WORKGROUP: u32 = 8;
/// Consecutive keys each sort thread owns in the CPU-driver layout, at the least: a sort with
/// many keys gives them longer runs (up to [`SORT_OWN_MAX_ITEMS`]; see
/// [`SORT_PARALLEL_BLOCKS`]).
pub const SORT_OWN_MIN_ITEMS: u32 = 4096;
/// The longest run of keys a sort thread owns in the CPU-driver layout: its loops take 4,096
/// passes of 4 keys and 512 over its counters, far under lavapipe's cap of 65,535.
pub const SORT_OWN_MAX_ITEMS: u32 = 16384;
/// Keys one radix-sort workgroup handles in the CPU-driver layout, at the least: more than
/// [`SORT_BLOCK`], since every run costs its thread two passes over its whole histogram.
pub const SORT_OWN_MIN_BLOCK: u32 = SORT_OWN_WORKGROUP * SORT_OWN_MIN_ITEMS;
/// Keys one radix-sort workgroup handles in the CPU-driver layout, at the most.
pub const SORT_OWN_MAX_BLOCK: u32 = SORT_OWN_WORKGROUP * SORT_OWN_MAX_ITEMS;
const _: () = assert!(SORT_OWN_MIN_BLOCK >= SORT_BLOCK);
const _: () = assert!(SORT_OWN_MAX_BLOCK.is_power_of_two() && SORT_OWN_MIN_BLOCK.is_power_of_two());
/// Blocks a sort keeps at the least where its layout's blocks can grow (the CPU-driver
/// layout): the sort doubles its block size while that leaves this many blocks or more, so
/// that a CPU driver's threads still share the work while each run's fixed cost (two passes
/// over the run's histogram, the histogram's scan) shrinks. lavapipe, 2 threads,
/// `bench --sort 2000000` (16 blocks of 16,384-key runs against 62 of 4,096), eight runs in
/// turn: median 56.6 -> 51.0 ms.
pub const SORT_PARALLEL_BLOCKS: u32 = 16;
/// Sorts of this many keys or more are segmented in the CPU-driver layout on CPU devices (of
/// 3 or 4 radix passes; see `RadixSort::set_segment_min_keys`): the first pass sorts by the
/// top digit, and then one invocation per bucket sorts it by the other digits
/// (`glsl/sort_segments.comp`, `glsl/sort_local_body.glsl`), its keys staying in the cache from
/// pass to pass instead of streaming through it twice a pass. lavapipe, `bench --sort`,
/// random 32-bit keys, segmented against not, three runs each in turn in a noisy hour:
/// 4,000,000 keys 73-85 against 98-122 ms, 1,048,576 keys 18.5-22.1 against 23.4-33.3 ms,
/// 524,288 keys 8.4-13.8 against 10.8-21.0 ms, 262,144 keys 5.2-6.3 against 6.2-7.6 ms. Keys
/// whose top digit takes few values (depths) fill buckets too large for one invocation and
/// gain nothing (runs within the buckets: 21-29 against 24-31 ms at 1,048,576, 45-58 against
/// 46-67 ms at 2,000,000). The threshold keeps the frames' sorts of the scenes measured here
/// (up to 500k Gaussians, tile sorts of 2 passes) as they were.
pub const SORT_SEGMENT_MIN_KEYS: u32 = 1 << 20;
/// The loop iterations that one invocation of `glsl/sort_local_body.glsl` may take: it sorts
/// a whole bucket of a segmented sort by the digits after the top one, so the bucket's size
/// is bounded ([`local_max_keys`](crate::stages::sort::local_max_keys)) to keep it under
/// lavapipe's cap of 65,535 loop iterations per invocation, with a margin. Where a bucket is
/// larger, the passes after the first sort all the keys, each bucket's runs apart.
pub const SORT_LOCAL_LOOP_BUDGET: u32 = 58_000;
/// Smallest subgroup size the kernels support (real devices have 4 or more): the sort's
/// scatter and the workgroup scan keep one shared-memory slot per subgroup.
pub const MIN_SUBGROUP_SIZE: u32 = 4;

/// Most (tile, splat) pairs one frame sorts: the sort dispatches one workgroup per
/// `SORT_BLOCK` keys along X (268,431,360; 6.4 GB of sort buffers; the CPU layout's blocks are
/// larger). A frame with more is drawn incomplete and flagged.
pub const MAX_INTERSECTIONS: u64 = SORT_BLOCK as u64 * LINEAR_GRID_X as u64;
/// Slots of the per-frame counters buffer (`uint` indices), written by the kernels and read
/// back by the host after the frame.
pub const COUNTER_INTERSECTIONS: u32 = 0;
/// Counter slot: longest tile list seen by the rasterizer.
pub const COUNTER_MAX_TILE_LEN: u32 = 1;
/// Counter slot: Gaussians that touch at least one tile (the total of the drawn flags' scan;
/// the depth sort sorts this many).
pub const COUNTER_VISIBLE: u32 = 2;
/// Counter slot: Gaussians classified as cutoff by the clip test.
pub const COUNTER_CUTOFF: u32 = 3;
/// Counter slot: entries the sort actually processes (`min(intersections, capacity)`).
pub const COUNTER_SORT_COUNT: u32 = 4;
/// Counter slot: cutoff splats' pairs classified (0 when the frame did not classify them): by
/// the cutoff-tiles stage, or all of a splat's at once where its bounds over the whole
/// footprint decide them ([`COUNTER_CUTOFF_WHOLE`]).
pub const COUNTER_CUTOFF_PAIRS: u32 = 5;
/// Counter slot: of those, pairs drawn as plain splats (weight 1 across the tile).
pub const COUNTER_CUTOFF_PAIRS_WEIGHT_ONE: u32 = 6;
/// Counter slot: of those, pairs dropped from the tile lists (nothing added to the tile).
pub const COUNTER_CUTOFF_PAIRS_EMPTY: u32 = 7;
/// Counter slot: tiles the weighted rasterize kernel walked, with the tile lists (CPU drivers,
/// rara clipping by planes with the mass weight; else 0).
pub const COUNTER_WEIGHTED_TILES: u32 = 8;
/// Counter slot: Gaussians not drawn because their footprint exceeds
/// [`MAX_FOOTPRINT_SIGMA_PX`].
pub const COUNTER_OVERSIZED: u32 = 9;
/// Counter slot: cutoff splats whose bounds over the whole footprint decided every pair of
/// theirs at once, weight 1 or nothing wherever they reach (`cutoff_splat_class` in
/// `glsl/clip.glsl`; 0 when the frame did not classify cutoff pairs).
pub const COUNTER_CUTOFF_WHOLE: u32 = 10;
/// Number of counter slots.
pub const COUNTER_SLOTS: u32 = 11;

/// The footprint bound (docs/ARCHITECTURE.md, "Extreme scales"): a Gaussian is not drawn when
/// one of its three scaled axes, projected by the Jacobian onto the image's x or y axis, spans
/// more than this many pixels (`|m_k| > B` for a component of `m0 = S R^T J_0^T` or
/// `m1 = S R^T J_1^T`). That is 4x the largest image side: such a splat is a line or a wash
/// across the whole image, and past it `f32` no longer holds its covariance (a log-scale of 12
/// seen from a few units away already projects to 10^7 px). Both paths test it before any
/// product that could overflow, and count what it skips (`FrameStats::oversized`).
pub const MAX_FOOTPRINT_SIGMA_PX: u32 = 65536;

/// Bit of a pair's value (the splat index) that marks a pair the rasterizer draws with the
/// per-pixel clip weight: emit sets it on every pair of a cutoff splat, and the cutoff-tiles
/// stage clears it where the weight is 1 at every pixel of the pair's tile. Splat indices stay
/// below `MAX_GAUSSIANS` < 2^31.
pub const PAIR_WEIGHTED: u32 = 1 << 31;
/// Lowest of the four bits of a pair's value that say which 8x8 blocks of its tile the splat's
/// footprint reaches (bit `PAIR_BLOCKS_SHIFT + 2 by + bx` for the block at pixel offset
/// `(8 bx, 8 by)`): emit sets them, and the CPU-driver rasterizer, one SIMD vector per block,
/// skips the pairs whose footprint misses its block.
pub const PAIR_BLOCKS_SHIFT: u32 = 27;
/// The splat index in a pair's value (below the block bits and `PAIR_WEIGHTED`).
pub const PAIR_INDEX_MASK: u32 = (1 << PAIR_BLOCKS_SHIFT) - 1;
/// Side in pixels of a tile's blocks (`PAIR_BLOCKS_SHIFT`).
pub const BLOCK_SIZE: u32 = TILE_SIZE / 2;
const _: () = assert!(MAX_GAUSSIANS <= PAIR_INDEX_MASK as u64 + 1);

/// Specialization constant id of `FLAT_SPLATS` (`glsl/clip.glsl`): whether the frame may hold
/// flat Gaussians (SPEC section 6); the rasterize kernels of frames without any are built with
/// it false.
pub const FLAT_SPLATS_CONSTANT_ID: u32 = 0;
/// Specialization constant id of `COMPOSITE_OVER` (`glsl/write_target_body.glsl`): the
/// write-target kernels for [`crate::target::Composite::Background`] are built with it false.
pub const TARGET_OVER_CONSTANT_ID: u32 = 1;
/// Specialization constant id of `WRITES_TARGET` (`glsl/rasterize_body.glsl`): the strips
/// kernels built with it true write the caller's RGBA8 buffer target themselves, over the
/// background, in place of the per-pixel state (frames of one round, no depth; see
/// `Renderer::record`).
pub const RASTER_WRITES_TARGET_CONSTANT_ID: u32 = 2;
/// Specialization constant id of `LISTS_CUTOFF` (`glsl/project_body.glsl`): what the project
/// kernels write for the cutoff Gaussians, one of the `PROJECT_LISTS_*` values.
pub const PROJECT_LISTS_CUTOFF_CONSTANT_ID: u32 = 3;
/// Specialization constant id of `CLIP_PLANE_SLOTS` (`glsl/project_body.glsl`): how many of the
/// clip region's plane slots the project kernel classifies a Gaussian against, one of the
/// `PROJECT_CLIP_*` values ([`crate::stages::project::PlaneSlots`]).
pub const PROJECT_CLIP_SLOTS_CONSTANT_ID: u32 = 4;
/// Specialization constant id of `MASS_ONE_END` (`glsl/rasterize_body.glsl`): the mass-weight
/// rasterize kernels built with it true take one bounded end per ray, which every region of
/// one plane gives ([`crate::stages::rasterize::MassEnds`]).
pub const RASTER_MASS_ONE_END_CONSTANT_ID: u32 = 5;
/// `CLIP_PLANE_SLOTS` of frames without a clip region: no classification at all.
pub const PROJECT_CLIP_NONE: u32 = 0;
/// `CLIP_PLANE_SLOTS` of regions of at most one plane (a plane, a sphere): the first slot.
pub const PROJECT_CLIP_ONE_PLANE: u32 = 1;
/// `LISTS_CUTOFF` of frames without rara clipping, which have no cutoff Gaussian: nothing.
pub const PROJECT_LISTS_NONE: u32 = 0;
/// `LISTS_CUTOFF` of rara frames: each cutoff Gaussian's record index, in its splat, and the
/// Gaussian under that index, for the records' pass.
pub const PROJECT_LISTS_RECORDS: u32 = 1;
/// `LISTS_CUTOFF` of rara frames of several objects clipped by regions of their own: also
/// each record's region.
pub const PROJECT_LISTS_REGIONS: u32 = 2;
/// `LISTS_CUTOFF` of rara frames of one region on the GPU layout (buffer-load kernels): each
/// cutoff Gaussian's record index, in its splat, and the record itself, so the frame has no
/// records' pass.
pub const PROJECT_LISTS_WRITES: u32 = 3;

/// Most half-spaces one clip region may have (an oriented box uses six).
pub const MAX_CLIP_PLANES: u32 = 16;
/// Clip mode `none` (SPEC section 5): nothing is clipped.
pub const CLIP_MODE_NONE: u32 = 0;
/// Clip mode `hard`: a Gaussian is drawn when its centre is visible, else dropped.
pub const CLIP_MODE_HARD: u32 = 1;
/// Clip mode `rara`: dropped / drawn / cutoff with a per-pixel weight.
pub const CLIP_MODE_RARA: u32 = 2;
/// Cutoff weight `mass`: the probability mass of the Gaussian along the ray that is visible.
pub const CLIP_WEIGHT_MASS: u32 = 0;
/// Cutoff weight `length`: the visible fraction of the ray's chord through the band ellipsoid.
pub const CLIP_WEIGHT_LENGTH: u32 = 1;
/// Clip flag: the visible set is the complement of the region (a cutaway).
pub const CLIP_FLAG_INVERT: u32 = 1;
/// Clip flag: every Gaussian that is not dropped is cutoff (the paper's "w/o RaRa" ablation).
pub const CLIP_FLAG_TRACE_ALL: u32 = 2;
/// Clip flag: the region is a sphere, not an intersection of half-spaces.
pub const CLIP_FLAG_SPHERE: u32 = 4;

/// Ray tracer stack entries per ray (`glsl/trace_body.glsl`): the BVH's depth is at most 63.
pub const TRACE_STACK: u32 = 64;
/// Ray tracer counter slot: hits composited (or skipped for alpha), over all rays.
pub const TRACE_COUNTER_WALKED: u32 = 0;
/// Ray tracer counter slot: rays the hit cap cut short.
pub const TRACE_COUNTER_CAPPED: u32 = 1;
/// Ray tracer counter slot: hits put in the k-buffers.
pub const TRACE_COUNTER_FOUND: u32 = 2;
/// Ray tracer counter slot: traversal stack overflows (never expected).
pub const TRACE_COUNTER_OVERFLOW: u32 = 3;
/// Ray tracer counter slot: traversal passes over all rays.
pub const TRACE_COUNTER_PASSES: u32 = 4;
/// Ray tracer counter slots: node visits over all rays, a low word and its carry word.
pub const TRACE_COUNTER_VISITS_LO: u32 = 5;
/// See [`TRACE_COUNTER_VISITS_LO`].
pub const TRACE_COUNTER_VISITS_HI: u32 = 6;
/// Ray tracer counter slots: Gaussians tested for a hit over all rays (the leaves a BVH pass
/// reached; with tile lists, the entries whose rectangle holds the pixel), a low word and its
/// carry word.
pub const TRACE_COUNTER_TESTS_LO: u32 = 7;
/// See [`TRACE_COUNTER_TESTS_LO`].
pub const TRACE_COUNTER_TESTS_HI: u32 = 8;
/// Words of the ray tracer's counters; its per-ray histograms follow them.
pub const TRACE_COUNTER_WORDS: u32 = 10;
/// Bins of each of the ray tracer's per-ray histograms (hits composited, hits found, passes);
/// the last bin holds that many or more.
pub const TRACE_HIST_BINS: u32 = 1024;

/// Bytes of a `ClipParams` (`GpuClipParams`): the mixed tracer reads splat object k's at k
/// times this.
pub const CLIP_PARAMS_BYTES: u32 = 48 + 16 * MAX_CLIP_PLANES;

/// Mixed scenes (SPEC section 8): lights a scene holds at most.
pub const MIXED_MAX_LIGHTS: u32 = 4;
/// Mixed scenes: splat objects a scene holds at most (their first Gaussians are a buffer of
/// their own, searched in halves per composited hit).
pub const MIXED_MAX_OBJECTS: u32 = 64;
/// Mixed scenes: pending rays per pixel (`glsl/mixed_spawn.comp`): a depth-first ray tree of
/// depth 8 leaves at most one sibling per level and the shadow rays of one diffuse hit.
pub const MIXED_STACK: u32 = 12;
/// Mixed scenes: entries of a BVH traversal stack over the triangles (the tree of at most
/// 4,194,304 triangles, four to a leaf, is 21 levels deep).
pub const MIXED_MESH_STACK: u32 = 32;
/// Mixed counter slot: rays the next generation traces.
pub const MIXED_COUNTER_LIVE: u32 = 0;
/// Mixed counter slot: camera rays.
pub const MIXED_COUNTER_PRIMARY: u32 = 1;
/// Mixed counter slot: reflected and refracted rays.
pub const MIXED_COUNTER_SECONDARY: u32 = 2;
/// Mixed counter slot: shadow rays.
pub const MIXED_COUNTER_SHADOW: u32 = 3;
/// Mixed counter slot: branches the depth or weight limit cut.
pub const MIXED_COUNTER_CUT: u32 = 4;
/// Mixed counter slot: rays a full pixel stack dropped (never expected).
pub const MIXED_COUNTER_OVERFLOW: u32 = 5;
/// Mixed counter slot: rays whose walk through the meshes' BVH in the ray tree's pass took
/// more than [`MIXED_MESH_VISITS_MAX`] node visits (an error: near lavapipe's loop cap).
pub const MIXED_COUNTER_LONG_WALKS: u32 = 6;
/// Node visits one mesh traversal of the ray tree's pass may take before the frame is
/// refused: lavapipe stops an invocation after 65,535 loop iterations in all (PLATFORM.md), and
/// the tree's pass has no rounds. A balanced tree of millions of triangles takes tens to
/// thousands of visits a ray.
pub const MIXED_MESH_VISITS_MAX: u32 = 49152;
/// Mixed counter words.
pub const MIXED_COUNTER_WORDS: u32 = 8;

/// Every constant above, by the macro name the kernels see.
pub const SHADER_DEFINES: &[(&str, u32)] = &[
    ("TILE_SIZE", TILE_SIZE),
    ("RASTER_WORKGROUP", RASTER_WORKGROUP),
    ("RASTER_CHUNK", RASTER_CHUNK),
    ("TILE_RECT_CHUNK", TILE_RECT_CHUNK),
    ("CUTOFF_TILES_LOOP_BUDGET", CUTOFF_TILES_LOOP_BUDGET),
    ("LINEAR_WORKGROUP", LINEAR_WORKGROUP),
    ("LINEAR_GRID_X", LINEAR_GRID_X),
    ("SCAN_WORKGROUP", SCAN_WORKGROUP),
    ("SCAN_ITEMS", SCAN_ITEMS),
    ("SCAN_BLOCK", SCAN_BLOCK),
    ("SCAN_RUN", SCAN_RUN),
    ("SCAN_RUN_WORKGROUP", SCAN_RUN_WORKGROUP),
    ("SORT_RADIX_BITS", SORT_RADIX_BITS),
    ("SORT_RADIX", SORT_RADIX),
    ("SORT_WORKGROUP", SORT_WORKGROUP),
    ("SORT_ITEMS", SORT_ITEMS),
    ("SORT_OWN_RADIX_BITS", SORT_OWN_RADIX_BITS),
    ("SORT_OWN_RADIX", SORT_OWN_RADIX),
    ("SORT_OWN_WORKGROUP", SORT_OWN_WORKGROUP),
    ("SORT_OWN_MIN_ITEMS", SORT_OWN_MIN_ITEMS),
    ("SORT_PARALLEL_BLOCKS", SORT_PARALLEL_BLOCKS),
    ("MIN_SUBGROUP_SIZE", MIN_SUBGROUP_SIZE),
    ("SORT_BLOCK", SORT_BLOCK),
    ("COUNTER_INTERSECTIONS", COUNTER_INTERSECTIONS),
    ("COUNTER_MAX_TILE_LEN", COUNTER_MAX_TILE_LEN),
    ("COUNTER_VISIBLE", COUNTER_VISIBLE),
    ("COUNTER_CUTOFF", COUNTER_CUTOFF),
    ("COUNTER_SORT_COUNT", COUNTER_SORT_COUNT),
    ("COUNTER_CUTOFF_PAIRS", COUNTER_CUTOFF_PAIRS),
    (
        "COUNTER_CUTOFF_PAIRS_WEIGHT_ONE",
        COUNTER_CUTOFF_PAIRS_WEIGHT_ONE,
    ),
    ("COUNTER_CUTOFF_PAIRS_EMPTY", COUNTER_CUTOFF_PAIRS_EMPTY),
    ("COUNTER_WEIGHTED_TILES", COUNTER_WEIGHTED_TILES),
    ("COUNTER_OVERSIZED", COUNTER_OVERSIZED),
    ("COUNTER_CUTOFF_WHOLE", COUNTER_CUTOFF_WHOLE),
    ("MAX_FOOTPRINT_SIGMA_PX", MAX_FOOTPRINT_SIGMA_PX),
    ("PAIR_WEIGHTED", PAIR_WEIGHTED),
    ("PAIR_BLOCKS_SHIFT", PAIR_BLOCKS_SHIFT),
    ("PAIR_INDEX_MASK", PAIR_INDEX_MASK),
    ("BLOCK_SIZE", BLOCK_SIZE),
    ("MAX_CLIP_PLANES", MAX_CLIP_PLANES),
    ("FLAT_SPLATS_CONSTANT_ID", FLAT_SPLATS_CONSTANT_ID),
    ("TARGET_OVER_CONSTANT_ID", TARGET_OVER_CONSTANT_ID),
    (
        "RASTER_WRITES_TARGET_CONSTANT_ID",
        RASTER_WRITES_TARGET_CONSTANT_ID,
    ),
    (
        "PROJECT_LISTS_CUTOFF_CONSTANT_ID",
        PROJECT_LISTS_CUTOFF_CONSTANT_ID,
    ),
    (
        "PROJECT_CLIP_SLOTS_CONSTANT_ID",
        PROJECT_CLIP_SLOTS_CONSTANT_ID,
    ),
    (
        "RASTER_MASS_ONE_END_CONSTANT_ID",
        RASTER_MASS_ONE_END_CONSTANT_ID,
    ),
    ("PROJECT_CLIP_NONE", PROJECT_CLIP_NONE),
    ("PROJECT_CLIP_ONE_PLANE", PROJECT_CLIP_ONE_PLANE),
    ("PROJECT_LISTS_NONE", PROJECT_LISTS_NONE),
    ("PROJECT_LISTS_RECORDS", PROJECT_LISTS_RECORDS),
    ("PROJECT_LISTS_REGIONS", PROJECT_LISTS_REGIONS),
    ("PROJECT_LISTS_WRITES", PROJECT_LISTS_WRITES),
    ("CLIP_MODE_NONE", CLIP_MODE_NONE),
    ("CLIP_MODE_HARD", CLIP_MODE_HARD),
    ("CLIP_MODE_RARA", CLIP_MODE_RARA),
    ("CLIP_WEIGHT_MASS", CLIP_WEIGHT_MASS),
    ("CLIP_WEIGHT_LENGTH", CLIP_WEIGHT_LENGTH),
    ("CLIP_FLAG_INVERT", CLIP_FLAG_INVERT),
    ("CLIP_FLAG_TRACE_ALL", CLIP_FLAG_TRACE_ALL),
    ("CLIP_FLAG_SPHERE", CLIP_FLAG_SPHERE),
    ("TRACE_STACK", TRACE_STACK),
    ("TRACE_COUNTER_WALKED", TRACE_COUNTER_WALKED),
    ("TRACE_COUNTER_CAPPED", TRACE_COUNTER_CAPPED),
    ("TRACE_COUNTER_FOUND", TRACE_COUNTER_FOUND),
    ("TRACE_COUNTER_OVERFLOW", TRACE_COUNTER_OVERFLOW),
    ("TRACE_COUNTER_PASSES", TRACE_COUNTER_PASSES),
    ("TRACE_COUNTER_VISITS_LO", TRACE_COUNTER_VISITS_LO),
    ("TRACE_COUNTER_VISITS_HI", TRACE_COUNTER_VISITS_HI),
    ("TRACE_COUNTER_TESTS_LO", TRACE_COUNTER_TESTS_LO),
    ("TRACE_COUNTER_TESTS_HI", TRACE_COUNTER_TESTS_HI),
    ("TRACE_COUNTER_WORDS", TRACE_COUNTER_WORDS),
    ("TRACE_HIST_BINS", TRACE_HIST_BINS),
    ("CLIP_PARAMS_BYTES", CLIP_PARAMS_BYTES),
    ("MIXED_MAX_LIGHTS", MIXED_MAX_LIGHTS),
    ("MIXED_MAX_OBJECTS", MIXED_MAX_OBJECTS),
    ("MIXED_STACK", MIXED_STACK),
    ("MIXED_MESH_STACK", MIXED_MESH_STACK),
    ("MIXED_COUNTER_LIVE", MIXED_COUNTER_LIVE),
    ("MIXED_COUNTER_PRIMARY", MIXED_COUNTER_PRIMARY),
    ("MIXED_COUNTER_SECONDARY", MIXED_COUNTER_SECONDARY),
    ("MIXED_COUNTER_SHADOW", MIXED_COUNTER_SHADOW),
    ("MIXED_COUNTER_CUT", MIXED_COUNTER_CUT),
    ("MIXED_COUNTER_OVERFLOW", MIXED_COUNTER_OVERFLOW),
    ("MIXED_COUNTER_LONG_WALKS", MIXED_COUNTER_LONG_WALKS),
    ("MIXED_MESH_VISITS_MAX", MIXED_MESH_VISITS_MAX),
    ("MIXED_COUNTER_WORDS", MIXED_COUNTER_WORDS),
];
