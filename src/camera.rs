//! Pinhole cameras (SPEC section 2) and the INRIA `cameras.json` format.

use std::path::Path;

use glam::{Mat3, Vec2, Vec3};

use crate::error::{Error, Result};

/// A pinhole camera (SPEC section 2), its principal point at the image centre unless a camera
/// file gives one (SPEC section 12).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Camera {
    /// Image width in pixels.
    pub width: u32,
    /// Image height in pixels.
    pub height: u32,
    /// Camera centre (world).
    pub position: Vec3,
    /// Camera-to-world rotation; its columns are the camera's x (right), y (down) and
    /// z (forward) axes in world coordinates.
    pub rotation: Mat3,
    /// Focal length in pixels, x.
    pub fx: f32,
    /// Focal length in pixels, y.
    pub fy: f32,
    /// The principal point `(cx, cy)` in rara's pixel coordinates (pixel `(i, j)` centred at
    /// `(i, j)`), where a camera file gives one (COLMAP's, or a cameras.json entry's `cx`,
    /// `cy`, both measured with pixel centres at `+ 0.5`, so 0.5 less here); `None`: the image
    /// centre, `(W/2 - 0.5, H/2 - 0.5)` ([`Camera::principal_point`]).
    pub principal: Option<Vec2>,
}

/// One camera as an INRIA `cameras.json` writes it (other fields, such as `id` and
/// `img_name`, are ignored).
#[derive(Clone, Debug, serde::Deserialize)]
pub struct InriaCamera {
    /// Image width.
    pub width: u32,
    /// Image height.
    pub height: u32,
    /// The camera centre.
    pub position: [f32; 3],
    /// Camera-to-world rotation, rows as written (columns: right, down, forward).
    pub rotation: [[f32; 3]; 3],
    /// Focal lengths in pixels.
    pub fx: f32,
    /// See `fx`.
    pub fy: f32,
    /// The principal point, x, with pixel centres at `+ 0.5` (COLMAP's and OpenCV's
    /// convention: `W/2` is the centre); rara's own files write it only where it is not the
    /// centre, and an INRIA file has none.
    #[serde(default)]
    pub cx: Option<f32>,
    /// See `cx`.
    #[serde(default)]
    pub cy: Option<f32>,
}

impl InriaCamera {
    /// The camera, checked ([`Camera::validate`]).
    pub fn to_camera(&self) -> Result<Camera> {
        // rotation[r][c]: rows as written; from_cols_array_2d takes columns, so transpose.
        let camera = Camera {
            width: self.width,
            height: self.height,
            position: Vec3::from_array(self.position),
            rotation: Mat3::from_cols_array_2d(&self.rotation).transpose(),
            fx: self.fx,
            fy: self.fy,
            principal: match (self.cx, self.cy) {
                (Some(cx), Some(cy)) => Some(Vec2::new(cx - 0.5, cy - 0.5)),
                (None, None) => None,
                _ => {
                    return Err(Error::InvalidInput(
                        "cx and cy come together (the principal point), or neither".into(),
                    ))
                }
            },
        };
        camera.validate()?;
        Ok(camera)
    }
}

impl Camera {
    /// World-to-camera rotation `R_wc = rotation^T`.
    pub fn world_to_camera(&self) -> Mat3 {
        self.rotation.transpose()
    }

    /// Camera-space coordinates of world point `p`: `R_wc (p - position)`.
    pub fn to_camera(&self, p: Vec3) -> Vec3 {
        self.world_to_camera() * (p - self.position)
    }

    /// The principal point: [`Camera::principal`], else `(W/2 - 0.5, H/2 - 0.5)`.
    pub fn principal_point(&self) -> (f32, f32) {
        match self.principal {
            Some(p) => (p.x, p.y),
            None => (
                self.width as f32 / 2.0 - 0.5,
                self.height as f32 / 2.0 - 0.5,
            ),
        }
    }

    /// The forward (viewing) direction in world coordinates.
    pub fn forward(&self) -> Vec3 {
        self.rotation.z_axis
    }

    /// Unit world-space direction of the ray through pixel `(i, j)`.
    pub fn ray_direction(&self, i: f32, j: f32) -> Vec3 {
        let (cx, cy) = self.principal_point();
        (self.rotation * Vec3::new((i - cx) / self.fx, (j - cy) / self.fy, 1.0)).normalize()
    }

    /// The height a camera gets where only its width is given: three quarters of it (4:3),
    /// at least one pixel.
    pub fn default_height(width: u32) -> u32 {
        (width as f32 * 0.75).round().max(1.0) as u32
    }

    /// The camera a scene given without one is seen from (SPEC section 12): a pinhole looking
    /// along +z (the scene's forward; -y up, the INRIA/COLMAP convention) at the centre of the
    /// box of the Gaussians' centres `means` (the 1st to 99th percentile per axis), from the
    /// distance at which that box's height fills 90 % of the image's height at a 50-degree
    /// vertical field of view, 640x480. Where the SPEC leaves a case open: a box without
    /// height is framed by its largest extent instead, and one without any extent (a single
    /// point) from one unit away; no Gaussian is an error.
    ///
    /// ```
    /// use glam::Vec3;
    /// let means = [Vec3::new(-1.0, -1.0, 0.0), Vec3::new(1.0, 1.0, 0.0)];
    /// let cam = rara::Camera::framing(&means).unwrap();
    /// assert_eq!((cam.width, cam.height), (640, 480));
    /// // The box's height (2) spans 90 % of the 480 rows.
    /// let top = cam.to_camera(Vec3::new(0.0, -1.0, 0.0));
    /// let v = cam.fy * top.y / top.z + cam.principal_point().1;
    /// assert!((v - (239.5 - 0.45 * 480.0)).abs() < 1e-2);
    /// ```
    pub fn framing(means: &[Vec3]) -> Result<Camera> {
        let (eye, target) = Camera::framing_eye_target(means)?;
        Camera::look_at(eye, target, Vec3::NEG_Y, FRAMING_FOV_Y_DEG, 640, 480)
    }

    /// Where [`Camera::framing`] puts the eye and what it looks at (with `-y` up and a
    /// vertical field of view of [`FRAMING_FOV_Y_DEG`], at any image size).
    pub fn framing_eye_target(means: &[Vec3]) -> Result<(Vec3, Vec3)> {
        if means.is_empty() {
            return Err(Error::InvalidInput(
                "no Gaussians to frame a camera on: give a camera".into(),
            ));
        }
        let (lo, hi) = percentile_box(means, 0.01);
        let centre = (lo + hi) / 2.0;
        let extent = hi - lo;
        let height = if extent.y > 0.0 {
            extent.y
        } else {
            extent.max_element()
        };
        let distance = if height > 0.0 {
            height / (2.0 * 0.9 * (FRAMING_FOV_Y_DEG.to_radians() / 2.0).tan())
        } else {
            1.0
        };
        Ok((centre - Vec3::Z * distance, centre))
    }

    /// A camera at `eye` looking at `target`, with `up` pointing up in the image and a vertical
    /// field of view of `fov_y_deg` degrees (square pixels).
    ///
    /// ```
    /// use glam::Vec3;
    /// let cam = rara::Camera::look_at(Vec3::new(0.0, 0.0, -5.0), Vec3::ZERO, Vec3::NEG_Y, 50.0, 640, 480).unwrap();
    /// // The target projects to the principal point (W/2 - 0.5, H/2 - 0.5).
    /// let t = cam.to_camera(Vec3::ZERO);
    /// let u = cam.fx * t.x / t.z + cam.principal_point().0;
    /// assert!((u - 319.5).abs() < 1e-4);
    /// // World up (-Y) is up in the image: camera y points down.
    /// assert!(cam.to_camera(Vec3::new(0.0, -1.0, 0.0)).y < 0.0);
    /// ```
    pub fn look_at(
        eye: Vec3,
        target: Vec3,
        up: Vec3,
        fov_y_deg: f32,
        width: u32,
        height: u32,
    ) -> Result<Camera> {
        let forward = (target - eye).normalize_or_zero();
        if forward == Vec3::ZERO {
            return Err(Error::InvalidInput("--eye and --target must differ".into()));
        }
        // Camera axes: x right, y down, z forward (x = y cross z with y = -up).
        let right = forward.cross(up).normalize_or_zero();
        if right == Vec3::ZERO {
            return Err(Error::InvalidInput(
                "--up must not be parallel to the viewing direction".into(),
            ));
        }
        if !(fov_y_deg > 0.0 && fov_y_deg < 180.0) {
            return Err(Error::InvalidInput(format!(
                "--fov-y {fov_y_deg} must lie in (0, 180) degrees"
            )));
        }
        check_size(width, height)?;
        let down = forward.cross(right);
        let fy = height as f32 / (2.0 * (fov_y_deg.to_radians() / 2.0).tan());
        let camera = Camera {
            width,
            height,
            position: eye,
            rotation: Mat3::from_cols(right, down, forward),
            fx: fy,
            fy,
            principal: None,
        };
        camera.validate()?;
        Ok(camera)
    }

    /// The same camera rendering at `width` pixels: `fx, fy` scale by `width / self.width`;
    /// the height is `height` or else `round(self.height * width / self.width)`; a principal
    /// point given moves with the image (`(c + 0.5)` scaled by the new size over the old, per
    /// axis).
    pub fn resized(&self, width: u32, height: Option<u32>) -> Result<Camera> {
        let k = width as f32 / self.width as f32;
        let height = height.unwrap_or_else(|| (self.height as f32 * k).round() as u32);
        check_size(width, height)?;
        let scale = Vec2::new(k, height as f32 / self.height as f32);
        let camera = Camera {
            width,
            height,
            fx: self.fx * k,
            fy: self.fy * k,
            principal: self.principal.map(|p| (p + 0.5) * scale - 0.5),
            ..*self
        };
        camera.validate()?;
        Ok(camera)
    }

    /// Reads every camera of an INRIA `cameras.json` file, or of a COLMAP model where `path` is
    /// a folder ([`crate::formats::colmap::read_cameras`]; a cameras.json is at most
    /// [`MAX_CAMERAS_FILE_BYTES`], counted as it is read, so a pipe or a device is bounded too).
    pub fn load_all(path: impl AsRef<Path>) -> Result<Vec<Camera>> {
        let path = path.as_ref();
        if path.is_dir() {
            return crate::formats::colmap::read_cameras(path);
        }
        let text = crate::input::read_text_limited(path, MAX_CAMERAS_FILE_BYTES, "cameras.json")?;
        Camera::parse_all(&text, path)
    }

    /// [`Camera::load_all`] from the text of a cameras.json; `path` only names the source in
    /// errors. Every camera is checked ([`Camera::validate`]): finite values, a rotation that
    /// is one, positive focal lengths, an image size the renderer accepts.
    pub fn parse_all(text: &str, path: &Path) -> Result<Vec<Camera>> {
        let err = |message: String| Error::Cameras {
            path: path.to_path_buf(),
            message,
        };
        let cams: Vec<InriaCamera> = serde_json::from_str(text).map_err(|e| {
            err(format!("not an INRIA cameras.json (an array of objects with width, height, position, rotation, fx, fy): {e}"))
        })?;
        if cams.is_empty() {
            return Err(err("holds no camera".into()));
        }
        cams.iter()
            .enumerate()
            .map(|(n, c)| c.to_camera().map_err(|e| err(format!("camera {n}: {e}"))))
            .collect()
    }

    /// Checks that the camera is one the renderer can use: finite values; a rotation that is
    /// a rotation (orthonormal to within [`ROTATION_TOLERANCE`] per entry of `R^T R - I`, with
    /// determinant +1); focal lengths in `(0, MAX_FOCAL_PX]`; an image size [`check_size`]
    /// accepts. A zero, scaled, sheared or mirrored matrix would otherwise render a black or
    /// distorted frame without a word.
    pub fn validate(&self) -> Result<()> {
        let finite = self.position.is_finite()
            && self.rotation.is_finite()
            && self.fx.is_finite()
            && self.fy.is_finite()
            && self.principal.map_or(true, |p| p.is_finite());
        if !finite {
            return Err(Error::InvalidInput(
                "the camera has a NaN or infinite value (position, rotation, fx, fy or its \
                 principal point)"
                    .into(),
            ));
        }
        if !(self.fx > 0.0 && self.fy > 0.0 && self.fx <= MAX_FOCAL_PX && self.fy <= MAX_FOCAL_PX) {
            return Err(Error::InvalidInput(format!(
                "focal lengths fx {} and fy {} must be positive and at most {MAX_FOCAL_PX} pixels",
                self.fx, self.fy
            )));
        }
        let r = self.rotation;
        let gram = r.transpose() * r;
        let off = (0..3)
            .flat_map(|i| (0..3).map(move |j| (i, j)))
            .map(|(i, j)| (gram.col(j)[i] - if i == j { 1.0 } else { 0.0 }).abs())
            .fold(0f32, f32::max);
        if off > ROTATION_TOLERANCE {
            return Err(Error::InvalidInput(format!(
                "rotation is not a rotation: its columns are not orthonormal (R^T R differs from \
                 the identity by {off:.3e}, more than {ROTATION_TOLERANCE:.0e})"
            )));
        }
        if r.determinant() <= 0.0 {
            return Err(Error::InvalidInput(
                "rotation is a reflection (determinant -1), not a rotation".into(),
            ));
        }
        check_size(self.width, self.height)
    }

    /// Camera `index` of a cameras.json file, with a clear error when it is out of range.
    pub fn load_one(path: impl AsRef<Path>, index: usize) -> Result<Camera> {
        let path = path.as_ref();
        let all = Camera::load_all(path)?;
        let n = all.len();
        all.into_iter().nth(index).ok_or_else(|| Error::Cameras {
            path: path.to_path_buf(),
            message: format!(
                "camera index {index} is out of range: the file holds {n} camera(s), 0..{}",
                n - 1
            ),
        })
    }

    /// Writes cameras as an INRIA `cameras.json` array.
    pub fn save_all(cameras: &[Camera], path: impl AsRef<Path>) -> Result<()> {
        let path = path.as_ref();
        std::fs::write(path, Camera::to_json_text(cameras)).map_err(|source| Error::Io {
            path: path.to_path_buf(),
            source,
        })
    }

    /// Cameras as the text of an INRIA `cameras.json` array ([`Camera::save_all`]).
    pub fn to_json_text(cameras: &[Camera]) -> String {
        let list: Vec<serde_json::Value> = cameras
            .iter()
            .enumerate()
            .map(|(id, c)| {
                let r = c.rotation.transpose().to_cols_array_2d();
                let mut entry = serde_json::json!({
                    "id": id, "img_name": format!("view_{id:03}"),
                    "width": c.width, "height": c.height,
                    "position": c.position.to_array(), "rotation": r,
                    "fx": c.fx, "fy": c.fy,
                });
                if let Some(p) = c.principal {
                    entry["cx"] = (p.x + 0.5).into();
                    entry["cy"] = (p.y + 0.5).into();
                }
                entry
            })
            .collect();
        serde_json::to_string_pretty(&list).expect("cameras serialise")
    }
}

/// The vertical field of view of [`Camera::framing`], degrees.
pub const FRAMING_FOV_Y_DEG: f32 = 50.0;

/// The box from the `q` to the `1 - q` quantile of `points` per axis (non-empty points; the
/// nearest rank, as [`Camera::framing`] takes it).
pub fn percentile_box(points: &[Vec3], q: f64) -> (Vec3, Vec3) {
    let mut lo = Vec3::ZERO;
    let mut hi = Vec3::ZERO;
    let mut axis: Vec<f32> = Vec::with_capacity(points.len());
    for k in 0..3 {
        axis.clear();
        axis.extend(points.iter().map(|p| p[k]));
        let rank = |q: f64| ((axis.len() - 1) as f64 * q).round() as usize;
        let (r_lo, r_hi) = (rank(q), rank(1.0 - q));
        lo[k] = *axis.select_nth_unstable_by(r_lo, f32::total_cmp).1;
        hi[k] = *axis.select_nth_unstable_by(r_hi, f32::total_cmp).1;
    }
    (lo, hi)
}

/// Tiles across and down for an image of `width` x `height` pixels.
pub fn tile_grid(width: u32, height: u32) -> (u32, u32) {
    (
        width.div_ceil(crate::constants::TILE_SIZE),
        height.div_ceil(crate::constants::TILE_SIZE),
    )
}

/// The tiles (x0, y0, x1, y1), end exclusive, of the square of half side `radius` pixels
/// around `uv` in a grid of `grid` tiles: clamp(int(v), 0, g) of SPEC section 3, clamped before
/// the conversion as on the GPU (`splat_tile_rect` in common.glsl, the same operations).
pub fn tile_rect(uv: Vec2, radius: f32, (gx, gy): (u32, u32)) -> [u32; 4] {
    let tile = crate::constants::TILE_SIZE as f32;
    let cell = |v: f32, g: u32| v.clamp(0.0, g as f32) as u32;
    [
        cell((uv.x - radius) / tile, gx),
        cell((uv.y - radius) / tile, gy),
        cell((uv.x + radius + tile - 1.0) / tile, gx),
        cell((uv.y + radius + tile - 1.0) / tile, gy),
    ]
}

/// Largest cameras.json [`Camera::load_all`] reads.
pub const MAX_CAMERAS_FILE_BYTES: u64 = 64 << 20;

/// Largest focal length in pixels: a field of view of 0.09 degrees across 16,384 pixels. It
/// keeps the projection's Jacobian, and so every splat's 2D covariance, finite in `f32`.
pub const MAX_FOCAL_PX: f32 = 1e7;

/// How far `R^T R` of a camera rotation may differ from the identity, per entry: files written
/// with 6 significant digits are within 1e-5; 1e-3 still accepts 4 digits.
pub const ROTATION_TOLERANCE: f32 = 1e-3;

/// Largest image side the renderer produces (the `maxImageDimension2D` most GPUs have).
pub const MAX_IMAGE_SIDE: u32 = 16384;

/// Rejects image sizes the renderer cannot produce.
pub fn check_size(width: u32, height: u32) -> Result<()> {
    if width == 0 || height == 0 || width > MAX_IMAGE_SIDE || height > MAX_IMAGE_SIDE {
        return Err(Error::InvalidInput(format!(
            "image size {width}x{height} is out of range (1..={MAX_IMAGE_SIDE} per side)"
        )));
    }
    Ok(())
}

/// A camera path through keyframes (issue 74: `sweep --camera-path`, `render-sequence
/// --camera-path`): the keyframes evenly spaced over `s` in [0, 1], positions by a uniform
/// Catmull-Rom spline (its end keyframes repeated, so it passes through every keyframe and
/// starts and ends there), rotations by slerp between neighbouring keyframes, focal lengths and
/// principal points linearly. Every keyframe has the same image size.
#[derive(Clone, Debug, PartialEq)]
pub struct CameraPath {
    keys: Vec<Camera>,
}

impl CameraPath {
    /// The path through `keys` (at least one, all of one image size).
    pub fn new(keys: Vec<Camera>) -> Result<CameraPath> {
        let Some(first) = keys.first() else {
            return Err(Error::InvalidInput("a camera path needs a keyframe".into()));
        };
        if let Some((k, c)) = keys
            .iter()
            .enumerate()
            .find(|(_, c)| (c.width, c.height) != (first.width, first.height))
        {
            return Err(Error::InvalidInput(format!(
                "camera path: keyframe {k} is {}x{}, keyframe 0 {}x{}: a path keeps one image size",
                c.width, c.height, first.width, first.height
            )));
        }
        Ok(CameraPath { keys })
    }

    /// The keyframes.
    pub fn keys(&self) -> &[Camera] {
        &self.keys
    }

    /// The camera at `s` in [0, 1] (clamped).
    pub fn at(&self, s: f32) -> Camera {
        let n = self.keys.len();
        if n == 1 {
            return self.keys[0];
        }
        let x = s.clamp(0.0, 1.0) * (n - 1) as f32;
        let k = (x.floor() as usize).min(n - 2);
        let u = x - k as f32;
        let key = |i: isize| &self.keys[i.clamp(0, n as isize - 1) as usize];
        let (p0, p1, p2, p3) = (
            key(k as isize - 1).position,
            key(k as isize).position,
            key(k as isize + 1).position,
            key(k as isize + 2).position,
        );
        // Uniform Catmull-Rom: p1 at u = 0, p2 at u = 1.
        let (u2, u3) = (u * u, u * u * u);
        let position = 0.5
            * (2.0 * p1
                + (p2 - p0) * u
                + (2.0 * p0 - 5.0 * p1 + 4.0 * p2 - p3) * u2
                + (3.0 * p1 - p0 - 3.0 * p2 + p3) * u3);
        let (a, b) = (key(k as isize), key(k as isize + 1));
        let qa = glam::Quat::from_mat3(&a.rotation);
        let qb = glam::Quat::from_mat3(&b.rotation);
        let principal = match (a.principal, b.principal) {
            (Some(pa), Some(pb)) => Some(pa.lerp(pb, u)),
            _ => None,
        };
        Camera {
            width: a.width,
            height: a.height,
            position,
            rotation: Mat3::from_quat(qa.slerp(qb, u).normalize()),
            fx: a.fx + (b.fx - a.fx) * u,
            fy: a.fy + (b.fy - a.fy) * u,
            principal,
        }
    }
}

#[cfg(test)]
mod path_tests {
    use super::*;

    #[test]
    fn a_path_passes_through_its_keyframes_and_turns_between_them() {
        let key = |x: f32, yaw: f32, f: f32| {
            let mut c = Camera::look_at(
                Vec3::new(x, 0.0, -3.0),
                Vec3::new(x + yaw.sin(), 0.0, -3.0 + yaw.cos()),
                Vec3::NEG_Y,
                50.0,
                64,
                48,
            )
            .unwrap();
            c.fx = f;
            c.fy = f;
            c
        };
        let keys = vec![
            key(0.0, 0.0, 50.0),
            key(1.0, 0.4, 60.0),
            key(3.0, 0.8, 70.0),
        ];
        let path = CameraPath::new(keys.clone()).unwrap();
        for (s, k) in [(0.0, 0), (0.5, 1), (1.0, 2)] {
            let c = path.at(s);
            assert!((c.position - keys[k].position).length() < 1e-5, "s {s}");
            assert!(
                (c.rotation.col(2) - keys[k].rotation.col(2)).length() < 1e-5,
                "s {s}"
            );
            assert!((c.fx - keys[k].fx).abs() < 1e-4);
        }
        // Halfway between keyframes 0 and 1: the rotation halfway (yaw 0.2), the focal length
        // halfway, the position on the spline (x between them, pulled by its neighbours).
        let mid = path.at(0.25);
        let forward = mid.rotation.col(2);
        assert!((forward.x.atan2(forward.z) - 0.2).abs() < 1e-4);
        assert!((mid.fx - 55.0).abs() < 1e-4);
        assert!(mid.position.x > 0.0 && mid.position.x < 1.0);
        assert!(mid.validate().is_ok());
        // Keyframes of two sizes are refused.
        let mut other = keys[1];
        other.width = 32;
        assert!(CameraPath::new(vec![keys[0], other]).is_err());
    }
}
