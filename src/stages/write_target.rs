//! Stage 8: write the rasterizer's per-pixel state into the caller's target, over a background
//! or over what the target holds (`glsl/write_target_body.glsl`).

use ash::vk;
use bytemuck::{Pod, Zeroable};
use std::ffi::CStr;

use super::FrameRecording;
use crate::constants::{TARGET_OVER_CONSTANT_ID, TILE_SIZE};
use crate::error::{Result, VkContext};
use crate::shaders;
use crate::target::{Composite, TargetFormat};
use crate::vk::{Context, LazyPipeline};

/// Push constants of the write-target kernels.
#[repr(C)]
#[derive(Clone, Copy, Pod, Zeroable)]
pub struct WriteTargetPush {
    /// Per-pixel (premultiplied colour, transmittance) from the rasterizer.
    pub state: u64,
    /// Device address of a buffer target's first pixel (0 for an image target).
    pub buffer_target: u64,
    /// Background rgba with [`Composite::Background`] (the kernel, not a flag, says which).
    pub background: [f32; 4],
    /// Width, height.
    pub size: [u32; 2],
}

/// Creates the layout of the descriptor set that holds an image target: one storage image at
/// binding 0. Layouts made by separate calls are identically defined, hence compatible, so a
/// frame slot allocates its set from one of its own and outlives any renderer.
pub fn image_target_set_layout(ctx: &Context) -> Result<vk::DescriptorSetLayout> {
    single_image_set_layout(ctx, vk::DescriptorType::STORAGE_IMAGE)
}

/// Creates the layout of a descriptor set of one image of descriptor type `ty` at binding 0,
/// for compute: a storage image (a target) or a sampled image (a depth test's engine depth).
pub fn single_image_set_layout(
    ctx: &Context,
    ty: vk::DescriptorType,
) -> Result<vk::DescriptorSetLayout> {
    let bindings = [vk::DescriptorSetLayoutBinding::default()
        .binding(0)
        .descriptor_type(ty)
        .descriptor_count(1)
        .stage_flags(vk::ShaderStageFlags::COMPUTE)];
    let info = vk::DescriptorSetLayoutCreateInfo::default().bindings(&bindings);
    unsafe { ctx.device().create_descriptor_set_layout(&info, None) }
        .vk("vkCreateDescriptorSetLayout")
}

/// The write-target kernel of one format for each [`Composite`]: the specialization constant
/// `COMPOSITE_OVER` (`glsl/write_target_body.glsl`) false for the background, true over the
/// target.
struct CompositeKernels {
    background: LazyPipeline,
    over: LazyPipeline,
}

impl CompositeKernels {
    /// Both kernels from `build`, which makes the unbuilt pipeline.
    fn new(build: impl Fn() -> LazyPipeline) -> Self {
        CompositeKernels {
            background: build().specialized(&[(TARGET_OVER_CONSTANT_ID, 0)]),
            over: build(),
        }
    }

    /// The kernel for `composite`.
    fn get(&self, composite: Composite) -> &LazyPipeline {
        match composite {
            Composite::Background => &self.background,
            Composite::Over => &self.over,
        }
    }
}

/// One write-target kernel per [`TargetFormat`] and [`Composite`], for one kind of target,
/// each built when a frame first needs it.
struct FormatKernels {
    rgba8: CompositeKernels,
    rgba16f: CompositeKernels,
    rgba32f: CompositeKernels,
}

impl FormatKernels {
    /// Builds the three kernels from `(name, SPIR-V)` in format order (rgba8, rgba16f,
    /// rgba32f), with descriptor sets of `set_layouts`.
    fn new(
        ctx: &Context,
        kernels: [(&'static CStr, &'static [u32]); 3],
        set_layouts: &[vk::DescriptorSetLayout],
    ) -> Result<Self> {
        let build = |(name, spirv): (&'static CStr, &'static [u32])| {
            CompositeKernels::new(|| {
                LazyPipeline::with_set_layouts::<WriteTargetPush>(ctx, name, spirv, set_layouts)
            })
        };
        let [rgba8, rgba16f, rgba32f] = kernels;
        Ok(FormatKernels {
            rgba8: build(rgba8),
            rgba16f: build(rgba16f),
            rgba32f: build(rgba32f),
        })
    }

    /// The kernel for `format` and `composite`.
    fn get(&self, format: TargetFormat, composite: Composite) -> &LazyPipeline {
        match format {
            TargetFormat::Rgba8Unorm => &self.rgba8,
            TargetFormat::Rgba16Float => &self.rgba16f,
            TargetFormat::Rgba32Float => &self.rgba32f,
        }
        .get(composite)
    }
}

/// The write-target kernels: one per storage-image format (GLSL must name the format to load
/// an image) and one per buffer format (a CPU driver would run every format's branch), and on
/// CPU drivers the same again reading the rasterizer's state through the frame's texel view.
pub struct WriteTarget {
    set_layout: vk::DescriptorSetLayout,
    image: FormatKernels,
    buffer: FormatKernels,
    /// With the frame's texel views: image kernels (set 0 the image, set 1 the views) and
    /// buffer kernels (set 0 the views), `write_target_*_texels`.
    texels: Option<(FormatKernels, FormatKernels)>,
    ctx: Context,
}

impl WriteTarget {
    /// Builds the kernels and the descriptor set layout of an image target, and with
    /// `frame_texels` (the layout of the frame's texel views, on CPU drivers) the kernels that
    /// read the state through them.
    pub fn new(ctx: &Context, frame_texels: Option<vk::DescriptorSetLayout>) -> Result<Self> {
        let set_layout = image_target_set_layout(ctx)?;
        // The layout is destroyed by Drop once `stage` exists; until then by hand on failure.
        let kernels = (|| {
            let image = FormatKernels::new(
                ctx,
                [
                    (
                        c"write_target_image_rgba8",
                        shaders::WRITE_TARGET_IMAGE_RGBA8,
                    ),
                    (
                        c"write_target_image_rgba16f",
                        shaders::WRITE_TARGET_IMAGE_RGBA16F,
                    ),
                    (
                        c"write_target_image_rgba32f",
                        shaders::WRITE_TARGET_IMAGE_RGBA32F,
                    ),
                ],
                &[set_layout],
            )?;
            let buffer = FormatKernels::new(
                ctx,
                [
                    (
                        c"write_target_buffer_rgba8",
                        shaders::WRITE_TARGET_BUFFER_RGBA8,
                    ),
                    (
                        c"write_target_buffer_rgba16f",
                        shaders::WRITE_TARGET_BUFFER_RGBA16F,
                    ),
                    (
                        c"write_target_buffer_rgba32f",
                        shaders::WRITE_TARGET_BUFFER_RGBA32F,
                    ),
                ],
                &[],
            )?;
            let texels = match frame_texels {
                None => None,
                Some(frame_texels) => Some((
                    FormatKernels::new(
                        ctx,
                        [
                            (
                                c"write_target_image_rgba8_texels",
                                shaders::WRITE_TARGET_IMAGE_RGBA8_TEXELS,
                            ),
                            (
                                c"write_target_image_rgba16f_texels",
                                shaders::WRITE_TARGET_IMAGE_RGBA16F_TEXELS,
                            ),
                            (
                                c"write_target_image_rgba32f_texels",
                                shaders::WRITE_TARGET_IMAGE_RGBA32F_TEXELS,
                            ),
                        ],
                        &[set_layout, frame_texels],
                    )?,
                    FormatKernels::new(
                        ctx,
                        [
                            (
                                c"write_target_buffer_rgba8_texels",
                                shaders::WRITE_TARGET_BUFFER_RGBA8_TEXELS,
                            ),
                            (
                                c"write_target_buffer_rgba16f_texels",
                                shaders::WRITE_TARGET_BUFFER_RGBA16F_TEXELS,
                            ),
                            (
                                c"write_target_buffer_rgba32f_texels",
                                shaders::WRITE_TARGET_BUFFER_RGBA32F_TEXELS,
                            ),
                        ],
                        &[frame_texels],
                    )?,
                )),
            };
            Ok((image, buffer, texels))
        })();
        match kernels {
            Ok((image, buffer, texels)) => Ok(WriteTarget {
                set_layout,
                image,
                buffer,
                texels,
                ctx: ctx.clone(),
            }),
            Err(e) => {
                unsafe { ctx.device().destroy_descriptor_set_layout(set_layout, None) };
                Err(e)
            }
        }
    }

    /// Records the pass "write target": the rasterizer's per-pixel state over `background`
    /// (or over what the target holds, by `composite`) into a target of `format`: the storage
    /// image whose view `image_set` holds or, with `image_set == None`, the buffer at
    /// `buffer_target`. Where the kernels were built for the frame's texel views and its state
    /// view holds every pixel (at most `maxTexelBufferElements`), the state is read through
    /// it, else by address. No barrier follows: the target is the caller's from here.
    pub fn record(
        &self,
        f: &mut FrameRecording,
        (format, image_set, buffer_target): (TargetFormat, Option<vk::DescriptorSet>, u64),
        background: glam::Vec3,
        composite: Composite,
    ) -> Result<()> {
        let (w, h) = f.size;
        let push = WriteTargetPush {
            state: f.at.state,
            buffer_target,
            background: [background.x, background.y, background.z, 1.0],
            size: [w, h],
        };
        let max_texels = f.ctx.info().max_texel_buffer_elements as u64;
        let frame_texels = f.texels.filter(|_| w as u64 * h as u64 <= max_texels);
        let (kernels, sets): (&FormatKernels, Vec<vk::DescriptorSet>) =
            match (image_set, self.texels.as_ref().zip(frame_texels)) {
                (None, None) => (&self.buffer, vec![]),
                (Some(image), None) => (&self.image, vec![image]),
                (None, Some(((_, buffer), texels))) => (buffer, vec![texels]),
                (Some(image), Some(((images, _), texels))) => (images, vec![image, texels]),
            };
        let kernel = kernels.get(format, composite).get()?;
        let groups = [w.div_ceil(TILE_SIZE), h.div_ceil(TILE_SIZE), 1];
        f.pass(c"write target", |f| {
            kernel.dispatch_with_sets(f.cmd, &push, &sets, groups)
        });
        Ok(())
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
