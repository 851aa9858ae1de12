//! PlayCanvas's compressed PLY (SuperSplat's and splat-transform's `.compressed.ply`), read.
//!
//! A binary little-endian PLY with an `element chunk` (per 256 Gaussians: the bounds of the
//! centres and of the log scales, and optionally of the colours, as floats), an `element
//! vertex` of four packed u32 (`packed_position`, `packed_rotation`, `packed_scale`,
//! `packed_color`) and optionally an `element sh` of `f_rest_*` bytes. Decoding follows
//! splat-transform's `decompress-ply.ts` (in f64, rounded once to f32, as its arrays are):
//!
//! - centre and log scale: 11, 10 and 11 bits (x in the top bits), each `u / (2^bits - 1)`
//!   between the chunk's min and max;
//! - rotation: the index of the largest of `(w, x, y, z)` in the top two bits, the other three
//!   as 10 bits each, `(u / 1023 - 0.5) sqrt 2`, the largest from the unit length;
//! - colour: four bytes, red in the top one, `u / 255` (between the chunk's colour bounds when
//!   it has them), `f_dc = (c - 0.5) / C0`, and the last byte the opacity after the sigmoid;
//! - SH: byte 0 is 0, 255 is 1, else `(u + 0.5) / 256`, then `(n - 0.5) 8`; `f_rest_*` are
//!   channel major as in an INRIA PLY.

use std::io::Cursor;
use std::path::Path;

use glam::Vec3;
use ply_rs::ply::{Encoding, PropertyDef, PropertyType, ScalarType};

use super::{from_smallest_three_wxyz, push_decoded};
use crate::error::{Error, Result};
use crate::ply::LoadReport;
use crate::scene::Scene;

/// Gaussians per chunk.
const CHUNK: usize = 256;
/// The chunk's float properties, in the order rara reads them (12 always, 6 with colours).
const CHUNK_NAMES: [&str; 18] = [
    "min_x",
    "min_y",
    "min_z",
    "max_x",
    "max_y",
    "max_z",
    "min_scale_x",
    "min_scale_y",
    "min_scale_z",
    "max_scale_x",
    "max_scale_y",
    "max_scale_z",
    "min_r",
    "min_g",
    "min_b",
    "max_r",
    "max_g",
    "max_b",
];
/// The vertex's packed words.
const VERTEX_NAMES: [&str; 4] = [
    "packed_position",
    "packed_rotation",
    "packed_scale",
    "packed_color",
];
const SH_C0: f64 = 0.282_094_791_773_878_14;
/// The largest compressed PLY rara reads.
pub const MAX_FILE_BYTES: u64 = 4 << 30;

fn bad(path: &Path, message: impl std::fmt::Display) -> Error {
    Error::Ply {
        path: path.to_path_buf(),
        message: format!("compressed PLY: {message}"),
    }
}

/// Where each named property sits in an element's row of scalars of one type.
fn columns(
    path: &Path,
    element: &str,
    properties: &[&PropertyDef],
    names: &[&str],
    scalar: ScalarType,
) -> Result<Vec<usize>> {
    for p in properties {
        if p.data_type != PropertyType::Scalar(scalar.clone()) {
            return Err(bad(
                path,
                format!(
                    "'{element}' property '{}' is {:?}, where the format has {scalar:?}",
                    p.name, p.data_type
                ),
            ));
        }
    }
    names
        .iter()
        .map(|name| {
            properties
                .iter()
                .position(|p| p.name == *name)
                .ok_or_else(|| bad(path, format!("'{element}' has no property '{name}'")))
        })
        .collect()
}

fn unorm(v: u32, shift: u32, bits: u32) -> f64 {
    let max = (1u32 << bits) - 1;
    ((v >> shift) & max) as f64 / max as f64
}

fn lerp(a: f32, b: f32, t: f64) -> f64 {
    a as f64 * (1.0 - t) + b as f64 * t
}

/// Reads a compressed PLY.
pub fn read_compressed_ply(path: &Path) -> Result<(Scene, LoadReport)> {
    let bytes = crate::input::read_bounded(path, MAX_FILE_BYTES, "compressed PLY")?;
    decode(&bytes, path)
}

/// Decodes a compressed PLY's bytes (`path` names it in errors).
pub fn decode(bytes: &[u8], path: &Path) -> Result<(Scene, LoadReport)> {
    let mut cursor = Cursor::new(bytes);
    let (header_bytes, header) = crate::ply::read_header(path, &mut cursor)?;
    if header.encoding != Encoding::BinaryLittleEndian {
        return Err(bad(
            path,
            "the format is binary_little_endian, and this file is not",
        ));
    }
    let elements: Vec<_> = header.elements.values().collect();
    let names: Vec<&str> = elements.iter().map(|e| e.name.as_str()).collect();
    if names != ["chunk", "vertex"] && names != ["chunk", "vertex", "sh"] {
        return Err(bad(
            path,
            format!("elements {names:?}, where the format has chunk, vertex and optionally sh"),
        ));
    }
    let props = |k: usize| elements[k].properties.values().collect::<Vec<_>>();
    let (chunk_props, vertex_props) = (props(0), props(1));
    let with_colour = match chunk_props.len() {
        12 => false,
        18 => true,
        n => {
            return Err(bad(
                path,
                format!("a chunk has {n} properties, where the format has 12 or 18"),
            ))
        }
    };
    let chunk_cols = columns(
        path,
        "chunk",
        &chunk_props,
        &CHUNK_NAMES[..chunk_props.len()],
        ScalarType::Float,
    )?;
    if vertex_props.len() != 4 {
        return Err(bad(
            path,
            format!(
                "a vertex has {} properties, where the format has the 4 packed words",
                vertex_props.len()
            ),
        ));
    }
    let vertex_cols = columns(
        path,
        "vertex",
        &vertex_props,
        &VERTEX_NAMES,
        ScalarType::UInt,
    )?;
    let (sh_rest, sh_cols) = if elements.len() == 3 {
        let sh_props = props(2);
        let rest = sh_props.len();
        if ![9, 24, 45].contains(&rest) {
            return Err(bad(
                path,
                format!("an sh row has {rest} bytes, where degrees 1 to 3 have 9, 24 or 45"),
            ));
        }
        if elements[2].count != elements[1].count {
            return Err(bad(
                path,
                format!(
                    "{} sh rows for {} vertices",
                    elements[2].count, elements[1].count
                ),
            ));
        }
        let wanted: Vec<String> = (0..rest).map(|k| format!("f_rest_{k}")).collect();
        let wanted: Vec<&str> = wanted.iter().map(String::as_str).collect();
        (
            rest,
            columns(path, "sh", &sh_props, &wanted, ScalarType::UChar)?,
        )
    } else {
        (0, Vec::new())
    };
    let (chunks, n) = (elements[0].count, elements[1].count);
    if n.div_ceil(CHUNK) != chunks {
        return Err(bad(
            path,
            format!("{chunks} chunks for {n} vertices (one per {CHUNK})"),
        ));
    }
    // The sizes are checked against the file before anything is allocated for them.
    let chunk_row = 4 * chunk_props.len();
    let vertex_row = 16usize;
    let need = [
        chunks as u128 * chunk_row as u128,
        n as u128 * vertex_row as u128,
        n as u128 * sh_rest as u128,
    ];
    let payload = (bytes.len() - header_bytes.len()) as u128;
    if need.iter().sum::<u128>() != payload {
        return Err(bad(
            path,
            format!(
                "{payload} bytes after the header, where {chunks} chunks, {n} vertices and \
                 their SH take {}{}",
                need.iter().sum::<u128>(),
                if need.iter().sum::<u128>() > payload {
                    " (truncated)"
                } else {
                    ""
                }
            ),
        ));
    }
    let data = &bytes[header_bytes.len()..];
    let (chunk_data, rest) = data.split_at(need[0] as usize);
    let (vertex_data, sh_data) = rest.split_at(need[1] as usize);
    let f32_at = |b: &[u8], at: usize| f32::from_le_bytes(b[at..at + 4].try_into().unwrap());
    let u32_at = |b: &[u8], at: usize| u32::from_le_bytes(b[at..at + 4].try_into().unwrap());

    let degree = match sh_rest {
        0 => 0,
        9 => 1,
        24 => 2,
        _ => 3,
    };
    let mut scene = Scene {
        sh_degree: degree,
        ..Scene::default()
    };
    let per_channel = sh_rest / 3;
    let mut sh = vec![0f32; 3 * (per_channel + 1)];
    let mut dropped = 0;
    for i in 0..n {
        let c = i / CHUNK;
        let ch = |k: usize| f32_at(chunk_data, c * chunk_row + 4 * chunk_cols[k]);
        let word = |k: usize| u32_at(vertex_data, i * vertex_row + 4 * vertex_cols[k]);
        let (p, r, s, col) = (word(0), word(1), word(2), word(3));
        let t = [unorm(p, 21, 11), unorm(p, 11, 10), unorm(p, 0, 11)];
        let mean = Vec3::from_array([0, 1, 2].map(|k| lerp(ch(k), ch(k + 3), t[k]) as f32));
        let t = [unorm(s, 21, 11), unorm(s, 11, 10), unorm(s, 0, 11)];
        let scale =
            Vec3::from_array([0, 1, 2].map(|k| (lerp(ch(6 + k), ch(9 + k), t[k]) as f32).exp()));
        let norm = std::f64::consts::SQRT_2;
        let abc = [20, 10, 0].map(|shift| (unorm(r, shift, 10) - 0.5) * norm);
        let rotation = from_smallest_three_wxyz((r >> 30) as usize, abc);
        let rgba = [24, 16, 8, 0].map(|shift| unorm(col, shift, 8));
        for k in 0..3 {
            let v = if with_colour {
                lerp(ch(12 + k), ch(15 + k), rgba[k])
            } else {
                rgba[k]
            };
            sh[k] = ((v - 0.5) / SH_C0) as f32;
        }
        for ch_index in 0..3 {
            for j in 0..per_channel {
                let u = sh_data[i * sh_rest + sh_cols[ch_index * per_channel + j]];
                let t = match u {
                    0 => 0.0,
                    255 => 1.0,
                    u => (u as f64 + 0.5) / 256.0,
                };
                sh[3 * (j + 1) + ch_index] = ((t - 0.5) * 8.0) as f32;
            }
        }
        push_decoded(
            &mut scene,
            &mut dropped,
            mean,
            scale,
            rgba[3] as f32,
            rotation,
            &sh,
        );
    }
    let comment = header
        .comments
        .iter()
        .find(|c| c.starts_with("Generated by"))
        .map(|c| {
            format!(
                "written by {}",
                c.trim_start_matches("Generated by ").trim()
            )
        });
    Ok((
        scene,
        LoadReport {
            vertices_in_file: n,
            dropped_non_finite: dropped,
            encoding: "PlayCanvas compressed PLY",
            notes: comment.into_iter().collect(),
        },
    ))
}
