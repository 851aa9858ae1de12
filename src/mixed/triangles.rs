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

/// A BVH over triangles: a median split on the longest axis of the centroids' bounds,
/// [`LEAF_TRIANGLES`] or fewer per leaf, the triangles stored in leaf order.
#[derive(Clone, Debug, Default)]
pub struct MeshBvh {
    /// Nodes, the root first; a node's left child follows it.
    pub nodes: Vec<GpuMeshNode>,
    /// The triangles, in leaf order.
    pub triangles: Vec<Triangle>,
    /// Milliseconds the build took (host wall time).
    pub build_ms: f64,
}

impl MeshBvh {
    /// The BVH of `triangles`.
    pub fn build(triangles: Vec<Triangle>) -> MeshBvh {
        let start = std::time::Instant::now();
        let mut bvh = MeshBvh::default();
        if triangles.is_empty() {
            return bvh;
        }
        let mut order: Vec<usize> = (0..triangles.len()).collect();
        let mut sorted = Vec::with_capacity(triangles.len());
        bvh.split(&triangles, &mut order, &mut sorted);
        bvh.triangles = sorted;
        bvh.build_ms = start.elapsed().as_secs_f64() * 1e3;
        bvh
    }

    fn split(&mut self, tris: &[Triangle], order: &mut [usize], sorted: &mut Vec<Triangle>) -> u32 {
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
        let l = self.split(tris, left, sorted);
        let r = self.split(tris, right, sorted);
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
