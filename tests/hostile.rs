//! Hostile and unusual input, third round (issue 69): the readers and commands added since the
//! second round, one test per class of failure the held-out campaign found, each reaching every
//! reader and command the class can reach.
//!
//! - arithmetic on untrusted offsets (a glTF accessor's `byteOffset` near 2^64) is checked, in
//!   the splat reader and the mesh reader alike;
//! - memory is bounded in the mesh path as in the scene path: node cycles and multiplying paths,
//!   `/dev/zero` and FIFOs as mesh files or buffer URIs, one mesh placed by many nodes;
//! - a FIFO is opened once, whatever its format;
//! - invalid input is refused (SPZ v3's gzip trailer and count, OBJ faces of one or two
//!   vertices) and valid input read (`mesh export` of any format, deep node chains, triangle
//!   strips and fans);
//! - every command leaves no output when it fails: a full disk, a bad frame, bad cameras, a
//!   failing depth file, a process killed half-way.
//!
//! Commands that could take unbounded memory run under an address-space limit (`ulimit -v`), and
//! every command under a watchdog: a hang or an abort fails the test rather than the machine.

mod common;

use std::path::{Path, PathBuf};
use std::process::{Command, Output, Stdio};
use std::time::{Duration, Instant};

use common::{assert_error, assert_success, glb_chunks, glb_of, mkfifo, rara};
use serde_json::{json, Value};

/// A fresh folder for one test.
fn case_dir(name: &str) -> PathBuf {
    let d = common::tempdir("hostile").join(name);
    std::fs::remove_dir_all(&d).ok();
    std::fs::create_dir_all(&d).unwrap();
    d
}

fn s(p: &Path) -> &str {
    p.to_str().unwrap()
}

/// The names in `dir`, sorted.
fn entries(dir: &Path) -> Vec<String> {
    let mut v: Vec<String> = std::fs::read_dir(dir)
        .unwrap()
        .map(|e| e.unwrap().file_name().to_string_lossy().into_owned())
        .collect();
    v.sort();
    v
}

/// Runs `cmd` to its end, failing the test if it takes longer than `secs` (a hang).
fn run_with_timeout(mut cmd: Command, secs: u64) -> Output {
    let mut child = cmd
        .stdout(Stdio::piped())
        .stderr(Stdio::piped())
        .spawn()
        .expect("spawn");
    let start = Instant::now();
    loop {
        if child.try_wait().unwrap().is_some() {
            return child.wait_with_output().unwrap();
        }
        if start.elapsed() > Duration::from_secs(secs) {
            child.kill().ok();
            let out = child.wait_with_output().unwrap();
            panic!(
                "hung for {secs} s: {cmd:?}\nstderr: {}",
                String::from_utf8_lossy(&out.stderr)
            );
        }
        std::thread::sleep(Duration::from_millis(20));
    }
}

/// `rara args` under an address-space limit of `kib` KiB (bash's `ulimit -v`) and a watchdog:
/// a reader that allocates without bound fails with an abort here, not the machine.
fn rara_capped(kib: u64, args: &[&str]) -> Output {
    let mut cmd = Command::new("bash");
    cmd.arg("-c")
        .arg("ulimit -v \"$1\"; shift; exec \"$@\"")
        .arg("rara")
        .arg(kib.to_string())
        .arg(env!("CARGO_BIN_EXE_rara"))
        .args(args);
    run_with_timeout(cmd, 120)
}

/// Writes `bytes` into the FIFO `path` from another thread: it opens it once a reader has
/// (polling, for at most 60 s, so that a reader that never comes cannot hang the test),
/// writes everything and closes it at once, as `cat file > fifo` does.
fn feed_fifo(path: &Path, bytes: Vec<u8>) -> std::thread::JoinHandle<()> {
    use std::io::Write;
    use std::os::unix::fs::OpenOptionsExt;
    let path = path.to_path_buf();
    std::thread::spawn(move || {
        let start = Instant::now();
        let mut file = loop {
            // Without a reader, a non-blocking open for writing fails with ENXIO.
            match std::fs::OpenOptions::new()
                .write(true)
                .custom_flags(libc::O_NONBLOCK)
                .open(&path)
            {
                Ok(f) => break f,
                Err(_) if start.elapsed() < Duration::from_secs(60) => {
                    std::thread::sleep(Duration::from_millis(5))
                }
                Err(_) => return,
            }
        };
        // Blocking writes from here on.
        use std::os::fd::AsRawFd;
        let fd = file.as_raw_fd();
        // SAFETY: fcntl on a descriptor this thread owns.
        unsafe {
            libc::fcntl(
                fd,
                libc::F_SETFL,
                libc::fcntl(fd, libc::F_GETFL) & !libc::O_NONBLOCK,
            )
        };
        // A reader that refuses the data early closes its end: the writer then gets EPIPE,
        // which is fine here.
        let _ = file.write_all(&bytes);
    })
}

/// A small scene as PLY at `path`.
fn scene_ply(path: &Path, count: usize, degree: u32) -> rara::Scene {
    let scene = rara::synth::shell(count, degree, 5);
    rara::ply::write_ply(&scene, path, rara::ply::PlyEncoding::BinaryLittleEndian).unwrap();
    scene
}

fn base64(bytes: &[u8]) -> String {
    use base64::Engine;
    base64::engine::general_purpose::STANDARD.encode(bytes)
}

/// The bytes of `n` f32 triples.
fn floats(v: &[[f32; 3]]) -> Vec<u8> {
    v.iter().flatten().flat_map(|f| f.to_le_bytes()).collect()
}

/// A glTF of one triangle mesh (its vertices `positions`, in a base64 buffer unless `uri` names
/// a file), placed by `nodes` under a scene of `roots`.
fn mesh_gltf(positions: &[[f32; 3]], uri: Option<&str>, nodes: Value, roots: Value) -> Value {
    let data = floats(positions);
    let uri = uri.map_or_else(
        || format!("data:application/octet-stream;base64,{}", base64(&data)),
        str::to_string,
    );
    json!({
        "asset": {"version": "2.0"},
        "scene": 0,
        "scenes": [{"nodes": roots}],
        "nodes": nodes,
        "meshes": [{"primitives": [{"attributes": {"POSITION": 0}}]}],
        "buffers": [{"byteLength": data.len(), "uri": uri}],
        "bufferViews": [{"buffer": 0, "byteLength": data.len()}],
        "accessors": [{"bufferView": 0, "componentType": 5126, "count": positions.len(), "type": "VEC3"}]
    })
}

const TRIANGLE: [[f32; 3]; 3] = [[0.0, 0.0, 0.0], [1.0, 0.0, 0.0], [0.0, 1.0, 0.0]];

/// rara's glb of `scene`, its JSON changed by `edit`.
fn edited_glb(scene: &rara::Scene, edit: impl FnOnce(&mut Value)) -> Vec<u8> {
    let glb = rara::formats::gltf::encode_glb(scene).unwrap();
    let (json, bin) = glb_chunks(&glb).unwrap();
    let mut v: Value = serde_json::from_slice(&json).unwrap();
    edit(&mut v);
    glb_of(&serde_json::to_vec(&v).unwrap(), &bin)
}

/// A scene file that places `mesh` (a path beside it), diffuse.
fn scene_file_with_mesh(dir: &Path, mesh: &str) -> PathBuf {
    let p = dir.join("scene.json");
    let v = json!({"meshes": [{"path": mesh, "material": {"diffuse": {"color": [1, 1, 1]}}}]});
    std::fs::write(&p, v.to_string()).unwrap();
    p
}

/// The arguments of `rara mesh import MESH --original ORIGINAL -o OUT`.
fn import_args<'a>(mesh: &'a Path, original: &'a Path, out: &'a Path) -> [&'a str; 7] {
    [
        "mesh",
        "import",
        s(mesh),
        "--original",
        s(original),
        "-o",
        s(out),
    ]
}

/// `rara render --scene` of `scene_file` from a fixed camera, to `dir/out.png`.
fn render_scene_file(dir: &Path, scene_file: &Path) -> Output {
    let out = dir.join("out.png");
    rara(&[
        "render",
        "--scene",
        s(scene_file),
        "--eye",
        "0,0,-3",
        "--target",
        "0,0,0",
        "--width",
        "32",
        "-o",
        s(&out),
    ])
}

/// An offset, count or length near 2^64 in a glTF, in the splat reader (`info`), the mesh
/// reader (`mesh import`) and a mixed scene's mesh (`render --scene`): an error that names the
/// accessor or view, never a panic (release builds wrap such sums, and slicing then panics).
#[test]
fn gltf_offsets_near_2_64_are_errors_not_panics() {
    let d = case_dir("offsets");
    let original = d.join("s.ply");
    let scene = scene_ply(&original, 50, 0);
    let edits: [(&str, &str, u64, &str); 5] = [
        ("/accessors/0", "byteOffset", u64::MAX - 3, "do not fit"),
        ("/accessors/0", "byteOffset", u64::MAX - 11, "do not fit"),
        ("/accessors/0", "count", 1 << 20, "do not fit"),
        (
            "/bufferViews/0",
            "byteOffset",
            u64::MAX - 7,
            "runs past its buffer",
        ),
        (
            "/bufferViews/0",
            "byteLength",
            u64::MAX,
            "runs past its buffer",
        ),
    ];
    for (at, field, value, message) in edits {
        let what = format!("{at}/{field} = {value}");
        let glb = d.join("splats.glb");
        std::fs::write(
            &glb,
            edited_glb(&scene, |v| v.pointer_mut(at).unwrap()[field] = json!(value)),
        )
        .unwrap();
        let out = rara(&["info", s(&glb)]);
        assert_error(&out, &["glTF", message]);

        let mut mesh = mesh_gltf(&TRIANGLE, None, json!([{"mesh": 0}]), json!([0]));
        mesh.pointer_mut(at).unwrap()[field] = json!(value);
        let gltf = d.join("mesh.gltf");
        std::fs::write(&gltf, mesh.to_string()).unwrap();
        let out = rara(&import_args(&gltf, &original, &d.join("o.ply")));
        assert_error(&out, &["glTF", message]);
        let out = render_scene_file(&d, &scene_file_with_mesh(&d, "mesh.gltf"));
        assert_error(&out, &["meshes[0].path", message]);
        eprintln!("{what}: refused in all three");
    }
    assert!(!d.join("o.ply").exists() && !d.join("out.png").exists());
}

/// A node that is its own child, and 41 nodes each listing the next twice (2^40 paths): the
/// scene reader and the mesh reader refuse both at the first repeated node, within 2 GB of
/// address space, as does a mixed scene.
#[test]
fn node_cycles_and_multiplying_paths_are_refused_within_a_memory_cap() {
    let d = case_dir("nodes");
    let original = d.join("s.ply");
    let scene = scene_ply(&original, 50, 0);
    let cycle = json!([{"mesh": 0, "children": [0]}]);
    let dag = Value::Array(
        (0..41)
            .map(|i| {
                if i < 40 {
                    json!({"mesh": 0, "children": [i + 1, i + 1]})
                } else {
                    json!({"mesh": 0})
                }
            })
            .collect(),
    );
    for (name, nodes) in [("cycle", cycle), ("dag", dag)] {
        let glb = d.join(format!("{name}.glb"));
        let n = nodes.clone();
        std::fs::write(
            &glb,
            edited_glb(&scene, |v| {
                v["nodes"] = n;
                v["scenes"] = json!([{"nodes": [0]}]);
            }),
        )
        .unwrap();
        assert_error(
            &rara_capped(2_000_000, &["info", s(&glb)]),
            &["reached twice"],
        );
        let gltf = d.join(format!("{name}.gltf"));
        std::fs::write(
            &gltf,
            mesh_gltf(&TRIANGLE, None, nodes, json!([0])).to_string(),
        )
        .unwrap();
        assert_error(
            &rara_capped(2_000_000, &import_args(&gltf, &original, &d.join("o.ply"))),
            &["reached twice"],
        );
        let file = scene_file_with_mesh(&d, &format!("{name}.gltf"));
        assert_error(&render_scene_file(&d, &file), &["reached twice"]);
    }
}

/// `/dev/zero` as a mesh file (through a symlink with the format's extension) is refused at
/// the stream cap, within 3 GB of address space; as a glTF buffer URI, or a FIFO there, it is
/// refused before it is opened (a side file must be a regular file), by both glTF readers and
/// a mixed scene. A FIFO that does end is read, once: a mesh imports from one.
#[test]
fn mesh_files_and_buffer_uris_that_never_end_are_refused() {
    let d = case_dir("endless");
    let original = d.join("s.ply");
    let scene = scene_ply(&original, 40, 0);
    let import =
        |mesh: &Path| rara_capped(3_000_000, &import_args(mesh, &original, &d.join("o.ply")));
    for ext in ["obj", "ply", "glb", "gltf"] {
        let zero = d.join(format!("zero.{ext}"));
        std::os::unix::fs::symlink("/dev/zero", &zero).unwrap();
        assert_error(&import(&zero), &["more than 1073741824 bytes from a pipe"]);
    }
    common::endless_files(&d, "bin");
    for uri in ["zero.bin", "fifo.bin"] {
        let gltf = d.join("uri.gltf");
        std::fs::write(
            &gltf,
            mesh_gltf(&TRIANGLE, Some(uri), json!([{"mesh": 0}]), json!([0])).to_string(),
        )
        .unwrap();
        assert_error(&import(&gltf), &[uri, "not a regular file"]);
        let file = scene_file_with_mesh(&d, "uri.gltf");
        assert_error(&render_scene_file(&d, &file), &["not a regular file"]);
        // The splat reader, the same rule.
        let splats = d.join("splats.gltf");
        let glb = rara::formats::gltf::encode_glb(&scene).unwrap();
        let (json, _) = glb_chunks(&glb).unwrap();
        let mut v: Value = serde_json::from_slice(&json).unwrap();
        v["buffers"][0]["uri"] = json!(uri);
        std::fs::write(&splats, v.to_string()).unwrap();
        assert_error(
            &rara_capped(2_000_000, &["info", s(&splats)]),
            &["not a regular file"],
        );
    }
    // A mixed scene's mesh path that is a device or a FIFO.
    let file = scene_file_with_mesh(&d, "zero.obj");
    assert_error(&render_scene_file(&d, &file), &["not a regular file"]);
    // An OBJ through a FIFO that ends: imported, the file opened once.
    let obj = d.join("octagons.obj");
    let out = rara(&["mesh", "export", s(&original), "-o", s(&obj)]);
    assert_success(&out);
    let fifo = d.join("fifo.obj");
    mkfifo(&fifo);
    let writer = feed_fifo(&fifo, std::fs::read(&obj).unwrap());
    let out = import(&fifo);
    writer.join().unwrap();
    assert_success(&out);
    let (back, _) = rara::ply::load_ply(d.join("o.ply")).unwrap();
    assert_eq!(back.len(), scene.len());
}

/// A scene given as a FIFO is opened once in every format: its format is told from the first
/// bytes read through that opening. The writer writes the whole file and closes its end at
/// once, as `cat file > fifo` does; a second opening would wait for a writer that has gone.
#[test]
fn a_fifo_scene_is_opened_once_in_every_format() {
    use rara::formats::spz::{encode, SpzAxes, SpzVersion};
    let d = case_dir("fifo");
    let scene = rara::synth::shell(300, 1, 9);
    let mut ply = Vec::new();
    rara::ply::write_ply_to(
        &scene,
        &mut ply,
        rara::ply::PlyEncoding::BinaryLittleEndian,
        rara::ply::PlyLayout::Inria,
        Path::new("x.ply"),
    )
    .unwrap();
    let mut splat = Vec::new();
    rara::formats::splat::write_splat_to(&scene, &mut splat, Path::new("x.splat")).unwrap();
    let cases: Vec<(&str, Vec<u8>)> = vec![
        ("ply", ply),
        ("spz", encode(&scene, SpzVersion::V4, SpzAxes::Rub).unwrap()),
        (
            "v3.spz",
            encode(&scene, SpzVersion::V3, SpzAxes::Rub).unwrap(),
        ),
        ("glb", rara::formats::gltf::encode_glb(&scene).unwrap()),
        ("splat", splat),
        (
            "compressed.ply",
            common::format_fixture("st.compressed.ply"),
        ),
        ("sog", common::format_fixture("st.sog")),
    ];
    for (ext, bytes) in cases {
        let file = d.join(format!("file.{ext}"));
        std::fs::write(&file, &bytes).unwrap();
        let (want, _) = rara::formats::load_scene(&file).unwrap();
        for round in 0..3 {
            let fifo = d.join(format!("fifo{round}.{ext}"));
            mkfifo(&fifo);
            let writer = feed_fifo(&fifo, bytes.clone());
            let mut cmd = Command::new(env!("CARGO_BIN_EXE_rara"));
            cmd.args(["info", "--json", s(&fifo)]);
            let out = run_with_timeout(cmd, 60);
            writer.join().unwrap();
            assert_success(&out);
            let info: Value = serde_json::from_slice(&out.stdout).unwrap();
            assert_eq!(info["count"], json!(want.len()), "{ext}");
        }
    }
}

/// SPZ v3 is one gzip stream: one whose trailer is cut or whose CRC is wrong, one whose header
/// count is one short of (or past) its payload, and one with bytes after the stream are
/// refused; extension records past the blocks are read past only when the header's flag
/// announces them.
#[test]
fn invalid_spz_v3_streams_are_refused() {
    use rara::formats::spz::{decode, encode, SpzAxes, SpzVersion};
    use std::io::{Read, Write};
    let scene = rara::synth::shell(200, 1, 3);
    let v3 = encode(&scene, SpzVersion::V3, SpzAxes::Rub).unwrap();
    let gunzip = |b: &[u8]| {
        let mut out = Vec::new();
        flate2::read::GzDecoder::new(b)
            .read_to_end(&mut out)
            .unwrap();
        out
    };
    let gzip = |b: &[u8]| {
        let mut e = flate2::write::GzEncoder::new(Vec::new(), flate2::Compression::fast());
        e.write_all(b).unwrap();
        e.finish().unwrap()
    };
    let raw = gunzip(&v3);
    let with_count = |delta: i64| {
        let mut r = raw.clone();
        let n = u32::from_le_bytes(r[8..12].try_into().unwrap()) as i64 + delta;
        r[8..12].copy_from_slice(&(n as u32).to_le_bytes());
        gzip(&r)
    };
    let mut crc = v3.clone();
    let at = crc.len() - 8;
    crc[at] ^= 0xff;
    let mut junk = v3.clone();
    junk.extend_from_slice(b"junk");
    let cases: [(&str, Vec<u8>, &str); 5] = [
        ("cut trailer", v3[..v3.len() - 4].to_vec(), "cut or corrupt"),
        ("wrong CRC", crc, "checksum"),
        (
            "count one short",
            with_count(-1),
            "announces no extension records",
        ),
        ("count one past", with_count(1), "truncated"),
        (
            "bytes after the stream",
            junk,
            "4 bytes follow the gzip stream",
        ),
    ];
    let path = Path::new("x.spz");
    assert_eq!(decode(&v3, path, SpzAxes::Rub).unwrap().0.len(), 200);
    for (what, bytes, message) in cases {
        let e = decode(&bytes, path, SpzAxes::Rub).unwrap_err().to_string();
        assert!(e.contains(message), "{what}: {e}");
    }
    // The same payload with the extension flag set: the extra bytes are records, skipped.
    let mut r = raw.clone();
    r[14] |= 0x2;
    r.extend_from_slice(&[1, 0, 0, 0, 4, 0, 0, 0, 9, 9, 9, 9]);
    let (read, report) = decode(&gzip(&r), path, SpzAxes::Rub).unwrap();
    assert_eq!(read.len(), 200);
    assert!(report.notes.iter().any(|n| n.contains("extension records")));
}

/// An OBJ face of two vertices (which tobj reads as a line) or of one (a point) is an error
/// that names the face, in `mesh import` and in a mixed scene; it is never dropped silently.
#[test]
fn obj_points_and_lines_are_errors() {
    let d = case_dir("obj_faces");
    let original = d.join("s.ply");
    scene_ply(&original, 30, 0);
    let obj = d.join("octagons.obj");
    assert_success(&rara(&["mesh", "export", s(&original), "-o", s(&obj)]));
    let text = std::fs::read_to_string(&obj).unwrap();
    let faces = text.lines().filter(|l| l.starts_with("f ")).count();
    // In the file's own form (position/uv), so that the vertices stay the octagons'.
    for (extra, vertices) in [("f 1/1 2/2\n", 2), ("f 3/3\n", 1)] {
        let bad = d.join("bad.obj");
        std::fs::write(&bad, format!("{text}{extra}")).unwrap();
        let out = rara(&import_args(&bad, &original, &d.join("o.ply")));
        assert_error(&out, &[&format!("face {faces} has {vertices} vertices")]);
        let quad = d.join("quad.obj");
        let extra = extra.replace("/1", "").replace("/2", "").replace("/3", "");
        std::fs::write(
            &quad,
            format!("v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 3\n{extra}"),
        )
        .unwrap();
        let out = render_scene_file(&d, &scene_file_with_mesh(&d, "quad.obj"));
        assert_error(&out, &[&format!("face 1 has {vertices} vertices")]);
    }
    assert!(!d.join("o.ply").exists());
}

/// `mesh export` reads every format rara reads, as its help says: a scene as PLY, SPZ, glb and
/// `.splat` gives the same octagons (the vertex count, and positions within the format's
/// quantisation), the splat-transform fixtures (SOG, compressed PLY) export one octagon per
/// Gaussian that has one, and a PLY from a pipe exports too.
#[test]
fn mesh_export_reads_every_scene_format() {
    use rara::mesh::export::has_octagon;
    let d = case_dir("export_formats");
    let ply = d.join("s.ply");
    let scene = scene_ply(&ply, 400, 1);
    let export = |input: &Path, name: &str| -> rara::mesh::import::MeshData {
        let out = d.join(name);
        assert_success(&rara(&["mesh", "export", s(input), "-o", s(&out)]));
        rara::mesh::import::read_mesh(&out).unwrap()
    };
    let want = export(&ply, "from_ply.ply");
    for ext in ["spz", "glb", "splat"] {
        let converted = d.join(format!("s.{ext}"));
        assert_success(&rara(&["convert", s(&ply), "-o", s(&converted)]));
        let got = export(&converted, &format!("from_{ext}.ply"));
        assert_eq!(got.positions.len(), want.positions.len(), "{ext}");
        let worst = got
            .positions
            .iter()
            .zip(&want.positions)
            .map(|(a, b)| (*a - *b).length())
            .fold(0.0, f64::max);
        // SPZ's centres are 1/4096 apart and its log scales 1/16; .splat keeps both as floats.
        assert!(worst < 0.05, "{ext}: octagon corners {worst} apart");
    }
    for fixture in ["st.sog", "st.compressed.ply", "st_v4.spz", "st.glb"] {
        let path = common::fixtures_dir().join(fixture);
        let (loaded, _) = rara::formats::load_scene(&path).unwrap();
        let octagons = (0..loaded.len())
            .filter(|&i| has_octagon(&loaded, i, rara::mesh::DEFAULT_Q, 0.0))
            .count();
        let mesh = export(&path, &format!("{fixture}.ply"));
        assert_eq!(mesh.positions.len(), 8 * octagons, "{fixture}");
    }
    // From a pipe: loaded once, whole.
    let out_path = d.join("from_pipe.ply");
    let mut child = Command::new(env!("CARGO_BIN_EXE_rara"))
        .args(["mesh", "export", "/dev/stdin", "-o", s(&out_path)])
        .stdin(Stdio::piped())
        .stdout(Stdio::piped())
        .stderr(Stdio::piped())
        .spawn()
        .unwrap();
    let bytes = std::fs::read(&ply).unwrap();
    let mut stdin = child.stdin.take().unwrap();
    let writer = std::thread::spawn(move || {
        use std::io::Write;
        stdin.write_all(&bytes).unwrap();
    });
    let out = child.wait_with_output().unwrap();
    writer.join().unwrap();
    assert_success(&out);
    let piped = rara::mesh::import::read_mesh(&out_path).unwrap();
    assert_eq!(piped.positions, want.positions);
    assert_eq!(want.positions.len(), 8 * scene.len());
}

/// Valid glTF the readers used to refuse: a node chain 100 deep (an undocumented limit of 64
/// refused it; the limit is now 4096, tested at its edge in `rara::input::gltf`), and triangle
/// strips and fans in a mesh.
#[test]
fn deep_node_chains_strips_and_fans_are_read() {
    let d = case_dir("valid_gltf");
    let scene = rara::synth::shell(50, 0, 2);
    let chain = |depth: usize, leaf: Value| {
        Value::Array(
            (0..depth)
                .map(|i| {
                    if i + 1 < depth {
                        json!({"children": [i + 1], "translation": [0.01, 0, 0]})
                    } else {
                        leaf.clone()
                    }
                })
                .collect(),
        )
    };
    let glb = d.join("deep.glb");
    std::fs::write(
        &glb,
        edited_glb(&scene, |v| {
            v["nodes"] = chain(100, json!({"mesh": 0}));
            v["scenes"] = json!([{"nodes": [0]}]);
        }),
    )
    .unwrap();
    let out = rara(&["info", "--json", s(&glb)]);
    assert_success(&out);
    let info: Value = serde_json::from_slice(&out.stdout).unwrap();
    assert_eq!(info["count"], json!(50));
    let gltf = d.join("deep.gltf");
    std::fs::write(
        &gltf,
        mesh_gltf(&TRIANGLE, None, chain(100, json!({"mesh": 0})), json!([0])).to_string(),
    )
    .unwrap();
    let mesh = rara::mesh::import::read_mesh(&gltf).unwrap();
    // 99 translations of 0.01 along x (glTF's axes, as the mesh reader keeps them).
    assert!(
        (mesh.positions[0].x - 0.99).abs() < 1e-4,
        "{}",
        mesh.positions[0]
    );
    assert_eq!(mesh.faces, vec![vec![0, 1, 2]]);

    // Four vertices as a strip (0 1 2, then 2 1 3 to keep the winding) and as a fan (0 1 2,
    // 0 2 3).
    let quad = [
        [0.0, 0.0, 0.0],
        [1.0, 0.0, 0.0],
        [0.0, 1.0, 0.0],
        [1.0, 1.0, 0.0],
    ];
    for (mode, faces) in [
        (5, vec![vec![0, 1, 2], vec![2, 1, 3]]),
        (6, vec![vec![0, 1, 2], vec![0, 2, 3]]),
    ] {
        let mut v = mesh_gltf(&quad, None, json!([{"mesh": 0}]), json!([0]));
        v["meshes"][0]["primitives"][0]["mode"] = json!(mode);
        std::fs::write(&gltf, v.to_string()).unwrap();
        assert_eq!(rara::mesh::import::read_mesh(&gltf).unwrap().faces, faces);
    }
    // Points and lines are no surface: refused by name.
    let mut v = mesh_gltf(&quad, None, json!([{"mesh": 0}]), json!([0]));
    v["meshes"][0]["primitives"][0]["mode"] = json!(1);
    std::fs::write(&gltf, v.to_string()).unwrap();
    let e = rara::mesh::import::read_mesh(&gltf)
        .unwrap_err()
        .to_string();
    assert!(e.contains("Lines, not triangles"), "{e}");
}

/// One mesh placed by a thousand nodes: the vertices, indices (or Gaussians) its nodes place
/// are counted before any is decoded, and past the limit the file is refused at once, within a small
/// address space (the edge itself is tested from both sides in the library's unit tests).
#[test]
fn instancing_is_bounded_before_anything_is_decoded() {
    let d = case_dir("instancing");
    let original = d.join("s.ply");
    scene_ply(&original, 10, 0);
    // 2^17 vertices under 1025 nodes: 2^27 + 2^17 vertices, past 2^27.
    let n = 1usize << 17;
    std::fs::write(d.join("zeros.bin"), vec![0u8; 12 * n]).unwrap();
    let nodes = Value::Array(
        std::iter::once(json!({"children": (1..=1025).collect::<Vec<_>>()}))
            .chain((0..1025).map(|_| json!({"mesh": 0})))
            .collect(),
    );
    let mut v = mesh_gltf(&[], Some("zeros.bin"), nodes.clone(), json!([0]));
    v["buffers"][0]["byteLength"] = json!(12 * n);
    v["bufferViews"][0]["byteLength"] = json!(12 * n);
    v["accessors"][0]["count"] = json!(n);
    let gltf = d.join("instanced.gltf");
    std::fs::write(&gltf, v.to_string()).unwrap();
    let out = rara_capped(1_500_000, &import_args(&gltf, &original, &d.join("o.ply")));
    assert_error(&out, &["place 134348800 vertices in all", "134217728"]);
    // Three vertices and 2^18 indices under 1025 nodes: few vertices, past 2^28 indices.
    let m = 1usize << 18;
    let mut bytes = floats(&TRIANGLE);
    bytes.extend(std::iter::repeat_n(0u8, 4 * m));
    std::fs::write(d.join("indexed.bin"), &bytes).unwrap();
    let mut v = mesh_gltf(&TRIANGLE, Some("indexed.bin"), nodes.clone(), json!([0]));
    v["buffers"][0]["byteLength"] = json!(bytes.len());
    v["bufferViews"] = json!([{"buffer": 0, "byteLength": 36},
        {"buffer": 0, "byteOffset": 36, "byteLength": 4 * m}]);
    v["accessors"]
        .as_array_mut()
        .unwrap()
        .push(json!({"bufferView": 1, "componentType": 5125, "count": m, "type": "SCALAR"}));
    v["meshes"][0]["primitives"][0]["indices"] = json!(1);
    std::fs::write(&gltf, v.to_string()).unwrap();
    let out = rara_capped(1_500_000, &import_args(&gltf, &original, &d.join("o.ply")));
    assert_error(
        &out,
        &["place 268697600 vertex indices in all", "268435456"],
    );
    // Splats: 2^16 Gaussians under 1025 nodes, past the 67,107,840 a scene may have.
    let scene = rara::synth::shell(1 << 16, 0, 4);
    let glb = d.join("instanced.glb");
    std::fs::write(
        &glb,
        edited_glb(&scene, |v| {
            v["nodes"] = nodes;
            v["scenes"] = json!([{"nodes": [0]}]);
        }),
    )
    .unwrap();
    let out = rara_capped(1_500_000, &["info", s(&glb)]);
    assert_error(&out, &["place 67174400 Gaussians in all", "67107840"]);
}

/// A full disk mid-write (the file-size limit, `ulimit -f`): with the signal it raises the
/// process dies, without it the write fails; either way `convert` leaves no partial file (the
/// old file stays as it was) and `mesh export` to OBJ leaves neither the OBJ nor its `.mtl`.
#[test]
fn a_full_disk_leaves_no_partial_file() {
    let d = case_dir("full_disk");
    let input = d.join("in.ply");
    scene_ply(&input, 20000, 3);
    let out_dir = d.join("out");
    std::fs::create_dir_all(&out_dir).unwrap();
    std::fs::write(out_dir.join("old.ply"), b"old").unwrap();
    let limited = |trap: bool, args: &[&str]| {
        let mut cmd = Command::new("bash");
        cmd.arg("-c")
            .arg(format!(
                // No core dump from the signal: it is the point of the test, not a crash.
                "{}ulimit -c 0; ulimit -f 1024; exec \"$@\"",
                if trap { "trap '' XFSZ; " } else { "" }
            ))
            .arg("rara")
            .arg(env!("CARGO_BIN_EXE_rara"))
            .args(args);
        run_with_timeout(cmd, 120)
    };
    for trap in [false, true] {
        let out = limited(
            trap,
            &["convert", s(&input), "-o", s(&out_dir.join("old.ply"))],
        );
        assert!(!out.status.success());
        if trap {
            assert_error(&out, &["File too large"]);
        }
        assert_eq!(std::fs::read(out_dir.join("old.ply")).unwrap(), b"old");
        let out = limited(
            trap,
            &["mesh", "export", s(&input), "-o", s(&out_dir.join("m.obj"))],
        );
        assert!(!out.status.success());
        assert_eq!(entries(&out_dir), ["old.ply"], "trap {trap}");
    }
}

/// `render-sequence` of a folder of garbage, or of a good frame followed by a bad one, and
/// `mesh import` of a folder with a bad frame: no GIF, no PNG, no PLY, and no output folder.
#[test]
fn a_sequence_with_a_bad_frame_leaves_nothing() {
    let d = case_dir("sequence");
    let frames = d.join("frames");
    std::fs::create_dir_all(&frames).unwrap();
    std::fs::write(frames.join("a.ply"), b"garbage").unwrap();
    let seq = d.join("seq");
    let render = || {
        rara(&[
            "render-sequence",
            s(&frames),
            "--eye",
            "0,0,-3",
            "--target",
            "0,0,0",
            "--width",
            "32",
            "-o",
            s(&seq),
        ])
    };
    assert_error(&render(), &["a.ply"]);
    assert!(!seq.exists());
    scene_ply(&frames.join("a.ply"), 100, 0);
    std::fs::write(frames.join("b.ply"), b"ply\nformat ascii 1.0\nend_header\n").unwrap();
    assert_error(&render(), &["b.ply"]);
    assert!(!seq.exists());
    std::fs::remove_file(frames.join("b.ply")).unwrap();
    assert_success(&render());
    // The MP4 too where ffmpeg is installed (scripts/clients.sh installs it).
    let ffmpeg = std::process::Command::new("ffmpeg")
        .arg("-version")
        .output()
        .is_ok();
    let mut want = vec!["a.png", "sequence.gif"];
    if ffmpeg {
        want.push("sequence.mp4");
    }
    assert_eq!(entries(&seq), want);

    // mesh import of a folder: the second frame is not an octagon mesh.
    let meshes = d.join("meshes");
    std::fs::create_dir_all(&meshes).unwrap();
    let original = frames.join("a.ply");
    assert_success(&rara(&[
        "mesh",
        "export",
        s(&original),
        "-o",
        s(&meshes.join("f0.ply")),
    ]));
    std::fs::write(meshes.join("f1.obj"), "v 0 0 0\n").unwrap();
    let imported = d.join("imported");
    let out = rara(&import_args(&meshes, &original, &imported));
    assert_error(&out, &["f1.obj"]);
    assert!(!imported.exists());
}

/// `bake --views` and `flatten` read and size their cameras before anything is written: a bad
/// camera file or `--width 0` leaves no scene; `render --depth /dev/full` leaves no image.
#[test]
fn views_and_depth_are_checked_before_outputs_land() {
    let d = case_dir("views");
    let scene = d.join("s.ply");
    scene_ply(&scene, 200, 0);
    let bad = d.join("bad.json");
    std::fs::write(&bad, "[{\"width\": 0}]").unwrap();
    let good = d.join("good.json");
    let cams = rara::synth::orbit_cameras(2, 3.0, 64, 48, 50.0).unwrap();
    rara::Camera::save_all(&cams, &good).unwrap();
    let baked = d.join("baked.ply");
    let bake = |views: &Path, width: &str| {
        rara(&[
            "bake",
            s(&scene),
            "--clip-plane",
            "1,0,0,0",
            "--views",
            s(views),
            "--width",
            width,
            "-o",
            s(&baked),
        ])
    };
    assert_error(&bake(&bad, "32"), &["bad.json"]);
    assert!(!baked.exists());
    let out = bake(&good, "0");
    assert_eq!(out.status.code(), Some(2), "a usage error");
    assert!(!baked.exists());
    assert_success(&bake(&good, "32"));
    assert!(baked.exists());

    let flat = d.join("flat.ply");
    for width in ["32", "0"] {
        let out = rara(&[
            "flatten",
            s(&scene),
            "--cameras",
            s(if width == "0" { &good } else { &bad }),
            "--width",
            width,
            "-o",
            s(&flat),
        ]);
        assert!(!out.status.success());
        assert!(!flat.exists());
    }

    let png = d.join("out.png");
    let out = rara(&[
        "render",
        s(&scene),
        "--cameras",
        s(&good),
        "--depth",
        "/dev/full",
        "-o",
        s(&png),
    ]);
    assert_error(&out, &["/dev/full"]);
    assert!(!png.exists());
}

/// A process killed while its outputs are prepared or being written leaves no temporary file:
/// they have no name until they are committed.
#[test]
fn a_killed_command_leaves_no_temporary_file() {
    let d = case_dir("killed");
    let scene = d.join("s.ply");
    scene_ply(&scene, 200_000, 3);
    let before = entries(&d);
    for (args, delay_ms) in [
        (
            vec![
                "render",
                s(&scene),
                "--eye",
                "0,0,-3",
                "--target",
                "0,0,0",
                "--width",
                "1280",
            ],
            300,
        ),
        (vec!["convert", s(&scene), "--to", "ply"], 150),
        (vec!["mesh", "export", s(&scene)], 400),
    ] {
        let target = d.join(match args[0] {
            "render" => "out.png",
            "convert" => "out.bin",
            _ => "out.obj",
        });
        let mut child = Command::new(env!("CARGO_BIN_EXE_rara"))
            .args(&args)
            .arg("-o")
            .arg(&target)
            .stdout(Stdio::null())
            .stderr(Stdio::null())
            .spawn()
            .unwrap();
        std::thread::sleep(Duration::from_millis(delay_ms));
        child.kill().ok();
        let status = child.wait().unwrap();
        let after = entries(&d);
        // Either it was killed and left nothing, or it had finished and left its output whole.
        let left: Vec<&String> = after.iter().filter(|n| !before.contains(n)).collect();
        assert!(
            left.iter()
                .all(|n| !n.contains(".tmp") && !n.starts_with('.')),
            "{args:?} ({status}): {left:?}"
        );
        for n in left {
            std::fs::remove_file(d.join(n)).unwrap();
        }
    }
}
