//! The CPU reference ray tracer (SPEC section 7), the oracle of the GPU tracer: every pixel's
//! ray (section 2) against the Gaussians, their hits composited front to back.
//!
//! Stage by stage, as the GPU tracer is built: [`proxy_bounds`] (each Gaussian's box: a flat
//! one's octagon, a volumetric one's `q <= 2 ln(255 o)` ellipsoid), a BVH over the boxes
//! ([`Bvh`], a plain median split here; the GPU builds an LBVH), [`gaussian_hit`] (the octagon
//! crossing, or 3DGRT's maximum response), [`clip_weight`], and [`composite`] over the hits in
//! ascending `(t, index)`. Geometry is in f64; colours and alphas round to f32 as the
//! rasterizer's reference does.

use glam::{DMat3, DVec3, Vec3};

use super::rasterize::pixel_ray;
use super::Rgba8Image;
use crate::camera::Camera;
use crate::clip::{Classification, Clip, ClipMode, ClipRegion, CutoffRay, FLAT_PARALLEL_EPSILON};
use crate::mesh::{octagon_radius, FlatFrame, DEFAULT_Q};
use crate::options::RenderOptions;
use crate::scene::{flat_axis, Scene};
use crate::sh::eval_sh;

/// Hits composited per ray at most (REdiSplats' default); a ray that needed more is counted.
pub const DEFAULT_MAX_HITS: usize = 512;

/// Settings of the ray tracer.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct RayTraceOptions {
    /// `Q` of the flat Gaussians' octagons (SPEC section 6).
    pub q: f64,
    /// Hits composited per ray at most.
    pub max_hits: usize,
}

impl Default for RayTraceOptions {
    fn default() -> Self {
        RayTraceOptions {
            q: DEFAULT_Q,
            max_hits: DEFAULT_MAX_HITS,
        }
    }
}

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

/// `q_max = 2 ln(255 o)`, the volumetric proxy's bound (SPEC section 7): past it a Gaussian
/// of opacity `o` has alpha under 1/255. Not positive (or NaN) when it can never be hit.
pub fn proxy_q_max(opacity: f32) -> f64 {
    2.0 * (255.0 * opacity as f64).ln()
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

/// A Gaussian's hit on a ray: its parameter and its alpha before clipping.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Hit {
    /// `t_g > 0`.
    pub t: f64,
    /// The Gaussian's index.
    pub index: u32,
    /// `alpha_g` (before the clip weight).
    pub alpha: f64,
}

/// Gaussian `i`'s hit on the ray `e + t d` (unit `d`), SPEC section 7: a flat Gaussian where
/// the ray crosses its plane inside its octagon (the polygon), alpha `o exp(-(a^2+b^2)/2)`
/// there; a volumetric one at its maximum response `t* = -B/(2A)`, when
/// `q = Cq - B^2/(4A) <= 2 ln(255 o)`, alpha `o exp(-q/2)`; alphas capped at 0.99; `t > 0`.
pub fn gaussian_hit(scene: &Scene, i: usize, e: DVec3, d: DVec3, q: f64) -> Option<Hit> {
    let o = scene.opacities[i] as f64;
    let mu = scene.means[i].as_dvec3();
    if flat_axis(scene.scales[i]).is_some() {
        let frame = FlatFrame::of(scene, i);
        let nd = frame.normal.dot(d);
        if nd.abs() < FLAT_PARALLEL_EPSILON {
            return None;
        }
        let t = frame.normal.dot(mu - e) / nd;
        let rho = octagon_radius(q, scene.opacities[i]);
        if t.is_nan() || t <= 0.0 || rho <= 0.0 {
            return None;
        }
        let (a, b) = frame.in_plane(e + t * d);
        // Inside the regular octagon of circumradius rho with corners at angles 2 pi k / 8:
        // within its apothem rho cos(pi/8) of the centre along every edge's normal, at
        // angles (2k + 1) pi / 8.
        let apothem = rho * (std::f64::consts::PI / 8.0).cos();
        let inside = (0..8).all(|k| {
            let phi = (2 * k + 1) as f64 * std::f64::consts::PI / 8.0;
            a * phi.cos() + b * phi.sin() <= apothem
        });
        if !inside {
            return None;
        }
        let alpha = (o * (-(a * a + b * b) / 2.0).exp()).min(0.99);
        return Some(Hit {
            t,
            index: i as u32,
            alpha,
        });
    }
    let r = DMat3::from_quat(scene.rotations[i].as_dquat().normalize());
    let s = scene.scales[i].as_dvec3();
    // M = S^-1 R^T: A = |M d|^2, B = 2 (M d).(M (e - mu)), Cq = |M (e - mu)|^2.
    let m = DMat3::from_cols(r.x_axis / s.x, r.y_axis / s.y, r.z_axis / s.z).transpose();
    let md = m * d;
    let mo = m * (e - mu);
    let a = md.length_squared();
    let b = 2.0 * md.dot(mo);
    let cq = mo.length_squared();
    let t = -b / (2.0 * a);
    let q_ray = (cq - b * b / (4.0 * a)).max(0.0);
    let q_max = proxy_q_max(scene.opacities[i]);
    if t.is_nan() || t <= 0.0 || q_ray.is_nan() || q_ray > q_max {
        return None;
    }
    Some(Hit {
        t,
        index: i as u32,
        alpha: (o * (-q_ray / 2.0).exp()).min(0.99),
    })
}

/// The clip weight of a hit (SPEC section 7): `hard` keeps a Gaussian whose centre is visible;
/// `rara` gives a flat Gaussian 1 where its crossing point is visible and 0 elsewhere (no band,
/// no classification), and a volumetric one section 5's classification and, when cutoff, its
/// weight on this ray. 1 without clipping.
pub fn clip_weight(scene: &Scene, hit: &Hit, e: DVec3, d: DVec3, clip: &Clip) -> f64 {
    let Some(region) = &clip.region else {
        return 1.0;
    };
    let i = hit.index as usize;
    match clip.effective_mode() {
        ClipMode::None => 1.0,
        ClipMode::Hard => {
            if region.signed_distance(scene.means[i]) >= 0.0 {
                1.0
            } else {
                0.0
            }
        }
        ClipMode::Rara => {
            if flat_axis(scene.scales[i]).is_some() {
                return if visible(region, e + hit.t * d) {
                    1.0
                } else {
                    0.0
                };
            }
            match clip.classify(scene.means[i], scene.scales[i]) {
                Classification::Dropped => 0.0,
                Classification::Drawn => 1.0,
                Classification::Cutoff => {
                    let ray = CutoffRay::new(
                        scene.means[i],
                        scene.scales[i],
                        scene.rotations[i],
                        e.as_vec3(),
                    );
                    let spans = region.ray_intervals(e, d);
                    ray.weight(d, &spans, clip.weight, clip.band as f64)
                }
            }
        }
    }
}

/// Whether point `p` is in the visible set: on the ray through it, `t = 0` is visible (the
/// same interval arithmetic as the weights, so the boundary rounds the same way).
fn visible(region: &ClipRegion, p: DVec3) -> bool {
    region.ray_intervals(p, DVec3::Z).contains(0.0)
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

/// Composites the hits of one ray (sorted here by `(t, index)`) by SPEC section 4's rule:
/// skip `alpha w < 1/255`, stop before `T_next < 1e-4`, at most `max_hits` walked. Returns the
/// colour, the transmittance, the hits walked and whether the cap cut the ray short.
pub fn composite(
    scene: &Scene,
    hits: &mut [Hit],
    e: DVec3,
    d: DVec3,
    clip: &Clip,
    background: Vec3,
    max_hits: usize,
) -> (Vec3, usize, bool) {
    hits.sort_by(|a, b| a.t.total_cmp(&b.t).then(a.index.cmp(&b.index)));
    let mut ray = RayComposite::default();
    for hit in hits.iter() {
        if !ray.take(scene, hit, e, d, clip, max_hits) {
            break;
        }
    }
    ray.finish(background)
}

/// One ray's compositing, hit by hit in `(t, index)` order (SPEC section 4's rule as section 7
/// applies it): what [`composite`] and the tiled tracer of section 11
/// ([`super::tiled`]) share, so that the two agree to the bit.
#[derive(Clone, Copy, Debug)]
pub struct RayComposite {
    colour: Vec3,
    transmittance: f32,
    walked: usize,
    /// The next hit would have been past the per-ray cap.
    capped: bool,
    /// The ray stopped: `T_next < 1e-4`, or capped.
    done: bool,
    /// The camera's forward axis when the ray keeps its depth (SPEC section 9), else zero.
    forward: DVec3,
    /// The view depth at which `1 - T` first reached 0.5 (`+inf` until then).
    median: f32,
    /// `sum(alpha T z)` over the composited hits.
    zsum: f32,
}

impl Default for RayComposite {
    fn default() -> Self {
        RayComposite {
            colour: Vec3::ZERO,
            transmittance: 1.0,
            walked: 0,
            capped: false,
            done: false,
            forward: DVec3::ZERO,
            median: f32::INFINITY,
            zsum: 0.0,
        }
    }
}

impl RayComposite {
    /// Takes the next hit: skipped when `alpha w < 1/255`, the ray stopped before
    /// `T_next < 1e-4`, capped when `max_hits` were walked before it. Returns whether the ray
    /// takes more hits.
    pub fn take(
        &mut self,
        scene: &Scene,
        hit: &Hit,
        e: DVec3,
        d: DVec3,
        clip: &Clip,
        max_hits: usize,
    ) -> bool {
        if self.done {
            return false;
        }
        if self.walked == max_hits {
            self.capped = true;
            self.done = true;
            return false;
        }
        self.walked += 1;
        let alpha = (hit.alpha * clip_weight(scene, hit, e, d, clip)) as f32;
        if alpha < 1.0 / 255.0 {
            return true;
        }
        let next = self.transmittance * (1.0 - alpha);
        if next < 1e-4 {
            self.done = true;
            return false;
        }
        let i = hit.index as usize;
        let dir = (scene.means[i].as_dvec3() - e).normalize().as_vec3();
        self.colour += alpha * self.transmittance * eval_sh(scene.sh_of(i), scene.sh_degree, dir);
        if self.forward != DVec3::ZERO {
            // A hit's view depth is t (d . forward) (SPEC sections 9 and 11).
            let z = (hit.t * d.dot(self.forward)) as f32;
            self.zsum += alpha * self.transmittance * z;
            if next <= 0.5 && self.median.is_infinite() {
                self.median = z;
            }
        }
        self.transmittance = next;
        true
    }

    /// A ray that keeps the depth of what it composites, the camera's `forward` axis giving a
    /// hit's view depth ([`RayComposite::depth`]).
    pub fn with_depth(forward: DVec3) -> Self {
        RayComposite {
            forward,
            ..RayComposite::default()
        }
    }

    /// The ray's depth of `mode` (SPEC section 9) so far: the median, or the alpha-weighted
    /// mean over the composited hits, whose weights sum to `1 - T`; `+inf` where none.
    pub fn depth(&self, mode: crate::depth::DepthMode) -> f32 {
        match mode {
            crate::depth::DepthMode::Median => self.median,
            crate::depth::DepthMode::Mean => {
                let weight = 1.0 - self.transmittance;
                if weight > 0.0 {
                    self.zsum / weight
                } else {
                    f32::INFINITY
                }
            }
        }
    }

    /// Whether the ray takes no more hits.
    pub fn done(&self) -> bool {
        self.done
    }

    /// The colour over `background`, the hits walked and whether the cap cut the ray short.
    pub fn finish(self, background: Vec3) -> (Vec3, usize, bool) {
        (
            self.colour + self.transmittance * background,
            self.walked,
            self.capped,
        )
    }
}

/// Which Gaussians a primary ray may hit: all but those section 3 culls (`t.z <= 0.2`).
pub(crate) fn not_culled(scene: &Scene, camera: &Camera) -> Vec<bool> {
    let forward = camera.rotation.col(2);
    scene
        .means
        .iter()
        .map(|&m| forward.dot(m - camera.position) > 0.2)
        .collect()
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

/// The image of `pixel(i, j, stats)` (a colour over the background already), rows shared among
/// the host's threads, each thread's stats folded into the total by `merge`: the frame loop of
/// the CPU ray tracers (this one and [`super::mixed`]).
pub(crate) fn render_rows<S: Default + Send>(
    camera: &Camera,
    pixel: impl Fn(u32, u32, &mut S) -> Vec3 + Sync,
    mut merge: impl FnMut(&mut S, S),
) -> (Rgba8Image, S) {
    let (w, h) = (camera.width, camera.height);
    let threads = std::thread::available_parallelism()
        .map_or(1, |n| n.get())
        .min(h as usize)
        .max(1);
    let rows_per = (h as usize).div_ceil(threads);
    let mut pixels = vec![[0u8; 4]; (w * h) as usize];
    let mut stats = S::default();
    let pixel = &pixel;
    std::thread::scope(|scope| {
        let handles: Vec<_> = pixels
            .chunks_mut(rows_per * w as usize)
            .enumerate()
            .map(|(c, chunk)| {
                scope.spawn(move || {
                    let mut s = S::default();
                    for (k, px) in chunk.iter_mut().enumerate() {
                        let idx = c * rows_per * w as usize + k;
                        let (i, j) = ((idx % w as usize) as u32, (idx / w as usize) as u32);
                        *px = super::rasterize::to_rgba8(pixel(i, j, &mut s));
                    }
                    s
                })
            })
            .collect();
        for handle in handles {
            merge(
                &mut stats,
                handle.join().expect("a ray tracing thread panicked"),
            );
        }
    });
    let img = image::RgbaImage::from_fn(w, h, |i, j| image::Rgba(pixels[(j * w + i) as usize]));
    (img, stats)
}
