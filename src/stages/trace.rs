//! The ray tracer (SPEC section 7, issue 32): a BVH built on the GPU
//! ([`super::bvh`]) every frame, then `glsl/trace_body.glsl` per pixel with a buffer of the
//! k = 16 closest hits, in dispatches of a bounded number of steps each (lavapipe's loop cap)
//! until every ray is done, every clip mode included. [`RayTracer::render`] runs a headless
//! frame; the `--tracer ray` option and recording into an engine's command buffer are the next
//! parts of the issue. CPU twin: [`crate::reference::raytrace`].

use bytemuck::{Pod, Zeroable};

use super::bvh::BvhBuild;
use super::linear_grid;
use crate::camera::Camera;
use crate::error::{Error, Result};
use crate::gpu_scene::GpuScene;
use crate::precision::ShPrecision;
use crate::reference::raytrace::RayTraceOptions;
use crate::shaders;
use crate::vk::{compute_barrier, Buffer, ComputePipeline, Context, MemoryLocation};

/// Hits a traversal pass collects (`TRACE_K`).
pub const TRACE_K: u64 = 16;
/// Stack entries per ray (`TRACE_STACK`): the tree's depth is at most 63.
pub const TRACE_STACK: u64 = 64;
/// Dispatches after which a frame that still has live rays is an error (each gives a ray
/// 8,192 steps, so this is 8M steps per ray).
pub const MAX_TRACE_DISPATCHES: u32 = 1024;

#[repr(C)]
#[derive(Clone, Copy, Pod, Zeroable)]
struct GpuTraceParams {
    eye: [f32; 4],
    right: [f32; 4],
    down: [f32; 4],
    forward: [f32; 4],
    focal: [f32; 4],
    background: [f32; 4],
    size: [u32; 4],
    options: [f32; 4],
}

#[repr(C)]
#[derive(Clone, Copy, Pod, Zeroable)]
struct TracePush {
    params: u64,
    gaussians: u64,
    sh: u64,
    nodes: u64,
    rays: u64,
    stacks: u64,
    k_t: u64,
    k_index: u64,
    k_alpha: u64,
    pixels: u64,
    counters: u64,
    clip: u64,
    init: u32,
    pad: u32,
}

/// What a frame of the ray tracer did.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct TraceFrameStats {
    /// Rays (pixels).
    pub rays: u64,
    /// Hits the traversal passes put in the k-buffers (a hit a later pass finds again, after
    /// one that a full buffer pushed out, counts again).
    pub hits_found: u64,
    /// Hits composited (or skipped for alpha) before the rays stopped.
    pub hits_walked: u64,
    /// Rays the hit cap cut short.
    pub capped: u64,
    /// Dispatches of the tracer it took (rays carry their state between them).
    pub dispatches: u32,
}

/// The ray tracer's kernels.
pub struct RayTracer {
    /// Per SH degree: f32, f16 coefficients.
    kernels: Vec<(ComputePipeline, ComputePipeline)>,
    bvh: BvhBuild,
}

impl RayTracer {
    /// Builds the kernels.
    pub fn new(ctx: &Context) -> Result<Self> {
        let variants = [
            (shaders::TRACE_DEG0, shaders::TRACE_DEG0_SH16),
            (shaders::TRACE_DEG1, shaders::TRACE_DEG1_SH16),
            (shaders::TRACE_DEG2, shaders::TRACE_DEG2_SH16),
            (shaders::TRACE_DEG3, shaders::TRACE_DEG3_SH16),
        ];
        let kernels = variants
            .iter()
            .map(|(f32, f16)| {
                Ok((
                    ComputePipeline::new::<TracePush>(ctx, c"trace", f32)?,
                    ComputePipeline::new::<TracePush>(ctx, c"trace", f16)?,
                ))
            })
            .collect::<Result<Vec<_>>>()?;
        Ok(RayTracer {
            kernels,
            bvh: BvhBuild::new(ctx)?,
        })
    }

    /// Ray traces `scene` from `camera` with `render` (background, clip), headless: builds
    /// the BVH, runs the tracer's dispatches until every ray is done, reads the image back.
    pub fn render(
        &self,
        ctx: &Context,
        scene: &GpuScene,
        camera: &Camera,
        render: &crate::RenderOptions,
        options: &RayTraceOptions,
    ) -> Result<(image::RgbaImage, TraceFrameStats)> {
        camera.validate()?;
        let background = render.background;
        let n = scene.len();
        let (w, h) = (camera.width, camera.height);
        let rays = w as u64 * h as u64;
        let gpu = MemoryLocation::GpuOnly;
        let bvh = self.bvh.buffers(ctx, n)?;
        let params = Buffer::new(
            ctx,
            "trace params",
            std::mem::size_of::<GpuTraceParams>() as u64,
            MemoryLocation::CpuToGpu,
        )?;
        let states = Buffer::new(ctx, "trace ray states", rays * 48, gpu)?;
        let stacks = Buffer::new(ctx, "trace stacks", rays * TRACE_STACK * 4, gpu)?;
        let k_t = Buffer::new(ctx, "trace k-buffer t", rays * TRACE_K * 4, gpu)?;
        let k_index = Buffer::new(ctx, "trace k-buffer index", rays * TRACE_K * 4, gpu)?;
        let k_alpha = Buffer::new(ctx, "trace k-buffer alpha", rays * TRACE_K * 4, gpu)?;
        let pixels = Buffer::new(ctx, "trace pixels", rays * 4, MemoryLocation::GpuToCpu)?;
        let counters = Buffer::new(ctx, "trace counters", 32, MemoryLocation::GpuToCpu)?;
        let clip_params = render.clip.to_gpu();
        let clip = Buffer::new(
            ctx,
            "trace clip params",
            std::mem::size_of_val(&clip_params) as u64,
            MemoryLocation::CpuToGpu,
        )?;
        clip.upload(bytemuck::bytes_of(&clip_params))?;
        let rot = camera.rotation;
        let (cx, cy) = camera.principal_point();
        let col = |v: glam::Vec3| [v.x, v.y, v.z, 0.0];
        let p = GpuTraceParams {
            eye: col(camera.position),
            right: col(rot.col(0)),
            down: col(rot.col(1)),
            forward: col(rot.col(2)),
            focal: [camera.fx, camera.fy, cx, cy],
            background: col(background),
            size: [
                w,
                h,
                n,
                3 * crate::scene::sh_coeffs(scene.sh_degree()) as u32,
            ],
            options: [options.q as f32, options.max_hits as f32, 0.0, 0.0],
        };
        params.upload(bytemuck::bytes_of(&p))?;
        let mut stats = TraceFrameStats {
            rays,
            ..Default::default()
        };
        if n == 0 {
            let bg = crate::reference::rasterize::to_rgba8(background);
            return Ok((image::RgbaImage::from_pixel(w, h, image::Rgba(bg)), stats));
        }
        let (f32_kernel, f16_kernel) = &self.kernels[scene.sh_degree().min(3) as usize];
        let kernel = match scene.sh_precision() {
            ShPrecision::F32 => f32_kernel,
            ShPrecision::F16 => f16_kernel,
        };
        let (gaussians, sh, _) = scene.buffers();
        let mut push = TracePush {
            params: params.address,
            gaussians: gaussians.address,
            sh: sh.address,
            nodes: bvh.nodes.address,
            rays: states.address,
            stacks: stacks.address,
            k_t: k_t.address,
            k_index: k_index.address,
            k_alpha: k_alpha.address,
            pixels: pixels.address,
            counters: counters.address,
            clip: clip.address,
            init: 1,
            pad: 0,
        };
        let grid =
            linear_grid(u32::try_from(rays).map_err(|_| {
                Error::InvalidInput(format!("{w}x{h}: too many rays for one frame"))
            })?);
        ctx.run_commands(|cmd| {
            unsafe {
                ctx.device()
                    .cmd_fill_buffer(cmd, counters.raw, 0, ash::vk::WHOLE_SIZE, 0)
            };
            self.bvh
                .record(ctx, cmd, gaussians.address, &bvh, options.q as f32);
            kernel.dispatch(cmd, &push, grid);
            compute_barrier(ctx, cmd);
        })?;
        stats.dispatches = 1;
        push.init = 0;
        loop {
            let c: Vec<u32> = counters.download_as(5)?;
            if c[4] > 0 {
                return Err(Error::InvalidInput(format!(
                    "ray tracer: {} traversal stack overflows (the BVH is deeper than 63)",
                    c[4]
                )));
            }
            if c[0] == 0 {
                stats.hits_found = c[3] as u64;
                stats.hits_walked = c[1] as u64;
                stats.capped = c[2] as u64;
                break;
            }
            if stats.dispatches >= MAX_TRACE_DISPATCHES {
                return Err(Error::InvalidInput(format!(
                    "ray tracer: {} rays still live after {} dispatches",
                    c[0], stats.dispatches
                )));
            }
            ctx.run_commands(|cmd| {
                // Only the live count starts again; the rest add up over the dispatches.
                unsafe { ctx.device().cmd_fill_buffer(cmd, counters.raw, 0, 4, 0) };
                compute_barrier(ctx, cmd);
                kernel.dispatch(cmd, &push, grid);
                compute_barrier(ctx, cmd);
            })?;
            stats.dispatches += 1;
        }
        let px: Vec<[u8; 4]> = pixels.download_as(rays as usize)?;
        let img = image::RgbaImage::from_fn(w, h, |i, j| image::Rgba(px[(j * w + i) as usize]));
        Ok((img, stats))
    }
}
