//! antimatter15's `.splat` (github.com/antimatter15/splat, `main.js` and `convert.py`): no
//! header, 32 bytes per Gaussian, little-endian: position (3 x f32), linear scale (3 x f32),
//! colour and opacity (4 x u8: `0.5 + C0 f_dc` and the activated opacity, times 255), and the
//! rotation quaternion `(w, x, y, z)` as 4 x u8 (`q * 128 + 128`). No SH above degree 0.
//!
//! Decoding follows antimatter15's viewer: rotation `(u - 128) / 128`, normalised (a zero one
//! becomes the identity, as splat-transform does); colour `u / 255`, so `f_dc = (u / 255 -
//! 0.5) / C0`; opacity `u / 255`, kept inside `[1e-6, 1 - 1e-6]` (splat-transform's clamp
//! before its logit). Encoding rounds to the nearest byte.

use std::io::{BufWriter, Read, Write};
use std::path::Path;

use glam::{Quat, Vec3};

use super::push_decoded;
use crate::error::{Error, Result};
use crate::input::InputFile;
use crate::ply::LoadReport;
use crate::scene::Scene;
use crate::sh::SH_C0;

/// Bytes per Gaussian.
pub const BYTES_PER_SPLAT: usize = 32;

/// Reads a `.splat` file. A record with a non-finite or negative value is dropped and counted,
/// and a Gaussian far thinner along one axis is made flat, as every reader does
/// (`push_decoded`).
pub fn read_splat(path: &Path) -> Result<(Scene, LoadReport)> {
    read_splat_input(InputFile::open(path, ".splat file")?)
}

/// The most bytes of a `.splat` rara reads: a scene's most Gaussians (67,107,840), 32 bytes each.
pub const MAX_FILE_BYTES: u64 = crate::constants::MAX_GAUSSIANS * BYTES_PER_SPLAT as u64;

/// [`read_splat`] from an input opened already: a regular file is read record by record, a
/// stream whole (through [`InputFile::into_sized_reader`]'s cap) so that its size is known.
pub fn read_splat_input(input: InputFile) -> Result<(Scene, LoadReport)> {
    let path = input.path().to_path_buf();
    let io = |source| Error::Io {
        path: path.clone(),
        source,
    };
    let (mut reader, size) = input.into_sized_reader(MAX_FILE_BYTES, ".splat file")?;
    if size == 0 || size % BYTES_PER_SPLAT as u64 != 0 {
        return Err(Error::InvalidInput(format!(
            "{}: a .splat file holds 32 bytes per Gaussian, and this one has {size} bytes",
            path.display()
        )));
    }
    let count = (size / BYTES_PER_SPLAT as u64) as usize;
    let mut scene = Scene {
        sh_degree: 0,
        ..Scene::default()
    };
    let mut dropped = 0;
    let mut record = [0u8; BYTES_PER_SPLAT];
    for _ in 0..count {
        reader.read_exact(&mut record).map_err(io)?;
        match decode(&record) {
            Some((mean, opacity, scale, rotation, dc)) => push_decoded(
                &mut scene,
                &mut dropped,
                mean,
                scale,
                opacity,
                rotation,
                &dc,
            ),
            None => dropped += 1,
        }
    }
    Ok((
        scene,
        LoadReport {
            vertices_in_file: count,
            dropped_non_finite: dropped,
            encoding: "antimatter15 .splat",
            notes: Vec::new(),
        },
    ))
}

/// One record: centre, opacity, scale, rotation and the degree-0 SH; `None` for a non-finite or
/// negative position or scale.
pub fn decode(r: &[u8; BYTES_PER_SPLAT]) -> Option<(Vec3, f32, Vec3, Quat, [f32; 3])> {
    let f = |k: usize| f32::from_le_bytes([r[4 * k], r[4 * k + 1], r[4 * k + 2], r[4 * k + 3]]);
    let mean = Vec3::new(f(0), f(1), f(2));
    let scale = Vec3::new(f(3), f(4), f(5));
    if !mean.is_finite() || !scale.is_finite() || scale.min_element() < 0.0 {
        return None;
    }
    let dc = [0, 1, 2].map(|c| (r[24 + c] as f32 / 255.0 - 0.5) / SH_C0);
    let opacity = (r[27] as f32 / 255.0).clamp(super::OPACITY_MIN, 1.0 - super::OPACITY_MIN);
    let q = [28, 29, 30, 31].map(|k| (r[k] as f32 - 128.0) / 128.0);
    let rotation = crate::scene::normalized_rotation(Quat::from_xyzw(q[1], q[2], q[3], q[0]))
        .unwrap_or(Quat::IDENTITY);
    Some((mean, opacity, scale, rotation, dc))
}

/// Gaussian `i` of `scene` as a record.
pub fn encode(scene: &Scene, i: usize) -> [u8; BYTES_PER_SPLAT] {
    let mut r = [0u8; BYTES_PER_SPLAT];
    let m = scene.means[i];
    let s = scene.scales[i];
    for (k, v) in [m.x, m.y, m.z, s.x, s.y, s.z].into_iter().enumerate() {
        r[4 * k..4 * k + 4].copy_from_slice(&v.to_le_bytes());
    }
    let byte = |x: f32| (x * 255.0).round().clamp(0.0, 255.0) as u8;
    let sh = scene.sh_of(i);
    for c in 0..3 {
        r[24 + c] = byte(0.5 + SH_C0 * sh[c]);
    }
    r[27] = byte(scene.opacities[i]);
    let q = scene.rotations[i].normalize();
    for (k, v) in [q.w, q.x, q.y, q.z].into_iter().enumerate() {
        r[28 + k] = (v * 128.0 + 128.0).round().clamp(0.0, 255.0) as u8;
    }
    r
}

/// Writes `scene` as a `.splat` (streamed; the SH above degree 0, which the format has no room
/// for, is left out: the caller warns when `scene.sh_degree > 0`).
pub fn write_splat(scene: &Scene, path: &Path) -> Result<()> {
    let io = |source| Error::Io {
        path: path.to_path_buf(),
        source,
    };
    let mut out = BufWriter::with_capacity(1 << 20, std::fs::File::create(path).map_err(io)?);
    write_splat_to(scene, &mut out, path)?;
    out.flush().map_err(io)
}

/// Writes `scene` as a `.splat` to `w` (`path` names it in errors).
pub fn write_splat_to(scene: &Scene, w: &mut dyn Write, path: &Path) -> Result<()> {
    for i in 0..scene.len() {
        w.write_all(&encode(scene, i)).map_err(|source| Error::Io {
            path: path.to_path_buf(),
            source,
        })?;
    }
    Ok(())
}
