//! Reading and writing 3DGS scenes as PLY files (INRIA layout, SPEC section 1).
//!
//! The header is parsed by `ply-rs`; the payload is decoded here, streaming, with the byte
//! layout of the `vertex` element precomputed once, so an 82 MB scene loads in a fraction of a
//! second and no count from the file is trusted before it is checked against the file size.

use std::fs::File;
use std::io::{BufRead, BufReader, BufWriter, Read, Seek, Write};
use std::path::{Path, PathBuf};

use glam::{Quat, Vec3};
use ply_rs::ply::{Encoding, PropertyType, ScalarType};

use crate::error::{Error, Result};
use crate::scene::{
    in_plane_axes, normalized_rotation, sh_coeffs, smallest_axis, Scene, FLAT_SCALE_RATIO,
};

/// Longest header accepted; real headers are a few kB.
const MAX_HEADER_BYTES: usize = 1 << 20;
/// Vertices decoded per chunk of the binary payload.
const CHUNK_VERTICES: usize = 16384;
/// Longest line of an ascii payload: a vertex of 62 properties takes about 1.5 kB.
const MAX_ASCII_LINE_BYTES: usize = 1 << 16;

/// What [`load_ply`] returns besides the scene.
#[derive(Clone, Debug, Default)]
pub struct LoadReport {
    /// Vertices in the file.
    pub vertices_in_file: usize,
    /// Gaussians dropped because one of their values was NaN or infinite (or their rotation
    /// was zero).
    pub dropped_non_finite: usize,
    /// The encoding: a PLY's as its header names it, or the format's name.
    pub encoding: &'static str,
    /// What the reader saw that a user should know (an SPZ's antialiased flag, an SH band a
    /// scene cannot hold, a draft-era glTF), one sentence each.
    pub notes: Vec<String>,
}

/// Where a chunk of [`for_each_chunk`] sits in the scene.
#[derive(Clone, Copy, Debug)]
pub struct ChunkInfo {
    /// Index (in the loaded scene, after any dropped Gaussian) of the chunk's first Gaussian.
    pub first: usize,
    /// Vertices the file declares (an upper bound on the Gaussians, for progress).
    pub vertices_in_file: usize,
}

/// The callback of [`for_each_chunk`].
type ChunkSink<'a> = &'a mut dyn FnMut(&Scene, ChunkInfo) -> Result<()>;

/// Where the loader puts Gaussians: one scene, or chunks handed to a callback and dropped.
struct Collect<'a> {
    scene: Scene,
    delivered: usize,
    vertices_in_file: usize,
    chunks: Option<(usize, ChunkSink<'a>)>,
}

impl Collect<'_> {
    /// Hands a full chunk to the callback.
    fn after_push(&mut self) -> Result<()> {
        match &self.chunks {
            Some((size, _)) if self.scene.len() >= *size => self.flush(),
            _ => Ok(()),
        }
    }

    /// Hands what is held to the callback (at the end, the last partial chunk).
    fn flush(&mut self) -> Result<()> {
        let Some((_, sink)) = &mut self.chunks else {
            return Ok(());
        };
        if self.scene.is_empty() {
            return Ok(());
        }
        let info = ChunkInfo {
            first: self.delivered,
            vertices_in_file: self.vertices_in_file,
        };
        sink(&self.scene, info)?;
        self.delivered += self.scene.len();
        let degree = self.scene.sh_degree;
        self.scene.means.clear();
        self.scene.opacities.clear();
        self.scene.scales.clear();
        self.scene.rotations.clear();
        self.scene.sh.clear();
        self.scene.sh_degree = degree;
        Ok(())
    }

    /// Reserves room for `count` Gaussians (a checked count), or for one chunk.
    fn reserve(&mut self, count: usize) {
        let n = match &self.chunks {
            Some((size, _)) => count.min(*size),
            None => count,
        };
        reserve(&mut self.scene, n);
    }
}

/// Where each value the loader needs sits among the vertex's properties.
struct Layout {
    /// Index into the decoded property row for: x y z, f_dc 0..3, opacity, scale 0..3,
    /// rot 0..4, then the K f_rest values.
    wanted: Vec<usize>,
    sh_degree: u32,
    f_rest: usize,
    /// The GaMeS / REdiSplats layout: `scale_0, scale_1` only, the normal along local x
    /// (SPEC section 6); slot 9 of `wanted` then repeats slot 8 and is not read.
    two_scales: bool,
    /// Mip-Splatting's `filter_3D` property (its index in the row), where the file has one:
    /// SPEC section 12's 3D filter, applied at load ([`apply_filter_3d`]).
    filter_3d: Option<usize>,
}

const BASE_NAMES: [&str; 14] = [
    "x", "y", "z", "f_dc_0", "f_dc_1", "f_dc_2", "opacity", "scale_0", "scale_1", "scale_2",
    "rot_0", "rot_1", "rot_2", "rot_3",
];

fn ply_err(path: &Path, message: impl Into<String>) -> Error {
    Error::Ply {
        path: path.to_path_buf(),
        message: message.into(),
    }
}

fn scalar_size(t: &ScalarType) -> usize {
    match t {
        ScalarType::Char | ScalarType::UChar => 1,
        ScalarType::Short | ScalarType::UShort => 2,
        ScalarType::Int | ScalarType::UInt | ScalarType::Float => 4,
        ScalarType::Double => 8,
    }
}

/// A scalar of type `t` from the start of `b`, exactly (every PLY type fits an `f64`).
fn decode_f64(t: &ScalarType, b: &[u8], big_endian: bool) -> f64 {
    macro_rules! num {
        ($ty:ty, $n:expr) => {{
            let arr: [u8; $n] = b[..$n].try_into().unwrap();
            (if big_endian {
                <$ty>::from_be_bytes(arr)
            } else {
                <$ty>::from_le_bytes(arr)
            }) as f64
        }};
    }
    match t {
        ScalarType::Char => b[0] as i8 as f64,
        ScalarType::UChar => b[0] as f64,
        ScalarType::Short => num!(i16, 2),
        ScalarType::UShort => num!(u16, 2),
        ScalarType::Int => num!(i32, 4),
        ScalarType::UInt => num!(u32, 4),
        ScalarType::Float => num!(f32, 4),
        ScalarType::Double => num!(f64, 8),
    }
}

/// A property value as the scene holds it (rounded once, from the exact value).
fn decode_scalar(t: &ScalarType, b: &[u8], big_endian: bool) -> f32 {
    decode_f64(t, b, big_endian) as f32
}

/// Reads the header bytes (through `end_header\n`) so that ply-rs never reads an unbounded line.
fn read_header_bytes(path: &Path, reader: &mut impl BufRead) -> Result<Vec<u8>> {
    let mut header = Vec::new();
    loop {
        let n = reader
            .by_ref()
            .take((MAX_HEADER_BYTES - header.len()) as u64)
            .read_until(b'\n', &mut header)
            .map_err(|source| Error::Io {
                path: path.to_path_buf(),
                source,
            })?;
        if header.is_empty() && n == 0 {
            return Err(ply_err(path, "empty file: not a PLY file"));
        }
        if header.len() >= 4 && !header.starts_with(b"ply") {
            return Err(ply_err(
                path,
                "not a PLY file (it does not start with 'ply')",
            ));
        }
        let line_start = header[..header.len().saturating_sub(1)]
            .iter()
            .rposition(|&c| c == b'\n')
            .map_or(0, |p| p + 1);
        let line = String::from_utf8_lossy(&header[line_start..]);
        if line.trim_end() == "end_header" {
            return Ok(header);
        }
        if header.len() >= MAX_HEADER_BYTES {
            return Err(ply_err(
                path,
                format!(
                    "malformed header: longer than {MAX_HEADER_BYTES} bytes (the limit; real \
                     headers are a few kB) without an 'end_header' line"
                ),
            ));
        }
        if n == 0 {
            if header.len() < 4 && !b"ply".starts_with(&header[..header.len().min(3)]) {
                return Err(ply_err(
                    path,
                    "not a PLY file (it does not start with 'ply')",
                ));
            }
            return Err(ply_err(
                path,
                "malformed header: the file ends before an 'end_header' line",
            ));
        }
    }
}

/// How one property of an element is stored.
#[derive(Clone, Debug)]
enum Stored {
    /// One value.
    Scalar(ScalarType),
    /// A count, then that many items.
    List { count: ScalarType, item: ScalarType },
}

impl Stored {
    fn of(path: &Path, element: &str, p: &ply_rs::ply::PropertyDef) -> Result<Stored> {
        Ok(match &p.data_type {
            PropertyType::Scalar(t) => Stored::Scalar(t.clone()),
            PropertyType::List(count, item) => {
                if matches!(count, ScalarType::Float | ScalarType::Double) {
                    return Err(ply_err(
                        path,
                        format!(
                            "element '{element}': list property '{}' has a floating-point \
                             count type; PLY list counts are integers",
                            p.name
                        ),
                    ));
                }
                Stored::List {
                    count: count.clone(),
                    item: item.clone(),
                }
            }
        })
    }

    /// Bytes of a scalar, or of a list's count (its least size).
    fn min_size(&self) -> usize {
        match self {
            Stored::Scalar(t) | Stored::List { count: t, .. } => scalar_size(t),
        }
    }
}

/// Loads a 3DGS PLY file: properties by name, SH degree 0-3, ascii or binary of either
/// endianness. Gaussians with non-finite values are dropped and counted in the report.
///
/// A regular file's counts are checked against its size before anything is allocated for
/// them; anything else (a pipe, a FIFO, `/dev/stdin`) is read as a stream
/// ([`read_ply_stream`]), where memory grows only with the bytes that actually arrive.
pub fn load_ply(path: impl AsRef<Path>) -> Result<(Scene, LoadReport)> {
    let path = path.as_ref();
    let (reader, len) = open_scene_file(path)?;
    read_ply_from(reader, len, path)
}

/// [`load_ply`] from an input opened already (whose first bytes may have been peeked at to
/// tell its format): a regular file is read with its size known, a stream as a stream.
pub fn load_ply_input(input: crate::input::InputFile) -> Result<(Scene, LoadReport)> {
    let path = input.path().to_path_buf();
    let (reader, len) = input.into_stream()?;
    read_ply_from(reader, len, &path)
}

/// The file at `path`, buffered, and its size when it is a regular file (`None` for a pipe or
/// a device, which is then read as a stream).
fn open_scene_file(path: &Path) -> Result<(Box<dyn BufRead>, Option<u64>)> {
    crate::input::InputFile::open(path, "PLY file")?.into_stream()
}

/// [`load_ply`] from any seekable reader holding `len` bytes (a file, a `Cursor` over bytes
/// received from elsewhere); `path` only names the source in errors. Every count in the header
/// is checked against `len` before anything is allocated for it.
pub fn read_ply<R: BufRead + Seek>(
    reader: R,
    len: u64,
    path: &Path,
) -> Result<(Scene, LoadReport)> {
    read_ply_from(reader, Some(len), path)
}

/// [`load_ply`] from a stream of unknown length (a pipe, a socket, a decompressor); `path`
/// only names the source in errors. Nothing is reserved from the header's counts: the scene
/// grows as vertices arrive, and a stream that ends early is a truncated payload.
pub fn read_ply_stream<R: BufRead>(reader: R, path: &Path) -> Result<(Scene, LoadReport)> {
    read_ply_from(reader, None, path)
}

/// The loader: `len` is the input's size when it is known (then every count is checked
/// against it), `None` for a stream.
fn read_ply_from<R: BufRead>(
    reader: R,
    len: Option<u64>,
    path: &Path,
) -> Result<(Scene, LoadReport)> {
    read_ply_into(reader, len, path, None)
}

/// The vertex count the header of the PLY file at `path` declares (only the header is read).
pub fn vertex_count(path: impl AsRef<Path>) -> Result<usize> {
    let path = path.as_ref();
    let file = File::open(path).map_err(|source| Error::Io {
        path: path.to_path_buf(),
        source,
    })?;
    let header_bytes = read_header_bytes(path, &mut BufReader::new(file))?;
    let header_text = String::from_utf8_lossy(&header_bytes).replace('\r', "");
    check_header_structure(path, &header_text)?;
    let header = ply_rs::parser::Parser::<ply_rs::ply::DefaultElement>::new()
        .read_header(&mut header_text.as_bytes())
        .map_err(|e| ply_err(path, format!("malformed header: {e}")))?;
    header
        .elements
        .get("vertex")
        .map(|v| v.count)
        .ok_or_else(|| ply_err(path, "no 'vertex' element in the header"))
}

/// Reads the scene at `path` in chunks of at most `chunk` Gaussians, each handed to `sink`
/// and then dropped, so that memory holds one chunk, never the scene (the export of a
/// multi-million-Gaussian scene). Gaussians are numbered as [`load_ply`] numbers them.
pub fn for_each_chunk(
    path: impl AsRef<Path>,
    chunk: usize,
    sink: &mut dyn FnMut(&Scene, ChunkInfo) -> Result<()>,
) -> Result<LoadReport> {
    let path = path.as_ref();
    let (reader, len) = open_scene_file(path)?;
    read_ply_into(reader, len, path, Some((chunk.max(1), sink))).map(|(_, report)| report)
}

/// The loader behind [`read_ply_from`] and [`for_each_chunk`].
/// Reads and parses a PLY header (up to and with its `end_header` line): its bytes, and what
/// ply-rs makes of them, with errors that name the offending line.
pub(crate) fn read_header(
    path: &Path,
    reader: &mut impl BufRead,
) -> Result<(Vec<u8>, ply_rs::ply::Header)> {
    let header_bytes = read_header_bytes(path, reader)?;
    // ply-rs expects '\n' line ends; accept '\r\n' too.
    let header_text = String::from_utf8_lossy(&header_bytes).replace('\r', "");
    check_header_structure(path, &header_text)?;
    let parser = ply_rs::parser::Parser::<ply_rs::ply::DefaultElement>::new();
    let header = parser
        .read_header(&mut header_text.as_bytes())
        .map_err(|e| {
            // ply-rs's message is a parser dump; name the offending line instead where we can.
            let bad_line = header_text
                .lines()
                .enumerate()
                .find(|(_, l)| parser.read_header_line(&format!("{l}\n")).is_err());
            match bad_line {
                Some((n, l)) => ply_err(
                    path,
                    format!(
                        "malformed header: line {} '{l}' is not a valid PLY header line",
                        n + 1
                    ),
                ),
                None => ply_err(
                    path,
                    format!(
                        "malformed header: {}",
                        e.to_string().lines().next().unwrap_or("")
                    ),
                ),
            }
        })?;
    Ok((header_bytes, header))
}

fn read_ply_into<R: BufRead>(
    mut reader: R,
    len: Option<u64>,
    path: &Path,
    chunks: Option<(usize, ChunkSink<'_>)>,
) -> Result<(Scene, LoadReport)> {
    let (header_bytes, header) = read_header(path, &mut reader)?;
    let (encoding_name, big_endian) = match header.encoding {
        Encoding::Ascii => ("ascii", false),
        Encoding::BinaryLittleEndian => ("binary_little_endian", false),
        Encoding::BinaryBigEndian => ("binary_big_endian", true),
    };
    let vertex_pos = header
        .elements
        .keys()
        .position(|k| k == "vertex")
        .ok_or_else(|| ply_err(path, "no 'vertex' element in the header"))?;
    let element_defs: Vec<_> = header.elements.values().collect();
    let vertex = element_defs[vertex_pos];
    let count = vertex.count;
    let stored_of = |e: &ply_rs::ply::ElementDef| -> Result<Vec<Stored>> {
        e.properties
            .values()
            .map(|p| Stored::of(path, &e.name, p))
            .collect()
    };

    // How every vertex property is stored, in file order.
    let stored = stored_of(vertex)?;
    let layout = vertex_layout(path, vertex, &stored)?;
    let min_row: usize = stored.iter().map(Stored::min_size).sum();

    let mut out = Collect {
        scene: Scene {
            sh_degree: layout.sh_degree,
            ..Default::default()
        },
        delivered: 0,
        vertices_in_file: count,
        chunks,
    };
    let mut report = LoadReport {
        vertices_in_file: count,
        encoding: encoding_name,
        ..Default::default()
    };
    if layout.filter_3d.is_some() && !layout.two_scales {
        report.notes.push(
            "the file's filter_3D property (Mip-Splatting's 3D filter) is applied at load: each \
             covariance widened by filter_3D^2 and its opacity scaled to keep the Gaussian's \
             integral (SPEC section 12)"
                .into(),
        );
    }
    let payload = len.map(|l| l.saturating_sub(header_bytes.len() as u64));
    // With the size known, the counts were checked against it before anything is reserved; a
    // stream trusts no count, reserves nothing and grows as vertices arrive.
    let sized = payload.is_some();

    match header.encoding {
        Encoding::Ascii => {
            let before: Vec<_> = element_defs[..vertex_pos]
                .iter()
                .map(|e| (e.name.as_str(), e.count))
                .collect();
            // Every ascii vertex takes at least 2 bytes per property ("0 ").
            if let Some(remaining) = payload {
                if (count as u128) * (2 * stored.len().max(1)) as u128 > remaining as u128 {
                    return Err(ply_err(
                        path,
                        format!(
                            "truncated payload: the header declares {count} vertices but only \
                             {remaining} bytes follow it"
                        ),
                    ));
                }
            }
            read_ascii(
                path,
                &mut reader,
                &before,
                count,
                &stored,
                &layout,
                sized,
                &mut out,
                &mut report,
            )?;
        }
        _ => {
            // Elements before 'vertex', in file order: rows of fixed size are skipped whole,
            // rows with a list walked one by one (each has at least one count, so the walk
            // ends with the input). Read past, not sought past, so a stream works too.
            let before = element_defs[..vertex_pos]
                .iter()
                .map(|e| Ok((e.name.as_str(), e.count, stored_of(e)?)))
                .collect::<Result<Vec<_>>>()?;
            if let Some(payload) = payload {
                let least = |n: usize, props: &[Stored]| {
                    n as u128 * props.iter().map(|p| p.min_size() as u128).sum::<u128>()
                };
                let needed = least(count, &stored)
                    + before
                        .iter()
                        .map(|(_, n, props)| least(*n, props))
                        .sum::<u128>();
                if needed > payload as u128 {
                    return Err(ply_err(
                        path,
                        format!(
                            "truncated payload: the header declares {count} vertices of {min_row} \
                             bytes ({needed} bytes with the elements before 'vertex') but only \
                             {payload} bytes follow the header"
                        ),
                    ));
                }
            }
            for (name, rows, props) in &before {
                let truncated = |row: String, e: String| {
                    ply_err(
                        path,
                        format!("truncated payload in element '{name}'{row}: {e}"),
                    )
                };
                if props.iter().any(|p| matches!(p, Stored::List { .. })) {
                    for row in 0..*rows {
                        skip_binary_row(&mut reader, props, big_endian)
                            .map_err(|e| truncated(format!(", row {row}"), e))?;
                    }
                } else {
                    let row: u64 = props.iter().map(|p| p.min_size() as u64).sum();
                    let bytes = row.saturating_mul(*rows as u64);
                    skip_bytes(&mut reader, bytes).map_err(|e| truncated(String::new(), e))?;
                }
            }
            read_binary(
                path,
                &mut reader,
                count,
                big_endian,
                &stored,
                &layout,
                sized,
                &mut out,
                &mut report,
            )?;
        }
    }
    out.flush()?;
    Ok((out.scene, report))
}

/// Reads one binary scalar of type `t`, exactly.
fn read_scalar(
    reader: &mut impl Read,
    t: &ScalarType,
    big_endian: bool,
) -> std::result::Result<f64, String> {
    let mut buf = [0u8; 8];
    let n = scalar_size(t);
    reader
        .read_exact(&mut buf[..n])
        .map_err(|e| e.to_string())?;
    Ok(decode_f64(t, &buf[..n], big_endian))
}

/// Reads past `bytes` bytes; fewer left in the input is an error.
fn skip_bytes(reader: &mut impl Read, bytes: u64) -> std::result::Result<(), String> {
    let got =
        std::io::copy(&mut reader.take(bytes), &mut std::io::sink()).map_err(|e| e.to_string())?;
    if got < bytes {
        return Err(format!("the file ends {} bytes early", bytes - got));
    }
    Ok(())
}

/// Reads past one binary property: a scalar, or a list (its count, then its items).
fn skip_property(
    reader: &mut impl Read,
    p: &Stored,
    big_endian: bool,
) -> std::result::Result<(), String> {
    match p {
        Stored::Scalar(t) => skip_bytes(reader, scalar_size(t) as u64),
        Stored::List { count, item } => {
            // Counts are of an integer type (`Stored::of`), which `read_scalar` holds exactly.
            let items = read_scalar(reader, count, big_endian)?;
            if items < 0.0 {
                return Err(format!("a list's count is negative ({items})"));
            }
            skip_bytes(
                reader,
                (items as u64).saturating_mul(scalar_size(item) as u64),
            )
        }
    }
}

/// Reads past one row of an element whose properties may be lists.
fn skip_binary_row(
    reader: &mut impl Read,
    props: &[Stored],
    big_endian: bool,
) -> std::result::Result<(), String> {
    props
        .iter()
        .try_for_each(|p| skip_property(reader, p, big_endian))
}

/// Checks the header's structure before ply-rs parses it, for what ply-rs gets wrong:
///
/// - it panics on a number that does not fit its integer type (found by fuzzing, in element
///   counts and in the format version), so every digit run outside comments must fit a `u64`,
///   and every `element NAME COUNT` line must have a count that fits a `usize`;
/// - it keeps one entry per name, so a property named twice in an element would shift every
///   later field of each record, and an element declared twice would merge into the first:
///   both are errors that name the property or element;
/// - a `property` line before any `element` line gets a debug dump from it.
fn check_header_structure(path: &Path, header_text: &str) -> Result<()> {
    let mut elements: Vec<(&str, usize)> = Vec::new();
    let mut properties: Vec<(&str, usize)> = Vec::new();
    for (n, line) in header_text.lines().enumerate() {
        let mut tokens = line.split_ascii_whitespace();
        let keyword = tokens.next();
        if matches!(keyword, Some("comment") | Some("obj_info")) {
            continue;
        }
        let too_large = line
            .split(|c: char| !c.is_ascii_digit())
            .any(|run| !run.is_empty() && run.parse::<u64>().is_err());
        if too_large {
            return Err(ply_err(
                path,
                format!(
                    "malformed header: line {} '{line}' has a number larger than {}",
                    n + 1,
                    u64::MAX
                ),
            ));
        }
        match keyword {
            Some("element") => {
                let (name, count) = (tokens.next(), tokens.next());
                let valid =
                    count.is_some_and(|c| c.parse::<usize>().is_ok()) && tokens.next().is_none();
                let Some(name) = name.filter(|_| valid) else {
                    return Err(ply_err(
                        path,
                        format!(
                            "malformed header: line {} '{line}' is not 'element NAME COUNT' with \
                             a count in 0..={}",
                            n + 1,
                            usize::MAX
                        ),
                    ));
                };
                if let Some((_, first)) = elements.iter().find(|(e, _)| *e == name) {
                    return Err(ply_err(
                        path,
                        format!(
                            "malformed header: element '{name}' is declared twice (lines {} and \
                             {}); a PLY file has one element of each name",
                            first + 1,
                            n + 1
                        ),
                    ));
                }
                elements.push((name, n));
                properties.clear();
            }
            Some("property") => {
                let Some((element, _)) = elements.last() else {
                    return Err(ply_err(
                        path,
                        format!(
                            "malformed header: line {} '{line}' declares a property before any \
                             'element' line",
                            n + 1
                        ),
                    ));
                };
                // The name is the last token: `property TYPE NAME` or
                // `property list COUNT_TYPE ITEM_TYPE NAME`.
                let Some(name) = line
                    .split_ascii_whitespace()
                    .last()
                    .filter(|_| tokens.next().is_some())
                else {
                    continue; // ply-rs reports the malformed line
                };
                if let Some((_, first)) = properties.iter().find(|(p, _)| *p == name) {
                    return Err(ply_err(
                        path,
                        format!(
                            "malformed header: element '{element}' names the property '{name}' \
                             twice (lines {} and {})",
                            first + 1,
                            n + 1
                        ),
                    ));
                }
                properties.push((name, n));
            }
            _ => {}
        }
    }
    Ok(())
}

fn vertex_layout(
    path: &Path,
    vertex: &ply_rs::ply::ElementDef,
    stored: &[Stored],
) -> Result<Layout> {
    let index_of = |name: &str| vertex.properties.keys().position(|k| k == name);
    let mut wanted = Vec::with_capacity(14 + 45);
    let mut missing = Vec::new();
    // No scale_2 beside scale_0 and scale_1: flat Gaussians in the GaMeS layout.
    let two_scales = index_of("scale_2").is_none()
        && index_of("scale_0").is_some()
        && index_of("scale_1").is_some();
    for name in BASE_NAMES {
        let name = if two_scales && name == "scale_2" {
            "scale_1"
        } else {
            name
        };
        match index_of(name) {
            Some(i) => wanted.push(i),
            None => missing.push(name),
        }
    }
    if !missing.is_empty() {
        return Err(ply_err(
            path,
            format!(
                "element 'vertex' lacks the propert{} {}",
                if missing.len() == 1 { "y" } else { "ies" },
                missing
                    .iter()
                    .map(|m| format!("'{m}'"))
                    .collect::<Vec<_>>()
                    .join(", ")
            ),
        ));
    }
    let f_rest = vertex
        .properties
        .keys()
        .filter(|k| k.starts_with("f_rest_"))
        .count();
    let sh_degree = match f_rest {
        0 => 0,
        9 => 1,
        24 => 2,
        45 => 3,
        k => {
            return Err(ply_err(path, format!(
                "element 'vertex' has {k} 'f_rest_*' properties; 3DGS needs 0, 9, 24 or 45 (SH degree 0-3)"
            )))
        }
    };
    for j in 0..f_rest {
        let name = format!("f_rest_{j}");
        match index_of(&name) {
            Some(i) => wanted.push(i),
            None => {
                return Err(ply_err(
                    path,
                    format!("element 'vertex' lacks the property '{name}'"),
                ))
            }
        }
    }
    // Lists the loader does not use are skipped (SPEC section 1: unknown properties are
    // ignored); one it needs must be a number.
    for &i in &wanted {
        if matches!(stored[i], Stored::List { .. }) {
            let name = vertex.properties.keys().nth(i).map_or("", String::as_str);
            return Err(ply_err(
                path,
                format!("element 'vertex': property '{name}' is a list; 3DGS needs one number"),
            ));
        }
    }
    let filter_3d = index_of("filter_3D");
    if let Some(i) = filter_3d {
        if matches!(stored[i], Stored::List { .. }) {
            return Err(ply_err(
                path,
                "element 'vertex': property 'filter_3D' is a list; the 3D filter is one number",
            ));
        }
    }
    Ok(Layout {
        wanted,
        sh_degree,
        f_rest,
        two_scales,
        filter_3d,
    })
}

/// Mip-Splatting's 3D filter of size `f` on a Gaussian of scales `s` and opacity `o` (SPEC
/// section 12): `Sigma' = Sigma + f^2 I`, which keeps the rotation and takes each scale to
/// `sqrt(s^2 + f^2)`, and `o' = o sqrt(det Sigma / det Sigma')`, the product of `s / s'` over
/// the axes.
pub fn apply_filter_3d(s: Vec3, o: f32, f: f32) -> (Vec3, f32) {
    if f == 0.0 {
        return (s, o);
    }
    let filtered = (s * s + Vec3::splat(f * f)).powf(0.5);
    let ratio = s / filtered;
    (filtered, o * ratio.x * ratio.y * ratio.z)
}

/// Turns one decoded property row into a Gaussian of `scene`, or counts it as dropped.
fn push_gaussian(
    row: &[f32],
    layout: &Layout,
    scene: &mut Scene,
    report: &mut LoadReport,
    sh: &mut Vec<f32>,
) {
    let v = |k: usize| row[layout.wanted[k]];
    let all_finite = layout.wanted.iter().all(|&i| row[i].is_finite());
    // rot_0..3 are (w, x, y, z).
    let rotation = normalized_rotation(Quat::from_xyzw(v(11), v(12), v(13), v(10)));
    let Some(q) = rotation.filter(|_| all_finite) else {
        report.dropped_non_finite += 1;
        return;
    };
    let mut opacity = 1.0 / (1.0 + (-v(6)).exp());
    let scale = if layout.two_scales {
        Vec3::new(0.0, v(7).exp(), v(8).exp())
    } else {
        let mut s = Vec3::new(v(7).exp(), v(8).exp(), v(9).exp());
        if let Some(i) = layout.filter_3d {
            let f = row[i];
            if !(f.is_finite() && f >= 0.0) {
                report.dropped_non_finite += 1;
                return;
            }
            (s, opacity) = apply_filter_3d(s, opacity, f);
        }
        flat_if_degenerate(s)
    };
    if !scale.is_finite() {
        report.dropped_non_finite += 1;
        return;
    }
    // f_rest is channel-major: f_rest[c * (K/3) + j] is coefficient j + 1 of channel c.
    let per_channel = sh_coeffs(layout.sh_degree);
    sh.clear();
    sh.resize(per_channel * 3, 0.0);
    for (c, slot) in sh[..3].iter_mut().enumerate() {
        *slot = v(3 + c);
    }
    let rest_per_channel = layout.f_rest / 3;
    for c in 0..3 {
        for j in 0..rest_per_channel {
            sh[3 * (j + 1) + c] = v(14 + c * rest_per_channel + j);
        }
    }
    scene.push(Vec3::new(v(0), v(1), v(2)), opacity, scale, q, sh);
}

/// A 3-scale Gaussian whose smallest scale is at most [`FLAT_SCALE_RATIO`] of its largest,
/// made flat along that axis (SPEC section 6).
pub(crate) fn flat_if_degenerate(mut scale: Vec3) -> Vec3 {
    let k = smallest_axis(scale);
    if scale[k] <= FLAT_SCALE_RATIO * scale.max_element() {
        scale[k] = 0.0;
    }
    scale
}

#[allow(clippy::too_many_arguments)]
fn read_binary(
    path: &Path,
    reader: &mut impl Read,
    count: usize,
    big_endian: bool,
    stored: &[Stored],
    layout: &Layout,
    sized: bool,
    out: &mut Collect,
    report: &mut LoadReport,
) -> Result<()> {
    if sized {
        out.reserve(count);
    }
    let mut row = vec![0f32; stored.len()];
    let mut sh = Vec::new();
    let types: Option<Vec<ScalarType>> = stored
        .iter()
        .map(|p| match p {
            Stored::Scalar(t) => Some(t.clone()),
            Stored::List { .. } => None,
        })
        .collect();
    let Some(types) = types else {
        // A list among the vertex properties: records differ in length, so they are read one
        // at a time (through the buffered reader), the lists read past.
        for i in 0..count {
            let truncated =
                |e: String| ply_err(path, format!("truncated payload at vertex {i}: {e}"));
            for (p, slot) in stored.iter().zip(row.iter_mut()) {
                match p {
                    Stored::Scalar(t) => {
                        *slot = read_scalar(reader, t, big_endian).map_err(truncated)? as f32
                    }
                    Stored::List { .. } => {
                        skip_property(reader, p, big_endian).map_err(truncated)?
                    }
                }
            }
            push_gaussian(&row, layout, &mut out.scene, report, &mut sh);
            out.after_push()?;
        }
        return Ok(());
    };
    let stride: usize = types.iter().map(scalar_size).sum();
    let offsets: Vec<usize> = types
        .iter()
        .scan(0, |acc, t| {
            let o = *acc;
            *acc += scalar_size(t);
            Some(o)
        })
        .collect();
    // Only the properties the loader uses are decoded.
    let used: Vec<usize> = {
        let mut u = layout.wanted.clone();
        u.sort_unstable();
        u.dedup();
        u
    };
    // A stream's count was checked against no size: it reads at most 1 MiB at a time, as it
    // can trust no count for a larger buffer.
    let mut chunk_vertices = CHUNK_VERTICES.min(count.max(1));
    if !sized {
        chunk_vertices = chunk_vertices.min(((1 << 20) / stride.max(1)).max(1));
    }
    let mut chunk = vec![0u8; stride * chunk_vertices];
    let mut done = 0;
    while done < count {
        let n = (count - done).min(chunk_vertices);
        let bytes = &mut chunk[..n * stride];
        reader
            .read_exact(bytes)
            .map_err(|e| ply_err(path, format!("truncated payload at vertex {done}: {e}")))?;
        for v in bytes.chunks_exact(stride) {
            for &p in &used {
                row[p] = decode_scalar(&types[p], &v[offsets[p]..], big_endian);
            }
            push_gaussian(&row, layout, &mut out.scene, report, &mut sh);
            out.after_push()?;
        }
        done += n;
    }
    Ok(())
}

#[allow(clippy::too_many_arguments)]
fn read_ascii(
    path: &Path,
    reader: &mut impl BufRead,
    before: &[(&str, usize)],
    count: usize,
    stored: &[Stored],
    layout: &Layout,
    sized: bool,
    out: &mut Collect,
    report: &mut LoadReport,
) -> Result<()> {
    let mut line = String::new();
    // Lines are read through a cap, so a payload without line breaks cannot grow `line`
    // without bound: a vertex of 59 properties is a few kB.
    let mut next_line = |line: &mut String, what: &dyn Fn() -> String| -> Result<()> {
        line.clear();
        let n = reader
            .by_ref()
            .take(MAX_ASCII_LINE_BYTES as u64 + 1)
            .read_line(line)
            .map_err(|e| ply_err(path, format!("reading {}: {e}", what())))?;
        if n == 0 {
            return Err(ply_err(
                path,
                format!("truncated payload: end of file while reading {}", what()),
            ));
        }
        if n > MAX_ASCII_LINE_BYTES {
            return Err(ply_err(
                path,
                format!(
                    "{}: a line longer than {MAX_ASCII_LINE_BYTES} bytes",
                    what()
                ),
            ));
        }
        Ok(())
    };
    for (name, rows) in before {
        for row in 0..*rows {
            next_line(&mut line, &|| format!("element '{name}', row {row}"))?;
        }
    }
    if sized {
        out.reserve(count);
    }
    let mut row = vec![0f32; stored.len()];
    let mut sh = Vec::new();
    for i in 0..count {
        next_line(&mut line, &|| format!("vertex {i}"))?;
        let mut tokens = line.split_ascii_whitespace();
        let mut next = |p: usize| {
            tokens.next().ok_or_else(|| {
                ply_err(
                    path,
                    format!(
                        "vertex {i}: the line ends at property {p} of {}",
                        stored.len()
                    ),
                )
            })
        };
        for (p, (kind, slot)) in stored.iter().zip(row.iter_mut()).enumerate() {
            let token = next(p)?;
            let number = || {
                ply_err(
                    path,
                    format!("vertex {i}, property {p}: '{token}' is not a number"),
                )
            };
            match kind {
                Stored::Scalar(_) => *slot = parse_ascii_value(token).ok_or_else(number)?,
                Stored::List { .. } => {
                    let items: usize = token.parse().map_err(|_| {
                        ply_err(
                            path,
                            format!("vertex {i}, property {p}: '{token}' is not a list count"),
                        )
                    })?;
                    for _ in 0..items {
                        next(p)?;
                    }
                }
            }
        }
        push_gaussian(&row, layout, &mut out.scene, report, &mut sh);
        out.after_push()?;
    }
    Ok(())
}

fn parse_ascii_value(token: &str) -> Option<f32> {
    token
        .parse::<f32>()
        .ok()
        .or_else(|| match token.to_ascii_lowercase().as_str() {
            "nan" | "-nan" => Some(f32::NAN),
            "inf" | "infinity" => Some(f32::INFINITY),
            "-inf" | "-infinity" => Some(f32::NEG_INFINITY),
            _ => None,
        })
}

fn reserve(scene: &mut Scene, count: usize) {
    // `count` was checked against the file size before this point (never called for a stream).
    scene.means.reserve(count);
    scene.opacities.reserve(count);
    scene.scales.reserve(count);
    scene.rotations.reserve(count);
    scene.sh.reserve(count * scene.sh_stride());
}

/// PLY encodings [`write_ply`] can produce.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum PlyEncoding {
    /// `binary_little_endian` (what the INRIA trainer writes).
    BinaryLittleEndian,
    /// `binary_big_endian`.
    BinaryBigEndian,
    /// `ascii`.
    Ascii,
}

/// How [`write_ply_layout`] stores the scales.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub enum PlyLayout {
    /// `scale_0..2`; a flat Gaussian's zero scale is written as [`FLAT_SCALE_WRITTEN`] times
    /// its largest, which reads back as 0 (SPEC section 6) and means the same to other tools.
    #[default]
    Inria,
    /// GaMeS / REdiSplats: `scale_0, scale_1` only, every Gaussian flat with its normal along
    /// local x (the rotation's axes are permuted cyclically to put it there).
    Games,
}

/// The ratio to its largest scale at which [`PlyLayout::Inria`] writes a flat Gaussian's zero
/// scale (below [`FLAT_SCALE_RATIO`], so it loads back flat).
pub const FLAT_SCALE_WRITTEN: f32 = 1e-6;

/// Writes `scene` in the INRIA layout (`x y z nx ny nz f_dc f_rest opacity scale rot`, floats),
/// inverting the activations, so that [`load_ply`] reads back the same scene.
pub fn write_ply(scene: &Scene, path: impl AsRef<Path>, encoding: PlyEncoding) -> Result<()> {
    write_ply_layout(scene, path, encoding, PlyLayout::Inria)
}

/// The rotation and the two in-plane scales of flat Gaussian `i` with its normal moved to local
/// x: `R' = R P` for the cyclic permutation `P` that takes x to the normal's axis.
pub fn games_frame(scale: Vec3, rotation: Quat) -> Option<(Quat, f32, f32)> {
    let k = crate::scene::flat_axis(scale)?;
    let (a, b) = in_plane_axes(k);
    let p = glam::Mat3::from_cols(Vec3::AXES[k], Vec3::AXES[a], Vec3::AXES[b]);
    let q = (rotation * Quat::from_mat3(&p)).normalize();
    Some((q, scale[a], scale[b]))
}

/// Writes `scene` as [`write_ply`] does, with the scales in `layout`. [`PlyLayout::Games`]
/// needs every Gaussian flat (`rara flatten` makes them so).
pub fn write_ply_layout(
    scene: &Scene,
    path: impl AsRef<Path>,
    encoding: PlyEncoding,
    layout: PlyLayout,
) -> Result<()> {
    let path = path.as_ref();
    check_layout(scene, layout, path)?;
    let io = |source| Error::Io {
        path: PathBuf::from(path),
        source,
    };
    let mut w = BufWriter::new(File::create(path).map_err(io)?);
    write_ply_to(scene, &mut w, encoding, layout, path)?;
    w.flush().map_err(io)
}

/// Refuses a scene `layout` cannot hold: [`PlyLayout::Games`] holds flat Gaussians only.
fn check_layout(scene: &Scene, layout: PlyLayout, path: &Path) -> Result<()> {
    if layout == PlyLayout::Games {
        if let Some(i) =
            (0..scene.len()).find(|&i| crate::scene::flat_axis(scene.scales[i]).is_none())
        {
            return Err(ply_err(
                path,
                format!(
                    "the GaMeS layout holds flat Gaussians only, and Gaussian {i} has three \
                     nonzero scales (flatten the scene first)"
                ),
            ));
        }
    }
    Ok(())
}

/// Writes `scene` as [`write_ply_layout`] does, to `w` (`path` names it in errors; a file, a
/// buffer or a staged output).
pub fn write_ply_to(
    scene: &Scene,
    w: &mut dyn Write,
    encoding: PlyEncoding,
    layout: PlyLayout,
    path: &Path,
) -> Result<()> {
    check_layout(scene, layout, path)?;
    let io = |source| Error::Io {
        path: PathBuf::from(path),
        source,
    };
    let per_channel = scene.sh_coeffs_per_channel();
    let rest = (per_channel - 1) * 3;
    let mut names: Vec<String> = [
        "x", "y", "z", "nx", "ny", "nz", "f_dc_0", "f_dc_1", "f_dc_2",
    ]
    .map(String::from)
    .to_vec();
    names.extend((0..rest).map(|j| format!("f_rest_{j}")));
    names.push("opacity".into());
    let scale_count = if layout == PlyLayout::Games { 2 } else { 3 };
    names.extend((0..scale_count).map(|k| format!("scale_{k}")));
    names.extend(["rot_0", "rot_1", "rot_2", "rot_3"].map(String::from));
    let format = match encoding {
        PlyEncoding::BinaryLittleEndian => "binary_little_endian",
        PlyEncoding::BinaryBigEndian => "binary_big_endian",
        PlyEncoding::Ascii => "ascii",
    };
    let mut header = format!("ply\nformat {format} 1.0\nelement vertex {}\n", scene.len());
    for n in &names {
        header.push_str(&format!("property float {n}\n"));
    }
    header.push_str("end_header\n");
    w.write_all(header.as_bytes()).map_err(io)?;
    let mut row = Vec::with_capacity(names.len());
    for i in 0..scene.len() {
        row.clear();
        let m = scene.means[i];
        row.extend([m.x, m.y, m.z, 0.0, 0.0, 0.0]);
        let sh = scene.sh_of(i);
        row.extend((0..3).map(|c| sh[c]));
        for c in 0..3 {
            for j in 1..per_channel {
                row.push(sh[3 * j + c]);
            }
        }
        let o = scene.opacities[i];
        row.push((o / (1.0 - o)).ln());
        let s = scene.scales[i];
        let q = match layout {
            PlyLayout::Inria => {
                let written = s.max_element() * FLAT_SCALE_WRITTEN;
                row.extend(
                    s.to_array()
                        .map(|v| (if v == 0.0 { written } else { v }).ln()),
                );
                scene.rotations[i]
            }
            PlyLayout::Games => {
                let (q, sa, sb) = games_frame(s, scene.rotations[i]).expect("checked flat above");
                row.extend([sa.ln(), sb.ln()]);
                q
            }
        };
        row.extend([q.w, q.x, q.y, q.z]);
        match encoding {
            PlyEncoding::BinaryLittleEndian => {
                for v in &row {
                    w.write_all(&v.to_le_bytes()).map_err(io)?;
                }
            }
            PlyEncoding::BinaryBigEndian => {
                for v in &row {
                    w.write_all(&v.to_be_bytes()).map_err(io)?;
                }
            }
            PlyEncoding::Ascii => {
                let line: Vec<String> = row.iter().map(|v| format!("{v:?}")).collect();
                writeln!(w, "{}", line.join(" ")).map_err(io)?;
            }
        }
    }
    Ok(())
}

#[cfg(test)]
mod filter_3d_tests {
    use super::*;

    /// A PLY with Mip-Splatting's `filter_3D` loads with SPEC 12's 3D filter applied (scales
    /// widened, opacity scaled by sqrt(det / det')); the same rows without it load as they are.
    #[test]
    fn the_3d_filter_is_applied_at_load() {
        let header = |extra: &str| {
            format!(
                "ply\nformat ascii 1.0\nelement vertex 1\nproperty float x\nproperty float y\n\
                 property float z\nproperty float f_dc_0\nproperty float f_dc_1\n\
                 property float f_dc_2\nproperty float opacity\nproperty float scale_0\n\
                 property float scale_1\nproperty float scale_2\nproperty float rot_0\n\
                 property float rot_1\nproperty float rot_2\nproperty float rot_3\n{extra}\
                 end_header\n"
            )
        };
        let row = format!(
            "0 0 1 0.1 0.2 0.3 0 {} {} {} 1 0 0 0",
            0.5f32.ln(),
            0.25f32.ln(),
            0.1f32.ln()
        );
        let plain = format!("{}{row}\n", header(""));
        let filtered = format!("{}{row} 0.2\n", header("property float filter_3D\n"));
        let (a, _) =
            read_ply_stream(std::io::Cursor::new(plain.into_bytes()), Path::new("a.ply")).unwrap();
        let (b, report) = read_ply_stream(
            std::io::Cursor::new(filtered.into_bytes()),
            Path::new("b.ply"),
        )
        .unwrap();
        assert!((a.opacities[0] - 0.5).abs() < 1e-6);
        let want = Vec3::new(0.29f32.sqrt(), 0.1025f32.sqrt(), 0.05f32.sqrt());
        assert!(
            (b.scales[0] - want).abs().max_element() < 1e-6,
            "{}",
            b.scales[0]
        );
        let ratio = Vec3::new(0.5, 0.25, 0.1) / want;
        assert!((b.opacities[0] - 0.5 * ratio.x * ratio.y * ratio.z).abs() < 1e-6);
        assert!(
            (a.scales[0] - Vec3::new(0.5, 0.25, 0.1))
                .abs()
                .max_element()
                < 1e-6
        );
        assert!(report.notes.iter().any(|n| n.contains("filter_3D")));
    }
}
