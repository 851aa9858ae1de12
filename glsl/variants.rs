// The kernel variants, read by build.rs (`include!`): each row is one SPIR-V module, a body of
// this folder compiled with a set of defines. The `.comp` files here are the kernels that are
// their own body; the `*_body.glsl` files are the bodies these rows compile.

/// The kernel variants: one row per SPIR-V module that is a body of `glsl/` compiled with a set
/// of defines. The source each row compiles is written out as a file would be (its description
/// as `//` lines, `#version 460`, the defines, the include) and compiled under the name
/// `glsl/NAME.comp`, so the words, debug strings included, are those a wrapper file gave.
const VARIANTS: &[Variant] = &[
    Variant {
        name: "cutoff_records",
        body: "cutoff_records_body.glsl",
        defines: &[],
        about: &[
            "Stage 1b, cutoff records, through buffer loads (GPUs, frames of several clipped objects;",
            "see cutoff_records_body.glsl).",
        ],
    },
    Variant {
        name: "cutoff_records_texels",
        body: "cutoff_records_body.glsl",
        defines: &["SPLAT_TEXELS"],
        about: &[
            "Stage 1b, cutoff records, reading the Gaussians, the splats and the tiles touched through",
            "the frame's texel views (CPU drivers; see cutoff_records_body.glsl).",
        ],
    },
    Variant {
        name: "cutoff_tiles",
        body: "cutoff_tiles_body.glsl",
        defines: &[],
        about: &[
            "Stage 4b, cutoff tiles, a splat's pairs walked by the invocation that takes it, through",
            "buffer loads (GPUs, RARA_CUTOFF_TILES=splats; see cutoff_tiles_body.glsl).",
        ],
    },
    Variant {
        name: "cutoff_tiles_balanced",
        body: "cutoff_tiles_body.glsl",
        defines: &["BALANCED_PAIRS"],
        about: &[
            "Stage 4b, cutoff tiles, the pairs of a workgroup's cutoff splats shared out over its",
            "invocations (GPUs; see cutoff_tiles_body.glsl).",
        ],
    },
    Variant {
        name: "cutoff_tiles_packed_texels",
        body: "cutoff_tiles_body.glsl",
        defines: &["SPLAT_TEXELS", "PACKED_PAIRS"],
        about: &[
            "Stage 4b, cutoff tiles through the frame's texel views over the packed pairs that",
            "emit_rara_packed_texels writes (CPU drivers; see cutoff_tiles_body.glsl).",
        ],
    },
    Variant {
        name: "cutoff_tiles_texels",
        body: "cutoff_tiles_body.glsl",
        defines: &["SPLAT_TEXELS"],
        about: &[
            "Stage 4b, cutoff tiles, reading the splats, the cutoff records, the tiles touched and the",
            "emitted keys through the frame's texel views (CPU drivers; see cutoff_tiles_body.glsl).",
        ],
    },
    Variant {
        name: "depth_prepare_buffer",
        body: "depth_prepare_body.glsl",
        defines: &[],
        about: &[
            "Depth test, first step: an engine's depth buffer (f32 per pixel) as view depth",
            "(see depth_prepare_body.glsl).",
        ],
    },
    Variant {
        name: "depth_prepare_image",
        body: "depth_prepare_body.glsl",
        defines: &["DEPTH_SOURCE_IMAGE"],
        about: &[
            "Depth test, first step: an engine's depth image, sampled, as view depth",
            "(see depth_prepare_body.glsl).",
        ],
    },
    Variant {
        name: "depth_counts",
        body: "depth_counts_body.glsl",
        defines: &[],
        about: &[
            "Stage 2, depth order, last step: the tiles touched in depth order (see depth_counts_body.glsl).",
        ],
    },
    Variant {
        name: "depth_counts_texels",
        body: "depth_counts_body.glsl",
        defines: &["FRAME_TEXELS"],
        about: &[
            "Stage 2, depth order, last step: the tiles touched in depth order, reading through the",
            "frame's texel views (CPU drivers); see depth_counts_body.glsl.",
        ],
    },
    Variant {
        name: "depth_keys",
        body: "depth_keys_body.glsl",
        defines: &[],
        about: &[
            "Stage 2, depth order, first step: the depth keys (see depth_keys_body.glsl).",
        ],
    },
    Variant {
        name: "depth_keys_texels",
        body: "depth_keys_body.glsl",
        defines: &["FRAME_TEXELS"],
        about: &[
            "Stage 2, depth order, first step: the depth keys, reading through the frame's texel views",
            "(CPU drivers); see depth_keys_body.glsl.",
        ],
    },
    Variant {
        name: "emit",
        body: "emit_body.glsl",
        defines: &[],
        about: &[
            "Stage 4, emit (see emit_body.glsl).",
        ],
    },
    Variant {
        name: "emit_rara",
        body: "emit_body.glsl",
        defines: &["RECORD_CUTOFF_PAIRS"],
        about: &[
            "Stage 4, emit, for rara clipping by planes with the mass weight: cutoff splats' pairs are",
            "classified per tile by the next stage (see emit_body.glsl, cutoff_tiles.comp).",
        ],
    },
    Variant {
        name: "emit_rara_texels",
        body: "emit_body.glsl",
        defines: &["RECORD_CUTOFF_PAIRS", "SPLAT_TEXELS"],
        about: &[
            "Stage 4, emit for rara clipping by planes with the mass weight, reading the depth order, the",
            "first pairs and the projected splats through the frame's texel views (CPU drivers; see",
            "emit_body.glsl, cutoff_tiles.comp).",
        ],
    },
    Variant {
        name: "emit_rara_packed_texels",
        body: "emit_body.glsl",
        defines: &["RECORD_CUTOFF_PAIRS", "SPLAT_TEXELS", "PACKED_PAIRS"],
        about: &[
            "Stage 4, emit_rara_texels writing each pair as one 64-bit word, for the CPU drivers'",
            "sort of packed pairs (see emit_body.glsl).",
        ],
    },
    Variant {
        name: "emit_packed_texels",
        body: "emit_body.glsl",
        defines: &["SPLAT_TEXELS", "PACKED_PAIRS"],
        about: &[
            "Stage 4, emit_texels writing each pair as one 64-bit word, for the CPU drivers' sort of",
            "packed pairs (see emit_body.glsl).",
        ],
    },
    Variant {
        name: "emit_texels",
        body: "emit_body.glsl",
        defines: &["SPLAT_TEXELS"],
        about: &[
            "Stage 4, emit, reading the depth order, the first pairs and the projected splats through the",
            "frame's texel views (CPU drivers; see emit_body.glsl).",
        ],
    },
    Variant {
        name: "project_deg0",
        body: "project_body.glsl",
        defines: &["SH_DEGREE 0"],
        about: &[
            "Stage 1, project, for scenes of SH degree 0 with the coefficients stored as 32-bit floats",
            "(see project_body.glsl).",
        ],
    },
    Variant {
        name: "project_deg0_sh16",
        body: "project_body.glsl",
        defines: &["SH_DEGREE 0", "SH_HALF 1"],
        about: &[
            "Stage 1, project, for scenes of SH degree 0 with the coefficients stored as half floats,",
            "two to a uint (ShPrecision::F16; see project_body.glsl).",
        ],
    },
    Variant {
        name: "project_deg0_sh16_texels",
        body: "project_body.glsl",
        defines: &["SH_DEGREE 0", "SH_HALF 1", "SCENE_TEXELS"],
        about: &[
            "Stage 1, project, for scenes of SH degree 0 with the coefficients stored as half floats, two to",
            "a uint (ShPrecision::F16), reading the Gaussians and coefficients through the frame's texel",
            "views (CPU drivers; see project_body.glsl).",
        ],
    },
    Variant {
        name: "project_deg0_texels",
        body: "project_body.glsl",
        defines: &["SH_DEGREE 0", "SCENE_TEXELS"],
        about: &[
            "Stage 1, project, for scenes of SH degree 0 with the coefficients stored as 32-bit floats,",
            "reading the Gaussians and coefficients through the frame's texel views (CPU drivers; see",
            "project_body.glsl).",
        ],
    },
    Variant {
        name: "project_deg1",
        body: "project_body.glsl",
        defines: &["SH_DEGREE 1"],
        about: &[
            "Stage 1, project, for scenes of SH degree 1 with the coefficients stored as 32-bit floats",
            "(see project_body.glsl).",
        ],
    },
    Variant {
        name: "project_deg1_sh16",
        body: "project_body.glsl",
        defines: &["SH_DEGREE 1", "SH_HALF 1"],
        about: &[
            "Stage 1, project, for scenes of SH degree 1 with the coefficients stored as half floats,",
            "two to a uint (ShPrecision::F16; see project_body.glsl).",
        ],
    },
    Variant {
        name: "project_deg1_sh16_texels",
        body: "project_body.glsl",
        defines: &["SH_DEGREE 1", "SH_HALF 1", "SCENE_TEXELS"],
        about: &[
            "Stage 1, project, for scenes of SH degree 1 with the coefficients stored as half floats, two to",
            "a uint (ShPrecision::F16), reading the Gaussians and coefficients through the frame's texel",
            "views (CPU drivers; see project_body.glsl).",
        ],
    },
    Variant {
        name: "project_deg1_texels",
        body: "project_body.glsl",
        defines: &["SH_DEGREE 1", "SCENE_TEXELS"],
        about: &[
            "Stage 1, project, for scenes of SH degree 1 with the coefficients stored as 32-bit floats,",
            "reading the Gaussians and coefficients through the frame's texel views (CPU drivers; see",
            "project_body.glsl).",
        ],
    },
    Variant {
        name: "project_deg2",
        body: "project_body.glsl",
        defines: &["SH_DEGREE 2"],
        about: &[
            "Stage 1, project, for scenes of SH degree 2 with the coefficients stored as 32-bit floats",
            "(see project_body.glsl).",
        ],
    },
    Variant {
        name: "project_deg2_sh16",
        body: "project_body.glsl",
        defines: &["SH_DEGREE 2", "SH_HALF 1"],
        about: &[
            "Stage 1, project, for scenes of SH degree 2 with the coefficients stored as half floats,",
            "two to a uint (ShPrecision::F16; see project_body.glsl).",
        ],
    },
    Variant {
        name: "project_deg2_sh16_texels",
        body: "project_body.glsl",
        defines: &["SH_DEGREE 2", "SH_HALF 1", "SCENE_TEXELS"],
        about: &[
            "Stage 1, project, for scenes of SH degree 2 with the coefficients stored as half floats, two to",
            "a uint (ShPrecision::F16), reading the Gaussians and coefficients through the frame's texel",
            "views (CPU drivers; see project_body.glsl).",
        ],
    },
    Variant {
        name: "project_deg2_texels",
        body: "project_body.glsl",
        defines: &["SH_DEGREE 2", "SCENE_TEXELS"],
        about: &[
            "Stage 1, project, for scenes of SH degree 2 with the coefficients stored as 32-bit floats,",
            "reading the Gaussians and coefficients through the frame's texel views (CPU drivers; see",
            "project_body.glsl).",
        ],
    },
    Variant {
        name: "project_deg3",
        body: "project_body.glsl",
        defines: &["SH_DEGREE 3"],
        about: &[
            "Stage 1, project, for scenes of SH degree 3 with the coefficients stored as 32-bit floats",
            "(see project_body.glsl).",
        ],
    },
    Variant {
        name: "project_deg3_sh16",
        body: "project_body.glsl",
        defines: &["SH_DEGREE 3", "SH_HALF 1"],
        about: &[
            "Stage 1, project, for scenes of SH degree 3 with the coefficients stored as half floats,",
            "two to a uint (ShPrecision::F16; see project_body.glsl).",
        ],
    },
    Variant {
        name: "project_deg3_sh16_texels",
        body: "project_body.glsl",
        defines: &["SH_DEGREE 3", "SH_HALF 1", "SCENE_TEXELS"],
        about: &[
            "Stage 1, project, for scenes of SH degree 3 with the coefficients stored as half floats, two to",
            "a uint (ShPrecision::F16), reading the Gaussians and coefficients through the frame's texel",
            "views (CPU drivers; see project_body.glsl).",
        ],
    },
    Variant {
        name: "project_deg3_texels",
        body: "project_body.glsl",
        defines: &["SH_DEGREE 3", "SCENE_TEXELS"],
        about: &[
            "Stage 1, project, for scenes of SH degree 3 with the coefficients stored as 32-bit floats,",
            "reading the Gaussians and coefficients through the frame's texel views (CPU drivers; see",
            "project_body.glsl).",
        ],
    },
    Variant {
        name: "rasterize",
        body: "rasterize_body.glsl",
        defines: &["PIXELS_PER_INVOCATION 1", "CUTOFF_WEIGHT 0"],
        about: &[
            "Stage 7, rasterize, GPU layout (one invocation per pixel), no rara clipping",
            "(see rasterize_body.glsl).",
        ],
    },
    Variant {
        name: "rasterize_length",
        body: "rasterize_body.glsl",
        defines: &["PIXELS_PER_INVOCATION 1", "CUTOFF_WEIGHT CLIP_WEIGHT_LENGTH + 1"],
        about: &[
            "Stage 7, rasterize, GPU layout, rara clipping with the length weight",
            "(see rasterize_body.glsl).",
        ],
    },
    Variant {
        name: "rasterize_mass",
        body: "rasterize_body.glsl",
        defines: &["PIXELS_PER_INVOCATION 1", "CUTOFF_WEIGHT CLIP_WEIGHT_MASS + 1"],
        about: &[
            "Stage 7, rasterize, GPU layout, rara clipping with the mass weight",
            "(see rasterize_body.glsl).",
        ],
    },
    Variant {
        name: "rasterize_strips",
        body: "rasterize_body.glsl",
        defines: &["PIXELS_PER_INVOCATION 8", "COLUMNS_PER_INVOCATION 1", "TILE_BLOCKS", "CUTOFF_WEIGHT 0", "SPLAT_TEXELS"],
        about: &[
            "Stage 7, rasterize, CPU-driver layout (8-pixel columns, a SIMD vector per 8x8 block, splats from",
            "texel buffers), no rara clipping (see rasterize_body.glsl).",
        ],
    },
    Variant {
        name: "rasterize_strips_length",
        body: "rasterize_body.glsl",
        defines: &["PIXELS_PER_INVOCATION 8", "COLUMNS_PER_INVOCATION 1", "TILE_BLOCKS", "CUTOFF_WEIGHT CLIP_WEIGHT_LENGTH + 1", "SPLAT_TEXELS"],
        about: &[
            "Stage 7, rasterize, CPU-driver layout (8-pixel columns, a SIMD vector per 8x8 block, splats from",
            "texel buffers), rara clipping with the length weight (see rasterize_body.glsl).",
        ],
    },
    Variant {
        name: "rasterize_strips_mass",
        body: "rasterize_body.glsl",
        defines: &["PIXELS_PER_INVOCATION 8", "COLUMNS_PER_INVOCATION 1", "TILE_BLOCKS", "CUTOFF_WEIGHT CLIP_WEIGHT_MASS + 1", "SPLAT_TEXELS"],
        about: &[
            "Stage 7, rasterize, CPU-driver layout (8-pixel columns, a SIMD vector per 8x8 block, splats from",
            "texel buffers), rara clipping with the mass weight (see rasterize_body.glsl).",
        ],
    },
    Variant {
        name: "rasterize_depth",
        body: "rasterize_body.glsl",
        defines: &["PIXELS_PER_INVOCATION 1", "CUTOFF_WEIGHT 0", "DEPTH"],
        about: &[
            "Stage 7, rasterize, GPU layout, no rara clipping, with the depth test and the",
            "depth outputs (SPEC section 9; see rasterize_body.glsl).",
        ],
    },
    Variant {
        name: "rasterize_length_depth",
        body: "rasterize_body.glsl",
        defines: &["PIXELS_PER_INVOCATION 1", "CUTOFF_WEIGHT CLIP_WEIGHT_LENGTH + 1", "DEPTH"],
        about: &[
            "Stage 7, rasterize, GPU layout, rara clipping with the length weight, with the depth test and the",
            "depth outputs (SPEC section 9; see rasterize_body.glsl).",
        ],
    },
    Variant {
        name: "rasterize_mass_depth",
        body: "rasterize_body.glsl",
        defines: &["PIXELS_PER_INVOCATION 1", "CUTOFF_WEIGHT CLIP_WEIGHT_MASS + 1", "DEPTH"],
        about: &[
            "Stage 7, rasterize, GPU layout, rara clipping with the mass weight, with the depth test and the",
            "depth outputs (SPEC section 9; see rasterize_body.glsl).",
        ],
    },
    Variant {
        name: "rasterize_strips_depth",
        body: "rasterize_body.glsl",
        defines: &["PIXELS_PER_INVOCATION 8", "COLUMNS_PER_INVOCATION 1", "TILE_BLOCKS", "CUTOFF_WEIGHT 0", "SPLAT_TEXELS", "DEPTH"],
        about: &[
            "Stage 7, rasterize, CPU-driver layout, no rara clipping, with the depth test and the",
            "depth outputs (SPEC section 9; see rasterize_body.glsl).",
        ],
    },
    Variant {
        name: "rasterize_strips_length_depth",
        body: "rasterize_body.glsl",
        defines: &["PIXELS_PER_INVOCATION 8", "COLUMNS_PER_INVOCATION 1", "TILE_BLOCKS", "CUTOFF_WEIGHT CLIP_WEIGHT_LENGTH + 1", "SPLAT_TEXELS", "DEPTH"],
        about: &[
            "Stage 7, rasterize, CPU-driver layout, rara clipping with the length weight, with the depth test and the",
            "depth outputs (SPEC section 9; see rasterize_body.glsl).",
        ],
    },
    Variant {
        name: "rasterize_strips_mass_depth",
        body: "rasterize_body.glsl",
        defines: &["PIXELS_PER_INVOCATION 8", "COLUMNS_PER_INVOCATION 1", "TILE_BLOCKS", "CUTOFF_WEIGHT CLIP_WEIGHT_MASS + 1", "SPLAT_TEXELS", "DEPTH"],
        about: &[
            "Stage 7, rasterize, CPU-driver layout, rara clipping with the mass weight, with the depth test and the",
            "depth outputs (SPEC section 9; see rasterize_body.glsl).",
        ],
    },
    Variant {
        name: "rasterize_mass_objects",
        body: "rasterize_body.glsl",
        defines: &["PIXELS_PER_INVOCATION 1", "CUTOFF_WEIGHT CLIP_WEIGHT_MASS + 1", "OBJECT_CLIPS"],
        about: &[
            "Stage 7, rasterize, GPU layout, rara clipping with the mass weight by a clip region per object",
            "(SPEC section 9; see rasterize_body.glsl).",
        ],
    },
    Variant {
        name: "rasterize_mass_objects_depth",
        body: "rasterize_body.glsl",
        defines: &["PIXELS_PER_INVOCATION 1", "CUTOFF_WEIGHT CLIP_WEIGHT_MASS + 1", "OBJECT_CLIPS", "DEPTH"],
        about: &[
            "Stage 7, rasterize, GPU layout, rara clipping with the mass weight by a clip region per object",
            "(SPEC section 9), with the depth test and the depth outputs (see rasterize_body.glsl).",
        ],
    },
    Variant {
        name: "rasterize_length_objects",
        body: "rasterize_body.glsl",
        defines: &["PIXELS_PER_INVOCATION 1", "CUTOFF_WEIGHT CLIP_WEIGHT_LENGTH + 1", "OBJECT_CLIPS"],
        about: &[
            "Stage 7, rasterize, GPU layout, rara clipping with the length weight by a clip region per object",
            "(SPEC section 9; see rasterize_body.glsl).",
        ],
    },
    Variant {
        name: "rasterize_length_objects_depth",
        body: "rasterize_body.glsl",
        defines: &["PIXELS_PER_INVOCATION 1", "CUTOFF_WEIGHT CLIP_WEIGHT_LENGTH + 1", "OBJECT_CLIPS", "DEPTH"],
        about: &[
            "Stage 7, rasterize, GPU layout, rara clipping with the length weight by a clip region per object",
            "(SPEC section 9), with the depth test and the depth outputs (see rasterize_body.glsl).",
        ],
    },
    Variant {
        name: "rasterize_strips_mass_objects",
        body: "rasterize_body.glsl",
        defines: &["PIXELS_PER_INVOCATION 8", "COLUMNS_PER_INVOCATION 1", "TILE_BLOCKS", "CUTOFF_WEIGHT CLIP_WEIGHT_MASS + 1", "SPLAT_TEXELS", "OBJECT_CLIPS"],
        about: &[
            "Stage 7, rasterize, CPU-driver layout, rara clipping with the mass weight by a clip region per object",
            "(SPEC section 9; see rasterize_body.glsl).",
        ],
    },
    Variant {
        name: "rasterize_strips_mass_objects_depth",
        body: "rasterize_body.glsl",
        defines: &["PIXELS_PER_INVOCATION 8", "COLUMNS_PER_INVOCATION 1", "TILE_BLOCKS", "CUTOFF_WEIGHT CLIP_WEIGHT_MASS + 1", "SPLAT_TEXELS", "OBJECT_CLIPS", "DEPTH"],
        about: &[
            "Stage 7, rasterize, CPU-driver layout, rara clipping with the mass weight by a clip region per object",
            "(SPEC section 9), with the depth test and the depth outputs (see rasterize_body.glsl).",
        ],
    },
    Variant {
        name: "rasterize_strips_length_objects",
        body: "rasterize_body.glsl",
        defines: &["PIXELS_PER_INVOCATION 8", "COLUMNS_PER_INVOCATION 1", "TILE_BLOCKS", "CUTOFF_WEIGHT CLIP_WEIGHT_LENGTH + 1", "SPLAT_TEXELS", "OBJECT_CLIPS"],
        about: &[
            "Stage 7, rasterize, CPU-driver layout, rara clipping with the length weight by a clip region per object",
            "(SPEC section 9; see rasterize_body.glsl).",
        ],
    },
    Variant {
        name: "rasterize_strips_length_objects_depth",
        body: "rasterize_body.glsl",
        defines: &["PIXELS_PER_INVOCATION 8", "COLUMNS_PER_INVOCATION 1", "TILE_BLOCKS", "CUTOFF_WEIGHT CLIP_WEIGHT_LENGTH + 1", "SPLAT_TEXELS", "OBJECT_CLIPS", "DEPTH"],
        about: &[
            "Stage 7, rasterize, CPU-driver layout, rara clipping with the length weight by a clip region per object",
            "(SPEC section 9), with the depth test and the depth outputs (see rasterize_body.glsl).",
        ],
    },
    Variant {
        name: "sort_count_own_counts",
        body: "sort_count_own_counts_body.glsl",
        defines: &["SORT_PAIRS_IN 0"],
        about: &[
            "Radix sort count step, CPU-driver layout, over separate keys (the first pass of a sort of",
            "separate keys and values).",
        ],
    },
    Variant {
        name: "sort_count_own_counts_pairs",
        body: "sort_count_own_counts_body.glsl",
        defines: &["SORT_PAIRS_IN 1"],
        about: &[
            "Radix sort count step, CPU-driver layout, over packed pairs (every pass but the first of a sort",
            "of separate keys and values, and every pass of a sort of packed pairs).",
        ],
    },
    Variant {
        name: "sort_local_2",
        body: "sort_local_body.glsl",
        defines: &["LOCAL_PASSES 2"],
        about: &[
            "Radix sort, 2 passes after the first of a segmented sort of small buckets, one invocation",
            "per bucket, by the 2 digits after the top one (see sort_local_body.glsl).",
        ],
    },
    Variant {
        name: "sort_local_3",
        body: "sort_local_body.glsl",
        defines: &["LOCAL_PASSES 3"],
        about: &[
            "Radix sort, 3 passes after the first of a segmented sort of small buckets, one invocation",
            "per bucket, by the 3 digits after the top one (see sort_local_body.glsl).",
        ],
    },
    Variant {
        name: "sort_scatter_own_counts",
        body: "sort_scatter_own_counts_body.glsl",
        defines: &["SORT_PAIRS_IN 0", "SORT_PAIRS_OUT 0"],
        about: &[
            "Radix sort scatter step, CPU-driver layout: separate keys and values in and out (a sort of one",
            "pass).",
        ],
    },
    Variant {
        name: "sort_scatter_own_counts_from_pairs",
        body: "sort_scatter_own_counts_body.glsl",
        defines: &["SORT_PAIRS_IN 1", "SORT_PAIRS_OUT 0"],
        about: &[
            "Radix sort scatter step, CPU-driver layout: packed pairs in, separate keys and values out (the",
            "last of several passes).",
        ],
    },
    Variant {
        name: "sort_scatter_own_counts_pairs",
        body: "sort_scatter_own_counts_body.glsl",
        defines: &["SORT_PAIRS_IN 1", "SORT_PAIRS_OUT 1"],
        about: &[
            "Radix sort scatter step, CPU-driver layout: packed pairs in and out (the passes between the",
            "first and the last, and every pass of a sort of packed pairs).",
        ],
    },
    Variant {
        name: "sort_scatter_own_counts_pairs_bound",
        body: "sort_scatter_own_counts_body.glsl",
        defines: &["SORT_PAIRS_IN 1", "SORT_PAIRS_OUT 1", "SORT_OUT_BOUND 1"],
        about: &[
            "Radix sort scatter step, CPU-driver layout: packed pairs in and out, written through the",
            "pass's bound storage buffer (see SORT_OUT_BOUND in sort_scatter_own_counts_body.glsl).",
        ],
    },
    Variant {
        name: "sort_scatter_own_counts_to_pairs",
        body: "sort_scatter_own_counts_body.glsl",
        defines: &["SORT_PAIRS_IN 0", "SORT_PAIRS_OUT 1"],
        about: &[
            "Radix sort scatter step, CPU-driver layout: separate keys and values in, packed pairs out (the",
            "first of several passes).",
        ],
    },
    Variant {
        name: "sort_scatter_own_counts_to_pairs_bound",
        body: "sort_scatter_own_counts_body.glsl",
        defines: &["SORT_PAIRS_IN 0", "SORT_PAIRS_OUT 1", "SORT_OUT_BOUND 1"],
        about: &[
            "Radix sort scatter step, CPU-driver layout: separate keys and values in, packed pairs out,",
            "written through the pass's bound storage buffer (see SORT_OUT_BOUND in",
            "sort_scatter_own_counts_body.glsl).",
        ],
    },
    Variant {
        name: "tile_ranges",
        body: "tile_ranges_body.glsl",
        defines: &[],
        about: &[
            "Stage 6, tile ranges (see tile_ranges_body.glsl).",
        ],
    },
    Variant {
        name: "tile_ranges_texels",
        body: "tile_ranges_body.glsl",
        defines: &["FRAME_TEXELS"],
        about: &[
            "Stage 6, tile ranges, reading the sorted keys through the frame's texel views (CPU",
            "drivers); see tile_ranges_body.glsl.",
        ],
    },
    Variant {
        name: "write_depth_buffer",
        body: "write_depth_body.glsl",
        defines: &[],
        about: &[
            "Depth output into an f32 buffer (see write_depth_body.glsl).",
        ],
    },
    Variant {
        name: "write_depth_image",
        body: "write_depth_body.glsl",
        defines: &["DEPTH_TARGET_IMAGE"],
        about: &[
            "Depth output into an R32_SFLOAT storage image (see write_depth_body.glsl).",
        ],
    },
    Variant {
        name: "write_target_buffer_rgba16f",
        body: "write_target_body.glsl",
        defines: &["TARGET_BUFFER_FORMAT BUFFER_RGBA16F"],
        about: &[
            "Stage 8, write target, into an rgba16f buffer reached by device address (see",
            "write_target_body.glsl).",
        ],
    },
    Variant {
        name: "write_target_buffer_rgba16f_texels",
        body: "write_target_body.glsl",
        defines: &["TARGET_BUFFER_FORMAT BUFFER_RGBA16F", "STATE_TEXELS"],
        about: &[
            "Stage 8, write target, into an rgba16f buffer reached by device address, reading the",
            "state through the frame's texel view (CPU drivers; see write_target_body.glsl).",
        ],
    },
    Variant {
        name: "write_target_buffer_rgba32f",
        body: "write_target_body.glsl",
        defines: &["TARGET_BUFFER_FORMAT BUFFER_RGBA32F"],
        about: &[
            "Stage 8, write target, into an rgba32f buffer reached by device address (see",
            "write_target_body.glsl).",
        ],
    },
    Variant {
        name: "write_target_buffer_rgba32f_texels",
        body: "write_target_body.glsl",
        defines: &["TARGET_BUFFER_FORMAT BUFFER_RGBA32F", "STATE_TEXELS"],
        about: &[
            "Stage 8, write target, into an rgba32f buffer reached by device address, reading the",
            "state through the frame's texel view (CPU drivers; see write_target_body.glsl).",
        ],
    },
    Variant {
        name: "write_target_buffer_rgba8",
        body: "write_target_body.glsl",
        defines: &["TARGET_BUFFER_FORMAT BUFFER_RGBA8"],
        about: &[
            "Stage 8, write target, into an rgba8 buffer reached by device address (see",
            "write_target_body.glsl).",
        ],
    },
    Variant {
        name: "write_target_buffer_rgba8_texels",
        body: "write_target_body.glsl",
        defines: &["TARGET_BUFFER_FORMAT BUFFER_RGBA8", "STATE_TEXELS"],
        about: &[
            "Stage 8, write target, into an rgba8 buffer reached by device address, reading the",
            "state through the frame's texel view (CPU drivers; see write_target_body.glsl).",
        ],
    },
    Variant {
        name: "write_target_image_rgba16f",
        body: "write_target_body.glsl",
        defines: &["TARGET_IMAGE_FORMAT rgba16f"],
        about: &[
            "Stage 8, write target, into a storage image of format rgba16f (see write_target_body.glsl).",
        ],
    },
    Variant {
        name: "write_target_image_rgba16f_texels",
        body: "write_target_body.glsl",
        defines: &["TARGET_IMAGE_FORMAT rgba16f", "STATE_TEXELS"],
        about: &[
            "Stage 8, write target, into a storage image of format rgba16f, reading the state through the",
            "frame's texel view (CPU drivers; see write_target_body.glsl).",
        ],
    },
    Variant {
        name: "write_target_image_rgba32f",
        body: "write_target_body.glsl",
        defines: &["TARGET_IMAGE_FORMAT rgba32f"],
        about: &[
            "Stage 8, write target, into a storage image of format rgba32f (see write_target_body.glsl).",
        ],
    },
    Variant {
        name: "write_target_image_rgba32f_texels",
        body: "write_target_body.glsl",
        defines: &["TARGET_IMAGE_FORMAT rgba32f", "STATE_TEXELS"],
        about: &[
            "Stage 8, write target, into a storage image of format rgba32f, reading the state through the",
            "frame's texel view (CPU drivers; see write_target_body.glsl).",
        ],
    },
    Variant {
        name: "write_target_image_rgba8",
        body: "write_target_body.glsl",
        defines: &["TARGET_IMAGE_FORMAT rgba8"],
        about: &[
            "Stage 8, write target, into a storage image of format rgba8 (see write_target_body.glsl).",
        ],
    },
    Variant {
        name: "write_target_image_rgba8_texels",
        body: "write_target_body.glsl",
        defines: &["TARGET_IMAGE_FORMAT rgba8", "STATE_TEXELS"],
        about: &[
            "Stage 8, write target, into a storage image of format rgba8, reading the state through the",
            "frame's texel view (CPU drivers; see write_target_body.glsl).",
        ],
    },
    Variant {
        name: "trace_deg0",
        body: "trace_body.glsl",
        defines: &["SH_DEGREE 0"],
        about: &[
            "The ray tracer (issue 32) for scenes of SH degree 0, coefficients as 32-bit floats",
            "(see trace_body.glsl).",
        ],
    },
    Variant {
        name: "trace_deg0_sh16",
        body: "trace_body.glsl",
        defines: &["SH_DEGREE 0", "SH_HALF 1"],
        about: &[
            "The ray tracer (issue 32) for scenes of SH degree 0, coefficients as half floats",
            "(see trace_body.glsl).",
        ],
    },
    Variant {
        name: "trace_deg1",
        body: "trace_body.glsl",
        defines: &["SH_DEGREE 1"],
        about: &[
            "The ray tracer (issue 32) for scenes of SH degree 1, coefficients as 32-bit floats",
            "(see trace_body.glsl).",
        ],
    },
    Variant {
        name: "trace_deg1_sh16",
        body: "trace_body.glsl",
        defines: &["SH_DEGREE 1", "SH_HALF 1"],
        about: &[
            "The ray tracer (issue 32) for scenes of SH degree 1, coefficients as half floats",
            "(see trace_body.glsl).",
        ],
    },
    Variant {
        name: "trace_deg2",
        body: "trace_body.glsl",
        defines: &["SH_DEGREE 2"],
        about: &[
            "The ray tracer (issue 32) for scenes of SH degree 2, coefficients as 32-bit floats",
            "(see trace_body.glsl).",
        ],
    },
    Variant {
        name: "trace_deg2_sh16",
        body: "trace_body.glsl",
        defines: &["SH_DEGREE 2", "SH_HALF 1"],
        about: &[
            "The ray tracer (issue 32) for scenes of SH degree 2, coefficients as half floats",
            "(see trace_body.glsl).",
        ],
    },
    Variant {
        name: "trace_deg3",
        body: "trace_body.glsl",
        defines: &["SH_DEGREE 3"],
        about: &[
            "The ray tracer (issue 32) for scenes of SH degree 3, coefficients as 32-bit floats",
            "(see trace_body.glsl).",
        ],
    },
    Variant {
        name: "trace_deg3_sh16",
        body: "trace_body.glsl",
        defines: &["SH_DEGREE 3", "SH_HALF 1"],
        about: &[
            "The ray tracer (issue 32) for scenes of SH degree 3, coefficients as half floats",
            "(see trace_body.glsl).",
        ],
    },
    Variant {
        name: "trace_deg0_texels",
        body: "trace_body.glsl",
        defines: &["SH_DEGREE 0", "SCENE_TEXELS"],
        about: &[
            "The ray tracer (issue 32) for scenes of SH degree 0, coefficients as 32-bit floats, reading",
            "the BVH, the Gaussians and the coefficients through texel views (CPU drivers; see",
            "trace_body.glsl).",
        ],
    },
    Variant {
        name: "trace_deg0_sh16_texels",
        body: "trace_body.glsl",
        defines: &["SH_DEGREE 0", "SH_HALF 1", "SCENE_TEXELS"],
        about: &[
            "The ray tracer (issue 32) for scenes of SH degree 0, coefficients as half floats, reading",
            "the BVH, the Gaussians and the coefficients through texel views (CPU drivers; see",
            "trace_body.glsl).",
        ],
    },
    Variant {
        name: "trace_deg1_texels",
        body: "trace_body.glsl",
        defines: &["SH_DEGREE 1", "SCENE_TEXELS"],
        about: &[
            "The ray tracer (issue 32) for scenes of SH degree 1, coefficients as 32-bit floats, reading",
            "the BVH, the Gaussians and the coefficients through texel views (CPU drivers; see",
            "trace_body.glsl).",
        ],
    },
    Variant {
        name: "trace_deg1_sh16_texels",
        body: "trace_body.glsl",
        defines: &["SH_DEGREE 1", "SH_HALF 1", "SCENE_TEXELS"],
        about: &[
            "The ray tracer (issue 32) for scenes of SH degree 1, coefficients as half floats, reading",
            "the BVH, the Gaussians and the coefficients through texel views (CPU drivers; see",
            "trace_body.glsl).",
        ],
    },
    Variant {
        name: "trace_deg2_texels",
        body: "trace_body.glsl",
        defines: &["SH_DEGREE 2", "SCENE_TEXELS"],
        about: &[
            "The ray tracer (issue 32) for scenes of SH degree 2, coefficients as 32-bit floats, reading",
            "the BVH, the Gaussians and the coefficients through texel views (CPU drivers; see",
            "trace_body.glsl).",
        ],
    },
    Variant {
        name: "trace_deg2_sh16_texels",
        body: "trace_body.glsl",
        defines: &["SH_DEGREE 2", "SH_HALF 1", "SCENE_TEXELS"],
        about: &[
            "The ray tracer (issue 32) for scenes of SH degree 2, coefficients as half floats, reading",
            "the BVH, the Gaussians and the coefficients through texel views (CPU drivers; see",
            "trace_body.glsl).",
        ],
    },
    Variant {
        name: "trace_deg3_texels",
        body: "trace_body.glsl",
        defines: &["SH_DEGREE 3", "SCENE_TEXELS"],
        about: &[
            "The ray tracer (issue 32) for scenes of SH degree 3, coefficients as 32-bit floats, reading",
            "the BVH, the Gaussians and the coefficients through texel views (CPU drivers; see",
            "trace_body.glsl).",
        ],
    },
    Variant {
        name: "trace_deg3_sh16_texels",
        body: "trace_body.glsl",
        defines: &["SH_DEGREE 3", "SH_HALF 1", "SCENE_TEXELS"],
        about: &[
            "The ray tracer (issue 32) for scenes of SH degree 3, coefficients as half floats, reading",
            "the BVH, the Gaussians and the coefficients through texel views (CPU drivers; see",
            "trace_body.glsl).",
        ],
    },
    Variant {
        name: "trace_deg0_k64",
        body: "trace_body.glsl",
        defines: &["SH_DEGREE 0", "TRACE_K 64"],
        about: &[
            "The ray tracer (issue 32) for scenes of SH degree 0, coefficients as 32-bit floats, with a",
            "buffer of 64 hits per ray, reading by address (see trace_body.glsl).",
        ],
    },
    Variant {
        name: "trace_deg0_texels_k64",
        body: "trace_body.glsl",
        defines: &["SH_DEGREE 0", "SCENE_TEXELS", "TRACE_K 64"],
        about: &[
            "The ray tracer (issue 32) for scenes of SH degree 0, coefficients as 32-bit floats, with a",
            "buffer of 64 hits per ray, reading the BVH, the Gaussians and the coefficients through texel views (CPU drivers) (see trace_body.glsl).",
        ],
    },
    Variant {
        name: "trace_deg0_sh16_k64",
        body: "trace_body.glsl",
        defines: &["SH_DEGREE 0", "SH_HALF 1", "TRACE_K 64"],
        about: &[
            "The ray tracer (issue 32) for scenes of SH degree 0, coefficients as half floats, with a",
            "buffer of 64 hits per ray, reading by address (see trace_body.glsl).",
        ],
    },
    Variant {
        name: "trace_deg0_sh16_texels_k64",
        body: "trace_body.glsl",
        defines: &["SH_DEGREE 0", "SH_HALF 1", "SCENE_TEXELS", "TRACE_K 64"],
        about: &[
            "The ray tracer (issue 32) for scenes of SH degree 0, coefficients as half floats, with a",
            "buffer of 64 hits per ray, reading the BVH, the Gaussians and the coefficients through texel views (CPU drivers) (see trace_body.glsl).",
        ],
    },
    Variant {
        name: "trace_deg1_k64",
        body: "trace_body.glsl",
        defines: &["SH_DEGREE 1", "TRACE_K 64"],
        about: &[
            "The ray tracer (issue 32) for scenes of SH degree 1, coefficients as 32-bit floats, with a",
            "buffer of 64 hits per ray, reading by address (see trace_body.glsl).",
        ],
    },
    Variant {
        name: "trace_deg1_texels_k64",
        body: "trace_body.glsl",
        defines: &["SH_DEGREE 1", "SCENE_TEXELS", "TRACE_K 64"],
        about: &[
            "The ray tracer (issue 32) for scenes of SH degree 1, coefficients as 32-bit floats, with a",
            "buffer of 64 hits per ray, reading the BVH, the Gaussians and the coefficients through texel views (CPU drivers) (see trace_body.glsl).",
        ],
    },
    Variant {
        name: "trace_deg1_sh16_k64",
        body: "trace_body.glsl",
        defines: &["SH_DEGREE 1", "SH_HALF 1", "TRACE_K 64"],
        about: &[
            "The ray tracer (issue 32) for scenes of SH degree 1, coefficients as half floats, with a",
            "buffer of 64 hits per ray, reading by address (see trace_body.glsl).",
        ],
    },
    Variant {
        name: "trace_deg1_sh16_texels_k64",
        body: "trace_body.glsl",
        defines: &["SH_DEGREE 1", "SH_HALF 1", "SCENE_TEXELS", "TRACE_K 64"],
        about: &[
            "The ray tracer (issue 32) for scenes of SH degree 1, coefficients as half floats, with a",
            "buffer of 64 hits per ray, reading the BVH, the Gaussians and the coefficients through texel views (CPU drivers) (see trace_body.glsl).",
        ],
    },
    Variant {
        name: "trace_deg2_k64",
        body: "trace_body.glsl",
        defines: &["SH_DEGREE 2", "TRACE_K 64"],
        about: &[
            "The ray tracer (issue 32) for scenes of SH degree 2, coefficients as 32-bit floats, with a",
            "buffer of 64 hits per ray, reading by address (see trace_body.glsl).",
        ],
    },
    Variant {
        name: "trace_deg2_texels_k64",
        body: "trace_body.glsl",
        defines: &["SH_DEGREE 2", "SCENE_TEXELS", "TRACE_K 64"],
        about: &[
            "The ray tracer (issue 32) for scenes of SH degree 2, coefficients as 32-bit floats, with a",
            "buffer of 64 hits per ray, reading the BVH, the Gaussians and the coefficients through texel views (CPU drivers) (see trace_body.glsl).",
        ],
    },
    Variant {
        name: "trace_deg2_sh16_k64",
        body: "trace_body.glsl",
        defines: &["SH_DEGREE 2", "SH_HALF 1", "TRACE_K 64"],
        about: &[
            "The ray tracer (issue 32) for scenes of SH degree 2, coefficients as half floats, with a",
            "buffer of 64 hits per ray, reading by address (see trace_body.glsl).",
        ],
    },
    Variant {
        name: "trace_deg2_sh16_texels_k64",
        body: "trace_body.glsl",
        defines: &["SH_DEGREE 2", "SH_HALF 1", "SCENE_TEXELS", "TRACE_K 64"],
        about: &[
            "The ray tracer (issue 32) for scenes of SH degree 2, coefficients as half floats, with a",
            "buffer of 64 hits per ray, reading the BVH, the Gaussians and the coefficients through texel views (CPU drivers) (see trace_body.glsl).",
        ],
    },
    Variant {
        name: "trace_deg3_k64",
        body: "trace_body.glsl",
        defines: &["SH_DEGREE 3", "TRACE_K 64"],
        about: &[
            "The ray tracer (issue 32) for scenes of SH degree 3, coefficients as 32-bit floats, with a",
            "buffer of 64 hits per ray, reading by address (see trace_body.glsl).",
        ],
    },
    Variant {
        name: "trace_deg3_texels_k64",
        body: "trace_body.glsl",
        defines: &["SH_DEGREE 3", "SCENE_TEXELS", "TRACE_K 64"],
        about: &[
            "The ray tracer (issue 32) for scenes of SH degree 3, coefficients as 32-bit floats, with a",
            "buffer of 64 hits per ray, reading the BVH, the Gaussians and the coefficients through texel views (CPU drivers) (see trace_body.glsl).",
        ],
    },
    Variant {
        name: "trace_deg3_sh16_k64",
        body: "trace_body.glsl",
        defines: &["SH_DEGREE 3", "SH_HALF 1", "TRACE_K 64"],
        about: &[
            "The ray tracer (issue 32) for scenes of SH degree 3, coefficients as half floats, with a",
            "buffer of 64 hits per ray, reading by address (see trace_body.glsl).",
        ],
    },
    Variant {
        name: "trace_deg3_sh16_texels_k64",
        body: "trace_body.glsl",
        defines: &["SH_DEGREE 3", "SH_HALF 1", "SCENE_TEXELS", "TRACE_K 64"],
        about: &[
            "The ray tracer (issue 32) for scenes of SH degree 3, coefficients as half floats, with a",
            "buffer of 64 hits per ray, reading the BVH, the Gaussians and the coefficients through texel views (CPU drivers) (see trace_body.glsl).",
        ],
    },
    Variant {
        name: "trace_mixed_deg0",
        body: "trace_body.glsl",
        defines: &["SH_DEGREE 0", "MIXED"],
        about: &[
            "The ray tracer of mixed scenes (issue 33) for scenes of SH degree 0, coefficients as 32-bit floats",
            "(GPUs; see trace_body.glsl).",
        ],
    },
    Variant {
        name: "trace_mixed_deg0_texels_k64",
        body: "trace_body.glsl",
        defines: &["SH_DEGREE 0", "SCENE_TEXELS", "TRACE_K 64", "MIXED"],
        about: &[
            "The ray tracer of mixed scenes (issue 33) for scenes of SH degree 0, coefficients as 32-bit floats,",
            "with a buffer of 64 hits per ray, reading through texel views (CPU drivers) (see trace_body.glsl).",
        ],
    },
    Variant {
        name: "trace_mixed_deg0_sh16",
        body: "trace_body.glsl",
        defines: &["SH_DEGREE 0", "SH_HALF 1", "MIXED"],
        about: &[
            "The ray tracer of mixed scenes (issue 33) for scenes of SH degree 0, coefficients as half floats",
            "(GPUs; see trace_body.glsl).",
        ],
    },
    Variant {
        name: "trace_mixed_deg0_sh16_texels_k64",
        body: "trace_body.glsl",
        defines: &["SH_DEGREE 0", "SH_HALF 1", "SCENE_TEXELS", "TRACE_K 64", "MIXED"],
        about: &[
            "The ray tracer of mixed scenes (issue 33) for scenes of SH degree 0, coefficients as half floats,",
            "with a buffer of 64 hits per ray, reading through texel views (CPU drivers) (see trace_body.glsl).",
        ],
    },
    Variant {
        name: "trace_mixed_deg1",
        body: "trace_body.glsl",
        defines: &["SH_DEGREE 1", "MIXED"],
        about: &[
            "The ray tracer of mixed scenes (issue 33) for scenes of SH degree 1, coefficients as 32-bit floats",
            "(GPUs; see trace_body.glsl).",
        ],
    },
    Variant {
        name: "trace_mixed_deg1_texels_k64",
        body: "trace_body.glsl",
        defines: &["SH_DEGREE 1", "SCENE_TEXELS", "TRACE_K 64", "MIXED"],
        about: &[
            "The ray tracer of mixed scenes (issue 33) for scenes of SH degree 1, coefficients as 32-bit floats,",
            "with a buffer of 64 hits per ray, reading through texel views (CPU drivers) (see trace_body.glsl).",
        ],
    },
    Variant {
        name: "trace_mixed_deg1_sh16",
        body: "trace_body.glsl",
        defines: &["SH_DEGREE 1", "SH_HALF 1", "MIXED"],
        about: &[
            "The ray tracer of mixed scenes (issue 33) for scenes of SH degree 1, coefficients as half floats",
            "(GPUs; see trace_body.glsl).",
        ],
    },
    Variant {
        name: "trace_mixed_deg1_sh16_texels_k64",
        body: "trace_body.glsl",
        defines: &["SH_DEGREE 1", "SH_HALF 1", "SCENE_TEXELS", "TRACE_K 64", "MIXED"],
        about: &[
            "The ray tracer of mixed scenes (issue 33) for scenes of SH degree 1, coefficients as half floats,",
            "with a buffer of 64 hits per ray, reading through texel views (CPU drivers) (see trace_body.glsl).",
        ],
    },
    Variant {
        name: "trace_mixed_deg2",
        body: "trace_body.glsl",
        defines: &["SH_DEGREE 2", "MIXED"],
        about: &[
            "The ray tracer of mixed scenes (issue 33) for scenes of SH degree 2, coefficients as 32-bit floats",
            "(GPUs; see trace_body.glsl).",
        ],
    },
    Variant {
        name: "trace_mixed_deg2_texels_k64",
        body: "trace_body.glsl",
        defines: &["SH_DEGREE 2", "SCENE_TEXELS", "TRACE_K 64", "MIXED"],
        about: &[
            "The ray tracer of mixed scenes (issue 33) for scenes of SH degree 2, coefficients as 32-bit floats,",
            "with a buffer of 64 hits per ray, reading through texel views (CPU drivers) (see trace_body.glsl).",
        ],
    },
    Variant {
        name: "trace_mixed_deg2_sh16",
        body: "trace_body.glsl",
        defines: &["SH_DEGREE 2", "SH_HALF 1", "MIXED"],
        about: &[
            "The ray tracer of mixed scenes (issue 33) for scenes of SH degree 2, coefficients as half floats",
            "(GPUs; see trace_body.glsl).",
        ],
    },
    Variant {
        name: "trace_mixed_deg2_sh16_texels_k64",
        body: "trace_body.glsl",
        defines: &["SH_DEGREE 2", "SH_HALF 1", "SCENE_TEXELS", "TRACE_K 64", "MIXED"],
        about: &[
            "The ray tracer of mixed scenes (issue 33) for scenes of SH degree 2, coefficients as half floats,",
            "with a buffer of 64 hits per ray, reading through texel views (CPU drivers) (see trace_body.glsl).",
        ],
    },
    Variant {
        name: "trace_mixed_deg3",
        body: "trace_body.glsl",
        defines: &["SH_DEGREE 3", "MIXED"],
        about: &[
            "The ray tracer of mixed scenes (issue 33) for scenes of SH degree 3, coefficients as 32-bit floats",
            "(GPUs; see trace_body.glsl).",
        ],
    },
    Variant {
        name: "trace_mixed_deg3_texels_k64",
        body: "trace_body.glsl",
        defines: &["SH_DEGREE 3", "SCENE_TEXELS", "TRACE_K 64", "MIXED"],
        about: &[
            "The ray tracer of mixed scenes (issue 33) for scenes of SH degree 3, coefficients as 32-bit floats,",
            "with a buffer of 64 hits per ray, reading through texel views (CPU drivers) (see trace_body.glsl).",
        ],
    },
    Variant {
        name: "trace_mixed_deg3_sh16",
        body: "trace_body.glsl",
        defines: &["SH_DEGREE 3", "SH_HALF 1", "MIXED"],
        about: &[
            "The ray tracer of mixed scenes (issue 33) for scenes of SH degree 3, coefficients as half floats",
            "(GPUs; see trace_body.glsl).",
        ],
    },
    Variant {
        name: "trace_mixed_deg3_sh16_texels_k64",
        body: "trace_body.glsl",
        defines: &["SH_DEGREE 3", "SH_HALF 1", "SCENE_TEXELS", "TRACE_K 64", "MIXED"],
        about: &[
            "The ray tracer of mixed scenes (issue 33) for scenes of SH degree 3, coefficients as half floats,",
            "with a buffer of 64 hits per ray, reading through texel views (CPU drivers) (see trace_body.glsl).",
        ],
    },
    Variant {
        name: "trace_tiled_deg0",
        body: "trace_body.glsl",
        defines: &["SH_DEGREE 0", "TILED"],
        about: &[
            "The ray tracer's camera rays from tile lists (SPEC section 11) for scenes of SH degree 0, coefficients as 32-bit floats,",
            "(GPUs; see trace_body.glsl).",
        ],
    },
    Variant {
        name: "trace_tiled_deg0_texels_k64",
        body: "trace_body.glsl",
        defines: &["SH_DEGREE 0", "SCENE_TEXELS", "TRACE_K 64", "TILED"],
        about: &[
            "The ray tracer's camera rays from tile lists (SPEC section 11) for scenes of SH degree 0, coefficients as 32-bit floats,",
            "with a buffer of 64 hits per ray, reading through texel views (CPU drivers) (see trace_body.glsl).",
        ],
    },
    Variant {
        name: "trace_tiled_deg0_sh16",
        body: "trace_body.glsl",
        defines: &["SH_DEGREE 0", "SH_HALF 1", "TILED"],
        about: &[
            "The ray tracer's camera rays from tile lists (SPEC section 11) for scenes of SH degree 0, coefficients as half floats,",
            "(GPUs; see trace_body.glsl).",
        ],
    },
    Variant {
        name: "trace_tiled_deg0_sh16_texels_k64",
        body: "trace_body.glsl",
        defines: &["SH_DEGREE 0", "SH_HALF 1", "SCENE_TEXELS", "TRACE_K 64", "TILED"],
        about: &[
            "The ray tracer's camera rays from tile lists (SPEC section 11) for scenes of SH degree 0, coefficients as half floats,",
            "with a buffer of 64 hits per ray, reading through texel views (CPU drivers) (see trace_body.glsl).",
        ],
    },
    Variant {
        name: "trace_tiled_deg1",
        body: "trace_body.glsl",
        defines: &["SH_DEGREE 1", "TILED"],
        about: &[
            "The ray tracer's camera rays from tile lists (SPEC section 11) for scenes of SH degree 1, coefficients as 32-bit floats,",
            "(GPUs; see trace_body.glsl).",
        ],
    },
    Variant {
        name: "trace_tiled_deg1_texels_k64",
        body: "trace_body.glsl",
        defines: &["SH_DEGREE 1", "SCENE_TEXELS", "TRACE_K 64", "TILED"],
        about: &[
            "The ray tracer's camera rays from tile lists (SPEC section 11) for scenes of SH degree 1, coefficients as 32-bit floats,",
            "with a buffer of 64 hits per ray, reading through texel views (CPU drivers) (see trace_body.glsl).",
        ],
    },
    Variant {
        name: "trace_tiled_deg1_sh16",
        body: "trace_body.glsl",
        defines: &["SH_DEGREE 1", "SH_HALF 1", "TILED"],
        about: &[
            "The ray tracer's camera rays from tile lists (SPEC section 11) for scenes of SH degree 1, coefficients as half floats,",
            "(GPUs; see trace_body.glsl).",
        ],
    },
    Variant {
        name: "trace_tiled_deg1_sh16_texels_k64",
        body: "trace_body.glsl",
        defines: &["SH_DEGREE 1", "SH_HALF 1", "SCENE_TEXELS", "TRACE_K 64", "TILED"],
        about: &[
            "The ray tracer's camera rays from tile lists (SPEC section 11) for scenes of SH degree 1, coefficients as half floats,",
            "with a buffer of 64 hits per ray, reading through texel views (CPU drivers) (see trace_body.glsl).",
        ],
    },
    Variant {
        name: "trace_tiled_deg2",
        body: "trace_body.glsl",
        defines: &["SH_DEGREE 2", "TILED"],
        about: &[
            "The ray tracer's camera rays from tile lists (SPEC section 11) for scenes of SH degree 2, coefficients as 32-bit floats,",
            "(GPUs; see trace_body.glsl).",
        ],
    },
    Variant {
        name: "trace_tiled_deg2_texels_k64",
        body: "trace_body.glsl",
        defines: &["SH_DEGREE 2", "SCENE_TEXELS", "TRACE_K 64", "TILED"],
        about: &[
            "The ray tracer's camera rays from tile lists (SPEC section 11) for scenes of SH degree 2, coefficients as 32-bit floats,",
            "with a buffer of 64 hits per ray, reading through texel views (CPU drivers) (see trace_body.glsl).",
        ],
    },
    Variant {
        name: "trace_tiled_deg2_sh16",
        body: "trace_body.glsl",
        defines: &["SH_DEGREE 2", "SH_HALF 1", "TILED"],
        about: &[
            "The ray tracer's camera rays from tile lists (SPEC section 11) for scenes of SH degree 2, coefficients as half floats,",
            "(GPUs; see trace_body.glsl).",
        ],
    },
    Variant {
        name: "trace_tiled_deg2_sh16_texels_k64",
        body: "trace_body.glsl",
        defines: &["SH_DEGREE 2", "SH_HALF 1", "SCENE_TEXELS", "TRACE_K 64", "TILED"],
        about: &[
            "The ray tracer's camera rays from tile lists (SPEC section 11) for scenes of SH degree 2, coefficients as half floats,",
            "with a buffer of 64 hits per ray, reading through texel views (CPU drivers) (see trace_body.glsl).",
        ],
    },
    Variant {
        name: "trace_tiled_deg3",
        body: "trace_body.glsl",
        defines: &["SH_DEGREE 3", "TILED"],
        about: &[
            "The ray tracer's camera rays from tile lists (SPEC section 11) for scenes of SH degree 3, coefficients as 32-bit floats,",
            "(GPUs; see trace_body.glsl).",
        ],
    },
    Variant {
        name: "trace_tiled_deg3_texels_k64",
        body: "trace_body.glsl",
        defines: &["SH_DEGREE 3", "SCENE_TEXELS", "TRACE_K 64", "TILED"],
        about: &[
            "The ray tracer's camera rays from tile lists (SPEC section 11) for scenes of SH degree 3, coefficients as 32-bit floats,",
            "with a buffer of 64 hits per ray, reading through texel views (CPU drivers) (see trace_body.glsl).",
        ],
    },
    Variant {
        name: "trace_tiled_deg3_sh16",
        body: "trace_body.glsl",
        defines: &["SH_DEGREE 3", "SH_HALF 1", "TILED"],
        about: &[
            "The ray tracer's camera rays from tile lists (SPEC section 11) for scenes of SH degree 3, coefficients as half floats,",
            "(GPUs; see trace_body.glsl).",
        ],
    },
    Variant {
        name: "trace_tiled_deg3_sh16_texels_k64",
        body: "trace_body.glsl",
        defines: &["SH_DEGREE 3", "SH_HALF 1", "SCENE_TEXELS", "TRACE_K 64", "TILED"],
        about: &[
            "The ray tracer's camera rays from tile lists (SPEC section 11) for scenes of SH degree 3, coefficients as half floats,",
            "with a buffer of 64 hits per ray, reading through texel views (CPU drivers) (see trace_body.glsl).",
        ],
    },
];
