//! Stage 4b, rara clipping by planes with the mass weight only: classifies each cutoff splat's
//! pairs by tile (`glsl/cutoff_tiles_body.glsl`). A pair whose clip weight is 1 at every pixel of
//! its tile loses the [`crate::constants::PAIR_WEIGHTED`] that emit gave it, so it is drawn as
//! a plain splat there; a pair that adds nothing to its tile leaves every tile list, and only
//! the rest pay the rasterizer's per-pixel weight.
//!
//! On CPU drivers (with the strips rasterizer) the kernel reads the splats, the cutoff records,
//! the tiles touched, the emitted keys and the clip planes through the frame's texel views
//! (`cutoff_tiles_texels`): a CPU driver loads a texel as a gather, where a buffer
//! load is a scalar loop over the lanes per 64-bit word.

use ash::vk;
use bytemuck::{Pod, Zeroable};

use crate::error::Result;
use crate::shaders;
use crate::vk::{ComputePipeline, Context};

/// Device addresses the cutoff-tiles kernel reads and writes.
#[repr(C)]
#[derive(Clone, Copy, Pod, Zeroable)]
pub struct CutoffTilesPush {
    /// `FrameParams`.
    pub frame: u64,
    /// `ProjectedSplat[]`.
    pub splats: u64,
    /// Tiles touched per Gaussian.
    pub tiles_touched: u64,
    /// The frame's counters (the number of cutoff splats).
    pub counters: u64,
    /// Per cutoff record: its splat's (first pair, splat index), from emit.
    pub cutoff_pairs: u64,
    /// `ClipParams`.
    pub clip: u64,
    /// `CutoffRecord[]`.
    pub cutoffs: u64,
    /// In and out: the pairs' keys (tile ids), as emitted.
    pub keys: u64,
    /// In and out: the pairs' values (splat indices).
    pub values: u64,
    /// Out, with the tile lists ([`super::tile_lists`]; else 0): per tile, set where a pair
    /// stays weighted, and after the last tile, set when pairs were left unclassified.
    pub tile_flags: u64,
}

/// The cutoff-tiles kernel.
pub struct CutoffTiles {
    pipeline: ComputePipeline,
}

impl CutoffTiles {
    /// Builds the kernel; with `texels`, the layout of the frame's texel views (CPU drivers),
    /// the variant that reads through them.
    pub fn new(ctx: &Context, texels: Option<vk::DescriptorSetLayout>) -> Result<Self> {
        let (name, spirv) = match texels {
            Some(_) => (c"cutoff_tiles_texels", shaders::CUTOFF_TILES_TEXELS),
            None => (c"cutoff_tiles", shaders::CUTOFF_TILES),
        };
        Ok(CutoffTiles {
            pipeline: ComputePipeline::with_set_layout::<CutoffTilesPush>(
                ctx, name, spirv, texels,
            )?,
        })
    }

    /// Records the kernel, one workgroup per [`crate::constants::LINEAR_WORKGROUP`] cutoff
    /// splats, which share their pairs out (`glsl/cutoff_tiles_body.glsl`), dispatched
    /// indirectly from the arguments emit wrote at `args` + `args_offset`. The texel kernel
    /// needs `frame_texels`, the frame's set of [`super::frame_texels_set_layout`].
    pub fn record(
        &self,
        cmd: vk::CommandBuffer,
        push: &CutoffTilesPush,
        frame_texels: Option<vk::DescriptorSet>,
        args: vk::Buffer,
        args_offset: u64,
    ) {
        self.pipeline
            .dispatch_indirect_in(cmd, push, frame_texels, args, args_offset);
    }
}
