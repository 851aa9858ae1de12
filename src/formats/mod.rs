//! Scene file formats (issue 34), told apart by their content (magic bytes and header), not
//! only by the file's extension, and read into [`Scene`].
//!
//! - INRIA PLY ([`crate::ply`]), read and written;
//! - antimatter15 `.splat` ([`splat`]), read and written;
//! - Niantic SPZ ([`spz`]) and glTF `KHR_gaussian_splatting` ([`gltf`]), read and written;
//! - PlayCanvas SOG ([`sog`]) and compressed PLY ([`compressed_ply`]), read;
//! - and cameras: COLMAP's model folders ([`colmap`]; INRIA's cameras.json is
//!   [`crate::camera`]'s).
//!
//! Every file is read through [`crate::input`] (opened once, its bytes counted against the
//! format's limit).

pub mod colmap;
pub mod compressed_ply;
pub mod gltf;
pub mod sog;
pub mod splat;
pub mod spz;

use std::path::Path;

use glam::{Quat, Vec3};

use crate::error::{Error, Result};
use crate::input::InputFile;
use crate::ply::LoadReport;
use crate::scene::Scene;

/// The parity of each real SH basis function (3DGS order, bands 1 to 3, after the DC) in
/// `x`, `y` and `z`: whether it changes sign when that axis does. Band 1 is `(y, z, x)`,
/// band 2 `(xy, yz, 3z^2 - 1, xz, x^2 - y^2)`, band 3 `(y(3x^2 - y^2), xyz, y(5z^2 - 1),
/// z(5z^2 - 3), x(5z^2 - 1), z(x^2 - y^2), x(x^2 - 3y^2))`.
const SH_PARITY: [[bool; 3]; 15] = [
    [false, true, false],
    [false, false, true],
    [true, false, false],
    [true, true, false],
    [false, true, true],
    [false, false, false],
    [true, false, true],
    [false, false, false],
    [false, true, false],
    [true, true, true],
    [false, true, false],
    [false, false, true],
    [true, false, false],
    [false, false, true],
    [true, false, false],
];

/// Turns `scene` into a frame whose axes are `flips` of its own (`true`: that axis points the
/// other way). Two flips at most, so the change is a rotation by half a turn and keeps the
/// handedness: centres flip, a rotation `q` becomes `F q F` (its vector part flips like a
/// centre) and each SH coefficient takes the sign its basis function takes. SPZ's RUB and
/// glTF's LUF are such turns of rara's RDF.
pub fn flip_axes(scene: &mut Scene, flips: [bool; 3]) {
    assert!(
        flips.iter().filter(|&&f| f).count() % 2 == 0,
        "an odd number of flips would mirror the scene"
    );
    let sign = Vec3::from_array(flips.map(|f| if f { -1.0 } else { 1.0 }));
    for m in &mut scene.means {
        *m *= sign;
    }
    for q in &mut scene.rotations {
        let v = Vec3::new(q.x, q.y, q.z) * sign;
        *q = Quat::from_xyzw(v.x, v.y, v.z, q.w);
    }
    let stride = scene.sh_stride();
    let per_channel = scene.sh_coeffs_per_channel();
    let coeff_sign: Vec<f32> = (1..per_channel)
        .map(|k| {
            let odd = SH_PARITY[k - 1]
                .iter()
                .zip(flips)
                .filter(|(p, f)| **p && *f)
                .count();
            if odd % 2 == 1 {
                -1.0
            } else {
                1.0
            }
        })
        .collect();
    if coeff_sign.iter().all(|&s| s > 0.0) {
        return;
    }
    for g in scene.sh.chunks_exact_mut(stride) {
        for (k, s) in coeff_sign.iter().enumerate() {
            for c in 0..3 {
                g[3 * (k + 1) + c] *= s;
            }
        }
    }
}

/// Adds one decoded Gaussian to `scene` the way the PLY reader does: the rotation normalised,
/// a 3-scale Gaussian far thinner along one axis made flat (SPEC section 6), and a Gaussian
/// with a value that is not finite, a negative scale or a zero rotation dropped and counted.
pub(crate) fn push_decoded(
    scene: &mut Scene,
    dropped: &mut usize,
    mean: Vec3,
    scale: Vec3,
    opacity: f32,
    rotation: Quat,
    sh: &[f32],
) {
    let rotation = crate::scene::normalized_rotation(rotation);
    let finite = mean.is_finite()
        && scale.is_finite()
        && opacity.is_finite()
        && sh.iter().all(|v| v.is_finite());
    match rotation {
        Some(q) if finite && scale.min_element() >= 0.0 => scene.push(
            mean,
            opacity.clamp(OPACITY_MIN, 1.0 - OPACITY_MIN),
            crate::ply::flat_if_degenerate(scale),
            q,
            sh,
        ),
        _ => *dropped += 1,
    }
}

/// A "smallest three" rotation stored in `(w, x, y, z)` order (compressed PLY's and SOG's):
/// the three `stored` components in order around the largest, at index `largest`, which is
/// rebuilt from the unit length (non-negative).
pub(crate) fn from_smallest_three_wxyz(largest: usize, stored: [f64; 3]) -> Quat {
    let mut wxyz = [0f64; 4];
    let mut others = stored.iter();
    for (k, slot) in wxyz.iter_mut().enumerate() {
        if k != largest {
            *slot = *others.next().unwrap();
        }
    }
    wxyz[largest] = (1.0 - stored.iter().map(|v| v * v).sum::<f64>())
        .max(0.0)
        .sqrt();
    let [w, x, y, z] = wxyz.map(|v| v as f32);
    Quat::from_xyzw(x, y, z, w)
}

/// The opacity a decoded Gaussian keeps at least (and `1 - ` it at most): splat-transform's
/// clamp before its logit, so an 8-bit 0 or 255 stays a finite logit when written back.
pub const OPACITY_MIN: f32 = 1e-6;

/// The most bytes a compressed stream may inflate to per byte it holds: generous (real SPZ
/// streams inflate 2 to 5 times), and what bounds a decompression bomb's allocation before
/// any of it is made. SPZ's reference reader uses the same ratio.
pub const MAX_INFLATION: u64 = 1024;

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

/// The format of the scene at `path`, from its first bytes (and, for a compressed PLY, its
/// header): `ply\n` is a PLY, with an `element chunk` a compressed one; `1f 8b` (gzip) or
/// `NGSP` an SPZ; `glTF` a glb, or a JSON text with an `"asset"` a `.gltf`; `PK\x03\x04` a
/// SOG bundle, and a folder holding `meta.json` a SOG folder. A file with none of these is a
/// `.splat` when its name says so; else an error that names what the file starts with.
///
/// This opens the file to read its first bytes: a FIFO, which can be read only once, is
/// better given to [`load_scene`] alone, which tells its format through the one opening.
pub fn detect(path: &Path) -> Result<SceneFormat> {
    if path.is_dir() {
        return sog_folder(path);
    }
    let mut input = InputFile::open(path, "scene")?;
    match sniff(&mut input)? {
        Some(f) => Ok(f),
        None => Err(Error::InvalidInput(format!(
            "{}: not a scene rara knows (PLY, compressed PLY, .splat, SPZ, glTF or SOG): {}",
            path.display(),
            starts_with(input.peek(SNIFF_BYTES)?)
        ))),
    }
}

/// How many of a scene's first bytes tell its format.
const SNIFF_BYTES: usize = 4096;

/// A folder is a SOG when it holds `meta.json`.
fn sog_folder(path: &Path) -> Result<SceneFormat> {
    if path.join("meta.json").is_file() {
        return Ok(SceneFormat::Sog);
    }
    Err(Error::InvalidInput(format!(
        "{}: a folder without meta.json is no scene",
        path.display()
    )))
}

fn starts_with(head: &[u8]) -> String {
    if head.is_empty() {
        return "it is empty".into();
    }
    let shown: Vec<String> = head.iter().take(8).map(|b| format!("{b:02x}")).collect();
    format!("it starts with {}", shown.join(" "))
}

/// The format of `input` from its first bytes (kept for whoever reads it next), or `None`.
fn sniff(input: &mut InputFile) -> Result<Option<SceneFormat>> {
    let has_splat_name = input
        .path()
        .extension()
        .is_some_and(|e| e.eq_ignore_ascii_case("splat"));
    let head = input.peek(SNIFF_BYTES)?;
    let found = |f| Ok(Some(f));
    if head.starts_with(b"ply\n") || head.starts_with(b"ply\r\n") {
        let text = String::from_utf8_lossy(head);
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
    let text = String::from_utf8_lossy(head);
    if text.trim_start().starts_with('{') {
        // A SOG's meta.json also has an "asset" (its generator); its "means" tell it apart.
        if text.contains("\"means\"") && text.contains("\"count\"") {
            return found(SceneFormat::Sog);
        }
        if text.contains("\"asset\"") {
            return found(SceneFormat::Gltf);
        }
    }
    // `.splat` has no magic: its name says it (its size is checked by its reader).
    if has_splat_name {
        return found(SceneFormat::Splat);
    }
    Ok(None)
}

/// How the readers take what a format leaves open.
#[derive(Clone, Copy, Debug, Default)]
pub struct ReadOptions {
    /// The axes of an SPZ file (RUB unless told otherwise).
    pub spz_axes: spz::SpzAxes,
}

/// Loads the scene at `path` in whichever format it is ([`detect`]), with the default
/// [`ReadOptions`].
pub fn load_scene(path: impl AsRef<Path>) -> Result<(Scene, LoadReport)> {
    load_scene_with(path, &ReadOptions::default())
}

/// Loads the scene at `path` in whichever format it is ([`detect`]). The file is opened once:
/// its format is told from the first bytes read through that opening, and the reader goes on
/// from there, so a FIFO or a pipe (`/dev/stdin`) loads in any format. A PLY streams (memory
/// grows with the vertices that arrive); any other format from a pipe is read whole, at most
/// [`crate::input::MAX_STREAM_BYTES`].
pub fn load_scene_with(
    path: impl AsRef<Path>,
    options: &ReadOptions,
) -> Result<(Scene, LoadReport)> {
    let path = path.as_ref();
    if path.is_dir() {
        sog_folder(path)?;
        return sog::read_sog(path);
    }
    let mut input = InputFile::open(path, "scene")?;
    let Some(format) = sniff(&mut input)? else {
        // Neither PLY nor any other format: the PLY reader says what is wrong (it knows a
        // PLY's layout best, and a scene without a magic is most likely a broken one).
        let head = starts_with(input.peek(SNIFF_BYTES)?);
        return crate::ply::load_ply_input(input).map_err(|e| {
            Error::InvalidInput(format!(
                "{e} (nor .splat, SPZ, glTF, SOG or compressed PLY: {head})"
            ))
        });
    };
    let what = format.name();
    match format {
        SceneFormat::Ply => crate::ply::load_ply_input(input),
        SceneFormat::Splat => splat::read_splat_input(input),
        SceneFormat::Spz => {
            let bytes = input.read_all(spz::MAX_FILE_BYTES, what)?;
            spz::decode(&bytes, path, options.spz_axes)
        }
        SceneFormat::CompressedPly => {
            let bytes = input.read_all(compressed_ply::MAX_FILE_BYTES, what)?;
            compressed_ply::decode(&bytes, path)
        }
        SceneFormat::Sog => sog::read_sog_input(input),
        SceneFormat::Gltf => {
            let bytes = input.read_all(crate::input::gltf::MAX_GLTF_BYTES, what)?;
            gltf::read_gltf_bytes(&bytes, path)
        }
    }
}
