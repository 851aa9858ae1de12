//! The GPU pipeline, one module per stage, in frame order. Each holds its kernel(s) and a
//! `record` that only appends dispatches (and barriers) to a command buffer; the GLSL lives
//! in `glsl/<stage>.comp` and the CPU twin in `reference`.

pub mod emit;
pub mod prefix_sum;
pub mod project;
pub mod rasterize;
pub mod sort;
pub mod tile_ranges;
pub mod write_target;
