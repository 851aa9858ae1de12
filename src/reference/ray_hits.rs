//! Section 7's hit model on the CPU, shared by every CPU ray tracer: the BVH's
//! ([`super::raytrace`]), the tile lists' ([`super::tiled`], SPEC section 11) and the mixed
//! scenes' ([`super::mixed`]). One function finds a Gaussian's hit on a ray ([`gaussian_hit`]:
//! the octagon crossing, or 3DGRT's maximum response), one weighs it by the clip
//! ([`clip_weight`]), one composites a ray's hits in `(t, index)` order ([`RayComposite`]);
//! sharing them is what makes the tracers agree to the bit. The GPU's twin is
//! `glsl/ray_hits.glsl`.

use glam::{DMat3, DVec3, Vec3};

use super::Rgba8Image;
use crate::camera::Camera;
use crate::clip::{Classification, Clip, ClipMode, ClipRegion, CutoffRay, FLAT_PARALLEL_EPSILON};
use crate::mesh::{octagon_radius, FlatFrame};
use crate::scene::{flat_axis, Scene};
use crate::sh::eval_sh;

/// `q_max = 2 ln(255 o)`, the volumetric proxy's bound (SPEC section 7): past it a Gaussian
/// of opacity `o` has alpha under 1/255. Not positive (or NaN) when it can never be hit.
pub fn proxy_q_max(opacity: f32) -> f64 {
    2.0 * (255.0 * opacity as f64).ln()
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
