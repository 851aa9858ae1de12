//! `rara bench`: the RaRa paper's Table 1 protocol (a fixed camera, a plane sweeping across
//! the scene, original / hard / rara), and the radix sort alone against the CPU's sort.

use std::path::{Path, PathBuf};

use clap::Args;
use indicatif::{ProgressBar, ProgressStyle};

use rara::clip::{Clip, ClipMode, Plane};
use rara::stages::sort::{PairForm, RadixSort, Segmentation, SortForms, TILE_SORT_LABELS};
use rara::timing::{PassTimer, PassTiming};
use rara::vk::Buffer;
use rara::{Context, Error, FrameStats, RenderOptions, Renderer, Result};

use super::args::{resolve_camera, resolve_scene_file_camera, CameraArgs};
use super::clip_args::ClipArgs;
use super::load::load_scene;
use super::median;
use super::output::Output;
use super::sweep::{default_range, with_moving_plane};

/// `rara bench` options.
#[derive(Args)]
pub struct BenchArgs {
    /// The scene (PLY, compressed PLY, SPZ, glTF, SOG or .splat, told apart by content); not needed with --sort or --scene.
    #[arg(required_unless_present_any = ["sort", "scene_file"], conflicts_with = "scene_file")]
    scene: Option<PathBuf>,
    /// A mixed scene (SPEC section 8, JSON), ray traced: frame time, rays per pixel, time per
    /// pass.
    #[arg(long = "scene", value_name = "SCENE.json")]
    scene_file: Option<PathBuf>,
    #[command(flatten)]
    camera: CameraArgs,
    /// Frames per mode (after the warm-up frames).
    #[arg(long, default_value_t = 30, value_parser = clap::value_parser!(u32).range(1..=100000))]
    frames: u32,
    /// Unmeasured frames per mode before the measured ones.
    #[arg(long, default_value_t = 2)]
    warmup: u32,
    /// Renders of each plane position per mode, the modes taking turns in every round; the
    /// frame keeps the render whose GPU time is the median (the lower one of an even count),
    /// so that the per-frame ratios move less with a shared machine's noise.
    #[arg(long, default_value_t = 1, value_parser = clap::value_parser!(u32).range(1..=99))]
    samples: u32,
    /// Normal of the sweeping plane (default: the camera's view direction).
    #[arg(long, allow_hyphen_values = true, value_parser = super::args::parse_vec3)]
    plane_normal: Option<glam::Vec3>,
    /// Modes to run, comma-separated.
    #[arg(long, value_delimiter = ',', default_value = "original,hard,rara")]
    modes: Vec<BenchMode>,
    /// Store the SH coefficients on the GPU in half precision.
    #[arg(long)]
    pub sh_half: bool,
    /// Write the results as JSON here.
    #[arg(long)]
    json: Option<PathBuf>,
    /// Write a Chrome trace-event file (opens in Perfetto) with one event per pass per frame.
    #[arg(long)]
    trace: Option<PathBuf>,
    /// Benchmark the radix sort alone on this many random (key, value) pairs instead.
    #[arg(long)]
    sort: Option<u64>,
    /// Weight, band and fixed clip planes for the rara (and hard) modes.
    #[command(flatten)]
    clip: ClipArgs,
    /// raster: the tile rasterizer; ray: the ray tracer (SPEC section 7), each mode then also
    /// drawn by the rasterizer, taking turns, for the ratio of their frame times in one run;
    /// ray-tiles: also with the tracer's camera rays from tile lists (section 11).
    #[arg(long, value_enum, default_value_t = super::args::TracerArg::Raster)]
    tracer: super::args::TracerArg,
    /// With the ray tracer (and scene files): build its BVH once on the host (obvhs, for a
    /// scene that does not move) instead of an LBVH on the GPU every frame; the same images.
    #[arg(long)]
    still_bvh: bool,
}

/// A benchmark mode of the paper's Table 1.
#[derive(Clone, Copy, Debug, PartialEq, Eq, clap::ValueEnum)]
pub enum BenchMode {
    /// No clipping.
    Original,
    /// Hard clipping by the sweeping plane.
    Hard,
    /// RaRa clipping by the sweeping plane.
    Rara,
    /// No clipping, depth-tested against an engine surface (SPEC section 9) behind every
    /// Gaussian (a flat depth buffer at twice the farthest centre's view depth, standard
    /// projection, near 0.01, far 1000): every splat is tested and none hidden, so the row
    /// shows what the test costs.
    Depth,
    /// No clipping, two views (the camera and a second eye 6.4 cm to its right), their frame
    /// times added: what `Renderer::record_views` costs for a stereo pair.
    Views2,
}

impl BenchMode {
    fn name(self) -> &'static str {
        match self {
            BenchMode::Original => "original",
            BenchMode::Hard => "hard",
            BenchMode::Rara => "rara",
            BenchMode::Depth => "depth",
            BenchMode::Views2 => "2 views",
        }
    }
}

/// What one mode measured.
struct ModeResult {
    mode: BenchMode,
    tracer: rara::Tracer,
    frames: Vec<FrameStats>,
}

impl ModeResult {
    /// The row's name: the mode, "ray " before it for the ray tracer.
    fn name(&self) -> String {
        match self.tracer {
            rara::Tracer::Raster => self.mode.name().to_string(),
            rara::Tracer::Ray => format!("ray {}", self.mode.name()),
            rara::Tracer::RayTiles => format!("ray-tiles {}", self.mode.name()),
        }
    }

    fn gpu(&self) -> Vec<f64> {
        self.frames.iter().map(|f| f.gpu_ms).collect()
    }

    fn wall(&self) -> Vec<f64> {
        self.frames.iter().map(|f| f.wall_ms).collect()
    }

    /// Median over the frames of each group's milliseconds, groups in pass order; `group`
    /// maps a pass name to its group, and a frame's passes of one group are summed.
    fn medians_by(&self, group: impl Fn(&'static str) -> &'static str) -> Vec<(String, f64)> {
        let runs: Vec<&[PassTiming]> = self.frames.iter().map(|f| &f.passes[..]).collect();
        medians_by(&runs, group)
    }

    /// Median per pass, in pass order.
    fn pass_medians(&self) -> Vec<(String, f64)> {
        self.medians_by(|name| name)
    }

    /// Medians of the groups shown in the table: the passes of each sort are summed into "sort"
    /// and "depth sort".
    fn group_medians(&self) -> Vec<(String, f64)> {
        self.medians_by(|name| {
            if name.starts_with("sort") {
                "sort"
            } else if name.starts_with("depth sort") {
                "depth sort"
            } else {
                name
            }
        })
    }
}

/// Median over `runs` (each run's passes) of each group's milliseconds, groups in pass order;
/// `group` maps a pass name to its group, and a run's passes of one group are summed.
fn medians_by(
    runs: &[&[PassTiming]],
    group: impl Fn(&'static str) -> &'static str,
) -> Vec<(String, f64)> {
    let mut names: Vec<&'static str> = Vec::new();
    for p in runs.iter().flat_map(|r| r.iter()) {
        if !names.contains(&group(p.name)) {
            names.push(group(p.name));
        }
    }
    let per_group = |name: &str| -> f64 {
        let mut v: Vec<f64> = runs
            .iter()
            .map(|r| {
                r.iter()
                    .filter(|p| group(p.name) == name)
                    .map(|p| p.ms)
                    .sum()
            })
            .collect();
        median(&mut v)
    };
    names
        .iter()
        .map(|n| (n.to_string(), per_group(n)))
        .collect()
}

fn mean(v: &[f64]) -> f64 {
    v.iter().sum::<f64>() / v.len().max(1) as f64
}

/// Runs the benchmark.
pub fn run(args: &BenchArgs) -> Result<()> {
    if let Some(n) = args.sort {
        return bench_sort(n);
    }
    let camera = match &args.scene_file {
        Some(file) => resolve_scene_file_camera(&args.camera, file)?,
        None => resolve_camera(&args.camera)?,
    };
    if let Some(file) = &args.scene_file {
        if !args.clip.is_empty() {
            return Err(super::scene::no_clip_options("clip options"));
        }
        let json = args
            .json
            .as_deref()
            .map(|p| Output::prepare(p, &["json"]))
            .transpose()?;
        return super::scene::bench(
            file,
            &camera,
            args.frames,
            args.warmup,
            args.sh_half,
            json,
            args.still_bvh,
        );
    }
    let path = args.scene.as_ref().expect("clap requires the scene");
    // The outputs are checked before the run, which can take minutes.
    let json_out = args
        .json
        .as_deref()
        .map(|p| Output::prepare(p, &["json"]))
        .transpose()?;
    let trace_out = args
        .trace
        .as_deref()
        .map(|p| Output::prepare(p, &["json"]))
        .transpose()?;
    let scene = load_scene(path)?;
    if scene.is_empty() {
        return Err(Error::InvalidInput(format!(
            "{}: no Gaussians",
            path.display()
        )));
    }
    let camera = camera.or_framing(|| scene.means.clone())?;
    let normal = Plane::new(
        args.plane_normal.unwrap_or(camera.rotation * glam::Vec3::Z),
        0.0,
    )?
    .normal;
    let (d0, d1) = default_range(&scene, normal);
    let base = args.clip.build(&[Plane::new(normal, d0)?])?;

    let ctx = Context::from_env()?;
    let mut renderer = Renderer::new(&ctx)?;
    let mut gpu_scene =
        rara::GpuScene::with_sh_precision(&ctx, &scene, super::sh_precision(args.sh_half))?;
    if args.still_bvh && args.tracer == super::args::TracerArg::Raster {
        return Err(Error::InvalidInput(
            "bench --still-bvh builds the ray tracer's BVH: give --tracer ray or ray-tiles".into(),
        ));
    }
    if args.still_bvh {
        let built = renderer.build_still_bvh(&mut gpu_scene)?;
        eprintln!("bench: {}", super::describe_still_bvh(&built));
    }
    eprintln!(
        "bench: {} ({} Gaussians, SH {}) at {}x{}, {} frames per mode after {} warm-up, {} render(s) per frame, plane normal ({:.3}, {:.3}, {:.3}) d {d0:.4} -> {d1:.4}",
        path.display(),
        scene.len(),
        scene.sh_degree,
        camera.width,
        camera.height,
        args.frames,
        args.warmup,
        args.samples,
        normal.x,
        normal.y,
        normal.z
    );
    // The engine surface of the depth mode, and the second eye of the two-view mode.
    let projection = rara::DepthProjection {
        near: 0.01,
        far: 1000.0,
        reversed: false,
        infinite: false,
    };
    let surface = {
        let z: Vec<f32> = scene
            .means
            .iter()
            .map(|m| (camera.rotation.transpose() * (*m - camera.position)).z)
            .filter(|z| *z > 0.2)
            .collect();
        let behind = 2.0 * z.iter().copied().fold(1.0, f32::max);
        let pixels = (camera.width * camera.height) as usize;
        let values = vec![projection.depth_value(behind); pixels];
        let buffer = rara::vk::Buffer::new(
            &ctx,
            "bench engine depth",
            pixels as u64 * 4,
            rara::vk::MemoryLocation::GpuOnly,
        )?;
        buffer.upload(bytemuck::cast_slice(&values))?;
        buffer
    };
    let depth_test = rara::DepthTest {
        source: rara::DepthSource::Buffer {
            buffer: surface.raw,
            offset: 0,
        },
        projection,
    };
    let second_eye = rara::Camera {
        position: camera.position + 0.064 * (camera.rotation * glam::Vec3::X),
        ..camera
    };
    let tracers: &[rara::Tracer] = match args.tracer {
        super::args::TracerArg::Raster => &[rara::Tracer::Raster],
        super::args::TracerArg::Ray => &[rara::Tracer::Raster, rara::Tracer::Ray],
        // Both sources of camera rays beside the rasterizer, for ratios in one run.
        super::args::TracerArg::RayTiles => &[
            rara::Tracer::Raster,
            rara::Tracer::Ray,
            rara::Tracer::RayTiles,
        ],
    };
    let total = (args.frames + args.warmup) as u64
        * args.samples as u64
        * (args.modes.len() * tracers.len()) as u64;
    let bar = ProgressBar::new(total)
        .with_style(
            ProgressStyle::with_template("{msg} {bar:30} {pos}/{len} [{elapsed} < {eta}]").unwrap(),
        )
        .with_message("bench");
    // The modes take turns frame by frame (every mode renders plane position k before any
    // renders k + 1): on a shared or throttling machine, speed drifts over a run, and taking
    // turns lets the drift hit every mode alike instead of whichever ran last.
    let mut results: Vec<ModeResult> = tracers
        .iter()
        .flat_map(|&tracer| {
            args.modes.iter().map(move |&mode| ModeResult {
                mode,
                tracer,
                frames: Vec::new(),
            })
        })
        .collect();
    for k in 0..args.warmup + args.frames {
        // Warm-up frames use the first plane position; measured frames sweep.
        let step = k.saturating_sub(args.warmup);
        let t = if args.frames > 1 {
            step as f32 / (args.frames - 1) as f32
        } else {
            0.0
        };
        let moving = Plane::new(normal, d0 + (d1 - d0) * t)?;
        // Each round renders this position once in every mode; a frame keeps its mode's
        // median render.
        let mut renders: Vec<Vec<FrameStats>> = vec![Vec::new(); results.len()];
        for _ in 0..args.samples {
            for (result, mine) in results.iter().zip(&mut renders) {
                bar.set_message(result.name());
                mine.push(render_bench_frame(
                    &mut renderer,
                    &gpu_scene,
                    (&camera, &second_eye),
                    result,
                    clip_for(result.mode, &base, moving),
                    depth_test,
                )?);
                bar.inc(1);
            }
        }
        if k >= args.warmup {
            for (result, mut mine) in results.iter_mut().zip(renders) {
                mine.sort_by(|a, b| a.gpu_ms.total_cmp(&b.gpu_ms));
                result.frames.push(mine.swap_remove((mine.len() - 1) / 2));
            }
        }
    }
    bar.finish_and_clear();

    print_table(&ctx, path, &camera, args, &results);
    let memory = renderer.headless_memory();
    println!("{}", super::describe_memory(&gpu_scene, &memory));
    // The report and the trace land together.
    let mut set = super::output::Outputs::new();
    let mut wrote = Vec::new();
    if let Some(out) = json_out {
        let mut report = json_report(&ctx, path, &camera, &results);
        report["samples"] = args.samples.into();
        report["memory"] = super::memory_json(&gpu_scene, &memory);
        wrote.push(format!("wrote {}", out.path().display()));
        set.add_json(out, &report)?;
    }
    if let Some(out) = trace_out {
        wrote.push(format!(
            "wrote {} (open in https://ui.perfetto.dev)",
            out.path().display()
        ));
        set.add_json(out, &trace(&results))?;
    }
    set.commit()?;
    for line in wrote {
        println!("{line}");
    }
    Ok(())
}

/// One render of `result`'s mode (its clip `clip`) from `cameras.0`; the two-view mode adds
/// the frame of `cameras.1`, its passes and times to the first's.
fn render_bench_frame(
    renderer: &mut Renderer,
    gpu_scene: &rara::GpuScene,
    cameras: (&rara::Camera, &rara::Camera),
    result: &ModeResult,
    clip: Clip,
    depth_test: rara::DepthTest,
) -> Result<FrameStats> {
    if result.mode == BenchMode::Depth && result.tracer.is_ray() {
        return Err(Error::InvalidInput(
            "bench: the depth mode is the rasterizer's (--tracer raster)".into(),
        ));
    }
    let options = RenderOptions {
        clip,
        tracer: result.tracer,
        depth_test: (result.mode == BenchMode::Depth).then_some(depth_test),
        ..RenderOptions::default()
    };
    let (_, mut stats) = renderer.render(gpu_scene, cameras.0, &options)?;
    if result.mode == BenchMode::Views2 {
        // The second view's frame, the same work for another camera.
        let (_, other) = renderer.render(gpu_scene, cameras.1, &options)?;
        stats.gpu_ms += other.gpu_ms;
        stats.wall_ms += other.wall_ms;
        for (mine, theirs) in stats.passes.iter_mut().zip(&other.passes) {
            mine.ms += theirs.ms;
        }
    }
    Ok(stats)
}

/// The clip of `mode` with the sweeping plane at `moving`.
fn clip_for(mode: BenchMode, base: &Clip, moving: Plane) -> Clip {
    let mut clip = with_moving_plane(base, moving);
    clip.mode = match mode {
        BenchMode::Original | BenchMode::Depth | BenchMode::Views2 => ClipMode::None,
        BenchMode::Hard => ClipMode::Hard,
        BenchMode::Rara => ClipMode::Rara,
    };
    clip
}

fn print_table(
    ctx: &Context,
    path: &Path,
    camera: &rara::Camera,
    args: &BenchArgs,
    results: &[ModeResult],
) {
    println!(
        "{} at {}x{}, {} frames per mode{}, on {} ({}), {} kernels",
        path.display(),
        camera.width,
        camera.height,
        args.frames,
        if args.samples > 1 {
            format!(" (each the median of {} renders)", args.samples)
        } else {
            String::new()
        },
        ctx.info().name,
        ctx.info().driver,
        ctx.info().kernel_form()
    );
    // Every mode's pass groups in pass order: rara frames have a pass the others lack.
    let mut groups: Vec<String> = Vec::new();
    for r in results {
        let mine: Vec<String> = r.group_medians().into_iter().map(|g| g.0).collect();
        for (i, name) in mine.iter().enumerate() {
            if !groups.contains(name) {
                let after = i
                    .checked_sub(1)
                    .and_then(|j| groups.iter().position(|g| g == &mine[j]));
                groups.insert(after.map_or(0, |p| p + 1), name.clone());
            }
        }
    }
    // The mode column as wide as its longest name ("ray original" with --tracer ray).
    let name_width = results
        .iter()
        .map(|r| r.name().len())
        .max()
        .unwrap_or(0)
        .max(8);
    print!(
        "| {:<name_width$} | {:>10} | {:>10} | {:>10} | {:>6} | {:>9} |",
        "mode", "median ms", "mean ms", "wall ms", "FPS", "cutoff"
    );
    for g in &groups {
        print!(" {g:>11} |");
    }
    println!();
    print!("|{}|", ["---"; 6].join("|"));
    for _ in &groups {
        print!("---|");
    }
    println!();
    let raster = |mode| {
        results
            .iter()
            .find(|r| r.mode == mode && r.tracer == rara::Tracer::Raster)
    };
    let original = raster(BenchMode::Original).map(|r| median(&mut r.gpu()));
    let hard = raster(BenchMode::Hard).map(|r| median(&mut r.gpu()));
    // Frames of a few ms (a GPU's) in hundredths, whose passes take tenths or less.
    let slowest = results
        .iter()
        .map(|r| median(&mut r.gpu()))
        .fold(0.0, f64::max);
    let digits = if slowest < 20.0 { 2 } else { 1 };
    for r in results {
        let med = median(&mut r.gpu());
        let wall = median(&mut r.wall());
        let cutoff = mean(&r.frames.iter().map(|f| f.cutoff as f64).collect::<Vec<_>>());
        print!(
            "| {:<name_width$} | {:>10.digits$} | {:>10.digits$} | {:>10.digits$} | {:>6.2} | {:>9.0} |",
            r.name(),
            med,
            mean(&r.gpu()),
            wall,
            1000.0 / wall,
            cutoff
        );
        let medians = r.group_medians();
        for g in &groups {
            match medians.iter().find(|m| &m.0 == g) {
                Some(m) => print!(" {:>11.digits$} |", m.1),
                None => print!(" {:>11} |", "-"),
            }
        }
        println!();
    }
    if let (Some(o), Some(h)) = (original, hard) {
        println!("hard / original (median GPU): {:.3}", h / o);
    }
    if let (Some(h), Some(r)) = (hard, raster(BenchMode::Rara)) {
        println!("rara / hard (median GPU): {:.3}", median(&mut r.gpu()) / h);
    }
    if let Some(paired) = paired_ratio(results, BenchMode::Rara, BenchMode::Hard) {
        println!("rara / hard, median of the per-frame ratios (same plane position): {paired:.3}");
        // rara draws more pairs than hard clipping by definition (cutoff Gaussians whose
        // centres are clipped); the time per pair is what its cutoff path costs.
        if let Some(pairs) = pair_ratio(results, BenchMode::Rara, BenchMode::Hard) {
            println!(
                "rara / hard pairs over the sweep: {pairs:.3}; per pair (the ratio above / \
                 pairs): {:.3}",
                paired / pairs
            );
        }
        // The line above divides a median over the frames by a ratio of sums, which the
        // frames with the most pairs dominate; this one takes each frame's time ratio over
        // its own pair ratio.
        if let Some(per_pair) = paired_per_pair_ratio(results, BenchMode::Rara, BenchMode::Hard) {
            println!(
                "rara / hard per pair, frame by frame (the median of each frame's time ratio \
                 over its pair ratio): {per_pair:.3}"
            );
        }
    }
    for (mode, what) in [
        (BenchMode::Depth, "depth-tested / original"),
        (BenchMode::Views2, "2 views / original"),
    ] {
        if let Some(paired) = paired_ratio(results, mode, BenchMode::Original) {
            println!("{what}, median of the per-frame ratios: {paired:.3}");
        }
    }
    print_trace_table(results);
    if let Some(r) = raster(BenchMode::Rara) {
        let sum = |f: fn(&FrameStats) -> u32| r.frames.iter().map(|x| f(x) as f64).sum::<f64>();
        let all = sum(|f| f.cutoff_pairs);
        if all > 0.0 {
            let (one, empty, partial) = (
                sum(|f| f.cutoff_pairs_weight_one),
                sum(|f| f.cutoff_pairs_empty),
                sum(FrameStats::cutoff_pairs_partial),
            );
            println!(
                "rara cutoff pairs by tile: {:.0} per frame, {:.0} % weight 1 (drawn plain), {:.0} % empty (left out), {:.0} % partial",
                all / r.frames.len() as f64,
                100.0 * one / all,
                100.0 * empty / all,
                100.0 * partial / all
            );
            let (whole, cutoff) = (sum(|f| f.cutoff_whole), sum(|f| f.cutoff));
            println!(
                "rara cutoff splats decided whole (every pair weight 1 or empty, past the cutoff-tiles pass): {:.0} % of {:.0} per frame",
                100.0 * whole / cutoff.max(1.0),
                cutoff / r.frames.len() as f64
            );
        }
        let weighted = sum(|f| f.weighted_tiles);
        if weighted > 0.0 {
            let (gx, gy) = rara::camera::tile_grid(camera.width, camera.height);
            println!(
                "rara tiles by rasterize kernel: {:.0} of {} per frame weighted (hold a partial pair), the rest plain",
                weighted / r.frames.len() as f64,
                gx * gy
            );
        }
    }
}

/// The ray tracer's medians over a mode's frames (`bench --tracer ray`).
struct TraceSummary {
    /// What comes before the rays: the BVH build, or the tile lists' passes.
    bvh_ms: f64,
    /// The k-buffer (with tile lists, the pending buffer K).
    k: f64,
    /// The tile lists' pairs (0 through the BVH).
    pairs: f64,
    trace_ms: f64,
    rays_per_s: f64,
    walked: f64,
    p99_walked: f64,
    found: f64,
    passes: f64,
    p99_passes: f64,
    visits: f64,
    tests: f64,
    rounds: f64,
}

impl ModeResult {
    /// The ray tracer's medians, for a ray-traced mode.
    fn trace_summary(&self) -> Option<TraceSummary> {
        if !self.tracer.is_ray() {
            return None;
        }
        // The median over the frames of the time of the passes `keep` names.
        let passes = |keep: &dyn Fn(&str) -> bool| {
            let mut v: Vec<f64> = self
                .frames
                .iter()
                .map(|f| f.passes.iter().filter(|p| keep(p.name)).map(|p| p.ms).sum())
                .collect();
            median(&mut v)
        };
        let pass = |name: &str| passes(&|n| n == name);
        let per = |f: &dyn Fn(&rara::raytrace::tracer::TraceFrameStats) -> f64| {
            let mut v: Vec<f64> = self
                .frames
                .iter()
                .filter_map(|x| x.trace.as_ref())
                .map(f)
                .collect();
            median(&mut v)
        };
        let trace_ms = pass("trace");
        let frames = self.frames.len().max(1) as f64;
        Some(TraceSummary {
            // The BVH build, or the tile lists' passes: everything before the rays.
            bvh_ms: passes(&|n| n != "trace" && n != "write target"),
            k: per(&|t| t.k as f64),
            pairs: self
                .frames
                .iter()
                .map(|f| f.intersections as f64)
                .sum::<f64>()
                / frames,
            trace_ms,
            rays_per_s: per(&|t| t.rays as f64) / (trace_ms / 1e3),
            walked: per(&|t| t.walked_per_ray()),
            p99_walked: per(&|t| t.p99_walked as f64),
            found: per(&|t| t.found_per_ray()),
            passes: per(&|t| t.passes_per_ray()),
            p99_passes: per(&|t| t.p99_passes as f64),
            visits: per(&|t| t.visits_per_ray()),
            tests: per(&|t| t.tests_per_ray()),
            rounds: per(&|t| t.rounds as f64),
        })
    }
}

/// The ray tracer's table: per ray-traced mode, its BVH build and traversal times, rays per
/// second, hits and passes per ray, and its frame time over the rasterizer's in this run.
fn print_trace_table(results: &[ModeResult]) {
    let rows: Vec<(&ModeResult, TraceSummary)> = results
        .iter()
        .filter_map(|r| r.trace_summary().map(|t| (r, t)))
        .collect();
    if rows.is_empty() {
        return;
    }
    println!(
        "| {:<16} | {:>9} | {:>9} | {:>9} | {:>8} | {:>8} | {:>8} | {:>8} | {:>8} | {:>9} | {:>8} | {:>4} | {:>6} | {:>10} |",
        "ray tracer", "build ms", "trace ms", "Mrays/s", "hits/ray", "hits p99", "found", "passes", "pass p99", "steps/ray", "tests", "K", "rounds", "ray/raster"
    );
    println!("|{}|", ["---"; 14].join("|"));
    for (r, t) in rows {
        let ratio = paired_tracer_ratio(results, r.mode, r.tracer);
        println!(
            "| {:<16} | {:>9.1} | {:>9.1} | {:>9.3} | {:>8.1} | {:>8.0} | {:>8.1} | {:>8.2} | {:>8.0} | {:>9.0} | {:>8.0} | {:>4.0} | {:>6.0} | {:>10} |",
            r.name(),
            t.bvh_ms,
            t.trace_ms,
            t.rays_per_s / 1e6,
            t.walked,
            t.p99_walked,
            t.found,
            t.passes,
            t.p99_passes,
            t.visits,
            t.tests,
            t.k,
            t.rounds,
            ratio.map_or("-".to_string(), |x| format!("{x:.2}"))
        );
    }
}

/// Median over the frames of the ray tracer's GPU time over the rasterizer's, same mode and
/// plane position.
fn paired_tracer_ratio(
    results: &[ModeResult],
    mode: BenchMode,
    tracer: rara::Tracer,
) -> Option<f64> {
    let find = |tracer| {
        results
            .iter()
            .find(|r| r.mode == mode && r.tracer == tracer)
    };
    let (ray, raster) = (find(tracer)?, find(rara::Tracer::Raster)?);
    let mut ratios: Vec<f64> = ray
        .frames
        .iter()
        .zip(&raster.frames)
        .map(|(a, b)| a.gpu_ms / b.gpu_ms)
        .collect();
    (!ratios.is_empty()).then(|| median(&mut ratios))
}

/// The sweep's tile pairs in mode `num` over those in mode `den`.
fn pair_ratio(results: &[ModeResult], num: BenchMode, den: BenchMode) -> Option<f64> {
    let pairs = |mode| {
        results
            .iter()
            .find(|r| r.mode == mode && r.tracer == rara::Tracer::Raster)
            .map(|r| r.frames.iter().map(|f| f.intersections as f64).sum::<f64>())
    };
    let (n, d) = (pairs(num)?, pairs(den)?);
    (d > 0.0).then(|| n / d)
}

/// Median over the frames of `ratio` of `num`'s frame and `den`'s at the same plane position
/// (frames where it is `None` left out).
fn paired_median(
    results: &[ModeResult],
    (num, den): (BenchMode, BenchMode),
    ratio: impl Fn(&FrameStats, &FrameStats) -> Option<f64>,
) -> Option<f64> {
    let find = |mode| {
        results
            .iter()
            .find(|r| r.mode == mode && r.tracer == rara::Tracer::Raster)
    };
    let (n, d) = (find(num)?, find(den)?);
    let mut ratios: Vec<f64> = n
        .frames
        .iter()
        .zip(&d.frames)
        .filter_map(|(a, b)| ratio(a, b))
        .collect();
    (!ratios.is_empty()).then(|| median(&mut ratios))
}

/// Median over the frames of `num`'s GPU time over `den`'s at the same plane position: less
/// sensitive than a ratio of medians to noise that comes and goes during a run.
fn paired_ratio(results: &[ModeResult], num: BenchMode, den: BenchMode) -> Option<f64> {
    paired_median(results, (num, den), |a, b| Some(a.gpu_ms / b.gpu_ms))
}

/// Median over the frames of `num`'s GPU time per tile pair over `den`'s at the same plane
/// position (frames where either mode drew no pair left out).
fn paired_per_pair_ratio(results: &[ModeResult], num: BenchMode, den: BenchMode) -> Option<f64> {
    paired_median(results, (num, den), |a, b| {
        (a.intersections > 0 && b.intersections > 0)
            .then(|| (a.gpu_ms / b.gpu_ms) / (a.intersections as f64 / b.intersections as f64))
    })
}

fn json_report(
    ctx: &Context,
    path: &Path,
    camera: &rara::Camera,
    results: &[ModeResult],
) -> serde_json::Value {
    let mut modes = serde_json::Map::new();
    for r in results {
        let passes: serde_json::Map<String, serde_json::Value> = r
            .pass_medians()
            .into_iter()
            .map(|(k, v)| (k, v.into()))
            .collect();
        let trace = r.trace_summary().map(|t| {
            serde_json::json!({
                "bvh_build_ms": t.bvh_ms,
                "trace_ms": t.trace_ms,
                "rays_per_s": t.rays_per_s,
                "hits_per_ray": t.walked,
                "hits_per_ray_p99": t.p99_walked,
                "hits_found_per_ray": t.found,
                "passes_per_ray": t.passes,
                "passes_per_ray_p99": t.p99_passes,
                "node_visits_per_ray": t.visits,
                "gaussians_tested_per_ray": t.tests,
                "camera_rays": if r.tracer == rara::Tracer::RayTiles { "tiles" } else { "bvh" },
                "k": t.k,
                "tile_pairs": t.pairs,
                "rounds": t.rounds,
                "over_raster": paired_tracer_ratio(results, r.mode, r.tracer),
            })
        });
        modes.insert(
            r.name(),
            serde_json::json!({
                "median_ms": median(&mut r.gpu()),
                "mean_ms": mean(&r.gpu()),
                "wall_median_ms": median(&mut r.wall()),
                "wall_mean_ms": mean(&r.wall()),
                "fps": 1000.0 / median(&mut r.wall()),
                "passes": passes,
                "frame_ms": r.gpu(),
                "cutoff_per_frame": r.frames.iter().map(|f| f.cutoff).collect::<Vec<_>>(),
                "intersections_per_frame": r.frames.iter().map(|f| f.intersections).collect::<Vec<_>>(),
                "cutoff_pairs_per_frame": r.frames.iter()
                    .map(|f| [f.cutoff_pairs, f.cutoff_pairs_weight_one, f.cutoff_pairs_empty])
                    .collect::<Vec<_>>(),
                "cutoff_whole_per_frame": r.frames.iter().map(|f| f.cutoff_whole).collect::<Vec<_>>(),
                "weighted_tiles_per_frame": r.frames.iter().map(|f| f.weighted_tiles).collect::<Vec<_>>(),
                "trace": trace,
            }),
        );
    }
    serde_json::json!({
        "device": ctx.info().name,
        "driver": ctx.info().driver,
        "kernels": ctx.info().kernel_form(),
        // The layout `Renderer::new` takes on this device; it decides some passes (strips:
        // "cutoff records", no "write target").
        "raster_layout": match rara::stages::rasterize::RasterLayout::for_device(ctx) {
            rara::stages::rasterize::RasterLayout::Strips => "strips",
            rara::stages::rasterize::RasterLayout::PixelPerInvocation => "pixels",
        },
        "scene": path.display().to_string(),
        "width": camera.width,
        "height": camera.height,
        "modes": modes,
        "rara_over_hard_per_frame_median": paired_ratio(results, BenchMode::Rara, BenchMode::Hard),
        "rara_over_hard_pairs": pair_ratio(results, BenchMode::Rara, BenchMode::Hard),
        "rara_over_hard_per_pair_frame_median":
            paired_per_pair_ratio(results, BenchMode::Rara, BenchMode::Hard),
    })
}

/// Chrome trace events: per mode a track, per frame its passes back to back (GPU durations),
/// frames in the order they were rendered (the modes taking turns) at their wall-clock spacing.
fn trace(results: &[ModeResult]) -> serde_json::Value {
    let mut events = Vec::new();
    for (tid, r) in results.iter().enumerate() {
        events.push(serde_json::json!({
            "name": "thread_name", "ph": "M", "pid": 1, "tid": tid,
            "args": {"name": r.name()}
        }));
    }
    let mut ts_us = 0.0;
    let frames = results.iter().map(|r| r.frames.len()).max().unwrap_or(0);
    for k in 0..frames {
        for (tid, r) in results.iter().enumerate() {
            let Some(f) = r.frames.get(k) else { continue };
            let mut t = ts_us;
            for p in &f.passes {
                events.push(serde_json::json!({
                    "name": p.name, "cat": r.name(), "ph": "X", "pid": 1, "tid": tid,
                    "ts": t, "dur": p.ms * 1e3,
                    "args": {"frame": k, "invocations": p.invocations, "cutoff": f.cutoff}
                }));
                t += p.ms * 1e3;
            }
            ts_us += f.wall_ms.max(f.gpu_ms) * 1e3;
        }
    }
    serde_json::json!({"traceEvents": events, "displayTimeUnit": "ms"})
}

/// The radix sort alone on `n` random pairs (full 32-bit keys, as the frame's depth sort uses),
/// GPU timestamps against `slice::sort_unstable_by_key` on the same data, medians of 5 runs
/// each. Where the layout sorts packed pairs (CPU drivers), the GPU sorts them packed, one
/// 64-bit word per pair, as the CPU's slice of `(u32, u32)` holds them; elsewhere as separate
/// keys and values.
fn bench_sort(n: u64) -> Result<()> {
    const RUNS: usize = 5;
    const KEY_BITS: u32 = 32;
    let ctx = Context::from_env()?;
    let sort = RadixSort::new(&ctx)?;
    let mut rng = rara::synth::Rng::new(1);
    let keys: Vec<u32> = (0..n).map(|_| rng.next_u64() as u32).collect();
    let values: Vec<u32> = (0..n as u32).collect();
    let packed: Vec<u64> = keys
        .iter()
        .zip(&values)
        .map(|(&k, &v)| k as u64 | (v as u64) << 32)
        .collect();
    let bufs = sort.buffers(&ctx, n)?;
    let count = Buffer::from_slice(&ctx, "sort count", &[n as u32])?;
    let mut timer = PassTimer::new(&ctx)?;
    let mut gpu_ms = Vec::new();
    // Each run's passes (the warm-up's first).
    let mut runs: Vec<Vec<PassTiming>> = Vec::new();
    let mut gpu_result = Vec::new();
    for _ in 0..RUNS + 1 {
        if sort.sorts_packed() {
            bufs.keys[0].upload(bytemuck::cast_slice(&packed))?;
        } else {
            bufs.keys[0].upload(bytemuck::cast_slice(&keys))?;
            bufs.values[0].upload(bytemuck::cast_slice(&values))?;
        }
        let out = ctx.run_commands(|cmd| {
            timer.begin_frame(cmd);
            let form = if sort.sorts_packed() {
                PairForm::Packed
            } else {
                PairForm::Split
            };
            sort.record_forms(
                &ctx,
                cmd,
                &bufs,
                count.address,
                KEY_BITS,
                SortForms::same(form),
                &TILE_SORT_LABELS,
                Some(&mut timer),
            )
        })?;
        let passes = timer.read()?;
        gpu_ms.push(passes.iter().map(|p| p.ms).sum::<f64>());
        runs.push(passes);
        gpu_result = if sort.sorts_packed() {
            let pairs = bufs.keys[out].download_as::<u64>(n as usize)?;
            pairs.into_iter().map(|p| p as u32).collect()
        } else {
            bufs.keys[out].download_as::<u32>(n as usize)?
        };
    }
    gpu_ms.remove(0); // warm-up
    let mut cpu_ms = Vec::new();
    let mut cpu_result = Vec::new();
    for _ in 0..RUNS {
        let mut pairs: Vec<(u32, u32)> = keys.iter().copied().zip(values.iter().copied()).collect();
        let start = std::time::Instant::now();
        pairs.sort_unstable_by_key(|p| p.0);
        cpu_ms.push(start.elapsed().as_secs_f64() * 1e3);
        cpu_result = pairs.into_iter().map(|p| p.0).collect();
    }
    if gpu_result != cpu_result {
        return Err(Error::InvalidInput(
            "the GPU sort disagrees with the CPU sort".into(),
        ));
    }
    let (g, c) = (median(&mut gpu_ms), median(&mut cpu_ms));
    let rate = |ms: f64| n as f64 / (ms * 1e-3) / 1e6;
    println!(
        "sort of {n} random (u32 key, u32 value) pairs on {} ({}, {} kernels), {:?} layout, {}, \
         medians of {RUNS} runs:",
        ctx.info().name,
        ctx.info().driver,
        ctx.info().kernel_form(),
        sort.layout(),
        if sort.sorts_packed() {
            "packed pairs"
        } else {
            "separate keys and values"
        }
    );
    println!(
        "  GPU radix sort (timestamps): {g:9.2} ms  {:8.1} Mkeys/s",
        rate(g)
    );
    println!(
        "  CPU sort_unstable_by_key:    {c:9.2} ms  {:8.1} Mkeys/s",
        rate(c)
    );
    println!("  GPU / CPU throughput: {:.2}x", c / g);
    let measured: Vec<&[PassTiming]> = runs[1..].iter().map(|r| &r[..]).collect();
    let passes: Vec<String> = medians_by(&measured, |name| name)
        .iter()
        .map(|(name, ms)| format!("{name} {ms:.2}"))
        .collect();
    println!("  GPU passes (median ms): {}", passes.join(", "));
    let how = match bufs.segmentation()? {
        Segmentation::None => "not segmented: every pass sorts all the keys by one digit",
        Segmentation::LocalBuckets => {
            "segmented: pass 0 sorts by the top digit, pass 1 then sorts each of its buckets \
             by the other digits, one invocation per bucket"
        }
        Segmentation::BucketRuns => {
            "segmented: pass 0 sorts by the top digit, the others all the keys in runs \
             within its buckets (a bucket too large for one invocation)"
        }
    };
    println!("  {how}");
    Ok(())
}
