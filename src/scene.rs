//! A 3D Gaussian Splatting scene in memory, with activated values (SPEC section 1).

use glam::{Quat, Vec3};

/// Gaussians as structure-of-arrays, with the activations already applied: opacity is
/// `sigmoid(opacity)`, scales are `exp(scale_i)`, rotations are normalised.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct Scene {
    /// Centres (world).
    pub means: Vec<Vec3>,
    /// Opacities in (0, 1).
    pub opacities: Vec<f32>,
    /// Standard deviations along the local axes.
    pub scales: Vec<Vec3>,
    /// Normalised rotations (local to world).
    pub rotations: Vec<Quat>,
    /// Spherical-harmonics degree, 0..=3.
    pub sh_degree: u32,
    /// SH coefficients, [`Scene::sh_coeffs_per_channel`] x 3 floats per Gaussian, coefficient
    /// major: `sh[g * stride + 3 * k + channel]`. Coefficient 0 is `f_dc`.
    pub sh: Vec<f32>,
}

impl Scene {
    /// Number of Gaussians.
    pub fn len(&self) -> usize {
        self.means.len()
    }

    /// Whether the scene has no Gaussian.
    pub fn is_empty(&self) -> bool {
        self.means.is_empty()
    }

    /// SH coefficients per colour channel: `(degree + 1)^2`.
    pub fn sh_coeffs_per_channel(&self) -> usize {
        sh_coeffs(self.sh_degree)
    }

    /// Floats of SH per Gaussian: `3 (degree + 1)^2`.
    pub fn sh_stride(&self) -> usize {
        3 * self.sh_coeffs_per_channel()
    }

    /// The SH coefficients of Gaussian `i`.
    pub fn sh_of(&self, i: usize) -> &[f32] {
        let s = self.sh_stride();
        &self.sh[i * s..(i + 1) * s]
    }

    /// Axis-aligned bounds of the centres, `None` for an empty scene.
    pub fn bounds(&self) -> Option<(Vec3, Vec3)> {
        let first = *self.means.first()?;
        Some(
            self.means
                .iter()
                .fold((first, first), |(lo, hi), &m| (lo.min(m), hi.max(m))),
        )
    }

    /// How many Gaussians are flat (one scale exactly 0; SPEC section 6).
    pub fn flat_count(&self) -> usize {
        self.scales
            .iter()
            .filter(|s| flat_axis(**s).is_some())
            .count()
    }

    /// The scene flattened (SPEC section 6): each Gaussian's smallest scale set to 0, the rest
    /// kept. Already-flat Gaussians are unchanged.
    pub fn flattened(&self) -> Scene {
        let mut flat = self.clone();
        for s in &mut flat.scales {
            let k = smallest_axis(*s);
            s[k] = 0.0;
        }
        flat
    }

    /// The scene at SH degree `degree`: the bands above it dropped, or new bands of zeros.
    pub fn with_sh_degree(self, degree: u32) -> Scene {
        if self.sh_degree == degree {
            return self;
        }
        let (from, to) = (self.sh_stride(), 3 * sh_coeffs(degree));
        let keep = from.min(to);
        let mut sh = vec![0.0; self.len() * to];
        for g in 0..self.len() {
            sh[g * to..g * to + keep].copy_from_slice(&self.sh[g * from..g * from + keep]);
        }
        Scene {
            sh_degree: degree,
            sh,
            ..self
        }
    }

    /// Appends one Gaussian (`sh` holds [`Scene::sh_stride`] floats).
    pub fn push(&mut self, mean: Vec3, opacity: f32, scale: Vec3, rotation: Quat, sh: &[f32]) {
        debug_assert_eq!(sh.len(), self.sh_stride());
        self.means.push(mean);
        self.opacities.push(opacity);
        self.scales.push(scale);
        self.rotations.push(rotation);
        self.sh.extend_from_slice(sh);
    }
}

/// `q` scaled to unit length, or `None` when its length is zero or not finite. Normalised in
/// f64: in f32 the squared length of a tiny or huge (but finite) quaternion underflows or
/// overflows, which fuzzing turned up as "normalised" rotations of length 1.003.
pub fn normalized_rotation(q: Quat) -> Option<Quat> {
    let q64 = [q.x, q.y, q.z, q.w].map(f64::from);
    let length = q64.iter().map(|c| c * c).sum::<f64>().sqrt();
    if !(length.is_finite() && length > 0.0) {
        return None;
    }
    let [x, y, z, w] = q64.map(|c| (c / length) as f32);
    Some(Quat::from_xyzw(x, y, z, w))
}

/// Below this ratio of its smallest to its largest scale, a Gaussian read from a 3-scale PLY
/// is flat along its smallest axis (SPEC section 6; REdiSplats writes `scale_0 = ln 1e-5`).
pub const FLAT_SCALE_RATIO: f32 = 1e-4;

/// The axis of a flat Gaussian's normal: the first whose scale is exactly 0, or `None` for a
/// Gaussian with three nonzero scales.
pub fn flat_axis(scale: Vec3) -> Option<usize> {
    (0..3).find(|&k| scale[k] == 0.0)
}

/// The axis of the smallest scale (the first of equal ones).
pub fn smallest_axis(scale: Vec3) -> usize {
    let mut k = 0;
    for j in 1..3 {
        if scale[j] < scale[k] {
            k = j;
        }
    }
    k
}

/// The two in-plane axes of a Gaussian flat along `axis`: the ones after it in the cyclic
/// order x, y, z, so that `r_a x r_b = n` (SPEC section 6).
pub fn in_plane_axes(axis: usize) -> (usize, usize) {
    ((axis + 1) % 3, (axis + 2) % 3)
}

/// SH coefficients per channel for a degree: `(degree + 1)^2`.
pub fn sh_coeffs(degree: u32) -> usize {
    ((degree + 1) * (degree + 1)) as usize
}

/// The SH DC coefficient that gives colour channel value `c` (inverse of `C0 * dc + 0.5`).
pub fn rgb_to_sh_dc(c: f32) -> f32 {
    (c - 0.5) / crate::sh::SH_C0
}
