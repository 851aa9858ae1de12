//! The `rara` command-line tool: render, inspect and demo 3DGS scenes. The commands live in
//! `cli/`, one module each; this file is their list and the dispatch.

use std::path::PathBuf;
use std::process::ExitCode;

use clap::{Parser, Subcommand};

mod cli;

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

#[derive(Subcommand)]
enum Command {
    /// Render a scene from one camera to a PNG, optionally clipped.
    Render(cli::render::RenderArgs),
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
        kind: cli::synth::SynthKindArg,
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

fn main() -> ExitCode {
    // Rust ignores SIGPIPE, so a closed stdout (`rara info x.ply | head`) would make every
    // println! panic; a command-line tool should end quietly instead, as cat and grep do.
    #[cfg(unix)]
    // SAFETY: signal() with SIG_DFL installs no handler; it runs before any other thread.
    unsafe {
        libc::signal(libc::SIGPIPE, libc::SIG_DFL);
    }
    let cli = Cli::parse();
    cli::load::set_spz_axes(match cli.spz_axes {
        SpzAxesArg::Rub => rara::formats::spz::SpzAxes::Rub,
        SpzAxesArg::AsStored => rara::formats::spz::SpzAxes::AsStored,
    });
    let result = match &cli.command {
        Command::Render(args) => cli::render::run(args),
        Command::Sweep(args) => cli::sweep::run(args),
        Command::Bench(args) => cli::bench::run(args),
        Command::Convert(args) => cli::convert::run(args),
        Command::Bake(args) => cli::bake::run(args),
        Command::Info { scene, json } => cli::info::run(scene, *json),
        Command::Compare { a, b, diff, json } => cli::compare::run(a, b, diff.as_deref(), *json),
        Command::Synth {
            kind,
            count,
            sh_degree,
            seed,
            output,
        } => cli::synth::run(*kind, *count, *sh_degree, *seed, output),
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
