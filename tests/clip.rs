//! RaRa clipping (SPEC section 5): GPU against the CPU reference for every mode x weight x
//! region kind, and the SPEC's properties (identity at infinity, continuity, partition, no
//! leaks, exact multi-plane intersection).

mod common;

use glam::{DVec3, Quat, Vec3};
use image::RgbaImage;
use rara::clip::{
    normal_cdf, Classification, Clip, ClipMode, ClipRegion, ClipWeight, CutoffRay, Plane,
};
use rara::gpu_types::GpuProjectedSplat;
use rara::metrics::{compare, ssim};
use rara::reference;
use rara::stages::rasterize::RasterLayout;
use rara::synth::Rng;
use rara::{Camera, FrameStats, GpuScene, RenderOptions, Renderer, Scene};

/// One region of each kind, placed through the middle of the scene.
fn regions(scene: &Scene) -> Vec<(&'static str, ClipRegion)> {
    let (lo, hi) = common::percentile_box(scene);
    let c = 0.5 * (lo + hi);
    let ext = hi - lo;
    let n1 = Vec3::new(1.0, 0.3, -0.2).normalize();
    let n2 = Vec3::new(-0.2, 1.0, 0.4).normalize();
    let planes = vec![
        Plane::new(n1, -n1.dot(c)).unwrap(),
        Plane::new(n2, -n2.dot(c + 0.15 * ext)).unwrap(),
    ];
    let rot = Quat::from_euler(glam::EulerRot::XYZ, 0.3, 0.5, -0.2);
    vec![
        ("planes", ClipRegion::planes(planes).unwrap()),
        (
            "box",
            ClipRegion::oriented_box(c + 0.1 * ext, 0.3 * ext, rot).unwrap(),
        ),
        (
            "sphere",
            ClipRegion::sphere(c + 0.25 * ext, 0.45 * ext.max_element()).unwrap(),
        ),
        (
            "box_cutaway",
            ClipRegion::oriented_box(c - 0.2 * ext, 0.35 * ext, rot)
                .unwrap()
                .inverted(),
        ),
    ]
}

/// hard, rara-mass, rara-length (and the trace-all ablation) of `region`.
fn modes(region: &ClipRegion) -> Vec<(&'static str, Clip)> {
    let hard = Clip::hard(region.clone());
    let mass = Clip::rara(region.clone());
    let length = Clip {
        weight: ClipWeight::Length,
        ..mass.clone()
    };
    let trace_all = Clip {
        trace_all: true,
        ..mass.clone()
    };
    vec![
        ("hard", hard),
        ("mass", mass),
        ("length", length),
        ("mass_trace_all", trace_all),
    ]
}

/// Renders every region x mode with the GPU (rasterizer `layout`) and the CPU reference;
/// PSNR >= 50 dB. `nudged`: cameras a hair away from `camera` whose reference images the GPU
/// may match instead, pixel by pixel (see `closest_reference`).
fn gpu_matches_cpu(
    name: &str,
    scene: &Scene,
    camera: &Camera,
    nudged: &[Camera],
    layout: RasterLayout,
) {
    let ctx = common::context();
    let mut renderer = Renderer::with_raster_layout(&ctx, layout).unwrap();
    let gpu_scene = renderer.upload(scene).unwrap();
    let (unclipped, _) = renderer
        .render(&gpu_scene, camera, &RenderOptions::default())
        .unwrap();
    for (region_name, region) in regions(scene) {
        for (mode_name, clip) in modes(&region) {
            let options = over_grey(clip);
            let (gpu, stats) = renderer.render(&gpu_scene, camera, &options).unwrap();
            let mut cpu = reference::render(scene, camera, &options);
            if !nudged.is_empty() {
                let others: Vec<_> = nudged
                    .iter()
                    .map(|c| reference::render(scene, c, &options))
                    .collect();
                cpu = closest_reference(&gpu, cpu, &others);
            }
            let d = common::check_images(
                &format!("clip_{name}_{region_name}_{mode_name}_{layout:?}"),
                &gpu,
                &cpu,
                50.0,
                16,
            );
            eprintln!(
                "  {name} {region_name} {mode_name} {layout:?}: {} cutoff, PSNR {:.2} dB",
                stats.cutoff, d.psnr
            );
            // Cutoff pairs are classified by tile exactly when the clip allows it.
            assert_eq!(
                stats.cutoff_pairs > 0,
                options.clip.classifies_cutoff_tiles(),
                "{region_name} {mode_name}: cutoff pairs classified: {}",
                stats.cutoff_pairs
            );
            if mode_name == "hard" {
                assert_eq!(stats.cutoff, 0);
            } else {
                assert!(
                    stats.cutoff > 0,
                    "{region_name} {mode_name}: no cutoff Gaussian"
                );
            }
            // The clip must change the picture, or the case tests nothing.
            assert!(compare(&gpu, &unclipped).differing_pixels > 0);
        }
    }
    common::assert_no_validation_messages(&ctx);
}

fn orbit_camera(scene: &Scene, width: u32) -> Camera {
    nudged_orbit_camera(scene, width, 0.0)
}

/// `orbit_camera` with its eye moved by `nudge` times the scene's size along x.
fn nudged_orbit_camera(scene: &Scene, width: u32, nudge: f32) -> Camera {
    let (lo, hi) = common::percentile_box(scene);
    let c = 0.5 * (lo + hi);
    let r = (hi - lo).length();
    let eye = c + r * Vec3::new(0.8 + nudge, -0.35, 0.6);
    Camera::look_at(eye, c, Vec3::NEG_Y, 50.0, width, width * 3 / 4).unwrap()
}

/// Per pixel, whichever of `reference` and `others` lies closest to `gpu`. A flat Gaussian's
/// clip weight is a step (SPEC section 6), 0 or 1 as its plane crossing falls outside or
/// inside the visible part of the ray: at a pixel whose crossing lies on the clip boundary to
/// within float rounding, the GPU's ray and the reference's can fall on either side. On
/// `layers_flat` two such pixels flip by 30 when the eye moves by 3e-6 of the scene's size;
/// comparing against the references from eyes moved by 1e-5 either way accepts what a camera
/// that close shows, and still fails any pixel that no such camera shows.
fn closest_reference(gpu: &RgbaImage, mut reference: RgbaImage, others: &[RgbaImage]) -> RgbaImage {
    let distance = |a: &image::Rgba<u8>, b: &image::Rgba<u8>| {
        (0..4).map(|k| a[k].abs_diff(b[k])).max().unwrap()
    };
    for (x, y, best) in reference.enumerate_pixels_mut() {
        let g = gpu.get_pixel(x, y);
        for other in others {
            let o = other.get_pixel(x, y);
            if distance(g, o) < distance(g, best) {
                *best = *o;
            }
        }
    }
    reference
}

/// Both rasterizer layouts: lavapipe picks strips, GPUs a pixel per invocation, and the two
/// compile the weight code differently.
#[test]
fn gpu_matches_cpu_on_synthetic_scenes() {
    for (name, scene) in [
        ("shell", rara::synth::shell(6000, 1, 3)),
        ("hair", rara::synth::hair(8000, 0, 4)),
        ("layers", rara::synth::layers(12000, 2, 5)),
        // Flat Gaussians (SPEC section 6): the same clips, the plane-crossing weight.
        ("layers_flat", rara::synth::layers(12000, 2, 5).flattened()),
    ] {
        let camera = orbit_camera(&scene, 240);
        let nudged: Vec<Camera> = if scene.flat_count() > 0 {
            [-1e-5, 1e-5]
                .map(|n| nudged_orbit_camera(&scene, 240, n))
                .into()
        } else {
            Vec::new()
        };
        for layout in common::raster_layouts(&common::context()) {
            gpu_matches_cpu(name, &scene, &camera, &nudged, layout);
        }
    }
}

#[test]
fn gpu_matches_cpu_on_real_scenes() {
    let mut ran = 0;
    for stem in ["plant_capture_sh0", "biker_capture_sh0"] {
        let Some((ply, cams)) = common::real_scene(stem) else {
            continue;
        };
        ran += 1;
        eprintln!("real-scene case '{stem}' RAN");
        let (scene, _) = rara::ply::load_ply(&ply).unwrap();
        let camera = match cams {
            Some(path) => Camera::load_one(&path, 0)
                .unwrap()
                .resized(240, None)
                .unwrap(),
            None => orbit_camera(&scene, 240),
        };
        // The device's own layout: strips on lavapipe.
        let layout = RasterLayout::for_device(&common::context());
        gpu_matches_cpu(stem, &scene, &camera, &[], layout);
    }
    if ran == 0 {
        common::test_skipped("none of its real scenes is here");
    }
}

/// SPEC: with a plane at infinity the rara image equals the unclipped one, both weights, with
/// and without trace_all (the paper's Table 2).
#[test]
fn plane_at_infinity_is_the_unclipped_image() {
    let ctx = common::context();
    let mut renderer = Renderer::new(&ctx).unwrap();
    let scene = rara::synth::layers(10000, 1, 9);
    let camera = orbit_camera(&scene, 200);
    let gpu_scene = renderer.upload(&scene).unwrap();
    let plain = RenderOptions::default();
    let (unclipped, _) = renderer.render(&gpu_scene, &camera, &plain).unwrap();
    let cpu_unclipped = reference::render(&scene, &camera, &plain);
    // Far away on the visible side of every Gaussian, in two orientations.
    for plane in [
        Plane::new(Vec3::new(0.3, -1.0, 0.2), 1e4).unwrap(),
        Plane::new(Vec3::new(-0.5, 0.1, -1.0), 1e4).unwrap(),
    ] {
        let region = ClipRegion::planes(vec![plane]).unwrap();
        for weight in [ClipWeight::Mass, ClipWeight::Length] {
            for trace_all in [false, true] {
                let options = RenderOptions {
                    clip: Clip {
                        weight,
                        trace_all,
                        ..Clip::rara(region.clone())
                    },
                    ..RenderOptions::default()
                };
                let (gpu, stats) = renderer.render(&gpu_scene, &camera, &options).unwrap();
                let d = compare(&gpu, &unclipped);
                let s = ssim(&gpu, &unclipped);
                eprintln!(
                    "infinite plane, {weight:?}, trace_all {trace_all}: {} cutoff, L1 {}, SSIM {s}",
                    stats.cutoff, d.l1
                );
                assert_eq!(d.l1, 0.0, "{weight:?} trace_all {trace_all}: L1 {}", d.l1);
                assert_eq!(s, 1.0);
                if trace_all {
                    assert_eq!(
                        stats.cutoff, stats.visible,
                        "trace_all makes every splat cutoff"
                    );
                } else {
                    assert_eq!(stats.cutoff, 0);
                }
                let cpu = reference::render(&scene, &camera, &options);
                assert_eq!(compare(&cpu, &cpu_unclipped).l1, 0.0, "CPU reference");
            }
        }
    }
    common::assert_no_validation_messages(&ctx);
}

/// SPEC: the rara image changes continuously as a plane moves; the hard image jumps when a
/// centre crosses it. The plane moves by 1e-4 of the scene size across one Gaussian's centre.
#[test]
fn rara_is_continuous_where_hard_clipping_pops() {
    let ctx = common::context();
    let mut renderer = Renderer::new(&ctx).unwrap();
    let mut scene = rara::synth::shell(4000, 0, 21);
    let camera = rara::synth::orbit_cameras(1, 3.2, 240, 180, 50.0).unwrap()[0];
    let view = camera.rotation * Vec3::Z;
    // The front-most Gaussian, made white and opaque so that its loss shows.
    let k = (0..scene.len())
        .max_by(|&a, &b| (-view.dot(scene.means[a])).total_cmp(&-view.dot(scene.means[b])))
        .unwrap();
    scene.opacities[k] = 0.95;
    let stride = scene.sh_stride();
    for c in 0..3 {
        scene.sh[k * stride + c] = rara::scene::rgb_to_sh_dc(1.0);
    }
    let gpu_scene = renderer.upload(&scene).unwrap();
    // A plane seen edge-on through that centre; the step is 1e-4 of the scene size (2).
    let n = view.cross(Vec3::Y).normalize();
    let step = 1e-4 * 2.0;
    let at = n.dot(scene.means[k]);
    let plane = |d: f32| ClipRegion::planes(vec![Plane::new(n, d).unwrap()]).unwrap();
    let render = |renderer: &mut Renderer, clip: Clip| {
        let options = RenderOptions {
            clip,
            ..RenderOptions::default()
        };
        renderer.render(&gpu_scene, &camera, &options).unwrap().0
    };
    let (before, after) = (plane(-at + step / 2.0), plane(-at - step / 2.0));
    let hard_jump = compare(
        &render(&mut renderer, Clip::hard(before.clone())),
        &render(&mut renderer, Clip::hard(after.clone())),
    )
    .max_diff;
    eprintln!("hard clipping: plane step {step} changes a pixel by {hard_jump}/255");
    assert!(hard_jump > 20, "hard clipping should pop: {hard_jump}/255");
    for weight in [ClipWeight::Mass, ClipWeight::Length] {
        let clip = |region: ClipRegion| Clip {
            weight,
            ..Clip::rara(region)
        };
        let a = render(&mut renderer, clip(before.clone()));
        let b = render(&mut renderer, clip(after.clone()));
        let jump = compare(&a, &b).max_diff;
        eprintln!("rara {weight:?}: plane step {step} changes a pixel by at most {jump}/255");
        assert!(jump <= 2, "rara {weight:?} jumps by {jump}/255");
    }
    common::assert_no_validation_messages(&ctx);
}

/// SPEC (mass): the weights of a region and of its inversion add up to 1 for any Gaussian and
/// ray; checked on the reference's maths to 1e-5 and through the GPU on single splats.
#[test]
fn mass_weights_of_a_region_and_its_inversion_sum_to_one() {
    let mut rng = Rng::new(5);
    let mut worst = 0f64;
    for case in 0..3000 {
        let mean = Vec3::new(
            rng.range(-1.0, 1.0),
            rng.range(-1.0, 1.0),
            rng.range(-1.0, 1.0),
        );
        let scale = Vec3::new(
            rng.range(0.01, 0.5),
            rng.range(0.01, 0.5),
            rng.range(0.002, 0.5),
        );
        let ray = CutoffRay::new(mean, scale, rng.rotation(), Vec3::new(0.0, 0.0, -4.0));
        let region = match case % 3 {
            0 => ClipRegion::planes(
                (0..1 + case % 5)
                    .map(|_| Plane::new(rng.unit_vector(), rng.range(-0.5, 0.5)).unwrap())
                    .collect(),
            )
            .unwrap(),
            1 => ClipRegion::oriented_box(
                mean * 0.5,
                Vec3::splat(rng.range(0.1, 1.0)),
                rng.rotation(),
            )
            .unwrap(),
            _ => ClipRegion::sphere(mean + 0.3 * rng.unit_vector(), rng.range(0.1, 1.0)).unwrap(),
        };
        let inverted = region.clone().inverted();
        let target = mean + 0.5 * scale.max_element() * rng.unit_vector();
        let dir = (target.as_dvec3() - DVec3::new(0.0, 0.0, -4.0)).normalize();
        let eye = DVec3::new(0.0, 0.0, -4.0);
        let w = |r: &ClipRegion| ray.weight(dir, &r.ray_intervals(eye, dir), ClipWeight::Mass, 3.0);
        let sum = w(&region) + w(&inverted);
        worst = worst.max((sum - 1.0).abs());
    }
    eprintln!("max |w(K) + w(not K) - 1| over 3000 cases: {worst:e}");
    assert!(worst <= 1e-5, "{worst}");
    assert_eq!(normal_cdf(20.0) - normal_cdf(-20.0), 1.0);

    // GPU: one translucent splat, so that the pixel is alpha * colour; the two halves add up
    // to the whole within the rounding of the three 8-bit images.
    let ctx = common::context();
    let mut renderer = Renderer::new(&ctx).unwrap();
    let mut scene = Scene::default();
    let grey = [rara::scene::rgb_to_sh_dc(0.9); 3];
    scene.push(
        Vec3::ZERO,
        0.6,
        Vec3::new(0.5, 0.2, 0.3),
        Quat::from_rotation_z(0.5),
        &grey,
    );
    let gpu_scene = renderer.upload(&scene).unwrap();
    let camera = Camera::look_at(
        Vec3::new(0.3, -0.2, -3.0),
        Vec3::ZERO,
        Vec3::NEG_Y,
        40.0,
        160,
        120,
    )
    .unwrap();
    let (whole, _) = renderer
        .render(&gpu_scene, &camera, &RenderOptions::default())
        .unwrap();
    for region in [
        ClipRegion::planes(vec![Plane::new(Vec3::new(1.0, 0.5, 0.3), 0.05).unwrap()]).unwrap(),
        ClipRegion::sphere(Vec3::new(0.2, 0.1, 0.0), 0.4).unwrap(),
    ] {
        let mut halves = Vec::new();
        for r in [region.clone(), region.inverted()] {
            let options = RenderOptions {
                clip: Clip::rara(r),
                ..RenderOptions::default()
            };
            let (img, stats) = renderer.render(&gpu_scene, &camera, &options).unwrap();
            assert_eq!(stats.cutoff, 1);
            halves.push(img);
        }
        let mut worst = 0;
        for ((a, b), w) in halves[0]
            .pixels()
            .zip(halves[1].pixels())
            .zip(whole.pixels())
        {
            for c in 0..3 {
                worst = worst.max((a.0[c] as i32 + b.0[c] as i32 - w.0[c] as i32).abs());
            }
        }
        eprintln!("GPU: |image(K) + image(not K) - image| <= {worst}/255");
        assert!(worst <= 2, "{worst}");
        assert!(compare(&halves[0], &whole).differing_pixels > 0);
        assert!(compare(&halves[1], &whole).differing_pixels > 0);
    }
    common::assert_no_validation_messages(&ctx);
}

/// A needle (length/width 100) just behind a plane: no pixel in front of it gets brighter than
/// 1/255, whatever the weight; the 2D dilation of 0.3 must not leak it.
#[test]
fn needle_behind_a_plane_does_not_leak() {
    let ctx = common::context();
    let mut renderer = Renderer::new(&ctx).unwrap();
    let camera = Camera::look_at(
        Vec3::new(0.0, 0.0, -3.0),
        Vec3::ZERO,
        Vec3::NEG_Y,
        50.0,
        240,
        180,
    )
    .unwrap();
    let white = [rara::scene::rgb_to_sh_dc(1.0); 3];
    let width = 0.004;
    let mut scene = Scene::default();
    // Two needles parallel to the plane z = 0, 6 widths behind it, seen face-on and turned.
    for rot in [
        Quat::IDENTITY,
        Quat::from_rotation_z(0.8) * Quat::from_rotation_x(0.3),
    ] {
        scene.push(
            Vec3::new(0.0, 0.0, 6.0 * width),
            0.99,
            Vec3::new(100.0 * width, width, width),
            rot,
            &white,
        );
    }
    // Visible where z <= 0, the camera's side.
    let region =
        ClipRegion::planes(vec![Plane::new(Vec3::new(0.0, 0.0, -1.0), 0.0).unwrap()]).unwrap();
    let gpu_scene = renderer.upload(&scene).unwrap();
    let (unclipped, _) = renderer
        .render(&gpu_scene, &camera, &RenderOptions::default())
        .unwrap();
    let brightest = |img: &image::RgbaImage| {
        img.pixels()
            .map(|p| p.0[0].max(p.0[1]).max(p.0[2]))
            .max()
            .unwrap()
    };
    assert!(
        brightest(&unclipped) > 200,
        "the needles must show unclipped"
    );
    for weight in [ClipWeight::Mass, ClipWeight::Length] {
        let options = RenderOptions {
            clip: Clip {
                weight,
                ..Clip::rara(region.clone())
            },
            ..RenderOptions::default()
        };
        let (gpu, stats) = renderer.render(&gpu_scene, &camera, &options).unwrap();
        assert_eq!(
            stats.cutoff, 2,
            "the needles are within the band, so cutoff"
        );
        let cpu = reference::render(&scene, &camera, &options);
        eprintln!(
            "needle behind plane, {weight:?}: brightest pixel GPU {}, CPU {}",
            brightest(&gpu),
            brightest(&cpu)
        );
        assert!(
            brightest(&gpu) <= 1,
            "{weight:?}: GPU leaks {}",
            brightest(&gpu)
        );
        assert!(
            brightest(&cpu) <= 1,
            "{weight:?}: CPU leaks {}",
            brightest(&cpu)
        );
    }
    common::assert_no_validation_messages(&ctx);
}

/// One frame rendered with the per-tile classes of cutoff pairs switched off, then on (left
/// on).
fn render_without_and_with_tile_classes(
    renderer: &mut Renderer,
    scene: &GpuScene,
    camera: &Camera,
    options: &RenderOptions,
) -> ((RgbaImage, FrameStats), (RgbaImage, FrameStats)) {
    renderer.set_cutoff_tile_classes(false);
    let plain = renderer.render(scene, camera, options).unwrap();
    renderer.set_cutoff_tile_classes(true);
    let classified = renderer.render(scene, camera, options).unwrap();
    (plain, classified)
}

/// Options that clip with `clip` over a dark, not black, background, so that an error in a
/// pixel's transmittance shows.
fn over_grey(clip: Clip) -> RenderOptions {
    RenderOptions {
        background: Vec3::new(0.1, 0.1, 0.15),
        clip,
        ..RenderOptions::default()
    }
}

/// The scenes and cameras of the per-tile tests: two synthetic scenes framed by
/// `orbit_camera` and, where the real scenes are found, plant from its camera 0 at 320 pixels
/// wide.
fn tile_class_cases() -> Vec<(&'static str, Scene, Camera)> {
    let mut cases = vec![];
    for (name, scene) in [
        ("shell", rara::synth::shell(6000, 1, 3)),
        ("layers", rara::synth::layers(12000, 2, 5)),
        // Flat Gaussians take flat_tile_class (cutoff_tiles_body.glsl).
        ("layers_flat", rara::synth::layers(12000, 2, 5).flattened()),
    ] {
        let camera = orbit_camera(&scene, 240);
        cases.push((name, scene, camera));
    }
    if let Some((ply, Some(cams))) = common::real_scene("plant_capture_sh0") {
        eprintln!("real-scene case 'plant_capture_sh0' RAN");
        let camera = Camera::load_one(&cams, 0)
            .unwrap()
            .resized(320, None)
            .unwrap();
        cases.push(("plant", rara::ply::load_ply(&ply).unwrap().0, camera));
    }
    cases
}

/// The per-tile classes of cutoff pairs (`stages::cutoff_tiles`) only save work: the image is
/// the same with and without them to within rounding, for planes, a box and a cutaway, while
/// some of the cutoff pairs are drawn plain or left out (45 % in these small frames, 58-69 %
/// in the bench's). A sphere is not classified. Both rasterizer layouts, whose cutoff-tiles
/// kernels share the pairs out differently (whole splats per invocation through texel views,
/// a workgroup's pairs over its invocations through buffer loads), classify the same pairs
/// the same way, the texel kernel from the bounds the records' pass stored, the other from
/// its own, over the records project wrote (GPU layout).
#[test]
fn cutoff_tile_classes_change_no_pixel() {
    let ctx = common::context();
    let mut counts_by_layout = Vec::new();
    for layout in common::raster_layouts(&ctx) {
        let mut renderer = Renderer::with_raster_layout(&ctx, layout).unwrap();
        counts_by_layout.push(tile_classes_change_no_pixel(&mut renderer, layout));
    }
    if let [strips, pixels] = &counts_by_layout[..] {
        assert_eq!(strips, pixels, "classes by layout");
    }
    common::assert_no_validation_messages(&ctx);
}

/// `cutoff_tile_classes_change_no_pixel` in one layout: each case's (cutoff pairs, weight 1,
/// empty, splats decided whole).
fn tile_classes_change_no_pixel(
    renderer: &mut Renderer,
    layout: RasterLayout,
) -> Vec<(u32, u32, u32, u32)> {
    let mut counts = Vec::new();
    let (mut all, mut weight_one, mut empty, mut whole) = (0u64, 0u64, 0u64, 0u64);
    for (name, scene, camera) in tile_class_cases() {
        let gpu_scene = renderer.upload(&scene).unwrap();
        for (region_name, region) in regions(&scene) {
            let options = over_grey(Clip::rara(region));
            let ((plain, plain_stats), (classified, stats)) =
                render_without_and_with_tile_classes(renderer, &gpu_scene, &camera, &options);
            assert_eq!(
                plain_stats.cutoff_pairs, 0,
                "{name} {region_name}: switched off"
            );
            assert_eq!(
                stats.cutoff_pairs > 0,
                region_name != "sphere",
                "{name} {region_name}: {} cutoff pairs classified",
                stats.cutoff_pairs
            );
            eprintln!(
                "  {layout:?} {name} {region_name}: {} cutoff pairs, {} weight 1, {} empty; {} of {} cutoff splats decided whole",
                stats.cutoff_pairs,
                stats.cutoff_pairs_weight_one,
                stats.cutoff_pairs_empty,
                stats.cutoff_whole,
                stats.cutoff
            );
            assert!(stats.cutoff_whole <= stats.cutoff);
            // The GPU layout's project writes the records itself, and its cutoff-tiles kernel
            // bounds the weights over the footprints: those frames have no records' pass, and
            // their classes and images are the ones checked here. The strips layout (CPU
            // drivers) keeps the pass.
            let records_pass = |s: &FrameStats| s.passes.iter().any(|p| p.name == "cutoff records");
            if !stats.passes.is_empty() {
                for (s, classes) in [(&plain_stats, "without"), (&stats, "with")] {
                    assert_eq!(
                        records_pass(s),
                        layout == RasterLayout::Strips,
                        "{layout:?} {name} {region_name}: records' pass {classes} the classes"
                    );
                }
            }
            common::check_images(
                &format!("cutoff_tile_classes_{layout:?}_{name}_{region_name}"),
                &classified,
                &plain,
                60.0,
                1,
            );
            counts.push((
                stats.cutoff_pairs,
                stats.cutoff_pairs_weight_one,
                stats.cutoff_pairs_empty,
                stats.cutoff_whole,
            ));
            all += stats.cutoff_pairs as u64;
            weight_one += stats.cutoff_pairs_weight_one as u64;
            empty += stats.cutoff_pairs_empty as u64;
            whole += stats.cutoff_whole as u64;
        }
    }
    // Some splats are decided whole (the records' pass on CPU drivers, the kernel itself on
    // GPUs), and the images above match those without any class.
    assert!(whole > 0, "no cutoff splat decided whole");
    // Both classes occur, and together spare at least a tenth of the cutoff pairs the weight.
    assert!(
        weight_one > 0 && empty > 0,
        "{weight_one} weight 1, {empty} empty"
    );
    assert!(
        (weight_one + empty) * 10 >= all,
        "{weight_one} weight 1 + {empty} empty of {all}"
    );
    counts
}

/// The split of the tiles by rasterize kernel (`stages::tile_lists`, the strips rasterizer
/// under rara clipping by planes with the mass weight) only saves work: the image is
/// bit-identical with and without it, and the weighted kernel walks some tiles but not all.
#[test]
fn tile_lists_change_no_pixel() {
    let ctx = common::context();
    if !common::runs_cpu_layouts(&ctx) {
        return;
    }
    let mut renderer = Renderer::with_raster_layout(&ctx, RasterLayout::Strips).unwrap();
    let mut split = 0;
    for (name, scene, camera) in tile_class_cases() {
        let (gx, gy) = rara::camera::tile_grid(camera.width, camera.height);
        let gpu_scene = renderer.upload(&scene).unwrap();
        for (region_name, region) in regions(&scene) {
            let options = over_grey(Clip::rara(region));
            renderer.set_tile_lists(false);
            let (whole_grid, whole_stats) = renderer.render(&gpu_scene, &camera, &options).unwrap();
            renderer.set_tile_lists(true);
            let (listed, stats) = renderer.render(&gpu_scene, &camera, &options).unwrap();
            eprintln!(
                "  {name} {region_name}: {} of {} tiles weighted, {} partial pairs",
                stats.weighted_tiles,
                gx * gy,
                stats.cutoff_pairs_partial()
            );
            assert_eq!(whole_stats.weighted_tiles, 0, "{name} {region_name}: off");
            assert!(stats.weighted_tiles <= stats.cutoff_pairs_partial());
            if stats.weighted_tiles > 0 && stats.weighted_tiles < gx * gy {
                split += 1;
            }
            common::check_images(
                &format!("tile_lists_{name}_{region_name}"),
                &listed,
                &whole_grid,
                f64::INFINITY,
                0,
            );
        }
    }
    assert!(split >= 4, "{split} frames split their tiles");
    common::assert_no_validation_messages(&ctx);
}

/// A workgroup's 256 cutoff splats that each cover hundreds of tiles (about 800 here, 230,000
/// pairs in all) outrun the cutoff-tiles kernel's loop budget (CUTOFF_TILES_LOOP_BUDGET) on a
/// CPU driver, whose first SIMD vector of 8 invocations takes the workgroup's splats in turn.
/// The pairs it leaves unclassified are drawn exactly, so the image matches the one without tile
/// classes. The other layout's kernel shares the 230,000 pairs out over the workgroup, within
/// the budget, and matches too.
#[test]
fn cutoff_tiles_past_the_loop_budget_change_no_pixel() {
    let ctx = common::context();
    for layout in common::raster_layouts(&ctx) {
        let mut renderer = Renderer::with_raster_layout(&ctx, layout).unwrap();
        cutoff_tiles_past_the_loop_budget(&mut renderer);
    }
    common::assert_no_validation_messages(&ctx);
}

/// `cutoff_tiles_past_the_loop_budget_change_no_pixel` in `renderer`'s layout.
fn cutoff_tiles_past_the_loop_budget(renderer: &mut Renderer) {
    let mut scene = rara::synth::shell(0, 0, 1);
    let mut rng = Rng::new(7);
    for _ in 0..300 {
        let mean = Vec3::new(
            rng.range(-0.4, 1.0),
            rng.range(-0.8, 0.8),
            rng.range(-0.3, 0.3),
        );
        let color = [
            rng.range(0.0, 1.0),
            rng.range(0.0, 1.0),
            rng.range(0.0, 1.0),
        ];
        let sh = color.map(rara::scene::rgb_to_sh_dc);
        scene.push(mean, 0.4, Vec3::splat(0.25), rng.rotation(), &sh);
    }
    let camera = Camera::look_at(
        Vec3::new(0.0, 0.0, -3.0),
        Vec3::ZERO,
        Vec3::NEG_Y,
        50.0,
        1280,
        960,
    )
    .unwrap();
    let gpu_scene = renderer.upload(&scene).unwrap();
    // Every splat is cutoff: within 0.7 of the plane x = 0.3, under 3 sigma (0.75).
    let region = ClipRegion::planes(vec![Plane::new(Vec3::X, -0.3).unwrap()]).unwrap();
    let options = RenderOptions {
        clip: Clip::rara(region),
        ..RenderOptions::default()
    };
    let ((plain, _), (classified, stats)) =
        render_without_and_with_tile_classes(renderer, &gpu_scene, &camera, &options);
    let layout = renderer.raster_layout();
    eprintln!(
        "{layout:?}: {} cutoff splats, {} cutoff pairs, {} weight 1, {} empty",
        stats.cutoff, stats.cutoff_pairs, stats.cutoff_pairs_weight_one, stats.cutoff_pairs_empty
    );
    assert!(stats.cutoff >= 256, "{} cutoff splats", stats.cutoff);
    assert!(
        stats.cutoff_pairs > 131_072,
        "{} cutoff pairs",
        stats.cutoff_pairs
    );
    assert!(stats.cutoff_pairs_weight_one + stats.cutoff_pairs_empty > 0);
    // Pairs left unclassified may be weighted in any tile: on a CPU driver (the strips
    // rasterizer, whose tile lists this is) every tile takes the weighted kernel.
    if layout == RasterLayout::Strips {
        assert_eq!(stats.weighted_tiles, 80 * 60, "weighted tiles");
    }
    common::check_images(
        &format!("cutoff_tiles_loop_budget_{layout:?}"),
        &classified,
        &plain,
        60.0,
        1,
    );
}

/// What the GPU made of each Gaussian in the last frame.
fn gpu_classes(splats: &[GpuProjectedSplat]) -> Vec<Option<bool>> {
    splats
        .iter()
        .map(|s| s.drawn().then_some(s.cutoff != u32::MAX))
        .collect()
}

/// Multi-plane regions are exact intersections; a box is its six planes; a sphere and its
/// inversion partition the scene.
#[test]
fn regions_combine_exactly() {
    let ctx = common::context();
    let mut renderer = Renderer::new(&ctx).unwrap();
    let scene = rara::synth::layers(20000, 0, 13);
    let camera = orbit_camera(&scene, 200);
    let gpu_scene = renderer.upload(&scene).unwrap();
    let (_, all) = renderer
        .render(&gpu_scene, &camera, &RenderOptions::default())
        .unwrap();
    let on_screen = gpu_classes(&renderer.intermediates(&gpu_scene, &all).unwrap().splats);

    // Eight planes around the origin.
    let mut rng = Rng::new(77);
    let planes: Vec<Plane> = (0..8)
        .map(|_| Plane::new(rng.unit_vector(), rng.range(0.2, 0.6)).unwrap())
        .collect();
    let clip = Clip::rara(ClipRegion::planes(planes.clone()).unwrap());
    let (_, stats) = renderer
        .render(
            &gpu_scene,
            &camera,
            &RenderOptions {
                clip: clip.clone(),
                ..RenderOptions::default()
            },
        )
        .unwrap();
    let classes = gpu_classes(&renderer.intermediates(&gpu_scene, &stats).unwrap().splats);
    let (mut gone, mut checked) = (0, 0);
    for i in 0..scene.len() {
        let r = 3.0 * scene.scales[i].max_element();
        let outside_one = planes.iter().any(|p| p.distance(scene.means[i]) < -r);
        if outside_one {
            gone += 1;
            assert_eq!(
                classes[i], None,
                "Gaussian {i} is outside a plane by more than r"
            );
        }
        // Away from the thresholds the GPU's classes are the reference's.
        let s = planes
            .iter()
            .map(|p| p.distance(scene.means[i]))
            .fold(f32::INFINITY, f32::min);
        if on_screen[i].is_some() && (s.abs() - r).abs() > 1e-4 {
            checked += 1;
            let expected = match clip.classify(scene.means[i], scene.scales[i]) {
                Classification::Dropped => None,
                Classification::Drawn => Some(false),
                Classification::Cutoff => Some(true),
            };
            assert_eq!(classes[i], expected, "Gaussian {i}");
        }
    }
    eprintln!("8 planes: {gone} Gaussians outside one plane by more than r, all gone; {checked} classes checked");
    assert!(gone > 1000 && stats.cutoff > 100);

    // A box equals its six planes, written out here independently.
    let (centre, half, rot) = (
        Vec3::new(0.1, -0.2, 0.05),
        Vec3::new(0.5, 0.7, 0.4),
        Quat::from_rotation_y(0.7),
    );
    let mut faces = Vec::new();
    for (axis, h) in [Vec3::X, Vec3::Y, Vec3::Z].into_iter().zip(half.to_array()) {
        let a = rot * axis;
        let face = centre + h * a; // a point on the +axis face; inside is behind it
        faces.push(Plane::new(-a, a.dot(face)).unwrap());
        let face = centre - h * a;
        faces.push(Plane::new(a, -a.dot(face)).unwrap());
    }
    for mode in [ClipMode::Hard, ClipMode::Rara] {
        for weight in [ClipWeight::Mass, ClipWeight::Length] {
            let render = |renderer: &mut Renderer, region: ClipRegion| {
                let clip = Clip {
                    mode,
                    weight,
                    ..Clip::rara(region)
                };
                renderer
                    .render(
                        &gpu_scene,
                        &camera,
                        &RenderOptions {
                            clip,
                            ..RenderOptions::default()
                        },
                    )
                    .unwrap()
                    .0
            };
            let as_box = render(
                &mut renderer,
                ClipRegion::oriented_box(centre, half, rot).unwrap(),
            );
            let as_planes = render(&mut renderer, ClipRegion::planes(faces.clone()).unwrap());
            let d = compare(&as_box, &as_planes);
            eprintln!(
                "box vs six planes, {mode:?} {weight:?}: max diff {}, {} pixels differ",
                d.max_diff, d.differing_pixels
            );
            assert!(
                d.max_diff <= 1 && d.differing_pixels < 10,
                "{mode:?} {weight:?}"
            );
        }
    }

    // A sphere and its inversion: hard puts every Gaussian on exactly one side; rara draws in
    // one what it drops in the other, and cuts off the same Gaussians in both.
    let sphere = ClipRegion::sphere(Vec3::new(0.2, 0.0, -0.1), 0.6).unwrap();
    for mode in [ClipMode::Hard, ClipMode::Rara] {
        let mut sides = Vec::new();
        for region in [sphere.clone(), sphere.clone().inverted()] {
            let clip = Clip {
                mode,
                ..Clip::rara(region)
            };
            let (_, stats) = renderer
                .render(
                    &gpu_scene,
                    &camera,
                    &RenderOptions {
                        clip,
                        ..RenderOptions::default()
                    },
                )
                .unwrap();
            sides.push(gpu_classes(
                &renderer.intermediates(&gpu_scene, &stats).unwrap().splats,
            ));
        }
        for i in (0..scene.len()).filter(|&i| on_screen[i].is_some()) {
            let (a, b) = (sides[0][i], sides[1][i]);
            match mode {
                ClipMode::Hard => assert!(a.is_some() != b.is_some(), "Gaussian {i}: {a:?} {b:?}"),
                _ => assert!(
                    matches!(
                        (a, b),
                        (Some(false), None) | (None, Some(false)) | (Some(true), Some(true))
                    ),
                    "Gaussian {i}: {a:?} {b:?}"
                ),
            }
        }
    }
    common::assert_no_validation_messages(&ctx);
}
