//! Stage 7: composite each tile's sorted splats per pixel (`glsl/rasterize.comp`; CPU twin
//! `reference::rasterize`).

use ash::vk;
use bytemuck::{Pod, Zeroable};

use std::ffi::CStr;

use crate::clip::ClipWeight;
use crate::error::Result;
use crate::shaders;
use crate::vk::{compute_barrier, ComputePipeline, Context};

/// Device addresses and round of the rasterizer.
#[repr(C)]
#[derive(Clone, Copy, Pod, Zeroable)]
pub struct RasterizePush {
    /// `FrameParams`.
    pub frame: u64,
    /// `ProjectedSplat[]`.
    pub splats: u64,
    /// Sorted splat indices.
    pub values: u64,
    /// Tile ranges.
    pub ranges: u64,
    /// Per-pixel state (premultiplied colour, transmittance): carried between rounds and
    /// left for the write-target stage.
    pub state: u64,
    /// Frame counters (longest tile list).
    pub counters: u64,
    /// `ClipParams`.
    pub clip: u64,
    /// Cutoff side records (0 when the frame is not rara-clipped).
    pub cutoffs: u64,
    /// Which RASTER_CHUNK of every tile list this dispatch walks.
    pub round_index: u32,
    /// ROUND_FIRST on the first round.
    pub flags: u32,
}

const ROUND_FIRST: u32 = 1;

/// How the rasterizer maps pixels to invocations. Both give the same image.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum RasterLayout {
    /// One invocation per pixel, 256 per tile (`rasterize.comp`): the layout for GPUs.
    PixelPerInvocation,
    /// One invocation per strip of 2 columns x 16 rows, 8 per tile (`rasterize_strips*.comp`):
    /// for CPU drivers such as lavapipe, where each staged splat is then loaded once for 32
    /// pixels and a tile is one 8-lane SIMD vector.
    Strips,
}

impl RasterLayout {
    /// The layout for a device: strips on CPU devices ([`RasterLayout::Strips`]), a pixel per
    /// invocation elsewhere.
    /// `RARA_RASTER=pixels|strips` overrides the choice.
    pub fn for_device(ctx: &Context) -> RasterLayout {
        match std::env::var("RARA_RASTER").as_deref() {
            Ok("pixels") => return RasterLayout::PixelPerInvocation,
            Ok("strips") => return RasterLayout::Strips,
            _ => {}
        }
        if ctx.info().device_type == vk::PhysicalDeviceType::CPU {
            RasterLayout::Strips
        } else {
            RasterLayout::PixelPerInvocation
        }
    }
}

/// The rasterize kernels of one layout: without rara clipping, and with each cutoff weight.
/// CPU drivers execute both sides of every branch, so each frame runs the kernel that holds
/// only the code it needs.
pub struct Rasterize {
    plain: ComputePipeline,
    mass: ComputePipeline,
    length: ComputePipeline,
    layout: RasterLayout,
}

impl Rasterize {
    /// Builds the kernels in `layout`.
    pub fn new(ctx: &Context, layout: RasterLayout) -> Result<Self> {
        let build = |name: &'static CStr, spirv: &[u32]| {
            ComputePipeline::new::<RasterizePush>(ctx, name, spirv)
        };
        Ok(match layout {
            RasterLayout::PixelPerInvocation => Rasterize {
                plain: build(c"rasterize", shaders::RASTERIZE)?,
                mass: build(c"rasterize_mass", shaders::RASTERIZE_MASS)?,
                length: build(c"rasterize_length", shaders::RASTERIZE_LENGTH)?,
                layout,
            },
            RasterLayout::Strips => Rasterize {
                plain: build(c"rasterize_strips", shaders::RASTERIZE_STRIPS)?,
                mass: build(c"rasterize_strips_mass", shaders::RASTERIZE_STRIPS_MASS)?,
                length: build(c"rasterize_strips_length", shaders::RASTERIZE_STRIPS_LENGTH)?,
                layout,
            },
        })
    }

    /// The layout the kernels were built in.
    pub fn layout(&self) -> RasterLayout {
        self.layout
    }

    /// Records `rounds` dispatches over the `tiles` grid; each walks the next RASTER_CHUNK
    /// entries of every tile list. `cutoff_weight` is the weight of the frame's rara clipping,
    /// `None` when no splat is cutoff.
    pub fn record(
        &self,
        ctx: &Context,
        cmd: vk::CommandBuffer,
        push: &RasterizePush,
        tiles: (u32, u32),
        rounds: u32,
        cutoff_weight: Option<ClipWeight>,
    ) {
        let pipeline = match cutoff_weight {
            None => &self.plain,
            Some(ClipWeight::Mass) => &self.mass,
            Some(ClipWeight::Length) => &self.length,
        };
        for round in 0..rounds {
            let mut p = *push;
            p.round_index = round;
            p.flags = if round == 0 { ROUND_FIRST } else { 0 };
            pipeline.dispatch(cmd, &p, [tiles.0, tiles.1, 1]);
            if round + 1 < rounds {
                compute_barrier(ctx, cmd);
            }
        }
    }
}
