//! Stage 6: where each tile's run of sorted pairs starts and ends
//! (`glsl/tile_ranges_body.glsl`).

use ash::vk;
use bytemuck::{Pod, Zeroable};

use super::sort::{SortBuffers, LINEAR_ARGS_OFFSET};
use super::FrameRecording;
use crate::error::Result;
use crate::shaders;
use crate::vk::{ComputePipeline, Context};

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
    /// Builds the kernel; with `texels`, the layout of the frame's texel views (CPU drivers,
    /// along with the strips rasterizer), the variant that reads the sorted keys through them
    /// (`tile_ranges_texels`).
    pub fn new(ctx: &Context, texels: Option<vk::DescriptorSetLayout>) -> Result<Self> {
        let (name, spirv) = match texels {
            Some(_) => (c"tile_ranges_texels", shaders::TILE_RANGES_TEXELS),
            None => (c"tile_ranges", shaders::TILE_RANGES),
        };
        Ok(TileRanges {
            pipeline: ComputePipeline::with_set_layout::<TileRangesPush>(ctx, name, spirv, texels)?,
        })
    }

    /// Records the pass "tile ranges" over the pairs sorted into buffer `sorted` of `sort`, as
    /// many as its info says, then a barrier.
    pub fn record(&self, f: &mut FrameRecording, sort: &SortBuffers, sorted: usize) {
        let push = TileRangesPush {
            keys: sort.keys[sorted].address,
            info: sort.info.address,
            ranges: f.at.ranges,
            tile_count: f.tile_count(),
            pad: 0,
        };
        f.pass(c"tile ranges", |f| {
            self.pipeline.dispatch_indirect_in(
                f.cmd,
                &push,
                f.texels,
                sort.info.raw,
                LINEAR_ARGS_OFFSET,
            );
            f.barrier();
        });
    }
}
