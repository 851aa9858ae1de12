//! Spherical harmonics: the colour of a Gaussian seen from a direction (SPEC section 3), with
//! the 3DGS reference's constants. Shared by the scene model (the DC term's colour), the mesh
//! exporters, the SH rotation of moved objects and the CPU reference renderers; the GPU's
//! twin is `glsl/sh.glsl`.

use glam::Vec3;

/// SH constant of degree 0.
pub const SH_C0: f32 = 0.282_094_8;
/// SH constant of degree 1.
pub const SH_C1: f32 = 0.488_602_5;
/// SH constants of degree 2.
pub const SH_C2: [f32; 5] = [
    1.092_548_4,
    -1.092_548_4,
    0.315_391_57,
    -1.092_548_4,
    0.546_274_2,
];
/// SH constants of degree 3.
pub const SH_C3: [f32; 7] = [
    -0.590_043_6,
    2.890_611_4,
    -0.457_045_8,
    0.373_176_34,
    -0.457_045_8,
    1.445_305_7,
    -0.590_043_6,
];

/// Colour of SH coefficients `sh` (coefficient major) seen along unit `dir`.
pub fn eval_sh(sh: &[f32], degree: u32, dir: Vec3) -> Vec3 {
    let c = |k: usize| Vec3::new(sh[3 * k], sh[3 * k + 1], sh[3 * k + 2]);
    let mut result = SH_C0 * c(0);
    if degree > 0 {
        let (x, y, z) = (dir.x, dir.y, dir.z);
        result = result - SH_C1 * y * c(1) + SH_C1 * z * c(2) - SH_C1 * x * c(3);
        if degree > 1 {
            let (xx, yy, zz) = (x * x, y * y, z * z);
            let (xy, yz, xz) = (x * y, y * z, x * z);
            result = result
                + SH_C2[0] * xy * c(4)
                + SH_C2[1] * yz * c(5)
                + SH_C2[2] * (2.0 * zz - xx - yy) * c(6)
                + SH_C2[3] * xz * c(7)
                + SH_C2[4] * (xx - yy) * c(8);
            if degree > 2 {
                result = result
                    + SH_C3[0] * y * (3.0 * xx - yy) * c(9)
                    + SH_C3[1] * xy * z * c(10)
                    + SH_C3[2] * y * (4.0 * zz - xx - yy) * c(11)
                    + SH_C3[3] * z * (2.0 * zz - 3.0 * xx - 3.0 * yy) * c(12)
                    + SH_C3[4] * x * (4.0 * zz - xx - yy) * c(13)
                    + SH_C3[5] * z * (xx - yy) * c(14)
                    + SH_C3[6] * x * (xx - 3.0 * yy) * c(15);
            }
        }
    }
    (result + 0.5).max(Vec3::ZERO)
}
