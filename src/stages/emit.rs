//! Stage 4: emit one (tile id, splat index) pair per touched tile, in depth order
//! (`glsl/emit_body.glsl`). Under rara clipping by planes with the mass weight, the variant
//! `emit_rara` also records where each cutoff splat's pairs start, for the cutoff-tiles stage
//! ([`super::cutoff_tiles`]). Where the frame's sort takes packed pairs (CPU drivers), emit
//! writes each pair as one 64-bit word ([`PairForm::Packed`]).

use ash::vk;
use bytemuck::{Pod, Zeroable};

use std::ffi::CStr;

use super::cutoff_tiles::CUTOFF_PAIRS_OFFSET;
use super::sort::{PairForm, SortBuffers};
use super::FrameRecording;
use crate::constants::COUNTER_VISIBLE;
use crate::error::Result;
use crate::shaders;
use crate::vk::{Buffer, Context, LazyPipeline};

/// Device addresses the emit kernel reads and writes.
#[repr(C)]
#[derive(Clone, Copy, Pod, Zeroable)]
pub struct EmitPush {
    /// `FrameParams`.
    pub frame: u64,
    /// `ProjectedSplat[]`.
    pub splats: u64,
    /// `u32`: the number of drawn Gaussians.
    pub drawn: u64,
    /// Gaussian indices in depth order.
    pub order: u64,
    /// Exclusive prefix sum of tiles touched, in depth order.
    pub offsets: u64,
    /// Out: keys (tile ids), or the packed pairs ([`Emit::pair_form`]).
    pub keys: u64,
    /// Out: values (splat indices); unused with packed pairs.
    pub values: u64,
    /// Out (`emit_rara` only): per cutoff record, its splat's (first pair, splat index).
    pub cutoff_pairs: u64,
    /// Scratch of a `u32` per drawn Gaussian: where a splat whose tile rectangle goes on past
    /// a round takes up its pairs in the next (read only when there are several rounds).
    pub progress: u64,
    /// Set by [`Emit::record`] for each round.
    pub round_index: u32,
    /// Padding.
    pub pad: u32,
}

/// The emit kernels: plain, and recording the cutoff splats' pairs (each built when a frame
/// first needs it).
pub struct Emit {
    plain: LazyPipeline,
    cutoff_pairs: LazyPipeline,
    packed: bool,
}

impl Emit {
    /// Builds the kernels; with `texels`, the layout of the frame's texel views (CPU drivers,
    /// along with the strips rasterizer), the variants that read the depth order, the first
    /// pairs and the projected splats through them (`emit*_texels`): a CPU driver loads
    /// those as gathers, where a buffer load is a scalar loop over the lanes per 64-bit word.
    /// With `packed` too (the frame's sort takes packed pairs), those that write each pair as
    /// one 64-bit word (`emit*_packed_texels`).
    pub fn new(
        ctx: &Context,
        texels: Option<vk::DescriptorSetLayout>,
        packed: bool,
    ) -> Result<Self> {
        let build = |name: &'static CStr, spirv: &'static [u32]| {
            LazyPipeline::new::<EmitPush>(ctx, name, spirv, texels)
        };
        let packed = packed && texels.is_some();
        let (plain, cutoff_pairs) = match texels {
            Some(_) if packed => (
                build(c"emit_packed_texels", shaders::EMIT_PACKED_TEXELS),
                build(c"emit_rara_packed_texels", shaders::EMIT_RARA_PACKED_TEXELS),
            ),
            Some(_) => (
                build(c"emit_texels", shaders::EMIT_TEXELS),
                build(c"emit_rara_texels", shaders::EMIT_RARA_TEXELS),
            ),
            None => (
                build(c"emit", shaders::EMIT),
                build(c"emit_rara", shaders::EMIT_RARA),
            ),
        };
        Ok(Emit {
            plain,
            cutoff_pairs,
            packed,
        })
    }

    /// How the kernels write the pairs: packed ([`PairForm::Packed`]) or split, the form the
    /// pair sort must then take them in.
    pub fn pair_form(&self) -> PairForm {
        if self.packed {
            PairForm::Packed
        } else {
            PairForm::Split
        }
    }

    /// Records the pass "emit" for a scene of `count` Gaussians (the drawn ones are read on
    /// the GPU, in depth `order`): the pairs into the first buffers of `sort`, in
    /// [`super::tile_rect_rounds`] rounds with a barrier after each. With `cutoff_pairs` (the
    /// cutoff-tiles stage's buffer), the kernel also lists where each cutoff splat's pairs
    /// start (the dispatch arguments of [`super::cutoff_tiles::CutoffTiles::record`] are
    /// project's, [`super::project::Project::record`]).
    /// `progress` is scratch of a `u32` per Gaussian for the rounds (the depth sort's other key
    /// buffer, free by then).
    pub fn record(
        &self,
        f: &mut FrameRecording,
        count: u32,
        order: u64,
        sort: &SortBuffers,
        cutoff_pairs: Option<&Buffer>,
        progress: u64,
    ) -> Result<()> {
        let push = EmitPush {
            frame: f.at.params,
            splats: f.at.splats,
            drawn: f.at.counter(COUNTER_VISIBLE),
            order,
            offsets: f.at.slots,
            keys: sort.keys[0].address,
            values: sort.values[0].address,
            cutoff_pairs: cutoff_pairs.map_or(0, |b| b.address + CUTOFF_PAIRS_OFFSET),
            progress,
            round_index: 0,
            pad: 0,
        };
        let pipeline = if cutoff_pairs.is_some() {
            &self.cutoff_pairs
        } else {
            &self.plain
        }
        .get()?;
        let rounds = super::tile_rect_rounds(f.tile_count());
        f.pass(c"emit", |f| {
            for round_index in 0..rounds {
                let push = EmitPush {
                    round_index,
                    ..push
                };
                pipeline.dispatch_in(f.cmd, &push, f.texels, super::linear_grid(count));
                f.barrier();
            }
        });
        Ok(())
    }
}
