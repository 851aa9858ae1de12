//! Stage 2: the drawn Gaussians in depth order (`glsl/depth_keys_body.glsl`, the radix sort,
//! `glsl/depth_counts_body.glsl`).
//!
//! The frame scans project's drawn flags into packed sort slots, writes one (depth bits,
//! index) pair per drawn Gaussian ([`DepthOrder::record_keys`]), sorts them by depth with the
//! stable [`super::sort::RadixSort`] (ties keep index order), and lists the tiles touched in
//! that order ([`DepthOrder::record_counts`]) for the prefix sum that places each Gaussian's
//! pairs. Emit then writes the pairs in depth order and the pair sort only needs the tile bits:
//! 32 depth bits are sorted once per Gaussian instead of once per (tile, splat) pair.

use ash::vk;
use bytemuck::{Pod, Zeroable};

use crate::error::Result;
use crate::shaders;
use crate::vk::{ComputePipeline, Context};

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

    /// Records the depth keys of a scene of `count` Gaussians (the texel kernels need
    /// `frame_texels`, the frame's set of [`super::frame_texels_set_layout`]).
    pub fn record_keys(
        &self,
        cmd: vk::CommandBuffer,
        push: &DepthKeysPush,
        count: u32,
        frame_texels: Option<vk::DescriptorSet>,
    ) {
        self.keys
            .dispatch_in(cmd, push, frame_texels, super::linear_grid(count));
    }

    /// Records the tiles touched in depth order for a scene of `count` Gaussians (the drawn
    /// ones are read on the GPU; `frame_texels` as for [`DepthOrder::record_keys`]).
    pub fn record_counts(
        &self,
        cmd: vk::CommandBuffer,
        push: &DepthCountsPush,
        count: u32,
        frame_texels: Option<vk::DescriptorSet>,
    ) {
        self.counts
            .dispatch_in(cmd, push, frame_texels, super::linear_grid(count));
    }
}
