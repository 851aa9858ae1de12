//! Fuzzing of the parsers that read untrusted files: the PLY loader, every scene format's
//! reader (`.splat` with the format detection, SPZ v3 and v4, compressed PLY, SOG, glb), the
//! cameras.json parser, the clip file parser, the mesh readers (OBJ, PLY, glb, and `.gltf` with
//! its buffers in files beside it) with what follows them (the octagon import's checks, a mixed
//! scene's triangles), and the mixed scene file with every file it names. A property test,
//! not a coverage-guided fuzzer: it mutates real headers and payloads
//! (the real scenes' first vertices when `../shared/data/real` is there, the crate's own
//! scenes in every encoding and SH degree always) with structure-aware and byte-level
//! mutations, and checks for every input that
//!
//! - the parser returns `Ok` or `Err` and never panics;
//! - no single allocation exceeds a bound proportional to the input's size (a count read from
//!   the file must be checked against the file size before it sizes anything);
//! - what it accepts is a valid scene or camera list (finite, activated, consistent lengths).
//!
//! Each target runs for `RARA_FUZZ_SECONDS` (default 10) from seed `RARA_FUZZ_SEED` (default
//! fixed, so CI is reproducible); a failing input is written to `target/test-artifacts/`.

mod common;

use std::alloc::{GlobalAlloc, Layout, System};
use std::cell::Cell;
use std::io::Cursor;
use std::path::Path;
use std::time::{Duration, Instant};

use rara::camera::Camera;
use rara::clip::ClipFile;
use rara::ply::{read_ply, read_ply_stream, write_ply, PlyEncoding};
use rara::synth::Rng;

/// Counts the largest single allocation made by threads that opted in.
struct TrackingAllocator;

thread_local! {
    /// Whether this thread's allocations are tracked, and the largest one since.
    static TRACKING: Cell<bool> = const { Cell::new(false) };
    static LARGEST_ALLOCATION: Cell<usize> = const { Cell::new(0) };
}

fn note_size(size: usize) {
    if TRACKING.try_with(|t| t.get()).unwrap_or(false) {
        let _ = LARGEST_ALLOCATION.try_with(|l| l.set(l.get().max(size)));
    }
}

unsafe impl GlobalAlloc for TrackingAllocator {
    unsafe fn alloc(&self, layout: Layout) -> *mut u8 {
        note_size(layout.size());
        System.alloc(layout)
    }
    unsafe fn alloc_zeroed(&self, layout: Layout) -> *mut u8 {
        note_size(layout.size());
        System.alloc_zeroed(layout)
    }
    unsafe fn realloc(&self, ptr: *mut u8, layout: Layout, new_size: usize) -> *mut u8 {
        note_size(new_size);
        System.realloc(ptr, layout, new_size)
    }
    unsafe fn dealloc(&self, ptr: *mut u8, layout: Layout) {
        System.dealloc(ptr, layout)
    }
}

#[global_allocator]
static ALLOCATOR: TrackingAllocator = TrackingAllocator;

/// Runs `f` with this thread's allocations tracked; returns its result (or the panic message)
/// and the largest single allocation it made on this thread.
fn tracked<T>(f: impl FnOnce() -> T) -> (Result<T, String>, usize) {
    LARGEST_ALLOCATION.with(|l| l.set(0));
    TRACKING.with(|t| t.set(true));
    let result = std::panic::catch_unwind(std::panic::AssertUnwindSafe(f)).map_err(|p| {
        p.downcast_ref::<String>()
            .cloned()
            .or_else(|| p.downcast_ref::<&str>().map(|s| s.to_string()))
            .unwrap_or_else(|| "non-string panic".into())
    });
    TRACKING.with(|t| t.set(false));
    (result, LARGEST_ALLOCATION.with(|l| l.get()))
}

/// The most one parse may allocate at once for an input of `len` bytes. The loader reserves
/// the scene for the vertex count the file can hold: up to 236 bytes of scene per vertex of
/// at least 59 bytes (SH degree 3 with one-byte properties), so 4x; the header buffer and a
/// read chunk make the constant.
fn allocation_bound(len: usize) -> usize {
    4 * len + (4 << 20)
}

fn seconds() -> Duration {
    let s = std::env::var("RARA_FUZZ_SECONDS")
        .ok()
        .and_then(|s| s.parse::<f64>().ok())
        .unwrap_or(10.0);
    Duration::from_secs_f64(s)
}

fn seed() -> u64 {
    std::env::var("RARA_FUZZ_SEED")
        .ok()
        .and_then(|s| s.parse().ok())
        .unwrap_or(20261122)
}

fn save_failure(name: &str, input: &[u8]) -> std::path::PathBuf {
    let path = common::artifacts_dir().join(name);
    std::fs::write(&path, input).unwrap();
    path
}

// ---------------------------------------------------------------- seeds

/// The header (through `end_header\n`) and payload of a PLY file, split.
fn split_header(bytes: &[u8]) -> Option<(&[u8], &[u8])> {
    let end = bytes.windows(11).position(|w| w == b"end_header\n")? + 11;
    Some(bytes.split_at(end))
}

/// The first `keep` vertices of a binary real scene (from the file's first 64 KiB), its
/// header's count rewritten.
fn real_prefix(path: &Path, keep: usize) -> Option<Vec<u8>> {
    use std::io::Read;
    let mut head = Vec::new();
    std::fs::File::open(path)
        .ok()?
        .take(64 << 10)
        .read_to_end(&mut head)
        .ok()?;
    let (header, rest) = split_header(&head)?;
    let header = String::from_utf8_lossy(header).into_owned();
    let count: usize = header
        .lines()
        .find_map(|l| l.strip_prefix("element vertex "))?
        .trim()
        .parse()
        .ok()?;
    let stride = (std::fs::metadata(path).ok()?.len() as usize - header.len()) / count.max(1);
    let keep = keep.min(count);
    let payload = rest.get(..keep * stride)?;
    let header = header.replace(
        &format!("element vertex {count}\n"),
        &format!("element vertex {keep}\n"),
    );
    let mut out = header.into_bytes();
    out.extend_from_slice(payload);
    Some(out)
}

fn ply_seeds() -> Vec<(String, Vec<u8>)> {
    let dir = std::env::temp_dir().join(format!("rara-fuzz-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    let mut seeds = Vec::new();
    for degree in 0..=3 {
        let scene = rara::synth::shell(12, degree, 3 + degree as u64);
        for (enc, name) in [
            (PlyEncoding::BinaryLittleEndian, "le"),
            (PlyEncoding::BinaryBigEndian, "be"),
            (PlyEncoding::Ascii, "ascii"),
        ] {
            let path = dir.join(format!("sh{degree}_{name}.ply"));
            write_ply(&scene, &path, enc).unwrap();
            seeds.push((
                format!("synth sh{degree} {name}"),
                std::fs::read(&path).unwrap(),
            ));
        }
    }
    std::fs::remove_dir_all(&dir).ok();
    match common::real_data_dir() {
        Some(real) => {
            let mut plys: Vec<_> = std::fs::read_dir(&real)
                .unwrap()
                .filter_map(|e| e.ok().map(|e| e.path()))
                .filter(|p| p.extension().is_some_and(|e| e == "ply"))
                .collect();
            plys.sort();
            for p in plys {
                if let Some(bytes) = real_prefix(&p, 24) {
                    let stem = p.file_stem().unwrap().to_string_lossy().into_owned();
                    eprintln!("fuzz seed: real scene {stem} (first 24 vertices)");
                    seeds.push((format!("real {stem}"), bytes));
                }
            }
        }
        None => eprintln!("fuzz seeds: no real data; the crate's own scenes only"),
    }
    seeds
}

fn camera_seeds() -> Vec<(String, Vec<u8>)> {
    let dir = std::env::temp_dir().join(format!("rara-fuzz-cams-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    let path = dir.join("orbit.cameras.json");
    let cams = rara::synth::orbit_cameras(3, 3.0, 64, 48, 50.0).unwrap();
    Camera::save_all(&cams, &path).unwrap();
    let mut seeds = vec![("synth orbit".to_string(), std::fs::read(&path).unwrap())];
    std::fs::remove_dir_all(&dir).ok();
    if let Some(real) = common::real_data_dir() {
        let mut files: Vec<_> = std::fs::read_dir(&real)
            .unwrap()
            .filter_map(|e| e.ok().map(|e| e.path()))
            .filter(|p| p.to_string_lossy().ends_with(".orbit_cameras.json"))
            .collect();
        files.sort();
        for p in files {
            let bytes = std::fs::read(&p).unwrap();
            // Two cameras are enough structure; keep inputs small so mutations hit it often.
            let text = String::from_utf8_lossy(&bytes);
            let v: serde_json::Value = serde_json::from_str(&text).unwrap();
            let first: Vec<_> = v.as_array().unwrap().iter().take(2).cloned().collect();
            let name = p.file_name().unwrap().to_string_lossy().into_owned();
            eprintln!("fuzz seed: real cameras {name} (first 2)");
            seeds.push((
                format!("real {name}"),
                serde_json::to_vec_pretty(&first).unwrap(),
            ));
        }
    }
    seeds
}

// ---------------------------------------------------------------- mutations

const INTERESTING_COUNTS: &[&str] = &[
    "0",
    "1",
    "2",
    "255",
    "65536",
    "2147483647",
    "2147483648",
    "4294967295",
    "4294967296",
    "9223372036854775807",
    "18446744073709551615",
    "18446744073709551616",
    "99999999999999999999999",
    "-1",
    "1e9",
    "0x10",
    "",
];

const TYPES: &[&str] = &[
    "char", "uchar", "short", "ushort", "int", "uint", "float", "double", "int8", "uint8", "int16",
    "uint16", "int32", "uint32", "float32", "float64", "half", "bogus",
];

fn pick<T: Copy>(rng: &mut Rng, items: &[T]) -> T {
    items[(rng.next_u64() % items.len() as u64) as usize]
}

fn below(rng: &mut Rng, n: usize) -> usize {
    if n == 0 {
        0
    } else {
        (rng.next_u64() % n as u64) as usize
    }
}

/// Rewrites one line of the PLY header.
fn mutate_header_line(rng: &mut Rng, input: &mut Vec<u8>) {
    let Some((header, payload)) = split_header(input) else {
        return;
    };
    let payload = payload.to_vec();
    let text = String::from_utf8_lossy(header).into_owned();
    let mut lines: Vec<String> = text.lines().map(str::to_string).collect();
    let i = below(rng, lines.len());
    match rng.next_u64() % 10 {
        0 | 1 => {
            // An element count.
            let count = pick(rng, INTERESTING_COUNTS);
            if let Some(e) = lines.iter_mut().find(|l| l.starts_with("element vertex")) {
                *e = format!("element vertex {count}");
            }
        }
        2 => {
            // A property type, or a list property.
            if lines[i].starts_with("property ") {
                let name = lines[i].rsplit(' ').next().unwrap_or("x").to_string();
                lines[i] = if rng.next_u64() % 4 == 0 {
                    format!("property list uchar {} {name}", pick(rng, TYPES))
                } else {
                    format!("property {} {name}", pick(rng, TYPES))
                };
            }
        }
        3 => {
            lines.remove(i);
        }
        4 => {
            let l = lines[i].clone();
            lines.insert(i, l);
        }
        5 => {
            let j = below(rng, lines.len());
            lines.swap(i, j);
        }
        6 => {
            let format = pick(
                rng,
                &[
                    "format ascii 1.0",
                    "format binary_little_endian 1.0",
                    "format binary_big_endian 1.0",
                    "format binary_little_endian 2.0",
                    "format",
                    "format ebcdic 1.0",
                ],
            );
            if let Some(f) = lines.iter_mut().find(|l| l.starts_with("format")) {
                *f = format.to_string();
            }
        }
        7 => {
            // Another element before the vertices, with a hostile count.
            let count = pick(rng, INTERESTING_COUNTS);
            let at = 2.min(lines.len());
            lines.insert(at, format!("property {} junk", pick(rng, TYPES)));
            lines.insert(at, format!("element extra {count}"));
        }
        8 => {
            // Rename a property (missing / f_rest counts that are not 0, 9, 24, 45).
            if lines[i].starts_with("property ") {
                let suffix = pick(rng, &["f_rest_7", "f_rest_99", "x", "rot_0", "", "  "]);
                let mut parts: Vec<&str> = lines[i].split(' ').collect();
                if let Some(last) = parts.last_mut() {
                    *last = suffix;
                }
                lines[i] = parts.join(" ");
            }
        }
        _ => {
            lines[i].push_str(pick(rng, &["\r", " extra", "\u{0}", "\u{fffd}", " 1 2 3"]));
        }
    }
    let mut out = lines.join("\n").into_bytes();
    out.push(b'\n');
    out.extend_from_slice(&payload);
    *input = out;
}

/// Writes a special float into the payload (or a special token into ascii).
fn mutate_payload_value(rng: &mut Rng, input: &mut [u8]) {
    let Some(start) = split_header(input).map(|(h, _)| h.len()) else {
        return;
    };
    if input.len() < start + 4 {
        return;
    }
    let at = start + below(rng, input.len() - start - 3);
    let v: f32 = pick(
        rng,
        &[
            f32::NAN,
            f32::INFINITY,
            f32::NEG_INFINITY,
            f32::MAX,
            -f32::MAX,
            f32::MIN_POSITIVE / 2.0,
            0.0,
            -0.0,
            1e30,
            -1e30,
            100.0,
            -100.0,
        ],
    );
    let bytes = if rng.next_u64() % 2 == 0 {
        v.to_le_bytes()
    } else {
        v.to_be_bytes()
    };
    input[at..at + 4].copy_from_slice(&bytes);
}

/// Generic byte-level mutations.
fn mutate_bytes(rng: &mut Rng, input: &mut Vec<u8>) {
    let len = input.len();
    match rng.next_u64() % 8 {
        0 if len > 0 => {
            let i = below(rng, len);
            input[i] ^= 1 << (rng.next_u64() % 8);
        }
        1 if len > 0 => {
            let i = below(rng, len);
            input[i] = pick(rng, &[0u8, 0xff, 0x7f, 0x80, b'\n', b' ', b'-', b'9']);
        }
        2 => input.truncate(below(rng, len + 1)),
        3 if len > 0 => {
            let a = below(rng, len);
            let b = (a + 1 + below(rng, 64)).min(len);
            input.drain(a..b);
        }
        4 if len > 0 => {
            let a = below(rng, len);
            let b = (a + 1 + below(rng, 256)).min(len);
            let chunk = input[a..b].to_vec();
            let at = below(rng, len + 1);
            input.splice(at..at, chunk);
        }
        5 => {
            let n = below(rng, 64);
            input.extend((0..n).map(|_| rng.next_u64() as u8));
        }
        6 if len > 0 => {
            // Random bytes over a random run.
            let a = below(rng, len);
            let b = (a + 1 + below(rng, 16)).min(len);
            for x in &mut input[a..b] {
                *x = rng.next_u64() as u8;
            }
        }
        _ => {
            let at = below(rng, len + 1);
            input.insert(at, rng.next_u64() as u8);
        }
    }
}

/// Replaces one JSON number or keyword with a hostile value, or breaks its structure.
/// Fields of a cameras.json that `mutate_json` renames away.
const CAMERA_FIELDS: &[&str] = &[
    "\"width\"",
    "\"height\"",
    "\"fx\"",
    "\"fy\"",
    "\"position\"",
    "\"rotation\"",
];

/// Fields of a clip file that `mutate_json` renames away.
const CLIP_FIELDS: &[&str] = &[
    "\"planes\"",
    "\"box\"",
    "\"center\"",
    "\"half_extents\"",
    "\"rotation\"",
    "\"sphere\"",
    "\"radius\"",
    "\"invert\"",
    "\"mode\"",
    "\"weight\"",
    "\"band\"",
];

/// The mutations of a JSON input: a byte-level one a third of the time, else `mutate_json`.
fn json_mutations(fields: &'static [&'static str]) -> impl Fn(&mut Rng, &mut Vec<u8>) {
    move |rng, input| {
        if rng.next_u64() % 3 == 0 {
            mutate_bytes(rng, input)
        } else {
            mutate_json(rng, input, fields)
        }
    }
}

/// Mutates a JSON text: a number replaced by an unusual value, a field renamed away (one of
/// `fields`), deep nesting, or the top array's contents repeated.
fn mutate_json(rng: &mut Rng, input: &mut Vec<u8>, fields: &[&str]) {
    let text = String::from_utf8_lossy(input).into_owned();
    // Token boundaries: runs of number characters.
    let numbers: Vec<(usize, usize)> = {
        let b = text.as_bytes();
        let mut v = Vec::new();
        let mut i = 0;
        while i < b.len() {
            if b[i].is_ascii_digit() || b[i] == b'-' {
                let s = i;
                while i < b.len() && (b[i].is_ascii_digit() || b"-+.eE".contains(&b[i])) {
                    i += 1;
                }
                v.push((s, i));
            } else {
                i += 1;
            }
        }
        v
    };
    let out = match rng.next_u64() % 6 {
        0..=2 if !numbers.is_empty() => {
            let (s, e) = pick(rng, &numbers);
            let value = pick(
                rng,
                &[
                    "0",
                    "-1",
                    "1e309",
                    "-1e309",
                    "4294967295",
                    "4294967296",
                    "16384",
                    "16385",
                    "99999999999999999999",
                    "1.5",
                    "NaN",
                    "null",
                    "\"7\"",
                    "[]",
                    "{}",
                    "1e-45",
                    "18446744073709551612",
                    "18446744073709551615",
                ],
            );
            format!("{}{}{}", &text[..s], value, &text[e..])
        }
        3 => {
            // Drop a field.
            let field = pick(rng, fields);
            text.replacen(field, "\"unused\"", 1)
        }
        4 => {
            let depth = 1 + below(rng, 4000);
            format!("{}{}{}", "[".repeat(depth), text, "]".repeat(depth))
        }
        _ => {
            // Duplicate the array's contents (many cameras).
            let inner = text.trim().trim_start_matches('[').trim_end_matches(']');
            format!("[{inner},{inner},{inner}]")
        }
    };
    *input = out.into_bytes();
}

// ---------------------------------------------------------------- oracles

fn check_scene(scene: &rara::Scene, vertices_in_file: usize) -> Result<(), String> {
    let n = scene.len();
    if n > vertices_in_file {
        return Err(format!("{n} Gaussians from {vertices_in_file} vertices"));
    }
    if scene.opacities.len() != n
        || scene.scales.len() != n
        || scene.rotations.len() != n
        || scene.sh.len() != n * scene.sh_stride()
    {
        return Err("inconsistent array lengths".into());
    }
    for i in 0..n {
        let (m, o, s, q) = (
            scene.means[i],
            scene.opacities[i],
            scene.scales[i],
            scene.rotations[i],
        );
        if !m.is_finite() || !(0.0..=1.0).contains(&o) || !s.is_finite() || s.min_element() < 0.0 {
            return Err(format!(
                "Gaussian {i} is not valid: mean {m}, opacity {o}, scale {s}"
            ));
        }
        if !q.is_finite() || (q.length() - 1.0).abs() > 1e-3 {
            return Err(format!("Gaussian {i}: rotation {q} is not normalised"));
        }
    }
    if scene.sh.iter().any(|v| !v.is_finite()) {
        return Err("non-finite SH".into());
    }
    Ok(())
}

fn check_cameras(cams: &[Camera]) -> Result<(), String> {
    for (i, c) in cams.iter().enumerate() {
        rara::camera::check_size(c.width, c.height).map_err(|e| format!("camera {i}: {e}"))?;
        let valid = c.fx.is_finite()
            && c.fy.is_finite()
            && c.fx > 0.0
            && c.fy > 0.0
            && c.position.is_finite()
            && c.rotation.is_finite();
        if !valid {
            return Err(format!("camera {i} accepted with bad values"));
        }
        // An accepted rotation is one (the parser checks with a tolerance of 1e-3 per entry).
        let gram = c.rotation.transpose() * c.rotation;
        if !gram.abs_diff_eq(glam::Mat3::IDENTITY, 2e-3) || c.rotation.determinant() <= 0.0 {
            return Err(format!(
                "camera {i} accepted with rotation {:?}",
                c.rotation
            ));
        }
    }
    Ok(())
}

/// Runs one target for the configured time; fails on the first bad input.
fn fuzz(
    target: &str,
    seeds: &[(String, Vec<u8>)],
    mutate: impl Fn(&mut Rng, &mut Vec<u8>),
    parse: impl Fn(&[u8]) -> Result<(), String>,
) {
    fuzz_bounded(target, seeds, mutate, parse, allocation_bound)
}

/// [`fuzz`] with the allocation bound `bound` (of the input's length).
fn fuzz_bounded(
    target: &str,
    seeds: &[(String, Vec<u8>)],
    mutate: impl Fn(&mut Rng, &mut Vec<u8>),
    parse: impl Fn(&[u8]) -> Result<(), String>,
    bound: fn(usize) -> usize,
) {
    let budget = seconds();
    let seed = seed();
    let mut rng = Rng::new(seed);
    let start = Instant::now();
    let (mut cases, mut accepted) = (0u64, 0u64);
    let mut errors = std::collections::BTreeMap::<String, u64>::new();
    let (mut slowest, mut largest_ratio, mut largest_any) = (Duration::ZERO, 0f64, 0usize);
    // Unmutated seeds first: every one must load.
    for (name, input) in seeds {
        let (result, _) = tracked(|| parse(input));
        if let Ok(Err(e)) | Err(e) = &result {
            panic!("{target}: seed '{name}' does not parse: {e}");
        }
    }
    while start.elapsed() < budget {
        let (_, base) = &seeds[below(&mut rng, seeds.len())];
        let mut input = base.clone();
        for _ in 0..1 + below(&mut rng, 4) {
            mutate(&mut rng, &mut input);
        }
        let t = Instant::now();
        let (result, largest) = tracked(|| parse(&input));
        slowest = slowest.max(t.elapsed());
        cases += 1;
        let bound = bound(input.len());
        largest_any = largest_any.max(largest);
        if input.len() >= 4096 {
            largest_ratio = largest_ratio.max(largest as f64 / input.len() as f64);
        }
        let failure = match result {
            Err(panic) => Some(format!("panicked: {panic}")),
            Ok(_) if largest > bound => Some(format!(
                "allocated {largest} bytes at once for a {}-byte input (bound {bound})",
                input.len()
            )),
            Ok(Ok(())) => {
                accepted += 1;
                None
            }
            Ok(Err(e)) if e.starts_with("ACCEPTED BAD INPUT") => Some(e),
            Ok(Err(e)) => {
                // Group errors by their message shape: digits and quoted text stripped.
                let mut key = String::new();
                let mut quoted = false;
                for c in e.chars() {
                    if c == '\'' {
                        quoted = !quoted;
                    } else if !quoted && !c.is_ascii_digit() {
                        key.push(c);
                    }
                }
                let key: String = key.chars().take(60).collect();
                *errors.entry(key).or_default() += 1;
                None
            }
        };
        if let Some(why) = failure {
            let path = save_failure(&format!("fuzz_{target}_case_{cases}.bin"), &input);
            panic!(
                "{target}: case {cases} (seed {seed}) {why}; input saved to {}",
                path.display()
            );
        }
    }
    eprintln!(
        "fuzz {target}: {cases} cases in {:.1} s from {} seeds (seed {seed}): {accepted} accepted, \
         {} rejected with {} distinct messages; slowest case {:.1} ms; largest allocation {} bytes, \
         at most {:.2}x the input among inputs of 4 KiB or more",
        start.elapsed().as_secs_f64(),
        seeds.len(),
        cases - accepted,
        errors.len(),
        slowest.as_secs_f64() * 1e3,
        largest_any,
        largest_ratio
    );
    let mut by_count: Vec<_> = errors.iter().collect();
    by_count.sort_by(|a, b| b.1.cmp(a.1));
    for (msg, n) in by_count.into_iter().take(25) {
        eprintln!("  {n:>8}  {msg}");
    }
    assert!(cases > 0);
}

#[test]
fn ply_loader_survives_mutated_headers_and_payloads() {
    let seeds = ply_seeds();
    fuzz(
        "ply",
        &seeds,
        |rng, input| match rng.next_u64() % 4 {
            0 => mutate_header_line(rng, input),
            1 => mutate_payload_value(rng, input),
            _ => mutate_bytes(rng, input),
        },
        |input| {
            let len = input.len() as u64;
            let sized = read_ply(Cursor::new(input), len, Path::new("fuzz.ply"));
            // The same bytes as a stream of unknown length (a pipe) load the same scene, or
            // fail too.
            let streamed = read_ply_stream(Cursor::new(input), Path::new("fuzz.ply"));
            match (sized, streamed) {
                (Ok((scene, report)), Ok((twin, _))) => {
                    if twin != scene {
                        return Err("ACCEPTED BAD INPUT: the streamed scene differs".into());
                    }
                    check_scene(&scene, report.vertices_in_file)
                        .map_err(|e| format!("ACCEPTED BAD INPUT: {e}"))
                }
                (Ok(_), Err(e)) => Err(format!("ACCEPTED BAD INPUT: only streamed fails: {e}")),
                // A stream cannot check counts against a size, so it may fail differently (at
                // the end of the input rather than before reading).
                (Err(e), Ok(_)) if !e.to_string().contains("truncated payload") => Err(format!(
                    "ACCEPTED BAD INPUT: only the sized read fails: {e}"
                )),
                (Err(e), _) => Err(e.to_string()),
            }
        },
    );
}

#[test]
fn cameras_parser_survives_mutated_files() {
    let seeds = camera_seeds();
    fuzz("cameras", &seeds, json_mutations(CAMERA_FIELDS), |input| {
        let text = String::from_utf8_lossy(input);
        match Camera::parse_all(&text, Path::new("fuzz.cameras.json")) {
            Ok(cams) => check_cameras(&cams).map_err(|e| format!("ACCEPTED BAD INPUT: {e}")),
            Err(e) => Err(e.to_string()),
        }
    });
}

fn clip_seeds() -> Vec<(String, Vec<u8>)> {
    [
        ("planes", r#"{"planes": [[1, 0, 0, 0.5], [0, -1, 0, 0.25]], "mode": "rara"}"#),
        (
            "box",
            r#"{"box": {"center": [0, 0.5, 0], "half_extents": [1, 2, 0.5], "rotation": [0.9, 0.1, 0.3, 0.3]}, "invert": true, "weight": "length", "band": 2.5}"#,
        ),
        ("sphere", r#"{"sphere": {"center": [0, 0, 1], "radius": 0.75}, "mode": "hard"}"#),
        ("box and plane", r#"{"planes": [[0, 0, 1, 0]], "box": {"center": [0, 0, 0], "half_extents": [1, 1, 1]}, "trace_all": true}"#),
    ]
    .into_iter()
    .map(|(name, text)| (name.to_string(), text.as_bytes().to_vec()))
    .collect()
}

fn check_clip(clip: &rara::Clip) -> Result<(), String> {
    if !(clip.band.is_finite() && clip.band > 0.0) {
        return Err(format!("band {}", clip.band));
    }
    match clip.region.as_ref().map(|r| &r.shape) {
        Some(rara::clip::ClipShape::HalfSpaces(planes)) => {
            if planes.is_empty() || planes.len() > rara::constants::MAX_CLIP_PLANES as usize {
                return Err(format!("{} half-spaces", planes.len()));
            }
            for p in planes {
                if !p.normal.is_finite()
                    || (p.normal.length() - 1.0).abs() > 1e-4
                    || !p.d.is_finite()
                {
                    return Err(format!("plane {p:?}"));
                }
            }
        }
        Some(rara::clip::ClipShape::Sphere { center, radius })
            if !(center.is_finite() && radius.is_finite() && *radius > 0.0) =>
        {
            return Err(format!("sphere {center} {radius}"));
        }
        Some(rara::clip::ClipShape::Sphere { .. }) => {}
        None => {}
    }
    Ok(())
}

/// Clip files (`--clip FILE.json`): mutated numbers, fields, nesting and bytes are parsed
/// and built, and every accepted clip is one the kernels can take.
#[test]
fn clip_file_parser_survives_mutated_files() {
    let seeds = clip_seeds();
    fuzz("clip", &seeds, json_mutations(CLIP_FIELDS), |input| {
        let text = String::from_utf8_lossy(input);
        let path = Path::new("fuzz.clip.json");
        match ClipFile::parse(&text, path).and_then(ClipFile::into_clip) {
            Ok(clip) => check_clip(&clip).map_err(|e| format!("ACCEPTED BAD INPUT: {e}")),
            Err(e) => Err(e.to_string()),
        }
    });
}

/// `.splat` seeds: a generated scene, and the first 2,000 records of the real plant's
/// original when it is here.
fn splat_seeds() -> Vec<(String, Vec<u8>)> {
    let dir = common::tempdir("fuzz_splat_seed");
    let mut scene = rara::synth::shell(400, 0, 5);
    scene.sh_degree = 0;
    scene.sh = (0..scene.len()).flat_map(|_| [0.3f32, -0.2, 0.1]).collect();
    let path = dir.join("seed.splat");
    rara::formats::splat::write_splat(&scene, &path).unwrap();
    let mut seeds = vec![("generated".to_string(), std::fs::read(&path).unwrap())];
    if let Some(bytes) = common::real_data_dir()
        .map(|d| d.join("originals/plant.splat"))
        .and_then(|p| std::fs::read(p).ok())
    {
        seeds.push((
            "plant".to_string(),
            bytes[..bytes.len().min(2000 * 32)].to_vec(),
        ));
    }
    seeds
}

/// The format detection and the `.splat` reader on mutated files (through a file: the
/// reader works from a path, since the format has no header and its count is the size).
#[test]
fn splat_reader_survives_mutated_files() {
    let seeds = splat_seeds();
    let dir = common::tempdir("fuzz_splat");
    let path = dir.join("fuzz.splat");
    fuzz("splat", &seeds, mutate_bytes, |input| {
        std::fs::write(&path, input).unwrap();
        match rara::formats::load_scene(&path) {
            Ok((scene, report)) => {
                if report.vertices_in_file * 32 != input.len() {
                    return Err(format!(
                        "ACCEPTED BAD INPUT: {} records from {} bytes",
                        report.vertices_in_file,
                        input.len()
                    ));
                }
                check_scene(&scene, report.vertices_in_file)
                    .map_err(|e| format!("ACCEPTED BAD INPUT: {e}"))
            }
            Err(e) => Err(e.to_string()),
        }
    });
}

// ---------------------------------------------------------------- compressed formats

/// The most one parse of a compressed format may allocate at once for `len` bytes of input:
/// its reader inflates at most `MAX_INFLATION` times the input (more is a decompression bomb,
/// refused before it is inflated), and a scene's largest vector takes at most 4 times the bytes
/// of the records it is decoded from (twice, and twice again while a vector grows).
fn inflating_bound(len: usize) -> usize {
    4 * rara::formats::MAX_INFLATION as usize * len + (4 << 20)
}

/// Loads `input` as a file named `name` (the readers of formats with members or an extension
/// to tell them apart work from a path), and checks what it accepts.
fn load_as_file(path: &Path, input: &[u8]) -> Result<(), String> {
    std::fs::write(path, input).unwrap();
    match rara::formats::load_scene(path) {
        Ok((scene, report)) => check_scene(&scene, report.vertices_in_file)
            .map_err(|e| format!("ACCEPTED BAD INPUT: {e}")),
        // Without the path, so that messages group by their shape.
        Err(e) => Err(e.to_string().replace(&path.display().to_string(), "")),
    }
}

fn gzip(bytes: &[u8]) -> Vec<u8> {
    use std::io::Write;
    let mut e = flate2::write::GzEncoder::new(Vec::new(), flate2::Compression::fast());
    e.write_all(bytes).unwrap();
    e.finish().unwrap()
}

fn gunzip(bytes: &[u8]) -> Option<Vec<u8>> {
    use std::io::Read;
    let mut out = Vec::new();
    flate2::read::GzDecoder::new(bytes)
        .take(64 << 20)
        .read_to_end(&mut out)
        .ok()?;
    Some(out)
}

/// Writes a hostile value into a little-endian u32 field at `at`.
fn hostile_u32(rng: &mut Rng, bytes: &mut [u8], at: usize) {
    if at + 4 <= bytes.len() {
        let old = u32::from_le_bytes(bytes[at..at + 4].try_into().unwrap());
        let v = pick(
            rng,
            &[0u32, 1, 2, 3, 4, 5, 255, 0xffff, 0x7fff_ffff, 0xffff_ffff],
        );
        let v = match rng.next_u64() % 3 {
            0 => v,
            1 => old.wrapping_add(1),
            _ => old.wrapping_mul(1 + below(rng, 4096) as u32),
        };
        bytes[at..at + 4].copy_from_slice(&v.to_le_bytes());
    }
}

/// SPZ seeds: splat-transform's v4 and v3 fixtures (SH degree 3), and rara's v4 and v3 of a
/// generated degree-1 scene.
fn spz_seeds() -> Vec<(String, Vec<u8>)> {
    use rara::formats::spz::{encode, SpzAxes, SpzVersion};
    let scene = rara::synth::shell(300, 1, 9);
    vec![
        (
            "splat-transform v4".into(),
            common::format_fixture("st_v4.spz"),
        ),
        (
            "splat-transform v3".into(),
            common::format_fixture("st_v3.spz"),
        ),
        (
            "rara v4".into(),
            encode(&scene, SpzVersion::V4, SpzAxes::Rub).unwrap(),
        ),
        (
            "rara v3".into(),
            encode(&scene, SpzVersion::V3, SpzAxes::Rub).unwrap(),
        ),
    ]
}

/// The mutations of an SPZ: byte-level ones on the file; a header field (version, count, SH
/// degree, fractional bits, flags, the v4 stream count and table offset) set to a hostile value;
/// for v3 the gzip stream's content mutated and compressed again; for v4 a table-of-contents
/// size; and bombs: megabytes of zeros compressed into a few kilobytes, appended to a v3
/// stream or in place of a v4 stream, with the header's count raised to match or not.
fn mutate_spz(rng: &mut Rng, input: &mut Vec<u8>) {
    let gz = input.starts_with(&[0x1f, 0x8b]);
    match rng.next_u64() % 5 {
        0 => mutate_bytes(rng, input),
        1 | 2 if gz => {
            let Some(mut inner) = gunzip(input) else {
                return mutate_bytes(rng, input);
            };
            if rng.next_u64() % 2 == 0 {
                let at = pick(rng, &[4usize, 8, 12]);
                hostile_u32(rng, &mut inner, at);
            } else {
                mutate_bytes(rng, &mut inner);
            }
            *input = gzip(&inner);
        }
        1 => {
            let at = pick(rng, &[4usize, 8, 12, 16]);
            hostile_u32(rng, input, at);
        }
        2 => {
            // A table-of-contents entry's packed or unpacked size (v4).
            if input.len() >= 32 {
                let toc = u32::from_le_bytes(input[16..20].try_into().unwrap()) as usize;
                let streams = input[15] as usize;
                if streams > 0 {
                    let at = toc + 16 * below(rng, streams) + 8 * below(rng, 2);
                    hostile_u32(rng, input, at);
                }
            }
        }
        _ => {
            let zeros = vec![0u8; (1 + below(rng, 8)) << 20];
            if gz {
                let Some(mut inner) = gunzip(input) else {
                    return mutate_bytes(rng, input);
                };
                inner.extend_from_slice(&zeros);
                if rng.next_u64() % 2 == 0 && inner.len() >= 12 {
                    let count = (inner.len() / 20) as u32;
                    inner[8..12].copy_from_slice(&count.to_le_bytes());
                }
                *input = gzip(&inner);
            } else if input.len() >= 32 {
                // Replace the last stream with the zeros, its table entry kept or told the truth.
                let toc = u32::from_le_bytes(input[16..20].try_into().unwrap()) as usize;
                let streams = input[15] as usize;
                let bomb = zstd::encode_all(&zeros[..], 1).unwrap();
                let toc_end = toc + 16 * streams;
                if streams > 0 && toc_end <= input.len() {
                    let last = toc_end - 16;
                    let packed = u64::from_le_bytes(input[last..last + 8].try_into().unwrap());
                    let start = (input.len() as u64).saturating_sub(packed) as usize;
                    input.truncate(start.max(toc_end));
                    input.extend_from_slice(&bomb);
                    input[last..last + 8].copy_from_slice(&(bomb.len() as u64).to_le_bytes());
                    if rng.next_u64() % 2 == 0 {
                        input[last + 8..last + 16]
                            .copy_from_slice(&(zeros.len() as u64).to_le_bytes());
                    }
                }
            }
        }
    }
}

/// The SPZ reader (v2 to v4, gzip and zstd) on mutated files and bombs.
#[test]
fn spz_reader_survives_mutated_files_and_bombs() {
    use rara::formats::spz::{decode, SpzAxes};
    let seeds = spz_seeds();
    fuzz_bounded(
        "spz",
        &seeds,
        mutate_spz,
        |input| match decode(input, Path::new("fuzz.spz"), SpzAxes::Rub) {
            Ok((scene, report)) => check_scene(&scene, report.vertices_in_file)
                .map_err(|e| format!("ACCEPTED BAD INPUT: {e}")),
            Err(e) => Err(e.to_string()),
        },
        inflating_bound,
    );
}

/// The compressed PLY reader on mutated headers, packed words and bytes: splat-transform's
/// fixture (SH degree 3) and its first chunk alone.
#[test]
fn compressed_ply_reader_survives_mutated_files() {
    let whole = common::format_fixture("st.compressed.ply");
    let seeds = vec![("splat-transform".to_string(), whole)];
    let dir = common::tempdir("fuzz_compressed_ply");
    let path = dir.join("fuzz.compressed.ply");
    fuzz(
        "compressed_ply",
        &seeds,
        |rng, input| match rng.next_u64() % 4 {
            0 => mutate_header_line(rng, input),
            1 => mutate_payload_value(rng, input),
            _ => mutate_bytes(rng, input),
        },
        |input| load_as_file(&path, input),
    );
}

/// Fields of a SOG's meta.json that `mutate_json` renames away.
const SOG_FIELDS: &[&str] = &[
    "\"version\"",
    "\"count\"",
    "\"means\"",
    "\"mins\"",
    "\"maxs\"",
    "\"scales\"",
    "\"codebook\"",
    "\"quats\"",
    "\"sh0\"",
    "\"shN\"",
    "\"bands\"",
    "\"files\"",
];

/// The mutations of a SOG bundle: byte-level ones on the zip; meta.json's numbers and fields
/// (`mutate_json`); a WebP member's bytes; a member dropped; a member replaced by a bomb
/// (megabytes of one byte, deflated).
fn mutate_sog(rng: &mut Rng, input: &mut Vec<u8>) {
    let Some(mut members) = common::unzip(input) else {
        return mutate_bytes(rng, input);
    };
    match rng.next_u64() % 5 {
        0 => return mutate_bytes(rng, input),
        1 | 2 => {
            if let Some(meta) = members.iter_mut().find(|(n, _)| n == "meta.json") {
                mutate_json(rng, &mut meta.1, SOG_FIELDS);
            }
        }
        3 if !members.is_empty() => {
            let k = below(rng, members.len());
            if rng.next_u64() % 4 == 0 {
                members.remove(k);
            } else {
                mutate_bytes(rng, &mut members[k].1);
            }
        }
        _ if !members.is_empty() => {
            let k = below(rng, members.len());
            members[k].1 = vec![b'{'; (1 + below(rng, 8)) << 20];
        }
        _ => {}
    }
    *input = common::zip_members(&members);
}

/// The SOG reader (a bundled .sog) on mutated bundles and bombs.
#[test]
fn sog_reader_survives_mutated_bundles_and_bombs() {
    let seeds = vec![(
        "splat-transform".to_string(),
        common::format_fixture("st.sog"),
    )];
    let dir = common::tempdir("fuzz_sog");
    let path = dir.join("fuzz.sog");
    fuzz_bounded(
        "sog",
        &seeds,
        mutate_sog,
        |input| load_as_file(&path, input),
        inflating_bound,
    );
}

/// Fields of a glTF that `mutate_json` renames away.
const GLTF_FIELDS: &[&str] = &[
    "\"accessors\"",
    "\"bufferViews\"",
    "\"buffers\"",
    "\"byteLength\"",
    "\"byteOffset\"",
    "\"count\"",
    "\"componentType\"",
    "\"type\"",
    "\"attributes\"",
    "\"POSITION\"",
    "\"KHR_gaussian_splatting\"",
    "\"KHR_gaussian_splatting:SCALE\"",
    "\"KHR_gaussian_splatting:ROTATION\"",
    "\"meshes\"",
    "\"nodes\"",
];

/// The mutations of a glb: byte-level ones; the JSON's numbers and fields (`mutate_json`, the
/// chunk lengths kept right); the binary chunk's bytes.
fn mutate_glb(rng: &mut Rng, input: &mut Vec<u8>) {
    let Some((mut json, mut bin)) = common::glb_chunks(input) else {
        return mutate_bytes(rng, input);
    };
    match rng.next_u64() % 4 {
        0 => return mutate_bytes(rng, input),
        1 | 2 => mutate_json(rng, &mut json, GLTF_FIELDS),
        _ => mutate_payload_value(rng, &mut bin),
    }
    *input = common::glb_of(&json, &bin);
}

/// The glTF reader (glb) on mutated files: splat-transform's fixture (SH degree 3) and rara's
/// glb of a generated degree-1 scene.
#[test]
fn gltf_reader_survives_mutated_files() {
    let scene = rara::synth::shell(300, 1, 11);
    let seeds = vec![
        (
            "splat-transform".to_string(),
            common::format_fixture("st.glb"),
        ),
        (
            "rara".to_string(),
            rara::formats::gltf::encode_glb(&scene).unwrap(),
        ),
    ];
    let dir = common::tempdir("fuzz_glb");
    let path = dir.join("fuzz.glb");
    fuzz("glb", &seeds, mutate_glb, |input| {
        load_as_file(&path, input)
    });
}

// ---------------------------------------------------------------- meshes and scene files

/// The most one parse of a mesh may allocate at once for `len` bytes of input: a PLY row of
/// one byte becomes a ply-rs record of 72 bytes in a vector that doubles as it grows (144x);
/// an OBJ or glTF face of a few bytes a face vector of 36; and 16 MiB for headers, buffers
/// and a read chunk.
fn mesh_bound(len: usize) -> usize {
    160 * len + (16 << 20)
}

/// The scene the mesh seeds are the octagons of, and its octagons in `format` (`falloff`).
fn octagon_seed(
    scene: &rara::Scene,
    format: rara::mesh::export::MeshFormat,
    falloff: rara::mesh::export::Falloff,
) -> Vec<u8> {
    let options = rara::mesh::export::ExportOptions {
        falloff,
        ..Default::default()
    };
    let mut out = Vec::new();
    rara::mesh::export::export_mesh_to(
        scene,
        &mut out,
        Path::new("seed.obj"),
        format,
        &options,
        &mut |_, _| {},
    )
    .unwrap();
    out
}

/// The scene the mesh fuzzers' octagons come from.
fn mesh_scene() -> rara::Scene {
    rara::synth::shell(60, 1, 21).flattened()
}

/// Reads the mesh at `path` (holding `input`) and, when it is accepted, runs what follows a
/// read: the octagon import against `original`, and a mixed scene's triangles. None may
/// panic; an accepted mesh's faces must name its vertices or be refused by what follows.
fn read_mesh_file(path: &Path, input: &[u8], original: &rara::Scene) -> Result<(), String> {
    std::fs::write(path, input).unwrap();
    let shown = path.display().to_string();
    let mesh =
        rara::mesh::import::read_mesh(path).map_err(|e| e.to_string().replace(&shown, ""))?;
    if mesh
        .primitive_ids
        .as_ref()
        .is_some_and(|p| p.len() != mesh.positions.len())
        || mesh
            .normals
            .as_ref()
            .is_some_and(|n| n.len() != mesh.positions.len())
    {
        return Err("ACCEPTED BAD INPUT: per-vertex arrays of other lengths".into());
    }
    let imported = rara::mesh::import::import_mesh(
        &mesh,
        original,
        &rara::mesh::import::ImportOptions::default(),
        path,
    );
    if let Ok((scene, _)) = &imported {
        check_scene(scene, original.len()).map_err(|e| format!("ACCEPTED BAD INPUT: {e}"))?;
    }
    // No material given: a glTF's own are read too (and their images decoded).
    let triangles = rara::mixed::mesh_triangles(
        path,
        &rara::mixed::Transform::default(),
        None,
        &mut Vec::new(),
        &mut Vec::new(),
    );
    match (imported, triangles) {
        (Ok(_), _) | (_, Ok(_)) => Ok(()),
        (Err(e), _) => Err(e.to_string().replace(&shown, "")),
    }
}

/// Rewrites one line of an OBJ: a number made hostile, a face cut to one or two vertices or
/// given hostile indices, a line repeated or dropped, a material library that never ends.
fn mutate_obj_line(rng: &mut Rng, input: &mut Vec<u8>) {
    let text = String::from_utf8_lossy(input).into_owned();
    let mut lines: Vec<String> = text.lines().map(str::to_string).collect();
    if lines.is_empty() {
        return;
    }
    let i = below(rng, lines.len());
    match rng.next_u64() % 7 {
        0 => {
            let mut parts: Vec<String> = lines[i].split(' ').map(str::to_string).collect();
            let k = below(rng, parts.len());
            parts[k] = pick(
                rng,
                &[
                    "nan",
                    "inf",
                    "-1",
                    "0",
                    "4294967296",
                    "1e39",
                    "-0",
                    "1/1/1",
                    "x",
                    "",
                ],
            )
            .to_string();
            lines[i] = parts.join(" ");
        }
        1 => {
            let face = pick(
                rng,
                &[
                    "f 1",
                    "f 1 2",
                    "f 1/1 2/2",
                    "f 0 1 2",
                    "f -99 1 2",
                    "f 1 1 1",
                    "f 4294967295 1 2",
                ],
            );
            lines.insert(i, face.to_string());
        }
        2 => {
            let n = 3 + below(rng, 2000);
            let face: Vec<String> = (0..n).map(|k| (1 + k % 8).to_string()).collect();
            lines.insert(i, format!("f {}", face.join(" ")));
        }
        3 => {
            lines.remove(i);
        }
        4 => {
            let l = lines[i].clone();
            lines.insert(i, l);
        }
        5 => lines.insert(
            i,
            pick(
                rng,
                &[
                    "mtllib /dev/zero",
                    "o other",
                    "g g",
                    "usemtl x",
                    "l 1 2",
                    "p 1",
                ],
            )
            .into(),
        ),
        _ => {
            let j = below(rng, lines.len());
            lines.swap(i, j);
        }
    }
    *input = (lines.join("\n") + "\n").into_bytes();
}

/// The OBJ reader, and the import and the triangles after it, on mutated octagon meshes (both
/// falloffs) and the example meshes.
#[test]
fn obj_mesh_reader_survives_mutated_files() {
    use rara::mesh::export::{Falloff, MeshFormat};
    let scene = mesh_scene();
    let example = |name: &str| {
        std::fs::read(
            Path::new(env!("CARGO_MANIFEST_DIR"))
                .join("examples/scenes/meshes")
                .join(name),
        )
        .unwrap()
    };
    let seeds = vec![
        (
            "octagons".to_string(),
            octagon_seed(&scene, MeshFormat::Obj, Falloff::Constant),
        ),
        (
            "octagons, centre".to_string(),
            octagon_seed(&scene, MeshFormat::Obj, Falloff::Centre),
        ),
        ("cube".to_string(), example("cube.obj")),
        ("quad".to_string(), example("quad.obj")),
    ];
    let path = common::tempdir("fuzz_obj").join("fuzz.obj");
    fuzz_bounded(
        "obj_mesh",
        &seeds,
        |rng, input| match rng.next_u64() % 3 {
            0 => mutate_bytes(rng, input),
            _ => mutate_obj_line(rng, input),
        },
        |input| read_mesh_file(&path, input, &scene),
        mesh_bound,
    );
}

/// The PLY mesh reader on mutated headers (counts, types, lists, extra elements), payload
/// values and bytes: rara's octagon PLY and an ascii mesh another tool might write.
#[test]
fn ply_mesh_reader_survives_mutated_files() {
    use rara::mesh::export::{Falloff, MeshFormat};
    let scene = mesh_scene();
    let ascii = b"ply\nformat ascii 1.0\nelement vertex 4\nproperty float x\nproperty float y\n\
property float z\nelement face 2\nproperty list uchar int vertex_indices\nend_header\n\
0 0 0\n1 0 0\n0 1 0\n1 1 0\n3 0 1 2\n3 2 1 3\n"
        .to_vec();
    let seeds = vec![
        (
            "octagons".to_string(),
            octagon_seed(&scene, MeshFormat::Ply, Falloff::Constant),
        ),
        (
            "octagons, centre".to_string(),
            octagon_seed(&scene, MeshFormat::Ply, Falloff::Centre),
        ),
        ("ascii quad".to_string(), ascii),
    ];
    let path = common::tempdir("fuzz_ply_mesh").join("fuzz.ply");
    fuzz_bounded(
        "ply_mesh",
        &seeds,
        |rng, input| match rng.next_u64() % 4 {
            0 => mutate_header_line(rng, input),
            1 => mutate_payload_value(rng, input),
            _ => mutate_bytes(rng, input),
        },
        |input| read_mesh_file(&path, input, &scene),
        mesh_bound,
    );
}

/// URIs a mutated glTF may name: beside it, outside it, a device, a FIFO, escapes.
const HOSTILE_URIS: &[&str] = &[
    "fuzz.bin",
    "zero.bin",
    "fifo.bin",
    "missing.bin",
    "../fuzz.bin",
    "/dev/zero",
    "%2e%2e/fuzz.bin",
    "%zz",
    "file:///etc/passwd",
    "sub/../fuzz.bin",
    "data:application/octet-stream;base64,AAAA",
    "data:,x",
    "",
];

/// Structural mutations of a glTF's JSON: a node made its own child or an ancestor's, a child
/// listed twice, a chain deeper than the walk allows, a mesh or accessor index out of range, a
/// hostile buffer URI, another primitive mode, a stride, an offset near 2^64, a sparse
/// accessor, many nodes placing one mesh.
fn mutate_gltf_structure(rng: &mut Rng, json: &mut Vec<u8>) {
    use serde_json::{json, Value};
    let Ok(mut v) = serde_json::from_slice::<Value>(json) else {
        return;
    };
    // Sets `field` of the object at `pointer`, when there is one (a mutated file may have
    // anything there).
    fn set(v: &mut Value, pointer: &str, field: &str, value: Value) {
        if let Some(o) = v.pointer_mut(pointer).and_then(Value::as_object_mut) {
            o.insert(field.to_string(), value);
        }
    }
    let len = |v: &Value, key: &str| v.get(key).and_then(Value::as_array).map_or(0, Vec::len);
    let nodes = len(&v, "nodes");
    match rng.next_u64() % 10 {
        0 if nodes > 0 => {
            let k = below(rng, nodes);
            let child = below(rng, nodes + 1);
            set(
                &mut v,
                &format!("/nodes/{k}"),
                "children",
                json!([child, child]),
            );
        }
        1 if nodes > 0 => {
            let k = below(rng, nodes);
            set(&mut v, &format!("/nodes/{k}"), "children", json!([k]));
        }
        2 => {
            let depth = pick(rng, &[64usize, 100, 4096, 4097, 5000]);
            let chain: Vec<Value> = (0..depth)
                .map(|i| {
                    if i + 1 < depth {
                        json!({"children": [i + 1]})
                    } else {
                        json!({"mesh": 0})
                    }
                })
                .collect();
            set(&mut v, "", "nodes", json!(chain));
            set(&mut v, "", "scenes", json!([{"nodes": [0]}]));
            set(&mut v, "", "scene", json!(0));
        }
        3 if nodes > 0 => {
            let k = below(rng, nodes);
            let mesh = pick(rng, &[0u64, 1, 7, u32::MAX as u64]);
            set(&mut v, &format!("/nodes/{k}"), "mesh", json!(mesh));
        }
        4 => set(&mut v, "/buffers/0", "uri", json!(pick(rng, HOSTILE_URIS))),
        5 => set(
            &mut v,
            "/meshes/0/primitives/0",
            "mode",
            json!(below(rng, 8)),
        ),
        6 => {
            let stride = pick(rng, &[0u64, 3, 4, 12, 252, 256]);
            set(&mut v, "/bufferViews/0", "byteStride", json!(stride));
        }
        7 => {
            let count = len(&v, "accessors");
            if count > 0 {
                let k = below(rng, count);
                let field = pick(rng, &["byteOffset", "count", "bufferView"]);
                let value = pick(rng, &[u64::MAX - 3, 1 << 62, 1 << 31, 0, 1]);
                set(&mut v, &format!("/accessors/{k}"), field, json!(value));
            }
        }
        8 => set(
            &mut v,
            "/accessors/0",
            "sparse",
            json!({"count": 1,
                "indices": {"bufferView": 0, "componentType": 5125},
                "values": {"bufferView": 0}}),
        ),
        _ => {
            // At most 64 placements: instancing multiplies what a file holds by design, bounded
            // by the placement limits (tests/hostile.rs), not by the input's size as here.
            let n = pick(rng, &[2usize, 16, 64]);
            let mut list = vec![json!({"children": (1..=n).collect::<Vec<_>>()})];
            list.extend((0..n).map(|_| json!({"mesh": 0})));
            set(&mut v, "", "nodes", json!(list));
            set(&mut v, "", "scenes", json!([{"nodes": [0]}]));
            set(&mut v, "", "scene", json!(0));
        }
    }
    *json = serde_json::to_vec(&v).unwrap();
}

/// A glTF fuzz input: its JSON and its binary chunk, mutated.
fn mutate_gltf_mesh(rng: &mut Rng, input: &mut Vec<u8>) {
    let Some((mut json, mut bin)) = common::glb_chunks(input) else {
        return mutate_bytes(rng, input);
    };
    match rng.next_u64() % 6 {
        0 => return mutate_bytes(rng, input),
        1 | 2 => mutate_json(rng, &mut json, GLTF_FIELDS),
        3 | 4 => mutate_gltf_structure(rng, &mut json),
        _ => mutate_payload_value(rng, &mut bin),
    }
    *input = common::glb_of(&json, &bin);
}

/// The folder of the glTF mesh fuzzers, with a device and a FIFO beside the file for URIs to
/// name (a reader that opened the FIFO would wait forever: the test would hang).
fn gltf_fuzz_dir(name: &str) -> std::path::PathBuf {
    let dir = common::tempdir(name);
    common::endless_files(&dir, "bin");
    dir
}

/// The glb mesh reader, and what follows it, on mutated octagon glbs (constant alpha, and the
/// falloff texture).
#[test]
fn glb_mesh_reader_survives_mutated_files() {
    use rara::mesh::export::{Falloff, MeshFormat};
    let scene = mesh_scene();
    let seeds = vec![
        (
            "octagons".to_string(),
            octagon_seed(&scene, MeshFormat::Glb, Falloff::Constant),
        ),
        (
            "octagons, texture".to_string(),
            octagon_seed(&scene, MeshFormat::Glb, Falloff::Texture),
        ),
    ];
    let path = gltf_fuzz_dir("fuzz_glb_mesh").join("fuzz.glb");
    fuzz_bounded(
        "glb_mesh",
        &seeds,
        mutate_gltf_mesh,
        |input| read_mesh_file(&path, input, &scene),
        mesh_bound,
    );
}

/// A `.gltf` whose buffer is a file beside it: the input carries the JSON and the buffer's
/// bytes (as a glb's two chunks); each is mutated, the JSON structurally too (its URI made
/// hostile among the rest), and written as `fuzz.gltf` and `fuzz.bin`.
#[test]
fn gltf_with_external_buffers_survives_mutated_files() {
    use rara::mesh::export::{Falloff, MeshFormat};
    let scene = mesh_scene();
    let glb = octagon_seed(&scene, MeshFormat::Glb, Falloff::Constant);
    let (json, bin) = common::glb_chunks(&glb).unwrap();
    let mut v: serde_json::Value = serde_json::from_slice(&json).unwrap();
    v["buffers"][0]["uri"] = serde_json::json!("fuzz.bin");
    let seeds = vec![(
        "octagons, external buffer".to_string(),
        common::glb_of(&serde_json::to_vec(&v).unwrap(), &bin),
    )];
    let dir = gltf_fuzz_dir("fuzz_gltf_external");
    let (gltf, buffer) = (dir.join("fuzz.gltf"), dir.join("fuzz.bin"));
    fuzz_bounded(
        "gltf_external",
        &seeds,
        mutate_gltf_mesh,
        |input| {
            let Some((json, bin)) = common::glb_chunks(input) else {
                return Err("no chunks".into());
            };
            std::fs::write(&buffer, bin).unwrap();
            read_mesh_file(&gltf, &json, &scene)
        },
        mesh_bound,
    );
}

/// Fields of a scene file that `mutate_json` renames away.
const SCENE_FIELDS: &[&str] = &[
    "\"splats\"",
    "\"meshes\"",
    "\"lights\"",
    "\"path\"",
    "\"transform\"",
    "\"material\"",
    "\"translation\"",
    "\"scale\"",
    "\"rotation_deg\"",
    "\"clip\"",
    "\"planes\"",
    "\"point\"",
    "\"intensity\"",
    "\"max_depth\"",
];

/// Paths a mutated scene file may name.
const HOSTILE_PATHS: &[&str] = &[
    "s.ply",
    "quad.obj",
    "cube.obj",
    "tri.gltf",
    "cycle.gltf",
    "zero.obj",
    "fifo.obj",
    "/dev/zero",
    "missing.ply",
    "../s.ply",
    "$REAL/missing.ply",
    ".",
    "",
];

/// The scene file reader with every file it names (real loads of a small scene and meshes,
/// and of hostile paths: a device, a FIFO, a node cycle, missing files).
#[test]
fn scene_file_loader_survives_mutated_files() {
    use rara::mixed::{file::SceneFile, MixedScene};
    let dir = common::tempdir("fuzz_scene_file");
    rara::ply::write_ply(
        &rara::synth::shell(40, 1, 2),
        dir.join("s.ply"),
        rara::ply::PlyEncoding::BinaryLittleEndian,
    )
    .unwrap();
    let meshes = Path::new(env!("CARGO_MANIFEST_DIR")).join("examples/scenes/meshes");
    for m in ["quad.obj", "cube.obj"] {
        std::fs::copy(meshes.join(m), dir.join(m)).unwrap();
    }
    let tri = |nodes: serde_json::Value| {
        let data: Vec<u8> = [0f32, 0., 0., 1., 0., 0., 0., 1., 0.]
            .iter()
            .flat_map(|f| f.to_le_bytes())
            .collect();
        use base64::Engine;
        serde_json::json!({"asset": {"version": "2.0"}, "scene": 0, "scenes": [{"nodes": [0]}],
            "nodes": nodes, "meshes": [{"primitives": [{"attributes": {"POSITION": 0}}]}],
            "buffers": [{"byteLength": 36, "uri": format!("data:application/octet-stream;base64,{}",
                base64::engine::general_purpose::STANDARD.encode(&data))}],
            "bufferViews": [{"buffer": 0, "byteLength": 36}],
            "accessors": [{"bufferView": 0, "componentType": 5126, "count": 3, "type": "VEC3"}]})
        .to_string()
    };
    std::fs::write(dir.join("tri.gltf"), tri(serde_json::json!([{"mesh": 0}]))).unwrap();
    std::fs::write(
        dir.join("cycle.gltf"),
        tri(serde_json::json!([{"mesh": 0, "children": [0]}])),
    )
    .unwrap();
    common::endless_files(&dir, "obj");
    let seed = serde_json::json!({
        "splats": [{"path": "s.ply", "transform": {"translation": [0, 0, 1], "rotation_deg": [0, 30, 0], "scale": 1.5},
                    "clip": {"planes": [[1, 0, 0, 0]]}}],
        "meshes": [{"path": "quad.obj", "transform": {"translation": [0, 0, 2], "scale": [2, 1, 1]},
                    "material": {"mirror": {"reflectance": 0.9}}},
                   {"path": "tri.gltf", "material": {"glass": {"ior": 1.5}}},
                   {"path": "cube.obj", "material": {"diffuse": {"color": [0.5, 0.5, 0.5]}}}],
        "lights": [{"point": {"position": [0, -2, 0], "intensity": [4, 4, 4]}},
                   {"directional": {"direction": [0, 1, 0], "intensity": [1, 1, 1]}}],
        "ambient": [0.2, 0.2, 0.2], "background": [0, 0, 0], "max_depth": 8, "shadow_strength": 0.75
    });
    let seeds = vec![(
        "showcase".to_string(),
        serde_json::to_vec_pretty(&seed).unwrap(),
    )];
    let file = dir.join("scene.json");
    fuzz(
        "scene_file",
        &seeds,
        |rng, input| match rng.next_u64() % 4 {
            0 => mutate_bytes(rng, input),
            1 => {
                // A path made hostile.
                let text = String::from_utf8_lossy(input).into_owned();
                let from = pick(
                    rng,
                    &["\"s.ply\"", "\"quad.obj\"", "\"tri.gltf\"", "\"cube.obj\""],
                );
                let to = format!("\"{}\"", pick(rng, HOSTILE_PATHS));
                *input = text.replacen(from, &to, 1).into_bytes();
            }
            _ => mutate_json(rng, input, SCENE_FIELDS),
        },
        |input| {
            let shown = file.display().to_string();
            let text = std::str::from_utf8(input).map_err(|e| e.to_string())?;
            let parsed =
                SceneFile::parse(text, &file).map_err(|e| e.to_string().replace(&shown, ""))?;
            let scene = MixedScene::from_file(parsed, &file, |p| {
                rara::formats::load_scene(p).map(|(s, _)| s)
            })
            .map_err(|e| e.to_string().replace(&shown, ""))?;
            scene
                .validate()
                .map_err(|e| format!("ACCEPTED BAD INPUT: {e}"))?;
            check_scene(&scene.gaussians, usize::MAX)
                .map_err(|e| format!("ACCEPTED BAD INPUT: {e}"))
        },
    );
}
