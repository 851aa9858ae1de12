//! Mixed scenes (SPEC section 8, issue 33): splat scenes, triangle meshes with a diffuse,
//! mirror or glass material (a glTF file's own, textures included), point and directional
//! lights, traced together.
//!
//! - [`file`](mod@file): the JSON scene file;
//! - [`triangles`]: the triangles, their BVH and the watertight ray-triangle test;
//! - [`material`]: materials and textures; [`gltf_material`]: a glTF file's, mapped onto them;
//! - [`MixedScene`]: everything in world space, ready for the CPU reference
//!   ([`crate::reference::mixed`]) and the GPU ([`crate::raytrace::mixed`]).

pub mod file;
pub mod gltf_material;
pub mod material;
pub mod shapes;
pub mod triangles;

use std::path::Path;

use glam::{DMat3, EulerRot, Quat, Vec3};

use crate::clip::{Clip, ClipRegion};
use crate::error::{Error, Result};
use crate::mesh::sh_rotation::ShRotation;
use crate::scene::Scene;
use file::{
    at_error, resolve_path, LightEntry, MaterialEntry, ScaleEntry, SceneFile, TransformEntry,
};
pub use material::{Material, Surface, Texture};
use triangles::{MeshBvh, Triangle};

/// Lights a scene holds at most (each composited Gaussian tests every light for a mesh shadow,
/// inside lavapipe's loop budget: docs/ARCHITECTURE.md).
pub const MAX_LIGHTS: usize = crate::constants::MIXED_MAX_LIGHTS as usize;
/// Triangles a scene holds at most (2^22): device memory of 112 B a triangle (and 48 B more
/// for an opaque one, which the shadow rays' BVH holds too) and 32 B a node, under 1 GB at
/// the limit; the BVH is kept inside the traversal's stack of `MIXED_MESH_STACK`
/// ([`triangles::MeshBvh`]), and a ray's walk that nears lavapipe's loop budget is counted
/// and refused (`MIXED_MESH_VISITS_MAX`).
pub const MAX_TRIANGLES: usize = 1 << 22;
/// Splat scenes a scene file places at most.
pub const MAX_SPLAT_OBJECTS: usize = crate::constants::MIXED_MAX_OBJECTS as usize;
/// The deepest ray tree a scene may ask for.
pub const MAX_RAY_DEPTH: u32 = 8;
/// Default darkening of a Gaussian a mesh shadows (REdiSplats' x0.25).
pub const DEFAULT_SHADOW_STRENGTH: f32 = 0.75;

/// A similarity (or, for meshes, an affine map with a per-axis scale): `x -> R (s * x) + t`.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Transform {
    /// Rotation.
    pub rotation: Quat,
    /// Translation.
    pub translation: Vec3,
    /// Scale per local axis (all equal for splats).
    pub scale: Vec3,
}

impl Default for Transform {
    fn default() -> Self {
        Transform {
            rotation: Quat::IDENTITY,
            translation: Vec3::ZERO,
            scale: Vec3::ONE,
        }
    }
}

impl Transform {
    /// A point's image.
    pub fn point(&self, p: Vec3) -> Vec3 {
        self.rotation * (self.scale * p) + self.translation
    }

    /// A normal's image (the inverse transpose), unit length.
    pub fn normal(&self, n: Vec3) -> Vec3 {
        (self.rotation * (n / self.scale)).normalize_or_zero()
    }

    fn from_entry(file: &Path, at: &str, t: &TransformEntry, uniform_only: bool) -> Result<Self> {
        let mut out = Transform::default();
        if let Some(v) = t.translation {
            if !v.iter().all(|x| x.is_finite()) {
                return Err(at_error(file, &format!("{at}.translation"), "not finite"));
            }
            out.translation = Vec3::from(v);
        }
        match (t.rotation, t.rotation_deg) {
            (Some(_), Some(_)) => {
                return Err(at_error(
                    file,
                    at,
                    "give rotation or rotation_deg, not both",
                ))
            }
            (Some(q), None) => {
                let q = Quat::from_xyzw(q[1], q[2], q[3], q[0]);
                out.rotation = crate::scene::normalized_rotation(q).ok_or_else(|| {
                    at_error(
                        file,
                        &format!("{at}.rotation"),
                        "not a finite, non-zero quaternion",
                    )
                })?;
            }
            (None, Some(a)) => {
                if !a.iter().all(|x| x.is_finite()) {
                    return Err(at_error(file, &format!("{at}.rotation_deg"), "not finite"));
                }
                // x first, then y, then z, about the world axes: R = Rz Ry Rx.
                out.rotation = Quat::from_euler(
                    EulerRot::ZYX,
                    a[2].to_radians(),
                    a[1].to_radians(),
                    a[0].to_radians(),
                );
            }
            (None, None) => {}
        }
        match &t.scale {
            None => {}
            Some(ScaleEntry::Uniform(s)) => out.scale = Vec3::splat(*s),
            Some(ScaleEntry::PerAxis(s)) => {
                if uniform_only && !(s[0] == s[1] && s[1] == s[2]) {
                    return Err(at_error(
                        file,
                        &format!("{at}.scale"),
                        "a splat scene takes one uniform scale (a Gaussian stays a Gaussian \
                         only under a similarity)",
                    ));
                }
                out.scale = Vec3::from(*s);
            }
        }
        if !(out.scale.is_finite() && out.scale.min_element() > 0.0) {
            return Err(at_error(
                file,
                &format!("{at}.scale"),
                "must be positive and finite",
            ));
        }
        Ok(out)
    }

    /// The clip region `r`, given in the local frame, in the world (a similarity: planes and
    /// spheres stay planes and spheres; [`crate::ObjectTransform::region_to_world`], as for the
    /// objects of SPEC section 9). The scale must be uniform, as a splat object's is.
    pub fn region(&self, r: &ClipRegion) -> Result<ClipRegion> {
        let object = crate::ObjectTransform {
            rotation: self.rotation,
            translation: self.translation,
            scale: self.scale.x,
        };
        object.validate()?;
        Ok(object.region_to_world(r))
    }
}

/// A light (SPEC section 8).
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Light {
    /// At a position; intensity over the squared distance.
    Point {
        /// Where.
        position: Vec3,
        /// RGB intensity.
        intensity: Vec3,
    },
    /// At infinity.
    Directional {
        /// Unit direction its light travels.
        direction: Vec3,
        /// RGB intensity.
        intensity: Vec3,
    },
}

/// A splat scene's run of the merged Gaussians and its clip (in world space).
#[derive(Clone, Debug, PartialEq)]
pub struct SplatObject {
    /// First Gaussian in [`MixedScene::gaussians`].
    pub first: u32,
    /// Gaussians.
    pub count: u32,
    /// Its clip, moved into the world.
    pub clip: Clip,
}

/// Everything a mixed frame needs, in world space.
#[derive(Clone, Debug)]
pub struct MixedScene {
    /// Every splat scene's Gaussians, moved into the world (centres, rotations, scales and the
    /// SH, turned with the object) and merged, at the highest SH degree among them.
    pub gaussians: Scene,
    /// Per splat scene, its run of `gaussians` and its clip.
    pub objects: Vec<SplatObject>,
    /// The meshes' triangles and their BVH.
    pub meshes: MeshBvh,
    /// The opaque (diffuse and mirror) triangles alone and their BVH: what shadow queries
    /// test (glass lets light through), so that they never walk a glass mesh's nodes.
    pub occluders: MeshBvh,
    /// Materials, indexed by [`Triangle::material`].
    pub materials: Vec<Material>,
    /// Textures, indexed by [`Material::texture`].
    pub textures: Vec<Texture>,
    /// Lights.
    pub lights: Vec<Light>,
    /// Ambient RGB.
    pub ambient: Vec3,
    /// Background RGB.
    pub background: Vec3,
    /// Depth of the ray tree: rays of a greater depth take the background.
    pub max_depth: u32,
    /// Darkening of a Gaussian a mesh shadows from a light.
    pub shadow_strength: f32,
}

fn colour(file: &Path, at: &str, c: [f32; 3], max: f32) -> Result<Vec3> {
    if !c.iter().all(|x| x.is_finite() && *x >= 0.0 && *x <= max) {
        return Err(at_error(
            file,
            at,
            if max.is_finite() {
                format!("each channel must lie in [0, {max}]")
            } else {
                "each channel must be finite and >= 0".into()
            },
        ));
    }
    Ok(Vec3::from(c))
}

impl MixedScene {
    /// A scene of `gaussians` alone (one object, clipped by `clip`), no mesh and no light.
    pub fn splats_only(gaussians: Scene, clip: Clip, background: Vec3) -> MixedScene {
        let count = gaussians.len() as u32;
        MixedScene {
            gaussians,
            objects: vec![SplatObject {
                first: 0,
                count,
                clip,
            }],
            meshes: MeshBvh::default(),
            occluders: MeshBvh::default(),
            materials: Vec::new(),
            textures: Vec::new(),
            lights: Vec::new(),
            ambient: Vec3::ZERO,
            background,
            max_depth: MAX_RAY_DEPTH,
            shadow_strength: DEFAULT_SHADOW_STRENGTH,
        }
    }

    /// Adds a mesh of `triangles` (world space) with `material`.
    pub fn add_mesh(&mut self, triangles: impl IntoIterator<Item = Triangle>, material: Material) {
        let m = self.materials.len() as u32;
        self.materials.push(material);
        let mut all = std::mem::take(&mut self.meshes).triangles;
        all.extend(triangles.into_iter().map(|mut t| {
            t.material = m;
            t
        }));
        self.set_triangles(all);
    }

    /// Sets the scene's triangles (materials indexed into [`MixedScene::materials`]): builds
    /// the BVH of all of them and the occluders' BVH.
    pub fn set_triangles(&mut self, triangles: Vec<Triangle>) {
        let opaque = triangles
            .iter()
            .filter(|t| self.materials[t.material as usize].is_opaque())
            .copied()
            .collect();
        self.meshes = MeshBvh::build(triangles);
        self.occluders = MeshBvh::build(opaque);
    }

    /// Loads a scene file with every file it names; `load_splats` reads a splat scene (the
    /// CLI's loader, with its progress and warnings).
    pub fn load(path: &Path, load_splats: impl Fn(&Path) -> Result<Scene>) -> Result<MixedScene> {
        let f = SceneFile::read(path)?;
        Self::from_file(f, path, load_splats)
    }

    /// [`MixedScene::load`] from a parsed file; `path` resolves its relative paths and names it
    /// in errors.
    pub fn from_file(
        f: SceneFile,
        path: &Path,
        load_splats: impl Fn(&Path) -> Result<Scene>,
    ) -> Result<MixedScene> {
        if f.splats.len() > MAX_SPLAT_OBJECTS {
            return Err(at_error(
                path,
                "splats",
                format!("at most {MAX_SPLAT_OBJECTS} splat scenes"),
            ));
        }
        if f.lights.len() > MAX_LIGHTS {
            return Err(at_error(
                path,
                "lights",
                format!("at most {MAX_LIGHTS} lights"),
            ));
        }
        let max_depth = f.max_depth.unwrap_or(MAX_RAY_DEPTH);
        if max_depth > MAX_RAY_DEPTH {
            return Err(at_error(
                path,
                "max_depth",
                format!("at most {MAX_RAY_DEPTH}"),
            ));
        }
        let shadow_strength = f.shadow_strength.unwrap_or(DEFAULT_SHADOW_STRENGTH);
        if !(0.0..=1.0).contains(&shadow_strength) {
            return Err(at_error(path, "shadow_strength", "must lie in [0, 1]"));
        }
        let ambient = colour(
            path,
            "ambient",
            f.ambient.unwrap_or([0.0; 3]),
            f32::INFINITY,
        )?;
        let background = colour(path, "background", f.background.unwrap_or([0.0; 3]), 1.0)?;
        let mut lights = Vec::new();
        for (i, l) in f.lights.iter().enumerate() {
            lights.push(match l {
                LightEntry::Point {
                    position,
                    intensity,
                } => {
                    if !position.iter().all(|x| x.is_finite()) {
                        return Err(at_error(
                            path,
                            &format!("lights[{i}].point.position"),
                            "not finite",
                        ));
                    }
                    Light::Point {
                        position: Vec3::from(*position),
                        intensity: colour(
                            path,
                            &format!("lights[{i}].point.intensity"),
                            *intensity,
                            f32::INFINITY,
                        )?,
                    }
                }
                LightEntry::Directional {
                    direction,
                    intensity,
                } => {
                    let d = Vec3::from(*direction);
                    if !(d.is_finite() && d.length() > 0.0) {
                        return Err(at_error(
                            path,
                            &format!("lights[{i}].directional.direction"),
                            "needs a finite, non-zero direction",
                        ));
                    }
                    Light::Directional {
                        direction: d.normalize(),
                        intensity: colour(
                            path,
                            &format!("lights[{i}].directional.intensity"),
                            *intensity,
                            f32::INFINITY,
                        )?,
                    }
                }
            });
        }
        // Splat scenes: moved into the world and merged.
        let mut parts = Vec::new();
        for (i, s) in f.splats.iter().enumerate() {
            let at = format!("splats[{i}]");
            let file = resolve_path(path, &format!("{at}.path"), &s.path)?;
            let t = Transform::from_entry(path, &format!("{at}.transform"), &s.transform, true)?;
            let clip = match &s.clip {
                None => Clip::default(),
                Some(c) => {
                    let mut clip = c
                        .clone()
                        .into_clip()
                        .map_err(|e| at_error(path, &format!("{at}.clip"), e))?;
                    if let Some(r) = &clip.region {
                        clip.region = Some(
                            t.region(r)
                                .map_err(|e| at_error(path, &format!("{at}.clip"), e))?,
                        );
                    }
                    clip
                }
            };
            let scene = load_splats(&file).map_err(|e| at_error(path, &format!("{at}.path"), e))?;
            parts.push((scene, t, clip));
        }
        let mut out = MixedScene {
            gaussians: Scene::default(),
            objects: Vec::new(),
            meshes: MeshBvh::default(),
            occluders: MeshBvh::default(),
            materials: Vec::new(),
            textures: Vec::new(),
            lights,
            ambient,
            background,
            max_depth,
            shadow_strength,
        };
        for (scene, t, clip) in parts {
            out.add_splats(&scene, &t, clip);
        }
        if out.objects.is_empty() {
            // Meshes and lights alone: one empty splat object keeps the frame's layout.
            out.add_splats(&Scene::default(), &Transform::default(), Clip::default());
        }
        // Meshes: the entry's material for all its faces, else the file's own.
        let mut all = Vec::new();
        for (i, m) in f.meshes.iter().enumerate() {
            let at = format!("meshes[{i}]");
            let file = resolve_path(path, &format!("{at}.path"), &m.path)?;
            let t = Transform::from_entry(path, &format!("{at}.transform"), &m.transform, false)?;
            let chosen = match &m.material {
                Some(entry) => Some(material_of(path, &format!("{at}.material"), entry)?),
                None => None,
            };
            let tris = mesh_triangles(&file, &t, chosen, &mut out.materials, &mut out.textures)
                .map_err(|e| at_error(path, &format!("{at}.path"), e))?;
            all.extend(tris);
            if all.len() > MAX_TRIANGLES {
                return Err(at_error(
                    path,
                    &at,
                    format!("the meshes hold more than {MAX_TRIANGLES} triangles"),
                ));
            }
        }
        out.set_triangles(all);
        Ok(out)
    }

    /// Adds a splat object: `scene` moved by `t` (a similarity), clipped by `clip` (given in
    /// the world). The merged Gaussians take the higher of the two SH degrees.
    pub fn add_splats(&mut self, scene: &Scene, t: &Transform, clip: Clip) {
        let s = moved(scene, t);
        let degree = self.gaussians.sh_degree.max(s.sh_degree);
        if degree != self.gaussians.sh_degree {
            self.gaussians = padded(&self.gaussians, degree);
        }
        let first = self.gaussians.len() as u32;
        let s = padded(&s, degree);
        self.gaussians.means.extend_from_slice(&s.means);
        self.gaussians.opacities.extend_from_slice(&s.opacities);
        self.gaussians.scales.extend_from_slice(&s.scales);
        self.gaussians.rotations.extend_from_slice(&s.rotations);
        self.gaussians.sh.extend_from_slice(&s.sh);
        self.objects.push(SplatObject {
            first,
            count: s.len() as u32,
            clip,
        });
    }

    /// Checks what the GPU kernels and the CPU reference assume.
    pub fn validate(&self) -> Result<()> {
        if self.lights.len() > MAX_LIGHTS
            || self.meshes.triangles.len() > MAX_TRIANGLES
            || self.objects.len() > MAX_SPLAT_OBJECTS
            || self.objects.is_empty()
            || self.max_depth > MAX_RAY_DEPTH
        {
            return Err(Error::InvalidInput(format!(
                "a mixed scene holds 1 to {MAX_SPLAT_OBJECTS} splat objects, at most \
                 {MAX_LIGHTS} lights and {MAX_TRIANGLES} triangles, and a ray tree of depth \
                 <= {MAX_RAY_DEPTH}"
            )));
        }
        for o in &self.objects {
            o.clip.validate()?;
        }
        Ok(())
    }

    /// The object that Gaussian `g` belongs to.
    pub fn object_of(&self, g: u32) -> &SplatObject {
        let k = self.objects.partition_point(|o| o.first <= g).max(1) - 1;
        &self.objects[k]
    }
}

/// `scene` with its SH at `degree` (>= its own), the new coefficients 0.
fn padded(scene: &Scene, degree: u32) -> Scene {
    scene.clone().with_sh_degree(degree)
}

/// `scene` moved by `t` (a similarity): centres `s R mu + t`, rotations `R q`, scales `s`
/// times, the SH turned by R (SPEC section 9's rule for objects).
pub fn moved(scene: &Scene, t: &Transform) -> Scene {
    let s = t.scale.x;
    let r = t.rotation;
    let mut out = scene.clone();
    for g in 0..out.len() {
        out.means[g] = t.point(out.means[g]);
        // Not turned (nor renormalized) by the identity: a scene placed as it is must stay
        // the same bits, so that a scene file of it renders as the scene alone (SPEC 8).
        if r != Quat::IDENTITY {
            out.rotations[g] = (r * out.rotations[g]).normalize();
        }
        out.scales[g] *= s;
    }
    if r != Quat::IDENTITY && scene.sh_degree > 0 {
        let turn = ShRotation::new(scene.sh_degree, DMat3::from_quat(r.as_dquat()));
        let stride = out.sh_stride();
        for g in 0..out.len() {
            turn.apply(&mut out.sh[g * stride..(g + 1) * stride]);
        }
    }
    out
}

/// A scene file's `material` entry, checked (`at` names it in errors).
fn material_of(path: &Path, at: &str, entry: &MaterialEntry) -> Result<Material> {
    Ok(match *entry {
        MaterialEntry::Diffuse { color } => {
            Material::diffuse(colour(path, &format!("{at}.diffuse.color"), color, 1.0)?)
        }
        MaterialEntry::Mirror { reflectance } => {
            if !(0.0..=1.0).contains(&reflectance) {
                return Err(at_error(
                    path,
                    &format!("{at}.mirror.reflectance"),
                    "must lie in [0, 1]",
                ));
            }
            Material::mirror(reflectance)
        }
        MaterialEntry::Glass { ior } => {
            if !(ior.is_finite() && ior >= 1.0) {
                return Err(at_error(
                    path,
                    &format!("{at}.glass.ior"),
                    "must be finite and >= 1",
                ));
            }
            Material::glass(ior)
        }
    })
}

/// The material a face without one takes: glTF's default material (white, fully rough), as
/// rara maps it (diffuse white).
pub fn default_material() -> Material {
    Material::diffuse(Vec3::ONE)
}

/// A mesh file's faces as world triangles (polygons as fans), with the file's vertex normals
/// and texture coordinates where it has them. Their materials are appended to `materials`
/// (and their textures to `textures`): `chosen` for every face where given, else the file's
/// own (a glTF's, per primitive; [`default_material`] for a face without one, and for the
/// formats without materials).
pub fn mesh_triangles(
    file: &Path,
    t: &Transform,
    chosen: Option<Material>,
    materials: &mut Vec<Material>,
    textures: &mut Vec<Texture>,
) -> Result<Vec<Triangle>> {
    let gltf = matches!(
        file.extension()
            .map(|e| e.to_string_lossy().to_ascii_lowercase())
            .as_deref(),
        Some("glb" | "gltf")
    );
    let (mesh, own) = if gltf && chosen.is_none() {
        let doc = crate::input::gltf::Document::open(file)?;
        let mesh = crate::mesh::import::read_gltf_mesh(&doc, file)?;
        let own = gltf_material::read_materials(&doc, file)?;
        (mesh, Some(own))
    } else {
        (crate::mesh::import::read_mesh(file)?, None)
    };
    // Each face's index into `materials`.
    let base = materials.len() as u32;
    if let (Some(own), Some(m)) = (&own, mesh.face_materials.iter().flatten().max()) {
        if *m as usize >= own.materials.len() {
            return Err(Error::InvalidInput(format!(
                "{}: a primitive names material {m}, and the file has {}",
                file.display(),
                own.materials.len()
            )));
        }
    }
    let face_material: Box<dyn Fn(usize) -> u32> = match own {
        Some(own) if !own.materials.is_empty() => {
            let first_texture = textures.len() as u32;
            materials.extend(own.materials.iter().map(|m| Material {
                texture: m.texture.map(|k| k + first_texture),
                ..*m
            }));
            textures.extend(own.textures);
            // Faces without a material take the default, after the file's.
            let fallback = materials.len() as u32;
            if mesh.face_materials.iter().any(|m| m.is_none()) {
                materials.push(default_material());
            }
            let faces = mesh.face_materials.clone();
            Box::new(move |f| faces[f].map_or(fallback, |m| base + m))
        }
        _ => {
            materials.push(chosen.unwrap_or_else(default_material));
            Box::new(move |_| base)
        }
    };
    let n = mesh.positions.len();
    let mut out = Vec::new();
    for (f, face) in mesh.faces.iter().enumerate() {
        if face.len() < 3 {
            return Err(Error::InvalidInput(format!(
                "{}: face {f} has {} vertices (a point or a line): a mesh here is of polygons",
                file.display(),
                face.len()
            )));
        }
        if face.iter().any(|&i| i as usize >= n) {
            return Err(Error::InvalidInput(format!(
                "{}: face {f} names a vertex beyond the {n} there are",
                file.display()
            )));
        }
        let material = face_material(f);
        for k in 1..face.len().saturating_sub(1) {
            let idx = [face[0], face[k], face[k + 1]].map(|i| i as usize);
            let v = idx.map(|i| t.point(mesh.positions[i].as_vec3()));
            if !v.iter().all(|p| p.is_finite()) {
                return Err(Error::InvalidInput(format!(
                    "{}: face {f} has a non-finite vertex",
                    file.display()
                )));
            }
            let face_n = Triangle::face_normal(&v);
            let normals = match &mesh.normals {
                Some(ns) => idx.map(|i| {
                    let m = t.normal(ns[i].as_vec3());
                    if m.is_finite() && m.length() > 0.5 {
                        m
                    } else {
                        face_n
                    }
                }),
                None => [face_n; 3],
            };
            let uv = match &mesh.uvs {
                Some(uvs) => idx.map(|i| glam::Vec2::from(uvs[i])),
                None => [glam::Vec2::ZERO; 3],
            };
            out.push(Triangle {
                v,
                n: normals,
                uv,
                material,
            });
        }
    }
    Ok(out)
}
