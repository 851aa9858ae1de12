//! Stage 5 (and part of stage 2): a stable GPU radix sort of (32-bit key, 32-bit value) pairs,
//! a reusable component. The frame uses it twice: the drawn Gaussians by depth, then their
//! (tile, splat) pairs by tile.
//!
//! Least-significant-digit first, each pass reduce-then-scan: a count kernel (histograms per
//! block, or per run of keys) -> prefix sum over the digit-major histogram -> a scatter kernel
//! (stable: each invocation writes its own run of keys in order, at positions the histogram
//! scan gives). Only the key bits in use are sorted. The number of pairs is read on
//! the GPU, so a frame never waits on the host; no workgroup waits on another. Two layouts
//! ([`SortLayout`]) do the same sort: one for GPUs (4-bit digits, counters in registers, ranks
//! from subgroup scans, at any subgroup size of
//! [`MIN_SUBGROUP_SIZE`](crate::constants::MIN_SUBGROUP_SIZE) or more) and one for CPU drivers
//! (8-bit digits, one histogram per invocation, in a private array). On CPU devices a sort of
//! many keys is segmented: its first pass sorts by the top digit, and then each of that
//! digit's buckets is sorted on its own, by one invocation where it is small enough, so its
//! keys stay in the cache ([`RadixSort::set_segment_min_keys`]).
//!
//! Kernels: `glsl/sort_prepare.comp`, `glsl/sort_{count,scatter}.comp` (GPU layout),
//! `sort_{count,scatter}_own_counts*` (CPU layout, a variant per way the pass
//! holds its input and output; shared code in `glsl/sort_own_counts.glsl` and the
//! `*_body.glsl` files), `glsl/sort_segments.comp` and `sort_local_{2,3}`
//! (segmented sorts, CPU devices).

use std::ffi::CStr;

use ash::vk;
use bytemuck::{Pod, Zeroable};

use super::prefix_sum::{PrefixSum, PrefixSumScratch};
use crate::constants::{
    SORT_BLOCK, SORT_LOCAL_LOOP_BUDGET, SORT_OWN_MAX_BLOCK, SORT_OWN_MIN_BLOCK, SORT_OWN_MIN_ITEMS,
    SORT_OWN_RADIX, SORT_OWN_RADIX_BITS, SORT_OWN_WORKGROUP, SORT_RADIX, SORT_RADIX_BITS,
    SORT_SEGMENT_MIN_KEYS,
};
use crate::error::{Error, Result, VkContext};
use crate::gpu_types::{GpuSortInfo, SORT_HIST_OFFSET};
use crate::shaders;
use crate::timing::PassTimer;
use crate::vk::descriptors::{allocate_sets, write_texel_view};
use crate::vk::{compute_barrier, Buffer, ComputePipeline, Context, MemoryLocation};

#[repr(C)]
#[derive(Clone, Copy, Pod, Zeroable)]
struct PreparePush {
    count: u64,
    info: u64,
    capacity: u32,
    hist_per_block: u32,
    min_block: u32,
    max_block: u32,
    segment_min: u32,
    pad: u32,
}

#[repr(C)]
#[derive(Clone, Copy, Pod, Zeroable)]
struct SegmentsPush {
    info: u64,
    hist: u64,
    table: u64,
    passes: u32,
    local_passes: u32,
    local_max_keys: u32,
    pad: u32,
}

#[repr(C)]
#[derive(Clone, Copy, Pod, Zeroable)]
struct LocalPush {
    table: u64,
}

/// What the own-counts kernels of a pass need beyond the GPU layout's push constants: the
/// runs table and digit of a segmented sort, used where the GPU side chose to segment it.
#[repr(C)]
#[derive(Clone, Copy, Pod, Zeroable)]
struct SegmentedPass {
    runs: u64,
    seg_shift: u32,
    seg_digit_mask: u32,
    from_table: u32,
    pad: u32,
}

#[repr(C)]
#[derive(Clone, Copy, Pod, Zeroable)]
struct CountPush {
    keys: u64,
    info: u64,
    hist: u64,
    shift: u32,
    digit_mask: u32,
    segmented: SegmentedPass,
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
    digit_mask: u32,
    segmented: SegmentedPass,
}

/// Byte offset of `block_args` in `SortInfo`.
const BLOCK_ARGS_OFFSET: u64 = 16;
/// Byte offset of `linear_args` in `SortInfo`.
pub(crate) const LINEAR_ARGS_OFFSET: u64 = 32;
/// Byte offset of `hist_len` in `SortInfo`.
const HIST_LEN_OFFSET: u64 = 8;
/// Byte offset of `pass_args` in `SortInfo` (passes 1, 2 and 3, 16 bytes each).
const PASS_ARGS_OFFSET: u64 = 64;
/// Byte offset of `local_args` in `SortInfo`.
const LOCAL_ARGS_OFFSET: u64 = 112;

/// How the count and scatter kernels split the work. Both sort the same way (and are tested
/// alike); they differ in speed by device.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum SortLayout {
    /// 4-bit digits; blocks of [`SORT_BLOCK`] keys, 256 invocations of 16 keys each with one
    /// counter per digit in registers, ranked with subgroup scans (`sort_count.comp`,
    /// `sort_scatter.comp`): the layout for GPUs, many threads with few registers each.
    ShortRuns,
    /// 8-bit digits (half the passes); every invocation owns a run of 4,096 keys, or up to
    /// 16,384 in a sort of many keys (8 runs per workgroup, [`SORT_OWN_MIN_BLOCK`] to
    /// [`SORT_OWN_MAX_BLOCK`] keys), counts it in a histogram of its own (a private
    /// array) and writes that to its own column of the global histogram, whose scan then
    /// gives each run its output positions: the scatter neither counts again nor waits on the
    /// other invocations (`sort_*_own_counts`). For CPU drivers such as lavapipe, where
    /// an indexed shared-memory, buffer or image store is a loop over the lanes, while a
    /// counter in registers costs a compare per digit value per key, which 8-bit digits make
    /// 256. Measured on llvmpipe (`bench --sort 2000000`, 32-bit keys): the 4-bit layout with
    /// 64 invocations of 64 keys each took 456 ms; a block histogram that the scatter counted
    /// again took 350 ms with 512-key runs and 280-293 ms with 2,048; a column per run
    /// 224-238 ms with 2,048-key runs, 206-214 ms with 4,096 and 261-276 ms with 1,024. The
    /// kernels read the keys and values through texel views (gathers on such a driver, where
    /// a buffer load is a lane loop) and kept the counters in a storage texel buffer: 205-210
    /// -> 104-114 ms; the counters in a private array, whose indexed stores gallivm writes
    /// without a loop or branch: 86-105 -> 58-70 ms. Between passes the pairs travel packed,
    /// one 64-bit store per pair in the scatter instead of two (each a loop over the lanes):
    /// 87-94 -> 64-84 ms (builds in turn; 58-70 -> 49-50 ms in a quieter hour). Runs that
    /// grow with the sort while 16 blocks or more are left: see
    /// [`SORT_PARALLEL_BLOCKS`](crate::constants::SORT_PARALLEL_BLOCKS).
    OwnCounts,
}

impl SortLayout {
    /// The layout for a device: own counts for the CPU drivers' layouts
    /// ([`super::cpu_layouts`]), short runs elsewhere.
    /// `RARA_SORT=short|own` overrides the choice.
    pub fn for_device(ctx: &Context) -> SortLayout {
        match std::env::var("RARA_SORT").as_deref() {
            Ok("short") => return SortLayout::ShortRuns,
            Ok("own") => return SortLayout::OwnCounts,
            _ => {}
        }
        if super::cpu_layouts(ctx) {
            SortLayout::OwnCounts
        } else {
            SortLayout::ShortRuns
        }
    }

    /// Bits per digit: one radix pass sorts this many key bits.
    pub fn radix_bits(self) -> u32 {
        match self {
            SortLayout::ShortRuns => SORT_RADIX_BITS,
            SortLayout::OwnCounts => SORT_OWN_RADIX_BITS,
        }
    }

    /// Keys per block, one workgroup's share of a pass: the fewest. The number of blocks, and
    /// the histogram's size, is at its largest with these.
    pub fn min_block(self) -> u32 {
        match self {
            SortLayout::ShortRuns => SORT_BLOCK,
            SortLayout::OwnCounts => SORT_OWN_MIN_BLOCK,
        }
    }

    /// Keys per block at the most: a sort of many keys doubles its blocks from
    /// [`SortLayout::min_block`] up to this while it keeps
    /// [`SORT_PARALLEL_BLOCKS`](crate::constants::SORT_PARALLEL_BLOCKS) blocks or more.
    /// The GPU layout's blocks are fixed.
    pub fn max_block(self) -> u32 {
        match self {
            SortLayout::ShortRuns => SORT_BLOCK,
            SortLayout::OwnCounts => SORT_OWN_MAX_BLOCK,
        }
    }

    /// Histogram entries per block: a count per digit value for the whole block (GPU layout)
    /// or for each invocation's run (CPU layout).
    pub fn hist_per_block(self) -> u32 {
        match self {
            SortLayout::ShortRuns => SORT_RADIX,
            SortLayout::OwnCounts => SORT_OWN_RADIX * SORT_OWN_WORKGROUP,
        }
    }

    /// Number of radix passes for `key_bits` (at most 32) significant key bits.
    pub fn passes_for(self, key_bits: u32) -> u32 {
        assert!(key_bits <= 32, "keys are 32-bit, {key_bits} bits asked for");
        key_bits.div_ceil(self.radix_bits())
    }
}

/// The radix-sort kernels.
pub struct RadixSort {
    prepare: ComputePipeline,
    /// Count kernel over separate keys (every pass of the GPU layout; in the own-counts
    /// layout the first pass of a sort of separate keys and values).
    count: ComputePipeline,
    /// Scatter kernel from separate keys and values to separate keys and values (every pass of
    /// the GPU layout, a one-pass sort in the own-counts layout).
    scatter: ComputePipeline,
    /// The own-counts layout's kernels that read or write packed pairs: the passes between
    /// the first and the last of a sort, and sorts of packed pairs.
    packed: Option<PackedPassKernels>,
    /// The own-counts layout's kernels of segmented sorts.
    segments: Option<SegmentKernels>,
    scan: PrefixSum,
    layout: SortLayout,
    /// The own-counts kernels' descriptor set layout, uniform texel buffers of the pass's
    /// input (`R32G32B32A32_UINT`): keys (binding 0) and values (binding 1) four to a texel,
    /// and the same key buffer as packed pairs (binding 2), two to a texel; and the pass's
    /// output key buffer as a storage buffer (binding 3), which the `*_bound` scatter kernels
    /// write packed pairs to.
    texel_layout: Option<vk::DescriptorSetLayout>,
    /// Whether packed pairs are written through bound storage buffers where the buffers allow
    /// it ([`RadixSort::set_bound_output`]).
    bound_output: bool,
    /// Sorts of this many keys or more are segmented where the layout can; `None`: none
    /// ([`RadixSort::set_segment_min_keys`]).
    segment_min_keys: Option<u32>,
    ctx: Context,
}

/// How a sort's input or result is held in a [`SortBuffers`].
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum PairForm {
    /// Keys in `keys[k]`, values in `values[k]`, one `u32` each.
    Split,
    /// Each pair as one `u64` in `keys[k]`: the key in the low 32 bits, the value in the
    /// high 32 bits.
    Packed,
}

/// The forms of a sort's input and of its result.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct SortForms {
    /// How the pairs to sort are held.
    pub input: PairForm,
    /// How the sorted pairs are left.
    pub output: PairForm,
}

impl SortForms {
    /// Input and result both in `form`.
    pub const fn same(form: PairForm) -> SortForms {
        SortForms {
            input: form,
            output: form,
        }
    }
}

/// The own-counts layout's kernels that read or write packed pairs ([`PairForm::Packed`]). A
/// sort of several passes hands the pairs on packed between them, so that a pass's scatter
/// writes a pair with one store (`sort_*_own_counts_*pairs`).
struct PackedPassKernels {
    /// Count kernel over packed pairs.
    count: ComputePipeline,
    /// Scatter kernel from separate keys and values to packed pairs (the first pass of a
    /// split sort).
    scatter_to_packed: ComputePipeline,
    /// Scatter kernel from packed pairs to packed pairs (the passes between the first and the
    /// last, and every pass of a packed sort).
    scatter_packed: ComputePipeline,
    /// Scatter kernel from packed pairs to separate keys and values (the last pass of a split
    /// sort).
    scatter_from_packed: ComputePipeline,
    /// As `scatter_to_packed`, writing through the set's storage buffer (binding 3), for
    /// buffers that fit `maxStorageBufferRange` ([`SortTexels::bound_out`]).
    scatter_to_packed_bound: ComputePipeline,
    /// As `scatter_packed`, writing through the set's storage buffer.
    scatter_packed_bound: ComputePipeline,
}

impl PackedPassKernels {
    fn new(ctx: &Context, set_layout: vk::DescriptorSetLayout) -> Result<Self> {
        let scatter = |name, spirv| {
            ComputePipeline::with_set_layout::<ScatterPush>(ctx, name, spirv, Some(set_layout))
        };
        Ok(PackedPassKernels {
            count: ComputePipeline::with_set_layout::<CountPush>(
                ctx,
                c"sort_count_own_counts_pairs",
                shaders::SORT_COUNT_OWN_COUNTS_PAIRS,
                Some(set_layout),
            )?,
            scatter_to_packed: scatter(
                c"sort_scatter_own_counts_to_pairs",
                shaders::SORT_SCATTER_OWN_COUNTS_TO_PAIRS,
            )?,
            scatter_packed: scatter(
                c"sort_scatter_own_counts_pairs",
                shaders::SORT_SCATTER_OWN_COUNTS_PAIRS,
            )?,
            scatter_from_packed: scatter(
                c"sort_scatter_own_counts_from_pairs",
                shaders::SORT_SCATTER_OWN_COUNTS_FROM_PAIRS,
            )?,
            scatter_to_packed_bound: scatter(
                c"sort_scatter_own_counts_to_pairs_bound",
                shaders::SORT_SCATTER_OWN_COUNTS_TO_PAIRS_BOUND,
            )?,
            scatter_packed_bound: scatter(
                c"sort_scatter_own_counts_pairs_bound",
                shaders::SORT_SCATTER_OWN_COUNTS_PAIRS_BOUND,
            )?,
        })
    }
}

/// The most keys a bucket of a segmented sort's first pass may hold for one invocation to sort
/// it by `local_passes` digits after the top one (`glsl/sort_local_body.glsl`, 2 or 3): its
/// loops take 263 iterations and one per 4 keys to count the bucket, then 264 and one per 4
/// keys per pass, and all of them together stay within [`SORT_LOCAL_LOOP_BUDGET`] (lavapipe
/// ends an invocation after 65,535 loop iterations): 114,946 keys for one pass, 76,278 for
/// two, 56,945 for three.
pub fn local_max_keys(local_passes: u32) -> u32 {
    assert!((1..=3).contains(&local_passes), "1 to 3 local passes");
    4 * (SORT_LOCAL_LOOP_BUDGET - 263 - 264 * local_passes) / (local_passes + 1)
}

/// How many of the passes after the first of a sort of `passes` passes (2 to 4) the local
/// kernels would make where every bucket is small enough: all of them, but the last of a sort
/// of separate keys and values (`glsl/sort_local_body.glsl`), which the kernels that sort the
/// buckets in runs then make. Sorts are segmented only where this is 2 or 3: a bucket stays in
/// the cache from one local pass to the next, and a single one gains nothing (the tile sort of
/// playbot at 1280x960, 1.05M pairs in 2 passes: 11.1-12.7 ms against 12.9-13.6 ms segmented).
fn local_passes(passes: u32, form: PairForm) -> u32 {
    match form {
        PairForm::Split => passes.saturating_sub(2),
        PairForm::Packed => passes.saturating_sub(1),
    }
}

/// The own-counts layout's kernels of a segmented sort ([`RadixSort::set_segment_min_keys`]):
/// after the first pass, `buckets` lists its buckets and chooses how the others run;
/// `local[k]` sorts each small bucket by the k + 2 digits after the top one.
struct SegmentKernels {
    buckets: ComputePipeline,
    local: [ComputePipeline; 2],
}

impl SegmentKernels {
    fn new(ctx: &Context, set_layout: vk::DescriptorSetLayout) -> Result<Self> {
        // The local kernels read one buffer and write the other through two sets: the sort's
        // set of buffer 1, then that of buffer 0.
        let local = |name, spirv| {
            ComputePipeline::with_set_layouts::<LocalPush>(
                ctx,
                name,
                spirv,
                &[set_layout, set_layout],
            )
        };
        Ok(SegmentKernels {
            buckets: ComputePipeline::new::<SegmentsPush>(
                ctx,
                c"sort_segments",
                shaders::SORT_SEGMENTS,
            )?,
            local: [
                local(c"sort_local_2", shaders::SORT_LOCAL_2)?,
                local(c"sort_local_3", shaders::SORT_LOCAL_3)?,
            ],
        })
    }
}

/// The own-counts layout's texel views of a [`SortBuffers`]' keys and values, and the
/// descriptor sets: `sets[k]` reads `keys[k]` and `values[k]` (or the packed pairs in
/// `keys[k]`), the input of a pass from buffer `k`, and binds `keys[1 - k]`, its output, as a
/// storage buffer where `bound_out`.
struct SortTexels {
    pool: vk::DescriptorPool,
    sets: [vk::DescriptorSet; 2],
    /// Whether the sets bind the output key buffers (binding 3): where their packed pairs fit
    /// the device's `maxStorageBufferRange` (128 MiB, 16.7M pairs, on lavapipe). Larger sorts
    /// write through the buffer references.
    bound_out: bool,
    views: Vec<vk::BufferView>,
    ctx: Context,
}

impl SortTexels {
    /// Views and sets for `keys` (each `capacity` packed pairs) and `values` (each `capacity`
    /// u32s); `capacity` is a multiple of 4.
    fn new(
        ctx: &Context,
        layout: vk::DescriptorSetLayout,
        keys: &[Buffer; 2],
        values: &[Buffer; 2],
        capacity: u64,
    ) -> Result<Self> {
        let uniform = vk::DescriptorType::UNIFORM_TEXEL_BUFFER;
        let sizes = [
            vk::DescriptorPoolSize {
                ty: uniform,
                descriptor_count: 6,
            },
            vk::DescriptorPoolSize {
                ty: vk::DescriptorType::STORAGE_BUFFER,
                descriptor_count: 2,
            },
        ];
        let (pool, sets) = allocate_sets(ctx, &sizes, &[layout, layout])?;
        // From here on Drop frees what exists.
        let mut texels = SortTexels {
            pool,
            sets: [sets[0], sets[1]],
            bound_out: capacity * 8 <= ctx.info().max_storage_buffer_range as u64,
            views: Vec::with_capacity(6),
            ctx: ctx.clone(),
        };
        for k in 0..2 {
            let set = texels.sets[k];
            let four = vk::Format::R32G32B32A32_UINT;
            for (binding, buffer, bytes) in [
                (0, &keys[k], capacity * 4),
                (1, &values[k], capacity * 4),
                (2, &keys[k], capacity * 8),
            ] {
                let view = write_texel_view(ctx, buffer, four, bytes, set, binding, uniform)?;
                texels.views.push(view);
            }
            if texels.bound_out {
                let out = [vk::DescriptorBufferInfo {
                    buffer: keys[1 - k].raw,
                    offset: 0,
                    range: capacity * 8,
                }];
                let write = vk::WriteDescriptorSet::default()
                    .dst_set(set)
                    .dst_binding(3)
                    .descriptor_type(vk::DescriptorType::STORAGE_BUFFER)
                    .buffer_info(&out);
                unsafe { ctx.device().update_descriptor_sets(&[write], &[]) };
            }
        }
        Ok(texels)
    }
}

impl Drop for SortTexels {
    fn drop(&mut self) {
        let device = self.ctx.device();
        unsafe {
            for &v in &self.views {
                device.destroy_buffer_view(v, None);
            }
            device.destroy_descriptor_pool(self.pool, None);
        }
    }
}

/// Ping-pong key/value buffers and scratch for sorting up to `capacity` pairs.
pub struct SortBuffers {
    /// The own-counts layout's texel views of `keys` and `values` (declared first: dropped
    /// before the buffers).
    texels: Option<SortTexels>,
    /// Keys (`u32`), two buffers that passes alternate between. In the own-counts layout each
    /// holds 8 bytes per pair: the passes between the first and the last leave the pairs
    /// packed in them.
    pub keys: [Buffer; 2],
    /// Values, alongside `keys`.
    pub values: [Buffer; 2],
    /// `SortInfo` header followed by the histograms (per block or per run, by layout).
    pub info: Buffer,
    scan: PrefixSumScratch,
    /// The own-counts layout's table of a segmented sort's buckets and runs
    /// (`sort_segments.comp`), a `uvec4` each.
    table: Option<Buffer>,
    capacity: u64,
}

impl SortBuffers {
    /// Device bytes held (keys, values, histograms and scan scratch).
    pub fn device_bytes(&self) -> u64 {
        self.keys
            .iter()
            .chain(&self.values)
            .map(|b| b.size)
            .sum::<u64>()
            + self.info.size
            + self.scan.device_bytes()
            + self.table.as_ref().map_or(0, |t| t.size)
    }

    /// Most pairs these buffers hold.
    pub fn capacity(&self) -> u64 {
        self.capacity
    }

    /// How the last sort recorded on these buffers, once it has run, took its passes after the
    /// first (the GPU side chooses). Reads the sort's header back.
    pub fn segmentation(&self) -> Result<Segmentation> {
        let info = self.info.download_as::<GpuSortInfo>(1)?[0];
        Ok(if info.segmented == 0 {
            Segmentation::None
        } else if info.local_args[0] != 0 {
            Segmentation::LocalBuckets
        } else {
            Segmentation::BucketRuns
        })
    }
}

/// How the last sort recorded on a [`SortBuffers`] ran its passes after the first
/// ([`SortBuffers::segmentation`]; see [`RadixSort::set_segment_min_keys`]).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Segmentation {
    /// Not segmented: every pass sorted all the keys by one digit, least significant first.
    None,
    /// The first pass sorted by the top digit, then one invocation per bucket sorted it by the
    /// other digits (`sort_local_*`).
    LocalBuckets,
    /// The first pass sorted by the top digit, then the other passes sorted all the keys in runs
    /// that keep within their bucket (a bucket was too large for one invocation).
    BucketRuns,
}

/// Most radix passes: 32-bit keys in the GPU layout's 4-bit digits.
const MAX_PASSES: usize = (32 / SORT_RADIX_BITS) as usize;

/// Debug labels / timing names of one use of the sort: its setup and each radix pass.
pub struct SortLabels {
    /// The setup pass.
    pub setup: &'static CStr,
    /// Radix pass `k`.
    pub passes: [&'static CStr; MAX_PASSES],
}

/// Labels of the frame's sort of (tile, splat) pairs by tile ("sort setup", "sort pass 0", ...),
/// also used by `rara bench --sort`.
pub const TILE_SORT_LABELS: SortLabels = SortLabels {
    setup: c"sort setup",
    passes: [
        c"sort pass 0",
        c"sort pass 1",
        c"sort pass 2",
        c"sort pass 3",
        c"sort pass 4",
        c"sort pass 5",
        c"sort pass 6",
        c"sort pass 7",
    ],
};

/// Sort key bits of the frame's pair sort: enough bits for the tile id and for the tile count,
/// the key of pairs that add nothing (`cutoff_tiles`). The pairs are emitted in depth
/// order, which the stable sort keeps within each tile.
pub fn tile_key_bits(width: u32, height: u32) -> u32 {
    let (gx, gy) = crate::camera::tile_grid(width, height);
    (gx * gy + 1).next_power_of_two().trailing_zeros()
}

/// Labels of the frame's sort of the visible Gaussians by depth ("depth sort setup", ...).
pub const DEPTH_SORT_LABELS: SortLabels = SortLabels {
    setup: c"depth sort setup",
    passes: [
        c"depth sort pass 0",
        c"depth sort pass 1",
        c"depth sort pass 2",
        c"depth sort pass 3",
        c"depth sort pass 4",
        c"depth sort pass 5",
        c"depth sort pass 6",
        c"depth sort pass 7",
    ],
};

impl RadixSort {
    /// Builds the kernels in the layout that suits the device ([`SortLayout::for_device`]).
    pub fn new(ctx: &Context) -> Result<Self> {
        Self::with_layout(ctx, SortLayout::for_device(ctx))
    }

    /// Builds the kernels in `layout`. The own-counts layout needs texel buffers of
    /// [`super::CPU_LAYOUT_MIN_TEXELS`] texels and is refused
    /// ([`crate::Error::MissingRequirement`]) on a device with smaller ones.
    pub fn with_layout(ctx: &Context, layout: SortLayout) -> Result<Self> {
        if layout == SortLayout::OwnCounts {
            super::check_cpu_layout(ctx, "own-counts sort", "short-runs")?;
        }
        let (count, scatter) = match layout {
            SortLayout::ShortRuns => (
                (c"sort_count", shaders::SORT_COUNT),
                (c"sort_scatter", shaders::SORT_SCATTER),
            ),
            SortLayout::OwnCounts => (
                (c"sort_count_own_counts", shaders::SORT_COUNT_OWN_COUNTS),
                (c"sort_scatter_own_counts", shaders::SORT_SCATTER_OWN_COUNTS),
            ),
        };
        let texel_layout = match layout {
            SortLayout::ShortRuns => None,
            SortLayout::OwnCounts => {
                let binding = |b: u32| {
                    vk::DescriptorSetLayoutBinding::default()
                        .binding(b)
                        .descriptor_type(vk::DescriptorType::UNIFORM_TEXEL_BUFFER)
                        .descriptor_count(1)
                        .stage_flags(vk::ShaderStageFlags::COMPUTE)
                };
                let bindings = [
                    binding(0),
                    binding(1),
                    binding(2),
                    vk::DescriptorSetLayoutBinding::default()
                        .binding(3)
                        .descriptor_type(vk::DescriptorType::STORAGE_BUFFER)
                        .descriptor_count(1)
                        .stage_flags(vk::ShaderStageFlags::COMPUTE),
                ];
                let info = vk::DescriptorSetLayoutCreateInfo::default().bindings(&bindings);
                Some(
                    unsafe { ctx.device().create_descriptor_set_layout(&info, None) }
                        .vk("vkCreateDescriptorSetLayout")?,
                )
            }
        };
        let kernels = (|| {
            Ok((
                ComputePipeline::new::<PreparePush>(ctx, c"sort_prepare", shaders::SORT_PREPARE)?,
                ComputePipeline::with_set_layout::<CountPush>(ctx, count.0, count.1, texel_layout)?,
                ComputePipeline::with_set_layout::<ScatterPush>(
                    ctx,
                    scatter.0,
                    scatter.1,
                    texel_layout,
                )?,
                texel_layout
                    .map(|l| PackedPassKernels::new(ctx, l))
                    .transpose()?,
                // Segmented sorts on CPU drivers only ([`super::cpu_layouts`]): the local kernels read through texel
                // views what they wrote through storage buffers in the same dispatch, which a
                // GPU's texture cache need not see (sort_local_body.glsl).
                texel_layout
                    .filter(|_| super::cpu_layouts(ctx))
                    .map(|l| SegmentKernels::new(ctx, l))
                    .transpose()?,
                PrefixSum::new(ctx)?,
            ))
        })();
        match kernels {
            Ok((prepare, count, scatter, packed, segments, scan)) => Ok(RadixSort {
                prepare,
                count,
                scatter,
                packed,
                segments,
                scan,
                layout,
                texel_layout,
                bound_output: true,
                segment_min_keys: Some(SORT_SEGMENT_MIN_KEYS),
                ctx: ctx.clone(),
            }),
            Err(e) => {
                if let Some(l) = texel_layout {
                    unsafe { ctx.device().destroy_descriptor_set_layout(l, None) };
                }
                Err(e)
            }
        }
    }

    /// The layout the kernels were built in.
    pub fn layout(&self) -> SortLayout {
        self.layout
    }

    /// Number of radix passes for `key_bits` (at most 32) significant key bits; the result of
    /// [`RadixSort::record`] is in buffer `passes % 2`.
    pub fn passes_for(&self, key_bits: u32) -> u32 {
        self.layout.passes_for(key_bits)
    }

    /// Allocates buffers for up to `capacity` pairs (a multiple of 4 keys and values, since
    /// the pass kernels read them four at a time).
    pub fn buffers(&self, ctx: &Context, capacity: u64) -> Result<SortBuffers> {
        let capacity = capacity.max(1).next_multiple_of(4);
        let blocks = capacity.div_ceil(self.layout.min_block() as u64);
        let mut hist_len = blocks * self.layout.hist_per_block() as u64;
        // A segmented sort's runs: at most one per SORT_OWN_MIN_ITEMS keys, and one more per
        // bucket for its cut at the bucket's end; the table lists the buckets first.
        let max_seg_runs = capacity.div_ceil(SORT_OWN_MIN_ITEMS as u64) + SORT_OWN_RADIX as u64;
        let table = match self.segments {
            Some(_) => {
                hist_len = hist_len.max(max_seg_runs * SORT_OWN_RADIX as u64);
                Some(Buffer::new(
                    ctx,
                    "sort segments",
                    (SORT_OWN_RADIX as u64 + max_seg_runs) * 16,
                    MemoryLocation::GpuOnly,
                )?)
            }
            None => None,
        };
        let gpu = MemoryLocation::GpuOnly;
        let key_bytes = match self.packed {
            Some(_) => capacity * 8,
            None => capacity * 4,
        };
        let keys = [
            Buffer::new(ctx, "sort keys A", key_bytes, gpu)?,
            Buffer::new(ctx, "sort keys B", key_bytes, gpu)?,
        ];
        let values = [
            Buffer::new(ctx, "sort values A", capacity * 4, gpu)?,
            Buffer::new(ctx, "sort values B", capacity * 4, gpu)?,
        ];
        let texels = match self.texel_layout {
            Some(layout) => {
                // The views hold capacity / 4 texels of keys or values, capacity / 2 of
                // packed pairs.
                let max_texels = ctx.info().max_texel_buffer_elements as u64;
                if capacity / 2 > max_texels {
                    return Err(Error::InvalidInput(format!(
                        "a sort of {capacity} pairs needs more than the {max_texels} texels a \
                         texel buffer holds on this device (maxTexelBufferElements) in the \
                         own-counts layout; RARA_SORT=short selects the other one"
                    )));
                }
                Some(SortTexels::new(ctx, layout, &keys, &values, capacity)?)
            }
            None => None,
        };
        Ok(SortBuffers {
            keys,
            values,
            info: Buffer::new(
                ctx,
                "sort info + histograms",
                SORT_HIST_OFFSET + hist_len * 4,
                gpu,
            )?,
            scan: self.scan.scratch(ctx, hist_len)?,
            table,
            capacity,
            texels,
        })
    }

    /// Switches the own-counts layout's writes of packed pairs through bound storage buffers
    /// (on by default) on or off. Off, every pass writes through buffer references, as the
    /// sorts too large for `maxStorageBufferRange` do; for comparison and tests. The result is
    /// the same.
    pub fn set_bound_output(&mut self, on: bool) {
        self.bound_output = on;
    }

    /// Which sorts the own-counts layout segments on CPU devices: those of `min_keys` keys or
    /// more (by default [`SORT_SEGMENT_MIN_KEYS`]) of packed pairs in 3 or 4 passes or of
    /// separate keys and values in 4 (see `local_passes` in this file), or none. A segmented sort
    /// sorts by its top digit first and then each of that digit's buckets on its own by the
    /// other digits, least significant first: one invocation per bucket where every bucket is
    /// small enough ([`local_max_keys`]), else in runs that stay within their bucket
    /// (`glsl/sort_segments.comp`); [`SortBuffers::segmentation`] tells which a sort took. The
    /// result is the same; for comparison and tests. The GPU layout ignores it.
    pub fn set_segment_min_keys(&mut self, min_keys: Option<u32>) {
        self.segment_min_keys = min_keys.map(|n| n.max(1));
    }

    /// Whether this sorter can segment a sort ([`RadixSort::set_segment_min_keys`]): the
    /// own-counts layout on a CPU device only, whose caches keep what the local kernels write
    /// and read back in one dispatch coherent (a GPU's texture cache need not).
    pub fn can_segment(&self) -> bool {
        self.segments.is_some()
    }

    /// Whether this sort takes and gives packed pairs ([`RadixSort::record_forms`]): in the
    /// own-counts layout.
    pub fn sorts_packed(&self) -> bool {
        self.packed.is_some()
    }

    /// The count and scatter kernels of radix pass `pass` of `passes`, for a sort whose input
    /// and result are in `forms`: the passes between hand the pairs on packed where the layout
    /// can, through the sets' storage buffers where they are `bound` ([`SortTexels`]).
    fn pass_kernels(
        &self,
        pass: u32,
        passes: u32,
        forms: SortForms,
        bound: bool,
    ) -> (&ComputePipeline, &ComputePipeline) {
        let Some(packed) = self.packed.as_ref() else {
            assert!(
                forms.input == PairForm::Split && forms.output == PairForm::Split,
                "packed pairs in the {:?} sort layout",
                self.layout
            );
            return (&self.count, &self.scatter);
        };
        let packed_in = pass > 0 || forms.input == PairForm::Packed;
        let packed_out = pass + 1 < passes || forms.output == PairForm::Packed;
        let count = if packed_in {
            &packed.count
        } else {
            &self.count
        };
        let scatter = match (packed_in, packed_out, bound) {
            (false, false, _) => &self.scatter,
            (false, true, false) => &packed.scatter_to_packed,
            (false, true, true) => &packed.scatter_to_packed_bound,
            (true, true, false) => &packed.scatter_packed,
            (true, true, true) => &packed.scatter_packed_bound,
            (true, false, _) => &packed.scatter_from_packed,
        };
        (count, scatter)
    }

    /// Records the sort of the pairs in `bufs.keys[0]` / `bufs.values[0]`. Their number is the
    /// `u32` at device address `count`, clamped to the capacity. Only the low `key_bits` bits
    /// (at most 32) of the keys are sorted. Returns the index (0 or 1) of the buffers holding
    /// the result. Ends with a barrier. With a `timer`, the setup and every radix pass are
    /// timed passes of their own, named by `labels`.
    #[allow(clippy::too_many_arguments)]
    pub fn record(
        &self,
        ctx: &Context,
        cmd: vk::CommandBuffer,
        bufs: &SortBuffers,
        count: u64,
        key_bits: u32,
        labels: &SortLabels,
        timer: Option<&mut PassTimer>,
    ) -> usize {
        let forms = SortForms::same(PairForm::Split);
        self.record_forms(ctx, cmd, bufs, count, key_bits, forms, labels, timer)
    }

    /// As [`RadixSort::record`], for a sort whose input is in `forms.input` and whose result
    /// is in `forms.output`: with [`PairForm::Packed`], packed pairs in `bufs.keys[0]`, or the
    /// result packed in `bufs.keys[result]`. The frame's tile pairs go in packed on CPU drivers
    /// (emit writes them so) and come out split for the rasterizer. Only the own-counts layout
    /// sorts packed pairs ([`RadixSort::sorts_packed`]); in the other a packed form panics.
    #[allow(clippy::too_many_arguments)]
    pub fn record_forms(
        &self,
        ctx: &Context,
        cmd: vk::CommandBuffer,
        bufs: &SortBuffers,
        count: u64,
        key_bits: u32,
        forms: SortForms,
        labels: &SortLabels,
        timer: Option<&mut PassTimer>,
    ) -> usize {
        self.record_passes(ctx, cmd, bufs, 0, count, key_bits, forms, labels, timer)
    }

    /// As [`RadixSort::record`], for pairs in `bufs.keys[first]` / `bufs.values[first]`: the
    /// result is in buffer `(first + passes) % 2`, which it returns. The frame's depth sort
    /// starts in buffer 1 or 0 so that its result lands in buffer 1, which leaves buffer 0 to
    /// the tile pairs emitted from it (the two sorts share their buffers).
    #[allow(clippy::too_many_arguments)]
    pub fn record_from(
        &self,
        ctx: &Context,
        cmd: vk::CommandBuffer,
        bufs: &SortBuffers,
        first: usize,
        count: u64,
        key_bits: u32,
        labels: &SortLabels,
        timer: Option<&mut PassTimer>,
    ) -> usize {
        let forms = SortForms::same(PairForm::Split);
        self.record_passes(ctx, cmd, bufs, first, count, key_bits, forms, labels, timer)
    }

    /// The passes of a sort from buffer `first` (0 or 1); returns the buffer of the result.
    #[allow(clippy::too_many_arguments)]
    fn record_passes(
        &self,
        ctx: &Context,
        cmd: vk::CommandBuffer,
        bufs: &SortBuffers,
        first: usize,
        count: u64,
        key_bits: u32,
        forms: SortForms,
        labels: &SortLabels,
        mut timer: Option<&mut PassTimer>,
    ) -> usize {
        assert!(first < 2, "sort buffer {first}");
        if let Some(t) = timer.as_deref_mut() {
            t.begin_pass(cmd, labels.setup);
        }
        let info = bufs.info.address;
        let hist = info + SORT_HIST_OFFSET;
        let passes = self.passes_for(key_bits);
        let bound = self.bound_output && bufs.texels.as_ref().is_some_and(|t| t.bound_out);
        // Where the GPU side may segment the sort (sort_prepare.comp decides by the count):
        // the local kernels write through the sets' storage buffers, so only where those are
        // bound.
        let segments = self
            .segments
            .as_ref()
            .zip(self.segment_min_keys)
            .filter(|_| bound && local_passes(passes, forms.output) >= 2);
        let table = bufs.table.as_ref().map_or(0, |t| t.address);
        let push = PreparePush {
            count,
            info,
            capacity: bufs.capacity.min(u32::MAX as u64) as u32,
            hist_per_block: self.layout.hist_per_block(),
            min_block: self.layout.min_block(),
            max_block: self.layout.max_block(),
            segment_min: segments.map_or(0, |(_, min_keys)| min_keys),
            pad: 0,
        };
        self.prepare.dispatch(cmd, &push, [1, 1, 1]);
        compute_barrier(ctx, cmd);
        if let Some(t) = timer.as_deref_mut() {
            t.end_pass(cmd, labels.setup);
        }
        let mut src = first;
        let bits = self.layout.radix_bits();
        // (shift, mask) of digit k of the key.
        let digit = |k: u32| {
            let shift = k * bits;
            (shift, (1u32 << bits.min(key_bits - shift)) - 1)
        };
        for pass in 0..passes {
            let label = labels.passes[pass as usize];
            if let Some(t) = timer.as_deref_mut() {
                t.begin_pass(cmd, label);
            }
            if let (Some((kernels, _)), 1) = (segments, pass) {
                self.record_buckets(ctx, cmd, bufs, src, kernels, passes, forms.output);
            }
            let (shift, digit_mask) = digit(pass);
            // A segmented sort takes the top digit first, then the others from the least
            // significant.
            let (seg_shift, seg_digit_mask) = digit(if pass == 0 { passes - 1 } else { pass - 1 });
            let segmented = SegmentedPass {
                runs: table,
                seg_shift,
                seg_digit_mask,
                from_table: (pass > 0) as u32,
                pad: 0,
            };
            // The GPU side wrote block_args to pass_args where it did not segment the sort.
            let args = if segments.is_some() && pass > 0 {
                PASS_ARGS_OFFSET + 16 * (pass as u64 - 1)
            } else {
                BLOCK_ARGS_OFFSET
            };
            let push = CountPush {
                keys: bufs.keys[src].address,
                info,
                hist,
                shift,
                digit_mask,
                segmented,
            };
            let texels = bufs.texels.as_ref().map(|t| t.sets[src]);
            let (count, scatter) = self.pass_kernels(pass, passes, forms, bound);
            count.dispatch_indirect_in(cmd, &push, texels, bufs.info.raw, args);
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
                digit_mask,
                segmented,
            };
            scatter.dispatch_indirect_in(cmd, &push, texels, bufs.info.raw, args);
            compute_barrier(ctx, cmd);
            if let Some(t) = timer.as_deref_mut() {
                t.end_pass(cmd, label);
            }
            src = 1 - src;
        }
        src
    }

    /// Records what follows a segmented sort's first pass (see
    /// [`RadixSort::set_segment_min_keys`]): `sort_segments.comp` lists the buckets and
    /// chooses, and where every bucket is small the local kernel sorts each by the digits
    /// after the top one ([`local_passes`] of them; the passes it makes then dispatch no
    /// workgroup). It leaves the pairs where those passes would have. `src` is the buffer the
    /// first pass left the pairs in.
    #[allow(clippy::too_many_arguments)]
    fn record_buckets(
        &self,
        ctx: &Context,
        cmd: vk::CommandBuffer,
        bufs: &SortBuffers,
        src: usize,
        kernels: &SegmentKernels,
        passes: u32,
        form: PairForm,
    ) {
        let info = bufs.info.address;
        let table = bufs.table.as_ref().map_or(0, |t| t.address);
        let local_passes = local_passes(passes, form);
        let push = SegmentsPush {
            info,
            hist: info + SORT_HIST_OFFSET,
            table,
            passes,
            local_passes,
            local_max_keys: local_max_keys(local_passes),
            pad: 0,
        };
        kernels.buckets.dispatch(cmd, &push, [1, 1, 1]);
        compute_barrier(ctx, cmd);
        let Some(texels) = bufs.texels.as_ref() else {
            return;
        };
        kernels.local[local_passes as usize - 2].dispatch_indirect_with_sets(
            cmd,
            &LocalPush { table },
            &[texels.sets[src], texels.sets[1 - src]],
            bufs.info.raw,
            LOCAL_ARGS_OFFSET,
        );
        compute_barrier(ctx, cmd);
    }

    /// Sorts `keys` with their `values` on the GPU (upload, sort, read back), comparing only the
    /// low `key_bits` bits (at most 32). Stable: equal keys keep their input order.
    pub fn sort_pairs(
        &self,
        ctx: &Context,
        keys: &[u32],
        values: &[u32],
        key_bits: u32,
    ) -> Result<(Vec<u32>, Vec<u32>)> {
        assert_eq!(keys.len(), values.len(), "one value per key");
        let bufs = self.buffers(ctx, keys.len() as u64)?;
        bufs.keys[0].upload(bytemuck::cast_slice(keys))?;
        bufs.values[0].upload(bytemuck::cast_slice(values))?;
        self.run_to_split(ctx, &bufs, keys.len(), key_bits, PairForm::Split)
    }

    /// Sorts packed pairs (see [`PairForm::Packed`]) on the GPU (upload, sort, readback) by
    /// the low `key_bits` bits (at most 32) of their keys. Stable. An error in a layout that
    /// does not sort packed pairs ([`RadixSort::sorts_packed`]).
    pub fn sort_packed_pairs(
        &self,
        ctx: &Context,
        pairs: &[u64],
        key_bits: u32,
    ) -> Result<Vec<u64>> {
        let bufs = self.upload_packed(ctx, pairs)?;
        let forms = SortForms::same(PairForm::Packed);
        let out = self.run_uploaded(ctx, &bufs, pairs.len(), key_bits, forms)?;
        bufs.keys[out].download_as(pairs.len())
    }

    /// As [`RadixSort::sort_packed_pairs`], the result split into keys and values: what a
    /// frame's tile sort does with the packed pairs emit writes on CPU drivers.
    pub fn sort_packed_pairs_split(
        &self,
        ctx: &Context,
        pairs: &[u64],
        key_bits: u32,
    ) -> Result<(Vec<u32>, Vec<u32>)> {
        let bufs = self.upload_packed(ctx, pairs)?;
        self.run_to_split(ctx, &bufs, pairs.len(), key_bits, PairForm::Packed)
    }

    /// Sorts the `n` pairs uploaded to `bufs` in `input` (as [`RadixSort::run_uploaded`]) and
    /// reads the result back as keys and values.
    fn run_to_split(
        &self,
        ctx: &Context,
        bufs: &SortBuffers,
        n: usize,
        key_bits: u32,
        input: PairForm,
    ) -> Result<(Vec<u32>, Vec<u32>)> {
        let forms = SortForms {
            input,
            output: PairForm::Split,
        };
        let out = self.run_uploaded(ctx, bufs, n, key_bits, forms)?;
        Ok((
            bufs.keys[out].download_as(n)?,
            bufs.values[out].download_as(n)?,
        ))
    }

    /// Buffers for `pairs` with the pairs uploaded packed; an error in a layout that does not
    /// sort packed pairs.
    fn upload_packed(&self, ctx: &Context, pairs: &[u64]) -> Result<SortBuffers> {
        if !self.sorts_packed() {
            return Err(Error::InvalidInput(format!(
                "the {:?} sort layout does not sort packed pairs",
                self.layout
            )));
        }
        let bufs = self.buffers(ctx, pairs.len() as u64)?;
        bufs.keys[0].upload(bytemuck::cast_slice(pairs))?;
        Ok(bufs)
    }

    /// Sorts the `n` pairs uploaded to `bufs` in `forms.input` and waits for it (the count
    /// from a buffer of its own, as in a frame); returns the index of the buffers holding the
    /// result, in `forms.output`.
    fn run_uploaded(
        &self,
        ctx: &Context,
        bufs: &SortBuffers,
        n: usize,
        key_bits: u32,
        forms: SortForms,
    ) -> Result<usize> {
        let count = Buffer::from_slice(ctx, "sort count", &[n as u32])?;
        ctx.run_commands(|cmd| {
            self.record_forms(
                ctx,
                cmd,
                bufs,
                count.address,
                key_bits,
                forms,
                &TILE_SORT_LABELS,
                None,
            )
        })
    }
}

impl Drop for RadixSort {
    fn drop(&mut self) {
        if let Some(l) = self.texel_layout {
            unsafe { self.ctx.device().destroy_descriptor_set_layout(l, None) };
        }
    }
}
