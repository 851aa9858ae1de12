//! Stage 1: project every Gaussian (`glsl/project_body.glsl`; CPU twin `reference::project`).

use ash::vk;
use bytemuck::{Pod, Zeroable};

use crate::error::Result;
use crate::precision::ShPrecision;
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
    /// Out: 1 per Gaussian that touches a tile, else 0.
    pub drawn: u64,
    /// Frame counters (visible count).
    pub counters: u64,
    /// `ClipParams`.
    pub clip: u64,
    /// Cutoff side records (0 when the frame is not rara-clipped).
    pub cutoffs: u64,
}

/// The project kernel, in one variant per SH storage precision.
pub struct Project {
    sh32: ComputePipeline,
    sh16: ComputePipeline,
}

impl Project {
    /// Builds the kernel.
    pub fn new(ctx: &Context) -> Result<Self> {
        Ok(Project {
            sh32: ComputePipeline::new::<ProjectPush>(ctx, c"project", shaders::PROJECT)?,
            sh16: ComputePipeline::new::<ProjectPush>(
                ctx,
                c"project (SH f16)",
                shaders::PROJECT_SH16,
            )?,
        })
    }

    /// Records the projection of `count` Gaussians whose SH are stored at `precision`.
    pub fn record(
        &self,
        cmd: vk::CommandBuffer,
        push: &ProjectPush,
        count: u32,
        precision: ShPrecision,
    ) {
        let pipeline = match precision {
            ShPrecision::F32 => &self.sh32,
            ShPrecision::F16 => &self.sh16,
        };
        pipeline.dispatch(cmd, push, super::linear_grid(count));
    }
}
