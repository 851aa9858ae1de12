//! The frame: project -> prefix sum -> emit -> sort -> tile ranges -> rasterize, recorded
//! into one command buffer with no host round trip inside it.

use ash::vk;
use glam::Vec3;

use crate::camera::{tile_grid, Camera};
use crate::clip::{Clip, ClipMode};
use crate::constants::{
    COUNTER_CUTOFF, COUNTER_INTERSECTIONS, COUNTER_MAX_TILE_LEN, COUNTER_SLOTS, COUNTER_VISIBLE,
    RASTER_CHUNK,
};
use crate::error::{Error, Result};
use crate::gpu_types::{GpuClipParams, GpuCutoffRecord, GpuFrameParams, GpuGaussian};
use crate::scene::Scene;
use crate::stages::emit::{Emit, EmitPush};
use crate::stages::prefix_sum::{PrefixSum, PrefixSumScratch};
use crate::stages::project::{Project, ProjectPush};
use crate::stages::rasterize::{RasterLayout, Rasterize, RasterizePush};
use crate::stages::sort::{RadixSort, SortBuffers};
use crate::stages::tile_ranges::{TileRanges, TileRangesPush};
use crate::timing::{PassTimer, PassTiming};
use crate::vk::{compute_barrier, Buffer, Context, MemoryLocation};

/// Byte offset of `scene.x` (the Gaussian count) in `FrameParams`: the prefix sum of tiles
/// touched reads its length there.
const PARAMS_COUNT_OFFSET: u64 = 112;

/// A scene uploaded to the GPU.
pub struct GpuScene {
    gaussians: Buffer,
    sh: Buffer,
    count: u32,
    sh_degree: u32,
}

impl GpuScene {
    /// Number of Gaussians.
    pub fn len(&self) -> u32 {
        self.count
    }

    /// Whether the scene is empty.
    pub fn is_empty(&self) -> bool {
        self.count == 0
    }

    /// SH degree.
    pub fn sh_degree(&self) -> u32 {
        self.sh_degree
    }

    /// Device bytes held by the scene.
    pub fn device_bytes(&self) -> u64 {
        self.gaussians.size + self.sh.size
    }
}

/// How to render a frame.
#[derive(Clone, Debug, PartialEq)]
pub struct RenderOptions {
    /// Colour behind the splats.
    pub background: Vec3,
    /// Clipping (SPEC section 5); the default clips nothing.
    pub clip: Clip,
}

impl Default for RenderOptions {
    fn default() -> Self {
        RenderOptions {
            background: Vec3::ZERO,
            clip: Clip::default(),
        }
    }
}

/// What a frame cost and produced.
#[derive(Clone, Debug, Default)]
pub struct FrameStats {
    /// (tile, splat) pairs, i.e. tile intersections.
    pub intersections: u32,
    /// Gaussians that touched at least one tile.
    pub visible: u32,
    /// Gaussians drawn as cutoff (per-pixel clip weight), among `visible`.
    pub cutoff: u32,
    /// Longest tile list.
    pub max_tile_len: u32,
    /// How often the frame was rendered again after growing a buffer.
    pub rerenders: u32,
    /// GPU time (and compute invocations) per pass, in pass order (empty without timestamps).
    pub passes: Vec<PassTiming>,
    /// Sum of `passes`.
    pub gpu_ms: f64,
    /// Wall-clock milliseconds of the last render: recording, submission and wait.
    pub wall_ms: f64,
}

/// Buffers of one frame size, reused while the sizes fit.
struct FrameResources {
    width: u32,
    height: u32,
    gaussians: u32,
    capacity: u64,
    rounds: u32,
    params: Buffer,
    clip_params: Buffer,
    counters: Buffer,
    /// Cutoff side records, one slot per Gaussian; allocated on the first rara frame.
    cutoffs: Option<Buffer>,
    splats: Buffer,
    tiles_touched: Buffer,
    touched_scan: PrefixSumScratch,
    sort: SortBuffers,
    ranges: Buffer,
    state: Option<Buffer>,
    image: Buffer,
    readback: Buffer,
    /// Which sort buffer holds the sorted pairs of the last frame.
    sorted: usize,
}

/// The intermediate buffers of the last rendered frame, read back for tests and debugging.
#[derive(Clone, Debug, Default)]
pub struct Intermediates {
    /// Output of project, per Gaussian.
    pub splats: Vec<crate::gpu_types::GpuProjectedSplat>,
    /// Exclusive prefix sum of tiles touched, per Gaussian.
    pub offsets: Vec<u32>,
    /// Sorted keys (tile in the high word, depth bits in the low word).
    pub keys: Vec<u64>,
    /// Splat index of each sorted key.
    pub values: Vec<u32>,
    /// `[start, end)` per tile.
    pub ranges: Vec<[u32; 2]>,
}

/// Renders scenes with the GPU pipeline.
pub struct Renderer {
    ctx: Context,
    project: Project,
    prefix_sum: PrefixSum,
    emit: Emit,
    sort: RadixSort,
    tile_ranges: TileRanges,
    rasterize: Rasterize,
    timer: PassTimer,
    frame: Option<FrameResources>,
}

/// Sort key bits: 32 depth bits + enough bits for the tile id.
pub fn key_bits(width: u32, height: u32) -> u32 {
    let (gx, gy) = tile_grid(width, height);
    32 + (gx * gy).next_power_of_two().trailing_zeros()
}

impl Renderer {
    /// Builds every kernel of the pipeline, with the rasterizer layout that suits the device
    /// ([`RasterLayout::for_device`]).
    pub fn new(ctx: &Context) -> Result<Self> {
        Self::with_raster_layout(ctx, RasterLayout::for_device(ctx))
    }

    /// Builds every kernel of the pipeline with the given rasterizer layout.
    pub fn with_raster_layout(ctx: &Context, layout: RasterLayout) -> Result<Self> {
        Ok(Renderer {
            ctx: ctx.clone(),
            project: Project::new(ctx)?,
            prefix_sum: PrefixSum::new(ctx)?,
            emit: Emit::new(ctx)?,
            sort: RadixSort::new(ctx)?,
            tile_ranges: TileRanges::new(ctx)?,
            rasterize: Rasterize::new(ctx, layout)?,
            timer: PassTimer::new(ctx)?,
            frame: None,
        })
    }

    /// Replaces the renderer's pass timer, e.g. with one that writes into an engine's query
    /// pool ([`PassTimer::with_engine_pool`]). Returns the old one.
    pub fn set_timer(&mut self, timer: PassTimer) -> PassTimer {
        std::mem::replace(&mut self.timer, timer)
    }

    /// The context the renderer was made with.
    pub fn context(&self) -> &Context {
        &self.ctx
    }

    /// Uploads a scene.
    pub fn upload(&self, scene: &Scene) -> Result<GpuScene> {
        let count = u32::try_from(scene.len()).map_err(|_| {
            Error::InvalidInput(format!("{} Gaussians exceed the 2^32 limit", scene.len()))
        })?;
        let gaussians: Vec<GpuGaussian> = (0..scene.len())
            .map(|i| {
                let m = scene.means[i];
                let q = scene.rotations[i];
                let s = scene.scales[i];
                GpuGaussian {
                    pos_opacity: [m.x, m.y, m.z, scene.opacities[i]],
                    rot: [q.w, q.x, q.y, q.z],
                    scale: [s.x, s.y, s.z, 0.0],
                }
            })
            .collect();
        Ok(GpuScene {
            gaussians: Buffer::from_slice(&self.ctx, "scene gaussians", &gaussians)?,
            sh: Buffer::from_slice(&self.ctx, "scene SH", &scene.sh)?,
            count,
            sh_degree: scene.sh_degree,
        })
    }

    fn frame_resources(
        &mut self,
        width: u32,
        height: u32,
        gaussians: u32,
        capacity: u64,
        rounds: u32,
    ) -> Result<&FrameResources> {
        let fits = self.frame.as_ref().is_some_and(|f| {
            f.width == width
                && f.height == height
                && f.gaussians >= gaussians
                && f.capacity >= capacity
                && f.rounds >= rounds
        });
        if !fits {
            self.frame = None; // free the old buffers first
            let ctx = &self.ctx;
            let gpu = MemoryLocation::GpuOnly;
            let (gx, gy) = tile_grid(width, height);
            let pixels = width as u64 * height as u64;
            let n = gaussians.max(1) as u64;
            self.frame = Some(FrameResources {
                width,
                height,
                gaussians,
                capacity,
                rounds,
                params: Buffer::new(
                    ctx,
                    "frame params",
                    std::mem::size_of::<GpuFrameParams>() as u64,
                    gpu,
                )?,
                clip_params: Buffer::new(
                    ctx,
                    "clip params",
                    std::mem::size_of::<GpuClipParams>() as u64,
                    gpu,
                )?,
                counters: Buffer::new(ctx, "frame counters", COUNTER_SLOTS as u64 * 4, gpu)?,
                cutoffs: None,
                splats: Buffer::new(ctx, "projected splats", n * 64, gpu)?,
                tiles_touched: Buffer::new(ctx, "tiles touched", n * 4, gpu)?,
                touched_scan: self.prefix_sum.scratch(ctx, n)?,
                sort: self.sort.buffers(ctx, capacity)?,
                ranges: Buffer::new(ctx, "tile ranges", (gx * gy) as u64 * 8, gpu)?,
                state: if rounds > 1 {
                    Some(Buffer::new(ctx, "raster state", pixels * 16, gpu)?)
                } else {
                    None
                },
                image: Buffer::new(ctx, "image rgba8", pixels * 4, gpu)?,
                readback: Buffer::new(
                    ctx,
                    "frame readback",
                    pixels * 4 + COUNTER_SLOTS as u64 * 4,
                    MemoryLocation::GpuToCpu,
                )?,
                sorted: 0,
            });
        }
        Ok(self.frame.as_ref().unwrap())
    }

    /// Renders `scene` from `camera`; grows the intersection buffers (and the rasterizer's
    /// rounds) and renders again when a frame did not fit.
    pub fn render(
        &mut self,
        scene: &GpuScene,
        camera: &Camera,
        options: &RenderOptions,
    ) -> Result<(image::RgbaImage, FrameStats)> {
        crate::camera::check_size(camera.width, camera.height)?;
        options.clip.validate()?;
        let mut capacity = self
            .frame
            .as_ref()
            .map_or(0, |f| f.capacity)
            .max(scene.count as u64 * 4)
            .max(1 << 16);
        let mut rounds = self.frame.as_ref().map_or(1, |f| f.rounds);
        let mut rerenders = 0;
        loop {
            let start = std::time::Instant::now();
            let (pixels, counters) = self.render_once(scene, camera, options, capacity, rounds)?;
            let wall_ms = start.elapsed().as_secs_f64() * 1e3;
            let intersections = counters[COUNTER_INTERSECTIONS as usize];
            let max_tile_len = counters[COUNTER_MAX_TILE_LEN as usize];
            if intersections as u64 > capacity {
                capacity = (intersections as u64 * 5 / 4).next_power_of_two();
                rerenders += 1;
                continue;
            }
            if max_tile_len > rounds * RASTER_CHUNK {
                rounds = max_tile_len.div_ceil(RASTER_CHUNK);
                rerenders += 1;
                continue;
            }
            let passes = self.timer.read()?;
            let stats = FrameStats {
                intersections,
                visible: counters[COUNTER_VISIBLE as usize],
                cutoff: counters[COUNTER_CUTOFF as usize],
                max_tile_len,
                rerenders,
                gpu_ms: passes.iter().map(|p| p.ms).sum(),
                passes,
                wall_ms,
            };
            let image = image::RgbaImage::from_raw(camera.width, camera.height, pixels)
                .expect("image size");
            return Ok((image, stats));
        }
    }

    /// Reads back the intermediate buffers of the last frame rendered (of `scene`, which has
    /// `stats.intersections` pairs). Slow; for tests and debugging.
    pub fn intermediates(&self, scene: &GpuScene, stats: &FrameStats) -> Result<Intermediates> {
        let f = self.frame.as_ref().expect("render a frame first");
        let n = scene.count as usize;
        let m = stats.intersections as usize;
        let (gx, gy) = tile_grid(f.width, f.height);
        Ok(Intermediates {
            splats: f.splats.download_as(n)?,
            offsets: f.tiles_touched.download_as(n)?,
            keys: f.sort.keys[f.sorted].download_as(m)?,
            values: f.sort.values[f.sorted].download_as(m)?,
            ranges: f.ranges.download_as((gx * gy) as usize)?,
        })
    }

    fn render_once(
        &mut self,
        scene: &GpuScene,
        camera: &Camera,
        options: &RenderOptions,
        capacity: u64,
        rounds: u32,
    ) -> Result<(Vec<u8>, Vec<u32>)> {
        let (w, h) = (camera.width, camera.height);
        let (gx, gy) = tile_grid(w, h);
        self.frame_resources(w, h, scene.count, capacity, rounds)?;
        let rara = options.clip.effective_mode() == ClipMode::Rara;
        // One side-record slot per Gaussian of this scene: (re)allocated when a rara frame needs
        // more than the last one did.
        let cutoff_bytes =
            scene.count.max(1) as u64 * std::mem::size_of::<GpuCutoffRecord>() as u64;
        let frame = self.frame.as_mut().unwrap();
        if rara
            && !frame
                .cutoffs
                .as_ref()
                .is_some_and(|b| b.size >= cutoff_bytes)
        {
            frame.cutoffs = None; // free the old buffer first
            let buffer = Buffer::new(
                &self.ctx,
                "cutoff records",
                cutoff_bytes,
                MemoryLocation::GpuOnly,
            )?;
            frame.cutoffs = Some(buffer);
        }
        let clip_params = options.clip.to_gpu();
        let sorted_index = crate::stages::sort::passes_for(key_bits(w, h)) as usize % 2;
        self.frame.as_mut().unwrap().sorted = sorted_index;
        let f = self.frame.as_ref().unwrap();
        let w2c = camera.world_to_camera();
        let (cx, cy) = camera.principal_point();
        let row = |r: usize| {
            let v = w2c.row(r);
            [v.x, v.y, v.z, 0.0]
        };
        let params = GpuFrameParams {
            world_to_cam: [row(0), row(1), row(2)],
            cam_pos: [camera.position.x, camera.position.y, camera.position.z, 0.0],
            focal: [camera.fx, camera.fy, cx, cy],
            background: [
                options.background.x,
                options.background.y,
                options.background.z,
                0.0,
            ],
            size: [w, h, gx, gy],
            scene: [
                scene.count,
                scene.sh_degree,
                3 * (scene.sh_degree + 1).pow(2),
                f.capacity.min(u32::MAX as u64) as u32,
            ],
        };
        // Only rara frames write or read side records; other frames pass a null address.
        let cutoffs_address = f.cutoffs.as_ref().map_or(0, |b| b.address);
        let ctx = self.ctx.clone();
        let device = ctx.device().clone();
        let counters_at = |slot: u32| f.counters.address + 4 * slot as u64;
        let timer = &mut self.timer;
        let image_bytes = w as u64 * h as u64 * 4;
        ctx.run_commands(|cmd| unsafe {
            timer.begin_frame(cmd);
            device.cmd_update_buffer(cmd, f.params.raw, 0, bytemuck::bytes_of(&params));
            device.cmd_update_buffer(cmd, f.clip_params.raw, 0, bytemuck::bytes_of(&clip_params));
            device.cmd_fill_buffer(cmd, f.counters.raw, 0, vk::WHOLE_SIZE, 0);
            device.cmd_fill_buffer(cmd, f.ranges.raw, 0, vk::WHOLE_SIZE, 0);
            compute_barrier(&ctx, cmd);

            timer.begin_pass(cmd, c"project");
            let push = ProjectPush {
                frame: f.params.address,
                gaussians: scene.gaussians.address,
                sh: scene.sh.address,
                splats: f.splats.address,
                tiles_touched: f.tiles_touched.address,
                counters: f.counters.address,
                clip: f.clip_params.address,
                cutoffs: cutoffs_address,
            };
            self.project.record(cmd, &push, scene.count);
            compute_barrier(&ctx, cmd);
            timer.end_pass(cmd, c"project");

            timer.begin_pass(cmd, c"prefix sum");
            self.prefix_sum.record(
                &ctx,
                cmd,
                f.tiles_touched.address,
                f.params.address + PARAMS_COUNT_OFFSET,
                Some(counters_at(COUNTER_INTERSECTIONS)),
                &f.touched_scan,
            );
            timer.end_pass(cmd, c"prefix sum");

            timer.begin_pass(cmd, c"emit");
            let push = EmitPush {
                frame: f.params.address,
                splats: f.splats.address,
                offsets: f.tiles_touched.address,
                keys: f.sort.keys[0].address,
                values: f.sort.values[0].address,
            };
            self.emit.record(cmd, &push, scene.count);
            compute_barrier(&ctx, cmd);
            timer.end_pass(cmd, c"emit");

            let sorted = self.sort.record(
                &ctx,
                cmd,
                &f.sort,
                counters_at(COUNTER_INTERSECTIONS),
                key_bits(w, h),
                Some(&mut *timer),
            );
            debug_assert_eq!(sorted, sorted_index);

            timer.begin_pass(cmd, c"tile ranges");
            let push = TileRangesPush {
                keys: f.sort.keys[sorted].address,
                info: f.sort.info.address,
                ranges: f.ranges.address,
            };
            self.tile_ranges.record(cmd, &push, &f.sort.info);
            compute_barrier(&ctx, cmd);
            timer.end_pass(cmd, c"tile ranges");

            timer.begin_pass(cmd, c"rasterize");
            let push = RasterizePush {
                frame: f.params.address,
                splats: f.splats.address,
                values: f.sort.values[sorted].address,
                ranges: f.ranges.address,
                state: f.state.as_ref().map_or(0, |s| s.address),
                image: f.image.address,
                counters: f.counters.address,
                clip: f.clip_params.address,
                cutoffs: cutoffs_address,
                round_index: 0,
                flags: 0,
            };
            let inverted = options.clip.region.as_ref().is_some_and(|r| r.invert);
            let cutoff_weight = rara.then_some((options.clip.weight, inverted));
            self.rasterize
                .record(&ctx, cmd, &push, (gx, gy), rounds, cutoff_weight);
            compute_barrier(&ctx, cmd);
            timer.end_pass(cmd, c"rasterize");

            let regions = [vk::BufferCopy {
                src_offset: 0,
                dst_offset: 0,
                size: image_bytes,
            }];
            device.cmd_copy_buffer(cmd, f.image.raw, f.readback.raw, &regions);
            let regions = [vk::BufferCopy {
                src_offset: 0,
                dst_offset: image_bytes,
                size: COUNTER_SLOTS as u64 * 4,
            }];
            device.cmd_copy_buffer(cmd, f.counters.raw, f.readback.raw, &regions);
            let to_host = vk::MemoryBarrier::default()
                .src_access_mask(vk::AccessFlags::TRANSFER_WRITE)
                .dst_access_mask(vk::AccessFlags::HOST_READ);
            device.cmd_pipeline_barrier(
                cmd,
                vk::PipelineStageFlags::TRANSFER,
                vk::PipelineStageFlags::HOST,
                vk::DependencyFlags::empty(),
                &[to_host],
                &[],
                &[],
            );
        })?;
        let mapped = f.readback.mapped();
        let pixels = mapped[..image_bytes as usize].to_vec();
        let counters: Vec<u32> = bytemuck::pod_collect_to_vec(
            &mapped[image_bytes as usize..image_bytes as usize + COUNTER_SLOTS as usize * 4],
        );
        Ok((pixels, counters))
    }
}
