//! Scale: millions of Gaussians through the PLY file and the GPU, SH stored in half precision,
//! and device memory limits reported as errors.
//!
//! `RARA_SCALE_COUNT` sets the Gaussian count of the large-scene test (default 6,000,000).

mod common;

use std::time::Instant;

use glam::Vec3;
use rara::ply::{load_ply, write_ply, PlyEncoding};
use rara::{reference, Camera, Error, GpuScene, RenderOptions, Renderer, ShPrecision};

fn options() -> RenderOptions {
    RenderOptions {
        background: Vec3::new(0.1, 0.2, 0.3),
        ..RenderOptions::default()
    }
}

/// The CLI's `rara synth` views of a unit shell, at another size.
fn shell_cameras(width: u32, height: u32) -> Vec<Camera> {
    rara::synth::orbit_cameras(8, 2.4 * 3f32.sqrt(), width, height, 50.0).unwrap()
}

/// A `/proc/self/status` field in bytes.
fn status_bytes(field: &str) -> Option<u64> {
    let status = std::fs::read_to_string("/proc/self/status").ok()?;
    let line = status.lines().find(|l| l.starts_with(field))?;
    let kb: u64 = line.split_whitespace().nth(1)?.parse().ok()?;
    Some(kb * 1024)
}

/// Resets the process's peak resident memory to its current value (Linux `clear_refs`) and
/// returns that value, or `None` where the kernel does not allow it.
fn reset_peak_rss() -> Option<u64> {
    std::fs::write("/proc/self/clear_refs", "5").ok()?;
    let (rss, peak) = (status_bytes("VmRSS:")?, status_bytes("VmHWM:")?);
    // The reset worked only if the peak came down to about the current size.
    (peak <= rss + (64 << 20)).then_some(rss)
}

fn peak_rss() -> u64 {
    status_bytes("VmHWM:").unwrap_or(0)
}

/// Runs the `rara` binary with `args` (without the validation layer, as users run it), its
/// output in `dir`, and returns its peak resident memory in bytes (`wait4`'s `ru_maxrss`) and
/// its output; panics if it fails.
fn cli_peak_rss(args: &[String], dir: &std::path::Path) -> (u64, String) {
    let log = dir.join("cli.log");
    let file = std::fs::File::create(&log).unwrap();
    // Linux counts in a child's ru_maxrss the peak of the memory it was spawned from (the
    // parent's, shared until exec): bring this process's peak down to its current size first.
    reset_peak_rss();
    // Reaped by wait4 below, which also gives its rusage.
    #[allow(clippy::zombie_processes)]
    let child = std::process::Command::new(env!("CARGO_BIN_EXE_rara"))
        .args(args)
        .env_remove("RARA_VALIDATION")
        .stdout(file.try_clone().unwrap())
        .stderr(file)
        .spawn()
        .unwrap();
    let pid = child.id() as libc::pid_t;
    let mut status = 0;
    // SAFETY: a zeroed rusage is a valid value for wait4 to fill; `pid` is our own child,
    // reaped here (the Child is not waited on again).
    let mut usage: libc::rusage = unsafe { std::mem::zeroed() };
    let reaped = unsafe { libc::wait4(pid, &mut status, 0, &mut usage) };
    let text = std::fs::read_to_string(&log).unwrap_or_default();
    assert_eq!(reaped, pid, "wait4 failed");
    assert!(
        libc::WIFEXITED(status) && libc::WEXITSTATUS(status) == 0,
        "rara {} failed:\n{text}",
        args.join(" ")
    );
    (usage.ru_maxrss as u64 * 1024, text)
}

/// A `rara synth --kind shell --count N --sh-degree 3` scene goes through a PLY file, the
/// loader, the upload (with the validation layer on: every buffer is reached by device
/// address, none is bound, so none is limited by `maxStorageBufferRange`) and a 160x120
/// frame, which must match the CPU reference; then the same frame ray traced, against the CPU
/// reference ray tracer.
#[test]
fn six_million_sh3_gaussians_match_the_reference() {
    let count: usize = std::env::var("RARA_SCALE_COUNT")
        .ok()
        .and_then(|s| s.parse().ok())
        .unwrap_or(6_000_000);
    let dir = std::env::temp_dir().join(format!("rara-scale-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    let path = dir.join("shell.ply");
    let t = Instant::now();
    write_ply(
        &rara::synth::shell(count, 3, 1),
        &path,
        PlyEncoding::BinaryLittleEndian,
    )
    .unwrap();
    let file_bytes = std::fs::metadata(&path).unwrap().len();
    let written = t.elapsed();
    // `rara render` of the file at 320 px, as a user runs it: the PLY streams from the file to
    // the device, and no host copy of the scene exists while it renders (issue 36). Peak
    // resident memory against the file's size: at most 1.5x with f32 SH and 1.0x with f16 SH
    // (on lavapipe, device memory is host memory: the f16 scene is 0.58x of the file).
    for (flags, bound) in [(&[][..], 1.5), (&["--sh-half"][..], 1.0)] {
        let out = dir.join("frame.png");
        let mut args = vec![
            "render".to_string(),
            path.display().to_string(),
            "--eye".into(),
            "0,-1.0,-4.0".into(),
            "--target".into(),
            "0,0,0".into(),
            "--width".into(),
            "320".into(),
            "--height".into(),
            "240".into(),
            "-o".into(),
            out.display().to_string(),
        ];
        args.extend(flags.iter().map(|f| f.to_string()));
        let (waited_peak, log) = cli_peak_rss(&args, &dir);
        // What the process itself reports (VmHWM), which wait4's count can exceed when the
        // child was spawned from this process.
        let peak: u64 = log
            .lines()
            .find_map(|l| l.strip_prefix("host memory: peak resident "))
            .and_then(|l| l.split('(').nth(1)?.split(' ').next()?.parse().ok())
            .unwrap_or(waited_peak);
        let ratio = peak as f64 / file_bytes as f64;
        let line = format!(
            "rara render{}{} at 320x240: peak resident memory {:.3} GB ({:.3} GB by wait4), \
             {ratio:.3}x the file (bound {bound}x)",
            if flags.is_empty() { "" } else { " " },
            flags.join(" "),
            peak as f64 / 1e9,
            waited_peak as f64 / 1e9
        );
        eprintln!("{line}");
        assert!(log.contains("streamed to the device"), "{log}");
        assert!(ratio <= bound, "{line}\n{log}");
    }
    let baseline = reset_peak_rss();
    let t = Instant::now();
    let (scene, report) = load_ply(&path).unwrap();
    let loaded = t.elapsed();
    // The loader streams: its peak is the scene it returns (236 of the file's 248 bytes per
    // Gaussian) plus a read buffer, never a second copy.
    let load_peak = baseline.map(|rss| peak_rss().saturating_sub(rss));
    if let Some(peak) = load_peak {
        assert!(
            peak as f64 <= 1.5 * file_bytes as f64,
            "loading a {file_bytes}-byte PLY raised the peak resident memory by {peak} bytes"
        );
    }
    std::fs::remove_dir_all(&dir).ok();
    assert_eq!(scene.len(), count);
    assert_eq!(report.dropped_non_finite, 0);

    let ctx = common::context();
    let mut renderer = Renderer::new(&ctx).unwrap();
    let t = Instant::now();
    let gpu_scene = renderer.upload(&scene).unwrap();
    let uploaded = t.elapsed();
    assert_eq!(
        gpu_scene.device_bytes(),
        count as u64 * GpuScene::bytes_per_gaussian(3, ShPrecision::F32) + GpuScene::SH_TAIL_BYTES
    );
    let camera = shell_cameras(160, 120)[0];
    let t = Instant::now();
    let (gpu, stats) = renderer.render(&gpu_scene, &camera, &options()).unwrap();
    let rendered = t.elapsed();
    assert!(stats.complete);
    assert!(stats.visible as usize > count / 3, "{stats:?}");
    let t = Instant::now();
    let cpu = reference::render(&scene, &camera, &options());
    let referenced = t.elapsed();
    let d = common::check_images("scale_shell", &gpu, &cpu, 50.0, 4);
    eprintln!(
        "{count} SH3 Gaussians: PLY {:.2} GB written in {:.1} s, loaded in {:.1} s (peak \
         resident memory +{}), uploaded \
         ({:.2} GB) in {:.1} s; 160x120 GPU frame {:.1} s ({} visible, {} pairs), CPU \
         reference {:.1} s; PSNR {:.2} dB, max diff {}",
        file_bytes as f64 / 1e9,
        written.as_secs_f64(),
        loaded.as_secs_f64(),
        load_peak.map_or("not measured".into(), |b| format!(
            "{:.2} GB, {:.2}x the file",
            b as f64 / 1e9,
            b as f64 / file_bytes as f64
        )),
        gpu_scene.device_bytes() as f64 / 1e9,
        uploaded.as_secs_f64(),
        rendered.as_secs_f64(),
        stats.visible,
        stats.intersections,
        referenced.as_secs_f64(),
        d.psnr,
        d.max_diff
    );

    // The ray tracer on the same scene (SPEC section 7, issue 32): its BVH over all of the
    // Gaussians is built on the GPU, and the frame matches the CPU reference ray tracer.
    let ray = RenderOptions {
        tracer: rara::Tracer::Ray,
        ..options()
    };
    let t = Instant::now();
    let (gpu, stats) = renderer.render(&gpu_scene, &camera, &ray).unwrap();
    let traced = t.elapsed();
    assert!(stats.complete);
    let trace = stats.trace.expect("the ray tracer's counts");
    let t = Instant::now();
    let (cpu, _) = reference::raytrace::render(
        &scene,
        &camera,
        &options(),
        &rara::RayTraceOptions::default(),
    );
    let referenced = t.elapsed();
    // 6M Gaussians on one shell put hits on a ray closer together than f32 resolves
    // (relative gaps of 1.6e-9 and 4.4e-9 at two pixels): a few pixels may differ by more
    // than 4 levels, each one such a tie (common::check_traced).
    let d = common::check_traced(
        "scale_shell_ray",
        &gpu,
        &cpu,
        &scene,
        &camera,
        &ray.clip,
        rara::RayTraceOptions::default().q,
        50.0,
        4,
    );
    let memory = renderer.headless_memory();
    eprintln!(
        "{count} SH3 Gaussians ray traced: 160x120 GPU frame {:.1} s (BVH build included; {:.1} \
         hits per ray, {} rounds; BVH {:.2} GB, {:.1} B/Gaussian), CPU reference {:.1} s; PSNR \
         {:.2} dB, max diff {}",
        traced.as_secs_f64(),
        trace.walked_per_ray(),
        trace.rounds,
        memory.bvh as f64 / 1e9,
        memory.bvh as f64 / count as f64,
        referenced.as_secs_f64(),
        d.psnr,
        d.max_diff
    );
    common::assert_no_validation_messages(&ctx);
}

/// SH in half precision: the GPU image equals the CPU reference of the scene whose SH were
/// rounded the same way (so the kernels unpack exactly what was stored), the scene takes the
/// bytes stated, and the error against 32-bit SH is small on real scenes.
#[test]
fn half_precision_sh() {
    let ctx = common::context();
    let mut renderer = Renderer::new(&ctx).unwrap();
    let scene = rara::synth::shell(30_001, 3, 9);
    let half = GpuScene::with_sh_precision(&ctx, &scene, ShPrecision::F16).unwrap();
    let full = GpuScene::new(&ctx, &scene).unwrap();
    assert_eq!(half.sh_precision(), ShPrecision::F16);
    // 48 bytes of Gaussian and 48 halves of SH each, and the SH buffer's tail.
    assert_eq!(
        half.device_bytes(),
        30_001 * 48 + 30_001 * 96 + GpuScene::SH_TAIL_BYTES
    );
    assert_eq!(
        full.device_bytes(),
        30_001 * (48 + 192) + GpuScene::SH_TAIL_BYTES
    );
    let rounded = ShPrecision::F16.round_scene(&scene);
    assert_ne!(rounded.sh, scene.sh, "rounding changed nothing");
    // Up to 8 levels in a few pixels: NVIDIA's floats differ from the CPU's in the last bits
    // (fused multiply-adds), enough to swap two overlapping splats of near-equal depth (seen in
    // tests/render.rs's tile lists) or to move one across a threshold; view 1 there: PSNR
    // 81 dB, 5 levels in 15 pixels (lavapipe matches the CPU's floats).
    for (k, camera) in shell_cameras(320, 240).iter().step_by(3).enumerate() {
        let (gpu, _) = renderer.render(&half, camera, &options()).unwrap();
        let cpu = reference::render(&rounded, camera, &options());
        common::check_images(&format!("sh16_shell_view{k}"), &gpu, &cpu, 50.0, 8);
    }
    // Replacing the contents keeps the precision; 400k SH3 Gaussians are 38 MB of halves, more
    // than one 32 MiB staging chunk, so the chunked conversion is exercised across a boundary.
    let mut half = half;
    let big = rara::synth::shell(400_000, 3, 10);
    half.replace(&big).unwrap();
    assert_eq!(half.sh_precision(), ShPrecision::F16);
    assert_eq!(half.len(), 400_000);
    let camera = shell_cameras(160, 120)[1];
    let (gpu, _) = renderer.render(&half, &camera, &options()).unwrap();
    let cpu = reference::render(&ShPrecision::F16.round_scene(&big), &camera, &options());
    common::check_images("sh16_shell_400k", &gpu, &cpu, 50.0, 8);

    for stem in [
        "kacytran_indoor_iter7000_sh3",
        "playbot_lod0_500k_sh2",
        "plant_capture_sh0",
    ] {
        let Some((ply, cams)) = common::real_scene(stem) else {
            continue;
        };
        let (scene, _) = load_ply(&ply).unwrap();
        let cameras = match cams {
            Some(path) => Camera::load_all(path).unwrap(),
            None => common::views_around(&scene, &[0.3, 2.2, 4.1], 320, 240),
        };
        let full = GpuScene::new(&ctx, &scene).unwrap();
        let half = GpuScene::with_sh_precision(&ctx, &scene, ShPrecision::F16).unwrap();
        let mut psnr = Vec::new();
        for camera in cameras.iter().step_by(cameras.len().div_ceil(3)) {
            let camera = camera.resized(320, None).unwrap();
            let (a, _) = renderer.render(&full, &camera, &options()).unwrap();
            let (b, _) = renderer.render(&half, &camera, &options()).unwrap();
            let d = rara::metrics::compare(&a, &b);
            assert!(d.psnr >= 45.0, "{stem}: f16 SH PSNR {:.2} dB", d.psnr);
            psnr.push(d.psnr);
        }
        eprintln!(
            "real-scene case '{stem}' RAN: SH f16 vs f32 at 320 px wide, PSNR {} dB; scene \
             device bytes {} -> {}",
            psnr.iter()
                .map(|p| format!("{p:.2}"))
                .collect::<Vec<_>>()
                .join(" / "),
            full.device_bytes(),
            half.device_bytes()
        );
    }
    common::assert_no_validation_messages(&ctx);
}

/// A frame whose buffers exceed what one allocation may be on the device is refused with an
/// error naming the buffer and the limit, and the renderer goes on drawing smaller frames.
#[test]
fn a_frame_too_large_for_the_device_is_a_clear_error() {
    let ctx = common::context();
    let mut renderer = Renderer::new(&ctx).unwrap();
    let scene = rara::synth::shell(2_000, 0, 2);
    let gpu_scene = renderer.upload(&scene).unwrap();
    let max = ctx.info().max_memory_allocation_size;
    // 16 bytes of per-pixel state: the largest square frame whose state exceeds `max`.
    let side = rara::camera::MAX_IMAGE_SIDE;
    if (side as u64).pow(2) * 16 <= max {
        eprintln!("skipped: this device allows allocations of {max} bytes");
        return;
    }
    let huge = Camera::look_at(
        Vec3::new(0.0, 0.0, -3.0),
        Vec3::ZERO,
        Vec3::NEG_Y,
        50.0,
        side,
        side,
    )
    .unwrap();
    let err = renderer
        .render(&gpu_scene, &huge, &options())
        .expect_err("a frame larger than the device allows");
    let text = err.to_string();
    eprintln!("{text}");
    assert!(matches!(err, Error::OutOfDeviceMemory { .. }), "{err:?}");
    assert!(text.contains("raster state") && text.contains("maxMemoryAllocationSize"));
    let small = Camera::look_at(
        Vec3::new(0.0, 0.0, -3.0),
        Vec3::ZERO,
        Vec3::NEG_Y,
        50.0,
        64,
        48,
    )
    .unwrap();
    let (gpu, _) = renderer.render(&gpu_scene, &small, &options()).unwrap();
    let cpu = reference::render(&scene, &small, &options());
    common::check_images("after_oom", &gpu, &cpu, 50.0, 4);
    common::assert_no_validation_messages(&ctx);
}

/// More (tile, splat) pairs than one row of linear workgroups covers (65,535 x 256 =
/// 16,776,960): tile ranges then run on a 2D grid whose size the GPU computes, and the image
/// must still match the CPU reference. Big opaque splats keep the compositing cheap.
#[test]
fn more_pairs_than_one_row_of_workgroups() {
    let mut rng = rara::synth::Rng::new(17);
    let mut scene = rara::Scene {
        sh_degree: 0,
        ..Default::default()
    };
    for _ in 0..240_000 {
        let rgb = Vec3::new(rng.f32(), rng.f32(), rng.f32());
        let dc = rgb.to_array().map(rara::scene::rgb_to_sh_dc);
        scene.push(
            0.3 * rng.unit_vector(),
            rng.range(0.5, 0.95),
            Vec3::splat(rng.range(1.0, 1.5)),
            glam::Quat::IDENTITY,
            &dc,
        );
    }
    let ctx = common::context();
    let mut renderer = Renderer::new(&ctx).unwrap();
    let gpu_scene = renderer.upload(&scene).unwrap();
    let camera = Camera::look_at(
        Vec3::new(0.0, -0.5, -3.0),
        Vec3::ZERO,
        Vec3::NEG_Y,
        50.0,
        160,
        120,
    )
    .unwrap();
    let (gpu, stats) = renderer.render(&gpu_scene, &camera, &options()).unwrap();
    assert!(stats.complete);
    let row = 65_535u32 * 256;
    assert!(
        stats.intersections > row,
        "{} pairs do not exceed one row of workgroups ({row})",
        stats.intersections
    );
    let cpu = reference::render(&scene, &camera, &options());
    let d = common::check_images("many_pairs", &gpu, &cpu, 50.0, 4);
    eprintln!(
        "{} pairs ({:.2} rows of linear workgroups): PSNR {:.2} dB, max diff {}",
        stats.intersections,
        stats.intersections as f64 / row as f64,
        d.psnr,
        d.max_diff
    );
    common::assert_no_validation_messages(&ctx);
}

/// The streaming loader (`GpuScene::load_ply`) puts on the device exactly what loading the
/// PLY into a host scene and uploading it does, byte for byte: three chunks and a part of
/// SH degree 3, with non-finite Gaussians dropped at and around a chunk boundary, binary and
/// ASCII, SH in f32 and in f16; and its progress ends at the file's vertices.
#[test]
fn streamed_ply_equals_load_and_upload() {
    let ctx = common::context();
    let dir = std::env::temp_dir().join(format!("rara-stream-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    let count = 2 * rara::gpu_scene::STREAM_CHUNK + 12_345;
    let mut scene = rara::synth::shell(count, 3, 21);
    let chunk = rara::gpu_scene::STREAM_CHUNK;
    for i in [5, chunk - 1, chunk, chunk + 1, count - 1] {
        scene.means[i].y = f32::NAN;
    }
    let small = rara::synth::hair(3000, 2, 22);
    for (name, scene, encoding) in [
        ("binary.ply", &scene, PlyEncoding::BinaryLittleEndian),
        ("ascii.ply", &small, PlyEncoding::Ascii),
    ] {
        let path = dir.join(name);
        write_ply(scene, &path, encoding).unwrap();
        let (host, host_report) = load_ply(&path).unwrap();
        for precision in [ShPrecision::F32, ShPrecision::F16] {
            let mut last = (0, 0);
            let (streamed, report) =
                GpuScene::load_ply(&ctx, &path, precision, |done, total| last = (done, total))
                    .unwrap();
            let uploaded = GpuScene::with_sh_precision(&ctx, &host, precision).unwrap();
            assert_eq!(streamed.len() as usize, host.len(), "{name}");
            assert_eq!(streamed.sh_degree(), host.sh_degree);
            assert_eq!(report.dropped_non_finite, host_report.dropped_non_finite);
            assert_eq!(last, (host.len(), report.vertices_in_file), "{name}");
            let (g, sh) = streamed.download().unwrap();
            let (g_ref, sh_ref) = uploaded.download().unwrap();
            assert!(g == g_ref, "{name} {precision:?}: the Gaussians differ");
            assert!(sh == sh_ref, "{name} {precision:?}: the SH differ");
            eprintln!(
                "{name} {precision:?}: {} Gaussians ({} dropped), {} + {} bytes equal",
                streamed.len(),
                report.dropped_non_finite,
                g.len(),
                sh.len()
            );
        }
        if name == "binary.ply" {
            assert_eq!(host_report.dropped_non_finite, 5);
        }
    }
    std::fs::remove_dir_all(&dir).ok();
    common::assert_no_validation_messages(&ctx);
}
