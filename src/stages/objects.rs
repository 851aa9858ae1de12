//! Several objects in one frame (SPEC section 9): each object's Gaussians transformed into the
//! frame's merged scene (`glsl/object_transform.comp`; CPU twin [`crate::objects`]), which the
//! frame's stages then draw as one scene.

use ash::vk;
use bytemuck::{Pod, Zeroable};

use crate::error::Result;
use crate::gpu_scene::GpuScene;
use crate::objects::{ObjectTransform, SH_ROTATION_FLOATS};
use crate::scene::sh_coeffs;
use crate::shaders;
use crate::vk::{compute_barrier, Buffer, Context, LazyPipeline};

/// Push constants of `object_transform`.
#[repr(C)]
#[derive(Clone, Copy, Pod, Zeroable)]
pub struct ObjectTransformPush {
    /// The object's Gaussians.
    pub src: u64,
    /// Its SH coefficients.
    pub src_sh: u64,
    /// The merged scene's Gaussians.
    pub dst: u64,
    /// Its SH coefficients.
    pub dst_sh: u64,
    /// The object's [`GpuObjectParams`].
    pub params: u64,
    /// The object's Gaussians.
    pub count: u32,
    /// Its first Gaussian in the merged scene.
    pub base: u32,
    /// SH coefficients per channel, the object's and the merged scene's.
    pub src_coeffs: u32,
    /// See `src_coeffs`.
    pub dst_coeffs: u32,
}

/// `ObjectParams` in `object_transform.comp`: one object's transform, 416 bytes.
#[repr(C)]
#[derive(Clone, Copy, Pod, Zeroable)]
pub struct GpuObjectParams {
    /// Rows of the rotation matrix, w unused.
    pub rows: [[f32; 4]; 3],
    /// Translation and scale.
    pub translation_scale: [f32; 4],
    /// The unit rotation, (w, x, y, z).
    pub rotation: [f32; 4],
    /// The SH rotation of bands 1 to 3 ([`ObjectTransform::sh_rotation`]).
    pub sh_rotation: [f32; SH_ROTATION_FLOATS],
    /// Padding to 16 bytes.
    pub padding: f32,
}

impl GpuObjectParams {
    /// The parameters of `t`.
    pub fn new(t: &ObjectTransform) -> Self {
        let rows = t.rotation_rows();
        let q = t.unit_rotation();
        GpuObjectParams {
            rows: rows.map(|r| [r[0], r[1], r[2], 0.0]),
            translation_scale: [t.translation.x, t.translation.y, t.translation.z, t.scale],
            rotation: [q.w, q.x, q.y, q.z],
            sh_rotation: t.sh_rotation(),
            padding: 0.0,
        }
    }
}

/// The object-transform kernel.
pub struct ObjectTransformStage {
    pipeline: LazyPipeline,
}

impl ObjectTransformStage {
    /// The stage; its kernel is built by the first frame of several objects.
    pub fn new(ctx: &Context) -> Result<Self> {
        Ok(ObjectTransformStage {
            pipeline: LazyPipeline::new::<ObjectTransformPush>(
                ctx,
                c"object_transform",
                shaders::OBJECT_TRANSFORM,
                None,
            ),
        })
    }

    /// Records the transform of every object into `merged` (the objects one after the other),
    /// with their parameters written into `params` first, then a barrier.
    pub fn record(
        &self,
        ctx: &Context,
        cmd: vk::CommandBuffer,
        objects: &[(&GpuScene, ObjectTransform)],
        merged: &GpuScene,
        params: &Buffer,
    ) -> Result<()> {
        let kernel = self.pipeline.get()?;
        let record = std::mem::size_of::<GpuObjectParams>() as u64;
        let all: Vec<GpuObjectParams> = objects
            .iter()
            .map(|(_, t)| GpuObjectParams::new(t))
            .collect();
        let bytes: &[u8] = bytemuck::cast_slice(&all);
        // vkCmdUpdateBuffer takes at most 65,536 bytes a call: whole records at a time.
        let chunk = (65536 / record * record) as usize;
        for (k, part) in bytes.chunks(chunk).enumerate() {
            unsafe {
                ctx.device()
                    .cmd_update_buffer(cmd, params.raw, (k * chunk) as u64, part)
            };
        }
        compute_barrier(ctx, cmd);
        let (dst, dst_sh, _) = merged.buffers();
        let dst_coeffs = sh_coeffs(merged.sh_degree()) as u32;
        let mut base = 0u32;
        for (k, (scene, _)) in objects.iter().enumerate() {
            let (src, src_sh, _) = scene.buffers();
            let push = ObjectTransformPush {
                src: src.address,
                src_sh: src_sh.address,
                dst: dst.address,
                dst_sh: dst_sh.address,
                params: params.address + k as u64 * record,
                count: scene.len(),
                base,
                src_coeffs: sh_coeffs(scene.sh_degree()) as u32,
                dst_coeffs,
            };
            kernel.dispatch(cmd, &push, [scene.len().div_ceil(256), 1, 1]);
            base += scene.len();
        }
        compute_barrier(ctx, cmd);
        Ok(())
    }
}
