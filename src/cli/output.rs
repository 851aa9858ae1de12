//! Output files, checked before the work that fills them and written whole or not at all.
//!
//! A render can take minutes; a wrong `-o` should fail before it, not after. So the output is
//! prepared first: a known extension, not a directory, an existing directory to go in, and a
//! temporary file created beside it (which proves the directory writable). The result is
//! written to that file and renamed over the target, so a failed write (a full disk) leaves
//! neither an empty nor a partial file. An existing target that is not a regular file (a
//! device such as `/dev/stdout`, a FIFO) is written in place: renaming over it would replace
//! the device node.

use std::fs::File;
use std::io::Write;
use std::path::{Path, PathBuf};

use rara::{Error, Result};

/// Creates the output folder `dir` and its parents (no error when it exists).
pub fn create_dir(dir: &Path) -> Result<()> {
    std::fs::create_dir_all(dir).map_err(io(dir))
}

/// A prepared output file; dropping it unwritten removes its temporary file.
pub struct Output {
    path: PathBuf,
    /// The temporary file beside the target, or `None` when the target is written in place.
    temp: Option<PathBuf>,
}

fn invalid(path: &Path, message: impl std::fmt::Display) -> Error {
    Error::InvalidInput(format!("output {}: {message}", path.display()))
}

fn io(path: &Path) -> impl FnOnce(std::io::Error) -> Error + '_ {
    move |source| Error::Io {
        path: path.to_path_buf(),
        source,
    }
}

impl Output {
    /// Checks `path` for a file of one of `extensions` (lower case, without the dot).
    pub fn prepare(path: &Path, extensions: &[&str]) -> Result<Output> {
        let meta = std::fs::metadata(path).ok();
        if meta.as_ref().is_some_and(|m| m.is_dir()) {
            return Err(invalid(path, "is a directory; give a file name"));
        }
        if meta.as_ref().is_some_and(|m| !m.is_file()) {
            // A device or FIFO: no extension to check, nothing to rename.
            return Ok(Output {
                path: path.to_path_buf(),
                temp: None,
            });
        }
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
        let dir = match path.parent() {
            Some(d) if !d.as_os_str().is_empty() => d,
            _ => Path::new("."),
        };
        if !dir.is_dir() {
            return Err(invalid(
                path,
                format!("the directory {} does not exist", dir.display()),
            ));
        }
        let name = path
            .file_name()
            .map_or_else(String::new, |n| n.to_string_lossy().into_owned());
        let temp = dir.join(format!(".{name}.rara-{}.tmp", std::process::id()));
        File::create(&temp).map_err(io(path))?;
        Ok(Output {
            path: path.to_path_buf(),
            temp: Some(temp),
        })
    }

    /// The target's path.
    pub fn path(&self) -> &Path {
        &self.path
    }

    /// Writes `bytes` as the whole file.
    pub fn write(mut self, bytes: &[u8]) -> Result<()> {
        match self.temp.take() {
            None => {
                let mut f = std::fs::OpenOptions::new()
                    .write(true)
                    .open(&self.path)
                    .map_err(io(&self.path))?;
                f.write_all(bytes)
                    .and_then(|()| f.flush())
                    .map_err(io(&self.path))
            }
            Some(temp) => {
                let written = File::create(&temp)
                    .and_then(|mut f| f.write_all(bytes).and_then(|()| f.sync_all()))
                    .and_then(|()| std::fs::rename(&temp, &self.path));
                if written.is_err() {
                    std::fs::remove_file(&temp).ok();
                }
                written.map_err(io(&self.path))
            }
        }
    }

    /// Writes the file with `write`, which is handed the path to create (the temporary file,
    /// or the target itself when it is written in place) and may stream into it; the result
    /// replaces the target only when `write` succeeds.
    pub fn write_with(mut self, write: impl FnOnce(&Path) -> Result<()>) -> Result<()> {
        match self.temp.take() {
            None => write(&self.path),
            Some(temp) => {
                let written = write(&temp)
                    .and_then(|()| std::fs::rename(&temp, &self.path).map_err(io(&self.path)));
                if written.is_err() {
                    std::fs::remove_file(&temp).ok();
                }
                written
            }
        }
    }

    /// Writes `img` as a PNG.
    pub fn write_png(self, img: &image::RgbaImage) -> Result<()> {
        let mut bytes = Vec::new();
        img.write_to(
            &mut std::io::Cursor::new(&mut bytes),
            image::ImageFormat::Png,
        )
        .map_err(|source| Error::Image {
            path: self.path.clone(),
            source,
        })?;
        self.write(&bytes)
    }

    /// Writes `value` as pretty-printed JSON.
    pub fn write_json(self, value: &serde_json::Value) -> Result<()> {
        let text = serde_json::to_string_pretty(value).expect("JSON values serialise");
        self.write(text.as_bytes())
    }
}

impl Drop for Output {
    fn drop(&mut self) {
        if let Some(temp) = self.temp.take() {
            std::fs::remove_file(temp).ok();
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

    #[test]
    fn bad_targets_fail_before_any_work() {
        let d = dir("bad");
        let e = |p: &Path| Output::prepare(p, &["png"]).err().unwrap().to_string();
        assert!(e(&d).contains("is a directory"));
        assert!(e(&d.join("a.jpg")).contains("unknown extension '.jpg'"));
        assert!(e(&d.join("noext")).contains("no extension"));
        assert!(e(&d.join("missing/a.png")).contains("does not exist"));
        // Nothing was left behind by the failed preparations.
        assert_eq!(std::fs::read_dir(&d).unwrap().count(), 0);
        std::fs::remove_dir_all(&d).ok();
    }

    #[test]
    fn a_failed_write_leaves_no_file_and_a_good_one_replaces_the_target() {
        let d = dir("write");
        let target = d.join("out.PNG");
        let out = Output::prepare(&target, &["png"]).unwrap();
        drop(out); // the render failed
        assert_eq!(std::fs::read_dir(&d).unwrap().count(), 0);
        std::fs::write(&target, b"old").unwrap();
        Output::prepare(&target, &["png"])
            .unwrap()
            .write(b"new")
            .unwrap();
        assert_eq!(std::fs::read(&target).unwrap(), b"new");
        assert_eq!(std::fs::read_dir(&d).unwrap().count(), 1);
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
}
