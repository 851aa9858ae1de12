//! `rara compare`: image metrics of two PNGs (L1, PSNR, SSIM, differing pixels), and a
//! difference image.

use std::path::Path;

use rara::{Error, Result};

use super::output::Output;

fn load_png(path: &Path) -> Result<image::RgbaImage> {
    Ok(image::open(path)
        .map_err(|source| Error::Image {
            path: path.to_path_buf(),
            source,
        })?
        .to_rgba8())
}

/// Prints the metrics of images `a` against `b` (text or JSON), and writes their difference
/// image to `diff` when given.
pub fn run(a: &Path, b: &Path, diff: Option<&Path>, json: bool) -> Result<()> {
    let diff = diff.map(|p| Output::prepare(p, &["png"])).transpose()?;
    let (ia, ib) = (load_png(a)?, load_png(b)?);
    if ia.dimensions() != ib.dimensions() {
        return Err(Error::InvalidInput(format!(
            "{} is {}x{} but {} is {}x{}",
            a.display(),
            ia.width(),
            ia.height(),
            b.display(),
            ib.width(),
            ib.height()
        )));
    }
    let d = rara::metrics::compare(&ia, &ib);
    let ssim = rara::metrics::ssim(&ia, &ib);
    if let Some(out) = diff {
        out.write_png(&rara::metrics::diff_image(&ia, &ib))?;
    }
    // JSON has no infinity: identical images report a PSNR of null.
    let psnr = d.psnr.is_finite().then_some(d.psnr);
    if json {
        let v = serde_json::json!({"l1": d.l1, "psnr": psnr, "ssim": ssim, "max_diff": d.max_diff, "differing_pixels": d.differing_pixels});
        println!("{v}");
    } else {
        println!(
            "L1 {:.4}  PSNR {}  SSIM {:.6}  max diff {}  differing pixels {}",
            d.l1,
            psnr.map_or("inf".into(), |p| format!("{p:.2} dB")),
            ssim,
            d.max_diff,
            d.differing_pixels
        );
    }
    Ok(())
}
