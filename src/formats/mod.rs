//! Scene file formats (issue 34), told apart by their content (magic bytes and header), not
//! only by the file's extension, and read into [`Scene`].
//!
//! - INRIA PLY ([`crate::ply`]), read;
//! - antimatter15 `.splat` ([`splat`]), read and written;
//! - SPZ, glTF `KHR_gaussian_splatting`, SOG and PlayCanvas compressed PLY are recognised and
//!   named, and refused with a clear error until their readers land.

pub mod splat;

use std::io::Read;
use std::path::Path;

use crate::error::{Error, Result};
use crate::ply::LoadReport;
use crate::scene::Scene;

/// A scene format, as [`detect`] finds it.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum SceneFormat {
    /// INRIA 3DGS PLY.
    Ply,
    /// PlayCanvas compressed PLY (`element chunk` and packed vertices).
    CompressedPly,
    /// antimatter15 `.splat`: 32 bytes per Gaussian, no header.
    Splat,
    /// Niantic SPZ: a gzip stream (versions 2 and 3) or an `NGSP` header (version 4).
    Spz,
    /// glTF 2.0 with `KHR_gaussian_splatting` (`.glb` or `.gltf`).
    Gltf,
    /// PlayCanvas SOG: a zip bundle, or a folder with `meta.json`.
    Sog,
}

impl SceneFormat {
    /// The format's name in messages.
    pub fn name(self) -> &'static str {
        match self {
            SceneFormat::Ply => "PLY",
            SceneFormat::CompressedPly => "PlayCanvas compressed PLY",
            SceneFormat::Splat => "antimatter15 .splat",
            SceneFormat::Spz => "SPZ",
            SceneFormat::Gltf => "glTF",
            SceneFormat::Sog => "SOG",
        }
    }
}

fn io_error(path: &Path, source: std::io::Error) -> Error {
    Error::Io {
        path: path.to_path_buf(),
        source,
    }
}

/// The format of the scene at `path`, from its first bytes (and, for a compressed PLY, its
/// header): `ply\n` is a PLY, with an `element chunk` a compressed one; `1f 8b` (gzip) or
/// `NGSP` an SPZ; `glTF` a glb, or a JSON text with an `"asset"` a `.gltf`; `PK\x03\x04` a
/// SOG bundle, and a folder holding `meta.json` a SOG folder. A file with none of these is a
/// `.splat` when its name says so and its size is a multiple of 32; else an error that names
/// what the file starts with. A pipe or a device, which cannot be read twice, is a PLY.
pub fn detect(path: &Path) -> Result<SceneFormat> {
    match sniff(path)? {
        Sniffed::Format(f) => Ok(f),
        Sniffed::Unknown(head) => Err(Error::InvalidInput(format!(
            "{}: not a scene rara knows (PLY, .splat; SPZ, glTF, SOG and compressed PLY are \
             recognised): {}",
            path.display(),
            starts_with(&head)
        ))),
    }
}

/// What [`sniff`] found.
enum Sniffed {
    Format(SceneFormat),
    /// None of the formats: the file's first bytes.
    Unknown(Vec<u8>),
}

fn starts_with(head: &[u8]) -> String {
    if head.is_empty() {
        return "it is empty".into();
    }
    let shown: Vec<String> = head.iter().take(8).map(|b| format!("{b:02x}")).collect();
    format!("it starts with {}", shown.join(" "))
}

fn sniff(path: &Path) -> Result<Sniffed> {
    if path.is_dir() {
        if path.join("meta.json").is_file() {
            return Ok(Sniffed::Format(SceneFormat::Sog));
        }
        return Err(Error::InvalidInput(format!(
            "{}: a folder without meta.json is no scene",
            path.display()
        )));
    }
    let mut file = std::fs::File::open(path).map_err(|e| io_error(path, e))?;
    // A pipe or a device cannot be read twice: it is streamed as a PLY, the one format read
    // from a stream (`rara render /dev/stdin`).
    if !file.metadata().map_err(|e| io_error(path, e))?.is_file() {
        return Ok(Sniffed::Format(SceneFormat::Ply));
    }
    let mut head = vec![0u8; 4096];
    let mut n = 0;
    while n < head.len() {
        match file.read(&mut head[n..]) {
            Ok(0) => break,
            Ok(k) => n += k,
            Err(e) if e.kind() == std::io::ErrorKind::Interrupted => {}
            Err(e) => return Err(io_error(path, e)),
        }
    }
    head.truncate(n);
    let found = |f| Ok(Sniffed::Format(f));
    if head.starts_with(b"ply\n") || head.starts_with(b"ply\r\n") {
        let text = String::from_utf8_lossy(&head);
        let header = text.split("end_header").next().unwrap_or("");
        let chunked = header
            .lines()
            .any(|l| l.trim_start().starts_with("element chunk"));
        return found(if chunked {
            SceneFormat::CompressedPly
        } else {
            SceneFormat::Ply
        });
    }
    if head.starts_with(&[0x1f, 0x8b]) || head.starts_with(b"NGSP") {
        return found(SceneFormat::Spz);
    }
    if head.starts_with(b"glTF") {
        return found(SceneFormat::Gltf);
    }
    if head.starts_with(b"PK\x03\x04") {
        return found(SceneFormat::Sog);
    }
    let text = String::from_utf8_lossy(&head);
    if text.trim_start().starts_with('{') && text.contains("\"asset\"") {
        return found(SceneFormat::Gltf);
    }
    let ext = path
        .extension()
        .map(|e| e.to_string_lossy().to_ascii_lowercase());
    if ext.as_deref() == Some("splat") {
        let size = std::fs::metadata(path)
            .map_err(|e| io_error(path, e))?
            .len();
        if size % splat::BYTES_PER_SPLAT as u64 == 0 && size > 0 {
            return found(SceneFormat::Splat);
        }
        return Err(Error::InvalidInput(format!(
            "{}: a .splat file holds 32 bytes per Gaussian, and this one has {size} bytes",
            path.display()
        )));
    }
    Ok(Sniffed::Unknown(head))
}

/// Loads the scene at `path` in whichever format it is ([`detect`]).
pub fn load_scene(path: impl AsRef<Path>) -> Result<(Scene, LoadReport)> {
    let path = path.as_ref();
    let format = match sniff(path)? {
        Sniffed::Format(f) => f,
        // Neither PLY nor any other format: the PLY reader says what is wrong (it knows a
        // PLY's layout best, and a scene without a magic is most likely a broken one).
        Sniffed::Unknown(head) => {
            return crate::ply::load_ply(path).map_err(|e| {
                Error::InvalidInput(format!(
                    "{e} (nor .splat, SPZ, glTF, SOG or compressed PLY: {})",
                    starts_with(&head)
                ))
            })
        }
    };
    match format {
        SceneFormat::Ply => crate::ply::load_ply(path),
        SceneFormat::Splat => splat::read_splat(path),
        other => Err(Error::InvalidInput(format!(
            "{}: {} is recognised but not read yet (rara reads PLY and .splat)",
            path.display(),
            other.name()
        ))),
    }
}
