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
    /// Unique per upload into new buffers: frame slots key their texel views of the scene by
    /// it (a freed buffer's handle may come back).
    pub(crate) id: u64,
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
            id: NEXT_SCENE_ID.fetch_add(1, std::sync::atomic::Ordering::Relaxed),
        };
        gpu_scene.upload(scene)?;
        Ok(gpu_scene)
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
            id: NEXT_SCENE_ID.fetch_add(1, std::sync::atomic::Ordering::Relaxed),
        })
    }

    /// Bytes of device memory per Gaussian of a scene of `sh_degree` stored at `precision`.
    pub fn bytes_per_gaussian(sh_degree: u32, precision: ShPrecision) -> u64 {
        std::mem::size_of::<GpuGaussian>() as u64
            + 3 * crate::scene::sh_coeffs(sh_degree) as u64 * precision.bytes()
    }

    /// Writes `scene` into the buffers (which are large enough), chunk by chunk.
    fn upload(&mut self, scene: &Scene) -> Result<()> {
        let (gaussian_bytes, _) = scene_buffer_sizes(scene, self.sh_precision);
        let sh_bytes = scene.sh.len() as u64 * self.sh_precision.bytes();
        let record = std::mem::size_of::<GpuGaussian>();
        self.gaussians
            .upload_with(gaussian_bytes, record as u64, |offset, chunk| {
                let first = offset as usize / record;
                for (k, out) in chunk.chunks_exact_mut(record).enumerate() {
                    out.copy_from_slice(bytemuck::bytes_of(&gpu_gaussian(scene, first + k)));
                }
            })?;
        match self.sh_precision {
            ShPrecision::F32 => self.sh.upload(bytemuck::cast_slice(&scene.sh))?,
            ShPrecision::F16 => self.sh.upload_with(sh_bytes, 2, |offset, chunk| {
                let first = offset as usize / 2;
                for (k, out) in chunk.chunks_exact_mut(2).enumerate() {
                    out.copy_from_slice(&f32_to_f16_bits(scene.sh[first + k]).to_le_bytes());
                }
            })?,
        }
        self.count = scene.len() as u32;
        self.sh_degree = scene.sh_degree;
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

    /// Device bytes held by the scene.
    pub fn device_bytes(&self) -> u64 {
        self.gaussians.size + self.sh.size
    }
}
