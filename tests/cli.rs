//! The `rara` binary on good and hostile input: errors go to stderr with a non-zero exit and
//! name what is wrong, never a panic.

use std::path::PathBuf;
use std::process::Command;

mod common;
use common::{assert_error, assert_success, rara};

/// `rara` with its standard input, output and error piped, running.
fn rara_piped(args: &[&str]) -> std::process::Child {
    use std::process::Stdio;
    Command::new(env!("CARGO_BIN_EXE_rara"))
        .args(args)
        .stdin(Stdio::piped())
        .stdout(Stdio::piped())
        .stderr(Stdio::piped())
        .spawn()
        .unwrap()
}

fn dir() -> PathBuf {
    common::tempdir("cli")
}

fn write(name: &str, bytes: &[u8]) -> PathBuf {
    let p = dir().join(name);
    std::fs::write(&p, bytes).unwrap();
    p
}

/// A valid binary scene and a cameras file for it, under names of their own: tests run in
/// parallel, and one must not read the files while another writes them.
fn good_scene() -> (PathBuf, PathBuf) {
    static NEXT: std::sync::atomic::AtomicUsize = std::sync::atomic::AtomicUsize::new(0);
    let n = NEXT.fetch_add(1, std::sync::atomic::Ordering::Relaxed);
    let scene = rara::synth::shell(500, 1, 3);
    let p = dir().join(format!("good{n}.ply"));
    rara::ply::write_ply(&scene, &p, rara::ply::PlyEncoding::BinaryLittleEndian).unwrap();
    let cams = rara::synth::orbit_cameras(2, 3.0, 64, 48, 50.0).unwrap();
    let c = dir().join(format!("good{n}.cameras.json"));
    rara::Camera::save_all(&cams, &c).unwrap();
    (p, c)
}

fn render_args<'a>(scene: &'a str, cams: &'a str, out: &'a str) -> Vec<&'a str> {
    vec!["render", scene, "--cameras", cams, "-o", out]
}

fn header(count: &str, props: &[&str]) -> String {
    let mut h = format!("ply\nformat binary_little_endian 1.0\nelement vertex {count}\n");
    for p in props {
        h.push_str(&format!("property float {p}\n"));
    }
    h + "end_header\n"
}

const BASE: [&str; 14] = [
    "x", "y", "z", "f_dc_0", "f_dc_1", "f_dc_2", "opacity", "scale_0", "scale_1", "scale_2",
    "rot_0", "rot_1", "rot_2", "rot_3",
];

/// A machine whose Vulkan loader finds no driver gets an error that says what to install, not
/// the loader's code alone.
#[test]
fn no_vulkan_driver_is_a_clear_error() {
    let (scene, cams) = good_scene();
    let out = dir().join("no_driver.png");
    let o = Command::new(env!("CARGO_BIN_EXE_rara"))
        .args(render_args(
            scene.to_str().unwrap(),
            cams.to_str().unwrap(),
            out.to_str().unwrap(),
        ))
        // The loader's list of driver manifests, then its older name: a file that is not there.
        .env("VK_DRIVER_FILES", "/nonexistent/rara_no_icd.json")
        .env("VK_ICD_FILENAMES", "/nonexistent/rara_no_icd.json")
        .output()
        .expect("run rara");
    assert_error(
        &o,
        &["no Vulkan driver found", "mesa-vulkan-drivers", "libglvnd0"],
    );
}

/// A wait for the GPU past `RARA_GPU_WARN_S` says so on stderr and goes on: the frame is the
/// same. Set to a microsecond, which no frame's submission takes less than.
#[test]
fn a_long_wait_for_the_gpu_is_reported() {
    let (scene, cams) = good_scene();
    let render = |name: &str, warn: Option<&str>| {
        let out = dir().join(name);
        let mut cmd = Command::new(env!("CARGO_BIN_EXE_rara"));
        cmd.args(render_args(
            scene.to_str().unwrap(),
            cams.to_str().unwrap(),
            out.to_str().unwrap(),
        ));
        if let Some(w) = warn {
            cmd.env("RARA_GPU_WARN_S", w);
        }
        let o = cmd.output().expect("run rara");
        assert_success(&o);
        (
            String::from_utf8_lossy(&o.stderr).into_owned(),
            image::open(&out).unwrap().to_rgba8(),
        )
    };
    let (quiet, image) = render("wait_default.png", None);
    let (warned, same) = render("wait_warned.png", Some("0.000001"));
    let needle = "the GPU has not finished a submission after 0.000001 s; still waiting";
    assert!(!quiet.contains("has not finished"), "{quiet}");
    assert!(warned.contains(needle), "{warned}");
    assert_eq!(image, same, "the frame changed");
}

#[test]
fn render_and_info_succeed() {
    let (scene, cams) = good_scene();
    let out = dir().join("out.png");
    let o = rara(&render_args(
        scene.to_str().unwrap(),
        cams.to_str().unwrap(),
        out.to_str().unwrap(),
    ));
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    let img = image::open(&out).unwrap();
    assert_eq!((img.width(), img.height()), (64, 48));
    // The memory report: 500 Gaussians of SH degree 1 are 48 + 12 * 4 bytes each in f32 and
    // 48 + 12 * 2 in f16; the half-precision image is within 8-bit rounding of the f32 one.
    let stdout = String::from_utf8_lossy(&o.stdout).into_owned();
    assert!(
        stdout.contains("device memory: scene 0.0 MB (96 B/Gaussian, SH f32)"),
        "{stdout}"
    );
    let half = dir().join("out_half.png");
    let mut args = render_args(
        scene.to_str().unwrap(),
        cams.to_str().unwrap(),
        half.to_str().unwrap(),
    );
    args.push("--sh-half");
    let o = rara(&args);
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    let stdout = String::from_utf8_lossy(&o.stdout).into_owned();
    assert!(stdout.contains("(72 B/Gaussian, SH f16)"), "{stdout}");
    let d = rara::metrics::compare(
        &image::open(&out).unwrap().to_rgba8(),
        &image::open(&half).unwrap().to_rgba8(),
    );
    assert!(
        d.max_diff <= 1,
        "f16 SH changed the image by {}",
        d.max_diff
    );
    let o = rara(&[
        "render",
        scene.to_str().unwrap(),
        "--eye",
        "0,-1,-3",
        "--target",
        "0,0,0",
        "--width",
        "80",
        "-o",
        out.to_str().unwrap(),
    ]);
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    assert_eq!(image::open(&out).unwrap().height(), 60);
    let o = rara(&["info", scene.to_str().unwrap(), "--json"]);
    assert!(o.status.success());
    let v: serde_json::Value = serde_json::from_slice(&o.stdout).unwrap();
    assert_eq!(v["count"], 500);
    assert_eq!(v["sh_degree"], 1);
}

#[test]
fn hostile_scenes_fail_cleanly() {
    let (good, cams) = good_scene();
    let cams = cams.to_str().unwrap();
    let out = dir().join("never.png");
    let out = out.to_str().unwrap();
    let bytes = std::fs::read(&good).unwrap();

    let truncated = write("truncated.ply", &bytes[..bytes.len() - 100]);
    assert_error(
        &rara(&render_args(truncated.to_str().unwrap(), cams, out)),
        &["truncated.ply", "truncated payload"],
    );

    let not_ply = write(
        "not_a_ply.ply",
        b"\x89PNG\r\n\x1a\n this is not a ply file at all",
    );
    assert_error(
        &rara(&render_args(not_ply.to_str().unwrap(), cams, out)),
        &["not_a_ply.ply", "not a PLY"],
    );

    let empty = write("empty.ply", b"");
    assert_error(
        &rara(&render_args(empty.to_str().unwrap(), cams, out)),
        &["empty.ply", "empty file"],
    );

    let huge = write("huge.ply", header("1000000000000", &BASE).as_bytes());
    assert_error(
        &rara(&render_args(huge.to_str().unwrap(), cams, out)),
        &["huge.ply", "1000000000000 vertices", "truncated payload"],
    );

    let mut props = BASE.to_vec();
    let rest: Vec<String> = (0..7).map(|j| format!("f_rest_{j}")).collect();
    props.extend(rest.iter().map(String::as_str));
    let bad_k = write("bad_k.ply", header("1", &props).as_bytes());
    assert_error(
        &rara(&render_args(bad_k.to_str().unwrap(), cams, out)),
        &["bad_k.ply", "7 'f_rest_*'"],
    );

    let no_opacity: Vec<&str> = BASE.iter().copied().filter(|p| *p != "opacity").collect();
    let missing = write("no_opacity.ply", header("1", &no_opacity).as_bytes());
    assert_error(
        &rara(&render_args(missing.to_str().unwrap(), cams, out)),
        &["no_opacity.ply", "'vertex'", "'opacity'"],
    );

    let garbage_header = write(
        "garbage_header.ply",
        b"ply\nformat binary_little_endian 1.0\nelement vertex 1\nproperty flot x\nend_header\n",
    );
    assert_error(
        &rara(&render_args(garbage_header.to_str().unwrap(), cams, out)),
        &["garbage_header.ply", "malformed header"],
    );

    let no_end = write(
        "no_end.ply",
        b"ply\nformat ascii 1.0\nelement vertex 1\nproperty float x\n",
    );
    assert_error(
        &rara(&render_args(no_end.to_str().unwrap(), cams, out)),
        &["no_end.ply", "end_header"],
    );

    let missing_file = dir().join("does_not_exist.ply");
    assert_error(
        &rara(&render_args(missing_file.to_str().unwrap(), cams, out)),
        &["does_not_exist.ply"],
    );
}

/// SPEC section 1: Gaussians with NaN values are dropped with a counted warning; the load and
/// the render succeed. A scene with nothing but NaN renders the background.
#[test]
fn nan_values_are_dropped_with_a_warning() {
    let (_, cams) = good_scene();
    let mut scene = rara::synth::shell(100, 0, 9);
    for i in 0..7 {
        scene.opacities[i * 3] = f32::NAN;
    }
    let p = dir().join("nan.ply");
    rara::ply::write_ply(&scene, &p, rara::ply::PlyEncoding::BinaryLittleEndian).unwrap();
    let out = dir().join("nan.png");
    let o = rara(&render_args(
        p.to_str().unwrap(),
        cams.to_str().unwrap(),
        out.to_str().unwrap(),
    ));
    let stderr = String::from_utf8_lossy(&o.stderr);
    assert!(o.status.success(), "{stderr}");
    assert!(
        stderr.contains("dropped 7 of 100 Gaussians with non-finite values"),
        "{stderr}"
    );
}

#[test]
fn hostile_cameras_fail_cleanly() {
    let (scene, cams) = good_scene();
    let scene = scene.to_str().unwrap();
    let out = dir().join("never.png");
    let out = out.to_str().unwrap();
    let o = rara(&[
        "render",
        scene,
        "--cameras",
        cams.to_str().unwrap(),
        "--camera",
        "5",
        "-o",
        out,
    ]);
    assert_error(&o, &["camera index 5 is out of range", "2 camera(s)"]);

    let malformed = write(
        "malformed.cameras.json",
        b"[{\"width\": 640, \"height\": 480, \"position\": [0, 0]}]",
    );
    assert_error(
        &rara(&render_args(scene, malformed.to_str().unwrap(), out)),
        &["malformed.cameras.json", "cameras.json"],
    );
    let not_json = write("not_json.cameras.json", b"{{{ nope");
    assert_error(
        &rara(&render_args(scene, not_json.to_str().unwrap(), out)),
        &["not_json.cameras.json"],
    );
    let empty = write("empty.cameras.json", b"[]");
    assert_error(
        &rara(&render_args(scene, empty.to_str().unwrap(), out)),
        &["empty.cameras.json", "no camera"],
    );
    let bad_values = write(
        "bad_values.cameras.json",
        b"[{\"width\": 640, \"height\": 480, \"position\": [0, 0, 0], \"rotation\": [[1,0,0],[0,1,0],[0,0,1]], \"fx\": -5, \"fy\": 500}]",
    );
    assert_error(
        &rara(&render_args(scene, bad_values.to_str().unwrap(), out)),
        &["bad_values.cameras.json", "must be positive"],
    );
    // A rotation must be one: orthonormal (within 1e-3) with determinant +1. Zero, rank
    // deficient, scaled, sheared and mirrored matrices used to render black or distorted
    // frames with exit 0.
    let camera_with = |rotation: &str, extra: &str| {
        format!(
            "[{{\"width\": 64, \"height\": 48, \"position\": [0, 0, -3], \"rotation\": {rotation}, \"fx\": 50, \"fy\": 50{extra}}}]"
        )
    };
    for (name, rotation, needle) in [
        ("zero", "[[0,0,0],[0,0,0],[0,0,0]]", "not orthonormal"),
        ("rank1", "[[1,0,0],[1,0,0],[0,0,1]]", "not orthonormal"),
        ("scaled", "[[2,0,0],[0,2,0],[0,0,2]]", "not orthonormal"),
        ("sheared", "[[1,0.1,0],[0,1,0],[0,0,1]]", "not orthonormal"),
        ("mirrored", "[[-1,0,0],[0,1,0],[0,0,1]]", "reflection"),
    ] {
        let f = write(
            &format!("{name}.cameras.json"),
            camera_with(rotation, "").as_bytes(),
        );
        let o = rara(&render_args(scene, f.to_str().unwrap(), out));
        assert_error(&o, &[&format!("{name}.cameras.json"), "camera 0", needle]);
    }
    // Four digits of a real rotation are still one.
    let rounded = camera_with("[[0.7071,0,0.7071],[0,1,0],[-0.7071,0,0.7071]]", "");
    let f = write("rounded.cameras.json", rounded.as_bytes());
    let ok = dir().join("rounded.png");
    assert_success(&rara(&render_args(
        scene,
        f.to_str().unwrap(),
        ok.to_str().unwrap(),
    )));
    // NaN and infinity anywhere: JSON has neither, so they come as overflowing numbers.
    let f = write(
        "huge.cameras.json",
        camera_with("[[1,0,0],[0,1,0],[0,0,1]]", "")
            .replace("-3]", "1e39]")
            .as_bytes(),
    );
    assert_error(
        &rara(&render_args(scene, f.to_str().unwrap(), out)),
        &["huge.cameras.json"],
    );
    let f = write(
        "focal.cameras.json",
        camera_with("[[1,0,0],[0,1,0],[0,0,1]]", "")
            .replace("\"fx\": 50", "\"fx\": 1e30")
            .as_bytes(),
    );
    assert_error(
        &rara(&render_args(scene, f.to_str().unwrap(), out)),
        &["focal.cameras.json", "at most 10000000 pixels"],
    );

    let o = rara(&[
        "render", scene, "--eye", "0,0,0", "--target", "0,0,0", "-o", out,
    ]);
    assert_error(&o, &["--eye and --target must differ"]);
    let o = rara(&[
        "render", scene, "--eye", "1,2", "--target", "0,0,0", "-o", out,
    ]);
    assert_error(&o, &["X,Y,Z"]);
    let o = rara(&[
        "render", scene, "--eye", "0,0,-3", "--target", "0,0,0", "--width", "0", "-o", out,
    ]);
    assert_error(&o, &["out of range"]);
}

#[test]
fn demo_shows_the_cut_and_the_popping() {
    let d = dir().join("demo");
    let o = rara(&["demo", "-o", d.to_str().unwrap()]);
    assert_success(&o);
    let stdout = String::from_utf8_lossy(&o.stdout);
    // Three panels side by side, each the demo camera's 400x300.
    let cutaway = image::open(d.join("demo_cutaway.png")).unwrap().to_rgba8();
    assert_eq!(cutaway.dimensions(), (1200, 300), "{stdout}");
    let panel = |k: u32| image::imageops::crop_imm(&cutaway, 400 * k, 0, 400, 300).to_image();
    let (none, hard, rara_img) = (panel(0), panel(1), panel(2));
    // The cut shows: both clipped panels differ from the unclipped one, and from each other.
    assert!(rara::metrics::compare(&none, &hard).l1 > 1.0);
    assert!(rara::metrics::compare(&none, &rara_img).l1 > 1.0);
    assert!(rara::metrics::compare(&hard, &rara_img).differing_pixels > 100);
    let gif = std::fs::read(d.join("demo_sweep.gif")).unwrap();
    assert!(gif.starts_with(b"GIF89a"));
    // The popping metric, hard against rara: RaRa pops less on this scene.
    let line = stdout
        .lines()
        .find(|l| l.contains("popping (p99.9"))
        .unwrap_or_else(|| panic!("no popping line: {stdout}"));
    let numbers: Vec<f64> = line
        .split(|c: char| !c.is_ascii_digit() && c != '.')
        .filter_map(|t| t.parse().ok())
        .collect();
    let (hard_p, rara_p) = (numbers[numbers.len() - 2], numbers[numbers.len() - 1]);
    assert!(rara_p < hard_p, "{line}");
}

#[test]
fn compare_reports_metrics() {
    let a = dir().join("cmp_a.png");
    let b = dir().join("cmp_b.png");
    image::RgbaImage::from_pixel(30, 20, image::Rgba([100, 100, 100, 255]))
        .save(&a)
        .unwrap();
    image::RgbaImage::from_pixel(30, 20, image::Rgba([104, 100, 100, 255]))
        .save(&b)
        .unwrap();
    let diff = dir().join("cmp_diff.png");
    let o = rara(&[
        "compare",
        a.to_str().unwrap(),
        b.to_str().unwrap(),
        "--json",
        "--diff",
        diff.to_str().unwrap(),
    ]);
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    let v: serde_json::Value = serde_json::from_slice(&o.stdout).unwrap();
    assert!((v["l1"].as_f64().unwrap() - 4.0 / 3.0).abs() < 1e-9);
    assert_eq!(v["max_diff"], 4);
    assert!(v["ssim"].as_f64().unwrap() < 1.0);
    assert!(diff.is_file());
    let o = rara(&[
        "compare",
        a.to_str().unwrap(),
        a.to_str().unwrap(),
        "--json",
    ]);
    let v: serde_json::Value = serde_json::from_slice(&o.stdout).unwrap();
    assert_eq!(v["ssim"], 1.0);
    assert!(v["psnr"].is_null());
    let small = dir().join("cmp_small.png");
    image::RgbaImage::new(3, 3).save(&small).unwrap();
    assert_error(
        &rara(&["compare", a.to_str().unwrap(), small.to_str().unwrap()]),
        &["30x20", "3x3"],
    );
}

#[test]
fn clip_options_and_clip_files_agree() {
    let (scene, cams) = good_scene();
    let (scene, cams) = (scene.to_str().unwrap(), cams.to_str().unwrap());
    let out_flags = dir().join("clip_flags.png");
    let out_file = dir().join("clip_file.png");
    let out_plain = dir().join("clip_none.png");
    let mut args = render_args(scene, cams, out_flags.to_str().unwrap());
    args.extend([
        "--clip-plane",
        "1,0.2,0,0.1",
        "--clip-box",
        "0,0,0,0.9,0.9,0.9,1,0,0,0",
        "--weight",
        "length",
        "--band",
        "2.5",
    ]);
    let out = rara(&args);
    assert_success(&out);
    let stdout = String::from_utf8_lossy(&out.stdout);
    assert!(stdout.contains("cutoff"), "{stdout}");
    let stderr = String::from_utf8_lossy(&out.stderr);
    assert!(
        stderr.contains("rara clip by 7 planes (length weight, band 2.5)"),
        "{stderr}"
    );

    let json = write(
        "clip.json",
        br#"{"planes": [[1, 0.2, 0, 0.1]],
             "box": {"center": [0, 0, 0], "half_extents": [0.9, 0.9, 0.9]},
             "weight": "length", "band": 2.5}"#,
    );
    let mut args = render_args(scene, cams, out_file.to_str().unwrap());
    args.extend(["--clip", json.to_str().unwrap()]);
    assert!(rara(&args).status.success());
    let a = image::open(&out_flags).unwrap().to_rgba8();
    let b = image::open(&out_file).unwrap().to_rgba8();
    assert_eq!(a, b, "--clip FILE and the same flags render the same image");

    let args = render_args(scene, cams, out_plain.to_str().unwrap());
    assert!(rara(&args).status.success());
    let plain = image::open(&out_plain).unwrap().to_rgba8();
    assert_ne!(a, plain, "the clip must remove something");

    // Vector options whose first number is negative are values, not flags.
    let mut args = render_args(scene, cams, out_plain.to_str().unwrap());
    args.extend(["--clip-plane", "-1,0.2,0,0.1", "--background", "-0,0,0.5"]);
    let out = rara(&args);
    assert_success(&out);

    // The sphere cutaway and hard mode parse and render.
    let mut args = render_args(scene, cams, out_plain.to_str().unwrap());
    args.extend([
        "--clip-sphere",
        "0,0,-1,0.7",
        "--invert",
        "--clip-mode",
        "hard",
    ]);
    let out = rara(&args);
    assert_success(&out);
    assert!(String::from_utf8_lossy(&out.stderr).contains("hard clip by a sphere, inverted"));
}

#[test]
fn bad_clip_options_fail_cleanly() {
    let (scene, cams) = good_scene();
    let (scene, cams) = (scene.to_str().unwrap(), cams.to_str().unwrap());
    let out = dir().join("bad_clip.png");
    let out = out.to_str().unwrap();
    let cases: Vec<(Vec<&str>, &[&str])> = vec![
        (vec!["--clip-plane", "0,0,0,1"], &["non-zero normal"]),
        (vec!["--clip-plane", "1,0,1"], &["expected 4"]),
        (vec!["--clip-sphere", "0,0,0,-1"], &["positive radius"]),
        (
            vec!["--clip-box", "0,0,0,1,0,1"],
            &["positive half extents"],
        ),
        (
            vec!["--clip-sphere", "0,0,0,1", "--clip-plane", "1,0,0,0"],
            &["cannot be combined"],
        ),
        (vec!["--invert"], &["need a region"]),
        (
            vec!["--clip-plane", "1,0,0,0", "--clip-mode", "soft"],
            &["soft"],
        ),
        (
            vec!["--clip-plane", "1,0,0,0", "--band", "0"],
            &["band must be positive"],
        ),
    ];
    for (extra, needles) in cases {
        let mut args = render_args(scene, cams, out);
        args.extend(extra.iter().copied());
        assert_error(&rara(&args), needles);
    }
    let bad_json = write("bad_clip.json", br#"{"planes": [[1, 0, 0]]}"#);
    let mut args = render_args(scene, cams, out);
    args.extend(["--clip", bad_json.to_str().unwrap()]);
    assert_error(&rara(&args), &["bad_clip.json"]);
    let unknown = write("unknown_clip.json", br#"{"plane": [[1, 0, 0, 0]]}"#);
    let mut args = render_args(scene, cams, out);
    args.extend(["--clip", unknown.to_str().unwrap()]);
    assert_error(&rara(&args), &["unknown_clip.json", "unknown field"]);
}

#[test]
fn sweep_writes_frames_gif_and_stats() {
    let (scene, cams) = good_scene();
    let out_dir = dir().join("sweep");
    let out = rara(&[
        "sweep",
        scene.to_str().unwrap(),
        "--cameras",
        cams.to_str().unwrap(),
        "--plane-normal",
        "1,0,0",
        "--frames",
        "4",
        "--side-by-side",
        "-o",
        out_dir.to_str().unwrap(),
    ]);
    assert_success(&out);
    for k in 0..4 {
        let frame = image::open(out_dir.join(format!("frame_{k:04}.png"))).unwrap();
        assert_eq!(
            (frame.width(), frame.height()),
            (128, 48),
            "hard | rara side by side"
        );
    }
    let gif = std::fs::read(out_dir.join("sweep.gif")).unwrap();
    assert_eq!(&gif[..6], b"GIF89a");
    let stats: serde_json::Value =
        serde_json::from_slice(&std::fs::read(out_dir.join("sweep.json")).unwrap()).unwrap();
    let series = stats["series"].as_array().unwrap();
    assert_eq!(series.len(), 2);
    assert_eq!(series[1]["cutoff_per_frame"].as_array().unwrap().len(), 4);
    // The default range starts with the whole scene visible and ends with almost nothing.
    let first = image::open(out_dir.join("frame_0000.png"))
        .unwrap()
        .to_rgba8();
    let last = image::open(out_dir.join("frame_0003.png"))
        .unwrap()
        .to_rgba8();
    let lit = |img: &image::RgbaImage| img.pixels().filter(|p| p.0[0] > 10).count();
    assert!(
        lit(&first) > 2 * lit(&last),
        "{} vs {}",
        lit(&first),
        lit(&last)
    );
}

#[test]
fn bench_writes_table_json_and_trace() {
    let (scene, cams) = good_scene();
    let json = dir().join("bench.json");
    let trace = dir().join("bench.trace.json");
    let frames = 3;
    let frames_arg = frames.to_string();
    let out = rara(&[
        "bench",
        scene.to_str().unwrap(),
        "--cameras",
        cams.to_str().unwrap(),
        "--frames",
        &frames_arg,
        "--warmup",
        "1",
        "--samples",
        "2",
        "--json",
        json.to_str().unwrap(),
        "--trace",
        trace.to_str().unwrap(),
    ]);
    let stdout = String::from_utf8_lossy(&out.stdout);
    assert_success(&out);
    for needle in ["| original", "| hard", "| rara", "rasterize", "rara / hard"] {
        assert!(stdout.contains(needle), "table lacks '{needle}':\n{stdout}");
    }

    let report: serde_json::Value = serde_json::from_slice(&std::fs::read(&json).unwrap()).unwrap();
    // Two renders per plane position, one kept per frame.
    assert_eq!(report["samples"], 2, "{report}");
    assert!(
        ["int64", "portable"].contains(&report["kernels"].as_str().unwrap())
            && ["strips", "pixels"].contains(&report["raster_layout"].as_str().unwrap()),
        "{report}"
    );
    for mode in ["original", "hard", "rara"] {
        let m = &report["modes"][mode];
        assert!(m["median_ms"].as_f64().unwrap() > 0.0, "{mode}: {m}");
        assert!(m["wall_median_ms"].as_f64().unwrap() >= m["median_ms"].as_f64().unwrap() * 0.5);
        for pass in ["project", "emit", "rasterize"] {
            assert!(
                m["passes"][pass].as_f64().unwrap() >= 0.0,
                "{mode} lacks {pass}: {m}"
            );
        }
        // In the strips layout (lavapipe's) the cutoff Gaussians' records are rara's own
        // pass, timed apart from project; in the pixels layout project writes them.
        let strips = report["raster_layout"] == "strips";
        assert_eq!(
            m["passes"].get("cutoff records").is_some(),
            mode == "rara" && strips,
            "{mode}: {m}"
        );
        // bench draws into an RGBA8 buffer over the background: the strips rasterizer writes
        // it itself, and the frames have no write-target pass.
        assert_eq!(
            m["passes"].get("write target").is_some(),
            !strips,
            "{mode}: {m}"
        );
        assert_eq!(m["cutoff_per_frame"].as_array().unwrap().len(), frames);
        let frame_ms = m["frame_ms"].as_array().unwrap();
        assert_eq!(frame_ms.len(), frames);
        assert!(
            frame_ms.iter().all(|t| t.as_f64().unwrap() > 0.0),
            "{mode}: {m}"
        );
    }
    // The sweeping plane cuts the shell: rara has cutoff Gaussians, the other modes none.
    // A per-frame count of the report, summed over the frames of a mode.
    let total = |mode: &str, key: &str| -> u64 {
        report["modes"][mode][key]
            .as_array()
            .unwrap()
            .iter()
            .map(|c| c.as_u64().unwrap())
            .sum()
    };
    let cutoffs = |mode: &str| total(mode, "cutoff_per_frame");
    assert!(cutoffs("rara") > 0);
    assert_eq!(cutoffs("hard") + cutoffs("original"), 0);
    // rara's cutoff pairs were classified by tile (the bench clips by a plane, mass weight).
    let classified: u64 = report["modes"]["rara"]["cutoff_pairs_per_frame"]
        .as_array()
        .unwrap()
        .iter()
        .map(|c| c[0].as_u64().unwrap())
        .sum();
    assert!(classified > 0);
    // On a CPU driver the tiles that hold a partial pair take the weighted kernel, the rest
    // the plain one; elsewhere one kernel walks the grid.
    let weighted_tiles = |mode: &str| total(mode, "weighted_tiles_per_frame");
    if report["device"].as_str().unwrap().contains("llvmpipe") {
        assert!(weighted_tiles("rara") > 0);
    }
    assert_eq!(weighted_tiles("hard") + weighted_tiles("original"), 0);
    assert!(report["rara_over_hard_per_frame_median"].as_f64().unwrap() > 0.0);
    // A per-frame array of the report, as floats.
    let per_frame = |mode: &str, key: &str| -> Vec<f64> {
        report["modes"][mode][key]
            .as_array()
            .unwrap()
            .iter()
            .map(|n| n.as_f64().unwrap())
            .collect()
    };
    let pairs = |mode: &str| -> f64 { per_frame(mode, "intersections_per_frame").iter().sum() };
    let pair_ratio = report["rara_over_hard_pairs"].as_f64().unwrap();
    assert!(
        (pair_ratio - pairs("rara") / pairs("hard")).abs() < 1e-9,
        "{pair_ratio}"
    );
    // The time per pair frame by frame: the median of each frame's time ratio over its pair
    // ratio, worked out again from the per-frame arrays.
    let (rara_ms, hard_ms) = (per_frame("rara", "frame_ms"), per_frame("hard", "frame_ms"));
    let (rara_pairs, hard_pairs) = (
        per_frame("rara", "intersections_per_frame"),
        per_frame("hard", "intersections_per_frame"),
    );
    let mut per_pair: Vec<f64> = (0..rara_ms.len())
        .filter(|&k| rara_pairs[k] > 0.0 && hard_pairs[k] > 0.0)
        .map(|k| (rara_ms[k] / hard_ms[k]) / (rara_pairs[k] / hard_pairs[k]))
        .collect();
    per_pair.sort_by(f64::total_cmp);
    let n = per_pair.len();
    assert!(n > 0);
    let median = if n % 2 == 1 {
        per_pair[n / 2]
    } else {
        0.5 * (per_pair[n / 2 - 1] + per_pair[n / 2])
    };
    let reported = report["rara_over_hard_per_pair_frame_median"]
        .as_f64()
        .unwrap();
    assert!(
        (reported - median).abs() < 1e-9,
        "{reported} against {median}"
    );

    // One event per pass per frame, each mode on its own track, frames in the order they were
    // rendered: frame k of every mode before frame k + 1 of any.
    let trace: serde_json::Value = serde_json::from_slice(&std::fs::read(&trace).unwrap()).unwrap();
    let events: Vec<&serde_json::Value> = trace["traceEvents"]
        .as_array()
        .unwrap()
        .iter()
        .filter(|e| e["ph"] == "X")
        .collect();
    let rasterize: Vec<(u64, u64, f64)> = events
        .iter()
        .filter(|e| e["name"] == "rasterize")
        .map(|e| {
            (
                e["tid"].as_u64().unwrap(),
                e["args"]["frame"].as_u64().unwrap(),
                e["ts"].as_f64().unwrap(),
            )
        })
        .collect();
    assert_eq!(rasterize.len(), 3 * frames, "{rasterize:?}");
    let last_of = |k: u64| {
        rasterize
            .iter()
            .filter(|r| r.1 == k)
            .map(|r| r.2)
            .fold(f64::MIN, f64::max)
    };
    let first_of = |k: u64| {
        rasterize
            .iter()
            .filter(|r| r.1 == k)
            .map(|r| r.2)
            .fold(f64::MAX, f64::min)
    };
    for k in 1..frames as u64 {
        assert!(last_of(k - 1) < first_of(k), "{rasterize:?}");
    }

    let out = rara(&["bench", "--sort", "5000"]);
    assert_success(&out);
    let text = String::from_utf8_lossy(&out.stdout);
    assert!(text.contains("GPU / CPU throughput"), "{text}");
    // Every pass's median, and how the sort went (5,000 keys: not segmented).
    assert!(
        text.contains("GPU passes (median ms): sort setup ") && text.contains("sort pass 3 "),
        "{text}"
    );
    assert!(text.contains("not segmented"), "{text}");
}

/// Issue 29: every input read is bounded by what is read (devices and pipes report no size),
/// scenes stream from a pipe, outputs are checked before the render and never left empty,
/// and exit codes are as documented (1 for errors, 2 for usage errors).
#[test]
fn bounded_reads_outputs_and_exit_codes() {
    let (scene, cams) = good_scene();
    let (scene, cams) = (scene.to_str().unwrap(), cams.to_str().unwrap());
    let out = dir().join("bounded.png");
    let out_s = out.to_str().unwrap();
    for device in ["/dev/zero", "/dev/urandom"] {
        let start = std::time::Instant::now();
        let o = rara(&render_args(scene, device, out_s));
        assert_error(&o, &[device, "more than 67108864 bytes", "cameras.json"]);
        assert_eq!(o.status.code(), Some(1));
        assert!(
            start.elapsed().as_secs() < 30,
            "{device} took {:?}",
            start.elapsed()
        );
        let mut args = render_args(scene, cams, out_s);
        args.extend(["--clip", device]);
        assert_error(
            &rara(&args),
            &[device, "more than 1048576 bytes", "clip file"],
        );
        assert_error(&rara(&["info", device]), &[device, "not a PLY file"]);
    }
    // A cameras file larger than the cap through a pipe (stat says 0 bytes).
    let mut child = rara_piped(&["render", scene, "--cameras", "/dev/stdin", "-o", out_s]);
    let mut stdin = child.stdin.take().unwrap();
    let feeder = std::thread::spawn(move || {
        use std::io::Write;
        let block = vec![b' '; 1 << 20];
        for _ in 0..65 {
            if stdin.write_all(&block).is_err() {
                break; // rara stopped reading at the cap
            }
        }
    });
    let o = child.wait_with_output().unwrap();
    feeder.join().unwrap();
    assert_error(&o, &["/dev/stdin", "more than 67108864 bytes"]);

    // A scene from a pipe loads, streamed.
    let bytes = std::fs::read(scene).unwrap();
    let mut child = rara_piped(&["info", "/dev/stdin", "--json"]);
    {
        use std::io::Write;
        child.stdin.take().unwrap().write_all(&bytes).unwrap();
    }
    let o = child.wait_with_output().unwrap();
    assert_success(&o);
    let info: serde_json::Value = serde_json::from_slice(&o.stdout).unwrap();
    assert_eq!(info["count"], 500);

    // --background outside [0, 1] is a usage error (clap: exit 2).
    let mut args = render_args(scene, cams, out_s);
    args.extend(["--background", "1.5,0,0"]);
    let o = rara(&args);
    assert_error(&o, &["--background", "must lie in [0, 1]"]);
    assert_eq!(o.status.code(), Some(2));
    let o = rara(&["render", "--no-such-flag"]);
    assert_eq!(o.status.code(), Some(2));

    // The output is checked before the scene is even loaded ("loaded" never printed), and a
    // failed render or write leaves nothing behind.
    let missing_dir = dir().join("no/such/dir/out.png");
    for (target, needle) in [
        (dir(), "is a directory"),
        (dir().join("out.jpg"), "unknown extension '.jpg'"),
        (dir().join("out"), "no extension"),
        (missing_dir.clone(), "does not exist"),
    ] {
        let o = rara(&render_args(scene, cams, target.to_str().unwrap()));
        assert_error(&o, &[needle]);
        assert_eq!(o.status.code(), Some(1));
        assert!(!String::from_utf8_lossy(&o.stderr).contains("loaded"));
    }
    assert!(!missing_dir.parent().unwrap().exists());
    if std::path::Path::new("/dev/full").exists() {
        assert_error(
            &rara(&render_args(scene, cams, "/dev/full")),
            &["/dev/full", "No space left on device"],
        );
    }
    let failed = dir().join("failed_render.png");
    let missing_scene = dir().join("missing_scene.ply");
    let o = rara(&render_args(
        missing_scene.to_str().unwrap(),
        cams,
        failed.to_str().unwrap(),
    ));
    assert_error(&o, &["missing_scene.ply"]);
    assert!(
        !failed.exists(),
        "a failed render left {}",
        failed.display()
    );
    let leftovers: Vec<_> = std::fs::read_dir(dir())
        .unwrap()
        .filter_map(|e| e.ok())
        .filter(|e| e.file_name().to_string_lossy().contains("failed_render"))
        .collect();
    assert!(leftovers.is_empty(), "{leftovers:?}");

    // A zero quaternion in --clip-box names the rotation, not the half extents.
    let mut args = render_args(scene, cams, out_s);
    args.extend(["--clip-box", "0,0,0,1,1,1,0,0,0,0"]);
    let o = rara(&args);
    assert_error(&o, &["rotation", "not a rotation"]);
    assert!(!String::from_utf8_lossy(&o.stderr).contains("half extents"));
}

/// `docs/CLI.md` holds every command and flag as the binary's `--help` prints them, between
/// two markers; this test regenerates that part and fails when the file differs, so the
/// reference cannot drift from clap. `RARA_UPDATE_DOCS=1` writes it instead.
#[test]
fn cli_reference_is_current() {
    const BEGIN: &str = "<!-- BEGIN GENERATED by tests/cli.rs cli_reference_is_current -->\n";
    const END: &str = "<!-- END GENERATED -->\n";
    let help = |args: &[&str]| {
        let o = rara(args);
        assert_success(&o);
        String::from_utf8(o.stdout).unwrap()
    };
    let mut generated = String::new();
    let top = help(&["--help"]);
    generated.push_str(&format!("## `rara`\n\n```text\n{top}```\n"));
    // The subcommands, in the order a help text lists them.
    let subcommands = |help_text: &str| -> Vec<String> {
        help_text
            .lines()
            .skip_while(|l| !l.starts_with("Commands:"))
            .skip(1)
            .take_while(|l| l.starts_with("  "))
            .filter_map(|l| l.split_whitespace().next().map(str::to_owned))
            .filter(|c| c != "help")
            .collect()
    };
    let commands = subcommands(&top);
    assert!(commands.len() >= 10, "{top}");
    for c in &commands {
        let text = help(&[c, "--help"]);
        generated.push_str(&format!("\n## `rara {c}`\n\n```text\n{text}```\n"));
        // A command with commands of its own (rara mesh export / import).
        for sub in subcommands(&text) {
            let text = help(&[c, &sub, "--help"]);
            generated.push_str(&format!("\n### `rara {c} {sub}`\n\n```text\n{text}```\n"));
        }
    }
    let path = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("docs/CLI.md");
    let doc = std::fs::read_to_string(&path).unwrap();
    let (Some(start), Some(end)) = (doc.find(BEGIN), doc.find(END)) else {
        panic!("{} lacks the markers {BEGIN:?} and {END:?}", path.display());
    };
    let current = &doc[start + BEGIN.len()..end];
    if current != generated {
        if std::env::var_os("RARA_UPDATE_DOCS").is_some() {
            let updated = format!("{}{BEGIN}{generated}{}", &doc[..start], &doc[end..]);
            std::fs::write(&path, updated).unwrap();
            eprintln!("rewrote the generated part of {}", path.display());
        } else {
            panic!(
                "docs/CLI.md is out of date with the binary's --help; run \
                 RARA_UPDATE_DOCS=1 cargo test --release --test cli cli_reference_is_current"
            );
        }
    }
}

/// The README's quick tour cannot rot: every `$ rara ...` line of its console blocks runs here,
/// in order, in a folder of its own (later commands use what earlier ones wrote), and every
/// line shown under it must appear in what the command printed (stdout and stderr), where
/// `[...]` stands for any text.
#[test]
fn readme_quick_tour_runs_as_shown() {
    let readme =
        std::fs::read_to_string(std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("README.md"))
            .unwrap();
    let tour = readme
        .split("\n## Quick tour\n")
        .nth(1)
        .and_then(|rest| rest.split("\n## ").next())
        .expect("README has a Quick tour section");
    // (command, the lines shown for it)
    let mut steps: Vec<(String, Vec<String>)> = Vec::new();
    let mut in_console = false;
    for line in tour.lines() {
        if line.starts_with("```") {
            in_console = line == "```console";
            continue;
        }
        if !in_console {
            continue;
        }
        if let Some(cmd) = line.strip_prefix("$ ") {
            steps.push((cmd.to_owned(), Vec::new()));
        } else if let Some((_, shown)) = steps.last_mut() {
            shown.push(line.to_owned());
        }
    }
    assert!(
        steps.len() >= 10,
        "only {} commands in the tour",
        steps.len()
    );
    let work = dir().join("readme_tour");
    std::fs::remove_dir_all(&work).ok();
    std::fs::create_dir_all(&work).unwrap();
    for (cmd, shown) in &steps {
        let mut words = cmd.split_whitespace();
        assert_eq!(words.next(), Some("rara"), "{cmd}");
        let o = Command::new(env!("CARGO_BIN_EXE_rara"))
            .args(words)
            .current_dir(&work)
            .output()
            .unwrap();
        let printed = format!(
            "{}{}",
            String::from_utf8_lossy(&o.stdout),
            String::from_utf8_lossy(&o.stderr)
        );
        assert!(o.status.success(), "`{cmd}` failed:\n{printed}");
        common::assert_no_validation_output(&o);
        for want in shown {
            let pieces: Vec<&str> = want.split("[...]").collect();
            let matches = |line: &str| {
                let mut at = 0;
                pieces.iter().all(|p| match line[at..].find(p) {
                    Some(k) => {
                        at += k + p.len();
                        true
                    }
                    None => false,
                })
            };
            assert!(
                printed.lines().any(matches),
                "README: `{cmd}` should print a line like\n  {want}\nbut printed:\n{printed}"
            );
        }
    }
}

/// `rara flatten`, `rara mesh export` / `import` (a file and a folder of frames) and
/// `rara render-sequence`, end to end, and their errors.
#[test]
fn flatten_mesh_and_render_sequence() {
    let (scene, cams) = good_scene();
    let (scene, cams) = (scene.to_str().unwrap(), cams.to_str().unwrap());
    let d = dir().join("mesh_cli");
    std::fs::create_dir_all(&d).unwrap();
    let p = |name: &str| d.join(name).to_string_lossy().into_owned();

    // flatten: the GaMeS layout, every Gaussian flat, a PSNR per view and a median.
    let out = rara(&[
        "flatten",
        scene,
        "-o",
        &p("flat.ply"),
        "--layout",
        "games",
        "--views",
        "2",
    ]);
    assert_success(&out);
    let stdout = String::from_utf8_lossy(&out.stdout);
    assert!(
        stdout.contains("view 1: PSNR") && stdout.contains("median PSNR"),
        "{stdout}"
    );
    let info = rara(&["info", &p("flat.ply")]);
    assert!(String::from_utf8_lossy(&info.stdout).contains("flat:        500 "));

    // export: the warning counts Gaussians that were not flat.
    for ext in ["ply", "obj", "glb"] {
        let out = rara(&["mesh", "export", scene, "-o", &p(&format!("m.{ext}"))]);
        assert_success(&out);
        let stderr = String::from_utf8_lossy(&out.stderr);
        assert!(
            stderr.contains("500 of 500 octagons are of Gaussians that were not flat"),
            "{stderr}"
        );
        assert!(String::from_utf8_lossy(&out.stdout).contains("500 octagons of 500 Gaussians"));
    }
    assert!(d.join("m.mtl").is_file());
    let out = rara(&[
        "mesh",
        "export",
        &p("flat.ply"),
        "-o",
        &p("flat.obj"),
        "--falloff",
        "centre",
    ]);
    assert_success(&out);
    assert!(!String::from_utf8_lossy(&out.stderr).contains("not flat"));

    // import: by ids (PLY) and by order (OBJ); the result renders.
    for ext in ["ply", "obj", "glb"] {
        let out = rara(&[
            "mesh",
            "import",
            &p(&format!("m.{ext}")),
            "--original",
            scene,
            "-o",
            &p(&format!("back_{ext}.ply")),
            "--rotate-sh",
            "--fit",
            "lsq",
        ]);
        assert_success(&out);
        let stdout = String::from_utf8_lossy(&out.stdout);
        assert!(stdout.contains("500 Gaussians fitted"), "{stdout}");
        let by = if ext == "obj" {
            "matched by order"
        } else {
            "matched by primitive_id/corner_id"
        };
        assert!(stdout.contains(by), "{stdout}");
    }
    assert_success(&rara(&render_args(
        &p("back_ply.ply"),
        cams,
        &p("back.png"),
    )));

    // A folder of frames, then render-sequence.
    let frames = d.join("frames");
    std::fs::create_dir_all(&frames).unwrap();
    for k in 0..3 {
        std::fs::copy(d.join("m.obj"), frames.join(format!("frame_{k:03}.obj"))).unwrap();
    }
    let out = rara(&[
        "mesh",
        "import",
        frames.to_str().unwrap(),
        "--original",
        scene,
        "-o",
        &p("imported"),
    ]);
    assert_success(&out);
    assert!(String::from_utf8_lossy(&out.stdout).contains("imported 3 frames"));
    assert!(d.join("imported/frame_002.ply").is_file());
    let out = rara(&[
        "render-sequence",
        &p("imported"),
        "--cameras",
        cams,
        "-o",
        &p("rendered"),
    ]);
    assert_success(&out);
    assert!(
        d.join("rendered/frame_000.png").is_file() && d.join("rendered/sequence.gif").is_file()
    );

    // Errors: a missing original, a mismatch, a bad extension, a bad Q, an empty folder.
    assert_error(
        &rara(&[
            "mesh",
            "import",
            &p("m.obj"),
            "--original",
            &p("nope.ply"),
            "-o",
            &p("x.ply"),
        ]),
        &["--original", "no such file"],
    );
    let (other, _) = good_scene();
    let small = rara::synth::shell(40, 1, 3);
    rara::ply::write_ply(&small, &other, rara::ply::PlyEncoding::BinaryLittleEndian).unwrap();
    assert_error(
        &rara(&[
            "mesh",
            "import",
            &p("m.obj"),
            "--original",
            other.to_str().unwrap(),
            "-o",
            &p("x.ply"),
        ]),
        &["4000 vertices", "320 or 360 vertices were expected"],
    );
    assert_error(
        &rara(&[
            "mesh",
            "import",
            &p("m.ply"),
            "--original",
            other.to_str().unwrap(),
            "-o",
            &p("x.ply"),
        ]),
        &["primitive_id", "the original has 40 Gaussians"],
    );
    assert_error(
        &rara(&["mesh", "export", scene, "-o", &p("m.stl")]),
        &["'.stl' is not a mesh format"],
    );
    assert_error(
        &rara(&["mesh", "export", scene, "-o", &p("q.ply"), "--q", "0"]),
        &["Q must be a positive number"],
    );
    std::fs::create_dir_all(d.join("empty")).unwrap();
    assert_error(
        &rara(&[
            "mesh",
            "import",
            &p("empty"),
            "--original",
            scene,
            "-o",
            &p("o2"),
        ]),
        &["no mesh frames"],
    );
    assert_error(
        &rara(&["flatten", scene, "-o", &p("flat.txt")]),
        &["unknown extension '.txt'"],
    );
    // A scene from a pipe is loaded once, whole (a PLY file is read twice, in chunks): here
    // stdin is empty, and says so; nothing is written.
    assert_error(
        &rara(&["mesh", "export", "/dev/stdin", "-o", &p("pipe.ply")]),
        &["empty file"],
    );
    assert!(!std::path::Path::new(&p("pipe.ply")).exists());
}

/// `rara render --tracer ray` ray traces (SPEC section 7) and says so; with `--reference` it is
/// an error that points to the library's CPU ray tracer.
#[test]
fn render_with_the_ray_tracer() {
    let (scene, cams) = good_scene();
    let (scene, cams) = (scene.to_str().unwrap(), cams.to_str().unwrap());
    // `render SCENE --cameras CAMS` with `args`, into `out`.
    let render = |args: &[&str], out: &std::path::Path| {
        let mut all = vec!["render", scene, "--cameras", cams];
        all.extend(args);
        all.extend(["-o", out.to_str().unwrap()]);
        rara(&all)
    };
    let out = dir().join("ray.png");
    let o = render(&["--tracer", "ray", "--clip-plane", "1,0,0,0"], &out);
    assert_success(&o);
    let stdout = String::from_utf8_lossy(&o.stdout);
    assert!(
        stdout.contains("ray traced")
            && stdout.contains("hits composited")
            && stdout.contains("ray tracer: BVH"),
        "{stdout}"
    );
    assert!(out.is_file());
    assert_error(
        &render(&["--tracer", "ray", "--reference"], &out),
        &["rara::reference::raytrace"],
    );
    // --still-bvh: the BVH built once on the host, the same image; only for --tracer ray.
    let still = dir().join("ray_still.png");
    let o = render(
        &["--tracer", "ray", "--still-bvh", "--clip-plane", "1,0,0,0"],
        &still,
    );
    assert_success(&o);
    assert!(
        String::from_utf8_lossy(&o.stderr).contains("still BVH built on the host"),
        "{}",
        String::from_utf8_lossy(&o.stderr)
    );
    assert_eq!(
        image::open(&out).unwrap().to_rgba8(),
        image::open(&still).unwrap().to_rgba8(),
        "render --still-bvh differs from the LBVH's image"
    );
    for tracer in ["raster", "ray-tiles"] {
        assert_error(
            &render(&["--tracer", tracer, "--still-bvh"], &still),
            &["--still-bvh", "--tracer ray"],
        );
    }
}

/// `render --depth`: an EXR of the view depths and a 16-bit PNG of the same depths spread over
/// the printed range, from the GPU and from the CPU reference (which agree), the error of a
/// bad name, and the ray tracer's depths through the BVH and through tile lists (equal).
#[test]
fn render_writes_depth_as_exr_and_16_bit_png() {
    let (scene, cams) = good_scene();
    let (scene, cams) = (scene.to_str().unwrap(), cams.to_str().unwrap());
    let d = dir();
    let png = d.join("depth_view.png");
    let png = png.to_str().unwrap();
    let mut depths = Vec::new();
    for (name, extra) in [("gpu", &[][..]), ("cpu", &["--reference"][..])] {
        let exr = d.join(format!("depth_{name}.exr"));
        let depth_png = d.join(format!("depth_{name}.png"));
        for out in [&exr, &depth_png] {
            let mut args = render_args(scene, cams, png);
            args.extend(["--depth", out.to_str().unwrap()]);
            args.extend(extra);
            let o = rara(&args);
            assert_success(&o);
            let stdout = String::from_utf8_lossy(&o.stdout);
            assert!(stdout.contains("median view depth of"), "{stdout}");
        }
        let exr_img = image::open(&exr).unwrap().to_rgb32f();
        let z: Vec<f32> = exr_img.pixels().map(|p| p.0[0]).collect();
        assert_eq!((exr_img.width(), exr_img.height()), (64, 48));
        let finite: Vec<f32> = z.iter().copied().filter(|v| v.is_finite()).collect();
        assert!(finite.len() > 100, "{} pixels with a depth", finite.len());
        // The shell has radius 1 around the origin and the camera stands 3 away.
        assert!(
            finite.iter().all(|&v| (1.5..=4.5).contains(&v)),
            "{finite:?}"
        );
        let lo = finite.iter().copied().fold(f32::MAX, f32::min);
        let hi = finite.iter().copied().fold(f32::MIN, f32::max);
        let levels = image::open(&depth_png).unwrap().to_luma16();
        for (v, l) in z.iter().zip(levels.pixels()) {
            let want = if v.is_finite() {
                ((v - lo) / (hi - lo) * 65534.0).round() as u16
            } else {
                65535
            };
            assert_eq!(l.0[0], want, "depth {v}");
        }
        depths.push(z);
    }
    let (gpu, cpu) = (&depths[0], &depths[1]);
    let close = gpu
        .iter()
        .zip(cpu)
        .filter(|(a, b)| a == b || (*a - *b).abs() <= 1e-4 * b.abs())
        .count();
    assert!(
        close * 100 >= gpu.len() * 99,
        "{close} of {} agree",
        gpu.len()
    );

    let mut args = render_args(scene, cams, png);
    args.extend(["--depth", "d.tiff"]);
    assert_error(&rara(&args), &["d.tiff"]);
    // Ray traced (SPEC section 9 with 7 and 11), through the BVH and through tile lists: the
    // same depths, on the shell.
    let mut traced = Vec::new();
    for tracer in ["ray", "ray-tiles"] {
        let exr = d.join(format!("depth_{tracer}.exr"));
        let mut args = render_args(scene, cams, png);
        args.extend(["--depth", exr.to_str().unwrap(), "--tracer", tracer]);
        let o = rara(&args);
        assert_success(&o);
        let stdout = String::from_utf8_lossy(&o.stdout);
        assert!(stdout.contains("median view depth of"), "{stdout}");
        let z: Vec<f32> = image::open(&exr)
            .unwrap()
            .to_rgb32f()
            .pixels()
            .map(|p| p.0[0])
            .collect();
        let finite = z.iter().filter(|v| v.is_finite()).count();
        assert!(finite > 100, "{tracer}: {finite} pixels with a depth");
        assert!(
            z.iter()
                .filter(|v| v.is_finite())
                .all(|v| (1.5..=4.5).contains(v)),
            "{tracer}: {z:?}"
        );
        traced.push(z);
    }
    assert!(
        traced[0]
            .iter()
            .zip(&traced[1])
            .all(|(a, b)| a.to_bits() == b.to_bits()),
        "the ray tracer's depths through the BVH and through tile lists"
    );
}

/// `render --object` and `sweep --object`: several objects in one frame equal their merged,
/// pre-transformed scene (written as a PLY by the library's `objects::merge`) rendered alone,
/// bit for bit; a bad transform is a clear error.
#[test]
fn objects_render_as_their_merged_scene() {
    use rara::objects::{merge, ObjectTransform};
    let d = dir();
    let shell = rara::synth::shell(800, 2, 7);
    let hair = rara::synth::hair(600, 1, 8);
    let (shell_path, hair_path) = (d.join("obj_shell.ply"), d.join("obj_hair.ply"));
    for (s, p) in [(&shell, &shell_path), (&hair, &hair_path)] {
        rara::ply::write_ply(s, p, rara::ply::PlyEncoding::BinaryLittleEndian).unwrap();
    }
    let cams = rara::synth::orbit_cameras(2, 3.0, 64, 48, 50.0).unwrap();
    let cams_path = d.join("obj.cameras.json");
    rara::Camera::save_all(&cams, &cams_path).unwrap();
    // The transforms the arguments below give.
    let r = |x: f32, y: f32, z: f32| {
        glam::Quat::from_rotation_z(z.to_radians())
            * glam::Quat::from_rotation_y(y.to_radians())
            * glam::Quat::from_rotation_x(x.to_radians())
    };
    let merged = merge(&[
        (&shell, ObjectTransform::default()),
        (
            &hair,
            ObjectTransform {
                rotation: r(10.0, 90.0, -20.0),
                translation: glam::Vec3::new(0.4, 0.1, 0.0),
                scale: 0.7,
            },
        ),
        (
            &hair,
            ObjectTransform {
                translation: glam::Vec3::new(-0.5, 0.0, 0.2),
                ..ObjectTransform::default()
            },
        ),
    ]);
    let merged_path = d.join("obj_merged.ply");
    rara::ply::write_ply(
        &merged,
        &merged_path,
        rara::ply::PlyEncoding::BinaryLittleEndian,
    )
    .unwrap();
    let (cams_s, shell_s, hair_s) = (
        cams_path.to_str().unwrap(),
        shell_path.to_str().unwrap(),
        hair_path.to_str().unwrap(),
    );
    let first = format!("{hair_s}:0.4,0.1,0,10,90,-20,0.7");
    let second = format!("{hair_s}:-0.5,0,0.2");
    // Rasterized and ray traced (through the BVH): the merged scene's frame each time.
    for tracer in ["raster", "ray"] {
        let objects_png = d.join(format!("objects_{tracer}.png"));
        let merged_png = d.join(format!("objects_merged_{tracer}.png"));
        let o = rara(&[
            "render",
            shell_s,
            "--object",
            &first,
            "--object",
            &second,
            "--cameras",
            cams_s,
            "--tracer",
            tracer,
            "-o",
            objects_png.to_str().unwrap(),
        ]);
        assert_success(&o);
        let stdout = String::from_utf8_lossy(&o.stdout);
        assert!(
            stdout.contains("3 objects, 2000 Gaussians in one frame"),
            "{stdout}"
        );
        assert_eq!(
            stdout.contains("ray traced, per ray"),
            tracer == "ray",
            "{stdout}"
        );
        let mut args = render_args(
            merged_path.to_str().unwrap(),
            cams_s,
            merged_png.to_str().unwrap(),
        );
        args.extend(["--tracer", tracer]);
        assert_success(&rara(&args));
        let (a, b) = (
            image::open(&objects_png).unwrap().to_rgba8(),
            image::open(&merged_png).unwrap().to_rgba8(),
        );
        assert_eq!(
            a, b,
            "render --object --tracer {tracer} differs from the merged scene"
        );
    }

    // sweep: the same frames as the merged scene's sweep.
    let (so, sm) = (d.join("sweep_objects"), d.join("sweep_merged"));
    let sweep = |scene_args: &[&str], out: &std::path::Path| {
        let mut args = vec!["sweep"];
        args.extend(scene_args);
        args.extend([
            "--cameras",
            cams_s,
            "--plane-normal",
            "1,0,0",
            "--frames",
            "3",
            "-o",
            out.to_str().unwrap(),
        ]);
        assert_success(&rara(&args));
    };
    sweep(&[shell_s, "--object", &first, "--object", &second], &so);
    sweep(&[merged_path.to_str().unwrap()], &sm);
    for k in 0..3 {
        let name = format!("frame_{k:04}.png");
        let (a, b) = (
            image::open(so.join(&name)).unwrap().to_rgba8(),
            image::open(sm.join(&name)).unwrap().to_rgba8(),
        );
        assert_eq!(a, b, "sweep frame {k} differs");
    }
    let bad = format!("{hair_s}:1,2");
    assert_error(
        &rara(&[
            "render",
            "--object",
            &bad,
            "--cameras",
            cams_s,
            "-o",
            "x.png",
        ]),
        &["TX,TY,TZ"],
    );
}

/// SPEC 12: a scene given without a camera is framed (its centres' 1st-99th percentile box
/// filling 90 % of the height, seen along +z), and the flags printed give the same camera: the
/// image rendered from them is the same, to the bit, on the GPU and on the CPU reference; a
/// scene file without a camera is framed the same way.
#[test]
fn a_scene_without_a_camera_is_framed_and_the_printed_flags_give_it_again() {
    let (scene, _) = good_scene();
    let scene = scene.to_str().unwrap();
    let d = dir();
    for (extra, name) in [(&[][..], "gpu"), (&["--reference"][..], "cpu")] {
        let framed = d.join(format!("framed_{name}.png"));
        let o = rara(
            &[
                &[
                    "render",
                    scene,
                    "--width",
                    "96",
                    "-o",
                    framed.to_str().unwrap(),
                ],
                extra,
            ]
            .concat(),
        );
        assert_success(&o);
        let stderr = String::from_utf8_lossy(&o.stderr);
        let flags = stderr
            .lines()
            .find_map(|l| {
                l.split_once("to render it again from here: ")
                    .map(|(_, f)| f)
            })
            .unwrap_or_else(|| panic!("no framing line in:\n{stderr}"));
        assert!(flags.contains("--width 96 --height 72"), "{flags}");
        let again = d.join(format!("again_{name}.png"));
        let mut args = vec!["render", scene];
        args.extend(flags.split_whitespace());
        args.extend(["-o", again.to_str().unwrap()]);
        args.extend(extra);
        assert_success(&rara(&args));
        let (a, b) = (
            image::open(&framed).unwrap().to_rgba8(),
            image::open(&again).unwrap().to_rgba8(),
        );
        assert_eq!((a.width(), a.height()), (96, 72));
        assert!(a == b, "{name}: the printed flags render another image");
        // The scene fills the middle of the frame: something is drawn at the centre.
        let centre = a.get_pixel(48, 36);
        assert!(
            centre[0] > 0 || centre[1] > 0 || centre[2] > 0,
            "{name}: nothing at the centre"
        );
    }
    let file = d.join("framed_scene.json");
    std::fs::write(
        &file,
        format!(r#"{{ "splats": [{{ "path": {scene:?} }}] }}"#),
    )
    .unwrap();
    let out = d.join("framed_scene.png");
    let o = rara(&[
        "render",
        "--scene",
        file.to_str().unwrap(),
        "--width",
        "48",
        "-o",
        out.to_str().unwrap(),
    ]);
    assert_success(&o);
    assert!(String::from_utf8_lossy(&o.stderr).contains("no camera given"));
}

/// `sweep --camera-path` (issue 74): the keyframes of a cameras.json flown through over the
/// frames: the first frame is keyframe 0's view, the last keyframe 1's (up to the rounding of
/// the rotation through a quaternion), the middle one neither.
#[test]
fn a_sweep_flies_its_camera_path() {
    let (scene, cams) = good_scene();
    let out_dir = dir().join("sweep_path");
    let out = rara(&[
        "sweep",
        scene.to_str().unwrap(),
        "--camera-path",
        cams.to_str().unwrap(),
        "--plane-normal",
        "1,0,0",
        "--from",
        "100",
        "--to",
        "100",
        "--frames",
        "3",
        "-o",
        out_dir.to_str().unwrap(),
    ]);
    assert_success(&out);
    assert!(String::from_utf8_lossy(&out.stderr).contains("2 keyframes over 3 frames"));
    let frame = |k: u32| {
        image::open(out_dir.join(format!("frame_{k:04}.png")))
            .unwrap()
            .to_rgba8()
    };
    let view = |camera: &str| {
        let png = dir().join(format!("path_view_{camera}.png"));
        let o = rara(&[
            "render",
            scene.to_str().unwrap(),
            "--cameras",
            cams.to_str().unwrap(),
            "--camera",
            camera,
            "-o",
            png.to_str().unwrap(),
        ]);
        assert_success(&o);
        image::open(png).unwrap().to_rgba8()
    };
    let (first, last) = (view("0"), view("1"));
    common::check_images(
        "camera path, frame 0 vs keyframe 0",
        &frame(0),
        &first,
        40.0,
        255,
    );
    common::check_images(
        "camera path, frame 2 vs keyframe 1",
        &frame(2),
        &last,
        40.0,
        255,
    );
    assert!(
        frame(1) != first && frame(1) != last,
        "the middle frame is a keyframe's"
    );
    // The MP4 through Debian's ffmpeg, where it is installed: its 3 frames at 64x48.
    let mp4 = out_dir.join("sweep.mp4");
    let ffmpeg = Command::new("ffmpeg").arg("-version").output().is_ok();
    if ffmpeg {
        let probe = Command::new("ffprobe")
            .args([
                "-v",
                "error",
                "-count_frames",
                "-select_streams",
                "v:0",
                "-show_entries",
            ])
            .args([
                "stream=codec_name,width,height,nb_read_frames",
                "-of",
                "csv=p=0",
            ])
            .arg(&mp4)
            .output()
            .unwrap();
        let fields = String::from_utf8_lossy(&probe.stdout).trim().to_string();
        assert_eq!(fields, "h264,64,48,3", "ffprobe of {}", mp4.display());
        assert!(!out_dir.join("sweep.mp4.part").exists());
    } else {
        assert!(String::from_utf8_lossy(&out.stderr).contains("no MP4: ffmpeg is not installed"));
        common::test_skipped("ffmpeg is not installed: the sweep's MP4 is not checked");
    }
}
