//! The CPU reference of SPEC section 11: section 7's camera rays composited from tile lists
//! instead of a BVH, the oracle of the GPU's tiled tracer and the proof of the section's
//! identity (with no forced hit, the image is section 7's to the bit: the hits, their clip
//! weights and their compositing are [`super::raytrace`]'s own functions).
//!
//! Stage by stage: [`bound`] (each Gaussian's ball `rho_g` around its centre and the key
//! `k_g = max(0, |mu - e| - rho_g)`, below which no hit of it lies) or [`depth_key`] (the
//! proxy's nearest view depth, [`TileKey`]), [`silhouette`] and [`silhouette_tiles`] (the tiles
//! under the bounding rectangle of its proxy's silhouette: exact for the pinhole),
//! [`tile_lists`] (each tile's Gaussians by `(key, index)`), then per pixel the walk of its
//! tile's list with a buffer of pending hits ([`PendingHits`]).

use glam::{DMat3, DVec3, Vec3};

use super::rasterize::pixel_ray;
use super::ray_hits::{gaussian_hit, not_culled, proxy_q_max, render_rows, Hit, RayComposite};
use super::Rgba8Image;
use crate::camera::{tile_grid, Camera};
use crate::constants::TILE_SIZE;
use crate::mesh::{octagon_radius, FlatFrame, CORNERS};
use crate::options::RayTraceOptions;
use crate::options::RenderOptions;
use crate::scene::{flat_axis, Scene};

/// The pending-buffer capacity of the reference's default: as many hits as a ray may hold
/// unresolved before one is forced out of order. The shared real scenes at 320 px peak at
/// 57-241 with the depth key (docs/ARCHITECTURE.md, "Section 7 in tiles").
pub const DEFAULT_PENDING: usize = 512;

/// A relative margin taken off `k_g`: the hit parameter `t_g` and `|mu - e| - rho_g` are
/// rounded apart, and a smaller key only composites a pending hit later, never out of order.
const KEY_MARGIN: f64 = 1e-9;

/// Gaussian `i`'s ball and key seen from the eye `e`: `(rho_g, k_g)`, SPEC section 11.
/// `rho_g` holds the proxy: `sqrt(2 ln(255 o)) max(scale)` for a volumetric Gaussian, the
/// octagon's `rho max(s_a, s_b)` for a flat one. `None` for an empty proxy (never hit).
pub fn bound(scene: &Scene, i: usize, e: DVec3, q: f64) -> Option<(f64, f64)> {
    let rho = if flat_axis(scene.scales[i]).is_some() {
        let r = octagon_radius(q, scene.opacities[i]);
        let frame = FlatFrame::of(scene, i);
        r * frame.s_a.max(frame.s_b)
    } else {
        let q_max = proxy_q_max(scene.opacities[i]);
        if q_max.is_nan() || q_max <= 0.0 {
            return None;
        }
        q_max.sqrt() * scene.scales[i].max_element() as f64
    };
    if rho.is_nan() || rho <= 0.0 {
        return None;
    }
    let distance = (scene.means[i].as_dvec3() - e).length();
    let k = ((distance - rho) * (1.0 - KEY_MARGIN) - KEY_MARGIN).max(0.0);
    Some((rho, k))
}

/// The bounding rectangle of a proxy's silhouette on the image plane.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Silhouette {
    /// No ray from the eye through the image plane crosses the proxy.
    Empty,
    /// The proxy reaches the camera's plane: its silhouette has no bound.
    Unbounded,
    /// Pixel coordinates `[u_lo, u_hi]` and `[v_lo, v_hi]` (pixel `(u, v)`'s ray is the one
    /// through the point `(u, v)` itself, `pixel_ray`): only rays inside it can cross the proxy.
    Pixels([f64; 2], [f64; 2]),
}

/// The bounding rectangle of Gaussian `i`'s proxy as the pinhole `camera` sees it, exact: the
/// octagon's corners' images (a convex polygon's silhouette is their hull), or for the
/// ellipsoid `q <= 2 ln(255 o)` the column and row planes through the eye tangent to it.
pub fn silhouette(scene: &Scene, i: usize, camera: &Camera, q: f64) -> Silhouette {
    let (cx, cy) = camera.principal_point();
    let (cx, cy) = (cx as f64, cy as f64);
    let (fx, fy) = (camera.fx as f64, camera.fy as f64);
    let e = camera.position.as_dvec3();
    let to_camera = camera.world_to_camera().as_dmat3();
    if flat_axis(scene.scales[i]).is_some() {
        let frame = FlatFrame::of(scene, i);
        let rho = octagon_radius(q, scene.opacities[i]);
        if rho.is_nan() || rho <= 0.0 {
            return Silhouette::Empty;
        }
        let mut u = [f64::INFINITY, f64::NEG_INFINITY];
        let mut v = u;
        for k in 0..CORNERS {
            let c = to_camera * (frame.corner(rho, k) - e);
            if c.z.is_nan() || c.z <= 0.0 {
                return Silhouette::Unbounded;
            }
            let (pu, pv) = (cx + fx * c.x / c.z, cy + fy * c.y / c.z);
            u = [u[0].min(pu), u[1].max(pu)];
            v = [v[0].min(pv), v[1].max(pv)];
        }
        return Silhouette::Pixels(u, v);
    }
    // The ellipsoid (x - mu)^T Sigma^-1 (x - mu) <= q_max meets the plane through the eye of
    // pixel column u (normal (fx, 0, -w) in the camera's frame, w = u - cx) when
    // (n . m)^2 <= q_max n^T Sigma n, m the centre in the camera's frame: a quadratic in w
    // whose roots bound the columns; the same for the rows.
    let q_max = proxy_q_max(scene.opacities[i]);
    if q_max.is_nan() || q_max <= 0.0 {
        return Silhouette::Empty;
    }
    let r = DMat3::from_quat(scene.rotations[i].as_dquat().normalize());
    let s = scene.scales[i].as_dvec3();
    let rs = to_camera * DMat3::from_cols(r.x_axis * s.x, r.y_axis * s.y, r.z_axis * s.z);
    let sigma = rs * rs.transpose() * q_max;
    let m = to_camera * (scene.means[i].as_dvec3() - e);
    let a = m.z * m.z - sigma.z_axis.z;
    if a.is_nan() || a <= 0.0 {
        return Silhouette::Unbounded; // the ellipsoid reaches the camera's plane
    }
    if m.z <= 0.0 {
        return Silhouette::Empty; // wholly behind the camera
    }
    // a w^2 - 2 f b w + f^2 c <= 0 between the roots.
    let range = |f: f64, mc: f64, s_cc: f64, s_cz: f64| -> Option<[f64; 2]> {
        let b = mc * m.z - s_cz;
        let c = mc * mc - s_cc;
        let disc = b * b - a * c;
        if disc.is_nan() || disc < 0.0 {
            return None;
        }
        let root = disc.sqrt();
        Some([f * (b - root) / a, f * (b + root) / a])
    };
    match (
        range(fx, m.x, sigma.x_axis.x, sigma.z_axis.x),
        range(fy, m.y, sigma.y_axis.y, sigma.z_axis.y),
    ) {
        (Some(wu), Some(wv)) => {
            Silhouette::Pixels([cx + wu[0], cx + wu[1]], [cy + wv[0], cy + wv[1]])
        }
        _ => Silhouette::Empty,
    }
}

/// The tiles `[x0, x1) x [y0, y1)` of `camera` holding a pixel inside Gaussian `i`'s
/// [`silhouette`] (widened by a hair against rounding: a looser bound is allowed); the whole
/// grid when it is unbounded, an empty rectangle when it is empty or off the image.
pub fn silhouette_tiles(scene: &Scene, i: usize, camera: &Camera, q: f64) -> [u32; 4] {
    let (gx, gy) = tile_grid(camera.width, camera.height);
    let (u, v) = match silhouette(scene, i, camera, q) {
        Silhouette::Empty => return [0, 0, 0, 0],
        Silhouette::Unbounded => return [0, 0, gx, gy],
        Silhouette::Pixels(u, v) => (u, v),
    };
    let tiles = |[lo, hi]: [f64; 2], pixels: u32| -> Option<[u32; 2]> {
        let pad = 1e-6 * (1.0 + lo.abs().max(hi.abs()));
        let (lo, hi) = ((lo - pad).ceil().max(0.0), (hi + pad).floor());
        if lo.is_nan() || hi.is_nan() || lo > hi || lo >= pixels as f64 {
            return None;
        }
        let hi = hi.min((pixels - 1) as f64);
        Some([lo as u32 / TILE_SIZE, hi as u32 / TILE_SIZE + 1])
    };
    match (tiles(u, camera.width), tiles(v, camera.height)) {
        (Some([x0, x1]), Some([y0, y1])) => [x0, y0, x1, y1],
        _ => [0, 0, 0, 0],
    }
}

/// Which lower bound of a Gaussian's hits orders the tile lists.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum TileKey {
    /// SPEC section 11 to the letter: `k_g = max(0, |mu - e| - rho_g)` in ray parameter `t`,
    /// a pending hit composited once its `t` is below the next key. The ball is loose around
    /// an anisotropic Gaussian: on the shared real scenes at 320 px a pixel held up to 473
    /// pending hits (guitar), 146 on plant.
    Ball,
    /// The least view depth at which a ray from the eye can hit the Gaussian ([`depth_key`]:
    /// the octagon's nearest corner; for the ellipsoid the nearest point of maximum response
    /// inside the proxy), compared with a pending hit's view depth `t (d . forward)`: on one
    /// ray depth orders hits as `t` does, and no hit lies nearer than the key, so the order is
    /// as exact as the ball's, and tighter.
    Depth,
    /// Per (Gaussian, tile), the least view depth of its hits on the tile's own pixel rays
    /// ([`tile_hit_depth`]), compared as [`TileKey::Depth`] is: the tightest key there is,
    /// found by testing every pixel of the tile; a pair no pixel hits is left out.
    TileHits,
}

/// The least view depth of Gaussian `i`'s hits on the pixel rays of tile `(tx, ty)`
/// ([`TileKey::TileHits`]), or `None` when none of them hits it.
pub fn tile_hit_depth(
    scene: &Scene,
    i: usize,
    camera: &Camera,
    q: f64,
    tx: u32,
    ty: u32,
) -> Option<f64> {
    let forward = camera.rotation.col(2).as_dvec3();
    let mut least: Option<f64> = None;
    for v in ty * TILE_SIZE..((ty + 1) * TILE_SIZE).min(camera.height) {
        for u in tx * TILE_SIZE..((tx + 1) * TILE_SIZE).min(camera.width) {
            let (e, d) = pixel_ray(camera, u, v);
            if let Some(hit) = gaussian_hit(scene, i, e, d, q) {
                let depth = hit.t * d.dot(forward);
                least = Some(least.map_or(depth, |l: f64| l.min(depth)));
            }
        }
    }
    least
}

/// Gaussian `i`'s depth key ([`TileKey::Depth`]): the least view depth of a hit of it on any
/// ray from `camera`'s eye, or `None` for an empty proxy.
pub fn depth_key(scene: &Scene, i: usize, camera: &Camera, q: f64) -> Option<f64> {
    let e = camera.position.as_dvec3();
    let forward = camera.rotation.col(2).as_dvec3();
    let margin = |z: f64| z - KEY_MARGIN * (1.0 + z.abs());
    if flat_axis(scene.scales[i]).is_some() {
        let rho = octagon_radius(q, scene.opacities[i]);
        if rho.is_nan() || rho <= 0.0 {
            return None;
        }
        let frame = FlatFrame::of(scene, i);
        let nearest = (0..CORNERS)
            .map(|k| forward.dot(frame.corner(rho, k) - e))
            .fold(f64::INFINITY, f64::min);
        return Some(margin(nearest));
    }
    let q_max = proxy_q_max(scene.opacities[i]);
    if q_max.is_nan() || q_max <= 0.0 {
        return None;
    }
    let r = DMat3::from_quat(scene.rotations[i].as_dquat().normalize());
    let s = scene.scales[i].as_dvec3();
    // In the Gaussian's whitened frame x' = S^-1 R^T (x - mu) the proxy is the ball
    // |x'|^2 <= q_max, and a ray from the eye e' has its maximum response where x' . d' = 0,
    // d' along x' - e': on the sphere with diameter [0, e'] (centre e'/2, radius |e'|/2).
    // View depth is linear there, z0 + g . x' with g = S R^T forward, so the nearest depth of
    // any hit is the least of g . x' over that sphere's cap inside the ball: the sphere's own
    // least point if it lies in the ball, else the least point of the rim circle (the plane
    // x' . e' = q_max, where the two spheres meet).
    let g = DVec3::new(
        forward.dot(r.x_axis) * s.x,
        forward.dot(r.y_axis) * s.y,
        forward.dot(r.z_axis) * s.z,
    );
    let to_eye = e - scene.means[i].as_dvec3();
    let e_w = DVec3::new(
        to_eye.dot(r.x_axis) / s.x,
        to_eye.dot(r.y_axis) / s.y,
        to_eye.dot(r.z_axis) / s.z,
    );
    let z0 = -forward.dot(to_eye);
    let (g_len, e_len2) = (g.length(), e_w.length_squared());
    let proxy_front = -q_max.sqrt() * g_len; // the least of g . x' over the whole ball
    let lowest = if g_len == 0.0 || e_len2 <= 0.0 {
        proxy_front
    } else {
        let (c, radius) = (0.5 * e_w, 0.5 * e_len2.sqrt());
        let on_sphere = c - radius * g / g_len;
        if on_sphere.length_squared() <= q_max {
            g.dot(c) - radius * g_len
        } else {
            // The rim: centre (q_max / |e'|^2) e', radius sqrt(q_max (1 - q_max / |e'|^2)),
            // in the plane of normal e'.
            let n = e_w / e_len2.sqrt();
            let rim_radius2 = q_max * (1.0 - q_max / e_len2);
            let g_in_plane = g - g.dot(n) * n;
            g.dot(e_w) * q_max / e_len2 - rim_radius2.max(0.0).sqrt() * g_in_plane.length()
        }
    };
    // Never looser than the proxy's front, and never past it by rounding the other way.
    let lowest = lowest.max(proxy_front);
    let size = z0.abs() + q_max.sqrt() * g_len + 0.5 * e_len2.sqrt() * g_len;
    Some(z0 + lowest - KEY_MARGIN * (1.0 + size))
}

/// Per tile (row-major), the Gaussians primary rays may hit whose silhouette rectangle covers
/// it, in ascending `(k_g, index)`, with their keys.
pub fn tile_lists(scene: &Scene, camera: &Camera, q: f64, key: TileKey) -> Vec<Vec<(f64, u32)>> {
    let (gx, gy) = tile_grid(camera.width, camera.height);
    let mut lists = vec![Vec::new(); (gx * gy) as usize];
    let e = camera.position.as_dvec3();
    let live = not_culled(scene, camera);
    for (i, _) in live.iter().enumerate().filter(|(_, &live)| live) {
        let k = match key {
            TileKey::Ball => bound(scene, i, e, q).map(|(_, k)| k),
            TileKey::Depth | TileKey::TileHits => depth_key(scene, i, camera, q),
        };
        let Some(k) = k else {
            continue;
        };
        let [x0, y0, x1, y1] = silhouette_tiles(scene, i, camera, q);
        for ty in y0..y1 {
            for tx in x0..x1 {
                let k = match key {
                    TileKey::TileHits => match tile_hit_depth(scene, i, camera, q, tx, ty) {
                        Some(depth) => depth,
                        None => continue, // no pixel of the tile hits it
                    },
                    _ => k,
                };
                lists[(ty * gx + tx) as usize].push((k, i as u32));
            }
        }
    }
    for list in &mut lists {
        list.sort_by(|a, b| a.0.total_cmp(&b.0).then(a.1.cmp(&b.1)));
    }
    lists
}

/// What a frame's rays did in the tiled tracer.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct TiledStats {
    /// Rays traced.
    pub rays: usize,
    /// (Gaussian, tile) pairs listed.
    pub pairs: u64,
    /// Hits found before each ray stopped.
    pub hits: u64,
    /// Hits composited (or skipped for alpha) before each ray stopped.
    pub hits_walked: u64,
    /// Rays that reached the per-ray cap with hits left and light left.
    pub capped: usize,
    /// Hits forced out of a full pending buffer (each may break section 7's order).
    pub forced: u64,
    /// The most hits a pixel's pending buffer held.
    pub max_pending: usize,
    /// Rays by the most hits their pending buffer held: entry b counts those whose peak is in
    /// `(2^(b-1), 2^b]` (entry 0: at most one), the last entry everything above 2^10.
    pub peaks: [u64; 12],
}

/// A pixel's pending hits, nearest first, at most `capacity` of them.
pub struct PendingHits {
    hits: Vec<Hit>,
    capacity: usize,
}

impl PendingHits {
    /// An empty buffer of `capacity` hits (at least one).
    pub fn new(capacity: usize) -> Self {
        PendingHits {
            hits: Vec::with_capacity(capacity + 1),
            capacity: capacity.max(1),
        }
    }

    /// Adds `hit` in `(t, index)` order; when that overfills the buffer, returns the nearest
    /// hit, forced out.
    pub fn insert(&mut self, hit: Hit) -> Option<Hit> {
        let at = self
            .hits
            .partition_point(|h| (h.t, h.index) < (hit.t, hit.index));
        self.hits.insert(at, hit);
        (self.hits.len() > self.capacity).then(|| self.hits.remove(0))
    }

    /// Takes the nearest hit when `t * along` is below `key` (nothing later can precede it):
    /// `along` 1 for keys in `t`, `d . forward` for keys in view depth.
    pub fn take_before(&mut self, key: f64, along: f64) -> Option<Hit> {
        (self.hits.first()?.t * along < key).then(|| self.hits.remove(0))
    }

    /// Takes the nearest hit.
    pub fn take(&mut self) -> Option<Hit> {
        (!self.hits.is_empty()).then(|| self.hits.remove(0))
    }

    /// Hits held.
    pub fn len(&self) -> usize {
        self.hits.len()
    }

    /// Whether it holds none.
    pub fn is_empty(&self) -> bool {
        self.hits.is_empty()
    }
}

/// Settings of the tiled tracer.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct TiledOptions {
    /// The pending buffer's capacity K.
    pub pending: usize,
    /// The key that orders the tile lists.
    pub key: TileKey,
}

impl Default for TiledOptions {
    fn default() -> Self {
        TiledOptions {
            pending: DEFAULT_PENDING,
            key: TileKey::Depth,
        }
    }
}

/// Section 7's image of `scene` from `camera`, its camera rays composited from tile lists
/// (SPEC section 11) as `tiled` says; rows shared among the host's threads.
pub fn render(
    scene: &Scene,
    camera: &Camera,
    options: &RenderOptions,
    rt: &RayTraceOptions,
    tiled: &TiledOptions,
) -> (Rgba8Image, TiledStats) {
    let lists = tile_lists(scene, camera, rt.q, tiled.key);
    let forward = camera.rotation.col(2).as_dvec3();
    let (gx, _) = tile_grid(camera.width, camera.height);
    let pairs = lists.iter().map(|l| l.len() as u64).sum();
    let (image, mut stats) = render_rows(
        camera,
        |i, j, s: &mut TiledStats| {
            let list = &lists[((j / TILE_SIZE) * gx + i / TILE_SIZE) as usize];
            let (e, d) = pixel_ray(camera, i, j);
            let along = match tiled.key {
                TileKey::Ball => 1.0,
                TileKey::Depth | TileKey::TileHits => d.dot(forward),
            };
            trace(scene, list, (e, d, along), options, rt, tiled.pending, s)
        },
        |total, s| {
            total.rays += s.rays;
            total.hits += s.hits;
            total.hits_walked += s.hits_walked;
            total.capped += s.capped;
            total.forced += s.forced;
            total.max_pending = total.max_pending.max(s.max_pending);
            for (t, p) in total.peaks.iter_mut().zip(s.peaks) {
                *t += p;
            }
        },
    );
    stats.pairs = pairs;
    (image, stats)
}

/// One pixel's ray `e + t d` through its tile's `list`: each Gaussian's hit joins the pending
/// buffer, and every pending hit nearer than the next Gaussian's key (`t * along` against it)
/// is composited first.
fn trace(
    scene: &Scene,
    list: &[(f64, u32)],
    (e, d, along): (DVec3, DVec3, f64),
    options: &RenderOptions,
    rt: &RayTraceOptions,
    pending: usize,
    stats: &mut TiledStats,
) -> Vec3 {
    let clip = &options.clip;
    let mut ray = RayComposite::default();
    let mut buffer = PendingHits::new(pending);
    let mut peak = 0;
    'list: for &(k, i) in list {
        while let Some(hit) = buffer.take_before(k, along) {
            if !ray.take(scene, &hit, e, d, clip, rt.max_hits) {
                break 'list;
            }
        }
        let Some(hit) = gaussian_hit(scene, i as usize, e, d, rt.q) else {
            continue;
        };
        stats.hits += 1;
        let forced = buffer.insert(hit);
        peak = peak.max(buffer.len());
        if let Some(hit) = forced {
            stats.forced += 1;
            if !ray.take(scene, &hit, e, d, clip, rt.max_hits) {
                break;
            }
        }
    }
    while let Some(hit) = buffer.take() {
        if !ray.take(scene, &hit, e, d, clip, rt.max_hits) {
            break;
        }
    }
    let (colour, walked, capped) = ray.finish(options.background);
    stats.max_pending = stats.max_pending.max(peak);
    let bucket = (usize::BITS - peak.saturating_sub(1).leading_zeros()) as usize;
    stats.peaks[bucket.min(11)] += 1;
    stats.rays += 1;
    stats.hits_walked += walked as u64;
    stats.capped += capped as usize;
    colour
}
