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

/// Structural similarity (Wang et al. 2004): 11x11 Gaussian window with sigma 1.5,
/// `K1 = 0.01`, `K2 = 0.03`, dynamic range 255, computed per RGB channel over the window
/// positions that lie fully inside the image (MATLAB `ssim_index`'s 'valid' region) and
/// averaged. 1 for identical images. Images smaller than the window are compared as one window.
pub fn ssim(a: &RgbaImage, b: &RgbaImage) -> f64 {
    assert_eq!(a.dimensions(), b.dimensions(), "images differ in size");
    let (w, h) = (a.width() as usize, a.height() as usize);
    let radius = 5usize.min((w.min(h).saturating_sub(1)) / 2);
    let taps: Vec<f64> = {
        let t: Vec<f64> = (0..=2 * radius)
            .map(|k| (-((k as f64 - radius as f64).powi(2)) / (2.0 * 1.5 * 1.5)).exp())
            .collect();
        let s: f64 = t.iter().sum();
        t.into_iter().map(|v| v / s).collect()
    };
    let (c1, c2) = ((0.01f64 * 255.0).powi(2), (0.03f64 * 255.0).powi(2));
    let (ow, oh) = (w - 2 * radius, h - 2 * radius);
    // Separable 'valid' filtering of one plane.
    let filter = |plane: &[f64]| -> Vec<f64> {
        let mut rows = vec![0f64; ow * h];
        for y in 0..h {
            for x in 0..ow {
                rows[y * ow + x] = taps
                    .iter()
                    .enumerate()
                    .map(|(k, t)| t * plane[y * w + x + k])
                    .sum();
            }
        }
        let mut out = vec![0f64; ow * oh];
        for y in 0..oh {
            for x in 0..ow {
                out[y * ow + x] = taps
                    .iter()
                    .enumerate()
                    .map(|(k, t)| t * rows[(y + k) * ow + x])
                    .sum();
            }
        }
        out
    };
    let mut total = 0f64;
    for c in 0..3 {
        let pa: Vec<f64> = a.pixels().map(|p| p[c] as f64).collect();
        let pb: Vec<f64> = b.pixels().map(|p| p[c] as f64).collect();
        let mu_a = filter(&pa);
        let mu_b = filter(&pb);
        let aa = filter(&pa.iter().map(|v| v * v).collect::<Vec<_>>());
        let bb = filter(&pb.iter().map(|v| v * v).collect::<Vec<_>>());
        let ab = filter(&pa.iter().zip(&pb).map(|(x, y)| x * y).collect::<Vec<_>>());
        let mut sum = 0f64;
        for i in 0..mu_a.len() {
            let (ma, mb) = (mu_a[i], mu_b[i]);
            let (va, vb, cov) = (aa[i] - ma * ma, bb[i] - mb * mb, ab[i] - ma * mb);
            sum += ((2.0 * ma * mb + c1) * (2.0 * cov + c2))
                / ((ma * ma + mb * mb + c1) * (va + vb + c2));
        }
        total += sum / mu_a.len() as f64;
    }
    total / 3.0
}

#[cfg(test)]
mod tests {
    use super::*;

    fn noise_image(seed: u64, w: u32, h: u32) -> RgbaImage {
        let mut rng = crate::synth::Rng::new(seed);
        RgbaImage::from_fn(w, h, |_, _| {
            image::Rgba([
                rng.next_u64() as u8,
                rng.next_u64() as u8,
                rng.next_u64() as u8,
                255,
            ])
        })
    }

    #[test]
    fn identical_images() {
        let a = noise_image(1, 40, 30);
        let d = compare(&a, &a);
        assert_eq!(d.max_diff, 0);
        assert!(d.psnr.is_infinite());
        assert!((ssim(&a, &a) - 1.0).abs() < 1e-12);
    }

    #[test]
    fn known_differences() {
        let a = RgbaImage::from_pixel(20, 20, image::Rgba([100, 100, 100, 255]));
        let b = RgbaImage::from_pixel(20, 20, image::Rgba([110, 100, 100, 255]));
        let d = compare(&a, &b);
        assert_eq!(d.max_diff, 10);
        assert!((d.l1 - 10.0 / 3.0).abs() < 1e-9);
        // MSE = 100 / 3 -> PSNR = 10 log10(255^2 * 3 / 100)
        assert!((d.psnr - 10.0 * (255.0f64 * 255.0 * 3.0 / 100.0).log10()).abs() < 1e-9);
        // Flat images: SSIM reduces to the luminance term (2 m1 m2 + C1) / (m1^2 + m2^2 + C1).
        let c1 = (0.01f64 * 255.0).powi(2);
        let red = (2.0 * 100.0 * 110.0 + c1) / (100.0f64.powi(2) + 110.0f64.powi(2) + c1);
        assert!((ssim(&a, &b) - (red + 2.0) / 3.0).abs() < 1e-9);
        // Noise against another noise: far from similar.
        assert!(ssim(&noise_image(1, 40, 30), &noise_image(2, 40, 30)) < 0.1);
    }
}
