//! `rara sweep`: a clip plane moving across a scene, as numbered PNGs and an animated GIF,
//! with the frame-to-frame change that shows popping (hard) or its absence (rara).

use std::io::Write;
use std::path::{Path, PathBuf};

use clap::Args;
use glam::Vec3;
use indicatif::{ProgressBar, ProgressStyle};

use rara::clip::{Clip, ClipMode, Plane};
use rara::{Context, Error, RenderOptions, Renderer, Result, Scene};

use super::args::{resolve_camera, resolve_scene_file_camera, CameraArgs};
use super::clip_args::{describe, ClipArgs};
use super::load::load_scene;
use super::output::{Output, Outputs};

/// `rara sweep` options.
#[derive(Args)]
pub struct SweepArgs {
    /// The scene (PLY, compressed PLY, SPZ, glTF, SOG or .splat, told apart by content); or give --scene.
    #[arg(required_unless_present_any = ["scene_file", "objects"], conflicts_with = "scene_file")]
    scene: Option<PathBuf>,
    /// A splat object, repeatable: SCENE[:TX,TY,TZ[,RX,RY,RZ[,S]]] (translation, rotations in
    /// degrees about x then y then z, uniform scale), all drawn in one frame with one sort
    /// (SPEC section 9); the moving plane clips them in world space.
    #[arg(long = "object", value_name = "SCENE[:TRANSFORM]", value_parser = super::objects::parse_object, conflicts_with = "scene_file")]
    objects: Vec<super::objects::ObjectArg>,
    /// A mixed scene (SPEC section 8, JSON), ray traced: the moving plane clips every splat
    /// object, in the world's frame, in place of the file's clips.
    #[arg(long = "scene", value_name = "SCENE.json")]
    scene_file: Option<PathBuf>,
    #[command(flatten)]
    camera: CameraArgs,
    /// A camera path: its keyframes are the cameras of a cameras.json (or a COLMAP folder), in
    /// order, flown through over the frames (positions by Catmull-Rom, rotations by slerp).
    #[arg(long, value_name = "CAMERAS", conflicts_with_all = ["cameras", "eye"])]
    camera_path: Option<PathBuf>,
    /// Normal NX,NY,NZ of the moving plane; visible where n.x + d >= 0.
    #[arg(long, allow_hyphen_values = true, value_parser = super::args::parse_vec3)]
    plane_normal: Vec3,
    /// Plane offset d of the first frame (default: the whole scene visible).
    #[arg(long, allow_hyphen_values = true)]
    from: Option<f32>,
    /// Plane offset d of the last frame (default: nearly nothing visible).
    #[arg(long, allow_hyphen_values = true)]
    to: Option<f32>,
    /// Number of frames.
    #[arg(long, default_value_t = 30, value_parser = clap::value_parser!(u32).range(2..=10000))]
    frames: u32,
    /// Put hard clipping (left) and rara (right) side by side in every frame.
    #[arg(long)]
    side_by_side: bool,
    /// Background colour R,G,B in [0, 1].
    #[arg(long, allow_hyphen_values = true, value_parser = super::args::parse_color, default_value = "0,0,0")]
    background: Vec3,
    /// GIF frame delay in milliseconds.
    #[arg(long, default_value_t = 100)]
    delay_ms: u32,
    #[command(flatten)]
    clip: ClipArgs,
    /// Output directory: frame_NNNN.png, sweep.gif, sweep.json.
    #[arg(short, long)]
    output: PathBuf,
    /// raster: the tile rasterizer; ray: the ray tracer (SPEC section 7); ray-tiles: its camera
    /// rays from tile lists (section 11, the same image).
    #[arg(long, value_enum, default_value_t = super::args::TracerArg::Raster)]
    tracer: super::args::TracerArg,
}

/// Frame-to-frame change and cutoff counts of one clip configuration over a sweep.
#[derive(Default)]
pub struct SeriesStats {
    /// The configuration, as `describe` puts it.
    pub label: String,
    /// Histogram of |a - b| over every RGB channel of every pixel of consecutive frame pairs
    /// (exact percentiles in constant memory, whatever the size and length of the sweep).
    changes: Vec<u64>,
    cutoff_per_frame: Vec<u32>,
    gpu_ms: Vec<f64>,
    previous: Option<image::RgbaImage>,
}

impl SeriesStats {
    fn add(&mut self, img: &image::RgbaImage, cutoff: u32, gpu_ms: f64) {
        if self.changes.is_empty() {
            self.changes = vec![0; 256];
        }
        if let Some(prev) = &self.previous {
            for (a, b) in prev.pixels().zip(img.pixels()) {
                for c in 0..3 {
                    self.changes[a.0[c].abs_diff(b.0[c]) as usize] += 1;
                }
            }
        }
        self.previous = Some(img.clone());
        self.cutoff_per_frame.push(cutoff);
        self.gpu_ms.push(gpu_ms);
    }

    /// Mean, 99.9th percentile and maximum of the frame-to-frame change, 8-bit units.
    pub fn change_summary(&self) -> (f64, f64, f64) {
        let total: u64 = self.changes.iter().sum();
        if total == 0 {
            return (0.0, 0.0, 0.0);
        }
        let sum: u64 = self
            .changes
            .iter()
            .enumerate()
            .map(|(v, &n)| v as u64 * n)
            .sum();
        let rank = ((total as f64) * 0.999).ceil() as u64;
        let mut seen = 0;
        let mut p999 = 0;
        for (value, &n) in self.changes.iter().enumerate() {
            seen += n;
            if seen >= rank {
                p999 = value;
                break;
            }
        }
        let max = self.changes.iter().rposition(|&n| n > 0).unwrap_or(0);
        (sum as f64 / total as f64, p999 as f64, max as f64)
    }
}

/// Offsets d that take the plane with unit normal `n` across the scene: from everything
/// visible to nearly nothing. The ends are the 0.5 and 99.5 percentiles of `n . mu`, so that
/// a few far floaters do not stretch the sweep over empty space.
pub fn default_range(scene: &Scene, n: Vec3) -> (f32, f32) {
    let mut proj: Vec<f32> = scene.means.iter().map(|m| n.dot(*m)).collect();
    proj.sort_by(f32::total_cmp);
    let at = |q: f64| proj[((proj.len() - 1) as f64 * q).round() as usize];
    let (lo, hi) = (at(0.005), at(0.995));
    (-lo, -hi)
}

/// Runs the sweep.
pub fn run(args: &SweepArgs) -> Result<()> {
    let camera = match &args.scene_file {
        Some(file) => resolve_scene_file_camera(&args.camera, file)?,
        None => resolve_camera(&args.camera)?,
    };
    let objects_path = PathBuf::from(format!(
        "{} objects",
        args.objects.len() + args.scene.is_some() as usize
    ));
    let (scene_path, mixed) = match &args.scene_file {
        Some(file) => (
            file,
            Some(super::scene::load_mixed(file, Some(args.background))?),
        ),
        None if !args.objects.is_empty() => (&objects_path, None),
        None => (args.scene.as_ref().expect("clap requires a scene"), None),
    };
    // With --object, the objects and their merged scene (for the plane's default range).
    let objects = if args.objects.is_empty() {
        Vec::new()
    } else {
        super::objects::load(args.scene.as_ref(), &args.objects)?
    };
    let loaded;
    let scene = match &mixed {
        Some(m) => &m.gaussians,
        None if !objects.is_empty() => {
            let list: Vec<_> = objects.iter().map(|(s, t)| (s, *t)).collect();
            loaded = rara::objects::merge(&list);
            &loaded
        }
        None => {
            loaded = load_scene(scene_path)?;
            &loaded
        }
    };
    if scene.is_empty() {
        return Err(Error::InvalidInput(format!(
            "{}: no Gaussians to sweep",
            scene_path.display()
        )));
    }
    let cameras = match &args.camera_path {
        Some(file) => super::args::path_cameras(file, args.frames, &args.camera)?,
        None => vec![camera.or_framing(|| scene.means.clone())?],
    };
    let camera = cameras[0];
    let normal = Plane::new(args.plane_normal, 0.0)?.normal;
    let (d0, d1) = {
        let (lo, hi) = default_range(scene, normal);
        (args.from.unwrap_or(lo), args.to.unwrap_or(hi))
    };
    // The configurations rendered per frame: the one asked for, or hard next to it.
    let base = args.clip.build(&[Plane::new(normal, d0)?])?;
    let mut configs: Vec<Clip> = Vec::new();
    if args.side_by_side {
        let mut hard = base.clone();
        hard.mode = ClipMode::Hard;
        let mut rara_clip = base.clone();
        if rara_clip.mode != ClipMode::Rara {
            rara_clip.mode = ClipMode::Rara;
        }
        configs.push(hard);
        configs.push(rara_clip);
    } else {
        configs.push(base);
    }
    if args.output.exists() && !args.output.is_dir() {
        return Err(Error::InvalidInput(format!(
            "-o {}: the sweep's frames go in a folder, and this is a file",
            args.output.display()
        )));
    }
    // Every frame, the GIF and the report land together once the sweep is done, or nothing
    // does (the folder included, when the sweep made it).
    let mut set = Outputs::new();
    set.create_dir(&args.output)?;
    let json_output = Output::prepare(&args.output.join("sweep.json"), &["json"])?;

    let ctx = Context::from_env()?;
    let mut renderer = Renderer::new(&ctx)?;
    let uploaded = super::objects::upload(&renderer, &objects)?;
    let scene_objects = super::objects::scene_objects(&uploaded, &objects);
    let (gpu_scene, mut mixed_gpu) = match &mixed {
        Some(m) => (
            None,
            Some(super::scene::MixedGpu::new(&ctx, m, false, false)?),
        ),
        None if !scene_objects.is_empty() => (None, None),
        None => (Some(renderer.upload(scene)?), None),
    };
    let target = match (&gpu_scene, &mut mixed_gpu) {
        (Some(g), _) => SweepTarget::Splats {
            renderer: &mut renderer,
            scene: g,
        },
        (None, Some(m)) => SweepTarget::Mixed(m),
        (None, None) => SweepTarget::Objects {
            renderer: &mut renderer,
            objects: &scene_objects,
        },
    };
    let gif_path = args.output.join("sweep.gif");
    let mut gif_file = Output::prepare(&gif_path, &["gif"])?.begin()?;
    let mut gif = GifWriter::new(&mut gif_file, &gif_path, args.delay_ms)?;
    let labels = configs.iter().map(describe).collect::<Vec<_>>();
    eprintln!(
        "sweeping {} frames, plane normal ({:.3}, {:.3}, {:.3}), d from {d0} to {d1}: {}",
        args.frames,
        normal.x,
        normal.y,
        normal.z,
        labels.join(" | ")
    );
    let plan = Sweep {
        cameras: &cameras,
        configs: &configs,
        normal,
        range: (d0, d1),
        frames: args.frames,
        background: args.background,
        tracer: args.tracer.into(),
    };
    let mut mp4 = super::video::Mp4Writer::start(
        &args.output.join("sweep.mp4"),
        camera.width * configs.len() as u32,
        camera.height,
        args.delay_ms,
    )?;
    let mut series = plan.run(target, |k, frame_img| {
        let frame = Output::prepare(&args.output.join(format!("frame_{k:04}.png")), &["png"])?;
        set.add_png(frame, &frame_img)?;
        if let Some(mp4) = &mut mp4 {
            mp4.add(&frame_img)?;
        }
        gif.add(frame_img)
    })?;
    drop(gif);
    set.add_written(gif_file)?;

    println!(
        "{:<60} {:>12} {:>12} {:>10} {:>14} {:>12}",
        "configuration", "mean change", "p99.9 change", "max change", "cutoff/frame", "median GPU"
    );
    let mut report = Vec::new();
    for s in &mut series {
        let (mean, p999, max) = s.change_summary();
        let mean_cutoff = s.cutoff_per_frame.iter().map(|&c| c as f64).sum::<f64>()
            / s.cutoff_per_frame.len() as f64;
        let median_ms = super::median(&mut s.gpu_ms.clone());
        println!(
            "{:<60} {:>12.4} {:>12.0} {:>10.0} {:>14.0} {:>9.1} ms",
            s.label, mean, p999, max, mean_cutoff, median_ms
        );
        report.push(serde_json::json!({
            "configuration": s.label,
            "mean_change": mean,
            "p999_change": p999,
            "max_change": max,
            "cutoff_per_frame": s.cutoff_per_frame,
            "gpu_ms_per_frame": s.gpu_ms,
        }));
    }
    let json = serde_json::json!({
        "scene": scene_path.display().to_string(),
        "width": camera.width,
        "height": camera.height,
        "frames": args.frames,
        "plane_normal": normal.to_array(),
        "from": d0,
        "to": d1,
        "device": ctx.info().name,
        "series": report,
    });
    set.add_json(json_output, &json)?;
    set.commit()?;
    if let Some(mp4) = mp4 {
        println!("wrote {}", mp4.finish()?.display());
    }
    println!(
        "wrote {} frames and {} ({}x{} per panel, {} on {})",
        args.frames,
        gif_path.display(),
        camera.width,
        camera.height,
        scene_path.display(),
        ctx.info().name
    );
    println!(
        "frame-to-frame change is |a - b| per RGB channel in 8-bit units; details in {}",
        args.output.join("sweep.json").display()
    );
    Ok(())
}

/// A plane moving across a scene, each frame rendered under every configuration.
pub struct Sweep<'a> {
    /// The camera of each frame, or one for every frame.
    pub cameras: &'a [rara::Camera],
    /// The clip configurations, side by side; the last half-space of each is the moving plane.
    pub configs: &'a [Clip],
    /// The moving plane's unit normal.
    pub normal: Vec3,
    /// Its offsets d in the first and the last frame.
    pub range: (f32, f32),
    /// Frames, at least 2.
    pub frames: u32,
    /// Background colour.
    pub background: Vec3,
    /// The rasterizer or the ray tracer.
    pub tracer: rara::Tracer,
}

/// What a sweep renders: a splat scene through the renderer, or a mixed scene (SPEC section 8)
/// whose splat objects all take the moving clip.
pub enum SweepTarget<'a> {
    /// A splat scene.
    Splats {
        /// The renderer.
        renderer: &'a mut Renderer,
        /// The scene.
        scene: &'a rara::GpuScene,
    },
    /// A mixed scene, ray traced.
    Mixed(&'a mut super::scene::MixedGpu),
    /// Several objects in one frame (`--object`).
    Objects {
        /// The renderer.
        renderer: &'a mut Renderer,
        /// The objects.
        objects: &'a [rara::SceneObject<'a>],
    },
}

impl Sweep<'_> {
    /// Renders the sweep, with a progress bar, handing each frame (the configurations' images
    /// side by side) to `on_frame`; returns the statistics per configuration. (A mixed scene's
    /// cutoff counts are 0: its tracer does not classify Gaussians up front.)
    pub fn run(
        &self,
        mut target: SweepTarget,
        mut on_frame: impl FnMut(u32, image::RgbaImage) -> Result<()>,
    ) -> Result<Vec<SeriesStats>> {
        let mut series: Vec<SeriesStats> = self
            .configs
            .iter()
            .map(|c| SeriesStats {
                label: describe(c),
                ..SeriesStats::default()
            })
            .collect();
        let bar = ProgressBar::new(self.frames as u64)
            .with_style(
                ProgressStyle::with_template("{msg} {bar:30} {pos}/{len} [{elapsed} < {eta}]")
                    .unwrap(),
            )
            .with_message("sweep");
        let (d0, d1) = self.range;
        for k in 0..self.frames {
            let camera = &self.cameras[(k as usize).min(self.cameras.len() - 1)];
            let d = d0 + (d1 - d0) * k as f32 / (self.frames - 1) as f32;
            let moving = Plane::new(self.normal, d)?;
            let mut panels = Vec::new();
            for (config, stats) in self.configs.iter().zip(series.iter_mut()) {
                let clip = with_moving_plane(config, moving);
                let img = match &mut target {
                    SweepTarget::Splats { renderer, scene } => {
                        let options = RenderOptions {
                            background: self.background,
                            clip,
                            tracer: self.tracer,
                            ..RenderOptions::default()
                        };
                        let (img, frame) = renderer.render(scene, camera, &options)?;
                        stats.add(&img, frame.cutoff, frame.gpu_ms);
                        img
                    }
                    SweepTarget::Objects { renderer, objects } => {
                        let options = RenderOptions {
                            background: self.background,
                            clip,
                            tracer: self.tracer,
                            ..RenderOptions::default()
                        };
                        let (img, frame) = renderer.render_objects(objects, camera, &options)?;
                        stats.add(&img, frame.cutoff, frame.gpu_ms);
                        img
                    }
                    SweepTarget::Mixed(gpu) => {
                        let objects = gpu.objects();
                        gpu.scene.set_clips(&vec![clip; objects])?;
                        let (img, frame, wall) = gpu.render(camera)?;
                        let gpu_ms = frame.passes.iter().map(|p| p.1).sum::<f64>();
                        stats.add(&img, 0, if gpu_ms > 0.0 { gpu_ms } else { wall });
                        img
                    }
                };
                panels.push(img);
            }
            on_frame(k, concat_horizontally(&panels))?;
            bar.inc(1);
        }
        bar.finish_and_clear();
        Ok(series)
    }
}

/// An animated GIF written frame by frame, looping, into a staged output (or any writer): the
/// file is whole once the writer is dropped (which writes the GIF's trailer).
pub struct GifWriter<'a> {
    path: PathBuf,
    encoder: image::codecs::gif::GifEncoder<&'a mut dyn Write>,
    delay_ms: u32,
}

impl<'a> GifWriter<'a> {
    /// A GIF written to `w` (the file at `path`, named in errors), each frame shown for
    /// `delay_ms`.
    pub fn new(w: &'a mut dyn Write, path: &Path, delay_ms: u32) -> Result<GifWriter<'a>> {
        let mut encoder = image::codecs::gif::GifEncoder::new_with_speed(w, 10);
        encoder
            .set_repeat(image::codecs::gif::Repeat::Infinite)
            .map_err(|source| Error::Image {
                path: path.to_path_buf(),
                source,
            })?;
        Ok(GifWriter {
            path: path.to_path_buf(),
            encoder,
            delay_ms,
        })
    }

    /// Appends a frame.
    pub fn add(&mut self, frame: image::RgbaImage) -> Result<()> {
        let delay = image::Delay::from_numer_denom_ms(self.delay_ms, 1);
        self.encoder
            .encode_frame(image::Frame::from_parts(frame, 0, 0, delay))
            .map_err(|source| Error::Image {
                path: self.path.clone(),
                source,
            })
    }
}

/// `config` with its last half-space (the moving plane) replaced by `moving`.
pub fn with_moving_plane(config: &Clip, moving: Plane) -> Clip {
    let mut clip = config.clone();
    if let Some(rara::clip::ClipRegion {
        shape: rara::clip::ClipShape::HalfSpaces(planes),
        ..
    }) = &mut clip.region
    {
        if let Some(last) = planes.last_mut() {
            *last = moving;
        }
    }
    clip
}

/// The images side by side, left to right.
pub fn concat_horizontally(panels: &[image::RgbaImage]) -> image::RgbaImage {
    let width = panels.iter().map(|p| p.width()).sum();
    let height = panels.iter().map(|p| p.height()).max().unwrap_or(0);
    let mut out = image::RgbaImage::new(width, height);
    let mut x = 0;
    for p in panels {
        image::imageops::replace(&mut out, p, x as i64, 0);
        x += p.width();
    }
    out
}
