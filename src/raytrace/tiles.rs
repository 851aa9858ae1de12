//! Section 7 in tiles (SPEC section 11): the tile lists the ray tracer's camera rays walk
//! instead of a BVH. Stage by stage, in the rasterizer's frame buffers
//! ([`crate::frame::FrameSlot`]) and with its sorting stages:
//!
//! 1. bounds (`glsl/tiled_bounds.comp`): per Gaussian its key (the least view depth of any hit
//!    of it) and the tiles under its proxy's silhouette rectangle;
//! 2. the listed Gaussians in key order: the depth order's scan and sort
//!    ([`crate::stages::depth_order::DepthOrder`], over the keys where project leaves depths), and the
//!    prefix sum of their tiles touched in that order;
//! 3. emit (`glsl/tiled_emit.comp`): the (tile, Gaussian) pairs, in key order;
//! 4. the stable pair sort by tile ([`crate::stages::sort::RadixSort`]) and the tile ranges
//!    ([`crate::stages::tile_ranges::TileRanges`]): each tile's list in (key, index) order.
//!
//! The ray tracer's `TILED` kernels (`glsl/trace_body.glsl`) then walk them ([`RayTileLists`]).
//! CPU twin: [`crate::reference::tiled`].

use bytemuck::{Pod, Zeroable};

use crate::constants::{COUNTER_INTERSECTIONS, COUNTER_VISIBLE};
use crate::error::Result;
use crate::gpu_scene::GpuScene;
use crate::shaders;
use crate::stages::depth_order::{DepthOrder, DEPTH_ORDER_BUFFER};
use crate::stages::prefix_sum::{PrefixSum, PrefixSumScratch};
use crate::stages::sort::{RadixSort, SortBuffers, TILE_SORT_LABELS};
use crate::stages::tile_ranges::TileRanges;
use crate::stages::{linear_grid, FrameRecording};
use crate::vk::{ComputePipeline, Context};

#[repr(C)]
#[derive(Clone, Copy, Pod, Zeroable)]
struct BoundsPush {
    frame: u64,
    gaussians: u64,
    splat_words: u64,
    tiles_touched: u64,
    listed: u64,
    q: f32,
    pad: u32,
}

#[repr(C)]
#[derive(Clone, Copy, Pod, Zeroable)]
struct EmitPush {
    frame: u64,
    splat_words: u64,
    listed: u64,
    order: u64,
    offsets: u64,
    tile_ids: u64,
    values: u64,
    progress: u64,
    round_index: u32,
    pad: u32,
}

/// Where a frame's tile lists are, for the ray tracer's `TILED` kernels.
#[derive(Clone, Copy, Debug)]
pub struct RayTileLists {
    /// Per tile `[start, end)` into `gaussians` (`u32` pairs).
    pub ranges: u64,
    /// The sorted pairs' Gaussians: each tile's list in (key, index) order.
    pub gaussians: u64,
    /// Per Gaussian its 48-byte record, whose first 16 bytes the tracer reads by the listed
    /// ones' index: the silhouette's pixels and the key (`glsl/tiled_bounds.comp`).
    pub records: u64,
    /// On CPU drivers, the frame's texel views over the same buffers
    /// ([`crate::stages::frame_texels_set_layout`]), which the tracer's texel kernels read
    /// the lists, the records and the scene through.
    pub texels: Option<ash::vk::DescriptorSet>,
}

/// The kernels that build the tile lists.
pub struct RayTiles {
    bounds: ComputePipeline,
    emit: ComputePipeline,
    /// The depth order's kernels, by address (the tile lists' frames run without the
    /// rasterizer's texel views).
    order: DepthOrder,
    ranges: TileRanges,
}

impl RayTiles {
    /// Builds the kernels.
    pub fn new(ctx: &Context) -> Result<Self> {
        Ok(RayTiles {
            bounds: ComputePipeline::new::<BoundsPush>(
                ctx,
                c"tiled_bounds",
                shaders::TILED_BOUNDS,
            )?,
            emit: ComputePipeline::new::<EmitPush>(ctx, c"tiled_emit", shaders::TILED_EMIT)?,
            order: DepthOrder::new(ctx, None)?,
            ranges: TileRanges::new(ctx, None)?,
        })
    }

    /// Records the stages of the tile lists of `scene` into the frame `f` (its `FrameParams`,
    /// counters, splat records, tiles touched, slots and ranges, zeroed where the rasterizer's
    /// frame zeroes them), with the octagons' `q`: passes "tiled bounds", "depth keys" and the
    /// key sort, "prefix sum", "tiled emit", the pair sort, "tile ranges". The pairs past the
    /// sort buffers' capacity are counted (`COUNTER_INTERSECTIONS`) and left out. `f.texels`
    /// (the frame's texel views, on CPU drivers) goes on to the tracer in the lists.
    pub fn record(
        &self,
        f: &mut FrameRecording,
        scene: &GpuScene,
        q: f32,
        (prefix_sum, scratch): (&PrefixSum, &PrefixSumScratch),
        sort: &RadixSort,
        bufs: &SortBuffers,
    ) -> RayTileLists {
        // These kernels read by address: the set is the tracer's alone.
        let texels = f.texels.take();
        let count = scene.count;
        let push = BoundsPush {
            frame: f.at.params,
            gaussians: scene.gaussians.address,
            splat_words: f.at.splats,
            tiles_touched: f.at.tiles_touched,
            listed: f.at.slots,
            q,
            pad: 0,
        };
        f.pass(c"tiled bounds", |f| {
            self.bounds.dispatch(f.cmd, &push, linear_grid(count));
            f.barrier();
        });
        self.order
            .record_sorted(f, count, (prefix_sum, scratch), sort, bufs);
        let order = bufs.values[DEPTH_ORDER_BUFFER].address;
        self.order
            .record_first_pairs(f, count, order, (prefix_sum, scratch));
        let mut push = EmitPush {
            frame: f.at.params,
            splat_words: f.at.splats,
            listed: f.at.counter(COUNTER_VISIBLE),
            order,
            offsets: f.at.slots,
            tile_ids: bufs.keys[0].address,
            values: bufs.values[0].address,
            // The key sort's other key buffer, free once the order is known.
            progress: bufs.keys[DEPTH_ORDER_BUFFER].address,
            round_index: 0,
            pad: 0,
        };
        let rounds = crate::stages::tile_rect_rounds(f.tile_count());
        f.pass(c"tiled emit", |f| {
            for round_index in 0..rounds {
                push.round_index = round_index;
                self.emit.dispatch(f.cmd, &push, linear_grid(count));
                f.barrier();
            }
        });
        let (w, h) = f.size;
        let sorted = sort.record(
            f.ctx,
            f.cmd,
            bufs,
            f.at.counter(COUNTER_INTERSECTIONS),
            crate::stages::sort::tile_key_bits(w, h),
            &TILE_SORT_LABELS,
            Some(&mut *f.timer),
        );
        self.ranges.record(f, bufs, sorted);
        RayTileLists {
            ranges: f.at.ranges,
            gaussians: bufs.values[sorted].address,
            records: f.at.splats,
            texels,
        }
    }
}
