//! A glTF file's materials as mixed-scene [`Material`]s (SPEC section 8 is silent on glTF;
//! docs/ARCHITECTURE.md, "glTF materials in mixed scenes", gives the mapping):
//!
//! - `KHR_materials_transmission` with a `transmissionFactor` above 0: glass of
//!   `KHR_materials_ior`'s `ior` (1.5 without it); its colour is unused.
//! - else a `metallicFactor` of at least 0.5 with a `roughnessFactor` of 0: a mirror whose
//!   reflectance is the base colour;
//! - else diffuse, of the base colour.
//!
//! The base colour is `baseColorFactor`'s RGB times `baseColorTexture`'s (sRGB-decoded,
//! sampled bilinearly at the hit's UV of the `texCoord` set it names, with the sampler's
//! wraps). Every surface adds `emissiveFactor` times `KHR_materials_emissive_strength`'s
//! `emissiveStrength`. Ignored, as docs/CLI.md lists: alpha, roughness above 0 (no glossy
//! reflection), the metallic-roughness, normal, occlusion, emissive and transmission
//! textures, `KHR_texture_transform`, the samplers' filters (always bilinear, no mipmaps).
//!
//! The fields are read from the document's raw JSON: `gltf-json` names none of the three
//! extensions without features this crate does not enable.

use std::collections::HashMap;
use std::path::Path;

use glam::Vec3;
use serde_json::Value;

use super::material::{Material, Surface, Texture, Wrap};
use crate::error::{Error, Result};
use crate::input::gltf::Document;

/// The most texels a mesh file's textures may hold in all: 2^28 (1 GiB on the device).
pub const MAX_TEXELS: u64 = 1 << 28;

/// A glTF file's materials and the textures they sample.
#[derive(Clone, Debug, Default)]
pub struct GltfMaterials {
    /// Per glTF material, its mapping; a [`Material::texture`] indexes
    /// [`GltfMaterials::textures`].
    pub materials: Vec<Material>,
    /// The textures, each (image, sampler) pair once.
    pub textures: Vec<Texture>,
}

fn bad(path: &Path, message: impl std::fmt::Display) -> Error {
    Error::InvalidInput(format!("mesh {}: {message}", path.display()))
}

/// `value` as a number, or `default` where it is absent.
fn number(value: &Value, default: f64, path: &Path, at: &str) -> Result<f64> {
    match value {
        Value::Null => Ok(default),
        Value::Number(n) => n
            .as_f64()
            .ok_or_else(|| bad(path, format!("{at} is not a number"))),
        _ => Err(bad(path, format!("{at} is not a number"))),
    }
}

/// `value` as three numbers in `[lo, hi]`, or `default` where it is absent; a fourth (alpha)
/// is allowed and dropped.
fn rgb(value: &Value, default: Vec3, (lo, hi): (f64, f64), path: &Path, at: &str) -> Result<Vec3> {
    let Some(items) = value.as_array() else {
        return if value.is_null() {
            Ok(default)
        } else {
            Err(bad(path, format!("{at} is not an array")))
        };
    };
    if items.len() < 3 {
        return Err(bad(
            path,
            format!("{at} has {} components, not 3 or 4", items.len()),
        ));
    }
    let mut c = [0.0f32; 3];
    for (k, item) in items.iter().take(3).enumerate() {
        let x = number(item, f64::NAN, path, at)?;
        if !(x.is_finite() && x >= lo && x <= hi) {
            return Err(bad(path, format!("{at}[{k}] is {x}, outside [{lo}, {hi}]")));
        }
        c[k] = x as f32;
    }
    Ok(Vec3::from(c))
}

/// The `texCoord` set material `m`'s base colour texture reads (0 without a texture).
pub fn base_colour_tex_coord(doc: &Document, m: usize) -> u32 {
    doc.raw["materials"][m]["pbrMetallicRoughness"]["baseColorTexture"]["texCoord"]
        .as_u64()
        .unwrap_or(0) as u32
}

/// Whether material `m` samples a base colour texture.
pub fn has_base_colour_texture(doc: &Document, m: usize) -> bool {
    !doc.raw["materials"][m]["pbrMetallicRoughness"]["baseColorTexture"].is_null()
}

/// Reads every material of `doc` (read from `path`) and decodes the textures they sample.
pub fn read_materials(doc: &Document, path: &Path) -> Result<GltfMaterials> {
    let mut out = GltfMaterials::default();
    // (texture's image, its sampler) -> index in out.textures; decoded images by index.
    let mut made: HashMap<(usize, Option<usize>), u32> = HashMap::new();
    let mut texels = 0u64;
    let empty = Vec::new();
    let materials = doc.raw["materials"].as_array().unwrap_or(&empty);
    for (i, m) in materials.iter().enumerate() {
        let at = |field: &str| format!("materials[{i}].{field}");
        let pbr = &m["pbrMetallicRoughness"];
        let colour = rgb(
            &pbr["baseColorFactor"],
            Vec3::ONE,
            (0.0, 1.0),
            path,
            &at("pbrMetallicRoughness.baseColorFactor"),
        )?;
        let metallic = number(&pbr["metallicFactor"], 1.0, path, &at("metallicFactor"))?;
        let roughness = number(&pbr["roughnessFactor"], 1.0, path, &at("roughnessFactor"))?;
        let ext = &m["extensions"];
        let transmission = number(
            &ext["KHR_materials_transmission"]["transmissionFactor"],
            0.0,
            path,
            &at("extensions.KHR_materials_transmission.transmissionFactor"),
        )?;
        let ior = number(
            &ext["KHR_materials_ior"]["ior"],
            1.5,
            path,
            &at("extensions.KHR_materials_ior.ior"),
        )?;
        let strength = number(
            &ext["KHR_materials_emissive_strength"]["emissiveStrength"],
            1.0,
            path,
            &at("extensions.KHR_materials_emissive_strength.emissiveStrength"),
        )?;
        let emissive = rgb(
            &m["emissiveFactor"],
            Vec3::ZERO,
            (0.0, 1.0),
            path,
            &at("emissiveFactor"),
        )?;
        if !(strength.is_finite() && strength >= 0.0) {
            return Err(bad(
                path,
                format!("{} must be finite and >= 0", at("emissiveStrength")),
            ));
        }
        let surface = if transmission > 0.0 {
            if !(ior.is_finite() && ior >= 1.0) {
                return Err(bad(
                    path,
                    format!("{} is {ior}: rara's glass takes an IOR >= 1", at("ior")),
                ));
            }
            Surface::Glass(ior as f32)
        } else if metallic >= 0.5 && roughness == 0.0 {
            Surface::Mirror
        } else {
            Surface::Diffuse
        };
        let texture = match &pbr["baseColorTexture"] {
            Value::Null => None,
            info => {
                let t = info["index"]
                    .as_u64()
                    .ok_or_else(|| bad(path, format!("{} has no index", at("baseColorTexture"))))?
                    as usize;
                let tex = &doc.raw["textures"][t];
                if tex.is_null() {
                    return Err(bad(
                        path,
                        format!("{} names a missing texture {t}", at("baseColorTexture")),
                    ));
                }
                let image = tex["source"].as_u64().ok_or_else(|| {
                    bad(
                        path,
                        format!(
                            "texture {t} has no source image (an image only an extension \
                             gives, such as KTX2 or WebP, is not read)"
                        ),
                    )
                })? as usize;
                let sampler = tex["sampler"].as_u64().map(|s| s as usize);
                let key = (image, sampler);
                if let Some(&k) = made.get(&key) {
                    Some(k)
                } else {
                    let texture = decode(doc, path, image, sampler)?;
                    texels += texture.texels.len() as u64;
                    if texels > MAX_TEXELS {
                        return Err(bad(
                            path,
                            format!(
                                "its textures hold more than the {MAX_TEXELS} texels rara takes"
                            ),
                        ));
                    }
                    let k = out.textures.len() as u32;
                    out.textures.push(texture);
                    made.insert(key, k);
                    Some(k)
                }
            }
        };
        out.materials.push(Material {
            surface,
            colour,
            texture: texture.filter(|_| !matches!(surface, Surface::Glass(_))),
            emission: emissive * strength as f32,
        });
    }
    Ok(out)
}

/// Image `image` of `doc` decoded to sRGB RGBA8, with sampler `sampler`'s wraps.
fn decode(doc: &Document, path: &Path, image: usize, sampler: Option<usize>) -> Result<Texture> {
    let bytes = doc.image_bytes(image)?;
    let mut reader = image::ImageReader::new(std::io::Cursor::new(bytes))
        .with_guessed_format()
        .map_err(|e| bad(path, format!("image {image}: {e}")))?;
    let mut limits = image::Limits::default();
    limits.max_alloc = Some(MAX_TEXELS * 8);
    reader.limits(limits);
    let decoded = reader
        .decode()
        .map_err(|e| bad(path, format!("image {image}: {e}")))?
        .to_rgba8();
    let (width, height) = decoded.dimensions();
    if width == 0 || height == 0 {
        return Err(bad(path, format!("image {image} has no texels")));
    }
    let wrap = |field: &str| -> Result<Wrap> {
        let Some(s) = sampler else {
            return Ok(Wrap::Repeat);
        };
        match &doc.raw["samplers"][s][field] {
            Value::Null => Ok(Wrap::Repeat),
            v => v
                .as_u64()
                .and_then(|c| Wrap::from_gltf(c as u32))
                .ok_or_else(|| {
                    bad(
                        path,
                        format!("samplers[{s}].{field} is {v}, not a wrap mode"),
                    )
                }),
        }
    };
    Ok(Texture {
        width,
        height,
        texels: decoded.pixels().map(|p| p.0).collect(),
        wrap: [wrap("wrapS")?, wrap("wrapT")?],
    })
}
