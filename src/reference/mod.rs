//! The CPU reference renderer: the SPEC implemented stage by stage, plainly, in `f32`.
//!
//! It mirrors the GPU pipeline's stages and names (`project`, then per-tile lists sorted by
//! depth, then `rasterize`) and is the oracle of the test suite.

pub mod mixed;
pub mod project;
pub mod rasterize;
pub mod ray_hits;
pub mod raytrace;
pub mod tiled;

use crate::camera::Camera;
use crate::options::RenderOptions;
use crate::scene::Scene;

/// An 8-bit RGBA image, row-major, row 0 at the top.
pub type Rgba8Image = image::RgbaImage;

/// Renders `scene` from `camera` with `options` (background, clipping).
pub fn render(scene: &Scene, camera: &Camera, options: &RenderOptions) -> Rgba8Image {
    let splats = project::project_all(scene, camera, &options.clip);
    rasterize::rasterize(&splats, camera, options.background, &options.clip)
}
