//! Several objects in one frame (SPEC section 9): the objects transformed on the GPU and drawn
//! with one sort equal the merged, pre-transformed scene rendered alone, bit for bit; and an
//! object turned by a rigid transform looks, view-dependent colour included, as the untouched
//! object does from the camera turned the other way.

mod common;

use glam::{EulerRot, Quat, Vec3};
use rara::objects::{merge, ObjectTransform};
use rara::{Camera, Clip, ClipRegion, GpuScene, RenderOptions, Renderer, SceneObject, Tracer};

fn transforms() -> [ObjectTransform; 2] {
    [
        ObjectTransform {
            rotation: Quat::from_euler(EulerRot::XYZ, 0.4, 1.2, -0.7),
            translation: Vec3::new(0.3, 0.0, 0.2),
            scale: 0.8,
        },
        ObjectTransform {
            rotation: Quat::from_euler(EulerRot::XYZ, -0.9, 0.3, 2.1),
            translation: Vec3::new(-0.25, 0.1, 0.0),
            scale: 1.3,
        },
    ]
}

/// The two overlapping objects of these tests on the device (a shell of SH degree 3 and hair of
/// degree 1, at `transforms()`), their merged scene, and the camera that sees them.
struct TwoObjects {
    shell: GpuScene,
    hair: GpuScene,
    merged: GpuScene,
    transforms: [ObjectTransform; 2],
    camera: Camera,
}

fn two_objects(renderer: &Renderer) -> TwoObjects {
    let shell = rara::synth::shell(3000, 3, 5);
    let hair = rara::synth::hair(2000, 1, 6);
    let [a, b] = transforms();
    let merged = merge(&[(&shell, a), (&hair, b)]);
    assert_eq!((merged.len(), merged.sh_degree), (5000, 3));
    TwoObjects {
        shell: renderer.upload(&shell).unwrap(),
        hair: renderer.upload(&hair).unwrap(),
        merged: renderer.upload(&merged).unwrap(),
        transforms: [a, b],
        camera: rara::synth::orbit_cameras(4, 3.5, 160, 120, 50.0).unwrap()[1],
    }
}

/// How many pixels of `a` and `b` differ.
fn differing(a: &image::RgbaImage, b: &image::RgbaImage) -> usize {
    a.pixels().zip(b.pixels()).filter(|(x, y)| x != y).count()
}

/// A shell (SH degree 3) and a head of hair (SH degree 1) overlapping, each turned, moved and
/// scaled, drawn as two objects in one frame, equal their merged pre-transformed scene (made
/// on the host by `objects::merge`) rendered alone: unclipped and under a rara plane.
#[test]
fn two_overlapping_objects_equal_their_merged_scene_bit_for_bit() {
    let ctx = common::context();
    let mut renderer = Renderer::new(&ctx).unwrap();
    let TwoObjects {
        shell: gpu_shell,
        hair: gpu_hair,
        merged: gpu_merged,
        transforms: [a, b],
        camera,
    } = two_objects(&renderer);
    let plane = rara::Plane::new(Vec3::new(0.2, 0.3, 1.0).normalize(), 0.1).unwrap();
    let objects = [
        SceneObject::new(&gpu_shell, a),
        SceneObject::new(&gpu_hair, b),
    ];
    for (name, clip) in [
        ("unclipped", Clip::default()),
        ("rara", Clip::rara(ClipRegion::planes(vec![plane]).unwrap())),
    ] {
        let options = RenderOptions {
            clip,
            background: Vec3::new(0.1, 0.1, 0.15),
            ..RenderOptions::default()
        };
        let (together, stats) = renderer
            .render_objects(&objects, &camera, &options)
            .unwrap();
        let (alone, alone_stats) = renderer.render(&gpu_merged, &camera, &options).unwrap();
        eprintln!(
            "{name}: {} visible, {} pairs (merged alone: {}, {})",
            stats.visible, stats.intersections, alone_stats.visible, alone_stats.intersections
        );
        assert!(stats.visible > 2000, "{}", stats.visible);
        let off = differing(&together, &alone);
        assert_eq!(off, 0, "{name}: {off} pixels differ from the merged scene");
    }
    common::assert_no_validation_messages(&ctx);
}

/// A rigid transform of an object (SH degree 3, so its colour depends on the view) seen from
/// a camera equals the untouched object seen from the camera moved by the inverse transform:
/// the centres, the shapes and the SH turn together (within rounding: PSNR >= 45 dB).
#[test]
fn a_turned_object_looks_as_the_object_from_the_camera_turned_back() {
    let ctx = common::context();
    let mut renderer = Renderer::new(&ctx).unwrap();
    let shell = rara::synth::shell(4000, 3, 8);
    let gpu = renderer.upload(&shell).unwrap();
    let t = ObjectTransform {
        rotation: Quat::from_euler(EulerRot::XYZ, 0.7, -0.5, 1.9),
        translation: Vec3::new(0.4, -0.2, 0.3),
        scale: 1.0,
    };
    let camera = rara::synth::orbit_cameras(4, 3.5, 160, 120, 50.0).unwrap()[2];
    let (turned, _) = renderer
        .render_objects(
            &[SceneObject::new(&gpu, t)],
            &camera,
            &RenderOptions::default(),
        )
        .unwrap();
    let r = glam::Mat3::from_quat(t.unit_rotation());
    let back = Camera {
        position: r.transpose() * (camera.position - t.translation),
        rotation: r.transpose() * camera.rotation,
        ..camera
    };
    let (moved_camera, _) = renderer
        .render(&gpu, &back, &RenderOptions::default())
        .unwrap();
    // Without turning the SH, the view-dependent colour would be wrong.
    let unturned_sh = {
        let mut s = t.apply(&shell);
        s.sh = shell.sh.clone();
        renderer.upload(&s).unwrap()
    };
    let (wrong, _) = renderer
        .render(&unturned_sh, &camera, &RenderOptions::default())
        .unwrap();
    let good = common::check_images("turned_object", &turned, &moved_camera, 45.0, 8);
    let bad = rara::metrics::compare(&wrong, &moved_camera);
    eprintln!(
        "SH turned: {:.2} dB; SH left as it was: {:.2} dB",
        good.psnr, bad.psnr
    );
    assert!(
        bad.psnr + 3.0 < good.psnr,
        "{} against {}",
        bad.psnr,
        good.psnr
    );
    common::assert_no_validation_messages(&ctx);
}

/// Two objects side by side on screen, each with a clip region of its own in its own frame:
/// an oblique plane for the shell, an inverted sphere (a cutaway) for the hair. Each half of
/// the frame equals, bit for bit, the merged scene rendered with that half's object's region
/// carried into the world (`ObjectTransform::region_to_world`), under hard clipping and rara
/// clipping with either weight; and the regions do differ where it matters (the other object's
/// region gives another picture). Cutoff pairs are not classified by tile in either frame.
/// The same holds ray traced (SPEC section 7's clip weight by each hit's object's region),
/// through the BVH and through the tile lists.
#[test]
fn each_object_is_clipped_by_its_own_region() {
    let ctx = common::context();
    let mut renderer = Renderer::new(&ctx).unwrap();
    renderer.set_cutoff_tile_classes(false);
    let camera = rara::synth::orbit_cameras(4, 5.0, 200, 120, 50.0).unwrap()[1];
    let right = camera.rotation.x_axis;
    let shell = rara::synth::shell(3000, 3, 11);
    let hair = rara::synth::hair(2000, 1, 12);
    let a = ObjectTransform {
        rotation: Quat::from_euler(EulerRot::XYZ, 0.4, 1.2, -0.7),
        translation: -1.6 * right,
        scale: 0.7,
    };
    let b = ObjectTransform {
        rotation: Quat::from_euler(EulerRot::XYZ, -0.9, 0.3, 2.1),
        translation: 1.7 * right,
        scale: 0.6,
    };
    let plane = rara::Plane::new(Vec3::new(0.3, -0.5, 0.8), 0.1).unwrap();
    let own_a = ClipRegion::planes(vec![plane]).unwrap();
    let own_b = ClipRegion::sphere(Vec3::new(0.9, -0.3, 0.0), 0.9)
        .unwrap()
        .inverted();
    let gpu_shell = renderer.upload(&shell).unwrap();
    let gpu_hair = renderer.upload(&hair).unwrap();
    let merged = renderer.upload(&merge(&[(&shell, a), (&hair, b)])).unwrap();
    let objects = [
        SceneObject::new(&gpu_shell, a).with_clip(own_a.clone()),
        SceneObject::new(&gpu_hair, b).with_clip(own_b.clone()),
    ];
    let background = Vec3::new(0.1, 0.1, 0.15);
    let half = camera.width / 2;
    // The rasterizer, and the ray tracer through its BVH and its tile lists: each weighs a
    // Gaussian by its own object's region.
    for tracer in [Tracer::Raster, Tracer::Ray, Tracer::RayTiles] {
        // Each object alone and unclipped leaves the other half as the background: the halves
        // separate the objects.
        let mut render_alone = |o: &SceneObject| {
            let unclipped = SceneObject::new(o.scene, o.transform);
            let (img, _) = renderer
                .render_objects(&[unclipped], &camera, &plain(background, tracer))
                .unwrap();
            img
        };
        let alone = [render_alone(&objects[0]), render_alone(&objects[1])];
        // The top left corner of the hair's frame, far from either object.
        let bg_pixel = *alone[1].get_pixel(0, 0);
        for (img, left) in [(&alone[0], true), (&alone[1], false)] {
            let (mut mine, mut other) = (0, 0);
            for (x, _, p) in img.enumerate_pixels() {
                if *p != bg_pixel {
                    if (x < half) == left {
                        mine += 1;
                    } else {
                        other += 1;
                    }
                }
            }
            // Ray traced, the hair's needles cover fewer pixel centres: no 0.3 px dilation.
            let least = if tracer == Tracer::Raster { 1000 } else { 250 };
            assert!(
                mine > least,
                "{tracer:?}: {mine} pixels of the object in its half"
            );
            assert_eq!(other, 0, "the object reaches into the other half");
        }
        let world_a = a.region_to_world(&own_a);
        let world_b = b.region_to_world(&own_b);
        for (name, mode, weight) in [
            ("hard", rara::ClipMode::Hard, rara::ClipWeight::Mass),
            ("rara mass", rara::ClipMode::Rara, rara::ClipWeight::Mass),
            (
                "rara length",
                rara::ClipMode::Rara,
                rara::ClipWeight::Length,
            ),
        ] {
            let options = |region: Option<ClipRegion>| RenderOptions {
                clip: Clip {
                    region,
                    mode,
                    weight,
                    ..Clip::default()
                },
                background,
                tracer,
                ..RenderOptions::default()
            };
            // The frame's own region (none) is not used: each object has one.
            let (together, stats) = renderer
                .render_objects(&objects, &camera, &options(None))
                .unwrap();
            let (ref_a, _) = renderer
                .render(&merged, &camera, &options(Some(world_a.clone())))
                .unwrap();
            let (ref_b, _) = renderer
                .render(&merged, &camera, &options(Some(world_b.clone())))
                .unwrap();
            let (unclipped, _) = renderer
                .render(&merged, &camera, &plain(background, tracer))
                .unwrap();
            let count = |img: &image::RgbaImage, other: &image::RgbaImage, left: bool| {
                img.enumerate_pixels()
                    .filter(|&(x, y, p)| (x < half) == left && p != other.get_pixel(x, y))
                    .count()
            };
            let (off_a, off_b) = (
                count(&together, &ref_a, true),
                count(&together, &ref_b, false),
            );
            // What each region changes, and what the other object's region would give instead.
            let (cut_a, cut_b) = (
                count(&ref_a, &unclipped, true),
                count(&ref_b, &unclipped, false),
            );
            let (swap_a, swap_b) = (count(&ref_b, &ref_a, true), count(&ref_a, &ref_b, false));
            eprintln!(
                "{tracer:?}, {name}: {} cutoff; pixels off: {off_a} + {off_b}; clipped away: {cut_a} + {cut_b}; \
                 with the other region: {swap_a} + {swap_b} differ",
                stats.cutoff
            );
            assert_eq!((off_a, off_b), (0, 0), "{tracer:?}, {name}");
            // (Ray traced, the hair's thin needles cover fewer pixels: less to clip away.)
            let least = if tracer == Tracer::Raster { 300 } else { 20 };
            assert!(
                cut_a > least && cut_b > least,
                "{tracer:?}, {name}: {cut_a}, {cut_b}"
            );
            assert!(
                swap_a > 100 && swap_b > 100,
                "{tracer:?}, {name}: {swap_a}, {swap_b}"
            );
            if mode == rara::ClipMode::Rara && tracer == Tracer::Raster {
                assert!(stats.cutoff > 100, "{name}: {}", stats.cutoff);
            }
        }
    }
    common::assert_no_validation_messages(&ctx);
}

/// An object without a region of its own is clipped by the frame's. With the frame's region
/// set to the shell's own box carried into the world, every Gaussian is clipped by one world
/// region, and the frame equals the merged scene rendered under it, bit for bit.
#[test]
fn an_object_without_a_region_takes_the_frames() {
    let ctx = common::context();
    let mut renderer = Renderer::new(&ctx).unwrap();
    renderer.set_cutoff_tile_classes(false);
    let TwoObjects {
        shell: gpu_shell,
        hair: gpu_hair,
        merged,
        transforms: [a, b],
        camera,
    } = two_objects(&renderer);
    let own = ClipRegion::oriented_box(
        Vec3::new(0.1, -0.2, 0.3),
        Vec3::new(0.6, 0.5, 0.7),
        Quat::from_rotation_y(0.5),
    )
    .unwrap();
    // The shell's own box, in the world, is the frame's region for the hair: every Gaussian
    // is then clipped by one world region.
    let world = a.region_to_world(&own);
    let options = RenderOptions {
        clip: Clip::rara(world),
        background: Vec3::new(0.1, 0.1, 0.15),
        ..RenderOptions::default()
    };
    let objects = [
        SceneObject::new(&gpu_shell, a).with_clip(own),
        SceneObject::new(&gpu_hair, b),
    ];
    let (together, stats) = renderer
        .render_objects(&objects, &camera, &options)
        .unwrap();
    let (alone, alone_stats) = renderer.render(&merged, &camera, &options).unwrap();
    eprintln!(
        "{} cutoff, {} visible (merged alone: {}, {})",
        stats.cutoff, stats.visible, alone_stats.cutoff, alone_stats.visible
    );
    assert!(stats.cutoff > 100, "{}", stats.cutoff);
    assert_eq!(
        (stats.cutoff, stats.visible),
        (alone_stats.cutoff, alone_stats.visible)
    );
    let off = differing(&together, &alone);
    assert_eq!(off, 0, "{off} pixels differ from the merged scene");
    common::assert_no_validation_messages(&ctx);
}

/// Objects with regions of their own under a depth test (the object-clip kernels with the
/// depth test) equal the merged scene under the one world region with the same depth test,
/// bit for bit: an engine surface at the objects' middle depth over the left half of the image.
#[test]
fn objects_with_their_own_regions_take_the_depth_test() {
    use rara::depth::{DepthProjection, DepthSource, DepthTest};
    let ctx = common::context();
    let mut renderer = Renderer::new(&ctx).unwrap();
    renderer.set_cutoff_tile_classes(false);
    let TwoObjects {
        shell: gpu_shell,
        hair: gpu_hair,
        merged,
        transforms: [a, b],
        camera,
    } = two_objects(&renderer);
    let own = ClipRegion::planes(vec![
        rara::Plane::new(Vec3::new(0.5, -0.4, 0.6), 0.05).unwrap()
    ])
    .unwrap();
    let world = a.region_to_world(&own);
    let projection = DepthProjection {
        near: 0.05,
        far: 50.0,
        reversed: true,
        infinite: false,
    };
    let (w, h) = (camera.width as usize, camera.height as usize);
    let values: Vec<f32> = (0..w * h)
        .map(|p| projection.depth_value(if p % w < w / 2 { 3.5 } else { f32::INFINITY }))
        .collect();
    let buffer = rara::vk::Buffer::new(
        &ctx,
        "engine depth",
        values.len() as u64 * 4,
        rara::vk::MemoryLocation::GpuOnly,
    )
    .unwrap();
    buffer.upload(bytemuck::cast_slice(&values)).unwrap();
    for weight in [rara::ClipWeight::Mass, rara::ClipWeight::Length] {
        let options = RenderOptions {
            clip: Clip {
                weight,
                ..Clip::rara(world.clone())
            },
            depth_test: Some(DepthTest {
                source: DepthSource::Buffer {
                    buffer: buffer.raw,
                    offset: 0,
                },
                projection,
            }),
            ..RenderOptions::default()
        };
        let objects = [
            SceneObject::new(&gpu_shell, a).with_clip(own.clone()),
            SceneObject::new(&gpu_hair, b),
        ];
        let (together, stats) = renderer
            .render_objects(&objects, &camera, &options)
            .unwrap();
        let (alone, _) = renderer.render(&merged, &camera, &options).unwrap();
        let (untested, _) = renderer
            .render(
                &merged,
                &camera,
                &RenderOptions {
                    depth_test: None,
                    ..options.clone()
                },
            )
            .unwrap();
        let hidden = differing(&untested, &alone);
        let off = differing(&together, &alone);
        eprintln!(
            "{weight:?}: {} cutoff; the surface changes {hidden} pixels; {off} differ",
            stats.cutoff
        );
        assert!(
            stats.cutoff > 100 && hidden > 300,
            "{} {hidden}",
            stats.cutoff
        );
        assert_eq!(off, 0, "{weight:?}");
    }
    drop(buffer);
    common::assert_no_validation_messages(&ctx);
}

/// An object's own region moves with it: the object turned, moved and scaled, clipped by a
/// region in its own frame, looks as the untouched object clipped by that region from the
/// camera moved back (within rounding, PSNR >= 45 dB), and not as the region left in the
/// world would make it.
#[test]
fn an_objects_region_moves_with_it() {
    let ctx = common::context();
    let mut renderer = Renderer::new(&ctx).unwrap();
    let shell = rara::synth::shell(4000, 3, 8);
    let gpu = renderer.upload(&shell).unwrap();
    let t = ObjectTransform {
        rotation: Quat::from_euler(EulerRot::XYZ, 0.7, -0.5, 1.9),
        translation: Vec3::new(0.4, -0.2, 0.3),
        scale: 1.0,
    };
    let region = ClipRegion::planes(vec![
        rara::Plane::new(Vec3::new(0.2, 0.9, -0.3), 0.15).unwrap(),
        rara::Plane::new(Vec3::new(-0.7, 0.1, 0.4), 0.3).unwrap(),
    ])
    .unwrap();
    let camera = rara::synth::orbit_cameras(4, 3.5, 160, 120, 50.0).unwrap()[2];
    let options = RenderOptions {
        clip: Clip::rara(region.clone()),
        ..RenderOptions::default()
    };
    // Rara clipping, with no region for the frame: the object has its own.
    let own_only = RenderOptions {
        clip: Clip {
            region: None,
            ..options.clip.clone()
        },
        ..RenderOptions::default()
    };
    let (moved, stats) = renderer
        .render_objects(
            &[SceneObject::new(&gpu, t).with_clip(region.clone())],
            &camera,
            &own_only,
        )
        .unwrap();
    let r = glam::Mat3::from_quat(t.unit_rotation());
    let back = Camera {
        position: r.transpose() * (camera.position - t.translation),
        rotation: r.transpose() * camera.rotation,
        ..camera
    };
    let (expected, _) = renderer.render(&gpu, &back, &options).unwrap();
    // The region left in the world instead.
    let (left_behind, _) = renderer
        .render_objects(&[SceneObject::new(&gpu, t)], &camera, &options)
        .unwrap();
    let good = common::check_images("clipped_object_moved", &moved, &expected, 45.0, 8);
    let bad = rara::metrics::compare(&left_behind, &expected);
    eprintln!(
        "{} cutoff; region moved with the object: {:.2} dB; left in the world: {:.2} dB",
        stats.cutoff, good.psnr, bad.psnr
    );
    assert!(stats.cutoff > 100, "{}", stats.cutoff);
    assert!(
        bad.psnr + 10.0 < good.psnr,
        "{} against {}",
        bad.psnr,
        good.psnr
    );
    common::assert_no_validation_messages(&ctx);
}

/// Options that clip nothing, over `background`.
fn plain(background: Vec3, tracer: Tracer) -> RenderOptions {
    RenderOptions {
        background,
        tracer,
        ..RenderOptions::default()
    }
}
