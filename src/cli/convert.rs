//! `rara convert`: a scene from any readable format to PLY, SPZ, glTF (`.glb`) or `.splat`,
//! with a warning for what the target drops.

use std::io::Write;
use std::path::{Path, PathBuf};

use clap::{Args, ValueEnum};

use rara::formats::spz::{SpzAxes, SpzVersion};
use rara::{Error, Result};

use super::load::load_scene;
use super::output::{Output, Outputs};

/// The formats `convert` writes.
#[derive(Clone, Copy, Debug, PartialEq, Eq, ValueEnum)]
pub enum Target {
    /// INRIA 3DGS PLY (binary little-endian, float): lossless.
    Ply,
    /// Niantic SPZ (8-bit attributes, 24-bit positions, 4 or 5 bits of SH).
    Spz,
    /// glTF 2.0 binary with KHR_gaussian_splatting (float attributes): lossless.
    Glb,
    /// antimatter15 .splat (32 bytes a Gaussian, no SH above degree 0).
    Splat,
}

/// `rara convert`.
#[derive(Args)]
pub struct ConvertArgs {
    /// The scene to read (PLY, compressed PLY, SPZ, glTF, SOG or .splat, told apart by content).
    pub input: PathBuf,
    /// The file to write; its extension picks the format unless --to says.
    #[arg(short, long)]
    pub output: PathBuf,
    /// The format to write (default: from the output's extension).
    #[arg(long, value_enum)]
    pub to: Option<Target>,
    /// SPZ version to write: 4 (zstd streams, the current one) or 3 (one gzip stream, which
    /// older SPZ readers take).
    #[arg(long, default_value_t = 4, value_parser = clap::value_parser!(u32).range(3..=4))]
    pub spz_version: u32,
}

fn target_of(args: &ConvertArgs) -> Result<Target> {
    target_for(&args.output, args.to)
}

/// The format to write `output` in: `to` when given, else its extension's.
pub fn target_for(output: &std::path::Path, to: Option<Target>) -> Result<Target> {
    if let Some(t) = to {
        return Ok(t);
    }
    let ext = output
        .extension()
        .map(|e| e.to_string_lossy().to_ascii_lowercase());
    match ext.as_deref() {
        Some("ply") => Ok(Target::Ply),
        Some("spz") => Ok(Target::Spz),
        Some("glb") => Ok(Target::Glb),
        Some("splat") => Ok(Target::Splat),
        _ => Err(Error::InvalidInput(format!(
            "{}: name the format with --to (ply, spz, glb, splat), or end the name with one",
            output.display()
        ))),
    }
}

/// What writing `scene` as `target` loses, one warning each.
pub fn losses(scene: &rara::Scene, target: Target, version: u32) -> Vec<String> {
    let mut out = Vec::new();
    match target {
        Target::Ply | Target::Glb => {}
        Target::Splat => {
            if scene.sh_degree > 0 {
                out.push(format!(
                    ".splat holds no SH above degree 0: the scene's degree {} is dropped, so \
                     view-dependent colour is lost",
                    scene.sh_degree
                ));
            }
            out.push(
                ".splat quantises colour, opacity and each rotation component to 8 bits \
                 (centres and scales stay float)"
                    .into(),
            );
        }
        Target::Spz => {
            out.push(format!(
                "SPZ v{version} quantises: centres to 1/4096 unit (24-bit fixed point, +-2048 \
                 units), log scales to 1/16, opacity and colour to 8 bits, rotations to 9 bits a \
                 component{}",
                if scene.sh_degree > 0 {
                    ", SH to 5 bits (degree 1) and 4 bits (degrees 2 and 3)"
                } else {
                    ""
                }
            ));
            let clamped = scene
                .scales
                .iter()
                .filter(|s| s.min_element() > 0.0 && s.min_element().ln() < -10.0)
                .count();
            if clamped > 0 {
                out.push(format!(
                    "{clamped} Gaussians have a scale below e^-10 ({:.1e}), SPZ's smallest: \
                     they grow to it",
                    (-10f32).exp()
                ));
            }
        }
    }
    out
}

/// Writes `scene` to `w` as `target` (SPZ of `spz_version`, in the axes `--spz-axes` names);
/// `path` names the file in errors.
pub fn write(
    scene: &rara::Scene,
    w: &mut dyn Write,
    path: &Path,
    target: Target,
    spz_version: u32,
) -> Result<()> {
    let io = |source| Error::Io {
        path: path.to_path_buf(),
        source,
    };
    match target {
        Target::Ply => rara::ply::write_ply_to(
            scene,
            w,
            rara::ply::PlyEncoding::BinaryLittleEndian,
            rara::ply::PlyLayout::Inria,
            path,
        ),
        Target::Spz => {
            let version = if spz_version == 3 {
                SpzVersion::V3
            } else {
                SpzVersion::V4
            };
            let bytes = rara::formats::spz::encode(scene, version, super::load::spz_axes())?;
            w.write_all(&bytes).map_err(io)
        }
        Target::Glb => w
            .write_all(&rara::formats::gltf::encode_glb(scene)?)
            .map_err(io),
        Target::Splat => rara::formats::splat::write_splat_to(scene, w, path),
    }
}

/// Runs `rara convert`.
pub fn run(args: &ConvertArgs) -> Result<()> {
    let target = target_of(args)?;
    // The output is checked (and its folder made) before the scene is read; a failure at any
    // point after leaves neither the file nor the folder.
    let mut set = Outputs::new();
    if let Some(dir) = args.output.parent().filter(|d| !d.as_os_str().is_empty()) {
        set.create_dir(dir)?;
    }
    let output = match args.to {
        Some(_) => Output::prepare_any(&args.output)?,
        None => Output::prepare(&args.output, &["ply", "spz", "glb", "splat"])?,
    };
    let scene = load_scene(&args.input)?;
    for warning in losses(&scene, target, args.spz_version) {
        eprintln!("warning: {warning}");
    }
    let start = std::time::Instant::now();
    let bytes = set.add_with(output, |w| {
        write(&scene, w, &args.output, target, args.spz_version)
    })?;
    set.commit()?;
    eprintln!(
        "wrote {} ({:?}{}, {} Gaussians, {} bytes, {:.0} ms)",
        args.output.display(),
        target,
        if target == Target::Spz {
            format!(
                " v{}, axes {}",
                args.spz_version,
                match super::load::spz_axes() {
                    SpzAxes::Rub => "RUB",
                    SpzAxes::AsStored => "as stored (rara's RDF)",
                }
            )
        } else {
            String::new()
        },
        scene.len(),
        bytes,
        start.elapsed().as_secs_f64() * 1e3
    );
    Ok(())
}
