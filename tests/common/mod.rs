//! Shared test helpers: a validated GPU context, real-scene discovery, image checks that
//! leave actual/expected/diff images in target/test-artifacts/ when they fail.
#![allow(dead_code)]

use std::path::{Path, PathBuf};

use rara::metrics::{compare, diff_image, ImageDiff};
pub use rara::stages::holds_cpu_layouts;
use rara::stages::rasterize::RasterLayout;
use rara::stages::sort::SortLayout;
use rara::vk::{Context, ContextDesc, Validation};

/// A headless context with the validation layer on whenever it is installed.
pub fn context() -> Context {
    context_with(ContextDesc::from_env())
}

/// [`context`] from `desc`, with the validation layer on whenever it is installed.
pub fn context_with(desc: ContextDesc) -> Context {
    let ctx = Context::headless(&ContextDesc {
        validation: Validation::IfAvailable,
        ..desc
    })
    .expect("Vulkan context (is mesa-vulkan-drivers installed?)");
    if !ctx.validation_enabled() {
        eprintln!("note: the validation layer is not installed; running without it");
    }
    ctx
}

/// The rasterizer layouts `ctx`'s device runs: both, or the pixel-per-invocation one alone
/// where its texel buffers are too small for the strips (`stages::holds_cpu_layouts`; so on
/// SwiftShader), which is printed.
pub fn raster_layouts(ctx: &Context) -> Vec<RasterLayout> {
    if holds_cpu_layouts(ctx) {
        vec![RasterLayout::Strips, RasterLayout::PixelPerInvocation]
    } else {
        eprintln!(
            "layout Strips not run: {} has small texel buffers",
            ctx.info().name
        );
        vec![RasterLayout::PixelPerInvocation]
    }
}

/// The sort layouts `ctx`'s device runs, as [`raster_layouts`] (own counts need texel buffers).
pub fn sort_layouts(ctx: &Context) -> Vec<SortLayout> {
    if holds_cpu_layouts(ctx) {
        vec![SortLayout::ShortRuns, SortLayout::OwnCounts]
    } else {
        eprintln!(
            "layout OwnCounts not run: {} has small texel buffers",
            ctx.info().name
        );
        vec![SortLayout::ShortRuns]
    }
}

/// Whether the test of a CPU driver's layout can run on `ctx`'s device; when not, says the
/// test skipped (`test_skipped`).
pub fn runs_cpu_layouts(ctx: &Context) -> bool {
    let runs = holds_cpu_layouts(ctx);
    if !runs {
        test_skipped(&format!(
            "{} has small texel buffers: it runs the GPU layouts only",
            ctx.info().name
        ));
    }
    runs
}

/// Fails the calling test when the validation layer reported anything.
pub fn assert_no_validation_messages(ctx: &Context) {
    let messages = ctx.take_validation_messages();
    assert!(
        messages.is_empty(),
        "validation layer reported {} message(s):\n{}",
        messages.len(),
        messages.join("\n")
    );
}

/// The folder of real scenes: `$RARA_REAL_DATA`, else `../shared/data/real` beside the crate.
pub fn real_data_dir() -> Option<PathBuf> {
    let dir = std::env::var_os("RARA_REAL_DATA")
        .map(PathBuf::from)
        .unwrap_or_else(|| Path::new(env!("CARGO_MANIFEST_DIR")).join("../shared/data/real"));
    dir.is_dir().then_some(dir)
}

/// The shared real scenes with orbit cameras (`../shared/data/real`), by file stem.
pub const REAL_SCENES: [&str; 5] = [
    "plant_capture_sh0",
    "biker_capture_sh0",
    "guitar_capture_sh0_anisotropic",
    "skull_mesh2splat_100k_sh0",
    "playbot_lod0_500k_sh2",
];

/// A real scene and its orbit cameras, or `None` (with a note) when they are not present.
pub fn real_scene(stem: &str) -> Option<(PathBuf, Option<PathBuf>)> {
    let Some(dir) = real_data_dir() else {
        eprintln!("real-scene case '{stem}' SKIPPED: no real data (set RARA_REAL_DATA or provide ../shared/data/real)");
        return None;
    };
    let ply = dir.join(format!("{stem}.ply"));
    if !ply.is_file() {
        eprintln!(
            "real-scene case '{stem}' SKIPPED: {} is missing",
            ply.display()
        );
        return None;
    }
    let cams = dir.join(format!("{stem}.orbit_cameras.json"));
    Some((ply, cams.is_file().then_some(cams)))
}

/// A real scene with orbit cameras and its first camera at `width` pixels, saying whether the
/// case ran (`None`, with the reason, when the files are not present).
pub fn real_scene_view(stem: &str, width: u32) -> Option<(rara::Scene, rara::Camera)> {
    let Some((ply, Some(cams))) = real_scene(stem) else {
        eprintln!("real-scene case '{stem}' SKIPPED (not found)");
        return None;
    };
    eprintln!("real-scene case '{stem}' RAN");
    let scene = rara::ply::load_ply(&ply).unwrap().0;
    let camera = rara::Camera::load_one(&cams, 0)
        .unwrap()
        .resized(width, None)
        .unwrap();
    Some((scene, camera))
}

/// The calling test process's folder `rara_test_{name}_{pid}` under the system's temp dir,
/// `name` telling its tests (or test binaries) apart. A test binary has no hook at its exit,
/// so a folder its tests share, or one a failed test left, stays behind: the first call of a
/// process with `name` removes that name's folders whose process is no longer running (where
/// `/proc` tells), and runs don't pile them up.
pub fn tempdir(name: &str) -> PathBuf {
    static SWEPT: std::sync::Mutex<Vec<String>> = std::sync::Mutex::new(Vec::new());
    let tmp = std::env::temp_dir();
    let prefix = format!("rara_test_{name}_");
    let mut swept = SWEPT
        .lock()
        .unwrap_or_else(|poisoned| poisoned.into_inner());
    if !swept.contains(&prefix) && Path::new("/proc/self").exists() {
        let entries = std::fs::read_dir(&tmp).into_iter().flatten().flatten();
        for entry in entries {
            let file_name = entry.file_name();
            let Some(pid) = file_name
                .to_str()
                .and_then(|n| n.strip_prefix(&prefix))
                .and_then(|p| p.parse::<u32>().ok())
            else {
                continue;
            };
            if pid != std::process::id() && !Path::new("/proc").join(pid.to_string()).exists() {
                std::fs::remove_dir_all(entry.path()).ok();
            }
        }
        swept.push(prefix.clone());
    }
    let dir = tmp.join(format!("{prefix}{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    dir
}

/// Marks the calling test as having checked nothing: `scripts/test.sh` counts a test whose
/// output holds this line as skipped, not passed, in its closing line (libtest has no skip).
pub fn test_skipped(why: &str) {
    eprintln!("TEST SKIPPED: {why}");
}

/// Directory for images of failed checks.
pub fn artifacts_dir() -> PathBuf {
    let d = Path::new(env!("CARGO_MANIFEST_DIR")).join("target/test-artifacts");
    std::fs::create_dir_all(&d).unwrap();
    d
}

/// Compares `actual` to `expected`; on failure of the bounds writes both and a diff map.
pub fn check_images(
    name: &str,
    actual: &image::RgbaImage,
    expected: &image::RgbaImage,
    min_psnr: f64,
    max_diff: u8,
) -> ImageDiff {
    let d = compare(actual, expected);
    eprintln!(
        "{name}: PSNR {:.2} dB, max diff {}, L1 {:.4}, differing pixels {}",
        d.psnr, d.max_diff, d.l1, d.differing_pixels
    );
    if d.psnr < min_psnr || d.max_diff > max_diff {
        let dir = artifacts_dir();
        actual.save(dir.join(format!("{name}_actual.png"))).unwrap();
        expected
            .save(dir.join(format!("{name}_expected.png")))
            .unwrap();
        diff_image(actual, expected)
            .save(dir.join(format!("{name}_diff.png")))
            .unwrap();
        panic!(
            "{name}: PSNR {:.2} dB (need >= {min_psnr}), max diff {} (need <= {max_diff}); images in {}",
            d.psnr,
            d.max_diff,
            dir.display()
        );
    }
    d
}

/// Views of `scene` from azimuths `angles` (radians) around its percentile box, a little above
/// it, at `width` x `height`: for scenes without camera files.
pub fn views_around(
    scene: &rara::Scene,
    angles: &[f32],
    width: u32,
    height: u32,
) -> Vec<rara::Camera> {
    let (lo, hi) = percentile_box(scene);
    let (centre, r) = (0.5 * (lo + hi), (hi - lo).length());
    angles
        .iter()
        .map(|&a| {
            let eye = centre + r * glam::Vec3::new(a.cos(), -0.25, a.sin());
            rara::Camera::look_at(eye, centre, glam::Vec3::NEG_Y, 50.0, width, height).unwrap()
        })
        .collect()
}

/// Bounds of the 2nd..98th percentile of the centres, per axis (robust to floaters).
pub fn percentile_box(scene: &rara::Scene) -> (glam::Vec3, glam::Vec3) {
    let (mut lo, mut hi) = (glam::Vec3::ZERO, glam::Vec3::ZERO);
    for axis in 0..3 {
        let mut v: Vec<f32> = scene.means.iter().map(|m| m[axis]).collect();
        v.sort_by(f32::total_cmp);
        lo[axis] = v[v.len() * 2 / 100];
        hi[axis] = v[v.len() * 98 / 100];
    }
    (lo, hi)
}

/// Flat and volumetric Gaussians mixed, SH degree 1 (the ray tracing tests' scene).
pub fn mixed_scene(count: usize, seed: u64) -> rara::Scene {
    let mut rng = rara::synth::Rng::new(seed);
    let mut s = rara::Scene {
        sh_degree: 1,
        ..rara::Scene::default()
    };
    for i in 0..count {
        let mut scale = glam::Vec3::new(
            rng.range(0.02, 0.15),
            rng.range(0.02, 0.15),
            rng.range(0.02, 0.15),
        );
        if i % 2 == 0 {
            scale[(i / 2) % 3] = 0.0;
        }
        let mean = glam::Vec3::new(
            rng.range(-1.0, 1.0),
            rng.range(-1.0, 1.0),
            rng.range(-1.0, 1.0),
        );
        let sh: Vec<f32> = (0..12).map(|_| rng.range(-0.7, 0.7)).collect();
        s.push(mean, rng.range(0.05, 0.99), scale, rng.rotation(), &sh);
    }
    s
}

/// The ray tracing tests' camera on `mixed_scene`, `width` wide (4:3).
pub fn tracer_camera(width: u32) -> rara::Camera {
    rara::Camera::look_at(
        glam::Vec3::new(0.4, -0.9, -3.5),
        glam::Vec3::ZERO,
        glam::Vec3::NEG_Y,
        50.0,
        width,
        width * 3 / 4,
    )
    .unwrap()
}

/// The ray tracing tests' clips of a scene whose bulk is the box (lo, hi): none, hard, rara
/// (mass and length) by a plane through it, a box cutaway, a sphere.
pub fn tracer_clips(lo: glam::Vec3, hi: glam::Vec3) -> Vec<(&'static str, rara::Clip)> {
    use glam::{Quat, Vec3};
    use rara::clip::{Clip, ClipRegion, ClipWeight, Plane};
    let c = 0.5 * (lo + hi);
    let ext = hi - lo;
    let n = Vec3::new(1.0, 0.3, -0.2).normalize();
    let plane = ClipRegion::planes(vec![Plane::new(n, -n.dot(c)).unwrap()]).unwrap();
    let cutaway = ClipRegion::oriented_box(c - 0.2 * ext, 0.35 * ext, Quat::from_rotation_y(0.4))
        .unwrap()
        .inverted();
    let sphere = ClipRegion::sphere(c + 0.2 * ext, 0.4 * ext.max_element()).unwrap();
    vec![
        ("none", Clip::default()),
        ("plane_hard", Clip::hard(plane.clone())),
        ("plane_mass", Clip::rara(plane.clone())),
        (
            "plane_length",
            Clip {
                weight: ClipWeight::Length,
                ..Clip::rara(plane)
            },
        ),
        ("cutaway_mass", Clip::rara(cutaway)),
        ("sphere_mass", Clip::rara(sphere)),
    ]
}

/// Checks a ray-traced GPU image against the CPU reference tracer's (SPEC section 7): at
/// least `min_psnr` dB, and every pixel off by more than `max_diff` levels must be one that f32
/// cannot decide, which the reference shows along the pixel's ray (among the hits the ray
/// reaches before its transmittance runs out): two hits whose t agree to
/// 1e-6 (the GPU may order them by index where the reference's f64 t orders them the other
/// way), or a flat hit whose crossing point lies within 1e-5 (1 + t) of the clip boundary (the
/// step weight of SPEC section 5 for flat Gaussians flips). At most one pixel in a thousand
/// (and at least 2) may be so; each is printed with its reason.
#[allow(clippy::too_many_arguments)]
pub fn check_traced(
    name: &str,
    gpu: &image::RgbaImage,
    cpu: &image::RgbaImage,
    scene: &rara::Scene,
    camera: &rara::Camera,
    clip: &rara::Clip,
    q: f64,
    min_psnr: f64,
    max_diff: u8,
) -> ImageDiff {
    use rara::reference::ray_hits;
    let d = check_images(name, gpu, cpu, min_psnr, 255);
    let mut undecidable = 0;
    for (x, y, p) in gpu.enumerate_pixels() {
        let e = cpu.get_pixel(x, y);
        let off = (0..3).map(|c| p[c].abs_diff(e[c])).max().unwrap();
        if off <= max_diff {
            continue;
        }
        let (o, dir) = rara::reference::rasterize::pixel_ray(camera, x, y);
        let mut hits: Vec<ray_hits::Hit> = (0..scene.len())
            .filter_map(|i| ray_hits::gaussian_hit(scene, i, o, dir, q))
            .collect();
        hits.sort_by(|a, b| a.t.total_cmp(&b.t).then(a.index.cmp(&b.index)));
        // Only the hits the ray reaches count: up to where its transmittance falls under
        // 1e-4 (SPEC section 4's stop), and one past, whose order against the last matters.
        let mut transmittance = 1.0;
        let reached = hits
            .iter()
            .position(|h| {
                let alpha = h.alpha * ray_hits::clip_weight(scene, h, o, dir, clip);
                if alpha >= 1.0 / 255.0 {
                    transmittance *= 1.0 - alpha;
                }
                transmittance < 1e-4
            })
            .map_or(hits.len(), |last| (last + 2).min(hits.len()));
        hits.truncate(reached);
        let tie = hits
            .windows(2)
            .find(|w| w[1].t - w[0].t <= 1e-6 * w[0].t)
            .map(|w| {
                format!(
                    "hits {} and {} at t {:.9} and {:.9}",
                    w[0].index, w[1].index, w[0].t, w[1].t
                )
            });
        let edge = clip
            .region
            .as_ref()
            .filter(|_| clip.effective_mode() == rara::ClipMode::Rara)
            .and_then(|region| {
                hits.iter()
                    .filter(|h| rara::scene::flat_axis(scene.scales[h.index as usize]).is_some())
                    .map(|h| (h, region.signed_distance((o + h.t * dir).as_vec3()) as f64))
                    .find(|(h, sd)| sd.abs() <= 1e-5 * (1.0 + h.t))
                    .map(|(h, sd)| {
                        format!(
                            "flat hit {} crosses {sd:.2e} from the clip boundary",
                            h.index
                        )
                    })
            });
        let why: Vec<String> = [edge, tie].into_iter().flatten().collect();
        if why.is_empty() {
            panic!(
                "{name}: pixel ({x}, {y}) is {off} levels off (GPU {p:?}, CPU {e:?}) with no hit \
                 that f32 cannot decide on its ray"
            );
        }
        let why = why.join("; ");
        eprintln!("{name}: pixel ({x}, {y}) {off} levels off, undecidable in f32: {why}");
        undecidable += 1;
    }
    let pixels = gpu.pixels().len();
    assert!(
        undecidable <= (pixels / 1000).max(2),
        "{name}: {undecidable} pixels of {pixels} off by more than {max_diff} levels"
    );
    d
}

/// Whether `node` runs here.
fn node_runs() -> bool {
    std::process::Command::new("node")
        .arg("--version")
        .output()
        .is_ok_and(|o| o.status.success())
}

/// The glTF validator's report on `glb` (its `issues` object: `numErrors`, `numWarnings`,
/// `messages`...), or `None` when node or npm's `gltf-validator` is not installed
/// (`scripts/clients.sh` installs it into target/clients; `RARA_GLTF_VALIDATOR` points elsewhere).
pub fn gltf_validator_issues(glb: &Path) -> Option<serde_json::Value> {
    let module = std::env::var_os("RARA_GLTF_VALIDATOR")
        .map(PathBuf::from)
        .unwrap_or_else(|| {
            Path::new(env!("CARGO_MANIFEST_DIR")).join("target/clients/node_modules/gltf-validator")
        });
    if !node_runs() || !module.is_dir() {
        return None;
    }
    let js = format!(
        "const v = require({module:?}); const fs = require('fs');\n\
         v.validateBytes(new Uint8Array(fs.readFileSync({glb:?})), {{maxIssues: 100}})\n\
          .then(r => console.log(JSON.stringify(r.issues)))\n\
          .catch(e => {{ console.error(e); process.exit(2); }});",
        module = module.display().to_string(),
        glb = glb.display().to_string()
    );
    let out = std::process::Command::new("node")
        .arg("-e")
        .arg(js)
        .output()
        .unwrap();
    assert!(
        out.status.success(),
        "gltf-validator on {}: {}",
        glb.display(),
        String::from_utf8_lossy(&out.stderr)
    );
    Some(serde_json::from_slice(&out.stdout).unwrap())
}

/// PlayCanvas' splat-transform command (npm `@playcanvas/splat-transform`, which
/// `scripts/clients.sh` installs into target/clients; `RARA_SPLAT_TRANSFORM` points elsewhere),
/// or `None` when it or node is not here.
pub fn splat_transform() -> Option<PathBuf> {
    let bin = std::env::var_os("RARA_SPLAT_TRANSFORM")
        .map(PathBuf::from)
        .unwrap_or_else(|| {
            Path::new(env!("CARGO_MANIFEST_DIR"))
                .join("target/clients/node_modules/.bin/splat-transform")
        });
    (node_runs() && bin.is_file()).then_some(bin)
}

/// Runs splat-transform to convert `input` into `output` (any format it writes, by extension),
/// failing the test with its message when it fails.
pub fn run_splat_transform(bin: &Path, input: &Path, output: &Path) {
    let out = std::process::Command::new(bin)
        .args(["-q", "-w"])
        .arg(input)
        .arg(output)
        .output()
        .unwrap();
    assert!(
        out.status.success() && output.exists(),
        "splat-transform {} {}: {}{}",
        input.display(),
        output.display(),
        String::from_utf8_lossy(&out.stdout),
        String::from_utf8_lossy(&out.stderr)
    );
}

/// The members of a zip, by name, in order.
pub fn unzip(bytes: &[u8]) -> Option<Vec<(String, Vec<u8>)>> {
    use std::io::Read;
    let mut archive = zip::ZipArchive::new(std::io::Cursor::new(bytes)).ok()?;
    let mut out = Vec::new();
    for i in 0..archive.len() {
        let mut f = archive.by_index(i).ok()?;
        let mut data = Vec::new();
        (&mut f).take(64 << 20).read_to_end(&mut data).ok()?;
        out.push((f.name().ok()?.to_string(), data));
    }
    Some(out)
}

/// A zip of `members` (deflated), in order.
pub fn zip_members(members: &[(String, Vec<u8>)]) -> Vec<u8> {
    use std::io::Write;
    let mut w = zip::ZipWriter::new(std::io::Cursor::new(Vec::new()));
    let options = zip::write::SimpleFileOptions::default()
        .compression_method(zip::CompressionMethod::Deflated);
    for (name, data) in members {
        w.start_file(name.as_str(), options).unwrap();
        w.write_all(data).unwrap();
    }
    w.finish().unwrap().into_inner()
}

/// The Gaussians `keep` of `s` (indices in order), as a scene of their own.
pub fn subset(s: &rara::Scene, keep: &[usize]) -> rara::Scene {
    rara::Scene {
        means: keep.iter().map(|&i| s.means[i]).collect(),
        opacities: keep.iter().map(|&i| s.opacities[i]).collect(),
        scales: keep.iter().map(|&i| s.scales[i]).collect(),
        rotations: keep.iter().map(|&i| s.rotations[i]).collect(),
        sh_degree: s.sh_degree,
        sh: keep.iter().flat_map(|&i| s.sh_of(i).to_vec()).collect(),
    }
}

/// The CPU's projected splats with the GPU's values (centre, depth, opacity, conic, colour)
/// from `mid` (a frame's intermediates), so the CPU compositor sees what the GPU did.
pub fn with_gpu_values(
    cpu: Vec<rara::reference::project::ProjectedSplat>,
    mid: &rara::Intermediates,
) -> Vec<rara::reference::project::ProjectedSplat> {
    cpu.into_iter()
        .map(|c| {
            let g = &mid.splats[c.index as usize];
            rara::reference::project::ProjectedSplat {
                uv: g.uv.into(),
                depth: g.depth,
                opacity: g.opacity,
                conic: g.conic.into(),
                color: g.color().into(),
                ..c
            }
        })
        .collect()
}

/// The JSON chunk and the binary chunk of a glb, or `None`.
pub fn glb_chunks(bytes: &[u8]) -> Option<(Vec<u8>, Vec<u8>)> {
    let u32_at = |at: usize| -> Option<usize> {
        Some(u32::from_le_bytes(bytes.get(at..at + 4)?.try_into().ok()?) as usize)
    };
    let json_len = u32_at(12)?;
    let json = bytes.get(20..20 + json_len)?.to_vec();
    let bin_at = 20 + json_len;
    let bin_len = u32_at(bin_at)?;
    let bin = bytes.get(bin_at + 8..bin_at + 8 + bin_len)?.to_vec();
    Some((json, bin))
}

/// A glb of `json` (padded with spaces) and `bin`.
pub fn glb_of(json: &[u8], bin: &[u8]) -> Vec<u8> {
    let mut json = json.to_vec();
    while json.len() % 4 != 0 {
        json.push(b' ');
    }
    let total = 12 + 8 + json.len() + 8 + bin.len();
    let mut out = Vec::with_capacity(total);
    out.extend_from_slice(b"glTF");
    out.extend_from_slice(&2u32.to_le_bytes());
    out.extend_from_slice(&(total as u32).to_le_bytes());
    out.extend_from_slice(&(json.len() as u32).to_le_bytes());
    out.extend_from_slice(b"JSON");
    out.extend_from_slice(&json);
    out.extend_from_slice(&(bin.len() as u32).to_le_bytes());
    out.extend_from_slice(b"BIN\0");
    out.extend_from_slice(bin);
    out
}

/// Runs the `rara` binary with `args` to its end.
pub fn rara(args: &[&str]) -> std::process::Output {
    std::process::Command::new(env!("CARGO_BIN_EXE_rara"))
        .args(args)
        .output()
        .expect("run rara")
}

/// Asserts that the command succeeded, showing its stderr if not, and that the validation
/// layer said nothing (with `RARA_VALIDATION=1`, which `scripts/test.sh` sets on SwiftShader).
pub fn assert_success(out: &std::process::Output) {
    assert!(
        out.status.success(),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    assert_no_validation_output(out);
}

/// Fails when the binary printed a validation message (`rara: Vulkan validation: ...`).
pub fn assert_no_validation_output(out: &std::process::Output) {
    let stderr = String::from_utf8_lossy(&out.stderr);
    assert!(
        !stderr.contains("Vulkan validation:"),
        "the validation layer reported: {stderr}"
    );
}

/// Asserts a clean failure whose stderr contains every one of `needles`.
pub fn assert_error(out: &std::process::Output, needles: &[&str]) {
    let stderr = String::from_utf8_lossy(&out.stderr);
    assert!(!out.status.success(), "expected failure, stderr: {stderr}");
    assert_ne!(out.status.code(), Some(101), "rara panicked: {stderr}");
    assert!(!stderr.contains("panicked"), "rara panicked: {stderr}");
    assert_no_validation_output(out);
    for n in needles {
        assert!(stderr.contains(n), "stderr lacks '{n}': {stderr}");
    }
}

/// A FIFO at `path`.
pub fn mkfifo(path: &Path) {
    let c = std::ffi::CString::new(path.to_str().unwrap()).unwrap();
    // SAFETY: a valid NUL-terminated path.
    assert_eq!(
        unsafe { libc::mkfifo(c.as_ptr(), 0o600) },
        0,
        "mkfifo {path:?}"
    );
}

/// `zero.EXT` (a symlink to `/dev/zero`, which never ends) and `fifo.EXT` (a FIFO, which a
/// reader that opened it would wait on forever) in `dir`, made when missing: what a hostile
/// file may name beside itself.
pub fn endless_files(dir: &Path, ext: &str) {
    let zero = dir.join(format!("zero.{ext}"));
    if !zero.exists() {
        std::os::unix::fs::symlink("/dev/zero", &zero).unwrap();
    }
    let fifo = dir.join(format!("fifo.{ext}"));
    if !fifo.exists() {
        mkfifo(&fifo);
    }
}

/// The folder of the format fixtures (`scripts/format_fixtures.sh` made them with
/// splat-transform from `source.ply`).
pub fn fixtures_dir() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("tests/fixtures/formats")
}

/// The bytes of the format fixture `name`.
pub fn format_fixture(name: &str) -> Vec<u8> {
    std::fs::read(fixtures_dir().join(name)).unwrap()
}
