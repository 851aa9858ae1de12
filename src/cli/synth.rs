//! `rara synth`: a generated scene (shell, hair, layers, solid) and its orbit cameras.

use std::path::Path;

use glam::Vec3;
use rara::{Camera, Error, Result};

use super::output::{Output, Outputs};

/// `rara synth --kind`.
#[derive(Clone, Copy, clap::ValueEnum)]
pub enum SynthKindArg {
    /// A sphere of isotropic Gaussians.
    Shell,
    /// Strands of needle-like Gaussians (length/width 30).
    Hair,
    /// Nested closed surfaces (skin, muscle, bone).
    Layers,
    /// A solid ellipsoid coloured in layers, for cuts through a volume.
    Solid,
}

/// Writes a generated scene of `kind` and its eight orbit cameras (`output` with extension
/// cameras.json).
pub fn run(
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
