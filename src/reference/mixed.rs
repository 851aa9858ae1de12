//! The CPU reference of mixed scenes (SPEC section 8), the oracle of the GPU's
//! ([`crate::raytrace::mixed`]): per pixel a ray tree, each ray compositing the Gaussians
//! (section 7) up to its nearest mesh hit, which ends it (diffuse, with shadow rays toward the
//! lights) or spawns rays (mirror, glass).
//!
//! The rules both implementations follow, where section 8 leaves a choice
//! (docs/ARCHITECTURE.md, "Mixed scenes"):
//! - A ray's weight is its transmittance: a child ray starts with the parent's remaining
//!   `T` times the mirror's reflectance or the Fresnel term, and composites on into the same
//!   pixel colour, stopping when its `T` would fall below 1e-4 (section 4's rule).
//! - A secondary ray is parametrised from its *virtual* origin (the parent's origin mirrored
//!   or refracted through the hit point, `p - s d'` with `s` the path length so far), so that
//!   the SH direction `normalize(mu - origin)` and the clip weights are those the mirrored
//!   camera sees. Its Gaussians are taken from the hit point on (`t >= s`), its meshes from
//!   1e-4 beyond it; a ray that goes straight on (glass of IOR 1) keeps its parent's origin
//!   and its depth, and no weight limit cuts it (it is the same ray going on, not a branch; the
//!   depth counts the turns of a ray's path). Together these keep section 8's identities
//!   exact.
//! - Shading normals face the incoming ray for diffuse and mirror meshes (two-sided); glass
//!   uses the file's orientation to tell entering from leaving.
//! - Diffuse and mirror meshes are opaque to shadow rays; glass lets light through (no
//!   caustics). With several lights a Gaussian's shadow factor is the mean of the per-light
//!   factors `1 - strength (1 - T_mesh)`.
//! - Shadow rays composite the Gaussians between the hit point (from 1e-4) and the light by
//!   section 4's rule, colour ignored: `T_shadow` is the transmittance that rule leaves.

use glam::{DVec3, Vec3};

use super::rasterize::pixel_ray;
use super::ray_hits::{clip_weight, gaussian_hit, render_rows, Hit};
use super::raytrace::Bvh;
use super::Rgba8Image;
use crate::camera::Camera;
use crate::mixed::triangles::TriangleHit;
use crate::mixed::{Light, MixedScene, Surface};
use crate::options::RayTraceOptions;
use crate::sh::eval_sh;

/// Where a secondary ray's meshes start beyond its origin point.
pub const SECONDARY_OFFSET: f64 = 1e-4;

/// What a frame's rays were.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct MixedStats {
    /// Camera rays.
    pub primary: u64,
    /// Reflected and refracted rays traced.
    pub secondary: u64,
    /// Shadow rays traced (or found blocked by a mesh).
    pub shadow: u64,
    /// Branches cut by the depth or weight limit (they took the background).
    pub cut: u64,
}

/// The kinds of ray.
#[derive(Clone, Copy, Debug, PartialEq)]
enum Kind {
    /// From the camera: drops what section 3 culls.
    Camera,
    /// Reflected or refracted.
    Secondary,
    /// Toward a light, carrying the light it brings if nothing blocks it.
    Shadow(Vec3),
}

/// A ray of the tree: `o + t d`, Gaussians with `t` from `t_start`, meshes beyond
/// `t_start + offset` (0 for camera rays, [`SECONDARY_OFFSET`] else).
#[derive(Clone, Copy, Debug)]
struct Ray {
    o: DVec3,
    d: DVec3,
    t_start: f64,
    /// Shadow rays: where the light is (infinity for a directional one).
    t_end: f64,
    /// RGB weight: what reaches the pixel of each unit of light it brings (its parent's
    /// remaining `T` times the reflectances and Fresnel terms on its path; 1 for the camera
    /// ray). Its largest channel is the `T` its Gaussians composite under.
    weight: Vec3,
    depth: u32,
    kind: Kind,
    /// Drops what section 3 culls (camera rays, and their straight continuations).
    cull: bool,
}

/// What one frame shares.
struct Frame<'a> {
    scene: &'a MixedScene,
    bvh: Bvh,
    camera: &'a Camera,
    rt: &'a RayTraceOptions,
}

/// The direction toward light `l` from `p` and its distance (infinity for a directional
/// light), and the light arriving there unshadowed (intensity over the squared distance).
pub fn toward_light(l: &Light, p: DVec3) -> (DVec3, f64, Vec3) {
    match *l {
        Light::Point {
            position,
            intensity,
        } => {
            let v = position.as_dvec3() - p;
            let dist = v.length();
            (v / dist, dist, intensity / (dist * dist) as f32)
        }
        Light::Directional {
            direction,
            intensity,
        } => (-direction.as_dvec3(), f64::INFINITY, intensity),
    }
}

impl Frame<'_> {
    /// Whether an opaque (diffuse or mirror) triangle lies on `p + t d`, `t` in
    /// `(SECONDARY_OFFSET, t_end)` (the occluders' BVH: glass is not in it).
    fn blocked(&self, p: DVec3, d: DVec3, t_end: f64) -> bool {
        self.scene
            .occluders
            .hit(p, d, SECONDARY_OFFSET, t_end, true)
            .is_some()
    }

    /// A Gaussian's shadow factor at `p` (section 8): per light `1 - strength (1 - T_mesh)`,
    /// their mean; 1 without lights or meshes.
    fn shadow_factor(&self, p: DVec3) -> f32 {
        let s = self.scene;
        if s.lights.is_empty() || s.meshes.triangles.is_empty() {
            return 1.0;
        }
        let mut sum = 0.0f32;
        for l in &s.lights {
            let (d, dist, _) = toward_light(l, p);
            let t_mesh = if self.blocked(p, d, dist) { 0.0 } else { 1.0 };
            sum += 1.0 - s.shadow_strength * (1.0 - t_mesh);
        }
        sum / s.lights.len() as f32
    }

    /// Composites the Gaussians of `ray` with `t` in `[t_lo, t_hi)` on top of `(colour, T)`
    /// (section 4's rule; shaded by the meshes' shadows unless it is a shadow ray). Returns
    /// the new colour and transmittance and whether the ray ended (opacity or the hit cap).
    fn segment(&self, ray: &Ray, t_lo: f64, t_hi: f64, colour: Vec3, t0: f32) -> (Vec3, f32, bool) {
        let g = &self.scene.gaussians;
        let forward = self.camera.rotation.col(2);
        let mut hits: Vec<Hit> = Vec::new();
        self.bvh.candidates(ray.o, ray.d, |i| {
            if ray.cull && forward.dot(g.means[i as usize] - self.camera.position) <= 0.2 {
                return;
            }
            if let Some(h) = gaussian_hit(g, i as usize, ray.o, ray.d, self.rt.q) {
                if h.t >= t_lo && h.t < t_hi {
                    hits.push(h);
                }
            }
        });
        hits.sort_by(|a, b| a.t.total_cmp(&b.t).then(a.index.cmp(&b.index)));
        let shade = !matches!(ray.kind, Kind::Shadow(_));
        let (mut colour, mut t) = (colour, t0);
        for (walked, hit) in hits.iter().enumerate() {
            if walked == self.rt.max_hits {
                return (colour, t, true);
            }
            let clip = &self.scene.object_of(hit.index).clip;
            let alpha = (hit.alpha * clip_weight(g, hit, ray.o, ray.d, clip)) as f32;
            if alpha < 1.0 / 255.0 {
                continue;
            }
            let next = t * (1.0 - alpha);
            if next < 1e-4 {
                return (colour, t, true);
            }
            let i = hit.index as usize;
            let dir = (g.means[i].as_dvec3() - ray.o).normalize().as_vec3();
            let factor = if shade {
                self.shadow_factor(ray.o + hit.t * ray.d)
            } else {
                1.0
            };
            colour += alpha * t * (factor * eval_sh(g.sh_of(i), g.sh_degree, dir));
            t = next;
        }
        (colour, t, false)
    }

    /// The pixel's colour: its ray tree, depth first.
    fn pixel(&self, i: u32, j: u32, stats: &mut MixedStats) -> Vec3 {
        let s = self.scene;
        let bg = s.background;
        let (e, d) = pixel_ray(self.camera, i, j);
        let mut stack = vec![Ray {
            o: e,
            d,
            t_start: 0.0,
            t_end: f64::INFINITY,
            weight: Vec3::ONE,
            depth: 0,
            kind: Kind::Camera,
            cull: true,
        }];
        let mut acc = Vec3::ZERO;
        while let Some(ray) = stack.pop() {
            match ray.kind {
                Kind::Camera => stats.primary += 1,
                Kind::Secondary => stats.secondary += 1,
                Kind::Shadow(_) => stats.shadow += 1,
            }
            if let Kind::Shadow(light) = ray.kind {
                if self.blocked(ray.o, ray.d, ray.t_end) {
                    continue;
                }
                let (_, t, _) = self.segment(&ray, SECONDARY_OFFSET, ray.t_end, Vec3::ZERO, 1.0);
                acc += light * t;
                continue;
            }
            let offset = if ray.kind == Kind::Camera {
                0.0
            } else {
                SECONDARY_OFFSET
            };
            let hit = s
                .meshes
                .hit(ray.o, ray.d, ray.t_start + offset, f64::INFINITY, false);
            let t_mesh = hit.map_or(f64::INFINITY, |h| h.t);
            // A ray of one weight in every channel composites on into the pixel's colour
            // under T = that weight (the kernels' order, so a scene without colour on its
            // paths is the ray tracer's frame to the bit); a tinted one composites from 0
            // under its largest channel, and its colour joins the pixel's times its tint.
            let (t0, tint) = split_weight(ray.weight);
            let start = if tint.is_some() { Vec3::ZERO } else { acc };
            let (mut colour, t, ended) = self.segment(&ray, ray.t_start, t_mesh, start, t0);
            let hit = hit.filter(|_| !ended);
            if hit.is_none() {
                colour += t * bg;
            }
            acc = match tint {
                Some(tint) => acc + tint * colour,
                None => colour,
            };
            let Some(hit) = hit else {
                continue;
            };
            let w = tint.unwrap_or(Vec3::ONE) * t;
            self.shade(&ray, &hit, w, &mut acc, &mut stack, stats);
        }
        acc
    }

    /// The mesh hit of `ray` with the RGB weight `w` that reaches it: its light, or its
    /// children onto `stack`.
    fn shade(
        &self,
        ray: &Ray,
        hit: &TriangleHit,
        w: Vec3,
        acc: &mut Vec3,
        stack: &mut Vec<Ray>,
        stats: &mut MixedStats,
    ) {
        let s = self.scene;
        let p = ray.o + hit.t * ray.d;
        let n = s.meshes.normal(hit);
        let material = s.materials[s.meshes.triangles[hit.triangle as usize].material as usize];
        *acc += w * material.emission;
        let facing = if n.dot(ray.d) > 0.0 { -n } else { n };
        let mut child = |d: DVec3, weight: Vec3, straight: bool, acc: &mut Vec3| {
            // A ray that goes straight on (glass of IOR 1) is the same ray going on, not a
            // branch: same depth, and no weight limit (section 4's rule stops it).
            let depth = if straight { ray.depth } else { ray.depth + 1 };
            if !straight && (depth > s.max_depth || weight.max_element() < 1.0 / 255.0) {
                stats.cut += 1;
                *acc += weight * s.background;
                return;
            }
            let (o, cull) = if straight {
                (ray.o, ray.cull)
            } else {
                (p - hit.t * d, false)
            };
            stack.push(Ray {
                o,
                d,
                t_start: hit.t,
                t_end: f64::INFINITY,
                weight,
                depth,
                kind: Kind::Secondary,
                cull,
            });
        };
        match material.surface {
            Surface::Diffuse => {
                let c = material.colour_at(&s.textures, s.meshes.uv(hit));
                *acc += w * (c * s.ambient);
                for l in &s.lights {
                    let (dl, dist, light) = toward_light(l, p);
                    let ndl = facing.dot(dl);
                    if ndl > 0.0 {
                        stack.push(Ray {
                            o: p,
                            d: dl,
                            t_start: 0.0,
                            t_end: dist,
                            weight: Vec3::ONE,
                            depth: ray.depth,
                            kind: Kind::Shadow(w * (c * (ndl as f32 * light))),
                            cull: false,
                        });
                    }
                }
            }
            Surface::Mirror => {
                let rho = material.colour_at(&s.textures, s.meshes.uv(hit));
                let r = ray.d - 2.0 * facing.dot(ray.d) * facing;
                child(r, w * rho, false, acc);
            }
            Surface::Glass(eta) => {
                let (n1, n2, nn) = if n.dot(ray.d) < 0.0 {
                    (1.0, eta as f64, n)
                } else {
                    (eta as f64, 1.0, -n)
                };
                let (f, refracted) = fresnel(ray.d, nn, n1, n2);
                let r = ray.d - 2.0 * nn.dot(ray.d) * nn;
                child(r, w * f as f32, false, acc);
                if let Some(dt) = refracted {
                    child(dt, w * (1.0 - f as f32), n1 == n2, acc);
                }
            }
        }
    }
}

/// A ray's RGB weight as the `T` its Gaussians composite under (its largest channel) and its
/// tint (the weight over that `T`), `None` where every channel is the same (the kernel's
/// `split_weight`).
pub fn split_weight(w: Vec3) -> (f32, Option<Vec3>) {
    let t = w.max_element();
    if w.x == w.y && w.y == w.z {
        (t, None)
    } else {
        (t, Some(w / t))
    }
}

/// The exact unpolarised Fresnel reflectance at a surface of normal `nn` facing the incoming
/// unit direction `d` (`nn.d < 0`), from index `n1` into `n2`, and the refracted direction
/// (Snell; `None` at total internal reflection, where the reflectance is 1). Equal indices give
/// exactly 0 and `d` itself.
pub fn fresnel(d: DVec3, nn: DVec3, n1: f64, n2: f64) -> (f64, Option<DVec3>) {
    let cosi = -nn.dot(d);
    let eta = n1 / n2;
    let sin2t = eta * eta * (1.0 - cosi * cosi);
    if sin2t >= 1.0 {
        return (1.0, None);
    }
    if n1 == n2 {
        return (0.0, Some(d));
    }
    let cost = (1.0 - sin2t).sqrt();
    let rs = (n1 * cosi - n2 * cost) / (n1 * cosi + n2 * cost);
    let rp = (n2 * cosi - n1 * cost) / (n2 * cosi + n1 * cost);
    let f = 0.5 * (rs * rs + rp * rp);
    (f, Some(eta * d + (eta * cosi - cost) * nn))
}

/// Ray traces the mixed `scene` from `camera` (SPEC section 8), rows shared among the host's
/// threads.
pub fn render(
    scene: &MixedScene,
    camera: &Camera,
    rt: &RayTraceOptions,
) -> (Rgba8Image, MixedStats) {
    let frame = Frame {
        scene,
        bvh: Bvh::build(&scene.gaussians, rt.q),
        camera,
        rt,
    };
    render_rows(
        camera,
        |i, j, s| frame.pixel(i, j, s),
        |total: &mut MixedStats, s| {
            total.primary += s.primary;
            total.secondary += s.secondary;
            total.shadow += s.shadow;
            total.cut += s.cut;
        },
    )
}
