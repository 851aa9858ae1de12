//! CPU twin of `glsl/project_body.glsl` (SPEC sections 3 and 5).

use glam::{Quat, Vec2, Vec3};

use crate::camera::{tile_rect, Camera};
use crate::clip::{Classification, Clip, CutoffRay};
use crate::constants::{BLOCK_SIZE, PAIR_BLOCKS_SHIFT, TILE_SIZE};
use crate::scene::Scene;
use crate::sh::eval_sh;

/// What the project stage produces for one Gaussian that draws something.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct ProjectedSplat {
    /// Index of the Gaussian in the scene.
    pub index: u32,
    /// Image coordinates of the centre.
    pub uv: Vec2,
    /// View-space depth.
    pub depth: f32,
    /// Opacity.
    pub opacity: f32,
    /// Inverse 2D covariance (A, B, C).
    pub conic: Vec3,
    /// SH colour.
    pub color: Vec3,
    /// Touched tiles `(x0, y0, x1, y1)`, end exclusive.
    pub rect: [u32; 4],
    /// For a cutoff Gaussian, what its per-pixel clip weight needs; `None` means w = 1.
    pub cutoff: Option<CutoffRay>,
}

/// Rows of the rotation matrix of a normalised quaternion.
fn quat_rows(q: Quat) -> [Vec3; 3] {
    let (w, x, y, z) = (q.w, q.x, q.y, q.z);
    [
        Vec3::new(
            1.0 - 2.0 * (y * y + z * z),
            2.0 * (x * y - w * z),
            2.0 * (x * z + w * y),
        ),
        Vec3::new(
            2.0 * (x * y + w * z),
            1.0 - 2.0 * (x * x + z * z),
            2.0 * (y * z - w * x),
        ),
        Vec3::new(
            2.0 * (x * z - w * y),
            2.0 * (y * z + w * x),
            1.0 - 2.0 * (x * x + y * y),
        ),
    ]
}

/// Why [`project_one`] draws nothing for a Gaussian.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Skipped {
    /// Dropped by the clip test.
    Clipped,
    /// At or behind the near plane (`t.z <= 0.2`).
    Culled,
    /// Past the footprint bound ([`crate::constants::MAX_FOOTPRINT_SIGMA_PX`]).
    Oversized,
    /// A 2D covariance with `det <= 0`.
    Degenerate,
    /// Its visible footprint reaches no tile of the image.
    NoTile,
}

/// Projects Gaussian `i`, or `None` when it is clipped away, culled or touches no tile.
pub fn project_one(
    scene: &Scene,
    camera: &Camera,
    clip: &Clip,
    i: usize,
) -> Option<ProjectedSplat> {
    project_or_skip(scene, camera, clip, i).ok()
}

/// [`project_one`], saying why a Gaussian draws nothing.
pub fn project_or_skip(
    scene: &Scene,
    camera: &Camera,
    clip: &Clip,
    i: usize,
) -> Result<ProjectedSplat, Skipped> {
    let class = clip.classify(scene.means[i], scene.scales[i]);
    if class == Classification::Dropped {
        return Err(Skipped::Clipped);
    }
    let w2c = camera.world_to_camera();
    // Rows of R_wc.
    let (r_x, r_y, r_z) = (w2c.row(0), w2c.row(1), w2c.row(2));
    let mu = scene.means[i];
    let rel = mu - camera.position;
    let t = Vec3::new(r_x.dot(rel), r_y.dot(rel), r_z.dot(rel));
    if t.z <= 0.2 {
        return Err(Skipped::Culled);
    }
    let (fx, fy) = (camera.fx, camera.fy);
    let (w, h) = (camera.width as f32, camera.height as f32);
    let lim_x = 1.3 * (w / (2.0 * fx));
    let lim_y = 1.3 * (h / (2.0 * fy));
    let xc = (t.x / t.z).clamp(-lim_x, lim_x) * t.z;
    let yc = (t.y / t.z).clamp(-lim_y, lim_y) * t.z;
    // Rows of J R_wc in world coordinates.
    let j0 = (fx / t.z) * r_x - (fx * xc / (t.z * t.z)) * r_z;
    let j1 = (fy / t.z) * r_y - (fy * yc / (t.z * t.z)) * r_z;
    // Sigma = M M^T, M = R S: v^T Sigma w = (S R^T v) . (S R^T w).
    let [q0, q1, q2] = quat_rows(scene.rotations[i]);
    let cols = [
        Vec3::new(q0.x, q1.x, q2.x),
        Vec3::new(q0.y, q1.y, q2.y),
        Vec3::new(q0.z, q1.z, q2.z),
    ];
    let s = scene.scales[i];
    let m0 = s * Vec3::new(cols[0].dot(j0), cols[1].dot(j0), cols[2].dot(j0));
    let m1 = s * Vec3::new(cols[0].dot(j1), cols[1].dot(j1), cols[2].dot(j1));
    // The footprint bound, before any square (see MAX_FOOTPRINT_SIGMA_PX); NaN fails it.
    let m_max = m0.abs().max(m1.abs()).max_element();
    let within = m_max <= crate::constants::MAX_FOOTPRINT_SIGMA_PX as f32;
    if !within {
        return Err(Skipped::Oversized);
    }
    let (aa, cc) = (m0.dot(m0), m1.dot(m1));
    let a = aa + 0.3;
    let b = m0.dot(m1);
    let c = cc + 0.3;
    // det = a c - b^2 by Lagrange's identity, without its cancellation (glsl/project_body.glsl).
    let m_cross = m0.cross(m1);
    let det = m_cross.dot(m_cross) + 0.3 * (aa + cc) + 0.09;
    if det <= 0.0 {
        return Err(Skipped::Degenerate);
    }
    let conic = Vec3::new(c, -b, a) / det;
    let mid = 0.5 * (a + c);
    let lambda = mid + (mid * mid - det).max(0.1).sqrt();
    let radius = (3.0 * lambda.sqrt()).ceil();
    let (cx, cy) = camera.principal_point();
    let uv = Vec2::new(fx * t.x / t.z + cx, fy * t.y / t.z + cy);
    let rect = tile_rect(uv, radius, tile_grid(camera));
    let [x0, y0, x1, y1] = rect;
    if x1 <= x0 || y1 <= y0 {
        return Err(Skipped::NoTile);
    }
    // Only tiles the visible footprint reaches (see footprint_touches_tile).
    let opacity = scene.opacities[i];
    let q_max = footprint_q_max(opacity);
    let reaches_a_tile = opacity >= 1.0 / 255.0
        && (y0..y1).any(|ty| (x0..x1).any(|tx| footprint_touches_tile(uv, conic, q_max, tx, ty)));
    if !reaches_a_tile {
        return Err(Skipped::NoTile);
    }
    let color = eval_sh(scene.sh_of(i), scene.sh_degree, rel.normalize());
    Ok(ProjectedSplat {
        index: i as u32,
        uv,
        depth: t.z,
        opacity: scene.opacities[i],
        conic,
        color,
        rect,
        cutoff: (class == Classification::Cutoff)
            .then(|| CutoffRay::new(mu, scene.scales[i], scene.rotations[i], camera.position)),
    })
}

/// How many Gaussians the footprint bound skips in this view (the GPU's
/// `FrameStats::oversized`).
pub fn count_oversized(scene: &Scene, camera: &Camera, clip: &Clip) -> usize {
    (0..scene.len())
        .filter(|&i| project_or_skip(scene, camera, clip, i) == Err(Skipped::Oversized))
        .count()
}

/// Bound on `q = A dx^2 + 2B dx dy + C dy^2` where a splat of opacity `o` still reaches alpha
/// 1/255: `q <= 2 ln(255 o)`, with a small margin against float rounding. Twin of
/// `footprint_q_max` in `glsl/common.glsl`.
pub fn footprint_q_max(opacity: f32) -> f32 {
    2.0 * (255.0 * opacity).ln() * 1.0001 + 1e-3
}

/// Whether the splat's visible footprint (`q <= q_max` around `uv`) reaches a pixel centre of
/// tile `(tx, ty)`. A tile of the SPEC's 3-sigma rectangle that it does not reach would skip
/// the splat at every pixel (alpha < 1/255), so the tile lists leave it out: fewer pairs to
/// sort and walk, the same image. Twin of `footprint_touches_tile` in `glsl/common.glsl`.
pub fn footprint_touches_tile(uv: Vec2, conic: Vec3, q_max: f32, tx: u32, ty: u32) -> bool {
    let corner = Vec2::new((tx * TILE_SIZE) as f32, (ty * TILE_SIZE) as f32);
    footprint_q_min_in_box(uv, conic, corner, (TILE_SIZE - 1) as f32) <= q_max
}

/// The minimum of `q(p - uv)` over the pixel centres of the square box whose first centre is
/// `corner` and that spans `span` pixels more each way. Twin of `footprint_q_min_in_box` in
/// `glsl/common.glsl`.
fn footprint_q_min_in_box(uv: Vec2, conic: Vec3, corner: Vec2, span: f32) -> f32 {
    let lo = corner - uv;
    let hi = lo + span;
    if lo.x <= 0.0 && hi.x >= 0.0 && lo.y <= 0.0 && hi.y >= 0.0 {
        return 0.0;
    }
    let q = |dx: f32, dy: f32| conic.x * dx * dx + 2.0 * conic.y * dx * dy + conic.z * dy * dy;
    let mut q_min = f32::INFINITY;
    for (dx, dy) in [(lo.x, lo.y), (hi.x, hi.y)] {
        // Edge x = dx: q is smallest at -B dx / C; edge y = dy: at -B dy / A.
        q_min = q_min.min(q(dx, (-conic.y * dx / conic.z).clamp(lo.y, hi.y)));
        q_min = q_min.min(q((-conic.y * dy / conic.x).clamp(lo.x, hi.x), dy));
    }
    q_min
}

/// The `d.x` that the ellipse `q(d) <= q_max` (`d = p - uv`) spans within the band of rows
/// `d.y` in `[lo_y, hi_y]`, widened against rounding; empty where the band misses it,
/// unbounded for a conic whose det has lost its digits. Twin of `footprint_x_range_in_band`
/// in `glsl/common.glsl` (the same operations; see there).
pub fn footprint_x_range_in_band(conic: Vec3, q_max: f32, lo_y: f32, hi_y: f32) -> (f32, f32) {
    let (a, b, c) = (conic.x, conic.y, conic.z);
    let det = a * c - b * b;
    let q = q_max.max(0.0);
    let b_s = b * (q / (det * c)).sqrt();
    let dy_extent = (q * a / det).sqrt() * 1.001 + 1e-3;
    let dy_right = (-b_s).clamp(lo_y, hi_y);
    let dy_left = b_s.clamp(lo_y, hi_y);
    let x_hi = ((a * q - det * dy_right * dy_right).max(0.0).sqrt() - b * dy_right) / a;
    let x_lo = (-(a * q - det * dy_left * dy_left).max(0.0).sqrt() - b * dy_left) / a;
    let pad = 1e-3 * (1.0 + x_hi - x_lo);
    let in_band = lo_y <= dy_extent && hi_y >= -dy_extent;
    let range = if in_band {
        (x_lo - pad, x_hi + pad)
    } else {
        (1e30, -1e30)
    };
    if det >= 1e-2 * a * c {
        range
    } else {
        (-1e30, 1e30)
    }
}

/// The block bits of the splat's pair in tile `(tx, ty)` ([`crate::constants::PAIR_BLOCKS_SHIFT`]):
/// which of the tile's four `BLOCK_SIZE` x `BLOCK_SIZE` blocks of pixel centres the visible
/// footprint reaches, a row of blocks at a time ([`footprint_x_range_in_band`]). Twin of
/// `footprint_blocks` in `glsl/common.glsl`.
pub fn footprint_blocks(uv: Vec2, conic: Vec3, q_max: f32, tx: u32, ty: u32) -> u32 {
    let span = (BLOCK_SIZE - 1) as f32;
    let mut bits = 0;
    for row in 0..2u32 {
        let lo_y = (ty * TILE_SIZE + row * BLOCK_SIZE) as f32 - uv.y;
        let (x_lo, x_hi) = footprint_x_range_in_band(conic, q_max, lo_y, lo_y + span);
        for column in 0..2u32 {
            let lo_x = (tx * TILE_SIZE + column * BLOCK_SIZE) as f32 - uv.x;
            if x_lo <= lo_x + span && x_hi >= lo_x {
                bits |= 1 << (PAIR_BLOCKS_SHIFT + row * 2 + column);
            }
        }
    }
    bits
}

/// Projects every Gaussian; the result holds only those that draw something, in index order.
pub fn project_all(scene: &Scene, camera: &Camera, clip: &Clip) -> Vec<ProjectedSplat> {
    (0..scene.len())
        .filter_map(|i| project_one(scene, camera, clip, i))
        .collect()
}

/// Tiles across and down for a camera's image.
pub fn tile_grid(camera: &Camera) -> (u32, u32) {
    crate::camera::tile_grid(camera.width, camera.height)
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A small deterministic generator (xorshift), for splats of every shape.
    struct Rng(u64);

    impl Rng {
        fn unit(&mut self) -> f32 {
            self.0 ^= self.0 << 13;
            self.0 ^= self.0 >> 7;
            self.0 ^= self.0 << 17;
            (self.0 >> 40) as f32 / (1u64 << 24) as f32
        }
    }

    /// The block bits (bands) hold every block with a pixel centre where the splat reaches
    /// alpha 1/255 and, for a conic whose det keeps its digits, none whose box the ellipse
    /// misses by more than rounding (against brute force over the pixel centres and the
    /// minimum of q over each box), and the tile test every tile with such a pixel centre: for
    /// round splats, needles at every angle (some past the det bound), and centres inside and
    /// outside the tile.
    #[test]
    fn footprint_blocks_and_tiles_hold_what_is_reached_and_little_else() {
        let mut rng = Rng(0x9e37_79b9_7f4a_7c15);
        let (tx, ty) = (3u32, 2u32);
        let origin = Vec2::new((tx * TILE_SIZE) as f32, (ty * TILE_SIZE) as f32);
        let mut loose = 0;
        let mut unconditioned = 0;
        for case in 0..20_000 {
            // A 2D covariance from two axis variances (0.3 px^2, the dilation's floor, up
            // to a 100-pixel sigma) and an angle, its conic the inverse.
            let s1 = 0.3 + rng.unit().powi(3) * 1e4;
            let s2 = 0.3 + rng.unit().powi(3) * 1e2;
            let angle = rng.unit() * std::f32::consts::PI;
            let (sin, cos) = angle.sin_cos();
            let (xx, xy, yy) = (
                s1 * cos * cos + s2 * sin * sin,
                (s1 - s2) * sin * cos,
                s1 * sin * sin + s2 * cos * cos,
            );
            let det = xx * yy - xy * xy;
            let conic = Vec3::new(yy / det, -xy / det, xx / det);
            let uv = origin + Vec2::new(rng.unit() * 64.0 - 24.0, rng.unit() * 64.0 - 24.0);
            let q_max = footprint_q_max(0.01 + rng.unit() * 0.99);
            let bits = footprint_blocks(uv, conic, q_max, tx, ty);
            let touches = footprint_touches_tile(uv, conic, q_max, tx, ty);
            let conditioned = conic.x * conic.z - conic.y * conic.y >= 1e-2 * conic.x * conic.z;
            unconditioned += !conditioned as u32;
            let q = |p: Vec2| {
                let d = p - uv;
                conic.x * d.x * d.x + 2.0 * conic.y * d.x * d.y + conic.z * d.y * d.y
            };
            for b in 0..4u32 {
                let corner = origin
                    + Vec2::new(
                        ((b & 1) * BLOCK_SIZE) as f32,
                        ((b >> 1) * BLOCK_SIZE) as f32,
                    );
                let set = bits & (1 << (PAIR_BLOCKS_SHIFT + b)) != 0;
                let pixel_min = (0..BLOCK_SIZE * BLOCK_SIZE)
                    .map(
                        |k| q(corner + Vec2::new((k % BLOCK_SIZE) as f32, (k / BLOCK_SIZE) as f32)),
                    )
                    .fold(f32::INFINITY, f32::min);
                assert!(
                    set || pixel_min > q_max,
                    "case {case}, block {b}: a pixel centre at q {pixel_min} <= {q_max} \
                     and no bit (uv {uv}, conic {conic})"
                );
                let box_min = footprint_q_min_in_box(uv, conic, corner, (BLOCK_SIZE - 1) as f32);
                if conditioned && set && box_min > q_max * 1.01 + 0.01 {
                    loose += 1;
                }
            }
            // The tile test, against brute force the same way.
            let reached = (0..TILE_SIZE * TILE_SIZE).any(|k| {
                q(origin + Vec2::new((k % TILE_SIZE) as f32, (k / TILE_SIZE) as f32)) <= q_max
            });
            assert!(
                touches || !reached,
                "case {case}: the tile holds a reached pixel centre (uv {uv}, conic {conic})"
            );
        }
        assert_eq!(loose, 0, "blocks set that the ellipse misses");
        assert!(
            (1000..10_000).contains(&unconditioned),
            "{unconditioned} of 20,000 past the det bound: the cases do not cover both sides"
        );
    }
}
