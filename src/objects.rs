//! Several splat objects in one frame (SPEC section 9): each a scene with a rigid transform and
//! a uniform scale, transformed on the GPU (`glsl/object_transform.comp`) into one merged scene
//! that the frame then sorts and composites as one, exactly as the merged, pre-transformed scene
//! would be. [`ObjectTransform::apply`] is the CPU twin, in the same f32 operations, so the two
//! agree bit for bit.
//!
//! The SH coefficients turn with the object: for a rotation `R`, the object's colour seen along
//! world direction `d` is its SH evaluated at `R^T d`, which equals rotated coefficients
//! `c' = D c` evaluated at `d`, band by band. `D` is the f64 least-squares fit of
//! [`crate::mesh::sh_rotation`] (against the very basis functions the renderer evaluates),
//! rounded to f32 for both sides.

use glam::{DMat3, Quat, Vec3};

use crate::clip::{ClipRegion, ClipShape, Plane};
use crate::mesh::sh_rotation::ShRotation;

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
    /// coefficients `D c` seen along `d` give what `c` gives along `R^T d`
    /// ([`crate::mesh::sh_rotation::ShRotation`]'s matrices, rounded to f32).
    pub fn sh_rotation(&self) -> [f32; SH_ROTATION_FLOATS] {
        let r = DMat3::from_quat(self.unit_rotation().as_dquat());
        let bands = ShRotation::new(3, r);
        let mut out = [0f32; SH_ROTATION_FLOATS];
        let mut at = 0;
        for l in 1..=3 {
            let n = 2 * l + 1;
            for (row, values) in bands.band(l).iter().take(n).enumerate() {
                for (k, v) in values.iter().take(n).enumerate() {
                    out[at + row * n + k] = *v as f32;
                }
            }
            at += n * n;
        }
        out
    }

    /// `region`, given in the object's own frame, carried into the world with the object (SPEC
    /// section 9): a half-space `n.x + d >= 0` becomes `(R n).x + s d - (R n).t >= 0`, a
    /// sphere's centre moves as a Gaussian's and its radius scales by `s`; inversion is kept.
    /// Since the scale is uniform, signed distances scale by `s` like the Gaussians'
    /// standard deviations, so every Gaussian is classified as in its own frame.
    pub fn region_to_world(&self, region: &ClipRegion) -> ClipRegion {
        let r = self.unit_rotation();
        let (s, t) = (self.scale, self.translation);
        let shape = match &region.shape {
            ClipShape::HalfSpaces(planes) => ClipShape::HalfSpaces(
                planes
                    .iter()
                    .map(|pl| {
                        let normal = r * pl.normal;
                        Plane {
                            normal,
                            d: s * pl.d - normal.dot(t),
                        }
                    })
                    .collect(),
            ),
            ClipShape::Sphere { center, radius } => ClipShape::Sphere {
                center: t + s * (r * *center),
                radius: s * radius,
            },
        };
        ClipRegion {
            shape,
            invert: region.invert,
        }
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

    /// A region carried into the world with its object: every point's signed distance to it
    /// is `s` times the distance of the point's place in the object's frame to the region.
    #[test]
    fn regions_move_and_scale_with_the_object() {
        let t = ObjectTransform {
            rotation: Quat::from_euler(glam::EulerRot::XYZ, 0.3, -1.1, 2.0),
            translation: Vec3::new(0.5, -2.0, 1.25),
            scale: 1.7,
        };
        let boxed = ClipRegion::oriented_box(
            Vec3::new(0.2, 0.1, -0.3),
            Vec3::new(0.5, 0.8, 0.3),
            Quat::from_rotation_z(0.4),
        )
        .unwrap();
        let regions = [
            boxed.clone(),
            boxed.inverted(),
            ClipRegion::sphere(Vec3::new(-0.4, 0.3, 0.2), 0.6).unwrap(),
            ClipRegion::sphere(Vec3::new(-0.4, 0.3, 0.2), 0.6)
                .unwrap()
                .inverted(),
        ];
        let mut rng = crate::synth::Rng::new(9);
        for region in &regions {
            let world = t.region_to_world(region);
            for _ in 0..200 {
                let local = Vec3::new(
                    rng.range(-1.5, 1.5),
                    rng.range(-1.5, 1.5),
                    rng.range(-1.5, 1.5),
                );
                let placed = t.translation + t.scale * (t.unit_rotation() * local);
                let (want, got) = (
                    t.scale * region.signed_distance(local),
                    world.signed_distance(placed),
                );
                assert!(
                    (want - got).abs() < 1e-5,
                    "{region:?}: {want} against {got}"
                );
            }
        }
    }

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
            let want = crate::sh::eval_sh(scene.sh_of(0), 3, r.transpose() * d);
            let got = crate::sh::eval_sh(turned.sh_of(0), 3, d);
            assert!((want - got).abs().max_element() < 1e-5, "{k}: {want} {got}");
        }
    }
}
