//! How a scene's SH coefficients are stored on the device: 32-bit floats, or half floats that
//! halve the largest buffer of an SH degree 3 scene (192 to 96 bytes per Gaussian).

use crate::scene::Scene;

/// Storage of the SH coefficients on the device ([`crate::GpuScene::with_sh_precision`]).
/// The kernels evaluate the SH in 32-bit floats either way; `F16` only rounds the stored
/// coefficients (to 11 significant bits, which is below 8-bit colour quantisation for
/// coefficients of the usual range; docs/ARCHITECTURE.md states the measured image error).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub enum ShPrecision {
    /// IEEE binary32, the coefficients as loaded.
    #[default]
    F32,
    /// IEEE binary16 (round to nearest even), two to a 32-bit word.
    F16,
}

impl ShPrecision {
    /// Bytes per stored coefficient.
    pub fn bytes(self) -> u64 {
        match self {
            ShPrecision::F32 => 4,
            ShPrecision::F16 => 2,
        }
    }

    /// `"f32"` or `"f16"`.
    pub fn name(self) -> &'static str {
        match self {
            ShPrecision::F32 => "f32",
            ShPrecision::F16 => "f16",
        }
    }

    /// A copy of `scene` with its SH coefficients rounded as they are stored at this
    /// precision: what the kernels see, for the CPU reference renderer to compare against.
    pub fn round_scene(self, scene: &Scene) -> Scene {
        let mut rounded = scene.clone();
        if self == ShPrecision::F16 {
            for v in &mut rounded.sh {
                *v = f16_bits_to_f32(f32_to_f16_bits(*v));
            }
        }
        rounded
    }
}

/// The IEEE binary16 nearest to `x` (ties to even), as bits; beyond the half range it is
/// infinity, NaN stays NaN.
pub fn f32_to_f16_bits(x: f32) -> u16 {
    let bits = x.to_bits();
    let sign = ((bits >> 16) & 0x8000) as u16;
    let exponent = ((bits >> 23) & 0xff) as i32;
    let mantissa = bits & 0x7f_ffff;
    if exponent == 0xff {
        let nan = if mantissa != 0 { 0x200 } else { 0 };
        return sign | 0x7c00 | nan;
    }
    // Rounds `value >> shift` to nearest, ties to even.
    let round_shift = |value: u32, shift: u32| -> u32 {
        let kept = value >> shift;
        let rest = value & ((1 << shift) - 1);
        let halfway = 1 << (shift - 1);
        kept + u32::from(rest > halfway || (rest == halfway && kept & 1 == 1))
    };
    let half_exponent = exponent - 127 + 15;
    if half_exponent >= 0x1f {
        return sign | 0x7c00;
    }
    if half_exponent <= 0 {
        // Subnormal half (or zero): value = m * 2^-24 with the implicit bit made explicit.
        if half_exponent < -10 {
            return sign;
        }
        let m = mantissa | 0x80_0000;
        return sign | round_shift(m, (14 - half_exponent) as u32) as u16;
    }
    // A carry out of the mantissa correctly bumps the exponent (up to infinity).
    let normal = ((half_exponent as u32) << 23) | mantissa;
    sign | round_shift(normal, 13) as u16
}

/// The value of IEEE binary16 bits.
pub fn f16_bits_to_f32(h: u16) -> f32 {
    let sign = u32::from(h & 0x8000) << 16;
    let exponent = u32::from((h >> 10) & 0x1f);
    let mantissa = u32::from(h & 0x3ff);
    match exponent {
        0 => {
            let magnitude = mantissa as f32 * (1.0 / 16_777_216.0);
            if sign != 0 {
                -magnitude
            } else {
                magnitude
            }
        }
        0x1f => f32::from_bits(sign | 0x7f80_0000 | (mantissa << 13)),
        _ => f32::from_bits(sign | ((exponent + 112) << 23) | (mantissa << 13)),
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn every_half_round_trips() {
        for h in 0..=u16::MAX {
            let x = f16_bits_to_f32(h);
            if x.is_nan() {
                assert!(f16_bits_to_f32(f32_to_f16_bits(x)).is_nan());
                continue;
            }
            assert_eq!(f32_to_f16_bits(x), h, "half {h:#06x} = {x}");
        }
    }

    #[test]
    fn rounds_to_the_nearest_half() {
        let mut rng = crate::synth::Rng::new(5);
        for _ in 0..200_000 {
            // Floats across and beyond the half range, including its subnormals.
            let x = f32::from_bits((rng.next_u64() as u32) & 0xc7ff_ffff);
            let h = f32_to_f16_bits(x);
            if x.abs() >= 65520.0 {
                assert_eq!(h & 0x7fff, 0x7c00, "{x} overflows to infinity");
                continue;
            }
            let y = f16_bits_to_f32(h) as f64;
            let err = (y - x as f64).abs();
            // The neighbours of h are no closer to x.
            for n in [h.wrapping_sub(1), h.wrapping_add(1)] {
                let z = f16_bits_to_f32(n);
                if z.is_finite() && (n & 0x7fff) <= 0x7bff && (z < 0.0) == (y < 0.0) {
                    assert!(
                        err <= (z as f64 - x as f64).abs(),
                        "{x}: {y} is further than its neighbour {z}"
                    );
                }
            }
        }
        assert_eq!(f32_to_f16_bits(65520.0), 0x7c00, "rounds up to infinity");
        assert_eq!(f32_to_f16_bits(65519.0), 0x7bff);
        assert_eq!(f32_to_f16_bits(1.0 + 1.0 / 2048.0), 0x3c00, "tie to even");
        assert_eq!(f32_to_f16_bits(2.0f32.powi(-25)), 0, "tie to even zero");
        assert_eq!(f32_to_f16_bits(-0.0), 0x8000);
    }
}
