//! Stage 3 (and a building block of the depth order and the sort): exclusive prefix sum of
//! `u32`s whose count is known only on the GPU. Reduce-then-scan, every pass an indirect
//! dispatch; no workgroup ever waits on another. Two layouts ([`ScanLayout`]) do the same scan:
//! up to three levels of blocks scanned by whole workgroups (GPUs), or one run of elements per
//! invocation (CPU drivers).
//!
//! Kernels: `glsl/scan_prepare.comp`, `glsl/scan_reduce.comp`, `glsl/scan_block.comp` (GPU
//! layout); `glsl/scan_runs_{prepare,reduce,top,down}.comp` (CPU layout, shared code in
//! `glsl/scan_runs.glsl`).

use ash::vk;
use bytemuck::{Pod, Zeroable};

use crate::constants::{SCAN_BLOCK, SCAN_LEVELS, SCAN_RUN, SCAN_RUNS_MAX};
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

#[repr(C)]
#[derive(Clone, Copy, Pod, Zeroable)]
struct RunsPreparePush {
    count: u64,
    args: u64,
}

#[repr(C)]
#[derive(Clone, Copy, Pod, Zeroable)]
struct RunsPush {
    data: u64,
    count: u64,
    sums: u64,
}

#[repr(C)]
#[derive(Clone, Copy, Pod, Zeroable)]
struct RunsTopPush {
    sums: u64,
    count: u64,
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

/// How the prefix-sum kernels split the work. Both give the same result (and are tested
/// alike); they differ in speed by device.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum ScanLayout {
    /// Blocks of [`SCAN_BLOCK`] elements, each scanned by a workgroup of 256 invocations with
    /// subgroup scans and shared memory, over up to [`SCAN_LEVELS`] levels: the layout for
    /// GPUs.
    Blocks,
    /// Every invocation sums a run of [`SCAN_RUN`] consecutive elements, one invocation scans
    /// the runs' sums, and every invocation scans its run from its offset
    /// (`glsl/scan_runs.glsl`): the layout for CPU drivers such as lavapipe, which run shared
    /// memory and subgroup operations lane by lane and a 256-wide workgroup as SIMD vectors
    /// taking turns at every barrier. Needs `data` 16-byte aligned.
    Runs,
}

impl ScanLayout {
    /// The layout for a device: runs for the CPU drivers' layouts ([`super::cpu_layouts`]),
    /// blocks elsewhere. `RARA_SCAN=blocks|runs` overrides the choice.
    pub fn for_device(ctx: &Context) -> ScanLayout {
        match std::env::var("RARA_SCAN").as_deref() {
            Ok("blocks") => return ScanLayout::Blocks,
            Ok("runs") => return ScanLayout::Runs,
            _ => {}
        }
        if super::cpu_layouts(ctx) {
            ScanLayout::Runs
        } else {
            ScanLayout::Blocks
        }
    }
}

/// The prefix-sum kernels of one layout.
pub struct PrefixSum {
    kernels: ScanKernels,
}

enum ScanKernels {
    Blocks {
        prepare: ComputePipeline,
        reduce: ComputePipeline,
        block: ComputePipeline,
    },
    Runs {
        prepare: ComputePipeline,
        reduce: ComputePipeline,
        top: ComputePipeline,
        down: ComputePipeline,
    },
}

/// Scratch memory for scanning up to `capacity` elements.
pub struct PrefixSumScratch {
    buffer: Buffer,
    capacity: u64,
    /// Blocks layout: the byte offsets of levels 1.. in `buffer` (none for a single level).
    /// Runs layout: the byte offset of the runs' sums.
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
    /// Builds the kernels in the layout that suits the device ([`ScanLayout::for_device`]).
    pub fn new(ctx: &Context) -> Result<Self> {
        Self::with_layout(ctx, ScanLayout::for_device(ctx))
    }

    /// Builds the kernels in `layout`.
    pub fn with_layout(ctx: &Context, layout: ScanLayout) -> Result<Self> {
        let kernels = match layout {
            ScanLayout::Blocks => ScanKernels::Blocks {
                prepare: ComputePipeline::new::<PreparePush>(
                    ctx,
                    c"scan_prepare",
                    shaders::SCAN_PREPARE,
                )?,
                reduce: ComputePipeline::new::<ReducePush>(
                    ctx,
                    c"scan_reduce",
                    shaders::SCAN_REDUCE,
                )?,
                block: ComputePipeline::new::<BlockPush>(ctx, c"scan_block", shaders::SCAN_BLOCK)?,
            },
            ScanLayout::Runs => ScanKernels::Runs {
                prepare: ComputePipeline::new::<RunsPreparePush>(
                    ctx,
                    c"scan_runs_prepare",
                    shaders::SCAN_RUNS_PREPARE,
                )?,
                reduce: ComputePipeline::new::<RunsPush>(
                    ctx,
                    c"scan_runs_reduce",
                    shaders::SCAN_RUNS_REDUCE,
                )?,
                top: ComputePipeline::new::<RunsTopPush>(
                    ctx,
                    c"scan_runs_top",
                    shaders::SCAN_RUNS_TOP,
                )?,
                down: ComputePipeline::new::<RunsPush>(
                    ctx,
                    c"scan_runs_down",
                    shaders::SCAN_RUNS_DOWN,
                )?,
            },
        };
        Ok(PrefixSum { kernels })
    }

    /// The layout the kernels were built in.
    pub fn layout(&self) -> ScanLayout {
        match self.kernels {
            ScanKernels::Blocks { .. } => ScanLayout::Blocks,
            ScanKernels::Runs { .. } => ScanLayout::Runs,
        }
    }

    /// Scratch for scans of up to `capacity` elements.
    pub fn scratch(&self, ctx: &Context, capacity: u64) -> Result<PrefixSumScratch> {
        let (max, unit) = match self.layout() {
            ScanLayout::Blocks => ((SCAN_BLOCK as u64).pow(SCAN_LEVELS), SCAN_BLOCK as u64),
            ScanLayout::Runs => (SCAN_RUNS_MAX, SCAN_RUN as u64),
        };
        assert!(
            capacity <= max,
            "prefix sum capacity {capacity} exceeds {max}"
        );
        let mut level_offsets = Vec::new();
        let mut offset = PARTIALS_OFFSET;
        let mut n = capacity.max(1);
        // Blocks: a level of block sums for each level of more than one block. Runs: one
        // level, the runs' sums.
        loop {
            let another = match self.layout() {
                ScanLayout::Blocks => n > unit,
                ScanLayout::Runs => level_offsets.is_empty(),
            };
            if !another {
                break;
            }
            n = n.div_ceil(unit);
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
    /// the result. In the runs layout `data` must be 16-byte aligned (every buffer rara
    /// allocates is).
    pub fn record(
        &self,
        ctx: &Context,
        cmd: vk::CommandBuffer,
        data: u64,
        count: u64,
        total: Option<u64>,
        scratch: &PrefixSumScratch,
    ) {
        match &self.kernels {
            ScanKernels::Blocks {
                prepare,
                reduce,
                block,
            } => Self::record_blocks(
                [prepare, reduce, block],
                ctx,
                cmd,
                data,
                count,
                total,
                scratch,
            ),
            ScanKernels::Runs {
                prepare,
                reduce,
                top,
                down,
            } => Self::record_runs(
                [prepare, reduce, top, down],
                ctx,
                cmd,
                data,
                count,
                total,
                scratch,
            ),
        }
    }

    /// [`PrefixSum::record`] in the runs layout: prepare, reduce, top, down.
    fn record_runs(
        [prepare, reduce, top, down]: [&ComputePipeline; 4],
        ctx: &Context,
        cmd: vk::CommandBuffer,
        data: u64,
        count: u64,
        total: Option<u64>,
        scratch: &PrefixSumScratch,
    ) {
        assert_eq!(data % 16, 0, "the runs layout scans 16-byte aligned data");
        let sums = scratch.buffer.address + scratch.level_offsets[0];
        let push = RunsPreparePush {
            count,
            args: scratch.buffer.address + ARGS_OFFSET,
        };
        prepare.dispatch(cmd, &push, [1, 1, 1]);
        compute_barrier(ctx, cmd);
        let push = RunsPush { data, count, sums };
        reduce.dispatch_indirect(cmd, &push, scratch.buffer.raw, ARGS_OFFSET);
        compute_barrier(ctx, cmd);
        let push = RunsTopPush {
            sums,
            count,
            total: total.unwrap_or(0),
            flags: if total.is_some() { SCAN_WRITE_TOTAL } else { 0 },
            pad: 0,
        };
        top.dispatch(cmd, &push, [1, 1, 1]);
        compute_barrier(ctx, cmd);
        down.dispatch_indirect(
            cmd,
            &RunsPush { data, count, sums },
            scratch.buffer.raw,
            ARGS_OFFSET,
        );
        compute_barrier(ctx, cmd);
    }

    /// [`PrefixSum::record`] in the blocks layout: prepare, reduce per level, the top block,
    /// then each level's blocks down again.
    fn record_blocks(
        [prepare, reduce, block]: [&ComputePipeline; 3],
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
        prepare.dispatch(cmd, &push, [1, 1, 1]);
        compute_barrier(ctx, cmd);
        for l in 0..top {
            let push = ReducePush {
                data: levels[l],
                count: sizes(l),
                partials: levels[l + 1],
            };
            reduce.dispatch_indirect(cmd, &push, scratch.buffer.raw, args_offset(l));
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
        block.dispatch(cmd, &push, [1, 1, 1]);
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
            block.dispatch_indirect(cmd, &push, scratch.buffer.raw, args_offset(l));
            compute_barrier(ctx, cmd);
        }
    }
}
