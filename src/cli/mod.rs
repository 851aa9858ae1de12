//! The `rara` tool's commands, one module each (`main.rs` lists them and dispatches), and what
//! they share: arguments ([`args`]), loading ([`load`]), outputs ([`output`]), clip options
//! ([`clip_args`]) and the reports below.

pub mod args;
pub mod bake;
pub mod bench;
pub mod clip_args;
pub mod compare;
pub mod convert;
pub mod demo;
pub mod depth;
pub mod flatten;
pub mod info;
pub mod load;
pub mod mesh;
pub mod objects;
pub mod output;
pub mod render;
pub mod scene;
pub mod sweep;
pub mod synth;
pub mod video;

use rara::{FrameMemory, GpuScene};

/// Prints each pass's median milliseconds, a line per pass, the names padded to the longest
/// so that the times line up (`render --repeat`).
pub fn print_pass_medians(passes: Vec<(&str, Vec<f64>)>) {
    let width = passes.iter().map(|(name, _)| name.len()).max().unwrap_or(0);
    for (name, mut v) in passes {
        println!("  {name:<width$} {:8.2} ms", median(&mut v));
    }
}

/// The median of `values` (sorted in place); NaN when empty.
pub fn median(values: &mut [f64]) -> f64 {
    values.sort_by(f64::total_cmp);
    let n = values.len();
    if n == 0 {
        return f64::NAN;
    }
    if n % 2 == 1 {
        values[n / 2]
    } else {
        0.5 * (values[n / 2 - 1] + values[n / 2])
    }
}

/// The line that reports a still BVH's build (`--still-bvh`).
pub fn describe_still_bvh(s: &rara::raytrace::still_bvh::StillBvhStats) -> String {
    format!(
        "still BVH built on the host in {:.0} ms: SAH cost {:.1} (the GPU's LBVH: {:.1}), depth \
         {}, {} Gaussians without a proxy",
        s.build_ms, s.sah, s.lbvh_sah, s.depth, s.empty
    )
}

/// `--sh-half`: how the SH coefficients are stored on the device.
pub fn sh_precision(half: bool) -> rara::ShPrecision {
    if half {
        rara::ShPrecision::F16
    } else {
        rara::ShPrecision::F32
    }
}

fn mb(bytes: u64) -> String {
    format!("{:.1} MB", bytes as f64 / 1e6)
}

/// The line `render` and `bench` print about a frame whose camera rays came from tile lists
/// (SPEC section 11): the lists' size and the pending buffer's capacity K, which forces no hit
/// out of order (a pass that runs out of room leaves the rest to the next one).
pub fn describe_tiled(
    frame: &rara::FrameStats,
    t: &rara::raytrace::tracer::TraceFrameStats,
) -> String {
    format!(
        "camera rays from tile lists (SPEC 11): {} Gaussians listed, {} (tile, Gaussian) pairs; \
         pending buffer K = {}; no hit is forced out of order (a full buffer ends its pass and \
         the next walks the list again from the first hit left out: {:.2} passes, {:.0} entries \
         tested per ray)",
        frame.visible,
        frame.intersections,
        t.k,
        t.passes_per_ray(),
        t.visits_per_ray()
    )
}

/// Device memory of a scene and of the frame that drew it, by what it scales with.
pub fn describe_memory(scene: &GpuScene, frame: &FrameMemory) -> String {
    let n = scene.len().max(1) as u64;
    let pairs = frame.intersection_capacity.max(1);
    format!(
        "device memory: scene {} ({} B/Gaussian, SH {}); frame scratch {} = per Gaussian {} \
         ({:.1} B) + cutoff records {} + sort {} for {} pairs ({:.1} B/pair) + per pixel {} + {} fixed",
        mb(scene.device_bytes()),
        scene.device_bytes() / n,
        scene.sh_precision().name(),
        mb(frame.total()),
        mb(frame.per_gaussian),
        frame.per_gaussian as f64 / n as f64,
        mb(frame.cutoff_records),
        mb(frame.per_intersection),
        frame.intersection_capacity,
        frame.per_intersection as f64 / pairs as f64,
        mb(frame.per_pixel),
        mb(frame.fixed),
    ) + &describe_trace_memory(scene, frame)
}

/// The process's peak resident memory so far, from Linux's `/proc/self/status` (`VmHWM`), as
/// a line for the render summary (on a CPU device, device memory is host memory too); `None`
/// where there is no such file.
pub fn describe_peak_host_memory() -> Option<String> {
    let status = std::fs::read_to_string("/proc/self/status").ok()?;
    let kb: u64 = status
        .lines()
        .find(|l| l.starts_with("VmHWM:"))?
        .split_whitespace()
        .nth(1)?
        .parse()
        .ok()?;
    Some(format!(
        "host memory: peak resident {} ({} bytes)",
        mb(kb * 1024),
        kb * 1024
    ))
}

/// The ray tracer's part of [`describe_memory`], empty before its first frame.
fn describe_trace_memory(scene: &GpuScene, frame: &FrameMemory) -> String {
    if frame.trace_per_ray == 0 {
        return String::new();
    }
    let n = frame.bvh_gaussians.max(1);
    let bvh = if frame.bvh > 0 {
        format!(
            "BVH {} ({:.1} B/Gaussian: {} nodes of 32 B, proxies, Morton sort)",
            mb(frame.bvh),
            frame.bvh as f64 / n as f64,
            2 * n - 1
        )
    } else if scene.has_still_bvh() {
        format!(
            "the scene's still BVH, walked where it lies ({:.1} B/Gaussian, counted with the scene)",
            scene.still_bvh_bytes() as f64 / scene.len().max(1) as f64
        )
    } else {
        "no BVH".to_string()
    };
    format!(
        "; ray tracer: {bvh} + per ray {} ({:.0} B/ray)",
        mb(frame.trace_per_ray),
        frame.trace_per_ray as f64 / frame.trace_rays.max(1) as f64,
    )
}

/// [`describe_memory`] as JSON.
pub fn memory_json(scene: &GpuScene, frame: &FrameMemory) -> serde_json::Value {
    serde_json::json!({
        "scene_bytes": scene.device_bytes(),
        "scene_bytes_per_gaussian": scene.device_bytes() as f64 / scene.len().max(1) as f64,
        "sh_precision": scene.sh_precision().name(),
        "frame_bytes": frame.total(),
        "frame_per_gaussian_bytes": frame.per_gaussian,
        "frame_cutoff_record_bytes": frame.cutoff_records,
        "frame_sort_bytes": frame.per_intersection,
        "frame_intersection_capacity": frame.intersection_capacity,
        "frame_per_pixel_bytes": frame.per_pixel,
        "frame_fixed_bytes": frame.fixed,
        "bvh_bytes": frame.bvh,
        "still_bvh_bytes": scene.still_bvh_bytes(),
        "bvh_bytes_per_gaussian": frame.bvh as f64 / frame.bvh_gaussians.max(1) as f64,
        "bvh_nodes": (2 * frame.bvh_gaussians).saturating_sub(1),
        "bvh_node_bytes": 32,
        "trace_per_ray_bytes": frame.trace_per_ray,
        "trace_bytes_per_ray": frame.trace_per_ray as f64 / frame.trace_rays.max(1) as f64,
    })
}
