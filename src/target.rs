//! Where [`crate::Renderer::record`] writes a frame: an engine's storage image or buffer.

use ash::vk;

/// Pixel format of a [`Target`]. Colour is premultiplied by alpha (see [`Composite`]).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum TargetFormat {
    /// `VK_FORMAT_R8G8B8A8_UNORM`; in a buffer, one `u32` per pixel, R in the low byte.
    Rgba8Unorm,
    /// `VK_FORMAT_R16G16B16A16_SFLOAT`; in a buffer, 8 bytes per pixel.
    Rgba16Float,
    /// `VK_FORMAT_R32G32B32A32_SFLOAT`; in a buffer, 16 bytes per pixel.
    Rgba32Float,
}

impl TargetFormat {
    /// Bytes per pixel.
    pub fn bytes_per_pixel(self) -> u64 {
        match self {
            TargetFormat::Rgba8Unorm => 4,
            TargetFormat::Rgba16Float => 8,
            TargetFormat::Rgba32Float => 16,
        }
    }

    /// The Vulkan format of an image of this format.
    pub fn vk_format(self) -> vk::Format {
        match self {
            TargetFormat::Rgba8Unorm => vk::Format::R8G8B8A8_UNORM,
            TargetFormat::Rgba16Float => vk::Format::R16G16B16A16_SFLOAT,
            TargetFormat::Rgba32Float => vk::Format::R32G32B32A32_SFLOAT,
        }
    }
}

/// The caller's target of [`crate::Renderer::record`]; its size must be the camera's.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Target {
    /// A 2D storage image, through a view of it with `format` (the image needs
    /// `VK_IMAGE_USAGE_STORAGE_BIT`). It must be in `VK_IMAGE_LAYOUT_GENERAL` when the recorded
    /// commands run, and stays in it.
    Image {
        /// A 2D view of mip level 0, one layer.
        view: vk::ImageView,
        /// The view's format.
        format: TargetFormat,
        /// Width in pixels.
        width: u32,
        /// Height in pixels.
        height: u32,
    },
    /// A buffer with `VK_BUFFER_USAGE_STORAGE_BUFFER_BIT | VK_BUFFER_USAGE_SHADER_DEVICE_ADDRESS_BIT`,
    /// pixels in rows of `width`, top row first, no padding, starting at `offset` (a multiple of
    /// 4).
    Buffer {
        /// The buffer.
        buffer: vk::Buffer,
        /// Byte offset of the first pixel.
        offset: u64,
        /// Pixel format.
        format: TargetFormat,
        /// Width in pixels.
        width: u32,
        /// Height in pixels.
        height: u32,
    },
}

impl Target {
    /// (width, height) in pixels.
    pub fn size(&self) -> (u32, u32) {
        match *self {
            Target::Image { width, height, .. } | Target::Buffer { width, height, .. } => {
                (width, height)
            }
        }
    }

    /// Pixel format.
    pub fn format(&self) -> TargetFormat {
        match *self {
            Target::Image { format, .. } | Target::Buffer { format, .. } => format,
        }
    }
}

/// What the splats are composited over. The splats of a pixel give a premultiplied colour C and
/// a transmittance T (how much of what lies behind shows through); the pixel becomes
/// `(C + T under.rgb, (1 - T) + T under.a)`.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub enum Composite {
    /// `under` is [`crate::RenderOptions::background`] with alpha 1: the target's contents are
    /// not read, only written (opaque result).
    #[default]
    Background,
    /// `under` is what the target already holds (premultiplied alpha "over"): the target is
    /// read and written.
    Over,
}
