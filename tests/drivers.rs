//! The Vulkan driver a run is on, and the two forms of the kernels (`glsl/common.glsl`): the
//! driver `scripts/test.sh` asked for (`RARA_EXPECT_DEVICE`) is the one found, and on a device
//! with shaderInt64 the portable kernels draw the same frames, bit for bit, as the 64-bit ones.

mod common;

use glam::Vec3;
use rara::mixed::shapes::Shape;
use rara::mixed::{Light, Material, MixedScene};
use rara::raytrace::mixed::{GpuMixedScene, MixedTracer};
use rara::stages::rasterize::RasterLayout;
use rara::vk::ContextDesc;
use rara::RayTraceOptions;
use rara::{Clip, ClipRegion, Context, Plane, RenderOptions, Renderer, ShPrecision, Tracer};

/// What the run found; with `RARA_EXPECT_DEVICE` set (scripts/test.sh sets it for each driver
/// it runs the suite on), the device's name or driver must contain it.
#[test]
fn the_expected_driver_is_the_one_found() {
    let ctx = common::context();
    let info = ctx.info();
    println!(
        "device: {} ({}), {:?}, subgroup size {}, shaderInt64 kernels {}, CPU layouts {}",
        info.name,
        info.driver,
        info.device_type,
        info.subgroup_size,
        info.shader_int64,
        rara::stages::cpu_layouts(&ctx)
    );
    match std::env::var("RARA_EXPECT_DEVICE") {
        Ok(want) if !want.is_empty() => {
            let want = want.to_lowercase();
            assert!(
                info.name.to_lowercase().contains(&want)
                    || info.driver.to_lowercase().contains(&want),
                "RARA_EXPECT_DEVICE={want}, but the device is {} ({})",
                info.name,
                info.driver
            );
        }
        _ => println!("RARA_EXPECT_DEVICE unset: any device will do"),
    }
}

/// The layouts made for CPU drivers (the strips rasterizer, the own-counts sort) read through
/// texel buffers of 2^24 texels: a device whose buffers hold that builds them when asked, one
/// with fewer (SwiftShader: 2^16) refuses them with a message that names the limit and the
/// layout to use, and takes the GPU layouts by default.
#[test]
fn cpu_layouts_are_refused_where_texel_buffers_are_small() {
    use rara::stages::sort::{RadixSort, SortLayout};
    let ctx = common::context();
    let strips = Renderer::with_raster_layout(&ctx, RasterLayout::Strips);
    let own = RadixSort::with_layout(&ctx, SortLayout::OwnCounts);
    if common::holds_cpu_layouts(&ctx) {
        assert!(strips.is_ok() && own.is_ok());
        return;
    }
    for (what, err) in [("strips", strips.err()), ("own-counts", own.err())] {
        let message = err.expect("refused").to_string();
        println!("{what}: {message}");
        assert!(message.contains("maxTexelBufferElements"), "{message}");
        assert!(message.contains(&ctx.info().name), "{message}");
    }
    assert_eq!(
        RasterLayout::for_device(&ctx),
        RasterLayout::PixelPerInvocation
    );
    assert_eq!(SortLayout::for_device(&ctx), SortLayout::ShortRuns);
}

/// The frames the forms are compared on: the rasterizer in both layouts, unclipped, hard and
/// rara by planes, rara by a sphere; the ray tracer unclipped and rara-clipped; a mixed scene.
fn frames(ctx: &Context) -> Vec<(String, image::RgbaImage)> {
    let scene = common::mixed_scene(900, 11);
    let camera = common::tracer_camera(128);
    let (lo, hi) = common::percentile_box(&scene);
    let c = 0.5 * (lo + hi);
    let n = Vec3::new(1.0, 0.3, -0.2).normalize();
    let planes = ClipRegion::planes(vec![Plane::new(n, -n.dot(c)).unwrap()]).unwrap();
    let sphere = ClipRegion::sphere(c, 0.4 * (hi - lo).max_element()).unwrap();
    let clips = [
        ("unclipped", Clip::default()),
        ("hard", Clip::hard(planes.clone())),
        ("rara_planes", Clip::rara(planes.clone())),
        ("rara_sphere", Clip::rara(sphere)),
    ];
    let mut out = Vec::new();
    for layout in [RasterLayout::Strips, RasterLayout::PixelPerInvocation] {
        let mut renderer = Renderer::with_raster_layout(ctx, layout).unwrap();
        let gpu = renderer.upload(&scene).unwrap();
        for (name, clip) in &clips {
            let options = RenderOptions {
                clip: clip.clone(),
                ..RenderOptions::default()
            };
            let (img, _) = renderer.render(&gpu, &camera, &options).unwrap();
            out.push((format!("{layout:?} {name}"), img));
        }
    }
    let mut renderer = Renderer::new(ctx).unwrap();
    let gpu = renderer.upload(&scene).unwrap();
    for (name, clip) in &clips[..3] {
        let options = RenderOptions {
            clip: clip.clone(),
            tracer: Tracer::Ray,
            ..RenderOptions::default()
        };
        let (img, _) = renderer.render(&gpu, &camera, &options).unwrap();
        out.push((format!("ray {name}"), img));
    }
    let mut mixed = MixedScene::splats_only(scene, Clip::rara(planes), Vec3::splat(0.1));
    let floor =
        Shape::quad().triangles(|p| Vec3::new(3.0 * p.x, 1.2, 3.0 * p.y), |_| Vec3::NEG_Y, 0);
    mixed.add_mesh(floor, Material::mirror(0.8));
    mixed.lights.push(Light::Point {
        position: Vec3::new(1.0, -2.5, -1.5),
        intensity: Vec3::splat(6.0),
    });
    let tracer = MixedTracer::new(ctx).unwrap();
    let gpu = GpuMixedScene::new(ctx, &mixed, ShPrecision::F32).unwrap();
    let (img, _) = tracer
        .render(&gpu, &camera, &RayTraceOptions::default())
        .unwrap();
    out.push(("mixed".into(), img));
    common::assert_no_validation_messages(ctx);
    out
}

/// Where the device runs 64-bit integers, the portable kernels (RARA_INT64 unset in the GLSL)
/// and the 64-bit ones read and write the same bytes and do the same arithmetic: every frame
/// is the same to the bit.
#[test]
fn the_portable_kernels_draw_what_the_int64_kernels_draw() {
    let int64 = common::context_with(ContextDesc {
        shader_int64: true,
        ..ContextDesc::from_env()
    });
    if !int64.info().shader_int64 {
        common::test_skipped(&format!(
            "{} has no shaderInt64: it runs the portable kernels only",
            int64.info().name
        ));
        return;
    }
    let portable = common::context_with(ContextDesc {
        shader_int64: false,
        ..ContextDesc::from_env()
    });
    assert!(!portable.info().shader_int64);
    let a = frames(&int64);
    let b = frames(&portable);
    for ((name, x), (_, y)) in a.iter().zip(&b) {
        let d = rara::metrics::compare(x, y);
        println!("{name}: {} pixels differ", d.differing_pixels);
        assert_eq!(d.differing_pixels, 0, "{name}: the two forms differ");
        assert!(
            x.pixels().any(|p| p.0 != x.get_pixel(0, 0).0),
            "{name}: a flat frame tests nothing"
        );
    }
}
