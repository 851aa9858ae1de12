//! The GPU ray tracer (issue 32) against the CPU reference ray tracer (SPEC section 7), a ray
//! that needs far more steps than lavapipe's loop cap allows one invocation, and the tracer
//! recorded into an engine's command buffer.

mod common;

use glam::{Quat, Vec3};
use rara::clip::{Clip, ClipRegion, ClipWeight, Plane};
use rara::raytrace::tracer::RayTracer;
use rara::reference::raytrace;
use rara::RayTraceOptions;
use rara::{Camera, RenderOptions, Renderer, Scene};

/// GPU against CPU: generated scenes (flat and volumetric mixed, a solid and the solid
/// flattened) under every clip, and, when present, the real scenes at 320 px, volumetric and
/// flattened, unclipped and under a rara cutaway: >= 50 dB, max 8-bit difference <= 4 but for
/// the pixels f32 cannot decide (`common::check_traced`).
#[test]
fn gpu_tracer_matches_the_cpu_reference() {
    let ctx = common::context();
    let renderer = Renderer::new(&ctx).unwrap();
    let tracer = RayTracer::new(&ctx).unwrap();
    // (name, scene, camera, the clips to run: all, or those named)
    let mut cases: Vec<(String, Scene, Camera, Option<&str>)> = vec![
        (
            "mixed".into(),
            common::mixed_scene(3000, 1),
            common::tracer_camera(96),
            None,
        ),
        (
            "solid".into(),
            rara::synth::solid(20000, 2, 2),
            common::tracer_camera(128),
            None,
        ),
        (
            "solid_flat".into(),
            rara::synth::solid(20000, 2, 2).flattened(),
            common::tracer_camera(128),
            None,
        ),
    ];
    // The real scenes at 320 px: each volumetric unclipped and flattened under a rara
    // cutaway, plant also the other way round (about 2-10 s of lavapipe a frame).
    for name in common::REAL_SCENES {
        let Some((scene, cam)) = common::real_scene_view(name, 320) else {
            continue;
        };
        let both = name.starts_with("plant");
        cases.push((
            format!("{name}_flat"),
            scene.flattened(),
            cam,
            Some("cutaway_mass"),
        ));
        if both {
            cases.push((format!("{name}_flat"), scene.flattened(), cam, Some("none")));
            cases.push((name.to_string(), scene.clone(), cam, Some("cutaway_mass")));
        }
        cases.push((name.to_string(), scene, cam, Some("none")));
    }
    let rt = RayTraceOptions::default();
    let background = Vec3::new(0.1, 0.1, 0.15);
    for (name, scene, cam, only) in cases {
        let gpu_scene = renderer.upload(&scene).unwrap();
        let (lo, hi) = common::percentile_box(&scene);
        let mut unclipped = None;
        for (clip_name, clip) in common::tracer_clips(lo, hi) {
            if only.is_some_and(|o| o != clip_name) {
                continue;
            }
            let options = RenderOptions {
                background,
                clip,
                ..RenderOptions::default()
            };
            let start = std::time::Instant::now();
            let (gpu, stats) = tracer
                .render(&ctx, &gpu_scene, &cam, &options, &rt)
                .unwrap();
            let wall = start.elapsed().as_secs_f64() * 1e3;
            let (cpu, cpu_stats) = raytrace::render(&scene, &cam, &options, &rt);
            let d = common::check_traced(
                &format!("trace_{name}_{clip_name}"),
                &gpu,
                &cpu,
                &scene,
                &cam,
                &options.clip,
                rt.q,
                50.0,
                4,
            );
            eprintln!(
                "  {name} {clip_name}: PSNR {:.2} dB, max diff {}; GPU {wall:.0} ms wall ({}x{}, \
                 BVH build included), {} rounds, {:.1} hits walked per ray (CPU {:.1}), {} capped",
                d.psnr,
                d.max_diff,
                cam.width,
                cam.height,
                stats.rounds,
                stats.hits_walked as f64 / stats.rays as f64,
                cpu_stats.hits_walked as f64 / cpu_stats.rays as f64,
                stats.capped
            );
            assert_eq!(
                stats.capped as usize, cpu_stats.capped,
                "{name} {clip_name}"
            );
            // A clip must change the picture, or the case tests nothing.
            match &unclipped {
                None => unclipped = Some(gpu),
                Some(u) => assert!(
                    rara::metrics::compare(u, &gpu).differing_pixels > 0,
                    "{name} {clip_name}"
                ),
            }
        }
    }
    common::assert_no_validation_messages(&ctx);
}

/// SPEC section 7: with a plane at infinity the GPU tracer's rara image equals its unclipped
/// one exactly, both weights, flat and volumetric Gaussians alike.
#[test]
fn gpu_plane_at_infinity_changes_nothing() {
    let ctx = common::context();
    let renderer = Renderer::new(&ctx).unwrap();
    let tracer = RayTracer::new(&ctx).unwrap();
    let scene = common::mixed_scene(3000, 2);
    let gpu_scene = renderer.upload(&scene).unwrap();
    let cam = common::tracer_camera(96);
    let rt = RayTraceOptions::default();
    let (unclipped, _) = tracer
        .render(&ctx, &gpu_scene, &cam, &RenderOptions::default(), &rt)
        .unwrap();
    let far = ClipRegion::planes(vec![Plane::new(Vec3::new(0.3, 1.0, 0.2), 1e6).unwrap()]).unwrap();
    for weight in [ClipWeight::Mass, ClipWeight::Length] {
        let options = RenderOptions {
            clip: Clip {
                weight,
                ..Clip::rara(far.clone())
            },
            ..RenderOptions::default()
        };
        let (img, _) = tracer
            .render(&ctx, &gpu_scene, &cam, &options, &rt)
            .unwrap();
        assert_eq!(
            rara::metrics::compare(&img, &unclipped).differing_pixels,
            0,
            "{weight:?}"
        );
    }
    common::assert_no_validation_messages(&ctx);
}

/// Rays through 70,000 flat Gaussians stacked on the view axis, all but one in a thousand too
/// faint to add anything (alpha < 1/255, still walked), with the hit cap above them: every ray
/// walks every one, more steps than lavapipe's 65,535-iteration cap allows an invocation, over
/// several dispatches, and matches the CPU reference.
#[test]
fn a_ray_past_the_loop_budget() {
    let ctx = common::context();
    let renderer = Renderer::new(&ctx).unwrap();
    let tracer = RayTracer::new(&ctx).unwrap();
    let mut scene = Scene::default();
    let facing = Quat::from_rotation_y(-std::f32::consts::FRAC_PI_2);
    let count = 70_000;
    for k in 0..count {
        let c = 0.5 + 0.4 * ((k % 7) as f32 / 7.0);
        let sh = [
            rara::scene::rgb_to_sh_dc(c),
            0.3,
            rara::scene::rgb_to_sh_dc(1.0 - c),
        ];
        let opacity = if k % 1000 == 0 { 0.05 } else { 0.003 };
        scene.push(
            Vec3::new(0.0, 0.0, k as f32 * 1e-5),
            opacity,
            Vec3::new(0.0, 1.0, 1.0),
            facing,
            &sh,
        );
    }
    let cam = Camera::look_at(
        Vec3::new(0.0, 0.0, -3.0),
        Vec3::ZERO,
        Vec3::NEG_Y,
        10.0,
        4,
        4,
    )
    .unwrap();
    // Q = 20: the faint ones (o = 0.003) still have octagons (rho^2 = Q + 2 ln o = 8.4).
    let rt = RayTraceOptions {
        max_hits: 1_000_000,
        q: 20.0,
    };
    let gpu_scene = renderer.upload(&scene).unwrap();
    let (gpu, stats) = tracer
        .render(&ctx, &gpu_scene, &cam, &RenderOptions::default(), &rt)
        .unwrap();
    let (cpu, cpu_stats) = raytrace::render(&scene, &cam, &RenderOptions::default(), &rt);
    eprintln!(
        "loop budget: {} rounds, {} hits walked (CPU {}), {:.0} nodes visited per ray, {} capped",
        stats.rounds,
        stats.hits_walked,
        cpu_stats.hits_walked,
        stats.visits_per_ray(),
        stats.capped
    );
    // Each ray took far more steps than one invocation may loop (65,535), over many rounds.
    assert!(stats.visits_per_ray() > 65_535.0, "{stats:?}");
    assert!(
        stats.rounds as u64 * rara::raytrace::tracer::TRACE_BUDGET as u64 > 2 * 65_535,
        "{stats:?}"
    );
    assert_eq!(stats.hits_walked, 16 * count as u64, "{stats:?}");
    assert_eq!(stats.hits_walked, cpu_stats.hits_walked);
    common::check_images("trace_loop_budget", &gpu, &cpu, 50.0, 2);
    common::assert_no_validation_messages(&ctx);
}

/// The library's `Tracer::Ray` through `Renderer::render` is the tracer's frame, with its
/// counts in the frame's stats.
#[test]
fn tracer_option_in_the_renderer() {
    let ctx = common::context();
    let mut renderer = Renderer::new(&ctx).unwrap();
    let scene = common::mixed_scene(500, 3);
    let gpu_scene = renderer.upload(&scene).unwrap();
    let cam = common::tracer_camera(48);
    let options = RenderOptions {
        tracer: rara::Tracer::Ray,
        ..RenderOptions::default()
    };
    let (img, stats) = renderer.render(&gpu_scene, &cam, &options).unwrap();
    let trace = stats.trace.expect("the ray tracer's counts");
    assert_eq!(trace.rays, 48 * 36);
    let tracer = RayTracer::new(&ctx).unwrap();
    let (direct, _) = tracer
        .render(
            &ctx,
            &gpu_scene,
            &cam,
            &options,
            &RayTraceOptions::default(),
        )
        .unwrap();
    assert_eq!(rara::metrics::compare(&img, &direct).differing_pixels, 0);
    common::assert_no_validation_messages(&ctx);
}

/// A still BVH (issue 72: built once on the host by obvhs over the GPU's own proxy boxes)
/// is a valid tree in the GPU's layout, of lower SAH cost than the LBVH, and gives the LBVH's
/// image bit for bit: generated scenes (flat and volumetric mixed, a solid) unclipped and
/// under a rara cutaway, and, when present, plant at 320 px.
#[test]
fn a_still_bvh_gives_the_lbvhs_image() {
    let ctx = common::context();
    let mut renderer = Renderer::new(&ctx).unwrap();
    let mut cases: Vec<(String, Scene, Camera)> = vec![
        (
            "mixed".into(),
            common::mixed_scene(3000, 1),
            common::tracer_camera(96),
        ),
        (
            "solid".into(),
            rara::synth::solid(20000, 2, 2),
            common::tracer_camera(128),
        ),
    ];
    if let Some((scene, camera)) = common::real_scene_view("plant_capture_sh0", 320) {
        cases.push(("plant".into(), scene, camera));
    }
    let cutaway = Clip {
        region: Some(
            ClipRegion::planes(vec![Plane::new(Vec3::new(0.3, -0.2, 0.9), 0.05).unwrap()]).unwrap(),
        ),
        mode: rara::ClipMode::Rara,
        weight: ClipWeight::Mass,
        ..Clip::default()
    };
    for (name, scene, camera) in cases {
        let mut gpu = renderer.upload(&scene).unwrap();
        let clips = [
            ("unclipped", Clip::default()),
            ("rara cutaway", cutaway.clone()),
        ];
        let options = |clip: &Clip| RenderOptions {
            clip: clip.clone(),
            tracer: rara::Tracer::Ray,
            ..RenderOptions::default()
        };
        let lbvh: Vec<(image::RgbaImage, u64)> = clips
            .iter()
            .map(|(_, clip)| {
                let (img, stats) = renderer.render(&gpu, &camera, &options(clip)).unwrap();
                (img, stats.trace.unwrap().node_visits)
            })
            .collect();
        assert!(!gpu.has_still_bvh());
        let built = renderer.build_still_bvh(&mut gpu).unwrap();
        assert!(gpu.has_still_bvh());
        assert!(
            built.sah < built.lbvh_sah,
            "{name}: SAH {} against the LBVH's {}",
            built.sah,
            built.lbvh_sah
        );
        for ((clip_name, clip), (want, lbvh_visits)) in clips.iter().zip(&lbvh) {
            let (img, stats) = renderer.render(&gpu, &camera, &options(clip)).unwrap();
            let visits = stats.trace.unwrap().node_visits;
            eprintln!(
                "{name}, {clip_name}: SAH {:.1} (LBVH {:.1}), depth {}, built in {:.0} ms; \
                 node visits {visits} (LBVH {lbvh_visits})",
                built.sah, built.lbvh_sah, built.depth, built.build_ms
            );
            let differ = img
                .pixels()
                .zip(want.pixels())
                .filter(|(a, b)| a != b)
                .count();
            assert_eq!(
                differ, 0,
                "{name}, {clip_name}: pixels differ from the LBVH's image"
            );
        }
        // A renderer whose frames all walk the still tree makes no LBVH buffers: the tree's
        // memory is the scene's 32-byte nodes alone.
        let mut fresh = Renderer::new(&ctx).unwrap();
        let (img, _) = fresh.render(&gpu, &camera, &options(&clips[0].1)).unwrap();
        assert!(
            img == lbvh[0].0,
            "{name}: a fresh renderer's still-BVH image"
        );
        let memory = fresh.headless_memory();
        assert_eq!(memory.bvh, 0, "{name}: LBVH buffers made for a still scene");
        assert!(memory.trace_per_ray > 0);
        assert_eq!(
            gpu.still_bvh_bytes(),
            (2 * scene.len() as u64 - 1) * 32,
            "{name}: the still tree's bytes"
        );
        // Replacing the Gaussians drops the tree built for the old ones.
        gpu.replace(&scene).unwrap();
        assert!(!gpu.has_still_bvh());
    }
    common::assert_no_validation_messages(&ctx);
}

/// The still BVH's layout: inner nodes `[0, n - 1)`, each Gaussian in exactly one leaf from
/// `n - 1` on with its proxy's own box, every inner box the exact union of its children's, and
/// the split axis's order kept; Gaussians without a proxy (empty boxes) included.
#[test]
fn a_still_bvh_is_a_tree_over_every_proxy() {
    use rara::raytrace::bvh::GpuBvhNode;
    use rara::raytrace::still_bvh::{depth, still_tree};
    let b = |lo: [f32; 3], hi: [f32; 3]| GpuBvhNode {
        lo,
        hi,
        ..GpuBvhNode::default()
    };
    let mut boxes: Vec<GpuBvhNode> = (0..500)
        .map(|i| {
            let x = (i as f32 * 0.37).sin() * 3.0;
            let y = (i as f32 * 0.11).cos() * 2.0;
            let z = i as f32 * 0.01;
            b([x, y, z], [x + 0.2, y + 0.1, z + 0.3])
        })
        .collect();
    for i in [3, 77, 78, 499] {
        boxes[i] = b([1.0; 3], [-1.0; 3]); // empty
    }
    for count in [1usize, 2, 5, 500] {
        let boxes = &boxes[..count];
        let (nodes, stats) = still_tree(boxes);
        let n = count;
        assert_eq!(nodes.len(), 2 * n - 1);
        assert_eq!(stats.depth, depth(&nodes));
        assert!(stats.depth as usize <= n);
        let mut seen = vec![0u32; n];
        let mut reached = vec![0u32; 2 * n - 1];
        let mut stack = vec![0u32];
        while let Some(i) = stack.pop() {
            reached[i as usize] += 1;
            let node = nodes[i as usize];
            if (i as usize) < n - 1 {
                let (l, r) = node.children();
                let (a, c) = (nodes[l as usize], nodes[r as usize]);
                for k in 0..3 {
                    let lo = match (a.is_empty(), c.is_empty()) {
                        (true, true) => continue,
                        (true, false) => c.lo[k],
                        (false, true) => a.lo[k],
                        (false, false) => a.lo[k].min(c.lo[k]),
                    };
                    let hi = match (a.is_empty(), c.is_empty()) {
                        (true, false) => c.hi[k],
                        (false, true) => a.hi[k],
                        _ => a.hi[k].max(c.hi[k]),
                    };
                    assert_eq!((node.lo[k], node.hi[k]), (lo, hi), "node {i} axis {k}");
                }
                if let Some(axis) = node.split_axis() {
                    let centre = |m: &GpuBvhNode| m.lo[axis] + m.hi[axis];
                    assert!(centre(&a) <= centre(&c), "node {i}: children out of order");
                }
                stack.extend([l, r]);
            } else {
                let g = node.left as usize;
                seen[g] += 1;
                assert_eq!(
                    (node.lo, node.hi),
                    (boxes[g].lo, boxes[g].hi),
                    "leaf of {g}"
                );
            }
        }
        assert!(seen.iter().all(|&s| s == 1), "{count}: every Gaussian once");
        assert!(reached.iter().all(|&r| r == 1), "{count}: every node once");
    }
}
