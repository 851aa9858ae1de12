//! `rara flatten`: a 3D scene made flat (SPEC section 6), and what flattening cost, as the
//! PSNR of the flat scene against the original over the scene's cameras.

use std::path::{Path, PathBuf};

use clap::{Args, ValueEnum};
use glam::Vec3;
use rara::ply::{write_ply_to, PlyEncoding, PlyLayout};
use rara::{Camera, Context, RenderOptions, Renderer, Result, Scene};

use super::output::{Output, Outputs};

/// `rara flatten`.
#[derive(Args)]
pub struct FlattenArgs {
    /// The scene (any format rara reads).
    pub scene: PathBuf,
    /// Output PLY of flat Gaussians.
    #[arg(short, long)]
    pub output: PathBuf,
    /// How the output stores the scales: `inria` (three, the zero one written as 1e-6 of the
    /// largest, readable by every 3DGS tool) or `games` (two, the normal along local x, as
    /// GaMeS and REdiSplats train and read).
    #[arg(long, value_enum, default_value_t = LayoutArg::Inria)]
    pub layout: LayoutArg,
    /// Cameras for the PSNR (default: SCENE.orbit_cameras.json, SCENE.cameras.json or
    /// cameras.json beside the scene, else an orbit around it).
    #[arg(long)]
    pub cameras: Option<PathBuf>,
    /// Use at most this many of the cameras, evenly spread (0: all).
    #[arg(long, default_value_t = 8)]
    pub views: usize,
    /// Width of the PSNR renders (the height keeps each camera's aspect ratio).
    #[arg(long, default_value_t = 320, value_parser = clap::value_parser!(u32).range(1..=i64::from(rara::camera::MAX_IMAGE_SIDE)))]
    pub width: u32,
}

/// `--layout`.
#[derive(Clone, Copy, Debug, ValueEnum)]
pub enum LayoutArg {
    /// INRIA: scale_0..2.
    Inria,
    /// GaMeS / REdiSplats: scale_0, scale_1, normal along local x.
    Games,
}

impl From<LayoutArg> for PlyLayout {
    fn from(l: LayoutArg) -> PlyLayout {
        match l {
            LayoutArg::Inria => PlyLayout::Inria,
            LayoutArg::Games => PlyLayout::Games,
        }
    }
}

/// The cameras beside a scene file: `STEM.orbit_cameras.json`, `STEM.cameras.json`, then
/// `cameras.json` in its folder.
pub fn cameras_beside(scene: &Path) -> Option<PathBuf> {
    let dir = scene.parent().unwrap_or(Path::new("."));
    let stem = scene.file_stem()?.to_string_lossy();
    [
        dir.join(format!("{stem}.orbit_cameras.json")),
        dir.join(format!("{stem}.cameras.json")),
        dir.join("cameras.json"),
    ]
    .into_iter()
    .find(|p| p.is_file())
}

/// `views` cameras on a circle around the bulk of a scene (its per-axis median, at 2.5 times
/// the distance within which 90 % of the centres lie), for a scene that comes without any.
pub fn orbit_around(scene: &Scene, views: usize, width: u32) -> Result<Vec<Camera>> {
    let median = |axis: usize| {
        let mut v: Vec<f32> = scene.means.iter().map(|m| m[axis]).collect();
        v.sort_by(f32::total_cmp);
        v.get(v.len() / 2).copied().unwrap_or(0.0)
    };
    let centre = Vec3::new(median(0), median(1), median(2));
    let mut d: Vec<f32> = scene.means.iter().map(|m| (*m - centre).length()).collect();
    d.sort_by(f32::total_cmp);
    let radius = d.get(d.len() * 9 / 10).copied().unwrap_or(1.0).max(1e-3);
    let height = rara::Camera::default_height(width);
    rara::synth::orbit_cameras(views, 2.5 * radius, width, height, 50.0)?
        .into_iter()
        .map(|c| {
            let eye = c.position + centre;
            Camera::look_at(eye, centre, Vec3::NEG_Y, 50.0, width, height)
        })
        .collect()
}

/// At most `views` of `cameras`, evenly spread (all for 0), resized to `width`.
pub fn pick_cameras(cameras: Vec<Camera>, views: usize, width: u32) -> Result<Vec<Camera>> {
    let n = cameras.len();
    let take = if views == 0 { n } else { views.min(n) };
    (0..take)
        .map(|k| cameras[k * n / take.max(1)].resized(width, None))
        .collect()
}

/// PSNR (dB) of `b` against `a` from each camera, rendered on the GPU.
pub fn psnr_per_camera(a: &Scene, b: &Scene, cameras: &[Camera]) -> Result<Vec<f64>> {
    let ctx = Context::from_env()?;
    let mut renderer = Renderer::new(&ctx)?;
    let (ga, gb) = (renderer.upload(a)?, renderer.upload(b)?);
    let options = RenderOptions::default();
    cameras
        .iter()
        .map(|cam| {
            let (ia, _) = renderer.render(&ga, cam, &options)?;
            let (ib, _) = renderer.render(&gb, cam, &options)?;
            Ok(rara::metrics::compare(&ia, &ib).psnr)
        })
        .collect()
}

/// Runs `rara flatten`.
pub fn run(args: &FlattenArgs) -> Result<()> {
    // The cameras are read and sized before anything is written: a bad camera file fails here,
    // not after the flat scene is on disk.
    let camera_file = args.cameras.clone().or_else(|| cameras_beside(&args.scene));
    let given = match &camera_file {
        Some(path) => {
            let cameras = Camera::load_all(path)?;
            if cameras.is_empty() {
                return Err(rara::Error::InvalidInput(format!(
                    "{}: no cameras to measure the PSNR from",
                    path.display()
                )));
            }
            Some((pick_cameras(cameras, args.views, args.width)?, path))
        }
        None => None,
    };
    let output = Output::prepare(&args.output, &["ply"])?;
    let scene = super::load::load_scene(&args.scene)?;
    let already = scene.flat_count();
    let flat = scene.flattened();
    eprintln!(
        "flattened {} of {} Gaussians ({already} were flat already)",
        scene.len() - already,
        scene.len()
    );
    let layout = PlyLayout::from(args.layout);
    let mut set = Outputs::new();
    set.add_with(output, |w| {
        write_ply_to(
            &flat,
            w,
            PlyEncoding::BinaryLittleEndian,
            layout,
            &args.output,
        )
    })?;
    let layout_name = match args.layout {
        LayoutArg::Inria => "INRIA layout",
        LayoutArg::Games => "GaMeS layout, normal along local x",
    };
    let (cameras, source) = match given {
        Some((cameras, path)) => (cameras, path.display().to_string()),
        None => (
            pick_cameras(
                orbit_around(&scene, args.views.max(1), args.width)?,
                args.views,
                args.width,
            )?,
            "an orbit around the scene".to_string(),
        ),
    };
    let mut psnr = psnr_per_camera(&scene, &flat, &cameras)?;
    // The flat scene lands once its PSNR is measured: the command's output is whole or absent.
    set.commit()?;
    println!("wrote {} ({layout_name})", args.output.display());
    for (k, p) in psnr.iter().enumerate() {
        println!("  view {k}: PSNR {p:.2} dB");
    }
    let min = psnr.iter().copied().fold(f64::INFINITY, f64::min);
    let median = super::median(&mut psnr);
    println!(
        "flat against original over {} views from {source} at {} px wide: median PSNR {median:.2} dB, min {min:.2} dB",
        cameras.len(),
        args.width
    );
    Ok(())
}
