//! Depth (SPEC section 9): the depth outputs (median, mean) and the depth test against an
//! engine's depth, GPU against the CPU reference over the GPU's own projected splats, and the
//! identities: a cleared engine depth changes nothing, a flat engine surface at depth z is the
//! scene without the Gaussians behind z, and an engine depth image reads as its buffer does.

mod common;

use ash::vk;
use glam::Vec3;
use rara::depth::{DepthMode, DepthProjection, DepthSource, DepthTest};
use rara::reference::{self, project::ProjectedSplat};
use rara::vk::{Buffer, MemoryLocation};
use rara::{Camera, Clip, ClipRegion, GpuScene, RenderOptions, Renderer, Scene};

fn scene_and_camera() -> (Scene, Camera) {
    let scene = rara::synth::solid(6000, 1, 3);
    let cam = rara::synth::orbit_cameras(3, 3.0, 160, 120, 50.0).unwrap()[1];
    (scene, cam)
}

/// The CPU's projected splats with the GPU's values (centre, depth, opacity, conic, colour)
/// from the last frame `renderer` rendered, so the CPU compositor sees what the GPU did.
fn gpu_as_cpu(
    renderer: &Renderer,
    gpu: &GpuScene,
    stats: &rara::FrameStats,
    scene: &Scene,
    cam: &Camera,
    clip: &Clip,
) -> Vec<ProjectedSplat> {
    let mid = renderer.intermediates(gpu, stats).unwrap();
    common::with_gpu_values(reference::project::project_all(scene, cam, clip), &mid)
}

/// How many of `gpu`'s depths differ from `cpu`'s by more than `rel` relatively (an infinite
/// one against a finite one counts), and the largest relative difference among the rest.
fn depth_differences(gpu: &[f32], cpu: &[f32], rel: f32) -> (usize, f32) {
    assert_eq!(gpu.len(), cpu.len());
    let mut off = 0;
    let mut worst = 0f32;
    for (&a, &b) in gpu.iter().zip(cpu) {
        if a.is_infinite() || b.is_infinite() {
            off += (a != b) as usize;
            continue;
        }
        let d = (a - b).abs() / b.abs().max(1e-6);
        if d > rel {
            off += 1;
        } else {
            worst = worst.max(d);
        }
    }
    (off, worst)
}

/// The median and mean depths of the GPU against the CPU compositor over the GPU's projected
/// splats, unclipped and rara-clipped: the same depth at every pixel but where the two
/// compositors' exponentials put a splat on either side of alpha's 1/255 or T's 0.5 (at most
/// 0.2 % of the pixels), the rest within 1e-5 relatively.
#[test]
fn depth_outputs_match_the_reference() {
    let ctx = common::context();
    let mut renderer = Renderer::new(&ctx).unwrap();
    let (scene, cam) = scene_and_camera();
    let gpu = renderer.upload(&scene).unwrap();
    let plane = rara::Plane::new(Vec3::new(0.3, 0.2, 1.0).normalize(), 0.1).unwrap();
    let clips = [
        ("unclipped", Clip::default()),
        ("rara", Clip::rara(ClipRegion::planes(vec![plane]).unwrap())),
    ];
    let pixels = (cam.width * cam.height) as usize;
    for (name, clip) in clips {
        let options = RenderOptions {
            clip: clip.clone(),
            ..RenderOptions::default()
        };
        let (plain, _) = renderer.render(&gpu, &cam, &options).unwrap();
        for mode in [DepthMode::Median, DepthMode::Mean] {
            let (image, depth, stats) = renderer
                .render_with_depth(&gpu, &cam, &options, mode)
                .unwrap();
            // The depth kernels draw the same image as the plain ones.
            assert_eq!(image, plain, "{name} {mode:?}: the image changed");
            let splats = gpu_as_cpu(&renderer, &gpu, &stats, &scene, &cam, &clip);
            let (_, median, mean) =
                reference::rasterize::rasterize_depth(&splats, &cam, Vec3::ZERO, &clip, None);
            let cpu = if mode == DepthMode::Median {
                median
            } else {
                mean
            };
            let finite = depth.iter().filter(|z| z.is_finite()).count();
            let (off, worst) = depth_differences(&depth, &cpu, 1e-5);
            eprintln!(
                "{name} {mode:?}: {finite} of {pixels} pixels have a depth; {off} differ from \
                 the reference, the rest by at most {worst:e} relatively"
            );
            assert!(finite > pixels / 10, "{finite}");
            assert!(off * 500 <= pixels, "{off} pixels differ");
        }
    }
    common::assert_no_validation_messages(&ctx);
}

/// A buffer of `values` (f32) on the device.
fn device_floats(ctx: &rara::Context, values: &[f32]) -> Buffer {
    let b = Buffer::new(
        ctx,
        "engine depth",
        values.len() as u64 * 4,
        MemoryLocation::GpuOnly,
    )
    .unwrap();
    b.upload(bytemuck::cast_slice(values)).unwrap();
    b
}

/// A depth test against the engine depths in `buffer` (from its start), of `projection`.
fn buffer_test(buffer: &Buffer, projection: DepthProjection) -> DepthTest {
    DepthTest {
        source: DepthSource::Buffer {
            buffer: buffer.raw,
            offset: 0,
        },
        projection,
    }
}

/// The engine's depth test, GPU against the CPU compositor over the GPU's projected splats,
/// for each projection (standard and reversed, finite and infinite far plane): an engine
/// surface that covers the left half of the image at the scene's middle depth and leaves the
/// right half cleared. And the identities, bit for bit: a cleared depth buffer changes no pixel,
/// and a surface at depth z over the whole image is the scene without its Gaussians at z or
/// behind.
#[test]
fn depth_test_hides_what_lies_behind_the_engine_surface() {
    let ctx = common::context();
    let mut renderer = Renderer::new(&ctx).unwrap();
    renderer.set_keep_depth_order(true);
    let (scene, cam) = scene_and_camera();
    let gpu = renderer.upload(&scene).unwrap();
    let (w, h) = (cam.width as usize, cam.height as usize);
    let (plain, plain_stats) = renderer
        .render(&gpu, &cam, &RenderOptions::default())
        .unwrap();
    // The view depths of the drawn Gaussians, and a surface depth in the middle of them with
    // no Gaussian within 5e-6 of it relatively (so that f32 rounding cannot move one across).
    let mid = renderer.intermediates(&gpu, &plain_stats).unwrap();
    let mut depths: Vec<f32> = mid
        .depth_order
        .iter()
        .map(|&i| mid.splats[i as usize].depth)
        .collect();
    depths.sort_by(f32::total_cmp);
    let z0 = depths
        .windows(2)
        .skip(depths.len() / 2)
        .find(|p| p[1] - p[0] > 1e-5 * p[1])
        .map(|p| 0.5 * (p[0] + p[1]))
        .expect("a gap between two depths");
    let behind = depths.iter().filter(|&&z| z >= z0).count();
    eprintln!(
        "surface at view depth {z0}: {behind} of {} drawn Gaussians behind it",
        depths.len()
    );
    for (reversed, infinite) in [(false, false), (true, false), (false, true), (true, true)] {
        let projection = DepthProjection {
            near: 0.05,
            far: 50.0,
            reversed,
            infinite,
        };
        let cleared = projection.depth_value(f32::INFINITY);
        let surface = projection.depth_value(z0);
        let half: Vec<f32> = (0..w * h)
            .map(|p| if p % w < w / 2 { surface } else { cleared })
            .collect();
        let render = |renderer: &mut Renderer, values: &[f32]| {
            let buffer = device_floats(&ctx, values);
            let options = RenderOptions {
                depth_test: Some(buffer_test(&buffer, projection)),
                ..RenderOptions::default()
            };
            renderer
                .render_with_depth(&gpu, &cam, &options, DepthMode::Median)
                .unwrap()
        };
        let what = format!("reversed {reversed}, infinite {infinite}");
        // Cleared everywhere: the plain image.
        let (image, _, _) = render(&mut renderer, &vec![cleared; w * h]);
        assert_eq!(
            image, plain,
            "{what}: a cleared depth buffer changed the image"
        );
        // The left half behind a surface, against the reference.
        let (image, median, stats) = render(&mut renderer, &half);
        let limits: Vec<f32> = half.iter().map(|&d| projection.view_depth(d)).collect();
        let splats = gpu_as_cpu(&renderer, &gpu, &stats, &scene, &cam, &Clip::default());
        let (cpu_image, cpu_median, _) = reference::rasterize::rasterize_depth(
            &splats,
            &cam,
            Vec3::ZERO,
            &Clip::default(),
            Some(&limits),
        );
        common::check_images(&format!("depth_test_{what}"), &image, &cpu_image, 45.0, 3);
        let (off, _) = depth_differences(&median, &cpu_median, 1e-5);
        assert!(off * 500 <= w * h, "{what}: {off} median depths differ");
        // No depth at the left half reaches the surface; the right half is the plain image's.
        for j in 0..h {
            for i in 0..w {
                let z = median[j * w + i];
                if i < w / 2 {
                    assert!(z.is_infinite() || z < z0, "{what}: ({i}, {j}) at {z}");
                } else {
                    assert_eq!(
                        image.get_pixel(i as u32, j as u32),
                        plain.get_pixel(i as u32, j as u32),
                        "{what}: ({i}, {j}) of the right half"
                    );
                }
            }
        }
        let changed = (0..w * h)
            .filter(|&p| {
                image.get_pixel((p % w) as u32, (p / w) as u32)
                    != plain.get_pixel((p % w) as u32, (p / w) as u32)
            })
            .count();
        eprintln!("{what}: the surface changed {changed} of {} pixels", w * h);
        assert!(changed > 0);
    }
    // A surface over the whole image at z0 is the scene without the Gaussians at z0 or behind.
    let projection = DepthProjection {
        near: 0.05,
        far: 50.0,
        reversed: true,
        infinite: false,
    };
    let buffer = device_floats(&ctx, &vec![projection.depth_value(z0); w * h]);
    let options = RenderOptions {
        depth_test: Some(buffer_test(&buffer, projection)),
        ..RenderOptions::default()
    };
    let (tested, _) = renderer.render(&gpu, &cam, &options).unwrap();
    let keep: Vec<usize> = (0..scene.len())
        .filter(|&i| {
            let s = &mid.splats[i];
            // Culled and undrawn Gaussians carry no depth worth testing; keep them.
            !(mid.depth_order.contains(&(i as u32)) && s.depth >= z0)
        })
        .collect();
    let front = common::subset(&scene, &keep);
    let front_gpu = renderer.upload(&front).unwrap();
    let (front_image, _) = renderer
        .render(&front_gpu, &cam, &RenderOptions::default())
        .unwrap();
    assert_eq!(
        tested, front_image,
        "a surface at z0 differs from the scene without what lies behind z0"
    );
    common::assert_no_validation_messages(&ctx);
}

/// A depth image of `format` holding `values` (as D32 floats, or D16's units), sampled, in
/// `DEPTH_STENCIL_READ_ONLY_OPTIMAL`; returns it, its memory and a depth view.
fn depth_image(
    ctx: &rara::Context,
    format: vk::Format,
    (w, h): (u32, u32),
    bytes: &[u8],
) -> (vk::Image, vk::DeviceMemory, vk::ImageView) {
    let device = ctx.device();
    let image = unsafe {
        device.create_image(
            &vk::ImageCreateInfo::default()
                .image_type(vk::ImageType::TYPE_2D)
                .format(format)
                .extent(vk::Extent3D {
                    width: w,
                    height: h,
                    depth: 1,
                })
                .mip_levels(1)
                .array_layers(1)
                .samples(vk::SampleCountFlags::TYPE_1)
                .tiling(vk::ImageTiling::OPTIMAL)
                .usage(
                    vk::ImageUsageFlags::SAMPLED
                        | vk::ImageUsageFlags::TRANSFER_DST
                        | vk::ImageUsageFlags::DEPTH_STENCIL_ATTACHMENT,
                ),
            None,
        )
    }
    .unwrap();
    let req = unsafe { device.get_image_memory_requirements(image) };
    let props = unsafe {
        ctx.instance()
            .get_physical_device_memory_properties(ctx.physical_device())
    };
    let type_index = (0..props.memory_type_count)
        .find(|&i| {
            req.memory_type_bits & (1 << i) != 0
                && props.memory_types[i as usize]
                    .property_flags
                    .contains(vk::MemoryPropertyFlags::DEVICE_LOCAL)
        })
        .unwrap();
    let memory = unsafe {
        device.allocate_memory(
            &vk::MemoryAllocateInfo::default()
                .allocation_size(req.size)
                .memory_type_index(type_index),
            None,
        )
    }
    .unwrap();
    unsafe { device.bind_image_memory(image, memory, 0) }.unwrap();
    let range = vk::ImageSubresourceRange::default()
        .aspect_mask(vk::ImageAspectFlags::DEPTH)
        .level_count(1)
        .layer_count(1);
    let staging = Buffer::new(
        ctx,
        "depth upload",
        bytes.len() as u64,
        MemoryLocation::GpuOnly,
    )
    .unwrap();
    staging.upload(bytes).unwrap();
    // A layout transition of the whole depth image between two stages.
    let transition = |cmd, (from, src_stage, src_access), (to, dst_stage, dst_access)| unsafe {
        let barrier = vk::ImageMemoryBarrier::default()
            .image(image)
            .subresource_range(range)
            .old_layout(from)
            .new_layout(to)
            .src_access_mask(src_access)
            .dst_access_mask(dst_access);
        device.cmd_pipeline_barrier(
            cmd,
            src_stage,
            dst_stage,
            vk::DependencyFlags::empty(),
            &[],
            &[],
            &[barrier],
        );
    };
    ctx.run_commands(|cmd| {
        transition(
            cmd,
            (
                vk::ImageLayout::UNDEFINED,
                vk::PipelineStageFlags::TOP_OF_PIPE,
                vk::AccessFlags::empty(),
            ),
            (
                vk::ImageLayout::TRANSFER_DST_OPTIMAL,
                vk::PipelineStageFlags::TRANSFER,
                vk::AccessFlags::TRANSFER_WRITE,
            ),
        );
        unsafe {
            device.cmd_copy_buffer_to_image(
                cmd,
                staging.raw,
                image,
                vk::ImageLayout::TRANSFER_DST_OPTIMAL,
                &[vk::BufferImageCopy::default()
                    .image_subresource(vk::ImageSubresourceLayers {
                        aspect_mask: vk::ImageAspectFlags::DEPTH,
                        mip_level: 0,
                        base_array_layer: 0,
                        layer_count: 1,
                    })
                    .image_extent(vk::Extent3D {
                        width: w,
                        height: h,
                        depth: 1,
                    })],
            )
        };
        transition(
            cmd,
            (
                vk::ImageLayout::TRANSFER_DST_OPTIMAL,
                vk::PipelineStageFlags::TRANSFER,
                vk::AccessFlags::TRANSFER_WRITE,
            ),
            (
                vk::ImageLayout::DEPTH_STENCIL_READ_ONLY_OPTIMAL,
                vk::PipelineStageFlags::COMPUTE_SHADER,
                vk::AccessFlags::SHADER_READ,
            ),
        );
    })
    .unwrap();
    let view = unsafe {
        device.create_image_view(
            &vk::ImageViewCreateInfo::default()
                .image(image)
                .view_type(vk::ImageViewType::TYPE_2D)
                .format(format)
                .subresource_range(range),
            None,
        )
    }
    .unwrap();
    (image, memory, view)
}

/// An engine's depth image (D32_SFLOAT and D16_UNORM, sampled in
/// `DEPTH_STENCIL_READ_ONLY_OPTIMAL`) hides the same splats as the same depths in a buffer
/// (D16's values as the image holds them, `u / 65535`): the same image, bit for bit.
#[test]
fn depth_images_test_as_their_buffers_do() {
    let ctx = common::context();
    let mut renderer = Renderer::new(&ctx).unwrap();
    let (scene, cam) = scene_and_camera();
    let gpu = renderer.upload(&scene).unwrap();
    let (w, h) = (cam.width, cam.height);
    let projection = DepthProjection {
        near: 0.05,
        far: 50.0,
        reversed: false,
        infinite: false,
    };
    // A slope: view depth from 2.2 on the left to 3.6 on the right, cleared in the top rows.
    let values: Vec<f32> = (0..w * h)
        .map(|p| {
            let (i, j) = (p % w, p / w);
            if j < h / 4 {
                projection.depth_value(f32::INFINITY)
            } else {
                projection.depth_value(2.2 + 1.4 * i as f32 / w as f32)
            }
        })
        .collect();
    let d16: Vec<u16> = values
        .iter()
        .map(|&d| (d.clamp(0.0, 1.0) * 65535.0).round() as u16)
        .collect();
    let d16_as_f32: Vec<f32> = d16.iter().map(|&u| u as f32 / 65535.0).collect();
    for (format, bytes, as_buffer) in [
        (
            vk::Format::D32_SFLOAT,
            bytemuck::cast_slice::<f32, u8>(&values).to_vec(),
            values.clone(),
        ),
        (
            vk::Format::D16_UNORM,
            bytemuck::cast_slice::<u16, u8>(&d16).to_vec(),
            d16_as_f32,
        ),
    ] {
        let (image, memory, view) = depth_image(&ctx, format, (w, h), &bytes);
        let test = |source| RenderOptions {
            depth_test: Some(DepthTest { source, projection }),
            ..RenderOptions::default()
        };
        let (from_image, _) = renderer
            .render(
                &gpu,
                &cam,
                &test(DepthSource::Image {
                    view,
                    layout: vk::ImageLayout::DEPTH_STENCIL_READ_ONLY_OPTIMAL,
                }),
            )
            .unwrap();
        let buffer = device_floats(&ctx, &as_buffer);
        let (from_buffer, _) = renderer
            .render(
                &gpu,
                &cam,
                &test(DepthSource::Buffer {
                    buffer: buffer.raw,
                    offset: 0,
                }),
            )
            .unwrap();
        let (plain, _) = renderer
            .render(&gpu, &cam, &RenderOptions::default())
            .unwrap();
        let hidden = from_image
            .pixels()
            .zip(plain.pixels())
            .filter(|(a, b)| a != b)
            .count();
        eprintln!("{format:?}: the depth image changed {hidden} pixels");
        assert!(hidden > 0);
        assert_eq!(
            from_image, from_buffer,
            "{format:?}: image and buffer differ"
        );
        unsafe {
            ctx.device().destroy_image_view(view, None);
            ctx.device().destroy_image(image, None);
            ctx.device().free_memory(memory, None);
        }
    }
    common::assert_no_validation_messages(&ctx);
}

/// Several views in one `record_views` call (two stereo eyes 6 cm apart and a cube face, each
/// into a buffer target of its own, the second eye depth-tested against a surface) equal the
/// same views rendered one at a time, bit for bit.
#[test]
fn several_views_equal_single_renders() {
    use rara::{FrameSlot, Target, TargetFormat, View};
    let ctx = common::context();
    let mut renderer = Renderer::new(&ctx).unwrap();
    let (scene, base) = scene_and_camera();
    let gpu = renderer.upload(&scene).unwrap();
    let right = base.rotation * Vec3::X;
    let eye = |dx: f32| Camera {
        position: base.position + dx * right,
        ..base
    };
    let face = Camera::look_at(
        base.position,
        Vec3::new(0.3, 0.0, 0.0),
        Vec3::NEG_Y,
        90.0,
        96,
        96,
    )
    .unwrap();
    let cameras = [eye(-0.03), eye(0.03), face];
    let projection = DepthProjection {
        near: 0.05,
        far: 50.0,
        reversed: false,
        infinite: false,
    };
    let surface = device_floats(
        &ctx,
        &vec![projection.depth_value(3.0); (base.width * base.height) as usize],
    );
    let depth_test = buffer_test(&surface, projection);
    let targets: Vec<Buffer> = cameras
        .iter()
        .map(|c| {
            Buffer::new(
                &ctx,
                "view target",
                (c.width * c.height * 4) as u64,
                MemoryLocation::GpuToCpu,
            )
            .unwrap()
        })
        .collect();
    let mut slots: Vec<FrameSlot> = cameras
        .iter()
        .map(|_| FrameSlot::new(&ctx).unwrap())
        .collect();
    let options = RenderOptions {
        background: Vec3::new(0.1, 0.2, 0.3),
        ..RenderOptions::default()
    };
    ctx.run_commands(|cmd| {
        let mut views: Vec<View> = slots
            .iter_mut()
            .zip(&cameras)
            .zip(&targets)
            .enumerate()
            .map(|(k, ((slot, camera), target))| View {
                camera: *camera,
                target: Target::Buffer {
                    buffer: target.raw,
                    offset: 0,
                    format: TargetFormat::Rgba8Unorm,
                    width: camera.width,
                    height: camera.height,
                },
                slot,
                timer: None,
                depth_test: (k == 1).then_some(depth_test),
                depth_output: None,
            })
            .collect();
        renderer
            .record_views(cmd, &gpu, &mut views, &options)
            .unwrap();
        // Make the writes visible to the host.
        unsafe {
            let barrier = vk::MemoryBarrier::default()
                .src_access_mask(vk::AccessFlags::SHADER_WRITE)
                .dst_access_mask(vk::AccessFlags::HOST_READ);
            ctx.device().cmd_pipeline_barrier(
                cmd,
                vk::PipelineStageFlags::COMPUTE_SHADER,
                vk::PipelineStageFlags::HOST,
                vk::DependencyFlags::empty(),
                &[barrier],
                &[],
                &[],
            );
        }
    })
    .unwrap();
    for (k, camera) in cameras.iter().enumerate() {
        assert!(slots[k].stats().unwrap().complete);
        let single = RenderOptions {
            depth_test: (k == 1).then_some(depth_test),
            ..options.clone()
        };
        let (alone, _) = renderer.render(&gpu, camera, &single).unwrap();
        let bytes = (camera.width * camera.height * 4) as usize;
        let together = image::RgbaImage::from_raw(
            camera.width,
            camera.height,
            targets[k].mapped()[..bytes].to_vec(),
        )
        .unwrap();
        assert_eq!(together, alone, "view {k} differs from its single render");
    }
    let (left, right_eye) = (
        renderer.render(&gpu, &cameras[0], &options).unwrap().0,
        renderer.render(&gpu, &cameras[1], &options).unwrap().0,
    );
    assert_ne!(left, right_eye, "the eyes see the same image");
    drop(slots);
    common::assert_no_validation_messages(&ctx);
}

/// The ray tracer's depth test (SPEC section 9; a hit's view depth is that of its point on
/// the ray): a cleared engine depth changes nothing, bit for bit; an engine surface over the
/// left half of the image, through the scene, matches the CPU ray tracer under the
/// same per-pixel view depths (>= 45 dB), and hides what lies behind it.
#[test]
fn ray_tracer_takes_the_depth_test() {
    let bvh = ray_traced_depth_test(rara::Tracer::Ray);
    // Camera rays from tile lists (SPEC section 11): the same image, to the bit.
    let tiles = ray_traced_depth_test(rara::Tracer::RayTiles);
    assert_eq!(
        rara::metrics::compare(&bvh, &tiles).differing_pixels,
        0,
        "tile lists against the BVH under the depth test"
    );
}

/// [`ray_tracer_takes_the_depth_test`] with `tracer`; returns the half-covered image.
fn ray_traced_depth_test(tracer: rara::Tracer) -> image::RgbaImage {
    let ctx = common::context();
    let mut renderer = Renderer::new(&ctx).unwrap();
    let (scene, cam) = scene_and_camera();
    let gpu = renderer.upload(&scene).unwrap();
    let (w, h) = (cam.width as usize, cam.height as usize);
    let traced = RenderOptions {
        tracer,
        ..RenderOptions::default()
    };
    let (plain, _) = renderer.render(&gpu, &cam, &traced).unwrap();
    let projection = DepthProjection {
        near: 0.05,
        far: 50.0,
        reversed: true,
        infinite: true,
    };
    let cleared = projection.depth_value(f32::INFINITY);
    let surface = projection.depth_value(2.6);
    let render = |renderer: &mut Renderer, values: &[f32]| {
        let buffer = device_floats(&ctx, values);
        let options = RenderOptions {
            depth_test: Some(buffer_test(&buffer, projection)),
            ..traced.clone()
        };
        renderer.render(&gpu, &cam, &options).unwrap().0
    };
    let image = render(&mut renderer, &vec![cleared; w * h]);
    assert_eq!(
        image, plain,
        "a cleared depth buffer changed the traced image"
    );
    let half: Vec<f32> = (0..w * h)
        .map(|p| if p % w < w / 2 { surface } else { cleared })
        .collect();
    let image = render(&mut renderer, &half);
    let limits: Vec<f32> = half.iter().map(|&d| projection.view_depth(d)).collect();
    let rt = rara::RayTraceOptions::default();
    let (cpu, _) = reference::raytrace::render_depth_tested(
        &scene,
        &cam,
        &RenderOptions::default(),
        &rt,
        &limits,
        None,
    );
    common::check_images("trace_depth_test", &image, &cpu, 45.0, 16);
    let hidden = (0..w * h)
        .filter(|&p| image.as_raw()[4 * p..4 * p + 4] != plain.as_raw()[4 * p..4 * p + 4])
        .collect::<Vec<_>>();
    eprintln!("the surface changes {} pixels", hidden.len());
    assert!(hidden.len() > w * h / 20, "{}", hidden.len());
    assert!(
        hidden.iter().all(|&p| p % w < w / 2),
        "a pixel right of the surface changed"
    );
    common::assert_no_validation_messages(&ctx);
    image
}

/// The ray tracer's depth output (SPEC sections 9 and 11: a composited hit's view depth is
/// `t (d . forward)`), through the BVH and through tile lists alike, against the CPU ray
/// tracer's (`reference::raytrace::depths`), median and mean: finite at the same pixels and
/// within 1e-4 relative but for a few pixels whose median sits at a hit where `1 - T` passes
/// 0.5 within f32's rounding; the two GPU paths give the same depths to the bit.
#[test]
fn ray_tracer_writes_the_depth_output() {
    let ctx = common::context();
    let mut renderer = Renderer::new(&ctx).unwrap();
    let (scene, cam) = scene_and_camera();
    let gpu = renderer.upload(&scene).unwrap();
    let rt = rara::RayTraceOptions::default();
    for mode in [DepthMode::Median, DepthMode::Mean] {
        let cpu = reference::raytrace::depths(&scene, &cam, &RenderOptions::default(), &rt, mode);
        let mut paths = Vec::new();
        for tracer in [rara::Tracer::Ray, rara::Tracer::RayTiles] {
            let options = RenderOptions {
                tracer,
                ..RenderOptions::default()
            };
            let (_, depths, _) = renderer
                .render_with_depth(&gpu, &cam, &options, mode)
                .unwrap();
            let (mut finite, mut off) = (0, 0);
            for (g, c) in depths.iter().zip(&cpu) {
                assert_eq!(
                    g.is_finite(),
                    c.is_finite(),
                    "{tracer:?} {mode:?}: {g} vs {c}"
                );
                if c.is_finite() {
                    finite += 1;
                    if (g - c).abs() > 1e-4 * c.abs() {
                        off += 1;
                    }
                }
            }
            eprintln!("{tracer:?} {mode:?}: {finite} pixels with a depth, {off} off by > 1e-4");
            assert!(finite > depths.len() / 4, "{tracer:?} {mode:?}: {finite}");
            assert!(
                off * 200 <= finite,
                "{tracer:?} {mode:?}: {off} of {finite}"
            );
            paths.push(depths);
        }
        assert!(
            paths[0]
                .iter()
                .zip(&paths[1])
                .all(|(a, b)| a.to_bits() == b.to_bits()),
            "{mode:?}: tile lists against the BVH"
        );
    }
    common::assert_no_validation_messages(&ctx);
}
