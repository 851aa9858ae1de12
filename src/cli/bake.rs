//! `rara bake SCENE [clip options] -o CLIPPED.{ply,spz,glb,splat}`: the clip baked into a scene
//! any viewer shows cut (SPEC section 10, `rara::bake`).

use std::path::PathBuf;

use clap::{Args, ValueEnum};

use rara::bake::{bake, BakeOpacity};
use rara::{ClipMode, Error, Result};

use super::clip_args::ClipArgs;
use super::load::load_scene;
use super::output::{Output, Outputs};

/// `--opacity`.
#[derive(Clone, Copy, Debug, PartialEq, Eq, ValueEnum)]
pub enum OpacityArg {
    /// Section 10: the visible part's mass, o P / sqrt(v).
    Mass,
    /// The peak alpha along the normal that the visible part keeps.
    Peak,
}

/// `rara bake`.
#[derive(Args)]
pub struct BakeArgs {
    /// The scene (any format rara reads).
    pub scene: PathBuf,
    /// The baked scene: .ply, .spz, .glb or .splat (by its extension).
    #[arg(short, long)]
    pub output: PathBuf,
    /// How a cut Gaussian's opacity is set: mass (section 10) or peak.
    #[arg(long, value_enum, default_value_t = OpacityArg::Mass)]
    pub opacity: OpacityArg,
    /// Also render, from every camera of this file, the baked scene unclipped and the original
    /// under the rara clip (the same region), and print the PSNR between the two per view and
    /// their mean: how well the bake stands in for clipping.
    #[arg(long, value_name = "CAMERAS.json")]
    pub views: Option<PathBuf>,
    /// Width of the --views renders.
    #[arg(long, default_value_t = 320, value_parser = clap::value_parser!(u32).range(1..=i64::from(rara::camera::MAX_IMAGE_SIDE)))]
    pub width: u32,
    /// The clip: rara (the default) reshapes the Gaussians it cuts; --clip-mode hard removes
    /// those whose centre is hidden, as centre filters (splat-transform's --filter-box) do.
    #[command(flatten)]
    pub clip: ClipArgs,
}

/// Runs `rara bake`.
pub fn run(args: &BakeArgs) -> Result<()> {
    let clip = args.clip.build(&[])?;
    if clip.region.is_none() || clip.effective_mode() == ClipMode::None {
        return Err(Error::InvalidInput(
            "bake needs a clip region (--clip-plane, --clip-box, --clip-sphere or --clip)".into(),
        ));
    }
    let target = super::convert::target_for(&args.output, None)?;
    // The views' cameras are read and sized before anything is written: a bad camera file or
    // width fails here, not after the baked scene is on disk.
    let views = args
        .views
        .as_deref()
        .map(|v| view_cameras(v, args.width))
        .transpose()?;
    let output = Output::prepare(&args.output, &["ply", "spz", "glb", "splat"])?;
    let scene = load_scene(&args.scene)?;
    eprintln!("{}", super::clip_args::describe(&clip));
    let start = std::time::Instant::now();
    let rule = match args.opacity {
        OpacityArg::Mass => BakeOpacity::Mass,
        OpacityArg::Peak => BakeOpacity::Peak,
    };
    let (baked, report) = bake(&scene, &clip, rule);
    for warning in super::convert::losses(&baked, target, 4) {
        eprintln!("warning: {warning}");
    }
    let bake_ms = start.elapsed().as_secs_f64() * 1e3;
    // Committed once the views (when asked for) are done: the command's output is whole or
    // absent.
    let mut set = Outputs::new();
    set.add_with(output, |w| {
        super::convert::write(&baked, w, &args.output, target, 4)
    })?;
    println!(
        "baked {} of {} Gaussians for {}: {} dropped, {} kept, {} reshaped ({:.0} ms)",
        baked.len(),
        scene.len(),
        args.output.display(),
        report.dropped,
        report.kept,
        report.reshaped,
        bake_ms
    );
    if let Some(cameras) = &views {
        compare_views(&scene, &baked, &clip, cameras)?;
    }
    set.commit()?;
    println!("wrote {}", args.output.display());
    Ok(())
}

/// The cameras of `path`, each resized to `width` (height keeping its aspect ratio).
pub fn view_cameras(path: &std::path::Path, width: u32) -> Result<Vec<rara::Camera>> {
    let cameras = rara::Camera::load_all(path)?;
    if cameras.is_empty() {
        return Err(Error::InvalidInput(format!(
            "{}: no cameras to render the views from",
            path.display()
        )));
    }
    cameras.iter().map(|c| c.resized(width, None)).collect()
}

/// Prints the PSNR of `baked` rendered unclipped against `scene` rendered under `clip` in rara
/// mode, from each of `cameras`, and the mean.
fn compare_views(
    scene: &rara::Scene,
    baked: &rara::Scene,
    clip: &rara::Clip,
    cameras: &[rara::Camera],
) -> Result<()> {
    let ctx = rara::Context::from_env()?;
    let mut renderer = rara::Renderer::new(&ctx)?;
    let (original, cut) = (renderer.upload(scene)?, renderer.upload(baked)?);
    let mut reference_clip = clip.clone();
    reference_clip.mode = ClipMode::Rara;
    let clipped = rara::RenderOptions {
        clip: reference_clip,
        ..rara::RenderOptions::default()
    };
    let mut psnrs = Vec::new();
    for (k, camera) in cameras.iter().enumerate() {
        let (want, _) = renderer.render(&original, camera, &clipped)?;
        let (got, _) = renderer.render(&cut, camera, &rara::RenderOptions::default())?;
        let d = rara::metrics::compare(&got, &want);
        // Identical images have no PSNR (infinite): counted as 100 dB in the mean.
        let psnr = if d.psnr.is_finite() { d.psnr } else { 100.0 };
        println!("view {k}: PSNR {psnr:.2} dB against the clipped original");
        psnrs.push(psnr);
    }
    let mean = psnrs.iter().sum::<f64>() / psnrs.len().max(1) as f64;
    println!(
        "mean PSNR over {} views: {mean:.2} dB (baked, unclipped, against the original under \
         the rara clip)",
        psnrs.len()
    );
    Ok(())
}
