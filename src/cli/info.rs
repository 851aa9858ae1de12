//! `rara info`: what a scene file holds: counts, SH degree, encoding, bounds and the range of
//! every property.

use std::path::Path;

use glam::Vec3;
use rara::Result;

use super::load::read_options;

/// Prints what the scene at `path` holds, as text or JSON.
pub fn run(path: &Path, json: bool) -> Result<()> {
    let (scene, report) = rara::formats::load_scene_with(path, &read_options())?;
    let n = scene.len();
    let range = |f: &dyn Fn(usize) -> f32| -> (f32, f32) {
        (0..n)
            .map(f)
            .fold((f32::INFINITY, f32::NEG_INFINITY), |(lo, hi), v| {
                (lo.min(v), hi.max(v))
            })
    };
    let mut props: Vec<(String, (f32, f32))> = Vec::new();
    for (axis, name) in ["x", "y", "z"].iter().enumerate() {
        props.push((name.to_string(), range(&|i| scene.means[i][axis])));
    }
    props.push(("opacity (activated)".into(), range(&|i| scene.opacities[i])));
    for axis in 0..3 {
        props.push((
            format!("scale_{axis} (activated)"),
            range(&|i| scene.scales[i][axis]),
        ));
    }
    props.push((
        "anisotropy (max/min scale)".into(),
        // Over the Gaussians that are not flat (NaN is passed over by the fold).
        range(&|i| {
            let s = scene.scales[i];
            if s.min_element() == 0.0 {
                f32::NAN
            } else {
                s.max_element() / s.min_element()
            }
        }),
    ));
    for c in 0..3 {
        props.push((format!("f_dc_{c}"), range(&|i| scene.sh_of(i)[c])));
    }
    let (lo, hi) = scene.bounds().unwrap_or((Vec3::ZERO, Vec3::ZERO));
    let flat = scene.flat_count();
    if json {
        let v = serde_json::json!({
            "file": path.display().to_string(),
            "count": n,
            "vertices_in_file": report.vertices_in_file,
            "dropped_non_finite": report.dropped_non_finite,
            "sh_degree": scene.sh_degree,
            "flat": flat,
            "encoding": report.encoding,
            "notes": report.notes,
            "bounds": {"min": lo.to_array(), "max": hi.to_array()},
            "properties": props.iter().map(|(k, (a, b))| (k.clone(), serde_json::json!({"min": a, "max": b}))).collect::<serde_json::Map<_, _>>(),
        });
        println!("{}", serde_json::to_string_pretty(&v).unwrap());
    } else {
        println!("file:        {}", path.display());
        println!(
            "Gaussians:   {n} ({} in file, {} dropped as non-finite)",
            report.vertices_in_file, report.dropped_non_finite
        );
        println!("SH degree:   {}", scene.sh_degree);
        println!("flat:        {flat} (one scale 0; SPEC section 6)");
        println!("encoding:    {}", report.encoding);
        for note in &report.notes {
            println!("note:        {note}");
        }
        println!(
            "bounds:      min {:?} max {:?}",
            lo.to_array(),
            hi.to_array()
        );
        for (k, (a, b)) in props {
            println!("  {k:<28} {a:>12.5} .. {b:<12.5}");
        }
    }
    Ok(())
}
