//! The triangles of a mixed scene (SPEC section 8): each with its vertices, its vertex
//! normals, texture coordinates and material, a BVH over them that the CPU reference and the GPU kernels both
//! traverse (the GPU gets the same nodes, [`GpuMeshNode`]), and the watertight ray-triangle
//! test of Woop, Benthin and Wald (2013), whose GLSL twin is `glsl/mixed_common.glsl`.

use bytemuck::{Pod, Zeroable};
use glam::{DVec3, Vec2, Vec3};

/// Triangles a leaf holds at most.
pub const LEAF_TRIANGLES: usize = 4;

/// The bit of [`GpuMeshNode::a`] that marks a leaf.
pub const MESH_LEAF_BIT: u32 = 1 << 31;

/// A triangle in world space.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Triangle {
    /// Vertices, counter-clockwise seen from the front.
    pub v: [Vec3; 3],
    /// Vertex normals (the file's, turned by the mesh's transform, unit length), or the face
    /// normal three times where the file has none.
    pub n: [Vec3; 3],
    /// Texture coordinates of the vertices (zero where the file has none).
    pub uv: [Vec2; 3],
    /// Index into the scene's materials.
    pub material: u32,
}

impl Triangle {
    /// The unit face normal `(v1 - v0) x (v2 - v0)`, or zero for a degenerate triangle.
    pub fn face_normal(v: &[Vec3; 3]) -> Vec3 {
        (v[1] - v[0]).cross(v[2] - v[0]).normalize_or_zero()
    }
}

/// A node as both traversals read it (`MeshNode` in `glsl/mixed_common.glsl`): its box, and for
/// an inner node its children `(a, b)`, for a leaf `(first | MESH_LEAF_BIT, count)`.
#[repr(C)]
#[derive(Clone, Copy, Debug, Default, PartialEq, Pod, Zeroable)]
pub struct GpuMeshNode {
    /// Lower corner.
    pub lo: [f32; 3],
    /// Left child, or the first triangle with [`MESH_LEAF_BIT`].
    pub a: u32,
    /// Upper corner.
    pub hi: [f32; 3],
    /// Right child, or the triangle count.
    pub b: u32,
}

/// A triangle as the intersection test reads it, three 16-byte words (`MeshTriangle` in
/// `glsl/mixed_common.glsl`): its vertices (`w` unused). What shading needs lies apart, in
/// [`GpuShading`], so that BVH walks (and the shadow rays' triangles, which have no shading)
/// load 48 bytes a triangle.
#[repr(C)]
#[derive(Clone, Copy, Debug, Default, PartialEq, Pod, Zeroable)]
pub struct GpuTriangle {
    /// Vertex 0.
    pub v0: [f32; 4],
    /// Vertex 1.
    pub v1: [f32; 4],
    /// Vertex 2.
    pub v2: [f32; 4],
}

/// What a hit on a triangle is shaded with, four 16-byte words (`MeshShading` in
/// `glsl/mixed_common.glsl`): the vertex normals with `u0, v0, u1` in their `w`, then `u2,
/// v2`, the material's index (its bits) and a word unused.
#[repr(C)]
#[derive(Clone, Copy, Debug, Default, PartialEq, Pod, Zeroable)]
pub struct GpuShading {
    /// Normal 0 and `u0`.
    pub n0: [f32; 4],
    /// Normal 1 and `v0`.
    pub n1: [f32; 4],
    /// Normal 2 and `u1`.
    pub n2: [f32; 4],
    /// `v1`, `u2`, `v2`, the material index's bits.
    pub rest: [f32; 4],
}

impl Triangle {
    /// Its intersection words.
    pub fn gpu(&self) -> GpuTriangle {
        let v = |k: usize| [self.v[k].x, self.v[k].y, self.v[k].z, 0.0];
        GpuTriangle {
            v0: v(0),
            v1: v(1),
            v2: v(2),
        }
    }

    /// Its shading words.
    pub fn gpu_shading(&self) -> GpuShading {
        let n = |k: usize, w: f32| [self.n[k].x, self.n[k].y, self.n[k].z, w];
        let uv = self.uv;
        GpuShading {
            n0: n(0, uv[0].x),
            n1: n(1, uv[0].y),
            n2: n(2, uv[1].x),
            rest: [uv[1].y, uv[2].x, uv[2].y, f32::from_bits(self.material)],
        }
    }
}

/// A ray's hit on a triangle: its parameter and the barycentric weights of its vertices.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct TriangleHit {
    /// Ray parameter.
    pub t: f64,
    /// The triangle (its index in [`MeshBvh::triangles`]).
    pub triangle: u32,
    /// Weights of vertices 0, 1, 2 (summing to 1).
    pub bary: DVec3,
}

/// The axis of the largest component, the first one on a tie (the kernels' rule).
pub fn largest_axis(v: [f64; 3]) -> usize {
    if v[0] >= v[1] && v[0] >= v[2] {
        0
    } else if v[1] >= v[2] {
        1
    } else {
        2
    }
}

/// Woop, Benthin and Wald's watertight test of the ray `o + t d` against triangle `v`: `(t,
/// barycentrics)` with `t` in `(t_lo, t_hi)`, or `None`. A ray through an edge or a vertex
/// shared by two triangles hits at least one of them (no crack), because every edge function
/// is evaluated in the same sheared frame with the same operands by both triangles. (The
/// paper's fallback to double precision for an edge function of exactly 0 is not needed here:
/// this twin of the kernel runs in f64, the kernel's f32 version counts 0 as inside.)
pub fn intersect(o: DVec3, d: DVec3, v: &[Vec3; 3], t_lo: f64, t_hi: f64) -> Option<(f64, DVec3)> {
    let kz = largest_axis(d.abs().to_array());
    let mut kx = (kz + 1) % 3;
    let mut ky = (kx + 1) % 3;
    if d[kz] < 0.0 {
        std::mem::swap(&mut kx, &mut ky);
    }
    let sx = d[kx] / d[kz];
    let sy = d[ky] / d[kz];
    let sz = 1.0 / d[kz];
    let a = v[0].as_dvec3() - o;
    let b = v[1].as_dvec3() - o;
    let c = v[2].as_dvec3() - o;
    let (ax, ay) = (a[kx] - sx * a[kz], a[ky] - sy * a[kz]);
    let (bx, by) = (b[kx] - sx * b[kz], b[ky] - sy * b[kz]);
    let (cx, cy) = (c[kx] - sx * c[kz], c[ky] - sy * c[kz]);
    let u = cx * by - cy * bx;
    let w_v = ax * cy - ay * cx;
    let w = bx * ay - by * ax;
    if (u < 0.0 || w_v < 0.0 || w < 0.0) && (u > 0.0 || w_v > 0.0 || w > 0.0) {
        return None;
    }
    let det = u + w_v + w;
    if det == 0.0 {
        return None;
    }
    let t = (u * sz * a[kz] + w_v * sz * b[kz] + w * sz * c[kz]) / det;
    if !(t > t_lo && t < t_hi) {
        return None;
    }
    Some((t, DVec3::new(u, w_v, w) / det))
}

/// `1 / d` with no infinite component, as the kernels form it (`0 * inf` in a slab test would
/// be NaN): a zero component becomes `1e-20`.
pub fn safe_inverse(d: DVec3) -> DVec3 {
    let f = |x: f64| {
        if x == 0.0 {
            1e20
        } else {
            1.0 / (x.signum() * x.abs().max(1e-20))
        }
    };
    DVec3::new(f(d.x), f(d.y), f(d.z))
}

/// Where the ray `o + t d` is inside the box `(lo, hi)`, with the slack of the kernels'
/// slab test (`1e-4 (1 + |t_out|)`, so that a grazing ray does not lose a triangle to
/// rounding): `(t_in, t_out)` or `None`.
pub fn box_range(lo: &[f32; 3], hi: &[f32; 3], o: DVec3, inv_d: DVec3) -> Option<(f64, f64)> {
    let a = (DVec3::from_array(lo.map(f64::from)) - o) * inv_d;
    let b = (DVec3::from_array(hi.map(f64::from)) - o) * inv_d;
    let t_in = a.min(b).max_element();
    let t_out = a.max(b).min_element();
    let slack = 1e-4 * (1.0 + t_out.abs());
    (t_in <= t_out + slack).then_some((t_in - slack, t_out + slack))
}

/// A BVH over triangles, [`LEAF_TRIANGLES`] or fewer per leaf, the triangles stored in leaf
/// order: `obvhs`'s (PLOC, then reinsertion to lower its SAH cost), its subtrees that end
/// deeper than the kernels' traversal stack holds ([`MAX_MESH_DEPTH`]) split again by the
/// median on the longest axis of the centroids' bounds (whose depth is `log2(n / 4)`), and
/// the median split of everything where even that is too deep.
#[derive(Clone, Debug, Default)]
pub struct MeshBvh {
    /// Nodes, the root first.
    pub nodes: Vec<GpuMeshNode>,
    /// The triangles, in leaf order.
    pub triangles: Vec<Triangle>,
    /// Milliseconds the build took (host wall time).
    pub build_ms: f64,
    /// The tree's depth (a lone leaf: 0).
    pub depth: u32,
    /// Whether the median split was built for all of it (obvhs's tree was too deep even with
    /// its deep subtrees split again).
    pub median_split: bool,
    /// Triangles of obvhs's subtrees that ended too deep, split again by the median.
    pub median_triangles: usize,
}

/// The deepest tree the kernels' traversal walks whole: with a stack of `MIXED_MESH_STACK`
/// entries, a node at depth `d` finds at most `d` entries on it and pushes two.
pub const MAX_MESH_DEPTH: u32 = crate::constants::MIXED_MESH_STACK - 1;

impl MeshBvh {
    /// The BVH of `triangles`.
    pub fn build(triangles: Vec<Triangle>) -> MeshBvh {
        let start = std::time::Instant::now();
        if triangles.is_empty() {
            return MeshBvh::default();
        }
        let mut bvh = MeshBvh::from_obvhs(&triangles);
        if bvh.depth > MAX_MESH_DEPTH {
            bvh = MeshBvh::median(triangles);
        }
        bvh.build_ms = start.elapsed().as_secs_f64() * 1e3;
        bvh
    }

    /// The median-split BVH of `triangles` (non-empty).
    pub fn median(triangles: Vec<Triangle>) -> MeshBvh {
        let mut bvh = MeshBvh {
            median_split: true,
            median_triangles: triangles.len(),
            ..MeshBvh::default()
        };
        let mut order: Vec<usize> = (0..triangles.len()).collect();
        let mut sorted = Vec::with_capacity(triangles.len());
        bvh.split(&triangles, &mut order, &mut sorted, 0);
        bvh.triangles = sorted;
        bvh
    }

    /// obvhs's BVH of `triangles` (non-empty) in the kernels' layout.
    fn from_obvhs(triangles: &[Triangle]) -> MeshBvh {
        use obvhs::aabb::Aabb;
        let aabbs: Vec<Aabb> = triangles
            .iter()
            .map(|t| {
                let lo = t.v[0].min(t.v[1]).min(t.v[2]);
                let hi = t.v[0].max(t.v[1]).max(t.v[2]);
                // obvhs's Aabb is two 16-byte vectors (x, y, z and a pad), plain old data.
                bytemuck::cast([lo.x, lo.y, lo.z, 0.0, hi.x, hi.y, hi.z, 0.0])
            })
            .collect();
        let params = obvhs::BvhBuildParams {
            // No pre-splitting: each triangle in one leaf, stored once.
            pre_split: false,
            max_prims_per_leaf: LEAF_TRIANGLES as u32,
            ..obvhs::BvhBuildParams::medium_build()
        };
        let tree = obvhs::bvh2::builder::build_bvh2(&aabbs, params, &mut Default::default());
        // Each obvhs node's height (a leaf: 0) and triangles, children before parents.
        let mut height = vec![0u32; tree.nodes.len()];
        let mut count = vec![0usize; tree.nodes.len()];
        let mut order = vec![(0usize, false)];
        while let Some((i, done)) = order.pop() {
            let node = &tree.nodes[i];
            if node.is_leaf() {
                count[i] = node.prim_count as usize;
                continue;
            }
            let a = node.first_index as usize;
            if done {
                height[i] = 1 + height[a].max(height[a + 1]);
                count[i] = count[a] + count[a + 1];
            } else {
                order.push((i, true));
                order.push((a, false));
                order.push((a + 1, false));
            }
        }
        let mut bvh = MeshBvh {
            nodes: Vec::with_capacity(tree.nodes.len()),
            ..MeshBvh::default()
        };
        let mut sorted = Vec::with_capacity(triangles.len());
        // The height of the median split of m triangles.
        let median_height = |m: usize| m.div_ceil(LEAF_TRIANGLES).next_power_of_two().ilog2();
        // Depth first from obvhs's root (node 0): each node's slot taken when it is reached,
        // its children filled in when they are. Where a subtree would end deeper than the
        // traversal's stack holds (PLOC chains slivers: a UV sphere's poles took obvhs's tree
        // of 2M triangles 63 deep), its nodes are kept as long as their children could still
        // be split by the median in time, and the node below which they could not is.
        let mut stack = vec![(0usize, u32::MAX, false, 0u32)];
        while let Some((src, parent, right, depth)) = stack.pop() {
            let node = &tree.nodes[src];
            let too_deep = depth + height[src] > MAX_MESH_DEPTH && {
                let a = node.first_index as usize;
                node.is_leaf()
                    || [a, a + 1]
                        .iter()
                        .any(|&c| depth + 1 + median_height(count[c]) > MAX_MESH_DEPTH)
            };
            let at = if too_deep {
                let mut prims = Vec::new();
                let mut under = vec![src];
                while let Some(i) = under.pop() {
                    let n = &tree.nodes[i];
                    if n.is_leaf() {
                        let first = n.first_index as usize;
                        prims.extend(
                            tree.primitive_indices[first..first + n.prim_count as usize]
                                .iter()
                                .map(|&k| k as usize),
                        );
                    } else {
                        under.push(n.first_index as usize + 1);
                        under.push(n.first_index as usize);
                    }
                }
                bvh.median_triangles += prims.len();
                bvh.split(triangles, &mut prims, &mut sorted, depth)
            } else {
                let at = bvh.nodes.len() as u32;
                bvh.depth = bvh.depth.max(depth);
                let (lo, hi) = (node.aabb.min, node.aabb.max);
                let mut out = GpuMeshNode {
                    lo: [lo.x, lo.y, lo.z],
                    a: 0,
                    hi: [hi.x, hi.y, hi.z],
                    b: 0,
                };
                if node.is_leaf() {
                    let first = node.first_index as usize;
                    out.a = sorted.len() as u32 | MESH_LEAF_BIT;
                    out.b = node.prim_count;
                    for &k in &tree.primitive_indices[first..first + node.prim_count as usize] {
                        sorted.push(triangles[k as usize]);
                    }
                } else {
                    let a = node.first_index as usize;
                    stack.push((a + 1, at, true, depth + 1));
                    stack.push((a, at, false, depth + 1));
                }
                bvh.nodes.push(out);
                at
            };
            if parent != u32::MAX {
                let p = &mut bvh.nodes[parent as usize];
                if right {
                    p.b = at;
                } else {
                    p.a = at;
                }
            }
        }
        bvh.triangles = sorted;
        debug_assert_eq!(bvh.triangles.len(), triangles.len());
        bvh
    }

    fn split(
        &mut self,
        tris: &[Triangle],
        order: &mut [usize],
        sorted: &mut Vec<Triangle>,
        depth: u32,
    ) -> u32 {
        self.depth = self.depth.max(depth);
        let (mut lo, mut hi) = (Vec3::splat(f32::INFINITY), Vec3::splat(f32::NEG_INFINITY));
        for &k in order.iter() {
            for v in tris[k].v {
                lo = lo.min(v);
                hi = hi.max(v);
            }
        }
        let node = self.nodes.len() as u32;
        self.nodes.push(GpuMeshNode {
            lo: lo.to_array(),
            a: 0,
            hi: hi.to_array(),
            b: 0,
        });
        if order.len() <= LEAF_TRIANGLES {
            self.nodes[node as usize].a = sorted.len() as u32 | MESH_LEAF_BIT;
            self.nodes[node as usize].b = order.len() as u32;
            sorted.extend(order.iter().map(|&k| tris[k]));
            return node;
        }
        let centre = |k: usize| (tris[k].v[0] + tris[k].v[1] + tris[k].v[2]) / 3.0;
        let (mut clo, mut chi) = (Vec3::splat(f32::INFINITY), Vec3::splat(f32::NEG_INFINITY));
        for &k in order.iter() {
            clo = clo.min(centre(k));
            chi = chi.max(centre(k));
        }
        let axis = largest_axis((chi - clo).as_dvec3().to_array());
        let mid = order.len() / 2;
        order.select_nth_unstable_by(mid, |&a, &b| centre(a)[axis].total_cmp(&centre(b)[axis]));
        let (left, right) = order.split_at_mut(mid);
        let l = self.split(tris, left, sorted, depth + 1);
        let r = self.split(tris, right, sorted, depth + 1);
        self.nodes[node as usize].a = l;
        self.nodes[node as usize].b = r;
        node
    }

    /// The nearest hit of the ray `o + t d` with `t` in `(t_lo, t_hi)` (ties: the lower
    /// triangle index), or, with `any`, the first one found.
    pub fn hit(&self, o: DVec3, d: DVec3, t_lo: f64, t_hi: f64, any: bool) -> Option<TriangleHit> {
        if self.nodes.is_empty() {
            return None;
        }
        let inv = safe_inverse(d);
        let mut best: Option<TriangleHit> = None;
        let mut stack = vec![0u32];
        while let Some(n) = stack.pop() {
            let node = &self.nodes[n as usize];
            let limit = best.map_or(t_hi, |b| b.t);
            match box_range(&node.lo, &node.hi, o, inv) {
                Some((t_in, t_out)) if t_out > t_lo && t_in < limit => {}
                _ => continue,
            }
            if node.a & MESH_LEAF_BIT != 0 {
                let first = node.a & !MESH_LEAF_BIT;
                for k in first..first + node.b {
                    let limit = best.map_or(t_hi, |b| b.t);
                    // At an equal t the lower index wins: accept a tie only from a lower one.
                    let tri = &self.triangles[k as usize];
                    if let Some((t, bary)) = intersect(o, d, &tri.v, t_lo, t_hi) {
                        let better = match best {
                            None => true,
                            Some(b) => t < limit || (t == b.t && k < b.triangle),
                        };
                        if better {
                            best = Some(TriangleHit {
                                t,
                                triangle: k,
                                bary,
                            });
                            if any {
                                return best;
                            }
                        }
                    }
                }
            } else {
                stack.push(node.b);
                stack.push(node.a);
            }
        }
        best
    }

    /// The texture coordinates at a hit: the vertices' weighted by its barycentrics (in f32,
    /// as the kernel forms them).
    pub fn uv(&self, hit: &TriangleHit) -> Vec2 {
        let uv = self.triangles[hit.triangle as usize].uv;
        let b = hit.bary.as_vec3();
        uv[0] * b.x + uv[1] * b.y + uv[2] * b.z
    }

    /// The shading normal at a hit: the vertex normals weighted by its barycentrics,
    /// normalised (the face normal where they cancel).
    pub fn normal(&self, hit: &TriangleHit) -> DVec3 {
        let tri = &self.triangles[hit.triangle as usize];
        let n = tri.n[0].as_dvec3() * hit.bary.x
            + tri.n[1].as_dvec3() * hit.bary.y
            + tri.n[2].as_dvec3() * hit.bary.z;
        let len = n.length();
        if len > 1e-12 {
            n / len
        } else {
            Triangle::face_normal(&tri.v).as_dvec3()
        }
    }
}
