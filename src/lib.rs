//! rara: a 3D Gaussian Splatting renderer on raw Vulkan compute, with RaRa clipping.
//!
//! The frame is a pipeline of compute stages, each visible three times under one name: the
//! kernel `glsl/<stage>_body.glsl` (or `glsl/<stage>.comp`; its variants are the rows of
//! `glsl/variants.rs`), the host side that records it in [`stages`], and the CPU twin in
//! [`reference`](mod@reference) that the tests use as the oracle:
//!
//! 1. `project`: clip classification, cull, 2D conic, radius, tiles touched, SH colour per
//!    Gaussian, and the side record of each cutoff Gaussian;
//! 2. `prefix_sum`: offsets of each Gaussian's tile pairs;
//! 3. `emit`: one (tile, depth) key and splat index per tile its visible footprint reaches;
//!    under rara clipping by planes, `cutoff_tiles` then classifies each cutoff splat's pairs
//!    by tile, and on CPU drivers `tile_lists` splits the tiles by rasterize kernel;
//! 4. `sort`: stable GPU radix sort of the pairs ([`stages::sort::RadixSort`]);
//! 5. `tile_ranges`: each tile's run of pairs;
//! 6. `rasterize`: per-pixel front-to-back compositing, one workgroup per 16x16 tile, with the
//!    per-pixel clip weight of cutoff splats;
//! 7. `write_target`: the composited pixels over a background or over the caller's target, into
//!    a storage image or a buffer.
//!
//! Clipping (SPEC section 5) is described by [`clip::Clip`] in [`RenderOptions`]; the same
//! description drives the kernels and the CPU reference.
//!
//! Entry points: [`ply::load_ply`], [`camera::Camera`], [`vk::Context`],
//! [`renderer::Renderer`], [`reference::render`], [`clip::Clip`].
//!
//! # Use from an engine
//! An engine lends its instance, device and queue with [`Context::borrowed`] (after merging
//! [`requirements()`] into its device creation), uploads scenes as [`GpuScene`]s, keeps one
//! [`FrameSlot`] per frame in flight, and calls [`Renderer::record`] to record a frame into its
//! own command buffer, writing its storage image or buffer ([`Target`]). `record`'s rustdoc is
//! the synchronisation contract; `examples/engine.rs` is a complete engine loop.

#![warn(missing_docs)]

pub mod bake;
pub mod camera;
pub mod clip;
/// Integer constants shared by the host and the GLSL kernels (tile size, workgroup sizes,
/// counter slots). `build.rs` passes them to the shader compiler as macros.
pub mod constants;
pub mod depth;
pub mod error;
pub mod formats;
pub mod frame;
pub mod gpu_scene;
pub mod gpu_types;
pub mod input;
pub mod mesh;
pub mod metrics;
pub mod mixed;
pub mod objects;
pub mod options;
pub mod ply;
pub mod precision;
pub mod raytrace;
pub mod reference;
pub mod renderer;
pub mod scene;
pub mod sh;
pub mod stages;
pub mod synth;
pub mod target;
pub mod timing;
pub mod vk;

/// SPIR-V of every kernel, compiled from `glsl/` by `build.rs`.
pub mod shaders {
    include!(concat!(env!("OUT_DIR"), "/kernels.rs"));
}

pub use camera::Camera;
pub use clip::{Clip, ClipMode, ClipRegion, ClipWeight, Plane};
pub use depth::{DepthMode, DepthOutput, DepthProjection, DepthSource, DepthTarget, DepthTest};
pub use error::{Error, Result};
pub use frame::{FrameMemory, FrameSlot};
pub use objects::ObjectTransform;
pub use options::{RayTraceOptions, RenderOptions, Tracer};
pub use precision::ShPrecision;
pub use renderer::{FrameStats, GpuScene, Intermediates, Renderer, SceneObject, View};
pub use scene::Scene;
pub use target::{Composite, Target, TargetFormat};
pub use timing::PassTimer;
pub use vk::{requirements, BorrowedDevice, Context, EnabledFeatures, Requirements};
