//! A scene uploaded to the device ([`GpuScene`]): the Gaussians and their SH coefficients in
//! the layouts the kernels read, reached by device address.

use crate::constants::MAX_GAUSSIANS;
use crate::error::{Error, Result};
use crate::gpu_types::GpuGaussian;
use crate::precision::{f32_to_f16_bits, ShPrecision};
use crate::scene::Scene;
use crate::vk::{Buffer, Context, MemoryLocation};

/// The Gaussian `i` of `scene` as the kernels read it (activated values, SPEC section 1).
fn gpu_gaussian(scene: &Scene, i: usize) -> GpuGaussian {
    let m = scene.means[i];
    let q = scene.rotations[i];
    let s = scene.scales[i];
    GpuGaussian {
        pos_opacity: [m.x, m.y, m.z, scene.opacities[i]],
        rot: [q.w, q.x, q.y, q.z],
        scale: [s.x, s.y, s.z, 0.0],
    }
}

/// Bytes of the two scene buffers: Gaussians and SH coefficients.
fn scene_buffer_sizes(scene: &Scene, precision: ShPrecision) -> (u64, u64) {
    let n = scene.len() as u64;
    // An empty scene still gets a 16-byte texel's worth, so that a texel view of it is valid.
    (
        (n * std::mem::size_of::<GpuGaussian>() as u64).max(16),
        (scene.sh.len() as u64 * precision.bytes() + GpuScene::SH_TAIL_BYTES).max(16),
    )
}

/// Gaussians per chunk of [`GpuScene::load_ply`]: 15 MB of host scene at SH degree 3.
pub const STREAM_CHUNK: usize = 65_536;

/// A scene uploaded to the GPU: a resource of its own, which any number of renderers of the
/// same device can draw. Dropping it frees its memory; frames that read it must have completed.
///
/// Buffers are reached by device address, never bound as descriptors, so their size is not
/// limited by `maxStorageBufferRange` (128 MiB on lavapipe): a 6M-Gaussian SH degree 3 scene is
/// one 1.15 GB SH buffer (576 MB with [`ShPrecision::F16`]).
pub struct GpuScene {
    pub(crate) gaussians: Buffer,
    pub(crate) sh: Buffer,
    pub(crate) count: u32,
    pub(crate) sh_degree: u32,
    pub(crate) sh_precision: ShPrecision,
    /// Whether a Gaussian may be flat (SPEC section 6) on the device: a scale of 0, or one so
    /// small that a driver flushing denormals to zero reads it as 0. False lets the rasterizer
    /// run its kernels without the flat Gaussians' branches (`stages::rasterize`).
    pub(crate) may_be_flat: bool,
    /// Unique per upload into new buffers: frame slots key their texel views of the scene by
    /// it (a freed buffer's handle may come back).
    pub(crate) id: u64,
    /// A BVH built once for the ray tracer ([`crate::Renderer::build_still_bvh`]), with the
    /// octagons' `Q` it was built for and an id unique to it: frames with that `Q` walk it
    /// instead of building one. Dropped whenever the Gaussians change.
    still_bvh: Option<(Buffer, f32, u64)>,
}

/// The next [`GpuScene`] id.
static NEXT_SCENE_ID: std::sync::atomic::AtomicU64 = std::sync::atomic::AtomicU64::new(1);

impl GpuScene {
    /// Bytes the SH buffer holds past the last coefficient, counted in
    /// [`GpuScene::device_bytes`]: the project kernels read a Gaussian's coefficients as whole
    /// aligned 64-bit words (`load_sh` in `glsl/sh.glsl`), up to 10 bytes past its last one
    /// (half floats, 27 values starting on a word: 8 words of 4).
    pub const SH_TAIL_BYTES: u64 = 16;

    /// Uploads `scene` to the device of `ctx` with 32-bit SH coefficients (on the context's
    /// queue, in chunks through one staging buffer; returns once the copies are done).
    pub fn new(ctx: &Context, scene: &Scene) -> Result<Self> {
        GpuScene::with_sh_precision(ctx, scene, ShPrecision::F32)
    }

    /// [`GpuScene::new`] storing the SH coefficients at `precision`.
    pub fn with_sh_precision(ctx: &Context, scene: &Scene, precision: ShPrecision) -> Result<Self> {
        if scene.len() as u64 > MAX_GAUSSIANS {
            return Err(Error::InvalidInput(format!(
                "{} Gaussians exceed the {MAX_GAUSSIANS} one scene may have",
                scene.len()
            )));
        }
        let (gaussian_bytes, sh_bytes) = scene_buffer_sizes(scene, precision);
        let gpu = MemoryLocation::GpuOnly;
        let mut gpu_scene = GpuScene {
            gaussians: Buffer::new(ctx, "scene gaussians", gaussian_bytes, gpu)?,
            sh: Buffer::new(ctx, "scene SH", sh_bytes, gpu)?,
            count: 0,
            sh_degree: scene.sh_degree,
            sh_precision: precision,
            may_be_flat: false,
            id: NEXT_SCENE_ID.fetch_add(1, std::sync::atomic::Ordering::Relaxed),
            still_bvh: None,
        };
        gpu_scene.upload(scene)?;
        Ok(gpu_scene)
    }

    /// Loads the 3DGS PLY at `path` straight into device buffers with the SH stored at
    /// `precision`: the file is read in chunks of [`STREAM_CHUNK`] Gaussians
    /// ([`crate::ply::for_each_chunk`]), each written in the kernels' layout into one reused
    /// staging buffer and copied to the device, so the host holds a chunk and never the scene
    /// (what [`crate::ply::load_ply`] followed by [`GpuScene::with_sh_precision`] would hold).
    /// The Gaussians are those `load_ply` loads, in its order, to the bit. `progress(done,
    /// total)` follows the Gaussians read of the file's vertices.
    pub fn load_ply(
        ctx: &Context,
        path: impl AsRef<std::path::Path>,
        precision: ShPrecision,
        mut progress: impl FnMut(usize, usize),
    ) -> Result<(Self, crate::ply::LoadReport)> {
        let path = path.as_ref();
        let record = std::mem::size_of::<GpuGaussian>() as u64;
        let mut staging = Buffer::new(
            ctx,
            "staging (scene stream)",
            crate::vk::buffer::STAGING_CHUNK,
            MemoryLocation::CpuToGpu,
        )?;
        let mut loaded: Option<GpuScene> = None;
        let report = crate::ply::for_each_chunk(path, STREAM_CHUNK, &mut |chunk, info| {
            let s = match &mut loaded {
                Some(s) => s,
                None => {
                    let vertices = info.vertices_in_file;
                    // The reader has checked the header against the file by now, so an error
                    // here is about the scene, not a broken file.
                    if vertices as u64 > MAX_GAUSSIANS {
                        return Err(Error::InvalidInput(format!(
                            "{}: {vertices} Gaussians exceed the {MAX_GAUSSIANS} one scene may \
                             have",
                            path.display()
                        )));
                    }
                    // Sized by the header's count; Gaussians the loader drops leave the tail
                    // unused.
                    let per_gaussian = chunk.sh_stride() as u64 * precision.bytes();
                    let gpu = MemoryLocation::GpuOnly;
                    loaded.insert(GpuScene {
                        gaussians: Buffer::new(
                            ctx,
                            "scene gaussians",
                            (vertices as u64 * record).max(16),
                            gpu,
                        )?,
                        sh: Buffer::new(
                            ctx,
                            "scene SH",
                            (vertices as u64 * per_gaussian + GpuScene::SH_TAIL_BYTES).max(16),
                            gpu,
                        )?,
                        count: 0,
                        sh_degree: chunk.sh_degree,
                        sh_precision: precision,
                        may_be_flat: false,
                        id: NEXT_SCENE_ID.fetch_add(1, std::sync::atomic::Ordering::Relaxed),
                        still_bvh: None,
                    })
                }
            };
            s.write_chunk(&mut staging, chunk, info.first)?;
            progress(info.first + chunk.len(), info.vertices_in_file);
            Ok(())
        })?;
        let scene = match loaded {
            Some(s) => s,
            None => GpuScene::with_sh_precision(ctx, &Scene::default(), precision)?,
        };
        Ok((scene, report))
    }

    /// Writes `chunk` as Gaussians `first..` (through `staging`), and counts them in.
    fn write_chunk(&mut self, staging: &mut Buffer, chunk: &Scene, first: usize) -> Result<()> {
        self.may_be_flat |= chunk
            .scales
            .iter()
            .any(|s| s.min_element().abs() < f32::MIN_POSITIVE);
        let record = std::mem::size_of::<GpuGaussian>();
        self.gaussians.upload_range_with(
            staging,
            (first * record) as u64,
            (chunk.len() * record) as u64,
            record as u64,
            |offset, bytes| {
                let at = offset as usize / record;
                for (k, out) in bytes.chunks_exact_mut(record).enumerate() {
                    out.copy_from_slice(bytemuck::bytes_of(&gpu_gaussian(chunk, at + k)));
                }
            },
        )?;
        let width = self.sh_precision.bytes();
        let sh_at = (first * chunk.sh_stride()) as u64 * width;
        let sh_len = chunk.sh.len() as u64 * width;
        match self.sh_precision {
            ShPrecision::F32 => {
                let all: &[u8] = bytemuck::cast_slice(&chunk.sh);
                self.sh
                    .upload_range_with(staging, sh_at, sh_len, 4, |offset, bytes| {
                        let offset = offset as usize;
                        bytes.copy_from_slice(&all[offset..offset + bytes.len()]);
                    })?
            }
            ShPrecision::F16 => {
                self.sh
                    .upload_range_with(staging, sh_at, sh_len, 2, |offset, bytes| {
                        let at = offset as usize / 2;
                        for (k, out) in bytes.chunks_exact_mut(2).enumerate() {
                            out.copy_from_slice(&f32_to_f16_bits(chunk.sh[at + k]).to_le_bytes());
                        }
                    })?
            }
        }
        self.count = (first + chunk.len()) as u32;
        Ok(())
    }

    /// A scene of `count` Gaussians of SH degree `sh_degree` (f32 coefficients) whose buffers
    /// the GPU fills: the merged scene of several objects (`crate::objects`).
    pub(crate) fn for_gpu_writes(ctx: &Context, count: u32, sh_degree: u32) -> Result<Self> {
        if count as u64 > MAX_GAUSSIANS {
            return Err(Error::InvalidInput(format!(
                "{count} Gaussians in all exceed the {MAX_GAUSSIANS} one frame may have"
            )));
        }
        let n = count as u64;
        let sh_floats = n * 3 * crate::scene::sh_coeffs(sh_degree) as u64;
        let gpu = MemoryLocation::GpuOnly;
        Ok(GpuScene {
            gaussians: Buffer::new(
                ctx,
                "merged objects' gaussians",
                (n * std::mem::size_of::<GpuGaussian>() as u64).max(16),
                gpu,
            )?,
            sh: Buffer::new(
                ctx,
                "merged objects' SH",
                (sh_floats * 4 + GpuScene::SH_TAIL_BYTES).max(16),
                gpu,
            )?,
            count,
            sh_degree,
            sh_precision: ShPrecision::F32,
            // The objects' transforms scale the scales: a tiny one may come out as 0.
            may_be_flat: true,
            id: NEXT_SCENE_ID.fetch_add(1, std::sync::atomic::Ordering::Relaxed),
            still_bvh: None,
        })
    }

    /// Bytes of device memory per Gaussian of a scene of `sh_degree` stored at `precision`.
    pub fn bytes_per_gaussian(sh_degree: u32, precision: ShPrecision) -> u64 {
        std::mem::size_of::<GpuGaussian>() as u64
            + 3 * crate::scene::sh_coeffs(sh_degree) as u64 * precision.bytes()
    }

    /// Writes `scene` into the buffers (which are large enough), chunk by chunk.
    fn upload(&mut self, scene: &Scene) -> Result<()> {
        // The whole scene as one chunk, through a staging buffer no larger than it needs.
        let gaussian_bytes = (scene.len() * std::mem::size_of::<GpuGaussian>()) as u64;
        let sh_bytes = scene.sh.len() as u64 * self.sh_precision.bytes();
        let mut staging = Buffer::new(
            self.gaussians.context(),
            "staging (upload)",
            crate::vk::buffer::STAGING_CHUNK.min(gaussian_bytes.max(sh_bytes)),
            MemoryLocation::CpuToGpu,
        )?;
        self.write_chunk(&mut staging, scene, 0)?;
        self.sh_degree = scene.sh_degree;
        self.still_bvh = None; // built for the Gaussians that were
        Ok(())
    }

    /// Replaces the contents with `scene` (same SH precision), reusing the device buffers when
    /// they are large enough. Frames recorded with the old contents must have completed.
    pub fn replace(&mut self, scene: &Scene) -> Result<()> {
        let (gaussian_bytes, sh_bytes) = scene_buffer_sizes(scene, self.sh_precision);
        if gaussian_bytes > self.gaussians.size || sh_bytes > self.sh.size {
            let ctx = self.gaussians.context().clone();
            *self = GpuScene::with_sh_precision(&ctx, scene, self.sh_precision)?;
            return Ok(());
        }
        self.upload(scene)
    }

    /// The nodes of the still BVH built for octagons of `q`, if any, with the tree's id
    /// (unique in the process: frame slots key their texel view of the nodes by it).
    pub(crate) fn still_bvh(&self, q: f32) -> Option<(&Buffer, u64)> {
        self.still_bvh
            .as_ref()
            .filter(|(_, built, _)| *built == q)
            .map(|(b, _, id)| (b, *id))
    }

    /// Keeps `nodes`, a BVH of the scene's Gaussians for octagons of `q`, with the scene.
    pub(crate) fn set_still_bvh(&mut self, nodes: Buffer, q: f32) {
        let id = NEXT_SCENE_ID.fetch_add(1, std::sync::atomic::Ordering::Relaxed);
        self.still_bvh = Some((nodes, q, id));
    }

    /// Whether a still BVH was built for the scene ([`crate::Renderer::build_still_bvh`]).
    pub fn has_still_bvh(&self) -> bool {
        self.still_bvh.is_some()
    }

    /// The Gaussians' and the SH coefficients' buffers, and the scene's id.
    pub(crate) fn buffers(&self) -> (&Buffer, &Buffer, u64) {
        (&self.gaussians, &self.sh, self.id)
    }

    /// How the SH coefficients are stored.
    pub fn sh_precision(&self) -> ShPrecision {
        self.sh_precision
    }

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

    /// Device bytes held by the scene (with its still BVH, when built: 32 bytes a node,
    /// `2n - 1` nodes).
    pub fn device_bytes(&self) -> u64 {
        self.gaussians.size + self.sh.size + self.still_bvh_bytes()
    }

    /// Device bytes of the still BVH (0 without one), counted in [`GpuScene::device_bytes`].
    pub fn still_bvh_bytes(&self) -> u64 {
        self.still_bvh.as_ref().map_or(0, |(b, ..)| b.size)
    }

    /// Reads the scene back as the kernels see it: the Gaussians' bytes (48 each: centre and
    /// opacity, rotation (w, x, y, z), scales and a zero) and the SH coefficients' bytes (f32 or
    /// f16 by [`GpuScene::sh_precision`]), of the `len()` Gaussians. Slow; for tests.
    pub fn download(&self) -> Result<(Vec<u8>, Vec<u8>)> {
        let n = self.count as u64;
        let sh_bytes =
            n * 3 * crate::scene::sh_coeffs(self.sh_degree) as u64 * self.sh_precision.bytes();
        Ok((
            self.gaussians
                .download(n * std::mem::size_of::<GpuGaussian>() as u64)?,
            self.sh.download(sh_bytes)?,
        ))
    }
}
