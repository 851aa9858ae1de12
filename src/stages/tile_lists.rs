//! Stage 4c, CPU drivers under rara clipping by planes with the mass weight: splits the tiles
//! into those whose list holds a weighted pair and the rest (`glsl/tile_lists.comp`), so that
//! the rasterizer runs its weighted kernel only over the first and its plain kernel over the
//! second. A CPU driver runs every branch, and every loop's body at least once, so the weighted
//! kernel costs a weighted compositing body on every tile it walks, weighted pair or not.
//!
//! The cutoff-tiles stage flags the tiles where it leaves a pair weighted (and every tile when
//! its loop budget left pairs unclassified); this stage lists them. GPUs branch for real and
//! keep one dispatch over the grid.

use ash::vk;
use bytemuck::{Pod, Zeroable};

use super::{linear_grid, FrameRecording};
use crate::error::Result;
use crate::shaders;
use crate::vk::{Buffer, Context, LazyPipeline};

/// Where the parts of a frame's tile-lists buffer lie, for a grid of `tile_count` tiles: the
/// two indirect dispatches (weighted list, then plain list; 16 bytes each), the flags (one
/// word per tile and one for the whole grid), and the two lists of tile ids.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct TileListsLayout {
    /// Tiles in the grid.
    pub tile_count: u32,
}

impl TileListsLayout {
    /// Offset of the weighted list's dispatch arguments (x, y, z).
    pub const WEIGHTED_ARGS: u64 = 0;
    /// Offset of the plain list's dispatch arguments.
    pub const PLAIN_ARGS: u64 = 16;
    /// Offset of the per-tile flags.
    pub const FLAGS: u64 = 32;

    /// Offset of the weighted list.
    pub fn weighted(&self) -> u64 {
        Self::FLAGS + 4 * (self.tile_count as u64 + 1)
    }

    /// Offset of the plain list.
    pub fn plain(&self) -> u64 {
        self.weighted() + 4 * self.tile_count as u64
    }

    /// Bytes of the whole buffer.
    pub fn size(&self) -> u64 {
        self.plain() + 4 * self.tile_count as u64
    }
}

/// Device addresses the tile-lists kernel reads and writes.
#[repr(C)]
#[derive(Clone, Copy, Pod, Zeroable)]
pub struct TileListsPush {
    /// Per-tile flags from the cutoff-tiles stage, then the whole grid's.
    pub flags: u64,
    /// Out: the weighted list's dispatch arguments.
    pub weighted_args: u64,
    /// Out: the plain list's dispatch arguments.
    pub plain_args: u64,
    /// Out: ids of the tiles with a weighted pair.
    pub weighted: u64,
    /// Out: ids of the other tiles.
    pub plain: u64,
    /// Out: the frame's counters (`COUNTER_WEIGHTED_TILES`).
    pub counters: u64,
    /// Tiles in the grid.
    pub tile_count: u32,
    /// The rows of tiles are taken in `spread_item` order with this stride
    /// ([`super::spread_stride`]), so the lists come out spread over the image.
    pub row_stride: u32,
    /// Tiles per row.
    pub columns: u32,
    /// Padding to 8 bytes.
    pub pad: u32,
}

/// The tile-lists kernel.
pub struct TileLists {
    pipeline: LazyPipeline,
}

impl TileLists {
    /// The stage; its kernel is built by the first frame that records it.
    pub fn new(ctx: &Context) -> Result<Self> {
        Ok(TileLists {
            pipeline: LazyPipeline::new::<TileListsPush>(
                ctx,
                c"tile_lists",
                shaders::TILE_LISTS,
                None,
            ),
        })
    }

    /// Records the reset of `buffer` (laid out as `layout`) for a new frame: both dispatches
    /// to (0, 1, 1) and every flag to 0. A compute barrier must follow before the cutoff-tiles
    /// stage writes the flags.
    pub fn record_reset(
        &self,
        ctx: &Context,
        cmd: vk::CommandBuffer,
        buffer: &Buffer,
        layout: &TileListsLayout,
    ) {
        let empty_dispatch: [u32; 4] = [0, 1, 1, 0];
        unsafe {
            for offset in [TileListsLayout::WEIGHTED_ARGS, TileListsLayout::PLAIN_ARGS] {
                ctx.device().cmd_update_buffer(
                    cmd,
                    buffer.raw,
                    offset,
                    bytemuck::bytes_of(&empty_dispatch),
                );
            }
            ctx.device().cmd_fill_buffer(
                cmd,
                buffer.raw,
                TileListsLayout::FLAGS,
                layout.weighted() - TileListsLayout::FLAGS,
                0,
            );
        }
    }

    /// Records the pass "tile lists" over the grid's tiles into `buffer` (laid out as
    /// `layout`), then a barrier.
    pub fn record(
        &self,
        f: &mut FrameRecording,
        buffer: &Buffer,
        layout: &TileListsLayout,
    ) -> Result<()> {
        let kernel = self.pipeline.get()?;
        let push = TileListsPush {
            flags: buffer.address + TileListsLayout::FLAGS,
            weighted_args: buffer.address + TileListsLayout::WEIGHTED_ARGS,
            plain_args: buffer.address + TileListsLayout::PLAIN_ARGS,
            weighted: buffer.address + layout.weighted(),
            plain: buffer.address + layout.plain(),
            counters: f.at.counters,
            tile_count: layout.tile_count,
            row_stride: super::spread_stride(f.grid.1),
            columns: f.grid.0,
            pad: 0,
        };
        f.pass(c"tile lists", |f| {
            kernel.dispatch(f.cmd, &push, linear_grid(push.tile_count));
            f.barrier();
        });
        Ok(())
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn layout_parts_follow_each_other() {
        let l = TileListsLayout { tile_count: 4800 };
        assert_eq!(l.weighted(), 32 + 4 * 4801);
        assert_eq!(l.plain(), l.weighted() + 4 * 4800);
        assert_eq!(l.size(), 32 + 4 * (3 * 4800 + 1));
    }
}
