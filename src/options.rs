//! What a frame is rendered with ([`RenderOptions`]): the background, the clip, which tracer
//! and the depth test and output; [`RayTraceOptions`], the ray tracer's settings. One set of options for the GPU renderer
//! ([`crate::Renderer`]) and the CPU reference ([`crate::reference`]), so that neither
//! depends on the other.

use glam::Vec3;

use crate::clip::Clip;
use crate::depth::{DepthOutput, DepthTest};
use crate::mesh::DEFAULT_Q;
use crate::target::Composite;

/// How to render a frame.
#[derive(Clone, Debug, PartialEq)]
pub struct RenderOptions {
    /// Colour behind the splats (with [`Composite::Background`]).
    pub background: Vec3,
    /// Over the background or over what the target holds ([`crate::Renderer::record`]).
    pub composite: Composite,
    /// Clipping (SPEC section 5); the default clips nothing.
    pub clip: Clip,
    /// The tile rasterizer (SPEC sections 3-5) or the ray tracer (section 7).
    pub tracer: Tracer,
    /// A depth test against the engine's depth buffer (SPEC section 9; both tracers).
    pub depth_test: Option<DepthTest>,
    /// The splats' depth written out (SPEC section 9; both tracers, a ray-traced hit's view
    /// depth that of its point on the ray, sections 7 and 11).
    pub depth_output: Option<DepthOutput>,
}

impl Default for RenderOptions {
    fn default() -> Self {
        RenderOptions {
            background: Vec3::ZERO,
            composite: Composite::Background,
            clip: Clip::default(),
            tracer: Tracer::Raster,
            depth_test: None,
            depth_output: None,
        }
    }
}

/// How a frame is drawn.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub enum Tracer {
    /// The tile rasterizer (SPEC sections 3-5).
    #[default]
    Raster,
    /// The ray tracer (SPEC section 7): a BVH built per frame, k-closest hits per ray.
    Ray,
    /// The ray tracer with its camera rays composited from tile lists (SPEC section 11,
    /// [`crate::raytrace::tiles`]) instead of the BVH: the same image to the bit. Not yet the
    /// default: on lavapipe it is slower (docs/ARCHITECTURE.md, "Section 7 in tiles on the
    /// GPU").
    RayTiles,
}

impl Tracer {
    /// Whether frames are ray traced (SPEC section 7), whatever their camera rays come from.
    pub fn is_ray(self) -> bool {
        matches!(self, Tracer::Ray | Tracer::RayTiles)
    }
}

/// Hits composited per ray at most (REdiSplats' default); a ray that needed more is counted.
pub const DEFAULT_MAX_HITS: usize = 512;

/// Settings of the ray tracer (SPEC section 7), the GPU's ([`crate::raytrace`]) and the CPU
/// reference's alike.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct RayTraceOptions {
    /// `Q` of the flat Gaussians' octagons (SPEC section 6).
    pub q: f64,
    /// Hits composited per ray at most.
    pub max_hits: usize,
}

impl Default for RayTraceOptions {
    fn default() -> Self {
        RayTraceOptions {
            q: DEFAULT_Q,
            max_hits: DEFAULT_MAX_HITS,
        }
    }
}
