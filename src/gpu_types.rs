//! Host mirrors of the structs in `glsl/common.glsl` and `glsl/sort_common.glsl`.
//!
//! `#[repr(C)]` + bytemuck, explicit padding, sizes asserted at compile time; the `layout`
//! test checks the member offsets against the compiled SPIR-V.

use bytemuck::{Pod, Zeroable};

use crate::constants::MAX_CLIP_PLANES;

/// `Gaussian` in common.glsl: one uploaded Gaussian, activated values.
#[repr(C)]
#[derive(Clone, Copy, Debug, Default, Pod, Zeroable)]
pub struct GpuGaussian {
    /// Centre xyz and opacity.
    pub pos_opacity: [f32; 4],
    /// Normalised quaternion (w, x, y, z).
    pub rot: [f32; 4],
    /// Scales xyz, w unused.
    pub scale: [f32; 4],
}

/// `ProjectedSplatWords` in common.glsl: the project stage's output per Gaussian, as it lies in
/// memory (`ProjectedSplat` is the same unpacked).
#[repr(C)]
#[derive(Clone, Copy, Debug, Default, Pod, Zeroable)]
pub struct GpuProjectedSplat {
    /// Image coordinates of the centre.
    pub uv: [f32; 2],
    /// Opacity.
    pub opacity: f32,
    /// The SH colour's first word, packed ([`GpuProjectedSplat::color`]).
    pub color0: u32,
    /// Conic (A, B, C).
    pub conic: [f32; 3],
    /// The SH colour's second word.
    pub color1: u32,
    /// View-space depth.
    pub depth: f32,
    /// Cutoff side-record index, or `u32::MAX`.
    pub cutoff: u32,
    /// 3-sigma radius in pixels (a whole number), or -1 for a Gaussian project skipped. The
    /// tile rectangle is not stored: [`GpuProjectedSplat::tile_rect`] derives it.
    pub radius: f32,
    /// Unused.
    pub pad: u32,
}

/// `SPLAT_COLOR_BIAS` in common.glsl.
const SPLAT_COLOR_BIAS: u32 = 111 << 16;

impl GpuProjectedSplat {
    /// The SH colour (`unpack_splat_color` in common.glsl): each channel kept as 21 bits, 5 of
    /// exponent and 16 of mantissa, relative error at most 2^-17 (0 below 2^-15).
    pub fn color(&self) -> [f32; 3] {
        let channel = |v: u32| {
            if v == 0 {
                0.0
            } else {
                f32::from_bits((v + SPLAT_COLOR_BIAS) << 7)
            }
        };
        let g = (self.color0 >> 21) | ((self.color1 >> 21) << 11);
        [
            channel(self.color0 & 0x1f_ffff),
            channel(g),
            channel(self.color1 & 0x1f_ffff),
        ]
    }

    /// Whether project drew this Gaussian (else it skipped it and nothing else is written).
    pub fn drawn(&self) -> bool {
        self.radius >= 0.0
    }

    /// The tiles (x0, y0, x1, y1), end exclusive, of its 3-sigma square in a grid of `grid`
    /// tiles: `splat_tile_rect` in common.glsl through its CPU twin
    /// [`crate::camera::tile_rect`], the same operations on the same floats (the
    /// division by the tile size is exact). Empty for a skipped Gaussian.
    pub fn tile_rect(&self, grid: (u32, u32)) -> [u32; 4] {
        if !self.drawn() {
            return [0; 4];
        }
        let uv = glam::Vec2::from(self.uv);
        crate::camera::tile_rect(uv, self.radius, grid)
    }
}

/// `FrameParams` in common.glsl: camera and frame constants, written each frame.
#[repr(C)]
#[derive(Clone, Copy, Debug, Default, Pod, Zeroable)]
pub struct GpuFrameParams {
    /// Rows of `R_wc`, w unused.
    pub world_to_cam: [[f32; 4]; 3],
    /// Camera centre, w unused.
    pub cam_pos: [f32; 4],
    /// fx, fy, cx, cy.
    pub focal: [f32; 4],
    /// Background rgb, a unused.
    pub background: [f32; 4],
    /// W, H, tiles x, tiles y.
    pub size: [u32; 4],
    /// Gaussians, SH degree, SH floats per Gaussian, intersection capacity.
    pub scene: [u32; 4],
}

/// `SortInfo` in sort_common.glsl: the radix sort's GPU-side sizes and dispatch arguments.
#[repr(C)]
#[derive(Clone, Copy, Debug, Default, Pod, Zeroable)]
pub struct GpuSortInfo {
    /// Keys being sorted (clamped to capacity).
    pub num_keys: u32,
    /// Blocks of `block_keys` keys.
    pub num_blocks: u32,
    /// Histogram entries per block (the layout's) times num_blocks.
    pub hist_len: u32,
    /// Keys per block: the layout's, or in the CPU-driver layout a power-of-two multiple of
    /// it for a sort with many keys (`SORT_PARALLEL_BLOCKS` in constants.rs).
    pub block_keys: u32,
    /// Indirect dispatch arguments: one workgroup per block.
    pub block_args: [u32; 4],
    /// Indirect dispatch arguments: one invocation per key.
    pub linear_args: [u32; 4],
    /// 1 where the sort is segmented (CPU-driver layout, sorts of
    /// [`SORT_SEGMENT_MIN_KEYS`](crate::constants::SORT_SEGMENT_MIN_KEYS) or more): the first
    /// pass sorts by the top digit, the others each of its buckets by the other digits.
    pub segmented: u32,
    /// Runs of the passes of a segmented sort that sort its buckets in runs
    /// (`sort_segments.comp` lists them).
    pub seg_runs: u32,
    /// Unused.
    pub seg_pad: [u32; 2],
    /// Indirect dispatch arguments of passes 1, 2 and 3: a workgroup per `SORT_OWN_WORKGROUP`
    /// runs of a segmented sort, none for a pass that `sort_local_*` made, `block_args`
    /// where the sort is not segmented.
    pub pass_args: [[u32; 4]; 3],
    /// Indirect dispatch arguments of `sort_local_*`: a workgroup per `SORT_OWN_WORKGROUP`
    /// buckets of a segmented sort whose buckets are all small enough, else none.
    pub local_args: [u32; 4],
}

/// `ClipParams` in clip.glsl: the clip region and mode of a frame (see [`crate::clip::Clip`]).
#[repr(C)]
#[derive(Clone, Copy, Debug, Default, Pod, Zeroable)]
pub struct GpuClipParams {
    /// Mode (`CLIP_MODE_*`), weight (`CLIP_WEIGHT_*`), flags (`CLIP_FLAG_*`), plane count.
    pub config: [u32; 4],
    /// band, band^2, unused, unused.
    pub band: [f32; 4],
    /// Sphere centre xyz and radius (with `CLIP_FLAG_SPHERE`).
    pub sphere: [f32; 4],
    /// Half-spaces `(n, d)`, visible where `n.x + d >= 0`.
    pub planes: [[f32; 4]; MAX_CLIP_PLANES as usize],
}

/// `CutoffRecord` in common.glsl: what a cutoff Gaussian carries for the per-pixel weight.
/// Rows of `M = S^-1 R^T` in xyz, and `o' = M (eye - mu)` spread over the three w; for a flat
/// Gaussian `(n, n.(eye - mu))`, `(eye - mu, 0)` and zeros (see `glsl/clip.glsl`).
#[repr(C)]
#[derive(Clone, Copy, Debug, Default, Pod, Zeroable)]
pub struct GpuCutoffRecord {
    /// Row 0 of `M`, `o'.x`.
    pub m0: [f32; 4],
    /// Row 1 of `M`, `o'.y`.
    pub m1: [f32; 4],
    /// Row 2 of `M`, `o'.z`.
    pub m2: [f32; 4],
}

/// Bytes of one [`GpuCutoffRecord`].
pub const CUTOFF_RECORD_BYTES: u64 = std::mem::size_of::<GpuCutoffRecord>() as u64;

const _: () = assert!(std::mem::size_of::<GpuGaussian>() == 48);
const _: () =
    assert!(std::mem::size_of::<GpuClipParams>() == crate::constants::CLIP_PARAMS_BYTES as usize);
const _: () = assert!(std::mem::size_of::<GpuClipParams>() == 48 + 16 * MAX_CLIP_PLANES as usize);
const _: () = assert!(std::mem::size_of::<GpuCutoffRecord>() == 48);
const _: () = assert!(std::mem::size_of::<GpuProjectedSplat>() == 48);
const _: () = assert!(std::mem::size_of::<GpuFrameParams>() == 128);
const _: () = assert!(std::mem::size_of::<GpuSortInfo>() == 128);

/// Byte offset of the block histogram in the sort's scratch buffer (after [`GpuSortInfo`]).
pub const SORT_HIST_OFFSET: u64 = 128;
const _: () = assert!(std::mem::size_of::<GpuSortInfo>() as u64 <= SORT_HIST_OFFSET);
