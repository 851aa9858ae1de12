//! Mixed scenes (SPEC section 8, issue 33): the GPU's ray trees against the CPU reference,
//! section 8's identities, the analytic shadow, the scene file's errors.

mod common;

use glam::{Quat, Vec3};
use rara::mixed::shapes::Shape;
use rara::mixed::{Light, Material, MixedScene};
use rara::raytrace::mixed::{GpuMixedScene, MixedTracer};
use rara::RayTraceOptions;
use rara::{Clip, ShPrecision};

/// `shape` scaled by `s`, turned by `r` and moved to `t`.
fn placed(shape: &Shape, s: Vec3, r: Quat, t: Vec3) -> Vec<rara::mixed::triangles::Triangle> {
    shape.triangles(|p| r * (s * p) + t, |n| r * (n / s), 0)
}

/// The GPU's render of `scene` and the CPU reference's.
fn both(scene: &MixedScene, camera: &rara::Camera) -> (image::RgbaImage, image::RgbaImage) {
    let ctx = common::context();
    let tracer = MixedTracer::new(&ctx).unwrap();
    let gpu = GpuMixedScene::new(&ctx, scene, ShPrecision::F32).unwrap();
    let rt = RayTraceOptions::default();
    let (img, stats) = tracer.render(&gpu, camera, &rt).unwrap();
    let (cpu, cpu_stats) = rara::reference::mixed::render(scene, camera, &rt);
    eprintln!("GPU {stats:?}\nCPU {cpu_stats:?}");
    drop(gpu);
    drop(tracer);
    common::assert_no_validation_messages(&ctx);
    (img, cpu)
}

/// A generated scene with a mirror behind it, a diffuse floor under it lit by a point light,
/// and a glass ball in front.
fn showcase(clip: Clip) -> MixedScene {
    let mut s =
        MixedScene::splats_only(common::mixed_scene(600, 7), clip, Vec3::new(0.1, 0.1, 0.2));
    add_mirror_behind(&mut s);
    s.add_mesh(
        placed(
            &Shape::quad(),
            Vec3::splat(3.0),
            Quat::from_rotation_x(std::f32::consts::FRAC_PI_2),
            Vec3::new(0.0, 1.3, 0.0),
        ),
        Material::diffuse(Vec3::new(0.8, 0.7, 0.5)),
    );
    s.add_mesh(
        placed(
            &Shape::sphere(12, 24),
            Vec3::splat(0.45),
            Quat::IDENTITY,
            Vec3::new(-0.5, 0.3, -1.4),
        ),
        Material::glass(1.5),
    );
    light_from_above(&mut s);
    s
}

/// The showcase's mirror: a quad behind the splats.
fn add_mirror_behind(s: &mut MixedScene) {
    s.add_mesh(
        placed(
            &Shape::quad(),
            Vec3::splat(2.5),
            Quat::IDENTITY,
            Vec3::new(0.0, 0.0, 1.6),
        ),
        Material::mirror(0.9),
    );
}

/// The showcase's light: a point light above and in front, and some ambient light.
fn light_from_above(s: &mut MixedScene) {
    s.lights.push(Light::Point {
        position: Vec3::new(1.0, -2.5, -1.5),
        intensity: Vec3::splat(6.0),
    });
    s.ambient = Vec3::splat(0.15);
}

#[test]
fn gpu_matches_the_cpu_reference_on_a_generated_showcase() {
    let camera = common::tracer_camera(160);
    let (gpu, cpu) = both(&showcase(Clip::default()), &camera);
    gpu.save(common::artifacts_dir().join("mixed_showcase_gpu.png"))
        .unwrap();
    common::check_images("mixed showcase", &gpu, &cpu, 45.0, 255);
}

/// The showcase (mirror, lit floor, glass ball) through a still BVH (built once on the host,
/// issue 72) equals its frame through the per-frame LBVH, bit for bit: camera, mirror, glass
/// and shadow rays all walk it.
#[test]
fn a_still_bvh_changes_no_pixel_of_a_mixed_scene() {
    let ctx = common::context();
    let tracer = MixedTracer::new(&ctx).unwrap();
    let camera = common::tracer_camera(160);
    let scene = showcase(Clip::default());
    let mut gpu = GpuMixedScene::new(&ctx, &scene, ShPrecision::F32).unwrap();
    let rt = RayTraceOptions::default();
    let (lbvh, _) = tracer.render(&gpu, &camera, &rt).unwrap();
    let built = tracer.build_still_bvh(&mut gpu).unwrap();
    let (still, stats) = tracer.render(&gpu, &camera, &rt).unwrap();
    eprintln!("{built:?}; {stats:?}");
    assert_eq!(differences(&lbvh, &still), (0, 0));
    assert!(stats.secondary > 0 && stats.shadow > 0, "{stats:?}");
    drop(gpu);
    drop(tracer);
    common::assert_no_validation_messages(&ctx);
}

/// The GPU's render of `scene`.
fn gpu_render(
    ctx: &rara::Context,
    tracer: &MixedTracer,
    scene: &MixedScene,
    camera: &rara::Camera,
) -> image::RgbaImage {
    let gpu = GpuMixedScene::new(ctx, scene, ShPrecision::F32).unwrap();
    tracer
        .render(&gpu, camera, &RayTraceOptions::default())
        .unwrap()
        .0
}

fn cpu_render(scene: &MixedScene, camera: &rara::Camera) -> image::RgbaImage {
    rara::reference::mixed::render(scene, camera, &RayTraceOptions::default()).0
}

/// Pixels that differ between two images, and the largest channel difference.
fn differences(a: &image::RgbaImage, b: &image::RgbaImage) -> (usize, u8) {
    let mut n = 0;
    let mut max = 0u8;
    for (p, q) in a.pixels().zip(b.pixels()) {
        let d = (0..3).map(|c| p[c].abs_diff(q[c])).max().unwrap();
        n += (d > 0) as usize;
        max = max.max(d);
    }
    (n, max)
}

/// Section 8: a scene without meshes renders as section 7 alone, on the GPU (against the
/// section 7 tracer) and on the CPU (against the section 7 reference), bit for bit, clipped
/// or not.
#[test]
fn a_scene_without_meshes_is_section_7() {
    let ctx = common::context();
    let tracer = MixedTracer::new(&ctx).unwrap();
    let ray = rara::raytrace::tracer::RayTracer::with_k(&ctx, tracer.k()).unwrap();
    let splats = common::mixed_scene(800, 3);
    let camera = common::tracer_camera(160);
    let (lo, hi) = common::percentile_box(&splats);
    for (name, clip) in common::tracer_clips(lo, hi) {
        let scene = MixedScene::splats_only(splats.clone(), clip.clone(), Vec3::new(0.2, 0.1, 0.0));
        let options = rara::RenderOptions {
            background: scene.background,
            clip: clip.clone(),
            ..Default::default()
        };
        let rt = RayTraceOptions::default();
        let gpu_scene = rara::GpuScene::new(&ctx, &splats).unwrap();
        let (section7, _) = ray
            .render(&ctx, &gpu_scene, &camera, &options, &rt)
            .unwrap();
        let mixed = gpu_render(&ctx, &tracer, &scene, &camera);
        let (n, max) = differences(&mixed, &section7);
        eprintln!("{name}: GPU mixed vs section 7: {n} pixels differ (max {max})");
        assert_eq!(n, 0, "{name}: the GPU's mixed render is not section 7's");
        let cpu7 = rara::reference::raytrace::render(&splats, &camera, &options, &rt).0;
        let cpu = cpu_render(&scene, &camera);
        assert_eq!(
            differences(&cpu, &cpu7).0,
            0,
            "{name}: the CPU's mixed render is not section 7's"
        );
    }
    drop(tracer);
    drop(ray);
    common::assert_no_validation_messages(&ctx);
}

/// Section 8 through a scene file, as `render --scene` reads it: one splat scene from a PLY,
/// no mesh, placed with no transform and with the identity written out, renders as
/// `render --tracer ray` of the PLY, bit for bit, on the GPU and the CPU. (Placing a scene
/// once renormalized its rotations even under the identity, which moved a few pixels by one
/// level on real scenes.)
#[test]
fn a_scene_file_without_meshes_is_section_7() {
    let ctx = common::context();
    let tracer = MixedTracer::new(&ctx).unwrap();
    let ray = rara::raytrace::tracer::RayTracer::with_k(&ctx, tracer.k()).unwrap();
    let dir = common::tempdir("mixed_scene_file");
    let splats = common::mixed_scene(800, 5);
    let ply = dir.join("splats.ply");
    rara::ply::write_ply(&splats, &ply, rara::ply::PlyEncoding::BinaryLittleEndian).unwrap();
    let (splats, _) = rara::ply::load_ply(&ply).unwrap();
    let camera = common::tracer_camera(160);
    let rt = RayTraceOptions::default();
    let gpu_scene = rara::GpuScene::new(&ctx, &splats).unwrap();
    let options = rara::RenderOptions::default();
    let (section7, _) = ray
        .render(&ctx, &gpu_scene, &camera, &options, &rt)
        .unwrap();
    let cpu7 = rara::reference::raytrace::render(&splats, &camera, &options, &rt).0;
    for (name, transform) in [
        ("no transform", ""),
        (
            "identity",
            r#", "transform": {"translation": [0, 0, 0], "rotation_deg": [0, 0, 0], "scale": 1}"#,
        ),
    ] {
        let file = dir.join("scene.json");
        std::fs::write(
            &file,
            format!(r#"{{"splats": [{{"path": "splats.ply"{transform}}}], "meshes": []}}"#),
        )
        .unwrap();
        let scene = MixedScene::load(&file, |p| rara::ply::load_ply(p).map(|(s, _)| s)).unwrap();
        let (n, max) = differences(&gpu_render(&ctx, &tracer, &scene, &camera), &section7);
        eprintln!("{name}: GPU scene file vs section 7: {n} pixels differ (max {max})");
        assert_eq!(
            n, 0,
            "{name}: the GPU's render of the scene file is not section 7's"
        );
        let (n, _) = differences(&cpu_render(&scene, &camera), &cpu7);
        assert_eq!(
            n, 0,
            "{name}: the CPU's render of the scene file is not section 7's"
        );
    }
    drop(tracer);
    drop(ray);
    common::assert_no_validation_messages(&ctx);
}

/// Section 8: glass of IOR 1 changes no pixel (a ball and a slab in front of the showcase,
/// clipped and not), on the GPU and on the CPU.
#[test]
fn glass_of_ior_1_changes_no_pixel() {
    let ctx = common::context();
    let tracer = MixedTracer::new(&ctx).unwrap();
    let camera = common::tracer_camera(160);
    let (lo, hi) = common::percentile_box(&common::mixed_scene(600, 7));
    for (name, clip) in common::tracer_clips(lo, hi)
        .into_iter()
        .filter(|(n, _)| ["none", "plane_mass", "cutaway_mass"].contains(n))
    {
        let without = showcase(clip.clone());
        let mut with = without.clone();
        with.add_mesh(
            placed(
                &Shape::sphere(10, 20),
                Vec3::splat(0.6),
                Quat::IDENTITY,
                Vec3::new(0.3, -0.2, -0.2),
            ),
            Material::glass(1.0),
        );
        with.add_mesh(
            placed(
                &Shape::cube(),
                Vec3::new(0.4, 0.3, 0.05),
                Quat::from_rotation_y(0.5),
                Vec3::new(-0.3, 0.2, -2.0),
            ),
            Material::glass(1.0),
        );
        let (n, max) = differences(
            &gpu_render(&ctx, &tracer, &with, &camera),
            &gpu_render(&ctx, &tracer, &without, &camera),
        );
        eprintln!("{name}: GPU, IOR 1 glass: {n} pixels differ (max {max})");
        assert_eq!(n, 0, "{name}: IOR-1 glass changed the GPU's image");
        let (n, max) = differences(&cpu_render(&with, &camera), &cpu_render(&without, &camera));
        eprintln!("{name}: CPU, IOR 1 glass: {n} pixels differ (max {max})");
        assert_eq!(n, 0, "{name}: IOR-1 glass changed the CPU's image");
    }
    drop(tracer);
    common::assert_no_validation_messages(&ctx);
}

/// Section 8: a reflectance-1 mirror that fills the view shows the scene behind the camera as
/// the mirrored camera sees it, flipped left to right; with a rara clip the cut is seen in the
/// mirror the same way. The mirrored rays start from the mirror (their origin is the mirrored
/// eye only up to rounding), so a pixel may differ by a level.
#[test]
fn a_full_view_mirror_shows_what_the_mirrored_camera_sees() {
    let ctx = common::context();
    let tracer = MixedTracer::new(&ctx).unwrap();
    // The scene lies behind the camera (z < -2.5); the camera at z = -1.5 looks at a mirror in
    // the plane z = 0, tilted a little so that the mirror is not square to the view.
    let mut splats = common::mixed_scene(700, 11);
    for m in &mut splats.means {
        *m = Vec3::new(m.x, m.y, m.z - 4.0);
    }
    let mirror_normal = Vec3::new(0.15, -0.1, -1.0).normalize();
    let mirror_rotation = Quat::from_rotation_arc(Vec3::Z, mirror_normal);
    let camera = rara::Camera::look_at(
        Vec3::new(0.2, -0.1, -1.5),
        Vec3::new(0.0, 0.0, 0.0),
        Vec3::NEG_Y,
        50.0,
        160,
        120,
    )
    .unwrap();
    // The mirrored camera: eye and axes reflected in the mirror's plane (through the origin),
    // then its x axis turned back so that its frame is right-handed; its image is the
    // mirror's flipped left to right.
    let reflect = |v: Vec3| v - 2.0 * v.dot(mirror_normal) * mirror_normal;
    let r = camera.rotation;
    let mirrored = rara::Camera {
        position: reflect(camera.position),
        rotation: glam::Mat3::from_cols(-reflect(r.x_axis), reflect(r.y_axis), reflect(r.z_axis)),
        ..camera
    };
    let (lo, hi) = common::percentile_box(&splats);
    for (name, clip) in common::tracer_clips(lo, hi)
        .into_iter()
        .filter(|(n, _)| ["none", "plane_mass", "cutaway_mass"].contains(n))
    {
        let mut with =
            MixedScene::splats_only(splats.clone(), clip.clone(), Vec3::new(0.0, 0.1, 0.2));
        with.add_mesh(
            placed(
                &Shape::quad(),
                Vec3::splat(40.0),
                mirror_rotation,
                Vec3::ZERO,
            ),
            Material::mirror(1.0),
        );
        let alone = MixedScene::splats_only(splats.clone(), clip.clone(), with.background);
        let gpu_mirror = gpu_render(&ctx, &tracer, &with, &camera);
        let gpu_direct =
            image::imageops::flip_horizontal(&gpu_render(&ctx, &tracer, &alone, &mirrored));
        if name == "plane_mass" {
            gpu_mirror
                .save(common::artifacts_dir().join("mixed_mirror_identity.png"))
                .unwrap();
        }
        let d = common::check_images(
            &format!("mirror identity, GPU, {name}"),
            &gpu_mirror,
            &gpu_direct,
            60.0,
            2,
        );
        assert!(d.differing_pixels * 200 <= (camera.width * camera.height) as usize);
        let cpu_mirror = cpu_render(&with, &camera);
        let cpu_direct = image::imageops::flip_horizontal(&cpu_render(&alone, &mirrored));
        let d = common::check_images(
            &format!("mirror identity, CPU, {name}"),
            &cpu_mirror,
            &cpu_direct,
            60.0,
            1,
        );
        assert!(d.differing_pixels * 200 <= (camera.width * camera.height) as usize);
    }
    drop(tracer);
    common::assert_no_validation_messages(&ctx);
}

/// The colour of a channel in [0, 1].
fn level(p: &image::Rgba<u8>, c: usize) -> f64 {
    p[c] as f64 / 255.0
}

/// Section 8's shadows, against closed forms. (1) Gaussians darken the mesh behind them: a
/// white quad at z = 0 lit by a directional light along (-1, 0, 1)/sqrt 2, with a sheet (one
/// flat Gaussian of opacity 0.6 at z = -1, out of the camera's view) in the light's way; each
/// pixel of the quad, over its unshadowed value, must be 1 - alpha of the sheet where the
/// pixel's shadow ray crosses it. (2) Meshes darken the Gaussians: a flat Gaussian seen
/// straight on, an opaque quad between it and the light (out of view): its colour is 1 - 0.75
/// of the unshadowed one.
#[test]
fn shadows_match_their_closed_forms() {
    let ctx = common::context();
    let tracer = MixedTracer::new(&ctx).unwrap();
    let camera = rara::Camera::look_at(
        Vec3::new(0.5, 0.0, -3.0),
        Vec3::new(0.5, 0.0, 0.0),
        Vec3::NEG_Y,
        30.0,
        96,
        72,
    )
    .unwrap();
    let sheet_mu = Vec3::new(2.4, 0.1, -1.0);
    let (sheet_s, sheet_o) = (0.35f32, 0.6f32);
    let mut sheet = rara::Scene {
        sh_degree: 0,
        ..Default::default()
    };
    sheet.push(
        sheet_mu,
        sheet_o,
        Vec3::new(sheet_s, sheet_s, 0.0),
        Quat::IDENTITY,
        &[0.5, 0.5, 0.5],
    );
    let build = |with_sheet: bool| {
        let splats = if with_sheet {
            sheet.clone()
        } else {
            rara::Scene {
                sh_degree: 0,
                ..Default::default()
            }
        };
        let mut s = MixedScene::splats_only(splats, Clip::default(), Vec3::ZERO);
        s.add_mesh(
            placed(&Shape::quad(), Vec3::splat(6.0), Quat::IDENTITY, Vec3::ZERO),
            Material::diffuse(Vec3::ONE),
        );
        s.lights.push(Light::Directional {
            direction: Vec3::new(-1.0, 0.0, 1.0).normalize(),
            intensity: Vec3::splat(1.2),
        });
        s
    };
    let light_dir = Vec3::new(1.0, 0.0, -1.0).normalize();
    for (who, lit, shadowed) in [
        (
            "GPU",
            gpu_render(&ctx, &tracer, &build(false), &camera),
            gpu_render(&ctx, &tracer, &build(true), &camera),
        ),
        (
            "CPU",
            cpu_render(&build(false), &camera),
            cpu_render(&build(true), &camera),
        ),
    ] {
        let (mut checked, mut worst) = (0, 0.0f64);
        for (i, j, p) in shadowed.enumerate_pixels() {
            // The quad point of the pixel and where its shadow ray crosses z = -1.
            let (e, d) = rara::reference::rasterize::pixel_ray(&camera, i, j);
            let q = e + (-e.z / d.z) * d;
            let c = q.as_vec3() + light_dir * (1.0 / -light_dir.z);
            let (a, b) = ((c.x - sheet_mu.x) / sheet_s, (c.y - sheet_mu.y) / sheet_s);
            let alpha = (sheet_o as f64 * (-(a * a + b * b) as f64 / 2.0).exp()).min(0.99);
            if alpha < 0.05 || (a * a + b * b) > 9.0 {
                continue; // skipped hits (alpha < 1/255) and the octagon's rim stay out
            }
            let unlit = level(lit.get_pixel(i, j), 0);
            let got = level(p, 0) / unlit;
            worst = worst.max((got - (1.0 - alpha)).abs());
            checked += 1;
        }
        eprintln!("{who}: shadow of the sheet on the quad: {checked} pixels, worst |ratio - (1 - alpha)| {worst:.4}");
        assert!(checked > 500, "{who}: too few shadowed pixels ({checked})");
        assert!(
            worst <= 2.0 / 255.0 / 0.8,
            "{who}: the sheet's shadow is off by {worst}"
        );
    }
    // (2) A flat Gaussian at z = 0 facing the camera, lit from -z; a blocker at z = -1 where
    // the light's rays to it pass (out of view, x > 1.4).
    let mut g = rara::Scene {
        sh_degree: 0,
        ..Default::default()
    };
    g.push(
        Vec3::new(0.5, 0.0, 0.0),
        0.9,
        Vec3::new(0.6, 0.6, 0.0),
        Quat::IDENTITY,
        &[1.0, 0.6, 0.3],
    );
    let build = |blocked: bool| {
        let mut s = MixedScene::splats_only(g.clone(), Clip::default(), Vec3::ZERO);
        // An opaque quad far off to the side either way, so both scenes have a mesh.
        let x = if blocked { 2.5 } else { 40.0 };
        s.add_mesh(
            placed(
                &Shape::quad(),
                Vec3::splat(1.1),
                Quat::IDENTITY,
                Vec3::new(x, 0.0, -1.0),
            ),
            Material::diffuse(Vec3::ONE),
        );
        s.lights.push(Light::Directional {
            direction: Vec3::new(-1.0, 0.0, 1.0).normalize(),
            intensity: Vec3::ONE,
        });
        s.shadow_strength = 0.75;
        s
    };
    for (who, lit, shadowed) in [
        (
            "GPU",
            gpu_render(&ctx, &tracer, &build(false), &camera),
            gpu_render(&ctx, &tracer, &build(true), &camera),
        ),
        (
            "CPU",
            cpu_render(&build(false), &camera),
            cpu_render(&build(true), &camera),
        ),
    ] {
        let (i, j) = (camera.width / 2, camera.height / 2);
        let (l, s) = (
            level(lit.get_pixel(i, j), 0),
            level(shadowed.get_pixel(i, j), 0),
        );
        eprintln!("{who}: a mesh's shadow on a Gaussian: {s:.4} of {l:.4} (expected x0.25)");
        assert!(l > 0.3);
        assert!(
            (s - 0.25 * l).abs() <= 1.0 / 255.0,
            "{who}: {s} is not 0.25 x {l}"
        );
    }
    drop(tracer);
    common::assert_no_validation_messages(&ctx);
}

/// Several splat objects, each placed by a similarity (the SH turned with it) and clipped in
/// its own frame, in mirrors and glass: GPU vs CPU.
#[test]
fn several_clipped_objects_match_the_cpu_reference() {
    use rara::mixed::Transform;
    let mut scene = showcase(Clip::default());
    let second = common::mixed_scene(400, 21);
    let t = Transform {
        rotation: Quat::from_rotation_y(0.7) * Quat::from_rotation_x(0.3),
        translation: Vec3::new(-1.2, -0.9, -1.0),
        scale: Vec3::splat(0.6),
    };
    let (lo, hi) = common::percentile_box(&second);
    let clip_local = common::tracer_clips(lo, hi)
        .into_iter()
        .find(|(n, _)| *n == "plane_mass")
        .unwrap()
        .1;
    let mut clip = clip_local.clone();
    clip.region = Some(t.region(clip_local.region.as_ref().unwrap()).unwrap());
    scene.add_splats(&second, &t, clip);
    let camera = common::tracer_camera(160);
    let (gpu, cpu) = both(&scene, &camera);
    gpu.save(common::artifacts_dir().join("mixed_two_objects_gpu.png"))
        .unwrap();
    common::check_images("mixed, two objects, one clipped", &gpu, &cpu, 45.0, 255);
}

fn write(dir: &std::path::Path, name: &str, text: &str) -> std::path::PathBuf {
    let p = dir.join(name);
    std::fs::write(&p, text).unwrap();
    p
}

/// `common::mixed_scene(count, seed)`, written to `dir/s.ply` (binary).
fn write_splats(dir: &std::path::Path, count: usize, seed: u64) -> rara::Scene {
    let splats = common::mixed_scene(count, seed);
    rara::ply::write_ply(
        &splats,
        dir.join("s.ply"),
        rara::ply::PlyEncoding::BinaryLittleEndian,
    )
    .unwrap();
    splats
}

/// The camera of the command-line tests: a look-at view of the generated scenes, 96 wide.
const CLI_CAMERA: [&str; 6] = [
    "--eye",
    "0.4,-0.9,-3.5",
    "--target",
    "0,0,0",
    "--width",
    "96",
];

/// The `rara` binary run with `args`.
fn run_rara(args: &[&str]) -> std::process::Output {
    std::process::Command::new(env!("CARGO_BIN_EXE_rara"))
        .args(args)
        .output()
        .unwrap()
}

/// A scene file read end to end (a PLY splat scene, an OBJ with normals, a PLY mesh), and its
/// errors: each names its JSON path.
#[test]
fn scene_files_load_and_name_the_path_of_each_error() {
    let dir = common::tempdir("mixed_files");
    let splats = write_splats(&dir, 50, 5);
    write(
        &dir,
        "ball.obj",
        &Shape::sphere(6, 12).to_obj("a test ball"),
    );
    let load = |text: &str| {
        let p = write(&dir, "scene.json", text);
        rara::mixed::MixedScene::load(&p, |f| Ok(rara::ply::load_ply(f)?.0))
    };
    let ok = load(
        r#"{ "splats": [{ "path": "s.ply", "transform": { "translation": [1, 0, 0], "rotation_deg": [0, 90, 0], "scale": 2 },
                          "clip": { "planes": [[1, 0, 0, 0]] } }],
             "meshes": [{ "path": "ball.obj", "material": { "glass": { "ior": 1.5 } } },
                        { "path": "ball.obj", "transform": { "scale": [1, 2, 3] }, "material": { "diffuse": { "color": [1, 0.5, 0] } } }],
             "lights": [{ "point": { "position": [0, -3, 0], "intensity": [5, 5, 5] } }],
             "ambient": [0.1, 0.1, 0.1], "max_depth": 5 }"#,
    )
    .unwrap();
    assert_eq!(ok.gaussians.len(), 50);
    assert_eq!(ok.meshes.triangles.len(), 2 * 6 * 12 * 2 - 2 * 2 * 12);
    assert_eq!(ok.materials.len(), 2);
    // The splat scene moved: centre i is 2 R mu_i + (1, 0, 0).
    let r = Quat::from_rotation_y(std::f32::consts::FRAC_PI_2);
    assert!((ok.gaussians.means[3] - (r * (2.0 * splats.means[3]) + Vec3::X)).length() < 1e-5);
    // The clip plane x >= 0 of the scene's own frame is, in the world, R x . (y - t) >= 0.
    let region = ok.objects[0].clip.region.as_ref().unwrap();
    let probe = Vec3::new(1.0, 0.0, 0.0) + r * Vec3::new(0.3, 0.0, 0.0);
    assert!(region.signed_distance(probe) > 0.0);
    // The OBJ's normals are read and turned: the ball's normals point out.
    let t = &ok.meshes.triangles[0];
    assert!(t.n[0].dot(t.v[0]) > 0.0 || t.material == 1);
    // Meshes and lights alone: one empty splat object.
    let meshes_only = load(r#"{ "meshes": [{ "path": "ball.obj", "material": { "diffuse": { "color": [1, 1, 1] } } }] }"#).unwrap();
    assert_eq!(
        (meshes_only.objects.len(), meshes_only.gaussians.len()),
        (1, 0)
    );
    // A .gltf with its buffer in a file beside it, and one with a base64 data URI: one
    // triangle under a node moved by (0, 0, 2).
    let tri: Vec<u8> = [0f32, 0.0, 0.0, 1.0, 0.0, 0.0, 0.0, 1.0, 0.0]
        .iter()
        .flat_map(|v| v.to_le_bytes())
        .collect();
    std::fs::write(dir.join("tri.bin"), &tri).unwrap();
    use base64::Engine;
    let data_uri = format!(
        "data:application/octet-stream;base64,{}",
        base64::engine::general_purpose::STANDARD.encode(&tri)
    );
    for (name, uri) in [
        ("tri_file.gltf", "tri.bin".to_string()),
        ("tri_data.gltf", data_uri),
    ] {
        write(
            &dir,
            name,
            &format!(
                r#"{{"asset": {{"version": "2.0"}}, "buffers": [{{"uri": "{uri}", "byteLength": 36}}],
                    "bufferViews": [{{"buffer": 0, "byteLength": 36}}],
                    "accessors": [{{"bufferView": 0, "componentType": 5126, "count": 3, "type": "VEC3", "min": [0, 0, 0], "max": [1, 1, 0]}}],
                    "meshes": [{{"primitives": [{{"attributes": {{"POSITION": 0}}}}]}}],
                    "nodes": [{{"mesh": 0, "translation": [0, 0, 2]}}], "scenes": [{{"nodes": [0]}}], "scene": 0}}"#
            ),
        );
        let s = load(&format!(r#"{{ "meshes": [{{ "path": "{name}", "material": {{ "mirror": {{ "reflectance": 1 }} }} }}] }}"#)).unwrap();
        assert_eq!(s.meshes.triangles.len(), 1, "{name}");
        assert_eq!(
            s.meshes.triangles[0].v[1],
            Vec3::new(1.0, 0.0, 2.0),
            "{name}"
        );
    }
    for (text, wanted) in [
        (
            r#"{ "splats": [{ "path": "s.ply", "transfrom": {} }] }"#,
            "splats[0].transfrom: unknown field `transfrom`",
        ),
        (
            r#"{ "meshes": [{ "path": "nope.obj", "material": { "mirror": { "reflectance": 1 } } }] }"#,
            "meshes[0].path: no such file",
        ),
        (
            r#"{ "meshes": [{ "path": "ball.obj", "material": { "glass": { "ior": 0.5 } } }] }"#,
            "meshes[0].material.glass.ior: must be finite and >= 1",
        ),
        (
            r#"{ "meshes": [{ "path": "ball.obj", "material": { "metal": {} } }] }"#,
            "meshes[0].material: unknown variant `metal`",
        ),
        (
            r#"{ "lights": [{ "point": { "position": [0, 0], "intensity": [1, 1, 1] } }] }"#,
            "lights[0].point.position",
        ),
        (
            r#"{ "splats": [{ "path": "s.ply", "transform": { "scale": [1, 2, 1] } }] }"#,
            "splats[0].transform.scale: a splat scene takes one uniform scale",
        ),
        (
            r#"{ "splats": [{ "path": "s.ply", "clip": { "planes": [[0, 0, 0, 1]] } }] }"#,
            "splats[0].clip",
        ),
        (r#"{ "max_depth": 9 }"#, "max_depth: at most 8"),
        (
            r#"{ "background": [2, 0, 0] }"#,
            "background: each channel must lie in [0, 1]",
        ),
    ] {
        let err = load(text)
            .err()
            .unwrap_or_else(|| panic!("{text} loaded"))
            .to_string();
        eprintln!("{err}");
        assert!(err.contains(wanted), "'{err}' does not name '{wanted}'");
    }
}

/// The example scenes' meshes (`examples/scenes/meshes/`) are the crate's own shapes, written
/// by this test (`RARA_UPDATE_DOCS=1` rewrites them).
#[test]
fn example_meshes_are_current() {
    let dir = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("examples/scenes/meshes");
    for (name, shape) in [
        ("quad.obj", Shape::quad()),
        ("cube.obj", Shape::cube()),
        ("sphere.obj", Shape::sphere(24, 48)),
    ] {
        let text = shape.to_obj(&format!(
            "{name}: made by rara::mixed::shapes (tests/mixed.rs, example_meshes_are_current)"
        ));
        let path = dir.join(name);
        if std::env::var_os("RARA_UPDATE_DOCS").is_some() {
            std::fs::create_dir_all(&dir).unwrap();
            std::fs::write(&path, &text).unwrap();
        }
        let on_disk = std::fs::read_to_string(&path).unwrap_or_default();
        assert!(
            on_disk == text,
            "{} is stale: run with RARA_UPDATE_DOCS=1",
            path.display()
        );
    }
}

/// The examples of `examples/scenes/` (real scenes, where they are present): GPU vs CPU at
/// 320 px wide, the orbit's first camera.
#[test]
fn examples_match_the_cpu_reference() {
    let dir = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("examples/scenes");
    let ctx = common::context();
    let tracer = MixedTracer::new(&ctx).unwrap();
    for (name, stem) in [
        ("mirror_plant", "plant_capture_sh0"),
        ("glass_biker", "biker_capture_sh0"),
        ("shadow_skull", "skull_mesh2splat_100k_sh0"),
        ("clipped_mirror", "plant_capture_sh0"),
        ("glass_plant", "plant_capture_sh0"),
    ] {
        let Some((_, Some(cameras))) = common::real_scene(stem) else {
            continue;
        };
        let scene = MixedScene::load(&dir.join(format!("{name}.json")), |f| {
            Ok(rara::ply::load_ply(f)?.0)
        })
        .unwrap();
        let camera = rara::Camera::load_one(&cameras, 0)
            .unwrap()
            .resized(320, None)
            .unwrap();
        let gpu = gpu_render(&ctx, &tracer, &scene, &camera);
        let cpu = cpu_render(&scene, &camera);
        eprintln!("real-scene case 'example {name}' ran");
        common::check_images(
            &format!("example {name}, GPU vs CPU"),
            &gpu,
            &cpu,
            45.0,
            255,
        );
    }
    drop(tracer);
    common::assert_no_validation_messages(&ctx);
}

/// `render --scene`, `bench --scene` and `sweep --scene` from the command line, on a scene file of the crate's
/// own (a generated PLY, an OBJ), and a bad file's error on stderr with its JSON path.
#[test]
fn the_cli_renders_and_benches_a_scene_file() {
    let dir = common::tempdir("mixed_cli");
    write_splats(&dir, 300, 9);
    write(&dir, "quad.obj", &Shape::quad().to_obj("a quad"));
    let scene = write(
        &dir,
        "scene.json",
        r#"{ "splats": [{ "path": "s.ply" }],
             "meshes": [{ "path": "quad.obj", "transform": { "translation": [0, 0, 1.5], "scale": 3 },
                          "material": { "mirror": { "reflectance": 0.8 } } }] }"#,
    );
    let rara = run_rara;
    let out = dir.join("out.png");
    let cam = CLI_CAMERA;
    let s = scene.to_str().unwrap();
    let run = rara(
        &[
            &["render", "--scene", s, "-o", out.to_str().unwrap()][..],
            &cam[..],
        ]
        .concat(),
    );
    let stdout = String::from_utf8_lossy(&run.stdout);
    assert!(
        run.status.success(),
        "{}",
        String::from_utf8_lossy(&run.stderr)
    );
    assert!(stdout.contains("secondary"), "{stdout}");
    assert_eq!(image::open(&out).unwrap().width(), 96);
    let run = rara(
        &[
            &["bench", "--scene", s, "--frames", "2", "--warmup", "0"][..],
            &cam[..],
        ]
        .concat(),
    );
    let stdout = String::from_utf8_lossy(&run.stdout);
    assert!(
        run.status.success(),
        "{}",
        String::from_utf8_lossy(&run.stderr)
    );
    assert!(
        stdout.contains("median frame") && stdout.contains("trace"),
        "{stdout}"
    );
    let sweep = dir.join("sweep");
    let run = rara(
        &[
            &[
                "sweep",
                "--scene",
                s,
                "--plane-normal",
                "1,0,0",
                "--frames",
                "2",
                "-o",
                sweep.to_str().unwrap(),
            ][..],
            &cam[..],
        ]
        .concat(),
    );
    assert!(
        run.status.success(),
        "{}",
        String::from_utf8_lossy(&run.stderr)
    );
    assert!(sweep.join("frame_0001.png").is_file() && sweep.join("sweep.gif").is_file());
    let bad = write(
        &dir,
        "bad.json",
        r#"{ "meshes": [{ "path": "quad.obj", "material": { "mirror": { "reflectance": 2 } } }] }"#,
    );
    let run = rara(
        &[
            &[
                "render",
                "--scene",
                bad.to_str().unwrap(),
                "-o",
                out.to_str().unwrap(),
            ][..],
            &cam[..],
        ]
        .concat(),
    );
    let stderr = String::from_utf8_lossy(&run.stderr);
    assert!(!run.status.success());
    assert!(
        stderr.contains("meshes[0].material.mirror.reflectance"),
        "{stderr}"
    );
}

/// A frame of more rays than one batch of the tracer (640x480: two batches of 2^18), whose
/// generations each trace a few rays in both: GPU vs CPU.
#[test]
fn a_frame_of_two_batches_matches_the_cpu_reference() {
    let camera = common::tracer_camera(640);
    assert!(camera.width * camera.height > rara::raytrace::tracer::TRACE_BATCH_RAYS);
    let (gpu, cpu) = both(&showcase(Clip::default()), &camera);
    common::check_images("mixed showcase, two batches", &gpu, &cpu, 45.0, 255);
}

/// A scene file's `camera` entry (look_at, inria, file): `render --scene` without camera
/// options renders what the same camera on the command line renders, to the byte; the command
/// line overrides it, `--width` resizes it, and a bad or missing camera is a clear error.
#[test]
fn a_scene_files_camera_is_the_command_lines() {
    let dir = common::tempdir("mixed_scene_camera");
    write_splats(&dir, 400, 7);
    let (eye, target) = (Vec3::new(0.4, -0.9, -3.5), Vec3::ZERO);
    let look = rara::Camera::look_at(eye, target, Vec3::NEG_Y, 40.0, 96, 64).unwrap();
    let other = rara::Camera::look_at(
        Vec3::new(-1.0, -0.5, -3.0),
        target,
        Vec3::NEG_Y,
        55.0,
        80,
        60,
    )
    .unwrap();
    // Both cameras as an INRIA cameras.json (rotation rows as written).
    let inria = |c: &rara::Camera, id: usize| {
        let r = c.rotation.transpose().to_cols_array_2d();
        format!(
            r#"{{"id": {id}, "img_name": "x", "width": {}, "height": {}, "position": {:?}, "rotation": {:?}, "fx": {}, "fy": {}}}"#,
            c.width,
            c.height,
            c.position.to_array(),
            r,
            c.fx,
            c.fy
        )
    };
    let cams = write(
        &dir,
        "cams.json",
        &format!("[{}, {}]", inria(&look, 0), inria(&other, 1)),
    );
    let scene = |camera: &str| {
        let extra = if camera.is_empty() {
            String::new()
        } else {
            format!(r#", "camera": {camera}"#)
        };
        format!(r#"{{ "splats": [{{ "path": "s.ply" }}]{extra} }}"#)
    };
    let plain = write(&dir, "plain.json", &scene(""));
    let rara = run_rara;
    let render = |file: &std::path::Path, extra: &[&str], name: &str| {
        let out = dir.join(format!("{name}.png"));
        let mut args = vec![
            "render",
            "--scene",
            file.to_str().unwrap(),
            "-o",
            out.to_str().unwrap(),
        ];
        args.extend_from_slice(extra);
        let run = rara(&args);
        assert!(
            run.status.success(),
            "{name}: {}",
            String::from_utf8_lossy(&run.stderr)
        );
        image::open(&out).unwrap().to_rgba8()
    };
    let cams_s = cams.to_str().unwrap();
    let eye_args = [
        "--eye",
        "0.4,-0.9,-3.5",
        "--target",
        "0,0,0",
        "--fov-y",
        "40",
        "--width",
        "96",
        "--height",
        "64",
    ];
    let by_eye = render(&plain, &eye_args, "by_eye");
    let by_file_1 = render(&plain, &["--cameras", cams_s, "--camera", "1"], "by_file_1");
    assert_ne!(by_eye, by_file_1, "the two cameras see different images");
    // The look_at form, its defaults (up -Y) and its numbers as the command line's.
    let look_at = write(
        &dir,
        "look_at.json",
        &scene(
            r#"{ "look_at": { "eye": [0.4, -0.9, -3.5], "target": [0, 0, 0], "fov_y_deg": 40, "width": 96, "height": 64 } }"#,
        ),
    );
    assert!(render(&look_at, &[], "look_at") == by_eye, "look_at");
    // An INRIA camera written out, and camera 1 of a cameras.json.
    let inria_file = write(
        &dir,
        "inria.json",
        &scene(&format!(r#"{{ "inria": {} }}"#, inria(&look, 0))),
    );
    assert!(render(&inria_file, &[], "inria") == by_eye, "inria");
    let from_file = write(
        &dir,
        "file.json",
        &scene(r#"{ "file": { "path": "cams.json", "index": 1 } }"#),
    );
    assert!(render(&from_file, &[], "file") == by_file_1, "file");
    // The command line overrides the file's camera; --width resizes it.
    assert!(
        render(&from_file, &eye_args, "override") == by_eye,
        "override"
    );
    let half = render(&look_at, &["--width", "48"], "half");
    assert_eq!((half.width(), half.height()), (48, 32));
    // The parsed camera is Camera::look_at's.
    let parsed = rara::mixed::file::SceneFile::read(&look_at)
        .unwrap()
        .camera(&look_at)
        .unwrap();
    assert_eq!(parsed, Some(look));
    // Without a camera entry, a glTF mesh's own camera (placed by the mesh entry's
    // transform), as a glTF viewer would show it: down the node's -Z, +Y up.
    let tri: Vec<u8> = [0f32, 0.0, 0.0, 1.0, 0.0, 0.0, 0.0, 1.0, 0.0]
        .iter()
        .flat_map(|v| v.to_le_bytes())
        .collect();
    std::fs::write(dir.join("tri.bin"), &tri).unwrap();
    let half_turn_y = std::f32::consts::FRAC_1_SQRT_2;
    for (name, rotation) in [
        ("plain", [0.0, 0.0, 0.0, 1.0]),
        ("turned", [0.0, half_turn_y, 0.0, half_turn_y]),
    ] {
        write(
            &dir,
            "cam.gltf",
            &format!(
                r#"{{"asset": {{"version": "2.0"}}, "buffers": [{{"uri": "tri.bin", "byteLength": 36}}],
                    "bufferViews": [{{"buffer": 0, "byteLength": 36}}],
                    "accessors": [{{"bufferView": 0, "componentType": 5126, "count": 3, "type": "VEC3", "min": [0, 0, 0], "max": [1, 1, 0]}}],
                    "meshes": [{{"primitives": [{{"attributes": {{"POSITION": 0}}}}]}}],
                    "cameras": [{{"type": "perspective", "perspective": {{"yfov": 0.6, "aspectRatio": 1.5, "znear": 0.01}}}}],
                    "nodes": [{{"mesh": 0}}, {{"camera": 0, "translation": [0, 0, 5], "rotation": {rotation:?}}}],
                    "scenes": [{{"nodes": [0, 1]}}], "scene": 0}}"#
            ),
        );
        let with_gltf = write(
            &dir,
            "gltf_camera.json",
            r#"{ "splats": [{ "path": "s.ply" }],
                 "meshes": [{ "path": "cam.gltf", "transform": { "translation": [1, 0, 0] },
                              "material": { "diffuse": { "color": [1, 1, 1] } } }] }"#,
        );
        let cam = rara::mixed::file::SceneFile::read(&with_gltf)
            .unwrap()
            .camera(&with_gltf)
            .unwrap()
            .expect("the glTF's camera");
        assert_eq!((cam.width, cam.height), (640, 427), "{name}");
        assert!(
            (cam.position - Vec3::new(1.0, 0.0, 5.0)).length() < 1e-6,
            "{name}"
        );
        let forward = cam.rotation.col(2);
        let want_forward = if name == "plain" {
            Vec3::NEG_Z
        } else {
            Vec3::NEG_X
        };
        assert!(
            (forward - want_forward).length() < 1e-6,
            "{name}: forward {forward}"
        );
        assert!(
            (cam.rotation.col(1) - Vec3::NEG_Y).length() < 1e-6,
            "{name}: down"
        );
        if name == "plain" {
            let want = rara::Camera::look_at(
                Vec3::new(1.0, 0.0, 5.0),
                Vec3::new(1.0, 0.0, 0.0),
                Vec3::Y,
                0.6f32.to_degrees(),
                640,
                427,
            )
            .unwrap();
            assert!((cam.fy - want.fy).abs() < 1e-3 && cam.fx == cam.fy);
            assert!((cam.rotation.col(0) - want.rotation.col(0)).length() < 1e-6);
        }
        let img = render(&with_gltf, &["--width", "64"], name);
        assert_eq!((img.width(), img.height()), (64, 43), "{name}");
    }
    // Errors name the entry (no camera at all frames the scene: tests/cli.rs).
    for (text, wanted) in [
        (
            r#"{ "look_at": { "eye": [0, 0, 0], "target": [0, 0, 0] } }"#,
            "camera.look_at: --eye and --target must differ",
        ),
        (
            r#"{ "file": { "path": "cams.json", "index": 5 } }"#,
            "camera index 5 is out of range",
        ),
        (
            r#"{ "file": { "path": "nope.json" } }"#,
            "camera.file.path: no such file",
        ),
        (r#"{ "orbit": {} }"#, "camera: unknown variant `orbit`"),
    ] {
        let bad = write(&dir, "bad.json", &scene(text));
        let out = dir.join("bad.png");
        let run = rara(&[
            "render",
            "--scene",
            bad.to_str().unwrap(),
            "-o",
            out.to_str().unwrap(),
        ]);
        let stderr = String::from_utf8_lossy(&run.stderr);
        assert!(!run.status.success(), "{text}: rendered");
        assert!(
            stderr.contains(wanted),
            "{text}: '{stderr}' does not name '{wanted}'"
        );
    }
}

/// A scene file's splat scenes are read by the loader `render` uses, so every format: a glb
/// (KHR_gaussian_splatting, lossless for these floats) renders the PLY's image to the byte,
/// the lossy SPZ and .splat the image of their own Gaussians written back as PLY.
#[test]
fn scene_files_take_splat_scenes_in_every_format() {
    let dir = common::tempdir("mixed_formats");
    write_splats(&dir, 600, 3);
    let ply = dir.join("s.ply");
    let rara = |args: &[&str]| {
        let run = run_rara(args);
        assert!(
            run.status.success(),
            "{args:?}: {}",
            String::from_utf8_lossy(&run.stderr)
        );
    };
    let render = |name: &str| {
        let file = write(
            &dir,
            &format!("{name}.json"),
            &format!(
                r#"{{ "splats": [{{ "path": "{name}" }}],
                     "meshes": [{{ "path": "ball.obj", "transform": {{ "translation": [0.6, 0, -0.5], "scale": 0.3 }},
                                  "material": {{ "mirror": {{ "reflectance": 0.9 }} }} }}] }}"#
            ),
        );
        let out = dir.join(format!("{name}.png"));
        let args = [
            "render",
            "--scene",
            file.to_str().unwrap(),
            "-o",
            out.to_str().unwrap(),
        ];
        rara(&[&args[..], &CLI_CAMERA[..]].concat());
        image::open(&out).unwrap().to_rgba8()
    };
    write(
        &dir,
        "ball.obj",
        &Shape::sphere(6, 12).to_obj("a test ball"),
    );
    let want = render("s.ply");
    // A lossless format gives the PLY's image; a lossy one, the image of the Gaussians it
    // holds, as converted back to PLY.
    for (name, lossless) in [("s.glb", true), ("s.spz", false), ("s.splat", false)] {
        rara(&[
            "convert",
            ply.to_str().unwrap(),
            "-o",
            dir.join(name).to_str().unwrap(),
        ]);
        let got = render(name);
        let want = if lossless {
            want.clone()
        } else {
            let back = format!("{name}.ply");
            rara(&[
                "convert",
                dir.join(name).to_str().unwrap(),
                "-o",
                dir.join(&back).to_str().unwrap(),
            ]);
            render(&back)
        };
        let (n, max) = differences(&got, &want);
        eprintln!("{name}: {n} pixels differ (max {max})");
        assert_eq!(n, 0, "{name}");
    }
}

/// Many splat objects (the showcase and 19 more, some clipped, one empty): each Gaussian's
/// object, found in halves over their first Gaussians, picks its clip; GPU against the CPU.
#[test]
fn many_objects_match_the_cpu_reference() {
    use rara::mixed::Transform;
    let mut scene = showcase(Clip::default());
    let small = common::mixed_scene(60, 31);
    let (lo, hi) = common::percentile_box(&small);
    let clip_local = common::tracer_clips(lo, hi)
        .into_iter()
        .find(|(n, _)| *n == "plane_mass")
        .unwrap()
        .1;
    let empty = rara::Scene::default();
    for k in 0..19 {
        let t = Transform {
            rotation: Quat::from_rotation_y(0.3 * k as f32),
            translation: Vec3::new(
                -1.5 + 0.33 * (k % 10) as f32,
                -1.0 + 0.8 * (k / 10) as f32,
                -1.2,
            ),
            scale: Vec3::splat(0.25),
        };
        let clip = if k % 3 == 0 {
            let mut c = clip_local.clone();
            c.region = Some(t.region(clip_local.region.as_ref().unwrap()).unwrap());
            c
        } else {
            Clip::default()
        };
        scene.add_splats(if k == 7 { &empty } else { &small }, &t, clip);
    }
    assert_eq!(scene.objects.len(), 20);
    let camera = common::tracer_camera(160);
    let (gpu, cpu) = both(&scene, &camera);
    gpu.save(common::artifacts_dir().join("mixed_many_objects_gpu.png"))
        .unwrap();
    common::check_images("mixed, 20 objects, some clipped", &gpu, &cpu, 45.0, 255);
}

/// Every node's box holds its children's boxes and its leaves' triangles, each triangle is in
/// one leaf, and the depth is the one recorded.
fn assert_bounds_hold(bvh: &rara::mixed::triangles::MeshBvh) {
    use rara::mixed::triangles::MESH_LEAF_BIT;
    let inside =
        |lo: [f32; 3], hi: [f32; 3], p: Vec3| (0..3).all(|k| lo[k] <= p[k] && p[k] <= hi[k]);
    let mut seen = vec![false; bvh.triangles.len()];
    let mut deepest = 0;
    let mut stack = vec![(0usize, 0u32)];
    while let Some((n, depth)) = stack.pop() {
        deepest = deepest.max(depth);
        let node = bvh.nodes[n];
        if node.a & MESH_LEAF_BIT != 0 {
            let first = (node.a & !MESH_LEAF_BIT) as usize;
            let count = node.b as usize;
            for (k, seen) in seen.iter_mut().enumerate().skip(first).take(count) {
                assert!(!*seen, "triangle {k} in two leaves");
                *seen = true;
                for v in bvh.triangles[k].v {
                    assert!(
                        inside(node.lo, node.hi, v),
                        "node {n} does not hold triangle {k}"
                    );
                }
            }
        } else {
            for c in [node.a, node.b] {
                let child = bvh.nodes[c as usize];
                assert!(
                    inside(node.lo, node.hi, Vec3::from(child.lo))
                        && inside(node.lo, node.hi, Vec3::from(child.hi)),
                    "node {n} does not hold its child {c}"
                );
                stack.push((c as usize, depth + 1));
            }
        }
    }
    assert!(seen.iter().all(|&s| s), "a triangle in no leaf");
    assert_eq!(deepest, bvh.depth);
}

/// Meshes of two million triangles (issue 73): a diffuse sphere of 2,000,000 triangles and a
/// mirror of 2 beside a splat scene, lit; obvhs's trees stay inside the traversal's stack and
/// bound what they hold, and the GPU's image is the CPU reference's.
#[test]
fn two_million_triangles_match_the_cpu_reference() {
    let mut scene = MixedScene::splats_only(
        common::mixed_scene(600, 7),
        Clip::default(),
        Vec3::new(0.1, 0.1, 0.2),
    );
    let start = std::time::Instant::now();
    let ball = Shape::sphere(1001, 1000);
    let tris = placed(
        &ball,
        Vec3::splat(0.5),
        Quat::IDENTITY,
        Vec3::new(0.7, 0.2, -0.6),
    );
    assert_eq!(tris.len(), 2_000_000);
    scene.add_mesh(tris, Material::diffuse(Vec3::new(0.8, 0.5, 0.3)));
    add_mirror_behind(&mut scene);
    light_from_above(&mut scene);
    let built_ms = start.elapsed().as_secs_f64() * 1e3;
    // The trees (obvhs's, within the GPU traversal's stack) bound every triangle they hold.
    for bvh in [&scene.meshes, &scene.occluders] {
        assert!(
            !bvh.median_split,
            "obvhs's tree was too deep: depth {}",
            bvh.depth
        );
        assert!(bvh.depth <= rara::mixed::triangles::MAX_MESH_DEPTH);
        assert_bounds_hold(bvh);
    }
    eprintln!(
        "2,000,002 triangles: BVHs (all, opaque) built in {built_ms:.0} ms ({:.0} + {:.0} ms by \
         obvhs, {} and {} triangles split again by the median), {} and {} nodes, depth {} and {}",
        scene.meshes.build_ms,
        scene.occluders.build_ms,
        scene.meshes.median_triangles,
        scene.occluders.median_triangles,
        scene.meshes.nodes.len(),
        scene.occluders.nodes.len(),
        scene.meshes.depth,
        scene.occluders.depth
    );
    let camera = common::tracer_camera(96);
    let (gpu, cpu) = both(&scene, &camera);
    gpu.save(common::artifacts_dir().join("mixed_two_million_triangles_gpu.png"))
        .unwrap();
    common::check_images("mixed, 2M triangles", &gpu, &cpu, 45.0, 255);
}

/// A glb made here (not by a real producer: the cases Blender does not write): its quad's
/// material samples a texture at `TEXCOORD_1` (`TEXCOORD_0` is all zeros) from a data-URI
/// PNG of four flat quadrants, with a base colour factor, u clamped and v mirrored; a second
/// primitive has no material. `image` picks the image's encoding (`"png"`, `"jpeg"`) and
/// `material` the quad's material JSON (`TEX` stands for the texture reference).
fn texture_glb(dir: &std::path::Path, image: &str, material: &str) -> std::path::PathBuf {
    use base64::Engine;
    let mut img = image::RgbImage::new(64, 64);
    for (x, y, p) in img.enumerate_pixels_mut() {
        *p = image::Rgb(match (x >= 32, y >= 32) {
            (false, false) => [255, 0, 0],
            (true, false) => [0, 255, 0],
            (false, true) => [0, 0, 255],
            (true, true) => [255, 255, 255],
        });
    }
    let mut encoded = Vec::new();
    let format = match image {
        "png" => image::ImageFormat::Png,
        _ => image::ImageFormat::Jpeg,
    };
    img.write_to(&mut std::io::Cursor::new(&mut encoded), format)
        .unwrap();
    let uri = format!(
        "data:image/{image};base64,{}",
        base64::engine::general_purpose::STANDARD.encode(&encoded)
    );
    // The quad at z = 2, x and y in [-1, 1]: u = x + 1 and v = y + 1, both in [0, 2]; then
    // a triangle off to the side; then the indices.
    let mut bin: Vec<u8> = Vec::new();
    let f = |bin: &mut Vec<u8>, xs: &[f32]| bin.extend(xs.iter().flat_map(|x| x.to_le_bytes()));
    f(
        &mut bin,
        &[-1., -1., 2., 1., -1., 2., 1., 1., 2., -1., 1., 2.],
    ); // 0..48
    f(&mut bin, &[0.0; 8]); // 48..80: TEXCOORD_0
    f(&mut bin, &[0., 0., 2., 0., 2., 2., 0., 2.]); // 80..112: TEXCOORD_1
    f(&mut bin, &[5., 0., 2., 6., 0., 2., 5., 1., 2.]); // 112..148
    bin.extend([0u16, 2, 1, 0, 3, 2].iter().flat_map(|i| i.to_le_bytes())); // 148..160
    let json = format!(
        r#"{{ "asset": {{ "version": "2.0" }},
  "buffers": [{{ "byteLength": {len} }}],
  "bufferViews": [
    {{ "buffer": 0, "byteOffset": 0, "byteLength": 48 }},
    {{ "buffer": 0, "byteOffset": 48, "byteLength": 32 }},
    {{ "buffer": 0, "byteOffset": 80, "byteLength": 32 }},
    {{ "buffer": 0, "byteOffset": 112, "byteLength": 36 }},
    {{ "buffer": 0, "byteOffset": 148, "byteLength": 12 }}],
  "accessors": [
    {{ "bufferView": 0, "componentType": 5126, "count": 4, "type": "VEC3",
       "min": [-1, -1, 2], "max": [1, 1, 2] }},
    {{ "bufferView": 1, "componentType": 5126, "count": 4, "type": "VEC2" }},
    {{ "bufferView": 2, "componentType": 5126, "count": 4, "type": "VEC2" }},
    {{ "bufferView": 3, "componentType": 5126, "count": 3, "type": "VEC3",
       "min": [5, 0, 2], "max": [6, 1, 2] }},
    {{ "bufferView": 4, "componentType": 5123, "count": 6, "type": "SCALAR" }}],
  "images": [{{ "uri": "{uri}" }}],
  "samplers": [{{ "wrapS": 33071, "wrapT": 33648 }}],
  "textures": [{{ "source": 0, "sampler": 0 }}],
  "materials": [{material}],
  "meshes": [{{ "primitives": [
    {{ "attributes": {{ "POSITION": 0, "TEXCOORD_0": 1, "TEXCOORD_1": 2 }}, "indices": 4,
       "material": 0 }},
    {{ "attributes": {{ "POSITION": 3 }} }}] }}],
  "nodes": [{{ "mesh": 0 }}], "scenes": [{{ "nodes": [0] }}], "scene": 0 }}"#,
        len = bin.len(),
        material = material.replace(
            "TEX",
            r#""baseColorTexture": { "index": 0, "texCoord": 1 }"#
        ),
    );
    let path = dir.join(format!("textured_{image}.glb"));
    std::fs::write(&path, common::glb_of(json.as_bytes(), &bin)).unwrap();
    path
}

/// glTF materials beyond what Blender writes (issue 73): the texture set a material names
/// (`TEXCOORD_1`), a base colour factor times the texture, the sampler's wraps (u clamped, v
/// mirrored: each distinguishable from the others at the sampled points), a data-URI image,
/// PNG and JPEG; a primitive without a material is diffuse white; a mesh entry's material
/// overrides the file's (no texture read); and the file's errors name where they are.
#[test]
fn gltf_textures_follow_their_texture_set_factor_and_wraps() {
    let dir = common::tempdir("mixed_gltf_textures");
    let camera = rara::Camera::look_at(
        Vec3::ZERO,
        Vec3::new(0.0, 0.0, 2.0),
        Vec3::NEG_Y,
        50.0,
        64,
        64,
    )
    .unwrap();
    let textured = r#"{ "pbrMetallicRoughness": { TEX, "baseColorFactor": [1, 0.5, 1, 1] } }"#;
    let load = |glb: &std::path::Path, material: &str| {
        let file = write(
            &dir,
            "scene.json",
            &format!(
                r#"{{ "meshes": [{{ "path": "{}"{material} }}], "ambient": [1, 1, 1] }}"#,
                glb.file_name().unwrap().to_str().unwrap()
            ),
        );
        MixedScene::load(&file, |f| Ok(rara::ply::load_ply(f)?.0))
    };
    for (image, tolerance) in [("png", 1u8), ("jpeg", 12)] {
        let glb = texture_glb(&dir, image, textured);
        let scene = load(&glb, "").unwrap();
        assert_eq!(scene.textures.len(), 1);
        assert_eq!(
            scene.materials.len(),
            2,
            "the file's material and the default"
        );
        assert_eq!(
            scene.materials[1],
            rara::mixed::Material::diffuse(Vec3::ONE)
        );
        let (gpu, cpu) = both(&scene, &camera);
        common::check_images(
            &format!("glTF texture ({image}), GPU vs CPU"),
            &gpu,
            &cpu,
            45.0,
            255,
        );
        // Sample points at u and v of about 0.26, 0.74, 1.25 and 1.74 (pixels 6, 23, 40, 57):
        // u clamped reads the right column past 1 (repeat: the left at 1.25), v mirrored the
        // bottom rows at 1.25 and the top at 1.74 (repeat: top at 1.25; clamp: bottom at 1.74).
        let (red, green, blue, white) = ([255, 0, 0], [0, 128, 0], [0, 0, 255], [255, 128, 255]);
        let want = [
            [red, green, green, green],
            [blue, white, white, white],
            [blue, white, white, white],
            [red, green, green, green],
        ];
        let at = [6u32, 23, 40, 57];
        for img in [&gpu, &cpu] {
            for (row, &j) in at.iter().enumerate() {
                for (col, &i) in at.iter().enumerate() {
                    let p = img.get_pixel(i, j);
                    let w = want[row][col];
                    let ok = (0..3).all(|c| p[c].abs_diff(w[c]) <= tolerance);
                    assert!(ok, "{image}: pixel ({i}, {j}) is {p:?}, not {w:?}");
                }
            }
        }
    }
    // A mesh entry's own material: the file's materials and textures are not read.
    let glb = texture_glb(&dir, "png", textured);
    let scene = load(
        &glb,
        r#", "material": { "mirror": { "reflectance": 0.5 } }"#,
    )
    .unwrap();
    assert!(scene.textures.is_empty());
    assert_eq!(scene.materials, vec![rara::mixed::Material::mirror(0.5)]);
    // Errors name the material and the field.
    for (material, wanted) in [
        (
            r#"{ "extensions": { "KHR_materials_transmission": { "transmissionFactor": 1 },
                 "KHR_materials_ior": { "ior": 0.5 } } }"#,
            "materials[0].ior is 0.5",
        ),
        (
            r#"{ "pbrMetallicRoughness": { "baseColorFactor": [2, 0, 0, 1] } }"#,
            "baseColorFactor[0] is 2",
        ),
        (
            r#"{ "pbrMetallicRoughness": { "baseColorTexture": { "index": 0, "texCoord": 2 } } }"#,
            "TEXCOORD_2, which the primitive lacks",
        ),
        (
            r#"{ "pbrMetallicRoughness": { "baseColorTexture": { "index": 7 } } }"#,
            "missing texture 7",
        ),
        // No material at all, where the quad names material 0.
        ("", "names material 0, and the file has 0"),
    ] {
        let glb = texture_glb(&dir, "png", material);
        let err = load(&glb, "").expect_err("refused").to_string();
        assert!(err.contains(wanted), "'{err}' does not say '{wanted}'");
    }
}
