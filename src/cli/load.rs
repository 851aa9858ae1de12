//! Loading scenes for the commands: any format rara reads, with a spinner or progress bar and
//! the "loaded" line, and the reading options (`--spz-axes`) of this run.

use std::path::Path;

use indicatif::{ProgressBar, ProgressStyle};
use rara::{Context, Result, Scene};

/// The `--spz-axes` of this run.
static SPZ_AXES: std::sync::OnceLock<rara::formats::spz::SpzAxes> = std::sync::OnceLock::new();

/// Sets this run's `--spz-axes` (once, before any scene is read).
pub fn set_spz_axes(axes: rara::formats::spz::SpzAxes) {
    let _ = SPZ_AXES.set(axes);
}

/// The `--spz-axes` of this run (RUB unless told).
pub fn spz_axes() -> rara::formats::spz::SpzAxes {
    SPZ_AXES.get().copied().unwrap_or_default()
}

/// How this run's readers take what a format leaves open (`--spz-axes`).
pub fn read_options() -> rara::formats::ReadOptions {
    rara::formats::ReadOptions {
        spz_axes: spz_axes(),
    }
}

/// Loads a scene of any format rara reads (told apart by content), with a spinner and the
/// "loaded" line.
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
pub fn stream_scene(
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
