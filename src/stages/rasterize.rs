//! Stage 7: composite each tile's sorted splats per pixel (`glsl/rasterize_body.glsl`; CPU twin
//! `reference::rasterize`).

use ash::vk;
use bytemuck::{Pod, Zeroable};

use std::ffi::CStr;
use std::sync::OnceLock;

use super::sh_texel;
use super::sort::SortBuffers;
use super::tile_lists::TileListsLayout;
use super::FrameRecording;
use crate::clip::ClipWeight;
use crate::constants::{
    CLIP_FLAG_SPHERE, CLIP_MODE_NONE, FLAT_SPLATS_CONSTANT_ID, MAX_INTERSECTIONS,
    RASTER_MASS_ONE_END_CONSTANT_ID, RASTER_WRITES_TARGET_CONSTANT_ID,
};
use crate::error::{Error, Result};
use crate::gpu_scene::GpuScene;
use crate::gpu_types::GpuClipParams;
use crate::shaders;
use crate::vk::{Buffer, ComputePipeline, Context, LazyPipeline};

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
    /// left for the write-target stage. The kernels that write the target themselves
    /// (`WRITES_TARGET`) take the RGBA8 buffer target's address here instead.
    pub state: u64,
    /// Frame counters (longest tile list).
    pub counters: u64,
    /// `ClipParams`.
    pub clip: u64,
    /// Cutoff side records (0 when the frame is not rara-clipped).
    pub cutoffs: u64,
    /// With `ROUND_TILE_LIST` in `flags`: the ids of the tiles to walk, one per workgroup.
    pub tiles: u64,
    /// With the depth kernels: per pixel the depth sums (median, sum alpha T z).
    pub depth_state: u64,
    /// With the depth kernels: per pixel the engine's view depth (0: no depth test).
    pub depth_limit: u64,
    /// With the object-clip kernels: per cutoff record, the index of its region in the array
    /// at `clip`.
    pub cutoff_regions: u64,
    /// Which RASTER_CHUNK of every tile list this dispatch walks.
    pub round_index: u32,
    /// ROUND_FIRST on the first round.
    pub flags: u32,
    /// Over the grid (no tile list): the rows of tiles in `spread_item` order with this stride
    /// ([`super::spread_stride`] on CPU drivers, 1 on GPUs).
    pub row_stride: u32,
    /// Padding to 8 bytes.
    pub pad: u32,
}

const ROUND_FIRST: u32 = 1;
const ROUND_TILE_LIST: u32 = 2;

/// Texels of `R32G32B32A32_UINT` per projected splat (48 bytes) in the strips kernels' view.
const SPLAT_TEXELS: u64 = 3;

/// Whether the strips kernels' texel view of the projected splats holds a scene of
/// `gaussians` on a device with `max_texels` texels per view (the cutoff records take 3 per
/// Gaussian, so they fit too).
fn strips_scene_fits(gaussians: u32, max_texels: u32) -> Result<()> {
    let max_texels = max_texels as u64;
    if gaussians as u64 * SPLAT_TEXELS > max_texels {
        return Err(Error::InvalidInput(format!(
            "{gaussians} Gaussians exceed the {} the strips rasterizer can read on this device \
             ({SPLAT_TEXELS} texels each, maxTexelBufferElements = {max_texels}); \
             RARA_RASTER=pixels selects the other layout",
            max_texels / SPLAT_TEXELS
        )));
    }
    Ok(())
}

/// How the rasterizer maps pixels to invocations. Both give the same image, to float rounding
/// (a pixel here and there off by one in 8 bits).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum RasterLayout {
    /// One invocation per pixel, 256 per tile (`rasterize`): the layout for GPUs.
    PixelPerInvocation,
    /// One invocation per column of 8 pixels, 32 per tile (`rasterize_strips*`): for CPU
    /// drivers such as lavapipe, where each splat is then loaded once for 8 pixels, each 8x8
    /// block of a tile is one 8-lane SIMD vector, and a vector passes over the pairs whose
    /// footprint misses its block ([`crate::constants::PAIR_BLOCKS_SHIFT`]). The kernels fetch the splats from uniform texel
    /// buffers ([`super::frame_texels_set_layout`]), which caps a frame's pairs and a scene's
    /// Gaussians ([`Rasterize::pair_limit`], [`Rasterize::check_scene`]).
    Strips,
}

impl RasterLayout {
    /// The layout for a device: strips for the CPU drivers' layouts ([`super::cpu_layouts`],
    /// [`RasterLayout::Strips`]), a pixel per invocation elsewhere.
    /// `RARA_RASTER=pixels|strips` overrides the choice.
    pub fn for_device(ctx: &Context) -> RasterLayout {
        match std::env::var("RARA_RASTER").as_deref() {
            Ok("pixels") => return RasterLayout::PixelPerInvocation,
            Ok("strips") => return RasterLayout::Strips,
            _ => {}
        }
        if super::cpu_layouts(ctx) {
            RasterLayout::Strips
        } else {
            RasterLayout::PixelPerInvocation
        }
    }
}

/// How many bounded ends the visible set of a pixel's ray can have under a frame's clip region
/// (`MassEnds` in `glsl/clip.glsl`), which picks the mass-weight kernel: a region of one plane
/// gives each ray at most one, the others up to two.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum MassEnds {
    /// At most one: no region, or one plane, kept or inverted. The kernels built with
    /// `MASS_ONE_END` weigh that end alone (`glsl/rasterize_body.glsl`).
    One,
    /// Up to two: several planes (a box), a sphere.
    Two,
}

impl MassEnds {
    /// The ends under the frame's region `clip` (its GPU form).
    pub fn for_region(clip: &GpuClipParams) -> MassEnds {
        let sphere = clip.config[2] & CLIP_FLAG_SPHERE != 0;
        if clip.config[0] == CLIP_MODE_NONE || (!sphere && clip.config[3] <= 1) {
            MassEnds::One
        } else {
            MassEnds::Two
        }
    }
}

/// The rasterize kernels of one layout: without rara clipping, and with each cutoff weight.
/// CPU drivers execute both sides of every branch, so each frame runs the kernel that holds
/// only the code it needs.
pub struct Rasterize {
    /// Without and with the depth test and the depth outputs (SPEC section 9): the kernels
    /// without rara clipping, with the mass weight and with the length weight. Each is built
    /// when a frame first needs it ([`Rasterize::prepare`]).
    kernels: [[LazyPipeline; 3]; 2],
    /// The weighted ones (mass, length) built for frames without flat Gaussians (SPEC section
    /// 6): the flat Gaussians' branches of the weight code compiled out (`FLAT_SPLATS` in
    /// `glsl/clip.glsl`), which a CPU driver would otherwise run, masked, for every cutoff
    /// splat.
    volume: [[LazyPipeline; 2]; 2],
    /// The mass kernels for frames whose rays have one bounded end ([`MassEnds::One`]), built
    /// with `MASS_ONE_END` true: without and with the depth test, each for frames that may
    /// hold flat Gaussians and for frames without.
    one_end: [[LazyPipeline; 2]; 2],
    /// The strips layout's kernels without the depth test again, built with `WRITES_TARGET`
    /// (`glsl/rasterize_body.glsl`) true, for frames that [`Rasterize::record`] with a target:
    /// without rara clipping; mass and length; mass and length without flat Gaussians; mass
    /// with one bounded end, with and without flat Gaussians.
    to_target: Option<[LazyPipeline; 7]>,
    /// The kernels for several objects each clipped by a region of its own (`OBJECT_CLIPS`):
    /// mass, length, and the two with the depth test. Built on first use
    /// ([`Rasterize::prepare_object_clips`]), as few frames need them.
    object_clips: OnceLock<[ComputePipeline; 4]>,
    texels: Option<vk::DescriptorSetLayout>,
    layout: RasterLayout,
}

/// The kernels of each layout, (name, SPIR-V) without and with the depth test: without rara
/// clipping, with the mass weight, with the length weight.
type KernelTable = [[(&'static CStr, &'static [u32]); 3]; 2];
const KERNELS: [KernelTable; 2] = [
    [
        [
            (c"rasterize", shaders::RASTERIZE),
            (c"rasterize_mass", shaders::RASTERIZE_MASS),
            (c"rasterize_length", shaders::RASTERIZE_LENGTH),
        ],
        [
            (c"rasterize_depth", shaders::RASTERIZE_DEPTH),
            (c"rasterize_mass_depth", shaders::RASTERIZE_MASS_DEPTH),
            (c"rasterize_length_depth", shaders::RASTERIZE_LENGTH_DEPTH),
        ],
    ],
    [
        [
            (c"rasterize_strips", shaders::RASTERIZE_STRIPS),
            (c"rasterize_strips_mass", shaders::RASTERIZE_STRIPS_MASS),
            (c"rasterize_strips_length", shaders::RASTERIZE_STRIPS_LENGTH),
        ],
        [
            (c"rasterize_strips_depth", shaders::RASTERIZE_STRIPS_DEPTH),
            (
                c"rasterize_strips_mass_depth",
                shaders::RASTERIZE_STRIPS_MASS_DEPTH,
            ),
            (
                c"rasterize_strips_length_depth",
                shaders::RASTERIZE_STRIPS_LENGTH_DEPTH,
            ),
        ],
    ],
];

/// The object-clip kernels of each layout: (name, SPIR-V) of mass, length, mass with depth,
/// length with depth.
const OBJECT_CLIP_KERNELS: [[(&CStr, &[u32]); 4]; 2] = [
    [
        (c"rasterize_mass_objects", shaders::RASTERIZE_MASS_OBJECTS),
        (
            c"rasterize_length_objects",
            shaders::RASTERIZE_LENGTH_OBJECTS,
        ),
        (
            c"rasterize_mass_objects_depth",
            shaders::RASTERIZE_MASS_OBJECTS_DEPTH,
        ),
        (
            c"rasterize_length_objects_depth",
            shaders::RASTERIZE_LENGTH_OBJECTS_DEPTH,
        ),
    ],
    [
        (
            c"rasterize_strips_mass_objects",
            shaders::RASTERIZE_STRIPS_MASS_OBJECTS,
        ),
        (
            c"rasterize_strips_length_objects",
            shaders::RASTERIZE_STRIPS_LENGTH_OBJECTS,
        ),
        (
            c"rasterize_strips_mass_objects_depth",
            shaders::RASTERIZE_STRIPS_MASS_OBJECTS_DEPTH,
        ),
        (
            c"rasterize_strips_length_objects_depth",
            shaders::RASTERIZE_STRIPS_LENGTH_OBJECTS_DEPTH,
        ),
    ],
];

impl Rasterize {
    /// Builds the kernels in `layout`; the strips kernels need `texels`, the layout of the
    /// frame's texel views.
    pub fn new(
        ctx: &Context,
        layout: RasterLayout,
        texels: Option<vk::DescriptorSetLayout>,
    ) -> Result<Self> {
        let build = |name: &'static CStr, spirv: &'static [u32]| {
            LazyPipeline::new::<RasterizePush>(ctx, name, spirv, texels)
        };
        if layout == RasterLayout::Strips && texels.is_none() {
            return Err(Error::InvalidInput(
                "the strips rasterizer needs the frame's texel views".into(),
            ));
        }
        let table = &KERNELS[(layout == RasterLayout::Strips) as usize];
        let kernels = table.map(|row| row.map(|(name, spirv)| build(name, spirv)));
        let no_flat = (FLAT_SPLATS_CONSTANT_ID, 0);
        let one = (RASTER_MASS_ONE_END_CONSTANT_ID, 1);
        // The weighted kernels again with FLAT_SPLATS false, for frames without flat Gaussians.
        let volume = table.map(|row| {
            [row[1], row[2]].map(|(name, spirv)| build(name, spirv).specialized(&[no_flat]))
        });
        // The mass kernels with MASS_ONE_END, for frames clipped by one plane.
        let one_end = table.map(|row| {
            let (name, spirv) = row[1];
            [
                build(name, spirv).specialized(&[one]),
                build(name, spirv).specialized(&[no_flat, one]),
            ]
        });
        let to_target = (layout == RasterLayout::Strips).then(|| {
            let row = &table[0];
            let writes = (RASTER_WRITES_TARGET_CONSTANT_ID, 1);
            [
                build(row[0].0, row[0].1).specialized(&[writes]),
                build(row[1].0, row[1].1).specialized(&[writes]),
                build(row[2].0, row[2].1).specialized(&[writes]),
                build(row[1].0, row[1].1).specialized(&[no_flat, writes]),
                build(row[2].0, row[2].1).specialized(&[no_flat, writes]),
                build(row[1].0, row[1].1).specialized(&[one, writes]),
                build(row[1].0, row[1].1).specialized(&[no_flat, one, writes]),
            ]
        });
        Ok(Rasterize {
            kernels,
            volume,
            one_end,
            to_target,
            object_clips: OnceLock::new(),
            texels,
            layout,
        })
    }

    /// Whether the kernels can write an RGBA8 buffer target themselves ([`Rasterize::record`]
    /// with a target): the strips layout's.
    pub fn writes_targets(&self) -> bool {
        self.to_target.is_some()
    }

    /// The kernel without object clips for `weight` (`None`: no rara clipping), with or without
    /// the depth test; `flat`: for a frame that may hold flat Gaussians; `ends`: the ends of
    /// the frame's rays (the mass weight); `to_target`: one that writes the target itself (no
    /// depth test; [`Rasterize::writes_targets`]).
    fn lazy_kernel(
        &self,
        weight: Option<ClipWeight>,
        depth: bool,
        (flat, ends): (bool, MassEnds),
        to_target: bool,
    ) -> &LazyPipeline {
        let one_end = weight == Some(ClipWeight::Mass) && ends == MassEnds::One;
        if to_target {
            let kernels = self
                .to_target
                .as_ref()
                .expect("a layout whose kernels write targets");
            debug_assert!(!depth);
            return match weight {
                None => &kernels[0],
                Some(_) if one_end => &kernels[5 + !flat as usize],
                Some(w) => &kernels[(w == ClipWeight::Length) as usize + if flat { 1 } else { 3 }],
            };
        }
        let depth = depth as usize;
        if one_end {
            return &self.one_end[depth][!flat as usize];
        }
        match weight {
            None => &self.kernels[depth][0],
            Some(w) => {
                let k = (w == ClipWeight::Length) as usize;
                if flat {
                    &self.kernels[depth][1 + k]
                } else {
                    &self.volume[depth][k]
                }
            }
        }
    }

    /// Builds what a frame of `weight` (with or without `depth`; `flat`: with flat Gaussians
    /// in the frame; `ends`: the ends of its rays under its region; `to_target`: the kernels
    /// that write the target) records, if it was not built yet: its kernel, and with
    /// `plain_too` (tile lists) the plain one beside it. Call it before [`Rasterize::record`].
    pub fn prepare(
        &self,
        weight: Option<ClipWeight>,
        depth: bool,
        plain_too: bool,
        (flat, ends): (bool, MassEnds),
        to_target: bool,
    ) -> Result<()> {
        self.lazy_kernel(weight, depth, (flat, ends), to_target)
            .get()?;
        if plain_too {
            self.lazy_kernel(None, depth, (flat, ends), to_target)
                .get()?;
        }
        Ok(())
    }

    /// Builds the kernels for objects clipped by regions of their own, once: call it before
    /// recording such a frame ([`Rasterize::record`] with `object_clips`).
    pub fn prepare_object_clips(&self, ctx: &Context) -> Result<()> {
        if self.object_clips.get().is_some() {
            return Ok(());
        }
        let table = &OBJECT_CLIP_KERNELS[match self.layout {
            RasterLayout::PixelPerInvocation => 0,
            RasterLayout::Strips => 1,
        }];
        let build = |(name, spirv): (&'static CStr, &[u32])| {
            ComputePipeline::with_set_layout::<RasterizePush>(ctx, name, spirv, self.texels)
        };
        let kernels = [
            build(table[0])?,
            build(table[1])?,
            build(table[2])?,
            build(table[3])?,
        ];
        // Another thread may have built them meanwhile: either set is the same kernels.
        let _ = self.object_clips.set(kernels);
        Ok(())
    }

    /// The layout the kernels were built in.
    pub fn layout(&self) -> RasterLayout {
        self.layout
    }

    /// The most sorted pairs a frame may have: [`MAX_INTERSECTIONS`], and for the strips
    /// kernels no more than a texel buffer holds (`maxTexelBufferElements`, 134,217,728 on
    /// lavapipe). A frame with more is drawn incomplete, as at [`MAX_INTERSECTIONS`].
    pub fn pair_limit(&self, ctx: &Context) -> u64 {
        match self.layout {
            RasterLayout::PixelPerInvocation => MAX_INTERSECTIONS,
            RasterLayout::Strips => {
                MAX_INTERSECTIONS.min(ctx.info().max_texel_buffer_elements as u64)
            }
        }
    }

    /// Whether the frame's texel views can hold `scene` when the kernels read through them
    /// (the strips layout): 4 texels per projected splat (3 per cutoff record), and the
    /// scene's Gaussians and SH coefficients ([`super::frame_texels_set_layout`]).
    pub fn check_scene(&self, ctx: &Context, scene: &GpuScene) -> Result<()> {
        if self.layout == RasterLayout::PixelPerInvocation {
            return Ok(());
        }
        let max_texels = ctx.info().max_texel_buffer_elements;
        strips_scene_fits(scene.len(), max_texels)?;
        let (gaussians, sh, _) = scene.buffers();
        let (_, sh_texel_bytes) = sh_texel(scene.sh_precision());
        for (what, texels) in [
            ("Gaussians", gaussians.size / 16),
            ("SH coefficients", sh.size / sh_texel_bytes),
        ] {
            if texels > max_texels as u64 {
                return Err(Error::InvalidInput(format!(
                    "the scene's {what} take {texels} texels, more than a texel buffer holds on \
                     this device (maxTexelBufferElements = {max_texels}); RARA_RASTER=pixels \
                     selects the layout that reads them as buffers"
                )));
            }
        }
        Ok(())
    }

    /// Records the pass "rasterize": `rounds` rounds over the grid, each walking the next
    /// RASTER_CHUNK entries of every tile list (the pairs sorted into buffer `sorted` of
    /// `sort`), then a barrier. `cutoff_weight` is the weight of the frame's rara clipping,
    /// `None` when no splat is cutoff; `flat`, whether the frame may hold flat Gaussians, and
    /// `ends`, the ends of its rays (the kernels [`Rasterize::prepare`] built for the same).
    /// With `lists` (the frame's tile-lists buffer and its layout, [`super::tile_lists`]; mass
    /// weight only) each round runs the plain kernel over the plain list and the weighted
    /// kernel over the weighted list, as indirect dispatches; else one kernel over the whole
    /// grid. The strips kernels read the frame's texel views.
    /// With `depth` (the addresses of the per-pixel depth sums and of the engine's view depth,
    /// 0 without a depth test) the depth kernels run (SPEC section 9). With `object_clips` (the
    /// address of each cutoff record's region; the frame's clip address is then the array of
    /// the objects' regions; no `lists`) the object-clip kernels run, which
    /// [`Rasterize::prepare_object_clips`] must have built. With `target` (the address of an
    /// RGBA8 buffer target; one round, no `depth`, no `object_clips`, the strips layout) the
    /// kernels write the frame over the background into it instead of the per-pixel state,
    /// and the frame needs no write-target pass.
    #[allow(clippy::too_many_arguments)]
    pub fn record(
        &self,
        f: &mut FrameRecording,
        (sort, sorted): (&SortBuffers, usize),
        rounds: u32,
        (cutoff_weight, flat, ends): (Option<ClipWeight>, bool, MassEnds),
        lists: Option<(&Buffer, TileListsLayout)>,
        depth: Option<(u64, u64)>,
        object_clips: Option<u64>,
        target: Option<u64>,
    ) {
        debug_assert!(
            target.is_none() || (rounds == 1 && depth.is_none() && object_clips.is_none())
        );
        let to_target = target.is_some();
        let push = RasterizePush {
            frame: f.at.params,
            splats: f.at.splats,
            values: sort.values[sorted].address,
            ranges: f.at.ranges,
            state: target.unwrap_or(f.at.state),
            counters: f.at.counters,
            clip: f.at.clip,
            cutoffs: f.at.cutoffs,
            tiles: 0,
            depth_state: depth.map_or(0, |d| d.0),
            depth_limit: depth.map_or(0, |d| d.1),
            cutoff_regions: object_clips.unwrap_or(0),
            round_index: 0,
            flags: 0,
            row_stride: match self.layout {
                RasterLayout::Strips => super::spread_stride(f.grid.1),
                RasterLayout::PixelPerInvocation => 1,
            },
            pad: 0,
        };
        let object_kernels = || {
            self.object_clips
                .get()
                .expect("Rasterize::prepare_object_clips before an object-clip frame")
        };
        // The kernel of the frame's weight; with tile lists, the plain one too.
        let kernel = |weight: Option<ClipWeight>| -> &ComputePipeline {
            let with_depth = depth.is_some() as usize;
            match (weight, object_clips) {
                (None, _) => self
                    .lazy_kernel(None, depth.is_some(), (flat, ends), to_target)
                    .built(),
                (Some(w), Some(_)) => {
                    let k = (w == ClipWeight::Length) as usize;
                    &object_kernels()[2 * with_depth + k]
                }
                (Some(w), None) => self
                    .lazy_kernel(Some(w), depth.is_some(), (flat, ends), to_target)
                    .built(),
            }
        };
        let pipeline = kernel(cutoff_weight);
        debug_assert!(lists.is_none() || cutoff_weight == Some(ClipWeight::Mass));
        debug_assert!(lists.is_none() || object_clips.is_none());
        let (gx, gy) = f.grid;
        f.pass(c"rasterize", |f| {
            for round in 0..rounds {
                let mut p = push;
                p.round_index = round;
                p.flags = if round == 0 { ROUND_FIRST } else { 0 };
                match lists {
                    Some((buffer, layout)) => {
                        p.flags |= ROUND_TILE_LIST;
                        // The two lists hold disjoint tiles: no barrier between them. (Tile lists
                        // come with the mass weight: `pipeline` is its kernel.)
                        for (kernel, list, args) in [
                            (kernel(None), layout.plain(), TileListsLayout::PLAIN_ARGS),
                            (pipeline, layout.weighted(), TileListsLayout::WEIGHTED_ARGS),
                        ] {
                            p.tiles = buffer.address + list;
                            kernel.dispatch_indirect_in(f.cmd, &p, f.texels, buffer.raw, args);
                        }
                    }
                    None => pipeline.dispatch_in(f.cmd, &p, f.texels, [gx, gy, 1]),
                }
                if round + 1 < rounds {
                    f.barrier();
                }
            }
            f.barrier();
        });
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::clip::{Clip, ClipMode, ClipRegion, Plane};
    use glam::{Quat, Vec3};

    #[test]
    fn one_bounded_end_only_under_one_plane() {
        let ends = |region: Option<ClipRegion>| {
            let clip = Clip {
                region,
                mode: ClipMode::Rara,
                ..Clip::default()
            };
            MassEnds::for_region(&clip.to_gpu())
        };
        let plane = || Plane::new(Vec3::new(0.0, 0.26, -0.97), 0.1).unwrap();
        let one_plane = ClipRegion::planes(vec![plane()]).unwrap();
        let mut inverted = one_plane.clone();
        inverted.invert = true;
        assert_eq!(ends(None), MassEnds::One);
        assert_eq!(ends(Some(one_plane)), MassEnds::One);
        assert_eq!(ends(Some(inverted)), MassEnds::One);
        let two_planes = ClipRegion::planes(vec![plane(), plane()]).unwrap();
        assert_eq!(ends(Some(two_planes)), MassEnds::Two);
        let cube = ClipRegion::oriented_box(Vec3::ZERO, Vec3::ONE, Quat::IDENTITY).unwrap();
        assert_eq!(ends(Some(cube)), MassEnds::Two);
        let ball = ClipRegion::sphere(Vec3::ZERO, 1.0).unwrap();
        assert_eq!(ends(Some(ball)), MassEnds::Two);
    }

    #[test]
    fn strips_scene_limit_is_a_third_of_the_texels() {
        // lavapipe's maxTexelBufferElements, and the spec's minimum.
        assert!(strips_scene_fits(44_739_242, 134_217_728).is_ok());
        let err = strips_scene_fits(44_739_243, 134_217_728).unwrap_err();
        assert!(err.to_string().contains("RARA_RASTER=pixels"), "{err}");
        assert!(strips_scene_fits(21_845, 65_536).is_ok());
        assert!(strips_scene_fits(21_846, 65_536).is_err());
    }
}
