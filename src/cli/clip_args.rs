//! The clip options shared by `rara render`, `rara sweep` and `rara bench`.

use std::path::PathBuf;

use clap::Args;
use glam::{Quat, Vec3};

use rara::clip::{Clip, ClipFile, ClipMode, ClipRegion, ClipShape, ClipWeight, Plane};
use rara::{Error, Result};

/// Clip region and mode (SPEC section 5).
#[derive(Args, Clone, Debug, Default)]
pub struct ClipArgs {
    /// Clip plane NX,NY,NZ,D: visible where n.x + d >= 0 (repeatable; planes intersect).
    #[arg(long = "clip-plane", allow_hyphen_values = true, value_name = "NX,NY,NZ,D", value_parser = parse_plane)]
    pub planes: Vec<Plane>,
    /// Oriented box CX,CY,CZ,HX,HY,HZ[,QW,QX,QY,QZ]: centre, half extents, rotation.
    #[arg(long = "clip-box", allow_hyphen_values = true, value_name = "CX,CY,CZ,HX,HY,HZ[,QW,QX,QY,QZ]", value_parser = parse_box)]
    pub boxes: Vec<Vec<Plane>>,
    /// Sphere CX,CY,CZ,R.
    #[arg(long = "clip-sphere", allow_hyphen_values = true, value_name = "CX,CY,CZ,R", value_parser = parse_floats::<4>)]
    pub sphere: Option<[f32; 4]>,
    /// Show the complement of the region (a cutaway).
    #[arg(long)]
    pub invert: bool,
    /// none, hard or rara (default: rara when a region is given).
    #[arg(long = "clip-mode", value_name = "MODE")]
    pub mode: Option<ClipMode>,
    /// Weight of cutoff Gaussians: mass (default) or length.
    #[arg(long, value_name = "WEIGHT")]
    pub weight: Option<ClipWeight>,
    /// Cutoff band in units of the largest standard deviation (default 3).
    #[arg(long)]
    pub band: Option<f32>,
    /// Treat every Gaussian that is not dropped as cutoff (the paper's "w/o RaRa" ablation).
    #[arg(long)]
    pub trace_all: bool,
    /// JSON file with the same settings; the options above add to it or override it.
    #[arg(long = "clip", value_name = "FILE.json")]
    pub file: Option<PathBuf>,
}

impl ClipArgs {
    /// Whether no clip option was given.
    pub fn is_empty(&self) -> bool {
        self.planes.is_empty()
            && self.boxes.is_empty()
            && self.sphere.is_none()
            && !self.invert
            && self.mode.is_none()
            && self.weight.is_none()
            && self.band.is_none()
            && !self.trace_all
            && self.file.is_none()
    }

    /// The clip these options describe, with `extra` half-spaces added to the region.
    pub fn build(&self, extra: &[Plane]) -> Result<Clip> {
        let file = match &self.file {
            Some(path) => ClipFile::read(path)?,
            None => ClipFile::default(),
        };
        let file_mode = file.mode.clone();
        let in_file = |e: Error| match &self.file {
            Some(path) => Error::InvalidInput(format!("{}: {e}", path.display())),
            None => e,
        };
        let mut clip = file.into_clip().map_err(in_file)?;
        let mut planes: Vec<Plane> = Vec::new();
        let mut sphere = None;
        let mut invert = self.invert;
        if let Some(region) = clip.region.take() {
            invert |= region.invert;
            match region.shape {
                ClipShape::HalfSpaces(p) => planes = p,
                ClipShape::Sphere { center, radius } => sphere = Some((center, radius)),
            }
        }
        planes.extend(self.planes.iter().copied());
        planes.extend(self.boxes.iter().flatten().copied());
        planes.extend(extra.iter().copied());
        if let Some(s) = self.sphere {
            sphere = Some((Vec3::new(s[0], s[1], s[2]), s[3]));
        }
        clip.region = ClipRegion::from_parts(planes, sphere, invert)?;
        clip.mode = match (self.mode, file_mode) {
            (Some(mode), _) => mode,
            (None, Some(mode)) => mode.parse()?,
            (None, None) if clip.region.is_some() => ClipMode::Rara,
            (None, None) => ClipMode::None,
        };
        if let Some(w) = self.weight {
            clip.weight = w;
        }
        if let Some(b) = self.band {
            clip.band = b;
        }
        clip.trace_all |= self.trace_all;
        let needs_region =
            self.invert || self.trace_all || self.mode.is_some_and(|m| m != ClipMode::None);
        if clip.region.is_none() && needs_region {
            return Err(Error::InvalidInput(
                "--invert, --trace-all and --clip-mode need a region: --clip-plane, --clip-box, \
                 --clip-sphere or --clip FILE"
                    .into(),
            ));
        }
        clip.validate()?;
        Ok(clip)
    }
}

/// A one-line description of a clip for logs.
pub fn describe(clip: &Clip) -> String {
    let Some(region) = &clip.region else {
        return "no clipping".into();
    };
    let shape = match &region.shape {
        ClipShape::HalfSpaces(p) if p.len() == 1 => "1 plane".to_string(),
        ClipShape::HalfSpaces(p) => format!("{} planes", p.len()),
        ClipShape::Sphere { .. } => "a sphere".to_string(),
    };
    let inverted = if region.invert { ", inverted" } else { "" };
    match clip.effective_mode() {
        ClipMode::None => format!("clip mode none ({shape}{inverted} ignored)"),
        ClipMode::Hard => format!("hard clip by {shape}{inverted}"),
        ClipMode::Rara => format!(
            "rara clip by {shape}{inverted} ({} weight, band {}{})",
            match clip.weight {
                ClipWeight::Mass => "mass",
                ClipWeight::Length => "length",
            },
            clip.band,
            if clip.trace_all { ", trace all" } else { "" }
        ),
    }
}

/// `N` comma-separated finite numbers.
pub fn parse_floats<const N: usize>(s: &str) -> std::result::Result<[f32; N], String> {
    let v = parse_list(s)?;
    v.try_into()
        .map_err(|v: Vec<f32>| format!("expected {N} comma-separated numbers, got {}", v.len()))
}

fn parse_list(s: &str) -> std::result::Result<Vec<f32>, String> {
    s.split(',')
        .map(str::trim)
        .map(|p| match p.parse::<f32>() {
            Ok(x) if x.is_finite() => Ok(x),
            Ok(_) => Err(format!("'{p}' is not finite")),
            Err(_) => Err(format!("'{p}' is not a number")),
        })
        .collect()
}

fn parse_plane(s: &str) -> std::result::Result<Plane, String> {
    let [nx, ny, nz, d] = parse_floats::<4>(s)?;
    Plane::new(Vec3::new(nx, ny, nz), d).map_err(|e| e.to_string())
}

fn parse_box(s: &str) -> std::result::Result<Vec<Plane>, String> {
    let v = parse_list(s)?;
    let q = match v.len() {
        6 => Quat::IDENTITY,
        10 => Quat::from_xyzw(v[7], v[8], v[9], v[6]),
        n => return Err(format!("expected 6 or 10 comma-separated numbers, got {n}")),
    };
    let region =
        ClipRegion::oriented_box(Vec3::new(v[0], v[1], v[2]), Vec3::new(v[3], v[4], v[5]), q)
            .map_err(|e| e.to_string())?;
    match region.shape {
        ClipShape::HalfSpaces(p) => Ok(p),
        ClipShape::Sphere { .. } => unreachable!("a box is half-spaces"),
    }
}
