//! The GPU pipeline, one module per stage, in frame order. Each holds its kernel(s) and a
//! `record` that appends the stage of a frame to a [`FrameRecording`]: its push constants,
//! dispatches, barriers and timed pass; [`crate::Renderer::record`] is the list of them. The
//! GLSL lives in `glsl/<stage>_body.glsl` (or `glsl/<stage>.comp` for a kernel without
//! variants), its variants in the table `glsl/variants.rs`, and the CPU twin in `reference`.

use ash::vk;

use crate::constants::{LINEAR_GRID_X, LINEAR_WORKGROUP};
use crate::error::{Error, Result, VkContext};
use crate::precision::ShPrecision;
use crate::timing::PassTimer;
use crate::vk::{compute_barrier, Context};

/// Device addresses of one frame's buffers, the ones most stages read or write.
#[derive(Clone, Copy, Debug)]
pub struct FrameAddresses {
    /// `FrameParams`: camera, image and scene sizes.
    pub params: u64,
    /// `ClipParams`: the clip region and mode.
    pub clip: u64,
    /// The frame's counters (`COUNTER_*` slots).
    pub counters: u64,
    /// One `ProjectedSplat` per Gaussian.
    pub splats: u64,
    /// Tiles touched per Gaussian.
    pub tiles_touched: u64,
    /// The drawn flags, then each drawn Gaussian's sort slot, then its first pair.
    pub slots: u64,
    /// Cutoff side records, or 0 on frames that are not rara-clipped.
    pub cutoffs: u64,
    /// Per cutoff record, its splat's bounds over the footprint ellipse, in frames that
    /// classify cutoff pairs by tile (`stages::cutoff_tiles`); else 0.
    pub cutoff_bounds: u64,
    /// Each tile's run of sorted pairs.
    pub ranges: u64,
    /// The rasterizer's per-pixel state.
    pub state: u64,
}

impl FrameAddresses {
    /// The address of counter `slot` (`COUNTER_*`).
    pub fn counter(&self, slot: u32) -> u64 {
        self.counters + 4 * slot as u64
    }
}

/// One frame being recorded into a command buffer: what every stage's `record` needs besides
/// its own inputs.
pub struct FrameRecording<'a> {
    /// The device.
    pub ctx: &'a Context,
    /// The caller's command buffer, recording.
    pub cmd: vk::CommandBuffer,
    /// Timestamps and debug labels of the passes.
    pub timer: &'a mut PassTimer,
    /// The frame's texel views (CPU drivers; [`frame_texels_set_layout`]), else `None`.
    pub texels: Option<vk::DescriptorSet>,
    /// The frame's buffers.
    pub at: FrameAddresses,
    /// Image size in pixels.
    pub size: (u32, u32),
    /// Tiles across and down.
    pub grid: (u32, u32),
}

impl FrameRecording<'_> {
    /// Tiles of the image.
    pub fn tile_count(&self) -> u32 {
        self.grid.0 * self.grid.1
    }

    /// Records `body` as the timed, labelled pass `name`.
    pub fn pass(&mut self, name: &'static std::ffi::CStr, body: impl FnOnce(&mut Self)) {
        self.timer.begin_pass(self.cmd, name);
        body(self);
        self.timer.end_pass(self.cmd, name);
    }

    /// A barrier from compute and transfer writes to what later passes read.
    pub fn barrier(&self) {
        compute_barrier(self.ctx, self.cmd);
    }

    /// Copies the start of `from` into `to` (as much as `to` holds), then a barrier: keeps
    /// what a later pass of the frame overwrites, for debugging.
    pub fn copy_aside(&self, from: &crate::vk::Buffer, to: &crate::vk::Buffer) {
        let region = ash::vk::BufferCopy {
            src_offset: 0,
            dst_offset: 0,
            size: from.size.min(to.size),
        };
        unsafe {
            self.ctx
                .device()
                .cmd_copy_buffer(self.cmd, from.raw, to.raw, &[region]);
        }
        self.barrier();
    }
}

pub mod cutoff_tiles;
pub mod depth;
pub mod depth_order;
pub mod emit;
pub mod objects;
pub mod prefix_sum;
pub mod project;
pub mod rasterize;
pub mod sort;
pub mod tile_lists;
pub mod tile_ranges;
pub mod write_target;

/// Rounds (dispatches) in which project and emit walk the splats' tile rectangles on an image
/// of `tiles` tiles: a rectangle has at most that many cells, and an invocation walks up to
/// [`TILE_RECT_CHUNK`](crate::constants::TILE_RECT_CHUNK) of them per round (lavapipe's cap on
/// an invocation's loop iterations). 1 up to 32,768 tiles (2,896 x 2,896 pixels).
pub fn tile_rect_rounds(tiles: u32) -> u32 {
    tiles.div_ceil(crate::constants::TILE_RECT_CHUNK).max(1)
}

/// Push constants of `glsl/linear_args.comp`, which writes at `args` the indirect dispatch
/// arguments of a linear kernel ([`linear_grid`]) over the `u32` count at `count`.
#[repr(C)]
#[derive(Clone, Copy, bytemuck::Pod, bytemuck::Zeroable)]
pub(crate) struct LinearArgsPush {
    /// The items (a `u32` the GPU wrote).
    pub(crate) count: u64,
    /// Out: the dispatch arguments (16 bytes).
    pub(crate) args: u64,
}

/// Workgroup counts of a linear kernel over `items` (GLSL `linear_grid` in `common.glsl`): rows
/// of at most [`LINEAR_GRID_X`] workgroups, as only 65,535 per dimension are guaranteed.
pub(crate) fn linear_grid(items: u32) -> [u32; 3] {
    let groups = items.div_ceil(LINEAR_WORKGROUP);
    [groups.min(LINEAR_GRID_X), groups.div_ceil(LINEAR_GRID_X), 1]
}

/// The fewest texels a texel buffer must hold (`maxTexelBufferElements`) for the layouts of the
/// CPU drivers: 2^24, a frame of 4 million splats at 4 texels each. lavapipe's views hold 2^27;
/// SwiftShader's 2^16 could not hold a 17,000-splat frame.
pub const CPU_LAYOUT_MIN_TEXELS: u32 = 1 << 24;

/// Whether the device takes the layouts made for CPU drivers (the strips rasterizer, the
/// own-counts sort, the runs scan, reads through texel views): a CPU device
/// (`VK_PHYSICAL_DEVICE_TYPE_CPU`, such as lavapipe) whose texel buffers hold
/// [`CPU_LAYOUT_MIN_TEXELS`]. Every other device, SwiftShader included, takes the GPU layouts,
/// which read through buffer addresses alone. Each layout's `RARA_*` variable overrides it.
pub fn cpu_layouts(ctx: &Context) -> bool {
    ctx.info().device_type == vk::PhysicalDeviceType::CPU && holds_cpu_layouts(ctx)
}

/// Whether the device's texel buffers hold the [`CPU_LAYOUT_MIN_TEXELS`] that the layouts of
/// the CPU drivers read through: the check of an explicit choice of one of those layouts
/// (`RasterLayout::Strips`, `SortLayout::OwnCounts`), which a GPU with large texel buffers may
/// run too. A device with small ones (SwiftShader: 2^16) could draw only toy frames through
/// them, and SwiftShader's compiler cannot build two of their kernels (docs/TESTING.md,
/// "Two drivers").
pub fn holds_cpu_layouts(ctx: &Context) -> bool {
    ctx.info().max_texel_buffer_elements >= CPU_LAYOUT_MIN_TEXELS
}

/// Refuses `layout`, one of the CPU drivers' layouts, on a device whose texel buffers are too
/// small for it ([`holds_cpu_layouts`]), with a message that names the limit.
pub(crate) fn check_cpu_layout(ctx: &Context, layout: &str, other: &str) -> Result<()> {
    if holds_cpu_layouts(ctx) {
        return Ok(());
    }
    Err(Error::MissingRequirement(format!(
        "the {layout} layout reads through texel buffers of at least {CPU_LAYOUT_MIN_TEXELS} \
         texels; {} holds {} (maxTexelBufferElements): use the {other} layout, the default \
         on this device",
        ctx.info().name,
        ctx.info().max_texel_buffer_elements
    )))
}

/// The stride of `spread_item` (`glsl/common.glsl`) for `n` items: the integer nearest
/// `n (sqrt(5) - 1) / 2` that is coprime with `n` (so that `i stride mod n` visits every item
/// once), which spreads any run of consecutive items over the whole range. CPU drivers hand
/// each thread a contiguous share of a dispatch (llvmpipe's `lp_cs_tpool`); kernels that take
/// their items in this order keep the threads evenly loaded when the costly items cluster.
pub fn spread_stride(n: u32) -> u32 {
    if n <= 2 {
        return 1;
    }
    fn gcd(mut a: u32, mut b: u32) -> u32 {
        while b != 0 {
            (a, b) = (b, a % b);
        }
        a
    }
    let mut s = ((n as f64 * 0.618_033_988_749_895).round() as u32).max(1);
    while gcd(s, n) != 1 {
        s += 1;
    }
    s
}

/// Creates the layout of the frame's texel views, descriptor set 0 of the kernels that read
/// through texel buffers on CPU drivers (project, depth order, emit, cutoff tiles, tile ranges,
/// the strips rasterizer, see `glsl/rasterize_body.glsl`, and write target, whose image kernels
/// take it as set 1), all uniform texel buffers: 0 the sorted pair values (`R32G32B32A32_UINT`,
/// four to a texel), 1 the projected splats (`R32G32B32A32_UINT`, 3 texels each), 2 the cutoff
/// records (`R32G32B32A32_UINT`, 3 texels each), 3 the drawn Gaussians in depth order and 4 their first
/// pairs, 5 the tiles touched per Gaussian, 6 the sorted tile keys, 7 the tile keys as emitted
/// (all five `R32_UINT`), 8 the rasterizer's per-pixel state (`R32G32B32A32_UINT`, one texel
/// per pixel), 9 the clip parameters (`R32G32B32A32_UINT`, planes from texel 3), 10 the scene's
/// Gaussians (`R32G32B32A32_UINT`, 3 texels each) and 11 its SH coefficients (4 to a texel:
/// `R32G32B32A32_UINT` for floats, `R32G32_UINT` for half floats). The kernels declare all
/// twelve, with these numbers, in `glsl/frame_texels.glsl`.
pub fn frame_texels_set_layout(ctx: &Context) -> Result<vk::DescriptorSetLayout> {
    texel_set_layout(ctx, 0..FRAME_TEXEL_BINDINGS)
}

/// A descriptor set layout of uniform texel buffers at `bindings`, for compute.
pub(crate) fn texel_set_layout(
    ctx: &Context,
    bindings: impl IntoIterator<Item = u32>,
) -> Result<vk::DescriptorSetLayout> {
    let bindings: Vec<vk::DescriptorSetLayoutBinding> = bindings
        .into_iter()
        .map(|b| {
            vk::DescriptorSetLayoutBinding::default()
                .binding(b)
                .descriptor_type(vk::DescriptorType::UNIFORM_TEXEL_BUFFER)
                .descriptor_count(1)
                .stage_flags(vk::ShaderStageFlags::COMPUTE)
        })
        .collect();
    let info = vk::DescriptorSetLayoutCreateInfo::default().bindings(&bindings);
    unsafe { ctx.device().create_descriptor_set_layout(&info, None) }
        .vk("vkCreateDescriptorSetLayout")
}

/// Format and bytes of a texel of the SH view (binding 11 of [`frame_texels_set_layout`]): four
/// coefficients at either precision.
pub(crate) fn sh_texel(precision: ShPrecision) -> (vk::Format, u64) {
    match precision {
        ShPrecision::F32 => (vk::Format::R32G32B32A32_UINT, 16),
        ShPrecision::F16 => (vk::Format::R32G32_UINT, 8),
    }
}

/// Bindings of [`frame_texels_set_layout`].
pub const FRAME_TEXEL_BINDINGS: u32 = 12;

/// [`frame_texels_set_layout`] made once for the kernels of a renderer (the frame slots make
/// their own, compatible one for their sets); destroyed on drop.
pub struct FrameTexelsLayout {
    /// The layout handle.
    pub raw: vk::DescriptorSetLayout,
    ctx: Context,
}

impl FrameTexelsLayout {
    /// Creates the layout.
    pub fn new(ctx: &Context) -> Result<Self> {
        Ok(FrameTexelsLayout {
            raw: frame_texels_set_layout(ctx)?,
            ctx: ctx.clone(),
        })
    }
}

impl Drop for FrameTexelsLayout {
    fn drop(&mut self) {
        unsafe {
            self.ctx
                .device()
                .destroy_descriptor_set_layout(self.raw, None)
        };
    }
}

#[cfg(test)]
mod tests {
    use super::spread_stride;

    #[test]
    fn spread_stride_permutes_and_spreads() {
        for n in [1u32, 2, 3, 4, 5, 12, 300, 1200, 4800, 8160, 65536] {
            let s = spread_stride(n) as u64;
            let order: Vec<u64> = (0..n as u64).map(|i| i * s % n as u64).collect();
            let mut seen = vec![false; n as usize];
            for &t in &order {
                assert!(!seen[t as usize], "n = {n}: {t} twice");
                seen[t as usize] = true;
            }
            // Either half of the order (each of two threads' share) takes close to half of
            // the items from each half of the range.
            if n >= 300 {
                let first = &order[..n as usize / 2];
                let low = first.iter().filter(|&&t| t < n as u64 / 2).count() as f64;
                let share = low / first.len() as f64;
                assert!((share - 0.5).abs() < 0.05, "n = {n}: {share}");
            }
        }
    }
}
