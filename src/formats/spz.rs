//! Niantic SPZ (github.com/nianticlabs/spz, `src/cc/load-spz.cc` and `splat-utils.h`, format
//! version 4 and the legacy versions 2 and 3), read and written.
//!
//! - **Versions 2 and 3** are one gzip stream holding a 16-byte header (`NGSP`, version,
//!   count, SH degree, fractional bits, flags, reserved) and then the attribute blocks one
//!   after the other: positions, alphas, colours, scales, rotations, SH.
//! - **Version 4** is a plain 32-byte header (the same fields, then the number of streams and
//!   the byte offset of a table of contents), optional extension bytes, the table (compressed
//!   and uncompressed size of each stream, two u64 each) and one zstd stream per attribute, in
//!   the same order, an empty one (the SH of a degree-0 scene) left out.
//!
//! Decoding follows the reference: positions are 24-bit signed fixed point over
//! `2^fractional_bits`; scales `u / 16 - 10`, log; alpha `u / 255`, after the sigmoid; colour
//! `(u / 255 - 0.5) / 0.15` is `f_dc`; SH `(u - 128) / 128`, coefficient major with the three
//! channels inside; rotations `(x, y, z)` as `u / 127.5 - 1` with `w >= 0` derived (version 2)
//! or "smallest three" (version 3 on): the largest component's index in the top two bits,
//! the other three as a sign and 9 bits of magnitude over `1/sqrt 2`.
//!
//! SPZ keeps its data in RUB axes (right, up, back, OpenGL's) unless an extension names
//! another; rara's scenes are in RDF (the INRIA PLY's), so by default reading and writing turn
//! the scene half a turn about x ([`SpzAxes::Rub`]). splat-transform writes and reads SPZ with
//! no conversion ("UNSPECIFIED"), which is [`SpzAxes::AsStored`].

use std::io::{Read, Write};
use std::path::Path;

use glam::{Quat, Vec3};

use super::{flip_axes, push_decoded, MAX_INFLATION};
use crate::error::{Error, Result};
use crate::ply::LoadReport;
use crate::scene::{sh_coeffs, Scene};

/// `NGSP`, little-endian.
const MAGIC: u32 = 0x5053_474e;
/// SPZ's scale of the DC colour (not SH's C0).
const COLOR_SCALE: f32 = 0.15;
/// `1 / sqrt 2`, the largest magnitude of a "smallest three" component.
const SQRT1_2: f32 = std::f32::consts::FRAC_1_SQRT_2;
/// Header flag: trained with antialiasing (Mip-Splatting's 2D filter).
const FLAG_ANTIALIASED: u8 = 0x1;
/// Header flag: extension records follow the header.
const FLAG_EXTENSIONS: u8 = 0x2;
/// The fractional bits rara writes (the reference's choice: 1/4096 over +-2048 units).
pub const FRACTIONAL_BITS: u8 = 12;
/// Bits kept of each band-1 SH value, and of each higher band's, when writing (the
/// reference's and splat-transform's defaults: the rest is noise that costs compression).
pub const SH1_BITS: u32 = 5;
/// See [`SH1_BITS`].
pub const SH_REST_BITS: u32 = 4;
/// The largest SPZ file rara reads (4 GiB): its counts are u32 and its streams fit in memory.
pub const MAX_FILE_BYTES: u64 = 4 << 30;

/// How SPZ's stored axes relate to rara's (RDF).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub enum SpzAxes {
    /// The format's own convention, RUB (what Niantic's library and its tools write): turned
    /// half a turn about x on the way in and out.
    #[default]
    Rub,
    /// Taken as they are, as splat-transform and SuperSplat write them (in the PLY's axes).
    AsStored,
}

impl SpzAxes {
    /// The axis flips that take one frame to the other.
    fn flips(self) -> [bool; 3] {
        match self {
            SpzAxes::Rub => [false, true, true],
            SpzAxes::AsStored => [false, false, false],
        }
    }
}

/// The SPZ versions rara writes.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum SpzVersion {
    /// One gzip stream, smallest-three rotations (read by every SPZ reader since 2024).
    V3,
    /// The NGSP header and one zstd stream per attribute (the current version).
    V4,
}

/// What an SPZ header says.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct SpzHeader {
    /// Format version, 2 to 4.
    pub version: u32,
    /// Gaussians.
    pub count: u32,
    /// SH degree, 0 to 4.
    pub sh_degree: u8,
    /// Fractional bits of the fixed-point positions.
    pub fractional_bits: u8,
    /// Whether the scene was trained with antialiasing.
    pub antialiased: bool,
    /// Whether extension records follow the header (rara skips them).
    pub has_extensions: bool,
}

impl SpzHeader {
    /// SH coefficients per channel above the DC.
    fn sh_rest(&self) -> usize {
        sh_coeffs(self.sh_degree as u32) - 1
    }

    fn rotation_bytes(&self) -> usize {
        if self.version >= 3 {
            4
        } else {
            3
        }
    }

    /// The byte size of each attribute block: positions, alphas, colours, scales, rotations, SH.
    fn block_sizes(&self) -> [u64; 6] {
        let n = self.count as u64;
        [
            9 * n,
            n,
            3 * n,
            3 * n,
            self.rotation_bytes() as u64 * n,
            3 * self.sh_rest() as u64 * n,
        ]
    }
}

fn bad(path: &Path, message: impl std::fmt::Display) -> Error {
    Error::InvalidInput(format!("{}: SPZ: {message}", path.display()))
}

fn u32_at(b: &[u8], at: usize) -> u32 {
    u32::from_le_bytes([b[at], b[at + 1], b[at + 2], b[at + 3]])
}

/// Parses the fields the 16-byte legacy header and the 32-byte v4 header share, and bounds the
/// count by what `stored_bytes` of input can hold (a decompression bomb's count is refused
/// before anything is allocated for it).
fn parse_header(path: &Path, b: &[u8], stored_bytes: u64) -> Result<SpzHeader> {
    if b.len() < 16 || u32_at(b, 0) != MAGIC {
        return Err(bad(path, "no NGSP header"));
    }
    let header = SpzHeader {
        version: u32_at(b, 4),
        count: u32_at(b, 8),
        sh_degree: b[12],
        fractional_bits: b[13],
        antialiased: b[14] & FLAG_ANTIALIASED != 0,
        has_extensions: b[14] & FLAG_EXTENSIONS != 0,
    };
    if !(2..=4).contains(&header.version) {
        return Err(bad(
            path,
            format!("version {} (rara reads versions 2 to 4)", header.version),
        ));
    }
    if header.sh_degree > 4 {
        return Err(bad(
            path,
            format!("SH degree {} (the format has 0 to 4)", header.sh_degree),
        ));
    }
    if header.fractional_bits > 23 {
        return Err(bad(
            path,
            format!(
                "{} fractional bits in a 24-bit position",
                header.fractional_bits
            ),
        ));
    }
    let most = stored_bytes.saturating_mul(MAX_INFLATION) / 9;
    if header.count == 0 || header.count as u64 > most {
        return Err(bad(
            path,
            format!(
                "the header's count {} does not fit in {stored_bytes} bytes of file (at most \
                 {most} at 9 bytes a Gaussian inflated {MAX_INFLATION} times)",
                header.count
            ),
        ));
    }
    Ok(header)
}

/// The decompressed attribute blocks.
struct Blocks {
    header: SpzHeader,
    /// positions, alphas, colours, scales, rotations, SH.
    blocks: [Vec<u8>; 6],
}

/// Reads up to `expected` bytes of `reader`, growing as data comes (a lying size allocates
/// only what the stream really holds), and checks that exactly `expected` came and nothing
/// more follows.
fn read_exactly(
    path: &Path,
    what: &str,
    reader: impl Read,
    expected: u64,
    trailing_ok: bool,
) -> Result<Vec<u8>> {
    let mut out = Vec::new();
    let mut limited = reader.take(expected + u64::from(!trailing_ok));
    limited
        .read_to_end(&mut out)
        .map_err(|e| bad(path, format!("{what}: {e}")))?;
    if (out.len() as u64) < expected {
        return Err(bad(
            path,
            format!(
                "{what}: the stream ends after {} of its {expected} bytes (truncated)",
                out.len()
            ),
        ));
    }
    if out.len() as u64 > expected {
        return Err(bad(
            path,
            format!("{what}: the stream holds more than the {expected} bytes its header gives"),
        ));
    }
    Ok(out)
}

fn decompress(path: &Path, bytes: &[u8]) -> Result<Blocks> {
    let names = [
        "positions",
        "alphas",
        "colours",
        "scales",
        "rotations",
        "SH",
    ];
    if bytes.starts_with(&[0x1f, 0x8b]) {
        let mut gz = flate2::bufread::GzDecoder::new(bytes);
        let mut head = [0u8; 16];
        gz.read_exact(&mut head).map_err(|e| {
            bad(
                path,
                format!("the gzip stream ends inside the header ({e})"),
            )
        })?;
        let header = parse_header(path, &head, bytes.len() as u64)?;
        if header.version > 3 {
            return Err(bad(
                path,
                format!(
                    "a gzip stream with version {} (gzip is versions 2 and 3)",
                    header.version
                ),
            ));
        }
        let sizes = header.block_sizes();
        let all = read_exactly(path, "gzip stream", &mut gz, sizes.iter().sum(), true)?;
        // The stream is read to its end, so that gzip's trailer (the CRC-32 and the length of
        // what it holds) is checked: a cut or corrupt stream is refused, as the reference's
        // zlib refuses it. Past the blocks come extension records when the header's flag says
        // so (skipped, and bounded like the blocks); without it, nothing may: a header count
        // short of the payload would otherwise read every block misaligned.
        let limit = (bytes.len() as u64).saturating_mul(MAX_INFLATION);
        let extra = std::io::copy(&mut (&mut gz).take(limit), &mut std::io::sink())
            .map_err(|e| bad(path, format!("gzip stream: {e} (cut or corrupt)")))?;
        if extra >= limit {
            return Err(bad(
                path,
                format!("the gzip stream inflates past {limit} bytes: a decompression bomb"),
            ));
        }
        if extra > 0 && !header.has_extensions {
            return Err(bad(
                path,
                format!(
                    "the gzip stream holds {extra} bytes more than the {} that {} Gaussians take, \
                     and the header announces no extension records (is its count right?)",
                    sizes.iter().sum::<u64>(),
                    header.count
                ),
            ));
        }
        let after = gz.into_inner().len();
        if after > 0 {
            return Err(bad(path, format!("{after} bytes follow the gzip stream")));
        }
        let mut blocks: [Vec<u8>; 6] = Default::default();
        let mut at = 0usize;
        for (block, size) in blocks.iter_mut().zip(sizes) {
            *block = all[at..at + size as usize].to_vec();
            at += size as usize;
        }
        return Ok(Blocks { header, blocks });
    }
    if bytes.len() < 32 {
        return Err(bad(
            path,
            format!("{} bytes, shorter than the 32-byte header", bytes.len()),
        ));
    }
    let header = parse_header(path, &bytes[..32], bytes.len() as u64)?;
    if header.version < 4 {
        return Err(bad(
            path,
            format!(
                "version {} without gzip (versions 2 and 3 are one gzip stream)",
                header.version
            ),
        ));
    }
    let streams = bytes[15] as usize;
    let toc = u32_at(bytes, 16) as usize;
    let sizes = header.block_sizes();
    let present: Vec<usize> = (0..6).filter(|&k| sizes[k] > 0).collect();
    if streams != present.len() {
        return Err(bad(
            path,
            format!(
                "{streams} streams where SH degree {} has {}",
                header.sh_degree,
                present.len()
            ),
        ));
    }
    let toc_end = toc
        .checked_add(16 * streams)
        .filter(|&end| toc >= 32 && end <= bytes.len())
        .ok_or_else(|| {
            bad(
                path,
                format!(
                    "its table of contents at byte {toc} does not lie in the file's {} bytes",
                    bytes.len()
                ),
            )
        })?;
    let mut blocks: [Vec<u8>; 6] = Default::default();
    let mut at = toc_end as u64;
    for (i, &k) in present.iter().enumerate() {
        let e = toc + 16 * i;
        let packed = u64::from_le_bytes(bytes[e..e + 8].try_into().unwrap());
        let unpacked = u64::from_le_bytes(bytes[e + 8..e + 16].try_into().unwrap());
        if unpacked != sizes[k] {
            return Err(bad(
                path,
                format!(
                    "the {} stream holds {unpacked} bytes where {} Gaussians need {}",
                    names[k], header.count, sizes[k]
                ),
            ));
        }
        let end = at
            .checked_add(packed)
            .filter(|&end| end <= bytes.len() as u64)
            .ok_or_else(|| {
                bad(
                    path,
                    format!(
                        "the {} stream runs past the end of the file (truncated)",
                        names[k]
                    ),
                )
            })?;
        let stream = &bytes[at as usize..end as usize];
        let decoder = zstd::stream::read::Decoder::with_buffer(stream)
            .map_err(|e| bad(path, format!("the {} stream: {e}", names[k])))?;
        blocks[k] = read_exactly(path, names[k], decoder, sizes[k], false)?;
        at = end;
    }
    if at != bytes.len() as u64 {
        return Err(bad(
            path,
            format!("{} bytes follow the last stream", bytes.len() as u64 - at),
        ));
    }
    Ok(Blocks { header, blocks })
}

/// The rotation of record `i` (`x, y, z, w`).
fn rotation_of(header: &SpzHeader, r: &[u8], i: usize) -> Quat {
    if header.version < 3 {
        let c = |k: usize| r[3 * i + k] as f32 / 127.5 - 1.0;
        let v = Vec3::new(c(0), c(1), c(2));
        let w = (1.0 - v.length_squared()).max(0.0).sqrt();
        return Quat::from_xyzw(v.x, v.y, v.z, w);
    }
    let mut comp = u32::from_le_bytes(r[4 * i..4 * i + 4].try_into().unwrap());
    let largest = (comp >> 30) as usize;
    let mask = (1u32 << 9) - 1;
    let mut q = [0f32; 4];
    let mut sum = 0.0;
    for k in (0..4).rev() {
        if k != largest {
            let mag = comp & mask;
            let negative = (comp >> 9) & 1 == 1;
            comp >>= 10;
            let v = SQRT1_2 * mag as f32 / mask as f32;
            q[k] = if negative { -v } else { v };
            sum += q[k] * q[k];
        }
    }
    q[largest] = (1.0 - sum).max(0.0).sqrt();
    Quat::from_array(q)
}

/// Decodes an SPZ file's bytes (`path` names it in errors). SH degree 4 keeps bands 0 to 3
/// and says so in the report's notes.
pub fn decode(bytes: &[u8], path: &Path, axes: SpzAxes) -> Result<(Scene, LoadReport)> {
    let Blocks { header, blocks } = decompress(path, bytes)?;
    let [pos, alpha, color, scale, rot, sh] = &blocks;
    let degree = (header.sh_degree as u32).min(3);
    let mut scene = Scene {
        sh_degree: degree,
        ..Scene::default()
    };
    let n = header.count as usize;
    scene.means.reserve(n);
    scene.opacities.reserve(n);
    scene.scales.reserve(n);
    scene.rotations.reserve(n);
    scene.sh.reserve(n * 3 * sh_coeffs(degree));
    let unit = 1.0 / (1u32 << header.fractional_bits) as f32;
    let rest = header.sh_rest();
    let kept = sh_coeffs(degree) - 1;
    let mut coeffs = vec![0f32; 3 * sh_coeffs(degree)];
    let mut dropped = 0;
    for i in 0..n {
        let fixed = |k: usize| {
            let b = &pos[9 * i + 3 * k..9 * i + 3 * k + 3];
            // Sign-extend the 24-bit value through the top byte of an i32.
            (i32::from_le_bytes([0, b[0], b[1], b[2]]) >> 8) as f32 * unit
        };
        let mean = Vec3::new(fixed(0), fixed(1), fixed(2));
        let s = Vec3::from_array([0, 1, 2].map(|k| (scale[3 * i + k] as f32 / 16.0 - 10.0).exp()));
        let opacity = alpha[i] as f32 / 255.0;
        for c in 0..3 {
            coeffs[c] = (color[3 * i + c] as f32 / 255.0 - 0.5) / COLOR_SCALE;
        }
        for k in 0..kept {
            for c in 0..3 {
                coeffs[3 * (k + 1) + c] = (sh[3 * rest * i + 3 * k + c] as f32 - 128.0) / 128.0;
            }
        }
        push_decoded(
            &mut scene,
            &mut dropped,
            mean,
            s,
            opacity,
            rotation_of(&header, rot, i),
            &coeffs,
        );
    }
    flip_axes(&mut scene, axes.flips());
    let mut notes = vec![format!(
        "SPZ version {}, {} fractional bits, axes {}",
        header.version,
        header.fractional_bits,
        match axes {
            SpzAxes::Rub => "RUB (turned into rara's RDF)",
            SpzAxes::AsStored => "taken as stored",
        }
    )];
    if header.antialiased {
        notes.push(
            "the file's antialiased flag is set: the scene was trained with antialiasing \
             (Mip-Splatting's 2D filter); rara renders it with the 3DGS reference's fixed 0.3 \
             px dilation and no opacity compensation, so it looks slightly softer than in an \
             antialiasing renderer"
                .into(),
        );
    }
    if header.has_extensions {
        notes.push(
            "the file carries extension records, which rara skips (an extension naming other \
             axes than RUB is not applied)"
                .into(),
        );
    }
    if header.sh_degree > 3 {
        notes.push(format!(
            "SH degree {} in the file; rara keeps bands 0 to 3",
            header.sh_degree
        ));
    }
    Ok((
        scene,
        LoadReport {
            vertices_in_file: n,
            dropped_non_finite: dropped,
            encoding: "SPZ",
            notes,
        },
    ))
}

/// Reads an SPZ file.
pub fn read_spz(path: &Path, axes: SpzAxes) -> Result<(Scene, LoadReport)> {
    let bytes = crate::input::read_bounded(path, MAX_FILE_BYTES, "SPZ file")?;
    decode(&bytes, path, axes)
}

fn to_u8(x: f32) -> u8 {
    x.round().clamp(0.0, 255.0) as u8
}

/// The reference's SH quantisation: 8 bits, then rounded to the centre of a bucket of
/// `2^(8 - bits)` levels.
fn quantize_sh(x: f32, bits: u32) -> u8 {
    let bucket = 1i32 << (8 - bits);
    let q = ((x * 128.0).round() + 128.0) as i32;
    let q = (q + bucket / 2) / bucket * bucket;
    q.clamp(0, 255) as u8
}

fn smallest_three(q: Quat) -> [u8; 4] {
    let q = q.normalize().to_array();
    let largest = (1..4).fold(
        0,
        |best, k| {
            if q[k].abs() > q[best].abs() {
                k
            } else {
                best
            }
        },
    );
    let negate = q[largest] < 0.0;
    let mut comp = largest as u32;
    for (k, &v) in q.iter().enumerate() {
        if k != largest {
            let negbit = ((v < 0.0) ^ negate) as u32;
            let mag = (((1u32 << 9) - 1) as f32 * (v.abs() / SQRT1_2) + 0.5) as u32;
            comp = (comp << 10) | (negbit << 9) | mag.min((1 << 9) - 1);
        }
    }
    comp.to_le_bytes()
}

/// The attribute blocks of `scene` as SPZ packs them (rotations as smallest three).
fn pack(scene: &Scene, axes: SpzAxes) -> Result<[Vec<u8>; 6]> {
    let mut scene = scene.clone();
    flip_axes(&mut scene, axes.flips());
    let n = scene.len();
    let rest = scene.sh_coeffs_per_channel() - 1;
    let mut blocks: [Vec<u8>; 6] = [
        Vec::with_capacity(9 * n),
        Vec::with_capacity(n),
        Vec::with_capacity(3 * n),
        Vec::with_capacity(3 * n),
        Vec::with_capacity(4 * n),
        Vec::with_capacity(3 * rest * n),
    ];
    let unit = (1u32 << FRACTIONAL_BITS) as f32;
    let limit = ((1i32 << 23) - 1) as f32 / unit;
    for i in 0..n {
        let m = scene.means[i];
        if m.abs().max_element() > limit {
            return Err(Error::InvalidInput(format!(
                "Gaussian {i} lies at {m}, outside SPZ's +-{limit} units (24-bit positions \
                 with {FRACTIONAL_BITS} fractional bits)"
            )));
        }
        for v in m.to_array() {
            let fixed = (v * unit).round() as i32;
            blocks[0].extend_from_slice(&fixed.to_le_bytes()[..3]);
        }
        blocks[1].push(to_u8(scene.opacities[i] * 255.0));
        let sh = scene.sh_of(i);
        for &dc in &sh[..3] {
            blocks[2].push(to_u8(dc * (COLOR_SCALE * 255.0) + 0.5 * 255.0));
        }
        for s in scene.scales[i].to_array() {
            blocks[3].push(to_u8((s.ln() + 10.0) * 16.0));
        }
        blocks[4].extend_from_slice(&smallest_three(scene.rotations[i]));
        for k in 0..rest {
            let bits = if k < 3 { SH1_BITS } else { SH_REST_BITS };
            for c in 0..3 {
                blocks[5].push(quantize_sh(sh[3 * (k + 1) + c], bits));
            }
        }
    }
    Ok(blocks)
}

fn header_bytes(scene: &Scene, version: u32) -> Result<[u8; 16]> {
    let count = u32::try_from(scene.len())
        .ok()
        .filter(|&c| c > 0)
        .ok_or_else(|| {
            Error::InvalidInput(format!(
                "SPZ holds 1 to 2^32 - 1 Gaussians, and the scene has {}",
                scene.len()
            ))
        })?;
    let mut h = [0u8; 16];
    h[..4].copy_from_slice(&MAGIC.to_le_bytes());
    h[4..8].copy_from_slice(&version.to_le_bytes());
    h[8..12].copy_from_slice(&count.to_le_bytes());
    h[12] = scene.sh_degree as u8;
    h[13] = FRACTIONAL_BITS;
    // Flags: not antialiased (rara's scenes are plain 3DGS), no extensions.
    h[14] = 0;
    Ok(h)
}

/// `scene` as the bytes of an SPZ file.
pub fn encode(scene: &Scene, version: SpzVersion, axes: SpzAxes) -> Result<Vec<u8>> {
    let blocks = pack(scene, axes)?;
    let io = |e: std::io::Error| Error::InvalidInput(format!("SPZ: compressing: {e}"));
    match version {
        SpzVersion::V3 => {
            let mut gz = flate2::write::GzEncoder::new(Vec::new(), flate2::Compression::default());
            gz.write_all(&header_bytes(scene, 3)?).map_err(io)?;
            for block in &blocks {
                gz.write_all(block).map_err(io)?;
            }
            gz.finish().map_err(io)
        }
        SpzVersion::V4 => {
            let streams: Vec<Vec<u8>> = blocks
                .iter()
                .filter(|b| !b.is_empty())
                .map(|b| zstd::bulk::compress(b, 12).map_err(io))
                .collect::<Result<_>>()?;
            let sizes: Vec<u64> = blocks
                .iter()
                .filter(|b| !b.is_empty())
                .map(|b| b.len() as u64)
                .collect();
            let mut out = Vec::new();
            out.extend_from_slice(&header_bytes(scene, 4)?[..15]);
            out.push(streams.len() as u8);
            out.extend_from_slice(&32u32.to_le_bytes());
            out.extend_from_slice(&[0u8; 12]);
            for (s, &size) in streams.iter().zip(&sizes) {
                out.extend_from_slice(&(s.len() as u64).to_le_bytes());
                out.extend_from_slice(&size.to_le_bytes());
            }
            for s in &streams {
                out.extend_from_slice(s);
            }
            Ok(out)
        }
    }
}

/// Writes `scene` as an SPZ file.
pub fn write_spz(scene: &Scene, path: &Path, version: SpzVersion, axes: SpzAxes) -> Result<()> {
    let bytes = encode(scene, version, axes)?;
    std::fs::write(path, bytes).map_err(|source| Error::Io {
        path: path.to_path_buf(),
        source,
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The header's count against the input's size, at the edge of the inflation ratio: a
    /// count the bytes could hold inflated 1024 times is taken, one more is refused.
    #[test]
    fn the_count_is_bounded_by_the_inflation_ratio_at_its_edge() {
        let stored: u64 = 9000;
        let most = stored * MAX_INFLATION / 9;
        let header = |count: u64| {
            let mut h = [0u8; 16];
            h[..4].copy_from_slice(&MAGIC.to_le_bytes());
            h[4..8].copy_from_slice(&3u32.to_le_bytes());
            h[8..12].copy_from_slice(&(count as u32).to_le_bytes());
            h[13] = FRACTIONAL_BITS;
            h
        };
        let path = Path::new("x.spz");
        assert_eq!(
            parse_header(path, &header(most), stored).unwrap().count as u64,
            most
        );
        let e = parse_header(path, &header(most + 1), stored).unwrap_err();
        assert!(e.to_string().contains("does not fit in 9000 bytes"), "{e}");
    }
}
