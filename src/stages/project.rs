//! Stage 1: project every Gaussian (`glsl/project.comp`; CPU twin `reference::project`).

use ash::vk;
use bytemuck::{Pod, Zeroable};

use crate::constants::LINEAR_WORKGROUP;
use crate::error::Result;
use crate::shaders;
use crate::vk::{ComputePipeline, Context};

/// Device addresses the project kernel reads and writes.
#[repr(C)]
#[derive(Clone, Copy, Pod, Zeroable)]
pub struct ProjectPush {
    /// `FrameParams`.
    pub frame: u64,
    /// `Gaussian[]`.
    pub gaussians: u64,
    /// SH coefficients.
    pub sh: u64,
    /// Out: `ProjectedSplat[]`.
    pub splats: u64,
    /// Out: tiles touched per Gaussian.
    pub tiles_touched: u64,
    /// Frame counters (visible count).
    pub counters: u64,
    /// `ClipParams`.
    pub clip: u64,
    /// Cutoff side records (0 when the frame is not rara-clipped).
    pub cutoffs: u64,
}

/// The project kernel.
pub struct Project {
    pipeline: ComputePipeline,
}

impl Project {
    /// Builds the kernel.
    pub fn new(ctx: &Context) -> Result<Self> {
        Ok(Project {
            pipeline: ComputePipeline::new::<ProjectPush>(ctx, c"project", shaders::PROJECT)?,
        })
    }

    /// Records the projection of `count` Gaussians.
    pub fn record(&self, cmd: vk::CommandBuffer, push: &ProjectPush, count: u32) {
        self.pipeline
            .dispatch(cmd, push, [count.div_ceil(LINEAR_WORKGROUP), 1, 1]);
    }
}
