//! The GPU pipeline, one module per stage, in frame order. Each holds its kernel(s) and a
//! `record` that only appends dispatches (and barriers) to a command buffer; the GLSL lives
//! in `glsl/<stage>.comp` and the CPU twin in `reference`.

use crate::constants::{LINEAR_GRID_X, LINEAR_WORKGROUP};

pub mod cutoff_tiles;
pub mod depth_order;
pub mod emit;
pub mod prefix_sum;
pub mod project;
pub mod rasterize;
pub mod sort;
pub mod tile_ranges;
pub mod write_target;

/// Workgroup counts of a linear kernel over `items` (GLSL `linear_grid` in `common.glsl`): rows
/// of at most [`LINEAR_GRID_X`] workgroups, as only 65,535 per dimension are guaranteed.
pub(crate) fn linear_grid(items: u32) -> [u32; 3] {
    let groups = items.div_ceil(LINEAR_WORKGROUP);
    [groups.min(LINEAR_GRID_X), groups.div_ceil(LINEAR_GRID_X), 1]
}
