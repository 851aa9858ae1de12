//! Flat Gaussians (SPEC section 6): loading both PLY layouts, drawing them (GPU against the
//! CPU reference), and the clip weight of section 6, edge-on views included.

mod common;

use std::io::Write;

use glam::{DVec3, Quat, Vec3};
use rara::clip::{Clip, ClipRegion, ClipWeight, CutoffRay, Plane};
use rara::ply::{load_ply, write_ply, write_ply_layout, PlyEncoding, PlyLayout};
use rara::reference;
use rara::synth::Rng;
use rara::{Camera, RenderOptions, Renderer, Scene};

/// `R S^2 R^T` of Gaussian `i`, in f64.
fn covariance(scene: &Scene, i: usize) -> glam::DMat3 {
    let r = glam::DMat3::from_quat(scene.rotations[i].as_dquat());
    let s = glam::DMat3::from_diagonal(scene.scales[i].as_dvec3());
    r * s * s * r.transpose()
}

/// A layer of flat Gaussians in the plane z = 0 (normal +-z, random in-plane axes), a few
/// tilted ones among them.
fn flat_layer(count: usize, seed: u64) -> Scene {
    let mut rng = Rng::new(seed);
    let mut scene = Scene {
        sh_degree: 1,
        ..Scene::default()
    };
    for i in 0..count {
        let spin = Quat::from_rotation_z(rng.range(0.0, 6.3));
        let tilt = if i % 7 == 0 {
            Quat::from_rotation_x(rng.range(-0.8, 0.8))
        } else {
            Quat::IDENTITY
        };
        // Local z is the normal (scale 0) for most; local x for every third.
        let (scale, to_normal) = if i % 3 == 0 {
            (
                Vec3::new(0.0, rng.range(0.02, 0.08), rng.range(0.02, 0.08)),
                Quat::from_rotation_y(std::f32::consts::FRAC_PI_2),
            )
        } else {
            (
                Vec3::new(rng.range(0.02, 0.08), rng.range(0.02, 0.08), 0.0),
                Quat::IDENTITY,
            )
        };
        let mean = Vec3::new(rng.range(-1.0, 1.0), rng.range(-1.0, 1.0), 0.0);
        let sh: Vec<f32> = (0..12).map(|_| rng.range(-0.6, 0.6)).collect();
        scene.push(
            mean,
            rng.range(0.3, 0.95),
            scale,
            (tilt * spin * to_normal).normalize(),
            &sh,
        );
    }
    scene
}

fn over_grey(clip: Clip) -> RenderOptions {
    RenderOptions {
        background: Vec3::new(0.1, 0.1, 0.15),
        clip,
        ..RenderOptions::default()
    }
}

/// Clips that cut the layer: a plane across it, the plane of the layer itself, a box, a
/// sphere and a cutaway; rara with both weights, and hard.
fn clips() -> Vec<(String, Clip)> {
    let across = Plane::new(Vec3::new(1.0, 0.2, 0.0), -0.1).unwrap();
    // Nearly the layer's own plane: it cuts the layer at a grazing angle.
    let in_layer = Plane::new(Vec3::new(0.05, 0.0, 1.0), 0.0).unwrap();
    let regions = [
        ("across", ClipRegion::planes(vec![across]).unwrap()),
        ("layer_plane", ClipRegion::planes(vec![in_layer]).unwrap()),
        (
            "box",
            ClipRegion::oriented_box(
                Vec3::new(0.2, 0.0, 0.0),
                Vec3::splat(0.5),
                Quat::from_rotation_z(0.4),
            )
            .unwrap(),
        ),
        (
            "sphere",
            ClipRegion::sphere(Vec3::new(-0.3, 0.2, 0.1), 0.6).unwrap(),
        ),
        (
            "cutaway",
            ClipRegion::oriented_box(Vec3::ZERO, Vec3::new(0.4, 0.4, 0.3), Quat::IDENTITY)
                .unwrap()
                .inverted(),
        ),
    ];
    let mut out = vec![];
    for (name, region) in regions {
        let mass = Clip::rara(region.clone());
        let length = Clip {
            weight: ClipWeight::Length,
            ..mass.clone()
        };
        out.push((format!("{name}_hard"), Clip::hard(region)));
        out.push((format!("{name}_mass"), mass));
        out.push((format!("{name}_length"), length));
    }
    out
}

/// Cameras on the layer: edge-on with the eye in its plane, edge-on from just above, oblique,
/// and straight down.
fn cameras() -> Vec<(&'static str, Camera)> {
    let at = |eye: Vec3, up: Vec3| Camera::look_at(eye, Vec3::ZERO, up, 50.0, 160, 120).unwrap();
    vec![
        (
            "edge_on_in_plane",
            at(Vec3::new(3.0, 0.4, 0.0), Vec3::NEG_Z),
        ),
        ("edge_on_above", at(Vec3::new(3.0, 0.4, 1e-3), Vec3::NEG_Z)),
        ("oblique", at(Vec3::new(2.0, -1.5, 1.2), Vec3::NEG_Z)),
        ("top_down", at(Vec3::new(0.1, 0.0, 3.0), Vec3::NEG_Y)),
    ]
}

/// SPEC section 6: the tile rasterizer draws flat Gaussians as its CPU twin does (>= 50 dB),
/// unclipped and under every clip, from every view, edge-on included, on both rasterizer
/// layouts. The CPU reference's weights are checked finite at every pixel on the way.
#[test]
fn flat_gpu_matches_cpu_from_every_view() {
    let ctx = common::context();
    let scene = flat_layer(3000, 11);
    assert_eq!(scene.flat_count(), scene.len());
    for layout in common::raster_layouts(&ctx) {
        let mut renderer = Renderer::with_raster_layout(&ctx, layout).unwrap();
        let gpu_scene = renderer.upload(&scene).unwrap();
        for (view, camera) in cameras() {
            let mut cases = vec![("none".to_string(), Clip::default())];
            cases.extend(clips());
            for (clip_name, clip) in cases {
                let options = over_grey(clip);
                let (gpu, stats) = renderer.render(&gpu_scene, &camera, &options).unwrap();
                assert_weights_finite(&scene, &camera, &options.clip);
                let cpu = reference::render(&scene, &camera, &options);
                let d = common::check_images(
                    &format!("flat_{view}_{clip_name}_{layout:?}"),
                    &gpu,
                    &cpu,
                    50.0,
                    16,
                );
                if clip_name.ends_with("mass") || clip_name.ends_with("length") {
                    assert!(stats.cutoff > 0, "{view} {clip_name}: no cutoff Gaussian");
                }
                eprintln!(
                    "  {view} {clip_name} {layout:?}: {} drawn, {} cutoff, PSNR {:.2} dB",
                    stats.visible, stats.cutoff, d.psnr
                );
            }
        }
    }
    common::assert_no_validation_messages(&ctx);
}

/// Every cutoff splat's weight at every pixel is a finite number in [0, 1].
fn assert_weights_finite(scene: &Scene, camera: &Camera, clip: &Clip) {
    let splats = reference::project::project_all(scene, camera, clip);
    let cutoff: Vec<_> = splats.iter().filter_map(|s| s.cutoff).collect();
    if cutoff.is_empty() {
        return;
    }
    for j in (0..camera.height).step_by(3) {
        for i in (0..camera.width).step_by(3) {
            let px = reference::rasterize::PixelClip::new(clip, camera, i, j).unwrap();
            for ray in &cutoff {
                let w = ray.weight(px.dir, &px.spans, px.weight, px.band);
                assert!((0.0..=1.0).contains(&w), "weight {w} at ({i}, {j})");
            }
        }
    }
}

/// Section 6's rule, checked against the region itself: the weight of a flat Gaussian is 1
/// where the ray's crossing with its plane is visible and 0 elsewhere, for both weights; a
/// ray parallel to the plane takes the visibility of its closest approach to the centre.
#[test]
fn flat_weight_is_the_visibility_of_the_plane_crossing() {
    let mut rng = Rng::new(5);
    let regions = [
        ClipRegion::planes(vec![Plane::new(Vec3::new(0.3, 1.0, -0.2), 0.1).unwrap()]).unwrap(),
        ClipRegion::sphere(Vec3::new(0.2, 0.0, 0.1), 0.7).unwrap(),
        ClipRegion::oriented_box(Vec3::ZERO, Vec3::splat(0.4), Quat::from_rotation_y(0.3))
            .unwrap()
            .inverted(),
    ];
    let mut checked = [0usize; 2];
    for region in &regions {
        for _ in 0..400 {
            let mean = Vec3::new(
                rng.range(-1.0, 1.0),
                rng.range(-1.0, 1.0),
                rng.range(-1.0, 1.0),
            );
            let q = rng.rotation();
            let axis = (rng.next_u64() % 3) as usize;
            let mut scale = Vec3::new(
                rng.range(0.05, 0.3),
                rng.range(0.05, 0.3),
                rng.range(0.05, 0.3),
            );
            scale[axis] = 0.0;
            let eye = Vec3::new(rng.range(-3.0, 3.0), rng.range(-3.0, 3.0), 3.0);
            let ray = CutoffRay::new(mean, scale, q, eye);
            // The normal as the weight works it out (in f64), so that `parallel` is parallel to it.
            let normal = glam::DMat3::from_quat(q.as_dquat().normalize()).col(axis);
            let e = eye.as_dvec3();
            // A ray towards a random point near the centre, and one exactly in the plane.
            let target = mean.as_dvec3()
                + DVec3::new(
                    rng.range(-0.5, 0.5) as f64,
                    rng.range(-0.5, 0.5) as f64,
                    rng.range(-0.5, 0.5) as f64,
                );
            let along = (target - e).normalize();
            let parallel = (along - along.dot(normal) * normal).normalize();
            for (k, dir) in [along, parallel].into_iter().enumerate() {
                let nd = normal.dot(dir);
                let t = if nd.abs() < 1e-7 {
                    dir.dot(mean.as_dvec3() - e)
                } else {
                    normal.dot(mean.as_dvec3() - e) / nd
                };
                let point = e + t * dir;
                let s = region.signed_distance(point.as_vec3());
                if s.abs() < 1e-4 {
                    continue; // on the boundary: rounding decides
                }
                let expected = if s > 0.0 { 1.0 } else { 0.0 };
                let spans = region.ray_intervals(e, dir);
                for kind in [ClipWeight::Mass, ClipWeight::Length] {
                    assert_eq!(
                        ray.weight(dir, &spans, kind, 3.0),
                        expected,
                        "{kind:?} ray {k}"
                    );
                }
                checked[k] += 1;
            }
        }
    }
    assert!(checked[0] > 1000 && checked[1] > 1000, "{checked:?}");
}

/// A 3-scale Gaussian converges to the flat rule as its smallest scale goes to 0 (the flat
/// rule is the limit of section 5's mass weight, not a new definition).
#[test]
fn thin_gaussians_tend_to_the_flat_weight() {
    let q = Quat::from_euler(glam::EulerRot::XYZ, 0.3, -0.4, 0.2);
    let mean = Vec3::new(0.1, -0.2, 0.0);
    let eye = Vec3::new(0.5, 0.3, -3.0);
    let region =
        ClipRegion::planes(vec![Plane::new(Vec3::new(1.0, 0.4, 0.1), -0.05).unwrap()]).unwrap();
    let flat = CutoffRay::new(mean, Vec3::new(0.2, 0.0, 0.1), q, eye);
    let mut rng = Rng::new(9);
    for _ in 0..200 {
        let target = Vec3::new(rng.range(-0.4, 0.6), rng.range(-0.6, 0.4), 0.0);
        let dir = (target - eye).as_dvec3().normalize();
        let spans = region.ray_intervals(eye.as_dvec3(), dir);
        let w_flat = flat.weight(dir, &spans, ClipWeight::Mass, 3.0);
        let thin = CutoffRay::new(mean, Vec3::new(0.2, 1e-6, 0.1), q, eye);
        let w_thin = thin.weight(dir, &spans, ClipWeight::Mass, 3.0);
        assert!(
            (w_flat - w_thin).abs() < 1e-3 || (0.01..0.99).contains(&w_thin),
            "{w_flat} {w_thin}"
        );
    }
}

/// Writes a 2-scale (GaMeS / REdiSplats) PLY of the given rows by hand, as their trainer does.
fn write_games_ply(path: &std::path::Path, rows: &[[f32; 13]]) {
    let mut f = std::fs::File::create(path).unwrap();
    let mut header = format!(
        "ply\nformat binary_little_endian 1.0\nelement vertex {}\n",
        rows.len()
    );
    for name in [
        "x", "y", "z", "f_dc_0", "f_dc_1", "f_dc_2", "opacity", "scale_0", "scale_1", "rot_0",
        "rot_1", "rot_2", "rot_3",
    ] {
        header.push_str(&format!("property float {name}\n"));
    }
    header.push_str("end_header\n");
    f.write_all(header.as_bytes()).unwrap();
    for row in rows {
        for v in row {
            f.write_all(&v.to_le_bytes()).unwrap();
        }
    }
}

#[test]
fn two_scale_ply_is_flat_along_local_x() {
    let dir = common::tempdir("two_scale");
    let path = dir.join("games.ply");
    let q = Quat::from_rotation_z(0.5);
    write_games_ply(
        &path,
        &[[
            0.0,
            1.0,
            2.0,
            0.1,
            0.2,
            0.3,
            0.5,
            0.02f32.ln(),
            0.05f32.ln(),
            q.w,
            q.x,
            q.y,
            q.z,
        ]],
    );
    let (scene, _) = load_ply(&path).unwrap();
    assert_eq!(scene.flat_count(), 1);
    assert_eq!(scene.scales[0].x, 0.0);
    assert!(scene.scales[0].abs_diff_eq(Vec3::new(0.0, 0.02, 0.05), 1e-7));
    assert!((scene.rotations[0].dot(q)).abs() > 1.0 - 1e-6);
}

#[test]
fn three_scale_ply_with_a_negligible_scale_is_flat() {
    let dir = common::tempdir("three_scale");
    let mut scene = Scene::default();
    let sh = [0.0f32; 3];
    // REdiSplats' own output: scale_0 = ln 1e-5 beside scales of 0.3.
    scene.push(
        Vec3::ZERO,
        0.5,
        Vec3::new(1e-5, 0.3, 0.2),
        Quat::IDENTITY,
        &sh,
    );
    // 1e-4 of the largest is flat; 2e-4 is not.
    scene.push(
        Vec3::ONE,
        0.5,
        Vec3::new(0.1, 0.999e-5, 0.05),
        Quat::IDENTITY,
        &sh,
    );
    scene.push(
        Vec3::ONE,
        0.5,
        Vec3::new(0.1, 2e-5, 0.05),
        Quat::IDENTITY,
        &sh,
    );
    let path = dir.join("three.ply");
    write_ply(&scene, &path, PlyEncoding::BinaryLittleEndian).unwrap();
    let (back, _) = load_ply(&path).unwrap();
    assert_eq!(back.scales[0].x, 0.0);
    assert!(back.scales[0].abs_diff_eq(Vec3::new(0.0, 0.3, 0.2), 1e-6));
    assert_eq!(back.scales[1].y, 0.0);
    assert!(back.scales[2].y > 0.0);
    assert_eq!(back.flat_count(), 2);
}

/// Both layouts write a flat scene that loads back with the same Gaussians: the INRIA one with
/// its zero scales intact, the GaMeS one with each normal moved to local x (the same
/// covariance, to float rounding).
#[test]
fn flat_scenes_round_trip_through_both_layouts() {
    let dir = common::tempdir("layouts");
    let scene = flat_layer(500, 3);
    for (layout, name) in [(PlyLayout::Inria, "inria"), (PlyLayout::Games, "games")] {
        let path = dir.join(format!("{name}.ply"));
        write_ply_layout(&scene, &path, PlyEncoding::BinaryLittleEndian, layout).unwrap();
        let (back, _) = load_ply(&path).unwrap();
        assert_eq!(back.len(), scene.len());
        assert_eq!(back.flat_count(), scene.len(), "{name}");
        for i in 0..scene.len() {
            let (a, b) = (covariance(&scene, i), covariance(&back, i));
            let err = (a - b)
                .to_cols_array()
                .iter()
                .map(|v| v.abs())
                .fold(0.0, f64::max);
            let size = a
                .to_cols_array()
                .iter()
                .map(|v| v.abs())
                .fold(0.0, f64::max);
            assert!(err <= 1e-5 * size, "{name} Gaussian {i}: {err} of {size}");
            if layout == PlyLayout::Games {
                assert_eq!(back.scales[i].x, 0.0);
            }
        }
    }
    // The GaMeS layout holds flat Gaussians only.
    let round = rara::synth::shell(10, 0, 1);
    let err = write_ply_layout(
        &round,
        dir.join("x.ply"),
        PlyEncoding::BinaryLittleEndian,
        PlyLayout::Games,
    )
    .unwrap_err()
    .to_string();
    assert!(err.contains("flat"), "{err}");
}
