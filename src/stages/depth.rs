//! Depth (SPEC section 9), around the rasterizer's `*_depth` kernels: before them, an engine's
//! depth turned into per-pixel view depth (`glsl/depth_prepare_body.glsl`); after them, the
//! depth output written into the caller's target (`glsl/write_depth_body.glsl`). CPU twin:
//! `reference::rasterize::composite_pixel_depth`.

use ash::vk;
use bytemuck::{Pod, Zeroable};

use super::write_target::single_image_set_layout;
use super::FrameRecording;
use crate::constants::TILE_SIZE;
use crate::depth::{DepthMode, DepthProjection};
use crate::error::Result;
use crate::shaders;
use crate::vk::{Context, LazyPipeline};

/// Push constants of `depth_prepare_*`.
#[repr(C)]
#[derive(Clone, Copy, Pod, Zeroable)]
pub struct DepthPreparePush {
    /// The engine's f32 depths (buffer source; 0 for an image).
    pub source: u64,
    /// Out: per pixel view depth.
    pub limit: u64,
    /// Width, height.
    pub size: [u32; 2],
    /// The projection's near plane.
    pub near: f32,
    /// Its far plane.
    pub far: f32,
    /// 1: reversed depth; 2: infinite far plane.
    pub flags: u32,
    /// Padding to the struct's 8-byte alignment (always 0).
    pub padding: u32,
}

/// Push constants of `write_depth_*`.
#[repr(C)]
#[derive(Clone, Copy, Pod, Zeroable)]
pub struct WriteDepthPush {
    /// Per pixel (premultiplied colour, transmittance).
    pub state: u64,
    /// Per pixel (median, sum alpha T z, 0, 0).
    pub depth_state: u64,
    /// A buffer target's first pixel (0 for an image).
    pub buffer_target: u64,
    /// Width, height.
    pub size: [u32; 2],
    /// 1 for [`DepthMode::Mean`].
    pub flags: u32,
    /// Padding to the struct's 8-byte alignment (always 0).
    pub padding: u32,
}

/// The depth kernels and the layouts of their image descriptor sets (set 0: the engine's depth
/// image, sampled; or the depth output's storage image).
pub struct DepthStages {
    prepare_buffer: LazyPipeline,
    prepare_image: LazyPipeline,
    write_buffer: LazyPipeline,
    write_image: LazyPipeline,
    sampled_layout: vk::DescriptorSetLayout,
    storage_layout: vk::DescriptorSetLayout,
    ctx: Context,
}

impl DepthStages {
    /// Builds the kernels.
    pub fn new(ctx: &Context) -> Result<Self> {
        let sampled_layout = single_image_set_layout(ctx, vk::DescriptorType::SAMPLED_IMAGE)?;
        let storage_layout = match single_image_set_layout(ctx, vk::DescriptorType::STORAGE_IMAGE) {
            Ok(l) => l,
            Err(e) => {
                unsafe {
                    ctx.device()
                        .destroy_descriptor_set_layout(sampled_layout, None)
                };
                return Err(e);
            }
        };
        // Built when a frame first asks for a depth test or output.
        Ok(DepthStages {
            prepare_buffer: LazyPipeline::new::<DepthPreparePush>(
                ctx,
                c"depth_prepare_buffer",
                shaders::DEPTH_PREPARE_BUFFER,
                None,
            ),
            prepare_image: LazyPipeline::new::<DepthPreparePush>(
                ctx,
                c"depth_prepare_image",
                shaders::DEPTH_PREPARE_IMAGE,
                Some(sampled_layout),
            ),
            write_buffer: LazyPipeline::new::<WriteDepthPush>(
                ctx,
                c"write_depth_buffer",
                shaders::WRITE_DEPTH_BUFFER,
                None,
            ),
            write_image: LazyPipeline::new::<WriteDepthPush>(
                ctx,
                c"write_depth_image",
                shaders::WRITE_DEPTH_IMAGE,
                Some(storage_layout),
            ),
            sampled_layout,
            storage_layout,
            ctx: ctx.clone(),
        })
    }

    fn groups((w, h): (u32, u32)) -> [u32; 3] {
        [w.div_ceil(TILE_SIZE), h.div_ceil(TILE_SIZE), 1]
    }

    /// Records the pass "depth prepare": the engine's depth (the buffer at `source`, or the
    /// sampled image of descriptor set `image`) into per-pixel view depth at `limit`, then a
    /// barrier. Builds the kernel on first use.
    pub fn record_prepare(
        &self,
        f: &mut FrameRecording,
        (source, image): (u64, Option<vk::DescriptorSet>),
        projection: &DepthProjection,
        limit: u64,
    ) -> Result<()> {
        let push = DepthPreparePush {
            source,
            limit,
            size: [f.size.0, f.size.1],
            near: projection.near,
            far: projection.far,
            flags: projection.gpu_flags(),
            padding: 0,
        };
        let groups = Self::groups(f.size);
        let kernel = match image {
            Some(_) => self.prepare_image.get()?,
            None => self.prepare_buffer.get()?,
        };
        f.pass(c"depth prepare", |f| {
            match image {
                Some(set) => kernel.dispatch_with_set(f.cmd, &push, set, groups),
                None => kernel.dispatch(f.cmd, &push, groups),
            }
            f.barrier();
        });
        Ok(())
    }

    /// Records the pass "write depth": the depth output of `mode` from the rasterizer's state
    /// into the buffer at `buffer_target` or the storage image of descriptor set `image`.
    /// Builds the kernel on first use.
    pub fn record_write(
        &self,
        f: &mut FrameRecording,
        depth_state: u64,
        mode: DepthMode,
        (buffer_target, image): (u64, Option<vk::DescriptorSet>),
    ) -> Result<()> {
        let push = WriteDepthPush {
            state: f.at.state,
            depth_state,
            buffer_target,
            size: [f.size.0, f.size.1],
            flags: (mode == DepthMode::Mean) as u32,
            padding: 0,
        };
        let groups = Self::groups(f.size);
        let kernel = match image {
            Some(_) => self.write_image.get()?,
            None => self.write_buffer.get()?,
        };
        f.pass(c"write depth", |f| match image {
            Some(set) => kernel.dispatch_with_set(f.cmd, &push, set, groups),
            None => kernel.dispatch(f.cmd, &push, groups),
        });
        Ok(())
    }
}

impl Drop for DepthStages {
    fn drop(&mut self) {
        unsafe {
            let device = self.ctx.device();
            device.destroy_descriptor_set_layout(self.sampled_layout, None);
            device.destroy_descriptor_set_layout(self.storage_layout, None);
        }
    }
}
