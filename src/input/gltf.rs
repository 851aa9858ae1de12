//! The glTF 2.0 container that both glTF readers share, the splat reader
//! ([`crate::formats::gltf`]) and the mesh reader ([`crate::mesh::import`]): the `.glb` or
//! `.gltf` file and its buffers, buffer views and accessors read with checked arithmetic, and
//! the node hierarchy walked with a visited set and a depth limit.
//!
//! Everything in a glTF file is an untrusted number: an accessor's `byteOffset` near 2^64, a
//! count times a stride past the end, a node that is its own child. Every offset and length is
//! added and multiplied with overflow checks and compared with the bytes there are before a
//! byte is read, and an error names the accessor, view or node. The `gltf` crate's own
//! accessor iterators add those numbers unchecked, so they are not used on a file's data.
//!
//! Limits ([`MAX_GLTF_BYTES`], [`MAX_NODE_DEPTH`]) are in docs/ARCHITECTURE.md.

use std::path::{Path, PathBuf};

use glam::{DMat4, DQuat, DVec3};
use gltf::json;
use json::accessor::ComponentType;
use serde_json::Value;

use super::{read_side_file, side_file, InputFile};
use crate::error::{Error, Result};

/// The largest glTF file, and the largest buffer, rara reads: 4 GiB (glb's own lengths are
/// 32-bit).
pub const MAX_GLTF_BYTES: u64 = 4 << 30;

/// The deepest node hierarchy rara walks: 4096 levels (real assets nest a few dozen: a
/// character's bone chain, a CAD assembly). The walk also visits each node once, so a cycle or
/// a node with two parents is an error however shallow.
pub const MAX_NODE_DEPTH: usize = 4096;

/// A glTF document and its buffers.
pub struct Document {
    /// The document, as `gltf-json` types.
    pub root: json::Root,
    /// The raw JSON, for what `gltf-json` cannot name (the splat extension's attributes).
    pub raw: Value,
    /// Each buffer's bytes, exactly its `byteLength` of them.
    pub buffers: Vec<Vec<u8>>,
    path: PathBuf,
}

/// A checked accessor: its bytes, and where each element lies in them.
struct Layout<'a> {
    data: &'a [u8],
    count: usize,
    offset: usize,
    stride: usize,
    /// Bytes of one component.
    size: usize,
    components: usize,
    component_type: ComponentType,
    normalized: bool,
}

impl Layout<'_> {
    /// Component `k` of element `i` as a number (an integer's value, not normalised).
    fn raw(&self, i: usize, k: usize) -> f64 {
        // In range: `offset + (count - 1) stride + components size <= data.len()` was checked.
        let at = self.offset + i * self.stride + k * self.size;
        let b = &self.data[at..at + self.size];
        match self.component_type {
            ComponentType::F32 => f32::from_le_bytes([b[0], b[1], b[2], b[3]]) as f64,
            ComponentType::U8 => b[0] as f64,
            ComponentType::I8 => b[0] as i8 as f64,
            ComponentType::U16 => u16::from_le_bytes([b[0], b[1]]) as f64,
            ComponentType::I16 => i16::from_le_bytes([b[0], b[1]]) as f64,
            ComponentType::U32 => u32::from_le_bytes([b[0], b[1], b[2], b[3]]) as f64,
        }
    }

    /// Component `k` of element `i` as glTF reads a float attribute: a float as it is, a
    /// normalised integer mapped to `[0, 1]` or `[-1, 1]`.
    fn float(&self, i: usize, k: usize) -> f32 {
        let v = self.raw(i, k);
        (match self.component_type {
            ComponentType::F32 => v,
            ComponentType::U8 => v / 255.0,
            ComponentType::I8 => (v / 127.0).max(-1.0),
            ComponentType::U16 => v / 65535.0,
            ComponentType::I16 => (v / 32767.0).max(-1.0),
            ComponentType::U32 => v / u32::MAX as f64,
        }) as f32
    }
}

/// What [`Document::ids`] reads.
fn id_of(v: f64) -> u32 {
    if v >= 0.0 && v.fract() == 0.0 && v < u32::MAX as f64 {
        v as u32
    } else {
        u32::MAX
    }
}

impl Document {
    /// Reads the `.glb` or `.gltf` at `path` and every buffer it names.
    pub fn open(path: &Path) -> Result<Document> {
        let bytes = InputFile::open(path, "glTF file")?.read_all(MAX_GLTF_BYTES, "glTF file")?;
        Document::from_bytes(&bytes, path)
    }

    /// The document in `bytes`, a `.glb` or a `.gltf`'s JSON read from `path` (whose folder
    /// holds the buffers its URIs name).
    pub fn from_bytes(bytes: &[u8], path: &Path) -> Result<Document> {
        let bad = |m: String| bad(path, m);
        let (json_bytes, bin) = if bytes.starts_with(b"glTF") {
            // The header's length first, so a cut file says so rather than what the chunk
            // parser trips on (and a length under the header's own 12 bytes is refused before
            // the crate subtracts them).
            let length = bytes
                .get(8..12)
                .map(|l| u32::from_le_bytes([l[0], l[1], l[2], l[3]]) as usize)
                .ok_or_else(|| bad("a glb shorter than its 12-byte header".into()))?;
            if length > bytes.len() {
                return Err(bad(format!(
                    "the glb header gives {length} bytes and the file has {} (truncated)",
                    bytes.len()
                )));
            }
            if length < bytes.len() {
                return Err(bad(format!(
                    "{} bytes follow the {length} the glb header gives",
                    bytes.len() - length
                )));
            }
            if length < 20 {
                return Err(bad(format!(
                    "the glb header gives {length} bytes, too few for a header and a JSON chunk"
                )));
            }
            let glb = gltf::Glb::from_slice(&bytes[..length]).map_err(|e| bad(e.to_string()))?;
            (glb.json.into_owned(), glb.bin.map(|b| b.into_owned()))
        } else {
            (bytes.to_vec(), None)
        };
        let raw: Value = serde_json::from_slice(&json_bytes).map_err(|e| bad(e.to_string()))?;
        let root: json::Root =
            serde_json::from_value(raw.clone()).map_err(|e| bad(e.to_string()))?;
        let mut bin = bin;
        let mut buffers = Vec::with_capacity(root.buffers.len());
        for (i, b) in root.buffers.iter().enumerate() {
            let length = b.byte_length.0;
            if length > MAX_GLTF_BYTES {
                return Err(bad(format!(
                    "buffer {i}'s byteLength {length} is more than the {MAX_GLTF_BYTES} rara reads"
                )));
            }
            let mut data = match &b.uri {
                None => bin.take().ok_or_else(|| {
                    bad(format!("buffer {i} has no uri and the file no BIN chunk"))
                })?,
                Some(uri) if uri.starts_with("data:") => {
                    let (_, encoded) = uri
                        .split_once(";base64,")
                        .ok_or_else(|| bad(format!("buffer {i}: a data URI that is not base64")))?;
                    use base64::Engine;
                    base64::engine::general_purpose::STANDARD
                        .decode(encoded)
                        .map_err(|e| bad(format!("buffer {i}: {e}")))?
                }
                Some(uri) => {
                    let what = format!("buffer {i}'s uri");
                    let file = side_file(path, false, uri, &what)?;
                    read_side_file(&file, Some(length), MAX_GLTF_BYTES, "glTF buffer")?
                }
            };
            if (data.len() as u64) < length {
                return Err(bad(format!(
                    "buffer {i} holds {} bytes where its byteLength says {length}",
                    data.len()
                )));
            }
            // A BIN chunk is padded to 4 bytes; nothing past byteLength is the buffer's.
            data.truncate(length as usize);
            buffers.push(data);
        }
        Ok(Document {
            root,
            raw,
            buffers,
            path: path.to_path_buf(),
        })
    }

    /// The encoded bytes of image `index` (PNG, JPEG...): from its buffer view, its base64
    /// data URI, or the file its URI names beside the document (at most [`MAX_GLTF_BYTES`]).
    pub fn image_bytes(&self, index: usize) -> Result<Vec<u8>> {
        let image = self
            .root
            .images
            .get(index)
            .ok_or_else(|| self.bad(format!("no image {index}")))?;
        match (&image.buffer_view, &image.uri) {
            (Some(view), _) => Ok(self.view(view.value())?.0.to_vec()),
            (None, Some(uri)) if uri.starts_with("data:") => {
                let (_, encoded) = uri.split_once(";base64,").ok_or_else(|| {
                    self.bad(format!("image {index}: a data URI that is not base64"))
                })?;
                use base64::Engine;
                base64::engine::general_purpose::STANDARD
                    .decode(encoded)
                    .map_err(|e| self.bad(format!("image {index}: {e}")))
            }
            (None, Some(uri)) => {
                let file = side_file(&self.path, false, uri, &format!("image {index}'s uri"))?;
                read_side_file(&file, None, MAX_GLTF_BYTES, "glTF image")
            }
            (None, None) => {
                Err(self.bad(format!("image {index} has neither a uri nor a bufferView")))
            }
        }
    }

    fn bad(&self, message: impl std::fmt::Display) -> Error {
        bad(&self.path, message)
    }

    /// The bytes of buffer view `view`, and its stride.
    pub fn view(&self, view: usize) -> Result<(&[u8], Option<usize>)> {
        let v = self
            .root
            .buffer_views
            .get(view)
            .ok_or_else(|| self.bad(format!("no buffer view {view}")))?;
        let buffer = self
            .buffers
            .get(v.buffer.value())
            .ok_or_else(|| self.bad(format!("buffer view {view} names a missing buffer")))?;
        let range = v
            .byte_offset
            .map_or(0, |o| o.0)
            .checked_add(v.byte_length.0)
            .filter(|&end| end <= buffer.len() as u64)
            .map(|end| (end - v.byte_length.0) as usize..end as usize)
            .ok_or_else(|| self.bad(format!("buffer view {view} runs past its buffer")))?;
        Ok((&buffer[range], v.byte_stride.map(|s| s.0)))
    }

    /// Accessor `index`, checked: `components` per element (1, 2, 3 or 4: its type), not
    /// sparse, with a buffer view that holds every element.
    fn layout(&self, index: usize, components: usize) -> Result<Layout<'_>> {
        use json::accessor::Type;
        use json::validation::Checked;
        let a = self
            .root
            .accessors
            .get(index)
            .ok_or_else(|| self.bad(format!("no accessor {index}")))?;
        let want = match components {
            1 => Type::Scalar,
            2 => Type::Vec2,
            3 => Type::Vec3,
            _ => Type::Vec4,
        };
        let Checked::Valid(ty) = a.type_ else {
            return Err(self.bad(format!("accessor {index} has an unknown type")));
        };
        if ty != want {
            return Err(self.bad(format!(
                "accessor {index} is {ty:?}, where {want:?} is needed"
            )));
        }
        let Checked::Valid(json::accessor::GenericComponentType(component_type)) = a.component_type
        else {
            return Err(self.bad(format!("accessor {index} has an unknown component type")));
        };
        if a.sparse.is_some() {
            return Err(self.bad(format!(
                "accessor {index} is sparse, which rara does not read"
            )));
        }
        let view = a
            .buffer_view
            .ok_or_else(|| self.bad(format!("accessor {index} has no buffer view")))?;
        let (data, stride) = self.view(view.value())?;
        let size = match component_type {
            ComponentType::I8 | ComponentType::U8 => 1,
            ComponentType::I16 | ComponentType::U16 => 2,
            ComponentType::U32 | ComponentType::F32 => 4,
        };
        let element = size * components;
        let stride = stride.unwrap_or(element);
        let too_big = || {
            self.bad(format!(
                "accessor {index}: {} elements of {element} bytes from byte {} do not fit in its \
                 buffer view of {} bytes",
                a.count.0,
                a.byte_offset.map_or(0, |o| o.0),
                data.len()
            ))
        };
        let count = usize::try_from(a.count.0).map_err(|_| too_big())?;
        let offset = usize::try_from(a.byte_offset.map_or(0, |o| o.0)).map_err(|_| too_big())?;
        // The end of the last element, every step checked: a byteOffset near 2^64 or a count
        // times a stride past 2^64 is refused, not wrapped.
        let end = match count.checked_sub(1) {
            None => Some(0),
            Some(last) => last
                .checked_mul(stride)
                .and_then(|s| s.checked_add(offset))
                .and_then(|s| s.checked_add(element)),
        };
        if stride < element || !matches!(end, Some(e) if e <= data.len()) {
            return Err(too_big());
        }
        Ok(Layout {
            data,
            count,
            offset,
            stride,
            size,
            components,
            component_type,
            normalized: a.normalized,
        })
    }

    /// Accessor `index`'s element count.
    pub fn count(&self, index: usize) -> Result<usize> {
        self.root
            .accessors
            .get(index)
            .ok_or_else(|| self.bad(format!("no accessor {index}")))
            .and_then(|a| {
                usize::try_from(a.count.0)
                    .map_err(|_| self.bad(format!("accessor {index}'s count is too large")))
            })
    }

    /// Accessor `index` as `components` floats per element: floats, or normalised integers
    /// mapped to `[0, 1]` or `[-1, 1]`.
    pub fn floats(&self, index: usize, components: usize) -> Result<Vec<f32>> {
        let l = self.layout(index, components)?;
        if l.component_type != ComponentType::F32 && !l.normalized {
            return Err(self.bad(format!(
                "accessor {index} holds {:?} that are not normalized",
                l.component_type
            )));
        }
        let mut out = Vec::with_capacity(l.count * l.components);
        for i in 0..l.count {
            for k in 0..l.components {
                out.push(l.float(i, k));
            }
        }
        Ok(out)
    }

    /// Accessor `index` as vertex indices: scalar unsigned integers, not normalised.
    pub fn indices(&self, index: usize) -> Result<Vec<u32>> {
        let l = self.layout(index, 1)?;
        let unsigned = matches!(
            l.component_type,
            ComponentType::U8 | ComponentType::U16 | ComponentType::U32
        );
        if !unsigned || l.normalized {
            return Err(self.bad(format!(
                "accessor {index} holds {:?}{}, where indices are unsigned integers",
                l.component_type,
                if l.normalized { " (normalized)" } else { "" }
            )));
        }
        Ok((0..l.count).map(|i| l.raw(i, 0) as u32).collect())
    }

    /// Accessor `index` as per-vertex ids: floats that are whole numbers (what rara writes;
    /// glTF has no plain integer vertex attributes) or unsigned integers (what another tool may
    /// write); a value that is no id is `u32::MAX`. `None` when the accessor is neither.
    pub fn ids(&self, index: usize) -> Result<Option<Vec<u32>>> {
        let l = self.layout(index, 1)?;
        let readable = match l.component_type {
            ComponentType::F32 => true,
            ComponentType::U8 | ComponentType::U16 | ComponentType::U32 => !l.normalized,
            _ => false,
        };
        Ok(readable.then(|| (0..l.count).map(|i| id_of(l.raw(i, 0))).collect()))
    }

    /// The lists of root nodes to walk: the default scene's; else each scene's; else one list
    /// of every node that is nobody's child. Node indices are checked by the walk.
    pub fn scene_roots(&self) -> Result<Vec<Vec<usize>>> {
        let roots = |s: &json::Scene| s.nodes.iter().map(|n| n.value()).collect::<Vec<_>>();
        Ok(match self.root.scene.map(|s| s.value()) {
            Some(s) => vec![roots(
                self.root
                    .scenes
                    .get(s)
                    .ok_or_else(|| self.bad(format!("no scene {s}")))?,
            )],
            None if !self.root.scenes.is_empty() => self.root.scenes.iter().map(roots).collect(),
            None => {
                let mut child = vec![false; self.root.nodes.len()];
                for n in &self.root.nodes {
                    for c in n.children.iter().flatten() {
                        if let Some(slot) = child.get_mut(c.value()) {
                            *slot = true;
                        }
                    }
                }
                vec![(0..child.len()).filter(|&i| !child[i]).collect()]
            }
        })
    }

    /// Every node of the scenes to walk ([`Document::scene_roots`], [`Document::walk`]) that
    /// places a mesh: `(node, mesh, world matrix)`, in walk order.
    pub fn placed_meshes(&self) -> Result<Vec<(usize, usize, DMat4)>> {
        let mut out = Vec::new();
        for roots in self.scene_roots()? {
            for (index, world) in self.walk(&roots)? {
                if let Some(mesh) = self.root.nodes[index].mesh {
                    out.push((index, mesh.value(), world));
                }
            }
        }
        Ok(out)
    }

    /// The first node of the scenes walked that holds a perspective camera: its world matrix,
    /// the camera's vertical field of view (radians) and its aspect ratio (width / height),
    /// when given. (glTF cameras look down the node's -Z with +Y up; orthographic ones are
    /// skipped.)
    pub fn first_camera(&self) -> Result<Option<(DMat4, f64, Option<f64>)>> {
        for roots in self.scene_roots()? {
            for (index, world) in self.walk(&roots)? {
                let Some(camera) = self.root.nodes[index].camera else {
                    continue;
                };
                let c = self.root.cameras.get(camera.value()).ok_or_else(|| {
                    self.bad(format!("node {index}: no camera {}", camera.value()))
                })?;
                if let Some(p) = &c.perspective {
                    return Ok(Some((world, p.yfov as f64, p.aspect_ratio.map(f64::from))));
                }
            }
        }
        Ok(None)
    }

    /// Every node reached from `roots`, parents before children in the document's order, with
    /// its world matrix. glTF's nodes form trees: a node reached twice (a cycle, a node with
    /// two parents or listed twice) is an error, as is a hierarchy deeper than
    /// [`MAX_NODE_DEPTH`], so the walk takes time and memory in proportion to the nodes.
    pub fn walk(&self, roots: &[usize]) -> Result<Vec<(usize, DMat4)>> {
        let nodes = &self.root.nodes;
        let mut seen = vec![false; nodes.len()];
        let mut out = Vec::new();
        let mut stack: Vec<(usize, DMat4, usize)> = roots
            .iter()
            .rev()
            .map(|&r| (r, DMat4::IDENTITY, 1))
            .collect();
        while let Some((index, parent, depth)) = stack.pop() {
            let node = nodes
                .get(index)
                .ok_or_else(|| self.bad(format!("no node {index}")))?;
            if depth > MAX_NODE_DEPTH {
                return Err(self.bad(format!(
                    "nodes nest deeper than {MAX_NODE_DEPTH} levels (node {index}), the most \
                     rara walks"
                )));
            }
            if std::mem::replace(&mut seen[index], true) {
                return Err(self.bad(format!(
                    "node {index} is reached twice: a cycle, or a node listed twice or under two \
                     parents (glTF's nodes form trees)"
                )));
            }
            let world = parent * local_matrix(node);
            out.push((index, world));
            for child in node.children.iter().flatten().rev() {
                stack.push((child.value(), world, depth + 1));
            }
        }
        Ok(out)
    }
}

/// An error about the glTF at `path`.
pub(crate) fn bad(path: &Path, message: impl std::fmt::Display) -> Error {
    Error::InvalidInput(format!("{}: glTF: {message}", path.display()))
}

/// Refuses `total` things placed by a glTF's nodes (`what`: Gaussians, vertices, vertex
/// indices; each mesh counted once per node that places it) past `most`.
pub(crate) fn check_placed(total: u64, most: u64, what: &str, path: &Path) -> Result<()> {
    if total > most {
        return Err(bad(
            path,
            format!(
                "its nodes place {total} {what} in all (each mesh counted once per node that \
                 places it), more than the {most} rara reads"
            ),
        ));
    }
    Ok(())
}

/// A node's local matrix: its `matrix`, else translation, rotation (normalised) and scale.
pub fn local_matrix(node: &json::scene::Node) -> DMat4 {
    if let Some(m) = node.matrix {
        return DMat4::from_cols_array(&m.map(f64::from));
    }
    let t = node
        .translation
        .map_or(DVec3::ZERO, |t| DVec3::from_array(t.map(f64::from)));
    let r = node.rotation.map_or(DQuat::IDENTITY, |q| {
        DQuat::from_array(q.0.map(f64::from)).normalize()
    });
    let s = node
        .scale
        .map_or(DVec3::ONE, |s| DVec3::from_array(s.map(f64::from)));
    DMat4::from_scale_rotation_translation(s, r, t)
}

#[cfg(test)]
mod tests {
    use super::*;
    use serde_json::json;

    fn doc(value: Value) -> Result<Document> {
        Document::from_bytes(&serde_json::to_vec(&value).unwrap(), Path::new("t.gltf"))
    }

    fn chain(depth: usize) -> Value {
        let nodes: Vec<Value> = (0..depth)
            .map(|i| {
                if i + 1 < depth {
                    json!({"children": [i + 1]})
                } else {
                    json!({})
                }
            })
            .collect();
        json!({"asset": {"version": "2.0"}, "scene": 0, "scenes": [{"nodes": [0]}], "nodes": nodes})
    }

    #[test]
    fn the_depth_limit_holds_at_its_edge() {
        let d = doc(chain(MAX_NODE_DEPTH)).unwrap();
        let roots = d.scene_roots().unwrap();
        assert_eq!(d.walk(&roots[0]).unwrap().len(), MAX_NODE_DEPTH);
        let d = doc(chain(MAX_NODE_DEPTH + 1)).unwrap();
        let e = d.walk(&d.scene_roots().unwrap()[0]).unwrap_err();
        assert!(e.to_string().contains("deeper than 4096"), "{e}");
    }

    #[test]
    fn cycles_and_shared_children_are_refused_at_once() {
        let base = json!({"asset": {"version": "2.0"}, "scene": 0, "scenes": [{"nodes": [0]}]});
        let mut cycle = base.clone();
        cycle["nodes"] = json!([{"children": [0]}]);
        let d = doc(cycle).unwrap();
        let e = d.walk(&[0]).unwrap_err();
        assert!(e.to_string().contains("node 0 is reached twice"), "{e}");
        // Each node lists its child twice, 40 deep: 2^40 paths, refused at the first repeat.
        let mut dag = base;
        dag["nodes"] = Value::Array(
            (0..41)
                .map(|i| {
                    if i < 40 {
                        json!({"children": [i + 1, i + 1]})
                    } else {
                        json!({})
                    }
                })
                .collect(),
        );
        let d = doc(dag).unwrap();
        let e = d.walk(&[0]).unwrap_err();
        assert!(e.to_string().contains("reached twice"), "{e}");
    }

    #[test]
    fn accessor_offsets_are_checked_not_wrapped() {
        let data = base64_of(&[0u8; 24]);
        let gltf = |offset: u64, count: u64| {
            json!({"asset": {"version": "2.0"},
                "buffers": [{"byteLength": 24, "uri": format!("data:application/octet-stream;base64,{data}")}],
                "bufferViews": [{"buffer": 0, "byteLength": 24}],
                "accessors": [{"bufferView": 0, "byteOffset": offset, "componentType": 5126, "count": count, "type": "VEC3"}]})
        };
        assert_eq!(doc(gltf(0, 2)).unwrap().floats(0, 3).unwrap().len(), 6);
        assert_eq!(doc(gltf(12, 1)).unwrap().floats(0, 3).unwrap().len(), 3);
        for (offset, count) in [
            (13, 1),
            (0, 3),
            (u64::MAX - 3, 1),
            (u64::MAX - 11, 2),
            (0, u64::MAX),
        ] {
            let e = doc(gltf(offset, count)).unwrap().floats(0, 3).unwrap_err();
            assert!(
                e.to_string().contains("do not fit"),
                "{offset} {count}: {e}"
            );
        }
    }

    /// A buffer's byteLength at the 4 GiB limit is taken (and then found longer than its
    /// data), one byte more is refused before anything is read.
    #[test]
    fn the_buffer_limit_holds_at_its_edge() {
        let gltf = |length: u64| {
            json!({"asset": {"version": "2.0"},
                "buffers": [{"byteLength": length, "uri": "data:application/octet-stream;base64,AAAA"}]})
        };
        let e = doc(gltf(MAX_GLTF_BYTES)).err().unwrap().to_string();
        assert!(
            e.contains("holds 3 bytes where its byteLength says 4294967296"),
            "{e}"
        );
        let e = doc(gltf(MAX_GLTF_BYTES + 1)).err().unwrap().to_string();
        assert!(e.contains("more than the 4294967296 rara reads"), "{e}");
    }

    fn base64_of(bytes: &[u8]) -> String {
        use base64::Engine;
        base64::engine::general_purpose::STANDARD.encode(bytes)
    }
}
