//! Arguments and parsers several commands share: the camera, the tracer, vectors and colours.

use std::path::PathBuf;

use clap::Args;
use glam::Vec3;
use rara::{Camera, Result};

/// Where the camera comes from and the image size.
#[derive(Args, Clone)]
pub struct CameraArgs {
    /// INRIA cameras.json file, or a COLMAP model folder (sparse/0, its cameras and images as
    /// .txt or .bin). Without it or --eye, the scene is framed (SPEC 12) and the camera printed
    /// as flags.
    #[arg(long, conflicts_with_all = ["eye", "target"])]
    cameras: Option<PathBuf>,
    /// Index of the camera in --cameras.
    #[arg(long, default_value_t = 0, requires = "cameras")]
    camera: usize,
    /// Camera centre X,Y,Z (with --target).
    #[arg(long, allow_hyphen_values = true, value_parser = parse_vec3, requires = "target")]
    eye: Option<Vec3>,
    /// Point looked at X,Y,Z (with --eye).
    #[arg(long, allow_hyphen_values = true, value_parser = parse_vec3, requires = "eye")]
    target: Option<Vec3>,
    /// Up direction X,Y,Z (default -Y, the INRIA/COLMAP convention).
    #[arg(long, allow_hyphen_values = true, value_parser = parse_vec3, default_value = "0,-1,0")]
    up: Vec3,
    /// Vertical field of view in degrees (with --eye).
    #[arg(long, default_value_t = 50.0)]
    fov_y: f32,
    /// Image width (default: the camera's, or 640 with --eye).
    #[arg(long)]
    width: Option<u32>,
    /// Image height (default: keeps the camera's aspect ratio, or 480 with --eye).
    #[arg(long)]
    height: Option<u32>,
}

/// `--tracer`.
#[derive(Clone, Copy, Debug, PartialEq, Eq, clap::ValueEnum)]
pub enum TracerArg {
    /// The tile rasterizer.
    Raster,
    /// The ray tracer.
    Ray,
    /// The ray tracer, camera rays from tile lists.
    RayTiles,
}

impl From<TracerArg> for rara::Tracer {
    fn from(t: TracerArg) -> rara::Tracer {
        match t {
            TracerArg::Raster => rara::Tracer::Raster,
            TracerArg::Ray => rara::Tracer::Ray,
            TracerArg::RayTiles => rara::Tracer::RayTiles,
        }
    }
}

/// X,Y,Z: three comma-separated finite numbers (`--eye`, `--target`, `--up`, ...).
pub fn parse_vec3(s: &str) -> std::result::Result<Vec3, String> {
    let parts: Vec<&str> = s.split(',').map(str::trim).collect();
    if parts.len() != 3 {
        return Err(format!(
            "expected X,Y,Z (three comma-separated numbers), got '{s}'"
        ));
    }
    let mut v = [0f32; 3];
    for (slot, p) in v.iter_mut().zip(&parts) {
        *slot = p.parse().map_err(|_| format!("'{p}' is not a number"))?;
        if !slot.is_finite() {
            return Err(format!("'{p}' is not finite"));
        }
    }
    Ok(Vec3::from_array(v))
}

/// R,G,B with every channel in [0, 1].
pub fn parse_color(s: &str) -> std::result::Result<Vec3, String> {
    let c = parse_vec3(s)?;
    if c.min_element() < 0.0 || c.max_element() > 1.0 {
        return Err(format!(
            "'{s}': each of R,G,B must lie in [0, 1] (0,0,0 is black, 1,1,1 white)"
        ));
    }
    Ok(c)
}

/// A command's camera: given (`--cameras`, `--eye`, a scene file's entry), or none, in which
/// case SPEC 12's framing of the scene is made once the scene is loaded.
#[derive(Clone, Debug)]
pub enum CameraChoice {
    /// Given.
    Given(Camera),
    /// None given: [`Camera::framing`], at the `--width` and `--height` given, if any.
    Framing {
        /// `--width`.
        width: Option<u32>,
        /// `--height`.
        height: Option<u32>,
    },
}

impl CameraChoice {
    /// The camera given, if one was.
    pub fn given(&self) -> Option<&Camera> {
        match self {
            CameraChoice::Given(c) => Some(c),
            CameraChoice::Framing { .. } => None,
        }
    }

    /// The camera: the one given, else the framing of the world-space Gaussian centres
    /// `means` (made only then), printed as the flags that give it again.
    pub fn or_framing(&self, means: impl FnOnce() -> Vec<Vec3>) -> Result<Camera> {
        let (width, height) = match self {
            CameraChoice::Given(c) => return Ok(*c),
            CameraChoice::Framing { width, height } => (*width, *height),
        };
        // As `--eye` and `--target` make it, so that the printed flags give it to the bit.
        let (eye, target) = Camera::framing_eye_target(&means())?;
        let (width, height) = look_at_size(width, height);
        let fov = rara::camera::FRAMING_FOV_Y_DEG;
        let camera = Camera::look_at(eye, target, Vec3::NEG_Y, fov, width, height)?;
        eprintln!(
            "no camera given: the scene framed as SPEC 12 says; to render it again from here: \
             --eye {},{},{} --target {},{},{} --up 0,-1,0 --fov-y {fov} --width {width} \
             --height {height}",
            eye.x, eye.y, eye.z, target.x, target.y, target.z,
        );
        Ok(camera)
    }
}

/// The camera `args` describe: a view of a cameras.json file (resized when told), a look-at
/// camera, or, with neither, the framing of the scene once it is loaded.
pub fn resolve_camera(args: &CameraArgs) -> Result<CameraChoice> {
    if let Some(path) = &args.cameras {
        return Ok(CameraChoice::Given(sized(
            args,
            Camera::load_one(path, args.camera)?,
        )?));
    }
    match (args.eye, args.target) {
        (Some(eye), Some(target)) => {
            let (width, height) = look_at_size(args.width, args.height);
            Ok(CameraChoice::Given(Camera::look_at(
                eye, target, args.up, args.fov_y, width, height,
            )?))
        }
        _ => Ok(CameraChoice::Framing {
            width: args.width,
            height: args.height,
        }),
    }
}

/// The image size of a look-at camera (`--eye`, and the framing camera, which prints itself as
/// `--eye` flags and must come out the same): the width given or 640, the height given or three
/// quarters of the width.
fn look_at_size(width: Option<u32>, height: Option<u32>) -> (u32, u32) {
    let width = width.unwrap_or(640);
    (
        width,
        height.unwrap_or_else(|| Camera::default_height(width)),
    )
}

/// `cam` at the width and height `args` give, if they give any (the aspect ratio kept when
/// only the width is given).
fn sized(args: &CameraArgs, cam: Camera) -> Result<Camera> {
    match args.width {
        Some(w) => cam.resized(w, args.height),
        None if args.height.is_some() => cam.resized(cam.width, args.height),
        None => Ok(cam),
    }
}

/// The camera of a scene file's frame: the command line's (`--cameras` or `--eye`) where it
/// gives one, else the file's `camera` entry (read from `file`; `--width` and `--height`
/// still apply), else the framing of the scene once it is loaded.
pub fn resolve_scene_file_camera(
    args: &CameraArgs,
    file: &std::path::Path,
) -> Result<CameraChoice> {
    if args.cameras.is_some() || args.eye.is_some() {
        return resolve_camera(args);
    }
    match rara::mixed::file::SceneFile::read(file)?.camera(file)? {
        Some(cam) => Ok(CameraChoice::Given(sized(args, cam)?)),
        None => resolve_camera(args),
    }
}

/// The camera of each of `frames` frames along the camera path whose keyframes are the cameras
/// of `file` (a cameras.json or a COLMAP folder, in order; [`rara::camera::CameraPath`]), at
/// the `--width` and `--height` of `args` where given.
pub fn path_cameras(file: &std::path::Path, frames: u32, args: &CameraArgs) -> Result<Vec<Camera>> {
    let path = rara::camera::CameraPath::new(Camera::load_all(file)?)?;
    eprintln!(
        "camera path {}: {} keyframes over {frames} frames",
        file.display(),
        path.keys().len()
    );
    (0..frames)
        .map(|k| sized(args, path.at(k as f32 / (frames.max(2) - 1) as f32)))
        .collect()
}
