//! CPU twin of the tile lists (emit + sort + tile ranges) and of the rasterizer
//! (`glsl/rasterize_body.glsl`, SPEC section 4).

use glam::{DVec3, Vec2, Vec3};

use super::project::{footprint_q_max, footprint_touches_tile, tile_grid, ProjectedSplat};
use super::Rgba8Image;
use crate::camera::Camera;
use crate::clip::{Clip, ClipMode, ClipWeight, Spans};
use crate::constants::TILE_SIZE;

/// One pixel's ray against the clip region, for the weights of cutoff splats.
#[derive(Clone, Copy, Debug)]
pub struct PixelClip {
    /// Unit world direction of the pixel's ray (SPEC section 2).
    pub dir: DVec3,
    /// Visible part of the ray.
    pub spans: Spans,
    /// Weight kind.
    pub weight: ClipWeight,
    /// Band.
    pub band: f64,
}

impl PixelClip {
    /// The ray of pixel `(i, j)` against `clip`, or `None` when no weight is ever needed.
    pub fn new(clip: &Clip, camera: &Camera, i: u32, j: u32) -> Option<PixelClip> {
        let region = clip.region.as_ref()?;
        if clip.effective_mode() != ClipMode::Rara {
            return None;
        }
        let (_, dir) = pixel_ray(camera, i, j);
        Some(PixelClip {
            dir,
            spans: region.ray_intervals(camera.position.as_dvec3(), dir),
            weight: clip.weight,
            band: clip.band as f64,
        })
    }
}

/// The ray of pixel `(i, j)` (SPEC section 2): the camera centre and the unit direction
/// through the pixel's image coordinates, in f64.
pub fn pixel_ray(camera: &Camera, i: u32, j: u32) -> (DVec3, DVec3) {
    let (cx, cy) = camera.principal_point();
    let c = DVec3::new(
        (i as f64 - cx as f64) / camera.fx as f64,
        (j as f64 - cy as f64) / camera.fy as f64,
        1.0,
    );
    (
        camera.position.as_dvec3(),
        (camera.rotation.as_dmat3() * c).normalize(),
    )
}

/// Per tile, the splats whose visible footprint reaches it, in compositing order: ascending
/// depth, ties by index.
pub fn tile_lists(splats: &[ProjectedSplat], camera: &Camera) -> Vec<Vec<u32>> {
    let (gx, gy) = tile_grid(camera);
    let mut lists: Vec<Vec<(u32, u32, u32)>> = vec![Vec::new(); (gx * gy) as usize];
    for (k, s) in splats.iter().enumerate() {
        let q_max = footprint_q_max(s.opacity);
        for ty in s.rect[1]..s.rect[3] {
            for tx in s.rect[0]..s.rect[2] {
                if !footprint_touches_tile(s.uv, s.conic, q_max, tx, ty) {
                    continue;
                }
                lists[(ty * gx + tx) as usize].push((s.depth.to_bits(), s.index, k as u32));
            }
        }
    }
    lists
        .into_iter()
        .map(|mut l| {
            l.sort_unstable_by_key(|&(d, i, _)| (d, i));
            l.into_iter().map(|(_, _, k)| k).collect()
        })
        .collect()
}

/// Composites one pixel front to back; returns the colour over `background`. `clip` is the
/// pixel's ray against the clip region, needed when some splats are cutoff.
pub fn composite_pixel(
    splats: &[ProjectedSplat],
    list: &[u32],
    pixel: Vec2,
    background: Vec3,
    clip: Option<&PixelClip>,
) -> Vec3 {
    composite_pixel_depth(splats, list, pixel, background, clip, f32::INFINITY).color
}

/// A pixel composited with depth (SPEC section 9).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct PixelDepth {
    /// The colour over the background.
    pub color: Vec3,
    /// The transmittance left.
    pub t: f32,
    /// The view depth at which `1 - T` first reached 0.5 (`+inf` when it never did).
    pub median: f32,
    /// `sum(alpha T z) / sum(alpha T)` over the composited splats (`+inf` when none).
    pub mean: f32,
}

/// [`composite_pixel`] with a depth test against the engine's view depth `limit` at the pixel
/// (`f32::INFINITY`: none): the pixel stops at the first splat not in front of it. Returns the
/// colour and the depth outputs, in the GPU's f32 operations.
pub fn composite_pixel_depth(
    splats: &[ProjectedSplat],
    list: &[u32],
    pixel: Vec2,
    background: Vec3,
    clip: Option<&PixelClip>,
    limit: f32,
) -> PixelDepth {
    let mut color = Vec3::ZERO;
    let mut t = 1.0f32;
    let mut median = f32::INFINITY;
    let mut zsum = 0.0f32;
    for &k in list {
        let s = &splats[k as usize];
        if s.depth >= limit {
            break;
        }
        let d = s.uv - pixel;
        let power = -0.5 * (s.conic.x * d.x * d.x + s.conic.z * d.y * d.y) - s.conic.y * d.x * d.y;
        if power > 0.0 {
            continue;
        }
        let w = match (&s.cutoff, clip) {
            (Some(ray), Some(c)) => ray.weight(c.dir, &c.spans, c.weight, c.band) as f32,
            (Some(_), None) => panic!("a cutoff splat needs the pixel's clip ray"),
            (None, _) => 1.0,
        };
        let alpha = (s.opacity * power.exp() * w).min(0.99);
        if alpha < 1.0 / 255.0 {
            continue;
        }
        let next_t = t * (1.0 - alpha);
        if next_t < 1e-4 {
            break;
        }
        color += alpha * t * s.color;
        zsum += alpha * t * s.depth;
        if next_t <= 0.5 && median.is_infinite() {
            median = s.depth;
        }
        t = next_t;
    }
    let weight = 1.0 - t;
    PixelDepth {
        color: color + t * background,
        t,
        median,
        mean: if weight > 0.0 {
            zsum / weight
        } else {
            f32::INFINITY
        },
    }
}

/// 8-bit quantisation of SPEC section 4: clamp to [0, 1], round(255 x).
pub fn to_rgba8(c: Vec3) -> [u8; 4] {
    let q = |x: f32| (x.clamp(0.0, 1.0) * 255.0 + 0.5).floor() as u8;
    [q(c.x), q(c.y), q(c.z), 255]
}

/// Rasterizes projected splats into an 8-bit image, tiles spread over the host's cores.
pub fn rasterize(
    splats: &[ProjectedSplat],
    camera: &Camera,
    background: Vec3,
    clip: &Clip,
) -> Rgba8Image {
    rasterize_depth(splats, camera, background, clip, None).0
}

/// [`rasterize`] with depth (SPEC section 9): a depth test against `limits` (the engine's view
/// depth per pixel, rows top first) when given, and the median and mean depths per pixel.
pub fn rasterize_depth(
    splats: &[ProjectedSplat],
    camera: &Camera,
    background: Vec3,
    clip: &Clip,
    limits: Option<&[f32]>,
) -> (Rgba8Image, Vec<f32>, Vec<f32>) {
    let lists = tile_lists(splats, camera);
    let (gx, gy) = tile_grid(camera);
    let (w, h) = (camera.width, camera.height);
    if let Some(l) = limits {
        assert_eq!(l.len(), (w * h) as usize, "one limit per pixel");
    }
    let threads = std::thread::available_parallelism().map_or(1, |n| n.get());
    let next = std::sync::atomic::AtomicU32::new(0);
    let done = std::sync::Mutex::new(Vec::new());
    std::thread::scope(|scope| {
        for _ in 0..threads {
            scope.spawn(|| loop {
                let ty = next.fetch_add(1, std::sync::atomic::Ordering::Relaxed);
                if ty >= gy {
                    break;
                }
                let mut band = Vec::new();
                for j in ty * TILE_SIZE..((ty + 1) * TILE_SIZE).min(h) {
                    for i in 0..w {
                        let list = &lists[(ty * gx + i / TILE_SIZE) as usize];
                        band.push(composite_pixel_depth(
                            splats,
                            list,
                            Vec2::new(i as f32, j as f32),
                            background,
                            PixelClip::new(clip, camera, i, j).as_ref(),
                            limits.map_or(f32::INFINITY, |l| l[(j * w + i) as usize]),
                        ));
                    }
                }
                done.lock().unwrap().push((ty, band));
            });
        }
    });
    let mut bands = done.into_inner().unwrap();
    bands.sort_by_key(|(ty, _)| *ty);
    let pixels: Vec<PixelDepth> = bands.into_iter().flat_map(|(_, b)| b).collect();
    let rgba: Vec<u8> = pixels.iter().flat_map(|p| to_rgba8(p.color)).collect();
    (
        Rgba8Image::from_raw(w, h, rgba).expect("image size"),
        pixels.iter().map(|p| p.median).collect(),
        pixels.iter().map(|p| p.mean).collect(),
    )
}
