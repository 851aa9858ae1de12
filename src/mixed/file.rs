//! The scene file (`--scene SCENE.json`, SPEC section 8): splat scenes, meshes, lights and the
//! settings of the ray tree, as JSON. Every object refuses unknown fields; a parse error, a
//! missing file and a bad value each name their JSON path (`meshes[1].material.glass.ior`).
//!
//! ```json
//! { "splats": [{ "path": "plant.ply",
//!                "transform": { "translation": [0, 0, 0], "rotation_deg": [0, 0, 0], "scale": 1 },
//!                "clip": { "planes": [[1, 0, 0, 0]] } }],
//!   "meshes": [{ "path": "quad.obj", "transform": { "translation": [0, 0, 1] },
//!                "material": { "mirror": { "reflectance": 0.9 } } }],
//!   "lights": [{ "point": { "position": [0, -2, 0], "intensity": [4, 4, 4] } },
//!              { "directional": { "direction": [0, 1, 0], "intensity": [1, 1, 1] } }],
//!   "ambient": [0.2, 0.2, 0.2], "background": [0, 0, 0], "max_depth": 8,
//!   "shadow_strength": 0.75 }
//! ```
//!
//! Paths are relative to the scene file; one that starts with `$REAL/` is in the folder of
//! real scenes (`$RARA_REAL_DATA`, else `../shared/data/real` from the working directory or
//! above it).

use std::path::{Path, PathBuf};

use serde::Deserialize;

use crate::clip::ClipFile;
use crate::error::{Error, Result};

/// Largest scene file read (the file lists objects; their data is in other files).
pub const MAX_SCENE_FILE_BYTES: u64 = 1 << 20;

/// The whole file.
#[derive(Clone, Debug, Default, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct SceneFile {
    /// Splat scenes.
    #[serde(default)]
    pub splats: Vec<SplatEntry>,
    /// Triangle meshes.
    #[serde(default)]
    pub meshes: Vec<MeshEntry>,
    /// Lights.
    #[serde(default)]
    pub lights: Vec<LightEntry>,
    /// Ambient light RGB (default 0).
    pub ambient: Option<[f32; 3]>,
    /// Background RGB (default black; `render --background` overrides it).
    pub background: Option<[f32; 3]>,
    /// Depth of the ray tree (default 8).
    pub max_depth: Option<u32>,
    /// Darkening of a Gaussian a mesh shadows (default 0.75).
    pub shadow_strength: Option<f32>,
}

/// A splat scene placed in the world.
#[derive(Clone, Debug, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct SplatEntry {
    /// The scene file (.ply).
    pub path: String,
    /// Where it goes (a rigid motion and a uniform scale).
    #[serde(default)]
    pub transform: TransformEntry,
    /// A clip region in the scene's own frame (the clip file's fields).
    pub clip: Option<ClipFile>,
}

/// A triangle mesh placed in the world, with one material.
#[derive(Clone, Debug, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct MeshEntry {
    /// The mesh file (.obj, .ply or .glb).
    pub path: String,
    /// Where it goes (scale may differ per axis).
    #[serde(default)]
    pub transform: TransformEntry,
    /// Its material.
    pub material: MaterialEntry,
}

/// Scale, then rotation, then translation.
#[derive(Clone, Debug, Default, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct TransformEntry {
    /// Translation.
    pub translation: Option<[f32; 3]>,
    /// Rotation as a quaternion `[w, x, y, z]`.
    pub rotation: Option<[f32; 4]>,
    /// Rotation as angles in degrees about x, then y, then z (world axes).
    pub rotation_deg: Option<[f32; 3]>,
    /// A uniform scale (a number) or one per axis (`[x, y, z]`, meshes only).
    pub scale: Option<ScaleEntry>,
}

/// `scale`: one number or three.
#[derive(Clone, Debug, Deserialize)]
#[serde(untagged)]
pub enum ScaleEntry {
    /// Uniform.
    Uniform(f32),
    /// Per axis.
    PerAxis([f32; 3]),
}

/// `material`: one of the three of section 8.
#[derive(Clone, Debug, Deserialize)]
#[serde(deny_unknown_fields, rename_all = "lowercase")]
pub enum MaterialEntry {
    /// Opaque, lit.
    Diffuse {
        /// RGB in [0, 1].
        color: [f32; 3],
    },
    /// A mirror.
    Mirror {
        /// In [0, 1].
        reflectance: f32,
    },
    /// A dielectric.
    Glass {
        /// Index of refraction, >= 1.
        ior: f32,
    },
}

/// `lights[i]`: a point or a directional light.
#[derive(Clone, Debug, Deserialize)]
#[serde(deny_unknown_fields, rename_all = "lowercase")]
pub enum LightEntry {
    /// A point light: intensity falls with the squared distance.
    Point {
        /// Where it is.
        position: [f32; 3],
        /// RGB intensity (>= 0).
        intensity: [f32; 3],
    },
    /// A light at infinity.
    Directional {
        /// The direction its light travels (towards the scene).
        direction: [f32; 3],
        /// RGB intensity (>= 0).
        intensity: [f32; 3],
    },
}

/// An error about the value at JSON path `at` of `file`.
pub fn at_error(file: &Path, at: &str, message: impl std::fmt::Display) -> Error {
    Error::InvalidInput(format!("{}: {at}: {message}", file.display()))
}

impl SceneFile {
    /// Reads and parses a scene file; a syntax or type error names its JSON path. (The values
    /// are checked when the scene is built, [`super::MixedScene::load`].)
    pub fn read(path: &Path) -> Result<SceneFile> {
        let text = crate::input::read_text_limited(path, MAX_SCENE_FILE_BYTES, "scene file")?;
        SceneFile::parse(&text, path)
    }

    /// [`SceneFile::read`] from the text; `path` names the file in errors.
    pub fn parse(text: &str, path: &Path) -> Result<SceneFile> {
        let de = &mut serde_json::Deserializer::from_str(text);
        serde_path_to_error::deserialize(de).map_err(|e| {
            let at = e.path().to_string();
            let inner = e.into_inner();
            let at = if at == "." { "(top level)".into() } else { at };
            at_error(path, &at, inner)
        })
    }
}

/// The folder of real scenes for `$REAL/` paths: `$RARA_REAL_DATA`, else the first
/// `../shared/data/real` found from the working directory upwards.
pub fn real_data_dir() -> Option<PathBuf> {
    if let Some(dir) = std::env::var_os("RARA_REAL_DATA") {
        return Some(PathBuf::from(dir));
    }
    let cwd = std::env::current_dir().ok()?;
    cwd.ancestors()
        .map(|a| a.join("../shared/data/real"))
        .find(|p| p.is_dir())
}

/// Resolves a path of the file at `file` (see the module docs); `at` names it in errors.
pub fn resolve_path(file: &Path, at: &str, path: &str) -> Result<PathBuf> {
    let resolved = if let Some(rest) = path.strip_prefix("$REAL/") {
        let dir = real_data_dir().ok_or_else(|| {
            at_error(
                file,
                at,
                format!(
                    "'{path}' is in the real scenes' folder, and there is none: set \
                     RARA_REAL_DATA"
                ),
            )
        })?;
        dir.join(rest)
    } else {
        let p = PathBuf::from(path);
        if p.is_absolute() {
            p
        } else {
            file.parent().unwrap_or(Path::new(".")).join(p)
        }
    };
    match std::fs::metadata(&resolved) {
        Ok(m) if m.is_file() => {}
        Ok(_) => {
            return Err(at_error(
                file,
                at,
                format!(
                    "{} is not a regular file (a folder, a pipe or a device)",
                    resolved.display()
                ),
            ))
        }
        Err(_) => {
            return Err(at_error(
                file,
                at,
                format!("no such file: {}", resolved.display()),
            ))
        }
    }
    Ok(resolved)
}
