//! COLMAP's cameras (SPEC section 12): the `cameras.txt` and `images.txt` of a model folder
//! (`sparse/0`), or their binary forms `cameras.bin` and `images.bin` (read where both are
//! there, as COLMAP itself does), one rara [`Camera`] per registered image, in the order of the
//! images' names (as 3DGS's loader and INRIA's `cameras.json` list them).
//!
//! - Models: `PINHOLE` (`fx fy cx cy`) and `SIMPLE_PINHOLE` (`f cx cy`), their principal point
//!   honoured (COLMAP measures it with pixel centres at `+ 0.5`: rara's is 0.5 less). A model
//!   with distortion parameters (`SIMPLE_RADIAL`, `RADIAL`, `OPENCV`, `FULL_OPENCV`) is taken
//!   as the pinhole it is where they are all exactly 0, and is an error naming the camera
//!   otherwise (undistort the images first: `colmap image_undistorter`). The fisheye models
//!   are errors: rara renders the pinhole only so far.
//! - Poses: `(qvec, tvec)` is world-to-camera, `x_cam = R(q) x_world + t`, with COLMAP's camera
//!   axes those of SPEC section 2 (x right, y down, z forward): the camera's centre is `-R^T
//!   t` and its camera-to-world rotation `R^T`.
//!
//! The files are read as streams: `images.*` hold every image's 2D points, which can run to
//! gigabytes, and are skipped without being kept. Every count is checked against the bytes
//! there are.

use std::collections::HashMap;
use std::io::{BufRead, BufReader, Read};
use std::path::{Path, PathBuf};

use glam::{DMat3, DQuat, DVec3, Vec2};

use crate::camera::Camera;
use crate::error::{Error, Result};

/// Cameras (intrinsics) a model may define at most (real models have one to a few thousand).
pub const MAX_COLMAP_CAMERAS: u64 = 1 << 20;
/// Images a model may register at most.
pub const MAX_COLMAP_IMAGES: u64 = 1 << 24;

/// COLMAP's camera models by id (`colmap/sensor/models.h`): name and parameter count.
const MODELS: [(&str, usize); 11] = [
    ("SIMPLE_PINHOLE", 3),
    ("PINHOLE", 4),
    ("SIMPLE_RADIAL", 4),
    ("RADIAL", 5),
    ("OPENCV", 8),
    ("OPENCV_FISHEYE", 8),
    ("FULL_OPENCV", 12),
    ("FOV", 5),
    ("SIMPLE_RADIAL_FISHEYE", 4),
    ("RADIAL_FISHEYE", 5),
    ("THIN_PRISM_FISHEYE", 12),
];

/// One camera's intrinsics as the file gives them.
#[derive(Clone, Debug)]
struct Intrinsics {
    model: &'static str,
    width: u64,
    height: u64,
    params: Vec<f64>,
}

/// One registered image: its pose and camera.
struct Pose {
    name: String,
    q: [f64; 4],
    t: [f64; 3],
    camera: u32,
}

fn err(path: &Path, message: impl std::fmt::Display) -> Error {
    Error::Cameras {
        path: path.to_path_buf(),
        message: message.to_string(),
    }
}

/// The model folder under `dir`: `dir` itself where it holds a model, else `dir/sparse/0`, else
/// `dir/0` (the layouts COLMAP and 3DGS datasets use).
fn model_dir(dir: &Path) -> Option<PathBuf> {
    let holds = |d: &Path| {
        (d.join("cameras.bin").is_file() && d.join("images.bin").is_file())
            || (d.join("cameras.txt").is_file() && d.join("images.txt").is_file())
    };
    [dir.to_path_buf(), dir.join("sparse/0"), dir.join("0")]
        .into_iter()
        .find(|d| holds(d))
}

/// Every registered image of the COLMAP model in `dir` (or `dir/sparse/0`) as a camera, in
/// the order of the images' names.
pub fn read_cameras(dir: &Path) -> Result<Vec<Camera>> {
    let model = model_dir(dir).ok_or_else(|| {
        err(
            dir,
            "a folder, and no COLMAP model in it (cameras.txt and images.txt, or cameras.bin and \
             images.bin, here or in sparse/0)",
        )
    })?;
    let binary = model.join("cameras.bin").is_file() && model.join("images.bin").is_file();
    let (cameras, mut poses) = if binary {
        (
            read_cameras_bin(&model.join("cameras.bin"))?,
            read_images_bin(&model.join("images.bin"))?,
        )
    } else {
        (
            read_cameras_txt(&model.join("cameras.txt"))?,
            read_images_txt(&model.join("images.txt"))?,
        )
    };
    if poses.is_empty() {
        return Err(err(&model, "the model registers no image"));
    }
    poses.sort_by(|a, b| a.name.cmp(&b.name));
    let images = model.join(if binary { "images.bin" } else { "images.txt" });
    poses
        .iter()
        .map(|p| {
            let c = cameras.get(&p.camera).ok_or_else(|| {
                err(
                    &images,
                    format!(
                        "image {} names camera {}, which cameras.* lacks",
                        p.name, p.camera
                    ),
                )
            })?;
            to_camera(c, p).map_err(|e| {
                err(
                    &images,
                    format!("image {} (camera {}): {e}", p.name, p.camera),
                )
            })
        })
        .collect()
}

/// The rara camera of image `p` taken by `c`.
fn to_camera(c: &Intrinsics, p: &Pose) -> std::result::Result<Camera, String> {
    let pr = &c.params;
    let (fx, fy, cx, cy, distortion) = match c.model {
        "SIMPLE_PINHOLE" => (pr[0], pr[0], pr[1], pr[2], &pr[3..]),
        "PINHOLE" => (pr[0], pr[1], pr[2], pr[3], &pr[4..]),
        "SIMPLE_RADIAL" | "RADIAL" => (pr[0], pr[0], pr[1], pr[2], &pr[3..]),
        "OPENCV" | "FULL_OPENCV" => (pr[0], pr[1], pr[2], pr[3], &pr[4..]),
        fisheye => {
            return Err(format!(
                "its model is {fisheye}: rara renders pinhole cameras only so far (PINHOLE, \
                 SIMPLE_PINHOLE, or a model whose distortion is 0)"
            ))
        }
    };
    if distortion.iter().any(|&k| k != 0.0) {
        return Err(format!(
            "its model {} has distortion {distortion:?}: rara renders undistorted pinhole \
             images (undistort them first: colmap image_undistorter)",
            c.model
        ));
    }
    let (width, height) = (
        u32::try_from(c.width).map_err(|_| format!("width {} is too large", c.width))?,
        u32::try_from(c.height).map_err(|_| format!("height {} is too large", c.height))?,
    );
    let q = DQuat::from_xyzw(p.q[1], p.q[2], p.q[3], p.q[0]);
    let len = q.length();
    if !(len.is_finite() && (len - 1.0).abs() < 1e-3) {
        return Err(format!("qvec {:?} is not a unit quaternion", p.q));
    }
    let r_cw = DMat3::from_quat(q / len);
    let centre = -(r_cw.transpose() * DVec3::from_array(p.t));
    let camera = Camera {
        width,
        height,
        position: centre.as_vec3(),
        rotation: r_cw.transpose().as_mat3(),
        fx: fx as f32,
        fy: fy as f32,
        principal: Some(Vec2::new(cx as f32 - 0.5, cy as f32 - 0.5)),
    };
    camera.validate().map_err(|e| e.to_string())?;
    Ok(camera)
}

/// The model of id `id` with `params`, checked.
fn intrinsics(
    model: &str,
    width: u64,
    height: u64,
    params: Vec<f64>,
) -> std::result::Result<Intrinsics, String> {
    let (name, count) = MODELS
        .iter()
        .find(|(n, _)| *n == model)
        .copied()
        .ok_or_else(|| format!("unknown camera model {model}"))?;
    if params.len() != count {
        return Err(format!(
            "{name} takes {count} parameters, not {}",
            params.len()
        ));
    }
    if !params.iter().all(|p| p.is_finite()) {
        return Err(format!("{name} has a non-finite parameter"));
    }
    Ok(Intrinsics {
        model: name,
        width,
        height,
        params,
    })
}

fn open(path: &Path) -> Result<BufReader<std::fs::File>> {
    let file = std::fs::File::open(path).map_err(|source| Error::Io {
        path: path.to_path_buf(),
        source,
    })?;
    Ok(BufReader::new(file))
}

/// The lines of a text file that are not comments, numbered from 1.
fn data_lines(path: &Path) -> Result<impl Iterator<Item = Result<(usize, String)>>> {
    let path_buf = path.to_path_buf();
    Ok(open(path)?
        .lines()
        .enumerate()
        .filter_map(move |(n, line)| match line {
            Err(source) => Some(Err(Error::Io {
                path: path_buf.clone(),
                source,
            })),
            Ok(l) if l.starts_with('#') => None,
            Ok(l) => Some(Ok((n + 1, l))),
        }))
}

fn read_cameras_txt(path: &Path) -> Result<HashMap<u32, Intrinsics>> {
    let mut out = HashMap::new();
    for line in data_lines(path)? {
        let (n, line) = line?;
        let f: Vec<&str> = line.split_whitespace().collect();
        if f.is_empty() {
            continue;
        }
        let bad = |m: String| err(path, format!("line {n}: {m}"));
        if f.len() < 4 {
            return Err(bad("not CAMERA_ID MODEL WIDTH HEIGHT PARAMS[]".into()));
        }
        let id: u32 = f[0]
            .parse()
            .map_err(|_| bad(format!("camera id '{}'", f[0])))?;
        let width: u64 = f[2].parse().map_err(|_| bad(format!("width '{}'", f[2])))?;
        let height: u64 = f[3]
            .parse()
            .map_err(|_| bad(format!("height '{}'", f[3])))?;
        let params = f[4..]
            .iter()
            .map(|p| {
                p.parse::<f64>()
                    .map_err(|_| bad(format!("parameter '{p}'")))
            })
            .collect::<Result<Vec<_>>>()?;
        let c = intrinsics(f[1], width, height, params)
            .map_err(|m| bad(format!("camera {id}: {m}")))?;
        if out.len() as u64 >= MAX_COLMAP_CAMERAS {
            return Err(bad(format!("more than {MAX_COLMAP_CAMERAS} cameras")));
        }
        out.insert(id, c);
    }
    Ok(out)
}

fn read_images_txt(path: &Path) -> Result<Vec<Pose>> {
    let mut out = Vec::new();
    // Two lines an image: its pose, then its 2D points (possibly blank), skipped.
    let mut expect_points = false;
    for line in data_lines(path)? {
        let (n, line) = line?;
        if expect_points {
            expect_points = false;
            continue;
        }
        let f: Vec<&str> = line.split_whitespace().collect();
        if f.is_empty() {
            continue;
        }
        let bad = |m: String| err(path, format!("line {n}: {m}"));
        if f.len() < 10 {
            return Err(bad(
                "not IMAGE_ID QW QX QY QZ TX TY TZ CAMERA_ID NAME".into()
            ));
        }
        let num = |k: usize| -> Result<f64> {
            f[k].parse::<f64>()
                .map_err(|_| bad(format!("'{}' is not a number", f[k])))
        };
        let camera: u32 = f[8]
            .parse()
            .map_err(|_| bad(format!("camera id '{}'", f[8])))?;
        if out.len() as u64 >= MAX_COLMAP_IMAGES {
            return Err(bad(format!("more than {MAX_COLMAP_IMAGES} images")));
        }
        out.push(Pose {
            // A name may hold spaces: the rest of the line.
            name: f[9..].join(" "),
            q: [num(1)?, num(2)?, num(3)?, num(4)?],
            t: [num(5)?, num(6)?, num(7)?],
            camera,
        });
        expect_points = true;
    }
    Ok(out)
}

/// A little-endian reader that says which file ran short.
struct Bin<'a> {
    input: BufReader<std::fs::File>,
    path: &'a Path,
}

impl Bin<'_> {
    fn bytes<const N: usize>(&mut self) -> Result<[u8; N]> {
        let mut b = [0u8; N];
        self.input
            .read_exact(&mut b)
            .map_err(|_| err(self.path, "ends before its counts say (truncated)"))?;
        Ok(b)
    }
    fn u64(&mut self) -> Result<u64> {
        Ok(u64::from_le_bytes(self.bytes()?))
    }
    fn i32(&mut self) -> Result<i32> {
        Ok(i32::from_le_bytes(self.bytes()?))
    }
    fn f64(&mut self) -> Result<f64> {
        Ok(f64::from_le_bytes(self.bytes()?))
    }
    /// Skips `n` bytes.
    fn skip(&mut self, n: u64) -> Result<()> {
        let copied = std::io::copy(&mut (&mut self.input).take(n), &mut std::io::sink()).map_err(
            |source| Error::Io {
                path: self.path.to_path_buf(),
                source,
            },
        )?;
        if copied != n {
            return Err(err(self.path, "ends before its counts say (truncated)"));
        }
        Ok(())
    }
}

fn read_cameras_bin(path: &Path) -> Result<HashMap<u32, Intrinsics>> {
    let mut b = Bin {
        input: open(path)?,
        path,
    };
    let count = b.u64()?;
    if count > MAX_COLMAP_CAMERAS {
        return Err(err(
            path,
            format!("{count} cameras, more than {MAX_COLMAP_CAMERAS}"),
        ));
    }
    let mut out = HashMap::new();
    for _ in 0..count {
        let id = b.i32()?;
        let model = b.i32()?;
        let width = b.u64()?;
        let height = b.u64()?;
        let (name, n) = usize::try_from(model)
            .ok()
            .and_then(|m| MODELS.get(m))
            .copied()
            .ok_or_else(|| err(path, format!("camera {id}: unknown model id {model}")))?;
        let params = (0..n).map(|_| b.f64()).collect::<Result<Vec<_>>>()?;
        let c = intrinsics(name, width, height, params)
            .map_err(|m| err(path, format!("camera {id}: {m}")))?;
        out.insert(id as u32, c);
    }
    Ok(out)
}

fn read_images_bin(path: &Path) -> Result<Vec<Pose>> {
    let mut b = Bin {
        input: open(path)?,
        path,
    };
    let count = b.u64()?;
    if count > MAX_COLMAP_IMAGES {
        return Err(err(
            path,
            format!("{count} images, more than {MAX_COLMAP_IMAGES}"),
        ));
    }
    let mut out = Vec::new();
    for _ in 0..count {
        let _id = b.i32()?;
        let q = [b.f64()?, b.f64()?, b.f64()?, b.f64()?];
        let t = [b.f64()?, b.f64()?, b.f64()?];
        let camera = b.i32()? as u32;
        let mut name = Vec::new();
        loop {
            let [c] = b.bytes::<1>()?;
            if c == 0 {
                break;
            }
            if name.len() >= 4096 {
                return Err(err(path, "an image name longer than 4096 bytes"));
            }
            name.push(c);
        }
        // The 2D points: x, y (f64) and a point id (i64) each, not kept.
        let points = b.u64()?;
        let bytes = points
            .checked_mul(24)
            .ok_or_else(|| err(path, format!("{points} 2D points overflow")))?;
        b.skip(bytes)?;
        out.push(Pose {
            name: String::from_utf8_lossy(&name).into_owned(),
            q,
            t,
            camera,
        });
    }
    Ok(out)
}

#[cfg(test)]
mod tests {
    use super::*;

    fn dir(name: &str) -> PathBuf {
        let d = std::env::temp_dir().join(format!("rara_colmap_{name}_{}", std::process::id()));
        std::fs::create_dir_all(&d).unwrap();
        d
    }

    #[test]
    fn text_models_read_with_their_principal_point_and_pose() {
        let d = dir("text");
        std::fs::write(
            d.join("cameras.txt"),
            "# comment\n1 PINHOLE 64 48 50 52 30 25\n2 SIMPLE_RADIAL 80 60 70 40 30 0\n",
        )
        .unwrap();
        std::fs::write(
            d.join("images.txt"),
            "# comment\n2 1 0 0 0 0 0 2 2 b name.png\n\n1 1 0 0 0 1 2 3 1 a.png\n10 20 -1\n",
        )
        .unwrap();
        let cams = read_cameras(&d).unwrap();
        assert_eq!(cams.len(), 2);
        // In name order: a.png first.
        let a = &cams[0];
        assert_eq!((a.width, a.height, a.fx, a.fy), (64, 48, 50.0, 52.0));
        assert_eq!(a.principal_point(), (29.5, 24.5));
        assert_eq!(a.position, glam::Vec3::new(-1.0, -2.0, -3.0));
        let b = &cams[1];
        assert_eq!((b.fx, b.fy), (70.0, 70.0));
        assert_eq!(b.principal_point(), (39.5, 29.5));
        assert_eq!(b.position, glam::Vec3::new(0.0, 0.0, -2.0));
        // Distortion, a fisheye model and a missing camera are errors naming the camera.
        for (cameras, wanted) in [
            (
                "1 PINHOLE 64 48 50 52 30 25\n2 SIMPLE_RADIAL 80 60 70 40 30 0.1\n",
                "distortion",
            ),
            (
                "1 PINHOLE 64 48 50 52 30 25\n2 OPENCV_FISHEYE 80 60 70 70 40 30 0 0 0 0\n",
                "OPENCV_FISHEYE",
            ),
            ("1 PINHOLE 64 48 50 52 30 25\n", "names camera 2"),
            (
                "1 PINHOLE 64 48 50 52 30\n",
                "PINHOLE takes 4 parameters, not 3",
            ),
        ] {
            std::fs::write(d.join("cameras.txt"), cameras).unwrap();
            let e = read_cameras(&d).unwrap_err().to_string();
            assert!(e.contains(wanted), "'{e}' does not say '{wanted}'");
        }
    }
}
