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
//!   "shadow_strength": 0.75,
//!   "camera": { "look_at": { "eye": [0, -1, -4], "target": [0, 0, 0], "fov_y_deg": 50,
//!                            "width": 640, "height": 480 } } }
//! ```
//!
//! The camera (optional; `--cameras` or `--eye` override it) is one of `look_at` (eye,
//! target, optional up, default `[0, -1, 0]`, vertical field of view `fov_y_deg`, default 50,
//! width and height, default 640x480), `inria` (one camera as an INRIA `cameras.json` writes
//! it: width, height, position, rotation rows, fx, fy; its id and img_name are ignored) or
//! `file` (camera `index`, default 0, of a `cameras.json` at `path`). Without the entry, the
//! first perspective camera of the first glTF mesh file that has one is used.
//!
//! Paths are relative to the scene file; one that starts with `$REAL/` is in the folder of
//! real scenes (`$RARA_REAL_DATA`, else `../shared/data/real` from the working directory or
//! above it).

use std::path::{Path, PathBuf};

use glam::{Mat3, Vec3};
use serde::Deserialize;

use crate::camera::{Camera, InriaCamera};
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
    /// The camera frames are rendered from unless the command line gives one.
    pub camera: Option<CameraEntry>,
}

/// `camera`: a look-at camera, an INRIA camera written out, or one of a cameras.json file.
#[derive(Clone, Debug, Deserialize)]
#[serde(deny_unknown_fields, rename_all = "snake_case")]
pub enum CameraEntry {
    /// From `eye` towards `target`.
    LookAt {
        /// The camera centre.
        eye: [f32; 3],
        /// The point at the image's centre.
        target: [f32; 3],
        /// World up (default `[0, -1, 0]`, the INRIA/COLMAP convention).
        up: Option<[f32; 3]>,
        /// Vertical field of view in degrees (default 50).
        fov_y_deg: Option<f32>,
        /// Image width (default 640).
        width: Option<u32>,
        /// Image height (default: three quarters of the width).
        height: Option<u32>,
    },
    /// One camera with the fields of an INRIA `cameras.json` entry (its `id` and `img_name`
    /// ignored).
    Inria(InriaCamera),
    /// Camera `index` of a cameras.json file.
    File {
        /// The file, relative to the scene file (or `$REAL/...`).
        path: String,
        /// Which camera (default 0).
        index: Option<usize>,
    },
}

/// A splat scene placed in the world.
#[derive(Clone, Debug, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct SplatEntry {
    /// The splat scene's file, in any format `render` reads (the caller's loader).
    pub path: String,
    /// Where it goes (a rigid motion and a uniform scale).
    #[serde(default)]
    pub transform: TransformEntry,
    /// A clip region in the scene's own frame (the clip file's fields).
    pub clip: Option<ClipFile>,
}

/// A triangle mesh placed in the world, with one material or the file's own.
#[derive(Clone, Debug, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct MeshEntry {
    /// The mesh file (.obj, .ply or .glb).
    pub path: String,
    /// Where it goes (scale may differ per axis).
    #[serde(default)]
    pub transform: TransformEntry,
    /// Its material for every face; without one, the file's own (a glTF's materials; white
    /// diffuse for a file without any).
    pub material: Option<MaterialEntry>,
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

    /// The file's camera, checked ([`Camera::validate`]), or `None` when it has no `camera`
    /// entry; `path` is the scene file's (for relative paths and errors).
    pub fn camera(&self, path: &Path) -> Result<Option<Camera>> {
        let Some(entry) = &self.camera else {
            return self.gltf_camera(path);
        };
        let camera = match entry {
            CameraEntry::LookAt {
                eye,
                target,
                up,
                fov_y_deg,
                width,
                height,
            } => {
                let width = width.unwrap_or(640);
                let height = height.unwrap_or_else(|| Camera::default_height(width));
                Camera::look_at(
                    Vec3::from_array(*eye),
                    Vec3::from_array(*target),
                    Vec3::from_array(up.unwrap_or([0.0, -1.0, 0.0])),
                    fov_y_deg.unwrap_or(50.0),
                    width,
                    height,
                )
                .map_err(|e| at_error(path, "camera.look_at", e))?
            }
            CameraEntry::Inria(c) => c
                .to_camera()
                .map_err(|e| at_error(path, "camera.inria", e))?,
            CameraEntry::File { path: file, index } => {
                let cameras = resolve_path(path, "camera.file.path", file)?;
                Camera::load_one(cameras, index.unwrap_or(0))
                    .map_err(|e| at_error(path, "camera.file", e))?
            }
        };
        Ok(Some(camera))
    }

    /// Without a `camera` entry: the first perspective camera of the first glTF mesh file
    /// that has one ([`crate::input::gltf::Document::first_camera`]), placed by that mesh
    /// entry's transform as its triangles are (the position through the whole transform, the
    /// axes turned by its rotation), 640 pixels wide and as high as its aspect ratio makes it
    /// (480 without one).
    fn gltf_camera(&self, path: &Path) -> Result<Option<Camera>> {
        for (i, mesh) in self.meshes.iter().enumerate() {
            let at = format!("meshes[{i}].path");
            let lower = mesh.path.to_ascii_lowercase();
            if !(lower.ends_with(".glb") || lower.ends_with(".gltf")) {
                continue;
            }
            let file = resolve_path(path, &at, &mesh.path)?;
            let doc = crate::input::gltf::Document::open(&file)?;
            let Some((world, yfov, aspect)) = doc.first_camera()? else {
                continue;
            };
            if !(yfov > 0.0 && yfov < std::f64::consts::PI) {
                return Err(at_error(
                    path,
                    &at,
                    format!(
                        "{}: the camera's yfov {yfov} is not in (0, pi)",
                        file.display()
                    ),
                ));
            }
            let placed = super::Transform::from_entry(
                path,
                &format!("meshes[{i}].transform"),
                &mesh.transform,
                false,
            )?;
            let eye = world.transform_point3(glam::DVec3::ZERO).as_vec3();
            // The node's axes: right +X, up +Y, backward +Z (scale, which glTF forbids on
            // camera nodes, taken out).
            let axis = |v: glam::DVec3| world.transform_vector3(v).as_vec3();
            let forward = placed.rotation * -axis(glam::DVec3::Z).normalize_or_zero();
            let right_raw = placed.rotation * axis(glam::DVec3::X);
            let right = (right_raw - right_raw.dot(forward) * forward).normalize_or_zero();
            let down = forward.cross(right);
            let width = 640u32;
            let height = aspect
                .filter(|a| a.is_finite() && *a > 0.0)
                .map_or(480, |a| (width as f64 / a).round().max(1.0) as u32);
            let fy = height as f32 / (2.0 * (yfov as f32 / 2.0).tan());
            let camera = Camera {
                width,
                height,
                position: placed.point(eye),
                rotation: Mat3::from_cols(right, down, forward),
                fx: fy,
                fy,
                principal: None,
            };
            camera
                .validate()
                .map_err(|e| at_error(path, &at, format!("{}: its camera: {e}", file.display())))?;
            return Ok(Some(camera));
        }
        Ok(None)
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
