//! `rara mesh export`: every Gaussian's octagon (SPEC section 6) as PLY, OBJ + MTL or glTF 2.0
//! binary, streamed.
//!
//! The scene is read twice, chunk by chunk ([`GaussianSource`]): a first pass counts the
//! octagons and bounds their corners (the PLY and GLB headers and glTF's POSITION min/max come
//! before the data), a second writes them. Memory is one chunk of the scene and one write
//! buffer, whatever the scene's size; faces follow from the vertex numbering alone.
//!
//! Per vertex: position, RGBA (the SH degree-0 colour, alpha by [`Falloff`]), the in-plane
//! coordinates `(a, b)` as UV, `primitive_id` (the Gaussian's index in the scene as rara loads
//! it) and `corner_id` (k; 8 is the centre of [`Falloff::Centre`]). Octagons keep Gaussian order.

use std::fs::File;
use std::io::{BufWriter, Write};
use std::path::{Path, PathBuf};

use glam::{DVec3, Vec3};

use super::{octagon, octagon_radius, CORNERS, FAN_TRIANGLES};
use crate::error::{Error, Result};
use crate::scene::{flat_axis, Scene};
use crate::sh::SH_C0;

/// The mesh file formats, by extension.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum MeshFormat {
    /// Binary PLY with per-vertex colour, UV, primitive and corner ids, and a face list.
    Ply,
    /// Wavefront OBJ (`v x y z r g b`, `vt`, `f`) with an MTL beside it.
    Obj,
    /// glTF 2.0 binary.
    Glb,
}

impl MeshFormat {
    /// The format a path's extension names.
    pub fn from_path(path: &Path) -> Result<MeshFormat> {
        let ext = path
            .extension()
            .map(|e| e.to_string_lossy().to_ascii_lowercase());
        match ext.as_deref() {
            Some("ply") => Ok(MeshFormat::Ply),
            Some("obj") => Ok(MeshFormat::Obj),
            Some("glb") => Ok(MeshFormat::Glb),
            other => Err(Error::InvalidInput(format!(
                "{}: {} a mesh format rara knows (.ply, .obj, .glb)",
                path.display(),
                match other {
                    Some(e) => format!("'.{e}' is not"),
                    None => "no extension names".into(),
                }
            ))),
        }
    }

    /// Lower-case extensions of the formats.
    pub const EXTENSIONS: [&'static str; 3] = ["ply", "obj", "glb"];
}

/// How an octagon's alpha falls off.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub enum Falloff {
    /// One constant colour and alpha `o` per octagon (REdiSplats' export).
    #[default]
    Constant,
    /// MeshSplats' variant: a centre vertex with alpha `o`, the rim at the Gaussian's value
    /// `o exp(-rho^2/2)`, and an 8-triangle fan.
    Centre,
    /// glb: the vertex alpha is `o` and a base-colour texture holds `exp(-(a^2+b^2)/2)` over
    /// UV, so any glTF viewer shows the falloff (other formats: as `Constant`).
    Texture,
}

impl Falloff {
    /// Vertices per octagon.
    pub fn vertices(self) -> usize {
        match self {
            Falloff::Centre => CORNERS + 1,
            _ => CORNERS,
        }
    }

    /// Triangles per octagon.
    pub fn triangles(self) -> usize {
        match self {
            Falloff::Centre => CORNERS,
            _ => FAN_TRIANGLES,
        }
    }

    /// Where corner `k` sits among an octagon's vertices: after the centre in
    /// [`Falloff::Centre`], so that in both variants the fan's triangles use the vertices in
    /// file order (an OBJ reader numbers vertices by first use).
    pub fn corner_slot(self, k: usize) -> usize {
        match self {
            Falloff::Centre => k + 1,
            _ => k,
        }
    }

    /// Triangle `t` of an octagon, as vertex numbers within it; counter-clockwise seen from
    /// `+n`.
    pub fn triangle(self, t: usize) -> [u32; 3] {
        match self {
            Falloff::Centre => [0, 1 + t as u32, 1 + ((t + 1) % CORNERS) as u32],
            _ => [0, t as u32 + 1, t as u32 + 2],
        }
    }
}

/// What `rara mesh export` writes.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct ExportOptions {
    /// `Q` of the octagon radius (SPEC section 6).
    pub q: f64,
    /// The alpha falloff.
    pub falloff: Falloff,
    /// Gaussians below this opacity get no octagon.
    pub min_opacity: f32,
}

impl Default for ExportOptions {
    fn default() -> Self {
        ExportOptions {
            q: super::DEFAULT_Q,
            falloff: Falloff::Constant,
            min_opacity: 0.0,
        }
    }
}

/// Whether Gaussian `i` gets an octagon: opacity at least `min_opacity` and `rho > 0`. The
/// import of a mesh without primitive ids matches its octagons to the Gaussians this selects.
pub fn has_octagon(scene: &Scene, i: usize, q: f64, min_opacity: f32) -> bool {
    scene.opacities[i] >= min_opacity && octagon_radius(q, scene.opacities[i]) > 0.0
}

/// What an export wrote.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct ExportReport {
    /// Gaussians read.
    pub gaussians: usize,
    /// Octagons written.
    pub octagons: usize,
    /// Octagons of Gaussians that were not flat, flattened on the fly.
    pub flattened: usize,
    /// Gaussians with `rho = 0` (opacity at most `exp(-Q/2)`): no octagon.
    pub no_octagon: usize,
    /// Gaussians below `--min-opacity`.
    pub below_min_opacity: usize,
    /// Vertices written.
    pub vertices: u64,
    /// Triangles written.
    pub triangles: u64,
    /// Bytes written (for OBJ: the .obj and the .mtl).
    pub bytes: u64,
}

/// A scene read in chunks: an in-memory [`Scene`] or a PLY file ([`PlySource`]).
pub trait GaussianSource {
    /// Gaussians expected (for progress; a file's vertex count).
    fn len_hint(&self) -> usize;
    /// Hands every chunk of Gaussians to `f`, with the index of its first one.
    fn visit(&self, f: &mut dyn FnMut(&Scene, usize) -> Result<()>) -> Result<()>;
}

impl GaussianSource for Scene {
    fn len_hint(&self) -> usize {
        self.len()
    }
    fn visit(&self, f: &mut dyn FnMut(&Scene, usize) -> Result<()>) -> Result<()> {
        f(self, 0)
    }
}

/// A PLY scene read chunk by chunk ([`crate::ply::for_each_chunk`]), never whole.
pub struct PlySource {
    /// The file.
    pub path: PathBuf,
    /// Gaussians per chunk.
    pub chunk: usize,
    /// Vertices the header declares.
    pub vertices: usize,
}

impl PlySource {
    /// The scene at `path`, its header read for the count. It must be a regular file: the
    /// export reads it twice.
    pub fn open(path: &Path) -> Result<PlySource> {
        let meta = std::fs::metadata(path).map_err(|source| Error::Io {
            path: path.to_path_buf(),
            source,
        })?;
        if !meta.is_file() {
            return Err(Error::InvalidInput(format!(
                "{}: not a regular file; the mesh export reads the scene twice (a count, then \
                 the octagons), so give it a file, not a pipe",
                path.display()
            )));
        }
        Ok(PlySource {
            path: path.to_path_buf(),
            chunk: 65536,
            vertices: crate::ply::vertex_count(path)?,
        })
    }
}

impl GaussianSource for PlySource {
    fn len_hint(&self) -> usize {
        self.vertices
    }
    fn visit(&self, f: &mut dyn FnMut(&Scene, usize) -> Result<()>) -> Result<()> {
        crate::ply::for_each_chunk(&self.path, self.chunk, &mut |scene, info| {
            f(scene, info.first)
        })
        .map(|_| ())
    }
}

/// One vertex of an octagon.
#[derive(Clone, Copy, Debug)]
struct MeshVertex {
    position: DVec3,
    rgba: [u8; 4],
    /// Colour before quantisation (OBJ writes it as text).
    rgb: Vec3,
    uv: [f32; 2],
    corner: u8,
}

/// The SH degree-0 colour `max(0, C0 sh0 + 0.5)` clamped to 1.
fn dc_colour(scene: &Scene, i: usize) -> Vec3 {
    let sh = scene.sh_of(i);
    (SH_C0 * Vec3::new(sh[0], sh[1], sh[2]) + 0.5).clamp(Vec3::ZERO, Vec3::ONE)
}

fn to_u8(v: f32) -> u8 {
    (v.clamp(0.0, 1.0) * 255.0).round() as u8
}

/// The vertices of Gaussian `i`'s octagon (8, or 9 with the centre first), or `None`.
fn octagon_vertices(scene: &Scene, i: usize, options: &ExportOptions) -> Option<Vec<MeshVertex>> {
    if !has_octagon(scene, i, options.q, options.min_opacity) {
        return None;
    }
    let (frame, rho, corners) = octagon(scene, i, options.q)?;
    let rgb = dc_colour(scene, i);
    let o = scene.opacities[i];
    let rim_alpha = match options.falloff {
        Falloff::Centre => (o as f64 * (-0.5 * rho * rho).exp()) as f32,
        _ => o,
    };
    let rgba = |alpha: f32| [to_u8(rgb.x), to_u8(rgb.y), to_u8(rgb.z), to_u8(alpha)];
    let mut out: Vec<MeshVertex> = corners
        .iter()
        .enumerate()
        .map(|(k, &p)| {
            let (c, s) = super::corner_angle(k);
            MeshVertex {
                position: p,
                rgba: rgba(rim_alpha),
                rgb,
                uv: [(rho * c) as f32, (rho * s) as f32],
                corner: k as u8,
            }
        })
        .collect();
    if options.falloff == Falloff::Centre {
        out.insert(
            0,
            MeshVertex {
                position: frame.mean,
                rgba: rgba(o),
                rgb,
                uv: [0.0, 0.0],
                corner: CORNERS as u8,
            },
        );
    }
    Some(out)
}

/// The first pass: counts and the bounds of the corners as written in f32.
#[derive(Default)]
struct Survey {
    report: ExportReport,
    min: Vec3,
    max: Vec3,
}

fn survey(
    source: &dyn GaussianSource,
    options: &ExportOptions,
    progress: &mut dyn FnMut(usize, usize),
) -> Result<Survey> {
    let total = source.len_hint() * 2;
    let mut s = Survey {
        min: Vec3::splat(f32::INFINITY),
        max: Vec3::splat(f32::NEG_INFINITY),
        ..Default::default()
    };
    source.visit(&mut |scene, first| {
        for i in 0..scene.len() {
            s.report.gaussians += 1;
            if scene.opacities[i] < options.min_opacity {
                s.report.below_min_opacity += 1;
                continue;
            }
            let Some(vertices) = octagon_vertices(scene, i, options) else {
                s.report.no_octagon += 1;
                continue;
            };
            s.report.octagons += 1;
            if flat_axis(scene.scales[i]).is_none() {
                s.report.flattened += 1;
            }
            for v in &vertices {
                let p = v.position.as_vec3();
                s.min = s.min.min(p);
                s.max = s.max.max(p);
            }
        }
        progress(first + scene.len(), total);
        Ok(())
    })?;
    s.report.vertices = (s.report.octagons * options.falloff.vertices()) as u64;
    s.report.triangles = (s.report.octagons * options.falloff.triangles()) as u64;
    Ok(s)
}

/// An OBJ's material library, which goes beside it.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct MtlFile {
    /// Where it goes: the OBJ's path with the extension `.mtl`.
    pub path: PathBuf,
    /// Its text.
    pub text: String,
}

/// Writes every octagon of `source` to `path` in `format`, an OBJ's MTL beside it with its
/// stem. `progress(done, total)` is called after each chunk of each pass.
pub fn export_mesh(
    source: &dyn GaussianSource,
    path: &Path,
    format: MeshFormat,
    options: &ExportOptions,
    progress: &mut dyn FnMut(usize, usize),
) -> Result<ExportReport> {
    let io = |source| Error::Io {
        path: path.to_path_buf(),
        source,
    };
    let mut w = BufWriter::with_capacity(1 << 20, File::create(path).map_err(io)?);
    let (report, mtl) = export_mesh_to(source, &mut w, path, format, options, progress)?;
    w.flush().map_err(io)?;
    if let Some(mtl) = mtl {
        std::fs::write(&mtl.path, &mtl.text).map_err(|source| Error::Io {
            path: mtl.path.clone(),
            source,
        })?;
    }
    Ok(report)
}

/// Writes every octagon of `source` to `w` in `format`: the file that will be at `path`
/// (named in errors, and by an OBJ's `mtllib`). An OBJ's material library is returned, not
/// written: the caller puts it beside the OBJ (the CLI commits both together or neither).
pub fn export_mesh_to(
    source: &dyn GaussianSource,
    w: &mut dyn Write,
    path: &Path,
    format: MeshFormat,
    options: &ExportOptions,
    progress: &mut dyn FnMut(usize, usize),
) -> Result<(ExportReport, Option<MtlFile>)> {
    if !(options.q > 0.0 && options.q.is_finite()) {
        return Err(Error::InvalidInput(format!(
            "--q {}: Q must be a positive number (default 11.3449)",
            options.q
        )));
    }
    let survey = survey(source, options, progress)?;
    let half = source.len_hint();
    let mut second_pass = |done: usize, _| progress(half + done, 2 * half);
    let io = |source| Error::Io {
        path: path.to_path_buf(),
        source,
    };
    let mut w = Counted { inner: w, bytes: 0 };
    let mut report = survey.report.clone();
    let mut mtl_file = None;
    match format {
        MeshFormat::Ply => {
            write_ply_mesh(&mut w, source, options, &report, &mut second_pass).map_err(io)?
        }
        MeshFormat::Obj => {
            let mtl = path.with_extension("mtl");
            let mtl_name = mtl
                .file_name()
                .map_or_else(String::new, |n| n.to_string_lossy().into_owned());
            let material = "rara_octagons";
            let mtl_text = format!(
                "# rara mesh export: the octagons' colours are per vertex (v x y z r g b)\n\
                 newmtl {material}\nKa 0 0 0\nKd 1 1 1\nKs 0 0 0\nd 1\nillum 0\n"
            );
            report.bytes += mtl_text.len() as u64;
            mtl_file = Some(MtlFile {
                path: mtl,
                text: mtl_text,
            });
            write_obj_mesh(
                &mut w,
                source,
                options,
                &mtl_name,
                material,
                &mut second_pass,
            )
            .map_err(io)?;
        }
        MeshFormat::Glb => {
            write_glb_mesh(&mut w, path, source, options, &survey, &mut second_pass)?
        }
    }
    w.flush().map_err(io)?;
    report.bytes += w.bytes;
    Ok((report, mtl_file))
}

/// A writer that counts the bytes through it.
struct Counted<'a> {
    inner: &'a mut dyn Write,
    bytes: u64,
}

impl Write for Counted<'_> {
    fn write(&mut self, buf: &[u8]) -> std::io::Result<usize> {
        let n = self.inner.write(buf)?;
        self.bytes += n as u64;
        Ok(n)
    }
    fn flush(&mut self) -> std::io::Result<()> {
        self.inner.flush()
    }
}

/// Runs `f` on every octagon's vertices in order, with the running octagon number.
fn each_octagon(
    source: &dyn GaussianSource,
    options: &ExportOptions,
    progress: &mut dyn FnMut(usize, usize),
    f: &mut dyn FnMut(u32, &[MeshVertex]) -> std::io::Result<()>,
) -> std::io::Result<()> {
    let mut failure = None;
    let visited = source.visit(&mut |scene, first| {
        for i in 0..scene.len() {
            if let Some(vertices) = octagon_vertices(scene, i, options) {
                if let Err(e) = f((first + i) as u32, &vertices) {
                    failure = Some(e);
                    return Err(Error::InvalidInput("write failed".into()));
                }
            }
        }
        progress(first + scene.len(), 0);
        Ok(())
    });
    if let Some(e) = failure {
        return Err(e);
    }
    visited.map_err(std::io::Error::other)
}

fn write_ply_mesh(
    w: &mut impl Write,
    source: &dyn GaussianSource,
    options: &ExportOptions,
    report: &ExportReport,
    progress: &mut dyn FnMut(usize, usize),
) -> std::io::Result<()> {
    write!(
        w,
        "ply\nformat binary_little_endian 1.0\n\
         comment rara mesh export: octagons of flat Gaussians (SPEC section 6), Q {}, falloff {:?}\n\
         element vertex {}\n\
         property double x\nproperty double y\nproperty double z\n\
         property uchar red\nproperty uchar green\nproperty uchar blue\nproperty uchar alpha\n\
         property float u\nproperty float v\n\
         property uint primitive_id\nproperty uchar corner_id\n\
         element face {}\nproperty list uchar uint vertex_indices\nend_header\n",
        options.q, options.falloff, report.vertices, report.triangles
    )?;
    each_octagon(source, options, progress, &mut |id, vertices| {
        for v in vertices {
            for c in v.position.to_array() {
                w.write_all(&c.to_le_bytes())?;
            }
            w.write_all(&v.rgba)?;
            w.write_all(&v.uv[0].to_le_bytes())?;
            w.write_all(&v.uv[1].to_le_bytes())?;
            w.write_all(&id.to_le_bytes())?;
            w.write_all(&[v.corner])?;
        }
        Ok(())
    })?;
    let per = options.falloff.vertices() as u64;
    for o in 0..report.octagons as u64 {
        for t in 0..options.falloff.triangles() {
            w.write_all(&[3])?;
            for k in options.falloff.triangle(t) {
                w.write_all(&((o * per + k as u64) as u32).to_le_bytes())?;
            }
        }
    }
    Ok(())
}

fn write_obj_mesh(
    w: &mut impl Write,
    source: &dyn GaussianSource,
    options: &ExportOptions,
    mtl_name: &str,
    material: &str,
    progress: &mut dyn FnMut(usize, usize),
) -> std::io::Result<()> {
    writeln!(
        w,
        "# rara mesh export: octagons of flat Gaussians (SPEC section 6), Q {}, falloff {:?}\n\
         # {} vertices per octagon, in Gaussian order; v x y z r g b; vt = in-plane (a, b)\n\
         mtllib {mtl_name}\no octagons\nusemtl {material}",
        options.q,
        options.falloff,
        options.falloff.vertices()
    )?;
    let per = options.falloff.vertices() as u64;
    let mut base = 1u64; // OBJ numbers vertices from 1
    each_octagon(source, options, progress, &mut |_, vertices| {
        for v in vertices {
            let p = v.position;
            // Shortest round-trip decimal of each f64: no precision lost in the text.
            writeln!(
                w,
                "v {} {} {} {} {} {}",
                p.x, p.y, p.z, v.rgb.x, v.rgb.y, v.rgb.z
            )?;
        }
        for v in vertices {
            writeln!(w, "vt {} {}", v.uv[0], v.uv[1])?;
        }
        for t in 0..options.falloff.triangles() {
            let [a, b, c] = options.falloff.triangle(t).map(|k| base + k as u64);
            writeln!(w, "f {a}/{a} {b}/{b} {c}/{c}")?;
        }
        base += per;
        Ok(())
    })
}

/// Side of the `--falloff texture` image.
const FALLOFF_TEXTURE_SIZE: u32 = 256;

/// The falloff texture: white, alpha `exp(-(a^2+b^2)/2)` with `(a, b) = (2 uv - 1) sqrt(Q)`,
/// the mapping of TEXCOORD_1 (PNG bytes).
fn falloff_texture(q: f64) -> Vec<u8> {
    let n = FALLOFF_TEXTURE_SIZE;
    let extent = q.sqrt();
    let img = image::RgbaImage::from_fn(n, n, |x, y| {
        let a = ((x as f64 + 0.5) / n as f64 * 2.0 - 1.0) * extent;
        let b = ((y as f64 + 0.5) / n as f64 * 2.0 - 1.0) * extent;
        image::Rgba([255, 255, 255, to_u8((-(a * a + b * b) / 2.0).exp() as f32)])
    });
    let mut bytes = Vec::new();
    img.write_to(
        &mut std::io::Cursor::new(&mut bytes),
        image::ImageFormat::Png,
    )
    .expect("PNG encoding of an in-memory image");
    bytes
}

fn pad4(n: u64) -> u64 {
    n.div_ceil(4) * 4
}

/// The glTF JSON of the export, built as JSON and checked by `gltf-json`'s typed model and
/// validator before it is written.
fn glb_json(
    options: &ExportOptions,
    survey: &Survey,
    image_bytes: u64,
    stride: u64,
    total_bin: u64,
) -> Result<Vec<u8>> {
    use serde_json::json;
    let vertices = survey.report.vertices;
    let vertex_offset = pad4(image_bytes);
    let vertex_bytes = vertices * stride;
    let index_offset = vertex_offset + vertex_bytes;
    let index_count = survey.report.triangles * 3;
    let texture = options.falloff == Falloff::Texture;
    let mut views = vec![
        json!({"buffer": 0, "byteOffset": vertex_offset, "byteLength": vertex_bytes,
               "byteStride": stride, "target": 34962}),
        json!({"buffer": 0, "byteOffset": index_offset, "byteLength": index_count * 4,
               "target": 34963}),
    ];
    let accessor = |offset: u64, component: u32, kind: &str, normalized: bool| {
        let mut a = json!({"bufferView": 0, "byteOffset": offset, "componentType": component,
                           "count": vertices, "type": kind});
        if normalized {
            a["normalized"] = json!(true);
        }
        a
    };
    let mut accessors = vec![
        {
            let mut a = accessor(0, 5126, "VEC3", false);
            a["min"] = json!(survey.min.to_array());
            a["max"] = json!(survey.max.to_array());
            a
        },
        accessor(12, 5121, "VEC4", true),
        accessor(16, 5126, "VEC2", false),
        accessor(24, 5126, "SCALAR", false),
        accessor(28, 5126, "SCALAR", false),
        json!({"bufferView": 1, "componentType": 5125, "count": index_count, "type": "SCALAR"}),
    ];
    let mut attributes = json!({"POSITION": 0, "COLOR_0": 1, "TEXCOORD_0": 2,
                                "_PRIMITIVE_ID": 3, "_CORNER_ID": 4});
    let mut material = json!({
        "name": "rara octagons (radiance: unlit)",
        "alphaMode": "BLEND",
        "doubleSided": true,
        "pbrMetallicRoughness": {"baseColorFactor": [1.0, 1.0, 1.0, 1.0],
                                 "metallicFactor": 0.0, "roughnessFactor": 1.0},
        "extensions": {"KHR_materials_unlit": {}}
    });
    let mut root = json!({
        "asset": {"version": "2.0",
                  "generator": format!("rara {} mesh export (SPEC section 6)", env!("CARGO_PKG_VERSION"))},
        "extensionsUsed": ["KHR_materials_unlit"],
        "scene": 0,
        "scenes": [{"nodes": [0]}],
        "nodes": [{"mesh": 0, "name": "octagons"}],
        "buffers": [{"byteLength": total_bin}],
    });
    if texture {
        accessors.push(accessor(32, 5126, "VEC2", false));
        attributes["TEXCOORD_1"] = json!(6);
        views.push(json!({"buffer": 0, "byteOffset": 0, "byteLength": image_bytes}));
        root["images"] = json!([{"bufferView": 2, "mimeType": "image/png", "name": "falloff"}]);
        root["samplers"] = json!([{"magFilter": 9729, "minFilter": 9729,
                                   "wrapS": 33071, "wrapT": 33071}]);
        root["textures"] = json!([{"sampler": 0, "source": 0}]);
        material["pbrMetallicRoughness"]["baseColorTexture"] = json!({"index": 0, "texCoord": 1});
    }
    root["bufferViews"] = json!(views);
    root["accessors"] = json!(accessors);
    root["materials"] = json!([material]);
    root["meshes"] = json!([{"name": "octagons", "primitives": [
        {"attributes": attributes, "indices": 5, "material": 0, "mode": 4}]}]);
    let typed: gltf::json::Root = serde_json::from_value(root)
        .map_err(|e| Error::InvalidInput(format!("internal: glTF JSON does not parse: {e}")))?;
    let mut problems = Vec::new();
    gltf::json::validation::Validate::validate(
        &typed,
        &typed,
        gltf::json::Path::new,
        &mut |path, error| problems.push(format!("{}: {error}", path())),
    );
    if !problems.is_empty() {
        return Err(Error::InvalidInput(format!(
            "internal: the glTF JSON is invalid: {}",
            problems.join("; ")
        )));
    }
    gltf::json::serialize::to_vec(&typed)
        .map_err(|e| Error::InvalidInput(format!("internal: glTF JSON: {e}")))
}

/// GLB container: the 12-byte header, then the JSON and BIN chunks (glTF 2.0 section 4.4),
/// written by hand only because the BIN chunk is streamed: `gltf::binary::Glb` needs it whole.
fn write_glb_mesh(
    w: &mut impl Write,
    path: &Path,
    source: &dyn GaussianSource,
    options: &ExportOptions,
    survey: &Survey,
    progress: &mut dyn FnMut(usize, usize),
) -> Result<()> {
    if survey.report.gaussians > 1 << 24 {
        return Err(Error::InvalidInput(format!(
            "{} Gaussians: glb stores _PRIMITIVE_ID as a float, exact up to 2^24 = 16777216 \
             Gaussians; export this scene as .ply or .obj",
            survey.report.gaussians
        )));
    }
    let texture = options.falloff == Falloff::Texture;
    let image = if texture {
        falloff_texture(options.q)
    } else {
        Vec::new()
    };
    let stride: u64 = if texture { 40 } else { 32 };
    let vertex_offset = pad4(image.len() as u64);
    let bin_len = vertex_offset + survey.report.vertices * stride + survey.report.triangles * 12;
    let mut json = glb_json(options, survey, image.len() as u64, stride, bin_len)?;
    while json.len() % 4 != 0 {
        json.push(b' ');
    }
    let total = 12 + 8 + json.len() as u64 + 8 + bin_len;
    if total > u32::MAX as u64 {
        return Err(Error::InvalidInput(format!(
            "the glb would be {total} bytes, past the format's 4 GiB limit; export as .ply or .obj"
        )));
    }
    let io = |source: std::io::Error| Error::Io {
        path: path.to_path_buf(),
        source,
    };
    let mut head = Vec::with_capacity(28);
    head.extend_from_slice(b"glTF");
    head.extend_from_slice(&2u32.to_le_bytes());
    head.extend_from_slice(&(total as u32).to_le_bytes());
    head.extend_from_slice(&(json.len() as u32).to_le_bytes());
    head.extend_from_slice(b"JSON");
    w.write_all(&head).map_err(io)?;
    w.write_all(&json).map_err(io)?;
    w.write_all(&(bin_len as u32).to_le_bytes()).map_err(io)?;
    w.write_all(b"BIN\0").map_err(io)?;
    w.write_all(&image).map_err(io)?;
    w.write_all(&vec![0u8; (vertex_offset - image.len() as u64) as usize])
        .map_err(io)?;
    let extent = options.q.sqrt() as f32;
    each_octagon(source, options, progress, &mut |id, vertices| {
        for v in vertices {
            let p = v.position.as_vec3();
            for c in p.to_array() {
                w.write_all(&c.to_le_bytes())?;
            }
            w.write_all(&v.rgba)?;
            w.write_all(&v.uv[0].to_le_bytes())?;
            w.write_all(&v.uv[1].to_le_bytes())?;
            w.write_all(&(id as f32).to_le_bytes())?;
            w.write_all(&(v.corner as f32).to_le_bytes())?;
            if texture {
                // TEXCOORD_1: (a, b) over [-sqrt Q, sqrt Q] mapped to [0, 1].
                for c in v.uv {
                    w.write_all(&(0.5 + 0.5 * c / extent).to_le_bytes())?;
                }
            }
        }
        Ok(())
    })
    .map_err(io)?;
    let per = options.falloff.vertices() as u64;
    for o in 0..survey.report.octagons as u64 {
        for t in 0..options.falloff.triangles() {
            for k in options.falloff.triangle(t) {
                w.write_all(&((o * per + k as u64) as u32).to_le_bytes())
                    .map_err(io)?;
            }
        }
    }
    Ok(())
}
