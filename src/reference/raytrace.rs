//! The CPU reference ray tracer (SPEC section 7), the oracle of the GPU tracer: every pixel's
//! ray (section 2) against the Gaussians through a BVH, their hits composited front to back.
//!
//! Stage by stage, as the GPU tracer is built: [`proxy_bounds`] (each Gaussian's box: a flat
//! one's octagon, a volumetric one's `q <= 2 ln(255 o)` ellipsoid), a BVH over the boxes
//! ([`Bvh`], a plain median split here; the GPU builds an LBVH), then section 7's hit model
//! ([`super::ray_hits`]: [`gaussian_hit`], [`super::ray_hits::clip_weight`], and
//! [`composite`] over the hits in ascending `(t, index)`). Geometry is in f64; colours and
//! alphas round to f32 as the rasterizer's reference does.

use glam::{DMat3, DVec3, Vec3};

use super::rasterize::pixel_ray;
use super::ray_hits::{
    composite, gaussian_hit, not_culled, proxy_q_max, render_rows, RayComposite,
};
use super::Rgba8Image;
use crate::camera::Camera;
use crate::mesh::{octagon_radius, FlatFrame};
use crate::options::RayTraceOptions;
use crate::options::RenderOptions;
use crate::scene::{flat_axis, Scene};

/// What a frame's rays did.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct TraceStats {
    /// Rays traced.
    pub rays: usize,
    /// Hits found over all rays (before compositing stops a ray).
    pub hits: u64,
    /// Hits composited (or skipped for alpha) before each ray stopped.
    pub hits_walked: u64,
    /// Rays that reached [`RayTraceOptions::max_hits`] with hits left and light left.
    pub capped: usize,
}

/// An axis-aligned box.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Aabb {
    /// Lower corner.
    pub lo: DVec3,
    /// Upper corner.
    pub hi: DVec3,
}

impl Aabb {
    /// Where the ray `e + t d` (t > 0) is inside the box: `(t_in, t_out)`, or `None`.
    pub fn ray_range(&self, e: DVec3, inv_d: DVec3) -> Option<(f64, f64)> {
        let a = (self.lo - e) * inv_d;
        let b = (self.hi - e) * inv_d;
        let t_in = a.min(b).max_element().max(0.0);
        let t_out = a.max(b).min_element();
        // NaN (0 * inf, a ray in a face's plane) counts as inside, so no hit is lost.
        (t_in.partial_cmp(&t_out) != Some(std::cmp::Ordering::Greater)).then_some((t_in, t_out))
    }

    fn union(&self, o: &Aabb) -> Aabb {
        Aabb {
            lo: self.lo.min(o.lo),
            hi: self.hi.max(o.hi),
        }
    }
}

/// The proxy box of Gaussian `i`: for a flat Gaussian its octagon's corners, for a volumetric
/// one the ellipsoid `q <= 2 ln(255 o)` (half extent `sqrt(q_max Sigma_jj)` along axis j).
/// `None` when it can never be hit (an opacity under 1/255, or no octagon).
pub fn proxy_bounds(scene: &Scene, i: usize, q: f64) -> Option<Aabb> {
    if flat_axis(scene.scales[i]).is_some() {
        let rho = octagon_radius(q, scene.opacities[i]);
        if rho <= 0.0 {
            return None;
        }
        let frame = FlatFrame::of(scene, i);
        let (mut lo, mut hi) = (DVec3::splat(f64::INFINITY), DVec3::splat(f64::NEG_INFINITY));
        for k in 0..crate::mesh::CORNERS {
            let p = frame.corner(rho, k);
            lo = lo.min(p);
            hi = hi.max(p);
        }
        return Some(Aabb { lo, hi });
    }
    let q_max = proxy_q_max(scene.opacities[i]);
    // (NaN, from a zero opacity, fails too.)
    if q_max.is_nan() || q_max <= 0.0 {
        return None;
    }
    let r = DMat3::from_quat(scene.rotations[i].as_dquat().normalize());
    let s = scene.scales[i].as_dvec3();
    // Sigma_jj = sum_k (R_jk s_k)^2.
    let ext = DVec3::new(
        (r.row(0) * s).length(),
        (r.row(1) * s).length(),
        (r.row(2) * s).length(),
    ) * q_max.sqrt();
    let mu = scene.means[i].as_dvec3();
    Some(Aabb {
        lo: mu - ext,
        hi: mu + ext,
    })
}

/// A BVH over the proxy boxes: a median split on the longest axis of the centroids' bounds,
/// four or fewer Gaussians per leaf.
pub struct Bvh {
    nodes: Vec<BvhNode>,
    /// Gaussian indices, each leaf a run of them.
    items: Vec<u32>,
}

struct BvhNode {
    bounds: Aabb,
    /// Leaf: `(first item, count)`; inner: `(left child, 0)`, the right child follows the
    /// left's subtree (stored at `right`).
    first: u32,
    count: u32,
    right: u32,
}

impl Bvh {
    /// The BVH of every Gaussian that has a proxy.
    pub fn build(scene: &Scene, q: f64) -> Bvh {
        let mut boxes = Vec::new();
        let mut items = Vec::new();
        for i in 0..scene.len() {
            if let Some(b) = proxy_bounds(scene, i, q) {
                boxes.push(b);
                items.push(i as u32);
            }
        }
        let mut order: Vec<usize> = (0..items.len()).collect();
        let mut bvh = Bvh {
            nodes: Vec::new(),
            items: Vec::new(),
        };
        if !order.is_empty() {
            bvh.split(&boxes, &items, &mut order[..]);
        }
        bvh
    }

    fn split(&mut self, boxes: &[Aabb], items: &[u32], order: &mut [usize]) -> u32 {
        let bounds = order[1..]
            .iter()
            .fold(boxes[order[0]], |acc, &k| acc.union(&boxes[k]));
        let node = self.nodes.len() as u32;
        self.nodes.push(BvhNode {
            bounds,
            first: 0,
            count: 0,
            right: 0,
        });
        if order.len() <= 4 {
            self.nodes[node as usize].first = self.items.len() as u32;
            self.nodes[node as usize].count = order.len() as u32;
            self.items.extend(order.iter().map(|&k| items[k]));
            return node;
        }
        let centre = |k: usize| 0.5 * (boxes[k].lo + boxes[k].hi);
        let (mut lo, mut hi) = (DVec3::splat(f64::INFINITY), DVec3::splat(f64::NEG_INFINITY));
        for &k in order.iter() {
            lo = lo.min(centre(k));
            hi = hi.max(centre(k));
        }
        let extent = hi - lo;
        let axis = if extent.x >= extent.y && extent.x >= extent.z {
            0
        } else if extent.y >= extent.z {
            1
        } else {
            2
        };
        let mid = order.len() / 2;
        order.select_nth_unstable_by(mid, |&a, &b| centre(a)[axis].total_cmp(&centre(b)[axis]));
        let (left, right) = order.split_at_mut(mid);
        self.split(boxes, items, left);
        let r = self.split(boxes, items, right);
        self.nodes[node as usize].right = r;
        node
    }

    /// Calls `f` with every Gaussian whose box the ray `e + t d` (t > 0) enters.
    pub fn candidates(&self, e: DVec3, d: DVec3, mut f: impl FnMut(u32)) {
        if self.nodes.is_empty() {
            return;
        }
        let inv = DVec3::ONE / d;
        let mut stack = vec![0u32];
        while let Some(n) = stack.pop() {
            let node = &self.nodes[n as usize];
            if node.bounds.ray_range(e, inv).is_none() {
                continue;
            }
            if node.count > 0 {
                let run = node.first as usize..(node.first + node.count) as usize;
                self.items[run].iter().for_each(|&i| f(i));
            } else {
                stack.push(node.right);
                stack.push(n + 1);
            }
        }
    }
}

/// What every primary ray of a frame shares.
struct Frame<'a> {
    scene: &'a Scene,
    /// `None`: test every Gaussian on every ray.
    bvh: Option<&'a Bvh>,
    /// Per Gaussian, whether primary rays may hit it.
    live: &'a [bool],
    options: &'a RenderOptions,
    rt: &'a RayTraceOptions,
    /// A depth test's view depth per pixel (SPEC section 9), with the camera's forward axis.
    depth_test: Option<(&'a [f32], DVec3)>,
    /// Per pixel what the splats composite over, instead of the options' background.
    under: Option<&'a [Vec3]>,
}

impl Frame<'_> {
    /// Traces the ray `e + t d` of pixel `pixel` and composites its hits.
    fn trace(&self, e: DVec3, d: DVec3, pixel: usize, stats: &mut TraceStats) -> Vec3 {
        let mut hits = Vec::new();
        let mut test = |i: u32| {
            if self.live[i as usize] {
                if let Some(h) = gaussian_hit(self.scene, i as usize, e, d, self.rt.q) {
                    hits.push(h);
                }
            }
        };
        match self.bvh {
            Some(b) => b.candidates(e, d, &mut test),
            None => (0..self.scene.len() as u32).for_each(&mut test),
        }
        if let Some((limits, forward)) = self.depth_test {
            // Only the hits in front of the engine's surface: view depth t (d . forward).
            let limit = limits[pixel] as f64;
            let along = d.dot(forward);
            hits.retain(|h| h.t * along < limit);
        }
        stats.rays += 1;
        stats.hits += hits.len() as u64;
        let (c, walked, capped) = composite(
            self.scene,
            &mut hits,
            e,
            d,
            &self.options.clip,
            self.under.map_or(self.options.background, |u| u[pixel]),
            self.rt.max_hits,
        );
        stats.hits_walked += walked as u64;
        stats.capped += capped as usize;
        c
    }
}

/// The view depth per pixel (rows top first) of `mode` of section 7's image of `scene` from
/// `camera` (SPEC section 9: a hit's view depth is `t (d . forward)`), one thread.
pub fn depths(
    scene: &Scene,
    camera: &Camera,
    options: &RenderOptions,
    rt: &RayTraceOptions,
    mode: crate::depth::DepthMode,
) -> Vec<f32> {
    let bvh = Bvh::build(scene, rt.q);
    let live = not_culled(scene, camera);
    let forward = camera.rotation.col(2).as_dvec3();
    let mut out = Vec::with_capacity((camera.width * camera.height) as usize);
    for j in 0..camera.height {
        for i in 0..camera.width {
            let (e, d) = pixel_ray(camera, i, j);
            let mut hits = Vec::new();
            bvh.candidates(e, d, &mut |g: u32| {
                if live[g as usize] {
                    hits.extend(gaussian_hit(scene, g as usize, e, d, rt.q));
                }
            });
            hits.sort_by(|a, b| a.t.total_cmp(&b.t).then(a.index.cmp(&b.index)));
            let mut ray = RayComposite::with_depth(forward);
            for hit in &hits {
                if !ray.take(scene, hit, e, d, &options.clip, rt.max_hits) {
                    break;
                }
            }
            out.push(ray.depth(mode));
        }
    }
    out
}

/// Ray traces `scene` from `camera` (SPEC section 7), through a BVH, the rows shared among the
/// machine's threads.
pub fn render(
    scene: &Scene,
    camera: &Camera,
    options: &RenderOptions,
    rt: &RayTraceOptions,
) -> (Rgba8Image, TraceStats) {
    render_with(scene, camera, options, rt, true, None, None)
}

/// [`render`] with a depth test (SPEC section 9): `limits` holds the engine's view depth per
/// pixel (rows top first, `f32::INFINITY` for none), and a ray composites only the hits whose
/// view depth `t (d . forward)` lies in front of it; over `under` per pixel (an engine's
/// colour) when given, else over the options' background.
pub fn render_depth_tested(
    scene: &Scene,
    camera: &Camera,
    options: &RenderOptions,
    rt: &RayTraceOptions,
    limits: &[f32],
    under: Option<&[Vec3]>,
) -> (Rgba8Image, TraceStats) {
    let pixels = (camera.width * camera.height) as usize;
    assert_eq!(limits.len(), pixels);
    assert!(under.map_or(true, |u| u.len() == pixels));
    render_with(scene, camera, options, rt, true, Some(limits), under)
}

/// [`render`] testing every Gaussian on every ray, no BVH: the brute-force check of the BVH.
pub fn render_brute_force(
    scene: &Scene,
    camera: &Camera,
    options: &RenderOptions,
    rt: &RayTraceOptions,
) -> (Rgba8Image, TraceStats) {
    render_with(scene, camera, options, rt, false, None, None)
}

fn render_with(
    scene: &Scene,
    camera: &Camera,
    options: &RenderOptions,
    rt: &RayTraceOptions,
    use_bvh: bool,
    limits: Option<&[f32]>,
    under: Option<&[Vec3]>,
) -> (Rgba8Image, TraceStats) {
    let bvh = use_bvh.then(|| Bvh::build(scene, rt.q));
    let live = not_culled(scene, camera);
    let frame = Frame {
        scene,
        bvh: bvh.as_ref(),
        live: &live,
        options,
        rt,
        depth_test: limits.map(|l| (l, camera.rotation.col(2).as_dvec3())),
        under,
    };
    render_rows(
        camera,
        |i, j, s: &mut TraceStats| {
            let (e, d) = pixel_ray(camera, i, j);
            frame.trace(e, d, (j * camera.width + i) as usize, s)
        },
        |total, s| {
            total.rays += s.rays;
            total.hits += s.hits;
            total.hits_walked += s.hits_walked;
            total.capped += s.capped;
        },
    )
}
