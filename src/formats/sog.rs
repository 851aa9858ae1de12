//! PlayCanvas SOG ("spatially ordered Gaussians", developer.playcanvas.com's SOG version 2
//! specification, as splat-transform 3.10's `read-sog.ts` reads it), read: a `meta.json` and
//! lossless WebP images with one pixel per Gaussian (row major), in a folder or bundled in a
//! zip (`.sog`).
//!
//! - centres: `means_l` and `means_u` hold the low and high bytes of 16 bits per axis, a
//!   fraction of `[mins, maxs]` of the log-transformed centre, `sign(v) ln(|v| + 1)`;
//! - `scales`: three bytes indexing a 256-entry codebook of log scales;
//! - `quats`: smallest three, `(u / 255 * 2 - 1) / sqrt 2` each, the fourth byte `252 + the
//!   index of the largest in (w, x, y, z)` (any other value: the identity);
//! - `sh0`: three bytes indexing a codebook of `f_dc`, the fourth the opacity times 255;
//! - `shN` (optional): a 16-bit label per Gaussian (`shN_labels`' red and green) into a palette
//!   of `count` entries, each `(bands + 1)^2 - 1` texels of `shN_centroids` (64 entries a row)
//!   whose red, green and blue index a codebook of SH values.
//!
//! SOG stores the Gaussians in the 3DGS PLY's axes, which are rara's: nothing turns.

use std::io::{Cursor, Read};
use std::path::{Path, PathBuf};

use glam::{Quat, Vec3};
use serde::Deserialize;

use super::{from_smallest_three_wxyz, push_decoded, MAX_INFLATION};
use crate::error::{Error, Result};
use crate::input::InputFile;
use crate::ply::LoadReport;
use crate::scene::Scene;

/// The largest SOG file (or file of a SOG folder) rara reads.
const MAX_FILE_BYTES: u64 = 2 << 30;

/// meta.json, version 2.
#[derive(Deserialize)]
struct Meta {
    version: Option<u32>,
    count: usize,
    means: Means,
    scales: Codebooked,
    quats: Files,
    sh0: Codebooked,
    #[serde(rename = "shN")]
    sh_n: Option<ShN>,
}

#[derive(Deserialize)]
struct Means {
    mins: [f64; 3],
    maxs: [f64; 3],
    files: Vec<String>,
}

#[derive(Deserialize)]
struct Codebooked {
    codebook: Vec<f32>,
    files: Vec<String>,
}

#[derive(Deserialize)]
struct Files {
    files: Vec<String>,
}

#[derive(Deserialize)]
struct ShN {
    count: usize,
    bands: u32,
    codebook: Vec<f32>,
    files: Vec<String>,
}

fn bad(path: &Path, message: impl std::fmt::Display) -> Error {
    Error::InvalidInput(format!("{}: SOG: {message}", path.display()))
}

/// Where a SOG's files come from.
enum Source {
    Folder(PathBuf),
    Zip(zip::ZipArchive<Cursor<Vec<u8>>>, u64),
}

impl Source {
    /// A bundle from its bytes.
    fn zip(path: &Path, bytes: Vec<u8>) -> Result<Source> {
        let size = bytes.len() as u64;
        let archive = zip::ZipArchive::new(Cursor::new(bytes))
            .map_err(|e| bad(path, format!("not a readable zip: {e}")))?;
        Ok(Source::Zip(archive, size))
    }

    /// The bytes of `name`, at most `limit` of them (more is an error that names a bomb).
    fn read(&mut self, path: &Path, name: &str, limit: u64) -> Result<Vec<u8>> {
        if name.contains("..") || name.starts_with('/') || name.contains('\\') {
            return Err(bad(path, format!("the file name '{name}' leaves the SOG")));
        }
        match self {
            Source::Folder(dir) => {
                let file = crate::input::side_file(dir, true, name, "SOG member")?;
                crate::input::read_side_file(&file, None, limit.min(MAX_FILE_BYTES), "SOG member")
            }
            Source::Zip(archive, _) => {
                let entry = archive
                    .by_name(name)
                    .map_err(|e| bad(path, format!("'{name}' in the bundle: {e}")))?;
                let mut out = Vec::new();
                // The declared size may lie: read at most one byte past the limit.
                entry
                    .take(limit + 1)
                    .read_to_end(&mut out)
                    .map_err(|e| bad(path, format!("'{name}' in the bundle: {e}")))?;
                if out.len() as u64 > limit {
                    return Err(bad(
                        path,
                        format!(
                            "'{name}' inflates past {limit} bytes, more than this SOG's member \
                             can hold: a decompression bomb, or not a SOG"
                        ),
                    ));
                }
                Ok(out)
            }
        }
    }

    /// The most a member may inflate to.
    fn member_limit(&self) -> u64 {
        match self {
            Source::Folder(_) => MAX_FILE_BYTES,
            Source::Zip(_, size) => size.saturating_mul(MAX_INFLATION).min(MAX_FILE_BYTES),
        }
    }
}

/// The most bytes a lossless WebP of `pixels` RGBA pixels takes: its raw size and a margin
/// for headers and an incompressible image's coding overhead.
fn max_webp_bytes(pixels: u64) -> u64 {
    pixels.saturating_mul(5).saturating_add(1 << 20)
}

/// An RGBA image of at least `need` pixels; the decoder may allocate at most `max_pixels`
/// pixels (a small WebP that claims a huge size is refused before it is decoded), and the
/// member may inflate to at most what a WebP of that many pixels takes (a bomb, which a zip's
/// deflate makes a thousand times its size, is refused at that bound, before the rest of it
/// is inflated).
fn image(
    source: &mut Source,
    path: &Path,
    name: &str,
    need: usize,
    max_pixels: u64,
) -> Result<image::RgbaImage> {
    let limit = source.member_limit().min(max_webp_bytes(max_pixels));
    let bytes = source.read(path, name, limit)?;
    let mut reader = image::ImageReader::with_format(Cursor::new(&bytes), image::ImageFormat::WebP);
    let mut limits = image::Limits::default();
    limits.max_alloc = Some(max_pixels.saturating_mul(8));
    reader.limits(limits);
    let decoded = reader
        .decode()
        .map_err(|e| bad(path, format!("'{name}': {e}")))?
        .to_rgba8();
    let (w, h) = decoded.dimensions();
    if (w as u64 * h as u64) < need as u64 {
        return Err(bad(
            path,
            format!("'{name}' is {w}x{h}, too small for {need} entries"),
        ));
    }
    Ok(decoded)
}

fn one_file<'a>(path: &Path, what: &str, files: &'a [String], n: usize) -> Result<&'a [String]> {
    if files.len() < n {
        return Err(bad(
            path,
            format!(
                "meta.json names {} files for {what}, where it needs {n}",
                files.len()
            ),
        ));
    }
    Ok(&files[..n])
}

fn inverse_log(v: f64) -> f64 {
    let e = v.abs().exp() - 1.0;
    if v < 0.0 {
        -e
    } else {
        e
    }
}

/// The largest meta.json read: three codebooks of 256 numbers and a few file names take a few
/// tens of kilobytes.
const MAX_META_BYTES: u64 = 1 << 20;

/// Reads a SOG: a folder holding `meta.json`, that `meta.json` itself, or a bundled `.sog`.
pub fn read_sog(path: &Path) -> Result<(Scene, LoadReport)> {
    if path.is_dir() {
        return decode_source(Source::Folder(path.to_path_buf()), path);
    }
    read_sog_input(InputFile::open(path, "SOG")?)
}

/// [`read_sog`] from an input opened already: a bundle (a zip), or a `meta.json` whose folder
/// holds the images.
pub fn read_sog_input(mut input: InputFile) -> Result<(Scene, LoadReport)> {
    let path = input.path().to_path_buf();
    if input.peek(4)? == b"PK\x03\x04" {
        let source = Source::zip(&path, input.read_all(MAX_FILE_BYTES, "SOG bundle")?)?;
        return decode_source(source, &path);
    }
    let meta = input.read_all(MAX_META_BYTES, "SOG meta.json")?;
    let folder = crate::input::folder_of(&path).to_path_buf();
    decode(Source::Folder(folder), meta, &path)
}

/// Reads the meta.json `source` holds (a bundle's, or a folder's), then the rest.
fn decode_source(mut source: Source, path: &Path) -> Result<(Scene, LoadReport)> {
    let meta = source.read(path, "meta.json", MAX_META_BYTES)?;
    decode(source, meta, path)
}

/// Decodes a SOG from its `meta.json` and the images `source` holds.
fn decode(mut source: Source, meta_bytes: Vec<u8>, path: &Path) -> Result<(Scene, LoadReport)> {
    let mut de = serde_json::Deserializer::from_slice(&meta_bytes);
    let meta: Meta = serde_path_to_error::deserialize(&mut de)
        .map_err(|e| bad(path, format!("meta.json: {}: {}", e.path(), e.inner())))?;
    match meta.version {
        Some(2) => {}
        Some(v) => {
            return Err(bad(
                path,
                format!(
                    "meta.json version {v}: rara reads SOG version 2 (the version splat-transform \
                     3.10 writes; re-save with `splat-transform in.sog out.sog`)"
                ),
            ))
        }
        None => {
            return Err(bad(
                path,
                "meta.json has no version: the deprecated SOG version 1, which rara does not read \
                 (re-save it with splat-transform)",
            ))
        }
    }
    let n = meta.count;
    // Every image holds at least `count` pixels; a count no input could carry is refused
    // before any image is decoded.
    let input_bytes = match &source {
        Source::Zip(_, size) => *size,
        Source::Folder(_) => meta_bytes.len() as u64 + MAX_FILE_BYTES,
    };
    if n == 0 || n as u64 > input_bytes.saturating_mul(MAX_INFLATION) {
        return Err(bad(path, format!("meta.json's count {n} cannot be right")));
    }
    if meta.scales.codebook.len() != 256 || meta.sh0.codebook.len() != 256 {
        return Err(bad(
            path,
            format!(
                "codebooks of {} (scales) and {} (sh0) entries, where the format has 256",
                meta.scales.codebook.len(),
                meta.sh0.codebook.len()
            ),
        ));
    }
    let max_pixels = 2 * n as u64 + (1 << 20);
    let means = one_file(path, "means", &meta.means.files, 2)?;
    let lo = image(&mut source, path, &means[0], n, max_pixels)?;
    let hi = image(&mut source, path, &means[1], n, max_pixels)?;
    let quats = image(
        &mut source,
        path,
        &one_file(path, "quats", &meta.quats.files, 1)?[0],
        n,
        max_pixels,
    )?;
    let scales = image(
        &mut source,
        path,
        &one_file(path, "scales", &meta.scales.files, 1)?[0],
        n,
        max_pixels,
    )?;
    let sh0 = image(
        &mut source,
        path,
        &one_file(path, "sh0", &meta.sh0.files, 1)?[0],
        n,
        max_pixels,
    )?;
    let sh_n = match &meta.sh_n {
        Some(s) if s.bands > 0 => {
            if s.bands > 3 {
                return Err(bad(path, format!("shN has {} bands (1 to 3)", s.bands)));
            }
            if s.codebook.len() != 256 || s.count == 0 || s.count > 65536 {
                return Err(bad(
                    path,
                    format!(
                        "shN: a {}-entry codebook and {} palette entries (256, and 1 to 65536)",
                        s.codebook.len(),
                        s.count
                    ),
                ));
            }
            let files = one_file(path, "shN", &s.files, 2)?;
            let coeffs = ((s.bands + 1) * (s.bands + 1) - 1) as usize;
            let centroids = image(
                &mut source,
                path,
                &files[0],
                0,
                (64 * coeffs * s.count.div_ceil(64)) as u64 + (1 << 20),
            )?;
            if centroids.width() as usize != 64 * coeffs {
                return Err(bad(
                    path,
                    format!(
                        "'{}' is {} wide, where {} bands take {}",
                        files[0],
                        centroids.width(),
                        s.bands,
                        64 * coeffs
                    ),
                ));
            }
            let labels = image(&mut source, path, &files[1], n, max_pixels)?;
            Some((s, coeffs, centroids, labels))
        }
        _ => None,
    };
    let degree = sh_n.as_ref().map_or(0, |(s, ..)| s.bands);
    let mut scene = Scene {
        sh_degree: degree,
        ..Scene::default()
    };
    let span = |k: usize| {
        let d = meta.means.maxs[k] - meta.means.mins[k];
        if d == 0.0 {
            1.0
        } else {
            d
        }
    };
    let (lo, hi, quats, scales, sh0) = (
        lo.as_raw(),
        hi.as_raw(),
        quats.as_raw(),
        scales.as_raw(),
        sh0.as_raw(),
    );
    let mut sh = vec![0f32; 3 * crate::scene::sh_coeffs(degree)];
    let mut dropped = 0;
    let sqrt2 = std::f64::consts::SQRT_2;
    for i in 0..n {
        let o = 4 * i;
        let mean = Vec3::from_array([0, 1, 2].map(|k| {
            let v = (lo[o + k] as u32 | (hi[o + k] as u32) << 8) as f64 / 65535.0;
            inverse_log(meta.means.mins[k] + span(k) * v) as f32
        }));
        let tag = quats[o + 3];
        let rotation = if (252..=255).contains(&tag) {
            let abc = [0, 1, 2].map(|k| (quats[o + k] as f64 / 255.0 * 2.0 - 1.0) / sqrt2);
            from_smallest_three_wxyz((tag - 252) as usize, abc)
        } else {
            Quat::IDENTITY
        };
        let scale =
            Vec3::from_array([0, 1, 2].map(|k| meta.scales.codebook[scales[o + k] as usize].exp()));
        for c in 0..3 {
            sh[c] = meta.sh0.codebook[sh0[o + c] as usize];
        }
        let opacity = sh0[o + 3] as f32 / 255.0;
        if let Some((s, coeffs, centroids, labels)) = &sh_n {
            let labels = labels.as_raw();
            let label = labels[o] as usize | (labels[o + 1] as usize) << 8;
            let (cw, ch) = (centroids.width() as usize, centroids.height() as usize);
            let raw = centroids.as_raw();
            for j in 0..*coeffs {
                let (cy, cx) = (label / 64, (label % 64) * coeffs + j);
                for c in 0..3 {
                    sh[3 * (j + 1) + c] = if label < s.count && cy < ch && cx < cw {
                        s.codebook[raw[(cy * cw + cx) * 4 + c] as usize]
                    } else {
                        0.0
                    };
                }
            }
        }
        push_decoded(
            &mut scene,
            &mut dropped,
            mean,
            scale,
            opacity,
            rotation,
            &sh,
        );
    }
    Ok((
        scene,
        LoadReport {
            vertices_in_file: n,
            dropped_non_finite: dropped,
            encoding: "SOG",
            notes: vec![format!(
                "SOG version 2{}",
                match &source {
                    Source::Zip(..) => ", bundled",
                    Source::Folder(_) => ", a folder",
                }
            )],
        },
    ))
}
