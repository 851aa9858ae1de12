//! The engine-facing API: a borrowed device, the caller's command buffer and targets, frames in
//! flight, teardown. The engine example runs here for real (with validation when installed).

mod common;

#[allow(dead_code)]
#[path = "../examples/engine.rs"]
mod engine_example;

use glam::Vec3;
use rara::vk::{Buffer, MemoryLocation};
use rara::{
    BorrowedDevice, Composite, Context, EnabledFeatures, Error, FrameSlot, RenderOptions, Renderer,
    Target, TargetFormat,
};

/// The example renders 4 frames with 2 in flight: its mesh pass (a lit cube, depth-tested, into
/// colour and depth attachments), rara over it with the depth test against the cube's depth and
/// a moving rara clip plane, then its own vignette pass. Every frame must equal the CPU
/// compositor over the GPU's projected splats, depth-tested against the same cube depth and
/// composited over the same cube colour, times the vignette (within 1/255 but for ties); the
/// cube must hide splats behind it and show splats in front of it; the engine's objects outlive
/// rara's teardown and are destroyed by the engine with no validation message; rara's
/// allocator ends empty.
#[test]
fn engine_example_frames_match_the_reference_over_its_cube() {
    engine_example_matches(rara::Tracer::Raster, 4);
}

/// The same with the ray tracer recorded into the engine's command buffer (SPEC section 7):
/// the same synchronisation contract, the same teardown, the same depth test against the
/// cube; every frame against the CPU ray tracer over the cube's colour, depth-tested against
/// its depth.
#[test]
fn engine_example_ray_traced_frames_match_the_reference_over_its_cube() {
    engine_example_matches(rara::Tracer::Ray, 3);
}

fn engine_example_matches(tracer: rara::Tracer, frames: usize) {
    let dir = std::env::temp_dir().join(format!(
        "rara-engine-test-{}-{tracer:?}",
        std::process::id()
    ));
    let report = engine_example::run(&dir, frames, tracer).expect("the engine example runs");
    assert_eq!(report.frames.len(), frames);
    assert!(report.leaks.is_empty(), "rara leaked: {:?}", report.leaks);
    assert!(
        report.validation_messages.is_empty(),
        "validation messages:\n{}",
        report.validation_messages.join("\n")
    );
    println!(
        "engine example: {} frames, validation {}, 0 messages, 0 live allocations",
        frames,
        if report.validation { "on" } else { "off" }
    );
    assert!(report.stats.iter().all(|s| s.3), "every frame complete");
    // The plane moves: the cutoff Gaussians (the hits composited) change from frame to frame.
    assert!(report
        .stats
        .windows(2)
        .any(|w| (w[0].1, w[0].4) != (w[1].1, w[1].4)));

    let ctx = common::context();
    let mut renderer = Renderer::new(&ctx).unwrap();
    let cpu_scene = rara::synth::demo_scene();
    let scene = renderer.upload(&cpu_scene).unwrap();
    let camera = engine_example::camera().unwrap();
    let projection = engine_example::depth_projection();
    let (w, h) = (camera.width, camera.height);
    // Over all frames: cube pixels where a splat in front of the cube shows, and cube pixels
    // where the cube hides a splat that lies behind it.
    let (mut in_front, mut hidden) = (0usize, 0usize);
    for (index, path) in report.frames.iter().enumerate() {
        let options = engine_example::frame_options(&camera, index, frames, tracer).unwrap();
        let (mesh, mesh_depth) = &report.mesh[index];
        let actual = image::open(path).unwrap().to_rgba8();
        let cube = |x: u32, y: u32| mesh_depth[(y * w + x) as usize] < 1.0;
        assert!(
            (0..w * h).any(|p| cube(p % w, p / w)),
            "frame {index}: the mesh pass drew no cube"
        );
        // The expected pixel before the vignette: for the rasterizer, the CPU compositor over
        // the GPU's own projected splats, depth-tested against the cube's depth and over the
        // mesh pass's colour; for the ray tracer, the CPU ray tracer likewise.
        let expected: Box<dyn Fn(u32, u32) -> [f32; 3]> = match tracer {
            rara::Tracer::Raster => {
                let mut headless = options.clone();
                headless.composite = Composite::Background;
                let (_, stats) = renderer.render(&scene, &camera, &headless).unwrap();
                let mid = renderer.intermediates(&scene, &stats).unwrap();
                let splats = common::with_gpu_values(
                    rara::reference::project::project_all(&cpu_scene, &camera, &options.clip),
                    &mid,
                );
                let lists = rara::reference::rasterize::tile_lists(&splats, &camera);
                let gx = w.div_ceil(rara::constants::TILE_SIZE);
                let clip = options.clip.clone();
                let composite = move |x: u32, y: u32, limit: f32| {
                    let tile =
                        (y / rara::constants::TILE_SIZE) * gx + x / rara::constants::TILE_SIZE;
                    let under = mesh.get_pixel(x, y);
                    let under =
                        Vec3::new(under[0] as f32, under[1] as f32, under[2] as f32) / 255.0;
                    rara::reference::rasterize::composite_pixel_depth(
                        &splats,
                        &lists[tile as usize],
                        glam::Vec2::new(x as f32, y as f32),
                        under,
                        rara::reference::rasterize::PixelClip::new(&clip, &camera, x, y).as_ref(),
                        limit,
                    )
                    .color
                };
                // Occlusion both ways, on the cube's pixels.
                for y in 0..h {
                    for x in 0..w {
                        if !cube(x, y) {
                            continue;
                        }
                        let limit = projection.view_depth(mesh_depth[(y * w + x) as usize]);
                        let tested = composite(x, y, limit);
                        let untested = composite(x, y, f32::INFINITY);
                        let m = mesh.get_pixel(x, y);
                        let mesh_rgb = Vec3::new(m[0] as f32, m[1] as f32, m[2] as f32) / 255.0;
                        hidden += ((tested - untested).abs().max_element() > 2.0 / 255.0) as usize;
                        in_front +=
                            ((tested - mesh_rgb).abs().max_element() > 2.0 / 255.0) as usize;
                    }
                }
                Box::new(move |x, y| {
                    let limit = projection.view_depth(mesh_depth[(y * w + x) as usize]);
                    let c = rara::reference::rasterize::to_rgba8(composite(x, y, limit));
                    [c[0] as f32, c[1] as f32, c[2] as f32]
                })
            }
            rara::Tracer::Ray | rara::Tracer::RayTiles => {
                // The CPU ray tracer over the mesh pass's colour (the clear colour away from
                // the cube), with and without the depth test against the cube's depth.
                let under: Vec<Vec3> = mesh
                    .pixels()
                    .map(|m| Vec3::new(m[0] as f32, m[1] as f32, m[2] as f32) / 255.0)
                    .collect();
                let limits: Vec<f32> = mesh_depth
                    .iter()
                    .map(|&d| projection.view_depth(d))
                    .collect();
                let rt = rara::RayTraceOptions::default();
                let trace = |limits: &[f32]| {
                    rara::reference::raytrace::render_depth_tested(
                        &cpu_scene,
                        &camera,
                        &options,
                        &rt,
                        limits,
                        Some(&under),
                    )
                    .0
                };
                let tested = trace(&limits);
                let untested = trace(&vec![f32::INFINITY; limits.len()]);
                for y in 0..h {
                    for x in 0..w {
                        if !cube(x, y) {
                            continue;
                        }
                        let off = |a: &image::Rgba<u8>, b: &image::Rgba<u8>| {
                            (0..3).map(|c| a[c].abs_diff(b[c])).max().unwrap() > 2
                        };
                        let t = tested.get_pixel(x, y);
                        hidden += off(t, untested.get_pixel(x, y)) as usize;
                        in_front += off(t, mesh.get_pixel(x, y)) as usize;
                    }
                }
                Box::new(move |x, y| {
                    let p = tested.get_pixel(x, y);
                    [p[0] as f32, p[1] as f32, p[2] as f32]
                })
            }
        };
        let mut worst = 0f32;
        let mut ties = 0;
        let mut compared = 0;
        for (x, y, a) in actual.enumerate_pixels() {
            assert_eq!(a[3], 255, "opaque over an opaque clear");
            let e = expected(x, y);
            compared += 1;
            let v = engine_example::vignette_factor(x, y);
            for c in 0..3 {
                // The image is rgba8: rounded once before the vignette (as the reference's
                // 8-bit pixel is) and once after it.
                let want = e[c] * v;
                let diff = (a[c] as f32 - want).abs();
                worst = worst.max(diff);
                if diff > 1.0 {
                    ties += 1;
                }
            }
        }
        println!(
            "engine frame {index} ({tracer:?}): {compared} pixels compared, largest difference \
             {worst:.2}/255, {ties} channels past 1/255"
        );
        // The image takes two stores to rgba8, and Vulkan lets a store to a unorm format
        // return either of the two levels nearest the value ("should" round to nearest): one
        // level off before the vignette and under one after it, so under 2 levels against the
        // reference's rounding (floor(x * 255 + 0.5)) and its vignette. lavapipe rounds to
        // nearest (to even at a half, where the synthetic scene's quantised colours put a
        // handful of channels past 1 level); NVIDIA 580 put 1,555 channels (0.7 %) past 1
        // level, at most 1.55. The ray tracer's reference finds its hits in f64 where the GPU
        // works in f32: a hit whose order or alpha threshold f32 cannot decide moves a few
        // pixels further (the bound of tests/trace.rs, 4 levels but for such pixels; NVIDIA:
        // 3.07 at most, 1,645 channels past 1 level).
        let most_ties = compared * 3 / 100; // 1 % of the channels
        let most = match tracer {
            rara::Tracer::Raster => 1.999,
            rara::Tracer::Ray | rara::Tracer::RayTiles => 8.0,
        };
        assert!(worst <= most, "frame {index} differs by {worst}/255");
        assert!(
            ties <= most_ties,
            "frame {index}: {ties} channels differ by more than 1/255"
        );
    }
    println!(
        "engine example ({tracer:?}): over the frames, {in_front} cube pixels show splats in \
         front of the cube, {hidden} cube pixels hide splats behind it"
    );
    assert!(in_front > 0, "no splat in front of the cube");
    assert!(hidden > 0, "the cube hid no splat");
    common::assert_no_validation_messages(&ctx);
    let _ = std::fs::remove_dir_all(&dir);
}

/// A device created without bufferDeviceAddress or the memory model is refused with an error
/// that names it, and so is a Vulkan 1.1 instance; the engine then destroys its device with no
/// message. (shaderInt64 is optional: `kernel_forms` renders without it.)
#[test]
fn a_device_missing_a_required_feature_gets_a_clear_error() {
    let engine = engine_example::Engine::new(false).expect("engine device");
    let lend = |enabled: EnabledFeatures| BorrowedDevice {
        instance: engine.instance.clone(),
        physical_device: engine.physical_device,
        device: engine.device.clone(),
        queue_family: engine.queue_family,
        queue: engine.queue,
        enabled,
    };
    let no_bda = EnabledFeatures {
        buffer_device_address: false,
        ..EnabledFeatures::default()
    };
    match unsafe { Context::borrowed(lend(no_bda)) } {
        Err(Error::MissingRequirement(m)) => {
            println!("missing feature: {m}");
            assert!(m.contains("bufferDeviceAddress"), "{m}");
        }
        Err(e) => panic!("wrong error: {e}"),
        Ok(_) => panic!("a device without bufferDeviceAddress was accepted"),
    }
    let no_memory_model = EnabledFeatures {
        vulkan_memory_model: false,
        ..EnabledFeatures::default()
    };
    match unsafe { Context::borrowed(lend(no_memory_model)) } {
        Err(Error::MissingRequirement(m)) => assert!(m.contains("vulkanMemoryModel"), "{m}"),
        Err(e) => panic!("wrong error: {e}"),
        Ok(_) => panic!("a device without vulkanMemoryModel was accepted"),
    }
    let old = EnabledFeatures {
        api_version: ash::vk::API_VERSION_1_1,
        ..EnabledFeatures::default()
    };
    match unsafe { Context::borrowed(lend(old)) } {
        Err(Error::MissingRequirement(m)) => assert!(m.contains("Vulkan 1.2"), "{m}"),
        Err(e) => panic!("wrong error: {e}"),
        Ok(_) => panic!("a Vulkan 1.1 instance was accepted"),
    }
    unsafe { engine.destroy() };
}

/// Buffer targets of every format, over a background and over what they hold, against the
/// headless image; two slots and two scenes on one renderer, recorded into one command buffer.
#[test]
fn buffer_targets_and_two_slots_in_one_command_buffer() {
    buffer_targets_and_two_slots(rara::Tracer::Raster);
}

/// The same with the ray tracer.
#[test]
fn ray_traced_buffer_targets_and_two_slots_in_one_command_buffer() {
    buffer_targets_and_two_slots(rara::Tracer::Ray);
}

fn buffer_targets_and_two_slots(tracer: rara::Tracer) {
    let ctx = common::context();
    let mut renderer = Renderer::new(&ctx).unwrap();
    let scenes = [
        renderer.upload(&rara::synth::shell(3000, 1, 5)).unwrap(),
        renderer.upload(&rara::synth::hair(3000, 0, 6)).unwrap(),
    ];
    let camera = &rara::synth::orbit_cameras(1, 3.0, 80, 60, 50.0).unwrap()[0];
    let background = Vec3::new(0.2, 0.4, 0.6);
    let pixels = 80 * 60;
    for format in [
        TargetFormat::Rgba8Unorm,
        TargetFormat::Rgba16Float,
        TargetFormat::Rgba32Float,
    ] {
        let bytes = pixels as u64 * format.bytes_per_pixel();
        let mut buffers: Vec<Buffer> = (0..2)
            .map(|_| Buffer::new(&ctx, "test target", bytes, MemoryLocation::CpuToGpu).unwrap())
            .collect();
        // "Over": the buffers hold the background, opaque, before the frame.
        for b in &mut buffers {
            let texel = encode(format, [background.x, background.y, background.z, 1.0]);
            for px in b.mapped_mut()[..bytes as usize].chunks_mut(texel.len()) {
                px.copy_from_slice(&texel);
            }
        }
        let mut slots = [FrameSlot::new(&ctx).unwrap(), FrameSlot::new(&ctx).unwrap()];
        ctx.run_commands(|cmd| {
            for (k, slot) in slots.iter_mut().enumerate() {
                let options = RenderOptions {
                    composite: if k == 0 {
                        Composite::Over
                    } else {
                        Composite::Background
                    },
                    background,
                    tracer,
                    ..RenderOptions::default()
                };
                let target = Target::Buffer {
                    buffer: buffers[k].raw,
                    offset: 0,
                    format,
                    width: 80,
                    height: 60,
                };
                renderer
                    .record(cmd, slot, &scenes[k], camera, &options, &target, None)
                    .unwrap();
            }
        })
        .unwrap();
        for (k, slot) in slots.iter_mut().enumerate() {
            assert!(slot.stats().unwrap().complete);
            let options = RenderOptions {
                background,
                tracer,
                ..RenderOptions::default()
            };
            let (expected, stats) = renderer.render(&scenes[k], camera, &options).unwrap();
            assert!(stats.visible > 0 || stats.trace.is_some_and(|t| t.hits_walked > 0));
            let got = &buffers[k].mapped()[..bytes as usize];
            let mut worst = 0f32;
            for (i, e) in expected.pixels().enumerate() {
                let texel = &got[i * format.bytes_per_pixel() as usize..]
                    [..format.bytes_per_pixel() as usize];
                let a = decode(format, texel);
                for c in 0..4 {
                    worst = worst.max((a[c] * 255.0 - e[c] as f32).abs());
                }
            }
            println!(
                "{format:?} buffer target ({tracer:?}), scene {k}: largest difference {worst:.3}/255"
            );
            // The headless image is rounded to 8 bits; float targets differ by that rounding
            // (and half floats by their own, 2^-11 near 1).
            let bound = match format {
                TargetFormat::Rgba8Unorm => 0.0,
                TargetFormat::Rgba16Float => 0.65,
                TargetFormat::Rgba32Float => 0.51,
            };
            assert!(worst <= bound, "{format:?}: {worst}/255");
        }
    }
    drop(scenes);
    drop(renderer);
    assert!(
        ctx.live_allocations().is_empty(),
        "{:?}",
        ctx.live_allocations()
    );
    common::assert_no_validation_messages(&ctx);
}

fn encode(format: TargetFormat, c: [f32; 4]) -> Vec<u8> {
    match format {
        TargetFormat::Rgba8Unorm => c.iter().map(|v| (v * 255.0).round() as u8).collect(),
        TargetFormat::Rgba16Float => c
            .iter()
            .flat_map(|v| half_from_f32(*v).to_le_bytes())
            .collect(),
        TargetFormat::Rgba32Float => c.iter().flat_map(|v| v.to_le_bytes()).collect(),
    }
}

fn decode(format: TargetFormat, texel: &[u8]) -> [f32; 4] {
    let mut out = [0f32; 4];
    for (c, o) in out.iter_mut().enumerate() {
        *o = match format {
            TargetFormat::Rgba8Unorm => texel[c] as f32 / 255.0,
            TargetFormat::Rgba16Float => {
                half_to_f32(u16::from_le_bytes([texel[2 * c], texel[2 * c + 1]]))
            }
            TargetFormat::Rgba32Float => {
                f32::from_le_bytes(texel[4 * c..4 * c + 4].try_into().unwrap())
            }
        };
    }
    out
}

/// IEEE half to f32 (normal numbers and zero; the test values are in [0, 1]).
fn half_to_f32(h: u16) -> f32 {
    let exp = ((h >> 10) & 0x1f) as i32;
    let mant = (h & 0x3ff) as f32;
    if exp == 0 {
        return mant * 2f32.powi(-24);
    }
    (1.0 + mant / 1024.0) * 2f32.powi(exp - 15)
}

/// f32 in [0, 1] to the nearest IEEE half.
fn half_from_f32(v: f32) -> u16 {
    if v == 0.0 {
        return 0;
    }
    let exp = v.log2().floor() as i32;
    let mant = ((v / 2f32.powi(exp) - 1.0) * 1024.0).round() as u16;
    (((exp + 15) as u16) << 10) + mant
}
