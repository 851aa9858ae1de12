//! Stage 1: project every Gaussian (`glsl/project_body.glsl`; CPU twin `reference::project`).

use ash::vk;

use bytemuck::{Pod, Zeroable};
use std::ffi::CStr;

use super::cutoff_tiles::{CUTOFF_ARGS_OFFSET, CUTOFF_PAIRS_OFFSET};
use super::{FrameRecording, LinearArgsPush};
use crate::constants::{
    CLIP_MODE_NONE, COUNTER_CUTOFF, MAX_CLIP_PLANES, PROJECT_CLIP_NONE, PROJECT_CLIP_ONE_PLANE,
    PROJECT_CLIP_SLOTS_CONSTANT_ID, PROJECT_LISTS_CUTOFF_CONSTANT_ID, PROJECT_LISTS_NONE,
    PROJECT_LISTS_RECORDS, PROJECT_LISTS_REGIONS, PROJECT_LISTS_WRITES,
};
use crate::error::Result;
use crate::gpu_scene::GpuScene;
use crate::gpu_types::GpuClipParams;
use crate::precision::ShPrecision;
use crate::shaders;
use crate::vk::{Buffer, ComputePipeline, Context, LazyPipeline};

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
    /// Out: per cutoff record, its Gaussian (0 when the frame is not rara-clipped).
    pub cutoff_gaussians: u64,
    /// Out, with several objects clipped by regions of their own: `region` per cutoff record
    /// (else 0).
    pub cutoff_regions: u64,
    /// Out, with [`CutoffListing::Writes`]: the cutoff records (else 0).
    pub cutoffs: u64,
    /// The Gaussians `[first, end)` the dispatch projects.
    pub first: u32,
    /// See `first`.
    pub end: u32,
    /// The index of the region at `clip` among the frame's regions.
    pub region: u32,
    /// Unused.
    pub pad: u32,
}

/// Several objects, each clipped by a region of its own (SPEC section 9), as project sees
/// them: per object its Gaussians `[first, end)` in the merged scene and the device address
/// of its region (`ClipParams`, world space), and where each cutoff record's region index goes.
pub struct ObjectClipRanges {
    /// Per object: first Gaussian, end, address of its region.
    pub objects: Vec<(u32, u32, u64)>,
    /// Out: the region index of each cutoff record.
    pub cutoff_regions: u64,
}

/// What `glsl/project_touched.comp` reads and writes: project's later rounds.
#[repr(C)]
#[derive(Clone, Copy, Pod, Zeroable)]
struct TouchedPush {
    frame: u64,
    splats: u64,
    tiles_touched: u64,
    drawn: u64,
    round_index: u32,
    pad: u32,
}

/// What `glsl/cutoff_records_body.glsl` reads and writes.
#[repr(C)]
#[derive(Clone, Copy, Pod, Zeroable)]
struct RecordsPush {
    frame: u64,
    gaussians: u64,
    counters: u64,
    /// Per cutoff record, its Gaussian (project's list).
    cutoff_gaussians: u64,
    /// Out: the records.
    cutoffs: u64,
    /// The projected splats.
    splats: u64,
    /// The frame's `ClipParams`.
    clip: u64,
    /// Out, in frames that classify cutoff pairs by tile (else 0): per record, its splat's
    /// bounds over the footprint ellipse (`ellipse_plane_u_range` in `glsl/clip.glsl`), and
    /// which splats those bounds decide whole (`CUTOFF_WHOLE_*` in `glsl/common.glsl`).
    cutoff_bounds: u64,
    /// Tiles touched per Gaussian: the pairs of a splat decided whole, for the frame's counts.
    tiles_touched: u64,
}

/// What a frame's project kernel writes for the cutoff Gaussians (`LISTS_CUTOFF` in
/// `glsl/project_body.glsl`): a CPU driver runs the listing's atomic and stores, masked, in
/// every SIMD vector of project, so each frame gets a kernel with only what it needs.
/// Its discriminant is the value of `LISTS_CUTOFF`, and indexes [`Project`]'s kernels.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
#[repr(u32)]
pub enum CutoffListing {
    /// Frames without rara clipping: no cutoff Gaussian.
    None = PROJECT_LISTS_NONE,
    /// Rara frames: each cutoff Gaussian's record index and the Gaussian under it.
    Records = PROJECT_LISTS_RECORDS,
    /// Rara frames of several objects clipped by regions of their own: also each record's
    /// region.
    RecordsAndRegions = PROJECT_LISTS_REGIONS,
    /// Rara frames of one region on the GPU layout: each cutoff Gaussian's record index and the
    /// record itself, and no records' pass.
    Writes = PROJECT_LISTS_WRITES,
}

// `Project::new` builds the kernels in the order of the discriminants, which index them.
const _: () = assert!(
    CutoffListing::None as u32 == 0
        && CutoffListing::Records as u32 == 1
        && CutoffListing::RecordsAndRegions as u32 == 2
        && CutoffListing::Writes as u32 == 3
);

impl CutoffListing {
    /// Whether the frame has the pass "cutoff records", which writes the listed Gaussians'
    /// records.
    pub fn has_records_pass(self) -> bool {
        matches!(
            self,
            CutoffListing::Records | CutoffListing::RecordsAndRegions
        )
    }
}

/// How many of the clip region's plane slots a frame's project kernel classifies the Gaussians
/// against (`CLIP_PLANE_SLOTS` in `glsl/project_body.glsl`): a CPU driver runs the test of
/// every slot, masked, for every Gaussian, so frames without a region or with one plane get
/// kernels that test no slot or one.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum PlaneSlots {
    /// Frames without a clip region: no classification.
    None,
    /// A region of at most one plane (one plane, or a sphere).
    One,
    /// Every slot (regions of several planes, and the objects' regions).
    All,
}

impl PlaneSlots {
    /// The slots for a frame clipped by `clip` (its GPU form), or by several objects' regions
    /// (`object_regions`), which each project dispatch takes from its own object.
    pub fn for_frame(clip: &GpuClipParams, object_regions: bool) -> PlaneSlots {
        if object_regions {
            PlaneSlots::All
        } else if clip.config[0] == CLIP_MODE_NONE {
            PlaneSlots::None
        } else if clip.config[3] <= 1 {
            PlaneSlots::One
        } else {
            PlaneSlots::All
        }
    }

    /// The value of `CLIP_PLANE_SLOTS`.
    fn constant(self) -> u32 {
        match self {
            PlaneSlots::None => PROJECT_CLIP_NONE,
            PlaneSlots::One => PROJECT_CLIP_ONE_PLANE,
            PlaneSlots::All => MAX_CLIP_PLANES,
        }
    }
}

/// The project kernel, in one variant per SH degree (0 to 3), storage precision and cutoff
/// listing ([`CutoffListing`]): a CPU driver runs every band's code under a mask whatever the
/// scene's degree, so each scene gets the kernel that holds only its own bands. Under rara
/// clipping the kernels that write the listed cutoff Gaussians' records follow it.
pub struct Project {
    /// Indexed by [`PlaneSlots`] (in declaration order), [`CutoffListing`] (its discriminant;
    /// `Project::new` builds them in that order), storage precision (32-bit, then half floats)
    /// and SH degree; each built when a frame first needs it ([`Project::prepare`]).
    kernels: [[[[LazyPipeline; 4]; 2]; 4]; 3],
    /// Whether the kernels read through the frame's texel views (CPU drivers), which never
    /// write the records themselves ([`Project::listing`]).
    texels: bool,
    /// The later rounds' count of tiles touched (`project_touched.comp`).
    touched: ComputePipeline,
    /// Rara frames: the dispatch arguments over the cutoff records (`linear_args.comp`).
    records_args: LazyPipeline,
    /// Rara frames: the records of the listed cutoff Gaussians (`cutoff_records_body.glsl`).
    records: LazyPipeline,
}

/// A project kernel: its name, and its SPIR-V reading through buffer loads and through the
/// frame's texel views.
type Variant = (&'static CStr, &'static [u32], &'static [u32]);

/// The kernels for SH in 32-bit floats, by degree.
const SH32_KERNELS: [Variant; 4] = [
    (
        c"project (SH 0)",
        shaders::PROJECT_DEG0,
        shaders::PROJECT_DEG0_TEXELS,
    ),
    (
        c"project (SH 1)",
        shaders::PROJECT_DEG1,
        shaders::PROJECT_DEG1_TEXELS,
    ),
    (
        c"project (SH 2)",
        shaders::PROJECT_DEG2,
        shaders::PROJECT_DEG2_TEXELS,
    ),
    (
        c"project (SH 3)",
        shaders::PROJECT_DEG3,
        shaders::PROJECT_DEG3_TEXELS,
    ),
];

/// The kernels for SH in half floats, by degree.
const SH16_KERNELS: [Variant; 4] = [
    (
        c"project (SH 0, f16)",
        shaders::PROJECT_DEG0_SH16,
        shaders::PROJECT_DEG0_SH16_TEXELS,
    ),
    (
        c"project (SH 1, f16)",
        shaders::PROJECT_DEG1_SH16,
        shaders::PROJECT_DEG1_SH16_TEXELS,
    ),
    (
        c"project (SH 2, f16)",
        shaders::PROJECT_DEG2_SH16,
        shaders::PROJECT_DEG2_SH16_TEXELS,
    ),
    (
        c"project (SH 3, f16)",
        shaders::PROJECT_DEG3_SH16,
        shaders::PROJECT_DEG3_SH16_TEXELS,
    ),
];

impl Project {
    /// Builds the kernels; with `texels`, the layout of the frame's texel views (CPU drivers,
    /// along with the strips rasterizer), the variants that read the Gaussians and SH
    /// coefficients through them (`project_deg*_texels`): a CPU driver loads those as
    /// gathers, where a buffer load is a scalar loop over the lanes per 64-bit word.
    pub fn new(ctx: &Context, texels: Option<vk::DescriptorSetLayout>) -> Result<Self> {
        let build = |(name, loads, fetches): &Variant| {
            let spirv = if texels.is_some() { fetches } else { loads };
            LazyPipeline::new::<ProjectPush>(ctx, name, spirv, texels)
        };
        let listed = |slots: PlaneSlots, listing: CutoffListing| {
            [&SH32_KERNELS, &SH16_KERNELS].map(|table| {
                table.each_ref().map(|v| {
                    build(v).specialized(&[
                        (PROJECT_LISTS_CUTOFF_CONSTANT_ID, listing as u32),
                        (PROJECT_CLIP_SLOTS_CONSTANT_ID, slots.constant()),
                    ])
                })
            })
        };
        Ok(Project {
            kernels: [PlaneSlots::None, PlaneSlots::One, PlaneSlots::All].map(|slots| {
                [
                    CutoffListing::None,
                    CutoffListing::Records,
                    CutoffListing::RecordsAndRegions,
                    CutoffListing::Writes,
                ]
                .map(|listing| listed(slots, listing))
            }),
            texels: texels.is_some(),
            touched: ComputePipeline::new::<TouchedPush>(
                ctx,
                c"project_touched",
                shaders::PROJECT_TOUCHED,
            )?,
            records_args: LazyPipeline::new::<LinearArgsPush>(
                ctx,
                c"linear_args",
                shaders::LINEAR_ARGS,
                None,
            ),
            // On CPU drivers through the frame's texel views, as project.
            records: match texels {
                Some(_) => LazyPipeline::new::<RecordsPush>(
                    ctx,
                    c"cutoff_records_texels",
                    shaders::CUTOFF_RECORDS_TEXELS,
                    texels,
                ),
                None => LazyPipeline::new::<RecordsPush>(
                    ctx,
                    c"cutoff_records",
                    shaders::CUTOFF_RECORDS,
                    None,
                ),
            },
        })
    }

    /// The listing a frame needs: `rara` clipped or not; with `object_regions` (several
    /// objects clipped by regions of their own) or not. The texel kernels (CPU drivers) leave
    /// the records to their own pass (a CPU driver runs a branch's stores, masked, in every
    /// SIMD vector), which also bounds the splats' weights for the cutoff tiles; on GPUs
    /// project writes them, and the cutoff-tiles kernels bound the weights themselves.
    pub fn listing(&self, rara: bool, object_regions: bool) -> CutoffListing {
        match (rara, object_regions) {
            (false, _) => CutoffListing::None,
            (true, true) => CutoffListing::RecordsAndRegions,
            (true, false) if self.texels => CutoffListing::Records,
            (true, false) => CutoffListing::Writes,
        }
    }

    /// The kernel for `scene`'s SH degree and precision with `listing` and `slots`.
    fn kernel(&self, scene: &GpuScene, listing: CutoffListing, slots: PlaneSlots) -> &LazyPipeline {
        let precision = match scene.sh_precision {
            ShPrecision::F32 => 0,
            ShPrecision::F16 => 1,
        };
        &self.kernels[slots as usize][listing as usize][precision][scene.sh_degree.min(3) as usize]
    }

    /// Builds the kernels a frame of `scene` with `listing` and `slots` needs, if they were
    /// not yet: call it before [`Project::record`] with the same listing and slots.
    pub fn prepare(
        &self,
        scene: &GpuScene,
        listing: CutoffListing,
        slots: PlaneSlots,
    ) -> Result<()> {
        self.kernel(scene, listing, slots).get()?;
        if listing.has_records_pass() {
            self.records_args.get()?;
            self.records.get()?;
        }
        Ok(())
    }

    /// Records stage 1 of a frame, the pass "project": every Gaussian of `scene` classified,
    /// culled and projected, with a barrier after it; on images of more than
    /// [`TILE_RECT_CHUNK`](crate::constants::TILE_RECT_CHUNK) tiles, then the later rounds of
    /// the count of tiles touched ([`super::tile_rect_rounds`]). The texel kernels read the
    /// frame's texel views. With `object_clips` each object is projected by a dispatch of its
    /// own, against its own region. `listing` is the frame's ([`Project::listing`]): with
    /// [`CutoffListing::Writes`] project writes the cutoff records at `f.at.cutoffs` itself.
    /// With a records' pass, `cutoff_pairs` is the frame's cutoff-pairs buffer, where project
    /// lists the cutoff Gaussians; then the pass "cutoff records": one invocation writes the
    /// dispatch arguments over the cutoff records (at [`CUTOFF_ARGS_OFFSET`], where the
    /// cutoff-tiles stage finds them too) and `cutoff_records` writes the records at
    /// `f.at.cutoffs`, each followed by a barrier. `slots` is the frame's
    /// ([`PlaneSlots::for_frame`]).
    #[allow(clippy::too_many_arguments)]
    pub fn record(
        &self,
        f: &mut FrameRecording,
        scene: &GpuScene,
        object_clips: Option<&ObjectClipRanges>,
        listing: CutoffListing,
        slots: PlaneSlots,
        cutoff_pairs: Option<&Buffer>,
    ) {
        assert_eq!(
            cutoff_pairs.is_some(),
            listing.has_records_pass(),
            "a records' pass needs the cutoff-pairs buffer"
        );
        let kernel = self.kernel(scene, listing, slots).built();
        let push = ProjectPush {
            frame: f.at.params,
            gaussians: scene.gaussians.address,
            sh: scene.sh.address,
            splats: f.at.splats,
            tiles_touched: f.at.tiles_touched,
            drawn: f.at.slots,
            counters: f.at.counters,
            clip: f.at.clip,
            cutoff_gaussians: cutoff_pairs.map_or(0, |b| b.address + CUTOFF_PAIRS_OFFSET),
            cutoff_regions: 0,
            cutoffs: if listing == CutoffListing::Writes {
                f.at.cutoffs
            } else {
                0
            },
            first: 0,
            end: scene.count,
            region: 0,
            pad: 0,
        };
        let grid = super::linear_grid(scene.count);
        let rounds = super::tile_rect_rounds(f.tile_count());
        f.pass(c"project", |f| {
            match object_clips {
                None => kernel.dispatch_in(f.cmd, &push, f.texels, grid),
                Some(clips) => {
                    // The objects' Gaussians are disjoint: no barrier between them.
                    for (region, &(first, end, clip)) in clips.objects.iter().enumerate() {
                        let p = ProjectPush {
                            clip,
                            cutoff_regions: clips.cutoff_regions,
                            first,
                            end,
                            region: region as u32,
                            ..push
                        };
                        let grid = super::linear_grid(end - first);
                        kernel.dispatch_in(f.cmd, &p, f.texels, grid);
                    }
                }
            }
            f.barrier();
            for round_index in 1..rounds {
                let touched = TouchedPush {
                    frame: push.frame,
                    splats: push.splats,
                    tiles_touched: push.tiles_touched,
                    drawn: push.drawn,
                    round_index,
                    pad: 0,
                };
                self.touched.dispatch(f.cmd, &touched, grid);
                f.barrier();
            }
        });
        if let Some(pairs) = cutoff_pairs {
            f.pass(c"cutoff records", |f| {
                let args = LinearArgsPush {
                    count: f.at.counter(COUNTER_CUTOFF),
                    args: pairs.address + CUTOFF_ARGS_OFFSET,
                };
                self.records_args.built().dispatch(f.cmd, &args, [1, 1, 1]);
                f.barrier();
                let records = RecordsPush {
                    frame: push.frame,
                    gaussians: push.gaussians,
                    counters: push.counters,
                    cutoff_gaussians: push.cutoff_gaussians,
                    cutoffs: f.at.cutoffs,
                    splats: f.at.splats,
                    clip: f.at.clip,
                    cutoff_bounds: f.at.cutoff_bounds,
                    tiles_touched: f.at.tiles_touched,
                };
                self.records.built().dispatch_indirect_in(
                    f.cmd,
                    &records,
                    f.texels,
                    pairs.raw,
                    CUTOFF_ARGS_OFFSET,
                );
                f.barrier();
            });
        }
    }
}
