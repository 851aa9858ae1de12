//! End-to-end renders and each stage of the GPU pipeline against the CPU reference.

mod common;

use glam::{Quat, Vec3};
use rara::constants::RASTER_CHUNK;
use rara::reference::project::{
    footprint_blocks, footprint_q_max, footprint_touches_tile, project_one,
};
use rara::reference::{self, rasterize::tile_lists};
use rara::{Camera, Clip, ClipRegion, GpuScene, RenderOptions, Renderer, Scene, ShPrecision};

/// Two views of `scene` at `width` pixels: from its orbit cameras, or around its percentile box.
fn two_cameras(scene: &Scene, cams: Option<&std::path::Path>, width: u32) -> Vec<Camera> {
    match cams {
        Some(path) => {
            let all = Camera::load_all(path).unwrap();
            [0, all.len() / 2 + 1]
                .iter()
                .map(|&k| all[k % all.len()].resized(width, None).unwrap())
                .collect()
        }
        None => common::views_around(scene, &[0.3, 2.2], width, width * 3 / 4),
    }
}

fn render_real_scene(stem: &str) {
    let Some((ply, cams)) = common::real_scene(stem) else {
        return common::test_skipped("its real scene is not here");
    };
    let (scene, _) = rara::ply::load_ply(&ply).unwrap();
    let ctx = common::context();
    let mut renderer = Renderer::new(&ctx).unwrap();
    let gpu_scene = renderer.upload(&scene).unwrap();
    for (k, cam) in two_cameras(&scene, cams.as_deref(), 320).iter().enumerate() {
        let options = RenderOptions {
            background: Vec3::new(0.1, 0.2, 0.3),
            ..RenderOptions::default()
        };
        let (gpu, stats) = renderer.render(&gpu_scene, cam, &options).unwrap();
        let cpu = reference::render(&scene, cam, &options);
        let d = common::check_images(&format!("{stem}_view{k}"), &gpu, &cpu, 50.0, 4);
        eprintln!(
            "real-scene case '{stem}' view {k} RAN: {} intersections, PSNR {:.2} dB, max diff {}",
            stats.intersections, d.psnr, d.max_diff
        );
    }
    common::assert_no_validation_messages(&ctx);
}

#[test]
fn real_kacytran_sh3() {
    render_real_scene("kacytran_indoor_iter7000_sh3");
}
#[test]
fn real_plant() {
    render_real_scene("plant_capture_sh0");
}
#[test]
fn real_biker() {
    render_real_scene("biker_capture_sh0");
}
#[test]
fn real_guitar() {
    render_real_scene("guitar_capture_sh0_anisotropic");
}
#[test]
fn real_skull() {
    render_real_scene("skull_mesh2splat_100k_sh0");
}
#[test]
fn real_playbot_500k_sh2() {
    render_real_scene("playbot_lod0_500k_sh2");
}

/// The crate's own fixtures: a shell at every SH degree, GPU against CPU.
#[test]
fn synthetic_scenes_every_sh_degree() {
    let ctx = common::context();
    let mut renderer = Renderer::new(&ctx).unwrap();
    let cams = rara::synth::orbit_cameras(3, 3.0, 200, 150, 50.0).unwrap();
    for degree in 0..=3 {
        let scene = rara::synth::shell(6000, degree, degree as u64);
        let gpu_scene = renderer.upload(&scene).unwrap();
        for (k, cam) in cams.iter().enumerate() {
            let (gpu, _) = renderer
                .render(&gpu_scene, cam, &RenderOptions::default())
                .unwrap();
            let cpu = reference::render(&scene, cam, &RenderOptions::default());
            common::check_images(&format!("shell_sh{degree}_view{k}"), &gpu, &cpu, 50.0, 4);
        }
        // Half floats too: with 3 or 27 values per Gaussian (degrees 0 and 2) its coefficients
        // start at every offset within the 64-bit words the kernels read (glsl/sh.glsl).
        let half = GpuScene::with_sh_precision(&ctx, &scene, ShPrecision::F16).unwrap();
        let rounded = ShPrecision::F16.round_scene(&scene);
        let (gpu, _) = renderer
            .render(&half, &cams[0], &RenderOptions::default())
            .unwrap();
        let cpu = reference::render(&rounded, &cams[0], &RenderOptions::default());
        common::check_images(&format!("shell_sh{degree}_f16"), &gpu, &cpu, 50.0, 4);
    }
    let demo = rara::synth::demo_scene();
    let gpu_scene = renderer.upload(&demo).unwrap();
    let (gpu, _) = renderer
        .render(&gpu_scene, &cams[1], &RenderOptions::default())
        .unwrap();
    common::check_images(
        "demo_scene",
        &gpu,
        &reference::render(&demo, &cams[1], &RenderOptions::default()),
        50.0,
        4,
    );
    common::assert_no_validation_messages(&ctx);
}

/// project, emit + sort + tile ranges and rasterize, each against its CPU twin, on one frame.
#[test]
fn each_stage_matches_its_cpu_twin() {
    let scene = rara::synth::demo_scene();
    let cam = &rara::synth::orbit_cameras(4, 3.0, 256, 192, 50.0).unwrap()[1];
    stages_match_cpu_twins(&scene, cam, (55.0, 1));
}

/// The same on needles: thin splats (axes up to 300:1) at every angle, small to larger than the
/// image, faint to opaque, many reaching past its edges. Project and emit walk only each tile
/// row's candidate columns (footprint_row_columns), a band around the ellipse; the tiles they
/// count and write must still be exactly those the CPU's per-tile test passes.
#[test]
fn each_stage_matches_its_cpu_twin_on_needles() {
    let mut rng = rara::synth::Rng::new(21);
    let mut scene = rara::synth::shell(0, 0, 1);
    for _ in 0..3000 {
        let mean = Vec3::new(
            rng.range(-1.6, 1.6),
            rng.range(-1.2, 1.2),
            rng.range(-1.0, 1.0),
        );
        let long = 10f32.powf(rng.range(-2.5, -0.3));
        let thin = long / 10f32.powf(rng.range(0.0, 2.5));
        let axis = Vec3::new(
            rng.range(-1.0, 1.0),
            rng.range(-1.0, 1.0),
            rng.range(-1.0, 1.0),
        );
        let rotation = Quat::from_axis_angle(
            axis.try_normalize().unwrap_or(Vec3::Z),
            rng.range(0.0, std::f32::consts::TAU),
        );
        let opacity = 10f32.powf(rng.range(-2.3, 0.0));
        let sh = [
            rng.range(-1.0, 1.0),
            rng.range(-1.0, 1.0),
            rng.range(-1.0, 1.0),
        ];
        scene.push(
            mean,
            opacity,
            Vec3::new(long, thin, thin * 0.5),
            rotation,
            &sh,
        );
    }
    let cam = &rara::synth::orbit_cameras(4, 3.0, 256, 192, 50.0).unwrap()[2];
    stages_match_cpu_twins(&scene, cam, (55.0, 1));
}

/// `raster`: the PSNR and largest difference the rasterizer may show against its CPU twin.
fn stages_match_cpu_twins(scene: &Scene, cam: &Camera, raster: (f64, u8)) {
    let ctx = common::context();
    let mut renderer = Renderer::new(&ctx).unwrap();
    renderer.set_keep_depth_order(true);
    let gpu_scene = renderer.upload(scene).unwrap();
    let (gpu_image, stats) = renderer
        .render(&gpu_scene, cam, &RenderOptions::default())
        .unwrap();
    let mid = renderer.intermediates(&gpu_scene, &stats).unwrap();

    // project: same visibility, values within float tolerance.
    let mut cpu_splats = Vec::new();
    let mut visible = 0;
    for i in 0..scene.len() {
        let g = &mid.splats[i];
        let gpu_visible = g.drawn();
        let cpu = project_one(scene, cam, &Clip::default(), i);
        assert_eq!(
            gpu_visible,
            cpu.is_some(),
            "Gaussian {i}: visibility differs"
        );
        let Some(c) = cpu else { continue };
        visible += 1;
        let close = |a: f32, b: f32, what: &str| {
            assert!(
                (a - b).abs() <= 1e-4 + 1e-4 * b.abs(),
                "Gaussian {i}: {what} GPU {a} CPU {b}"
            );
        };
        close(g.uv[0], c.uv.x, "u");
        close(g.uv[1], c.uv.y, "v");
        close(g.depth, c.depth, "depth");
        close(g.opacity, c.opacity, "opacity");
        for k in 0..3 {
            close(g.conic[k], c.conic[k], "conic");
            close(g.color()[k], c.color[k], "colour");
        }
        let grid = rara::camera::tile_grid(cam.width, cam.height);
        assert_eq!(g.tile_rect(grid), c.rect, "Gaussian {i}: tile rect");
        cpu_splats.push(c);
    }
    assert_eq!(visible, stats.visible as usize);

    // depth order: the drawn Gaussians by (depth, index), using the GPU's own depths so that
    // float differences between the twins cannot reorder near-equal depths.
    let mut expected_order: Vec<u32> = cpu_splats.iter().map(|c| c.index).collect();
    expected_order.sort_by_key(|&i| (mid.splats[i as usize].depth.to_bits(), i));
    assert_eq!(mid.depth_order, expected_order, "depth order");

    // tiles touched and the prefix sum over them in depth order: each drawn Gaussian's first
    // pair (the tiles of its rectangle that its visible footprint reaches).
    let by_index: std::collections::HashMap<u32, &reference::project::ProjectedSplat> =
        cpu_splats.iter().map(|c| (c.index, c)).collect();
    let mut acc = 0u32;
    for (j, &i) in mid.depth_order.iter().enumerate() {
        assert_eq!(
            mid.offsets[j], acc,
            "offset of Gaussian {i} (depth rank {j})"
        );
        let c = by_index[&i];
        let q_max = footprint_q_max(c.opacity);
        let mut touched = 0;
        for ty in c.rect[1]..c.rect[3] {
            for tx in c.rect[0]..c.rect[2] {
                touched += footprint_touches_tile(c.uv, c.conic, q_max, tx, ty) as u32;
            }
        }
        assert_eq!(
            mid.tiles_touched[i as usize], touched,
            "tiles touched by Gaussian {i}"
        );
        acc += touched;
    }
    assert_eq!(acc, stats.intersections);

    // emit + sort + tile ranges: every tile's list equals the CPU's (depth, index) order, each
    // pair with the blocks of the tile that its splat's footprint reaches. Ordered by the GPU's
    // depths, as the depth order above: NVIDIA's depths differ from the CPU's in the last bit
    // (fused multiply-adds), which swapped two near-equal splats in a tile's list.
    let by_gpu_depth: Vec<_> = cpu_splats
        .iter()
        .map(|c| reference::project::ProjectedSplat {
            depth: mid.splats[c.index as usize].depth,
            ..*c
        })
        .collect();
    let cpu_lists = tile_lists(&by_gpu_depth, cam);
    let grid_x = reference::project::tile_grid(cam).0;
    for (tile, list) in cpu_lists.iter().enumerate() {
        let [start, end] = mid.ranges[tile];
        let gpu_list: Vec<u32> = mid.values[start as usize..end as usize].to_vec();
        let (tx, ty) = (tile as u32 % grid_x, tile as u32 / grid_x);
        let cpu_list: Vec<u32> = list
            .iter()
            .map(|&k| {
                // From the GPU's own projection, as emit worked them out.
                let i = cpu_splats[k as usize].index;
                let g = &mid.splats[i as usize];
                let blocks = footprint_blocks(
                    g.uv.into(),
                    g.conic.into(),
                    footprint_q_max(g.opacity),
                    tx,
                    ty,
                );
                i | blocks
            })
            .collect();
        assert_eq!(gpu_list, cpu_list, "tile {tile}: sorted list differs");
        assert!(mid.keys[start as usize..end as usize]
            .iter()
            .all(|&key| key as usize == tile));
    }

    // rasterize: the CPU compositor over the GPU's own projected splats and lists.
    let gpu_as_cpu: Vec<_> = cpu_splats
        .iter()
        .map(|c| {
            let g = &mid.splats[c.index as usize];
            reference::project::ProjectedSplat {
                uv: g.uv.into(),
                depth: g.depth,
                opacity: g.opacity,
                conic: g.conic.into(),
                color: g.color().into(),
                ..*c
            }
        })
        .collect();
    let twin = reference::rasterize::rasterize(&gpu_as_cpu, cam, Vec3::ZERO, &Clip::default());
    common::check_images("rasterize_twin", &gpu_image, &twin, raster.0, raster.1);
    common::assert_no_validation_messages(&ctx);
}

/// A splat over all 65,536 tiles of a 4096 x 4096 image, so its tile rectangle has more cells
/// than one invocation may loop over on lavapipe (65,535 iterations): project counts its tiles
/// and emit writes its pairs in rounds of TILE_RECT_CHUNK cells (one dispatch per round), in
/// front of a shell of small splats. Unclipped and under rara clipping by a plane through it
/// (a cutoff splat whose pairs the cutoff-tiles pass classifies), in both rasterizer layouts
/// (whose emit and cutoff-tiles kernels read the splats differently), GPU against CPU.
#[test]
fn splat_over_more_tiles_than_one_round_walks() {
    use rara::constants::TILE_RECT_CHUNK;
    let ctx = common::context();
    let mut scene = rara::synth::shell(2000, 0, 5);
    let dc = rara::scene::rgb_to_sh_dc;
    scene.push(
        Vec3::ZERO,
        0.95,
        Vec3::splat(1.65),
        Quat::IDENTITY,
        &[dc(1.0), dc(0.5), dc(0.2)],
    );
    let cam = rara::synth::orbit_cameras(1, 2.4, 4096, 4096, 50.0).unwrap()[0];
    let plane = rara::Plane::new(Vec3::new(0.3, 0.2, 1.0).normalize(), 0.0).unwrap();
    let rara_clip = Clip::rara(ClipRegion::planes(vec![plane]).unwrap());
    for (name, clip) in [("unclipped", Clip::default()), ("rara", rara_clip)] {
        let options = RenderOptions {
            clip,
            ..RenderOptions::default()
        };
        let cpu = reference::render(&scene, &cam, &options);
        for layout in common::raster_layouts(&ctx) {
            let mut renderer = Renderer::with_raster_layout(&ctx, layout).unwrap();
            let gpu_scene = renderer.upload(&scene).unwrap();
            let (gpu, stats) = renderer.render(&gpu_scene, &cam, &options).unwrap();
            assert!(
                stats.intersections > TILE_RECT_CHUNK * 2,
                "{name}: {} pairs, want the big splat over more than two rounds of cells",
                stats.intersections
            );
            let label = format!("splat_over_65536_tiles_{name}_{layout:?}");
            common::check_images(&label, &gpu, &cpu, 50.0, 4);
        }
    }
    common::assert_no_validation_messages(&ctx);
}

/// A tile list of more than 100k splats (lavapipe ends a shader invocation after 65,535 loop
/// iterations in total): about 110k splats too faint to count (alpha < 1/255 away from their
/// pixel) in front of one opaque splat, which is the last entry of a full rasterizer round
/// (RASTER_CHUNK entries), so a round cut short by the loop cap would lose it.
#[test]
fn tile_with_more_than_100k_splats() {
    let ctx = common::context();
    let mut renderer = Renderer::new(&ctx).unwrap();
    let mut scene = Scene {
        sh_degree: 0,
        ..Default::default()
    };
    // Tiny splats on pixel (3, 3) of tile (0, 0), in front of an opaque red splat
    // that covers the image: every pixel of that tile but the few under the tiny splats has to
    // walk the whole list to reach the red one.
    let cam = Camera::look_at(
        Vec3::new(0.0, 0.0, -3.0),
        Vec3::ZERO,
        Vec3::NEG_Y,
        40.0,
        32,
        32,
    )
    .unwrap();
    let mut rng = rara::synth::Rng::new(1);
    let grey = [rara::scene::rgb_to_sh_dc(1.0); 3];
    for _ in 0..9 * RASTER_CHUNK - 1 {
        let depth = 3.0 + rng.range(-0.5, 0.5);
        // The camera-space point that projects to pixel (3, 3) at this depth.
        let (cx, cy) = cam.principal_point();
        let local = Vec3::new((3.0 - cx) / cam.fx, (3.0 - cy) / cam.fy, 1.0) * depth;
        let p = cam.position + cam.rotation * local;
        scene.push(p, 0.5, Vec3::splat(0.0005), Quat::IDENTITY, &grey);
    }
    let red = [
        rara::scene::rgb_to_sh_dc(0.9),
        rara::scene::rgb_to_sh_dc(0.1),
        rara::scene::rgb_to_sh_dc(0.1),
    ];
    scene.push(
        Vec3::new(0.0, 0.0, 2.0),
        0.999,
        Vec3::splat(1.0),
        Quat::IDENTITY,
        &red,
    );
    let gpu_scene = renderer.upload(&scene).unwrap();
    let (gpu, stats) = renderer
        .render(&gpu_scene, &cam, &RenderOptions::default())
        .unwrap();
    assert!(
        stats.max_tile_len > 100_000,
        "longest tile list {}",
        stats.max_tile_len
    );
    assert!(
        stats.rerenders >= 1,
        "the rasterizer should have needed more than one round"
    );
    let cpu = reference::render(&scene, &cam, &RenderOptions::default());
    common::check_images("long_tile_list", &gpu, &cpu, 50.0, 4);
    let far = gpu.get_pixel(12, 12);
    assert!(
        far[0] > 150 && far[1] < 60,
        "the opaque splat behind the list must show, got {far:?}"
    );
    let under = gpu.get_pixel(3, 3);
    assert!(
        under[1] > 200,
        "the tiny splats must show at (3, 3), got {under:?}"
    );

    // The same list with every splat cutoff (trace_all) by a box around the scene, the eye
    // outside it: every ray's visible interval has two bounded ends, the most loop iterations
    // per entry the rara kernel takes.
    let boxed = Clip {
        trace_all: true,
        ..Clip::rara(
            ClipRegion::oriented_box(Vec3::new(0.0, 0.0, 1.0), Vec3::splat(3.0), Quat::IDENTITY)
                .unwrap(),
        )
    };
    let options = RenderOptions {
        clip: boxed,
        ..RenderOptions::default()
    };
    let (gpu, stats) = renderer.render(&gpu_scene, &cam, &options).unwrap();
    assert_eq!(stats.cutoff, scene.len() as u32);
    assert!(stats.max_tile_len > 100_000);
    let cpu = reference::render(&scene, &cam, &options);
    common::check_images("long_tile_list_rara_box", &gpu, &cpu, 50.0, 4);
    let far = gpu.get_pixel(12, 12);
    assert!(
        far[0] > 150 && far[1] < 60,
        "rara: the opaque splat behind the list must show, got {far:?}"
    );
    common::assert_no_validation_messages(&ctx);
}

/// The validation hook itself: an invalid command is reported (so a clean run means something).
#[test]
fn validation_messages_are_caught() {
    let ctx = common::context();
    if !ctx.validation_enabled() {
        eprintln!("validation layer not installed: nothing to check");
        return;
    }
    let buf =
        rara::vk::Buffer::new(&ctx, "misused", 64, rara::vk::MemoryLocation::GpuOnly).unwrap();
    // vkCmdFillBuffer needs an offset that is a multiple of 4.
    ctx.run_commands(|cmd| unsafe { ctx.device().cmd_fill_buffer(cmd, buf.raw, 2, 4, 0) })
        .unwrap();
    let messages = ctx.take_validation_messages();
    assert!(
        !messages.is_empty(),
        "the validation layer did not report a misaligned vkCmdFillBuffer"
    );
}

/// More tile pairs than the intersection buffers first hold: the frame detects it, the buffers
/// grow and the frame is rendered again, with nothing truncated.
#[test]
fn intersection_overflow_grows_and_rerenders() {
    let ctx = common::context();
    let mut renderer = Renderer::new(&ctx).unwrap();
    let mut scene = Scene {
        sh_degree: 0,
        ..Default::default()
    };
    let mut rng = rara::synth::Rng::new(5);
    for _ in 0..3000 {
        let p = Vec3::new(
            rng.range(-1.0, 1.0),
            rng.range(-1.0, 1.0),
            rng.range(-1.0, 1.0),
        );
        let c = [
            rng.range(-1.0, 1.0),
            rng.range(-1.0, 1.0),
            rng.range(-1.0, 1.0),
        ];
        scene.push(
            p,
            0.05,
            Vec3::splat(rng.range(0.2, 0.5)),
            rng.rotation(),
            &c,
        );
    }
    let cam = Camera::look_at(
        Vec3::new(0.0, -0.5, -4.0),
        Vec3::ZERO,
        Vec3::NEG_Y,
        50.0,
        256,
        256,
    )
    .unwrap();
    let gpu_scene = renderer.upload(&scene).unwrap();
    let (gpu, stats) = renderer
        .render(&gpu_scene, &cam, &RenderOptions::default())
        .unwrap();
    assert!(
        stats.intersections > 1 << 16,
        "only {} intersections: the case does not overflow",
        stats.intersections
    );
    assert!(
        stats.rerenders >= 1,
        "the first frame should have overflowed"
    );
    common::check_images(
        "overflow",
        &gpu,
        &reference::render(&scene, &cam, &RenderOptions::default()),
        50.0,
        4,
    );
    // The grown buffers are kept: the next frame fits at once.
    let (_, again) = renderer
        .render(&gpu_scene, &cam, &RenderOptions::default())
        .unwrap();
    assert_eq!(again.rerenders, 0);
    common::assert_no_validation_messages(&ctx);
}

/// The two rasterizer layouts (a pixel per invocation for GPUs, column strips for CPU drivers)
/// give the same image to rounding, clipped or not, on an image whose size is not a multiple of the tile.
#[test]
fn raster_layouts_agree() {
    use rara::stages::rasterize::RasterLayout;
    let ctx = common::context();
    if !common::runs_cpu_layouts(&ctx) {
        return;
    }
    let scene = rara::synth::layers(15000, 1, 8);
    let cam = &rara::synth::orbit_cameras(3, 3.0, 203, 149, 50.0).unwrap()[2];
    let region = rara::ClipRegion::sphere(Vec3::new(0.3, 0.0, 0.2), 0.7).unwrap();
    for clip in [Clip::default(), Clip::rara(region.inverted())] {
        let options = RenderOptions {
            clip,
            ..RenderOptions::default()
        };
        let mut images = Vec::new();
        for layout in [RasterLayout::PixelPerInvocation, RasterLayout::Strips] {
            let mut renderer = Renderer::with_raster_layout(&ctx, layout).unwrap();
            let gpu_scene = renderer.upload(&scene).unwrap();
            images.push(renderer.render(&gpu_scene, cam, &options).unwrap().0);
        }
        // The same to float rounding: the strips evaluate a splat's exponent down a column
        // from the strip's first pixel (a quadratic in the row), the pixel layout at each
        // pixel, so the two alphas can differ in the last bits and put a pixel on the other
        // side of a rounding to 8 bits.
        let d = rara::metrics::compare(&images[0], &images[1]);
        assert!(
            d.max_diff <= 1 && d.differing_pixels <= 3,
            "layouts differ in {} pixels, by up to {}",
            d.differing_pixels,
            d.max_diff
        );
        let cpu = reference::render(&scene, cam, &options);
        common::check_images("raster_layouts", &images[1], &cpu, 50.0, 4);
    }
    common::assert_no_validation_messages(&ctx);
}

/// Leaving out the tiles a splat's visible footprint does not reach changes no pixel: the CPU
/// reference composited over the SPEC's full 3-sigma rectangles gives the same image.
#[test]
fn tight_footprints_change_no_pixel() {
    let scene = rara::synth::demo_scene();
    let cam = &rara::synth::orbit_cameras(4, 3.2, 160, 120, 50.0).unwrap()[1];
    let splats = reference::project::project_all(&scene, cam, &Clip::default());
    let tight = tile_lists(&splats, cam);
    let (gx, gy) = rara::camera::tile_grid(cam.width, cam.height);
    let mut full: Vec<Vec<(u32, u32, u32)>> = vec![Vec::new(); (gx * gy) as usize];
    for (k, s) in splats.iter().enumerate() {
        for ty in s.rect[1]..s.rect[3] {
            for tx in s.rect[0]..s.rect[2] {
                full[(ty * gx + tx) as usize].push((s.depth.to_bits(), s.index, k as u32));
            }
        }
    }
    let full: Vec<Vec<u32>> = full
        .into_iter()
        .map(|mut l| {
            l.sort_unstable_by_key(|&(d, i, _)| (d, i));
            l.into_iter().map(|(_, _, k)| k).collect()
        })
        .collect();
    let (n_tight, n_full): (usize, usize) = (
        tight.iter().map(Vec::len).sum(),
        full.iter().map(Vec::len).sum(),
    );
    eprintln!("tile pairs: {n_tight} tight vs {n_full} over full rectangles");
    assert!(n_tight < n_full);
    for j in 0..cam.height {
        for i in 0..cam.width {
            let tile = ((j / 16) * gx + i / 16) as usize;
            let pixel = glam::Vec2::new(i as f32, j as f32);
            let a = reference::rasterize::composite_pixel(
                &splats,
                &tight[tile],
                pixel,
                Vec3::ZERO,
                None,
            );
            let b = reference::rasterize::composite_pixel(
                &splats,
                &full[tile],
                pixel,
                Vec3::ZERO,
                None,
            );
            assert_eq!(a, b, "pixel ({i}, {j})");
        }
    }
}

/// The pass timestamps can live in a query pool the caller owns: the renderer writes its queries
/// there, reads them back, and leaves the pool to its owner.
#[test]
fn pass_timings_into_a_callers_query_pool() {
    use ash::vk;
    use rara::timing::{PassTimer, MAX_PASSES};
    let ctx = common::context();
    if !ctx.info().timestamps {
        eprintln!("the queue has no timestamps: nothing to time");
        return;
    }
    let first = 5;
    let info = vk::QueryPoolCreateInfo::default()
        .query_type(vk::QueryType::TIMESTAMP)
        .query_count(first + MAX_PASSES + 1);
    let pool = unsafe { ctx.device().create_query_pool(&info, None) }.unwrap();
    {
        let mut renderer = Renderer::new(&ctx).unwrap();
        // SAFETY: the pool is a timestamp pool of this device with enough queries, it outlives
        // the renderer (destroyed below), and nothing else uses those queries.
        renderer.set_timer(unsafe { PassTimer::with_engine_pool(&ctx, pool, first) });
        let scene = rara::synth::shell(2000, 0, 1);
        let gpu_scene = renderer.upload(&scene).unwrap();
        let cam = &rara::synth::orbit_cameras(1, 3.0, 96, 72, 50.0).unwrap()[0];
        let (_, stats) = renderer
            .render(&gpu_scene, cam, &RenderOptions::default())
            .unwrap();
        let names: Vec<&str> = stats.passes.iter().map(|p| p.name).collect();
        assert_eq!(names.first(), Some(&"project"));
        // render() draws into an RGBA8 buffer over the background: the strips rasterizer
        // (CPU drivers) writes it itself, in a frame without a write-target pass.
        use rara::stages::rasterize::RasterLayout;
        let last = match renderer.raster_layout() {
            RasterLayout::Strips => "rasterize",
            RasterLayout::PixelPerInvocation => "write target",
        };
        assert_eq!(names.last(), Some(&last), "{names:?}");
        assert!(stats
            .passes
            .iter()
            .all(|p| p.ms >= 0.0 && p.invocations.is_none()));
        assert!(stats.gpu_ms > 0.0);
    }
    // The renderer is gone; the pool is still the caller's to destroy.
    unsafe { ctx.device().destroy_query_pool(pool, None) };
    common::assert_no_validation_messages(&ctx);
}

/// Extreme but finite scales (issue 29): log-scales of 12-16 and 18-50 on one axis, seen from
/// in front, beside, and right before the camera. Both paths follow the footprint bound
/// (`MAX_FOOTPRINT_SIGMA_PX`): the same Gaussians are skipped and counted, the rest agree,
/// and nothing paints tile-shaped blocks or NaN. Gaussians inside the bound but large (a few
/// thousand pixels, where `a c - b^2` used to lose every digit) are drawn alike, but for a few
/// pixels on a long needle's centre line: there the true exponent is about -1e-6 and the f32
/// rounding of the paths (the GPU's per-column quadratic, the CPU's direct form) puts it on
/// either side of SPEC section 4's `power > 0` test (8 of 19,200 pixels here).
#[test]
fn extreme_scales_agree_between_gpu_and_cpu() {
    let ctx = common::context();
    let mut renderer = Renderer::new(&ctx).unwrap();
    // An ordinary scene to stay visible around the extreme Gaussians.
    let base_count = 300;
    let mut scene = rara::synth::shell(base_count, 0, 5);
    let grey = [rara::scene::rgb_to_sh_dc(0.6); 3];
    let tilt = Quat::from_rotation_y(0.4) * Quat::from_rotation_x(0.7);
    let log_scales = [
        4.0f32, 6.0, 8.0, 12.0, 13.0, 14.0, 16.0, 18.0, 24.0, 30.0, 40.0, 50.0,
    ];
    for (k, &ls) in log_scales.iter().enumerate() {
        let x = -0.8 + 1.6 * k as f32 / (log_scales.len() - 1) as f32;
        for (axis, rotation) in [(0usize, tilt), (1, Quat::IDENTITY), (2, tilt.inverse())] {
            let mut scale = Vec3::splat(0.01);
            scale[axis] = ls.exp();
            scene.push(
                Vec3::new(x, 0.1 * axis as f32, 0.3),
                0.4,
                scale,
                rotation,
                &grey,
            );
        }
    }
    // Large but within the bound: a 3,000-unit-long needle and a disc near the camera.
    scene.push(
        Vec3::new(0.2, 0.0, -2.0),
        0.5,
        Vec3::new(3000.0, 0.002, 0.002),
        tilt,
        &grey,
    );
    scene.push(
        Vec3::new(0.0, 0.3, -2.4),
        0.3,
        Vec3::new(2.0, 2.0, 0.01),
        tilt,
        &grey,
    );
    let cams = [
        Camera::look_at(
            Vec3::new(0.0, 0.0, -3.0),
            Vec3::ZERO,
            Vec3::NEG_Y,
            50.0,
            160,
            120,
        )
        .unwrap(),
        Camera::look_at(
            Vec3::new(2.5, -1.0, -1.5),
            Vec3::ZERO,
            Vec3::NEG_Y,
            60.0,
            160,
            120,
        )
        .unwrap(),
    ];
    let gpu_scene = GpuScene::new(&ctx, &scene).unwrap();
    let mut skipped_somewhere = false;
    for (k, cam) in cams.iter().enumerate() {
        let options = RenderOptions {
            background: Vec3::new(0.1, 0.2, 0.3),
            ..RenderOptions::default()
        };
        // Project, tiles and lists exactly as the CPU's; the rasterizer but for the centre
        // lines of the longest needles (see above).
        stages_match_cpu_twins(&scene, cam, (50.0, 255));
        let (gpu, stats) = renderer.render(&gpu_scene, cam, &options).unwrap();
        let cpu = reference::render(&scene, cam, &options);
        let oversized = reference::project::count_oversized(&scene, cam, &options.clip);
        assert_eq!(stats.oversized as usize, oversized, "view {k}");
        // Everything from a log-scale of 12 on is past the bound; 4 is within it.
        assert!(oversized >= 3 * 8, "view {k}: only {oversized} skipped");
        assert!(
            oversized < scene.len() - base_count - 3,
            "view {k}: {oversized} skipped"
        );
        skipped_somewhere |= oversized > 0;
        let d = common::check_images(&format!("extreme_scales_view{k}"), &gpu, &cpu, 50.0, 255);
        assert!(
            d.differing_pixels <= 20,
            "view {k}: {} pixels differ",
            d.differing_pixels
        );
    }
    assert!(skipped_somewhere);
    common::assert_no_validation_messages(&ctx);
}
