//! `rara mesh import`: edited octagons back into Gaussians (SPEC section 6).
//!
//! A mesh is read with the format's maintained crate (`ply-rs`, `tobj`, `gltf`), its vertices
//! matched to the original scene's Gaussians, and every octagon fitted back ([`Fit`]). The
//! match is by `primitive_id` / `corner_id` where the file has them (rara's PLY and glb),
//! else by order (OBJ, and meshes other tools re-exported): the octagons follow the Gaussians
//! [`super::export::has_octagon`] selects, 8 vertices each (9 with a centre, first). Anything
//! that does not add up is an error that says what, never a silent mismatch.

use std::path::{Path, PathBuf};

use glam::{DMat3, DMat4, DVec3};

use super::export::{has_octagon, Falloff};
use super::{fit_lsq, fit_redisplats, octagon_radius, FlatFrame, CORNERS};
use crate::error::{Error, Result};
use crate::input::gltf::{check_placed, Document};
use crate::input::InputFile;
use crate::scene::Scene;

/// How corners become a Gaussian.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub enum Fit {
    /// SPEC section 6's three-point rule (corners 0, 2 and 6), exactly as REdiSplats.
    #[default]
    Redisplats,
    /// The least-squares fit over all eight corners.
    Lsq,
}

/// What `rara mesh import` does.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct ImportOptions {
    /// `Q` the mesh was exported with (the octagon radius).
    pub q: f64,
    /// `--min-opacity` it was exported with (which Gaussians have an octagon).
    pub min_opacity: f32,
    /// The fit.
    pub fit: Fit,
    /// Turn each Gaussian's SH (degrees 1-3) by the rotation its face underwent.
    pub rotate_sh: bool,
}

impl Default for ImportOptions {
    fn default() -> Self {
        ImportOptions {
            q: super::DEFAULT_Q,
            min_opacity: 0.0,
            fit: Fit::Redisplats,
            rotate_sh: false,
        }
    }
}

/// A mesh as read: positions, faces, and the ids where the file has them.
#[derive(Clone, Debug, Default)]
pub struct MeshData {
    /// Vertex positions.
    pub positions: Vec<DVec3>,
    /// Per vertex, the Gaussian's index (`primitive_id`).
    pub primitive_ids: Option<Vec<u32>>,
    /// Per vertex, the corner (`corner_id`; 8 for a centre).
    pub corner_ids: Option<Vec<u32>>,
    /// Faces as vertex indices.
    pub faces: Vec<Vec<u32>>,
    /// Per vertex, its normal, where the file has one for every vertex (not normalised).
    pub normals: Option<Vec<DVec3>>,
    /// Per vertex, its texture coordinates (glTF: the `TEXCOORD_n` set its primitive's base
    /// colour texture reads, `TEXCOORD_0` without one; `(0, 0)` for a primitive without that
    /// set), where some primitive has them.
    pub uvs: Option<Vec<[f32; 2]>>,
    /// Per face, its glTF material (`None`: the primitive names none); empty for the other
    /// formats.
    pub face_materials: Vec<Option<u32>>,
}

fn mesh_err(path: &Path, message: impl std::fmt::Display) -> Error {
    Error::InvalidInput(format!("mesh {}: {message}", path.display()))
}

/// The largest mesh file rara reads: 4 GiB (glb's own lengths are 32-bit; an octagon PLY of
/// 20 million Gaussians takes about 7 GB, which is past what an import holds in memory anyway).
pub const MAX_MESH_FILE_BYTES: u64 = 4 << 30;

/// The most vertices a glTF's nodes may place, each mesh counted once per node that places it:
/// 2^27 (134,217,728). Without it a small file that places one large mesh under thousands of
/// nodes would be decoded thousands of times.
pub const MAX_PLACED_VERTICES: u64 = 1 << 27;

/// The most vertex indices a glTF's nodes may place, counted the same way: 2^28 (a triangle
/// list of 2^27 vertices takes about 2^28 indices; a few vertices with millions of indices
/// under many nodes would otherwise make billions of faces).
pub const MAX_PLACED_INDICES: u64 = 1 << 28;

/// Reads a mesh (.ply, .obj, .glb, or .gltf with its buffers in files beside it or in
/// base64 data URIs), told by its extension. The file is opened once and read through
/// [`crate::input`]: a regular file at most [`MAX_MESH_FILE_BYTES`], a pipe or a device through
/// the stream cap, a glTF buffer only as a regular file beside it and only up to its
/// `byteLength`.
pub fn read_mesh(path: &Path) -> Result<MeshData> {
    let ext = path
        .extension()
        .map(|e| e.to_string_lossy().to_ascii_lowercase());
    let format = if ext.as_deref() == Some("gltf") {
        super::export::MeshFormat::Glb
    } else {
        super::export::MeshFormat::from_path(path)?
    };
    let input = InputFile::open(path, "mesh")?;
    match format {
        super::export::MeshFormat::Ply => read_ply_mesh(input),
        super::export::MeshFormat::Obj => read_obj_mesh(input),
        super::export::MeshFormat::Glb => {
            let bytes = input.read_all(MAX_MESH_FILE_BYTES, "mesh")?;
            read_gltf_mesh(&Document::from_bytes(&bytes, path)?, path)
        }
    }
}

/// A PLY vertex as ply-rs hands it over: only what the import needs.
#[derive(Default)]
struct PlyVertex {
    xyz: [f64; 3],
    /// `nx, ny, nz`, where the file has them.
    normal: Option<[f64; 3]>,
    primitive_id: Option<u32>,
    corner_id: Option<u32>,
}

fn property_f64(p: &ply_rs::ply::Property) -> Option<f64> {
    use ply_rs::ply::Property as P;
    Some(match *p {
        P::Char(v) => v as f64,
        P::UChar(v) => v as f64,
        P::Short(v) => v as f64,
        P::UShort(v) => v as f64,
        P::Int(v) => v as f64,
        P::UInt(v) => v as f64,
        P::Float(v) => v as f64,
        P::Double(v) => v,
        _ => return None,
    })
}

/// An id property as a u32, or `u32::MAX` for a value that is not one (negative, fractional,
/// non-finite), which the matching then reports.
fn property_id(p: &ply_rs::ply::Property) -> u32 {
    match property_f64(p) {
        Some(v) if v >= 0.0 && v.fract() == 0.0 && v < u32::MAX as f64 => v as u32,
        _ => u32::MAX,
    }
}

impl ply_rs::ply::PropertyAccess for PlyVertex {
    fn new() -> Self {
        PlyVertex {
            xyz: [f64::NAN; 3],
            ..Default::default()
        }
    }
    fn set_property(&mut self, name: String, p: ply_rs::ply::Property) {
        match name.as_str() {
            "x" => self.xyz[0] = property_f64(&p).unwrap_or(f64::NAN),
            "y" => self.xyz[1] = property_f64(&p).unwrap_or(f64::NAN),
            "z" => self.xyz[2] = property_f64(&p).unwrap_or(f64::NAN),
            "nx" | "ny" | "nz" => {
                let n = self.normal.get_or_insert([f64::NAN; 3]);
                n[(name.as_bytes()[1] - b'x') as usize] = property_f64(&p).unwrap_or(f64::NAN);
            }
            "primitive_id" => self.primitive_id = Some(property_id(&p)),
            "corner_id" => self.corner_id = Some(property_id(&p)),
            _ => {}
        }
    }
}

/// A PLY face: its vertex list.
#[derive(Default)]
struct PlyFace(Vec<u32>);

impl ply_rs::ply::PropertyAccess for PlyFace {
    fn new() -> Self {
        PlyFace::default()
    }
    fn set_property(&mut self, name: String, p: ply_rs::ply::Property) {
        use ply_rs::ply::Property as P;
        if name != "vertex_indices" && name != "vertex_index" {
            return;
        }
        self.0 = match p {
            P::ListUInt(v) => v,
            P::ListInt(v) => v.into_iter().map(|i| i.max(-1) as u32).collect(),
            P::ListUShort(v) => v.into_iter().map(u32::from).collect(),
            P::ListShort(v) => v.into_iter().map(|i| i.max(-1) as u32).collect(),
            P::ListUChar(v) => v.into_iter().map(u32::from).collect(),
            P::ListChar(v) => v.into_iter().map(|i| i.max(-1) as u32).collect(),
            _ => vec![u32::MAX],
        };
    }
}

/// The fewest bytes a row of `element` takes in `encoding`: each scalar's size (a list's count)
/// in binary, a character and a separator per property in ascii; and 1 for an element without
/// properties, whose rows would otherwise cost nothing to declare by the billion.
fn min_row_bytes(element: &ply_rs::ply::ElementDef, encoding: ply_rs::ply::Encoding) -> u64 {
    use ply_rs::ply::{Encoding, PropertyType, ScalarType};
    let size = |t: &ScalarType| match t {
        ScalarType::Char | ScalarType::UChar => 1,
        ScalarType::Short | ScalarType::UShort => 2,
        ScalarType::Int | ScalarType::UInt | ScalarType::Float => 4,
        ScalarType::Double => 8,
    };
    element
        .properties
        .values()
        .map(|p| match (&encoding, &p.data_type) {
            (Encoding::Ascii, _) => 2,
            (_, PropertyType::Scalar(t)) => size(t),
            (_, PropertyType::List(count, _)) => size(count),
        })
        .sum::<u64>()
        .max(1)
}

fn read_ply_mesh(input: InputFile) -> Result<MeshData> {
    let path = input.path().to_path_buf();
    let path = path.as_path();
    let (mut reader, size) = input.into_sized_reader(MAX_MESH_FILE_BYTES, "mesh")?;
    // The header through the scene reader's bounded header reader (1 MiB at most).
    let (header_bytes, header) = crate::ply::read_header(path, &mut reader)?;
    let mut left = size.saturating_sub(header_bytes.len() as u64);
    let vertex_parser = ply_rs::parser::Parser::<PlyVertex>::new();
    let mut mesh = MeshData::default();
    let face_parser = ply_rs::parser::Parser::<PlyFace>::new();
    let mut ids = (Vec::new(), Vec::new(), true, true);
    let (mut normals, mut all_normals) = (Vec::new(), true);
    for (name, element) in &header.elements {
        // Every row takes its fewest bytes at least: a count beyond what is left of the file
        // is refused before reading.
        let least = (element.count as u64).saturating_mul(min_row_bytes(element, header.encoding));
        if least > left {
            return Err(mesh_err(
                path,
                format!(
                    "element '{name}' declares {} rows, which take at least {least} bytes, and \
                     the file has {left} left",
                    element.count
                ),
            ));
        }
        left -= least;
        match name.as_str() {
            "vertex" => {
                let rows = vertex_parser
                    .read_payload_for_element(&mut reader, element, &header)
                    .map_err(|e| mesh_err(path, format!("vertex data: {}", first_line(&e))))?;
                for v in rows {
                    mesh.positions.push(DVec3::from_array(v.xyz));
                    match v.normal {
                        Some(n) => normals.push(DVec3::from_array(n)),
                        None => all_normals = false,
                    }
                    match v.primitive_id {
                        Some(id) => ids.0.push(id),
                        None => ids.2 = false,
                    }
                    match v.corner_id {
                        Some(id) => ids.1.push(id),
                        None => ids.3 = false,
                    }
                }
            }
            "face" => {
                let rows = face_parser
                    .read_payload_for_element(&mut reader, element, &header)
                    .map_err(|e| mesh_err(path, format!("face data: {}", first_line(&e))))?;
                mesh.faces = rows.into_iter().map(|f| f.0).collect();
            }
            _ => {
                // Another element: read past it.
                ply_rs::parser::Parser::<ply_rs::ply::DefaultElement>::new()
                    .read_payload_for_element(&mut reader, element, &header)
                    .map_err(|e| mesh_err(path, format!("element '{name}': {}", first_line(&e))))?;
            }
        }
    }
    if !header.elements.contains_key("vertex") {
        return Err(mesh_err(path, "no 'vertex' element"));
    }
    if ids.2 && ids.3 && !mesh.positions.is_empty() {
        mesh.primitive_ids = Some(ids.0);
        mesh.corner_ids = Some(ids.1);
    }
    if all_normals && !mesh.positions.is_empty() {
        mesh.normals = Some(normals);
    }
    Ok(mesh)
}

fn first_line(e: &dyn std::fmt::Display) -> String {
    e.to_string().lines().next().unwrap_or("").to_string()
}

fn read_obj_mesh(input: InputFile) -> Result<MeshData> {
    let path = input.path().to_path_buf();
    let path = path.as_path();
    // Points and lines are kept (as faces of one and two vertices) so that the checks that
    // follow name them: tobj would otherwise drop a two-vertex `f` as a line, silently.
    let options = tobj::LoadOptions {
        single_index: true,
        triangulate: false,
        ignore_points: false,
        ignore_lines: false,
    };
    let (mut reader, _) = input.into_sized_reader(MAX_MESH_FILE_BYTES, "mesh")?;
    // Materials do not matter here; a missing .mtl must not fail the import.
    let (models, _) = tobj::load_obj_buf(&mut reader, &options, |_| Ok(Default::default()))
        .map_err(|e| mesh_err(path, format!("OBJ: {e}")))?;
    let mut mesh = MeshData::default();
    let (mut normals, mut all_normals) = (Vec::new(), true);
    for model in models {
        let m = model.mesh;
        let base = u32::try_from(mesh.positions.len())
            .map_err(|_| mesh_err(path, "more than 2^32 vertices"))?;
        // (single_index: a normal per position, where the file gives them.)
        if m.normals.len() == m.positions.len() {
            normals.extend(
                m.normals
                    .chunks_exact(3)
                    .map(|n| DVec3::new(n[0], n[1], n[2])),
            );
        } else {
            all_normals = false;
        }
        mesh.positions.extend(
            m.positions
                .chunks_exact(3)
                .map(|p| DVec3::new(p[0], p[1], p[2])),
        );
        let mut next = 0usize;
        let arities: Vec<u32> = if m.face_arities.is_empty() {
            vec![3; m.indices.len() / 3]
        } else {
            m.face_arities.clone()
        };
        for n in arities {
            let face = next
                .checked_add(n as usize)
                .and_then(|end| m.indices.get(next..end))
                .ok_or_else(|| mesh_err(path, "OBJ: faces past the index list"))?;
            mesh.faces
                .push(face.iter().map(|&i| base.saturating_add(i)).collect());
            next += n as usize;
        }
    }
    if all_normals && !mesh.positions.is_empty() {
        mesh.normals = Some(normals);
    }
    Ok(mesh)
}

/// Every triangle primitive of the glTF `doc`, placed by its node's world transform. The nodes
/// walked are the default scene's (else each scene's, else every node that is nobody's child;
/// a file with meshes and no nodes has its meshes where they are), each once
/// ([`Document::walk`]); the vertices they place are counted against
/// [`MAX_PLACED_VERTICES`] before any is read.
pub fn read_gltf_mesh(doc: &Document, path: &Path) -> Result<MeshData> {
    use gltf::json::mesh::{Mode, Semantic};
    use gltf::json::validation::Checked;
    let placed: Vec<(usize, DMat4)> = if doc.root.nodes.is_empty() {
        (0..doc.root.meshes.len())
            .map(|m| (m, DMat4::IDENTITY))
            .collect()
    } else {
        doc.placed_meshes()?
            .into_iter()
            .map(|(_, mesh, world)| (mesh, world))
            .collect()
    };
    let (mut vertices, mut indices) = (0u64, 0u64);
    for &(m, _) in &placed {
        let mesh = doc
            .root
            .meshes
            .get(m)
            .ok_or_else(|| mesh_err(path, format!("a node names a missing mesh {m}")))?;
        for primitive in &mesh.primitives {
            if let Some(a) = primitive
                .attributes
                .get(&Checked::Valid(Semantic::Positions))
            {
                vertices = vertices.saturating_add(doc.count(a.value())? as u64);
            }
            if let Some(a) = primitive.indices {
                indices = indices.saturating_add(doc.count(a.value())? as u64);
            }
        }
    }
    check_placed(vertices, MAX_PLACED_VERTICES, "vertices", path)?;
    check_placed(indices, MAX_PLACED_INDICES, "vertex indices", path)?;
    let mut mesh = MeshData::default();
    let mut all_ids = true;
    let (mut normals, mut all_normals) = (Vec::new(), true);
    let (mut primitive_ids, mut corner_ids) = (Vec::new(), Vec::new());
    let (mut uvs, mut any_uvs) = (Vec::new(), false);
    for (m, world) in placed {
        for primitive in &doc.root.meshes[m].primitives {
            let mode = match primitive.mode {
                Checked::Valid(m @ (Mode::Triangles | Mode::TriangleStrip | Mode::TriangleFan)) => {
                    m
                }
                Checked::Valid(m) => {
                    return Err(mesh_err(
                        path,
                        format!("a primitive of {m:?}, not triangles: a mesh of points or lines"),
                    ))
                }
                Checked::Invalid => return Err(mesh_err(path, "a primitive of an unknown mode")),
            };
            let attribute = |s: Semantic| {
                primitive
                    .attributes
                    .get(&Checked::Valid(s))
                    .map(|a| a.value())
            };
            let position = attribute(Semantic::Positions)
                .ok_or_else(|| mesh_err(path, "a primitive without POSITION"))?;
            let base = u32::try_from(mesh.positions.len())
                .map_err(|_| mesh_err(path, "more than 2^32 vertices"))?;
            let positions = doc.floats(position, 3)?;
            mesh.positions.extend(positions.chunks_exact(3).map(|p| {
                world.transform_point3(DVec3::new(p[0] as f64, p[1] as f64, p[2] as f64))
            }));
            let count = positions.len() / 3;
            // Normals turn with the inverse transpose of the node's matrix.
            let normal_matrix = DMat3::from_mat4(world).inverse().transpose();
            match attribute(Semantic::Normals) {
                Some(a) => {
                    let n = doc.floats(a, 3)?;
                    all_normals &= n.len() / 3 == count;
                    normals.extend(n.chunks_exact(3).map(|n| {
                        normal_matrix * DVec3::new(n[0] as f64, n[1] as f64, n[2] as f64)
                    }));
                }
                None => all_normals = false,
            }
            let read_ids = |name: &str, out: &mut Vec<u32>| -> Result<bool> {
                let Some(a) = attribute(Semantic::Extras(name.to_string())) else {
                    return Ok(false);
                };
                Ok(match doc.ids(a)? {
                    Some(ids) if ids.len() == count => {
                        out.extend(ids);
                        true
                    }
                    _ => false,
                })
            };
            let material = primitive.material.map(|m| m.value() as u32);
            let set = material.map_or(0, |m| {
                crate::mixed::gltf_material::base_colour_tex_coord(doc, m as usize)
            });
            match attribute(Semantic::TexCoords(set)) {
                Some(a) => {
                    let uv = doc.floats(a, 2)?;
                    if uv.len() / 2 != count {
                        return Err(mesh_err(
                            path,
                            format!(
                                "TEXCOORD_{set} has {} entries for {count} vertices",
                                uv.len() / 2
                            ),
                        ));
                    }
                    uvs.extend(uv.chunks_exact(2).map(|p| [p[0], p[1]]));
                    any_uvs = true;
                }
                None => {
                    if material.is_some_and(|m| {
                        crate::mixed::gltf_material::has_base_colour_texture(doc, m as usize)
                    }) {
                        return Err(mesh_err(
                            path,
                            format!(
                                "mesh {m}: a primitive's material samples a texture at \
                                 TEXCOORD_{set}, which the primitive lacks"
                            ),
                        ));
                    }
                    uvs.resize(uvs.len() + count, [0.0f32; 2]);
                }
            }
            all_ids &= read_ids("PRIMITIVE_ID", &mut primitive_ids)?;
            all_ids &= read_ids("CORNER_ID", &mut corner_ids)?;
            let (idx, what) = match primitive.indices {
                Some(a) => (doc.indices(a.value())?, "indices"),
                None => ((0..count as u32).collect(), "vertices (and no indices)"),
            };
            mesh.faces.extend(
                triangles(mode, &idx, what, path)?
                    .map(|t| t.map(|i| base.saturating_add(i)).to_vec()),
            );
            mesh.face_materials.resize(mesh.faces.len(), material);
        }
    }
    if all_ids && !mesh.positions.is_empty() {
        mesh.primitive_ids = Some(primitive_ids);
        mesh.corner_ids = Some(corner_ids);
    }
    if all_normals && !mesh.positions.is_empty() {
        mesh.normals = Some(normals);
    }
    if any_uvs {
        mesh.uvs = Some(uvs);
    }
    Ok(mesh)
}

/// The triangles of a primitive of `mode` over the vertex indices `idx` (glTF 2.0 section
/// 3.7.2.1: a list takes three at a time, a strip each new one with the two before it, its
/// odd ones turned to keep their winding, a fan each new pair with the first).
fn triangles<'a>(
    mode: gltf::json::mesh::Mode,
    idx: &'a [u32],
    what: &str,
    path: &Path,
) -> Result<Box<dyn Iterator<Item = [u32; 3]> + 'a>> {
    use gltf::json::mesh::Mode;
    Ok(match mode {
        Mode::Triangles => {
            if idx.len() % 3 != 0 {
                return Err(mesh_err(
                    path,
                    format!(
                        "a triangle-list primitive with {} {what}, not a multiple of 3",
                        idx.len()
                    ),
                ));
            }
            Box::new(idx.chunks_exact(3).map(|t| [t[0], t[1], t[2]]))
        }
        Mode::TriangleStrip => Box::new(idx.windows(3).enumerate().map(|(k, t)| {
            if k % 2 == 0 {
                [t[0], t[1], t[2]]
            } else {
                [t[1], t[0], t[2]]
            }
        })),
        _ => Box::new(
            idx.get(1..)
                .unwrap_or_default()
                .windows(2)
                .map(move |t| [idx[0], t[0], t[1]]),
        ),
    })
}

/// What an import did.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct ImportReport {
    /// Gaussians refitted from their octagons.
    pub fitted: usize,
    /// Gaussians without an octagon, kept as they were.
    pub kept: usize,
    /// How vertices were matched to Gaussians.
    pub matched_by_ids: bool,
    /// Vertices per octagon: 8, or 9 with a centre.
    pub vertices_per_octagon: usize,
}

/// A mesh's octagons matched to the Gaussians of the original scene.
#[derive(Clone, Debug)]
pub struct MatchedOctagons {
    /// Per Gaussian, its octagon's corners, or `None` (no octagon).
    pub corners: Vec<Option<[DVec3; CORNERS]>>,
    /// Matched by `primitive_id` / `corner_id` (else by order).
    pub by_ids: bool,
    /// Vertices per octagon: 8, or 9 with a centre.
    pub vertices_per_octagon: usize,
}

/// The corners of every octagon in `mesh`, matched to the Gaussians of `original`, with the
/// faces checked (within one octagon, distinct in-range vertices, some area).
pub fn match_octagons(
    mesh: &MeshData,
    original: &Scene,
    options: &ImportOptions,
    path: &Path,
) -> Result<MatchedOctagons> {
    let n = original.len();
    let v = mesh.positions.len();
    // A point or a line (an OBJ `f` of one or two vertices) is named before any count is
    // compared: it is the more telling error.
    if let Some((f, face)) = mesh.faces.iter().enumerate().find(|(_, f)| f.len() < 3) {
        return Err(mesh_err(
            path,
            format!("face {f} has {} vertices", face.len()),
        ));
    }
    if let Some(i) = mesh.positions.iter().position(|p| !p.is_finite()) {
        return Err(mesh_err(
            path,
            format!("vertex {i} is not finite: {}", mesh.positions[i]),
        ));
    }
    let selected: Vec<usize> = (0..n)
        .filter(|&i| has_octagon(original, i, options.q, options.min_opacity))
        .collect();
    let mut corners: Vec<Option<[DVec3; CORNERS]>> = vec![None; n];
    // For each vertex, the octagon it belongs to (for the face check).
    let owner: Vec<u32>;
    let per;
    match (&mesh.primitive_ids, &mesh.corner_ids) {
        (Some(prim), Some(corner)) => {
            if prim.len() != v || corner.len() != v {
                return Err(mesh_err(
                    path,
                    format!(
                        "{v} vertices but {} primitive ids and {} corner ids",
                        prim.len(),
                        corner.len()
                    ),
                ));
            }
            let mut filled: Vec<u16> = vec![0; n];
            let mut has_centre = false;
            for (j, (&g, &k)) in prim.iter().zip(corner).enumerate() {
                let g = g as usize;
                if g >= n {
                    return Err(mesh_err(
                        path,
                        format!(
                            "vertex {j} has primitive_id {g}, but the original has {n} Gaussians"
                        ),
                    ));
                }
                if k as usize == CORNERS {
                    has_centre = true;
                    continue;
                }
                if k as usize > CORNERS {
                    return Err(mesh_err(path, format!("vertex {j} has corner_id {k}: an octagon has corners 0-7 (and 8, a centre)")));
                }
                let bit = 1u16 << k;
                if filled[g] & bit != 0 {
                    return Err(mesh_err(
                        path,
                        format!("Gaussian {g} has corner {k} twice (vertex {j})"),
                    ));
                }
                filled[g] |= bit;
                corners[g].get_or_insert([DVec3::ZERO; CORNERS])[k as usize] = mesh.positions[j];
            }
            for (g, &f) in filled.iter().enumerate() {
                if f != 0 && f != 0xff {
                    let missing = (0..8).find(|k| f & (1 << k) == 0).unwrap();
                    return Err(mesh_err(
                        path,
                        format!("the octagon of Gaussian {g} lacks corner {missing}"),
                    ));
                }
            }
            let with_octagon = filled.iter().filter(|&&f| f != 0).count();
            if let Some(&g) = selected.iter().find(|&&g| filled[g] == 0) {
                return Err(mesh_err(
                    path,
                    format!(
                        "the mesh has octagons for {with_octagon} Gaussians, but {} of the original's have one \
                         (Q {}, min opacity {}): Gaussian {g} has none",
                        selected.len(), options.q, options.min_opacity
                    ),
                ));
            }
            owner = prim.clone();
            per = if has_centre { CORNERS + 1 } else { CORNERS };
            Ok::<(), Error>(())
        }
        _ => {
            let s = selected.len();
            per = if v == s * CORNERS {
                CORNERS
            } else if v == s * (CORNERS + 1) && s > 0 {
                CORNERS + 1
            } else {
                return Err(mesh_err(
                    path,
                    format!(
                        "{v} vertices, no primitive_id/corner_id to match them by, and the original has {s} \
                         Gaussians with an octagon (Q {}, min opacity {}): {} or {} vertices were expected, \
                         in Gaussian order",
                        options.q,
                        options.min_opacity,
                        s * CORNERS,
                        s * (CORNERS + 1)
                    ),
                ));
            };
            let falloff = if per == CORNERS {
                Falloff::Constant
            } else {
                Falloff::Centre
            };
            for (j, &g) in selected.iter().enumerate() {
                corners[g] = Some(std::array::from_fn(|k| {
                    mesh.positions[j * per + falloff.corner_slot(k)]
                }));
            }
            owner = (0..v).map(|j| selected[j / per] as u32).collect();
            Ok(())
        }
    }?;
    // Faces: within one octagon, with distinct in-range vertices and some area.
    for (f, face) in mesh.faces.iter().enumerate() {
        if face.len() < 3 {
            return Err(mesh_err(
                path,
                format!("face {f} has {} vertices", face.len()),
            ));
        }
        if let Some(&i) = face.iter().find(|&&i| i as usize >= v) {
            return Err(mesh_err(
                path,
                format!("face {f} names vertex {i}; the mesh has {v}"),
            ));
        }
        let g = owner[face[0] as usize];
        if face.iter().any(|&i| owner[i as usize] != g) {
            return Err(mesh_err(
                path,
                format!("face {f} joins vertices of different octagons (Gaussians {g} and {}): not an octagon mesh",
                    face.iter().map(|&i| owner[i as usize]).find(|&o| o != g).unwrap()),
            ));
        }
        let p: Vec<DVec3> = face.iter().map(|&i| mesh.positions[i as usize]).collect();
        let normal: DVec3 = (1..p.len() - 1)
            .map(|k| (p[k] - p[0]).cross(p[k + 1] - p[0]))
            .sum();
        let size = p.iter().map(|q| (*q - p[0]).length()).fold(0.0, f64::max);
        // Written so that NaN counts as degenerate.
        if normal.length().partial_cmp(&(1e-12 * size * size)) != Some(std::cmp::Ordering::Greater)
        {
            return Err(mesh_err(path, format!("face {f} is degenerate (no area)")));
        }
    }
    Ok(MatchedOctagons {
        corners,
        by_ids: mesh.primitive_ids.is_some(),
        vertices_per_octagon: per,
    })
}

/// Turns the edited `mesh` back into Gaussians: the original's opacity and SH (turned with
/// `--rotate-sh`), the geometry fitted from each octagon; Gaussians without one are kept.
pub fn import_mesh(
    mesh: &MeshData,
    original: &Scene,
    options: &ImportOptions,
    path: &Path,
) -> Result<(Scene, ImportReport)> {
    let matched = match_octagons(mesh, original, options, path)?;
    let mut scene = original.clone();
    let mut report = ImportReport {
        matched_by_ids: matched.by_ids,
        vertices_per_octagon: matched.vertices_per_octagon,
        ..Default::default()
    };
    let stride = original.sh_stride();
    for (g, c) in matched.corners.iter().enumerate() {
        let Some(c) = c else {
            report.kept += 1;
            continue;
        };
        let rho = octagon_radius(options.q, original.opacities[g]);
        if rho <= 0.0 {
            return Err(mesh_err(
                path,
                format!(
                    "the mesh has an octagon for Gaussian {g}, whose opacity {} gives it none \
                     under Q {} (was it exported with another --q?)",
                    original.opacities[g], options.q
                ),
            ));
        }
        let fitted = match options.fit {
            Fit::Redisplats => fit_redisplats(c, rho),
            Fit::Lsq => fit_lsq(c, rho),
        }
        .map_err(|e| mesh_err(path, format!("the octagon of Gaussian {g}: {e}")))?;
        scene.means[g] = fitted.mean.as_vec3();
        scene.scales[g] = fitted.scales();
        scene.rotations[g] = fitted.rotation();
        if options.rotate_sh && original.sh_degree > 0 {
            let before = FlatFrame::of(original, g);
            let turn = frame_matrix(&fitted) * frame_matrix(&before).transpose();
            super::sh_rotation::rotate_sh(
                &mut scene.sh[g * stride..(g + 1) * stride],
                original.sh_degree,
                turn,
            );
        }
        report.fitted += 1;
    }
    Ok((scene, report))
}

/// `[n r_a r_b]`.
fn frame_matrix(f: &FlatFrame) -> DMat3 {
    DMat3::from_cols(f.normal, f.r_a, f.r_b)
}

/// The mesh files of a folder of frames (.obj, .ply, .glb), in name order.
pub fn frame_files(dir: &Path) -> Result<Vec<PathBuf>> {
    let entries = std::fs::read_dir(dir).map_err(|source| Error::Io {
        path: dir.to_path_buf(),
        source,
    })?;
    let mut files: Vec<PathBuf> = entries
        .filter_map(|e| e.ok().map(|e| e.path()))
        .filter(|p| {
            p.is_file()
                && p.extension().is_some_and(|e| {
                    super::export::MeshFormat::EXTENSIONS
                        .contains(&e.to_string_lossy().to_ascii_lowercase().as_str())
                })
        })
        .collect();
    files.sort();
    if files.is_empty() {
        return Err(Error::InvalidInput(format!(
            "{}: no mesh frames (.obj, .ply, .glb) in this folder",
            dir.display()
        )));
    }
    Ok(files)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_vertices_nodes_place_are_bounded_at_the_edge() {
        let path = Path::new("t.gltf");
        let most = MAX_PLACED_VERTICES;
        check_placed(most, most, "vertices", path).unwrap();
        let e = check_placed(most + 1, most, "vertices", path).unwrap_err();
        assert!(e.to_string().contains("134217729 vertices"), "{e}");
        let most = MAX_PLACED_INDICES;
        check_placed(most, most, "vertex indices", path).unwrap();
        assert!(check_placed(most + 1, most, "vertex indices", path).is_err());
        // Through a document: 2^17 vertices under 2^10 nodes is the most; one node more is
        // refused before anything is read (the accessor has no data at all).
        let doc = |nodes: usize| {
            let v = serde_json::json!({
                "asset": {"version": "2.0"},
                "scene": 0,
                "scenes": [{"nodes": [0]}],
                "nodes": std::iter::once(serde_json::json!({"children": (1..=nodes).collect::<Vec<_>>()}))
                    .chain((0..nodes).map(|_| serde_json::json!({"mesh": 0})))
                    .collect::<Vec<_>>(),
                "meshes": [{"primitives": [{"attributes": {"POSITION": 0}}]}],
                "accessors": [{"bufferView": 0, "componentType": 5126, "count": 1 << 17, "type": "VEC3"}]
            });
            Document::from_bytes(&serde_json::to_vec(&v).unwrap(), path).unwrap()
        };
        let e = read_gltf_mesh(&doc(1024), path).unwrap_err();
        assert!(e.to_string().contains("no buffer view 0"), "{e}");
        let e = read_gltf_mesh(&doc(1025), path).unwrap_err();
        assert!(e.to_string().contains("134348800 vertices"), "{e}");
    }
}
