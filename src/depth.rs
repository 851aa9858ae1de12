//! Depth (SPEC section 9): the engine's depth buffer that the splats are tested against, and the
//! splats' own depth written out, for [`crate::RenderOptions::depth_test`] and
//! [`crate::RenderOptions::depth_output`].
//!
//! Depths here are **view depths**: a Gaussian's is its camera-space `t.z` (SPEC section 3); an
//! engine's depth buffer holds values of its projection, which [`DepthProjection`] turns into
//! view depth.

use ash::vk;

use crate::error::{Error, Result};

/// The engine's perspective projection, to turn its depth values (Vulkan's `[0, 1]`) into view
/// depth.
///
/// - standard: `d = far (z - near) / (z (far - near))`, so `z = near far / (far - d (far -
///   near))`;
/// - reversed (1 at the near plane, 0 at the far plane): `z = near far / (near + d (far -
///   near))`;
/// - infinite far plane: `z = near / (1 - d)`, reversed `z = near / d`.
///
/// A pixel still at the cleared value (1, or 0 when reversed) holds no surface and hides
/// nothing.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct DepthProjection {
    /// Distance of the near plane, > 0.
    pub near: f32,
    /// Distance of the far plane, > near (ignored when `infinite`).
    pub far: f32,
    /// Reversed depth: 1 at the near plane, 0 at the far plane.
    pub reversed: bool,
    /// An infinite far plane.
    pub infinite: bool,
}

impl DepthProjection {
    /// Checks the planes.
    pub fn validate(&self) -> Result<()> {
        let finite_ok = self.infinite || (self.far.is_finite() && self.far > self.near);
        if !(self.near.is_finite() && self.near > 0.0 && finite_ok) {
            return Err(Error::InvalidInput(format!(
                "depth projection: near {} and far {} (need 0 < near < far, or an infinite far \
                 plane)",
                self.near, self.far
            )));
        }
        Ok(())
    }

    /// The view depth of depth value `d` (`f32::INFINITY` at the cleared value): what the GPU's
    /// `depth_prepare` computes, in the same f32 operations.
    pub fn view_depth(&self, d: f32) -> f32 {
        let (n, f) = (self.near, self.far);
        let cleared = if self.reversed { d <= 0.0 } else { d >= 1.0 };
        if cleared {
            return f32::INFINITY;
        }
        match (self.infinite, self.reversed) {
            (true, true) => n / d,
            (true, false) => n / (1.0 - d),
            (false, true) => n * f / (n + d * (f - n)),
            (false, false) => n * f / (f - d * (f - n)),
        }
    }

    /// The depth value the projection gives view depth `z` (the inverse of
    /// [`DepthProjection::view_depth`]; `z` infinite gives the cleared value).
    pub fn depth_value(&self, z: f32) -> f32 {
        let (n, f) = (self.near, self.far);
        if z.is_infinite() {
            return if self.reversed { 0.0 } else { 1.0 };
        }
        match (self.infinite, self.reversed) {
            (true, true) => n / z,
            (true, false) => 1.0 - n / z,
            (false, true) => n * (f - z) / (z * (f - n)),
            (false, false) => f * (z - n) / (z * (f - n)),
        }
    }

    /// The flags word of `depth_prepare_body.glsl`.
    pub(crate) fn gpu_flags(&self) -> u32 {
        self.reversed as u32 | (self.infinite as u32) << 1
    }
}

/// Where the engine's depth comes from.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum DepthSource {
    /// A depth image, sampled: a 2D view of mip level 0, one layer, the depth aspect only, of
    /// `VK_FORMAT_D32_SFLOAT`, `D24_UNORM_S8_UINT`, `X8_D24_UNORM_PACK32`, `D16_UNORM` or
    /// `D32_SFLOAT_S8_UINT` (the image needs `VK_IMAGE_USAGE_SAMPLED_BIT`). It must be in
    /// `layout` when the recorded commands run: `DEPTH_STENCIL_READ_ONLY_OPTIMAL`,
    /// `DEPTH_READ_ONLY_OPTIMAL`, `SHADER_READ_ONLY_OPTIMAL` or `GENERAL`.
    Image {
        /// The view.
        view: vk::ImageView,
        /// Its layout while the frame runs.
        layout: vk::ImageLayout,
    },
    /// A buffer of f32 depth values (a `D32_SFLOAT` image copied out), one per pixel, rows of
    /// the camera's width, top row first, from `offset` (a multiple of 4). Usage
    /// `STORAGE_BUFFER | SHADER_DEVICE_ADDRESS`.
    Buffer {
        /// The buffer.
        buffer: vk::Buffer,
        /// Byte offset of the first pixel.
        offset: u64,
    },
}

/// A depth test against the engine's depth (SPEC section 9): at each pixel the splats behind
/// the engine's surface are not composited, and the pixel stops at the first of them.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct DepthTest {
    /// The engine's depth, the camera's size.
    pub source: DepthSource,
    /// Its projection.
    pub projection: DepthProjection,
}

/// Which depth a pixel reports (SPEC section 9).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub enum DepthMode {
    /// The view depth of the splat at which the accumulated alpha `1 - T` first reaches 0.5
    /// (`+inf` when it never does): a surface's depth, "the closest" depth that compositing
    /// with meshes wants.
    #[default]
    Median,
    /// `sum(alpha_i T_i z_i) / sum(alpha_i T_i)` over the composited splats (`+inf` when none).
    Mean,
}

/// Where the depth output goes: one f32 view depth per pixel, `+inf` where there is none.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum DepthTarget {
    /// An `R32_SFLOAT` storage image (usage `STORAGE`), a 2D view of mip 0, one layer, in
    /// `VK_IMAGE_LAYOUT_GENERAL` while the frame runs.
    Image {
        /// The view.
        view: vk::ImageView,
    },
    /// A buffer of f32 values in rows of the camera's width, top row first, from `offset` (a
    /// multiple of 4). Usage `STORAGE_BUFFER | SHADER_DEVICE_ADDRESS`.
    Buffer {
        /// The buffer.
        buffer: vk::Buffer,
        /// Byte offset of the first pixel.
        offset: u64,
    },
}

/// The frame's depth output.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct DepthOutput {
    /// Median or mean.
    pub mode: DepthMode,
    /// Where it goes; the camera's size.
    pub target: DepthTarget,
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn depth_values_and_view_depths_invert_each_other() {
        for reversed in [false, true] {
            for infinite in [false, true] {
                let p = DepthProjection {
                    near: 0.1,
                    far: 100.0,
                    reversed,
                    infinite,
                };
                p.validate().unwrap();
                for z in [0.1f32, 0.5, 1.0, 3.7, 42.0, 99.0] {
                    let d = p.depth_value(z);
                    assert!((0.0..=1.0).contains(&d), "{p:?} {z} {d}");
                    let back = p.view_depth(d);
                    assert!((back - z).abs() <= 1e-3 * z, "{p:?}: {z} -> {d} -> {back}");
                }
                assert_eq!(p.view_depth(p.depth_value(f32::INFINITY)), f32::INFINITY);
            }
        }
        let bad = DepthProjection {
            near: 1.0,
            far: 0.5,
            reversed: false,
            infinite: false,
        };
        assert!(bad.validate().is_err());
    }
}
