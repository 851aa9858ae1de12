//! Stage 3 (and a building block of the depth order and the sort): exclusive prefix sum of `u32`s whose count is
//! known only on the GPU. Reduce-then-scan over up to three levels of blocks, every pass an
//! indirect dispatch; no workgroup ever waits on another.
//!
//! Kernels: `glsl/scan_prepare.comp`, `glsl/scan_reduce.comp`, `glsl/scan_block.comp`.

use ash::vk;
use bytemuck::{Pod, Zeroable};

use crate::constants::{SCAN_BLOCK, SCAN_LEVELS};
use crate::error::Result;
use crate::shaders;
use crate::vk::{compute_barrier, Buffer, ComputePipeline, Context, MemoryLocation};

#[repr(C)]
#[derive(Clone, Copy, Pod, Zeroable)]
struct PreparePush {
    count: u64,
    level_sizes: u64,
    args: u64,
}

#[repr(C)]
#[derive(Clone, Copy, Pod, Zeroable)]
struct ReducePush {
    data: u64,
    count: u64,
    partials: u64,
}

#[repr(C)]
#[derive(Clone, Copy, Pod, Zeroable)]
struct BlockPush {
    data: u64,
    count: u64,
    offsets: u64,
    total: u64,
    flags: u32,
    pad: u32,
}

const SCAN_ADD_OFFSETS: u32 = 1;
const SCAN_WRITE_TOTAL: u32 = 2;
/// Scratch layout: level sizes (4 u32), then 4 indirect argument slots of 16 bytes, then the
/// block sums of levels 1.. .
const ARGS_OFFSET: u64 = 16;
const PARTIALS_OFFSET: u64 = 128;

/// The prefix-sum kernels.
pub struct PrefixSum {
    prepare: ComputePipeline,
    reduce: ComputePipeline,
    block: ComputePipeline,
}

/// Scratch memory for scanning up to `capacity` elements.
pub struct PrefixSumScratch {
    buffer: Buffer,
    capacity: u64,
    /// Number of levels (1..=SCAN_LEVELS) and the byte offsets of levels 1.. in `buffer`.
    level_offsets: Vec<u64>,
}

impl PrefixSumScratch {
    /// Largest element count this scratch can scan.
    pub fn capacity(&self) -> u64 {
        self.capacity
    }

    /// Device bytes held.
    pub fn device_bytes(&self) -> u64 {
        self.buffer.size
    }
}

impl PrefixSum {
    /// Builds the kernels.
    pub fn new(ctx: &Context) -> Result<Self> {
        Ok(PrefixSum {
            prepare: ComputePipeline::new::<PreparePush>(
                ctx,
                c"scan_prepare",
                shaders::SCAN_PREPARE,
            )?,
            reduce: ComputePipeline::new::<ReducePush>(ctx, c"scan_reduce", shaders::SCAN_REDUCE)?,
            block: ComputePipeline::new::<BlockPush>(ctx, c"scan_block", shaders::SCAN_BLOCK)?,
        })
    }

    /// Scratch for scans of up to `capacity` elements.
    pub fn scratch(&self, ctx: &Context, capacity: u64) -> Result<PrefixSumScratch> {
        let block = SCAN_BLOCK as u64;
        let max = block.pow(SCAN_LEVELS);
        assert!(
            capacity <= max,
            "prefix sum capacity {capacity} exceeds {max}"
        );
        let mut level_offsets = Vec::new();
        let mut offset = PARTIALS_OFFSET;
        let mut n = capacity.max(1);
        while n > block {
            n = n.div_ceil(block);
            level_offsets.push(offset);
            offset += (n * 4).next_multiple_of(16);
        }
        let buffer = Buffer::new(ctx, "prefix sum scratch", offset, MemoryLocation::GpuOnly)?;
        Ok(PrefixSumScratch {
            buffer,
            capacity,
            level_offsets,
        })
    }

    /// Records an in-place exclusive scan of the `u32` array at device address `data`, whose
    /// length is the `u32` at `count` (at most the scratch's capacity). When `total` is given,
    /// the sum of all elements is stored there. Ends with a barrier: later compute work sees
    /// the result.
    pub fn record(
        &self,
        ctx: &Context,
        cmd: vk::CommandBuffer,
        data: u64,
        count: u64,
        total: Option<u64>,
        scratch: &PrefixSumScratch,
    ) {
        let base = scratch.buffer.address;
        let sizes = |level: usize| base + 4 * level as u64;
        let args_offset = |level: usize| ARGS_OFFSET + 16 * level as u64;
        // Level l's data: the input for l = 0, block sums of level l - 1 above that.
        let levels: Vec<u64> = std::iter::once(data)
            .chain(scratch.level_offsets.iter().map(|o| base + o))
            .collect();
        let top = levels.len() - 1;

        let push = PreparePush {
            count,
            level_sizes: base,
            args: base + ARGS_OFFSET,
        };
        self.prepare.dispatch(cmd, &push, [1, 1, 1]);
        compute_barrier(ctx, cmd);
        for l in 0..top {
            let push = ReducePush {
                data: levels[l],
                count: sizes(l),
                partials: levels[l + 1],
            };
            self.reduce
                .dispatch_indirect(cmd, &push, scratch.buffer.raw, args_offset(l));
            compute_barrier(ctx, cmd);
        }
        let push = BlockPush {
            data: levels[top],
            count: sizes(top),
            offsets: 0,
            total: total.unwrap_or(0),
            flags: if total.is_some() { SCAN_WRITE_TOTAL } else { 0 },
            pad: 0,
        };
        self.block.dispatch(cmd, &push, [1, 1, 1]);
        compute_barrier(ctx, cmd);
        for l in (0..top).rev() {
            let push = BlockPush {
                data: levels[l],
                count: sizes(l),
                offsets: levels[l + 1],
                total: 0,
                flags: SCAN_ADD_OFFSETS,
                pad: 0,
            };
            self.block
                .dispatch_indirect(cmd, &push, scratch.buffer.raw, args_offset(l));
            compute_barrier(ctx, cmd);
        }
    }
}
