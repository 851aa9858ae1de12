//! Octagon meshes (SPEC section 6): the geometry's round trip, the files' round trip in every
//! format, rigid edits, SH rotation, and hostile mesh files.

mod common;

use std::path::Path;

use glam::{DMat3, DQuat, DVec3, Vec3};
use rara::mesh::export::{export_mesh, ExportOptions, Falloff, MeshFormat};
use rara::mesh::import::{import_mesh, read_mesh, Fit, ImportOptions, MeshData};
use rara::mesh::{fit_lsq, fit_redisplats, octagon, octagon_radius, FlatFrame, DEFAULT_Q};
use rara::synth::Rng;
use rara::{Camera, RenderOptions, Renderer, Scene};

/// Flat Gaussians in the REdiSplats convention (normal = local x) and some 3D ones, around
/// `offset`, SH degree `degree`.
fn scene(count: usize, degree: u32, offset: Vec3, seed: u64) -> Scene {
    let mut rng = Rng::new(seed);
    let mut s = Scene {
        sh_degree: degree,
        ..Scene::default()
    };
    let stride = s.sh_stride();
    for i in 0..count {
        let scale = if i % 4 == 3 {
            Vec3::new(
                rng.range(0.01, 0.1),
                rng.range(0.01, 0.1),
                rng.range(0.01, 0.1),
            )
        } else {
            Vec3::new(0.0, rng.range(0.01, 0.1), rng.range(0.01, 0.1))
        };
        let mean = offset
            + Vec3::new(
                rng.range(-1.0, 1.0),
                rng.range(-1.0, 1.0),
                rng.range(-1.0, 1.0),
            );
        let sh: Vec<f32> = (0..stride).map(|_| rng.range(-0.8, 0.8)).collect();
        s.push(mean, rng.range(0.05, 0.99), scale, rng.rotation(), &sh);
    }
    s
}

/// Largest relative errors (centre, covariance) of `b`'s Gaussians against `a`'s, flattened
/// (an octagon holds the flattened Gaussian).
fn errors(a: &Scene, b: &Scene) -> (f64, f64) {
    let mut worst = (0.0f64, 0.0f64);
    for i in 0..a.len() {
        let (fa, fb) = (FlatFrame::of(a, i), FlatFrame::of(b, i));
        let dm = (fa.mean - fb.mean).length() / fa.mean.length().max(fa.s_a.max(fa.s_b));
        let (ca, cb) = (fa.covariance(), fb.covariance());
        let norm = |m: DMat3| {
            m.to_cols_array()
                .iter()
                .map(|v| v.abs())
                .fold(0.0, f64::max)
        };
        let dc = norm(ca - cb) / norm(ca);
        worst = (worst.0.max(dm), worst.1.max(dc));
    }
    worst
}

#[test]
fn octagon_round_trip_is_exact() {
    let s = scene(2000, 0, Vec3::new(3.0, -2.0, 5.0), 1);
    for i in 0..s.len() {
        let Some((frame, rho, corners)) = octagon(&s, i, DEFAULT_Q) else {
            continue;
        };
        // Every corner's in-plane coordinates lie on the circle of radius rho, where the
        // Gaussian's alpha is exp(-Q/2).
        for p in &corners {
            let (a, b) = frame.in_plane(*p);
            assert!(((a * a + b * b).sqrt() - rho).abs() < 1e-9 * rho);
            let alpha = s.opacities[i] as f64 * (-(a * a + b * b) / 2.0).exp();
            assert!(
                (alpha - (-DEFAULT_Q / 2.0).exp()).abs() < 1e-9,
                "rim alpha {alpha}"
            );
        }
        for (name, fit) in [
            ("redisplats", fit_redisplats(&corners, rho).unwrap()),
            ("lsq", fit_lsq(&corners, rho).unwrap()),
        ] {
            assert!(
                (fit.mean - frame.mean).length() < 1e-12 * frame.mean.length(),
                "{name}"
            );
            let d = fit.covariance() - frame.covariance();
            let size = frame
                .covariance()
                .to_cols_array()
                .iter()
                .map(|v| v.abs())
                .fold(0.0, f64::max);
            assert!(
                d.to_cols_array().iter().all(|v| v.abs() < 1e-10 * size),
                "{name} {i}"
            );
        }
        // Already in the REdiSplats convention: scales and quaternion back, up to sign.
        if s.scales[i].x == 0.0 {
            let fit = fit_redisplats(&corners, rho).unwrap();
            let sc = fit.scales();
            assert!((sc - s.scales[i]).abs().max_element() < 1e-6 * s.scales[i].max_element());
            assert!(fit.rotation().dot(s.rotations[i]).abs() > 1.0 - 1e-6, "{i}");
        }
    }
    // rho = 0 below exp(-Q/2): no octagon.
    assert_eq!(
        octagon_radius(DEFAULT_Q, (-DEFAULT_Q / 2.0).exp() as f32 * 0.999),
        0.0
    );
}

fn export(s: &Scene, path: &Path, falloff: Falloff) -> rara::mesh::export::ExportReport {
    let options = ExportOptions {
        falloff,
        ..ExportOptions::default()
    };
    let format = MeshFormat::from_path(path).unwrap();
    export_mesh(s, path, format, &options, &mut |_, _| {}).unwrap()
}

fn import(s: &Scene, path: &Path, options: &ImportOptions) -> rara::Result<Scene> {
    let mesh = read_mesh(path)?;
    import_mesh(&mesh, s, options, path).map(|(scene, _)| scene)
}

/// Export then import, in every format and both fits: every Gaussian's centre and covariance
/// within 1e-5 relative (glb's positions are f32; PLY's are doubles, OBJ's shortest decimals).
#[test]
fn files_round_trip_in_every_format() {
    let dir = common::tempdir("formats");
    let s = scene(3000, 1, Vec3::new(2.0, 1.0, -3.0), 2);
    for ext in ["ply", "obj", "glb"] {
        for falloff in [Falloff::Constant, Falloff::Centre, Falloff::Texture] {
            let path = dir.join(format!("m_{falloff:?}.{ext}"));
            let report = export(&s, &path, falloff);
            assert_eq!(
                report.vertices as usize,
                report.octagons * falloff.vertices()
            );
            for fit in [Fit::Redisplats, Fit::Lsq] {
                let options = ImportOptions {
                    fit,
                    ..ImportOptions::default()
                };
                let back = import(&s, &path, &options).unwrap();
                let (dm, dc) = errors(&s, &back);
                eprintln!(
                    "{ext} {falloff:?} {fit:?}: centre {dm:.2e}, covariance {dc:.2e} relative"
                );
                assert!(
                    dm < 1e-5 && dc < 1e-5,
                    "{ext} {falloff:?} {fit:?}: {dm} {dc}"
                );
                assert_eq!(back.opacities, s.opacities);
                assert_eq!(back.sh, s.sh);
            }
        }
    }
}

/// Applies `f` to every vertex of a mesh file, in memory.
fn transformed(mesh: &MeshData, f: impl Fn(DVec3) -> DVec3) -> MeshData {
    let mut m = mesh.clone();
    for p in &mut m.positions {
        *p = f(*p);
    }
    m
}

/// A rigid motion of the mesh imports as exactly the moved Gaussians: centres `R mu + t`,
/// covariances `R Sigma R^T`.
#[test]
fn rigid_motions_give_the_moved_gaussians() {
    let dir = common::tempdir("rigid");
    let s = scene(1500, 0, Vec3::ZERO, 3);
    let path = dir.join("m.ply");
    export(&s, &path, Falloff::Constant);
    let mesh = read_mesh(&path).unwrap();
    let r = DMat3::from_quat(DQuat::from_euler(glam::EulerRot::XYZ, 0.4, -1.1, 2.3));
    let t = DVec3::new(0.5, -2.0, 1.5);
    let moved = transformed(&mesh, |p| r * p + t);
    for fit in [Fit::Redisplats, Fit::Lsq] {
        let options = ImportOptions {
            fit,
            ..ImportOptions::default()
        };
        let (back, _) = import_mesh(&moved, &s, &options, &path).unwrap();
        for i in 0..s.len() {
            let (f0, f1) = (FlatFrame::of(&s, i), FlatFrame::of(&back, i));
            assert!((r * f0.mean + t - f1.mean).length() < 1e-6, "{fit:?} {i}");
            let want = r * f0.covariance() * r.transpose();
            let d = (want - f1.covariance()).to_cols_array();
            let size = f0.s_a.max(f0.s_b).powi(2);
            assert!(d.iter().all(|v| v.abs() < 1e-5 * size), "{fit:?} {i}");
        }
    }
}

/// `--rotate-sh`: a rigidly rotated mesh imported with it renders as the original seen from
/// the inversely rotated camera; without it, the view-dependent colour does not turn.
#[test]
fn rotated_sh_turns_with_the_surface() {
    let ctx = common::context();
    let mut renderer = Renderer::new(&ctx).unwrap();
    let dir = common::tempdir("rotate_sh");
    let mut s = scene(4000, 3, Vec3::ZERO, 4);
    // Strongly view-dependent: the higher bands dominate.
    for g in 0..s.len() {
        let stride = s.sh_stride();
        for v in &mut s.sh[g * stride + 3..(g + 1) * stride] {
            *v *= 2.0;
        }
    }
    let s = s.flattened();
    let path = dir.join("m.glb");
    export(&s, &path, Falloff::Constant);
    let mesh = read_mesh(&path).unwrap();
    let q = DQuat::from_euler(glam::EulerRot::YXZ, 1.2, 0.5, -0.3);
    let r = DMat3::from_quat(q);
    let rotated = transformed(&mesh, |p| r * p);
    let eye = Vec3::new(0.3, -0.8, -4.5);
    let camera = Camera::look_at(eye, Vec3::ZERO, Vec3::NEG_Y, 50.0, 200, 150).unwrap();
    // The original, seen from the camera rotated by R^-1.
    let rq = q.as_quat();
    let inverse = Camera {
        position: rq.inverse() * camera.position,
        rotation: glam::Mat3::from_quat(rq.inverse()) * camera.rotation,
        ..camera
    };
    let options = RenderOptions::default();
    let render = |renderer: &mut Renderer, scene: &Scene, cam: &Camera| {
        let g = renderer.upload(scene).unwrap();
        renderer.render(&g, cam, &options).unwrap().0
    };
    let want = render(&mut renderer, &s, &inverse);
    let mut psnr = vec![];
    for rotate_sh in [true, false] {
        let options = ImportOptions {
            rotate_sh,
            ..ImportOptions::default()
        };
        let (back, _) = import_mesh(&rotated, &s, &options, &path).unwrap();
        let got = render(&mut renderer, &back, &camera);
        let d = rara::metrics::compare(&want, &got);
        eprintln!(
            "rotate_sh {rotate_sh}: PSNR {:.2} dB, max diff {}",
            d.psnr, d.max_diff
        );
        psnr.push(d.psnr);
    }
    assert!(psnr[0] >= 45.0, "with --rotate-sh: {} dB", psnr[0]);
    assert!(
        psnr[1] < psnr[0] - 10.0,
        "without: {} dB against {} dB",
        psnr[1],
        psnr[0]
    );
    common::assert_no_validation_messages(&ctx);
}

fn expect_error(result: rara::Result<Scene>, needle: &str) {
    match result {
        Ok(_) => panic!("expected an error containing '{needle}'"),
        Err(e) => {
            let m = e.to_string();
            assert!(m.contains(needle), "'{m}' lacks '{needle}'");
        }
    }
}

/// Hostile meshes: each gets an error that says what is wrong.
#[test]
fn hostile_meshes_give_clear_errors() {
    let dir = common::tempdir("hostile");
    let s = scene(50, 0, Vec3::ZERO, 5);
    let path = dir.join("m.ply");
    export(&s, &path, Falloff::Constant);
    let mesh = read_mesh(&path).unwrap();
    let options = ImportOptions::default();
    let run = |m: &MeshData| import_mesh(m, &s, &options, &path).map(|(s, _)| s);

    let mut nan = mesh.clone();
    nan.positions[17].y = f64::NAN;
    expect_error(run(&nan), "vertex 17 is not finite");

    let mut collapsed = mesh.clone();
    for k in 0..8 {
        collapsed.positions[8 + k] = collapsed.positions[8];
    }
    expect_error(run(&collapsed), "degenerate");

    let mut mixed = mesh.clone();
    mixed.faces[0] = vec![0, 1, 9];
    expect_error(run(&mixed), "different octagons");

    let mut short = mesh.clone();
    short.faces[3] = vec![0, 1];
    expect_error(run(&short), "face 3 has 2 vertices");

    let mut beyond = mesh.clone();
    beyond.faces[2] = vec![0, 1, 1_000_000];
    expect_error(run(&beyond), "names vertex 1000000");

    let mut twice = mesh.clone();
    twice.corner_ids.as_mut().unwrap()[1] = 0;
    expect_error(run(&twice), "corner 0 twice");

    let mut far = mesh.clone();
    far.primitive_ids.as_mut().unwrap()[0] = 999;
    expect_error(run(&far), "primitive_id 999");

    // Without ids: the count decides, and a wrong one is an error that gives both counts.
    let mut by_order = mesh.clone();
    by_order.primitive_ids = None;
    by_order.corner_ids = None;
    assert!(run(&by_order).is_ok());
    by_order.positions.truncate(by_order.positions.len() - 8);
    by_order.faces.truncate(by_order.faces.len() - 6);
    expect_error(run(&by_order), "vertices were expected");

    // An octagon the mesh lacks.
    let mut missing = mesh.clone();
    missing.primitive_ids.as_mut().unwrap()[..8].fill(1);
    expect_error(run(&missing), "corner");

    // Not a mesh file at all.
    let junk = dir.join("junk.ply");
    std::fs::write(&junk, b"ply\nformat binary_little_endian 1.0\nelement vertex 99999999\nproperty float x\nend_header\n").unwrap();
    assert!(read_mesh(&junk)
        .unwrap_err()
        .to_string()
        .contains("99999999"));
    let bad_ext = dir.join("m.stl");
    assert!(read_mesh(&bad_ext)
        .unwrap_err()
        .to_string()
        .contains(".stl"));
}

/// Real scenes through every format: the round-trip errors (an unedited export, then an
/// import), within 1e-5 relative for PLY (double positions) and OBJ (shortest decimals); glb
/// stores positions as f32, which bounds its error by the f32 rounding of the corners against
/// the octagon's size, so it is reported and held to 1e-3.
#[test]
fn real_scenes_round_trip() {
    let mut ran = 0;
    for (stem, formats) in [
        ("plant_capture_sh0", &["ply", "obj", "glb"][..]),
        ("playbot_lod0_500k_sh2", &["ply", "glb"][..]),
    ] {
        let Some((ply, _)) = common::real_scene(stem) else {
            continue;
        };
        eprintln!("real-scene case '{stem}' RAN");
        ran += 1;
        let s = rara::ply::load_ply(&ply).unwrap().0;
        let dir = common::tempdir(&format!("real_{stem}"));
        for ext in formats {
            let path = dir.join(format!("m.{ext}"));
            export(&s, &path, Falloff::Constant);
            let back = import(&s, &path, &ImportOptions::default()).unwrap();
            let fitted: Vec<usize> = (0..s.len())
                .filter(|&i| rara::mesh::export::has_octagon(&s, i, DEFAULT_Q, 0.0))
                .collect();
            let pick = |scene: &Scene| {
                let mut out = Scene {
                    sh_degree: scene.sh_degree,
                    ..Scene::default()
                };
                for &i in &fitted {
                    out.push(
                        scene.means[i],
                        scene.opacities[i],
                        scene.scales[i],
                        scene.rotations[i],
                        scene.sh_of(i),
                    );
                }
                out
            };
            let (dm, dc) = errors(&pick(&s), &pick(&back));
            eprintln!(
                "{stem} {ext}: {} octagons, centre {dm:.2e}, covariance {dc:.2e} relative",
                fitted.len()
            );
            let bound = if *ext == "glb" { 1e-3 } else { 1e-5 };
            assert!(dm < bound && dc < bound, "{stem} {ext}: {dm} {dc}");
            std::fs::remove_file(&path).ok();
        }
    }
    if ran == 0 {
        common::test_skipped("none of its real scenes is here");
    }
}

/// A glb whose mesh sits under a node transform (as other tools write them) imports where the
/// scene places it: a translated node gives translated Gaussians.
#[test]
fn glb_node_transforms_are_applied() {
    let dir = common::tempdir("node");
    let s = scene(200, 0, Vec3::ZERO, 8);
    let path = dir.join("m.glb");
    export(&s, &path, Falloff::Constant);
    let bytes = std::fs::read(&path).unwrap();
    let glb = gltf::binary::Glb::from_slice(&bytes).unwrap();
    let mut json: serde_json::Value = serde_json::from_slice(&glb.json).unwrap();
    json["nodes"][0]["translation"] = serde_json::json!([1.0, -2.0, 0.5]);
    let moved = gltf::binary::Glb {
        header: glb.header,
        json: serde_json::to_vec(&json).unwrap().into(),
        bin: glb.bin.clone(),
    };
    let moved_path = dir.join("moved.glb");
    std::fs::write(&moved_path, moved.to_vec().unwrap()).unwrap();
    let back = import(&s, &moved_path, &ImportOptions::default()).unwrap();
    for i in 0..s.len() {
        let d = back.means[i] - s.means[i] - Vec3::new(1.0, -2.0, 0.5);
        assert!(d.length() < 1e-5, "{i}: {d}");
    }
}

/// `--min-opacity`: only Gaussians at or above it get an octagon; an import by order needs the
/// same value to find them, and says what it expected otherwise.
#[test]
fn min_opacity_selects_the_octagons() {
    let dir = common::tempdir("min_opacity");
    let s = scene(400, 0, Vec3::ZERO, 9);
    let path = dir.join("m.obj");
    let options = ExportOptions {
        min_opacity: 0.5,
        ..ExportOptions::default()
    };
    let report = export_mesh(&s, &path, MeshFormat::Obj, &options, &mut |_, _| {}).unwrap();
    let above = s.opacities.iter().filter(|&&o| o >= 0.5).count();
    assert_eq!(report.octagons, above);
    assert_eq!(report.below_min_opacity, s.len() - above);
    let with = ImportOptions {
        min_opacity: 0.5,
        ..ImportOptions::default()
    };
    let back = import(&s, &path, &with).unwrap();
    for i in 0..s.len() {
        if s.opacities[i] < 0.5 {
            assert_eq!(back.means[i], s.means[i]);
            assert_eq!(back.scales[i], s.scales[i]);
        }
    }
    let err = import(&s, &path, &ImportOptions::default())
        .unwrap_err()
        .to_string();
    assert!(err.contains("vertices were expected"), "{err}");
}

/// Ids that do not cover every vertex, and an octagon for a Gaussian that cannot have one
/// under the import's Q, are errors too.
#[test]
fn inconsistent_ids_and_q_are_errors() {
    let dir = common::tempdir("ids_q");
    let s = scene(30, 0, Vec3::ZERO, 10);
    let path = dir.join("m.ply");
    export(&s, &path, Falloff::Constant);
    let mesh = read_mesh(&path).unwrap();
    let mut short = mesh.clone();
    short.corner_ids.as_mut().unwrap().pop();
    let err = import_mesh(&short, &s, &ImportOptions::default(), &path)
        .unwrap_err()
        .to_string();
    assert!(err.contains("corner ids"), "{err}");
    // Under a tiny Q every Gaussian here has rho = 0, yet the mesh has their octagons.
    let tiny = ImportOptions {
        q: 1e-3,
        ..ImportOptions::default()
    };
    let err = import_mesh(&mesh, &s, &tiny, &path)
        .unwrap_err()
        .to_string();
    assert!(err.contains("another --q"), "{err}");
}
