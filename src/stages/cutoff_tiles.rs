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

use super::sort::SortBuffers;
use super::FrameRecording;
use crate::constants::FLAT_SPLATS_CONSTANT_ID;
use crate::error::Result;
use crate::shaders;
use crate::vk::{Buffer, Context, LazyPipeline};

/// Offset of the dispatch arguments over the cutoff records in the frame's cutoff-pairs buffer
/// (written after project on rara frames; the cutoff-records and cutoff-tiles stages read them).
pub const CUTOFF_ARGS_OFFSET: u64 = 0;
/// Offset of the (first pair, splat index) entries in the cutoff-pairs buffer, one per cutoff
/// record (before emit writes them, project's list of the cutoff Gaussians).
pub const CUTOFF_PAIRS_OFFSET: u64 = 16;

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
    /// Per cutoff record, its splat's bounds over the footprint ellipse (cutoff records), or
    /// 0: none.
    pub cutoff_bounds: u64,
}

/// The cutoff-tiles kernel.
pub struct CutoffTiles {
    pipeline: LazyPipeline,
    /// The same kernel for frames without flat Gaussians: their branch compiled out
    /// (`FLAT_SPLATS` in `glsl/clip.glsl`).
    volume: LazyPipeline,
}

impl CutoffTiles {
    /// The stage, whose kernel the first rara frame that classifies tiles builds; with
    /// `texels`, the layout of the frame's texel views (CPU drivers), the variant that reads
    /// through them, and with `packed` too, the one over the packed pairs that emit then writes
    /// ([`super::emit::Emit::pair_form`]).
    ///
    /// Without texel views the pairs of a workgroup's cutoff splats are shared out over its
    /// invocations (`cutoff_tiles_balanced`), so that a splat over many tiles does not hold the
    /// pass up; `RARA_CUTOFF_TILES=splats` gives each invocation whole splats instead
    /// (`cutoff_tiles`, as the texel variant does), for comparison.
    pub fn new(
        ctx: &Context,
        texels: Option<vk::DescriptorSetLayout>,
        packed: bool,
    ) -> Result<Self> {
        let whole_splats = std::env::var("RARA_CUTOFF_TILES").as_deref() == Ok("splats");
        let (name, spirv) = match texels {
            Some(_) if packed => (
                c"cutoff_tiles_packed_texels",
                shaders::CUTOFF_TILES_PACKED_TEXELS,
            ),
            Some(_) => (c"cutoff_tiles_texels", shaders::CUTOFF_TILES_TEXELS),
            None if whole_splats => (c"cutoff_tiles", shaders::CUTOFF_TILES),
            None => (c"cutoff_tiles_balanced", shaders::CUTOFF_TILES_BALANCED),
        };
        let build = || LazyPipeline::new::<CutoffTilesPush>(ctx, name, spirv, texels);
        Ok(CutoffTiles {
            pipeline: build(),
            volume: build().specialized(&[(FLAT_SPLATS_CONSTANT_ID, 0)]),
        })
    }

    /// Records the pass "cutoff tiles": one workgroup per
    /// [`crate::constants::LINEAR_WORKGROUP`] cutoff splats, which share their pairs out
    /// (`glsl/cutoff_tiles_body.glsl`), over the pairs emit wrote into the first buffers of
    /// `sort`; flags the tiles that keep a weighted pair at `tile_flags` (0: none), then a
    /// barrier. `flat`: whether the frame may hold flat Gaussians. In frames with a records'
    /// pass (CPU drivers) the kernel is dispatched indirectly from the arguments that pass
    /// wrote in `pairs` (the frame's cutoff-pairs buffer); in the others (GPUs) directly over
    /// `over_gaussians`, the scene's count, the workgroups past the cutoff records leaving at
    /// once.
    pub fn record(
        &self,
        f: &mut FrameRecording,
        pairs: &Buffer,
        sort: &SortBuffers,
        tile_flags: u64,
        (over_gaussians, flat): (Option<u32>, bool),
    ) -> Result<()> {
        let kernel = if flat { &self.pipeline } else { &self.volume }.get()?;
        let push = CutoffTilesPush {
            frame: f.at.params,
            splats: f.at.splats,
            tiles_touched: f.at.tiles_touched,
            counters: f.at.counters,
            cutoff_pairs: pairs.address + CUTOFF_PAIRS_OFFSET,
            clip: f.at.clip,
            cutoffs: f.at.cutoffs,
            keys: sort.keys[0].address,
            values: sort.values[0].address,
            tile_flags,
            cutoff_bounds: f.at.cutoff_bounds,
        };
        f.pass(c"cutoff tiles", |f| {
            match over_gaussians {
                None => kernel.dispatch_indirect_in(
                    f.cmd,
                    &push,
                    f.texels,
                    pairs.raw,
                    CUTOFF_ARGS_OFFSET,
                ),
                Some(n) => kernel.dispatch_in(f.cmd, &push, f.texels, super::linear_grid(n)),
            }
            f.barrier();
        });
        Ok(())
    }
}
