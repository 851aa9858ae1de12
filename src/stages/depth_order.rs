//! Stage 2: the drawn Gaussians in depth order (`glsl/depth_keys_body.glsl`, the radix sort,
//! `glsl/depth_counts_body.glsl`).
//!
//! The frame scans project's drawn flags into packed sort slots, writes one (depth bits,
//! index) pair per drawn Gaussian ([`DepthOrder::record_sorted`]), sorts them by depth with the
//! stable [`super::sort::RadixSort`] (ties keep index order), and lists the tiles touched in
//! that order ([`DepthOrder::record_first_pairs`]) for the prefix sum that places each Gaussian's
//! pairs. Emit then writes the pairs in depth order and the pair sort only needs the tile bits:
//! 32 depth bits are sorted once per Gaussian instead of once per (tile, splat) pair.

use ash::vk;
use bytemuck::{Pod, Zeroable};

use super::prefix_sum::{PrefixSum, PrefixSumScratch};
use super::sort::{RadixSort, SortBuffers, DEPTH_SORT_LABELS};
use super::FrameRecording;
use crate::constants::{COUNTER_INTERSECTIONS, COUNTER_VISIBLE};
use crate::error::Result;
use crate::shaders;
use crate::vk::{ComputePipeline, Context};

/// Bits of the depth sort's keys: a drawn Gaussian's whole `f32` depth (positive, so its bits
/// order as the depths do).
pub const DEPTH_KEY_BITS: u32 = 32;

/// The buffer of the frame's [`SortBuffers`] (shared with the tile pairs' sort) that holds the
/// depth order: buffer 1, so that emit can write the tile pairs into buffer 0, where the pair
/// sort starts, while it reads the order. The depth sort starts in whichever buffer makes its
/// passes end there. Sharing the buffers saves the depth sort's own (16 B per Gaussian on GPUs,
/// 24 B in the CPU drivers' layout): the pairs are not written until the order is read.
pub const DEPTH_ORDER_BUFFER: usize = 1;

/// Byte offset of `scene.x` (the Gaussian count) in `FrameParams`: the scan of the drawn flags
/// reads its length there.
const PARAMS_COUNT_OFFSET: u64 = 112;

/// Device addresses the depth-keys kernel reads and writes.
#[repr(C)]
#[derive(Clone, Copy, Pod, Zeroable)]
pub struct DepthKeysPush {
    /// `FrameParams`.
    pub frame: u64,
    /// `ProjectedSplat[]`.
    pub splats: u64,
    /// Tiles touched per Gaussian.
    pub tiles_touched: u64,
    /// Exclusive scan of the drawn flags: each drawn Gaussian's slot.
    pub slots: u64,
    /// Out: depth bits per slot.
    pub keys: u64,
    /// Out: Gaussian index per slot.
    pub values: u64,
}

/// Device addresses the depth-counts kernel reads and writes.
#[repr(C)]
#[derive(Clone, Copy, Pod, Zeroable)]
pub struct DepthCountsPush {
    /// `u32`: the number of drawn Gaussians.
    pub drawn: u64,
    /// Gaussian indices in depth order (the depth sort's values).
    pub order: u64,
    /// Tiles touched per Gaussian.
    pub tiles_touched: u64,
    /// Out: tiles touched in depth order.
    pub counts: u64,
}

/// The two kernels around the depth sort.
pub struct DepthOrder {
    keys: ComputePipeline,
    counts: ComputePipeline,
}

impl DepthOrder {
    /// Builds the kernels; with `texels`, the layout of the frame's texel views (CPU drivers,
    /// along with the strips rasterizer), the variants that read through them
    /// (`depth_{keys,counts}_texels`).
    pub fn new(ctx: &Context, texels: Option<vk::DescriptorSetLayout>) -> Result<Self> {
        let (keys, counts) = match texels {
            Some(_) => (
                (c"depth_keys_texels", shaders::DEPTH_KEYS_TEXELS),
                (c"depth_counts_texels", shaders::DEPTH_COUNTS_TEXELS),
            ),
            None => (
                (c"depth_keys", shaders::DEPTH_KEYS),
                (c"depth_counts", shaders::DEPTH_COUNTS),
            ),
        };
        Ok(DepthOrder {
            keys: ComputePipeline::with_set_layout::<DepthKeysPush>(ctx, keys.0, keys.1, texels)?,
            counts: ComputePipeline::with_set_layout::<DepthCountsPush>(
                ctx, counts.0, counts.1, texels,
            )?,
        })
    }

    /// Records the pass "depth keys" (project's drawn flags scanned into packed sort slots,
    /// the count into `COUNTER_VISIBLE`, then one (depth bits, index) pair per drawn
    /// Gaussian) and then the depth sort's passes over `depth_sort` (the frame's sort buffers,
    /// which must hold a pair per Gaussian), whose result is in buffer
    /// [`DEPTH_ORDER_BUFFER`]. The texel kernels read the frame's texel views.
    pub fn record_sorted(
        &self,
        f: &mut FrameRecording,
        count: u32,
        scan: (&PrefixSum, &PrefixSumScratch),
        sort: &RadixSort,
        depth_sort: &SortBuffers,
    ) {
        assert!(
            depth_sort.capacity() >= count as u64,
            "a sort slot per Gaussian"
        );
        let (prefix_sum, scratch) = scan;
        let first = (DEPTH_ORDER_BUFFER + sort.passes_for(DEPTH_KEY_BITS) as usize) % 2;
        let push = DepthKeysPush {
            frame: f.at.params,
            splats: f.at.splats,
            tiles_touched: f.at.tiles_touched,
            slots: f.at.slots,
            keys: depth_sort.keys[first].address,
            values: depth_sort.values[first].address,
        };
        f.pass(c"depth keys", |f| {
            prefix_sum.record(
                f.ctx,
                f.cmd,
                f.at.slots,
                f.at.params + PARAMS_COUNT_OFFSET,
                Some(f.at.counter(COUNTER_VISIBLE)),
                scratch,
            );
            self.keys
                .dispatch_in(f.cmd, &push, f.texels, super::linear_grid(count));
            f.barrier();
        });
        let sorted = sort.record_from(
            f.ctx,
            f.cmd,
            depth_sort,
            first,
            f.at.counter(COUNTER_VISIBLE),
            DEPTH_KEY_BITS,
            &DEPTH_SORT_LABELS,
            Some(&mut *f.timer),
        );
        debug_assert_eq!(sorted, DEPTH_ORDER_BUFFER);
    }

    /// Records the pass "prefix sum": the tiles touched listed in depth `order` (the depth
    /// sort's values), then scanned into each drawn Gaussian's first pair, with the frame's
    /// pair count into `COUNTER_INTERSECTIONS`.
    pub fn record_first_pairs(
        &self,
        f: &mut FrameRecording,
        count: u32,
        order: u64,
        scan: (&PrefixSum, &PrefixSumScratch),
    ) {
        let (prefix_sum, scratch) = scan;
        let push = DepthCountsPush {
            drawn: f.at.counter(COUNTER_VISIBLE),
            order,
            tiles_touched: f.at.tiles_touched,
            counts: f.at.slots,
        };
        f.pass(c"prefix sum", |f| {
            self.counts
                .dispatch_in(f.cmd, &push, f.texels, super::linear_grid(count));
            f.barrier();
            prefix_sum.record(
                f.ctx,
                f.cmd,
                f.at.slots,
                f.at.counter(COUNTER_VISIBLE),
                Some(f.at.counter(COUNTER_INTERSECTIONS)),
                scratch,
            );
        });
    }
}
