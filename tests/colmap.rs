//! COLMAP cameras (SPEC section 12, issue 74) against a real client: pycolmap (PyPI, installed by
//! `scripts/clients.sh` into `target/clients/pycolmap`) writes a model as text and as binary;
//! rara reads both into the cameras pycolmap says, projects a point where pycolmap projects it
//! (the principal point honoured), and renders from them on the GPU as the CPU reference does.
//! Says TEST SKIPPED where pycolmap is not installed.

mod common;

use std::path::{Path, PathBuf};
use std::process::Command;

use glam::Vec3;

/// A Python that imports pycolmap: `$RARA_PYCOLMAP_PYTHON`, the clients' virtual environment,
/// or `python3`.
fn pycolmap_python() -> Option<PathBuf> {
    let root = Path::new(env!("CARGO_MANIFEST_DIR"));
    let candidates = [
        std::env::var_os("RARA_PYCOLMAP_PYTHON").map(PathBuf::from),
        Some(root.join("target/clients/pycolmap/bin/python")),
        Some(PathBuf::from("python3")),
    ];
    let found = candidates.into_iter().flatten().find(|p| {
        Command::new(p)
            .args(["-c", "import pycolmap"])
            .output()
            .is_ok_and(|o| o.status.success())
    });
    if found.is_none() {
        common::test_skipped("pycolmap is not installed (scripts/clients.sh installs it)");
    }
    found
}

#[test]
fn colmap_models_pycolmap_writes_read_as_its_cameras() {
    let Some(python) = pycolmap_python() else {
        return;
    };
    let dir = common::tempdir("colmap");
    let script = Path::new(env!("CARGO_MANIFEST_DIR")).join("tests/colmap/write_model.py");
    let out = Command::new(&python)
        .arg(&script)
        .arg(&dir)
        .output()
        .unwrap();
    let stdout = String::from_utf8_lossy(&out.stdout);
    assert!(
        out.status.success(),
        "write_model.py failed:\n{stdout}\n{}",
        String::from_utf8_lossy(&out.stderr)
    );
    let expected: Vec<Vec<f64>> = stdout
        .lines()
        .filter_map(|l| l.strip_prefix("EXPECT "))
        .map(|l| l.split(' ').skip(1).map(|x| x.parse().unwrap()).collect())
        .collect();
    assert_eq!(expected.len(), 3);
    let point = Vec3::new(0.3, -0.2, 0.5);
    for form in ["txt", "bin"] {
        let cams = rara::Camera::load_all(dir.join(form)).unwrap();
        assert_eq!(cams.len(), 3, "{form}");
        for (k, (cam, e)) in cams.iter().zip(&expected).enumerate() {
            let at = format!("{form} camera {k}");
            assert_eq!((cam.width, cam.height), (e[0] as u32, e[1] as u32), "{at}");
            assert_eq!((cam.fx as f64, cam.fy as f64), (e[2], e[3]), "{at}");
            let (cx, cy) = cam.principal_point();
            assert_eq!(
                (cx as f64 + 0.5, cy as f64 + 0.5),
                (e[4], e[5]),
                "{at}: principal point"
            );
            let centre = Vec3::new(e[6] as f32, e[7] as f32, e[8] as f32);
            assert!(
                (cam.position - centre).length() < 1e-5,
                "{at}: {} vs {centre}",
                cam.position
            );
            let w2c = cam.world_to_camera();
            for r in 0..3 {
                for c in 0..3 {
                    let want = e[9 + 3 * r + c] as f32;
                    assert!((w2c.row(r)[c] - want).abs() < 1e-6, "{at}: R[{r}][{c}]");
                }
            }
            // The pixel a world point lands on, rara's (pixel centres at integers) against
            // pycolmap's (at + 0.5).
            let t = cam.to_camera(point);
            let (u, v) = (cam.fx * t.x / t.z + cx, cam.fy * t.y / t.z + cy);
            assert!(
                ((u + 0.5) as f64 - e[18]).abs() < 1e-3 && ((v + 0.5) as f64 - e[19]).abs() < 1e-3,
                "{at}: rara projects to ({u}, {v}), pycolmap to ({}, {}) minus 0.5",
                e[18],
                e[19]
            );
        }
    }
    // Rendered from them: the GPU (rasterizer and ray tracer) against the CPU reference, with
    // the principal point off the centre.
    let scene = rara::synth::shell(2000, 1, 5);
    let ctx = common::context();
    let mut renderer = rara::Renderer::new(&ctx).unwrap();
    let gpu = renderer.upload(&scene).unwrap();
    for cam in rara::Camera::load_all(dir.join("bin")).unwrap() {
        let options = rara::RenderOptions::default();
        let (img, _) = renderer.render(&gpu, &cam, &options).unwrap();
        assert!(
            img.pixels()
                .filter(|p| p[0] > 0 || p[1] > 0 || p[2] > 0)
                .count()
                > 100,
            "the shell is not in view"
        );
        let cpu = rara::reference::render(&scene, &cam, &options);
        common::check_images("COLMAP camera, raster GPU vs CPU", &img, &cpu, 45.0, 255);
        let rt = rara::RenderOptions {
            tracer: rara::Tracer::Ray,
            ..options
        };
        let (traced, _) = renderer.render(&gpu, &cam, &rt).unwrap();
        let cpu_rt = rara::reference::raytrace::render(&scene, &cam, &rt, &Default::default()).0;
        common::check_images("COLMAP camera, ray GPU vs CPU", &traced, &cpu_rt, 45.0, 255);
    }
    drop(gpu);
    drop(renderer);
    common::assert_no_validation_messages(&ctx);
}
