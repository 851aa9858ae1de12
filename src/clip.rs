//! Clip regions and RaRa clipping (SPEC section 5).
//!
//! A [`Clip`] says what is visible ([`ClipRegion`]: half-spaces, an oriented box or a sphere,
//! optionally inverted into a cutaway) and how Gaussians near its boundary are treated
//! ([`ClipMode`], [`ClipWeight`], the band). The same description drives both renderers: the
//! GPU kernels get it as [`GpuClipParams`], the CPU reference calls the functions here.
//!
//! The per-pixel maths of a cutoff Gaussian works in the Gaussian's whitened frame: with
//! `M = S^-1 R^T`, `Sigma^-1 = M^T M`, a ray `e + t d` becomes `o' + t d'` with `o' = M (e - mu)`
//! and `d' = M d`, so `A = |d'|^2`, `t* = -(o'.d')/A` and the squared Mahalanobis distance of
//! the ray from the centre is `|o' x d'|^2 / A`. The cross product keeps that distance accurate
//! when the camera is far from a small Gaussian, where `Cq - B^2/(4A)` would cancel
//! catastrophically in `f32`.

use std::path::Path;

use glam::{DVec3, Quat, Vec3};
use serde::Deserialize;

use crate::constants::{
    CLIP_FLAG_INVERT, CLIP_FLAG_SPHERE, CLIP_FLAG_TRACE_ALL, CLIP_MODE_HARD, CLIP_MODE_NONE,
    CLIP_MODE_RARA, CLIP_WEIGHT_LENGTH, CLIP_WEIGHT_MASS, MAX_CLIP_PLANES,
};
use crate::error::{Error, Result};
use crate::gpu_types::GpuClipParams;

/// The default band: cutoff Gaussians are those whose centre is within `3 max(s_i)` of the
/// region's boundary.
pub const DEFAULT_BAND: f32 = 3.0;

/// Stand-in for an unbounded end of a ray interval. Finite, so that interval arithmetic never
/// meets `inf - inf`; far beyond any scene, so that `Phi` of it is exactly 0 or 1.
pub const UNBOUNDED: f64 = 1e30;

/// A half-space `{x : normal . x + d >= 0}`, normal of unit length.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Plane {
    /// Unit normal, pointing into the visible side.
    pub normal: Vec3,
    /// Offset: the plane is `normal . x + d = 0`.
    pub d: f32,
}

impl Plane {
    /// The half-space `n . x + d >= 0`; `n` is normalised and `d` divided by the same length.
    pub fn new(n: Vec3, d: f32) -> Result<Plane> {
        let len = n.length();
        if !(len.is_finite() && len > 0.0 && d.is_finite()) {
            return Err(Error::InvalidInput(format!(
                "clip plane ({}, {}, {}, {d}) needs a finite, non-zero normal and a finite offset",
                n.x, n.y, n.z
            )));
        }
        Ok(Plane {
            normal: n / len,
            d: d / len,
        })
    }

    /// Signed distance of `p`: positive on the visible side.
    pub fn distance(&self, p: Vec3) -> f32 {
        self.normal.dot(p) + self.d
    }
}

/// The shape of a clip region.
#[derive(Clone, Debug, PartialEq)]
pub enum ClipShape {
    /// The intersection of half-spaces (planes and boxes), at most [`MAX_CLIP_PLANES`].
    HalfSpaces(Vec<Plane>),
    /// A ball.
    Sphere {
        /// Centre (world).
        center: Vec3,
        /// Radius (world units, > 0).
        radius: f32,
    },
}

/// A clip region K and whether the visible set is K or its complement.
#[derive(Clone, Debug, PartialEq)]
pub struct ClipRegion {
    /// The region K.
    pub shape: ClipShape,
    /// When true the visible set is the complement of K (a cutaway).
    pub invert: bool,
}

impl ClipRegion {
    /// The intersection of `planes` (at least one, at most [`MAX_CLIP_PLANES`]).
    pub fn planes(planes: Vec<Plane>) -> Result<ClipRegion> {
        check_plane_count(planes.len())?;
        Ok(ClipRegion {
            shape: ClipShape::HalfSpaces(planes),
            invert: false,
        })
    }

    /// The six half-spaces of an oriented box: `center`, positive `half_extents` along the
    /// box's local axes, `rotation` from box-local to world.
    pub fn oriented_box(center: Vec3, half_extents: Vec3, rotation: Quat) -> Result<ClipRegion> {
        Ok(ClipRegion {
            shape: ClipShape::HalfSpaces(box_planes(center, half_extents, rotation)?),
            invert: false,
        })
    }

    /// A sphere of `radius` > 0 around `center`.
    pub fn sphere(center: Vec3, radius: f32) -> Result<ClipRegion> {
        if !(center.is_finite() && radius.is_finite() && radius > 0.0) {
            return Err(Error::InvalidInput(format!(
                "clip sphere needs a finite centre and a positive radius, got radius {radius}"
            )));
        }
        Ok(ClipRegion {
            shape: ClipShape::Sphere { center, radius },
            invert: false,
        })
    }

    /// The region made of half-spaces (planes and boxes, intersected) or a sphere, inverted
    /// when `invert`; `None` when there is neither. A sphere cannot be combined with planes.
    pub fn from_parts(
        planes: Vec<Plane>,
        sphere: Option<(Vec3, f32)>,
        invert: bool,
    ) -> Result<Option<ClipRegion>> {
        let region = match (sphere, planes.is_empty()) {
            (Some(_), false) => {
                return Err(Error::InvalidInput(
                    "a clip sphere cannot be combined with planes or boxes".into(),
                ))
            }
            (Some((center, radius)), true) => Some(ClipRegion::sphere(center, radius)?),
            (None, false) => Some(ClipRegion::planes(planes)?),
            (None, true) => None,
        };
        Ok(region.map(|r| if invert { r.inverted() } else { r }))
    }

    /// The same region with the visible set complemented.
    pub fn inverted(mut self) -> ClipRegion {
        self.invert = !self.invert;
        self
    }

    /// Signed distance of a Gaussian centre to the visible set, positive inside (SPEC: the
    /// minimum over half-spaces, `radius - |mu - centre|` for a sphere, negated when inverted).
    pub fn signed_distance(&self, p: Vec3) -> f32 {
        let s = match &self.shape {
            ClipShape::HalfSpaces(planes) => planes
                .iter()
                .map(|pl| pl.distance(p))
                .fold(f32::INFINITY, f32::min),
            ClipShape::Sphere { center, radius } => radius - (p - *center).length(),
        };
        if self.invert {
            -s
        } else {
            s
        }
    }

    /// The visible part of the ray `origin + t dir`, all real t, as at most two disjoint
    /// intervals. Unbounded ends are [`UNBOUNDED`]; unused or empty intervals are `(0, 0)`.
    pub fn ray_intervals(&self, origin: DVec3, dir: DVec3) -> Spans {
        // The part inside K: one interval (lo, hi), empty when lo >= hi.
        let (lo, hi) = match &self.shape {
            ClipShape::HalfSpaces(planes) => {
                let (mut lo, mut hi) = (-UNBOUNDED, UNBOUNDED);
                for pl in planes {
                    let n = pl.normal.as_dvec3();
                    let (nd, ne) = (n.dot(dir), n.dot(origin) + pl.d as f64);
                    // ne + t nd >= 0.
                    if nd > 0.0 {
                        lo = lo.max(-ne / nd);
                    } else if nd < 0.0 {
                        hi = hi.min(-ne / nd);
                    } else if ne < 0.0 {
                        (lo, hi) = (0.0, 0.0);
                    }
                }
                (lo, hi)
            }
            ClipShape::Sphere { center, radius } => {
                // |oc + t d|^2 = r^2 with |d| = 1: t = -b +- sqrt(b^2 - c).
                let oc = origin - center.as_dvec3();
                let b = oc.dot(dir);
                let r = *radius as f64;
                let disc = b * b - (oc.length_squared() - r * r);
                if disc > 0.0 {
                    let h = disc.sqrt();
                    (-b - h, -b + h)
                } else {
                    (0.0, 0.0)
                }
            }
        };
        let inside_empty = lo >= hi;
        match (self.invert, inside_empty) {
            (false, true) => Spans::EMPTY,
            (false, false) => Spans([(lo, hi), (0.0, 0.0)]),
            (true, true) => Spans([(-UNBOUNDED, UNBOUNDED), (0.0, 0.0)]),
            (true, false) => Spans([(-UNBOUNDED, lo), (hi, UNBOUNDED)]),
        }
    }
}

/// Checks that a region has 1 to [`MAX_CLIP_PLANES`] half-spaces.
fn check_plane_count(n: usize) -> Result<()> {
    if n == 0 || n > MAX_CLIP_PLANES as usize {
        return Err(Error::InvalidInput(format!(
            "a clip region takes 1 to {MAX_CLIP_PLANES} planes, got {n}"
        )));
    }
    Ok(())
}

/// The six half-spaces of an oriented box.
fn box_planes(center: Vec3, half_extents: Vec3, rotation: Quat) -> Result<Vec<Plane>> {
    if !center.is_finite() {
        return Err(Error::InvalidInput(format!(
            "clip box needs a finite centre, got ({}, {}, {})",
            center.x, center.y, center.z
        )));
    }
    if !(half_extents.is_finite() && half_extents.min_element() > 0.0) {
        return Err(Error::InvalidInput(format!(
            "clip box needs positive half extents, got ({}, {}, {})",
            half_extents.x, half_extents.y, half_extents.z
        )));
    }
    let Some(rotation) = crate::scene::normalized_rotation(rotation) else {
        return Err(Error::InvalidInput(format!(
            "clip box rotation (w, x, y, z) = ({}, {}, {}, {}) is not a rotation: a quaternion \
             needs a finite, non-zero length",
            rotation.w, rotation.x, rotation.y, rotation.z
        )));
    };
    let mut planes = Vec::with_capacity(6);
    for (axis, h) in [Vec3::X, Vec3::Y, Vec3::Z]
        .into_iter()
        .zip(half_extents.to_array())
    {
        let a = rotation * axis;
        // Inside: -h <= a.(x - c) <= h, i.e. -a.x + a.c + h >= 0 and a.x - a.c + h >= 0.
        planes.push(Plane::new(-a, a.dot(center) + h)?);
        planes.push(Plane::new(a, -a.dot(center) + h)?);
    }
    Ok(planes)
}

/// Up to two disjoint intervals of the ray parameter t; `(0, 0)` marks an unused slot.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Spans(pub [(f64, f64); 2]);

impl Spans {
    /// No visible t at all.
    pub const EMPTY: Spans = Spans([(0.0, 0.0), (0.0, 0.0)]);

    /// Whether `t` lies in one of the intervals.
    pub fn contains(&self, t: f64) -> bool {
        self.0.iter().any(|&(lo, hi)| lo <= t && t <= hi && lo < hi)
    }
}

/// How Gaussians are treated against the region.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub enum ClipMode {
    /// No clipping.
    #[default]
    None,
    /// Keep or drop by the centre (the RaRa paper's baseline).
    Hard,
    /// Drop, draw, or draw with a per-pixel weight (cutoff).
    Rara,
}

impl std::str::FromStr for ClipMode {
    type Err = Error;
    fn from_str(s: &str) -> Result<Self> {
        match s {
            "none" => Ok(ClipMode::None),
            "hard" => Ok(ClipMode::Hard),
            "rara" => Ok(ClipMode::Rara),
            _ => Err(Error::InvalidInput(format!(
                "clip mode '{s}': expected none, hard or rara"
            ))),
        }
    }
}

/// The per-pixel weight of a cutoff Gaussian.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub enum ClipWeight {
    /// The Gaussian's probability mass along the ray that is visible (EWA-consistent).
    #[default]
    Mass,
    /// The visible fraction of the chord through the band ellipsoid (the paper's Eq. 11).
    Length,
}

impl std::str::FromStr for ClipWeight {
    type Err = Error;
    fn from_str(s: &str) -> Result<Self> {
        match s {
            "mass" => Ok(ClipWeight::Mass),
            "length" => Ok(ClipWeight::Length),
            _ => Err(Error::InvalidInput(format!(
                "clip weight '{s}': expected mass or length"
            ))),
        }
    }
}

/// What the clip test makes of one Gaussian.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Classification {
    /// Not drawn.
    Dropped,
    /// Drawn with w = 1.
    Drawn,
    /// Drawn with w computed per pixel.
    Cutoff,
}

/// A complete clipping setup: region, mode, weight, band, ablation switch.
#[derive(Clone, Debug, PartialEq)]
pub struct Clip {
    /// The region; `None` draws everything whatever the mode.
    pub region: Option<ClipRegion>,
    /// How Gaussians are treated.
    pub mode: ClipMode,
    /// Weight of cutoff Gaussians.
    pub weight: ClipWeight,
    /// Band in units of the largest standard deviation (> 0).
    pub band: f32,
    /// Treat every Gaussian that is not dropped as cutoff (the paper's "w/o RaRa" ablation).
    pub trace_all: bool,
}

impl Default for Clip {
    fn default() -> Self {
        Clip {
            region: None,
            mode: ClipMode::None,
            weight: ClipWeight::Mass,
            band: DEFAULT_BAND,
            trace_all: false,
        }
    }
}

impl Clip {
    /// RaRa clipping (mass weight, default band) of `region`.
    pub fn rara(region: ClipRegion) -> Clip {
        Clip {
            region: Some(region),
            mode: ClipMode::Rara,
            ..Clip::default()
        }
    }

    /// Hard clipping of `region`.
    pub fn hard(region: ClipRegion) -> Clip {
        Clip {
            region: Some(region),
            mode: ClipMode::Hard,
            ..Clip::default()
        }
    }

    /// The mode in effect: `None` when there is no region.
    pub fn effective_mode(&self) -> ClipMode {
        if self.region.is_some() {
            self.mode
        } else {
            ClipMode::None
        }
    }

    /// Whether the frame classifies cutoff splats' pairs by tile in its cutoff-tiles stage
    /// (weight 1 across the tile, no contribution, or partial; `glsl/clip.glsl`,
    /// `cutoff_tile_class`): rara
    /// clipping by planes with the mass weight. Not under `trace_all`, whose point is to trace
    /// every Gaussian.
    pub fn classifies_cutoff_tiles(&self) -> bool {
        self.effective_mode() == ClipMode::Rara
            && self.weight == ClipWeight::Mass
            && !self.trace_all
            && matches!(
                self.region.as_ref().map(|r| &r.shape),
                Some(ClipShape::HalfSpaces(_))
            )
    }

    /// Checks the band and the region's size.
    pub fn validate(&self) -> Result<()> {
        if !(self.band.is_finite() && self.band > 0.0) {
            return Err(Error::InvalidInput(format!(
                "clip band must be positive, got {}",
                self.band
            )));
        }
        if let Some(ClipRegion {
            shape: ClipShape::HalfSpaces(planes),
            ..
        }) = &self.region
        {
            check_plane_count(planes.len())?;
        }
        Ok(())
    }

    /// Classifies a Gaussian by its centre and standard deviations (SPEC section 5).
    pub fn classify(&self, mean: Vec3, scale: Vec3) -> Classification {
        let region = match (&self.region, self.effective_mode()) {
            (Some(r), ClipMode::Hard | ClipMode::Rara) => r,
            _ => return Classification::Drawn,
        };
        let s = region.signed_distance(mean);
        if self.mode == ClipMode::Hard {
            return if s >= 0.0 {
                Classification::Drawn
            } else {
                Classification::Dropped
            };
        }
        let r = self.band * scale.max_element();
        if s < -r {
            Classification::Dropped
        } else if s > r && !self.trace_all {
            Classification::Drawn
        } else {
            Classification::Cutoff
        }
    }

    /// The layout the kernels read (`ClipParams` in `glsl/clip.glsl`).
    pub fn to_gpu(&self) -> GpuClipParams {
        let mut p = GpuClipParams::default();
        let mode = self.effective_mode();
        p.config[0] = match mode {
            ClipMode::None => CLIP_MODE_NONE,
            ClipMode::Hard => CLIP_MODE_HARD,
            ClipMode::Rara => CLIP_MODE_RARA,
        };
        p.config[1] = match self.weight {
            ClipWeight::Mass => CLIP_WEIGHT_MASS,
            ClipWeight::Length => CLIP_WEIGHT_LENGTH,
        };
        p.band = [self.band, self.band * self.band, 0.0, 0.0];
        let Some(region) = &self.region else {
            return p;
        };
        let mut flags = 0;
        if region.invert {
            flags |= CLIP_FLAG_INVERT;
        }
        if self.trace_all {
            flags |= CLIP_FLAG_TRACE_ALL;
        }
        match &region.shape {
            ClipShape::HalfSpaces(planes) => {
                for (slot, pl) in p.planes.iter_mut().zip(planes) {
                    *slot = [pl.normal.x, pl.normal.y, pl.normal.z, pl.d];
                }
                p.config[3] = planes.len().min(MAX_CLIP_PLANES as usize) as u32;
            }
            ClipShape::Sphere { center, radius } => {
                flags |= CLIP_FLAG_SPHERE;
                p.sphere = [center.x, center.y, center.z, *radius];
            }
        }
        p.config[2] = flags;
        p
    }

    /// Reads a clip description from JSON (the schema of [`ClipFile`]).
    pub fn from_json_file(path: &Path) -> Result<Clip> {
        ClipFile::read(path)?
            .into_clip()
            .map_err(|e| Error::InvalidInput(format!("{}: {e}", path.display())))
    }
}

/// The JSON form of a [`Clip`] (`--clip FILE.json`). Every field is optional:
///
/// ```json
/// { "planes": [[0, 0, 1, 0.5]],
///   "box": { "center": [0, 0, 0], "half_extents": [1, 1, 1], "rotation": [1, 0, 0, 0] },
///   "sphere": { "center": [0, 0, 0], "radius": 1 },
///   "invert": false, "mode": "rara", "weight": "mass", "band": 3, "trace_all": false }
/// ```
///
/// Planes are `[nx, ny, nz, d]`, visible where `n.x + d >= 0`; `rotation` is a quaternion
/// `[w, x, y, z]`. Planes and a box combine into one intersection; a sphere stands alone. The
/// mode defaults to `rara` when a region is given.
#[derive(Clone, Debug, Default, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct ClipFile {
    /// Half-spaces `[nx, ny, nz, d]`.
    #[serde(default)]
    pub planes: Vec<[f32; 4]>,
    /// An oriented box.
    #[serde(rename = "box")]
    pub box_: Option<BoxSpec>,
    /// A sphere.
    pub sphere: Option<SphereSpec>,
    /// Complement the region.
    #[serde(default)]
    pub invert: bool,
    /// `none`, `hard` or `rara`.
    pub mode: Option<String>,
    /// `mass` or `length`.
    pub weight: Option<String>,
    /// Band (default 3).
    pub band: Option<f32>,
    /// The ablation switch.
    #[serde(default)]
    pub trace_all: bool,
}

/// An oriented box in a [`ClipFile`].
#[derive(Clone, Debug, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct BoxSpec {
    /// Centre.
    pub center: [f32; 3],
    /// Half extents along the box axes.
    pub half_extents: [f32; 3],
    /// Quaternion `[w, x, y, z]`, box-local to world (identity when absent).
    pub rotation: Option<[f32; 4]>,
}

/// Largest clip file [`ClipFile::read`] reads: a clip holds at most 16 half-spaces, a few
/// hundred bytes.
pub const MAX_CLIP_FILE_BYTES: u64 = 1 << 20;

/// A sphere in a [`ClipFile`].
#[derive(Clone, Debug, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct SphereSpec {
    /// Centre.
    pub center: [f32; 3],
    /// Radius.
    pub radius: f32,
}

impl ClipFile {
    /// Parses a clip JSON file (values are checked by [`ClipFile::into_clip`]).
    pub fn read(path: &Path) -> Result<ClipFile> {
        let text = crate::input::read_text_limited(path, MAX_CLIP_FILE_BYTES, "clip file")?;
        ClipFile::parse(&text, path)
    }

    /// [`ClipFile::read`] from the file's text; `path` only names the source in errors.
    pub fn parse(text: &str, path: &Path) -> Result<ClipFile> {
        serde_json::from_str(text)
            .map_err(|e| Error::InvalidInput(format!("{}: {e}", path.display())))
    }

    /// Builds the [`Clip`], checking every value.
    pub fn into_clip(self) -> Result<Clip> {
        let mut planes = self
            .planes
            .iter()
            .map(|p| Plane::new(Vec3::new(p[0], p[1], p[2]), p[3]))
            .collect::<Result<Vec<_>>>()?;
        if let Some(b) = &self.box_ {
            let q = b.rotation.unwrap_or([1.0, 0.0, 0.0, 0.0]);
            planes.extend(box_planes(
                Vec3::from(b.center),
                Vec3::from(b.half_extents),
                Quat::from_xyzw(q[1], q[2], q[3], q[0]),
            )?);
        }
        let sphere = self
            .sphere
            .as_ref()
            .map(|s| (Vec3::from(s.center), s.radius));
        let region = ClipRegion::from_parts(planes, sphere, self.invert)?;
        let mode = match &self.mode {
            Some(m) => m.parse()?,
            None if region.is_some() => ClipMode::Rara,
            None => ClipMode::None,
        };
        let clip = Clip {
            region,
            mode,
            weight: self.weight.as_deref().unwrap_or("mass").parse()?,
            band: self.band.unwrap_or(DEFAULT_BAND),
            trace_all: self.trace_all,
        };
        clip.validate()?;
        Ok(clip)
    }
}

/// The standard normal CDF `Phi(x)`, via the Abramowitz-Stegun 7.1.28 form of erf: on `|x|`,
/// `erfc(z) = 1 / p(z)^16` with a polynomial `p` of degree 6 (absolute error below 3e-7; under
/// 1e-6 in the GPU's float), reflected so that `Phi(x) + Phi(-x) = 1`. Unlike 7.1.26 it needs
/// no `exp`, which a CPU driver evaluates as a polynomial of its own. The argument is clamped
/// to +-10, where `Phi` is 0 or 1 to within 1e-20. The GLSL twin is `normal_cdf` in
/// `glsl/clip.glsl`.
pub fn normal_cdf(x: f64) -> f64 {
    let x = x.clamp(-10.0, 10.0);
    let z = x.abs() * std::f64::consts::FRAC_1_SQRT_2;
    let p = 1.0
        + z * (0.070_523_078_4
            + z * (0.042_282_012_3
                + z * (0.009_270_527_2
                    + z * (0.000_152_014_3 + z * (0.000_276_567_2 + z * 0.000_043_063_8)))));
    let tail = 0.5 / p.powi(16); // Phi(-|x|)
    if x >= 0.0 {
        1.0 - tail
    } else {
        tail
    }
}

/// What the per-pixel weight of one cutoff Gaussian needs. The GPU's side record holds the
/// same (CutoffRecord in `glsl/clip.glsl`; a flat one is marked by a zero third row).
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum CutoffRay {
    /// A Gaussian with three nonzero scales: the whitening `M = S^-1 R^T` (rows) and the eye
    /// in the whitened frame, `o' = M (e - mu)`.
    Volume {
        /// Rows of `M`.
        m: [DVec3; 3],
        /// `M (e - mu)`.
        origin: DVec3,
    },
    /// A flat Gaussian (SPEC section 6): along a ray it is a point mass where the ray crosses
    /// its plane, so no `S^-1` is ever formed.
    Flat {
        /// The plane's unit normal `n` (the axis of R whose scale is 0).
        normal: DVec3,
        /// `e - mu`.
        eye_offset: DVec3,
    },
}

/// Below this `|n.d|` (unit `d`) a ray counts as parallel to a flat Gaussian's plane
/// (SPEC section 6).
pub const FLAT_PARALLEL_EPSILON: f64 = 1e-7;

impl CutoffRay {
    /// The record of a Gaussian (centre, standard deviations, rotation) seen from `eye`.
    pub fn new(mean: Vec3, scale: Vec3, rotation: Quat, eye: Vec3) -> CutoffRay {
        let r = glam::DMat3::from_quat(rotation.as_dquat().normalize());
        let s = scale.as_dvec3();
        let rel = (eye - mean).as_dvec3();
        if let Some(axis) = crate::scene::flat_axis(scale) {
            return CutoffRay::Flat {
                normal: r.col(axis),
                eye_offset: rel,
            };
        }
        // Row k of S^-1 R^T is column k of R over s_k.
        let m = [r.x_axis / s.x, r.y_axis / s.y, r.z_axis / s.z];
        CutoffRay::Volume {
            m,
            origin: DVec3::new(m[0].dot(rel), m[1].dot(rel), m[2].dot(rel)),
        }
    }

    /// Where the ray `e + t dir` (unit `dir`) meets a flat Gaussian: the plane crossing
    /// `t_hit = n.(mu - e) / n.d`, or for a ray parallel to the plane its closest approach to
    /// `mu`, `t = d.(mu - e)`.
    pub fn flat_hit(normal: DVec3, eye_offset: DVec3, dir: DVec3) -> f64 {
        let nd = normal.dot(dir);
        if nd.abs() < FLAT_PARALLEL_EPSILON {
            -dir.dot(eye_offset)
        } else {
            -normal.dot(eye_offset) / nd
        }
    }

    /// The weight along the unit ray direction `dir` whose visible part is `visible`.
    pub fn weight(&self, dir: DVec3, visible: &Spans, kind: ClipWeight, band: f64) -> f64 {
        let (m, origin) = match *self {
            CutoffRay::Volume { m, origin } => (m, origin),
            // Both weights: 1 where the ray's point on the plane is visible, else 0.
            CutoffRay::Flat { normal, eye_offset } => {
                let t = CutoffRay::flat_hit(normal, eye_offset, dir);
                return if visible.contains(t) { 1.0 } else { 0.0 };
            }
        };
        let d = DVec3::new(m[0].dot(dir), m[1].dot(dir), m[2].dot(dir));
        let a = d.length_squared();
        let t_star = -origin.dot(d) / a;
        match kind {
            ClipWeight::Mass => {
                let sqrt_a = a.sqrt();
                // Unbounded ends contribute exactly 0 and 1, empty intervals nothing. The GPU
                // sums the same terms rewritten over the bounded ends (MassEnds in
                // glsl/clip.glsl), one normal CDF per end.
                let w: f64 = visible
                    .0
                    .iter()
                    .filter(|(lo, hi)| lo < hi)
                    .map(|&(lo, hi)| {
                        let upper = if hi >= UNBOUNDED {
                            1.0
                        } else {
                            normal_cdf((hi - t_star) * sqrt_a)
                        };
                        let lower = if lo <= -UNBOUNDED {
                            0.0
                        } else {
                            normal_cdf((lo - t_star) * sqrt_a)
                        };
                        upper - lower
                    })
                    .sum();
                w.clamp(0.0, 1.0)
            }
            ClipWeight::Length => {
                let q_min = origin.cross(d).length_squared() / a;
                let band2 = band * band;
                if q_min >= band2 {
                    return if visible.contains(t_star) { 1.0 } else { 0.0 };
                }
                let half = ((band2 - q_min) / a).sqrt();
                let (t1, t2) = (t_star - half, t_star + half);
                let inside: f64 = visible
                    .0
                    .iter()
                    .map(|&(lo, hi)| (t2.min(hi) - t1.max(lo)).max(0.0))
                    .sum();
                (inside / (t2 - t1)).clamp(0.0, 1.0)
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn normal_cdf_known_values() {
        assert!((normal_cdf(0.0) - 0.5).abs() < 2e-7);
        assert!((normal_cdf(1.0) - 0.841_344_746).abs() < 2e-7);
        assert!((normal_cdf(-1.959_964) - 0.025).abs() < 2e-7);
        assert_eq!(normal_cdf(f64::INFINITY), 1.0);
        assert_eq!(normal_cdf(-1e300), normal_cdf(-10.0));
        assert_eq!(1.0 - normal_cdf(-10.0), 1.0);
    }

    #[test]
    fn box_is_its_six_planes() {
        let q = Quat::from_rotation_y(0.4);
        let r = ClipRegion::oriented_box(Vec3::new(1.0, 2.0, 3.0), Vec3::new(1.0, 2.0, 0.5), q)
            .unwrap();
        let local = |p: Vec3| q.inverse() * (p - Vec3::new(1.0, 2.0, 3.0));
        for p in [
            Vec3::new(1.0, 2.0, 3.0),
            Vec3::new(1.9, 2.0, 3.0),
            Vec3::new(3.0, 0.0, 0.0),
        ] {
            let l = local(p);
            let inside = l.x.abs() <= 1.0 && l.y.abs() <= 2.0 && l.z.abs() <= 0.5;
            assert_eq!(r.signed_distance(p) >= 0.0, inside, "{p}");
        }
    }
}
