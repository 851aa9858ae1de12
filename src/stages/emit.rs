//! Stage 4: emit one (tile id, splat index) pair per touched tile, in depth order
//! (`glsl/emit.comp`).

use ash::vk;
use bytemuck::{Pod, Zeroable};

use crate::error::Result;
use crate::shaders;
use crate::vk::{ComputePipeline, Context};

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
    /// Out: keys (tile ids).
    pub keys: u64,
    /// Out: values (splat indices).
    pub values: u64,
}

/// The emit kernel.
pub struct Emit {
    pipeline: ComputePipeline,
}

impl Emit {
    /// Builds the kernel.
    pub fn new(ctx: &Context) -> Result<Self> {
        Ok(Emit {
            pipeline: ComputePipeline::new::<EmitPush>(ctx, c"emit", shaders::EMIT)?,
        })
    }

    /// Records the emission for a scene of `count` Gaussians (the drawn ones are read on the
    /// GPU).
    pub fn record(&self, cmd: vk::CommandBuffer, push: &EmitPush, count: u32) {
        self.pipeline.dispatch(cmd, push, super::linear_grid(count));
    }
}
