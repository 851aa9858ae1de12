//! The frame: project -> depth order -> prefix sum -> emit -> sort -> tile ranges -> rasterize
//! -> write target, recorded into one command buffer with no host round trip inside it.
//!
//! [`Renderer::record`] is the engine-facing entry point: it only records into the caller's
//! command buffer. [`Renderer::render`] is the headless one the CLI uses, built on `record`.

use ash::vk;

use crate::camera::{tile_grid, Camera};
use crate::clip::{Clip, ClipMode, ClipRegion};
use crate::constants::{CLIP_MODE_RARA, COUNTER_INTERSECTIONS, COUNTER_SLOTS};
use crate::depth::{DepthMode, DepthOutput, DepthSource, DepthTarget, DepthTest};
use crate::error::{Error, Result};
pub use crate::frame::FrameStats;
use crate::frame::{FrameMemory, FrameSlot, ObjectBuffers};
pub use crate::gpu_scene::GpuScene;
use crate::gpu_types::{GpuClipParams, GpuFrameParams, CUTOFF_RECORD_BYTES};
use crate::objects::ObjectTransform;
use crate::options::{RenderOptions, Tracer};
use crate::raytrace::tiles::RayTiles;
use crate::raytrace::tracer::{ObjectRegions, RayTracer};
use crate::scene::Scene;
use crate::stages::cutoff_tiles::CutoffTiles;
use crate::stages::depth::DepthStages;
use crate::stages::depth_order::{DepthOrder, DEPTH_ORDER_BUFFER};
use crate::stages::emit::Emit;
use crate::stages::objects::{GpuObjectParams, ObjectTransformStage};
use crate::stages::prefix_sum::PrefixSum;
use crate::stages::project::{ObjectClipRanges, PlaneSlots, Project};
use crate::stages::rasterize::{MassEnds, RasterLayout, Rasterize};
use crate::stages::sort::{tile_key_bits, PairForm, RadixSort, SortForms, TILE_SORT_LABELS};
use crate::stages::tile_lists::{TileLists, TileListsLayout};
use crate::stages::tile_ranges::TileRanges;
use crate::stages::write_target::WriteTarget;
use crate::stages::{FrameAddresses, FrameRecording, FrameTexelsLayout};
use crate::target::{Composite, Target, TargetFormat};
use crate::timing::PassTimer;
use crate::vk::buffer::copy_to_host;
use crate::vk::{compute_barrier, Buffer, Context, MemoryLocation};

/// The intermediate buffers of the last rendered frame, read back for tests and debugging.
#[derive(Clone, Debug, Default)]
pub struct Intermediates {
    /// Output of project, per Gaussian.
    pub splats: Vec<crate::gpu_types::GpuProjectedSplat>,
    /// Tiles touched, per Gaussian.
    pub tiles_touched: Vec<u32>,
    /// The drawn Gaussians' indices in depth order (ties: index order); empty unless the
    /// renderer keeps it ([`Renderer::set_keep_depth_order`]).
    pub depth_order: Vec<u32>,
    /// Exclusive prefix sum of tiles touched, in depth order: each drawn Gaussian's first
    /// pair.
    pub offsets: Vec<u32>,
    /// Sorted keys (tile ids).
    pub keys: Vec<u32>,
    /// Each sorted key's pair value: the splat index (bits of
    /// [`crate::constants::PAIR_INDEX_MASK`]), the blocks of the tile its footprint reaches
    /// ([`crate::constants::PAIR_BLOCKS_SHIFT`]) and [`crate::constants::PAIR_WEIGHTED`].
    pub values: Vec<u32>,
    /// `[start, end)` per tile.
    pub ranges: Vec<[u32; 2]>,
}

/// Renders scenes with the GPU pipeline: holds the kernels of every stage and nothing of any
/// one frame, so one renderer draws any scene of its device into any number of
/// [`FrameSlot`]s.
pub struct Renderer {
    ctx: Context,
    project: Project,
    prefix_sum: PrefixSum,
    depth_order: DepthOrder,
    emit: Emit,
    cutoff_tiles: CutoffTiles,
    /// Whether frames that allow it classify cutoff pairs by tile (on unless switched off,
    /// by [`Renderer::set_cutoff_tile_classes`] or `RARA_CUTOFF_TILES=off`).
    cutoff_tile_classes: bool,
    tile_lists: TileLists,
    /// Whether frames that allow it split the tiles by rasterize kernel (on unless switched
    /// off).
    tile_lists_on: bool,
    sort: RadixSort,
    tile_ranges: TileRanges,
    rasterize: Rasterize,
    write_target: WriteTarget,
    /// The depth test's and depth output's kernels (SPEC section 9).
    depth: DepthStages,
    /// The object-transform kernel of several objects in one frame (SPEC section 9).
    objects: ObjectTransformStage,
    timer: PassTimer,
    /// Whether frames copy their depth order aside for [`Renderer::intermediates`]
    /// ([`Renderer::set_keep_depth_order`]).
    keep_depth_order: bool,
    /// The slot and rgba8 image (+ host copy) of the headless path, [`Renderer::render`].
    headless: Option<HeadlessFrame>,
    /// The ray tracer, made on the first frame that asks for it.
    ray_tracer: std::sync::OnceLock<RayTracer>,
    /// The tile lists of its camera rays, made on the first frame that asks for them.
    ray_tiles: std::sync::OnceLock<RayTiles>,
    /// The layout of the frame's texel views, for the kernels that read through them (with the
    /// strips rasterizer, i.e. on CPU drivers).
    _frame_texels_layout: Option<FrameTexelsLayout>,
}

/// What a headless frame draws: one scene, or several objects ([`Renderer::render_objects`]).
#[derive(Clone, Copy)]
enum Drawn<'a> {
    Scene(&'a GpuScene),
    Objects(&'a [SceneObject<'a>]),
}

/// What [`Renderer::render`] renders into and reads back from.
struct HeadlessFrame {
    slot: FrameSlot,
    /// Image of `width` x `height` rgba8 pixels, and its host-visible copy.
    image: Option<(u32, u32, Buffer, Buffer)>,
    /// The depth output of [`Renderer::render_with_depth`] (f32 per pixel), and its copy.
    depth: Option<(u32, u32, Buffer, Buffer)>,
}

impl Renderer {
    /// Builds every kernel of the pipeline, with the rasterizer layout that suits the device
    /// ([`RasterLayout::for_device`]).
    pub fn new(ctx: &Context) -> Result<Self> {
        Self::with_raster_layout(ctx, RasterLayout::for_device(ctx))
    }

    /// Builds every kernel of the pipeline with the given rasterizer layout. The strips layout
    /// needs texel buffers of [`crate::stages::CPU_LAYOUT_MIN_TEXELS`] texels and is refused
    /// ([`crate::Error::MissingRequirement`]) on a device with smaller ones.
    pub fn with_raster_layout(ctx: &Context, layout: RasterLayout) -> Result<Self> {
        if layout == RasterLayout::Strips {
            crate::stages::check_cpu_layout(ctx, "strips rasterizer", "pixel-per-invocation")?;
        }
        // CPU drivers (the strips layout) read through texel views wherever that pays.
        let frame_texels_layout = match layout {
            RasterLayout::Strips => Some(FrameTexelsLayout::new(ctx)?),
            RasterLayout::PixelPerInvocation => None,
        };
        let texels = frame_texels_layout.as_ref().map(|l| l.raw);
        let sort = RadixSort::new(ctx)?;
        // Emit writes each pair as one 64-bit word where the sort takes packed pairs (CPU
        // drivers): on those every store is a loop over the SIMD lanes.
        let packed_pairs = texels.is_some() && sort.sorts_packed();
        Ok(Renderer {
            ctx: ctx.clone(),
            project: Project::new(ctx, texels)?,
            prefix_sum: PrefixSum::new(ctx)?,
            depth_order: DepthOrder::new(ctx, texels)?,
            emit: Emit::new(ctx, texels, packed_pairs)?,
            cutoff_tiles: CutoffTiles::new(ctx, texels, packed_pairs)?,
            // `RARA_CUTOFF_TILES=off`: for profiling the classes' worth on a device.
            cutoff_tile_classes: std::env::var("RARA_CUTOFF_TILES").as_deref() != Ok("off"),
            tile_lists: TileLists::new(ctx)?,
            tile_lists_on: true,
            sort,
            tile_ranges: TileRanges::new(ctx, texels)?,
            rasterize: Rasterize::new(ctx, layout, texels)?,
            write_target: WriteTarget::new(ctx, texels)?,
            depth: DepthStages::new(ctx)?,
            objects: ObjectTransformStage::new(ctx)?,
            timer: PassTimer::new(ctx)?,
            keep_depth_order: false,
            headless: None,
            ray_tracer: std::sync::OnceLock::new(),
            ray_tiles: std::sync::OnceLock::new(),
            _frame_texels_layout: frame_texels_layout,
        })
    }

    /// Replaces the pass timer of [`Renderer::render`], e.g. with one that writes into an
    /// engine's query pool ([`PassTimer::with_engine_pool`]). Returns the old one.
    pub fn set_timer(&mut self, timer: PassTimer) -> PassTimer {
        std::mem::replace(&mut self.timer, timer)
    }

    /// Makes later frames copy their depth order aside (4 B per Gaussian and a copy), for
    /// [`Intermediates::depth_order`]: the tile pairs' sort overwrites it within the frame,
    /// since the two sorts share their buffers. Off by default; for tests and debugging.
    pub fn set_keep_depth_order(&mut self, on: bool) {
        self.keep_depth_order = on;
    }

    /// Switches the per-tile classes of cutoff pairs ([`crate::stages::cutoff_tiles`]) on (the
    /// default) or off. They change no pixel by more than rounding and only save work; off is
    /// for profiling what they save and for testing that they change nothing. The environment
    /// variable `RARA_CUTOFF_TILES=off` switches them off in every new renderer (the CLI's
    /// too).
    pub fn set_cutoff_tile_classes(&mut self, on: bool) {
        self.cutoff_tile_classes = on;
    }

    /// Switches the split of the tiles by rasterize kernel ([`crate::stages::tile_lists`]) on
    /// (the default) or off. It applies to the strips rasterizer under rara clipping with
    /// per-tile classes, changes no pixel and only saves work; off is for profiling and
    /// testing.
    pub fn set_tile_lists(&mut self, on: bool) {
        self.tile_lists_on = on;
    }

    /// The rasterizer layout the renderer was built with.
    pub fn raster_layout(&self) -> RasterLayout {
        self.rasterize.layout()
    }

    /// The context the renderer was made with.
    pub fn context(&self) -> &Context {
        &self.ctx
    }

    /// Device memory of the headless path of [`Renderer::render`]: its frame slot, plus its
    /// rgba8 target and host copy (counted in `per_pixel`). Zero before the first frame.
    pub fn headless_memory(&self) -> FrameMemory {
        let Some(h) = &self.headless else {
            return FrameMemory::default();
        };
        let mut m = h.slot.memory();
        if let Some((_, _, image, readback)) = &h.image {
            m.per_pixel += image.size + readback.size;
        }
        m
    }

    /// Uploads a scene ([`GpuScene::new`]).
    pub fn upload(&self, scene: &Scene) -> Result<GpuScene> {
        GpuScene::new(&self.ctx, scene)
    }

    /// Renders `scene` from `camera` on the context's queue and waits: the headless path (CLI,
    /// tests). It records with [`Renderer::record`] into a buffer target of its own and reads
    /// the image back; a frame that did not fit its slot grows the slot and is rendered again.
    pub fn render(
        &mut self,
        scene: &GpuScene,
        camera: &Camera,
        options: &RenderOptions,
    ) -> Result<(image::RgbaImage, FrameStats)> {
        self.render_inner(Drawn::Scene(scene), camera, options, None)
            .map(|(image, _, stats)| (image, stats))
    }

    /// [`Renderer::render`] of several objects in one frame ([`Renderer::record_objects`]).
    pub fn render_objects(
        &mut self,
        objects: &[SceneObject],
        camera: &Camera,
        options: &RenderOptions,
    ) -> Result<(image::RgbaImage, FrameStats)> {
        self.render_inner(Drawn::Objects(objects), camera, options, None)
            .map(|(image, _, stats)| (image, stats))
    }

    /// [`Renderer::render`], also reading back the depth output of `mode` (SPEC section 9):
    /// one f32 view depth per pixel, rows top first, `f32::INFINITY` where there is none.
    pub fn render_with_depth(
        &mut self,
        scene: &GpuScene,
        camera: &Camera,
        options: &RenderOptions,
        mode: DepthMode,
    ) -> Result<(image::RgbaImage, Vec<f32>, FrameStats)> {
        self.render_inner(Drawn::Scene(scene), camera, options, Some(mode))
    }

    fn render_inner(
        &mut self,
        scene: Drawn,
        camera: &Camera,
        options: &RenderOptions,
        depth_mode: Option<DepthMode>,
    ) -> Result<(image::RgbaImage, Vec<f32>, FrameStats)> {
        camera.validate()?;
        let mut headless = match self.headless.take() {
            Some(h) => h,
            None => HeadlessFrame {
                slot: FrameSlot::new(&self.ctx)?,
                image: None,
                depth: None,
            },
        };
        let result = self.render_headless(&mut headless, scene, camera, options, depth_mode);
        self.headless = Some(headless);
        result
    }

    /// Sets the ray tracer's k-buffer (hits collected per traversal pass, one of
    /// [`crate::raytrace::tracer::TRACE_KS`]; the default is [`crate::raytrace::tracer::default_k`]).
    /// It changes no pixel, only speed and the per-ray memory.
    pub fn set_trace_k(&mut self, k: u32) -> Result<()> {
        self.ray_tracer = std::sync::OnceLock::from(RayTracer::with_k(&self.ctx, k)?);
        Ok(())
    }

    /// Builds the ray tracer's BVH of `scene` once, on the host, for a scene that does not
    /// move ([`crate::raytrace::still_bvh`]): ray-traced frames of it then walk that tree
    /// instead of building an LBVH on the GPU, the same image with fewer nodes per ray. The
    /// scene drops it when its Gaussians are replaced.
    pub fn build_still_bvh(
        &self,
        scene: &mut GpuScene,
    ) -> Result<crate::raytrace::still_bvh::StillBvhStats> {
        let q = crate::options::RayTraceOptions::default().q as f32;
        self.ray_tracer()?.build_still_bvh(&self.ctx, scene, q)
    }

    /// The ray tracer's kernels, built by the first frame that asks for them.
    fn ray_tracer(&self) -> Result<&RayTracer> {
        if let Some(t) = self.ray_tracer.get() {
            return Ok(t);
        }
        let tracer = RayTracer::new(&self.ctx)?;
        Ok(self.ray_tracer.get_or_init(|| tracer))
    }

    /// The tile lists' kernels, built now if they were not yet.
    fn ray_tiles(&self) -> Result<&RayTiles> {
        if let Some(t) = self.ray_tiles.get() {
            return Ok(t);
        }
        let tiles = RayTiles::new(&self.ctx)?;
        Ok(self.ray_tiles.get_or_init(|| tiles))
    }

    fn render_headless(
        &mut self,
        headless: &mut HeadlessFrame,
        scene: Drawn,
        camera: &Camera,
        options: &RenderOptions,
        depth_mode: Option<DepthMode>,
    ) -> Result<(image::RgbaImage, Vec<f32>, FrameStats)> {
        let (w, h) = (camera.width, camera.height);
        let image_bytes = w as u64 * h as u64 * 4;
        if depth_mode.is_some()
            && !headless
                .depth
                .as_ref()
                .is_some_and(|d| d.0 == w && d.1 == h)
        {
            headless.depth = None;
            headless.depth = Some((
                w,
                h,
                Buffer::new(&self.ctx, "depth f32", image_bytes, MemoryLocation::GpuOnly)?,
                Buffer::new(
                    &self.ctx,
                    "depth readback",
                    image_bytes,
                    MemoryLocation::GpuToCpu,
                )?,
            ));
        }
        if !headless
            .image
            .as_ref()
            .is_some_and(|i| i.0 == w && i.1 == h)
        {
            headless.image = None; // free the old buffers first
            let image = Buffer::new(
                &self.ctx,
                "image rgba8",
                image_bytes,
                MemoryLocation::GpuOnly,
            )?;
            let readback = Buffer::new(
                &self.ctx,
                "image readback",
                image_bytes,
                MemoryLocation::GpuToCpu,
            )?;
            headless.image = Some((w, h, image, readback));
        }
        let (_, _, image, readback) = headless.image.as_ref().unwrap();
        let target = Target::Buffer {
            buffer: image.raw,
            offset: 0,
            format: TargetFormat::Rgba8Unorm,
            width: w,
            height: h,
        };
        let mut options = options.clone();
        options.composite = Composite::Background;
        let depth = depth_mode.map(|mode| {
            let (_, _, buffer, readback) = headless.depth.as_ref().expect("made above");
            options.depth_output = Some(DepthOutput {
                mode,
                target: DepthTarget::Buffer {
                    buffer: buffer.raw,
                    offset: 0,
                },
            });
            (buffer, readback)
        });
        let mut timer = std::mem::replace(&mut self.timer, PassTimer::labels_only(&self.ctx));
        let mut rerenders = 0;
        let result = loop {
            let start = std::time::Instant::now();
            let recorded = self.ctx.run_commands(|cmd| -> Result<()> {
                match scene {
                    Drawn::Scene(scene) => self.record(
                        cmd,
                        &mut headless.slot,
                        scene,
                        camera,
                        &options,
                        &target,
                        Some(&mut timer),
                    )?,
                    Drawn::Objects(objects) => self.record_objects(
                        cmd,
                        &mut headless.slot,
                        objects,
                        camera,
                        &options,
                        &target,
                        Some(&mut timer),
                    )?,
                }
                copy_to_host(&self.ctx, cmd, image, readback, image_bytes);
                if let Some((buffer, readback)) = depth {
                    copy_to_host(&self.ctx, cmd, buffer, readback, image_bytes);
                }
                Ok(())
            });
            if let Err(e) = recorded.and_then(|r| r) {
                break Err(e);
            }
            let wall_ms = start.elapsed().as_secs_f64() * 1e3;
            let mut stats = match headless.slot.stats() {
                Ok(s) => s,
                Err(e) => break Err(e),
            };
            if !stats.complete {
                rerenders += 1;
                continue;
            }
            stats.passes = match timer.read() {
                Ok(p) => p,
                Err(e) => break Err(e),
            };
            stats.gpu_ms = stats.passes.iter().map(|p| p.ms).sum();
            stats.wall_ms = wall_ms;
            stats.rerenders = rerenders;
            let pixels = readback.mapped()[..image_bytes as usize].to_vec();
            let image = image::RgbaImage::from_raw(w, h, pixels).expect("image size");
            let depths = depth.map_or_else(Vec::new, |(_, readback)| {
                bytemuck::pod_collect_to_vec(&readback.mapped()[..image_bytes as usize])
            });
            break Ok((image, depths, stats));
        };
        self.timer = timer;
        result
    }

    /// Reads back the intermediate buffers of the last frame [`Renderer::render`] rendered
    /// (of `scene`, which has `stats.intersections` pairs). Slow; for tests and debugging.
    pub fn intermediates(&self, scene: &GpuScene, stats: &FrameStats) -> Result<Intermediates> {
        let f = self
            .headless
            .as_ref()
            .and_then(|h| h.slot.resources.as_ref())
            .expect("render a frame first");
        let n = scene.count as usize;
        let drawn = stats.visible as usize;
        let m = stats.intersections as usize;
        let (gx, gy) = tile_grid(f.width, f.height);
        Ok(Intermediates {
            splats: f.splats.download_as(n)?,
            tiles_touched: f.tiles_touched.download_as(n)?,
            depth_order: match &f.depth_order_copy {
                Some(copy) => copy.download_as(drawn)?,
                None => Vec::new(),
            },
            offsets: f.slots.download_as(drawn)?,
            keys: f.sort.keys[f.sorted].download_as(m)?,
            values: f.sort.values[f.sorted].download_as(m)?,
            ranges: f.ranges.download_as((gx * gy) as usize)?,
        })
    }

    /// Records one frame of `scene` seen by `camera` into the caller's command buffer `cmd`,
    /// writing `target`; submits nothing and waits for nothing. The frame's working buffers
    /// are `slot`'s ([`FrameSlot`]); pass timings go to `timings` when given (read them with
    /// [`PassTimer::read`] after the submission completed), and every pass gets a
    /// `VK_EXT_debug_utils` label when the instance has the extension.
    ///
    /// # Synchronisation contract
    /// - `cmd` is in the recording state, outside a render pass, from a pool of a queue family
    ///   with compute support. Compute pipelines and descriptor sets bound by the caller are
    ///   not preserved; the caller rebinds its own afterwards.
    /// - **First access to the target**: the write-target pass, stage
    ///   `VK_PIPELINE_STAGE_COMPUTE_SHADER_BIT`, access `VK_ACCESS_SHADER_WRITE_BIT`, plus
    ///   `VK_ACCESS_SHADER_READ_BIT` with [`Composite::Over`]. **Last access**: the same pass
    ///   and accesses. The target is not touched before that pass. (On CPU drivers, a frame
    ///   drawn over the background into a [`TargetFormat::Rgba8Unorm`] buffer, without depth,
    ///   in one rasterizer round, has no write-target pass: the rasterize pass writes the
    ///   target, with the same stage and access.)
    /// - **Image layout**: an image target must be in `VK_IMAGE_LAYOUT_GENERAL` when the
    ///   commands execute, and is left in it.
    /// - **Depth test** ([`RenderOptions::depth_test`]): the engine's depth image or buffer is
    ///   read by the "depth prepare" pass only (first and last access), stage
    ///   `COMPUTE_SHADER`, access `SHADER_READ_BIT`; an image in the layout its
    ///   [`crate::DepthSource::Image`] names (`DEPTH_STENCIL_READ_ONLY_OPTIMAL`,
    ///   `DEPTH_READ_ONLY_OPTIMAL`, `SHADER_READ_ONLY_OPTIMAL` or `GENERAL`), left in it. The
    ///   caller's barrier before: from its depth writes (`LATE_FRAGMENT_TESTS`,
    ///   `DEPTH_STENCIL_ATTACHMENT_WRITE`) to `COMPUTE_SHADER` reads, with the transition.
    /// - **Depth output** ([`RenderOptions::depth_output`]): written by the "write depth" pass
    ///   only, after the write-target pass, stage `COMPUTE_SHADER`, access `SHADER_WRITE_BIT`;
    ///   an `R32_SFLOAT` image in `GENERAL`.
    /// - **The caller's barriers**: before, one that makes the caller's earlier writes to the
    ///   target (a clear, a draw) available to `COMPUTE_SHADER` reads/writes and transitions an
    ///   image to `GENERAL`; after, one from `COMPUTE_SHADER` / `SHADER_WRITE` to whatever
    ///   next uses the target (a blit, a fragment shader, a present). rara's barriers between its
    ///   own passes are global memory barriers from compute/transfer to compute, transfer
    ///   and indirect reads; they order nothing of the caller's that is not compute or transfer.
    /// - **Frames in flight**: `slot`'s previous frame must have completed on the GPU before
    ///   this call (the caller waits on the fence of the submission that used it), and a slot
    ///   is recorded at most once per submission. Several slots, renderers and scenes may be in
    ///   flight at once; `scene` must stay alive until the frames that read it completed.
    /// - After completion, [`FrameSlot::stats`] gives the frame's counters.
    #[allow(clippy::too_many_arguments)]
    pub fn record(
        &self,
        cmd: vk::CommandBuffer,
        slot: &mut FrameSlot,
        scene: &GpuScene,
        camera: &Camera,
        options: &RenderOptions,
        target: &Target,
        timings: Option<&mut PassTimer>,
    ) -> Result<()> {
        self.record_frame(cmd, slot, scene, camera, options, target, timings, None)
    }

    /// [`Renderer::record`], and with `object_clips` a frame of several objects clipped by
    /// regions of their own ([`Renderer::record_objects`]).
    #[allow(clippy::too_many_arguments)]
    fn record_frame(
        &self,
        cmd: vk::CommandBuffer,
        slot: &mut FrameSlot,
        scene: &GpuScene,
        camera: &Camera,
        options: &RenderOptions,
        target: &Target,
        timings: Option<&mut PassTimer>,
        object_clips: Option<&ObjectClipsFrame>,
    ) -> Result<()> {
        camera.validate()?;
        options.clip.validate()?;
        let (w, h) = (camera.width, camera.height);
        let buffer_target = self.buffer_target_address(target, (w, h))?;
        if let Some(test) = &options.depth_test {
            test.projection.validate()?;
        }
        if options.tracer.is_ray() {
            return self.record_trace(
                cmd,
                slot,
                scene,
                camera,
                options,
                (target, buffer_target),
                timings,
                object_clips,
            );
        }
        let (gx, gy) = tile_grid(w, h);
        let rara = match object_clips {
            Some(o) => o.rara,
            None => options.clip.effective_mode() == ClipMode::Rara,
        };
        if rara && object_clips.is_some() {
            self.rasterize.prepare_object_clips(&self.ctx)?;
        }
        self.rasterize.check_scene(&self.ctx, scene)?;
        let (_capacity, rounds) = slot.prepare(
            &self.prefix_sum,
            &self.sort,
            (w, h),
            scene.count,
            rara,
            self.rasterize.pair_limit(&self.ctx),
        )?;
        let image_set = match *target {
            Target::Image { view, .. } => Some(slot.image_target_set(view)?),
            Target::Buffer { .. } => None,
        };
        let depth = self.depth_bindings(slot, options)?;
        let sorted_index = self.sort.passes_for(tile_key_bits(w, h)) as usize % 2;
        slot.resources.as_mut().unwrap().sorted = sorted_index;
        // The texel views that most kernels read through on CPU drivers (project, depth order,
        // emit, tile ranges, rasterize).
        let frame_texels = match self.rasterize.layout() {
            RasterLayout::Strips => Some(slot.frame_texels_set(sorted_index, scene)?),
            RasterLayout::PixelPerInvocation => None,
        };
        if self.keep_depth_order {
            slot.keep_depth_order(scene.count)?;
        }
        let f = slot.resources.as_ref().unwrap();
        let counters_readback = slot.counters_readback();

        let clip_params = options.clip.to_gpu();
        let params = frame_params(camera, options, scene, f.capacity);
        // Only rara frames write or read side records; other frames pass a null address.
        let cutoffs_address = if rara {
            f.cutoffs.as_ref().map_or(0, |b| b.address)
        } else {
            0
        };
        // Cutoff pairs are classified by tile only under rara clipping by planes with the mass
        // weight (stages::cutoff_tiles), and by the frame's one region.
        let cutoff_pairs = if self.cutoff_tile_classes
            && options.clip.classifies_cutoff_tiles()
            && object_clips.is_none()
        {
            f.cutoff_pairs.as_ref()
        } else {
            None
        };
        // With the strips rasterizer, such frames run the weighted kernel only over the tiles
        // that hold a weighted pair (stages::tile_lists).
        let tile_lists = (cutoff_pairs.is_some()
            && self.tile_lists_on
            && self.rasterize.layout() == RasterLayout::Strips)
            .then_some((
                &f.tile_lists,
                TileListsLayout {
                    tile_count: gx * gy,
                },
            ));
        // A frame of one round without depth drawn over the background into an RGBA8 buffer:
        // the strips rasterizer (CPU drivers) writes the target itself, and the frame has no
        // write-target pass (stages::rasterize, `WRITES_TARGET`). A CPU driver stores to a
        // buffer one lane at a time: the per-pixel state was four words a pixel, which write
        // target read back to store the fifth.
        let rasterizer_writes_target = (self.rasterize.writes_targets()
            && rounds == 1
            && depth.is_none()
            && !(rara && object_clips.is_some())
            && matches!(options.composite, Composite::Background)
            && matches!(
                target,
                Target::Buffer {
                    format: TargetFormat::Rgba8Unorm,
                    ..
                }
            ))
        .then_some(buffer_target);
        // The kernels this frame runs, each built when a frame first needs it.
        let listing = self.project.listing(rara, object_clips.is_some());
        let plane_slots = PlaneSlots::for_frame(&clip_params, object_clips.is_some());
        let mass_ends = MassEnds::for_region(&clip_params);
        self.project.prepare(scene, listing, plane_slots)?;
        if !(rara && object_clips.is_some()) {
            self.rasterize.prepare(
                rara.then_some(options.clip.weight),
                depth.is_some(),
                tile_lists.is_some(),
                (scene.may_be_flat, mass_ends),
                rasterizer_writes_target.is_some(),
            )?;
        }
        let ctx = &self.ctx;
        let mut labels_only;
        let timer: &mut PassTimer = match timings {
            Some(t) => t,
            None => {
                labels_only = PassTimer::labels_only(ctx);
                &mut labels_only
            }
        };
        unsafe {
            let device = ctx.device();
            timer.begin_frame(cmd);
            device.cmd_update_buffer(cmd, f.params.raw, 0, bytemuck::bytes_of(&params));
            device.cmd_update_buffer(cmd, f.clip_params.raw, 0, bytemuck::bytes_of(&clip_params));
            device.cmd_fill_buffer(cmd, f.counters.raw, 0, vk::WHOLE_SIZE, 0);
            device.cmd_fill_buffer(cmd, f.ranges.raw, 0, vk::WHOLE_SIZE, 0);
        }
        if let Some((buffer, layout)) = &tile_lists {
            self.tile_lists.record_reset(ctx, cmd, buffer, layout);
        }
        compute_barrier(ctx, cmd);

        // The stages, in frame order; each records its passes, push constants and barriers.
        let mut rec = FrameRecording {
            ctx,
            cmd,
            timer,
            texels: frame_texels,
            at: FrameAddresses {
                params: f.params.address,
                // With several clipped objects, the array of their regions.
                clip: object_clips.map_or(f.clip_params.address, |o| o.regions),
                counters: f.counters.address,
                splats: f.splats.address,
                tiles_touched: f.tiles_touched.address,
                slots: f.slots.address,
                cutoffs: cutoffs_address,
                // After the records (FrameSlot::prepare sizes the buffer for both); the records'
                // pass writes them (CPU drivers).
                cutoff_bounds: if cutoff_pairs.is_some() && listing.has_records_pass() {
                    cutoffs_address + scene.count as u64 * CUTOFF_RECORD_BYTES
                } else {
                    0
                },
                ranges: f.ranges.address,
                state: f.state.address,
            },
            size: (w, h),
            grid: (gx, gy),
        };
        let scan = (&self.prefix_sum, &f.slots_scan);
        // Rara frames list their cutoff Gaussians in the cutoff-pairs buffer, and the pass
        // "cutoff records" after project writes their records (emit later overwrites the list
        // with the pairs' starts); on the GPU layout, frames of one region have project write
        // the records itself (CutoffListing::Writes).
        let records_list = if listing.has_records_pass() {
            f.cutoff_pairs.as_ref()
        } else {
            None
        };
        self.project.record(
            &mut rec,
            scene,
            object_clips.map(|o| &o.project),
            listing,
            plane_slots,
            records_list,
        );
        self.depth_order
            .record_sorted(&mut rec, scene.count, scan, &self.sort, &f.sort);
        let depth_order = f.sort.values[DEPTH_ORDER_BUFFER].address;
        if let Some(copy) = &f.depth_order_copy {
            rec.copy_aside(&f.sort.values[DEPTH_ORDER_BUFFER], copy);
        }
        self.depth_order
            .record_first_pairs(&mut rec, scene.count, depth_order, scan);
        // Emit writes the pairs into sort buffer 0 and keeps its rounds' progress in the depth
        // sort's keys, which nothing reads once the order is known.
        let progress = f.sort.keys[DEPTH_ORDER_BUFFER].address;
        self.emit.record(
            &mut rec,
            scene.count,
            depth_order,
            &f.sort,
            cutoff_pairs,
            progress,
        )?;
        if let Some(pairs) = cutoff_pairs {
            let flags = tile_lists.map_or(0, |(b, _)| b.address + TileListsLayout::FLAGS);
            self.cutoff_tiles.record(
                &mut rec,
                pairs,
                &f.sort,
                flags,
                // Without a records' pass, no dispatch arguments over the records.
                (
                    (!listing.has_records_pass()).then_some(scene.count),
                    scene.may_be_flat,
                ),
            )?;
        }
        if let Some((buffer, layout)) = &tile_lists {
            self.tile_lists.record(&mut rec, buffer, layout)?;
        }
        let forms = SortForms {
            input: self.emit.pair_form(),
            output: PairForm::Split,
        };
        let sorted = self.sort.record_forms(
            ctx,
            cmd,
            &f.sort,
            rec.at.counter(COUNTER_INTERSECTIONS),
            tile_key_bits(w, h),
            forms,
            &TILE_SORT_LABELS,
            Some(&mut *rec.timer),
        );
        debug_assert_eq!(sorted, sorted_index);
        self.tile_ranges.record(&mut rec, &f.sort, sorted);
        let depth_buffers = depth.as_ref().map(|_| {
            let (sums, limit) = f.depth.as_ref().expect("prepare_depth");
            (sums.address, limit.address)
        });
        let mut depth_limit = 0;
        if let (Some(d), Some((_, limit))) = (&depth, depth_buffers) {
            if let (Some(test), Some(source)) = (&options.depth_test, d.source) {
                self.depth
                    .record_prepare(&mut rec, source, &test.projection, limit)?;
                depth_limit = limit;
            }
        }
        let cutoff_weight = rara.then_some(options.clip.weight);
        self.rasterize.record(
            &mut rec,
            (&f.sort, sorted),
            rounds,
            (cutoff_weight, scene.may_be_flat, mass_ends),
            tile_lists,
            depth_buffers.map(|(sums, _)| (sums, depth_limit)),
            object_clips
                .filter(|_| rara)
                .map(|o| o.project.cutoff_regions),
            rasterizer_writes_target,
        );
        if rasterizer_writes_target.is_none() {
            self.record_write_target(&mut rec, options, (target, image_set, buffer_target))?;
        }
        if let (Some(d), Some((sums, _)), Some(output)) =
            (&depth, depth_buffers, &options.depth_output)
        {
            self.depth
                .record_write(&mut rec, sums, output.mode, d.target.expect("an output"))?;
        }

        // The counters, for FrameSlot::stats once the frame completed.
        copy_to_host(
            ctx,
            cmd,
            &f.counters,
            counters_readback,
            COUNTER_SLOTS as u64 * 4,
        );
        Ok(())
    }
}

/// One view of [`Renderer::record_views`]: a camera, the target it is drawn into (the camera's
/// size) and the frame slot that holds its working buffers.
pub struct View<'a> {
    /// The view's camera.
    pub camera: Camera,
    /// Where it is drawn.
    pub target: Target,
    /// Its working buffers (one slot per view and frame in flight).
    pub slot: &'a mut FrameSlot,
    /// Its pass timings, when wanted.
    pub timer: Option<&'a mut PassTimer>,
    /// Its depth test against the engine's depth of this view ([`RenderOptions::depth_test`]).
    pub depth_test: Option<DepthTest>,
    /// Its depth output ([`RenderOptions::depth_output`]).
    pub depth_output: Option<DepthOutput>,
}

impl Renderer {
    /// Records several views of one scene (stereo eyes, cube faces) into `cmd`, each exactly as
    /// [`Renderer::record`] records it alone, one after the other. The views share the scene on
    /// the device and the renderer's kernels; every stage from project on depends on the camera
    /// (the projection, the SH colour's view direction, the depth order, the tiles), so each
    /// view has its own slot and passes. `options` applies to every view but for the depth
    /// test and the depth output, which each view names for itself (those of `options` must be
    /// `None`). The synchronisation contract is `record`'s, per view and target.
    pub fn record_views(
        &self,
        cmd: vk::CommandBuffer,
        scene: &GpuScene,
        views: &mut [View],
        options: &RenderOptions,
    ) -> Result<()> {
        if options.depth_test.is_some() || options.depth_output.is_some() {
            return Err(Error::InvalidInput(
                "record_views: a depth test or depth output names one view's image; give each \
                 view its own (View::depth_test, View::depth_output)"
                    .into(),
            ));
        }
        let mut per_view = options.clone();
        for view in views.iter_mut() {
            per_view.depth_test = view.depth_test;
            per_view.depth_output = view.depth_output;
            self.record(
                cmd,
                view.slot,
                scene,
                &view.camera,
                &per_view,
                &view.target,
                view.timer.as_deref_mut(),
            )?;
        }
        Ok(())
    }
}

/// One object of [`Renderer::record_objects`]: a scene, where it stands in the world, and
/// optionally a clip region of its own.
#[derive(Clone)]
pub struct SceneObject<'a> {
    /// The object's Gaussians (f32 SH coefficients).
    pub scene: &'a GpuScene,
    /// Its rigid transform and uniform scale.
    pub transform: ObjectTransform,
    /// Its clip region in its own frame (SPEC section 9), which moves with it; `None` clips
    /// it by the frame's region (`RenderOptions::clip.region`, world space). The frame's clip
    /// gives the mode, weight and band of every region.
    pub clip: Option<ClipRegion>,
}

impl<'a> SceneObject<'a> {
    /// The object `scene` at `transform`, clipped by the frame's region.
    pub fn new(scene: &'a GpuScene, transform: ObjectTransform) -> Self {
        SceneObject {
            scene,
            transform,
            clip: None,
        }
    }

    /// The same object clipped by `region`, given in the object's own frame.
    pub fn with_clip(mut self, region: ClipRegion) -> Self {
        self.clip = Some(region);
        self
    }
}

/// A frame of several objects of which some have clip regions of their own: what project and
/// rasterize need to clip each object's Gaussians by its region.
struct ObjectClipsFrame {
    /// Per object its Gaussians and region; where the cutoff records' region indices go.
    project: ObjectClipRanges,
    /// The array of the objects' regions (`GpuClipParams`, world space).
    regions: u64,
    /// Whether any region is rara-clipped (the frame then has cutoff splats to weigh).
    rara: bool,
}

impl Renderer {
    /// Records one frame of several objects (SPEC section 9), sorted and composited together
    /// as one scene: each object's Gaussians are transformed on the GPU (centres, rotations,
    /// scales, and the SH coefficients, which turn with the object) into a merged scene that
    /// `slot` keeps, which the frame's stages then draw exactly as [`Renderer::record`] draws
    /// a scene, so the frame equals the merged, pre-transformed scene rendered alone
    /// ([`crate::objects::merge`] is the CPU twin). An object with a clip region of its own
    /// ([`SceneObject::clip`], in its own frame) is clipped by that region carried into the world
    /// by its transform ([`ObjectTransform::region_to_world`]), the others by
    /// `options.clip`'s region; `options.clip` gives every region's mode, weight and band.
    /// Ray traced ([`Tracer::Ray`], [`Tracer::RayTiles`]), each hit is weighed by its
    /// Gaussian's object's region (SPEC section 7's clip weight under that region). Frames with
    /// regions of the objects' own do not classify cutoff pairs by tile. The objects' scenes must stay alive until
    /// the frame completed; the synchronisation contract is `record`'s.
    #[allow(clippy::too_many_arguments)]
    pub fn record_objects(
        &self,
        cmd: vk::CommandBuffer,
        slot: &mut FrameSlot,
        objects: &[SceneObject],
        camera: &Camera,
        options: &RenderOptions,
        target: &Target,
        timings: Option<&mut PassTimer>,
    ) -> Result<()> {
        let mut count = 0u64;
        for o in objects {
            o.transform.validate()?;
            if let Some(region) = &o.clip {
                Clip {
                    region: Some(region.clone()),
                    ..options.clip.clone()
                }
                .validate()?;
            }
            if o.scene.sh_precision() != crate::ShPrecision::F32 {
                return Err(Error::InvalidInput(
                    "several objects need f32 SH coefficients (not --sh-half) so far".into(),
                ));
            }
            count += o.scene.len() as u64;
        }
        let count = u32::try_from(count).map_err(|_| {
            Error::InvalidInput(format!(
                "{count} Gaussians in all are too many for one frame"
            ))
        })?;
        let degree = objects
            .iter()
            .map(|o| o.scene.sh_degree())
            .max()
            .unwrap_or(0);
        let params_bytes = (objects.len().max(1) * std::mem::size_of::<GpuObjectParams>()) as u64;
        let own_clips = objects.iter().any(|o| o.clip.is_some());
        let regions_bytes = (objects.len().max(1) * std::mem::size_of::<GpuClipParams>()) as u64;
        let fits = slot.objects.as_ref().is_some_and(|o| {
            o.merged.len() == count
                && o.merged.sh_degree() == degree
                && o.params.size >= params_bytes
                && (!own_clips
                    || o.clips.as_ref().is_some_and(|(r, c)| {
                        r.size >= regions_bytes && c.size >= count.max(1) as u64 * 4
                    }))
        });
        if !fits {
            slot.objects = None; // free the old buffers first
            let clips = if own_clips {
                Some((
                    Buffer::new(
                        &self.ctx,
                        "object clip regions",
                        regions_bytes,
                        MemoryLocation::GpuOnly,
                    )?,
                    Buffer::new(
                        &self.ctx,
                        "cutoff record regions",
                        count.max(1) as u64 * 4,
                        MemoryLocation::GpuOnly,
                    )?,
                ))
            } else {
                None
            };
            slot.objects = Some(ObjectBuffers {
                merged: GpuScene::for_gpu_writes(&self.ctx, count, degree)?,
                params: Buffer::new(
                    &self.ctx,
                    "object params",
                    params_bytes,
                    MemoryLocation::GpuOnly,
                )?,
                clips,
            });
        }
        let buffers = slot.objects.take().expect("made above");
        let list: Vec<(&GpuScene, ObjectTransform)> =
            objects.iter().map(|o| (o.scene, o.transform)).collect();
        self.objects
            .record(&self.ctx, cmd, &list, &buffers.merged, &buffers.params)?;
        let frame_clips = match (&buffers.clips, own_clips) {
            (Some((regions, cutoff_regions)), true) => {
                let frame =
                    self.record_object_regions(cmd, objects, options, regions, cutoff_regions);
                if options.tracer.is_ray() {
                    // The ray tracer weighs each hit by its Gaussian's object's region: the
                    // cutoff records' region indices (which project writes in rasterized
                    // frames) become per Gaussian its object's, one fill per object.
                    for (k, &(first, end, _)) in frame.project.objects.iter().enumerate() {
                        if end > first {
                            unsafe {
                                self.ctx.device().cmd_fill_buffer(
                                    cmd,
                                    cutoff_regions.raw,
                                    first as u64 * 4,
                                    (end - first) as u64 * 4,
                                    k as u32,
                                );
                            }
                        }
                    }
                }
                Some(frame)
            }
            _ => None,
        };
        let recorded = self.record_frame(
            cmd,
            slot,
            &buffers.merged,
            camera,
            options,
            target,
            timings,
            frame_clips.as_ref(),
        );
        slot.objects = Some(buffers);
        recorded
    }

    /// Writes each object's region, in world space, into `regions` (the objects without one
    /// get the frame's), and returns what project and rasterize need to clip by them.
    fn record_object_regions(
        &self,
        cmd: vk::CommandBuffer,
        objects: &[SceneObject],
        options: &RenderOptions,
        regions: &Buffer,
        cutoff_regions: &Buffer,
    ) -> ObjectClipsFrame {
        let params: Vec<GpuClipParams> = objects
            .iter()
            .map(|o| {
                let region = match &o.clip {
                    Some(own) => Some(o.transform.region_to_world(own)),
                    None => options.clip.region.clone(),
                };
                Clip {
                    region,
                    ..options.clip.clone()
                }
                .to_gpu()
            })
            .collect();
        let bytes: &[u8] = bytemuck::cast_slice(&params);
        // vkCmdUpdateBuffer takes at most 65536 bytes at a time.
        for (k, chunk) in bytes.chunks(65536).enumerate() {
            unsafe {
                self.ctx
                    .device()
                    .cmd_update_buffer(cmd, regions.raw, k as u64 * 65536, chunk);
            }
        }
        let stride = std::mem::size_of::<GpuClipParams>() as u64;
        let mut first = 0u32;
        let mut ranges = Vec::with_capacity(objects.len());
        for (k, o) in objects.iter().enumerate() {
            let end = first + o.scene.len();
            if end > first {
                ranges.push((first, end, regions.address + k as u64 * stride));
            }
            first = end;
        }
        ObjectClipsFrame {
            project: ObjectClipRanges {
                objects: ranges,
                cutoff_regions: cutoff_regions.address,
            },
            regions: regions.address,
            rara: params.iter().any(|p| p.config[0] == CLIP_MODE_RARA),
        }
    }
}

/// What a frame with a depth test or a depth output binds: the engine's depth (a buffer
/// address, or a descriptor set of its image) and the depth output's target (likewise).
struct DepthBindings {
    source: Option<(u64, Option<vk::DescriptorSet>)>,
    target: Option<(u64, Option<vk::DescriptorSet>)>,
}

impl Renderer {
    /// The device address of `buffer` plus `offset`, which must be a multiple of 4 (`what`
    /// names it in the error).
    fn buffer_address(&self, buffer: vk::Buffer, offset: u64, what: &str) -> Result<u64> {
        if offset % 4 != 0 {
            return Err(Error::InvalidInput(format!(
                "{what}'s offset must be a multiple of 4, not {offset}"
            )));
        }
        let base = unsafe {
            self.ctx
                .device()
                .get_buffer_device_address(&vk::BufferDeviceAddressInfo::default().buffer(buffer))
        };
        Ok(base + offset)
    }

    /// The depth buffers and bindings of a frame with a depth test or a depth output, made in
    /// `slot` (whose frame `prepare` has sized); `None` for a frame with neither.
    fn depth_bindings(
        &self,
        slot: &mut FrameSlot,
        options: &RenderOptions,
    ) -> Result<Option<DepthBindings>> {
        if options.depth_test.is_none() && options.depth_output.is_none() {
            return Ok(None);
        }
        slot.prepare_depth()?;
        let source = match options.depth_test {
            Some(DepthTest {
                source: DepthSource::Image { view, layout },
                ..
            }) => Some((0, Some(slot.depth_in_set(view, layout)?))),
            Some(DepthTest {
                source: DepthSource::Buffer { buffer, offset },
                ..
            }) => Some((
                self.buffer_address(buffer, offset, "the depth test's buffer")?,
                None,
            )),
            None => None,
        };
        let target = match options.depth_output {
            Some(DepthOutput {
                target: DepthTarget::Image { view },
                ..
            }) => Some((0, Some(slot.depth_out_set(view)?))),
            Some(DepthOutput {
                target: DepthTarget::Buffer { buffer, offset },
                ..
            }) => Some((
                self.buffer_address(buffer, offset, "the depth output's buffer")?,
                None,
            )),
            None => None,
        };
        Ok(Some(DepthBindings { source, target }))
    }

    /// Checks that `target` is `size` and returns a buffer target's device address (0 for an
    /// image target).
    fn buffer_target_address(&self, target: &Target, (w, h): (u32, u32)) -> Result<u64> {
        if target.size() != (w, h) {
            return Err(Error::InvalidInput(format!(
                "the target is {}x{} but the camera renders {w}x{h}",
                target.size().0,
                target.size().1
            )));
        }
        Ok(match *target {
            Target::Buffer { buffer, offset, .. } => {
                if offset % 4 != 0 {
                    return Err(Error::InvalidInput(format!(
                        "a buffer target's offset must be a multiple of 4, not {offset}"
                    )));
                }
                let base = unsafe {
                    self.ctx.device().get_buffer_device_address(
                        &vk::BufferDeviceAddressInfo::default().buffer(buffer),
                    )
                };
                base + offset
            }
            Target::Image { .. } => 0,
        })
    }

    /// [`Renderer::record`] of a ray-traced frame: with [`Tracer::RayTiles`] the tile lists of
    /// its camera rays ([`RayTiles::record`], in the slot's rasterizer buffers), with
    /// [`Tracer::Ray`] the BVH build, then the tracer's rounds ([`RayTracer::record`]) into
    /// the slot's trace buffers, then the write-target pass, under the same synchronisation
    /// contract. A frame whose tile pairs did not fit is reported incomplete as a rasterized
    /// one is, and the slot grows for the next. A frame whose rays needed
    /// more rounds than the slot recorded shows what they composited so far and is reported
    /// with [`FrameStats::complete`] `== false`; the slot records more rounds from its next
    /// frame.
    #[allow(clippy::too_many_arguments)]
    fn record_trace(
        &self,
        cmd: vk::CommandBuffer,
        slot: &mut FrameSlot,
        scene: &GpuScene,
        camera: &Camera,
        options: &RenderOptions,
        (target, buffer_target): (&Target, u64),
        timings: Option<&mut PassTimer>,
        object_clips: Option<&ObjectClipsFrame>,
    ) -> Result<()> {
        let tracer = self.ray_tracer()?;
        let (w, h) = (camera.width, camera.height);
        let image_set = match *target {
            Target::Image { view, .. } => Some(slot.image_target_set(view)?),
            Target::Buffer { .. } => None,
        };
        // The depth test: the engine's depth into view depth per pixel (the rasterizer's
        // depth prepare pass), which each ray then ends at.
        let depth = match &options.depth_test {
            Some(test) => {
                let source = match test.source {
                    DepthSource::Image { view, layout } => {
                        (0, Some(slot.depth_in_set(view, layout)?))
                    }
                    DepthSource::Buffer { buffer, offset } => (
                        self.buffer_address(buffer, offset, "the depth test's buffer")?,
                        None,
                    ),
                };
                Some((test.projection, source, slot.trace_depth_limit((w, h))?))
            }
            None => None,
        };
        let tiled = options.tracer == Tracer::RayTiles;
        let (capacity, rounds) = if tiled {
            slot.prepare_tiled_trace(
                tracer,
                (&self.prefix_sum, &self.sort),
                (w, h),
                scene.count,
                self.rasterize.pair_limit(&self.ctx),
            )?
        } else {
            (0, slot.prepare_trace(tracer, (w, h), scene.count, false)?.1)
        };
        // The depth output (SPEC sections 9 and 11): the rays' per-pixel depth sums, then the
        // rasterizer's write pass into the caller's target.
        let depth_output = match &options.depth_output {
            Some(output) => {
                let target = match output.target {
                    DepthTarget::Image { view } => (0, Some(slot.depth_out_set(view)?)),
                    DepthTarget::Buffer { buffer, offset } => (
                        self.buffer_address(buffer, offset, "the depth output's buffer")?,
                        None,
                    ),
                };
                let sums = slot.trace.as_mut().expect("prepared").depth_sums()?;
                Some((sums, output.mode, target))
            }
            None => None,
        };
        let ctx = &self.ctx;
        let mut labels_only;
        let timer: &mut PassTimer = match timings {
            Some(t) => t,
            None => {
                labels_only = PassTimer::labels_only(ctx);
                &mut labels_only
            }
        };
        timer.begin_frame(cmd);
        let state = slot.trace.as_ref().expect("prepared").state.address;
        let mut at = FrameAddresses {
            params: 0,
            clip: 0,
            counters: 0,
            splats: 0,
            tiles_touched: 0,
            slots: 0,
            cutoffs: 0,
            cutoff_bounds: 0,
            ranges: 0,
            state,
        };
        let trace_options = crate::options::RayTraceOptions::default();
        // On CPU drivers the tracer reads the lists through the frame's texel views.
        let frame_texels = if tiled && tracer.reads_texels() {
            let sorted = self.sort.passes_for(tile_key_bits(w, h)) as usize % 2;
            Some(slot.frame_texels_set(sorted, scene)?)
        } else {
            None
        };
        let bufs = slot.trace.as_mut().expect("prepared");
        let tile_lists = match slot.resources.as_ref().filter(|_| tiled) {
            Some(f) => {
                // The tile lists (SPEC section 11) in the rasterizer's buffers, zeroed as its
                // frames zero them.
                let params = frame_params(camera, options, scene, capacity);
                unsafe {
                    let device = ctx.device();
                    device.cmd_update_buffer(cmd, f.params.raw, 0, bytemuck::bytes_of(&params));
                    device.cmd_fill_buffer(cmd, f.counters.raw, 0, vk::WHOLE_SIZE, 0);
                    device.cmd_fill_buffer(cmd, f.ranges.raw, 0, vk::WHOLE_SIZE, 0);
                }
                compute_barrier(ctx, cmd);
                at = FrameAddresses {
                    params: f.params.address,
                    counters: f.counters.address,
                    splats: f.splats.address,
                    tiles_touched: f.tiles_touched.address,
                    slots: f.slots.address,
                    ranges: f.ranges.address,
                    ..at
                };
                let mut rec = FrameRecording {
                    ctx,
                    cmd,
                    timer: &mut *timer,
                    texels: frame_texels,
                    at,
                    size: (w, h),
                    grid: tile_grid(w, h),
                };
                Some(self.ray_tiles()?.record(
                    &mut rec,
                    scene,
                    trace_options.q as f32,
                    (&self.prefix_sum, &f.slots_scan),
                    &self.sort,
                    &f.sort,
                ))
            }
            None => None,
        };
        if let Some((projection, source, limit)) = &depth {
            let mut rec = FrameRecording {
                ctx,
                cmd,
                timer: &mut *timer,
                texels: None,
                at,
                size: (w, h),
                grid: tile_grid(w, h),
            };
            self.depth
                .record_prepare(&mut rec, *source, projection, *limit)?;
        }
        tracer.record(
            ctx,
            cmd,
            timer,
            bufs,
            scene,
            camera,
            &options.clip,
            &trace_options,
            0..bufs.batches,
            0..rounds,
            None,
            depth.map(|(_, _, limit)| limit),
            tile_lists,
            depth_output.map(|(sums, _, _)| sums),
            object_clips.map(|o| ObjectRegions {
                regions: o.regions,
                of_gaussian: o.project.cutoff_regions,
            }),
        )?;
        if let Some(f) = slot.resources.as_ref().filter(|_| tiled) {
            // The lists' counters, for FrameSlot::stats (their pairs must have fit).
            copy_to_host(
                ctx,
                cmd,
                &f.counters,
                slot.counters_readback(),
                COUNTER_SLOTS as u64 * 4,
            );
        }
        let mut rec = FrameRecording {
            ctx,
            cmd,
            timer,
            texels: None,
            at,
            size: (w, h),
            grid: tile_grid(w, h),
        };
        self.record_write_target(&mut rec, options, (target, image_set, buffer_target))?;
        if let Some((sums, mode, output)) = depth_output {
            self.depth.record_write(&mut rec, sums, mode, output)?;
        }
        Ok(())
    }

    /// Records the pass that writes the frame's per-pixel state into `target` (its image
    /// target's descriptor set, or its buffer target's address) over the background or the
    /// target, as `options` says.
    fn record_write_target(
        &self,
        rec: &mut FrameRecording,
        options: &RenderOptions,
        (target, image_set, buffer_target): (&Target, Option<vk::DescriptorSet>, u64),
    ) -> Result<()> {
        self.write_target.record(
            rec,
            (target.format(), image_set, buffer_target),
            options.background,
            options.composite,
        )
    }
}

/// The frame's `FrameParams`: the camera, the image and its tiles, the scene's size and the
/// pair capacity of the frame's buffers.
fn frame_params(
    camera: &Camera,
    options: &RenderOptions,
    scene: &GpuScene,
    capacity: u64,
) -> GpuFrameParams {
    let w2c = camera.world_to_camera();
    let (cx, cy) = camera.principal_point();
    let (gx, gy) = tile_grid(camera.width, camera.height);
    let row = |r: usize| {
        let v = w2c.row(r);
        [v.x, v.y, v.z, 0.0]
    };
    let bg = options.background;
    GpuFrameParams {
        world_to_cam: [row(0), row(1), row(2)],
        cam_pos: [camera.position.x, camera.position.y, camera.position.z, 0.0],
        focal: [camera.fx, camera.fy, cx, cy],
        background: [bg.x, bg.y, bg.z, 0.0],
        size: [camera.width, camera.height, gx, gy],
        scene: [
            scene.count,
            scene.sh_degree,
            3 * (scene.sh_degree + 1).pow(2),
            capacity.min(u32::MAX as u64) as u32,
        ],
    }
}
