//! glTF 2.0 with `KHR_gaussian_splatting` (the ratified extension, Khronos glTF repository,
//! `extensions/2.0/Khronos/KHR_gaussian_splatting`), read from `.glb` or `.gltf` and written as
//! `.glb`; and `KHR_gaussian_splatting_compression_spz_2` read.
//!
//! A splat primitive is a `POINTS` primitive with the extension: `POSITION`,
//! `KHR_gaussian_splatting:ROTATION` (unit quaternion, `x y z w`), `:SCALE` (linear, not
//! negative), `:OPACITY` (after the sigmoid, in `[0, 1]`), `:SH_DEGREE_0_COEF_0` and
//! `:SH_DEGREE_l_COEF_n` (RGB per coefficient); `COLOR_0` (`0.5 + C0 f_dc` and the opacity) is
//! the fallback for a file without the SH or opacity attributes. Accessors may be floats or
//! normalised integers. Each primitive is placed by its node's world transform (a similarity:
//! rotation, translation and one positive scale; the SH turn with the rotation).
//!
//! - **Draft-era files.** splat-transform wrote `:SCALE` as the log scale before its fix for
//!   issue #267 (PR #268, June 2026), and drafts of the extension said so. A file with a
//!   negative scale cannot be linear: its scales are read as logs, and the report says so.
//! - **SPZ compression.** With `KHR_gaussian_splatting_compression_spz_2` the attributes'
//!   accessors carry no data and the extension's `bufferView` holds an SPZ file, decoded by
//!   [`super::spz`] (the extension asks for its data in glTF's LUF axes; RUB to LUF and LUF
//!   to rara's RDF are the two halves of SPZ's usual RUB to RDF turn).
//! - **Axes.** glTF is +Y up, +Z forward, +X left (LUF); rara's scenes are in the INRIA PLY's
//!   RDF, so centres, rotations and SH turn half a turn about z on the way in and out (as
//!   splat-transform's writer does).
//! - The Gaussians of every splat primitive in the default scene (or every scene, where none is
//!   the default) are joined, in the order the nodes are walked; they must share one SH
//!   degree, else the lower is kept.

use std::collections::HashMap;
use std::path::Path;

use glam::{DMat4, Quat, Vec3};
use serde_json::{json, Value};

use super::{flip_axes, push_decoded};
use crate::error::{Error, Result};
use crate::input::gltf::{bad, check_placed, Document};
use crate::ply::LoadReport;
use crate::scene::{sh_coeffs, Scene};
use crate::sh::SH_C0;

/// The extension's name and its attribute prefix.
const EXT: &str = "KHR_gaussian_splatting";
/// The SPZ compression extension.
const EXT_SPZ: &str = "KHR_gaussian_splatting_compression_spz_2";
/// glTF's LUF against rara's RDF: x and y point the other way.
const GLTF_FLIPS: [bool; 3] = [true, true, false];
/// One decoded splat primitive, in glTF's axes and the mesh's own frame.
fn read_primitive(
    doc: &Document,
    path: &Path,
    mesh: usize,
    primitive: &Value,
    notes: &mut Vec<String>,
    dropped: &mut usize,
) -> Result<Option<Scene>> {
    let Some(ext) = primitive.pointer(&format!("/extensions/{EXT}")) else {
        return Ok(None);
    };
    let attributes: HashMap<String, usize> = primitive
        .get("attributes")
        .and_then(Value::as_object)
        .map(|m| {
            m.iter()
                .filter_map(|(k, v)| Some((k.clone(), v.as_u64()? as usize)))
                .collect()
        })
        .unwrap_or_default();
    let attribute = |name: &str| attributes.get(name).copied();
    let position = attribute("POSITION").ok_or_else(|| {
        bad(
            path,
            format!("mesh {mesh}: a splat primitive without POSITION"),
        )
    })?;
    let n = doc.count(position)?;

    if let Some(spz) = ext.pointer(&format!("/extensions/{EXT_SPZ}")) {
        let view = spz
            .get("bufferView")
            .and_then(Value::as_u64)
            .ok_or_else(|| bad(path, format!("mesh {mesh}: {EXT_SPZ} without a bufferView")))?;
        let (bytes, _) = doc.view(usize::try_from(view).unwrap_or(usize::MAX))?;
        let (mut scene, report) = super::spz::decode(bytes, path, super::spz::SpzAxes::Rub)?;
        if scene.len() + report.dropped_non_finite != n {
            return Err(bad(
                path,
                format!(
                    "mesh {mesh}: the SPZ data holds {} Gaussians and POSITION's accessor {n}",
                    report.vertices_in_file
                ),
            ));
        }
        *dropped += report.dropped_non_finite;
        notes.push(format!(
            "mesh {mesh}: {EXT_SPZ} ({})",
            report.notes.join("; ")
        ));
        flip_axes(&mut scene, GLTF_FLIPS);
        return Ok(Some(scene));
    }

    let floats = |name: &str, components: usize| -> Result<Option<Vec<f32>>> {
        let Some(index) = attribute(name) else {
            return Ok(None);
        };
        let data = doc.floats(index, components)?;
        if data.len() != n * components {
            return Err(bad(
                path,
                format!(
                    "mesh {mesh}: {name} has {} elements for {n} Gaussians",
                    data.len() / components
                ),
            ));
        }
        Ok(Some(data))
    };
    let positions = floats("POSITION", 3)?.unwrap_or_default();
    let need = |name: &str, components: usize| -> Result<Vec<f32>> {
        floats(&format!("{EXT}:{name}"), components)?.ok_or_else(|| {
            bad(
                path,
                format!("mesh {mesh}: a splat primitive without {EXT}:{name}"),
            )
        })
    };
    let rotations = need("ROTATION", 4)?;
    let mut scales = need("SCALE", 3)?;
    let color = floats("COLOR_0", 4)?;
    let opacity = match floats(&format!("{EXT}:OPACITY"), 1)? {
        Some(o) => o,
        None => {
            let c = color.as_ref().ok_or_else(|| {
                bad(
                    path,
                    format!("mesh {mesh}: neither {EXT}:OPACITY nor COLOR_0"),
                )
            })?;
            c.chunks_exact(4).map(|c| c[3]).collect()
        }
    };
    let dc = match floats(&format!("{EXT}:SH_DEGREE_0_COEF_0"), 3)? {
        Some(d) => d,
        None => {
            let c = color.as_ref().ok_or_else(|| {
                bad(
                    path,
                    format!("mesh {mesh}: neither {EXT}:SH_DEGREE_0_COEF_0 nor COLOR_0"),
                )
            })?;
            c.chunks_exact(4)
                .flat_map(|c| [0, 1, 2].map(|k| (c[k] - 0.5) / SH_C0))
                .collect()
        }
    };
    let mut degree = 0;
    let mut rest: Vec<Vec<f32>> = Vec::new();
    for l in 1..=3u32 {
        let band: Vec<Option<Vec<f32>>> = (0..2 * l + 1)
            .map(|c| floats(&format!("{EXT}:SH_DEGREE_{l}_COEF_{c}"), 3))
            .collect::<Result<_>>()?;
        if band.iter().all(Option::is_some) {
            degree = l;
            rest.extend(band.into_iter().flatten());
        } else {
            if band.iter().any(Option::is_some) {
                notes.push(format!(
                    "mesh {mesh}: SH degree {l} is incomplete; rara keeps degrees 0 to {}",
                    l - 1
                ));
            }
            break;
        }
    }
    // A scale below zero cannot be linear: a draft-era file with log scales.
    if scales.iter().any(|&s| s < 0.0) {
        notes.push(format!(
            "mesh {mesh}: negative {EXT}:SCALE values, so its scales are logs (a draft-era file, \
             as splat-transform wrote before its issue #267): read as exp(scale)"
        ));
        for s in &mut scales {
            *s = s.exp();
        }
    }
    let logit_opacity = opacity.iter().any(|&o| !(0.0..=1.0).contains(&o));
    if logit_opacity {
        notes.push(format!(
            "mesh {mesh}: {EXT}:OPACITY values outside [0, 1], so they are logits (a draft-era \
             file): read through the sigmoid"
        ));
    }
    let mut scene = Scene {
        sh_degree: degree,
        ..Scene::default()
    };
    let mut sh = vec![0f32; 3 * sh_coeffs(degree)];
    for i in 0..n {
        sh[..3].copy_from_slice(&dc[3 * i..3 * i + 3]);
        for (k, coeff) in rest.iter().enumerate() {
            sh[3 * (k + 1)..3 * (k + 2)].copy_from_slice(&coeff[3 * i..3 * i + 3]);
        }
        let o = if logit_opacity {
            1.0 / (1.0 + (-opacity[i]).exp())
        } else {
            opacity[i]
        };
        let q = &rotations[4 * i..4 * i + 4];
        push_decoded(
            &mut scene,
            dropped,
            Vec3::from_slice(&positions[3 * i..3 * i + 3]),
            Vec3::from_slice(&scales[3 * i..3 * i + 3]),
            o,
            Quat::from_xyzw(q[0], q[1], q[2], q[3]),
            &sh,
        );
    }
    Ok(Some(scene))
}

/// `a` and `b` joined (at the lower SH degree of the two).
fn join(a: Scene, b: Scene) -> Scene {
    if a.is_empty() {
        return b;
    }
    let degree = a.sh_degree.min(b.sh_degree);
    let (mut a, b) = (a.with_sh_degree(degree), b.with_sh_degree(degree));
    a.means.extend(b.means);
    a.opacities.extend(b.opacities);
    a.scales.extend(b.scales);
    a.rotations.extend(b.rotations);
    a.sh.extend(b.sh);
    a
}

/// Reads the Gaussians of a `.glb` or `.gltf`.
pub fn read_gltf(path: &Path) -> Result<(Scene, LoadReport)> {
    decode_gltf(&Document::open(path)?, path)
}

/// Reads the Gaussians of a `.glb` or `.gltf` whose bytes were read already (from `path`, whose
/// folder holds the buffers a `.gltf` names).
pub fn read_gltf_bytes(bytes: &[u8], path: &Path) -> Result<(Scene, LoadReport)> {
    decode_gltf(&Document::from_bytes(bytes, path)?, path)
}

/// The splat primitives of `doc`: where each is placed (node, mesh, world matrix), checked
/// against [`crate::constants::MAX_GAUSSIANS`] before any is decoded, so that a small file
/// that places one primitive under many nodes is refused rather than decoded many times.
fn placements(doc: &Document, path: &Path) -> Result<Vec<(usize, usize, DMat4)>> {
    let meshes = doc.raw.get("meshes").and_then(Value::as_array);
    let placed = doc.placed_meshes()?;
    let mut total: u64 = 0;
    for &(index, mesh, _) in &placed {
        let primitives = meshes
            .and_then(|m| m.get(mesh))
            .and_then(|m| m.get("primitives"))
            .and_then(Value::as_array)
            .ok_or_else(|| bad(path, format!("node {index} names a missing mesh {mesh}")))?;
        for primitive in primitives {
            if primitive.pointer(&format!("/extensions/{EXT}")).is_none() {
                continue;
            }
            let count = primitive
                .pointer("/attributes/POSITION")
                .and_then(Value::as_u64)
                .map(|a| doc.count(usize::try_from(a).unwrap_or(usize::MAX)))
                .transpose()?
                .unwrap_or(0);
            total = total.saturating_add(count as u64);
        }
    }
    check_placed(total, crate::constants::MAX_GAUSSIANS, "Gaussians", path)?;
    Ok(placed)
}

fn decode_gltf(doc: &Document, path: &Path) -> Result<(Scene, LoadReport)> {
    let meshes = doc.raw.get("meshes").and_then(Value::as_array);
    let mut notes = Vec::new();
    let mut dropped = 0;
    let mut scene = Scene::default();
    let mut found = 0;
    for (index, mesh, world) in placements(doc, path)? {
        let primitives = meshes
            .and_then(|m| m.get(mesh))
            .and_then(|m| m.get("primitives"))
            .and_then(Value::as_array)
            .map(Vec::as_slice)
            .unwrap_or_default();
        for primitive in primitives {
            let Some(part) = read_primitive(doc, path, mesh, primitive, &mut notes, &mut dropped)?
            else {
                continue;
            };
            found += 1;
            let part = if world == DMat4::IDENTITY {
                part
            } else {
                let world = world.as_mat4();
                let (s, r, t) = world.to_scale_rotation_translation();
                let uniform =
                    (s.max_element() - s.min_element()).abs() <= 1e-4 * s.max_element().abs();
                if !(uniform && s.min_element() > 0.0 && world.determinant() > 0.0) {
                    return Err(bad(
                        path,
                        format!(
                            "node {index} scales its splats by {s} (a Gaussian takes one \
                             positive scale, not a stretch or a mirror)"
                        ),
                    ));
                }
                crate::mixed::moved(
                    &part,
                    &crate::mixed::Transform {
                        rotation: r,
                        translation: t,
                        scale: Vec3::splat(s.x),
                    },
                )
            };
            scene = join(scene, part);
        }
    }
    if found == 0 {
        return Err(bad(
            path,
            format!(
                "no {EXT} primitive in the scene (a plain mesh is read by `rara render --scene`)"
            ),
        ));
    }
    flip_axes(&mut scene, GLTF_FLIPS);
    let n = scene.len() + dropped;
    Ok((
        scene,
        LoadReport {
            vertices_in_file: n,
            dropped_non_finite: dropped,
            encoding: "glTF KHR_gaussian_splatting",
            notes,
        },
    ))
}

/// `scene` as a `.glb` with one `KHR_gaussian_splatting` primitive (the ratified layout:
/// float positions, unit `x y z w` rotations, linear scales, opacities after the sigmoid, SH
/// per coefficient, and `COLOR_0` as 8-bit `0.5 + C0 f_dc` and opacity for viewers that read
/// only it).
pub fn encode_glb(scene: &Scene) -> Result<Vec<u8>> {
    let mut scene = scene.clone();
    flip_axes(&mut scene, GLTF_FLIPS);
    let n = scene.len();
    let mut bin: Vec<u8> = Vec::new();
    let mut views = Vec::new();
    let mut accessors = Vec::new();
    let mut attributes = serde_json::Map::new();
    let mut push = |name: String,
                    bytes: Vec<u8>,
                    ty: &str,
                    component: u32,
                    normalized: bool,
                    bounds: Option<(Vec3, Vec3)>| {
        while bin.len() % 4 != 0 {
            bin.push(0);
        }
        views.push(json!({"buffer": 0, "byteOffset": bin.len(), "byteLength": bytes.len(), "target": 34962}));
        let mut accessor = json!({"bufferView": views.len() - 1, "componentType": component, "count": n, "type": ty});
        if normalized {
            accessor["normalized"] = json!(true);
        }
        if let Some((lo, hi)) = bounds {
            accessor["min"] = json!(lo.to_array());
            accessor["max"] = json!(hi.to_array());
        }
        accessors.push(accessor);
        attributes.insert(name, json!(accessors.len() - 1));
        bin.extend_from_slice(&bytes);
    };
    const FLOAT: u32 = 5126;
    const UNSIGNED_BYTE: u32 = 5121;
    let floats = |values: &mut dyn Iterator<Item = f32>| -> Vec<u8> {
        values.flat_map(f32::to_le_bytes).collect()
    };
    let lo = scene
        .means
        .iter()
        .fold(Vec3::splat(f32::INFINITY), |a, &m| a.min(m));
    let hi = scene
        .means
        .iter()
        .fold(Vec3::splat(f32::NEG_INFINITY), |a, &m| a.max(m));
    push(
        "POSITION".into(),
        floats(&mut scene.means.iter().flat_map(|m| m.to_array())),
        "VEC3",
        FLOAT,
        false,
        Some((lo, hi)),
    );
    let byte = |x: f32| (x * 255.0).round().clamp(0.0, 255.0) as u8;
    let colour: Vec<u8> = (0..n)
        .flat_map(|i| {
            let sh = scene.sh_of(i);
            [
                byte(0.5 + SH_C0 * sh[0]),
                byte(0.5 + SH_C0 * sh[1]),
                byte(0.5 + SH_C0 * sh[2]),
                byte(scene.opacities[i]),
            ]
        })
        .collect();
    push("COLOR_0".into(), colour, "VEC4", UNSIGNED_BYTE, true, None);
    push(
        format!("{EXT}:ROTATION"),
        floats(
            &mut scene
                .rotations
                .iter()
                .flat_map(|q| q.normalize().to_array()),
        ),
        "VEC4",
        FLOAT,
        false,
        None,
    );
    push(
        format!("{EXT}:SCALE"),
        floats(&mut scene.scales.iter().flat_map(|s| s.to_array())),
        "VEC3",
        FLOAT,
        false,
        None,
    );
    push(
        format!("{EXT}:OPACITY"),
        floats(&mut scene.opacities.iter().copied()),
        "SCALAR",
        FLOAT,
        false,
        None,
    );
    let stride = scene.sh_stride();
    let mut k = 0;
    for l in 0..=scene.sh_degree {
        for c in 0..2 * l + 1 {
            let column = floats(
                &mut (0..n)
                    .flat_map(|i| scene.sh[i * stride + 3 * k..i * stride + 3 * k + 3].to_vec()),
            );
            push(
                format!("{EXT}:SH_DEGREE_{l}_COEF_{c}"),
                column,
                "VEC3",
                FLOAT,
                false,
                None,
            );
            k += 1;
        }
    }
    while bin.len() % 4 != 0 {
        bin.push(0);
    }
    let document = json!({
        "asset": {"version": "2.0", "generator": concat!("rara ", env!("CARGO_PKG_VERSION"))},
        "extensionsUsed": [EXT],
        "scene": 0,
        "scenes": [{"nodes": [0]}],
        "nodes": [{"mesh": 0}],
        "meshes": [{"primitives": [{
            "attributes": attributes,
            "mode": 0,
            "extensions": {EXT: {
                "kernel": "ellipse",
                "colorSpace": "srgb_rec709_display",
                "sortingMethod": "cameraDistance",
                "projection": "perspective"
            }}
        }]}],
        "buffers": [{"byteLength": bin.len()}],
        "bufferViews": views,
        "accessors": accessors,
    });
    let json_bytes =
        serde_json::to_vec(&document).map_err(|e| Error::InvalidInput(format!("glTF: {e}")))?;
    let glb = gltf::Glb {
        header: gltf::binary::Header {
            magic: *b"glTF",
            version: 2,
            length: 0,
        },
        json: json_bytes.into(),
        bin: Some(bin.into()),
    };
    glb.to_vec()
        .map_err(|e| Error::InvalidInput(format!("glTF: {e}")))
}

/// Writes `scene` as a `.glb`.
pub fn write_glb(scene: &Scene, path: &Path) -> Result<()> {
    let bytes = encode_glb(scene)?;
    std::fs::write(path, bytes).map_err(|source| Error::Io {
        path: path.to_path_buf(),
        source,
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A document whose one splat primitive (POSITION of `count`) is placed by `nodes` nodes.
    fn placed_by(count: u64, nodes: usize) -> Document {
        let v = json!({
            "asset": {"version": "2.0"},
            "scene": 0,
            "scenes": [{"nodes": [0]}],
            "nodes": std::iter::once(json!({"children": (1..=nodes).collect::<Vec<_>>()}))
                .chain((0..nodes).map(|_| json!({"mesh": 0})))
                .collect::<Vec<_>>(),
            "meshes": [{"primitives": [{"attributes": {"POSITION": 0}, "mode": 0,
                "extensions": {EXT: {}}}]}],
            "accessors": [{"bufferView": 0, "componentType": 5126, "count": count, "type": "VEC3"}]
        });
        Document::from_bytes(&serde_json::to_vec(&v).unwrap(), Path::new("t.gltf")).unwrap()
    }

    #[test]
    fn the_gaussians_nodes_place_are_bounded_at_the_edge() {
        let most = crate::constants::MAX_GAUSSIANS;
        // 67,107,840 = 1024 x 65535: exactly the most, accepted (nothing is decoded here);
        // one node more is refused.
        assert_eq!(most, 1024 * 65535);
        let path = Path::new("t.gltf");
        assert_eq!(
            placements(&placed_by(65535, 1024), path).unwrap().len(),
            1024
        );
        let e = placements(&placed_by(65535, 1025), path).unwrap_err();
        assert!(e.to_string().contains("67173375 Gaussians"), "{e}");
        check_placed(most, most, "Gaussians", path).unwrap();
        assert!(check_placed(most + 1, most, "Gaussians", path).is_err());
    }
}
