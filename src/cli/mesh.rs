//! `rara mesh export`, `rara mesh import` and `rara render-sequence`: octagon meshes of flat
//! Gaussians out to mesh tools and edits back in (SPEC section 6).

use std::path::{Path, PathBuf};
use std::time::Instant;

use clap::{Args, Subcommand, ValueEnum};
use glam::Vec3;
use indicatif::{ProgressBar, ProgressStyle};
use rara::mesh::export::{
    export_mesh_to, ExportOptions, Falloff, GaussianSource, MeshFormat, PlySource,
};
use rara::mesh::import::{frame_files, import_mesh, read_mesh, Fit, ImportOptions};
use rara::ply::{write_ply_to, PlyEncoding};
use rara::{Context, Error, RenderOptions, Renderer, Result};

use super::flatten::LayoutArg;
use super::output::{Output, Outputs};
use super::sweep::GifWriter;

/// `rara mesh`.
#[derive(Args)]
pub struct MeshArgs {
    #[command(subcommand)]
    command: MeshCommand,
}

#[derive(Subcommand)]
enum MeshCommand {
    /// Write every Gaussian's octagon (SPEC section 6) as PLY, OBJ + MTL or glTF binary.
    Export(ExportArgs),
    /// Turn an edited octagon mesh (or a folder of frames) back into Gaussians.
    Import(ImportArgs),
}

#[derive(Args)]
struct ExportArgs {
    /// The scene (any format rara reads); Gaussians that are not flat are flattened on the fly.
    scene: PathBuf,
    /// Output mesh: .ply, .obj (with an .mtl beside it) or .glb.
    #[arg(short, long)]
    output: PathBuf,
    /// Q of the octagon radius rho^2 = Q + 2 ln(opacity) (the chi-square(3) 0.99 quantile).
    #[arg(long, default_value_t = rara::mesh::DEFAULT_Q)]
    q: f64,
    /// Alpha over the octagon: constant (one alpha per octagon), centre (a centre vertex, the
    /// rim at the Gaussian's value), texture (glb: a falloff texture over UV).
    #[arg(long, value_enum, default_value_t = FalloffArg::Constant)]
    falloff: FalloffArg,
    /// Gaussians below this opacity get no octagon.
    #[arg(long, default_value_t = 0.0)]
    min_opacity: f32,
}

/// `--falloff`.
#[derive(Clone, Copy, Debug, ValueEnum)]
enum FalloffArg {
    Constant,
    Centre,
    Texture,
}

#[derive(Args)]
struct ImportArgs {
    /// The edited mesh (.ply, .obj, .glb), or a folder of them (frames, in name order).
    mesh: PathBuf,
    /// The scene the mesh was exported from: opacity and SH come from it.
    #[arg(long)]
    original: PathBuf,
    /// Output PLY, or a folder for a folder of frames (one PLY per frame, same stem).
    #[arg(short, long)]
    output: PathBuf,
    /// redisplats: SPEC section 6's rule from corners 0, 2 and 6; lsq: a least-squares fit
    /// over all eight corners (robust to uneven edits).
    #[arg(long, value_enum, default_value_t = FitArg::Redisplats)]
    fit: FitArg,
    /// Rotate each Gaussian's SH (degrees 1-3) by the rotation its face underwent.
    #[arg(long)]
    rotate_sh: bool,
    /// Q the mesh was exported with.
    #[arg(long, default_value_t = rara::mesh::DEFAULT_Q)]
    q: f64,
    /// --min-opacity the mesh was exported with.
    #[arg(long, default_value_t = 0.0)]
    min_opacity: f32,
    /// How the output stores the scales (see `rara flatten`).
    #[arg(long, value_enum, default_value_t = LayoutArg::Inria)]
    layout: LayoutArg,
}

/// `--fit`.
#[derive(Clone, Copy, Debug, ValueEnum)]
enum FitArg {
    Redisplats,
    Lsq,
}

/// `rara render-sequence`.
#[derive(Args)]
pub struct RenderSequenceArgs {
    /// Folder of scenes (.ply), rendered in name order (what `rara mesh import FRAMES/` wrote).
    frames: PathBuf,
    #[command(flatten)]
    camera: super::args::CameraArgs,
    /// A camera path: its keyframes are the cameras of a cameras.json (or a COLMAP folder), in
    /// order, flown through over the frames (positions by Catmull-Rom, rotations by slerp).
    #[arg(long, value_name = "CAMERAS", conflicts_with_all = ["cameras", "eye"])]
    camera_path: Option<PathBuf>,
    /// Background colour R,G,B in [0, 1].
    #[arg(long, allow_hyphen_values = true, value_parser = super::args::parse_color, default_value = "0,0,0")]
    background: Vec3,
    /// Output folder: one PNG per frame (same stem) and sequence.gif.
    #[arg(short, long)]
    output: PathBuf,
    /// Time each GIF frame is shown, in milliseconds.
    #[arg(long, default_value_t = 100)]
    delay_ms: u32,
}

fn bar(len: u64, message: &str) -> ProgressBar {
    ProgressBar::new(len)
        .with_style(
            ProgressStyle::with_template("{msg} {bar:30} {pos}/{len} [{elapsed} < {eta}]").unwrap(),
        )
        .with_message(message.to_string())
}

/// Runs `rara mesh`.
pub fn run(args: &MeshArgs) -> Result<()> {
    match &args.command {
        MeshCommand::Export(a) => run_export(a),
        MeshCommand::Import(a) => run_import(a),
    }
}

fn run_export(args: &ExportArgs) -> Result<()> {
    if !(0.0..=1.0).contains(&args.min_opacity) {
        return Err(Error::InvalidInput(format!(
            "--min-opacity {}: an opacity, in [0, 1]",
            args.min_opacity
        )));
    }
    let format = MeshFormat::from_path(&args.output)?;
    let output = Output::prepare(&args.output, &MeshFormat::EXTENSIONS)?;
    let mtl_output = match format {
        MeshFormat::Obj => Some(Output::prepare(
            &args.output.with_extension("mtl"),
            &["mtl"],
        )?),
        _ => None,
    };
    let options = ExportOptions {
        q: args.q,
        falloff: match args.falloff {
            FalloffArg::Constant => Falloff::Constant,
            FalloffArg::Centre => Falloff::Centre,
            FalloffArg::Texture => Falloff::Texture,
        },
        min_opacity: args.min_opacity,
    };
    if options.falloff == Falloff::Texture && format != MeshFormat::Glb {
        eprintln!(
            "note: --falloff texture makes a glTF texture; {} gets constant alpha",
            args.output.display()
        );
    }
    // A PLY file is read twice, chunk by chunk (memory: one chunk, whatever the scene's
    // size); any other format, or a scene from a pipe, is loaded once, whole.
    let streamed = args.scene.is_file()
        && matches!(
            rara::formats::detect(&args.scene),
            Ok(rara::formats::SceneFormat::Ply)
        );
    let (ply_source, loaded);
    let source: &dyn GaussianSource = if streamed {
        ply_source = PlySource::open(&args.scene)?;
        &ply_source
    } else {
        loaded = super::load::load_scene(&args.scene)?;
        &loaded
    };
    let start = Instant::now();
    let progress = bar(2 * source.len_hint() as u64, "export (count, then write)");
    let mut report = None;
    let mut mtl = None;
    let mut set = Outputs::new();
    set.add_with(output, |w| {
        let (r, m) = export_mesh_to(
            source,
            w,
            &args.output,
            format,
            &options,
            &mut |done, total| {
                progress.set_length(total.max(done) as u64);
                progress.set_position(done as u64)
            },
        )?;
        report = Some(r);
        mtl = m;
        Ok(())
    })?;
    // The OBJ and its material library land together or not at all.
    if let (Some(out), Some(mtl)) = (mtl_output, mtl) {
        set.add(out, mtl.text.as_bytes())?;
    }
    set.commit()?;
    progress.finish_and_clear();
    let r = report.expect("written");
    if r.flattened > 0 {
        eprintln!(
            "warning: {} of {} octagons are of Gaussians that were not flat, flattened on the fly \
             (their smallest scale taken as 0; `rara flatten` makes this explicit)",
            r.flattened, r.octagons
        );
    }
    if r.no_octagon + r.below_min_opacity > 0 {
        eprintln!(
            "note: {} Gaussians have no octagon (rho = 0: opacity at most exp(-Q/2)), {} are below --min-opacity",
            r.no_octagon, r.below_min_opacity
        );
    }
    println!(
        "wrote {}: {} octagons of {} Gaussians, {} vertices, {} triangles, {:.1} MB in {:.2} s",
        args.output.display(),
        r.octagons,
        r.gaussians,
        r.vertices,
        r.triangles,
        r.bytes as f64 / 1e6,
        start.elapsed().as_secs_f64()
    );
    Ok(())
}

fn import_options(args: &ImportArgs) -> ImportOptions {
    ImportOptions {
        q: args.q,
        min_opacity: args.min_opacity,
        fit: match args.fit {
            FitArg::Redisplats => Fit::Redisplats,
            FitArg::Lsq => Fit::Lsq,
        },
        rotate_sh: args.rotate_sh,
    }
}

/// Imports one mesh file to one PLY, staged in `set`.
fn import_one(
    set: &mut Outputs,
    mesh_path: &Path,
    output: Output,
    original: &rara::Scene,
    args: &ImportArgs,
) -> Result<rara::mesh::import::ImportReport> {
    let mesh = read_mesh(mesh_path)?;
    let (scene, report) = import_mesh(&mesh, original, &import_options(args), mesh_path)?;
    let layout = args.layout.into();
    let path = output.path().to_path_buf();
    set.add_with(output, |w| {
        write_ply_to(&scene, w, PlyEncoding::BinaryLittleEndian, layout, &path)
    })?;
    Ok(report)
}

fn run_import(args: &ImportArgs) -> Result<()> {
    if !(args.q > 0.0 && args.q.is_finite()) {
        return Err(Error::InvalidInput(format!(
            "--q {}: Q must be a positive number, the one the mesh was exported with (default \
             11.3449)",
            args.q
        )));
    }
    if !(0.0..=1.0).contains(&args.min_opacity) {
        return Err(Error::InvalidInput(format!(
            "--min-opacity {}: an opacity, in [0, 1]",
            args.min_opacity
        )));
    }
    if !args.original.exists() {
        return Err(Error::InvalidInput(format!(
            "--original {}: no such file (the scene the mesh was exported from)",
            args.original.display()
        )));
    }
    let start = Instant::now();
    let mut set = Outputs::new();
    if args.mesh.is_dir() {
        let frames = frame_files(&args.mesh)?;
        if args.output.exists() && !args.output.is_dir() {
            return Err(Error::InvalidInput(format!(
                "-o {}: a folder of frames imports to a folder, and this is a file",
                args.output.display()
            )));
        }
        let original = super::load::load_scene(&args.original)?;
        // Every frame is imported before any lands: a bad frame leaves no output at all.
        set.create_dir(&args.output)?;
        let progress = bar(frames.len() as u64, "import frames");
        for frame in &frames {
            let stem = frame.file_stem().unwrap_or_default().to_string_lossy();
            let out = args.output.join(format!("{stem}.ply"));
            let output = Output::prepare(&out, &["ply"])?;
            let report = import_one(&mut set, frame, output, &original, args)?;
            progress.println(format!(
                "{} -> {}: {} Gaussians fitted, {} kept",
                frame.display(),
                out.display(),
                report.fitted,
                report.kept
            ));
            progress.inc(1);
        }
        progress.finish_and_clear();
        set.commit()?;
        println!(
            "imported {} frames into {} in {:.2} s",
            frames.len(),
            args.output.display(),
            start.elapsed().as_secs_f64()
        );
        return Ok(());
    }
    let output = Output::prepare(&args.output, &["ply"])?;
    let original = super::load::load_scene(&args.original)?;
    let report = import_one(&mut set, &args.mesh, output, &original, args)?;
    set.commit()?;
    println!(
        "wrote {}: {} Gaussians fitted ({:?} fit, matched by {}, {} vertices per octagon{}), {} kept, in {:.2} s",
        args.output.display(),
        report.fitted,
        args.fit,
        if report.matched_by_ids { "primitive_id/corner_id" } else { "order" },
        report.vertices_per_octagon,
        if args.rotate_sh { ", SH rotated" } else { "" },
        report.kept,
        start.elapsed().as_secs_f64()
    );
    Ok(())
}

/// Runs `rara render-sequence`.
pub fn run_render_sequence(args: &RenderSequenceArgs) -> Result<()> {
    let camera = super::args::resolve_camera(&args.camera)?;
    let entries = std::fs::read_dir(&args.frames).map_err(|source| Error::Io {
        path: args.frames.clone(),
        source,
    })?;
    let mut frames: Vec<PathBuf> = entries
        .filter_map(|e| e.ok().map(|e| e.path()))
        .filter(|p| p.is_file() && p.extension().is_some_and(|e| e.eq_ignore_ascii_case("ply")))
        .collect();
    frames.sort();
    if frames.is_empty() {
        return Err(Error::InvalidInput(format!(
            "{}: no scenes (.ply) in this folder",
            args.frames.display()
        )));
    }
    if args.output.exists() && !args.output.is_dir() {
        return Err(Error::InvalidInput(format!(
            "-o {}: the frames go in a folder, and this is a file",
            args.output.display()
        )));
    }
    // The first frame is read before any output is made, so that a folder of garbage fails
    // at once; the rest are staged with it and land together when the last has rendered.
    let first = rara::ply::load_ply(&frames[0])?.0;
    // Without a camera, every frame is seen from the first one's framing (SPEC 12).
    let cameras = match &args.camera_path {
        Some(file) => super::args::path_cameras(file, frames.len() as u32, &args.camera)?,
        None => vec![camera.or_framing(|| first.means.clone())?],
    };
    let camera = cameras[0];
    let ctx = Context::from_env()?;
    let mut renderer = Renderer::new(&ctx)?;
    let options = RenderOptions {
        background: args.background,
        ..RenderOptions::default()
    };
    let mut set = Outputs::new();
    set.create_dir(&args.output)?;
    let gif_path = args.output.join("sequence.gif");
    let mut gif_file = Output::prepare(&gif_path, &["gif"])?.begin()?;
    let mut gif = GifWriter::new(&mut gif_file, &gif_path, args.delay_ms)?;
    let mut mp4 = super::video::Mp4Writer::start(
        &args.output.join("sequence.mp4"),
        camera.width,
        camera.height,
        args.delay_ms,
    )?;
    let progress = bar(frames.len() as u64, "render frames");
    let mut first = Some(first);
    for (k, frame) in frames.iter().enumerate() {
        let camera = cameras[k.min(cameras.len() - 1)];
        let scene = match first.take() {
            Some(scene) => scene,
            None => rara::ply::load_ply(frame)?.0,
        };
        let gpu_scene = renderer.upload(&scene)?;
        let (img, _) = renderer.render(&gpu_scene, &camera, &options)?;
        let stem = frame.file_stem().unwrap_or_default().to_string_lossy();
        set.add_png(
            Output::prepare(&args.output.join(format!("{stem}.png")), &["png"])?,
            &img,
        )?;
        if let Some(mp4) = &mut mp4 {
            mp4.add(&img)?;
        }
        gif.add(img)?;
        progress.inc(1);
    }
    progress.finish_and_clear();
    drop(gif);
    set.add_written(gif_file)?;
    set.commit()?;
    if let Some(mp4) = mp4 {
        println!("wrote {}", mp4.finish()?.display());
    }
    println!(
        "rendered {} frames ({}x{}) to {} and {}",
        frames.len(),
        camera.width,
        camera.height,
        args.output.display(),
        gif_path.display()
    );
    Ok(())
}
