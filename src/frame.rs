//! Per-frame GPU resources: what one frame in flight needs of its own.

use ash::vk;

use crate::camera::tile_grid;
use crate::constants::{
    COUNTER_CUTOFF, COUNTER_CUTOFF_PAIRS, COUNTER_CUTOFF_PAIRS_EMPTY,
    COUNTER_CUTOFF_PAIRS_WEIGHT_ONE, COUNTER_CUTOFF_WHOLE, COUNTER_INTERSECTIONS,
    COUNTER_MAX_TILE_LEN, COUNTER_OVERSIZED, COUNTER_SLOTS, COUNTER_VISIBLE,
    COUNTER_WEIGHTED_TILES, MAX_INTERSECTIONS, RASTER_CHUNK,
};
use crate::error::Result;
use crate::gpu_scene::GpuScene;
use crate::gpu_types::{GpuClipParams, GpuFrameParams, GpuProjectedSplat, CUTOFF_RECORD_BYTES};
use crate::raytrace::tracer::{RayTracer, TraceBuffers, FIRST_TRACE_ROUNDS, MAX_TRACE_ROUNDS};
use crate::stages::cutoff_tiles::CUTOFF_PAIRS_OFFSET;
use crate::stages::depth_order::DEPTH_ORDER_BUFFER;
use crate::stages::prefix_sum::{PrefixSum, PrefixSumScratch};
use crate::stages::sort::{RadixSort, SortBuffers};
use crate::stages::tile_lists::TileListsLayout;
use crate::stages::write_target::single_image_set_layout;
use crate::stages::{frame_texels_set_layout, sh_texel, FRAME_TEXEL_BINDINGS};
use crate::timing::PassTiming;
use crate::vk::descriptors::{allocate_sets, write_texel_view};
use crate::vk::{Buffer, Context, MemoryLocation};

/// The first binding of [`frame_texels_set_layout`] that views the scene's buffers.
const FIRST_SCENE_BINDING: usize = 10;

/// Smallest intersection capacity a slot starts with.
const MIN_CAPACITY: u64 = 1 << 16;
/// Intersections per Gaussian a slot first reserves (real scenes at 640x480 average 2 to 3).
const FIRST_INTERSECTIONS_PER_GAUSSIAN: u64 = 4;

/// The working buffers of one frame in flight: parameters, projected splats, tile pairs and
/// their sort, tile ranges, per-pixel state, counters, and the descriptor set of an image
/// target. [`crate::Renderer::record`] writes them, so a slot must not be recorded again until
/// the GPU has finished the submission that last used it; an engine with two or three frames
/// in flight keeps one slot per frame, next to its own per-frame command buffer and fence.
///
/// Sizes follow the frames: a slot grows its buffers when the scene, image size or the last
/// frame's intersection count needs it. A frame whose tile pairs exceed the capacity the slot
/// had when it was recorded is drawn without the pairs that did not fit and reported with
/// [`FrameStats::complete`] `== false`; the slot then grows for its next frame
/// ([`FrameSlot::reserve`] sizes it ahead of time).
pub struct FrameSlot {
    ctx: Context,
    pub(crate) resources: Option<FrameResources>,
    counters_readback: Buffer,
    /// Intersection capacity and rasterizer rounds the next frame gets (at least).
    capacity: u64,
    rounds: u32,
    /// What the last recorded frame had, to judge its counters.
    recorded: Option<(u64, u32)>,
    image_set: Option<ImageTargetSet>,
    /// The engine's depth image of a depth test ([`crate::depth::DepthSource::Image`]).
    depth_in_set: Option<ImageTargetSet>,
    /// The depth output's image ([`crate::depth::DepthTarget::Image`]).
    depth_out_set: Option<ImageTargetSet>,
    frame_texels: Option<FrameTexelsSet>,
    /// The ray tracer's buffers, made by its first frame ([`crate::Tracer::Ray`]).
    pub(crate) trace: Option<TraceBuffers>,
    /// Rounds the ray tracer's next frame records (at least).
    trace_rounds: u32,
    /// Rounds the last recorded frame had, when it was ray traced.
    recorded_trace: Option<u32>,
    /// The pair capacity the last recorded frame had, when it was ray traced from tile lists
    /// (SPEC section 11), which are the rasterizer's buffers.
    recorded_tiles: Option<u64>,
    /// With several objects ([`crate::Renderer::record_objects`]): the merged scene the
    /// objects are transformed into, and their parameters.
    pub(crate) objects: Option<ObjectBuffers>,
    /// A ray-traced frame's depth test: the engine's view depth per pixel.
    trace_depth_limit: Option<Buffer>,
}

/// A slot's buffers for several objects ([`crate::Renderer::record_objects`]).
pub(crate) struct ObjectBuffers {
    /// The merged scene the objects are transformed into.
    pub merged: GpuScene,
    /// The objects' transforms (`GpuObjectParams`).
    pub params: Buffer,
    /// With clip regions of the objects' own: the regions in world space (`GpuClipParams`
    /// per object), and a u32 per Gaussian: each cutoff record's region index (rasterized
    /// frames, written by project) or each Gaussian's object's (ray-traced frames).
    pub clips: Option<(Buffer, Buffer)>,
}

/// The device memory of a [`FrameSlot`], grouped by what it scales with: the per-frame
/// scratch that comes on top of the scene ([`crate::GpuScene::device_bytes`]).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct FrameMemory {
    /// Per Gaussian of the scene: projected splats (48 B), tiles touched (4 B), sort slots /
    /// pair offsets (4 B), the prefix sum's partial sums (4 B per 1,024), and the depth order
    /// when kept ([`crate::Renderer::set_keep_depth_order`], 4 B). The depth sort shares the
    /// tile pairs' sort buffers (`per_intersection`), which hold a pair per Gaussian at least.
    pub per_gaussian: u64,
    /// Cutoff side records (48 B per Gaussian) and where their pairs start (8 B), allocated by
    /// the first rara-clipped frame.
    pub cutoff_records: u64,
    /// Sort keys and values, double-buffered (16 B per pair; 24 B in the CPU drivers' sort
    /// layout), and the sort histograms, for `intersection_capacity` (tile, splat) pairs; the
    /// depth sort runs in them first.
    pub per_intersection: u64,
    /// Pairs the sort buffers hold (grown from the frames' counts).
    pub intersection_capacity: u64,
    /// Per-pixel state (16 B), and per tile its range (8 B) and tile-list entries (12 B).
    pub per_pixel: u64,
    /// Parameters and counters.
    pub fixed: u64,
    /// The ray tracer's BVH ([`crate::Tracer::Ray`] frames): per Gaussian its proxy box
    /// (32 B), Morton sort (16 B and histograms) and leaf node (32 B), per inner node 32 B,
    /// per node its parent (4 B), per inner node an arrival count (4 B). 0 where no frame
    /// built one: a scene with a still BVH ([`crate::GpuScene::still_bvh_bytes`]) is walked
    /// where it lies, and camera rays from tile lists walk no tree.
    pub bvh: u64,
    /// The ray tracer's per-ray buffers: per ray of a batch (at most
    /// [`crate::raytrace::tracer::TRACE_BATCH_RAYS`]) its state (48 B), stack (256 B), k-buffer
    /// (12 B per entry: 192 B with k = 16, 768 B with k = 64) and live-list entries (8 B), and
    /// per pixel its state (16 B).
    pub trace_per_ray: u64,
    /// The rays (pixels) of the frame `trace_per_ray` is for, and the Gaussians the BVH is
    /// over.
    pub trace_rays: u64,
    /// See `trace_rays`.
    pub bvh_gaussians: u64,
}

impl FrameMemory {
    /// All of it.
    pub fn total(&self) -> u64 {
        self.per_gaussian
            + self.cutoff_records
            + self.per_intersection
            + self.per_pixel
            + self.fixed
            + self.bvh
            + self.trace_per_ray
    }
}

/// Buffers of one frame size, reused while the sizes fit.
pub(crate) struct FrameResources {
    pub(crate) width: u32,
    pub(crate) height: u32,
    pub(crate) gaussians: u32,
    pub(crate) capacity: u64,
    pub(crate) params: Buffer,
    pub(crate) clip_params: Buffer,
    pub(crate) counters: Buffer,
    /// Cutoff side records, one slot per Gaussian; allocated on the first rara frame.
    pub(crate) cutoffs: Option<Buffer>,
    /// With the records: the dispatch arguments over the cutoff records (16 B at
    /// [`crate::stages::cutoff_tiles::CUTOFF_ARGS_OFFSET`], for the cutoff-records and
    /// cutoff-tiles stages), then at [`CUTOFF_PAIRS_OFFSET`] per record its Gaussian (project's
    /// list), which emit overwrites with its splat's (first pair, splat index).
    pub(crate) cutoff_pairs: Option<Buffer>,
    pub(crate) splats: Buffer,
    pub(crate) tiles_touched: Buffer,
    /// Per Gaussian: project's drawn flags, scanned into each drawn Gaussian's slot in the
    /// depth sort; then, in depth order, the tiles touched, scanned into each one's first pair.
    pub(crate) slots: Buffer,
    /// Scratch of both prefix sums over `slots`.
    pub(crate) slots_scan: PrefixSumScratch,
    /// The drawn Gaussians' (depth bits, index) pairs and their sort, ending in buffer
    /// [`DEPTH_ORDER_BUFFER`]; then the (tile id, splat index) pairs and theirs, from buffer
    /// 0. Room for a pair per Gaussian at least.
    pub(crate) sort: SortBuffers,
    /// The depth order copied aside for [`crate::Renderer::intermediates`], when asked for
    /// ([`crate::Renderer::set_keep_depth_order`]).
    pub(crate) depth_order_copy: Option<Buffer>,
    pub(crate) ranges: Buffer,
    /// The tile lists of the strips rasterizer under rara clipping ([`TileListsLayout`]).
    pub(crate) tile_lists: Buffer,
    /// Per pixel (premultiplied colour, transmittance), for the write-target stage.
    pub(crate) state: Buffer,
    /// With a depth test or a depth output (SPEC section 9), made by the first such frame:
    /// per pixel the depth sums (median, sum alpha T z; 16 B) and the engine's view depth
    /// (4 B).
    pub(crate) depth: Option<(Buffer, Buffer)>,
    /// Which sort buffer holds the sorted pairs of the last frame.
    pub(crate) sorted: usize,
}

/// The descriptor pool and set of the frame's texel views ([`frame_texels_set_layout`]), made
/// for the buffers in `viewed`.
struct FrameTexelsSet {
    layout: vk::DescriptorSetLayout,
    pool: vk::DescriptorPool,
    set: vk::DescriptorSet,
    views: [vk::BufferView; FRAME_TEXEL_BINDINGS as usize],
    viewed: [vk::Buffer; FRAME_TEXEL_BINDINGS as usize],
    /// The [`GpuScene`] the scene views (bindings 10 and 11) are of.
    scene_id: u64,
}

impl FrameTexelsSet {
    /// Destroys the views (before their buffers are freed: a new buffer may get a freed
    /// one's handle).
    fn forget_views(&mut self, device: &ash::Device) {
        self.forget_views_from(device, 0);
    }

    /// Destroys the views of bindings `first..`.
    fn forget_views_from(&mut self, device: &ash::Device, first: usize) {
        for (view, viewed) in self.views[first..]
            .iter_mut()
            .zip(&mut self.viewed[first..])
        {
            if *view != vk::BufferView::null() {
                unsafe { device.destroy_buffer_view(*view, None) };
            }
            *view = vk::BufferView::null();
            *viewed = vk::Buffer::null();
        }
    }
}

/// The descriptor pool and set that hold one image view: an image target's, or a depth
/// test's or depth output's.
struct ImageTargetSet {
    layout: vk::DescriptorSetLayout,
    pool: vk::DescriptorPool,
    set: vk::DescriptorSet,
    view: vk::ImageView,
    image_layout: vk::ImageLayout,
}

impl FrameSlot {
    /// An empty slot; buffers are allocated by the first frame recorded into it.
    pub fn new(ctx: &Context) -> Result<Self> {
        Ok(FrameSlot {
            ctx: ctx.clone(),
            resources: None,
            counters_readback: Buffer::new(
                ctx,
                "frame counters (host)",
                COUNTER_SLOTS as u64 * 4,
                MemoryLocation::GpuToCpu,
            )?,
            capacity: 0,
            rounds: 1,
            recorded: None,
            image_set: None,
            depth_in_set: None,
            depth_out_set: None,
            frame_texels: None,
            trace: None,
            trace_rounds: FIRST_TRACE_ROUNDS,
            recorded_trace: None,
            recorded_tiles: None,
            objects: None,
            trace_depth_limit: None,
        })
    }

    /// Sizes the slot for frames of up to `intersections` tile pairs whose longest tile list
    /// has `longest_tile_list` entries (both are in [`FrameStats`]), so that they are complete
    /// from the first. The capacity stops at [`MAX_INTERSECTIONS`]: a frame with more pairs is
    /// drawn incomplete.
    pub fn reserve(&mut self, intersections: u64, longest_tile_list: u32) {
        self.capacity = self.capacity.max(intersections.min(MAX_INTERSECTIONS));
        self.rounds = self
            .rounds
            .max(longest_tile_list.div_ceil(RASTER_CHUNK).max(1));
    }

    /// Device bytes the slot holds now.
    pub fn device_bytes(&self) -> u64 {
        self.memory().total()
    }

    /// Device bytes the slot holds now, by what they scale with.
    pub fn memory(&self) -> FrameMemory {
        let mut m = FrameMemory {
            fixed: self.counters_readback.size,
            ..FrameMemory::default()
        };
        if let Some(r) = &self.resources {
            m.fixed += r.params.size + r.clip_params.size + r.counters.size;
            m.per_gaussian = r.splats.size
                + r.tiles_touched.size
                + r.slots.size
                + r.slots_scan.device_bytes()
                + r.depth_order_copy.as_ref().map_or(0, |b| b.size);
            m.cutoff_records = r.cutoffs.as_ref().map_or(0, |b| b.size)
                + r.cutoff_pairs.as_ref().map_or(0, |b| b.size);
            m.per_intersection = r.sort.device_bytes();
            m.intersection_capacity = r.capacity;
            m.per_pixel = r.ranges.size + r.tile_lists.size + r.state.size;
            if let Some((sums, limit)) = &r.depth {
                m.per_pixel += sums.size + limit.size;
            }
        }
        if let Some(o) = &self.objects {
            // The merged scene of several objects is per-Gaussian memory of the frame.
            m.per_gaussian += o.merged.device_bytes() + o.params.size;
            if let Some((regions, cutoff_regions)) = &o.clips {
                m.per_gaussian += regions.size + cutoff_regions.size;
            }
        }
        if let Some(t) = &self.trace {
            m.bvh = t.bvh_bytes();
            m.trace_per_ray = t.per_ray_bytes();
            m.trace_rays = t.width as u64 * t.height as u64;
            m.bvh_gaussians = t.gaussians as u64;
            m.fixed += t.fixed_bytes();
        }
        m
    }

    /// The counters of the last frame recorded into this slot: call it once the submission
    /// that holds the frame has completed (e.g. after waiting on its fence). `passes` and the
    /// times are left empty: they live in the caller's [`crate::timing::PassTimer`].
    pub fn stats(&mut self) -> Result<FrameStats> {
        let counters: Vec<u32> = bytemuck::pod_collect_to_vec(
            &self.counters_readback.mapped()[..COUNTER_SLOTS as usize * 4],
        );
        if let (Some(rounds), Some(t)) = (self.recorded_trace, &self.trace) {
            let trace = t.stats(rounds);
            let mut complete = trace.unfinished == 0;
            if !complete {
                self.trace_rounds = (rounds * 4).min(MAX_TRACE_ROUNDS);
            }
            let mut stats = FrameStats::default();
            if let Some(capacity) = self.recorded_tiles {
                // Camera rays from tile lists: the lists' pairs, which must have fit.
                stats.intersections = counters[COUNTER_INTERSECTIONS as usize];
                stats.visible = counters[COUNTER_VISIBLE as usize];
                if stats.intersections as u64 > capacity {
                    complete = false;
                    self.reserve((stats.intersections as u64 * 5 / 4).next_power_of_two(), 0);
                }
            }
            return Ok(FrameStats {
                complete,
                trace: Some(trace),
                ..stats
            });
        }
        let intersections = counters[COUNTER_INTERSECTIONS as usize];
        let max_tile_len = counters[COUNTER_MAX_TILE_LEN as usize];
        let complete = match self.recorded {
            Some((capacity, rounds)) => {
                intersections as u64 <= capacity && max_tile_len <= rounds * RASTER_CHUNK
            }
            None => true,
        };
        if !complete {
            // Room for this frame and some growth, so a moving camera does not grow every frame.
            self.reserve(
                (intersections as u64 * 5 / 4).next_power_of_two(),
                max_tile_len,
            );
        }
        Ok(FrameStats {
            intersections,
            visible: counters[COUNTER_VISIBLE as usize],
            cutoff: counters[COUNTER_CUTOFF as usize],
            cutoff_pairs: counters[COUNTER_CUTOFF_PAIRS as usize],
            cutoff_pairs_weight_one: counters[COUNTER_CUTOFF_PAIRS_WEIGHT_ONE as usize],
            cutoff_pairs_empty: counters[COUNTER_CUTOFF_PAIRS_EMPTY as usize],
            cutoff_whole: counters[COUNTER_CUTOFF_WHOLE as usize],
            weighted_tiles: counters[COUNTER_WEIGHTED_TILES as usize],
            oversized: counters[COUNTER_OVERSIZED as usize],
            max_tile_len,
            complete,
            ..FrameStats::default()
        })
    }

    /// Makes the ray tracer's buffers fit a frame of `(width, height)` over `gaussians`
    /// Gaussians; returns them and the rounds the frame gets. The slot then counts as holding
    /// a ray-traced frame.
    pub(crate) fn prepare_trace(
        &mut self,
        tracer: &RayTracer,
        size: (u32, u32),
        gaussians: u32,
        tiled: bool,
    ) -> Result<(&mut TraceBuffers, u32)> {
        if self.recorded_trace.is_some() {
            // The previous frame has completed (the slot's contract): learn whether it needed
            // more rounds.
            self.stats()?;
        }
        if !self
            .trace
            .as_ref()
            .is_some_and(|t| t.fits(size, gaussians, tracer.k(), tiled))
        {
            self.trace = None; // free the old buffers first
            self.trace = Some(TraceBuffers::new(
                tracer, &self.ctx, size, gaussians, tiled,
            )?);
        }
        self.recorded = None;
        self.recorded_trace = Some(self.trace_rounds);
        self.recorded_tiles = None;
        Ok((self.trace.as_mut().expect("made above"), self.trace_rounds))
    }

    /// Makes the buffers fit a frame of `(width, height)` and `gaussians` Gaussians (with the
    /// cutoff records when `rara`) and at most `pair_limit` tile pairs; returns the
    /// intersection capacity and rasterizer rounds the frame gets.
    pub(crate) fn prepare(
        &mut self,
        prefix_sum: &PrefixSum,
        sort: &RadixSort,
        (width, height): (u32, u32),
        gaussians: u32,
        rara: bool,
        pair_limit: u64,
    ) -> Result<(u64, u32)> {
        if self.recorded.is_some() {
            // The previous frame of this slot has completed (the slot's contract): learn from
            // its counters whether it overflowed.
            self.stats()?;
        }
        self.capacity = self
            .capacity
            .max((gaussians as u64 * FIRST_INTERSECTIONS_PER_GAUSSIAN).min(MAX_INTERSECTIONS))
            .max(MIN_CAPACITY);
        let capacity = self.capacity.min(pair_limit);
        // The depth sort shares the pairs' buffers: a slot per Gaussian. Scenes that the
        // kernels' limits admit stay far below the pair limit (a third of it, or less).
        if capacity < gaussians as u64 {
            return Err(crate::error::Error::InvalidInput(format!(
                "{gaussians} Gaussians exceed the {capacity} sort slots one frame may have on \
                 this device"
            )));
        }
        let fits = self.resources.as_ref().is_some_and(|f| {
            f.width == width
                && f.height == height
                && f.gaussians >= gaussians
                && f.capacity >= capacity
        });
        if !fits {
            if let Some(t) = &mut self.frame_texels {
                t.forget_views(self.ctx.device());
            }
            self.resources = None; // free the old buffers first
            let ctx = &self.ctx;
            let gpu = MemoryLocation::GpuOnly;
            let (gx, gy) = tile_grid(width, height);
            let pixels = width as u64 * height as u64;
            let n = gaussians.max(1) as u64;
            self.resources = Some(FrameResources {
                width,
                height,
                gaussians,
                capacity,
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
                cutoff_pairs: None,
                splats: Buffer::new(
                    ctx,
                    "projected splats",
                    n * std::mem::size_of::<GpuProjectedSplat>() as u64,
                    gpu,
                )?,
                tiles_touched: Buffer::new(ctx, "tiles touched", n * 4, gpu)?,
                slots: Buffer::new(ctx, "depth sort slots / pair offsets", n * 4, gpu)?,
                slots_scan: prefix_sum.scratch(ctx, n)?,
                sort: sort.buffers(ctx, capacity)?,
                depth_order_copy: None,
                ranges: Buffer::new(ctx, "tile ranges", (gx * gy) as u64 * 8, gpu)?,
                tile_lists: Buffer::new(
                    ctx,
                    "tile lists",
                    TileListsLayout {
                        tile_count: gx * gy,
                    }
                    .size(),
                    gpu,
                )?,
                state: Buffer::new(ctx, "raster state", pixels * 16, gpu)?,
                depth: None,
                sorted: 0,
            });
        }
        // One side-record slot per Gaussian of the scene, then one slot of its ellipse bounds
        // (two floats; stages::cutoff_tiles): (re)allocated when a rara frame needs more than
        // the last one did.
        let cutoff_bytes = gaussians.max(1) as u64 * (CUTOFF_RECORD_BYTES + 8);
        let frame = self.resources.as_mut().unwrap();
        if rara
            && !frame
                .cutoffs
                .as_ref()
                .is_some_and(|b| b.size >= cutoff_bytes)
        {
            // Free the old buffers first.
            if let Some(t) = &mut self.frame_texels {
                t.forget_views(self.ctx.device());
            }
            frame.cutoffs = None;
            frame.cutoff_pairs = None;
            frame.cutoffs = Some(Buffer::new(
                &self.ctx,
                "cutoff records",
                cutoff_bytes,
                MemoryLocation::GpuOnly,
            )?);
            frame.cutoff_pairs = Some(Buffer::new(
                &self.ctx,
                "cutoff pairs",
                CUTOFF_PAIRS_OFFSET + gaussians.max(1) as u64 * 8,
                MemoryLocation::GpuOnly,
            )?);
        }
        self.recorded = Some((capacity, self.rounds));
        self.recorded_trace = None;
        self.recorded_tiles = None;
        Ok((capacity, self.rounds))
    }

    /// Makes the slot fit a ray-traced frame whose camera rays come from tile lists (SPEC
    /// section 11): the rasterizer's buffers for the lists (as [`FrameSlot::prepare`], no
    /// cutoff records) and the tracer's (as [`FrameSlot::prepare_trace`]). Returns the pair
    /// capacity and the tracer's rounds; the slot then counts as holding such a frame, whose
    /// stats judge both.
    pub(crate) fn prepare_tiled_trace(
        &mut self,
        tracer: &RayTracer,
        (prefix_sum, sort): (&PrefixSum, &RadixSort),
        size: (u32, u32),
        gaussians: u32,
        pair_limit: u64,
    ) -> Result<(u64, u32)> {
        if self.recorded.is_some() || self.recorded_trace.is_some() {
            // The previous frame has completed (the slot's contract): learn what it needed.
            self.stats()?;
        }
        self.recorded = None;
        self.recorded_trace = None;
        let (capacity, _) = self.prepare(prefix_sum, sort, size, gaussians, false, pair_limit)?;
        let (_, rounds) = self.prepare_trace(tracer, size, gaussians, true)?;
        self.recorded_tiles = Some(capacity);
        Ok((capacity, rounds))
    }

    /// Makes room for the depth order of `gaussians` copied aside
    /// ([`crate::Renderer::set_keep_depth_order`]); call after `prepare`.
    pub(crate) fn keep_depth_order(&mut self, gaussians: u32) -> Result<()> {
        let f = self.resources.as_mut().expect("prepared");
        let bytes = gaussians.max(1) as u64 * 4;
        if !f.depth_order_copy.as_ref().is_some_and(|b| b.size >= bytes) {
            f.depth_order_copy = None;
            f.depth_order_copy = Some(Buffer::new(
                &self.ctx,
                "depth order (kept)",
                bytes,
                MemoryLocation::GpuOnly,
            )?);
        }
        Ok(())
    }

    /// The buffer the frame's counters are copied to for [`FrameSlot::stats`].
    pub(crate) fn counters_readback(&self) -> &Buffer {
        &self.counters_readback
    }

    /// The descriptor set of the frame's texel views ([`frame_texels_set_layout`]) for the
    /// frame `prepare` sized, whose sorted pairs are in sort buffer `sorted` (and drawn
    /// Gaussians in depth order in sort buffer [`DEPTH_ORDER_BUFFER`]), of `scene`: views are
    /// remade only when the buffers changed (the slot is idle, so the set is not in use).
    pub(crate) fn frame_texels_set(
        &mut self,
        sorted: usize,
        scene: &GpuScene,
    ) -> Result<vk::DescriptorSet> {
        let device = self.ctx.device();
        if self.frame_texels.is_none() {
            let layout = frame_texels_set_layout(&self.ctx)?;
            let sizes = [vk::DescriptorPoolSize {
                ty: vk::DescriptorType::UNIFORM_TEXEL_BUFFER,
                descriptor_count: FRAME_TEXEL_BINDINGS,
            }];
            let (pool, set) = match allocate_sets(&self.ctx, &sizes, &[layout]) {
                Ok((pool, sets)) => (pool, sets[0]),
                Err(e) => {
                    unsafe { device.destroy_descriptor_set_layout(layout, None) };
                    return Err(e);
                }
            };
            self.frame_texels = Some(FrameTexelsSet {
                layout,
                pool,
                set,
                views: [vk::BufferView::null(); FRAME_TEXEL_BINDINGS as usize],
                viewed: [vk::Buffer::null(); FRAME_TEXEL_BINDINGS as usize],
                scene_id: 0,
            });
        }
        let f = self.resources.as_ref().unwrap();
        let (gaussians, sh, scene_id) = scene.buffers();
        let buffers = [
            Some(&f.sort.values[sorted]),
            Some(&f.splats),
            f.cutoffs.as_ref(),
            Some(&f.sort.values[DEPTH_ORDER_BUFFER]),
            Some(&f.slots),
            Some(&f.tiles_touched),
            Some(&f.sort.keys[sorted]),
            Some(&f.sort.keys[0]),
            Some(&f.state),
            Some(&f.clip_params),
            Some(gaussians),
            Some(sh),
        ];
        let (r32, rgba32) = (vk::Format::R32_UINT, vk::Format::R32G32B32A32_UINT);
        let (sh_format, sh_texel_bytes) = sh_texel(scene.sh_precision());
        let formats = [
            rgba32, rgba32, rgba32, r32, r32, r32, r32, r32, rgba32, rgba32, rgba32, sh_format,
        ];
        let texel_bytes = [16u64, 16, 16, 4, 4, 4, 4, 4, 16, 16, 16, sh_texel_bytes];
        let max_texels = self.ctx.info().max_texel_buffer_elements as u64;
        let texels = self.frame_texels.as_mut().unwrap();
        if texels.scene_id != scene_id {
            // A freed scene's buffer handles may come back: key the scene views by the scene.
            texels.forget_views_from(device, FIRST_SCENE_BINDING);
            texels.scene_id = scene_id;
        }
        for b in 0..FRAME_TEXEL_BINDINGS as usize {
            let Some(buffer) = buffers[b] else { continue };
            if texels.viewed[b] == buffer.raw {
                continue;
            }
            let range = (buffer.size / texel_bytes[b]).min(max_texels) * texel_bytes[b];
            let view = write_texel_view(
                &self.ctx,
                buffer,
                formats[b],
                range,
                texels.set,
                b as u32,
                vk::DescriptorType::UNIFORM_TEXEL_BUFFER,
            )?;
            if texels.views[b] != vk::BufferView::null() {
                unsafe { device.destroy_buffer_view(texels.views[b], None) };
            }
            texels.views[b] = view;
            texels.viewed[b] = buffer.raw;
        }
        Ok(texels.set)
    }

    /// The descriptor set holding `view` as the storage image at binding 0 (updated only when
    /// the view changed; the slot is idle, so the set is not in use).
    pub(crate) fn image_target_set(&mut self, view: vk::ImageView) -> Result<vk::DescriptorSet> {
        single_image_set(
            &self.ctx,
            &mut self.image_set,
            vk::DescriptorType::STORAGE_IMAGE,
            view,
            vk::ImageLayout::GENERAL,
        )
    }

    /// The descriptor set of a depth test's engine depth image: `view` as the sampled image at
    /// binding 0, in `layout`.
    /// The address of the per-pixel view depth of a ray-traced frame's depth test, `size`
    /// pixels (made, or remade for another size, here).
    pub(crate) fn trace_depth_limit(&mut self, (w, h): (u32, u32)) -> Result<u64> {
        let bytes = w as u64 * h as u64 * 4;
        if self.trace_depth_limit.as_ref().map(|b| b.size) != Some(bytes) {
            self.trace_depth_limit = None;
            self.trace_depth_limit = Some(Buffer::new(
                &self.ctx,
                "trace depth limit",
                bytes,
                MemoryLocation::GpuOnly,
            )?);
        }
        Ok(self.trace_depth_limit.as_ref().expect("made above").address)
    }

    pub(crate) fn depth_in_set(
        &mut self,
        view: vk::ImageView,
        layout: vk::ImageLayout,
    ) -> Result<vk::DescriptorSet> {
        single_image_set(
            &self.ctx,
            &mut self.depth_in_set,
            vk::DescriptorType::SAMPLED_IMAGE,
            view,
            layout,
        )
    }

    /// The descriptor set of a depth output's image: `view` as the storage image at binding 0.
    pub(crate) fn depth_out_set(&mut self, view: vk::ImageView) -> Result<vk::DescriptorSet> {
        single_image_set(
            &self.ctx,
            &mut self.depth_out_set,
            vk::DescriptorType::STORAGE_IMAGE,
            view,
            vk::ImageLayout::GENERAL,
        )
    }

    /// Makes the depth buffers of the frame `prepare` sized (a depth test or a depth output).
    pub(crate) fn prepare_depth(&mut self) -> Result<()> {
        let f = self.resources.as_mut().expect("prepare first");
        if f.depth.is_none() {
            let pixels = f.width as u64 * f.height as u64;
            let gpu = MemoryLocation::GpuOnly;
            f.depth = Some((
                Buffer::new(&self.ctx, "depth sums", pixels * 16, gpu)?,
                Buffer::new(&self.ctx, "depth limit", pixels * 4, gpu)?,
            ));
        }
        Ok(())
    }
}

/// The set in `slot` (made on first use, with a layout of one `ty` descriptor at binding 0)
/// holding `view` in `layout` (updated only when they changed; the slot is idle, so the set is
/// not in use).
fn single_image_set(
    ctx: &Context,
    slot: &mut Option<ImageTargetSet>,
    ty: vk::DescriptorType,
    view: vk::ImageView,
    layout: vk::ImageLayout,
) -> Result<vk::DescriptorSet> {
    let device = ctx.device();
    if slot.is_none() {
        let set_layout = single_image_set_layout(ctx, ty)?;
        let sizes = [vk::DescriptorPoolSize {
            ty,
            descriptor_count: 1,
        }];
        let (pool, set) = match allocate_sets(ctx, &sizes, &[set_layout]) {
            Ok((pool, sets)) => (pool, sets[0]),
            Err(e) => {
                unsafe { device.destroy_descriptor_set_layout(set_layout, None) };
                return Err(e);
            }
        };
        *slot = Some(ImageTargetSet {
            layout: set_layout,
            pool,
            set,
            view: vk::ImageView::null(),
            image_layout: vk::ImageLayout::UNDEFINED,
        });
    }
    let s = slot.as_mut().unwrap();
    if s.view != view || s.image_layout != layout {
        let images = [vk::DescriptorImageInfo::default()
            .image_view(view)
            .image_layout(layout)];
        let write = vk::WriteDescriptorSet::default()
            .dst_set(s.set)
            .dst_binding(0)
            .descriptor_type(ty)
            .image_info(&images);
        unsafe { device.update_descriptor_sets(&[write], &[]) };
        s.view = view;
        s.image_layout = layout;
    }
    Ok(s.set)
}

impl Drop for FrameSlot {
    fn drop(&mut self) {
        if let Some(mut s) = self.frame_texels.take() {
            s.forget_views(self.ctx.device());
            unsafe {
                self.ctx.device().destroy_descriptor_pool(s.pool, None);
                self.ctx
                    .device()
                    .destroy_descriptor_set_layout(s.layout, None);
            }
        }
        for s in [
            self.image_set.take(),
            self.depth_in_set.take(),
            self.depth_out_set.take(),
        ]
        .into_iter()
        .flatten()
        {
            unsafe {
                self.ctx.device().destroy_descriptor_pool(s.pool, None);
                self.ctx
                    .device()
                    .destroy_descriptor_set_layout(s.layout, None);
            }
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
    /// The cutoff splats' pairs, when the frame classified them by tile (rara clipping by
    /// planes with the mass weight; else 0): all of them, ...
    pub cutoff_pairs: u32,
    /// ... those drawn as plain splats, their weight being 1 across the tile, ...
    pub cutoff_pairs_weight_one: u32,
    /// ... and those left out of the tile lists, adding nothing to the tile. The rest pay the
    /// per-pixel weight.
    pub cutoff_pairs_empty: u32,
    /// Cutoff splats whose every pair was decided at once, weight 1 or empty, from the splat's
    /// bounds over its whole footprint (their pairs are in the three counts above).
    pub cutoff_whole: u32,
    /// Tiles the weighted rasterize kernel walked, when the frame split the tiles by kernel
    /// (the strips rasterizer under rara clipping by planes with the mass weight; else 0).
    pub weighted_tiles: u32,
    /// Gaussians not drawn because their footprint exceeds the bound
    /// [`crate::constants::MAX_FOOTPRINT_SIGMA_PX`] (extreme scales, or a huge Gaussian right
    /// in front of the camera).
    pub oversized: u32,
    /// Longest tile list.
    pub max_tile_len: u32,
    /// Whether every tile pair and tile-list entry fitted the frame slot's buffers. `false`
    /// means splats are missing from the image; the slot grows for its next frame (and
    /// [`crate::Renderer::render`] renders again).
    pub complete: bool,
    /// How often the frame was rendered again after growing a buffer.
    pub rerenders: u32,
    /// GPU time (and compute invocations) per pass, in pass order (empty without timestamps).
    pub passes: Vec<PassTiming>,
    /// Sum of `passes`.
    pub gpu_ms: f64,
    /// Wall-clock milliseconds of the last render: recording, submission and wait.
    pub wall_ms: f64,
    /// The ray tracer's counts, on its frames ([`crate::Tracer::Ray`]).
    pub trace: Option<crate::raytrace::tracer::TraceFrameStats>,
}

impl FrameStats {
    /// The classified cutoff pairs that still pay the per-pixel weight: neither weight 1 nor
    /// empty across their tile.
    pub fn cutoff_pairs_partial(&self) -> u32 {
        self.cutoff_pairs - self.cutoff_pairs_weight_one - self.cutoff_pairs_empty
    }
}
