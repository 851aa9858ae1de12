//! Image comparison metrics.

use image::RgbaImage;

/// Differences between two images of the same size, over the RGB channels.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct ImageDiff {
    /// Peak signal-to-noise ratio in dB (infinite for identical images).
    pub psnr: f64,
    /// Largest absolute 8-bit difference.
    pub max_diff: u8,
    /// Mean absolute difference in 8-bit units.
    pub l1: f64,
    /// Pixels with any channel differing.
    pub differing_pixels: usize,
}

/// Compares `a` and `b` (RGB channels; alpha ignored). Panics if the sizes differ.
pub fn compare(a: &RgbaImage, b: &RgbaImage) -> ImageDiff {
    assert_eq!(a.dimensions(), b.dimensions(), "images differ in size");
    let mut sq = 0f64;
    let mut abs = 0f64;
    let mut max_diff = 0u8;
    let mut differing = 0;
    for (pa, pb) in a.pixels().zip(b.pixels()) {
        let mut any = false;
        for c in 0..3 {
            let d = pa[c].abs_diff(pb[c]);
            any |= d > 0;
            max_diff = max_diff.max(d);
            sq += (d as f64) * (d as f64);
            abs += d as f64;
        }
        differing += any as usize;
    }
    let n = (a.width() as f64) * (a.height() as f64) * 3.0;
    let mse = sq / n;
    let psnr = if mse == 0.0 {
        f64::INFINITY
    } else {
        10.0 * (255.0f64 * 255.0 / mse).log10()
    };
    ImageDiff {
        psnr,
        max_diff,
        l1: abs / n,
        differing_pixels: differing,
    }
}

/// A heat map of the per-pixel largest channel difference, scaled so 32 levels are white.
pub fn diff_image(a: &RgbaImage, b: &RgbaImage) -> RgbaImage {
    RgbaImage::from_fn(a.width(), a.height(), |x, y| {
        let (pa, pb) = (a.get_pixel(x, y), b.get_pixel(x, y));
        let d = (0..3).map(|c| pa[c].abs_diff(pb[c])).max().unwrap_or(0) as u32;
        let v = (d * 8).min(255) as u8;
        image::Rgba([v, v / 2, 255 - v, 255])
    })
}
