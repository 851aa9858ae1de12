//! `rara render`: one frame of a scene (or of several objects, or of a mixed scene file) to a
//! PNG, rasterized, ray traced or by the CPU reference, with its counts and timings.

use std::path::{Path, PathBuf};

use clap::Args;
use glam::Vec3;
use indicatif::{ProgressBar, ProgressStyle};
use rara::{Context, Error, RenderOptions, Renderer, Result};

use super::args::{
    parse_color, resolve_camera, resolve_scene_file_camera, CameraArgs, CameraChoice, TracerArg,
};
use super::clip_args::{describe, ClipArgs};
use super::load::{load_scene, stream_scene, warn_oversized};
use super::output::{Output, Outputs};
use super::{median, print_pass_medians};

#[derive(Args)]
pub struct RenderArgs {
    /// The scene (PLY, compressed PLY, SPZ, glTF, SOG or .splat, told apart by content); or give --scene.
    #[arg(required_unless_present_any = ["scene_file", "objects"], conflicts_with = "scene_file")]
    scene: Option<PathBuf>,
    /// A splat object, repeatable: SCENE[:TX,TY,TZ[,RX,RY,RZ[,S]]] (translation, rotations in
    /// degrees about x then y then z, uniform scale). Every object (and SCENE, at the identity)
    /// is drawn in one frame with one sort (SPEC section 9).
    #[arg(long = "object", value_name = "SCENE[:TRANSFORM]", value_parser = super::objects::parse_object, conflicts_with = "scene_file")]
    objects: Vec<super::objects::ObjectArg>,
    /// A mixed scene (SPEC section 8, JSON: splat scenes, meshes, lights; docs/CLI.md), ray
    /// traced; its splat entries carry their clips.
    #[arg(long = "scene", value_name = "SCENE.json")]
    scene_file: Option<PathBuf>,
    #[command(flatten)]
    camera: CameraArgs,
    /// Background colour R,G,B in [0, 1] (default black, or a scene file's).
    #[arg(long, allow_hyphen_values = true, value_parser = parse_color)]
    background: Option<Vec3>,
    /// Output PNG.
    #[arg(short, long)]
    output: PathBuf,
    /// Store the SH coefficients on the GPU in half precision (half the memory of the
    /// largest scene buffer; docs/ARCHITECTURE.md gives the image error).
    #[arg(long)]
    sh_half: bool,
    /// Render with the CPU reference renderer instead of the GPU.
    #[arg(long)]
    reference: bool,
    /// Render this many more times after the first and report median timings.
    #[arg(long, default_value_t = 0)]
    repeat: usize,
    /// raster: the tile rasterizer; ray: the ray tracer (SPEC section 7, a BVH built per
    /// frame); ray-tiles: the ray tracer with camera rays from tile lists (section 11, the same
    /// image).
    #[arg(long, value_enum, default_value_t = TracerArg::Raster)]
    tracer: TracerArg,
    /// With --tracer ray (and scene files): build the ray tracer's BVH once on the host
    /// (obvhs; fewer nodes per ray) instead of an LBVH on the GPU per frame: pays for a scene
    /// rendered many times (--repeat). The same image.
    #[arg(long)]
    still_bvh: bool,
    /// Also write the splats' depth (SPEC section 9): OUT.exr (32-bit float view depth,
    /// infinity where there is none) or OUT.png (16-bit grey, the depths' range spread over
    /// 0..65534, 65535 where there is none; the range is printed). Ray traced, a hit's depth
    /// is that of its point on the pixel's ray.
    #[arg(long, value_name = "OUT.{exr,png}")]
    depth: Option<PathBuf>,
    /// Which depth --depth writes: median (where the accumulated alpha reaches 0.5) or mean
    /// (alpha-weighted).
    #[arg(long, value_enum, default_value_t = super::depth::DepthModeArg::Median)]
    depth_mode: super::depth::DepthModeArg,
    #[command(flatten)]
    clip: ClipArgs,
}

/// `render --object ...`: several objects in one frame.
fn render_objects(args: &RenderArgs, camera: &CameraChoice) -> Result<()> {
    if args.depth.is_some() || args.repeat > 0 || args.sh_half || args.still_bvh {
        return Err(Error::InvalidInput(
            "--object draws without --depth, --repeat, --sh-half or --still-bvh so far (the \
             objects' merged scene is made anew each frame)"
                .into(),
        ));
    }
    let options = RenderOptions {
        background: args.background.unwrap_or(Vec3::ZERO),
        clip: args.clip.build(&[])?,
        tracer: args.tracer.into(),
        ..RenderOptions::default()
    };
    let output = Output::prepare(&args.output, &["png"])?;
    let loaded = super::objects::load(args.scene.as_ref(), &args.objects)?;
    let camera = &camera.or_framing(|| {
        let list: Vec<_> = loaded.iter().map(|(s, t)| (s, *t)).collect();
        rara::objects::merge(&list).means
    })?;
    if options.clip.region.is_some() {
        eprintln!(
            "{} (in world space, over every object)",
            describe(&options.clip)
        );
    }
    let count: usize = loaded.iter().map(|(s, _)| s.len()).sum();
    if args.reference {
        let start = std::time::Instant::now();
        let list: Vec<_> = loaded.iter().map(|(s, t)| (s, *t)).collect();
        let merged = rara::objects::merge(&list);
        let img = if options.tracer.is_ray() {
            let rt = rara::RayTraceOptions::default();
            rara::reference::raytrace::render(&merged, camera, &options, &rt).0
        } else {
            rara::reference::render(&merged, camera, &options)
        };
        output.write_png(&img)?;
        println!(
            "wrote {} ({}x{}, CPU reference, {} objects, {count} Gaussians merged, {:.0} ms)",
            args.output.display(),
            camera.width,
            camera.height,
            loaded.len(),
            start.elapsed().as_secs_f64() * 1e3
        );
        return Ok(());
    }
    let ctx = Context::from_env()?;
    let mut renderer = Renderer::new(&ctx)?;
    let uploaded = super::objects::upload(&renderer, &loaded)?;
    let objects = super::objects::scene_objects(&uploaded, &loaded);
    let (img, stats) = renderer.render_objects(&objects, camera, &options)?;
    output.write_png(&img)?;
    let what = match &stats.trace {
        Some(t) => format!(
            "ray traced, per ray {:.1} hits composited, {:.0} {}",
            t.walked_per_ray(),
            t.visits_per_ray(),
            if t.tiled {
                "list entries tested"
            } else {
                "nodes visited"
            }
        ),
        None => format!(
            "{} visible ({} cutoff), {} tile intersections",
            stats.visible, stats.cutoff, stats.intersections
        ),
    };
    println!(
        "wrote {} ({}x{}) on {}: {} objects, {count} Gaussians in one frame, {what}",
        args.output.display(),
        camera.width,
        camera.height,
        ctx.info().name,
        objects.len(),
    );
    Ok(())
}

/// Renders the frame `args` describe and writes it (and its depth, when asked).
pub fn run(args: &RenderArgs) -> Result<()> {
    // Everything that can be checked before the (possibly long) load and render is.
    let camera = match &args.scene_file {
        Some(file) => resolve_scene_file_camera(&args.camera, file)?,
        None => resolve_camera(&args.camera)?,
    };
    if let Some(file) = &args.scene_file {
        if !args.clip.is_empty() {
            return Err(super::scene::no_clip_options("clip options"));
        }
        if args.depth.is_some() {
            return Err(Error::InvalidInput(
                "--depth writes the rasterizer's depth; a scene file is ray traced".into(),
            ));
        }
        let output = Output::prepare(&args.output, &["png"])?;
        return super::scene::render(
            file,
            &camera,
            args.background,
            output,
            &args.output,
            args.reference,
            args.sh_half,
            args.repeat,
            args.still_bvh,
        );
    }
    if !args.objects.is_empty() {
        return render_objects(args, &camera);
    }
    let scene_path = args.scene.as_ref().expect("clap requires a scene");
    let options = RenderOptions {
        background: args.background.unwrap_or(Vec3::ZERO),
        clip: args.clip.build(&[])?,
        tracer: args.tracer.into(),
        ..RenderOptions::default()
    };
    if args.still_bvh && (options.tracer != rara::Tracer::Ray || args.reference) {
        return Err(Error::InvalidInput(
            "--still-bvh builds the BVH the GPU ray tracer walks: give --tracer ray (ray-tiles \
             takes its camera rays from tile lists; the rasterizer and --reference walk no BVH)"
                .into(),
        ));
    }
    if args.reference && options.tracer.is_ray() {
        return Err(Error::InvalidInput(
            "--reference renders with the CPU rasterizer; the CPU ray tracer is the library's \
             rara::reference::raytrace::render"
                .into(),
        ));
    }
    let output = Output::prepare(&args.output, &["png"])?;
    let depth_output = args
        .depth
        .as_deref()
        .map(super::depth::prepare)
        .transpose()?;
    let depth_mode = rara::DepthMode::from(args.depth_mode);
    // A PLY file the GPU draws goes from the file to the device chunk by chunk: the host never
    // holds the scene (GpuScene::load_ply); one without a camera is framed on its centres
    // (SPEC 12), so it is loaded.
    let streamed = !args.reference
        && camera.given().is_some()
        && scene_path.is_file()
        && matches!(
            rara::formats::detect(scene_path),
            Ok(rara::formats::SceneFormat::Ply)
        );
    let scene = if streamed {
        None
    } else {
        Some(load_scene(scene_path)?)
    };
    let camera = camera.or_framing(|| {
        scene
            .as_ref()
            .map(|s| s.means.clone())
            .expect("a scene without a camera is not streamed")
    })?;
    if options.clip.region.is_some() {
        eprintln!("{}", describe(&options.clip));
    }
    if let (true, Some(scene)) = (args.reference, &scene) {
        let start = std::time::Instant::now();
        let splats = rara::reference::project::project_all(scene, &camera, &options.clip);
        let (img, median, mean) = rara::reference::rasterize::rasterize_depth(
            &splats,
            &camera,
            options.background,
            &options.clip,
            None,
        );
        warn_oversized(
            rara::reference::project::count_oversized(scene, &camera, &options.clip),
            scene.len(),
        );
        // The image and its depth land together or not at all.
        let mut set = Outputs::new();
        set.add_png(output, &img)?;
        let depth_line = match depth_output {
            Some(out) => {
                let depths = if depth_mode == rara::DepthMode::Median {
                    median
                } else {
                    mean
                };
                let size = (camera.width, camera.height);
                Some(super::depth::stage(
                    &mut set, out, &depths, size, depth_mode,
                )?)
            }
            None => None,
        };
        set.commit()?;
        println!(
            "wrote {} ({}x{}, CPU reference, {:.0} ms)",
            args.output.display(),
            camera.width,
            camera.height,
            start.elapsed().as_secs_f64() * 1e3
        );
        if let Some(line) = depth_line {
            println!("{line}");
        }
        return Ok(());
    }
    let ctx = Context::from_env()?;
    let mut renderer = Renderer::new(&ctx)?;
    let precision = super::sh_precision(args.sh_half);
    let mut gpu_scene = match scene {
        Some(scene) => {
            // Large scenes take seconds to upload and, on a CPU device, to render: say what is
            // going on.
            let spinner = ProgressBar::new_spinner().with_message(format!(
                "uploading {} Gaussians to {}",
                scene.len(),
                ctx.info().name
            ));
            spinner.enable_steady_tick(std::time::Duration::from_millis(120));
            let uploaded = rara::GpuScene::with_sh_precision(&ctx, &scene, precision);
            spinner.finish_and_clear();
            drop(scene); // the device copy is all the GPU path needs
            uploaded?
        }
        None => stream_scene(&ctx, scene_path, precision)?,
    };
    if args.still_bvh {
        let spinner = ProgressBar::new_spinner().with_message("building the still BVH");
        spinner.enable_steady_tick(std::time::Duration::from_millis(120));
        let built = renderer.build_still_bvh(&mut gpu_scene);
        spinner.finish_and_clear();
        eprintln!("{}", super::describe_still_bvh(&built?));
    }
    let spinner = ProgressBar::new_spinner()
        .with_message(format!("rendering {}x{}", camera.width, camera.height));
    spinner.enable_steady_tick(std::time::Duration::from_millis(120));
    let rendered = match depth_output {
        Some(_) => renderer
            .render_with_depth(&gpu_scene, &camera, &options, depth_mode)
            .map(|(img, depths, stats)| (img, Some(depths), stats)),
        None => renderer
            .render(&gpu_scene, &camera, &options)
            .map(|(img, stats)| (img, None, stats)),
    };
    spinner.finish_and_clear();
    let (img, depths, stats) = rendered?;
    // The image and its depth land together or not at all.
    let mut set = Outputs::new();
    set.add_png(output, &img)?;
    let depth_line = match (depth_output, depths) {
        (Some(out), Some(depths)) => {
            let size = (camera.width, camera.height);
            Some(super::depth::stage(
                &mut set, out, &depths, size, depth_mode,
            )?)
        }
        _ => None,
    };
    set.commit()?;
    if let Some(t) = &stats.trace {
        let (visited, built) = if t.tiled {
            ("list entries tested".to_string(), "tile lists built")
        } else {
            (
                format!("nodes visited ({:.0} Gaussians tested)", t.tests_per_ray()),
                "BVH build",
            )
        };
        println!(
            "wrote {} ({}x{}) on {}: ray traced, per ray {:.1} hits composited (p99 {}), {:.1} \
             found, {:.2} passes, {:.0} {visited}; {} capped at {}, {} rounds, {:.0} ms wall \
             ({built} included)",
            args.output.display(),
            camera.width,
            camera.height,
            ctx.info().name,
            t.walked_per_ray(),
            t.p99_walked,
            t.found_per_ray(),
            t.passes_per_ray(),
            t.visits_per_ray(),
            t.capped,
            rara::RayTraceOptions::default().max_hits,
            t.rounds,
            stats.wall_ms
        );
        if t.tiled {
            println!("{}", super::describe_tiled(&stats, t));
        }
    } else {
        print_raster_counts(&args.output, &camera, &ctx, &gpu_scene, &stats);
    }
    if let Some(line) = depth_line {
        println!("{line}");
    }
    println!(
        "{}",
        super::describe_memory(&gpu_scene, &renderer.headless_memory())
    );
    if let Some(line) = super::describe_peak_host_memory() {
        println!("{line}");
    }
    if args.repeat > 0 {
        let bar = ProgressBar::new(args.repeat as u64)
            .with_style(ProgressStyle::with_template("{msg} {bar:30} {pos}/{len}").unwrap())
            .with_message("timing");
        let (mut gpu, mut wall) = (Vec::new(), Vec::new());
        let mut passes: Vec<(&'static str, Vec<f64>)> = Vec::new();
        for _ in 0..args.repeat {
            let (_, s) = renderer.render(&gpu_scene, &camera, &options)?;
            gpu.push(s.gpu_ms);
            wall.push(s.wall_ms);
            for (k, pass) in s.passes.iter().enumerate() {
                if passes.len() <= k {
                    passes.push((pass.name, Vec::new()));
                }
                passes[k].1.push(pass.ms);
            }
            bar.inc(1);
        }
        bar.finish_and_clear();
        println!(
            "median over {} frames: GPU {:.2} ms, wall {:.2} ms (device {}, driver {})",
            args.repeat,
            median(&mut gpu),
            median(&mut wall),
            ctx.info().name,
            ctx.info().driver
        );
        print_pass_medians(passes);
    }
    Ok(())
}

/// What `render` prints of a rasterized frame: its counts, and warnings.
fn print_raster_counts(
    output: &Path,
    camera: &rara::Camera,
    ctx: &Context,
    gpu_scene: &rara::GpuScene,
    stats: &rara::FrameStats,
) {
    warn_oversized(stats.oversized as usize, gpu_scene.len() as usize);
    println!(
        "wrote {} ({}x{}) on {}: {} visible Gaussians ({} cutoff), {} tile intersections",
        output.display(),
        camera.width,
        camera.height,
        ctx.info().name,
        stats.visible,
        stats.cutoff,
        stats.intersections
    );
    if stats.cutoff_pairs > 0 {
        println!(
            "cutoff pairs by tile: {} in all, {} weight 1 (drawn plain), {} empty (left out), {} partial; {} of {} cutoff splats decided whole",
            stats.cutoff_pairs,
            stats.cutoff_pairs_weight_one,
            stats.cutoff_pairs_empty,
            stats.cutoff_pairs_partial(),
            stats.cutoff_whole,
            stats.cutoff
        );
    }
    if stats.weighted_tiles > 0 {
        let (gx, gy) = rara::camera::tile_grid(camera.width, camera.height);
        println!(
            "tiles by rasterize kernel: {} of {} weighted (hold a partial pair), the rest plain",
            stats.weighted_tiles,
            gx * gy
        );
    }
}
