//! The ray tracer (SPEC section 7, issue 32): a BVH built on the GPU ([`super::bvh`]) every
//! frame, then `glsl/trace_body.glsl` per pixel with a buffer of the k = 16 closest hits, in
//! rounds of a bounded number of steps per ray (lavapipe's loop cap). A round runs over the
//! rays the previous one left live (`glsl/linear_args.comp` sizes its indirect dispatch), so
//! nothing on the host waits between rounds and a frame records into an engine's command
//! buffer like the rasterizer's ([`crate::Renderer::record`]). Every clip mode works. The
//! rays write the per-pixel (colour, transmittance) state that the write-target stage turns
//! into the caller's target. CPU twin: [`crate::reference::raytrace`].

use ash::vk;
use bytemuck::{Pod, Zeroable};

use super::bvh::{BvhBuffers, BvhBuild};
use super::tiles::RayTileLists;
use crate::camera::tile_grid;
use crate::camera::Camera;
use crate::constants::{
    TILE_SIZE, TRACE_COUNTER_CAPPED, TRACE_COUNTER_FOUND, TRACE_COUNTER_OVERFLOW,
    TRACE_COUNTER_PASSES, TRACE_COUNTER_TESTS_HI, TRACE_COUNTER_TESTS_LO, TRACE_COUNTER_VISITS_HI,
    TRACE_COUNTER_VISITS_LO, TRACE_COUNTER_WALKED, TRACE_COUNTER_WORDS, TRACE_HIST_BINS,
    TRACE_STACK,
};
use crate::error::{Error, Result};
use crate::gpu_scene::GpuScene;
use crate::options::RayTraceOptions;
use crate::precision::ShPrecision;
use crate::shaders;
use crate::stages::{linear_grid, LinearArgsPush};
use crate::timing::PassTimer;
use crate::vk::descriptors::{allocate_sets, write_texel_view};
use crate::vk::{compute_barrier, Buffer, ComputePipeline, Context, MemoryLocation};

/// Steps (a node visit or a composited hit) a ray gets per round. Smaller rounds refill the
/// SIMD lanes with live rays more often, at the cost of saving and loading the ray's state
/// (lavapipe, plant at 320x240: see docs/PERFORMANCE.md). An invocation's loops run at most
/// about three times this many iterations, far inside lavapipe's 65,535.
pub const TRACE_BUDGET: u32 = 4096;
/// Rounds a frame may take at most (16M steps per ray); a frame with rays still live after
/// them is an error of [`RayTracer::render`], and an incomplete frame of
/// [`crate::Renderer::record`].
pub const MAX_TRACE_ROUNDS: u32 = 4096;
/// Rounds a frame slot records at first; it grows after a frame that needed more.
pub const FIRST_TRACE_ROUNDS: u32 = 64;
/// Words of the counters (`TRACE_COUNTER_*` slots); the histograms follow them in the same
/// buffer, [`TRACE_HIST_BINS`] bins each.
const COUNTER_WORDS: usize = TRACE_COUNTER_WORDS as usize;
/// Bins of each histogram.
const HIST_BINS: usize = TRACE_HIST_BINS as usize;
/// Rays traced together at most (a batch): the per-ray buffers (state, stack, k-buffer, live
/// lists) hold one batch, so their memory is bounded whatever the image size, and the batches
/// of a frame run one after another.
pub const TRACE_BATCH_RAYS: u32 = 1 << 18;
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
    /// The mixed scene's parameters' address (lo, hi) for the MIXED kernels, else 0; then,
    /// without MIXED, the depth test's per-pixel view depth (lo, hi; 0: no depth test).
    mixed: [u32; 4],
    /// The `TILED` kernels' tile lists ([`RayTileLists`]): the ranges' address (lo, hi), the
    /// sorted Gaussians' address (lo, hi).
    lists: [u32; 4],
    /// The lists' records' address (lo, hi), the tiles across the image, unused.
    records: [u32; 4],
    /// The depth output's per-pixel sums' address (lo, hi; 0: none), unused.
    depth_out: [u32; 4],
    /// Without MIXED, the objects' own clip regions ([`ObjectRegions`]): the regions' address
    /// (lo, hi; 0: the frame's one clip), the per-Gaussian region indices' address (lo, hi).
    objects: [u32; 4],
}

impl GpuTraceParams {
    /// The parameters of a frame of `camera` over `scene`.
    fn new(camera: &Camera, scene: &GpuScene, options: &RayTraceOptions, mixed: u64) -> Self {
        let rot = camera.rotation;
        let (cx, cy) = camera.principal_point();
        let col = |v: glam::Vec3| [v.x, v.y, v.z, 0.0];
        GpuTraceParams {
            eye: col(camera.position),
            right: col(rot.col(0)),
            down: col(rot.col(1)),
            forward: col(rot.col(2)),
            focal: [camera.fx, camera.fy, cx, cy],
            size: [
                camera.width,
                camera.height,
                scene.len(),
                3 * crate::scene::sh_coeffs(scene.sh_degree()) as u32,
            ],
            options: [options.q as f32, options.max_hits as f32, 0.0, 0.0],
            mixed: [mixed as u32, (mixed >> 32) as u32, 0, 0],
            lists: [0; 4],
            records: [0, 0, tile_grid(camera.width, camera.height).0, 0],
            depth_out: [0; 4],
            objects: [0; 4],
        }
    }
}

/// The bytes of the tracer's parameters of a frame of `camera` over `scene` (no mixed scene):
/// the mixed scenes' ray tree reads its camera from them.
pub(crate) fn camera_params(
    camera: &Camera,
    scene: &GpuScene,
    options: &RayTraceOptions,
) -> Vec<u8> {
    bytemuck::bytes_of(&GpuTraceParams::new(camera, scene, options, 0)).to_vec()
}

/// Bytes of the tracer's per-frame parameters (the camera first: `glsl/mixed_spawn.comp` reads
/// the same buffer's first words).
pub const TRACE_PARAMS_BYTES: u64 = std::mem::size_of::<GpuTraceParams>() as u64;

/// A frame of several objects with clip regions of their own ([`crate::Renderer::record_objects`]):
/// each hit is weighed by its Gaussian's object's region instead of the frame's clip.
#[derive(Clone, Copy, Debug)]
pub struct ObjectRegions {
    /// The regions, one `GpuClipParams` per object (world space, the frame's mode and band).
    pub regions: u64,
    /// Per Gaussian of the merged scene, the index of its object's region (u32).
    pub of_gaussian: u64,
}

/// What a mixed scene's generation hands the tracer ([`RayTracer::record`]): the MIXED
/// kernels' parameters (whose rays replace the camera's) and the splat objects' clips, and
/// whether this generation builds the BVH (the first of the frame) or reuses it.
#[derive(Clone, Copy, Debug)]
pub struct MixedRays {
    /// Address of the `MixedParams`.
    pub params: u64,
    /// Address of the objects' `ClipParams`, object 0 first.
    pub clips: u64,
    /// Build the BVH in this call.
    pub build_bvh: bool,
    /// The rays of the batch the call records (one batch per call), listed by the ray tree:
    /// round 0 runs over them alone.
    pub listed_rays: u32,
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
    kbuf: u64,
    state: u64,
    counters: u64,
    lists: u64,
    live: u64,
    clip: u64,
    round: u32,
    budget: u32,
    ray_base: u32,
    batch_rays: u32,
    stride: u32,
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
    /// BVH nodes visited over all rays; with camera rays from tile lists
    /// ([`TraceBuffers::tiled`]), the list entries tested (an entry a later pass tests again
    /// counts again).
    pub node_visits: u64,
    /// Gaussians tested for a hit over all rays: the leaves BVH passes reached (each a
    /// Gaussian whose proxy's box the ray enters), or the list entries whose rectangle holds
    /// the pixel (then the same as `node_visits`).
    pub gaussian_tests: u64,
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
    /// The hits a pass collects per ray (the k-buffer; with tile lists, SPEC section 11's
    /// pending buffer K).
    pub k: u32,
    /// Whether the camera rays came from tile lists (SPEC section 11). Such a frame forces no
    /// hit out of order, whatever K: a pass that runs out of room leaves the rest to the next,
    /// which walks the list again from the first hit left out (the visits count it).
    pub tiled: bool,
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

    /// Mean Gaussians tested for a hit per ray.
    pub fn tests_per_ray(&self) -> f64 {
        self.gaussian_tests as f64 / self.rays.max(1) as f64
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
    /// The k-buffer's hits per ray.
    pub k: u32,
    /// Camera rays from tile lists (SPEC section 11): the rays run tile by tile, 256 per tile
    /// (those past the image's edge do nothing).
    pub tiled: bool,
    /// Rays per batch (the per-ray buffers' size) and batches per frame.
    pub batch_rays: u32,
    /// See `batch_rays`.
    pub batches: u32,
    /// The per-frame LBVH's buffers, made by the first frame that builds one: frames of a
    /// scene with a still BVH walk the scene's tree where it lies, and camera rays from tile
    /// lists need no tree.
    bvh: Option<BvhBuffers>,
    params: Buffer,
    clip: Buffer,
    rays: Buffer,
    stacks: Buffer,
    /// The k-buffers: t, Gaussian and alpha sections.
    kbuf: Buffer,
    /// Per pixel (premultiplied colour, transmittance), as the rasterizer's state.
    pub state: Buffer,
    /// With a depth output, per pixel (median view depth, sum alpha T z, 0, 0), made by the
    /// first frame that asks ([`TraceBuffers::depth_sums`]).
    depth_sums: Option<Buffer>,
    /// The counters, then the histograms.
    counters: Buffer,
    lists: Buffer,
    /// Per batch, per round: rays left live.
    live: Buffer,
    /// Per batch, per round: the indirect dispatch.
    args: Buffer,
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
    /// What the node view is of ([`NodeSource`]).
    nodes_of: NodeSource,
    /// The scene the Gaussian and coefficient views are of.
    scene_id: u64,
}

/// Whose BVH nodes a frame walks.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
enum NodeSource {
    /// The frame slot's own LBVH, built per frame.
    Lbvh,
    /// The scene's still BVH with this id ([`GpuScene::still_bvh`]).
    Still(u64),
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

/// Where in [`TraceBuffers`]'s host copy each part lies (in words): the counters and
/// histograms, then the live counts of every batch.
const READ_COUNTERS: usize = 0;
const READ_HIST: usize = COUNTER_WORDS;
const READ_LIVE: usize = READ_HIST + 3 * HIST_BINS;

impl TraceBuffers {
    /// Buffers for frames of `width` x `height` over `gaussians` Gaussians, their camera rays
    /// from tile lists when `tiled`.
    pub fn new(
        tracer: &RayTracer,
        ctx: &Context,
        (width, height): (u32, u32),
        gaussians: u32,
        tiled: bool,
    ) -> Result<Self> {
        let pixels = width as u64 * height as u64;
        let (gx, gy) = tile_grid(width, height);
        let rays = if tiled {
            (gx * gy) as u64 * (TILE_SIZE * TILE_SIZE) as u64
        } else {
            pixels
        };
        if pixels == 0 || rays > u32::MAX as u64 {
            return Err(Error::InvalidInput(format!(
                "{width}x{height}: the ray tracer takes at most {} rays a frame",
                u32::MAX
            )));
        }
        let batch = rays.min(TRACE_BATCH_RAYS as u64);
        let batches = rays.div_ceil(batch);
        let k = tracer.k as u64;
        let gpu = MemoryLocation::GpuOnly;
        let counters = (COUNTER_WORDS + 3 * HIST_BINS) as u64 * 4;
        let live = batches * MAX_TRACE_ROUNDS as u64 * 4;
        Ok(TraceBuffers {
            width,
            height,
            gaussians,
            k: tracer.k,
            tiled,
            batch_rays: batch as u32,
            batches: batches as u32,
            bvh: None,
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
            rays: Buffer::new(ctx, "trace ray states", batch * RAY_STATE_BYTES, gpu)?,
            stacks: Buffer::new(ctx, "trace stacks", batch * TRACE_STACK as u64 * 4, gpu)?,
            kbuf: Buffer::new(ctx, "trace k-buffers", 3 * batch * k * 4, gpu)?,
            state: Buffer::new(ctx, "trace pixel state", pixels * 16, gpu)?,
            counters: Buffer::new(ctx, "trace counters", counters, gpu)?,
            lists: Buffer::new(ctx, "trace live rays", 2 * batch * 4, gpu)?,
            live: Buffer::new(ctx, "trace live counts", live, gpu)?,
            args: Buffer::new(ctx, "trace round args", 4 * live, gpu)?,
            readback: Buffer::new(
                ctx,
                "trace counters (host)",
                counters + live,
                MemoryLocation::GpuToCpu,
            )?,
            texels: None,
            depth_sums: None,
            ctx: ctx.clone(),
        })
    }

    /// The address of the per-pixel depth sums of the depth output (SPEC section 9), made now
    /// if they were not yet (16 bytes a pixel).
    pub fn depth_sums(&mut self) -> Result<u64> {
        if self.depth_sums.is_none() {
            let bytes = self.width as u64 * self.height as u64 * 16;
            self.depth_sums = Some(Buffer::new(
                &self.ctx,
                "trace depth sums",
                bytes,
                MemoryLocation::GpuOnly,
            )?);
        }
        Ok(self.depth_sums.as_ref().expect("made above").address)
    }

    /// Whether they fit frames of this size, scene, k and source of camera rays.
    pub fn fits(&self, (width, height): (u32, u32), gaussians: u32, k: u32, tiled: bool) -> bool {
        self.width == width
            && self.height == height
            && self.gaussians == gaussians
            && self.k == k
            && self.tiled == tiled
    }

    /// Device bytes of the per-frame LBVH (which scale with the Gaussians; 0 before a frame
    /// built one).
    pub fn bvh_bytes(&self) -> u64 {
        self.bvh.as_ref().map_or(0, BvhBuffers::device_bytes)
    }

    /// The per-frame LBVH's buffers, made now if they were not yet.
    fn lbvh(&mut self, build: &BvhBuild) -> Result<&BvhBuffers> {
        if self.bvh.is_none() {
            self.bvh = Some(build.buffers(&self.ctx, self.gaussians)?);
        }
        Ok(self.bvh.as_ref().expect("made above"))
    }

    /// Device bytes that scale with the rays: per pixel its state, per ray of a batch its
    /// state, stack, k-buffer and live-list entries.
    pub fn per_ray_bytes(&self) -> u64 {
        [
            &self.rays,
            &self.stacks,
            &self.kbuf,
            &self.state,
            &self.lists,
        ]
        .iter()
        .map(|b| b.size)
        .sum::<u64>()
            + self.depth_sums.as_ref().map_or(0, |b| b.size)
    }

    /// Device bytes of the rest: parameters, counters and histograms, round counts and
    /// arguments, the host copy.
    pub fn fixed_bytes(&self) -> u64 {
        [
            &self.params,
            &self.clip,
            &self.counters,
            &self.live,
            &self.args,
            &self.readback,
        ]
        .iter()
        .map(|b| b.size)
        .sum()
    }

    /// The counts of the last frame recorded into these buffers, whose batches each took
    /// rounds `0..rounds`: call it once that submission completed.
    pub fn stats(&self, rounds: u32) -> TraceFrameStats {
        let words: Vec<u32> =
            bytemuck::pod_collect_to_vec(&self.readback.mapped()[..self.readback.size as usize]);
        let c = &words[READ_COUNTERS..READ_COUNTERS + COUNTER_WORDS];
        let hist = &words[READ_HIST..READ_LIVE];
        let max = MAX_TRACE_ROUNDS as usize;
        let (mut used, mut unfinished) = (0, 0);
        for b in 0..self.batches as usize {
            let live = &words[READ_LIVE + b * max..][..rounds as usize];
            used = used.max(live.iter().take_while(|&&l| l > 0).count() as u32 + 1);
            unfinished += live[rounds as usize - 1] as u64;
        }
        let b = HIST_BINS;
        let slot = |s: u32| c[s as usize] as u64;
        TraceFrameStats {
            rays: self.width as u64 * self.height as u64,
            hits_walked: slot(TRACE_COUNTER_WALKED),
            capped: slot(TRACE_COUNTER_CAPPED),
            hits_found: slot(TRACE_COUNTER_FOUND),
            passes: slot(TRACE_COUNTER_PASSES),
            node_visits: slot(TRACE_COUNTER_VISITS_LO) | slot(TRACE_COUNTER_VISITS_HI) << 32,
            gaussian_tests: slot(TRACE_COUNTER_TESTS_LO) | slot(TRACE_COUNTER_TESTS_HI) << 32,
            p99_walked: p99(&hist[..b]),
            p99_found: p99(&hist[b..2 * b]),
            p99_passes: p99(&hist[2 * b..]),
            rounds: used.min(rounds),
            unfinished,
            k: self.k,
            tiled: self.tiled,
        }
    }

    /// Rays of `batch` still live after its rounds `0..rounds` (the last frame's).
    pub(crate) fn live_after(&self, batch: u32, rounds: u32) -> u32 {
        let at = (READ_LIVE + (batch * MAX_TRACE_ROUNDS + rounds - 1) as usize) * 4;
        bytemuck::pod_read_unaligned(&self.readback.mapped()[at..at + 4])
    }

    /// Stack overflows the last frame counted (never expected: the tree's depth is at most 63).
    fn overflows(&self) -> u32 {
        let words: Vec<u32> =
            bytemuck::pod_collect_to_vec(&self.readback.mapped()[..COUNTER_WORDS * 4]);
        words[TRACE_COUNTER_OVERFLOW as usize]
    }

    /// The texel set for `scene` with `layout` ([`RayTracer`]'s), made or brought up to date
    /// (the buffers are idle: the slot's previous frame completed); `None` where a view would
    /// pass the device's `maxTexelBufferElements` (the frame then reads by address).
    fn texel_set(
        &mut self,
        layout: vk::DescriptorSetLayout,
        scene: &GpuScene,
        still: Option<(&Buffer, u64)>,
    ) -> Result<Option<vk::DescriptorSet>> {
        let (nodes, nodes_of) = match still {
            Some((nodes, id)) => (nodes, NodeSource::Still(id)),
            None => match &self.bvh {
                Some(lbvh) => (&lbvh.nodes, NodeSource::Lbvh),
                None => return Err(Error::InvalidInput("ray tracer: no BVH to walk".into())),
            },
        };
        let (gaussians, sh, scene_id) = scene.buffers();
        let (sh_format, sh_bytes) = crate::stages::sh_texel(scene.sh_precision());
        let rgba32 = vk::Format::R32G32B32A32_UINT;
        let viewed = [
            (nodes, rgba32, 16u64),
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
                nodes_of: NodeSource::Lbvh,
                scene_id: u64::MAX,
            });
        }
        let t = self.texels.as_mut().expect("made above");
        // Each view is made again when what it is of changes (a freed buffer's handle may come
        // back, so they are keyed by the scene's and the still tree's ids, not by handle).
        let stale = [
            t.views[0] == vk::BufferView::null() || t.nodes_of != nodes_of,
            t.scene_id != scene_id,
            t.scene_id != scene_id,
        ];
        for i in (0..3).filter(|&i| stale[i]) {
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
        t.nodes_of = nodes_of;
        t.scene_id = scene_id;
        Ok(Some(t.set))
    }
}

/// The sizes of the k-closest-hit buffer the tracer is built for (`TRACE_K` of its kernels).
pub const TRACE_KS: [u32; 2] = [16, 64];

/// The k-buffer size a tracer gets by default: `RARA_TRACE_K` (16 or 64) when set, else 16 on
/// GPUs (REdiSplats' and 3DGRT's k, and their register budget) and 64 on CPU drivers, where
/// every array spills anyway and fewer restarts from the root pay (lavapipe, plant at 320x240:
/// docs/PERFORMANCE.md). The image is the same for any k.
pub fn default_k(ctx: &Context) -> u32 {
    match std::env::var("RARA_TRACE_K").as_deref() {
        Ok("16") => return 16,
        Ok("64") => return 64,
        _ => {}
    }
    if cpu_driver(ctx) {
        64
    } else {
        16
    }
}

/// Whether the device is a CPU driver, where the kernels read through texel views.
fn cpu_driver(ctx: &Context) -> bool {
    crate::stages::rasterize::RasterLayout::for_device(ctx)
        == crate::stages::rasterize::RasterLayout::Strips
}

/// The SPIR-V of the mixed scenes' tracer for SH `degree` and half-float coefficients or not:
/// with texel views and k = 64 (CPU drivers) or neither (GPUs); `None` for another pairing.
fn trace_mixed_spirv(degree: usize, f16: bool, texels: bool, k: u32) -> Option<&'static [u32]> {
    use shaders::*;
    let table: [[&'static [u32]; 2]; 4] = match (texels, k) {
        (true, 64) => [
            [
                TRACE_MIXED_DEG0_TEXELS_K64,
                TRACE_MIXED_DEG0_SH16_TEXELS_K64,
            ],
            [
                TRACE_MIXED_DEG1_TEXELS_K64,
                TRACE_MIXED_DEG1_SH16_TEXELS_K64,
            ],
            [
                TRACE_MIXED_DEG2_TEXELS_K64,
                TRACE_MIXED_DEG2_SH16_TEXELS_K64,
            ],
            [
                TRACE_MIXED_DEG3_TEXELS_K64,
                TRACE_MIXED_DEG3_SH16_TEXELS_K64,
            ],
        ],
        (false, 16) => [
            [TRACE_MIXED_DEG0, TRACE_MIXED_DEG0_SH16],
            [TRACE_MIXED_DEG1, TRACE_MIXED_DEG1_SH16],
            [TRACE_MIXED_DEG2, TRACE_MIXED_DEG2_SH16],
            [TRACE_MIXED_DEG3, TRACE_MIXED_DEG3_SH16],
        ],
        _ => return None,
    };
    Some(table[degree][f16 as usize])
}

/// The SPIR-V of the tracer's kernel for camera rays from tile lists (SPEC section 11) for SH
/// `degree` and half-float coefficients or not: with texel views and k = 64 (CPU drivers) or
/// neither (GPUs); `None` for another pairing.
fn trace_tiled_spirv(degree: usize, f16: bool, texels: bool, k: u32) -> Option<&'static [u32]> {
    use shaders::*;
    let table: [[&'static [u32]; 2]; 4] = match (texels, k) {
        (true, 64) => [
            [
                TRACE_TILED_DEG0_TEXELS_K64,
                TRACE_TILED_DEG0_SH16_TEXELS_K64,
            ],
            [
                TRACE_TILED_DEG1_TEXELS_K64,
                TRACE_TILED_DEG1_SH16_TEXELS_K64,
            ],
            [
                TRACE_TILED_DEG2_TEXELS_K64,
                TRACE_TILED_DEG2_SH16_TEXELS_K64,
            ],
            [
                TRACE_TILED_DEG3_TEXELS_K64,
                TRACE_TILED_DEG3_SH16_TEXELS_K64,
            ],
        ],
        (false, 16) => [
            [TRACE_TILED_DEG0, TRACE_TILED_DEG0_SH16],
            [TRACE_TILED_DEG1, TRACE_TILED_DEG1_SH16],
            [TRACE_TILED_DEG2, TRACE_TILED_DEG2_SH16],
            [TRACE_TILED_DEG3, TRACE_TILED_DEG3_SH16],
        ],
        _ => return None,
    };
    Some(table[degree][f16 as usize])
}

/// The SPIR-V of the tracer's kernel for SH `degree`, half-float coefficients or not, reading
/// through texel views or not, with a `k`-hit buffer.
fn trace_spirv(degree: usize, f16: bool, texels: bool, k: u32) -> &'static [u32] {
    use shaders::*;
    let table: [[[&'static [u32]; 2]; 2]; 4] = if k == 64 {
        [
            [
                [TRACE_DEG0_K64, TRACE_DEG0_SH16_K64],
                [TRACE_DEG0_TEXELS_K64, TRACE_DEG0_SH16_TEXELS_K64],
            ],
            [
                [TRACE_DEG1_K64, TRACE_DEG1_SH16_K64],
                [TRACE_DEG1_TEXELS_K64, TRACE_DEG1_SH16_TEXELS_K64],
            ],
            [
                [TRACE_DEG2_K64, TRACE_DEG2_SH16_K64],
                [TRACE_DEG2_TEXELS_K64, TRACE_DEG2_SH16_TEXELS_K64],
            ],
            [
                [TRACE_DEG3_K64, TRACE_DEG3_SH16_K64],
                [TRACE_DEG3_TEXELS_K64, TRACE_DEG3_SH16_TEXELS_K64],
            ],
        ]
    } else {
        [
            [
                [TRACE_DEG0, TRACE_DEG0_SH16],
                [TRACE_DEG0_TEXELS, TRACE_DEG0_SH16_TEXELS],
            ],
            [
                [TRACE_DEG1, TRACE_DEG1_SH16],
                [TRACE_DEG1_TEXELS, TRACE_DEG1_SH16_TEXELS],
            ],
            [
                [TRACE_DEG2, TRACE_DEG2_SH16],
                [TRACE_DEG2_TEXELS, TRACE_DEG2_SH16_TEXELS],
            ],
            [
                [TRACE_DEG3, TRACE_DEG3_SH16],
                [TRACE_DEG3_TEXELS, TRACE_DEG3_SH16_TEXELS],
            ],
        ]
    };
    table[degree][texels as usize][f16 as usize]
}

/// The ray tracer's kernels, each built by the first frame that needs it (a scene's SH degree
/// and precision pick one of eight).
pub struct RayTracer {
    /// The k-buffer size, one of [`TRACE_KS`].
    k: u32,
    /// Per (what the rays are, texel views, SH degree, half-float coefficients): the kernel,
    /// once built. The rays: camera rays through the BVH, a mixed scene's, camera rays from
    /// tile lists ([`RayKind`]).
    kernels: [[[[std::sync::OnceLock<ComputePipeline>; 2]; 4]; 2]; 3],
    /// On CPU drivers: the layout of the texel set ([`TraceTexels`]) of the texel kernels.
    texel_layout: Option<vk::DescriptorSetLayout>,
    /// On CPU drivers: the frame's texel set layout, which the texel kernels of camera rays
    /// from tile lists read through ([`RayTileLists::texels`]).
    frame_texel_layout: Option<crate::stages::FrameTexelsLayout>,
    args: ComputePipeline,
    bvh: BvhBuild,
    ctx: Context,
}

impl Drop for RayTracer {
    fn drop(&mut self) {
        // The kernels go before the layout they were made with.
        self.kernels = Default::default();
        if let Some(layout) = self.texel_layout.take() {
            unsafe {
                self.ctx
                    .device()
                    .destroy_descriptor_set_layout(layout, None)
            };
        }
    }
}

/// What a tracer kernel's rays are.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
enum RayKind {
    /// Camera rays through the BVH.
    Camera = 0,
    /// A mixed scene's generation of rays (`MIXED`).
    Mixed = 1,
    /// Camera rays from tile lists (`TILED`, SPEC section 11).
    Tiled = 2,
}

/// The layout of the texel set: uniform texel buffers at [`TEXEL_BINDINGS`].
fn texel_set_layout(ctx: &Context) -> Result<vk::DescriptorSetLayout> {
    crate::stages::texel_set_layout(ctx, TEXEL_BINDINGS)
}

impl RayTracer {
    /// A tracer with the device's default k-buffer ([`default_k`]).
    pub fn new(ctx: &Context) -> Result<Self> {
        Self::with_k(ctx, default_k(ctx))
    }

    /// A tracer whose rays collect `k` hits per traversal pass, one of [`TRACE_KS`]. The
    /// kernels are built when first used; on CPU drivers
    /// ([`crate::stages::rasterize::RasterLayout::Strips`]) they read through texel views.
    pub fn with_k(ctx: &Context, k: u32) -> Result<Self> {
        if !TRACE_KS.contains(&k) {
            return Err(Error::InvalidInput(format!(
                "a k-buffer of {k} hits: the ray tracer is built for {TRACE_KS:?}"
            )));
        }
        // (Made first: it frees itself if what follows fails.)
        let frame_texel_layout = if cpu_driver(ctx) {
            Some(crate::stages::FrameTexelsLayout::new(ctx)?)
        } else {
            None
        };
        let texel_layout = if cpu_driver(ctx) {
            Some(texel_set_layout(ctx)?)
        } else {
            None
        };
        let args =
            ComputePipeline::new::<LinearArgsPush>(ctx, c"linear_args", shaders::LINEAR_ARGS);
        let bvh = BvhBuild::new(ctx);
        let (args, bvh) = match (args, bvh) {
            (Ok(a), Ok(b)) => (a, b),
            (a, b) => {
                if let Some(layout) = texel_layout {
                    unsafe { ctx.device().destroy_descriptor_set_layout(layout, None) };
                }
                return Err(a.err().or(b.err()).expect("one failed"));
            }
        };
        Ok(RayTracer {
            k,
            kernels: Default::default(),
            texel_layout,
            frame_texel_layout,
            args,
            bvh,
            ctx: ctx.clone(),
        })
    }

    /// Whether the kernels read through texel views (CPU drivers): camera rays from tile lists
    /// then need the frame's texel set ([`RayTileLists::texels`]).
    pub fn reads_texels(&self) -> bool {
        self.texel_layout.is_some()
    }

    /// Builds a BVH of `scene` once, on the host ([`super::still_bvh`]: obvhs over the GPU's
    /// own proxy boxes for octagons of `q`), and keeps it with the scene: its frames walk it
    /// where it lies instead of building an LBVH (the same image; fewer nodes per ray). Refused for a tree
    /// deeper than the traversal's stack.
    pub fn build_still_bvh(
        &self,
        ctx: &Context,
        scene: &mut GpuScene,
        q: f32,
    ) -> Result<super::still_bvh::StillBvhStats> {
        if scene.count == 0 {
            return Err(Error::InvalidInput("a still BVH of no Gaussians".into()));
        }
        let read = self.bvh.build_and_read(ctx, scene, q)?;
        let (nodes, mut stats) = super::still_bvh::still_tree(&read.boxes);
        let depth = stats.depth;
        stats.lbvh_sah = super::still_bvh::sah_cost(&read.nodes);
        if depth > TRACE_STACK {
            return Err(Error::InvalidInput(format!(
                "the still BVH is {depth} deep, past the traversal's stack of {TRACE_STACK}"
            )));
        }
        let buffer = Buffer::from_slice(ctx, "still bvh nodes", &nodes)?;
        scene.set_still_bvh(buffer, q);
        Ok(stats)
    }

    /// Hits a traversal pass collects per ray.
    pub fn k(&self) -> u32 {
        self.k
    }

    /// The kernel for a scene of SH `degree` and `precision`, through texel views or not, for
    /// mixed scenes or not, built now if it was not yet.
    fn kernel(
        &self,
        degree: usize,
        precision: ShPrecision,
        texels: bool,
        rays: RayKind,
    ) -> Result<&ComputePipeline> {
        let f16 = precision == ShPrecision::F16;
        let cell = &self.kernels[rays as usize][texels as usize][degree][f16 as usize];
        if let Some(k) = cell.get() {
            return Ok(k);
        }
        let mismatch = |what: &str| {
            Error::InvalidInput(format!(
                "{what} traced with k = 64 through texel views on CPU drivers and k = 16 by \
                 address on GPUs, not k = {} {}",
                self.k,
                if texels {
                    "through texel views"
                } else {
                    "by address"
                }
            ))
        };
        let spirv = match rays {
            RayKind::Camera => trace_spirv(degree, f16, texels, self.k),
            RayKind::Mixed => trace_mixed_spirv(degree, f16, texels, self.k)
                .ok_or_else(|| mismatch("mixed scenes are"))?,
            RayKind::Tiled => trace_tiled_spirv(degree, f16, texels, self.k)
                .ok_or_else(|| mismatch("camera rays from tile lists are"))?,
        };
        // Camera rays from tile lists read the rasterizer's frame set, the others the tracer's.
        let layout = match rays {
            RayKind::Tiled => self.frame_texel_layout.as_ref().map(|l| l.raw),
            _ => self.texel_layout,
        };
        let built = match (texels, layout) {
            (true, Some(layout)) => ComputePipeline::with_set_layouts::<TracePush>(
                &self.ctx,
                c"trace",
                spirv,
                &[layout],
            )?,
            _ => ComputePipeline::new::<TracePush>(&self.ctx, c"trace", spirv)?,
        };
        Ok(cell.get_or_init(|| built))
    }

    /// Records a ray-traced frame of `scene` from `camera` into `cmd`: for each batch of rays
    /// in `batches` (of [`TraceBuffers::batches`]), rounds `rounds` of it. The frame's set-up
    /// (parameters, counters) and the BVH build (pass "bvh build") come first when the call
    /// starts the frame (batch 0, round 0); then the rounds (pass "trace"), then the copy of
    /// the counters for [`TraceBuffers::stats`]. A later call for the same batch from a later
    /// round goes on with the rays its earlier rounds left live (the per-ray buffers hold one
    /// batch: a batch must be finished before the next is started). The per-pixel state is in
    /// `bufs.state` afterwards. With `mixed`, the rays are a mixed scene's generation
    /// ([`MixedRays`]; the camera then only culls). Else, with `depth_limit` (the address of
    /// one f32 view depth per pixel, the depth test's, [`crate::stages::depth`]), a ray takes
    /// only the hits in front of its pixel's depth (SPEC section 9). With `tiles` (the
    /// buffers must be [`TraceBuffers::tiled`]), the camera rays walk the frame's tile lists
    /// (SPEC section 11, [`super::tiles::RayTiles`], recorded before) and no BVH is built.
    /// With `depth_sums` (not with `mixed`), each pixel's (median view depth, sum alpha T z) of
    /// its composited hits goes there, 16 bytes a pixel, for the depth output's write pass
    /// ([`crate::stages::depth::DepthStages::record_write`]).
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
        batches: std::ops::Range<u32>,
        rounds: std::ops::Range<u32>,
        mixed: Option<MixedRays>,
        depth_limit: Option<u64>,
        tiles: Option<RayTileLists>,
        depth_sums: Option<u64>,
        object_regions: Option<ObjectRegions>,
    ) -> Result<()> {
        let n = scene.len();
        let (w, h) = (camera.width, camera.height);
        if !bufs.fits((w, h), n, self.k, tiles.is_some()) {
            return Err(Error::InvalidInput(format!(
                "trace buffers for {}x{}, {} Gaussians, k = {} and tiled {}, not {w}x{h}, {n}, \
                 {} and {}",
                bufs.width,
                bufs.height,
                bufs.gaussians,
                bufs.k,
                bufs.tiled,
                self.k,
                tiles.is_some()
            )));
        }
        if mixed.is_some() && tiles.is_some() {
            return Err(Error::InvalidInput(
                "a mixed scene's rays come from its ray tree, not from tile lists".into(),
            ));
        }
        if rounds.end > MAX_TRACE_ROUNDS || rounds.start >= rounds.end {
            return Err(Error::InvalidInput(format!(
                "ray tracer rounds {rounds:?}: at most {MAX_TRACE_ROUNDS}"
            )));
        }
        if mixed.is_some() && object_regions.is_some() {
            return Err(Error::InvalidInput(
                "a mixed scene's objects carry their clips in the mixed parameters".into(),
            ));
        }
        if mixed.is_some() && (depth_limit.is_some() || depth_sums.is_some()) {
            return Err(Error::InvalidInput(
                "a mixed scene's rays take no depth test and have no depth output".into(),
            ));
        }
        if mixed.is_some() && batches.len() != 1 {
            return Err(Error::InvalidInput(
                "a mixed scene's generation records one batch per call".into(),
            ));
        }
        if batches.end > bufs.batches || batches.start >= batches.end {
            return Err(Error::InvalidInput(format!(
                "ray tracer batches {batches:?} of {}",
                bufs.batches
            )));
        }
        let device = ctx.device();
        let rays = if tiles.is_some() {
            let (gx, gy) = tile_grid(w, h);
            gx * gy * TILE_SIZE * TILE_SIZE
        } else {
            w * h
        };
        if rounds.start == 0 && batches.start == 0 {
            let mut p = GpuTraceParams::new(camera, scene, options, mixed.map_or(0, |m| m.params));
            if let Some(limit) = depth_limit {
                p.mixed[2..].copy_from_slice(&[limit as u32, (limit >> 32) as u32]);
            }
            let words = |a: u64| [a as u32, (a >> 32) as u32];
            if let Some(sums) = depth_sums {
                p.depth_out[..2].copy_from_slice(&words(sums));
            }
            if let Some(o) = object_regions {
                p.objects[..2].copy_from_slice(&words(o.regions));
                p.objects[2..].copy_from_slice(&words(o.of_gaussian));
            }
            if let Some(t) = &tiles {
                p.lists[..2].copy_from_slice(&words(t.ranges));
                p.lists[2..].copy_from_slice(&words(t.gaussians));
                p.records[..2].copy_from_slice(&words(t.records));
            }
            let clip_params = clip.to_gpu();
            unsafe {
                device.cmd_update_buffer(cmd, bufs.params.raw, 0, bytemuck::bytes_of(&p));
                device.cmd_update_buffer(cmd, bufs.clip.raw, 0, bytemuck::bytes_of(&clip_params));
                for b in [&bufs.counters, &bufs.live] {
                    device.cmd_fill_buffer(cmd, b.raw, 0, vk::WHOLE_SIZE, 0);
                }
            }
            compute_barrier(ctx, cmd);
            // A scene that does not move brings its tree, built once on the host: its rays
            // walk it where it lies, and nothing is built.
            let still = scene.still_bvh(options.q as f32).is_some();
            if tiles.is_none() && mixed.map_or(true, |m| m.build_bvh) && !still {
                timer.begin_pass(cmd, c"bvh build");
                let lbvh = bufs.lbvh(&self.bvh)?;
                self.bvh
                    .record(ctx, cmd, scene.gaussians.address, lbvh, options.q as f32);
                timer.end_pass(cmd, c"bvh build");
            }
        }
        // The tree the rays walk (none for camera rays from tile lists).
        let still = scene.still_bvh(options.q as f32);
        let nodes_address = match (&tiles, still) {
            (Some(_), _) => 0,
            (None, Some((nodes, _))) => nodes.address,
            (None, None) => bufs.lbvh(&self.bvh)?.nodes.address,
        };
        let degree = scene.sh_degree().min(3) as usize;
        let set = match (&tiles, self.texel_layout) {
            (Some(t), _) => t.texels,
            (None, Some(layout)) => bufs.texel_set(layout, scene, still)?,
            (None, None) => None,
        };
        let ray_kind = match (mixed, tiles) {
            (Some(_), _) => RayKind::Mixed,
            (None, Some(_)) => RayKind::Tiled,
            (None, None) => RayKind::Camera,
        };
        let kernel = self.kernel(degree, scene.sh_precision(), set.is_some(), ray_kind)?;
        let sets: Vec<vk::DescriptorSet> = set.into_iter().collect();
        let (gaussians, sh, _) = scene.buffers();
        let mut push = TracePush {
            params: bufs.params.address,
            gaussians: gaussians.address,
            sh: sh.address,
            nodes: nodes_address,
            rays: bufs.rays.address,
            stacks: bufs.stacks.address,
            kbuf: bufs.kbuf.address,
            state: bufs.state.address,
            counters: bufs.counters.address,
            lists: bufs.lists.address,
            live: 0,
            clip: mixed.map_or(bufs.clip.address, |m| m.clips),
            round: 0,
            budget: TRACE_BUDGET,
            ray_base: 0,
            batch_rays: 0,
            stride: bufs.batch_rays,
            pad: 0,
        };
        let max = MAX_TRACE_ROUNDS as u64;
        timer.begin_pass(cmd, c"trace");
        for batch in batches {
            // Each batch's rays go through all of their rounds before the next batch reuses
            // the per-ray buffers.
            push.ray_base = batch * bufs.batch_rays;
            push.batch_rays = match mixed {
                Some(m) => m.listed_rays,
                None => bufs.batch_rays.min(rays - push.ray_base),
            };
            push.live = bufs.live.address + 4 * batch as u64 * max;
            for round in rounds.clone() {
                push.round = round;
                if round == 0 {
                    kernel.dispatch_with_sets(cmd, &push, &sets, linear_grid(push.batch_rays));
                } else {
                    let slot = batch as u64 * max + round as u64;
                    let args = LinearArgsPush {
                        count: push.live + 4 * (round - 1) as u64,
                        args: bufs.args.address + 16 * slot,
                    };
                    self.args.dispatch(cmd, &args, [1, 1, 1]);
                    compute_barrier(ctx, cmd);
                    kernel.dispatch_indirect_with_sets(cmd, &push, &sets, bufs.args.raw, 16 * slot);
                }
                compute_barrier(ctx, cmd);
            }
        }
        timer.end_pass(cmd, c"trace");
        crate::vk::buffer::copy_parts_to_host(
            ctx,
            cmd,
            &[
                (&bufs.counters, READ_COUNTERS as u64 * 4),
                (&bufs.live, READ_LIVE as u64 * 4),
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
        let mut bufs = TraceBuffers::new(self, ctx, (w, h), scene.len(), false)?;
        let mut timer = PassTimer::labels_only(ctx);
        // Batch by batch: each runs its first rounds, then more (from the host) while it has
        // live rays, before the next batch takes over the per-ray buffers.
        let mut most = 1;
        for batch in 0..bufs.batches {
            let mut end = 0;
            let mut next = FIRST_TRACE_ROUNDS;
            loop {
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
                        batch..batch + 1,
                        end..next,
                        None,
                        None,
                        None,
                        None,
                        None,
                    )
                })??;
                end = next;
                if bufs.live_after(batch, end) == 0 || end == MAX_TRACE_ROUNDS {
                    break;
                }
                next = (end * 2).min(MAX_TRACE_ROUNDS);
            }
            most = most.max(end);
        }
        let stats = bufs.stats(most);
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
