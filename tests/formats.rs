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
    let Some(dir) = common::real_data_dir() else {
        common::test_skipped("none of its real scenes is here");
        return;
    };
    let mut ran = 0;
    for (original, ply) in [
        ("originals/plant.splat", "plant_capture_sh0.ply"),
        (
            "originals/skull_100k.splat",
            "skull_mesh2splat_100k_sh0.ply",
        ),
    ] {
        let (o, p) = (dir.join(original), dir.join(ply));
        if !o.is_file() || !p.is_file() {
            eprintln!("real-scene case '{original}' SKIPPED: not here");
            continue;
        }
        let start = std::time::Instant::now();
        let (a, report) = load_scene(&o).unwrap();
        let load_ms = start.elapsed().as_secs_f64() * 1e3;
        let (b, _) = rara::ply::load_ply(&p).unwrap();
        let [pos, scale, opacity, colour, rotation] = differences(&b, &a);
        eprintln!(
            "real-scene case '{original}' ran: {} Gaussians ({} dropped) in {load_ms:.0} ms; against {ply}: position {pos:e}, scale {scale:e}, opacity {opacity:e}, colour {colour:e}, rotation {rotation:e}",
            a.len(),
            report.dropped_non_finite
        );
        assert_eq!(pos, 0.0);
        assert!(scale <= 1e-5, "{scale}");
        assert!(opacity <= 1e-5, "{opacity}");
        assert!(colour <= 1e-5, "{colour}");
        assert!(rotation <= 1e-3, "{rotation}");
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
    Scene {
        means: keep.iter().map(|&i| s.means[i]).collect(),
        opacities: keep.iter().map(|&i| s.opacities[i]).collect(),
        scales: keep.iter().map(|&i| s.scales[i]).collect(),
        rotations: keep.iter().map(|&i| s.rotations[i]).collect(),
        sh_degree: s.sh_degree,
        sh: keep.iter().flat_map(|&i| s.sh_of(i).to_vec()).collect(),
    }
}

/// The real originals in compressed PLY, SPZ v4 and SOG decode to the shared PLY conversions
/// (splat-transform 2.7.1): compressed PLY and SOG to f32 rounding (SH included), SPZ within
/// its quantisation (centres 1/8192, colour half a level of 1/(0.15 * 255) in f_dc).
#[test]
fn original_compressed_files_match_the_shared_ply_conversions() {
    let Some(dir) = common::real_data_dir() else {
        common::test_skipped("none of its real scenes is here");
        return;
    };
    let mut ran = 0;
    for (original, ply) in [
        ("originals/biker.compressed.ply", "biker_capture_sh0.ply"),
        (
            "originals/guitar.compressed.ply",
            "guitar_capture_sh0_anisotropic.ply",
        ),
        ("originals/biker.spz", "biker_capture_sh0.ply"),
        ("originals/playbot_lod0_sog", "playbot_lod0_500k_sh2.ply"),
    ] {
        let (o, p) = (dir.join(original), dir.join(ply));
        if !o.exists() || !p.is_file() {
            eprintln!("real-scene case '{original}' SKIPPED: not here");
            continue;
        }
        let start = std::time::Instant::now();
        let (a, report) = load_scene(&o).unwrap();
        let load_ms = start.elapsed().as_secs_f64() * 1e3;
        let (b, _) = rara::ply::load_ply(&p).unwrap();
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
            "real-scene case '{original}' ran: {} Gaussians in {load_ms:.0} ms ({:?}); against {ply}: position {pos:e}, scale {scale:e}, opacity {opacity:e}, colour {colour:e}, rotation {rotation:e}, SH {sh:e}",
            a.len(),
            report.notes
        );
        if original.ends_with(".spz") {
            assert!(pos <= 0.5 / 4096.0 + 1e-6, "{pos}");
            assert!(
                colour <= 0.5 * SH_C0 / (0.15 * 255.0) / SH_C0 * SH_C0 + 1e-4,
                "{colour}"
            );
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
        ran += 1;
    }
    if ran == 0 {
        common::test_skipped("none of its real scenes is here");
    }
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
