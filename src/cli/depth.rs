//! `rara render --depth OUT.{exr,png}`: the splats' depth (SPEC section 9) as a file, OpenEXR
//! (32-bit float view depth, infinity where there is none) through the `image` crate, or a
//! 16-bit grey PNG scaled to the depths' range.

use std::path::Path;

use clap::ValueEnum;

use rara::depth::DepthMode;
use rara::{Error, Result};

use super::output::{Output, Outputs};

/// `--depth-mode`.
#[derive(Clone, Copy, Debug, PartialEq, Eq, ValueEnum)]
pub enum DepthModeArg {
    /// The depth at which the accumulated alpha first reaches 0.5 (a surface's depth).
    Median,
    /// The alpha-weighted mean depth of the composited splats.
    Mean,
}

impl From<DepthModeArg> for DepthMode {
    fn from(m: DepthModeArg) -> DepthMode {
        match m {
            DepthModeArg::Median => DepthMode::Median,
            DepthModeArg::Mean => DepthMode::Mean,
        }
    }
}

/// The level of a 16-bit depth PNG that means "no depth".
pub const PNG_NONE: u16 = 65535;

/// The range of the finite depths, or `None` when no pixel has one.
pub fn finite_range(depths: &[f32]) -> Option<(f32, f32)> {
    depths
        .iter()
        .filter(|z| z.is_finite())
        .fold(None, |r, &z| match r {
            None => Some((z, z)),
            Some((lo, hi)) => Some((lo.min(z), hi.max(z))),
        })
}

/// The 16-bit levels of `depths`: `[lo, hi]` spread over 0..=65534, [`PNG_NONE`] where there is
/// no depth.
pub fn png_levels(depths: &[f32], (lo, hi): (f32, f32)) -> Vec<u16> {
    let span = (hi - lo).max(f32::MIN_POSITIVE);
    depths
        .iter()
        .map(|&z| {
            if z.is_finite() {
                ((z - lo) / span * 65534.0).round().clamp(0.0, 65534.0) as u16
            } else {
                PNG_NONE
            }
        })
        .collect()
}

/// Checks the depth output's name before any work: `.exr` or `.png`.
pub fn prepare(path: &Path) -> Result<Output> {
    Output::prepare(path, &["exr", "png"])
}

/// Stages `depths` (`width` x `height`, rows top first) as `output` in `set` (committed with
/// the image it belongs to) and returns the line that says what it holds.
pub fn stage(
    set: &mut Outputs,
    output: Output,
    depths: &[f32],
    (width, height): (u32, u32),
    mode: DepthMode,
) -> Result<String> {
    let path = output.path().to_path_buf();
    let image_error = |source| Error::Image {
        path: path.clone(),
        source,
    };
    let exr = path
        .extension()
        .is_some_and(|e| e.eq_ignore_ascii_case("exr"));
    let range = finite_range(depths);
    let covered = depths.iter().filter(|z| z.is_finite()).count();
    let what = format!(
        "{mode:?} view depth of {covered} of {} pixels",
        depths.len()
    )
    .to_lowercase();
    let mut bytes = Vec::new();
    let line = if exr {
        // Three equal channels: viewers show grey; infinity where there is no depth.
        let rgb: Vec<f32> = depths.iter().flat_map(|&z| [z, z, z]).collect();
        let img = image::Rgb32FImage::from_raw(width, height, rgb).expect("depth size");
        image::DynamicImage::ImageRgb32F(img)
            .write_to(
                &mut std::io::Cursor::new(&mut bytes),
                image::ImageFormat::OpenExr,
            )
            .map_err(image_error)?;
        format!(
            "wrote {} ({what}; 32-bit float, +inf where there is none)",
            path.display()
        )
    } else {
        let (lo, hi) = range.unwrap_or((0.0, 0.0));
        let levels = png_levels(depths, (lo, hi));
        let img = image::ImageBuffer::<image::Luma<u16>, Vec<u16>>::from_raw(width, height, levels)
            .expect("depth size");
        image::DynamicImage::ImageLuma16(img)
            .write_to(
                &mut std::io::Cursor::new(&mut bytes),
                image::ImageFormat::Png,
            )
            .map_err(image_error)?;
        format!(
            "wrote {} ({what}; 16-bit grey: 0 = {lo}, 65534 = {hi}, linear; {PNG_NONE} = none)",
            path.display()
        )
    };
    set.add(output, &bytes)?;
    Ok(line)
}
