//! Octagon meshes of flat Gaussians (SPEC section 6, REdiSplats): each Gaussian becomes eight
//! vertices on its opacity-adaptive ellipse, the mesh can be edited or simulated by mesh tools,
//! and edited octagons turn back into Gaussians.
//!
//! - [`octagon`] gives a Gaussian's eight corners, [`fit_redisplats`] and [`fit_lsq`] turn
//!   corners back into a Gaussian;
//! - [`export`] writes every octagon of a scene as PLY, OBJ + MTL or glTF binary, streamed;
//! - [`import`] reads an edited mesh back and matches it to the original scene;
//! - [`sh_rotation`] turns a Gaussian's view-dependent colour with its face.
//!
//! Geometry is worked out in f64 and rounded once, when written.

pub mod export;
pub mod import;
pub mod sh_rotation;

use glam::{DMat3, DQuat, DVec3, Quat, Vec3};

use crate::scene::{flat_axis, in_plane_axes, smallest_axis, Scene};

/// The chi-square(3) 0.99 quantile: the octagon's squared radius for an opaque Gaussian.
pub const DEFAULT_Q: f64 = 11.3449;

/// Corners of an octagon.
pub const CORNERS: usize = 8;

/// Triangles of an octagon's fan `(0, k, k + 1)`, k = 1..6.
pub const FAN_TRIANGLES: usize = 6;

/// The octagon's radius in standard deviations, `rho = sqrt(max(0, Q + 2 ln o))`: its rim is
/// where the Gaussian's alpha `o exp(-rho^2/2)` falls to `exp(-Q/2)`.
pub fn octagon_radius(q: f64, opacity: f32) -> f64 {
    (q + 2.0 * (opacity as f64).ln()).max(0.0).sqrt()
}

/// `(cos, sin)` of corner k's angle `2 pi k / 8`, exact at the axes and diagonals.
pub fn corner_angle(k: usize) -> (f64, f64) {
    let h = std::f64::consts::FRAC_1_SQRT_2;
    [
        (1.0, 0.0),
        (h, h),
        (0.0, 1.0),
        (-h, h),
        (-1.0, 0.0),
        (-h, -h),
        (0.0, -1.0),
        (h, -h),
    ][k]
}

/// A flat Gaussian's frame: centre, normal, in-plane axes and their scales (SPEC section 6).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct FlatFrame {
    /// Centre `mu`.
    pub mean: DVec3,
    /// Normal `n = r_a x r_b`.
    pub normal: DVec3,
    /// First in-plane axis `r_a`.
    pub r_a: DVec3,
    /// Second in-plane axis `r_b`.
    pub r_b: DVec3,
    /// Standard deviation along `r_a`.
    pub s_a: f64,
    /// Standard deviation along `r_b`.
    pub s_b: f64,
}

impl FlatFrame {
    /// The frame of Gaussian `i`, flattened along its smallest axis if it is not flat.
    pub fn of(scene: &Scene, i: usize) -> FlatFrame {
        let scale = scene.scales[i];
        let axis = flat_axis(scale).unwrap_or_else(|| smallest_axis(scale));
        let (a, b) = in_plane_axes(axis);
        let r = DMat3::from_quat(scene.rotations[i].as_dquat().normalize());
        FlatFrame {
            mean: scene.means[i].as_dvec3(),
            normal: r.col(axis),
            r_a: r.col(a),
            r_b: r.col(b),
            s_a: scale[a] as f64,
            s_b: scale[b] as f64,
        }
    }

    /// Corner `k` of the octagon of radius `rho`: `mu + rho (s_a cos r_a + s_b sin r_b)`.
    pub fn corner(&self, rho: f64, k: usize) -> DVec3 {
        let (c, s) = corner_angle(k);
        self.mean + rho * (self.s_a * c * self.r_a + self.s_b * s * self.r_b)
    }

    /// In-plane coordinates `(a, b)` of a point (SPEC section 6).
    pub fn in_plane(&self, p: DVec3) -> (f64, f64) {
        let d = p - self.mean;
        (d.dot(self.r_a) / self.s_a, d.dot(self.r_b) / self.s_b)
    }

    /// The rotation `R = [n r_a r_b]` (REdiSplats: the normal is local x), its quaternion.
    pub fn rotation(&self) -> Quat {
        let m = DMat3::from_cols(self.normal, self.r_a, self.r_b);
        DQuat::from_mat3(&m).normalize().as_quat()
    }

    /// The Gaussian's scales in the REdiSplats convention: `(0, s_a, s_b)`.
    pub fn scales(&self) -> Vec3 {
        Vec3::new(0.0, self.s_a as f32, self.s_b as f32)
    }

    /// The covariance `s_a^2 r_a r_a^T + s_b^2 r_b r_b^T`.
    pub fn covariance(&self) -> DMat3 {
        let outer = |v: DVec3| DMat3::from_cols(v * v.x, v * v.y, v * v.z);
        self.s_a * self.s_a * outer(self.r_a) + self.s_b * self.s_b * outer(self.r_b)
    }
}

/// The octagon of Gaussian `i` with `Q = q`: its frame, radius and eight corners, or `None`
/// when `rho = 0` (no octagon).
pub fn octagon(scene: &Scene, i: usize, q: f64) -> Option<(FlatFrame, f64, [DVec3; CORNERS])> {
    let rho = octagon_radius(q, scene.opacities[i]);
    if rho <= 0.0 {
        return None;
    }
    let frame = FlatFrame::of(scene, i);
    Some((frame, rho, std::array::from_fn(|k| frame.corner(rho, k))))
}

/// Why corners cannot be turned back into a Gaussian.
#[derive(Clone, Debug, PartialEq)]
pub enum FitError {
    /// A corner is NaN or infinite.
    NonFinite,
    /// The corners do not span a plane (a collapsed or zero-area octagon).
    Degenerate,
}

impl std::fmt::Display for FitError {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        match self {
            FitError::NonFinite => write!(f, "a corner is not a finite number"),
            FitError::Degenerate => write!(f, "the corners do not span a plane (degenerate)"),
        }
    }
}

/// The REdiSplats rule of SPEC section 6, exactly: `m = (P_2 + P_6)/2`, `a = P_0 - m`,
/// `b = P_2 - m`, `r_a = a/|a|`, `n = normalize(r_a x b)`, `r_b = normalize(b - (b.r_a) r_a)`,
/// `s_a = |a|/rho`, `s_b = (b.r_b)/rho`.
pub fn fit_redisplats(p: &[DVec3; CORNERS], rho: f64) -> Result<FlatFrame, FitError> {
    if !p.iter().all(|v| v.is_finite()) {
        return Err(FitError::NonFinite);
    }
    let m = 0.5 * (p[2] + p[6]);
    let a = p[0] - m;
    let b = p[2] - m;
    let a_len = a.length();
    let r_a = a / a_len;
    let n = r_a.cross(b);
    let b_perp = b - b.dot(r_a) * r_a;
    let scale = a_len.max(b.length());
    if !(a_len > 0.0 && n.length() > 1e-12 * scale && b_perp.length() > 1e-12 * scale) {
        return Err(FitError::Degenerate);
    }
    let r_b = b_perp.normalize();
    Ok(FlatFrame {
        mean: m,
        normal: n.normalize(),
        r_a,
        r_b,
        s_a: a_len / rho,
        s_b: b.dot(r_b) / rho,
    })
}

/// The least-squares fit over all eight corners: the centroid, the in-plane axes and scales
/// from the corners' covariance (`sum_k d_k d_k^T = 4 rho^2 (s_a^2 r_a r_a^T + s_b^2 r_b r_b^T)`
/// for an exact octagon), signs aligned to corners 0 and 2. Robust where an edit moved
/// corners unevenly.
pub fn fit_lsq(p: &[DVec3; CORNERS], rho: f64) -> Result<FlatFrame, FitError> {
    if !p.iter().all(|v| v.is_finite()) {
        return Err(FitError::NonFinite);
    }
    let c = p.iter().copied().sum::<DVec3>() / CORNERS as f64;
    let mut cov = DMat3::ZERO;
    for v in p {
        let d = *v - c;
        cov += DMat3::from_cols(d * d.x, d * d.y, d * d.z);
    }
    let (values, vectors) = symmetric_eigen(cov);
    // values ascending: 0 is the normal, 1 and 2 span the plane.
    let scale = values[2].abs().max(f64::MIN_POSITIVE);
    // Written so that NaN counts as degenerate.
    if values[1].partial_cmp(&(1e-18 * scale)) != Some(std::cmp::Ordering::Greater) {
        return Err(FitError::Degenerate);
    }
    let d0 = p[0] - c;
    let (u, w) = (vectors[1], vectors[2]);
    // r_a: the in-plane axis most along corner 0; r_b the other, towards corner 2.
    let (mut r_a, mut r_b, mut l_a, mut l_b) = if d0.dot(u).abs() >= d0.dot(w).abs() {
        (u, w, values[1], values[2])
    } else {
        (w, u, values[2], values[1])
    };
    if d0.dot(r_a) < 0.0 {
        r_a = -r_a;
    }
    if (p[2] - c).dot(r_b) < 0.0 {
        r_b = -r_b;
    }
    l_a = l_a.max(0.0);
    l_b = l_b.max(0.0);
    let norm = 2.0 * rho;
    Ok(FlatFrame {
        mean: c,
        normal: r_a.cross(r_b).normalize(),
        r_a,
        r_b,
        s_a: l_a.sqrt() / norm,
        s_b: l_b.sqrt() / norm,
    })
}

/// Eigenvalues (ascending) and unit eigenvectors of a symmetric 3x3 matrix, by cyclic Jacobi
/// rotations (converges to machine precision in a handful of sweeps).
pub fn symmetric_eigen(m: DMat3) -> ([f64; 3], [DVec3; 3]) {
    let mut a = m.to_cols_array_2d(); // a[col][row]; symmetric, so a[i][j] = a[j][i]
    let mut v = DMat3::IDENTITY.to_cols_array_2d();
    for _ in 0..50 {
        let off = a[0][1].powi(2) + a[0][2].powi(2) + a[1][2].powi(2);
        let diag = a[0][0].powi(2) + a[1][1].powi(2) + a[2][2].powi(2);
        if off <= 1e-30 * diag || off == 0.0 {
            break;
        }
        for (p, q) in [(0, 1), (0, 2), (1, 2)] {
            if a[p][q] == 0.0 {
                continue;
            }
            let theta = (a[q][q] - a[p][p]) / (2.0 * a[p][q]);
            let t = theta.signum() / (theta.abs() + (theta * theta + 1.0).sqrt());
            let t = if theta == 0.0 { 1.0 } else { t };
            let c = 1.0 / (t * t + 1.0).sqrt();
            let s = t * c;
            // A <- J^T A J with J the rotation in the (p, q) plane.
            for row in &mut a {
                let (akp, akq) = (row[p], row[q]);
                row[p] = c * akp - s * akq;
                row[q] = s * akp + c * akq;
            }
            let (row_p, row_q) = (a[p], a[q]);
            for k in 0..3 {
                a[p][k] = c * row_p[k] - s * row_q[k];
                a[q][k] = s * row_p[k] + c * row_q[k];
            }
            for row in &mut v {
                let (vp, vq) = (row[p], row[q]);
                row[p] = c * vp - s * vq;
                row[q] = s * vp + c * vq;
            }
        }
    }
    // v[i][k] is row i, column k of V; eigenvector k is V's column k, (v[0][k], v[1][k],
    // v[2][k]), which is row k of the matrix whose columns are v's rows.
    let vm = DMat3::from_cols_array_2d(&v);
    let mut pairs: Vec<(f64, DVec3)> = (0..3).map(|k| (a[k][k], vm.row(k))).collect();
    pairs.sort_by(|x, y| x.0.total_cmp(&y.0));
    (
        [pairs[0].0, pairs[1].0, pairs[2].0],
        [
            pairs[0].1.normalize(),
            pairs[1].1.normalize(),
            pairs[2].1.normalize(),
        ],
    )
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn eigen_of_a_rotated_diagonal() {
        let r = DMat3::from_quat(DQuat::from_euler(glam::EulerRot::XYZ, 0.3, -0.7, 1.1));
        let d = DMat3::from_diagonal(DVec3::new(4.0, 0.5, 2.0));
        let (values, vectors) = symmetric_eigen(r * d * r.transpose());
        assert!((values[0] - 0.5).abs() < 1e-12 && (values[2] - 4.0).abs() < 1e-12);
        assert!((vectors[0].dot(r.col(1)).abs() - 1.0).abs() < 1e-12);
        assert!((vectors[2].dot(r.col(0)).abs() - 1.0).abs() < 1e-12);
    }
}
