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

use glam::{Mat4, Quat, Vec3};
use gltf::json;
use serde_json::{json, Value};

use super::{flip_axes, push_decoded, read_file_bounded};
use crate::error::{Error, Result};
use crate::ply::LoadReport;
use crate::scene::{sh_coeffs, Scene};

/// The extension's name and its attribute prefix.
const EXT: &str = "KHR_gaussian_splatting";
/// The SPZ compression extension.
const EXT_SPZ: &str = "KHR_gaussian_splatting_compression_spz_2";
const SH_C0: f32 = 0.282_094_8;
/// glTF's LUF against rara's RDF: x and y point the other way.
const GLTF_FLIPS: [bool; 3] = [true, true, false];
/// The largest glTF file (or buffer file) rara reads.
const MAX_FILE_BYTES: u64 = 4 << 30;

fn bad(path: &Path, message: impl std::fmt::Display) -> Error {
    Error::InvalidInput(format!("{}: glTF: {message}", path.display()))
}

/// The document and its buffers.
struct Document {
    root: json::Root,
    /// The raw JSON, for what `gltf-json` cannot name: the extension's attribute semantics.
    raw: Value,
    buffers: Vec<Vec<u8>>,
}

fn load(path: &Path) -> Result<Document> {
    let bytes = read_file_bounded(path, MAX_FILE_BYTES)?;
    let (json_bytes, bin) = if bytes.starts_with(b"glTF") {
        // The header's length first, so a cut file says so rather than what the chunk
        // parser trips on.
        if let Some(length) = bytes.get(8..12) {
            let length = u32::from_le_bytes(length.try_into().unwrap()) as usize;
            if length > bytes.len() {
                return Err(bad(
                    path,
                    format!(
                        "the glb header gives {length} bytes and the file has {} (truncated)",
                        bytes.len()
                    ),
                ));
            }
        }
        let glb = gltf::Glb::from_slice(&bytes).map_err(|e| bad(path, e))?;
        (glb.json.into_owned(), glb.bin.map(|b| b.into_owned()))
    } else {
        (bytes, None)
    };
    let raw: Value = serde_json::from_slice(&json_bytes).map_err(|e| bad(path, e))?;
    let root: json::Root = serde_json::from_value(raw.clone()).map_err(|e| bad(path, e))?;
    let mut bin = bin;
    let mut buffers = Vec::new();
    for (i, b) in root.buffers.iter().enumerate() {
        let data = match &b.uri {
            None => bin.take().ok_or_else(|| {
                bad(
                    path,
                    format!("buffer {i} has no uri and the file no BIN chunk"),
                )
            })?,
            Some(uri) if uri.starts_with("data:") => {
                let (_, encoded) = uri.split_once(";base64,").ok_or_else(|| {
                    bad(path, format!("buffer {i}: a data URI that is not base64"))
                })?;
                use base64::Engine;
                base64::engine::general_purpose::STANDARD
                    .decode(encoded)
                    .map_err(|e| bad(path, format!("buffer {i}: {e}")))?
            }
            Some(uri) => {
                if uri.contains("..") || uri.starts_with('/') || uri.contains(':') {
                    return Err(bad(
                        path,
                        format!("buffer {i}'s uri '{uri}' leaves the file's folder"),
                    ));
                }
                read_file_bounded(
                    &path.parent().unwrap_or(Path::new(".")).join(uri),
                    MAX_FILE_BYTES,
                )?
            }
        };
        if (data.len() as u64) < b.byte_length.0 {
            return Err(bad(
                path,
                format!(
                    "buffer {i} holds {} bytes where its byteLength says {}",
                    data.len(),
                    b.byte_length.0
                ),
            ));
        }
        buffers.push(data);
    }
    Ok(Document { root, raw, buffers })
}

impl Document {
    /// The bytes of buffer view `view`.
    fn view(&self, path: &Path, view: usize) -> Result<(&[u8], Option<usize>)> {
        let v = self
            .root
            .buffer_views
            .get(view)
            .ok_or_else(|| bad(path, format!("no buffer view {view}")))?;
        let buffer = self
            .buffers
            .get(v.buffer.value())
            .ok_or_else(|| bad(path, format!("buffer view {view} names a missing buffer")))?;
        let start = v.byte_offset.map_or(0, |o| o.0) as usize;
        let end = start
            .checked_add(v.byte_length.0 as usize)
            .filter(|&e| e <= buffer.len())
            .ok_or_else(|| bad(path, format!("buffer view {view} runs past its buffer")))?;
        Ok((&buffer[start..end], v.byte_stride.map(|s| s.0)))
    }

    /// Accessor `index` as `components` floats per element (normalised integers mapped to
    /// `[0, 1]` or `[-1, 1]`), and its count.
    fn floats(&self, path: &Path, index: usize, components: usize) -> Result<Vec<f32>> {
        use json::accessor::{ComponentType as C, Type};
        let a = self
            .root
            .accessors
            .get(index)
            .ok_or_else(|| bad(path, format!("no accessor {index}")))?;
        let want = match components {
            1 => Type::Scalar,
            3 => Type::Vec3,
            _ => Type::Vec4,
        };
        let json::validation::Checked::Valid(ty) = a.type_ else {
            return Err(bad(path, format!("accessor {index} has an unknown type")));
        };
        if ty != want {
            return Err(bad(
                path,
                format!("accessor {index} is {ty:?}, where {want:?} is needed"),
            ));
        }
        let json::validation::Checked::Valid(json::accessor::GenericComponentType(ct)) =
            a.component_type
        else {
            return Err(bad(
                path,
                format!("accessor {index} has an unknown component type"),
            ));
        };
        if a.sparse.is_some() {
            return Err(bad(
                path,
                format!("accessor {index} is sparse, which rara does not read"),
            ));
        }
        if ct != C::F32 && !a.normalized {
            return Err(bad(
                path,
                format!("accessor {index} holds {ct:?} that are not normalized"),
            ));
        }
        let size = match ct {
            C::I8 | C::U8 => 1,
            C::I16 | C::U16 => 2,
            C::U32 | C::F32 => 4,
        };
        let count = a.count.0 as usize;
        let view = a
            .buffer_view
            .ok_or_else(|| bad(path, format!("accessor {index} has no buffer view")))?;
        let (data, stride) = self.view(path, view.value())?;
        let element = size * components;
        let stride = stride.unwrap_or(element);
        let offset = a.byte_offset.map_or(0, |o| o.0) as usize;
        let need = if count == 0 {
            0
        } else {
            (count - 1)
                .checked_mul(stride)
                .and_then(|s| s.checked_add(offset + element))
                .unwrap_or(usize::MAX)
        };
        if stride < element || need > data.len() {
            return Err(bad(
                path,
                format!(
                    "accessor {index}: {count} elements of {element} bytes do not fit in its \
                     buffer view of {} bytes",
                    data.len()
                ),
            ));
        }
        let mut out = Vec::with_capacity(count * components);
        for i in 0..count {
            for k in 0..components {
                let at = offset + i * stride + k * size;
                let b = &data[at..at + size];
                out.push(match ct {
                    C::F32 => f32::from_le_bytes(b.try_into().unwrap()),
                    C::U8 => b[0] as f32 / 255.0,
                    C::I8 => (b[0] as i8 as f32 / 127.0).max(-1.0),
                    C::U16 => u16::from_le_bytes(b.try_into().unwrap()) as f32 / 65535.0,
                    C::I16 => {
                        (i16::from_le_bytes(b.try_into().unwrap()) as f32 / 32767.0).max(-1.0)
                    }
                    C::U32 => u32::from_le_bytes(b.try_into().unwrap()) as f32 / u32::MAX as f32,
                });
            }
        }
        Ok(out)
    }

    /// Accessor `index`'s element count.
    fn count(&self, path: &Path, index: usize) -> Result<usize> {
        self.root
            .accessors
            .get(index)
            .map(|a| a.count.0 as usize)
            .ok_or_else(|| bad(path, format!("no accessor {index}")))
    }
}

/// A node's local matrix.
fn local_matrix(node: &json::scene::Node) -> Mat4 {
    if let Some(m) = node.matrix {
        return Mat4::from_cols_array(&m);
    }
    let t = node.translation.map_or(Vec3::ZERO, Vec3::from_array);
    let r = node
        .rotation
        .map_or(Quat::IDENTITY, |q| Quat::from_array(q.0).normalize());
    let s = node.scale.map_or(Vec3::ONE, Vec3::from_array);
    Mat4::from_scale_rotation_translation(s, r, t)
}

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
    let n = doc.count(path, position)?;

    if let Some(spz) = ext.pointer(&format!("/extensions/{EXT_SPZ}")) {
        let view = spz
            .get("bufferView")
            .and_then(Value::as_u64)
            .ok_or_else(|| bad(path, format!("mesh {mesh}: {EXT_SPZ} without a bufferView")))?;
        let (bytes, _) = doc.view(path, view as usize)?;
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
        let data = doc.floats(path, index, components)?;
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
    let doc = load(path)?;
    let meshes = doc
        .raw
        .get("meshes")
        .and_then(Value::as_array)
        .cloned()
        .unwrap_or_default();
    let mut notes = Vec::new();
    let mut dropped = 0;
    // The nodes to walk: the default scene's roots, else every scene's, else every node that
    // is nobody's child.
    let roots: Vec<usize> = match doc.root.scene.map(|s| s.value()) {
        Some(s) => doc
            .root
            .scenes
            .get(s)
            .ok_or_else(|| bad(path, format!("no scene {s}")))?
            .nodes
            .iter()
            .map(|n| n.value())
            .collect(),
        None if !doc.root.scenes.is_empty() => doc
            .root
            .scenes
            .iter()
            .flat_map(|s| s.nodes.iter().map(|n| n.value()))
            .collect(),
        None => {
            let children: std::collections::HashSet<usize> = doc
                .root
                .nodes
                .iter()
                .flat_map(|n| n.children.iter().flatten().map(|c| c.value()))
                .collect();
            (0..doc.root.nodes.len())
                .filter(|i| !children.contains(i))
                .collect()
        }
    };
    let mut scene = Scene::default();
    let mut found = 0;
    let mut stack: Vec<(usize, Mat4, usize)> = roots
        .into_iter()
        .rev()
        .map(|r| (r, Mat4::IDENTITY, 0))
        .collect();
    while let Some((index, parent, depth)) = stack.pop() {
        let node = doc
            .root
            .nodes
            .get(index)
            .ok_or_else(|| bad(path, format!("no node {index}")))?;
        if depth > 64 {
            return Err(bad(path, "nodes nest deeper than 64 (a cycle?)"));
        }
        let world = parent * local_matrix(node);
        if let Some(mesh) = node.mesh.map(|m| m.value()) {
            let primitives = meshes
                .get(mesh)
                .and_then(|m| m.get("primitives"))
                .and_then(Value::as_array)
                .ok_or_else(|| bad(path, format!("node {index} names a missing mesh {mesh}")))?;
            for primitive in primitives {
                let Some(part) =
                    read_primitive(&doc, path, mesh, primitive, &mut notes, &mut dropped)?
                else {
                    continue;
                };
                found += 1;
                let part = if world == Mat4::IDENTITY {
                    part
                } else {
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
        for child in node.children.iter().flatten().rev() {
            stack.push((child.value(), world, depth + 1));
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
