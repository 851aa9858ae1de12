//! Several splat objects in one frame (SPEC section 9): each a scene with a rigid transform and
//! a uniform scale, transformed on the GPU (`glsl/object_transform.comp`) into one merged scene
//! that the frame then sorts and composites as one, exactly as the merged, pre-transformed scene
//! would be. [`ObjectTransform::apply`] is the CPU twin, in the same f32 operations, so the two
//! agree bit for bit.
//!
//! The SH coefficients turn with the object: for a rotation `R`, the object's colour seen along
//! world direction `d` is its SH evaluated at `R^T d`, which equals rotated coefficients
//! `c' = D c` evaluated at `d`, band by band. `D` is computed here in f64, against the very
//! basis functions the renderer evaluates (SPEC section 3's, signs included), by least squares
//! over 64 fixed directions, then rounded to f32 for both sides.

use glam::{DMat3, DVec3, Quat, Vec3};

use crate::error::{Error, Result};
use crate::scene::{sh_coeffs, Scene};

/// The f32 values of an object's SH rotation: the band-1, band-2 and band-3 matrices, row major
/// (9 + 25 + 49).
pub const SH_ROTATION_FLOATS: usize = 83;

/// Where an object stands in the world: `world = translation + scale * rotation * local`.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct ObjectTransform {
    /// The rotation (normalised when used).
    pub rotation: Quat,
    /// The translation.
    pub translation: Vec3,
    /// The uniform scale, > 0.
    pub scale: f32,
}

impl Default for ObjectTransform {
    fn default() -> Self {
        ObjectTransform {
            rotation: Quat::IDENTITY,
            translation: Vec3::ZERO,
            scale: 1.0,
        }
    }
}

/// The product `r q` of two quaternions, written out term by term in the order the GPU kernel
/// evaluates it (no fused operations on either side).
pub fn quat_product(r: Quat, q: Quat) -> Quat {
    let w = r.w * q.w - r.x * q.x - r.y * q.y - r.z * q.z;
    let x = r.w * q.x + r.x * q.w + r.y * q.z - r.z * q.y;
    let y = r.w * q.y - r.x * q.z + r.y * q.w + r.z * q.x;
    let z = r.w * q.z + r.x * q.y - r.y * q.x + r.z * q.w;
    Quat::from_xyzw(x, y, z, w)
}

/// The SH basis functions of bands 1 to 3 at `d`, as the renderer weights the coefficients
/// (SPEC section 3, INRIA order and signs), in f64.
fn sh_basis(d: DVec3) -> [f64; 15] {
    const C1: f64 = 0.4886025119029199;
    const C2: [f64; 5] = [
        1.0925484305920792,
        -1.0925484305920792,
        0.31539156525252005,
        -1.0925484305920792,
        0.5462742152960396,
    ];
    const C3: [f64; 7] = [
        -0.5900435899266435,
        2.890611442640554,
        -0.4570457994644658,
        0.3731763325901154,
        -0.4570457994644658,
        1.445305721320277,
        -0.5900435899266435,
    ];
    let (x, y, z) = (d.x, d.y, d.z);
    let (xx, yy, zz) = (x * x, y * y, z * z);
    [
        -C1 * y,
        C1 * z,
        -C1 * x,
        C2[0] * x * y,
        C2[1] * y * z,
        C2[2] * (2.0 * zz - xx - yy),
        C2[3] * x * z,
        C2[4] * (xx - yy),
        C3[0] * y * (3.0 * xx - yy),
        C3[1] * x * y * z,
        C3[2] * y * (4.0 * zz - xx - yy),
        C3[3] * z * (2.0 * zz - 3.0 * xx - 3.0 * yy),
        C3[4] * x * (4.0 * zz - xx - yy),
        C3[5] * z * (xx - yy),
        C3[6] * x * (xx - 3.0 * yy),
    ]
}

/// Solves `m x = b` for a small dense system (Gaussian elimination with partial pivoting).
fn solve(mut m: Vec<Vec<f64>>, mut b: Vec<f64>) -> Vec<f64> {
    let n = b.len();
    for col in 0..n {
        let pivot = (col..n)
            .max_by(|&i, &j| m[i][col].abs().total_cmp(&m[j][col].abs()))
            .unwrap();
        m.swap(col, pivot);
        b.swap(col, pivot);
        for row in col + 1..n {
            let f = m[row][col] / m[col][col];
            let pivot_row = m[col].clone();
            for (x, p) in m[row][col..].iter_mut().zip(&pivot_row[col..]) {
                *x -= f * p;
            }
            b[row] -= f * b[col];
        }
    }
    let mut x = vec![0.0; n];
    for row in (0..n).rev() {
        let s: f64 = (row + 1..n).map(|k| m[row][k] * x[k]).sum();
        x[row] = (b[row] - s) / m[row][row];
    }
    x
}

impl ObjectTransform {
    /// Checks the transform.
    pub fn validate(&self) -> Result<()> {
        let q = self.rotation;
        if !(self.scale.is_finite()
            && self.scale > 0.0
            && self.translation.is_finite()
            && q.is_finite()
            && q.length_squared() > 0.0)
        {
            return Err(Error::InvalidInput(format!(
                "object transform: rotation {q}, translation {}, scale {} (need a non-zero \
                 finite rotation, a finite translation and a scale > 0)",
                self.translation, self.scale
            )));
        }
        Ok(())
    }

    /// The normalised rotation.
    pub fn unit_rotation(&self) -> Quat {
        self.rotation.normalize()
    }

    /// The rotation as a matrix, rows first (what the GPU kernel multiplies centres by).
    pub fn rotation_rows(&self) -> [[f32; 3]; 3] {
        let m = glam::Mat3::from_quat(self.unit_rotation()).transpose();
        [
            m.x_axis.to_array(),
            m.y_axis.to_array(),
            m.z_axis.to_array(),
        ]
    }

    /// The SH rotation of bands 1 to 3 ([`SH_ROTATION_FLOATS`] values): `D` such that the
    /// coefficients `D c` seen along `d` give what `c` gives along `R^T d`.
    pub fn sh_rotation(&self) -> [f32; SH_ROTATION_FLOATS] {
        let r = DMat3::from_quat(self.unit_rotation().as_dquat());
        // 64 fixed directions spread over the sphere (a Fibonacci lattice).
        let dirs: Vec<DVec3> = (0..64)
            .map(|i| {
                let z = 1.0 - (2 * i + 1) as f64 / 64.0;
                let rho = (1.0 - z * z).sqrt();
                let phi = i as f64 * std::f64::consts::PI * (3.0 - 5f64.sqrt());
                DVec3::new(rho * phi.cos(), rho * phi.sin(), z)
            })
            .collect();
        let mut out = [0f32; SH_ROTATION_FLOATS];
        let mut at = 0;
        for (first, n) in [(0usize, 3usize), (3, 5), (8, 7)] {
            // A[i][m] = B_m(d_i), T[i][k] = B_k(R^T d_i); D = (A^T A)^-1 A^T T.
            let a: Vec<Vec<f64>> = dirs
                .iter()
                .map(|&d| sh_basis(d)[first..first + n].to_vec())
                .collect();
            let t: Vec<Vec<f64>> = dirs
                .iter()
                .map(|&d| sh_basis(r.transpose() * d)[first..first + n].to_vec())
                .collect();
            let ata: Vec<Vec<f64>> = (0..n)
                .map(|i| {
                    (0..n)
                        .map(|j| a.iter().map(|row| row[i] * row[j]).sum())
                        .collect()
                })
                .collect();
            for k in 0..n {
                let rhs: Vec<f64> = (0..n)
                    .map(|i| a.iter().zip(&t).map(|(ar, tr)| ar[i] * tr[k]).sum())
                    .collect();
                let column = solve(ata.clone(), rhs);
                for (m, v) in column.into_iter().enumerate() {
                    out[at + m * n + k] = v as f32;
                }
            }
            at += n * n;
        }
        out
    }

    /// `scene` transformed, as the GPU transforms an object (the CPU twin, the same f32
    /// operations in the same order): centres `t + s (R x)`, rotations `r q`, scales `s x`, the
    /// SH of bands 1 to 3 multiplied by [`ObjectTransform::sh_rotation`]; opacities kept.
    pub fn apply(&self, scene: &Scene) -> Scene {
        let rows = self.rotation_rows();
        let r = self.unit_rotation();
        let d = self.sh_rotation();
        let (s, t) = (self.scale, self.translation);
        let per_channel = sh_coeffs(scene.sh_degree);
        let mut out = scene.clone();
        for i in 0..scene.len() {
            let m = scene.means[i];
            let rx = rows[0][0] * m.x + rows[0][1] * m.y + rows[0][2] * m.z;
            let ry = rows[1][0] * m.x + rows[1][1] * m.y + rows[1][2] * m.z;
            let rz = rows[2][0] * m.x + rows[2][1] * m.y + rows[2][2] * m.z;
            out.means[i] = Vec3::new(s * rx + t.x, s * ry + t.y, s * rz + t.z);
            out.rotations[i] = quat_product(r, scene.rotations[i]);
            out.scales[i] = Vec3::new(
                s * scene.scales[i].x,
                s * scene.scales[i].y,
                s * scene.scales[i].z,
            );
            let src = scene.sh_of(i);
            let dst = &mut out.sh[i * 3 * per_channel..(i + 1) * 3 * per_channel];
            for (first, n, at) in [(1usize, 3usize, 0usize), (4, 5, 9), (9, 7, 34)] {
                if first + n > per_channel {
                    break;
                }
                for c in 0..3 {
                    for row in 0..n {
                        let mut v = 0.0f32;
                        for k in 0..n {
                            v += d[at + row * n + k] * src[3 * (first + k) + c];
                        }
                        dst[3 * (first + row) + c] = v;
                    }
                }
            }
        }
        out
    }
}

/// The objects merged into one scene of the largest SH degree among them (the CPU twin of the
/// GPU's merge: lower degrees padded with zeros), in order.
pub fn merge(objects: &[(&Scene, ObjectTransform)]) -> Scene {
    let degree = objects.iter().map(|(s, _)| s.sh_degree).max().unwrap_or(0);
    let per_channel = sh_coeffs(degree);
    let mut merged = Scene {
        sh_degree: degree,
        ..Scene::default()
    };
    for (scene, transform) in objects {
        let t = transform.apply(scene);
        let mine = sh_coeffs(t.sh_degree);
        for i in 0..t.len() {
            let mut sh = vec![0f32; 3 * per_channel];
            sh[..3 * mine].copy_from_slice(t.sh_of(i));
            merged.means.push(t.means[i]);
            merged.opacities.push(t.opacities[i]);
            merged.scales.push(t.scales[i]);
            merged.rotations.push(t.rotations[i]);
            merged.sh.extend_from_slice(&sh);
        }
    }
    merged
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Rotated coefficients seen along `d` give what the original ones give along `R^T d`.
    #[test]
    fn sh_rotation_turns_the_colour_with_the_object() {
        let t = ObjectTransform {
            rotation: Quat::from_euler(glam::EulerRot::XYZ, 0.3, -1.1, 2.0),
            ..ObjectTransform::default()
        };
        let mut rng = crate::synth::Rng::new(4);
        let mut scene = Scene {
            sh_degree: 3,
            ..Scene::default()
        };
        let sh: Vec<f32> = (0..48).map(|_| rng.range(-1.0, 1.0)).collect();
        scene.push(Vec3::ZERO, 0.5, Vec3::ONE, Quat::IDENTITY, &sh);
        let turned = t.apply(&scene);
        let r = glam::Mat3::from_quat(t.unit_rotation());
        for k in 0..20 {
            let d = rng.unit_vector();
            let want = crate::reference::project::eval_sh(scene.sh_of(0), 3, r.transpose() * d);
            let got = crate::reference::project::eval_sh(turned.sh_of(0), 3, d);
            assert!((want - got).abs().max_element() < 1e-5, "{k}: {want} {got}");
        }
    }
}
