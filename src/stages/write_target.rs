//! Stage 8: write the rasterizer's per-pixel state into the caller's target, over a background
//! or over what the target holds (`glsl/write_target_*.comp`).

use ash::vk;
use bytemuck::{Pod, Zeroable};

use crate::constants::TILE_SIZE;
use crate::error::{Result, VkContext};
use crate::shaders;
use crate::target::{Composite, TargetFormat};
use crate::vk::{ComputePipeline, Context};

/// Push constants of the write-target kernels.
#[repr(C)]
#[derive(Clone, Copy, Pod, Zeroable)]
pub struct WriteTargetPush {
    /// Per-pixel (premultiplied colour, transmittance) from the rasterizer.
    pub state: u64,
    /// Device address of a buffer target's first pixel (0 for an image target).
    pub buffer_target: u64,
    /// Background rgba with [`Composite::Background`].
    pub background: [f32; 4],
    /// Width, height.
    pub size: [u32; 2],
    /// 1 for [`Composite::Over`].
    pub flags: u32,
    /// Padding to the struct's 8-byte alignment (always 0).
    pub padding: u32,
}

impl WriteTargetPush {
    /// The flags word for `composite`.
    pub fn flags_for(composite: Composite) -> u32 {
        match composite {
            Composite::Background => 0,
            Composite::Over => 1,
        }
    }
}

/// Creates the layout of the descriptor set that holds an image target: one storage image at
/// binding 0. Layouts made by separate calls are identically defined, hence compatible, so a
/// frame slot allocates its set from one of its own and outlives any renderer.
pub fn image_target_set_layout(ctx: &Context) -> Result<vk::DescriptorSetLayout> {
    let bindings = [vk::DescriptorSetLayoutBinding::default()
        .binding(0)
        .descriptor_type(vk::DescriptorType::STORAGE_IMAGE)
        .descriptor_count(1)
        .stage_flags(vk::ShaderStageFlags::COMPUTE)];
    let info = vk::DescriptorSetLayoutCreateInfo::default().bindings(&bindings);
    unsafe { ctx.device().create_descriptor_set_layout(&info, None) }
        .vk("vkCreateDescriptorSetLayout")
}

/// The write-target kernels: one per storage-image format (GLSL must name the format to load
/// an image) and one per buffer format (a CPU driver would run every format's branch).
pub struct WriteTarget {
    set_layout: vk::DescriptorSetLayout,
    image_rgba8: ComputePipeline,
    image_rgba16f: ComputePipeline,
    image_rgba32f: ComputePipeline,
    buffer_rgba8: ComputePipeline,
    buffer_rgba16f: ComputePipeline,
    buffer_rgba32f: ComputePipeline,
    ctx: Context,
}

impl WriteTarget {
    /// Builds the kernels and the descriptor set layout of an image target.
    pub fn new(ctx: &Context) -> Result<Self> {
        let set_layout = image_target_set_layout(ctx)?;
        // The layout is destroyed by Drop once `stage` exists; until then by hand on failure.
        let build = |name, spirv: &[u32], set: Option<vk::DescriptorSetLayout>| {
            ComputePipeline::with_set_layout::<WriteTargetPush>(ctx, name, spirv, set)
        };
        let pipelines = (|| {
            Ok((
                build(
                    c"write_target_image_rgba8",
                    shaders::WRITE_TARGET_IMAGE_RGBA8,
                    Some(set_layout),
                )?,
                build(
                    c"write_target_image_rgba16f",
                    shaders::WRITE_TARGET_IMAGE_RGBA16F,
                    Some(set_layout),
                )?,
                build(
                    c"write_target_image_rgba32f",
                    shaders::WRITE_TARGET_IMAGE_RGBA32F,
                    Some(set_layout),
                )?,
                build(
                    c"write_target_buffer_rgba8",
                    shaders::WRITE_TARGET_BUFFER_RGBA8,
                    None,
                )?,
                build(
                    c"write_target_buffer_rgba16f",
                    shaders::WRITE_TARGET_BUFFER_RGBA16F,
                    None,
                )?,
                build(
                    c"write_target_buffer_rgba32f",
                    shaders::WRITE_TARGET_BUFFER_RGBA32F,
                    None,
                )?,
            ))
        })();
        match pipelines {
            Ok((
                image_rgba8,
                image_rgba16f,
                image_rgba32f,
                buffer_rgba8,
                buffer_rgba16f,
                buffer_rgba32f,
            )) => Ok(WriteTarget {
                set_layout,
                image_rgba8,
                image_rgba16f,
                image_rgba32f,
                buffer_rgba8,
                buffer_rgba16f,
                buffer_rgba32f,
                ctx: ctx.clone(),
            }),
            Err(e) => {
                unsafe { ctx.device().destroy_descriptor_set_layout(set_layout, None) };
                Err(e)
            }
        }
    }

    /// Records the kernel for a target of `format`: the storage image whose view `image_set`
    /// holds or, with `image_set == None`, the buffer at `push.buffer_target`.
    pub fn record(
        &self,
        cmd: vk::CommandBuffer,
        push: &WriteTargetPush,
        format: TargetFormat,
        image_set: Option<vk::DescriptorSet>,
    ) {
        let groups = [
            push.size[0].div_ceil(TILE_SIZE),
            push.size[1].div_ceil(TILE_SIZE),
            1,
        ];
        match image_set {
            None => {
                let pipeline = match format {
                    TargetFormat::Rgba8Unorm => &self.buffer_rgba8,
                    TargetFormat::Rgba16Float => &self.buffer_rgba16f,
                    TargetFormat::Rgba32Float => &self.buffer_rgba32f,
                };
                pipeline.dispatch(cmd, push, groups);
            }
            Some(set) => {
                let pipeline = match format {
                    TargetFormat::Rgba8Unorm => &self.image_rgba8,
                    TargetFormat::Rgba16Float => &self.image_rgba16f,
                    TargetFormat::Rgba32Float => &self.image_rgba32f,
                };
                pipeline.dispatch_with_set(cmd, push, set, groups);
            }
        }
    }
}

impl Drop for WriteTarget {
    fn drop(&mut self) {
        unsafe {
            self.ctx
                .device()
                .destroy_descriptor_set_layout(self.set_layout, None)
        };
    }
}
