//! The ray tracer on the GPU (SPEC sections 7, 8 and 11): section 7's hits of every ray,
//! composited front to back in exact `(t, index)` order, found one of two ways.
//!
//! - **Through a BVH** ([`bvh`]): Karras' LBVH over the Gaussians' proxy boxes, built on the
//!   GPU every frame; each ray walks it with a buffer of its K closest hits. Every ray can take
//!   this path: camera rays ([`crate::Tracer::Ray`]), and the mirror, glass and shadow rays of
//!   mixed scenes ([`mixed`]).
//! - **Through tile lists** ([`tiles`], SPEC section 11): the Gaussians under each 16 x 16
//!   tile, in the order of the least depth any hit of theirs can have; each pixel's ray walks
//!   its tile's list with the same buffer and composites a hit once nothing later in the list
//!   can precede it. Camera rays only ([`crate::Tracer::RayTiles`]); the same image to the
//!   bit.
//!
//! What the two paths share:
//! - the hit model: `glsl/ray_hits.glsl` on the GPU (a Gaussian's hit, its clip weight, the
//!   composite of one hit), [`crate::reference::ray_hits`] on the CPU;
//! - the tracer ([`tracer::RayTracer`]): one kernel source, `glsl/trace_body.glsl`, whose
//!   variants walk a BVH or a tile list, with the per-ray state, the rounds that keep every
//!   invocation under lavapipe's loop cap, and the statistics;
//! - the rasterizer's sorting stages ([`crate::stages::sort`], [`crate::stages::depth_order`],
//!   [`crate::stages::prefix_sum`], [`crate::stages::tile_ranges`]): the BVH's Morton order
//!   and the tile lists are sorted by them.
//!
//! CPU twins: [`crate::reference::raytrace`] (BVH), [`crate::reference::tiled`] (tile
//! lists), [`crate::reference::mixed`].

pub mod bvh;
pub mod mixed;
pub mod still_bvh;
pub mod tiles;
pub mod tracer;
