//! Compiles every kernel to SPIR-V with shaderc and embeds the words.
//!
//! A kernel is either a `glsl/*.comp` file that is its own body, or a row of the variant table
//! (`glsl/variants.rs`): a `glsl/*_body.glsl` compiled with a set of defines. The integer
//! constants of `src/constants.rs` are handed to the compiler as macros, so host and kernels
//! share one definition. Each kernel is compiled twice where the two differ: portable, and with
//! `RARA_INT64` for devices with `shaderInt64` (`glsl/common.glsl`). A compile error fails the
//! build with glslang's message. Compiled kernels are cached by their preprocessed text
//! (`SpirvCache`), so a build after editing one body compiles only the kernels that include it.

use std::fmt::Write as _;
use std::path::{Path, PathBuf};

#[allow(dead_code)]
mod constants {
    include!("src/constants.rs");
}

/// One row of the variant table: the module `name`, compiled from `body` with `defines`.
struct Variant {
    /// The kernel's name (`shaders::NAME`), as if it were `glsl/NAME.comp`.
    name: &'static str,
    /// The body it includes, a file of `glsl/`.
    body: &'static str,
    /// Each define as written after `#define`: `NAME` or `NAME VALUE`.
    defines: &'static [&'static str],
    /// What the variant is, in lines (the source's leading comment).
    about: &'static [&'static str],
}

include!("glsl/variants.rs");

impl Variant {
    /// The source a wrapper file `glsl/NAME.comp` would hold, byte for byte.
    fn source(&self) -> String {
        let mut s = String::new();
        for line in self.about {
            writeln!(s, "// {line}").unwrap();
        }
        s.push_str("#version 460\n");
        for d in self.defines {
            writeln!(s, "#define {d}").unwrap();
        }
        writeln!(s, "#include \"{}\"", self.body).unwrap();
        s
    }
}

fn main() {
    let glsl_dir = Path::new("glsl");
    println!("cargo:rerun-if-changed=src/constants.rs");
    println!("cargo:rerun-if-changed=glsl");

    let mut files: Vec<PathBuf> = std::fs::read_dir(glsl_dir)
        .expect("glsl/ directory")
        .map(|e| e.expect("glsl/ entry").path())
        .collect();
    files.sort();
    for path in &files {
        println!("cargo:rerun-if-changed={}", path.display());
    }

    // (name, file name shown in errors and debug info, source), sorted by name.
    let mut kernels: Vec<(String, String, String)> = files
        .iter()
        .filter(|p| p.extension().is_some_and(|e| e == "comp"))
        .map(|path| {
            let name = path.file_stem().unwrap().to_str().unwrap().to_owned();
            let source = std::fs::read_to_string(path).expect("read kernel");
            (name, path.display().to_string(), source)
        })
        .collect();
    for v in VARIANTS {
        assert!(
            glsl_dir.join(v.body).is_file(),
            "variant {}: no body glsl/{}",
            v.name,
            v.body
        );
        assert!(
            kernels.iter().all(|(name, ..)| name != v.name),
            "variant {} is also a file or an earlier row",
            v.name
        );
        let path = glsl_dir.join(format!("{}.comp", v.name));
        kernels.push((v.name.to_owned(), path.display().to_string(), v.source()));
    }
    kernels.sort();

    // Every kernel in two forms (glsl/common.glsl): portable, and with RARA_INT64 for devices
    // with shaderInt64, kept only where the define changes the preprocessed source and the
    // SPIR-V uses 64-bit integers. The
    // kernels compile on every core: shaderc's optimiser takes most of the build.
    let compiler = shaderc::Compiler::new().expect("shaderc compiler");
    // (name, file, source, int64, preprocessed source).
    let jobs: Vec<(&str, &str, &str, bool, String)> = kernels
        .iter()
        .flat_map(|(name, file, source)| {
            let portable = preprocess(&compiler, file, source, false);
            let wide = preprocess(&compiler, file, source, true);
            let int64 = (wide != portable).then_some((name, file, source, true, wide));
            std::iter::once((name, file, source, false, portable)).chain(int64)
        })
        .map(|(name, file, source, int64, text)| {
            (name.as_str(), file.as_str(), source.as_str(), int64, text)
        })
        .collect();
    // SPIR-V already compiled from the same preprocessed text by this build script is taken
    // from the cache (target/<profile>/rara-spirv-cache), so that editing one body recompiles
    // only the kernels that include it. A fresh clone has no cache and compiles everything.
    let out_dir = PathBuf::from(std::env::var("OUT_DIR").unwrap());
    let cache = SpirvCache::beside(&out_dir);
    let threads = std::thread::available_parallelism().map_or(1, |n| n.get());
    let next = std::sync::atomic::AtomicUsize::new(0);
    let mut results: Vec<(usize, Result<Vec<u32>, String>)> = std::thread::scope(|scope| {
        let workers: Vec<_> = (0..threads)
            .map(|_| {
                scope.spawn(|| {
                    let mut done = Vec::new();
                    loop {
                        let i = next.fetch_add(1, std::sync::atomic::Ordering::Relaxed);
                        let Some((_, file, source, int64, text)) = jobs.get(i) else {
                            return done;
                        };
                        let words = cache.get(text, *int64).map(Ok).unwrap_or_else(|| {
                            let words = compile(&compiler, file, source, *int64);
                            if let Ok(w) = &words {
                                cache.put(text, *int64, w);
                            }
                            words
                        });
                        done.push((i, words));
                    }
                })
            })
            .collect();
        workers
            .into_iter()
            .flat_map(|w| w.join().expect("a compile thread panicked"))
            .collect()
    });
    results.sort_by_key(|r| r.0);
    cache.keep_only(
        jobs.iter()
            .map(|(_, _, _, int64, text)| (text.as_str(), *int64)),
    );

    // The words go to OUT_DIR as .spv files, embedded with include_bytes! (a literal of
    // every word made the crate slow to compile), aligned for vkCreateShaderModule.
    let big_endian = std::env::var("CARGO_CFG_TARGET_ENDIAN").is_ok_and(|e| e == "big");
    let mut generated = String::from(
        "// Generated by build.rs: SPIR-V of every kernel.\n\
         #[repr(C, align(4))]\n\
         struct Aligned<const N: usize>([u8; N]);\n\
         const fn words<const N: usize>(bytes: &'static Aligned<N>) -> &'static [u32] {\n\
         \x20   // Safety: 4-byte aligned, N a multiple of 4 (SPIR-V is words).\n\
         \x20   unsafe { std::slice::from_raw_parts(bytes.0.as_ptr().cast::<u32>(), N / 4) }\n\
         }\n",
    );
    let mut failures = Vec::new();
    let mut names = Vec::new();
    let mut int64_forms = Vec::new();
    for ((name, file_name, _, int64, _), (_, result)) in jobs.iter().zip(&results) {
        let words = match result {
            Ok(words) => words,
            Err(e) => {
                failures.push(e.clone());
                continue;
            }
        };
        if *int64 && !declares_int64(words) {
            continue; // the optimiser left no 64-bit integer: the portable form is the same
        }
        let konst = if *int64 {
            int64_forms.push(name.to_uppercase());
            format!("{}_INT64", name.to_uppercase())
        } else {
            names.push(name.to_string());
            name.to_uppercase()
        };
        let spv = format!("{}.spv", konst.to_lowercase());
        let bytes: Vec<u8> = words
            .iter()
            .flat_map(|w| {
                if big_endian {
                    w.to_be_bytes()
                } else {
                    w.to_le_bytes()
                }
            })
            .collect();
        std::fs::write(out_dir.join(&spv), &bytes).unwrap();
        let form = if *int64 { ", with RARA_INT64" } else { "" };
        writeln!(
            generated,
            "const {konst}_SPV: &Aligned<{}> = &Aligned(*include_bytes!(concat!(env!(\"OUT_DIR\"), \"/{spv}\")));\n\
             /// SPIR-V of `{file_name}`{form}.\n\
             pub const {konst}: &[u32] = words({konst}_SPV);",
            bytes.len()
        )
        .unwrap();
    }
    if !failures.is_empty() {
        panic!("GLSL compilation failed:\n{}", failures.join("\n"));
    }
    generated.push_str("/// Every kernel by name, in its portable form.\npub const ALL_KERNELS: &[(&str, &[u32])] = &[");
    for name in &names {
        write!(generated, "(\"{name}\", {}),", name.to_uppercase()).unwrap();
    }
    generated.push_str("];\n");
    generated.push_str(
        "/// Each kernel with a form for devices with shaderInt64: (portable, with RARA_INT64).\n\
         pub const INT64_FORMS: &[(&[u32], &[u32])] = &[",
    );
    for konst in &int64_forms {
        write!(generated, "({konst}, {konst}_INT64),").unwrap();
    }
    generated.push_str("];\n");
    std::fs::write(out_dir.join("kernels.rs"), generated).unwrap();
}

/// The options every kernel compiles with: Vulkan 1.2, SPIR-V 1.5, optimised, with debug
/// information, the constants of src/constants.rs, includes from glsl/, and `RARA_INT64` for the
/// form that uses 64-bit integers.
fn options(int64: bool) -> shaderc::CompileOptions<'static> {
    let mut options = shaderc::CompileOptions::new().unwrap();
    options.set_target_env(
        shaderc::TargetEnv::Vulkan,
        shaderc::EnvVersion::Vulkan1_2 as u32,
    );
    options.set_target_spirv(shaderc::SpirvVersion::V1_5);
    options.set_optimization_level(shaderc::OptimizationLevel::Performance);
    options.set_generate_debug_info();
    for (macro_name, value) in constants::SHADER_DEFINES {
        options.add_macro_definition(macro_name, Some(&value.to_string()));
    }
    if int64 {
        options.add_macro_definition("RARA_INT64", None);
    }
    let dir = Path::new("glsl").to_path_buf();
    options.set_include_callback(move |requested, _ty, _from, _depth| {
        let p = dir.join(requested);
        std::fs::read_to_string(&p)
            .map(|content| shaderc::ResolvedInclude {
                resolved_name: p.display().to_string(),
                content,
            })
            .map_err(|e| format!("{}: {e}", p.display()))
    });
    options
}

/// The kernel's source after the preprocessor (an error's text when it fails: the compile
/// then reports it).
fn preprocess(compiler: &shaderc::Compiler, file_name: &str, source: &str, int64: bool) -> String {
    match compiler.preprocess(source, file_name, "main", Some(&options(int64))) {
        Ok(artifact) => artifact.as_text(),
        Err(e) => e.to_string(),
    }
}

/// A kernel's SPIR-V words, or glslang's message; warnings go to cargo.
fn compile(
    compiler: &shaderc::Compiler,
    file_name: &str,
    source: &str,
    int64: bool,
) -> Result<Vec<u32>, String> {
    let form = if int64 { " (RARA_INT64)" } else { "" };
    match compiler.compile_into_spirv(
        source,
        shaderc::ShaderKind::Compute,
        file_name,
        "main",
        Some(&options(int64)),
    ) {
        Ok(artifact) => {
            if artifact.get_num_warnings() > 0 {
                println!(
                    "cargo:warning={file_name}{form}: {}",
                    artifact.get_warning_messages()
                );
            }
            Ok(artifact.as_binary().to_vec())
        }
        Err(e) => Err(format!("{file_name}{form}:\n{e}")),
    }
}

/// Whether a SPIR-V module declares the Int64 capability (`OpCapability`, opcode 17, of 11).
fn declares_int64(words: &[u32]) -> bool {
    let mut at = 5; // past the header
    while at < words.len() {
        let (count, opcode) = ((words[at] >> 16) as usize, words[at] & 0xffff);
        if opcode == 17 && words.get(at + 1) == Some(&11) {
            return true;
        }
        at += count.max(1);
    }
    false
}

/// Compiled kernels kept between builds, each under the hash of its preprocessed text (which
/// holds every include and define) with the build script's own source and the form, the text
/// stored beside the words and compared in full, so a hash collision cannot hand back another
/// kernel's SPIR-V.
struct SpirvCache {
    /// `None` where the folder cannot be made: everything is compiled.
    dir: Option<PathBuf>,
    /// This build script's source: a change to the compile options empties the cache in effect.
    script: String,
}

impl SpirvCache {
    /// The cache of the build profile `OUT_DIR` belongs to (`target/<profile>/build/rara-*/out`).
    fn beside(out_dir: &Path) -> SpirvCache {
        let dir = out_dir
            .ancestors()
            .nth(3)
            .map(|profile| profile.join("rara-spirv-cache"))
            .filter(|dir| std::fs::create_dir_all(dir).is_ok());
        let script = std::fs::read_to_string("build.rs").unwrap_or_default();
        SpirvCache { dir, script }
    }

    /// The entry's path without extension, or `None` without a cache folder.
    fn entry(&self, text: &str, int64: bool) -> Option<PathBuf> {
        use std::hash::{Hash, Hasher};
        let mut h = std::collections::hash_map::DefaultHasher::new();
        (text, int64, &self.script).hash(&mut h);
        Some(self.dir.as_ref()?.join(format!("{:016x}", h.finish())))
    }

    /// Removes every entry but those of `kept` (this build's kernels), so the cache holds one
    /// build's worth whatever the edits before it.
    fn keep_only<'a>(&self, kept: impl Iterator<Item = (&'a str, bool)>) {
        let Some(dir) = &self.dir else {
            return;
        };
        let keep: std::collections::HashSet<PathBuf> = kept
            .filter_map(|(text, int64)| self.entry(text, int64))
            .collect();
        let Ok(listing) = std::fs::read_dir(dir) else {
            return;
        };
        for path in listing.flatten().map(|e| e.path()) {
            // `KEY.spv`, `KEY.glsl`, `KEY.spv.PID.tmp`: the entry is the path up to the first dot.
            let name = path.file_name().and_then(|n| n.to_str()).unwrap_or("");
            let key = dir.join(name.split('.').next().unwrap_or(""));
            if !keep.contains(&key) {
                let _ = std::fs::remove_file(&path);
            }
        }
    }

    /// The words compiled from `text` before, if the cache has them.
    fn get(&self, text: &str, int64: bool) -> Option<Vec<u32>> {
        let entry = self.entry(text, int64)?;
        let stored = std::fs::read_to_string(entry.with_extension("glsl")).ok()?;
        if stored != text {
            return None;
        }
        let bytes = std::fs::read(entry.with_extension("spv")).ok()?;
        let words: Vec<u32> = bytes
            .chunks_exact(4)
            .map(|b| u32::from_ne_bytes([b[0], b[1], b[2], b[3]]))
            .collect();
        (bytes.len() % 4 == 0 && words.first() == Some(&0x0723_0203)).then_some(words)
    }

    /// Keeps `words` for `text` (best effort: a failed write only costs a compile later). Each
    /// file is written beside its place and renamed into it, the words first and the text
    /// last, so neither a killed build nor another build script writing the same entry at the
    /// same time leaves an entry that reads back cut short.
    fn put(&self, text: &str, int64: bool, words: &[u32]) {
        let Some(entry) = self.entry(text, int64) else {
            return;
        };
        let place = |ext: &str, bytes: &[u8]| {
            let tmp = entry.with_extension(format!("{ext}.{}.tmp", std::process::id()));
            std::fs::write(&tmp, bytes).is_ok()
                && std::fs::rename(&tmp, entry.with_extension(ext)).is_ok()
        };
        let bytes: Vec<u8> = words.iter().flat_map(|w| w.to_ne_bytes()).collect();
        if place("spv", &bytes) {
            place("glsl", text.as_bytes());
        }
    }
}
