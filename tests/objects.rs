//! Several objects in one frame (SPEC section 9): the objects transformed on the GPU and drawn
//! with one sort equal the merged, pre-transformed scene rendered alone, bit for bit; and an
//! object turned by a rigid transform looks, view-dependent colour included, as the untouched
//! object does from the camera turned the other way.

mod common;

use glam::{EulerRot, Quat, Vec3};
use rara::objects::{merge, ObjectTransform};
use rara::{Camera, Clip, ClipRegion, RenderOptions, Renderer, SceneObject};

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

/// A shell (SH degree 3) and a head of hair (SH degree 1) overlapping, each turned, moved and
/// scaled, drawn as two objects in one frame, equal their merged pre-transformed scene (made
/// on the host by `objects::merge`) rendered alone: unclipped and under a rara plane.
#[test]
fn two_overlapping_objects_equal_their_merged_scene_bit_for_bit() {
    let ctx = common::context();
    let mut renderer = Renderer::new(&ctx).unwrap();
    let shell = rara::synth::shell(3000, 3, 5);
    let hair = rara::synth::hair(2000, 1, 6);
    let [a, b] = transforms();
    let gpu_shell = renderer.upload(&shell).unwrap();
    let gpu_hair = renderer.upload(&hair).unwrap();
    let merged = merge(&[(&shell, a), (&hair, b)]);
    assert_eq!(merged.len(), 5000);
    assert_eq!(merged.sh_degree, 3);
    let gpu_merged = renderer.upload(&merged).unwrap();
    let camera = rara::synth::orbit_cameras(4, 3.5, 160, 120, 50.0).unwrap()[1];
    let plane = rara::Plane::new(Vec3::new(0.2, 0.3, 1.0).normalize(), 0.1).unwrap();
    let objects = [
        SceneObject {
            scene: &gpu_shell,
            transform: a,
        },
        SceneObject {
            scene: &gpu_hair,
            transform: b,
        },
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
        let differing = together
            .pixels()
            .zip(alone.pixels())
            .filter(|(x, y)| x != y)
            .count();
        assert_eq!(
            differing, 0,
            "{name}: {differing} pixels differ from the merged scene"
        );
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
            &[SceneObject {
                scene: &gpu,
                transform: t,
            }],
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
