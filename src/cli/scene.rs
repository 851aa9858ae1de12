//! `--scene SCENE.json` (SPEC section 8): mixed scenes of splats, meshes and lights, ray traced,
//! for `render`, `bench` and `sweep`.

use std::path::Path;

use indicatif::ProgressBar;

use rara::mixed::MixedScene;
use rara::raytrace::mixed::{GpuMixedScene, MixedFrameStats, MixedTracer};
use rara::RayTraceOptions;
use rara::{Camera, Context, Error, Result};

use super::args::CameraChoice;
use super::load::load_scene;
use super::{median, print_pass_medians};

/// Loads a scene file, each splat scene through the CLI's loader (its progress and warnings),
/// and says what it holds. `background` overrides the file's.
pub fn load_mixed(path: &Path, background: Option<glam::Vec3>) -> Result<MixedScene> {
    let mut scene = MixedScene::load(path, load_scene)?;
    if let Some(bg) = background {
        scene.background = bg;
    }
    eprintln!("{}", describe(&scene, path));
    Ok(scene)
}

/// What a mixed scene without a camera is framed on (SPEC 12): its Gaussians' centres, or,
/// without Gaussians, its triangles' vertices.
pub fn framing_points(scene: &MixedScene) -> Vec<glam::Vec3> {
    if scene.gaussians.is_empty() {
        scene.meshes.triangles.iter().flat_map(|t| t.v).collect()
    } else {
        scene.gaussians.means.clone()
    }
}

/// One line on a mixed scene.
pub fn describe(scene: &MixedScene, path: &Path) -> String {
    let clipped = scene
        .objects
        .iter()
        .filter(|o| o.clip.region.is_some())
        .count();
    format!(
        "scene {}: {} splat objects ({} Gaussians, {clipped} clipped), {} triangles of {} \
         materials ({} textures; their BVHs built in {:.0} ms by {}, depth {}), {} lights, ray depth {}",
        path.display(),
        scene.objects.len(),
        scene.gaussians.len(),
        scene.meshes.triangles.len(),
        scene.materials.len(),
        scene.textures.len(),
        scene.meshes.build_ms + scene.occluders.build_ms,
        if scene.meshes.median_split {
            "median split (obvhs's tree was deeper than the traversal's stack)".to_string()
        } else if scene.meshes.median_triangles > 0 {
            format!(
                "obvhs ({} triangles of its subtrees too deep for the traversal's stack split \
                 again by the median)",
                scene.meshes.median_triangles
            )
        } else {
            "obvhs".to_string()
        },
        scene.meshes.depth,
        scene.lights.len(),
        scene.max_depth
    )
}

/// Rays per pixel of a frame, as a phrase.
pub fn rays_per_pixel(stats: &MixedFrameStats, pixels: u64) -> String {
    let per = |n: u64| n as f64 / pixels.max(1) as f64;
    format!(
        "per pixel {:.2} primary, {:.3} secondary, {:.3} shadow rays ({} generations, {} \
         branches cut)",
        per(stats.primary),
        per(stats.secondary),
        per(stats.shadow),
        stats.generations,
        stats.cut
    )
}

/// The device side of a scene file: the kernels and the uploaded scene.
pub struct MixedGpu {
    /// The kernels.
    pub tracer: MixedTracer,
    /// The uploaded scene.
    pub scene: GpuMixedScene,
}

impl MixedGpu {
    /// Builds the kernels and uploads `scene`.
    /// With `still_bvh`, the Gaussians' BVH is built once on the host (`--still-bvh`).
    pub fn new(ctx: &Context, scene: &MixedScene, sh_half: bool, still_bvh: bool) -> Result<Self> {
        let spinner = ProgressBar::new_spinner().with_message(format!(
            "uploading {} Gaussians and {} triangles to {}",
            scene.gaussians.len(),
            scene.meshes.triangles.len(),
            ctx.info().name
        ));
        spinner.enable_steady_tick(std::time::Duration::from_millis(120));
        let made = MixedTracer::new(ctx).and_then(|tracer| {
            let s = GpuMixedScene::new(ctx, scene, super::sh_precision(sh_half))?;
            Ok(MixedGpu { tracer, scene: s })
        });
        spinner.finish_and_clear();
        let mut made = made?;
        if !scene.meshes.triangles.is_empty() {
            let bytes = made.scene.mesh_bytes();
            let texels: usize = scene.textures.iter().map(|t| t.texels.len()).sum();
            eprintln!(
                "meshes on the device: {} ({:.0} B a triangle: 48 B to intersect, 64 B to \
                 shade, 32 B a node, and 48 B and 32 B again for an opaque one, which the shadow \
                 rays' BVH holds too); {} materials, {} textures of {} texels",
                super::mb(bytes),
                bytes as f64 / scene.meshes.triangles.len() as f64,
                scene.materials.len(),
                scene.textures.len(),
                texels,
            );
        }
        if still_bvh && !scene.gaussians.is_empty() {
            let built = made.tracer.build_still_bvh(&mut made.scene)?;
            eprintln!("{}", super::describe_still_bvh(&built));
        }
        Ok(made)
    }

    /// Splat objects of the scene.
    pub fn objects(&self) -> usize {
        self.scene.objects()
    }

    /// `n` frames: each one's wall milliseconds, each pass's GPU milliseconds per frame (in
    /// the order the passes first ran), and the last frame's counts.
    #[allow(clippy::type_complexity)]
    pub fn time_frames(
        &self,
        camera: &Camera,
        n: u32,
    ) -> Result<(Vec<f64>, Vec<(&'static str, Vec<f64>)>, MixedFrameStats)> {
        let (mut walls, mut passes) = (Vec::new(), Vec::<(&'static str, Vec<f64>)>::new());
        let mut last = MixedFrameStats::default();
        for _ in 0..n {
            let (_, s, w) = self.render(camera)?;
            walls.push(w);
            for &(name, ms) in &s.passes {
                match passes.iter_mut().find(|(n, _)| *n == name) {
                    Some(p) => p.1.push(ms),
                    None => passes.push((name, vec![ms])),
                }
            }
            last = s;
        }
        Ok((walls, passes, last))
    }

    /// One frame and its wall milliseconds.
    pub fn render(&self, camera: &Camera) -> Result<(image::RgbaImage, MixedFrameStats, f64)> {
        let start = std::time::Instant::now();
        let (img, stats) = self
            .tracer
            .render(&self.scene, camera, &RayTraceOptions::default())?;
        Ok((img, stats, start.elapsed().as_secs_f64() * 1e3))
    }
}

/// `render --scene`: the GPU (or, with `reference`, the CPU reference) image, its counts, and
/// with `repeat` the medians of that many more frames.
#[allow(clippy::too_many_arguments)]
pub fn render(
    path: &Path,
    camera: &CameraChoice,
    background: Option<glam::Vec3>,
    output: super::output::Output,
    out_path: &Path,
    reference: bool,
    sh_half: bool,
    repeat: usize,
    still_bvh: bool,
) -> Result<()> {
    let scene = load_mixed(path, background)?;
    let camera = &camera.or_framing(|| framing_points(&scene))?;
    let pixels = camera.width as u64 * camera.height as u64;
    if reference {
        let start = std::time::Instant::now();
        let (img, s) = rara::reference::mixed::render(&scene, camera, &RayTraceOptions::default());
        output.write_png(&img)?;
        let per = |n: u64| n as f64 / pixels as f64;
        println!(
            "wrote {} ({}x{}, CPU reference of section 8): per pixel {:.2} primary, {:.3} \
             secondary, {:.3} shadow rays, {:.0} ms",
            out_path.display(),
            camera.width,
            camera.height,
            per(s.primary),
            per(s.secondary),
            per(s.shadow),
            start.elapsed().as_secs_f64() * 1e3
        );
        return Ok(());
    }
    let ctx = Context::from_env()?;
    let gpu = MixedGpu::new(&ctx, &scene, sh_half, still_bvh)?;
    drop(scene);
    let spinner = ProgressBar::new_spinner()
        .with_message(format!("ray tracing {}x{}", camera.width, camera.height));
    spinner.enable_steady_tick(std::time::Duration::from_millis(120));
    let rendered = gpu.render(camera);
    spinner.finish_and_clear();
    let (img, stats, wall) = rendered?;
    output.write_png(&img)?;
    println!(
        "wrote {} ({}x{}) on {}: {}; {:.0} ms wall",
        out_path.display(),
        camera.width,
        camera.height,
        ctx.info().name,
        rays_per_pixel(&stats, pixels),
        wall
    );
    if repeat > 0 {
        let (mut walls, passes, _) = gpu.time_frames(camera, repeat as u32)?;
        println!(
            "median over {repeat} frames: wall {:.1} ms (device {}, driver {})",
            median(&mut walls),
            ctx.info().name,
            ctx.info().driver
        );
        print_pass_medians(passes);
    }
    Ok(())
}

/// `bench --scene`: `frames` frames after `warmup`, the median frame time, the rays per pixel
/// and the median GPU time of each pass (summed over a frame's generations).
pub fn bench(
    path: &Path,
    camera: &CameraChoice,
    frames: u32,
    warmup: u32,
    sh_half: bool,
    json: Option<super::output::Output>,
    still_bvh: bool,
) -> Result<()> {
    let scene = load_mixed(path, None)?;
    let camera = &camera.or_framing(|| framing_points(&scene))?;
    let ctx = Context::from_env()?;
    let gpu = MixedGpu::new(&ctx, &scene, sh_half, still_bvh)?;
    let pixels = camera.width as u64 * camera.height as u64;
    for _ in 0..warmup {
        gpu.render(camera)?;
    }
    let (mut walls, mut passes, last) = gpu.time_frames(camera, frames)?;
    let frame_ms = median(&mut walls);
    println!(
        "{} at {}x{} on {} (driver {}), {frames} frames after {warmup} warm-up",
        path.display(),
        camera.width,
        camera.height,
        ctx.info().name,
        ctx.info().driver
    );
    println!(
        "median frame {frame_ms:.1} ms wall; {}",
        rays_per_pixel(&last, pixels)
    );
    let mut pass_medians = Vec::new();
    for (name, v) in &mut passes {
        let m = median(v);
        println!("  {name:<12} {m:9.2} ms (median GPU, summed over the generations)");
        pass_medians.push(serde_json::json!({ "pass": name, "median_ms": m }));
    }
    if let Some(out) = json {
        let per = |n: u64| n as f64 / pixels as f64;
        let value = serde_json::json!({
            "scene": path.display().to_string(),
            "width": camera.width,
            "height": camera.height,
            "device": ctx.info().name,
            "driver": ctx.info().driver,
            "frames": frames,
            "median_frame_ms": frame_ms,
            "rays_per_pixel": {
                "primary": per(last.primary),
                "secondary": per(last.secondary),
                "shadow": per(last.shadow),
            },
            "generations": last.generations,
            "passes": pass_medians,
        });
        out.write_json(&value)?;
    }
    Ok(())
}

/// The error for a clip option given with `--scene` (the scene file's splat entries hold
/// their clips).
pub fn no_clip_options(what: &str) -> Error {
    Error::InvalidInput(format!(
        "{what} with --scene: a scene file's splat entries carry their own clips (\"clip\")"
    ))
}
