//! The GPU radix sort against `sort_by_key` (stable), and the prefix sum against a CPU scan.

mod common;

use rara::constants::{
    SCAN_BLOCK, SCAN_RUN, SCAN_RUN_WORKGROUP, SORT_OWN_WORKGROUP, SORT_PARALLEL_BLOCKS,
};
use rara::stages::sort::{
    local_max_keys, PairForm, RadixSort, Segmentation, SortForms, SortLayout, TILE_SORT_LABELS,
};
use rara::vk::Buffer;

/// Both layouts run on every device, so the GPU one is checked here too.
use rara::synth::Rng;

fn check_sort(sorter: &RadixSort, ctx: &rara::Context, keys: Vec<u32>, key_bits: u32, what: &str) {
    let values: Vec<u32> = (0..keys.len() as u32).collect();
    let (gpu_keys, gpu_values) = sorter.sort_pairs(ctx, &keys, &values, key_bits).unwrap();
    let mask = if key_bits >= 32 {
        u32::MAX
    } else {
        (1u32 << key_bits) - 1
    };
    let mut expected: Vec<(u32, u32)> = keys.iter().copied().zip(values).collect();
    expected.sort_by_key(|&(k, _)| k & mask); // stable
    assert_eq!(gpu_keys.len(), keys.len(), "{what}");
    for (i, (&(k, v), (&gk, &gv))) in expected
        .iter()
        .zip(gpu_keys.iter().zip(&gpu_values))
        .enumerate()
    {
        assert!(
            k == gk && v == gv,
            "{what} (n = {}, {:?}): position {i}: GPU ({gk:#x}, {gv}), expected ({k:#x}, {v})",
            keys.len(),
            sorter.layout()
        );
    }
    common::assert_no_validation_messages(ctx);
}

/// Sorts `keys` packed with their indices as values (key low, value high) by their low
/// `key_bits` bits, against a stable CPU sort.
fn check_packed_sort(
    sorter: &RadixSort,
    ctx: &rara::Context,
    keys: &[u32],
    key_bits: u32,
    what: &str,
) {
    let pairs: Vec<u64> = keys
        .iter()
        .enumerate()
        .map(|(i, &key)| key as u64 | (i as u64) << 32)
        .collect();
    let got = sorter.sort_packed_pairs(ctx, &pairs, key_bits).unwrap();
    let mask = (u64::MAX >> (64 - key_bits)) & u32::MAX as u64;
    let mut expected = pairs.clone();
    expected.sort_by_key(|&p| p & mask); // stable
    let n = keys.len();
    assert_eq!(got.len(), n, "{what}");
    if let Some(i) = (0..n).find(|&i| got[i] != expected[i]) {
        panic!(
            "{what}: {key_bits}-bit keys, n = {n}: position {i}: GPU {:#x}, expected {:#x}",
            got[i], expected[i]
        );
    }
    // The same input with the result split into keys and values, as a frame's tile sort
    // leaves the packed pairs that emit writes on CPU drivers.
    let (got_keys, got_values) = sorter
        .sort_packed_pairs_split(ctx, &pairs, key_bits)
        .unwrap();
    assert_eq!((got_keys.len(), got_values.len()), (n, n), "{what}, split");
    if let Some(i) =
        (0..n).find(|&i| got_keys[i] as u64 | (got_values[i] as u64) << 32 != expected[i])
    {
        panic!(
            "{what}, split: {key_bits}-bit keys, n = {n}: position {i}: GPU ({:#x}, {:#x}), \
             expected {:#x}",
            got_keys[i], got_values[i], expected[i]
        );
    }
    common::assert_no_validation_messages(ctx);
}

/// Sorts `keys` with their indices as values by their low `key_bits` bits in `form`, through
/// the sort's buffers as a frame records it, against a stable CPU sort; returns how the sort
/// ran its passes after the first.
fn check_segmented_sort(
    sorter: &RadixSort,
    ctx: &rara::Context,
    keys: &[u32],
    key_bits: u32,
    form: PairForm,
    what: &str,
) -> Segmentation {
    let n = keys.len();
    let values: Vec<u32> = (0..n as u32).collect();
    let bufs = sorter.buffers(ctx, n as u64).unwrap();
    let packed: Vec<u64> = keys
        .iter()
        .zip(&values)
        .map(|(&k, &v)| k as u64 | (v as u64) << 32)
        .collect();
    match form {
        PairForm::Packed => bufs.keys[0].upload(bytemuck::cast_slice(&packed)).unwrap(),
        PairForm::Split => {
            bufs.keys[0].upload(bytemuck::cast_slice(keys)).unwrap();
            bufs.values[0]
                .upload(bytemuck::cast_slice(&values))
                .unwrap();
        }
    }
    let count = Buffer::from_slice(ctx, "sort count", &[n as u32]).unwrap();
    let out = ctx
        .run_commands(|cmd| {
            sorter.record_forms(
                ctx,
                cmd,
                &bufs,
                count.address,
                key_bits,
                SortForms::same(form),
                &TILE_SORT_LABELS,
                None,
            )
        })
        .unwrap();
    let got: Vec<u64> = match form {
        PairForm::Packed => bufs.keys[out].download_as(n).unwrap(),
        PairForm::Split => {
            let k: Vec<u32> = bufs.keys[out].download_as(n).unwrap();
            let v: Vec<u32> = bufs.values[out].download_as(n).unwrap();
            k.iter()
                .zip(&v)
                .map(|(&k, &v)| k as u64 | (v as u64) << 32)
                .collect()
        }
    };
    let mask = (u64::MAX >> (64 - key_bits)) & u32::MAX as u64;
    let mut expected = packed;
    expected.sort_by_key(|&p| p & mask); // stable
    if let Some(i) = (0..n).find(|&i| got[i] != expected[i]) {
        panic!(
            "{what}: {key_bits}-bit keys, n = {n}, {form:?}: position {i}: GPU {:#x}, expected {:#x}",
            got[i], expected[i]
        );
    }
    common::assert_no_validation_messages(ctx);
    bufs.segmentation().unwrap()
}

fn random_keys(n: usize, bits: u32, seed: u64) -> Vec<u32> {
    let mut rng = Rng::new(seed);
    let mask = if bits >= 32 {
        u32::MAX
    } else {
        (1u32 << bits) - 1
    };
    (0..n).map(|_| rng.next_u64() as u32 & mask).collect()
}

#[test]
fn sort_sizes_around_block_boundaries() {
    let ctx = common::context();
    for layout in common::sort_layouts(&ctx) {
        sort_sizes_in_layout(&ctx, layout);
    }
}

fn sort_sizes_in_layout(ctx: &rara::Context, layout: SortLayout) {
    let sorter = RadixSort::with_layout(ctx, layout).unwrap();
    let block = layout.min_block() as usize;
    // The histogram's scan changes level at SCAN_BLOCK entries: a whole number of blocks in
    // the GPU layout. The CPU layout's histogram has more than SCAN_BLOCK entries per block
    // (one column per run), so it spans levels from the first block and gets a size of a few
    // blocks instead.
    let per_block = layout.hist_per_block();
    let hist_level = if per_block < SCAN_BLOCK {
        (SCAN_BLOCK / per_block) as usize * block
    } else {
        4 * block
    };
    // In the CPU layout each of the workgroup's invocations owns a run of the block.
    let run = block / SORT_OWN_WORKGROUP as usize;
    let mut sizes = vec![0, 1, 2, 255, 256, 257];
    for b in [run, run + 2, 3 * run, block, 2 * block, hist_level] {
        sizes.extend([b - 1, b, b + 1]);
    }
    for (k, n) in sizes.into_iter().enumerate() {
        check_sort(
            &sorter,
            ctx,
            random_keys(n, 32, k as u64),
            32,
            "random 32-bit keys",
        );
    }
}

#[test]
fn sort_key_patterns() {
    let ctx = common::context();
    for layout in common::sort_layouts(&ctx) {
        key_patterns_in_layout(&ctx, layout);
    }
}

fn key_patterns_in_layout(ctx: &rara::Context, layout: SortLayout) {
    let sorter = RadixSort::with_layout(ctx, layout).unwrap();
    let n = 3 * layout.min_block() as usize + 17;
    check_sort(&sorter, ctx, vec![0x1234_5678; n], 32, "all-equal keys");
    check_sort(
        &sorter,
        ctx,
        (0..n as u32).map(|i| i * 3).collect(),
        32,
        "sorted keys",
    );
    check_sort(
        &sorter,
        ctx,
        (0..n as u32).rev().map(|i| i << 14).collect(),
        32,
        "reverse-sorted keys",
    );
    // Few distinct keys: stability decides the order of the values.
    check_sort(&sorter, ctx, random_keys(n, 3, 5), 3, "3-bit keys");
    // Bits above key_bits must be ignored.
    check_sort(
        &sorter,
        ctx,
        random_keys(n, 32, 6),
        13,
        "32-bit keys sorted on 13 bits",
    );
    // Tile ids as a frame sorts them: few bits, long runs of equal keys.
    check_sort(&sorter, ctx, random_keys(n, 11, 7), 11, "11-bit keys");
    // Three passes in the CPU layout (and five in the GPU one): an odd number above one, whose
    // result ends in the second buffers.
    check_sort(&sorter, ctx, random_keys(n, 20, 8), 20, "20-bit keys");
}

/// Sorts of packed pairs (key in the low 32 bits, value in the high), in the layout that
/// takes them, the result packed and split: every count of passes, sizes around a run and a
/// block, against a stable CPU sort. The GPU layout refuses them.
#[test]
fn sort_packed_pairs() {
    let ctx = common::context();
    let refused = RadixSort::with_layout(&ctx, SortLayout::ShortRuns).unwrap();
    assert!(!refused.sorts_packed());
    assert!(refused.sort_packed_pairs(&ctx, &[1, 2], 32).is_err());
    assert!(refused.sort_packed_pairs_split(&ctx, &[1, 2], 32).is_err());
    if !common::runs_cpu_layouts(&ctx) {
        return;
    }
    let sorter = RadixSort::with_layout(&ctx, SortLayout::OwnCounts).unwrap();
    assert!(sorter.sorts_packed());
    let block = SortLayout::OwnCounts.min_block() as usize;
    let run = block / SORT_OWN_WORKGROUP as usize;
    let sizes = [0, 1, 5, run - 1, run + 3, block + 1, 3 * block + 17];
    // One, two, three and four passes.
    for (k, key_bits) in [3u32, 13, 20, 32].into_iter().enumerate() {
        for (j, &n) in sizes.iter().enumerate() {
            let keys = random_keys(n, 32, (10 * k + j) as u64);
            check_packed_sort(&sorter, &ctx, &keys, key_bits, "packed pairs");
        }
    }
}

/// The CPU layout's blocks double while SORT_PARALLEL_BLOCKS or more are left: sizes on both
/// sides of each doubling, whose last block holds one key past the others or is whole. Split
/// and packed pairs.
#[test]
fn sort_sizes_where_runs_grow() {
    let ctx = common::context();
    if !common::runs_cpu_layouts(&ctx) {
        return;
    }
    let layout = SortLayout::OwnCounts;
    let sorter = RadixSort::with_layout(&ctx, layout).unwrap();
    let parallel = SORT_PARALLEL_BLOCKS as usize;
    let mut block = layout.min_block() as usize;
    let mut k = 0;
    while block < layout.max_block() as usize {
        // Above (parallel - 1) blocks of twice the size, the block doubles.
        let edge = (parallel - 1) * 2 * block;
        for n in [edge, edge + 1] {
            check_sort(
                &sorter,
                &ctx,
                random_keys(n, 32, 200 + k),
                32,
                "random 32-bit keys where the runs grow",
            );
            k += 1;
        }
        block *= 2;
    }
    let n = (parallel - 1) * block + 1;
    check_packed_sort(
        &sorter,
        &ctx,
        &random_keys(n, 32, 300),
        32,
        "packed pairs in the longest runs",
    );
}

/// The own-counts layout writes packed pairs through bound storage buffers where they fit
/// `maxStorageBufferRange`, and through buffer references past it: the reference path, forced
/// here, sorts the same (split pairs of one to four passes, and packed pairs).
#[test]
fn sort_through_buffer_references() {
    let ctx = common::context();
    if !common::runs_cpu_layouts(&ctx) {
        return;
    }
    let mut sorter = RadixSort::with_layout(&ctx, SortLayout::OwnCounts).unwrap();
    sorter.set_bound_output(false);
    let block = SortLayout::OwnCounts.min_block() as usize;
    for (k, key_bits) in [3u32, 13, 20, 32].into_iter().enumerate() {
        let n = 3 * block + 17;
        check_sort(
            &sorter,
            &ctx,
            random_keys(n, 32, 400 + k as u64),
            key_bits,
            "through buffer references",
        );
    }
    check_packed_sort(
        &sorter,
        &ctx,
        &random_keys(2 * block + 5, 32, 410),
        32,
        "packed pairs through buffer references",
    );
}

/// 2M pairs: in the CPU layout a segmented sort at the default threshold, its buckets sorted
/// one per invocation (on a CPU device; on a GPU, plain).
#[test]
fn sort_two_million_pairs() {
    let ctx = common::context();
    let keys = random_keys(2_000_000, 32, 99);
    let short = RadixSort::with_layout(&ctx, SortLayout::ShortRuns).unwrap();
    check_sort(&short, &ctx, keys.clone(), 32, "2M random pairs");
    if !common::holds_cpu_layouts(&ctx) {
        return;
    }
    let own = RadixSort::with_layout(&ctx, SortLayout::OwnCounts).unwrap();
    let how = check_segmented_sort(&own, &ctx, &keys, 32, PairForm::Split, "2M random pairs");
    let way = if own.can_segment() {
        Segmentation::LocalBuckets
    } else {
        Segmentation::None
    };
    assert_eq!(how, way);
}

/// Segmented sorts in the CPU layout, with every sort of many keys segmented here: the first
/// pass by the top digit, then each bucket by the other digits, by one invocation where every
/// bucket is small enough (2 and 3 passes, up to the largest bucket it takes, which keeps
/// within lavapipe's loop cap) and in runs within the buckets where one is larger (skewed keys,
/// one key past that bucket size). Split and packed pairs, buckets starting anywhere, against a
/// stable CPU sort; each case also checks which way the sort went (on a GPU, which segments
/// nothing, that it went plain). Sorts with a single pass for
/// the local kernel (two passes, or three of separate keys and values) are not segmented, and
/// with segmentation off nothing is.
#[test]
fn segmented_sorts() {
    use Segmentation::{BucketRuns, LocalBuckets, None as Plain};
    let ctx = common::context();
    if !common::runs_cpu_layouts(&ctx) {
        return;
    }
    let mut sorter = RadixSort::with_layout(&ctx, SortLayout::OwnCounts).unwrap();
    sorter.set_segment_min_keys(Some(1));
    // Buckets of the top byte: one holding `big` keys (top byte 0x40), the others random.
    let one_big_bucket = |big: usize, others: usize, seed: u64| -> Vec<u32> {
        let mut keys: Vec<u32> = random_keys(others, 32, seed)
            .into_iter()
            .map(|k| if k >> 24 == 0x40 { k ^ 0x8000_0000 } else { k })
            .collect();
        let low = random_keys(big, 24, seed + 1);
        keys.extend(low.into_iter().map(|k| 0x4000_0000 | k));
        let mut rng = Rng::new(seed + 2);
        for i in (1..keys.len()).rev() {
            keys.swap(i, rng.next_u64() as usize % (i + 1));
        }
        keys
    };
    // Depth-like keys: the top byte takes two values, so a bucket holds half the keys.
    let depth_like: Vec<u32> = random_keys(200_001, 25, 31)
        .into_iter()
        .map(|k| 0x3f00_0000 + k)
        .collect();
    // (keys, key bits, way of the split sort, way of the packed sort, what)
    let cases: Vec<(Vec<u32>, u32, Segmentation, Segmentation, &str)> = vec![
        (
            random_keys(100_003, 32, 20),
            32,
            LocalBuckets,
            LocalBuckets,
            "random 32-bit keys",
        ),
        (
            random_keys(300_001, 20, 21),
            20,
            Plain,
            LocalBuckets,
            "20-bit keys, 16 buckets",
        ),
        (
            random_keys(60_000, 3, 22),
            20,
            Plain,
            LocalBuckets,
            "few distinct keys, 1 bucket",
        ),
        (
            random_keys(80_000, 3, 23),
            20,
            Plain,
            BucketRuns,
            "few distinct keys, too many",
        ),
        (depth_like, 32, BucketRuns, BucketRuns, "depth-like keys"),
        (
            random_keys(300_001, 32, 24),
            13,
            Plain,
            Plain,
            "13 of 32 bits, 2 passes",
        ),
    ];
    // On a GPU nothing is segmented (RadixSort::can_segment): the same sorts, plain.
    let segmenting = sorter.can_segment();
    if !segmenting {
        eprintln!(
            "segmented_sorts: {} does not segment; the sorts run plain",
            ctx.info().name
        );
    }
    let expect = |way: Segmentation| if segmenting { way } else { Plain };
    for (keys, key_bits, split_way, packed_way, what) in &cases {
        for (form, way) in [(PairForm::Split, split_way), (PairForm::Packed, packed_way)] {
            let how = check_segmented_sort(&sorter, &ctx, keys, *key_bits, form, what);
            assert_eq!(how, expect(*way), "{what}, {form:?}");
        }
    }
    // The largest bucket one invocation sorts, by 3 digits (packed pairs) or 2 (separate keys
    // and values, whose last pass the runs make), and one key more.
    for (form, local_passes) in [(PairForm::Packed, 3), (PairForm::Split, 2)] {
        let limit = local_max_keys(local_passes) as usize;
        for (big, way) in [(limit, LocalBuckets), (limit + 1, BucketRuns)] {
            let keys = one_big_bucket(big, 60_000, 25 + big as u64);
            let what = format!("a bucket of {big} keys");
            let how = check_segmented_sort(&sorter, &ctx, &keys, 32, form, &what);
            assert_eq!(how, expect(way), "{what}, {form:?}");
        }
    }
    sorter.set_segment_min_keys(None);
    let (keys, key_bits, _, _, what) = &cases[0];
    let how = check_segmented_sort(&sorter, &ctx, keys, *key_bits, PairForm::Packed, what);
    assert_eq!(how, Plain);
}

/// `data` scanned on the GPU by `scan`, with the grand total it stores.
fn scan_on_gpu(
    ctx: &rara::Context,
    scan: &rara::stages::prefix_sum::PrefixSum,
    data: &[u32],
) -> (Vec<u32>, u32) {
    use rara::vk::Buffer;
    let n = data.len();
    let buf = Buffer::from_slice(ctx, "scan data", data).unwrap();
    let meta = Buffer::from_slice(ctx, "scan count + total", &[n as u32, u32::MAX]).unwrap();
    let scratch = scan.scratch(ctx, n as u64).unwrap();
    ctx.run_commands(|cmd| {
        scan.record(
            ctx,
            cmd,
            buf.address,
            meta.address,
            Some(meta.address + 4),
            &scratch,
        )
    })
    .unwrap();
    (
        buf.download_as(n).unwrap(),
        meta.download_as::<u32>(2).unwrap()[1],
    )
}

#[test]
fn prefix_sum_matches_cpu() {
    use rara::stages::prefix_sum::{PrefixSum, ScanLayout};
    let ctx = common::context();
    let b = SCAN_BLOCK as usize;
    let run = SCAN_RUN as usize;
    let runs_per_group = run * SCAN_RUN_WORKGROUP as usize;
    let mut rng = Rng::new(3);
    for layout in [ScanLayout::Blocks, ScanLayout::Runs] {
        let scan = PrefixSum::with_layout(&ctx, layout).unwrap();
        // Around the blocks layout's level changes, and the runs layout's runs (read four at
        // a time, so also sizes that leave 1-3 elements over) and workgroups.
        for n in [
            0,
            1,
            5,
            run - 1,
            run,
            run + 3,
            4 * run + 2,
            runs_per_group - 1,
            runs_per_group + 1,
            b - 1,
            b,
            b + 1,
            b * b - 1,
            b * b,
            b * b + 1,
            3 * b * b + 7,
        ] {
            let data: Vec<u32> = (0..n).map(|_| (rng.next_u64() % 50) as u32).collect();
            let (got, total) = scan_on_gpu(&ctx, &scan, &data);
            let mut acc = 0u32;
            for (i, (&x, &g)) in data.iter().zip(&got).enumerate() {
                assert_eq!(g, acc, "{layout:?}, n = {n}: element {i}");
                acc += x;
            }
            assert_eq!(total, acc, "{layout:?}, n = {n}: total");
        }
    }
    common::assert_no_validation_messages(&ctx);
}

/// The CPU layout's largest scan, which one invocation's loop over the runs' sums bounds
/// (lavapipe stops an invocation's loops after 65,535 iterations): 2^26 ones, so element i
/// must come out as i.
#[test]
fn prefix_sum_runs_at_its_largest() {
    use rara::constants::SCAN_RUNS_MAX;
    use rara::stages::prefix_sum::{PrefixSum, ScanLayout};
    let ctx = common::context();
    let scan = PrefixSum::with_layout(&ctx, ScanLayout::Runs).unwrap();
    let n = SCAN_RUNS_MAX as usize;
    let (got, total) = scan_on_gpu(&ctx, &scan, &vec![1u32; n]);
    if let Some(i) = (0..n).find(|&i| got[i] != i as u32) {
        panic!("element {i} of {n}: {} instead of {i}", got[i]);
    }
    assert_eq!(total, n as u32, "total");
    common::assert_no_validation_messages(&ctx);
}
