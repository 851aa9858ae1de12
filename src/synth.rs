//! Procedural scenes the crate generates itself: test fixtures and the demo.

use glam::{Quat, Vec3};

use crate::camera::Camera;
use crate::error::Result;
use crate::scene::{rgb_to_sh_dc, sh_coeffs, Scene};

/// A small deterministic random number generator (SplitMix64), so scenes depend only on the
/// seed.
#[derive(Clone, Debug)]
pub struct Rng(u64);

impl Rng {
    /// Seeds the generator.
    pub fn new(seed: u64) -> Self {
        Rng(seed ^ 0x9E37_79B9_7F4A_7C15)
    }

    /// Next 64 random bits.
    pub fn next_u64(&mut self) -> u64 {
        self.0 = self.0.wrapping_add(0x9E37_79B9_7F4A_7C15);
        let mut z = self.0;
        z = (z ^ (z >> 30)).wrapping_mul(0xBF58_476D_1CE4_E5B9);
        z = (z ^ (z >> 27)).wrapping_mul(0x94D0_49BB_1331_11EB);
        z ^ (z >> 31)
    }

    /// Uniform in [0, 1).
    pub fn f32(&mut self) -> f32 {
        (self.next_u64() >> 40) as f32 / (1u64 << 24) as f32
    }

    /// Uniform in [lo, hi).
    pub fn range(&mut self, lo: f32, hi: f32) -> f32 {
        lo + (hi - lo) * self.f32()
    }

    /// A uniformly random unit vector (rejection sampling in the unit ball).
    pub fn unit_vector(&mut self) -> Vec3 {
        loop {
            let v = Vec3::new(
                self.range(-1.0, 1.0),
                self.range(-1.0, 1.0),
                self.range(-1.0, 1.0),
            );
            if v.length_squared() > 0.01 && v.length_squared() <= 1.0 {
                return v.normalize();
            }
        }
    }

    /// A uniformly random unit quaternion.
    pub fn rotation(&mut self) -> Quat {
        let (u1, u2, u3) = (
            self.f32(),
            self.f32() * std::f32::consts::TAU,
            self.f32() * std::f32::consts::TAU,
        );
        let (a, b) = ((1.0 - u1).sqrt(), u1.sqrt());
        Quat::from_xyzw(a * u2.sin(), a * u2.cos(), b * u3.sin(), b * u3.cos()).normalize()
    }
}

/// SH coefficients (coefficient major) for base colour `rgb`, with small random view-dependent
/// terms of the higher degrees.
fn sh_for(rgb: Vec3, degree: u32, rng: &mut Rng, wobble: f32) -> Vec<f32> {
    let mut sh = vec![0.0; 3 * sh_coeffs(degree)];
    sh[0] = rgb_to_sh_dc(rgb.x);
    sh[1] = rgb_to_sh_dc(rgb.y);
    sh[2] = rgb_to_sh_dc(rgb.z);
    for v in &mut sh[3..] {
        *v = rng.range(-wobble, wobble);
    }
    sh
}

/// A unit sphere of `count` isotropic Gaussians, coloured by direction.
pub fn shell(count: usize, sh_degree: u32, seed: u64) -> Scene {
    let mut rng = Rng::new(seed);
    let mut scene = Scene {
        sh_degree,
        ..Default::default()
    };
    let spacing = (4.0 * std::f32::consts::PI / count.max(1) as f32).sqrt();
    let golden = std::f32::consts::PI * (3.0 - 5f32.sqrt());
    for i in 0..count {
        // Fibonacci sphere with a little jitter.
        let y = 1.0 - 2.0 * (i as f32 + 0.5) / count as f32;
        let r = (1.0 - y * y).max(0.0).sqrt();
        let phi = golden * i as f32 + rng.range(-0.3, 0.3);
        let p = Vec3::new(r * phi.cos(), y, r * phi.sin());
        let rgb = 0.5 + 0.45 * p;
        let s = spacing * rng.range(0.6, 0.9);
        let sh = sh_for(rgb, sh_degree, &mut rng, 0.15);
        scene.push(p, rng.range(0.6, 0.95), Vec3::splat(s), Quat::IDENTITY, &sh);
    }
    scene
}

/// `views` cameras on a circle around the origin at `distance`, 15 degrees above the equator
/// (world up is -Y, the INRIA convention), looking at the origin.
pub fn orbit_cameras(
    views: usize,
    distance: f32,
    width: u32,
    height: u32,
    fov_y_deg: f32,
) -> Result<Vec<Camera>> {
    let elevation = 15f32.to_radians();
    (0..views)
        .map(|k| {
            let a = k as f32 / views as f32 * std::f32::consts::TAU;
            let eye = distance
                * Vec3::new(
                    elevation.cos() * a.cos(),
                    -elevation.sin(),
                    elevation.cos() * a.sin(),
                );
            Camera::look_at(eye, Vec3::ZERO, Vec3::NEG_Y, fov_y_deg, width, height)
        })
        .collect()
}

/// The built-in scene of `rara demo`: a view-dependent (SH degree 3) shell around a smaller,
/// denser core of elongated Gaussians.
pub fn demo_scene() -> Scene {
    let mut scene = shell(20_000, 3, 7);
    let mut rng = Rng::new(11);
    let core_count = 8_000;
    for _ in 0..core_count {
        let dir = rng.unit_vector();
        let p = dir * rng.range(0.2, 0.45);
        let rgb = Vec3::new(0.95, 0.55 + 0.3 * dir.y, 0.2);
        let sh = sh_for(rgb, 3, &mut rng, 0.1);
        let scale = Vec3::new(rng.range(0.02, 0.05), 0.006, 0.006);
        scene.push(p, rng.range(0.5, 0.9), scale, rng.rotation(), &sh);
    }
    scene
}

/// Kinds of scene `rara synth` makes.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum SynthKind {
    /// A unit sphere of isotropic Gaussians ([`shell`]).
    Shell,
    /// Strands of needle-like Gaussians ([`hair`]).
    Hair,
    /// Nested closed surfaces ([`layers`]).
    Layers,
    /// A solid ellipsoid filled with Gaussians, coloured in layers ([`solid`]).
    Solid,
}

/// Makes a scene of `kind` with about `count` Gaussians.
pub fn generate(kind: SynthKind, count: usize, sh_degree: u32, seed: u64) -> Scene {
    match kind {
        SynthKind::Shell => shell(count, sh_degree, seed),
        SynthKind::Hair => hair(count, sh_degree, seed),
        SynthKind::Layers => layers(count, sh_degree, seed),
        SynthKind::Solid => solid(count, sh_degree, seed),
    }
}

/// Hair: strands rooted on the upper half of a unit "scalp" sphere that leave along the
/// normal and bend down under gravity, each strand a chain of highly anisotropic Gaussians
/// (length/width = 30) along its smooth curve, as in strand-based hair reconstructions.
pub fn hair(count: usize, sh_degree: u32, seed: u64) -> Scene {
    const SEGMENTS: usize = 16;
    let mut rng = Rng::new(seed);
    let mut scene = Scene {
        sh_degree,
        ..Default::default()
    };
    let strands = count.div_ceil(SEGMENTS).max(1);
    for _ in 0..strands {
        // Root on the upper hemisphere (world up is -Y).
        let mut root = rng.unit_vector();
        root.y = -root.y.abs();
        let length = rng.range(0.8, 1.4);
        let seg = length / SEGMENTS as f32;
        let tint = rng.range(0.8, 1.2);
        let base = Vec3::new(0.35, 0.22, 0.12) * tint;
        let mut p = root;
        let mut dir = root;
        for k in 0..SEGMENTS {
            if scene.len() >= count {
                break;
            }
            // Gravity (+Y is down) bends the strand smoothly.
            let next_dir = (dir + Vec3::new(0.0, 0.18, 0.0)).normalize();
            let next = p + seg * next_dir;
            let mid = 0.5 * (p + next);
            let tangent = (next - p).normalize();
            let rgb = base * (0.8 + 0.4 * k as f32 / SEGMENTS as f32);
            let sh = sh_for(rgb, sh_degree, &mut rng, 0.05);
            let long = 0.6 * seg;
            scene.push(
                mid,
                rng.range(0.7, 0.95),
                Vec3::new(long, long / 30.0, long / 30.0),
                Quat::from_rotation_arc(Vec3::X, tangent),
                &sh,
            );
            p = next;
            dir = next_dir;
        }
    }
    scene
}

/// Solid: an ellipsoid (semi-axes 1, 1.25, 0.9) filled with isotropic Gaussians, coloured by
/// their depth in it like [`layers`] (skin outside, muscle, a bone core), so that every cut
/// shows a face of rings. Cutting a volume is where hard clipping pops most: each Gaussian that
/// the cut crosses is all there or all gone, while RaRa shades the face smoothly (`rara demo`).
pub fn solid(count: usize, sh_degree: u32, seed: u64) -> Scene {
    let mut rng = Rng::new(seed);
    let mut scene = Scene {
        sh_degree,
        ..Default::default()
    };
    let axes = Vec3::new(1.0, 1.25, 0.9);
    // Spacing of `count` points in the ellipsoid's volume; the Gaussians overlap their
    // neighbours so that the solid looks closed.
    let volume = 4.0 / 3.0 * std::f32::consts::PI * axes.x * axes.y * axes.z;
    let spacing = (volume / count.max(1) as f32).cbrt();
    for _ in 0..count {
        let unit = loop {
            let p = Vec3::new(
                rng.range(-1.0, 1.0),
                rng.range(-1.0, 1.0),
                rng.range(-1.0, 1.0),
            );
            if p.length_squared() < 1.0 {
                break p;
            }
        };
        let depth = unit.length();
        let rgb = if depth > 0.8 {
            Vec3::new(0.93, 0.76, 0.65)
        } else if depth > 0.45 {
            Vec3::new(0.75, 0.15, 0.15)
        } else {
            Vec3::new(0.95, 0.93, 0.85)
        };
        let sh = sh_for(rgb * rng.range(0.9, 1.05), sh_degree, &mut rng, 0.05);
        let s = 0.65 * spacing * rng.range(0.7, 1.2);
        scene.push(unit * axes, 0.6, Vec3::splat(s), Quat::IDENTITY, &sh);
    }
    scene
}

/// Layers: three nested closed ellipsoids, like multi-layer anatomy scenes for cutaways: an
/// outer translucent "skin", a red "muscle" and an opaque white "bone" core, each covered by
/// flat Gaussians tangent to the surface.
pub fn layers(count: usize, sh_degree: u32, seed: u64) -> Scene {
    let mut rng = Rng::new(seed);
    let mut scene = Scene {
        sh_degree,
        ..Default::default()
    };
    // (semi-axes, colour, opacity)
    let shells = [
        (Vec3::new(1.0, 1.25, 0.9), Vec3::new(0.93, 0.76, 0.65), 0.55),
        (
            Vec3::new(0.75, 0.95, 0.68),
            Vec3::new(0.75, 0.15, 0.15),
            0.8,
        ),
        (
            Vec3::new(0.42, 0.6, 0.38),
            Vec3::new(0.95, 0.93, 0.85),
            0.97,
        ),
    ];
    let areas: Vec<f32> = shells
        .iter()
        .map(|(a, _, _)| a.x * a.y + a.y * a.z + a.x * a.z)
        .collect();
    let total: f32 = areas.iter().sum();
    for (k, (axes, rgb, opacity)) in shells.iter().enumerate() {
        let n = if k + 1 == shells.len() {
            count.saturating_sub(scene.len())
        } else {
            ((count as f32) * areas[k] / total) as usize
        };
        let size = (4.0 * std::f32::consts::PI * areas[k] / 3.0 / n.max(1) as f32).sqrt();
        for _ in 0..n {
            let dir = rng.unit_vector();
            let p = dir * *axes;
            let normal = (p / (*axes * *axes)).normalize();
            let s = size * rng.range(0.7, 1.0);
            let sh = sh_for(*rgb * rng.range(0.9, 1.05), sh_degree, &mut rng, 0.05);
            scene.push(
                p,
                *opacity,
                Vec3::new(s, s, s / 6.0),
                Quat::from_rotation_arc(Vec3::Z, normal),
                &sh,
            );
        }
    }
    scene
}
