//! A mesh's material (SPEC section 8) and its base-colour texture: what a hit on a triangle
//! returns, on the host (the CPU reference) and as the GPU reads it ([`GpuMaterial`], the
//! texels in one buffer). glTF materials map onto it in [`super::gltf_material`].
//!
//! The texture twin of `sample_texture` in `glsl/mixed_spawn.comp`: glTF's conventions (UV
//! `(0, 0)` at the image's first texel's corner, `v` down the rows), texel centres at `(i +
//! 0.5) / size`, each of the four texels sRGB-decoded before the bilinear blend (as a GPU's
//! sRGB texture filters), the sampler's wrap per axis. No mipmaps: a texture far smaller on
//! screen than its size aliases (docs/CLI.md says so).

use bytemuck::{Pod, Zeroable};
use glam::{Vec2, Vec3};

/// How a surface turns a ray that hits it.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Surface {
    /// Opaque and lit by the lights and the ambient term: the colour is its albedo.
    Diffuse,
    /// Reflects: the colour is its reflectance per channel.
    Mirror,
    /// A clear dielectric of this index of refraction (exact Fresnel, Snell); the colour is
    /// unused.
    Glass(f32),
}

/// A mesh's material: its surface, colour (times its texture's, where it has one) and the
/// light it emits.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Material {
    /// How rays leave it.
    pub surface: Surface,
    /// Diffuse albedo or mirror reflectance, RGB in [0, 1].
    pub colour: Vec3,
    /// A texture of [`super::MixedScene::textures`] whose linear RGB multiplies `colour` at
    /// the hit's UV.
    pub texture: Option<u32>,
    /// RGB added to what the surface returns (scaled by the ray's weight), >= 0.
    pub emission: Vec3,
}

impl Material {
    /// A diffuse surface of albedo `colour`.
    pub fn diffuse(colour: Vec3) -> Material {
        Material {
            surface: Surface::Diffuse,
            colour,
            texture: None,
            emission: Vec3::ZERO,
        }
    }

    /// A grey mirror of `reflectance`.
    pub fn mirror(reflectance: f32) -> Material {
        Material {
            surface: Surface::Mirror,
            colour: Vec3::splat(reflectance),
            texture: None,
            emission: Vec3::ZERO,
        }
    }

    /// Clear glass of index of refraction `ior`.
    pub fn glass(ior: f32) -> Material {
        Material {
            surface: Surface::Glass(ior),
            colour: Vec3::ONE,
            texture: None,
            emission: Vec3::ZERO,
        }
    }

    /// Whether it stops shadow rays (glass lets light through).
    pub fn is_opaque(&self) -> bool {
        !matches!(self.surface, Surface::Glass(_))
    }

    /// The colour at `uv`: [`Material::colour`] times the texture's linear RGB.
    pub fn colour_at(&self, textures: &[Texture], uv: Vec2) -> Vec3 {
        match self.texture {
            Some(t) => self.colour * textures[t as usize].sample(uv),
            None => self.colour,
        }
    }
}

/// How texture coordinates outside [0, 1] map back onto the image (glTF's sampler wraps).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub enum Wrap {
    /// The image tiles (glTF's default).
    #[default]
    Repeat,
    /// The edge texel goes on.
    ClampToEdge,
    /// The image tiles, every other copy mirrored.
    MirroredRepeat,
}

impl Wrap {
    /// glTF's code for it (the OpenGL enum).
    pub fn from_gltf(code: u32) -> Option<Wrap> {
        match code {
            10497 => Some(Wrap::Repeat),
            33071 => Some(Wrap::ClampToEdge),
            33648 => Some(Wrap::MirroredRepeat),
            _ => None,
        }
    }

    /// The kernels' code (`WRAP_*` in `glsl/mixed_spawn.comp`).
    pub fn code(self) -> u32 {
        match self {
            Wrap::Repeat => 0,
            Wrap::ClampToEdge => 1,
            Wrap::MirroredRepeat => 2,
        }
    }

    /// Texel `i` (any integer) of a row of `n` moved into `[0, n)`.
    pub fn texel(self, i: i64, n: i64) -> i64 {
        match self {
            Wrap::Repeat => i.rem_euclid(n),
            Wrap::ClampToEdge => i.clamp(0, n - 1),
            Wrap::MirroredRepeat => {
                let k = i.rem_euclid(2 * n);
                if k < n {
                    k
                } else {
                    2 * n - 1 - k
                }
            }
        }
    }
}

/// An image texture: sRGB-encoded RGBA8 texels, row by row from the top, and its wraps.
#[derive(Clone, Debug, PartialEq)]
pub struct Texture {
    /// Texels across.
    pub width: u32,
    /// Rows.
    pub height: u32,
    /// `width * height` texels, RGBA8, sRGB-encoded (alpha linear and unused).
    pub texels: Vec<[u8; 4]>,
    /// The wrap along u (across) and v (down).
    pub wrap: [Wrap; 2],
}

/// An 8-bit sRGB value decoded to linear (IEC 61966-2-1).
pub fn srgb_to_linear(c: u8) -> f32 {
    let c = c as f32 / 255.0;
    if c <= 0.04045 {
        c / 12.92
    } else {
        ((c + 0.055) / 1.055).powf(2.4)
    }
}

impl Texture {
    /// The linear RGB at `uv`: the four nearest texels decoded, blended bilinearly.
    pub fn sample(&self, uv: Vec2) -> Vec3 {
        let (w, h) = (self.width as i64, self.height as i64);
        let x = uv.x * self.width as f32 - 0.5;
        let y = uv.y * self.height as f32 - 0.5;
        if !(x.is_finite() && y.is_finite()) {
            return Vec3::ZERO;
        }
        let (x0, y0) = (x.floor(), y.floor());
        let (fx, fy) = (x - x0, y - y0);
        let (x0, y0) = (x0 as i64, y0 as i64);
        let texel = |i: i64, j: i64| {
            let i = self.wrap[0].texel(i, w);
            let j = self.wrap[1].texel(j, h);
            let t = self.texels[(j * w + i) as usize];
            Vec3::new(
                srgb_to_linear(t[0]),
                srgb_to_linear(t[1]),
                srgb_to_linear(t[2]),
            )
        };
        let top = texel(x0, y0).lerp(texel(x0 + 1, y0), fx);
        let bottom = texel(x0, y0 + 1).lerp(texel(x0 + 1, y0 + 1), fx);
        top.lerp(bottom, fy)
    }
}

/// The GPU's form of `NO_TEXTURE` (`GpuMaterial::texture.x`).
pub const NO_TEXTURE: u32 = u32::MAX;

/// A material as the kernels read it (`MeshMaterial` in `glsl/mixed_common.glsl`), three
/// 16-byte words.
#[repr(C)]
#[derive(Clone, Copy, Debug, Default, PartialEq, Pod, Zeroable)]
pub struct GpuMaterial {
    /// The colour, and the surface (`MATERIAL_*`) as a float.
    pub colour: [f32; 4],
    /// The emission, and glass's index of refraction.
    pub emission: [f32; 4],
    /// The texture's first texel in the texel buffer ([`NO_TEXTURE`] for none), its width,
    /// its height, and its wraps (u's code, v's code times 4).
    pub texture: [u32; 4],
}

/// The scene's materials and textures as the GPU reads them: one [`GpuMaterial`] each, and
/// every texture's texels in one run of RGBA8 words.
pub fn gpu_materials(materials: &[Material], textures: &[Texture]) -> (Vec<GpuMaterial>, Vec<u32>) {
    let mut firsts = Vec::with_capacity(textures.len());
    let mut texels = Vec::new();
    for t in textures {
        firsts.push(texels.len() as u32);
        texels.extend(t.texels.iter().map(|c| u32::from_le_bytes(*c)));
    }
    let gpu = materials
        .iter()
        .map(|m| {
            let (kind, ior) = match m.surface {
                Surface::Diffuse => (0.0, 0.0),
                Surface::Mirror => (1.0, 0.0),
                Surface::Glass(ior) => (2.0, ior),
            };
            let texture = match m.texture {
                Some(k) => {
                    let t = &textures[k as usize];
                    [
                        firsts[k as usize],
                        t.width,
                        t.height,
                        t.wrap[0].code() | t.wrap[1].code() << 2,
                    ]
                }
                None => [NO_TEXTURE, 0, 0, 0],
            };
            GpuMaterial {
                colour: [m.colour.x, m.colour.y, m.colour.z, kind],
                emission: [m.emission.x, m.emission.y, m.emission.z, ior],
                texture,
            }
        })
        .collect();
    (gpu, texels)
}

#[cfg(test)]
mod tests {
    use super::*;

    fn texture(wrap: Wrap) -> Texture {
        // 2 x 1: black, white (sRGB 255 = linear 1).
        Texture {
            width: 2,
            height: 1,
            texels: vec![[0, 0, 0, 255], [255, 255, 255, 255]],
            wrap: [wrap, wrap],
        }
    }

    #[test]
    fn srgb_decodes_to_linear() {
        assert_eq!(srgb_to_linear(0), 0.0);
        assert_eq!(srgb_to_linear(255), 1.0);
        // Mid grey in sRGB is about a fifth of the light.
        assert!((srgb_to_linear(128) - 0.2158605).abs() < 1e-6);
        assert!((srgb_to_linear(10) - 10.0 / 255.0 / 12.92).abs() < 1e-9);
    }

    #[test]
    fn texels_centres_blend_bilinearly_and_wrap() {
        let t = texture(Wrap::ClampToEdge);
        assert_eq!(t.sample(Vec2::new(0.25, 0.5)), Vec3::ZERO);
        assert_eq!(t.sample(Vec2::new(0.75, 0.5)), Vec3::ONE);
        assert_eq!(t.sample(Vec2::new(0.5, 0.5)), Vec3::splat(0.5));
        // Clamped past the edge; repeated it blends the last texel into the first.
        assert_eq!(t.sample(Vec2::new(1.0, 0.5)), Vec3::ONE);
        assert_eq!(
            texture(Wrap::Repeat).sample(Vec2::new(1.0, 0.5)),
            Vec3::splat(0.5)
        );
        assert_eq!(
            texture(Wrap::Repeat).sample(Vec2::new(1.25, 0.5)),
            Vec3::ZERO
        );
        // Mirrored: the copy past 1 runs backwards.
        assert_eq!(
            texture(Wrap::MirroredRepeat).sample(Vec2::new(1.25, 0.5)),
            Vec3::ONE
        );
        assert_eq!(Wrap::MirroredRepeat.texel(-1, 4), 0);
        assert_eq!(Wrap::MirroredRepeat.texel(4, 4), 3);
        assert_eq!(Wrap::Repeat.texel(-1, 4), 3);
    }

    #[test]
    fn the_gpu_form_packs_texels_and_codes() {
        let m = Material {
            texture: Some(1),
            ..Material::diffuse(Vec3::ONE)
        };
        let mut t = texture(Wrap::MirroredRepeat);
        t.wrap[0] = Wrap::ClampToEdge;
        let (gpu, texels) = gpu_materials(&[Material::glass(1.5), m], &[texture(Wrap::Repeat), t]);
        assert_eq!(gpu[0].texture[0], NO_TEXTURE);
        assert_eq!(gpu[0].emission[3], 1.5);
        assert_eq!(gpu[0].colour[3], 2.0);
        assert_eq!(gpu[1].texture, [2, 2, 1, 1 | 2 << 2]);
        assert_eq!(texels.len(), 4);
        assert_eq!(texels[3], 0xffff_ffff);
        assert_eq!(texels[2], 0xff00_0000);
    }
}
