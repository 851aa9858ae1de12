//! A high-quality BVH for scenes that do not move (issue 72): built once on the host by
//! `obvhs` (PLOC, then reinsertion to lower its SAH cost) over the very proxy boxes the GPU
//! build makes (`glsl/bvh_proxies.comp`, read back), and laid out as the GPU's tree
//! ([`super::bvh::GpuBvhNode`]: inner nodes `[0, n - 1)` with node 0 the root, then the `n`
//! leaves, one Gaussian each). The tracer's frames then walk it where it lies (no LBVH
//! buffers, no pass) instead of building an LBVH each frame; the traversal is the same code. The leaves' boxes are the GPU's own floats and
//! every inner box the exact union of its children's, so a ray meets the same leaves; it may
//! find them in another order (and find some again in another pass), but its buffer keeps the
//! nearest hits whatever the order, so it composites the same hits in the same order: the
//! image is the LBVH's, bit for bit.

use std::time::Instant;

use obvhs::aabb::Aabb;
use obvhs::bvh2::builder::build_bvh2;
use obvhs::BvhBuildParams;

use super::bvh::{GpuBvhNode, BVH_CHILD_MASK};

/// What a still BVH's build did.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct StillBvhStats {
    /// Milliseconds of the host build (obvhs and the layout), without the proxies' readback.
    pub build_ms: f64,
    /// The tree's SAH cost ([`sah_cost`]).
    pub sah: f64,
    /// The SAH cost of the LBVH the GPU builds over the same boxes, for comparison (0 where
    /// not measured: [`still_tree`] alone does not build it).
    pub lbvh_sah: f64,
    /// The tree's depth ([`depth`]).
    pub depth: u32,
    /// Gaussians without a proxy (empty boxes), kept as leaves no ray meets.
    pub empty: u32,
}

/// The GPU layout of a still BVH over `boxes` (a proxy box per Gaussian; empty where
/// `lo > hi`), and how its build went.
pub fn still_tree(boxes: &[GpuBvhNode]) -> (Vec<GpuBvhNode>, StillBvhStats) {
    let start = Instant::now();
    let n = boxes.len();
    let (full, empty): (Vec<u32>, Vec<u32>) =
        (0..n as u32).partition(|&g| !boxes[g as usize].is_empty());
    let mut out = Layout {
        nodes: vec![GpuBvhNode::default(); (2 * n).saturating_sub(1)],
        boxes,
        next_inner: 0,
        next_leaf: n.saturating_sub(1) as u32,
    };
    if n > 0 {
        // The root: the tree over the non-empty boxes, beside a subtree of the empty ones.
        match (full.is_empty(), empty.is_empty()) {
            (false, true) => {
                out.obvhs_subtree(&full);
            }
            (true, false) => {
                out.empty_subtree(&empty);
            }
            _ => {
                let root = out.inner();
                let left = out.obvhs_subtree(&full);
                let right = out.empty_subtree(&empty);
                out.join(root, left, right);
            }
        }
    }
    debug_assert_eq!(out.next_inner as usize, n.saturating_sub(1));
    let nodes = out.nodes;
    let stats = StillBvhStats {
        build_ms: start.elapsed().as_secs_f64() * 1e3,
        sah: sah_cost(&nodes),
        empty: empty.len() as u32,
        depth: depth(&nodes),
        lbvh_sah: 0.0,
    };
    (nodes, stats)
}

/// The SAH cost of a tree in the GPU layout: the sum over its nodes of their boxes' surface
/// areas over the root's (a node visit and a leaf's hit test each costing 1), what a random
/// ray that meets the root is expected to pay.
pub fn sah_cost(nodes: &[GpuBvhNode]) -> f64 {
    let area = |b: &GpuBvhNode| -> f64 {
        if b.is_empty() {
            return 0.0;
        }
        let e: Vec<f64> = (0..3).map(|k| (b.hi[k] - b.lo[k]) as f64).collect();
        2.0 * (e[0] * e[1] + e[1] * e[2] + e[2] * e[0])
    };
    let root = nodes.first().map_or(0.0, area);
    if root <= 0.0 {
        return 0.0;
    }
    nodes.iter().map(area).sum::<f64>() / root
}

/// The tree being laid out: inner nodes taken in order from 0, leaves from `n - 1`.
struct Layout<'a> {
    nodes: Vec<GpuBvhNode>,
    boxes: &'a [GpuBvhNode],
    next_inner: u32,
    next_leaf: u32,
}

impl Layout<'_> {
    /// A new inner node's index (its contents set by [`Layout::join`]).
    fn inner(&mut self) -> u32 {
        self.next_inner += 1;
        self.next_inner - 1
    }

    /// A new leaf holding Gaussian `g`, its box the proxy's own floats.
    fn leaf(&mut self, g: u32) -> u32 {
        let at = self.next_leaf;
        self.next_leaf += 1;
        let b = self.boxes[g as usize];
        self.nodes[at as usize] = GpuBvhNode {
            lo: b.lo,
            left: g,
            hi: b.hi,
            right: 0,
        };
        at
    }

    /// Makes `node` the parent of `a` and `b`: their boxes' union, and the axis on which the
    /// left child's centre lies below the right one's, farthest apart (the children swapped
    /// to make it so), which the traversal visits in the ray's direction. An axis on which
    /// an empty box takes part is none (3).
    fn join(&mut self, node: u32, a: u32, b: u32) {
        let (na, nb) = (self.nodes[a as usize], self.nodes[b as usize]);
        let (mut left, mut right) = (a, b);
        let mut axis = 3u32;
        if !na.is_empty() && !nb.is_empty() {
            let centre = |n: &GpuBvhNode, k: usize| 0.5 * (n.lo[k] + n.hi[k]);
            let k = (0..3)
                .max_by(|&i, &j| {
                    let di = (centre(&na, i) - centre(&nb, i)).abs();
                    let dj = (centre(&na, j) - centre(&nb, j)).abs();
                    di.total_cmp(&dj)
                })
                .unwrap();
            if centre(&na, k) > centre(&nb, k) {
                (left, right) = (b, a);
            }
            axis = k as u32;
        }
        let union = |f: fn(f32, f32) -> f32, x: [f32; 3], y: [f32; 3]| {
            [f(x[0], y[0]), f(x[1], y[1]), f(x[2], y[2])]
        };
        let (lo, hi) = match (na.is_empty(), nb.is_empty()) {
            (true, true) => (na.lo, na.hi),
            (true, false) => (nb.lo, nb.hi),
            (false, true) => (na.lo, na.hi),
            (false, false) => (union(f32::min, na.lo, nb.lo), union(f32::max, na.hi, nb.hi)),
        };
        debug_assert!(right <= BVH_CHILD_MASK);
        self.nodes[node as usize] = GpuBvhNode {
            lo,
            left,
            hi,
            right: right | (axis << 30),
        };
    }

    /// The subtree over `gaussians` (non-empty boxes) that obvhs builds; its root's index.
    fn obvhs_subtree(&mut self, gaussians: &[u32]) -> u32 {
        if let [g] = gaussians {
            return self.leaf(*g);
        }
        let aabbs: Vec<Aabb> = gaussians
            .iter()
            .map(|&g| {
                let b = self.boxes[g as usize];
                // obvhs's Aabb is two 16-byte vectors (x, y, z and a pad), plain old data.
                bytemuck::cast([
                    b.lo[0], b.lo[1], b.lo[2], 0.0, b.hi[0], b.hi[1], b.hi[2], 0.0,
                ])
            })
            .collect();
        let params = BvhBuildParams {
            max_prims_per_leaf: 1,
            ..BvhBuildParams::slow_build()
        };
        let bvh = build_bvh2(&aabbs, params, &mut Default::default());
        let place = |layout: &mut Self, i: usize| -> u32 {
            let node = &bvh.nodes[i];
            if node.is_leaf() {
                assert_eq!(node.prim_count, 1, "obvhs left several Gaussians in a leaf");
                let k = bvh.primitive_indices[node.first_index as usize];
                layout.leaf(gaussians[k as usize])
            } else {
                layout.inner()
            }
        };
        // Depth first from obvhs's root (node 0); a parent's join is listed before its
        // children's, so the list run backwards joins children first.
        let root = place(self, 0);
        let mut joins = Vec::new();
        let mut stack = vec![(0usize, root)];
        while let Some((src, dst)) = stack.pop() {
            let node = bvh.nodes[src];
            if node.is_leaf() {
                continue;
            }
            let a = node.first_index as usize;
            let (pa, pb) = (place(self, a), place(self, a + 1));
            joins.push((dst, pa, pb));
            stack.push((a + 1, pb));
            stack.push((a, pa));
        }
        for (node, a, b) in joins.into_iter().rev() {
            self.join(node, a, b);
        }
        root
    }

    /// A balanced subtree over `gaussians` (empty boxes, which no ray meets); its root.
    fn empty_subtree(&mut self, gaussians: &[u32]) -> u32 {
        if let [g] = gaussians {
            return self.leaf(*g);
        }
        let node = self.inner();
        let (l, r) = gaussians.split_at(gaussians.len() / 2);
        let a = self.empty_subtree(l);
        let b = self.empty_subtree(r);
        self.join(node, a, b);
        node
    }
}

/// The depth of a tree in the GPU layout (a lone leaf: 0): the traversal's stack holds at
/// most that many entries.
pub fn depth(nodes: &[GpuBvhNode]) -> u32 {
    let leaves = nodes.len().div_ceil(2).saturating_sub(1) as u32;
    let mut most = 0;
    let mut stack = vec![(0u32, 0u32)];
    while let Some((node, d)) = stack.pop() {
        most = most.max(d);
        if node < leaves {
            let (a, b) = nodes[node as usize].children();
            stack.push((a, d + 1));
            stack.push((b, d + 1));
        }
    }
    most
}
