//! Rotating a Gaussian's spherical harmonics with its surface (`rara mesh import --rotate-sh`).
//!
//! A Gaussian turned by `R` should show, towards direction `d`, the colour it showed towards
//! `R^T d`. Each SH band `l` is closed under rotation, so its coefficients map linearly,
//! `x' = M_l(R) x`. `M_l` is found by sampling: with `B` the band's basis (in the INRIA term
//! order and signs of SPEC section 3) at fixed directions `d_i` and `B_R` the basis at
//! `R^T d_i`, `B M = B_R`, solved once in the least-squares sense: `M = P B_R` with the
//! pseudo-inverse `P = (B^T B)^-1 B^T` worked out once per band. The DC term (band 0) does
//! not turn.

use std::sync::OnceLock;

use glam::{DMat3, DVec3};

use crate::sh::{SH_C1, SH_C2, SH_C3};

/// Sample directions for the fit (more than the 7 unknowns of band 3, well spread).
const SAMPLES: usize = 32;

/// The basis functions of band `l` (1..=3) at unit direction `d`, as eval_sh weighs the
/// coefficients (first `2l + 1` entries used).
fn band_basis(l: usize, d: DVec3) -> [f64; 7] {
    let (x, y, z) = (d.x, d.y, d.z);
    let (c1, c2, c3) = (SH_C1 as f64, SH_C2.map(f64::from), SH_C3.map(f64::from));
    let (xx, yy, zz) = (x * x, y * y, z * z);
    match l {
        1 => [-c1 * y, c1 * z, -c1 * x, 0.0, 0.0, 0.0, 0.0],
        2 => [
            c2[0] * x * y,
            c2[1] * y * z,
            c2[2] * (2.0 * zz - xx - yy),
            c2[3] * x * z,
            c2[4] * (xx - yy),
            0.0,
            0.0,
        ],
        3 => [
            c3[0] * y * (3.0 * xx - yy),
            c3[1] * x * y * z,
            c3[2] * y * (4.0 * zz - xx - yy),
            c3[3] * z * (2.0 * zz - 3.0 * xx - 3.0 * yy),
            c3[4] * x * (4.0 * zz - xx - yy),
            c3[5] * z * (xx - yy),
            c3[6] * x * (xx - 3.0 * yy),
        ],
        _ => unreachable!("SH bands 1-3"),
    }
}

/// Directions on a Fibonacci sphere.
fn sample_directions() -> [DVec3; SAMPLES] {
    let golden = std::f64::consts::PI * (3.0 - 5f64.sqrt());
    std::array::from_fn(|i| {
        let z = 1.0 - 2.0 * (i as f64 + 0.5) / SAMPLES as f64;
        let r = (1.0 - z * z).sqrt();
        let phi = golden * i as f64;
        DVec3::new(r * phi.cos(), r * phi.sin(), z)
    })
}

/// Per band, the pseudo-inverse `P = (B^T B)^-1 B^T` ((2l+1) x SAMPLES, row-major).
fn pseudo_inverses() -> &'static [Vec<f64>; 3] {
    static P: OnceLock<[Vec<f64>; 3]> = OnceLock::new();
    P.get_or_init(|| {
        let dirs = sample_directions();
        std::array::from_fn(|band| {
            let l = band + 1;
            let n = 2 * l + 1;
            let b: Vec<[f64; 7]> = dirs.iter().map(|&d| band_basis(l, d)).collect();
            // Normal matrix B^T B (n x n), inverted by Gauss-Jordan with partial pivoting.
            let mut a = vec![0.0; n * 2 * n];
            for i in 0..n {
                for j in 0..n {
                    a[i * 2 * n + j] = b.iter().map(|row| row[i] * row[j]).sum();
                }
                a[i * 2 * n + n + i] = 1.0;
            }
            for col in 0..n {
                let pivot = (col..n)
                    .max_by(|&r, &s| {
                        a[r * 2 * n + col]
                            .abs()
                            .total_cmp(&a[s * 2 * n + col].abs())
                    })
                    .unwrap();
                for k in 0..2 * n {
                    a.swap(col * 2 * n + k, pivot * 2 * n + k);
                }
                let p = a[col * 2 * n + col];
                for k in 0..2 * n {
                    a[col * 2 * n + k] /= p;
                }
                for r in 0..n {
                    if r != col {
                        let f = a[r * 2 * n + col];
                        for k in 0..2 * n {
                            a[r * 2 * n + k] -= f * a[col * 2 * n + k];
                        }
                    }
                }
            }
            let mut p = vec![0.0; n * SAMPLES];
            for i in 0..n {
                for (s, row) in b.iter().enumerate() {
                    p[i * SAMPLES + s] = (0..n).map(|j| a[i * 2 * n + n + j] * row[j]).sum();
                }
            }
            p
        })
    })
}

/// Rotates the SH coefficients `sh` (coefficient-major, 3 channels, degree `degree`) of a
/// Gaussian turned by `rotation`, in place: afterwards its colour towards `d` is the colour it
/// had towards `rotation^T d`.
pub fn rotate_sh(sh: &mut [f32], degree: u32, rotation: DMat3) {
    ShRotation::new(degree, rotation).apply(sh);
}

/// The per-band matrices that turn SH coefficients by one rotation ([`rotate_sh`]), made once
/// for every Gaussian an object turns by the same rotation.
pub struct ShRotation {
    degree: u32,
    /// Band l's `(2l + 1) x (2l + 1)` matrix at `bands[l - 1]`.
    bands: Vec<[[f64; 7]; 7]>,
}

impl ShRotation {
    /// The matrices of `rotation` for SH of degree `degree` (bands above 3 are not turned).
    pub fn new(degree: u32, rotation: DMat3) -> ShRotation {
        let dirs = sample_directions();
        let inverse = rotation.transpose();
        let p = pseudo_inverses();
        let mut bands = Vec::new();
        for l in 1..=degree.min(3) as usize {
            let n = 2 * l + 1;
            let b_rot: Vec<[f64; 7]> = dirs.iter().map(|&d| band_basis(l, inverse * d)).collect();
            // M = P B_R (n x n): M[i][j] = sum_s P[i][s] B_R[s][j].
            let mut m = [[0.0f64; 7]; 7];
            for (i, row) in m.iter_mut().enumerate().take(n) {
                for (j, v) in row.iter_mut().enumerate().take(n) {
                    *v = (0..SAMPLES)
                        .map(|s| p[l - 1][i * SAMPLES + s] * b_rot[s][j])
                        .sum();
                }
            }
            bands.push(m);
        }
        ShRotation { degree, bands }
    }

    /// Band `l`'s matrix (1 to the degree, at most 3): `(2l + 1) x (2l + 1)` entries of the
    /// 7 x 7 array, rows first.
    pub fn band(&self, l: usize) -> &[[f64; 7]; 7] {
        &self.bands[l - 1]
    }

    /// Turns one Gaussian's coefficients in place.
    pub fn apply(&self, sh: &mut [f32]) {
        for l in 1..=self.degree.min(3) as usize {
            let n = 2 * l + 1;
            let first = l * l; // coefficients before band l
            let m = &self.bands[l - 1];
            for c in 0..3 {
                let x: Vec<f64> = (0..n).map(|j| sh[3 * (first + j) + c] as f64).collect();
                for (i, row) in m.iter().enumerate().take(n) {
                    sh[3 * (first + i) + c] = (0..n).map(|j| row[j] * x[j]).sum::<f64>() as f32;
                }
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::sh::eval_sh;
    use glam::DQuat;

    /// The rotated coefficients show towards d what the originals showed towards R^T d.
    #[test]
    fn rotated_sh_turns_the_colour() {
        let mut rng = crate::synth::Rng::new(4);
        let sh: Vec<f32> = (0..48).map(|_| rng.range(-0.5, 0.5)).collect();
        let r = DMat3::from_quat(DQuat::from_euler(glam::EulerRot::YXZ, 0.7, -0.4, 1.9));
        let mut turned = sh.clone();
        rotate_sh(&mut turned, 3, r);
        for _ in 0..50 {
            let d = rng.unit_vector();
            let back = (r.transpose() * d.as_dvec3()).as_vec3();
            let want = eval_sh(&sh, 3, back);
            let got = eval_sh(&turned, 3, d);
            assert!((want - got).abs().max_element() < 1e-5, "{want} {got}");
        }
        // The identity changes nothing; the DC term never changes.
        let mut same = sh.clone();
        rotate_sh(&mut same, 3, DMat3::IDENTITY);
        assert!(same.iter().zip(&sh).all(|(a, b)| (a - b).abs() < 1e-6));
        assert_eq!(&turned[..3], &sh[..3]);
    }
}
