//! Output files: checked before the work that fills them, and written whole or not at all,
//! every output of a command together.
//!
//! A render can take minutes; a wrong `-o` should fail before it, not after. So each output is
//! prepared first ([`Output::prepare`]): a known extension, not a directory, an existing
//! directory to go in, and a file opened in that directory to write to (which proves it
//! writable). On Linux that file has no name (`O_TMPFILE`): a crash, a kill or a power cut
//! leaves nothing behind. Elsewhere, or on a file system without unnamed files, it is a
//! hidden `.NAME.rara-PID-N.tmp` beside the target, removed unless it is committed.
//!
//! A command's outputs are staged into an [`Outputs`] set as they are made and committed
//! together when the command has succeeded ([`Outputs::commit`]): each one linked into place
//! under a temporary name and renamed over its target, so a reader sees the old file or the new
//! one, never a part. A failure before the commit (a bad frame, a full disk, a device that
//! fails) leaves no output, side files (an OBJ's `.mtl`) and folders the command created
//! included. An existing target that is not a regular file (a device such as `/dev/stdout`, a
//! FIFO) is written in place when the set is committed, before any file is renamed.

use std::fs::File;
use std::io::{BufWriter, Write};
use std::path::{Path, PathBuf};
use std::sync::atomic::{AtomicU64, Ordering};

use rara::input::folder_of;
use rara::{Error, Result};

fn invalid(path: &Path, message: impl std::fmt::Display) -> Error {
    Error::InvalidInput(format!("output {}: {message}", path.display()))
}

fn io(path: &Path) -> impl FnOnce(std::io::Error) -> Error + '_ {
    move |source| Error::Io {
        path: path.to_path_buf(),
        source,
    }
}

/// Temporary names made by this process, numbered so that no two collide.
static TEMP_NAMES: AtomicU64 = AtomicU64::new(0);

/// A hidden name beside `path` for its temporary file.
fn temp_name(path: &Path) -> PathBuf {
    let name = path
        .file_name()
        .map_or_else(String::new, |n| n.to_string_lossy().into_owned());
    let n = TEMP_NAMES.fetch_add(1, Ordering::Relaxed);
    folder_of(path).join(format!(".{name}.rara-{}-{n}.tmp", std::process::id()))
}

/// Where an output's bytes go until it is committed.
enum Sink {
    /// A file with no name in the target's folder (Linux's `O_TMPFILE`), linked into place
    /// when committed; it vanishes with the process otherwise.
    Unnamed(File),
    /// A hidden temporary file beside the target, removed unless committed.
    Named(PathBuf, Option<File>),
    /// A device or a FIFO, written in place.
    InPlace,
}

impl Sink {
    /// An unnamed file in `dir`, or `None` where the file system (or the OS) has none.
    #[cfg(target_os = "linux")]
    fn unnamed(dir: &Path) -> std::io::Result<Option<File>> {
        use std::os::unix::fs::OpenOptionsExt;
        // Linking it into place goes through /proc (linkat with AT_EMPTY_PATH needs a
        // capability an ordinary user lacks).
        if !Path::new("/proc/self/fd").is_dir() {
            return Ok(None);
        }
        match std::fs::OpenOptions::new()
            .read(true)
            .write(true)
            .mode(0o666)
            .custom_flags(libc::O_TMPFILE)
            .open(dir)
        {
            Ok(f) => Ok(Some(f)),
            // No O_TMPFILE on this file system, or an old kernel.
            Err(e) if matches!(e.raw_os_error(), Some(libc::EOPNOTSUPP | libc::EISDIR)) => Ok(None),
            Err(e) => Err(e),
        }
    }

    #[cfg(not(target_os = "linux"))]
    fn unnamed(_dir: &Path) -> std::io::Result<Option<File>> {
        Ok(None)
    }

    /// A fresh temporary file for the target `path`.
    fn temporary(path: &Path) -> Result<Sink> {
        if let Some(f) = Sink::unnamed(folder_of(path)).map_err(io(path))? {
            return Ok(Sink::Unnamed(f));
        }
        let temp = temp_name(path);
        let f = File::create(&temp).map_err(io(path))?;
        Ok(Sink::Named(temp, Some(f)))
    }

    /// Gives the unnamed file `f` the temporary name `temp`.
    #[cfg(target_os = "linux")]
    fn link(f: &File, temp: &Path) -> std::io::Result<()> {
        use std::os::fd::AsRawFd;
        use std::os::unix::ffi::OsStrExt;
        let from = std::ffi::CString::new(format!("/proc/self/fd/{}", f.as_raw_fd()))
            .expect("no NUL in a number");
        let to = std::ffi::CString::new(temp.as_os_str().as_bytes())
            .map_err(|_| std::io::Error::from(std::io::ErrorKind::InvalidInput))?;
        // SAFETY: both are valid NUL-terminated paths; linkat reads them and nothing else.
        let r = unsafe {
            libc::linkat(
                libc::AT_FDCWD,
                from.as_ptr(),
                libc::AT_FDCWD,
                to.as_ptr(),
                libc::AT_SYMLINK_FOLLOW,
            )
        };
        if r == 0 {
            Ok(())
        } else {
            Err(std::io::Error::last_os_error())
        }
    }

    #[cfg(not(target_os = "linux"))]
    fn link(_f: &File, _temp: &Path) -> std::io::Result<()> {
        unreachable!("unnamed files are Linux's")
    }
}

/// A prepared output file; dropping it unwritten leaves nothing.
pub struct Output {
    path: PathBuf,
    sink: Sink,
}

impl Output {
    /// Checks `path` for a file of one of `extensions` (lower case, without the dot) and opens
    /// the file its bytes will go to.
    pub fn prepare(path: &Path, extensions: &[&str]) -> Result<Output> {
        Output::prepare_checked(path, Some(extensions))
    }

    /// [`Output::prepare`] for a file of any name (a format named by an option, not by the
    /// extension).
    pub fn prepare_any(path: &Path) -> Result<Output> {
        Output::prepare_checked(path, None)
    }

    fn prepare_checked(path: &Path, extensions: Option<&[&str]>) -> Result<Output> {
        let meta = std::fs::metadata(path).ok();
        if meta.as_ref().is_some_and(|m| m.is_dir()) {
            return Err(invalid(path, "is a directory; give a file name"));
        }
        if meta.as_ref().is_some_and(|m| !m.is_file()) {
            // A device or FIFO: no extension to check, nothing to rename.
            return Ok(Output {
                path: path.to_path_buf(),
                sink: Sink::InPlace,
            });
        }
        if let Some(extensions) = extensions {
            let ext = path
                .extension()
                .map(|e| e.to_string_lossy().to_ascii_lowercase());
            if !ext.as_deref().is_some_and(|e| extensions.contains(&e)) {
                let list = extensions
                    .iter()
                    .map(|e| format!(".{e}"))
                    .collect::<Vec<_>>()
                    .join(", ");
                return Err(invalid(
                    path,
                    match ext {
                        Some(e) => format!("unknown extension '.{e}': rara writes {list}"),
                        None => format!("no extension: rara writes {list}"),
                    },
                ));
            }
        }
        let dir = folder_of(path);
        if !dir.is_dir() {
            return Err(invalid(
                path,
                format!("the directory {} does not exist", dir.display()),
            ));
        }
        Ok(Output {
            path: path.to_path_buf(),
            sink: Sink::temporary(path)?,
        })
    }

    /// The target's path.
    pub fn path(&self) -> &Path {
        &self.path
    }

    /// Starts writing: what is written goes to the temporary file (buffered), or, for a
    /// device, to memory until the set it joins is committed.
    pub fn begin(mut self) -> Result<Writing> {
        let to = match &mut self.sink {
            Sink::Unnamed(f) => To::File(BufWriter::with_capacity(
                1 << 20,
                f.try_clone().map_err(io(&self.path))?,
            )),
            Sink::Named(_, f) => To::File(BufWriter::with_capacity(
                1 << 20,
                f.take().expect("a named temporary is opened once"),
            )),
            Sink::InPlace => To::Memory(Vec::new()),
        };
        Ok(Writing {
            output: self,
            to,
            written: 0,
        })
    }

    /// Writes `bytes` as the whole file, committed at once.
    pub fn write(self, bytes: &[u8]) -> Result<()> {
        self.write_with(|w| {
            w.write_all(bytes).map_err(|e| Error::Io {
                path: PathBuf::new(),
                source: e,
            })
        })
    }

    /// Writes the file with `write`, which may stream into it; the result replaces the target
    /// only when `write` succeeds. A device is streamed into directly.
    pub fn write_with(self, write: impl FnOnce(&mut dyn Write) -> Result<()>) -> Result<()> {
        if let Sink::InPlace = self.sink {
            let mut w = BufWriter::new(
                std::fs::OpenOptions::new()
                    .write(true)
                    .open(&self.path)
                    .map_err(io(&self.path))?,
            );
            write(&mut w).map_err(|e| name_io(e, &self.path))?;
            return w.flush().map_err(io(&self.path));
        }
        let mut set = Outputs::new();
        set.add_with(self, write)?;
        set.commit()
    }

    /// Writes `img` as a PNG.
    pub fn write_png(self, img: &image::RgbaImage) -> Result<()> {
        let bytes = png_bytes(img, &self.path)?;
        self.write(&bytes)
    }

    /// Writes `value` as pretty-printed JSON.
    pub fn write_json(self, value: &serde_json::Value) -> Result<()> {
        self.write(json_text(value).as_bytes())
    }
}

impl Drop for Output {
    fn drop(&mut self) {
        if let Sink::Named(temp, _) = &self.sink {
            std::fs::remove_file(temp).ok();
        }
    }
}

/// An I/O error that a writer reported without a path (it wrote to a stream) given the
/// target's.
fn name_io(e: Error, path: &Path) -> Error {
    match e {
        Error::Io { path: p, source } if p.as_os_str().is_empty() => Error::Io {
            path: path.to_path_buf(),
            source,
        },
        e => e,
    }
}

/// `img` as PNG bytes.
pub fn png_bytes(img: &image::RgbaImage, path: &Path) -> Result<Vec<u8>> {
    let mut bytes = Vec::new();
    img.write_to(
        &mut std::io::Cursor::new(&mut bytes),
        image::ImageFormat::Png,
    )
    .map_err(|source| Error::Image {
        path: path.to_path_buf(),
        source,
    })?;
    Ok(bytes)
}

fn json_text(value: &serde_json::Value) -> String {
    serde_json::to_string_pretty(value).expect("JSON values serialise")
}

enum To {
    File(BufWriter<File>),
    Memory(Vec<u8>),
}

/// An output being written ([`Output::begin`]); staged with [`Outputs::add_written`].
pub struct Writing {
    output: Output,
    to: To,
    /// Bytes written so far (the size a device target has no metadata for).
    written: u64,
}

impl Write for Writing {
    fn write(&mut self, buf: &[u8]) -> std::io::Result<usize> {
        let n = match &mut self.to {
            To::File(w) => w.write(buf),
            To::Memory(v) => v.write(buf),
        }?;
        self.written += n as u64;
        Ok(n)
    }
    fn flush(&mut self) -> std::io::Result<()> {
        match &mut self.to {
            To::File(w) => w.flush(),
            To::Memory(_) => Ok(()),
        }
    }
}

/// An output written whole, waiting for its set's commit.
struct Staged {
    output: Output,
    /// A device's bytes.
    bytes: Vec<u8>,
}

/// Unnamed files a set holds open at most; past them, staged files take their temporary names
/// at once and are closed (a sequence of thousands of frames stays under the limit of open
/// files; a crash then leaves those names).
const MAX_UNNAMED_HELD: usize = 256;

/// A command's outputs, committed together or not at all. Dropped uncommitted (an error, a
/// panic), it leaves nothing: its temporary files go, and so do the folders it created.
#[derive(Default)]
pub struct Outputs {
    staged: Vec<Staged>,
    /// Folders created by [`Outputs::create_dir`], parents first.
    created: Vec<PathBuf>,
    committed: bool,
}

impl Outputs {
    /// An empty set.
    pub fn new() -> Outputs {
        Outputs::default()
    }

    /// Creates the output folder `dir` and its missing parents; they are removed again (when
    /// empty) unless the set is committed.
    pub fn create_dir(&mut self, dir: &Path) -> Result<()> {
        if dir.is_dir() {
            return Ok(());
        }
        let missing: Vec<PathBuf> = dir
            .ancestors()
            .filter(|a| !a.as_os_str().is_empty() && !a.exists())
            .map(Path::to_path_buf)
            .collect();
        std::fs::create_dir_all(dir).map_err(io(dir))?;
        self.created.extend(missing.into_iter().rev());
        Ok(())
    }

    /// Stages `writing`, written whole: flushed and on disk, not yet in place.
    pub fn add_written(&mut self, writing: Writing) -> Result<()> {
        let Writing { mut output, to, .. } = writing;
        let bytes = match to {
            To::File(mut w) => {
                w.flush().map_err(io(&output.path))?;
                let f = w.into_inner().map_err(|e| Error::Io {
                    path: output.path.clone(),
                    source: e.into_error(),
                })?;
                f.sync_all().map_err(io(&output.path))?;
                Vec::new()
            }
            To::Memory(v) => v,
        };
        let held = self
            .staged
            .iter()
            .filter(|s| matches!(s.output.sink, Sink::Unnamed(_)))
            .count();
        if held >= MAX_UNNAMED_HELD {
            if let Sink::Unnamed(f) = &output.sink {
                let temp = temp_name(&output.path);
                Sink::link(f, &temp).map_err(io(&output.path))?;
                output.sink = Sink::Named(temp, None);
            }
        }
        self.staged.push(Staged { output, bytes });
        Ok(())
    }

    /// Stages `output`, written by `write`; returns the bytes written.
    pub fn add_with(
        &mut self,
        output: Output,
        write: impl FnOnce(&mut dyn Write) -> Result<()>,
    ) -> Result<u64> {
        let path = output.path.clone();
        let mut writing = output.begin()?;
        write(&mut writing).map_err(|e| name_io(e, &path))?;
        let written = writing.written;
        self.add_written(writing)?;
        Ok(written)
    }

    /// Stages `output` holding `bytes`.
    pub fn add(&mut self, output: Output, bytes: &[u8]) -> Result<()> {
        self.add_with(output, |w| {
            w.write_all(bytes).map_err(|source| Error::Io {
                path: PathBuf::new(),
                source,
            })
        })
        .map(drop)
    }

    /// Stages `output` holding `img` as a PNG.
    pub fn add_png(&mut self, output: Output, img: &image::RgbaImage) -> Result<()> {
        let bytes = png_bytes(img, &output.path)?;
        self.add(output, &bytes)
    }

    /// Stages `output` holding `value` as pretty-printed JSON.
    pub fn add_json(&mut self, output: Output, value: &serde_json::Value) -> Result<()> {
        self.add(output, json_text(value).as_bytes())
    }

    /// Puts every staged output in place: devices written first (a device that fails leaves
    /// no file), then each file renamed over its target.
    pub fn commit(mut self) -> Result<()> {
        for s in &self.staged {
            if let Sink::InPlace = s.output.sink {
                let path = &s.output.path;
                std::fs::OpenOptions::new()
                    .write(true)
                    .open(path)
                    .and_then(|mut f| f.write_all(&s.bytes).and_then(|()| f.flush()))
                    .map_err(io(path))?;
            }
        }
        for s in &mut self.staged {
            let path = s.output.path.clone();
            match &s.output.sink {
                Sink::InPlace => {}
                Sink::Unnamed(f) => {
                    let temp = temp_name(&path);
                    Sink::link(f, &temp).map_err(io(&path))?;
                    // Named from here on: removed should the rename fail.
                    s.output.sink = Sink::Named(temp.clone(), None);
                    std::fs::rename(&temp, &path).map_err(io(&path))?;
                }
                Sink::Named(temp, _) => std::fs::rename(temp, &path).map_err(io(&path))?,
            }
            // In place: nothing for the drop to remove.
            s.output.sink = Sink::InPlace;
        }
        self.committed = true;
        Ok(())
    }
}

impl Drop for Outputs {
    fn drop(&mut self) {
        // The staged outputs' temporaries go with them (`Output`'s drop).
        self.staged.clear();
        if !self.committed {
            for dir in self.created.iter().rev() {
                std::fs::remove_dir(dir).ok();
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn dir(name: &str) -> PathBuf {
        let d = std::env::temp_dir().join(format!("rara-output-{}-{name}", std::process::id()));
        std::fs::create_dir_all(&d).unwrap();
        d
    }

    fn entries(d: &Path) -> Vec<String> {
        let mut v: Vec<String> = std::fs::read_dir(d)
            .unwrap()
            .map(|e| e.unwrap().file_name().to_string_lossy().into_owned())
            .collect();
        v.sort();
        v
    }

    #[test]
    fn bad_targets_fail_before_any_work() {
        let d = dir("bad");
        let e = |p: &Path| Output::prepare(p, &["png"]).err().unwrap().to_string();
        assert!(e(&d).contains("is a directory"));
        assert!(e(&d.join("a.jpg")).contains("unknown extension '.jpg'"));
        assert!(e(&d.join("noext")).contains("no extension"));
        assert!(e(&d.join("missing/a.png")).contains("does not exist"));
        // Nothing was left behind by the failed preparations, nor by a prepared one: its file
        // has no name until it is committed.
        let prepared = Output::prepare(&d.join("a.png"), &["png"]).unwrap();
        assert!(entries(&d).is_empty(), "{:?}", entries(&d));
        drop(prepared);
        assert!(entries(&d).is_empty());
        std::fs::remove_dir_all(&d).ok();
    }

    #[test]
    fn a_failed_write_leaves_no_file_and_a_good_one_replaces_the_target() {
        let d = dir("write");
        let target = d.join("out.PNG");
        let out = Output::prepare(&target, &["png"]).unwrap();
        drop(out); // the render failed
        assert!(entries(&d).is_empty());
        std::fs::write(&target, b"old").unwrap();
        Output::prepare(&target, &["png"])
            .unwrap()
            .write(b"new")
            .unwrap();
        assert_eq!(std::fs::read(&target).unwrap(), b"new");
        assert_eq!(entries(&d), ["out.PNG"]);
        // A writer that fails half-way: the old file stays, and nothing else appears.
        let e = Output::prepare(&target, &["png"])
            .unwrap()
            .write_with(|w| {
                w.write_all(b"half").unwrap();
                Err(Error::InvalidInput("failed".into()))
            })
            .unwrap_err();
        assert!(e.to_string().contains("failed"));
        assert_eq!(std::fs::read(&target).unwrap(), b"new");
        assert_eq!(entries(&d), ["out.PNG"]);
        // A device is written in place and its error is reported: /dev/full is always full.
        let full = Path::new("/dev/full");
        if full.exists() {
            let e = Output::prepare(full, &["png"])
                .unwrap()
                .write(b"x")
                .unwrap_err();
            assert!(e.to_string().contains("/dev/full"), "{e}");
        }
        std::fs::remove_dir_all(&d).ok();
    }

    #[test]
    fn a_set_is_committed_whole_or_not_at_all() {
        let d = dir("set");
        // A device that fails at the commit: neither the file staged before it nor the folder
        // the set created is left.
        let sub = d.join("made/deeper");
        let mut set = Outputs::new();
        set.create_dir(&sub).unwrap();
        set.add(Output::prepare(&sub.join("a.png"), &["png"]).unwrap(), b"a")
            .unwrap();
        set.add(
            Output::prepare(Path::new("/dev/full"), &["png"]).unwrap(),
            b"b",
        )
        .unwrap();
        assert!(set.commit().is_err());
        assert!(entries(&d).is_empty(), "{:?}", entries(&d));
        // Dropped half-way (an error in the command): nothing.
        let mut set = Outputs::new();
        set.create_dir(&sub).unwrap();
        set.add(Output::prepare(&sub.join("a.png"), &["png"]).unwrap(), b"a")
            .unwrap();
        drop(set);
        assert!(entries(&d).is_empty());
        // More outputs than the set holds unnamed: all land, and no temporary is left.
        let mut set = Outputs::new();
        set.create_dir(&sub).unwrap();
        for k in 0..MAX_UNNAMED_HELD + 5 {
            let o = Output::prepare(&sub.join(format!("f{k:04}.png")), &["png"]).unwrap();
            set.add(o, &k.to_le_bytes()).unwrap();
        }
        set.commit().unwrap();
        let names = entries(&sub);
        assert_eq!(names.len(), MAX_UNNAMED_HELD + 5);
        assert!(names
            .iter()
            .all(|n| n.starts_with('f') && n.ends_with(".png")));
        assert_eq!(
            std::fs::read(sub.join("f0260.png")).unwrap(),
            260usize.to_le_bytes()
        );
        std::fs::remove_dir_all(&d).ok();
    }
}
