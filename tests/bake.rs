//! Baking a clip (SPEC section 10): a plane at infinity bakes to the identical scene; a
//! Gaussian split through its centre gets its visible half's exact moments (against numerical
//! integration); flat Gaussians stay flat; the baked scene rendered unclipped is close to the
//! clipped render of the original.

mod common;

use glam::{DMat3, DVec3, Quat, Vec3};
use rara::bake::{bake, BakeOpacity};
use rara::{Clip, ClipMode, ClipRegion, Plane, Scene};

fn plane_clip(normal: Vec3, d: f32) -> Clip {
    Clip::rara(ClipRegion::planes(vec![Plane::new(normal, d).unwrap()]).unwrap())
}

#[test]
fn a_plane_at_infinity_bakes_to_the_identical_scene() {
    let scene = rara::synth::solid(3000, 2, 4);
    for rule in [BakeOpacity::Mass, BakeOpacity::Peak] {
        let (baked, report) = bake(&scene, &plane_clip(Vec3::new(0.3, -0.2, 1.0), 1e6), rule);
        assert_eq!(report.kept, scene.len());
        assert_eq!((report.dropped, report.reshaped), (0, 0));
        assert!(baked == scene, "the baked scene differs");
    }
}

/// The moments of `G(mu, sigma)` over the half-space `n.x + d >= 0`, by quadrature on a grid of
/// the whitened space (+-7 sigma, 161^3 points, midpoint rule): (mass, mean, covariance).
fn integrated_moments(mu: DVec3, sigma: DMat3, n: DVec3, d: f64) -> (f64, DVec3, DMat3) {
    // sigma = L L^T by Cholesky.
    let a = sigma.to_cols_array_2d();
    let l00 = a[0][0].sqrt();
    let l10 = a[0][1] / l00;
    let l20 = a[0][2] / l00;
    let l11 = (a[1][1] - l10 * l10).sqrt();
    let l21 = (a[1][2] - l20 * l10) / l11;
    let l22 = (a[2][2] - l20 * l20 - l21 * l21).sqrt();
    let l = DMat3::from_cols(
        DVec3::new(l00, l10, l20),
        DVec3::new(0.0, l11, l21),
        DVec3::new(0.0, 0.0, l22),
    );
    let steps = 161;
    let h = 14.0 / steps as f64;
    let (mut mass, mut first) = (0.0, DVec3::ZERO);
    let mut second = DMat3::ZERO;
    for i in 0..steps {
        for j in 0..steps {
            for k in 0..steps {
                let z = DVec3::new(
                    -7.0 + (i as f64 + 0.5) * h,
                    -7.0 + (j as f64 + 0.5) * h,
                    -7.0 + (k as f64 + 0.5) * h,
                );
                let x = mu + l * z;
                if n.dot(x) + d < 0.0 {
                    continue;
                }
                let w = (-0.5 * z.length_squared()).exp();
                mass += w;
                first += w * x;
                second += DMat3::from_cols(x * x.x, x * x.y, x * x.z) * w;
            }
        }
    }
    let total = (2.0 * std::f64::consts::PI).powf(1.5) / h.powi(3);
    let mean = first / mass;
    let cov = second * (1.0 / mass) - DMat3::from_cols(mean * mean.x, mean * mean.y, mean * mean.z);
    (mass / total, mean, cov)
}

/// A Gaussian cut by a plane through its centre: the baked Gaussian has the visible half's
/// mean and covariance (against quadrature, within 1e-3 of its spread), and opacity `o P /
/// sqrt(v)` with P = 1/2 (the half's mass, also against quadrature).
#[test]
fn a_gaussian_split_through_its_centre_gets_its_visible_half_s_moments() {
    let mean = Vec3::new(0.2, -0.1, 0.4);
    let rotation = Quat::from_euler(glam::EulerRot::XYZ, 0.5, -0.8, 1.3);
    let scale = Vec3::new(0.3, 0.12, 0.05);
    let mut scene = Scene {
        sh_degree: 0,
        ..Scene::default()
    };
    scene.push(mean, 0.8, scale, rotation, &[0.1, 0.2, 0.3]);
    let n = Vec3::new(0.4, 0.7, -0.3).normalize();
    let d = -n.dot(mean);
    let (baked, report) = bake(&scene, &plane_clip(n, d), BakeOpacity::Mass);
    assert_eq!(report.reshaped, 1);
    let r = DMat3::from_quat(rotation.as_dquat());
    let sigma = r * DMat3::from_diagonal(scale.as_dvec3() * scale.as_dvec3()) * r.transpose();
    let (p, want_mean, want_cov) =
        integrated_moments(mean.as_dvec3(), sigma, n.as_dvec3(), d as f64);
    let got_r = DMat3::from_quat(baked.rotations[0].as_dquat());
    let s = baked.scales[0].as_dvec3();
    let got_cov = got_r * DMat3::from_diagonal(s * s) * got_r.transpose();
    let spread = scale.max_element() as f64;
    let mean_err = (baked.means[0].as_dvec3() - want_mean).length() / spread;
    let cov_err = (got_cov - want_cov)
        .to_cols_array()
        .iter()
        .fold(0f64, |m, v| m.max(v.abs()))
        / (spread * spread);
    // Section 10's opacity with alpha = 0: P = 1/2, lambda = phi(0)/P, v = 1 - lambda^2.
    let lambda = (2.0 / std::f64::consts::PI).sqrt();
    let want_opacity = 0.8 * 0.5 / (1.0 - lambda * lambda).sqrt();
    eprintln!(
        "split Gaussian: mass by quadrature {p:.6}; mean off by {mean_err:.2e}, covariance by \
         {cov_err:.2e} of the spread; opacity {} (want {want_opacity:.6})",
        baked.opacities[0]
    );
    assert!((p - 0.5).abs() < 1e-4, "{p}");
    assert!(mean_err < 1e-3, "{mean_err}");
    assert!(cov_err < 1e-3, "{cov_err}");
    assert!((baked.opacities[0] as f64 - want_opacity).abs() < 1e-5);
}

/// Flat Gaussians (SPEC section 6) stay flat through a bake, with their normals: a flattened
/// scene cut by an oblique plane and by a sphere.
#[test]
fn flat_gaussians_stay_flat() {
    let mut scene = rara::synth::solid(4000, 1, 9);
    for s in &mut scene.scales {
        let k = (0..3).min_by(|&a, &b| s[a].total_cmp(&s[b])).unwrap();
        s[k] = 0.0;
    }
    let sphere = Clip::rara(ClipRegion::sphere(Vec3::new(0.2, 0.0, 0.1), 0.6).unwrap());
    for clip in [plane_clip(Vec3::new(0.5, 0.4, 0.7), 0.05), sphere] {
        let (baked, report) = bake(&scene, &clip, BakeOpacity::Mass);
        assert!(report.reshaped > 100, "{report:?}");
        for i in 0..baked.len() {
            assert_eq!(
                baked.scales[i].min_element(),
                0.0,
                "Gaussian {i} is no longer flat"
            );
        }
    }
    // Normals: the zero-scale axis of each reshaped Gaussian is its original's. Checked on one
    // Gaussian cut obliquely.
    let mut one = Scene {
        sh_degree: 0,
        ..Scene::default()
    };
    let q = Quat::from_euler(glam::EulerRot::XYZ, 0.3, 0.9, -0.4);
    one.push(Vec3::ZERO, 0.7, Vec3::new(0.2, 0.1, 0.0), q, &[0.0; 3]);
    let (baked, _) = bake(
        &one,
        &plane_clip(Vec3::new(0.6, 0.3, 0.74).normalize(), 0.02),
        BakeOpacity::Mass,
    );
    let axis = |q: Quat, s: Vec3| {
        let k = (0..3).min_by(|&a, &b| s[a].total_cmp(&s[b])).unwrap();
        glam::Mat3::from_quat(q).col(k)
    };
    let before = axis(q, one.scales[0]);
    let after = axis(baked.rotations[0], baked.scales[0]);
    assert!(before.dot(after).abs() > 1.0 - 1e-5, "{before} {after}");
}

/// Hard mode bakes what centre filters export: the Gaussians whose centre is visible, as they
/// are.
#[test]
fn hard_mode_keeps_the_visible_centres() {
    let scene = rara::synth::solid(3000, 0, 2);
    let mut clip = plane_clip(Vec3::new(1.0, 0.2, 0.0), 0.1);
    clip.mode = ClipMode::Hard;
    let (baked, report) = bake(&scene, &clip, BakeOpacity::Mass);
    let plane = Plane::new(Vec3::new(1.0, 0.2, 0.0), 0.1).unwrap();
    let visible = scene
        .means
        .iter()
        .filter(|m| plane.distance(**m) >= 0.0)
        .count();
    assert_eq!(baked.len(), visible);
    assert_eq!(report.reshaped, 0);
}

/// `rara bake` end to end: it prints the counts and writes a PLY and an SPZ that
/// splat-transform (npm) reads back with every Gaussian (skipped without node or
/// splat-transform, `scripts/clients.sh`).
#[test]
fn rara_bake_writes_files_splat_transform_reads() {
    let dir = common::tempdir("bake_cli");
    let scene = rara::synth::solid(2000, 1, 3);
    let input = dir.join("solid.ply");
    rara::ply::write_ply(&scene, &input, rara::ply::PlyEncoding::BinaryLittleEndian).unwrap();
    let mut counts = Vec::new();
    for name in ["baked.ply", "baked.spz"] {
        let out = dir.join(name);
        let o = std::process::Command::new(env!("CARGO_BIN_EXE_rara"))
            .args([
                "bake",
                input.to_str().unwrap(),
                "--clip-plane",
                "0.6,0.3,0.74,0.05",
                "-o",
            ])
            .arg(&out)
            .output()
            .unwrap();
        let stdout = String::from_utf8_lossy(&o.stdout).into_owned();
        assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
        assert!(
            stdout.contains("dropped") && stdout.contains("reshaped"),
            "{stdout}"
        );
        let baked = rara::formats::load_scene(&out).unwrap().0;
        counts.push(baked.len());
        let Some(st) = common::splat_transform() else {
            common::test_skipped(
                "node or npm's @playcanvas/splat-transform is not installed (scripts/clients.sh)",
            );
            return;
        };
        let back = dir.join(format!("{name}.read_by_splat_transform.ply"));
        common::run_splat_transform(&st, &out, &back);
        let theirs = rara::ply::load_ply(&back).unwrap().0;
        eprintln!(
            "{name}: {} Gaussians, splat-transform read {}",
            baked.len(),
            theirs.len()
        );
        assert_eq!(theirs.len(), baked.len(), "{name}");
    }
    assert_eq!(counts[0], counts[1]);
    assert!(counts[0] < scene.len() && counts[0] > 0);
}
