//! Scene formats (issue 34): content detection, and the antimatter15 `.splat` reader and writer
//! against generated scenes and the real scenes' original `.splat` files.

mod common;

use glam::Vec3;
use rara::formats::{detect, load_scene, splat, SceneFormat};
use rara::Scene;

const SH_C0: f32 = 0.282_094_8;

/// The largest differences of `b` from `a` (same Gaussians, same order): centre, scale
/// (relative), opacity, `0.5 + C0 f_dc`, and `1 - |q_a . q_b|`.
fn differences(a: &Scene, b: &Scene) -> [f32; 5] {
    assert_eq!(a.len(), b.len());
    let mut d = [0f32; 5];
    for i in 0..a.len() {
        d[0] = d[0].max((a.means[i] - b.means[i]).abs().max_element());
        let rel = (a.scales[i] - b.scales[i]).abs() / a.scales[i].max(Vec3::splat(1e-12));
        d[1] = d[1].max(rel.max_element());
        d[2] = d[2].max((a.opacities[i] - b.opacities[i]).abs());
        for c in 0..3 {
            let (x, y) = (0.5 + SH_C0 * a.sh_of(i)[c], 0.5 + SH_C0 * b.sh_of(i)[c]);
            d[3] = d[3].max((x - y).abs());
        }
        d[4] = d[4].max(1.0 - a.rotations[i].dot(b.rotations[i]).abs());
    }
    d
}

/// A generated scene written as `.splat` reads back within the format's quantisation: centres
/// and scales exactly, opacity and colour within half a level (1/510), the rotation within
/// `1 - |q . q'| <= 1e-4` (four components of 1/256).
#[test]
fn splat_round_trip_keeps_values_within_quantisation() {
    let dir = common::tempdir("formats_splat");
    let mut scene = common::mixed_scene(3000, 17);
    // .splat's colours are in [0, 1]: keep 0.5 + C0 f_dc there, and degree 0.
    scene = rara::Scene {
        sh_degree: 0,
        sh: (0..scene.len())
            .flat_map(|i| {
                scene.sh_of(i)[..3]
                    .iter()
                    .map(|v| v.clamp(-1.7, 1.7))
                    .collect::<Vec<_>>()
            })
            .collect(),
        ..scene
    };
    let path = dir.join("s.splat");
    splat::write_splat(&scene, &path).unwrap();
    assert_eq!(
        std::fs::metadata(&path).unwrap().len(),
        32 * scene.len() as u64
    );
    assert_eq!(detect(&path).unwrap(), SceneFormat::Splat);
    let (back, report) = load_scene(&path).unwrap();
    assert_eq!(
        (report.vertices_in_file, report.dropped_non_finite),
        (scene.len(), 0)
    );
    let [pos, scale, opacity, colour, rotation] = differences(&scene, &back);
    eprintln!("splat round trip: position {pos}, scale {scale}, opacity {opacity}, colour {colour}, rotation {rotation:e}");
    assert_eq!(pos, 0.0);
    assert_eq!(scale, 0.0);
    assert!(opacity <= 0.5 / 255.0 + 1e-6, "{opacity}");
    assert!(colour <= 0.5 / 255.0 + 1e-6, "{colour}");
    assert!(rotation <= 1e-4, "{rotation}");
}

/// Files are told apart by content; a wrong one is an error that says what it starts with.
#[test]
fn formats_are_detected_by_content() {
    let dir = common::tempdir("formats_detect");
    let cases: [(&str, &[u8], Option<SceneFormat>); 8] = [
        (
            "a.ply",
            b"ply\nformat binary_little_endian 1.0\nelement vertex 1\nend_header\n",
            Some(SceneFormat::Ply),
        ),
        (
            "b.bin",
            b"ply\nformat binary_little_endian 1.0\nelement chunk 1\nend_header\n",
            Some(SceneFormat::CompressedPly),
        ),
        ("c.spz", &[0x1f, 0x8b, 8, 0, 0, 0], Some(SceneFormat::Spz)),
        ("d.spz", b"NGSP\x04\0\0\0", Some(SceneFormat::Spz)),
        ("e.glb", b"glTF\x02\0\0\0", Some(SceneFormat::Gltf)),
        ("f.sog", b"PK\x03\x04rest", Some(SceneFormat::Sog)),
        (
            "g.gltf",
            br#"{ "asset": { "version": "2.0" } }"#,
            Some(SceneFormat::Gltf),
        ),
        ("h.ply", b"not a scene at all", None),
    ];
    for (name, bytes, want) in cases {
        let p = dir.join(name);
        std::fs::write(&p, bytes).unwrap();
        match (detect(&p), want) {
            (Ok(f), Some(w)) => assert_eq!(f, w, "{name}"),
            (Err(e), None) => {
                assert!(e.to_string().contains("starts with 6e 6f 74 20"), "{e}");
                // Loading it lets the PLY reader say what is wrong, and names the rest.
                let e = load_scene(&p).unwrap_err().to_string();
                assert!(e.contains("not a PLY") && e.contains("nor .splat"), "{e}");
            }
            (got, want) => panic!("{name}: {got:?}, wanted {want:?}"),
        }
    }
    // A .splat whose size is no multiple of 32, and an empty one.
    for (name, len) in [("odd.splat", 33usize), ("empty.splat", 0)] {
        let p = dir.join(name);
        std::fs::write(&p, vec![0u8; len]).unwrap();
        let e = load_scene(&p).unwrap_err().to_string();
        assert!(
            e.contains("32 bytes per Gaussian") || e.contains("empty"),
            "{e}"
        );
    }
    // A truncated SPZ says so, by format.
    let e = load_scene(dir.join("c.spz")).unwrap_err().to_string();
    assert!(e.contains("SPZ"), "{e}");
    // A folder with meta.json is a SOG.
    let sog = dir.join("sog");
    std::fs::create_dir_all(&sog).unwrap();
    std::fs::write(sog.join("meta.json"), "{}").unwrap();
    assert_eq!(detect(&sog).unwrap(), SceneFormat::Sog);
}

/// The real scenes' original `.splat` files decode to the shared PLY conversions (made with
/// splat-transform 2.7.1): the same Gaussians in the same order, centres and scales to f32
/// rounding, opacity and colour to the conversion's float rounding, the rotation within the
/// quantisation (splat-transform decodes `u / 255 * 2 - 1`, antimatter15 `(u - 128) / 128`).
#[test]
fn original_splat_files_match_the_shared_ply_conversions() {
    let cases = [
        ("originals/plant.splat", "plant_capture_sh0.ply"),
        (
            "originals/skull_100k.splat",
            "skull_mesh2splat_100k_sh0.ply",
        ),
    ];
    with_real_originals(&cases, |original, ply, a, b, note| {
        let [pos, scale, opacity, colour, rotation] = differences(&b, &a);
        eprintln!(
            "real-scene case '{original}' ran: {note}; against {ply}: position {pos:e}, scale {scale:e}, opacity {opacity:e}, colour {colour:e}, rotation {rotation:e}",
        );
        assert_eq!(pos, 0.0);
        assert!(scale <= 1e-5, "{scale}");
        assert!(opacity <= 1e-5, "{opacity}");
        assert!(colour <= 1e-5, "{colour}");
        assert!(rotation <= 1e-3, "{rotation}");
    });
}

/// Loads each real original (`originals/...`) and its shared PLY conversion that are here and
/// hands both to `check`, with a note of the original's count, load time and load notes;
/// names each case that ran or was skipped, and marks the test skipped when none ran.
fn with_real_originals(
    cases: &[(&str, &str)],
    mut check: impl FnMut(&str, &str, Scene, Scene, String),
) {
    let Some(dir) = common::real_data_dir() else {
        common::test_skipped("none of its real scenes is here");
        return;
    };
    let mut ran = 0;
    for &(original, ply) in cases {
        let (o, p) = (dir.join(original), dir.join(ply));
        if !o.exists() || !p.is_file() {
            eprintln!("real-scene case '{original}' SKIPPED: not here");
            continue;
        }
        let start = std::time::Instant::now();
        let (a, report) = load_scene(&o).unwrap();
        let load_ms = start.elapsed().as_secs_f64() * 1e3;
        let (b, _) = rara::ply::load_ply(&p).unwrap();
        let note = format!(
            "{} Gaussians ({} dropped) in {load_ms:.0} ms {:?}",
            a.len(),
            report.dropped_non_finite,
            report.notes
        );
        check(original, ply, a, b, note);
        ran += 1;
    }
    if ran == 0 {
        common::test_skipped("none of its real scenes is here");
    }
}

/// `s` without the Gaussians whose 8-bit opacity was 0 or 255: the shared PLY conversions hold
/// those as infinite logits, which the PLY reader drops.
fn without_saturated_opacity(s: &Scene) -> Scene {
    let keep: Vec<usize> = (0..s.len())
        .filter(|&i| s.opacities[i] > 2e-6 && s.opacities[i] < 1.0 - 2e-6)
        .collect();
    common::subset(s, &keep)
}

/// The real originals in compressed PLY, SPZ v4 and SOG decode to the shared PLY conversions
/// (splat-transform 2.7.1): compressed PLY and SOG to f32 rounding (SH included), SPZ within
/// its quantisation (centres 1/8192, log scales 1/32 above SPZ's floor of -10, colour half a
/// level of 1/(0.15 * 255) in f_dc).
#[test]
fn original_compressed_files_match_the_shared_ply_conversions() {
    let cases = [
        ("originals/biker.compressed.ply", "biker_capture_sh0.ply"),
        (
            "originals/guitar.compressed.ply",
            "guitar_capture_sh0_anisotropic.ply",
        ),
        ("originals/biker.spz", "biker_capture_sh0.ply"),
        ("originals/playbot_lod0_sog", "playbot_lod0_500k_sh2.ply"),
    ];
    with_real_originals(&cases, |original, ply, a, b, note| {
        let a = if a.len() == b.len() {
            a
        } else {
            without_saturated_opacity(&a)
        };
        let [pos, scale, opacity, colour, rotation] = differences(&b, &a);
        let mut sh = 0f32;
        for i in 0..a.len() {
            for k in 3..a.sh_stride() {
                sh = sh.max((a.sh_of(i)[k] - b.sh_of(i)[k]).abs());
            }
        }
        eprintln!(
            "real-scene case '{original}' ran: {note}; against {ply}: position {pos:e}, scale {scale:e}, opacity {opacity:e}, colour {colour:e}, rotation {rotation:e}, SH {sh:e}",
        );
        if original.ends_with(".spz") {
            // SPZ's log scales are u / 16 - 10: half a level of 1/16 in the log, and a scale
            // below e^-10 (88 of biker's, down to e^-11.25) stored as e^-10.
            let log_scale = (0..a.len())
                .map(|i| {
                    let (x, y) = (a.scales[i].to_array(), b.scales[i].to_array());
                    (0..3)
                        .map(|k| (x[k].ln() - y[k].ln().max(-10.0)).abs())
                        .fold(0f32, f32::max)
                })
                .fold(0f32, f32::max);
            eprintln!("  log scale, e^-10 and up: {log_scale:e}");
            assert!(log_scale <= 0.5 / 16.0 + 1e-4, "{log_scale}");
            assert!(pos <= 0.5 / 4096.0 + 1e-6, "{pos}");
            assert!(colour <= 0.5 * SH_C0 / (0.15 * 255.0) + 1e-4, "{colour}");
            assert!(opacity <= 1e-6, "{opacity}");
            assert!(rotation <= 1e-5, "{rotation}");
        } else {
            assert_eq!(pos, 0.0);
            assert!(scale <= 1e-6, "{scale}");
            assert!(opacity <= 1e-6, "{opacity}");
            assert!(colour <= 1e-6, "{colour}");
            assert!(rotation <= 1e-6, "{rotation}");
            assert_eq!(sh, 0.0);
        }
    });
}

/// rara's own writers read back within each format's quantisation: SPZ v3 and v4 (centres
/// 1/8192, colour within half a level, rotations 1e-5 in 1 - |q.q'|), glTF losslessly.
#[test]
fn spz_and_glb_round_trip_a_generated_scene() {
    use rara::formats::spz::{write_spz, SpzAxes, SpzVersion};
    let dir = common::tempdir("formats_spz_glb");
    let scene = common::mixed_scene(3000, 23);
    for (name, version) in [("v3.spz", SpzVersion::V3), ("v4.spz", SpzVersion::V4)] {
        let path = dir.join(name);
        write_spz(&scene, &path, version, SpzAxes::Rub).unwrap();
        assert_eq!(detect(&path).unwrap(), SceneFormat::Spz);
        let (back, _) = load_scene(&path).unwrap();
        let [pos, _, opacity, _, rotation] = differences(&scene, &back);
        eprintln!("{name}: position {pos:e}, opacity {opacity:e}, rotation {rotation:e}");
        assert!(pos <= 0.5 / 4096.0 + 1e-6, "{pos}");
        assert!(opacity <= 0.5 / 255.0 + 1e-6, "{opacity}");
        assert!(rotation <= 2e-5, "{rotation}");
    }
    let path = dir.join("s.glb");
    rara::formats::gltf::write_glb(&scene, &path).unwrap();
    assert_eq!(detect(&path).unwrap(), SceneFormat::Gltf);
    let (back, _) = load_scene(&path).unwrap();
    let [pos, scale, opacity, colour, rotation] = differences(&scene, &back);
    assert_eq!((pos, scale, opacity, colour), (0.0, 0.0, 0.0, 0.0));
    assert!(rotation <= 1e-6, "{rotation}");
    assert_eq!(back.sh, scene.sh);
}

// ------------------------------------------------------------- splat-transform fixtures

/// Reads `path` the way splat-transform writes it: SPZ in the file's own axes.
fn load_as_splat_transform_writes(path: &std::path::Path) -> Scene {
    use rara::formats::{load_scene_with, spz::SpzAxes, ReadOptions};
    let options = ReadOptions {
        spz_axes: SpzAxes::AsStored,
    };
    load_scene_with(path, &options)
        .unwrap_or_else(|e| panic!("{}: {e}", path.display()))
        .0
}

/// For each Gaussian of `decoded`, the source Gaussian it encodes: the one with the nearest
/// centre (compressed PLY and SOG store the Gaussians in Morton order, not the source's).
/// Fails unless every source Gaussian is matched exactly once.
fn match_by_centre(source: &Scene, decoded: &Scene) -> Vec<usize> {
    assert_eq!(source.len(), decoded.len());
    let matched: Vec<usize> = decoded
        .means
        .iter()
        .map(|m| {
            (0..source.len())
                .min_by(|&a, &b| {
                    let (da, db) = (
                        source.means[a].distance_squared(*m),
                        source.means[b].distance_squared(*m),
                    );
                    da.total_cmp(&db)
                })
                .unwrap()
        })
        .collect();
    let mut seen = vec![false; source.len()];
    for &i in &matched {
        assert!(!seen[i], "two decoded Gaussians match source Gaussian {i}");
        seen[i] = true;
    }
    matched
}

/// How far apart two rotations put a Gaussian's axes: the largest `1 - |a_k . b_k|` over the
/// three local axes. A Gaussian is symmetric about each axis, so rotations that differ by
/// half a turn about one of its axes are the same Gaussian: splat-transform turns a scene into
/// glTF's axes by `t q`, rara by `t q t^-1`, two quaternions 90 degrees apart in 4D that give
/// the same covariance.
fn axis_error(a: glam::Quat, b: glam::Quat) -> f32 {
    let (ma, mb) = (glam::Mat3::from_quat(a), glam::Mat3::from_quat(b));
    (0..3)
        .map(|k| 1.0 - ma.col(k).dot(mb.col(k)).abs())
        .fold(0f32, f32::max)
}

/// The bound of [`axis_error`] for a "smallest three" quaternion whose three stored
/// components are within `component` each: the fourth, at least 1/2, is off by at most
/// 3 `component` (from `sqrt(1 - a^2 - b^2 - c^2)`), so the quaternion by `sqrt 12`
/// `component`, and an axis turns by at most twice that.
fn axis_bound(component: f32) -> f32 {
    let angle = 2.0 * 12f32.sqrt() * component;
    1.0 - angle.cos() + 1e-6
}

/// The largest difference of a decoded scene from its source, property by property, in the
/// terms formats quantise them: centre coordinates, log scales, opacity (after the sigmoid),
/// `f_dc`, the axes ([`axis_error`]), and the SH of band 1 and of bands 2 and 3.
#[derive(Clone, Copy, Debug, Default)]
struct PropertyErrors {
    position: f32,
    log_scale: f32,
    opacity: f32,
    dc: f32,
    rotation: f32,
    sh1: f32,
    sh23: f32,
}

impl PropertyErrors {
    /// Fails, naming `what` and the property, where an error exceeds its bound.
    fn assert_within(&self, bound: &PropertyErrors, what: &str) {
        let pairs = [
            ("position", self.position, bound.position),
            ("log scale", self.log_scale, bound.log_scale),
            ("opacity", self.opacity, bound.opacity),
            ("f_dc", self.dc, bound.dc),
            ("axes", self.rotation, bound.rotation),
            ("SH band 1", self.sh1, bound.sh1),
            ("SH bands 2-3", self.sh23, bound.sh23),
        ];
        for (property, got, most) in pairs {
            assert!(
                got <= most,
                "{what}: {property} differs by {got}, bound {most}"
            );
        }
    }

    /// The errors of `decoded` (Gaussian `k` encoding `source`'s `matched[k]`). SH bands the
    /// decoded scene lacks are not compared.
    fn measure(source: &Scene, decoded: &Scene, matched: &[usize]) -> Self {
        let mut e = PropertyErrors::default();
        let per_channel = decoded.sh_coeffs_per_channel();
        for (k, &i) in matched.iter().enumerate() {
            e.position = e
                .position
                .max((source.means[i] - decoded.means[k]).abs().max_element());
            let ls = |s: Vec3| Vec3::new(s.x.ln(), s.y.ln(), s.z.ln());
            e.log_scale = e.log_scale.max(
                (ls(source.scales[i]) - ls(decoded.scales[k]))
                    .abs()
                    .max_element(),
            );
            e.opacity = e
                .opacity
                .max((source.opacities[i] - decoded.opacities[k]).abs());
            e.rotation = e
                .rotation
                .max(axis_error(source.rotations[i], decoded.rotations[k]));
            let (a, b) = (source.sh_of(i), decoded.sh_of(k));
            for j in 0..per_channel {
                for c in 0..3 {
                    let d = (a[3 * j + c] - b[3 * j + c]).abs();
                    match j {
                        0 => e.dc = e.dc.max(d),
                        1..=3 => e.sh1 = e.sh1.max(d),
                        _ => e.sh23 = e.sh23.max(d),
                    }
                }
            }
        }
        e
    }
}

/// How much farther, at worst, a decoded value lies from its source value than the codebook
/// entry nearest that source value does: SOG stores each scale and colour as the index of a
/// k-means centre (and each SH vector as the index of a palette entry), so a value within its
/// quantisation is (nearly: the k-means' last step moves the centres after the values were
/// assigned) the centre nearest its source. Values are vectors (one component for a scale);
/// the codebook is the set of decoded values, the centres in use.
fn codebook_excess(source: &[Vec<f32>], decoded: &[Vec<f32>]) -> f32 {
    let dist = |a: &[f32], b: &[f32]| {
        a.iter()
            .zip(b)
            .map(|(x, y)| (x - y) * (x - y))
            .sum::<f32>()
            .sqrt()
    };
    let mut book: Vec<&Vec<f32>> = decoded.iter().collect();
    book.sort_by(|a, b| a.partial_cmp(b).unwrap());
    book.dedup();
    source
        .iter()
        .zip(decoded)
        .map(|(s, d)| {
            let nearest = book
                .iter()
                .map(|c| dist(c, s))
                .fold(f32::INFINITY, f32::min);
            dist(d, s) - nearest
        })
        .fold(0f32, f32::max)
}

/// How much farther than the nearest entry of its codebook a SOG value may decode from its
/// source (in the value's units: log scale, `f_dc`, an SH vector's length): f32 rounding. On
/// the fixture every value decodes to the nearest entry exactly.
const SOG_CODEBOOK_SLACK: f32 = 1e-4;

/// Per-axis extents of the centres, the log scales and `f_dc` of `s`, over all Gaussians: what
/// the range-quantising formats spread their levels over (at most; compressed PLY's chunks
/// span less).
fn ranges(s: &Scene) -> (f32, f32, f32) {
    let (mut lo, mut hi) = ([f32::MAX; 9], [f32::MIN; 9]);
    for i in 0..s.len() {
        let m = s.means[i].to_array();
        let l = s.scales[i].to_array().map(f32::ln);
        let c = [s.sh_of(i)[0], s.sh_of(i)[1], s.sh_of(i)[2]];
        for (k, v) in m.iter().chain(&l).chain(&c).enumerate() {
            lo[k] = lo[k].min(*v);
            hi[k] = hi[k].max(*v);
        }
    }
    let span = |r: std::ops::Range<usize>| r.map(|k| hi[k] - lo[k]).fold(0f32, f32::max);
    (span(0..3), span(3..6), span(6..9))
}

/// What a scene written as `format` (`ply`, `glb`, `compressed.ply`, `spz`, `sog`, `splat`)
/// may differ from its source, property by property: the quantisation of the format as
/// splat-transform 3.10.2 (or rara, which quantises SPZ as the reference does) writes it (half a level, plus f32
/// rounding), or, for SOG's k-means codebooks, the codebook criterion of
/// [`codebook_excess`].
fn quantisation_bounds(format: &str, source: &Scene) -> PropertyErrors {
    let (extent, log_scale_range, dc_range) = ranges(source);
    let max_abs = source
        .means
        .iter()
        .map(|m| m.abs().max_element())
        .fold(0f32, f32::max);
    let eps = 1e-6;
    match format {
        // f32 attributes; splat-transform takes exp and the sigmoid in f64.
        "ply" | "glb" => PropertyErrors {
            position: 0.0,
            log_scale: 1e-6,
            opacity: eps,
            dc: 0.0,
            rotation: 1e-6,
            sh1: 0.0,
            sh23: 0.0,
        },
        // Centres 11, 10 and 11 bits and log scales 11, 10, 11 bits over each chunk's range;
        // colour 8 bits over the chunk's range of 0.5 + C0 f_dc; opacity 8 bits; rotations
        // smallest three of 10 bits over [-1/sqrt 2, 1/sqrt 2]; SH 8 bits over [-4, 4]
        // (truncated when written, so up to a whole level).
        "compressed.ply" => PropertyErrors {
            position: 0.5 * extent / 1023.0 + eps,
            log_scale: 0.5 * log_scale_range / 1023.0 + eps,
            opacity: 0.5 / 255.0 + eps,
            dc: 0.5 * dc_range / 255.0 + eps,
            rotation: axis_bound(0.5 * std::f32::consts::SQRT_2 / 1023.0),
            sh1: 8.0 / 255.0 + eps,
            sh23: 8.0 / 255.0 + eps,
        },
        // 24-bit fixed point of 12 fractional bits; log scales u / 16 - 10; opacity and
        // colour (f_dc * 0.15 + 0.5) 8 bits; rotations smallest three of 9 bits; SH rounded
        // to 8 bits over [-1, 1], then to 5 bits (band 1) or 4 bits (bands 2, 3): two
        // roundings, half a level of each.
        "spz" => PropertyErrors {
            position: 0.5 / 4096.0 + eps,
            log_scale: 0.5 / 16.0 + eps,
            opacity: 0.5 / 255.0 + eps,
            dc: 0.5 / (0.15 * 255.0) + eps,
            rotation: axis_bound(0.5 * std::f32::consts::FRAC_1_SQRT_2 / 511.0),
            sh1: 4.5 / 128.0 + eps,
            sh23: 8.5 / 128.0 + eps,
        },
        // Centres 16 bits over the range of sign(x) ln(|x| + 1), so a level is at most
        // range / 65535 times (|x| + 1); opacity 8 bits; rotations smallest three of 8 bits
        // over [-1/sqrt 2, 1/sqrt 2]. splat-transform truncates all three when it writes them,
        // so a value is within a whole level. Scales, colours and SH are checked against their
        // codebooks instead (`codebook_excess`).
        "sog" => {
            let log_range = 2.0 * (max_abs + 1.0).ln();
            PropertyErrors {
                position: log_range / 65535.0 * (max_abs + 1.0) * 1.001 + eps,
                log_scale: f32::INFINITY,
                opacity: 1.0 / 255.0 + eps,
                dc: f32::INFINITY,
                rotation: axis_bound(std::f32::consts::SQRT_2 / 255.0),
                sh1: f32::INFINITY,
                sh23: f32::INFINITY,
            }
        }
        // rara's .splat: centres and scales f32; opacity and 0.5 + C0 f_dc 8 bits; each of
        // the four rotation components 8 bits, within 1.5/128 as splat-transform decodes
        // them (half a level of (u - 128) / 128, and one between that and u / 127.5 - 1),
        // so the quaternion within 4 times that once normalised.
        "splat" => PropertyErrors {
            position: 0.0,
            log_scale: 1e-6,
            opacity: 0.5 / 255.0 + eps,
            dc: 0.5 / 255.0 / SH_C0 + eps,
            rotation: 1.0 - (2.0f32 * 4.0 * 1.5 / 128.0).cos(),
            sh1: 0.0,
            sh23: 0.0,
        },
        _ => unreachable!("{format}"),
    }
}

/// splat-transform's files (made by `scripts/format_fixtures.sh` from a generated scene) read
/// back to their source within each format's quantisation, property by property: glTF to f32
/// rounding, compressed PLY, SPZ v3 and v4 and SOG within half a level of what they quantise.
#[test]
fn splat_transform_fixtures_read_within_each_formats_quantisation() {
    let dir = common::fixtures_dir();
    let (source, _) = rara::ply::load_ply(dir.join("source.ply")).unwrap();
    for (name, format) in [
        ("st.glb", "glb"),
        ("st.compressed.ply", "compressed.ply"),
        ("st_v4.spz", "spz"),
        ("st_v3.spz", "spz"),
        ("st.sog", "sog"),
    ] {
        let path = dir.join(name);
        let decoded = load_as_splat_transform_writes(&path);
        assert_eq!(decoded.sh_degree, source.sh_degree, "{name}");
        let matched = match_by_centre(&source, &decoded);
        let reordered = matched.iter().enumerate().any(|(k, &i)| k != i);
        let e = PropertyErrors::measure(&source, &decoded, &matched);
        let b = quantisation_bounds(format, &source);
        eprintln!(
            "{name} ({} bytes{}): {e:?}",
            std::fs::metadata(&path).unwrap().len(),
            if reordered { ", reordered" } else { "" }
        );
        e.assert_within(&b, name);
        if name == "st.sog" {
            // Scales and colours index 1-D codebooks per axis or channel, the SH a palette of
            // whole vectors: each decoded value is (within SOG_CODEBOOK_SLACK) the entry
            // nearest its source value.
            let column = |f: &dyn Fn(&Scene, usize) -> Vec<f32>| {
                let s: Vec<Vec<f32>> = matched.iter().map(|&i| f(&source, i)).collect();
                let d: Vec<Vec<f32>> = (0..decoded.len()).map(|k| f(&decoded, k)).collect();
                codebook_excess(&s, &d)
            };
            for axis in 0..3 {
                let log_scale = column(&|s: &Scene, i| vec![s.scales[i][axis].ln()]);
                let dc = column(&|s: &Scene, i| vec![s.sh_of(i)[axis]]);
                eprintln!(
                    "  codebook excess, axis/channel {axis}: log scale {log_scale:e}, f_dc {dc:e}"
                );
                assert!(
                    log_scale <= SOG_CODEBOOK_SLACK,
                    "{name}: log scale {axis}: {log_scale}"
                );
                assert!(dc <= SOG_CODEBOOK_SLACK, "{name}: f_dc {axis}: {dc}");
            }
            let sh = column(&|s: &Scene, i| s.sh_of(i)[3..].to_vec());
            eprintln!("  codebook excess, SH vectors: {sh:e}");
            assert!(sh <= SOG_CODEBOOK_SLACK, "{name}: SH: {sh}");
        }
    }
}

/// The cross-check with the reference tool, both ways (skipped where node or splat-transform
/// is not installed; `scripts/clients.sh` installs it):
///
/// - splat-transform decodes each fixture but the glb (into a PLY) to the values rara decodes, Gaussian
///   for Gaussian, to f32 rounding;
/// - splat-transform reads what rara writes (PLY, SPZ v4 and v3 in the PLY's axes, as
///   splat-transform takes SPZ, and `.splat`) and, rewritten as PLY, it holds the source
///   within the format's quantisation ([`quantisation_bounds`]). It reads no glb: rara's glb
///   goes to the glTF validator instead, which must find no error.
#[test]
fn splat_transform_and_rara_read_each_others_files() {
    use rara::formats::spz::{write_spz, SpzAxes, SpzVersion};
    let Some(st) = common::splat_transform() else {
        common::test_skipped(
            "node or npm's @playcanvas/splat-transform is not installed (scripts/clients.sh)",
        );
        return;
    };
    let fixtures = common::fixtures_dir();
    let dir = common::tempdir("formats_cross");
    let (source, _) = rara::ply::load_ply(fixtures.join("source.ply")).unwrap();
    let same = PropertyErrors {
        position: 1e-6,
        log_scale: 1e-6,
        opacity: 1e-6,
        dc: 1e-6,
        rotation: 1e-6,
        sh1: 1e-6,
        sh23: 1e-6,
    };
    // splat-transform reads no glb, so its own glb is not among them.
    for name in ["st.compressed.ply", "st_v4.spz", "st_v3.spz", "st.sog"] {
        let theirs_path = dir.join(format!("{name}.decoded.ply"));
        common::run_splat_transform(&st, &fixtures.join(name), &theirs_path);
        let (theirs, _) = rara::ply::load_ply(&theirs_path).unwrap();
        let ours = load_as_splat_transform_writes(&fixtures.join(name));
        assert_eq!(ours.sh_degree, theirs.sh_degree, "{name}");
        let in_order: Vec<usize> = (0..ours.len()).collect();
        let e = PropertyErrors::measure(&theirs, &ours, &in_order);
        eprintln!("{name}: rara's decode against splat-transform's: {e:?}");
        e.assert_within(&same, &format!("{name}, rara against splat-transform"));
    }

    type Write<'a> = &'a dyn Fn(&std::path::Path);
    let written: [(&str, &str, Write); 4] = [
        ("rara.ply", "ply", &|p| {
            rara::ply::write_ply(&source, p, rara::ply::PlyEncoding::BinaryLittleEndian).unwrap()
        }),
        ("rara_v4.spz", "spz", &|p| {
            write_spz(&source, p, SpzVersion::V4, SpzAxes::AsStored).unwrap()
        }),
        ("rara_v3.spz", "spz", &|p| {
            write_spz(&source, p, SpzVersion::V3, SpzAxes::AsStored).unwrap()
        }),
        ("rara.splat", "splat", &|p| {
            rara::formats::splat::write_splat(&source, p).unwrap()
        }),
    ];
    for (name, format, write) in written {
        let ours = dir.join(name);
        write(&ours);
        let theirs_path = dir.join(format!("{name}.read_by_splat_transform.ply"));
        common::run_splat_transform(&st, &ours, &theirs_path);
        let (theirs, _) = rara::ply::load_ply(&theirs_path).unwrap();
        let matched = match_by_centre(&source, &theirs);
        let e = PropertyErrors::measure(&source, &theirs, &matched);
        eprintln!(
            "{name} ({} bytes) read by splat-transform (SH degree {}): {e:?}",
            std::fs::metadata(&ours).unwrap().len(),
            theirs.sh_degree
        );
        assert_eq!(
            theirs.sh_degree,
            if format == "splat" {
                0
            } else {
                source.sh_degree
            },
            "{name}"
        );
        e.assert_within(&quantisation_bounds(format, &source), name);
    }

    // The validator (npm's newest, 2.0.0-dev.3.10) predates KHR_gaussian_splatting: it names
    // each of the extension's attributes an invalid attribute name, as it does in
    // splat-transform's own glb. Everything else (buffers, views, accessors, bounds) it checks,
    // and finds no other error and no warning.
    let glb = dir.join("rara.glb");
    rara::formats::gltf::write_glb(&source, &glb).unwrap();
    let issues = common::gltf_validator_issues(&glb);
    let reference = common::gltf_validator_issues(&fixtures.join("st.glb"));
    match (issues, reference) {
        (Some(issues), Some(reference)) => {
            let codes = |i: &serde_json::Value| -> Vec<(String, String)> {
                let mut v: Vec<(String, String)> = i["messages"]
                    .as_array()
                    .unwrap()
                    .iter()
                    .map(|m| (m["code"].to_string(), m["pointer"].to_string()))
                    .collect();
                v.sort();
                v
            };
            eprintln!(
                "rara.glb, glTF validator: {} errors, {} warnings, {} infos",
                issues["numErrors"], issues["numWarnings"], issues["numInfos"]
            );
            for m in issues["messages"].as_array().unwrap() {
                if m["severity"] == 0 {
                    assert!(
                        m["code"] == "MESH_PRIMITIVE_INVALID_ATTRIBUTE"
                            && m["pointer"]
                                .as_str()
                                .unwrap()
                                .contains("/attributes/KHR_gaussian_splatting:"),
                        "rara.glb: {m}"
                    );
                }
            }
            assert_eq!(issues["numWarnings"], 0, "{issues}");
            assert_eq!(
                codes(&issues),
                codes(&reference),
                "rara's glb against splat-transform's"
            );
        }
        _ => eprintln!("rara.glb: the glTF validator is not installed, not checked"),
    }
}

/// Each reader's error for the hostile inputs every format meets: a truncated file or stream,
/// a bad magic, a count that does not match the data, and a decompression bomb (a count or a
/// stream far larger than the file could hold), each named for what it is.
#[test]
fn hostile_files_get_clear_errors() {
    use rara::formats::spz::{decode, encode, SpzAxes, SpzVersion};
    let dir = common::tempdir("formats_hostile");
    let fixtures = common::fixtures_dir();
    let scene = rara::synth::shell(300, 1, 9);
    let path = std::path::Path::new("hostile.spz");
    let spz = |bytes: &[u8]| decode(bytes, path, SpzAxes::Rub).unwrap_err().to_string();
    let gz = |inner: &[u8]| {
        use std::io::Write;
        let mut e = flate2::write::GzEncoder::new(Vec::new(), flate2::Compression::fast());
        e.write_all(inner).unwrap();
        e.finish().unwrap()
    };
    let gunzip = |bytes: &[u8]| {
        use std::io::Read;
        let mut out = Vec::new();
        flate2::read::GzDecoder::new(bytes)
            .read_to_end(&mut out)
            .unwrap();
        out
    };
    let v4 = encode(&scene, SpzVersion::V4, SpzAxes::Rub).unwrap();
    let v3 = encode(&scene, SpzVersion::V3, SpzAxes::Rub).unwrap();
    let mut cases: Vec<(String, String, &str)> = Vec::new();
    let mut case = |what: &str, message: String, expect: &'static str| {
        cases.push((what.to_string(), message, expect))
    };

    // SPZ v4: truncated, bad magic, a count one more than the streams hold, a count no file
    // of this size could hold, and a stream that inflates past its table entry.
    case("SPZ v4 truncated", spz(&v4[..v4.len() - 10]), "truncated");
    let mut bad_magic = v4.clone();
    bad_magic[0] = b'X';
    case("SPZ v4 bad magic", spz(&bad_magic), "no NGSP header");
    let mut more = v4.clone();
    more[8..12].copy_from_slice(&301u32.to_le_bytes());
    case(
        "SPZ v4 count mismatch",
        spz(&more),
        "where 301 Gaussians need",
    );
    let mut huge = v4.clone();
    huge[8..12].copy_from_slice(&u32::MAX.to_le_bytes());
    case("SPZ v4 count bomb", spz(&huge), "does not fit in");
    let mut bomb = v4.clone();
    {
        // The last (SH) stream replaced by 64 MiB of zeros, its table entry kept.
        let toc = u32::from_le_bytes(bomb[16..20].try_into().unwrap()) as usize;
        let last = toc + 16 * (bomb[15] as usize - 1);
        let packed = u64::from_le_bytes(bomb[last..last + 8].try_into().unwrap()) as usize;
        bomb.truncate(bomb.len() - packed);
        let zeros = zstd::encode_all(&vec![0u8; 64 << 20][..], 3).unwrap();
        bomb[last..last + 8].copy_from_slice(&(zeros.len() as u64).to_le_bytes());
        bomb.extend_from_slice(&zeros);
    }
    case("SPZ v4 stream bomb", spz(&bomb), "holds more than");
    // SPZ v3: truncated gzip, a count the stream does not hold, a count bomb.
    case(
        "SPZ v3 truncated",
        spz(&v3[..v3.len() / 2]),
        "SPZ: gzip stream",
    );
    let mut inner = gunzip(&v3);
    inner[8..12].copy_from_slice(&400u32.to_le_bytes());
    case("SPZ v3 count mismatch", spz(&gz(&inner)), "truncated");
    inner[8..12].copy_from_slice(&u32::MAX.to_le_bytes());
    case("SPZ v3 count bomb", spz(&gz(&inner)), "does not fit in");

    // Through files: compressed PLY, SOG, glb.
    let load = |name: &str, bytes: &[u8]| {
        let p = dir.join(name);
        std::fs::write(&p, bytes).unwrap();
        rara::formats::load_scene(&p).unwrap_err().to_string()
    };
    let cply = std::fs::read(fixtures.join("st.compressed.ply")).unwrap();
    case(
        "compressed PLY truncated",
        load("t.compressed.ply", &cply[..cply.len() - 100]),
        "bytes after the header",
    );
    let text = String::from_utf8_lossy(&cply[..4000]).into_owned();
    let header_end = text.find("end_header\n").unwrap() + "end_header\n".len();
    let header = text[..header_end].replace("element vertex 1000", "element vertex 1001");
    let mut counted = header.into_bytes();
    counted.extend_from_slice(&cply[header_end..]);
    case(
        "compressed PLY count mismatch",
        load("c.compressed.ply", &counted),
        "sh rows for 1001 vertices",
    );

    let sog = std::fs::read(fixtures.join("st.sog")).unwrap();
    case(
        "SOG truncated",
        load("t.sog", &sog[..sog.len() / 2]),
        "not a readable zip",
    );
    let mut bad = sog.clone();
    bad[0] = b'X';
    case("SOG bad magic", load("m.sog", &bad), "starts with");
    {
        // meta.json's count raised past the images' pixels, and a member that is a bomb.
        let members = common::unzip(&sog).unwrap();
        let rezip = common::zip_members;
        let mut counted = members.clone();
        for (n, d) in &mut counted {
            if n == "meta.json" {
                let t = String::from_utf8(d.clone()).unwrap();
                *d = t.replace("\"count\":1000", "\"count\":5000").into_bytes();
            }
        }
        case(
            "SOG count mismatch",
            load("c.sog", &rezip(&counted)),
            "too small for 5000",
        );
        let mut bombed = members.clone();
        for (n, d) in &mut bombed {
            if n == "means_l.webp" {
                *d = vec![0u8; 256 << 20];
            }
        }
        case(
            "SOG member bomb",
            load("b.sog", &rezip(&bombed)),
            "decompression bomb",
        );
    }

    let glb = std::fs::read(fixtures.join("st.glb")).unwrap();
    case(
        "glb truncated",
        load("t.glb", &glb[..glb.len() - 1000]),
        "(truncated)",
    );
    let mut bad = glb.clone();
    bad[0] = b'X';
    case("glb bad magic", load("m.glb", &bad), "starts with");
    let json_len = u32::from_le_bytes(glb[12..16].try_into().unwrap()) as usize;
    let json = String::from_utf8_lossy(&glb[20..20 + json_len]).into_owned();
    let counted = json.replacen("\"count\":1000", "\"count\":9000", 1);
    assert_ne!(counted, json);
    let mut counted_glb = glb[..20].to_vec();
    counted_glb.extend_from_slice(counted.as_bytes());
    counted_glb.extend_from_slice(&glb[20 + json_len..]);
    case(
        "glb count mismatch",
        load("c.glb", &counted_glb),
        "do not fit in",
    );

    for (what, message, expect) in &cases {
        eprintln!("{what}: {message}");
        assert!(
            message.contains(expect),
            "{what}: '{message}' does not say '{expect}'"
        );
    }
}
