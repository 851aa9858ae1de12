//! The ray tracer's BVH, built on the GPU (SPEC section 7, issue 32): proxy boxes
//! (`glsl/bvh_proxies.comp`), their centres' Morton codes (`bvh_morton.comp`) sorted by
//! [`RadixSort`], Karras' radix tree over them (`bvh_tree.comp`) and the nodes' boxes bottom up
//! (`bvh_bounds.comp`, where the second walker to reach a node continues and nobody waits).
//! Every step is one pass over the Gaussians, so an edited or animated scene costs a rebuild,
//! not a reload. The ray tracer that traverses it is the next part of issue 32; its CPU twin
//! is [`crate::reference::raytrace`]. Node layout: inner nodes `[0, n - 1)` with node 0 the
//! root, leaf k (the k-th Gaussian in Morton order) at `n - 1 + k`, 32 bytes each
//! ([`GpuBvhNode`]).

use ash::vk;
use bytemuck::{Pod, Zeroable};

use crate::error::Result;
use crate::gpu_scene::GpuScene;
use crate::shaders;
use crate::stages::linear_grid;
use crate::stages::sort::{RadixSort, SortBuffers, SortLabels};
use crate::vk::{compute_barrier, Buffer, ComputePipeline, Context, MemoryLocation};

/// The bits of [`GpuBvhNode::right`] that hold the child (the top two hold the split axis).
pub const BVH_CHILD_MASK: u32 = (1 << 30) - 1;

/// Bits of the Morton keys: 30 of code (10 per axis) and one above them for empty boxes.
pub const MORTON_KEY_BITS: u32 = 31;

/// A node as the GPU stores it (`BvhNode` in `glsl/bvh_common.glsl`): its box, and an inner
/// node's children or a leaf's Gaussian (in `left`). An empty box has `lo > hi`.
#[repr(C)]
#[derive(Clone, Copy, Debug, Default, PartialEq, Pod, Zeroable)]
pub struct GpuBvhNode {
    /// Lower corner.
    pub lo: [f32; 3],
    /// Left child (inner node) or the Gaussian (leaf).
    pub left: u32,
    /// Upper corner.
    pub hi: [f32; 3],
    /// Right child (inner node) in the low 30 bits, and in the top two the axis of the node's
    /// Morton split ([`GpuBvhNode::split_axis`]).
    pub right: u32,
}

impl GpuBvhNode {
    /// `(left, right)` of an inner node.
    pub fn children(&self) -> (u32, u32) {
        (self.left, self.right & BVH_CHILD_MASK)
    }

    /// The axis (0 x, 1 y, 2 z) on which an inner node's left child lies below its right one,
    /// the first bit where its Morton codes differ; `None` where they are equal. The ray
    /// tracer visits first the child the ray's direction meets first.
    pub fn split_axis(&self) -> Option<usize> {
        let axis = (self.right >> 30) as usize;
        (axis < 3).then_some(axis)
    }

    /// Whether the box is empty (`lo > hi`).
    pub fn is_empty(&self) -> bool {
        self.lo[0] > self.hi[0]
    }
}

/// Labels of the Morton sort's passes.
const BVH_SORT_LABELS: SortLabels = SortLabels {
    setup: c"bvh sort setup",
    passes: [
        c"bvh sort pass 0",
        c"bvh sort pass 1",
        c"bvh sort pass 2",
        c"bvh sort pass 3",
        c"bvh sort pass 4",
        c"bvh sort pass 5",
        c"bvh sort pass 6",
        c"bvh sort pass 7",
    ],
};

#[repr(C)]
#[derive(Clone, Copy, Pod, Zeroable)]
struct ProxiesPush {
    gaussians: u64,
    boxes: u64,
    bounds: u64,
    count: u32,
    q: f32,
}

#[repr(C)]
#[derive(Clone, Copy, Pod, Zeroable)]
struct MortonPush {
    boxes: u64,
    bounds: u64,
    keys: u64,
    values: u64,
    count: u32,
    pad: u32,
}

#[repr(C)]
#[derive(Clone, Copy, Pod, Zeroable)]
struct TreePush {
    codes: u64,
    nodes: u64,
    parents: u64,
    count: u32,
    pad: u32,
}

#[repr(C)]
#[derive(Clone, Copy, Pod, Zeroable)]
struct BoundsPush {
    boxes: u64,
    order: u64,
    nodes: u64,
    parents: u64,
    arrivals: u64,
    count: u32,
    pad: u32,
}

/// The BVH build's kernels and its Morton sort.
pub struct BvhBuild {
    proxies: ComputePipeline,
    morton: ComputePipeline,
    tree: ComputePipeline,
    bounds: ComputePipeline,
    sort: RadixSort,
}

/// The buffers of a BVH over `count` Gaussians.
pub struct BvhBuffers {
    /// Proxy boxes, one per Gaussian ([`GpuBvhNode`] without children).
    pub boxes: Buffer,
    /// The centres' bounds as order-preserving `u32`s (min xyz, max xyz).
    pub centre_bounds: Buffer,
    /// The Morton sort: codes in `keys`, Gaussians in `values`.
    pub sort: SortBuffers,
    /// The sort's count (`u32`).
    pub sort_count: Buffer,
    /// `2n - 1` nodes.
    pub nodes: Buffer,
    /// Per node, its parent (`u32::MAX` for the root).
    pub parents: Buffer,
    /// Per inner node, how many of its children's walkers arrived.
    pub arrivals: Buffer,
    /// Gaussians.
    pub count: u32,
}

impl BvhBuffers {
    /// Device bytes of the BVH's buffers.
    pub fn device_bytes(&self) -> u64 {
        [
            &self.boxes,
            &self.centre_bounds,
            &self.sort_count,
            &self.nodes,
            &self.parents,
            &self.arrivals,
        ]
        .iter()
        .map(|b| b.size)
        .sum::<u64>()
            + self.sort.device_bytes()
    }
}

/// A built BVH read back (tests, tools).
#[derive(Clone, Debug)]
pub struct BvhReadback {
    /// Proxy boxes per Gaussian.
    pub boxes: Vec<GpuBvhNode>,
    /// Morton codes in sorted order.
    pub codes: Vec<u32>,
    /// Gaussians in Morton order.
    pub order: Vec<u32>,
    /// The `2n - 1` nodes.
    pub nodes: Vec<GpuBvhNode>,
    /// Parents per node.
    pub parents: Vec<u32>,
    /// Per inner node, the walkers that arrived (2 each once built).
    pub arrivals: Vec<u32>,
}

impl BvhBuild {
    /// Builds the kernels.
    pub fn new(ctx: &Context) -> Result<Self> {
        Ok(BvhBuild {
            proxies: ComputePipeline::new::<ProxiesPush>(
                ctx,
                c"bvh_proxies",
                shaders::BVH_PROXIES,
            )?,
            morton: ComputePipeline::new::<MortonPush>(ctx, c"bvh_morton", shaders::BVH_MORTON)?,
            tree: ComputePipeline::new::<TreePush>(ctx, c"bvh_tree", shaders::BVH_TREE)?,
            bounds: ComputePipeline::new::<BoundsPush>(ctx, c"bvh_bounds", shaders::BVH_BOUNDS)?,
            sort: RadixSort::new(ctx)?,
        })
    }

    /// Buffers for a BVH over `count` Gaussians.
    pub fn buffers(&self, ctx: &Context, count: u32) -> Result<BvhBuffers> {
        let n = count.max(1) as u64;
        let gpu = MemoryLocation::GpuOnly;
        Ok(BvhBuffers {
            boxes: Buffer::new(ctx, "bvh proxy boxes", n * 32, gpu)?,
            centre_bounds: Buffer::new(ctx, "bvh centre bounds", 24, gpu)?,
            sort: self.sort.buffers(ctx, n)?,
            sort_count: Buffer::new(ctx, "bvh sort count", 4, gpu)?,
            nodes: Buffer::new(ctx, "bvh nodes", (2 * n - 1) * 32, gpu)?,
            parents: Buffer::new(ctx, "bvh parents", (2 * n - 1) * 4, gpu)?,
            arrivals: Buffer::new(ctx, "bvh arrivals", n * 4, gpu)?,
            count,
        })
    }

    /// Records the build over the Gaussians at device address `gaussians` (`bufs.count` of
    /// them), octagons with `q`; returns which of the sort's buffers holds the result.
    pub fn record(
        &self,
        ctx: &Context,
        cmd: vk::CommandBuffer,
        gaussians: u64,
        bufs: &BvhBuffers,
        q: f32,
    ) -> usize {
        let n = bufs.count;
        if n == 0 {
            return 0;
        }
        let device = ctx.device();
        let start: [u32; 6] = [u32::MAX, u32::MAX, u32::MAX, 0, 0, 0];
        unsafe {
            device.cmd_update_buffer(cmd, bufs.centre_bounds.raw, 0, bytemuck::bytes_of(&start));
            device.cmd_update_buffer(cmd, bufs.sort_count.raw, 0, bytemuck::bytes_of(&n));
            device.cmd_fill_buffer(cmd, bufs.arrivals.raw, 0, vk::WHOLE_SIZE, 0);
            device.cmd_fill_buffer(cmd, bufs.parents.raw, 0, vk::WHOLE_SIZE, u32::MAX);
        }
        compute_barrier(ctx, cmd);
        let grid = linear_grid(n);
        self.proxies.dispatch(
            cmd,
            &ProxiesPush {
                gaussians,
                boxes: bufs.boxes.address,
                bounds: bufs.centre_bounds.address,
                count: n,
                q,
            },
            grid,
        );
        compute_barrier(ctx, cmd);
        self.morton.dispatch(
            cmd,
            &MortonPush {
                boxes: bufs.boxes.address,
                bounds: bufs.centre_bounds.address,
                keys: bufs.sort.keys[0].address,
                values: bufs.sort.values[0].address,
                count: n,
                pad: 0,
            },
            grid,
        );
        compute_barrier(ctx, cmd);
        let sorted = self.sort.record(
            ctx,
            cmd,
            &bufs.sort,
            bufs.sort_count.address,
            MORTON_KEY_BITS,
            &BVH_SORT_LABELS,
            None,
        );
        compute_barrier(ctx, cmd);
        if n > 1 {
            self.tree.dispatch(
                cmd,
                &TreePush {
                    codes: bufs.sort.keys[sorted].address,
                    nodes: bufs.nodes.address,
                    parents: bufs.parents.address,
                    count: n,
                    pad: 0,
                },
                linear_grid(n - 1),
            );
            compute_barrier(ctx, cmd);
        }
        self.bounds.dispatch(
            cmd,
            &BoundsPush {
                boxes: bufs.boxes.address,
                order: bufs.sort.values[sorted].address,
                nodes: bufs.nodes.address,
                parents: bufs.parents.address,
                arrivals: bufs.arrivals.address,
                count: n,
                pad: 0,
            },
            grid,
        );
        compute_barrier(ctx, cmd);
        sorted
    }

    /// Builds the BVH of `scene` and reads it back (tests and tools; a frame records it).
    pub fn build_and_read(&self, ctx: &Context, scene: &GpuScene, q: f32) -> Result<BvhReadback> {
        let bufs = self.buffers(ctx, scene.count)?;
        let sorted =
            ctx.run_commands(|cmd| self.record(ctx, cmd, scene.gaussians.address, &bufs, q))?;
        let n = scene.count as usize;
        let nodes = (2 * n).saturating_sub(1);
        Ok(BvhReadback {
            boxes: bufs.boxes.download_as(n)?,
            codes: bufs.sort.keys[sorted].download_as(n)?,
            order: bufs.sort.values[sorted].download_as(n)?,
            nodes: bufs.nodes.download_as(nodes)?,
            parents: bufs.parents.download_as(nodes)?,
            arrivals: bufs.arrivals.download_as(n.saturating_sub(1))?,
        })
    }
}

/// Karras' radix tree over sorted codes (the CPU twin of `bvh_tree.comp`): the children of
/// each of the `n - 1` inner nodes, with leaves numbered from `n - 1`.
pub fn karras_tree(codes: &[u32]) -> Vec<(u32, u32)> {
    let n = codes.len() as i64;
    let delta = |i: i64, j: i64| -> i64 {
        if j < 0 || j >= n {
            return -1;
        }
        let (a, b) = (codes[i as usize], codes[j as usize]);
        if a == b {
            32 + ((i ^ j) as u32).leading_zeros() as i64
        } else {
            (a ^ b).leading_zeros() as i64
        }
    };
    (0..n - 1)
        .map(|i| {
            let d = if delta(i, i + 1) - delta(i, i - 1) >= 0 {
                1
            } else {
                -1
            };
            let delta_min = delta(i, i - d);
            let mut l_max = 2;
            while delta(i, i + l_max * d) > delta_min {
                l_max *= 2;
            }
            let mut l = 0;
            let mut t = l_max / 2;
            while t >= 1 {
                if delta(i, i + (l + t) * d) > delta_min {
                    l += t;
                }
                t /= 2;
            }
            let j = i + l * d;
            let delta_node = delta(i, j);
            let (mut s, mut step) = (0, l);
            loop {
                step = (step + 1) / 2;
                if delta(i, i + (s + step) * d) > delta_node {
                    s += step;
                }
                if step <= 1 {
                    break;
                }
            }
            let gamma = i + s * d + d.min(0);
            let leaves = n - 1;
            let left = if i.min(j) == gamma {
                leaves + gamma
            } else {
                gamma
            };
            let right = if i.max(j) == gamma + 1 {
                leaves + gamma + 1
            } else {
                gamma + 1
            };
            (left as u32, right as u32)
        })
        .collect()
}
