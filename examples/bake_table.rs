//! The measure of SPEC section 10's bake on the real scenes: for each scene with orbit cameras
//! and two clips (an oblique plane through the scene's centre, and a cutaway of one octant of
//! its 5-95 % box), the PSNR of a baked scene rendered unclipped against rara's clipped render
//! of the original, over the scene's first 8 orbit views at 320 px wide: the bake with
//! section 10's opacity rule (mass), with the alternative rule (peak alpha along the normal),
//! and the centre filter that other tools export (`bake --clip-mode hard`).
//!
//! Run: `cargo run --release --example bake_table` (real scenes from `$RARA_REAL_DATA` or
//! `../shared/data/real`). Prints a Markdown table.

use std::error::Error;
use std::path::PathBuf;

use glam::{Quat, Vec3};
use rara::bake::{bake, BakeOpacity};
use rara::{Camera, Clip, ClipMode, ClipRegion, Context, Plane, RenderOptions, Renderer, Scene};

const SCENES: [&str; 5] = [
    "biker_capture_sh0",
    "guitar_capture_sh0_anisotropic",
    "plant_capture_sh0",
    "playbot_lod0_500k_sh2",
    "skull_mesh2splat_100k_sh0",
];

/// The 5 % and 95 % quantiles of the centres, per axis.
fn percentile_box(scene: &Scene) -> (Vec3, Vec3) {
    let q = |axis: usize, f: f32| {
        let mut v: Vec<f32> = scene.means.iter().map(|m| m[axis]).collect();
        v.sort_by(f32::total_cmp);
        v[((v.len() - 1) as f32 * f) as usize]
    };
    (
        Vec3::new(q(0, 0.05), q(1, 0.05), q(2, 0.05)),
        Vec3::new(q(0, 0.95), q(1, 0.95), q(2, 0.95)),
    )
}

fn main() -> Result<(), Box<dyn Error>> {
    let dir = std::env::var_os("RARA_REAL_DATA")
        .map(PathBuf::from)
        .unwrap_or_else(|| PathBuf::from("../shared/data/real"));
    let ctx = Context::from_env()?;
    let mut renderer = Renderer::new(&ctx)?;
    println!(
        "| scene | clip | bake (mass) dB | bake (peak) dB | bake (o P) dB | centre filter dB | \
         mass - filter |"
    );
    println!("|---|---|---|---|---|---|---|");
    let mut gains = Vec::new();
    let mut peak_minus_mass = Vec::new();
    let mut fraction_minus_mass = Vec::new();
    for stem in SCENES {
        let (ply, cams) = (
            dir.join(format!("{stem}.ply")),
            dir.join(format!("{stem}.orbit_cameras.json")),
        );
        if !ply.is_file() || !cams.is_file() {
            eprintln!("{stem}: not here, skipped");
            continue;
        }
        let (scene, _) = rara::ply::load_ply(&ply)?;
        let cameras: Vec<Camera> = Camera::load_all(&cams)?
            .into_iter()
            .take(8)
            .map(|c| c.resized(320, None))
            .collect::<Result<_, _>>()?;
        let (lo, hi) = percentile_box(&scene);
        let (centre, extent) = ((lo + hi) / 2.0, hi - lo);
        let plane = Plane::new(Vec3::new(0.48, 0.36, 0.8), 0.0)?;
        let plane = Plane::new(plane.normal, -plane.normal.dot(centre))?;
        let quarter = extent / 4.0;
        let octant = ClipRegion::oriented_box(
            centre + quarter * Vec3::new(1.0, -1.0, -1.0),
            quarter,
            Quat::IDENTITY,
        )?
        .inverted();
        let original = renderer.upload(&scene)?;
        for (clip_name, region) in [
            ("plane", ClipRegion::planes(vec![plane])?),
            ("octant cutaway", octant),
        ] {
            let clip = Clip::rara(region);
            let clipped = RenderOptions {
                clip: clip.clone(),
                ..RenderOptions::default()
            };
            let references: Vec<_> = cameras
                .iter()
                .map(|c| renderer.render(&original, c, &clipped).map(|r| r.0))
                .collect::<Result<_, _>>()?;
            let mut hard = clip.clone();
            hard.mode = ClipMode::Hard;
            let mut row = Vec::new();
            for (rule, clip) in [
                (BakeOpacity::Mass, &clip),
                (BakeOpacity::Peak, &clip),
                (BakeOpacity::Mass, &hard),
                (BakeOpacity::Fraction, &clip),
            ] {
                let (baked, _) = bake(&scene, clip, rule);
                let gpu = renderer.upload(&baked)?;
                let mut sum = 0.0;
                for (camera, want) in cameras.iter().zip(&references) {
                    let (got, _) = renderer.render(&gpu, camera, &RenderOptions::default())?;
                    let psnr = rara::metrics::compare(&got, want).psnr;
                    sum += if psnr.is_finite() { psnr } else { 100.0 };
                }
                row.push(sum / cameras.len() as f64);
            }
            gains.push(row[0] - row[2]);
            peak_minus_mass.push(row[1] - row[0]);
            fraction_minus_mass.push(row[3] - row[0]);
            println!(
                "| {stem} | {clip_name} | {:.2} | {:.2} | {:.2} | {:.2} | {:+.2} |",
                row[0],
                row[1],
                row[3],
                row[2],
                row[0] - row[2]
            );
        }
    }
    let mean = |v: &[f64]| v.iter().sum::<f64>() / v.len().max(1) as f64;
    println!(
        "\nbake (mass) over the centre filter: {:+.2} dB on average over {} cases; peak rule \
         against mass rule: {:+.2} dB; o P against mass rule: {:+.2} dB",
        mean(&gains),
        gains.len(),
        mean(&peak_minus_mass),
        mean(&fraction_minus_mass)
    );
    Ok(())
}
