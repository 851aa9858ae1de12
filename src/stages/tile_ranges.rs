//! Stage 6: where each tile's run of sorted pairs starts and ends (`glsl/tile_ranges.comp`).

use ash::vk;
use bytemuck::{Pod, Zeroable};

use super::sort::LINEAR_ARGS_OFFSET;
use crate::error::Result;
use crate::shaders;
use crate::vk::{Buffer, ComputePipeline, Context};

/// Device addresses the tile-ranges kernel reads and writes.
#[repr(C)]
#[derive(Clone, Copy, Pod, Zeroable)]
pub struct TileRangesPush {
    /// Sorted keys.
    pub keys: u64,
    /// The sort's `SortInfo` (number of keys).
    pub info: u64,
    /// Out: `[start, end)` per tile (zero-filled beforehand).
    pub ranges: u64,
    /// Tiles in the grid: keys from here on (pairs that add nothing) belong to no tile.
    pub tile_count: u32,
    /// Padding to 8 bytes.
    pub pad: u32,
}

/// The tile-ranges kernel.
pub struct TileRanges {
    pipeline: ComputePipeline,
}

impl TileRanges {
    /// Builds the kernel.
    pub fn new(ctx: &Context) -> Result<Self> {
        Ok(TileRanges {
            pipeline: ComputePipeline::new::<TileRangesPush>(
                ctx,
                c"tile_ranges",
                shaders::TILE_RANGES,
            )?,
        })
    }

    /// Records the kernel, one invocation per sorted pair (indirect, from the sort's info).
    pub fn record(&self, cmd: vk::CommandBuffer, push: &TileRangesPush, sort_info: &Buffer) {
        self.pipeline
            .dispatch_indirect(cmd, push, sort_info.raw, LINEAR_ARGS_OFFSET);
    }
}
