//! Stage 4: a stable GPU radix sort of (64-bit key, 32-bit value) pairs, a reusable component.
//!
//! Least-significant-digit first, SORT_RADIX_BITS bits per pass, each pass reduce-then-scan:
//! `sort_count` (block histograms) -> prefix sum over the digit-major histogram ->
//! `sort_scatter` (stable, rank by per-invocation counters). Only the key bits in use are
//! sorted. The number of pairs is read on the GPU, so a frame never waits on the host; no
//! workgroup waits on another and nothing assumes a subgroup size.
//!
//! Kernels: `glsl/sort_prepare.comp`, `glsl/sort_count.comp`, `glsl/sort_scatter.comp`.

use ash::vk;
use bytemuck::{Pod, Zeroable};

use super::prefix_sum::{PrefixSum, PrefixSumScratch};
use crate::constants::{SORT_BLOCK, SORT_RADIX, SORT_RADIX_BITS};
use crate::error::Result;
use crate::gpu_types::SORT_HIST_OFFSET;
use crate::shaders;
use crate::timing::PassTimer;
use crate::vk::{compute_barrier, Buffer, ComputePipeline, Context, MemoryLocation};

#[repr(C)]
#[derive(Clone, Copy, Pod, Zeroable)]
struct PreparePush {
    count: u64,
    info: u64,
    capacity: u32,
    pad: u32,
}

#[repr(C)]
#[derive(Clone, Copy, Pod, Zeroable)]
struct CountPush {
    keys: u64,
    info: u64,
    hist: u64,
    shift: u32,
    pad: u32,
}

#[repr(C)]
#[derive(Clone, Copy, Pod, Zeroable)]
struct ScatterPush {
    keys_in: u64,
    values_in: u64,
    keys_out: u64,
    values_out: u64,
    info: u64,
    hist: u64,
    shift: u32,
    pad: u32,
}

/// Byte offset of `block_args` in `SortInfo`.
const BLOCK_ARGS_OFFSET: u64 = 16;
/// Byte offset of `linear_args` in `SortInfo`.
pub(crate) const LINEAR_ARGS_OFFSET: u64 = 32;
/// Byte offset of `hist_len` in `SortInfo`.
const HIST_LEN_OFFSET: u64 = 8;

/// The radix-sort kernels.
pub struct RadixSort {
    prepare: ComputePipeline,
    count: ComputePipeline,
    scatter: ComputePipeline,
    scan: PrefixSum,
}

/// Ping-pong key/value buffers and scratch for sorting up to `capacity` pairs.
pub struct SortBuffers {
    /// Keys as `u64` (low word, high word), two buffers that passes alternate between.
    pub keys: [Buffer; 2],
    /// Values, alongside `keys`.
    pub values: [Buffer; 2],
    /// `SortInfo` header followed by the block histograms.
    pub info: Buffer,
    scan: PrefixSumScratch,
    capacity: u64,
}

impl SortBuffers {
    /// Device bytes held (keys, values, histograms, scan scratch).
    pub fn device_bytes(&self) -> u64 {
        self.keys
            .iter()
            .chain(&self.values)
            .map(|b| b.size)
            .sum::<u64>()
            + self.info.size
            + self.scan.device_bytes()
    }

    /// Most pairs these buffers hold.
    pub fn capacity(&self) -> u64 {
        self.capacity
    }
}

/// Debug labels / timing names of the radix passes (64-bit keys need at most 16).
const SORT_PASS_LABELS: [&std::ffi::CStr; 16] = [
    c"sort pass 0",
    c"sort pass 1",
    c"sort pass 2",
    c"sort pass 3",
    c"sort pass 4",
    c"sort pass 5",
    c"sort pass 6",
    c"sort pass 7",
    c"sort pass 8",
    c"sort pass 9",
    c"sort pass 10",
    c"sort pass 11",
    c"sort pass 12",
    c"sort pass 13",
    c"sort pass 14",
    c"sort pass 15",
];

/// Number of radix passes for `key_bits` significant key bits.
pub fn passes_for(key_bits: u32) -> u32 {
    key_bits.div_ceil(SORT_RADIX_BITS)
}

impl RadixSort {
    /// Builds the kernels.
    pub fn new(ctx: &Context) -> Result<Self> {
        Ok(RadixSort {
            prepare: ComputePipeline::new::<PreparePush>(
                ctx,
                c"sort_prepare",
                shaders::SORT_PREPARE,
            )?,
            count: ComputePipeline::new::<CountPush>(ctx, c"sort_count", shaders::SORT_COUNT)?,
            scatter: ComputePipeline::new::<ScatterPush>(
                ctx,
                c"sort_scatter",
                shaders::SORT_SCATTER,
            )?,
            scan: PrefixSum::new(ctx)?,
        })
    }

    /// Allocates buffers for up to `capacity` pairs.
    pub fn buffers(&self, ctx: &Context, capacity: u64) -> Result<SortBuffers> {
        let capacity = capacity.max(1);
        let blocks = capacity.div_ceil(SORT_BLOCK as u64);
        let hist_len = blocks * SORT_RADIX as u64;
        let gpu = MemoryLocation::GpuOnly;
        Ok(SortBuffers {
            keys: [
                Buffer::new(ctx, "sort keys A", capacity * 8, gpu)?,
                Buffer::new(ctx, "sort keys B", capacity * 8, gpu)?,
            ],
            values: [
                Buffer::new(ctx, "sort values A", capacity * 4, gpu)?,
                Buffer::new(ctx, "sort values B", capacity * 4, gpu)?,
            ],
            info: Buffer::new(
                ctx,
                "sort info + histograms",
                SORT_HIST_OFFSET + hist_len * 4,
                gpu,
            )?,
            scan: self.scan.scratch(ctx, hist_len)?,
            capacity,
        })
    }

    /// Records the sort of the pairs in `bufs.keys[0]` / `bufs.values[0]`. Their number is the
    /// `u32` at device address `count`, clamped to the capacity. Only the low `key_bits` bits
    /// of the keys are sorted. Returns the index (0 or 1) of the buffers holding the result.
    /// Ends with a barrier. With a `timer`, every radix pass is a timed pass of its own
    /// ("sort setup", "sort pass 0", ...).
    pub fn record(
        &self,
        ctx: &Context,
        cmd: vk::CommandBuffer,
        bufs: &SortBuffers,
        count: u64,
        key_bits: u32,
        mut timer: Option<&mut PassTimer>,
    ) -> usize {
        if let Some(t) = timer.as_deref_mut() {
            t.begin_pass(cmd, c"sort setup");
        }
        let info = bufs.info.address;
        let hist = info + SORT_HIST_OFFSET;
        let push = PreparePush {
            count,
            info,
            capacity: bufs.capacity.min(u32::MAX as u64) as u32,
            pad: 0,
        };
        self.prepare.dispatch(cmd, &push, [1, 1, 1]);
        compute_barrier(ctx, cmd);
        if let Some(t) = timer.as_deref_mut() {
            t.end_pass(cmd, c"sort setup");
        }
        let mut src = 0;
        for pass in 0..passes_for(key_bits) {
            let label = SORT_PASS_LABELS[(pass as usize).min(SORT_PASS_LABELS.len() - 1)];
            if let Some(t) = timer.as_deref_mut() {
                t.begin_pass(cmd, label);
            }
            let shift = pass * SORT_RADIX_BITS;
            let push = CountPush {
                keys: bufs.keys[src].address,
                info,
                hist,
                shift,
                pad: 0,
            };
            self.count
                .dispatch_indirect(cmd, &push, bufs.info.raw, BLOCK_ARGS_OFFSET);
            compute_barrier(ctx, cmd);
            self.scan
                .record(ctx, cmd, hist, info + HIST_LEN_OFFSET, None, &bufs.scan);
            let push = ScatterPush {
                keys_in: bufs.keys[src].address,
                values_in: bufs.values[src].address,
                keys_out: bufs.keys[1 - src].address,
                values_out: bufs.values[1 - src].address,
                info,
                hist,
                shift,
                pad: 0,
            };
            self.scatter
                .dispatch_indirect(cmd, &push, bufs.info.raw, BLOCK_ARGS_OFFSET);
            compute_barrier(ctx, cmd);
            if let Some(t) = timer.as_deref_mut() {
                t.end_pass(cmd, label);
            }
            src = 1 - src;
        }
        src
    }

    /// Sorts `keys` with their `values` on the GPU (upload, sort, read back), comparing only the
    /// low `key_bits` bits. Stable: equal keys keep their input order.
    pub fn sort_pairs(
        &self,
        ctx: &Context,
        keys: &[u64],
        values: &[u32],
        key_bits: u32,
    ) -> Result<(Vec<u64>, Vec<u32>)> {
        assert_eq!(keys.len(), values.len(), "one value per key");
        let bufs = self.buffers(ctx, keys.len() as u64)?;
        bufs.keys[0].upload(bytemuck::cast_slice(keys))?;
        bufs.values[0].upload(bytemuck::cast_slice(values))?;
        let count = Buffer::from_slice(ctx, "sort count", &[keys.len() as u32])?;
        let out =
            ctx.run_commands(|cmd| self.record(ctx, cmd, &bufs, count.address, key_bits, None))?;
        Ok((
            bufs.keys[out].download_as(keys.len())?,
            bufs.values[out].download_as(values.len())?,
        ))
    }
}
