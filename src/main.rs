//! The `rara` command-line tool: render, inspect and demo 3DGS scenes.

use std::path::{Path, PathBuf};
use std::process::ExitCode;

use clap::{Args, Parser, Subcommand};
use glam::Vec3;
use indicatif::{ProgressBar, ProgressStyle};

use rara::{Camera, Context, Error, RenderOptions, Renderer, Result, Scene};

mod cli;
use cli::clip_args::{describe, ClipArgs};
use cli::output::{Output, Outputs};

/// Renders 3D Gaussian Splatting scenes on Vulkan compute (lavapipe or a GPU).
#[derive(Parser)]
#[command(name = "rara", version, about)]
struct Cli {
    #[command(subcommand)]
    command: Command,
    /// The axes of SPZ files read or written: rub (the format's own, what Niantic's tools
    /// write; turned into rara's RDF) or as-stored (what splat-transform and SuperSplat write,
    /// already in the PLY's axes).
    #[arg(long, global = true, value_enum, default_value = "rub")]
    spz_axes: SpzAxesArg,
}

/// `--spz-axes`.
#[derive(Clone, Copy, clap::ValueEnum)]
enum SpzAxesArg {
    /// Right, up, back: SPZ's default.
    Rub,
    /// Taken as they are.
    AsStored,
}

/// The `--spz-axes` of this run.
static SPZ_AXES: std::sync::OnceLock<rara::formats::spz::SpzAxes> = std::sync::OnceLock::new();

/// The `--spz-axes` of this run (RUB unless told).
pub fn spz_axes() -> rara::formats::spz::SpzAxes {
    SPZ_AXES.get().copied().unwrap_or_default()
}

/// How this run's readers take what a format leaves open (`--spz-axes`).
fn read_options() -> rara::formats::ReadOptions {
    rara::formats::ReadOptions {
        spz_axes: spz_axes(),
    }
}

#[derive(Subcommand)]
enum Command {
    /// Render a scene from one camera to a PNG, optionally clipped.
    Render(RenderArgs),
    /// Move a clip plane across a scene: numbered PNGs, an animated GIF and the frame-to-frame
    /// change (popping) per clip mode.
    Sweep(cli::sweep::SweepArgs),
    /// Benchmark: the RaRa paper's Table 1 (original / hard / rara while a plane sweeps the
    /// scene) with per-pass GPU timings, or the radix sort alone (--sort N).
    Bench(cli::bench::BenchArgs),
    /// Convert a scene to PLY, SPZ (v4 or v3), glTF (.glb, KHR_gaussian_splatting) or .splat,
    /// warning about what the target format drops.
    Convert(cli::convert::ConvertArgs),
    /// Bake a clip into a scene (SPEC section 10): cut Gaussians replaced by their visible
    /// part, so any viewer shows the scene cut.
    Bake(cli::bake::BakeArgs),
    /// Print what a scene holds: count, SH degree, bounds, per-property ranges.
    Info {
        /// The scene (PLY, compressed PLY, SPZ, glTF, SOG or .splat, told apart by content).
        scene: PathBuf,
        /// Print JSON instead of text.
        #[arg(long)]
        json: bool,
    },
    /// Compare two images: L1 (mean absolute difference, 8-bit units), PSNR (dB), SSIM.
    Compare {
        /// First image.
        a: PathBuf,
        /// Second image.
        b: PathBuf,
        /// Write a heat map of the per-pixel difference here.
        #[arg(long)]
        diff: Option<PathBuf>,
        /// Print JSON instead of text.
        #[arg(long)]
        json: bool,
    },
    /// Generate a synthetic scene (PLY) and orbit cameras for it (SCENE.cameras.json).
    Synth {
        /// What to generate.
        #[arg(long, value_enum)]
        kind: SynthKindArg,
        /// Number of Gaussians.
        #[arg(long)]
        count: usize,
        /// SH degree 0-3.
        #[arg(long, default_value_t = 0, value_parser = clap::value_parser!(u32).range(0..=3))]
        sh_degree: u32,
        /// Random seed (the scene depends only on it and the other options).
        #[arg(long, default_value_t = 1)]
        seed: u64,
        /// Output PLY; the cameras go beside it as NAME.cameras.json.
        #[arg(short, long)]
        output: PathBuf,
    },
    /// Flatten a scene (SPEC section 6): each Gaussian's smallest scale set to 0. Prints the
    /// PSNR of the flat scene against the original over the scene's cameras.
    Flatten(cli::flatten::FlattenArgs),
    /// Octagon meshes of flat Gaussians (SPEC section 6): export for mesh tools, import edits.
    Mesh(cli::mesh::MeshArgs),
    /// Render a folder of scenes (e.g. imported simulation frames) to PNGs and a GIF.
    RenderSequence(cli::mesh::RenderSequenceArgs),
    /// The headline on a built-in scene: a box cutaway unclipped, hard and rara side by side
    /// (PNG), and a plane sweeping through it, hard and rara (GIF, with the popping metric).
    Demo {
        /// Output directory.
        #[arg(short, long, default_value = "rara-demo")]
        output: PathBuf,
    },
}

/// `rara synth --kind`.
#[derive(Clone, Copy, clap::ValueEnum)]
enum SynthKindArg {
    /// A sphere of isotropic Gaussians.
    Shell,
    /// Strands of needle-like Gaussians (length/width 30).
    Hair,
    /// Nested closed surfaces (skin, muscle, bone).
    Layers,
    /// A solid ellipsoid coloured in layers, for cuts through a volume.
    Solid,
}

/// Where the camera comes from and the image size.
#[derive(Args, Clone)]
pub struct CameraArgs {
    /// INRIA cameras.json file.
    #[arg(long, conflicts_with_all = ["eye", "target"])]
    cameras: Option<PathBuf>,
    /// Index of the camera in --cameras.
    #[arg(long, default_value_t = 0, requires = "cameras")]
    camera: usize,
    /// Camera centre X,Y,Z (with --target).
    #[arg(long, allow_hyphen_values = true, value_parser = parse_vec3, requires = "target")]
    eye: Option<Vec3>,
    /// Point looked at X,Y,Z (with --eye).
    #[arg(long, allow_hyphen_values = true, value_parser = parse_vec3, requires = "eye")]
    target: Option<Vec3>,
    /// Up direction X,Y,Z (default -Y, the INRIA/COLMAP convention).
    #[arg(long, allow_hyphen_values = true, value_parser = parse_vec3, default_value = "0,-1,0")]
    up: Vec3,
    /// Vertical field of view in degrees (with --eye).
    #[arg(long, default_value_t = 50.0)]
    fov_y: f32,
    /// Image width (default: the camera's, or 640 with --eye).
    #[arg(long)]
    width: Option<u32>,
    /// Image height (default: keeps the camera's aspect ratio, or 480 with --eye).
    #[arg(long)]
    height: Option<u32>,
}

#[derive(Args)]
struct RenderArgs {
    /// The scene (PLY, compressed PLY, SPZ, glTF, SOG or .splat, told apart by content); or give --scene.
    #[arg(required_unless_present_any = ["scene_file", "objects"], conflicts_with = "scene_file")]
    scene: Option<PathBuf>,
    /// A splat object, repeatable: SCENE[:TX,TY,TZ[,RX,RY,RZ[,S]]] (translation, rotations in
    /// degrees about x then y then z, uniform scale). Every object (and SCENE, at the identity)
    /// is drawn in one frame with one sort (SPEC section 9).
    #[arg(long = "object", value_name = "SCENE[:TRANSFORM]", value_parser = cli::objects::parse_object, conflicts_with = "scene_file")]
    objects: Vec<cli::objects::ObjectArg>,
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
    /// Also write the splats' depth (SPEC section 9): OUT.exr (32-bit float view depth,
    /// infinity where there is none) or OUT.png (16-bit grey, the depths' range spread over
    /// 0..65534, 65535 where there is none; the range is printed). Ray traced, a hit's depth
    /// is that of its point on the pixel's ray.
    #[arg(long, value_name = "OUT.{exr,png}")]
    depth: Option<PathBuf>,
    /// Which depth --depth writes: median (where the accumulated alpha reaches 0.5) or mean
    /// (alpha-weighted).
    #[arg(long, value_enum, default_value_t = cli::depth::DepthModeArg::Median)]
    depth_mode: cli::depth::DepthModeArg,
    #[command(flatten)]
    clip: ClipArgs,
}

/// `--tracer`.
#[derive(Clone, Copy, Debug, PartialEq, Eq, clap::ValueEnum)]
pub enum TracerArg {
    /// The tile rasterizer.
    Raster,
    /// The ray tracer.
    Ray,
    /// The ray tracer, camera rays from tile lists.
    RayTiles,
}

impl From<TracerArg> for rara::Tracer {
    fn from(t: TracerArg) -> rara::Tracer {
        match t {
            TracerArg::Raster => rara::Tracer::Raster,
            TracerArg::Ray => rara::Tracer::Ray,
            TracerArg::RayTiles => rara::Tracer::RayTiles,
        }
    }
}

pub fn parse_vec3(s: &str) -> std::result::Result<Vec3, String> {
    let parts: Vec<&str> = s.split(',').map(str::trim).collect();
    if parts.len() != 3 {
        return Err(format!(
            "expected X,Y,Z (three comma-separated numbers), got '{s}'"
        ));
    }
    let mut v = [0f32; 3];
    for (slot, p) in v.iter_mut().zip(&parts) {
        *slot = p.parse().map_err(|_| format!("'{p}' is not a number"))?;
        if !slot.is_finite() {
            return Err(format!("'{p}' is not finite"));
        }
    }
    Ok(Vec3::from_array(v))
}

/// R,G,B with every channel in [0, 1].
pub fn parse_color(s: &str) -> std::result::Result<Vec3, String> {
    let c = parse_vec3(s)?;
    if c.min_element() < 0.0 || c.max_element() > 1.0 {
        return Err(format!(
            "'{s}': each of R,G,B must lie in [0, 1] (0,0,0 is black, 1,1,1 white)"
        ));
    }
    Ok(c)
}

pub fn resolve_camera(args: &CameraArgs) -> Result<Camera> {
    if let Some(path) = &args.cameras {
        let cam = Camera::load_one(path, args.camera)?;
        return match args.width {
            Some(w) => cam.resized(w, args.height),
            None if args.height.is_some() => cam.resized(cam.width, args.height),
            None => Ok(cam),
        };
    }
    match (args.eye, args.target) {
        (Some(eye), Some(target)) => {
            let width = args.width.unwrap_or(640);
            let height = args
                .height
                .unwrap_or_else(|| (width as f32 * 0.75).round().max(1.0) as u32);
            Camera::look_at(eye, target, args.up, args.fov_y, width, height)
        }
        _ => Err(Error::InvalidInput(
            "give a camera: --cameras FILE [--camera N], or --eye X,Y,Z --target X,Y,Z".into(),
        )),
    }
}

pub fn load_scene(path: &Path) -> Result<Scene> {
    let spinner = ProgressBar::new_spinner().with_message(format!("loading {}", path.display()));
    spinner.enable_steady_tick(std::time::Duration::from_millis(120));
    let start = std::time::Instant::now();
    let loaded = rara::formats::load_scene_with(path, &read_options());
    spinner.finish_and_clear();
    let (scene, report) = loaded?;
    print_load_report(path, (scene.len(), scene.sh_degree), &report, "", start);
    Ok(scene)
}

/// The "loaded" line of a scene of (count, SH degree) read from `path` since `start` (`how`
/// says where it went, after the encoding), then the reader's notes and dropped Gaussians.
fn print_load_report(
    path: &Path,
    (count, degree): (usize, u32),
    report: &rara::ply::LoadReport,
    how: &str,
    start: std::time::Instant,
) {
    eprintln!(
        "loaded {}: {count} Gaussians, SH degree {degree}, {}{how} ({:.0} ms)",
        path.display(),
        report.encoding,
        start.elapsed().as_secs_f64() * 1e3
    );
    for note in &report.notes {
        eprintln!("note: {note}");
    }
    if report.dropped_non_finite > 0 {
        eprintln!(
            "warning: dropped {} of {} Gaussians with non-finite values",
            report.dropped_non_finite, report.vertices_in_file
        );
    }
}

/// Loads the PLY at `path` straight into device memory ([`rara::GpuScene::load_ply`]), with a
/// progress bar and the same report as [`load_scene`].
fn stream_scene(
    ctx: &Context,
    path: &Path,
    precision: rara::ShPrecision,
) -> Result<rara::GpuScene> {
    let bar = ProgressBar::new(0)
        .with_style(ProgressStyle::with_template("{msg} {bar:30} {pos}/{len} Gaussians").unwrap());
    bar.set_message(format!(
        "loading {} into {}",
        path.display(),
        ctx.info().name
    ));
    let start = std::time::Instant::now();
    let loaded = rara::GpuScene::load_ply(ctx, path, precision, |done, total| {
        bar.set_length(total as u64);
        bar.set_position(done as u64);
    });
    bar.finish_and_clear();
    let (scene, report) = loaded?;
    print_load_report(
        path,
        (scene.len() as usize, scene.sh_degree()),
        &report,
        ", streamed to the device",
        start,
    );
    Ok(scene)
}

/// Prints each pass's median milliseconds, a line per pass, the names padded to the longest
/// so that the times line up (`render --repeat`).
pub fn print_pass_medians(passes: Vec<(&str, Vec<f64>)>) {
    let width = passes.iter().map(|(name, _)| name.len()).max().unwrap_or(0);
    for (name, mut v) in passes {
        println!("  {name:<width$} {:8.2} ms", median(&mut v));
    }
}

pub fn median(values: &mut [f64]) -> f64 {
    values.sort_by(f64::total_cmp);
    let n = values.len();
    if n == 0 {
        return f64::NAN;
    }
    if n % 2 == 1 {
        values[n / 2]
    } else {
        0.5 * (values[n / 2 - 1] + values[n / 2])
    }
}

/// Prints the count of Gaussians the footprint bound skipped (`MAX_FOOTPRINT_SIGMA_PX`).
pub fn warn_oversized(oversized: usize, total: usize) {
    if oversized > 0 {
        eprintln!(
            "warning: {oversized} of {total} Gaussians not drawn: in this view their footprint \
             spans more than {} px per standard deviation (an extreme scale, or a huge Gaussian \
             right before the camera)",
            rara::constants::MAX_FOOTPRINT_SIGMA_PX
        );
    }
}

/// `render --object ...`: several objects in one frame.
fn render_objects(args: &RenderArgs, camera: &Camera) -> Result<()> {
    if args.tracer != TracerArg::Raster || args.depth.is_some() || args.repeat > 0 || args.sh_half {
        return Err(Error::InvalidInput(
            "--object draws with the rasterizer, without --depth, --repeat or --sh-half so far"
                .into(),
        ));
    }
    let options = RenderOptions {
        background: args.background.unwrap_or(Vec3::ZERO),
        clip: args.clip.build(&[])?,
        ..RenderOptions::default()
    };
    let output = Output::prepare(&args.output, &["png"])?;
    let loaded = cli::objects::load(args.scene.as_ref(), &args.objects)?;
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
        let img = rara::reference::render(&merged, camera, &options);
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
    let uploaded = cli::objects::upload(&renderer, &loaded)?;
    let objects = cli::objects::scene_objects(&uploaded, &loaded);
    let (img, stats) = renderer.render_objects(&objects, camera, &options)?;
    output.write_png(&img)?;
    println!(
        "wrote {} ({}x{}) on {}: {} objects, {count} Gaussians in one sort, {} visible ({} \
         cutoff), {} tile intersections",
        args.output.display(),
        camera.width,
        camera.height,
        ctx.info().name,
        objects.len(),
        stats.visible,
        stats.cutoff,
        stats.intersections
    );
    Ok(())
}

fn cmd_render(args: &RenderArgs) -> Result<()> {
    // Everything that can be checked before the (possibly long) load and render is.
    let camera = resolve_camera(&args.camera)?;
    if let Some(file) = &args.scene_file {
        if !args.clip.is_empty() {
            return Err(cli::scene::no_clip_options("clip options"));
        }
        if args.depth.is_some() {
            return Err(Error::InvalidInput(
                "--depth writes the rasterizer's depth; a scene file is ray traced".into(),
            ));
        }
        let output = Output::prepare(&args.output, &["png"])?;
        return cli::scene::render(
            file,
            &camera,
            args.background,
            output,
            &args.output,
            args.reference,
            args.sh_half,
            args.repeat,
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
    if args.reference && options.tracer.is_ray() {
        return Err(Error::InvalidInput(
            "--reference renders with the CPU rasterizer; the CPU ray tracer is the library's \
             rara::reference::raytrace::render"
                .into(),
        ));
    }
    let output = Output::prepare(&args.output, &["png"])?;
    let depth_output = args.depth.as_deref().map(cli::depth::prepare).transpose()?;
    let depth_mode = rara::DepthMode::from(args.depth_mode);
    // A PLY file the GPU draws goes from the file to the device chunk by chunk: the host never
    // holds the scene (GpuScene::load_ply).
    let streamed = !args.reference
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
                Some(cli::depth::stage(&mut set, out, &depths, size, depth_mode)?)
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
    let precision = cli::sh_precision(args.sh_half);
    let gpu_scene = match scene {
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
            Some(cli::depth::stage(&mut set, out, &depths, size, depth_mode)?)
        }
        _ => None,
    };
    set.commit()?;
    if let Some(t) = &stats.trace {
        let (visited, built) = if t.tiled {
            ("list entries tested", "tile lists built")
        } else {
            ("nodes visited", "BVH build")
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
            rara::reference::raytrace::RayTraceOptions::default().max_hits,
            t.rounds,
            stats.wall_ms
        );
        if t.tiled {
            println!("{}", cli::describe_tiled(&stats, t));
        }
    } else {
        print_raster_counts(&args.output, &camera, &ctx, &gpu_scene, &stats);
    }
    if let Some(line) = depth_line {
        println!("{line}");
    }
    println!(
        "{}",
        cli::describe_memory(&gpu_scene, &renderer.headless_memory())
    );
    if let Some(line) = cli::describe_peak_host_memory() {
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

fn cmd_info(path: &Path, json: bool) -> Result<()> {
    let (scene, report) = rara::formats::load_scene_with(path, &read_options())?;
    let n = scene.len();
    let range = |f: &dyn Fn(usize) -> f32| -> (f32, f32) {
        (0..n)
            .map(f)
            .fold((f32::INFINITY, f32::NEG_INFINITY), |(lo, hi), v| {
                (lo.min(v), hi.max(v))
            })
    };
    let mut props: Vec<(String, (f32, f32))> = Vec::new();
    for (axis, name) in ["x", "y", "z"].iter().enumerate() {
        props.push((name.to_string(), range(&|i| scene.means[i][axis])));
    }
    props.push(("opacity (activated)".into(), range(&|i| scene.opacities[i])));
    for axis in 0..3 {
        props.push((
            format!("scale_{axis} (activated)"),
            range(&|i| scene.scales[i][axis]),
        ));
    }
    props.push((
        "anisotropy (max/min scale)".into(),
        // Over the Gaussians that are not flat (NaN is passed over by the fold).
        range(&|i| {
            let s = scene.scales[i];
            if s.min_element() == 0.0 {
                f32::NAN
            } else {
                s.max_element() / s.min_element()
            }
        }),
    ));
    for c in 0..3 {
        props.push((format!("f_dc_{c}"), range(&|i| scene.sh_of(i)[c])));
    }
    let (lo, hi) = scene.bounds().unwrap_or((Vec3::ZERO, Vec3::ZERO));
    let flat = scene.flat_count();
    if json {
        let v = serde_json::json!({
            "file": path.display().to_string(),
            "count": n,
            "vertices_in_file": report.vertices_in_file,
            "dropped_non_finite": report.dropped_non_finite,
            "sh_degree": scene.sh_degree,
            "flat": flat,
            "encoding": report.encoding,
            "notes": report.notes,
            "bounds": {"min": lo.to_array(), "max": hi.to_array()},
            "properties": props.iter().map(|(k, (a, b))| (k.clone(), serde_json::json!({"min": a, "max": b}))).collect::<serde_json::Map<_, _>>(),
        });
        println!("{}", serde_json::to_string_pretty(&v).unwrap());
    } else {
        println!("file:        {}", path.display());
        println!(
            "Gaussians:   {n} ({} in file, {} dropped as non-finite)",
            report.vertices_in_file, report.dropped_non_finite
        );
        println!("SH degree:   {}", scene.sh_degree);
        println!("flat:        {flat} (one scale 0; SPEC section 6)");
        println!("encoding:    {}", report.encoding);
        for note in &report.notes {
            println!("note:        {note}");
        }
        println!(
            "bounds:      min {:?} max {:?}",
            lo.to_array(),
            hi.to_array()
        );
        for (k, (a, b)) in props {
            println!("  {k:<28} {a:>12.5} .. {b:<12.5}");
        }
    }
    Ok(())
}

fn load_png(path: &Path) -> Result<image::RgbaImage> {
    Ok(image::open(path)
        .map_err(|source| Error::Image {
            path: path.to_path_buf(),
            source,
        })?
        .to_rgba8())
}

fn cmd_compare(a: &Path, b: &Path, diff: Option<&Path>, json: bool) -> Result<()> {
    let diff = diff.map(|p| Output::prepare(p, &["png"])).transpose()?;
    let (ia, ib) = (load_png(a)?, load_png(b)?);
    if ia.dimensions() != ib.dimensions() {
        return Err(Error::InvalidInput(format!(
            "{} is {}x{} but {} is {}x{}",
            a.display(),
            ia.width(),
            ia.height(),
            b.display(),
            ib.width(),
            ib.height()
        )));
    }
    let d = rara::metrics::compare(&ia, &ib);
    let ssim = rara::metrics::ssim(&ia, &ib);
    if let Some(out) = diff {
        out.write_png(&rara::metrics::diff_image(&ia, &ib))?;
    }
    // JSON has no infinity: identical images report a PSNR of null.
    let psnr = d.psnr.is_finite().then_some(d.psnr);
    if json {
        let v = serde_json::json!({"l1": d.l1, "psnr": psnr, "ssim": ssim, "max_diff": d.max_diff, "differing_pixels": d.differing_pixels});
        println!("{v}");
    } else {
        println!(
            "L1 {:.4}  PSNR {}  SSIM {:.6}  max diff {}  differing pixels {}",
            d.l1,
            psnr.map_or("inf".into(), |p| format!("{p:.2} dB")),
            ssim,
            d.max_diff,
            d.differing_pixels
        );
    }
    Ok(())
}

fn cmd_synth(
    kind: SynthKindArg,
    count: usize,
    sh_degree: u32,
    seed: u64,
    output: &Path,
) -> Result<()> {
    use rara::synth::SynthKind;
    if count == 0 {
        return Err(Error::InvalidInput("--count must be at least 1".into()));
    }
    let kind = match kind {
        SynthKindArg::Shell => SynthKind::Shell,
        SynthKindArg::Hair => SynthKind::Hair,
        SynthKindArg::Layers => SynthKind::Layers,
        SynthKindArg::Solid => SynthKind::Solid,
    };
    let scene = rara::synth::generate(kind, count, sh_degree, seed);
    let (lo, hi) = scene.bounds().unwrap_or((Vec3::ZERO, Vec3::ZERO));
    let radius = lo.abs().max(hi.abs()).length().max(1e-3);
    let cameras = rara::synth::orbit_cameras(8, 2.4 * radius, 640, 480, 50.0)?;
    let cams_path = output.with_extension("cameras.json");
    // The scene and its cameras land together (in a folder made for them, when missing).
    let mut set = Outputs::new();
    if let Some(dir) = output.parent().filter(|d| !d.as_os_str().is_empty()) {
        set.create_dir(dir)?;
    }
    set.add_with(Output::prepare_any(output)?, |w| {
        rara::ply::write_ply_to(
            &scene,
            w,
            rara::ply::PlyEncoding::BinaryLittleEndian,
            rara::ply::PlyLayout::Inria,
            output,
        )
    })?;
    set.add(
        Output::prepare_any(&cams_path)?,
        Camera::to_json_text(&cameras).as_bytes(),
    )?;
    set.commit()?;
    println!(
        "wrote {} ({} Gaussians, SH degree {sh_degree}) and {} (8 orbit views)",
        output.display(),
        scene.len(),
        cams_path.display()
    );
    Ok(())
}

fn main() -> ExitCode {
    // Rust ignores SIGPIPE, so a closed stdout (`rara info x.ply | head`) would make every
    // println! panic; a command-line tool should end quietly instead, as cat and grep do.
    #[cfg(unix)]
    // SAFETY: signal() with SIG_DFL installs no handler; it runs before any other thread.
    unsafe {
        libc::signal(libc::SIGPIPE, libc::SIG_DFL);
    }
    let cli = Cli::parse();
    let _ = SPZ_AXES.set(match cli.spz_axes {
        SpzAxesArg::Rub => rara::formats::spz::SpzAxes::Rub,
        SpzAxesArg::AsStored => rara::formats::spz::SpzAxes::AsStored,
    });
    let result = match &cli.command {
        Command::Render(args) => cmd_render(args),
        Command::Sweep(args) => cli::sweep::run(args),
        Command::Bench(args) => cli::bench::run(args),
        Command::Convert(args) => cli::convert::run(args),
        Command::Bake(args) => cli::bake::run(args),
        Command::Info { scene, json } => cmd_info(scene, *json),
        Command::Compare { a, b, diff, json } => cmd_compare(a, b, diff.as_deref(), *json),
        Command::Synth {
            kind,
            count,
            sh_degree,
            seed,
            output,
        } => cmd_synth(*kind, *count, *sh_degree, *seed, output),
        Command::Demo { output } => cli::demo::run(output),
        Command::Flatten(args) => cli::flatten::run(args),
        Command::Mesh(args) => cli::mesh::run(args),
        Command::RenderSequence(args) => cli::mesh::run_render_sequence(args),
    };
    match result {
        Ok(()) => ExitCode::SUCCESS,
        Err(e) => {
            eprintln!("error: {e}");
            ExitCode::FAILURE
        }
    }
}
