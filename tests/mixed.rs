//! Mixed scenes (SPEC section 8, issue 33): the GPU's ray trees against the CPU reference,
//! section 8's identities, the analytic shadow, the scene file's errors.

mod common;

use glam::{Quat, Vec3};
use rara::mixed::shapes::Shape;
use rara::mixed::{Light, Material, MixedScene};
use rara::reference::raytrace::RayTraceOptions;
use rara::stages::mixed::{GpuMixedScene, MixedTracer};
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
    s.add_mesh(
        placed(
            &Shape::quad(),
            Vec3::splat(2.5),
            Quat::IDENTITY,
            Vec3::new(0.0, 0.0, 1.6),
        ),
        Material::Mirror(0.9),
    );
    s.add_mesh(
        placed(
            &Shape::quad(),
            Vec3::splat(3.0),
            Quat::from_rotation_x(std::f32::consts::FRAC_PI_2),
            Vec3::new(0.0, 1.3, 0.0),
        ),
        Material::Diffuse(Vec3::new(0.8, 0.7, 0.5)),
    );
    s.add_mesh(
        placed(
            &Shape::sphere(12, 24),
            Vec3::splat(0.45),
            Quat::IDENTITY,
            Vec3::new(-0.5, 0.3, -1.4),
        ),
        Material::Glass(1.5),
    );
    s.lights.push(Light::Point {
        position: Vec3::new(1.0, -2.5, -1.5),
        intensity: Vec3::splat(6.0),
    });
    s.ambient = Vec3::splat(0.15);
    s
}

#[test]
fn gpu_matches_the_cpu_reference_on_a_generated_showcase() {
    let camera = common::tracer_camera(160);
    let (gpu, cpu) = both(&showcase(Clip::default()), &camera);
    gpu.save(common::artifacts_dir().join("mixed_showcase_gpu.png"))
        .unwrap();
    common::check_images("mixed showcase", &gpu, &cpu, 45.0, 255);
}
