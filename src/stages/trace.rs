//! The ray tracer (SPEC section 7, issue 32): a BVH built on the GPU ([`super::bvh`]) every
//! frame, then `glsl/trace_body.glsl` per pixel with a buffer of the k = 16 closest hits, in
//! rounds of a bounded number of steps per ray (lavapipe's loop cap). A round runs over the
//! rays the previous one left live (`glsl/trace_args.comp` sizes its indirect dispatch), so
//! nothing on the host waits between rounds and a frame records into an engine's command
//! buffer like the rasterizer's ([`crate::Renderer::record`]). Every clip mode works. The
//! rays write the per-pixel (colour, transmittance) state that the write-target stage turns
//! into the caller's target. CPU twin: [`crate::reference::raytrace`].

use ash::vk;
use bytemuck::{Pod, Zeroable};

use super::bvh::{BvhBuffers, BvhBuild};
use super::linear_grid;
use crate::camera::Camera;
use crate::error::VkContext;
use crate::error::{Error, Result};
use crate::gpu_scene::GpuScene;
use crate::precision::ShPrecision;
use crate::reference::raytrace::RayTraceOptions;
use crate::shaders;
use crate::timing::PassTimer;
use crate::vk::descriptors::{allocate_sets, write_texel_view};
use crate::vk::{compute_barrier, Buffer, ComputePipeline, Context, MemoryLocation};

/// Hits a traversal pass collects (`TRACE_K`).
pub const TRACE_K: u64 = 16;
/// Stack entries per ray (`TRACE_STACK`): the tree's depth is at most 63.
pub const TRACE_STACK: u64 = 64;
/// Steps (a node visit or a composited hit) a ray gets per round. Smaller rounds refill the
/// SIMD lanes with live rays more often, at the cost of saving and loading the ray's state
/// (lavapipe, plant at 320x240: see docs/PERFORMANCE.md).
pub const TRACE_BUDGET: u32 = 1024;
/// Rounds a frame may take at most (4M steps per ray); a frame with rays still live after
/// them is an error of [`RayTracer::render`], and an incomplete frame of
/// [`crate::Renderer::record`].
pub const MAX_TRACE_ROUNDS: u32 = 4096;
/// Rounds a frame slot records at first; it grows after a frame that needed more.
pub const FIRST_TRACE_ROUNDS: u32 = 64;
/// Bins of each per-ray histogram (`HIST_BINS`): the last bin holds that many or more.
pub const TRACE_HIST_BINS: usize = 1024;
/// Words of the counters (`TRACE_*` slots).
const COUNTER_WORDS: usize = 8;
/// Per-ray state: three 16-byte words.
const RAY_STATE_BYTES: u64 = 48;

#[repr(C)]
#[derive(Clone, Copy, Pod, Zeroable)]
struct GpuTraceParams {
    eye: [f32; 4],
    right: [f32; 4],
    down: [f32; 4],
    forward: [f32; 4],
    focal: [f32; 4],
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
    state: u64,
    counters: u64,
    lists: u64,
    live: u64,
    histograms: u64,
    clip: u64,
    round: u32,
    budget: u32,
}

#[repr(C)]
#[derive(Clone, Copy, Pod, Zeroable)]
struct ArgsPush {
    live: u64,
    args: u64,
    round: u32,
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
    /// Traversal passes (k-buffer fills) over all rays.
    pub passes: u64,
    /// BVH nodes visited over all rays.
    pub node_visits: u64,
    /// The 99th percentile over the rays of hits walked, hits found and passes.
    pub p99_walked: u32,
    /// See `p99_walked`.
    pub p99_found: u32,
    /// See `p99_walked`.
    pub p99_passes: u32,
    /// Rays the hit cap cut short.
    pub capped: u64,
    /// Rounds the frame took (rays carry their state between them).
    pub rounds: u32,
    /// Rays still live after the rounds the frame recorded (0 for a complete frame).
    pub unfinished: u64,
}

impl TraceFrameStats {
    /// Mean hits walked per ray.
    pub fn walked_per_ray(&self) -> f64 {
        self.hits_walked as f64 / self.rays.max(1) as f64
    }

    /// Mean hits found per ray.
    pub fn found_per_ray(&self) -> f64 {
        self.hits_found as f64 / self.rays.max(1) as f64
    }

    /// Mean traversal passes per ray.
    pub fn passes_per_ray(&self) -> f64 {
        self.passes as f64 / self.rays.max(1) as f64
    }

    /// Mean node visits per ray.
    pub fn visits_per_ray(&self) -> f64 {
        self.node_visits as f64 / self.rays.max(1) as f64
    }
}

/// The 99th percentile of a histogram (bin i holds the rays with value i).
fn p99(bins: &[u32]) -> u32 {
    let total: u64 = bins.iter().map(|&b| b as u64).sum();
    let rank = (total * 99).div_ceil(100);
    let mut seen = 0u64;
    for (i, &b) in bins.iter().enumerate() {
        seen += b as u64;
        if seen >= rank && total > 0 {
            return i as u32;
        }
    }
    0
}

/// The buffers of ray-traced frames of one size (a frame slot's, [`crate::FrameSlot`]): the
/// BVH, per ray its state, stack and k-buffer, per pixel the (colour, transmittance) state,
/// the lists of live rays, and the counters with their host copy.
pub struct TraceBuffers {
    /// Image size and Gaussians they were made for.
    pub width: u32,
    /// See `width`.
    pub height: u32,
    /// See `width`.
    pub gaussians: u32,
    /// The BVH.
    pub bvh: BvhBuffers,
    params: Buffer,
    clip: Buffer,
    rays: Buffer,
    stacks: Buffer,
    k_t: Buffer,
    k_index: Buffer,
    k_alpha: Buffer,
    /// Per pixel (premultiplied colour, transmittance), as the rasterizer's state.
    pub state: Buffer,
    counters: Buffer,
    lists: Buffer,
    live: Buffer,
    args: Buffer,
    histograms: Buffer,
    readback: Buffer,
    /// The texel views of the CPU drivers' kernels, made by the first frame that uses them.
    texels: Option<TraceTexels>,
    ctx: Context,
}

/// The descriptor set of the texel-view kernels (CPU drivers): binding 10 the Gaussians and
/// 11 their SH coefficients (as `glsl/frame_texels.glsl` numbers them), 12 the BVH nodes.
struct TraceTexels {
    pool: vk::DescriptorPool,
    set: vk::DescriptorSet,
    /// Views of the nodes, the Gaussians, the coefficients.
    views: [vk::BufferView; 3],
    /// The scene the Gaussian and coefficient views are of.
    scene_id: u64,
}

/// Bindings of the texel set ([`TraceTexels`]).
const TEXEL_BINDINGS: [u32; 3] = [12, 10, 11];

impl Drop for TraceBuffers {
    fn drop(&mut self) {
        if let Some(t) = self.texels.take() {
            let device = self.ctx.device();
            unsafe {
                for v in t.views {
                    if v != vk::BufferView::null() {
                        device.destroy_buffer_view(v, None);
                    }
                }
                device.destroy_descriptor_pool(t.pool, None);
            }
        }
    }
}

/// Where in [`TraceBuffers`]'s host copy each part lies (in words).
const READ_COUNTERS: usize = 0;
const READ_LIVE: usize = COUNTER_WORDS;
const READ_HIST: usize = READ_LIVE + MAX_TRACE_ROUNDS as usize;
const READ_WORDS: usize = READ_HIST + 3 * TRACE_HIST_BINS;

impl TraceBuffers {
    /// Buffers for frames of `width` x `height` over `gaussians` Gaussians.
    pub fn new(
        tracer: &RayTracer,
        ctx: &Context,
        (width, height): (u32, u32),
        gaussians: u32,
    ) -> Result<Self> {
        let rays = width as u64 * height as u64;
        if rays == 0 || rays > u32::MAX as u64 / TRACE_STACK {
            return Err(Error::InvalidInput(format!(
                "{width}x{height}: the ray tracer takes at most {} rays a frame",
                u32::MAX as u64 / TRACE_STACK
            )));
        }
        let gpu = MemoryLocation::GpuOnly;
        let hist = 3 * TRACE_HIST_BINS as u64 * 4;
        Ok(TraceBuffers {
            width,
            height,
            gaussians,
            bvh: tracer.bvh.buffers(ctx, gaussians)?,
            params: Buffer::new(
                ctx,
                "trace params",
                std::mem::size_of::<GpuTraceParams>() as u64,
                gpu,
            )?,
            clip: Buffer::new(
                ctx,
                "trace clip params",
                std::mem::size_of::<crate::gpu_types::GpuClipParams>() as u64,
                gpu,
            )?,
            rays: Buffer::new(ctx, "trace ray states", rays * RAY_STATE_BYTES, gpu)?,
            stacks: Buffer::new(ctx, "trace stacks", rays * TRACE_STACK * 4, gpu)?,
            k_t: Buffer::new(ctx, "trace k-buffer t", rays * TRACE_K * 4, gpu)?,
            k_index: Buffer::new(ctx, "trace k-buffer index", rays * TRACE_K * 4, gpu)?,
            k_alpha: Buffer::new(ctx, "trace k-buffer alpha", rays * TRACE_K * 4, gpu)?,
            state: Buffer::new(ctx, "trace pixel state", rays * 16, gpu)?,
            counters: Buffer::new(ctx, "trace counters", COUNTER_WORDS as u64 * 4, gpu)?,
            lists: Buffer::new(ctx, "trace live rays", 2 * rays * 4, gpu)?,
            live: Buffer::new(ctx, "trace live counts", MAX_TRACE_ROUNDS as u64 * 4, gpu)?,
            args: Buffer::new(ctx, "trace round args", MAX_TRACE_ROUNDS as u64 * 16, gpu)?,
            histograms: Buffer::new(ctx, "trace histograms", hist, gpu)?,
            readback: Buffer::new(
                ctx,
                "trace counters (host)",
                READ_WORDS as u64 * 4,
                MemoryLocation::GpuToCpu,
            )?,
            texels: None,
            ctx: ctx.clone(),
        })
    }

    /// The texel set for `scene` with `layout` ([`RayTracer`]'s), made or brought up to date
    /// (the buffers are idle: the slot's previous frame completed); `None` where a view would
    /// pass the device's `maxTexelBufferElements` (the frame then reads by address).
    fn texel_set(
        &mut self,
        layout: vk::DescriptorSetLayout,
        scene: &GpuScene,
    ) -> Result<Option<vk::DescriptorSet>> {
        let (gaussians, sh, scene_id) = scene.buffers();
        let (sh_format, sh_bytes) = super::sh_texel(scene.sh_precision());
        let rgba32 = vk::Format::R32G32B32A32_UINT;
        let viewed = [
            (&self.bvh.nodes, rgba32, 16u64),
            (gaussians, rgba32, 16),
            (sh, sh_format, sh_bytes),
        ];
        let max = self.ctx.info().max_texel_buffer_elements as u64;
        if viewed.iter().any(|(b, _, bytes)| b.size / bytes > max) {
            return Ok(None);
        }
        let device = self.ctx.device();
        if self.texels.is_none() {
            let sizes = [vk::DescriptorPoolSize {
                ty: vk::DescriptorType::UNIFORM_TEXEL_BUFFER,
                descriptor_count: 3,
            }];
            let (pool, sets) = allocate_sets(&self.ctx, &sizes, &[layout])?;
            self.texels = Some(TraceTexels {
                pool,
                set: sets[0],
                views: [vk::BufferView::null(); 3],
                scene_id: u64::MAX,
            });
        }
        let t = self.texels.as_mut().expect("made above");
        // The node view is made once; the scene's when the scene changes (a freed scene's
        // buffer handles may come back, so they are keyed by the scene's id).
        let first = if t.views[0] == vk::BufferView::null() {
            0
        } else if t.scene_id != scene_id {
            1
        } else {
            return Ok(Some(t.set));
        };
        for i in first..3 {
            let (buffer, format, bytes) = viewed[i];
            let view = write_texel_view(
                &self.ctx,
                buffer,
                format,
                buffer.size / bytes * bytes,
                t.set,
                TEXEL_BINDINGS[i],
                vk::DescriptorType::UNIFORM_TEXEL_BUFFER,
            )?;
            if t.views[i] != vk::BufferView::null() {
                unsafe { device.destroy_buffer_view(t.views[i], None) };
            }
            t.views[i] = view;
        }
        t.scene_id = scene_id;
        Ok(Some(t.set))
    }

    /// Whether they fit frames of this size.
    pub fn fits(&self, (width, height): (u32, u32), gaussians: u32) -> bool {
        self.width == width && self.height == height && self.gaussians == gaussians
    }

    /// Device bytes of the BVH (which scale with the Gaussians).
    pub fn bvh_bytes(&self) -> u64 {
        self.bvh.device_bytes()
    }

    /// Device bytes that scale with the rays (pixels).
    pub fn per_ray_bytes(&self) -> u64 {
        [
            &self.rays,
            &self.stacks,
            &self.k_t,
            &self.k_index,
            &self.k_alpha,
            &self.state,
            &self.lists,
        ]
        .iter()
        .map(|b| b.size)
        .sum()
    }

    /// Device bytes of the rest: parameters, counters, round arguments, histograms.
    pub fn fixed_bytes(&self) -> u64 {
        [
            &self.params,
            &self.clip,
            &self.counters,
            &self.live,
            &self.args,
            &self.histograms,
            &self.readback,
        ]
        .iter()
        .map(|b| b.size)
        .sum()
    }

    /// The counts of the last frame recorded into these buffers, which took rounds
    /// `0..rounds`: call it once that submission completed.
    pub fn stats(&self, rounds: u32) -> TraceFrameStats {
        let words: Vec<u32> =
            bytemuck::pod_collect_to_vec(&self.readback.mapped()[..READ_WORDS * 4]);
        let c = &words[READ_COUNTERS..READ_COUNTERS + COUNTER_WORDS];
        let live = &words[READ_LIVE..READ_LIVE + MAX_TRACE_ROUNDS as usize];
        let hist = &words[READ_HIST..READ_WORDS];
        let used = live[..rounds as usize]
            .iter()
            .take_while(|&&l| l > 0)
            .count() as u32
            + 1;
        let b = TRACE_HIST_BINS;
        TraceFrameStats {
            rays: self.width as u64 * self.height as u64,
            hits_walked: c[0] as u64,
            capped: c[1] as u64,
            hits_found: c[2] as u64,
            passes: c[4] as u64,
            node_visits: c[5] as u64 | (c[6] as u64) << 32,
            p99_walked: p99(&hist[..b]),
            p99_found: p99(&hist[b..2 * b]),
            p99_passes: p99(&hist[2 * b..]),
            rounds: used.min(rounds),
            unfinished: live[rounds as usize - 1] as u64,
        }
    }

    /// Stack overflows the last frame counted (never expected: the tree's depth is at most 63).
    fn overflows(&self) -> u32 {
        let words: Vec<u32> =
            bytemuck::pod_collect_to_vec(&self.readback.mapped()[..COUNTER_WORDS * 4]);
        words[3]
    }
}

/// The ray tracer's kernels.
pub struct RayTracer {
    /// Per SH degree: f32, f16 coefficients.
    kernels: Vec<(ComputePipeline, ComputePipeline)>,
    /// On CPU drivers: the layout of the texel set ([`TraceTexels`]) and the kernels that read
    /// through it, per SH degree as `kernels`.
    texels: Option<(
        vk::DescriptorSetLayout,
        Vec<(ComputePipeline, ComputePipeline)>,
    )>,
    args: ComputePipeline,
    bvh: BvhBuild,
    ctx: Context,
}

impl Drop for RayTracer {
    fn drop(&mut self) {
        if let Some((layout, kernels)) = self.texels.take() {
            drop(kernels);
            unsafe {
                self.ctx
                    .device()
                    .destroy_descriptor_set_layout(layout, None)
            };
        }
    }
}

/// The layout of the texel set: uniform texel buffers at [`TEXEL_BINDINGS`].
fn texel_set_layout(ctx: &Context) -> Result<vk::DescriptorSetLayout> {
    let bindings: Vec<vk::DescriptorSetLayoutBinding> = TEXEL_BINDINGS
        .iter()
        .map(|&b| {
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

impl RayTracer {
    /// Builds the kernels: on CPU drivers ([`crate::stages::rasterize::RasterLayout::Strips`]) those that read
    /// through texel views too.
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
        let cpu = crate::stages::rasterize::RasterLayout::for_device(ctx)
            == crate::stages::rasterize::RasterLayout::Strips;
        let texels = if cpu {
            let layout = texel_set_layout(ctx)?;
            let variants = [
                (shaders::TRACE_DEG0_TEXELS, shaders::TRACE_DEG0_SH16_TEXELS),
                (shaders::TRACE_DEG1_TEXELS, shaders::TRACE_DEG1_SH16_TEXELS),
                (shaders::TRACE_DEG2_TEXELS, shaders::TRACE_DEG2_SH16_TEXELS),
                (shaders::TRACE_DEG3_TEXELS, shaders::TRACE_DEG3_SH16_TEXELS),
            ];
            let built = variants
                .iter()
                .map(|(f32, f16)| {
                    let build = |spirv| {
                        ComputePipeline::with_set_layouts::<TracePush>(
                            ctx,
                            c"trace",
                            spirv,
                            &[layout],
                        )
                    };
                    Ok((build(f32)?, build(f16)?))
                })
                .collect::<Result<Vec<_>>>();
            match built {
                Ok(k) => Some((layout, k)),
                Err(e) => {
                    unsafe { ctx.device().destroy_descriptor_set_layout(layout, None) };
                    return Err(e);
                }
            }
        } else {
            None
        };
        Ok(RayTracer {
            kernels,
            texels,
            args: ComputePipeline::new::<ArgsPush>(ctx, c"trace_args", shaders::TRACE_ARGS)?,
            bvh: BvhBuild::new(ctx)?,
            ctx: ctx.clone(),
        })
    }

    /// Records a ray-traced frame of `scene` from `camera` into `cmd`, rounds `first..end` of
    /// it: with `first == 0` the frame's set-up (parameters, counters) and the BVH build (pass
    /// "bvh build") first, then the rounds (pass "trace"), then the copy of the counters for
    /// [`TraceBuffers::stats`]. A later call with `first > 0` goes on with the rays the earlier
    /// rounds left live. The per-pixel state is in `bufs.state` afterwards.
    #[allow(clippy::too_many_arguments)]
    pub fn record(
        &self,
        ctx: &Context,
        cmd: vk::CommandBuffer,
        timer: &mut PassTimer,
        bufs: &mut TraceBuffers,
        scene: &GpuScene,
        camera: &Camera,
        clip: &crate::clip::Clip,
        options: &RayTraceOptions,
        rounds: std::ops::Range<u32>,
    ) -> Result<()> {
        let n = scene.len();
        let (w, h) = (camera.width, camera.height);
        if !bufs.fits((w, h), n) {
            return Err(Error::InvalidInput(format!(
                "trace buffers for {}x{} and {} Gaussians, not {w}x{h} and {n}",
                bufs.width, bufs.height, bufs.gaussians
            )));
        }
        if rounds.end > MAX_TRACE_ROUNDS || rounds.start >= rounds.end {
            return Err(Error::InvalidInput(format!(
                "ray tracer rounds {rounds:?}: at most {MAX_TRACE_ROUNDS}"
            )));
        }
        let device = ctx.device();
        let rays = w * h;
        if rounds.start == 0 {
            let rot = camera.rotation;
            let (cx, cy) = camera.principal_point();
            let col = |v: glam::Vec3| [v.x, v.y, v.z, 0.0];
            let p = GpuTraceParams {
                eye: col(camera.position),
                right: col(rot.col(0)),
                down: col(rot.col(1)),
                forward: col(rot.col(2)),
                focal: [camera.fx, camera.fy, cx, cy],
                size: [
                    w,
                    h,
                    n,
                    3 * crate::scene::sh_coeffs(scene.sh_degree()) as u32,
                ],
                options: [options.q as f32, options.max_hits as f32, 0.0, 0.0],
            };
            let clip_params = clip.to_gpu();
            unsafe {
                device.cmd_update_buffer(cmd, bufs.params.raw, 0, bytemuck::bytes_of(&p));
                device.cmd_update_buffer(cmd, bufs.clip.raw, 0, bytemuck::bytes_of(&clip_params));
                for b in [&bufs.counters, &bufs.live, &bufs.histograms] {
                    device.cmd_fill_buffer(cmd, b.raw, 0, vk::WHOLE_SIZE, 0);
                }
            }
            compute_barrier(ctx, cmd);
            timer.begin_pass(cmd, c"bvh build");
            self.bvh.record(
                ctx,
                cmd,
                scene.gaussians.address,
                &bufs.bvh,
                options.q as f32,
            );
            timer.end_pass(cmd, c"bvh build");
        }
        let degree = scene.sh_degree().min(3) as usize;
        let set = match &self.texels {
            Some((layout, kernels)) => bufs
                .texel_set(*layout, scene)?
                .map(|set| (set, &kernels[degree])),
            None => None,
        };
        let (f32_kernel, f16_kernel) = set.map_or(&self.kernels[degree], |(_, k)| k);
        let kernel = match scene.sh_precision() {
            ShPrecision::F32 => f32_kernel,
            ShPrecision::F16 => f16_kernel,
        };
        let sets: Vec<vk::DescriptorSet> = set.map(|(s, _)| s).into_iter().collect();
        let (gaussians, sh, _) = scene.buffers();
        let mut push = TracePush {
            params: bufs.params.address,
            gaussians: gaussians.address,
            sh: sh.address,
            nodes: bufs.bvh.nodes.address,
            rays: bufs.rays.address,
            stacks: bufs.stacks.address,
            k_t: bufs.k_t.address,
            k_index: bufs.k_index.address,
            k_alpha: bufs.k_alpha.address,
            state: bufs.state.address,
            counters: bufs.counters.address,
            lists: bufs.lists.address,
            live: bufs.live.address,
            histograms: bufs.histograms.address,
            clip: bufs.clip.address,
            round: 0,
            budget: TRACE_BUDGET,
        };
        timer.begin_pass(cmd, c"trace");
        for round in rounds.clone() {
            push.round = round;
            if round == 0 {
                kernel.dispatch_with_sets(cmd, &push, &sets, linear_grid(rays));
            } else {
                let args = ArgsPush {
                    live: bufs.live.address,
                    args: bufs.args.address,
                    round,
                    pad: 0,
                };
                self.args.dispatch(cmd, &args, [1, 1, 1]);
                compute_barrier(ctx, cmd);
                kernel.dispatch_indirect_with_sets(
                    cmd,
                    &push,
                    &sets,
                    bufs.args.raw,
                    round as u64 * 16,
                );
            }
            compute_barrier(ctx, cmd);
        }
        timer.end_pass(cmd, c"trace");
        crate::renderer::copy_parts_to_host(
            ctx,
            cmd,
            &[
                (&bufs.counters, READ_COUNTERS as u64 * 4),
                (&bufs.live, READ_LIVE as u64 * 4),
                (&bufs.histograms, READ_HIST as u64 * 4),
            ],
            &bufs.readback,
        );
        Ok(())
    }

    /// Ray traces `scene` from `camera` with `render`'s clip and background and the tracer
    /// options `options`, headless, into buffers of its own: builds the BVH, runs rounds until
    /// every ray is done (going on from the host while rays are live), and reads the image back.
    pub fn render(
        &self,
        ctx: &Context,
        scene: &GpuScene,
        camera: &Camera,
        render: &crate::RenderOptions,
        options: &RayTraceOptions,
    ) -> Result<(image::RgbaImage, TraceFrameStats)> {
        camera.validate()?;
        render.clip.validate()?;
        let (w, h) = (camera.width, camera.height);
        let mut bufs = TraceBuffers::new(self, ctx, (w, h), scene.len())?;
        let mut timer = PassTimer::labels_only(ctx);
        let mut end = FIRST_TRACE_ROUNDS;
        ctx.run_commands(|cmd| {
            self.record(
                ctx,
                cmd,
                &mut timer,
                &mut bufs,
                scene,
                camera,
                &render.clip,
                options,
                0..end,
            )
        })??;
        let mut stats = bufs.stats(end);
        while stats.unfinished > 0 && end < MAX_TRACE_ROUNDS {
            let next = (end * 2).min(MAX_TRACE_ROUNDS);
            ctx.run_commands(|cmd| {
                self.record(
                    ctx,
                    cmd,
                    &mut timer,
                    &mut bufs,
                    scene,
                    camera,
                    &render.clip,
                    options,
                    end..next,
                )
            })??;
            end = next;
            stats = bufs.stats(end);
        }
        if bufs.overflows() > 0 {
            return Err(Error::InvalidInput(format!(
                "ray tracer: {} traversal stack overflows (the BVH is deeper than 63)",
                bufs.overflows()
            )));
        }
        if stats.unfinished > 0 {
            return Err(Error::InvalidInput(format!(
                "ray tracer: {} rays still live after {MAX_TRACE_ROUNDS} rounds",
                stats.unfinished
            )));
        }
        let state: Vec<[f32; 4]> = bufs.state.download_as(w as usize * h as usize)?;
        let bg = render.background;
        let img = image::RgbaImage::from_fn(w, h, |i, j| {
            let s = state[(j * w + i) as usize];
            let t = s[3].abs();
            let c = glam::Vec3::new(s[0], s[1], s[2]) + t * bg;
            image::Rgba(crate::reference::rasterize::to_rgba8(c))
        });
        Ok((img, stats))
    }
}
