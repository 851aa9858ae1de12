//! `rara demo`: the headline on a built-in scene. A solid ellipsoid coloured in layers (skin,
//! muscle, bone: `synth::solid`) is cut away by a box and shown unclipped, hard-clipped and
//! RaRa-clipped side by side, then a plane sweeps through it along the view, hard and RaRa
//! side by side, as a GIF with the popping metric of each.

use std::path::Path;

use glam::{Quat, Vec3};

use rara::clip::{Clip, ClipMode, ClipRegion, Plane};
use rara::{Camera, Context, RenderOptions, Renderer, Result};

use super::output::{Output, Outputs};
use super::sweep::{concat_horizontally, GifWriter, Sweep};

/// Gaussians of the demo scene: few enough that single splats show at the cut, so that hard
/// clipping's ragged faces are visible.
const DEMO_GAUSSIANS: usize = 30_000;
/// Frames of the demo sweep: steps small against a Gaussian, so that the frame-to-frame change
/// shows popping rather than the cut's motion.
const SWEEP_FRAMES: u32 = 60;
/// Background of every demo image.
const BACKGROUND: Vec3 = Vec3::new(0.08, 0.08, 0.1);

/// The demo's camera: above and beside the cut octant, looking into it.
pub fn demo_camera() -> Result<Camera> {
    Camera::look_at(
        Vec3::new(3.0, -1.5, -1.2),
        Vec3::new(0.0, 0.1, 0.0),
        Vec3::NEG_Y,
        50.0,
        400,
        300,
    )
}

/// The cutaway: everything inside a box over one upper octant is removed.
pub fn demo_cut() -> Result<ClipRegion> {
    let rotation = Quat::from_xyzw(0.1, 0.2, 0.1, 0.96).normalize();
    Ok(
        ClipRegion::oriented_box(Vec3::new(0.75, -0.75, -0.75), Vec3::splat(0.75), rotation)?
            .inverted(),
    )
}

/// Runs the demo into `dir`.
pub fn run(dir: &Path) -> Result<()> {
    let start = std::time::Instant::now();
    // Both files land together when the demo is done, or nothing does.
    let mut set = Outputs::new();
    set.create_dir(dir)?;
    let scene = rara::synth::solid(DEMO_GAUSSIANS, 1, 7);
    let camera = demo_camera()?;
    let ctx = Context::from_env()?;
    let mut renderer = Renderer::new(&ctx)?;
    let gpu_scene = renderer.upload(&scene)?;
    let cut = demo_cut()?;

    // 1. Unclipped, hard and rara side by side.
    let mut panels = Vec::new();
    for (mode, label) in [
        (ClipMode::None, "UNCLIPPED"),
        (ClipMode::Hard, "HARD"),
        (ClipMode::Rara, "RARA"),
    ] {
        let clip = Clip {
            region: Some(cut.clone()),
            mode,
            ..Clip::default()
        };
        let options = RenderOptions {
            background: BACKGROUND,
            clip,
            ..RenderOptions::default()
        };
        let (mut img, _) = renderer.render(&gpu_scene, &camera, &options)?;
        draw_label(&mut img, label, 8, 8, 2);
        panels.push(img);
    }
    let comparison = dir.join("demo_cutaway.png");
    set.add_png(
        Output::prepare(&comparison, &["png"])?,
        &concat_horizontally(&panels),
    )?;

    // 2. A plane sweeping through the scene along the view, the far side kept: the camera
    //    looks at the cut face all along, hard | rara.
    let normal = camera.forward();
    let (d0, d1) = super::sweep::default_range(&scene, normal);
    let configs: Vec<Clip> = [ClipMode::Hard, ClipMode::Rara]
        .into_iter()
        .map(|mode| -> Result<Clip> {
            Ok(Clip {
                region: ClipRegion::from_parts(vec![Plane::new(normal, d0)?], None, false)?,
                mode,
                ..Clip::default()
            })
        })
        .collect::<Result<_>>()?;
    let sweep = dir.join("demo_sweep.gif");
    let mut gif_file = Output::prepare(&sweep, &["gif"])?.begin()?;
    let mut gif = GifWriter::new(&mut gif_file, &sweep, 120)?;
    let plan = Sweep {
        cameras: std::slice::from_ref(&camera),
        configs: &configs,
        normal,
        range: (d0, d1),
        frames: SWEEP_FRAMES,
        background: BACKGROUND,
        tracer: rara::Tracer::Raster,
    };
    let target = super::sweep::SweepTarget::Splats {
        renderer: &mut renderer,
        scene: &gpu_scene,
    };
    let series = plan.run(target, |_, mut frame| {
        draw_label(&mut frame, "HARD", 8, 8, 2);
        draw_label(&mut frame, "RARA", camera.width + 8, 8, 2);
        gif.add(frame)
    })?;
    drop(gif);
    set.add_written(gif_file)?;
    set.commit()?;
    // p99.9 of the sweep's frame-to-frame change, hard then rara (8-bit units).
    let (hard_p999, rara_p999) = (series[0].change_summary().1, series[1].change_summary().1);

    println!(
        "demo: {} Gaussians (synth solid: skin, muscle, bone), {}x{}, on {} ({})",
        scene.len(),
        camera.width,
        camera.height,
        ctx.info().name,
        ctx.info().driver
    );
    println!(
        "  wrote {}: a box cutaway unclipped | hard | rara",
        comparison.display()
    );
    println!(
        "  wrote {}: a plane sweeping through, hard | rara, {SWEEP_FRAMES} frames",
        sweep.display()
    );
    println!(
        "  popping (p99.9 of the frame-to-frame change, 8-bit units): hard {hard_p999:.0}, \
         rara {rara_p999:.0}"
    );
    println!("  {:.1} s", start.elapsed().as_secs_f64());
    Ok(())
}

/// Rows of a 5x7 glyph, the top row first, bit 4 the left column.
fn glyph(c: char) -> [u8; 7] {
    match c {
        'A' => [0x0e, 0x11, 0x11, 0x1f, 0x11, 0x11, 0x11],
        'C' => [0x0e, 0x11, 0x10, 0x10, 0x10, 0x11, 0x0e],
        'D' => [0x1e, 0x11, 0x11, 0x11, 0x11, 0x11, 0x1e],
        'E' => [0x1f, 0x10, 0x10, 0x1e, 0x10, 0x10, 0x1f],
        'H' => [0x11, 0x11, 0x11, 0x1f, 0x11, 0x11, 0x11],
        'I' => [0x0e, 0x04, 0x04, 0x04, 0x04, 0x04, 0x0e],
        'L' => [0x10, 0x10, 0x10, 0x10, 0x10, 0x10, 0x1f],
        'N' => [0x11, 0x19, 0x15, 0x13, 0x11, 0x11, 0x11],
        'P' => [0x1e, 0x11, 0x11, 0x1e, 0x10, 0x10, 0x10],
        'R' => [0x1e, 0x11, 0x11, 0x1e, 0x14, 0x12, 0x11],
        'U' => [0x11, 0x11, 0x11, 0x11, 0x11, 0x11, 0x0e],
        _ => [0; 7],
    }
}

/// Writes `text` (the capitals of `glyph`) in white at (x, y), each font pixel `scale` pixels.
fn draw_label(img: &mut image::RgbaImage, text: &str, x: u32, y: u32, scale: u32) {
    for (k, c) in text.chars().enumerate() {
        for (row, bits) in glyph(c).iter().enumerate() {
            for col in 0..5u32 {
                if bits & (0x10 >> col) == 0 {
                    continue;
                }
                for dy in 0..scale {
                    for dx in 0..scale {
                        let px = x + (k as u32 * 6 + col) * scale + dx;
                        let py = y + row as u32 * scale + dy;
                        if px < img.width() && py < img.height() {
                            img.put_pixel(px, py, image::Rgba([255, 255, 255, 255]));
                        }
                    }
                }
            }
        }
    }
}
