//! Reading input files within stated limits: every file rara reads comes through here.
//!
//! The rules (docs/ARCHITECTURE.md, "Hostile input"):
//!
//! - **One opening.** An input is opened once ([`InputFile::open`]); its format is told from
//!   the bytes read through that opening ([`InputFile::peek`]), never by opening it again (a
//!   FIFO opened twice waits forever for a writer that has gone).
//! - **Every byte counted.** A regular file is refused when `stat` gives more than the limit,
//!   before anything is read. A pipe, a FIFO or a device (`/dev/zero`, `/dev/stdin`) reports
//!   no size, so it is read through a cap of `limit + 1` bytes (at most [`MAX_STREAM_BYTES`])
//!   and refused when the cap is reached: what `stat` says is never trusted for what is read.
//! - **Side files are files.** A file that another file names (a glTF buffer URI, a SOG
//!   member in a folder) must be a regular file beside it: no absolute path, no `..`, no URI
//!   scheme, no FIFO or device; and a glTF buffer is read up to its declared `byteLength`,
//!   no further ([`read_side_file`]).

pub mod gltf;

use std::fs::File;
use std::io::{BufRead, BufReader, Cursor, Read, Seek};
use std::path::{Path, PathBuf};

use crate::error::{Error, Result};

/// The most bytes read whole from an input that is not a regular file (a pipe, a FIFO, a
/// device): 1 GiB. A regular file is bounded by its size and the format's own limit; a stream
/// has no size, and `/dev/zero` never ends.
pub const MAX_STREAM_BYTES: u64 = 1 << 30;

fn io_error(path: &Path, source: std::io::Error) -> Error {
    Error::Io {
        path: path.to_path_buf(),
        source,
    }
}

fn input_error(path: &Path, message: impl std::fmt::Display) -> Error {
    Error::Input {
        path: path.to_path_buf(),
        message: message.to_string(),
    }
}

/// The error for `size` bytes at `path`, past the `limit` a `what` may have.
fn too_large(path: &Path, size: u64, limit: u64, what: &str) -> Error {
    input_error(
        path,
        format!("{size} bytes, more than the {limit} a {what} may have"),
    )
}

/// The folder a file is in (`.` for a bare name).
pub fn folder_of(path: &Path) -> &Path {
    match path.parent() {
        Some(d) if !d.as_os_str().is_empty() => d,
        _ => Path::new("."),
    }
}

/// An input opened once: a regular file (its size known) or a stream (a pipe, a FIFO, a
/// device), with the first bytes [`InputFile::peek`] read kept for whoever reads it next.
#[derive(Debug)]
pub struct InputFile {
    path: PathBuf,
    file: File,
    /// The size `stat` gave, for a regular file.
    size: Option<u64>,
    /// Bytes read ahead by [`InputFile::peek`], not yet handed on.
    head: Vec<u8>,
}

impl InputFile {
    /// Opens `path`; a directory is refused (`what` names what was expected in the error).
    pub fn open(path: &Path, what: &str) -> Result<InputFile> {
        let file = File::open(path).map_err(|e| io_error(path, e))?;
        let meta = file.metadata().map_err(|e| io_error(path, e))?;
        if meta.is_dir() {
            return Err(input_error(path, format!("is a directory, not a {what}")));
        }
        Ok(InputFile {
            path: path.to_path_buf(),
            file,
            size: meta.is_file().then_some(meta.len()),
            head: Vec::new(),
        })
    }

    /// The path it was opened at.
    pub fn path(&self) -> &Path {
        &self.path
    }

    /// Its first `n` bytes (fewer when it ends sooner), kept: what is read next starts at the
    /// beginning again.
    pub fn peek(&mut self, n: usize) -> Result<&[u8]> {
        while self.head.len() < n {
            let start = self.head.len();
            self.head.resize(n, 0);
            match self.file.read(&mut self.head[start..]) {
                Ok(0) => {
                    self.head.truncate(start);
                    break;
                }
                Ok(k) => self.head.truncate(start + k),
                Err(e) if e.kind() == std::io::ErrorKind::Interrupted => self.head.truncate(start),
                Err(e) => return Err(io_error(&self.path, e)),
            }
        }
        Ok(&self.head[..n.min(self.head.len())])
    }

    /// The whole input, at most `limit` bytes (`what` names it in the error): a regular file
    /// larger than that is refused before it is read, a stream is read through a cap of
    /// `min(limit, MAX_STREAM_BYTES) + 1` bytes and refused at the cap.
    pub fn read_all(mut self, limit: u64, what: &str) -> Result<Vec<u8>> {
        let cap = match self.size {
            Some(size) if size > limit => return Err(too_large(&self.path, size, limit, what)),
            Some(size) => size,
            None => limit.min(MAX_STREAM_BYTES),
        };
        let mut bytes = std::mem::take(&mut self.head);
        if self.size.is_some() {
            // A regular file's size is known: one allocation (fallible, like the growth).
            let rest = (cap as usize).saturating_sub(bytes.len());
            bytes
                .try_reserve_exact(rest)
                .map_err(|_| input_error(&self.path, format!("no memory for its {cap} bytes")))?;
        }
        read_capped(&mut self.file, &mut bytes, cap + 1).map_err(|e| io_error(&self.path, e))?;
        if bytes.len() as u64 > cap {
            return Err(input_error(
                &self.path,
                match self.size {
                    // A regular file that grew while it was read.
                    Some(size) => format!("grew past its {size} bytes while it was read"),
                    None => format!(
                        "more than {cap} bytes from a pipe or a device (the most rara reads \
                         whole from one; is it the right file?), for a {what}"
                    ),
                },
            ));
        }
        Ok(bytes)
    }

    /// A buffered reader from the beginning, and the size when it is known: a regular file
    /// read in place, a stream read whole first (through [`InputFile::read_all`]'s cap), so
    /// that every count in it can be checked against its length.
    pub fn into_sized_reader(mut self, limit: u64, what: &str) -> Result<(Box<dyn BufRead>, u64)> {
        match self.size {
            Some(size) if size > limit => Err(too_large(&self.path, size, limit, what)),
            Some(size) => {
                self.file.rewind().map_err(|e| io_error(&self.path, e))?;
                let reader = BufReader::with_capacity(1 << 20, self.file.take(size));
                Ok((Box::new(reader), size))
            }
            None => {
                let bytes = self.read_all(limit, what)?;
                let len = bytes.len() as u64;
                Ok((Box::new(Cursor::new(bytes)), len))
            }
        }
    }

    /// A buffered reader from the beginning with no cap, for the one format read as a stream
    /// of any length (a PLY from a pipe: memory grows only with the vertices that arrive), and
    /// the size of a regular file.
    pub fn into_stream(mut self) -> Result<(Box<dyn BufRead>, Option<u64>)> {
        if self.size.is_some() {
            self.file.rewind().map_err(|e| io_error(&self.path, e))?;
            return Ok((
                Box::new(BufReader::with_capacity(1 << 20, self.file)),
                self.size,
            ));
        }
        let head = Cursor::new(std::mem::take(&mut self.head));
        Ok((
            Box::new(BufReader::with_capacity(1 << 20, head.chain(self.file))),
            None,
        ))
    }
}

/// Appends what `reader` holds to `bytes` until it ends or `bytes` holds `most` bytes. The
/// buffer grows as the bytes arrive, never past `most`, and through a fallible allocation: a
/// process under an address-space limit gets an error, not an abort.
fn read_capped(reader: &mut impl Read, bytes: &mut Vec<u8>, most: u64) -> std::io::Result<()> {
    let most = usize::try_from(most).unwrap_or(usize::MAX);
    let mut chunk = vec![0u8; 1 << 16];
    while bytes.len() < most {
        let want = chunk.len().min(most - bytes.len());
        let n = match reader.read(&mut chunk[..want]) {
            Ok(0) => break,
            Ok(n) => n,
            Err(e) if e.kind() == std::io::ErrorKind::Interrupted => continue,
            Err(e) => return Err(e),
        };
        if bytes.capacity() - bytes.len() < n {
            // Double, but never past `most`.
            let grow = bytes.len().max(n).min(most - bytes.len());
            bytes.try_reserve_exact(grow).map_err(|_| {
                std::io::Error::new(
                    std::io::ErrorKind::OutOfMemory,
                    format!(
                        "no memory for more than {} bytes (a process memory limit?)",
                        bytes.len()
                    ),
                )
            })?;
        }
        bytes.extend_from_slice(&chunk[..n]);
    }
    Ok(())
}

/// The text of `path`, a `what` (named in errors) of at most `limit` bytes.
pub fn read_text_limited(path: &Path, limit: u64, what: &'static str) -> Result<String> {
    let bytes = InputFile::open(path, what)?.read_all(limit, what)?;
    String::from_utf8(bytes).map_err(|e| {
        input_error(
            path,
            format!(
                "not UTF-8 text (byte {} is invalid): not a {what}",
                e.utf8_error().valid_up_to()
            ),
        )
    })
}

/// All of `path`, a `what` of at most `limit` bytes ([`InputFile::read_all`]).
pub fn read_bounded(path: &Path, limit: u64, what: &str) -> Result<Vec<u8>> {
    InputFile::open(path, what)?.read_all(limit, what)
}

/// Decodes the `%XX` escapes of a URI's path (glTF's relative URIs may have them); `None` for
/// an escape that is not two hex digits or a result that is not UTF-8.
fn percent_decode(uri: &str) -> Option<String> {
    let bytes = uri.as_bytes();
    let mut out = Vec::with_capacity(bytes.len());
    let mut i = 0;
    while i < bytes.len() {
        if bytes[i] == b'%' {
            let hex = std::str::from_utf8(bytes.get(i + 1..i + 3)?).ok()?;
            out.push(u8::from_str_radix(hex, 16).ok()?);
            i += 3;
        } else {
            out.push(bytes[i]);
            i += 1;
        }
    }
    String::from_utf8(out).ok()
}

/// The file that `name` (a relative URI or file name inside `owner`, such as a glTF buffer's
/// `uri` or a SOG member) names beside `owner` (a file, or with `owner_is_folder` a folder):
/// refused when it leaves the folder (an absolute path, a `..`, a drive or a URI scheme, a
/// backslash), when it does not exist, or when it is not a regular file (a FIFO would block,
/// a device never end). `what` names the reference in errors (`buffer 2's uri`).
pub fn side_file(owner: &Path, owner_is_folder: bool, name: &str, what: &str) -> Result<PathBuf> {
    let decoded = percent_decode(name)
        .ok_or_else(|| input_error(owner, format!("{what} '{name}' has a malformed %-escape")))?;
    let leaves = decoded.is_empty()
        || decoded.starts_with('/')
        || decoded.contains('\\')
        || decoded.contains(':')
        || decoded.split('/').any(|part| part == "..");
    if leaves {
        return Err(input_error(
            owner,
            format!(
                "{what} '{name}' leaves the file's folder (rara reads side files beside it: no \
                 absolute path, '..' or URI scheme)"
            ),
        ));
    }
    let folder = if owner_is_folder {
        owner
    } else {
        folder_of(owner)
    };
    let file = folder.join(&decoded);
    // stat, not open: opening a FIFO would wait for a writer.
    let meta = std::fs::metadata(&file)
        .map_err(|e| input_error(owner, format!("{what} '{name}': {}: {e}", file.display())))?;
    if !meta.is_file() {
        return Err(input_error(
            owner,
            format!(
                "{what} '{name}' is {}, not a regular file",
                if meta.is_dir() {
                    "a directory"
                } else {
                    "a pipe, a socket or a device"
                }
            ),
        ));
    }
    Ok(file)
}

/// Reads the side file `file` ([`side_file`]): its first `length` bytes when a length is
/// declared (a glTF buffer's `byteLength`: the file must hold that many, and nothing past them
/// is read), else all of it; at most `limit` bytes either way.
pub fn read_side_file(file: &Path, length: Option<u64>, limit: u64, what: &str) -> Result<Vec<u8>> {
    let mut input = InputFile::open(file, what)?;
    let size = input.size.ok_or_else(|| {
        input_error(
            file,
            format!("not a regular file, where a {what} must be one"),
        )
    })?;
    let want = length.unwrap_or(size);
    if want > limit {
        return Err(too_large(file, want, limit, what));
    }
    if size < want {
        return Err(input_error(
            file,
            format!("holds {size} bytes where its {what} needs {want}"),
        ));
    }
    let mut bytes = Vec::with_capacity(want as usize);
    (&mut input.file)
        .take(want)
        .read_to_end(&mut bytes)
        .map_err(|e| io_error(file, e))?;
    if (bytes.len() as u64) < want {
        return Err(input_error(
            file,
            format!(
                "ended after {} of its {want} bytes while it was read",
                bytes.len()
            ),
        ));
    }
    Ok(bytes)
}

#[cfg(test)]
mod tests {
    use super::*;

    fn dir(name: &str) -> PathBuf {
        let d = std::env::temp_dir().join(format!("rara-input-{}-{name}", std::process::id()));
        std::fs::create_dir_all(&d).unwrap();
        d
    }

    #[test]
    fn devices_and_pipes_are_read_through_the_cap() {
        // /dev/zero reports a size of 0 and never ends.
        let e = read_text_limited(Path::new("/dev/zero"), 1 << 16, "cameras.json").unwrap_err();
        assert!(e.to_string().contains("more than 65536 bytes"), "{e}");
        let dir = dir("cap");
        let e = read_text_limited(&dir, 10, "clip file").unwrap_err();
        assert!(e.to_string().contains("is a directory"), "{e}");
        let exact = dir.join("exact.json");
        std::fs::write(&exact, "0123456789").unwrap();
        assert_eq!(
            read_text_limited(&exact, 10, "clip file").unwrap(),
            "0123456789"
        );
        let e = read_text_limited(&exact, 9, "clip file").unwrap_err();
        assert!(e.to_string().contains("10 bytes, more than the 9"), "{e}");
        std::fs::write(&exact, b"[\xff]").unwrap();
        let e = read_text_limited(&exact, 10, "clip file").unwrap_err();
        assert!(e.to_string().contains("not UTF-8"), "{e}");
        std::fs::remove_dir_all(&dir).ok();
    }

    #[test]
    fn a_stream_is_capped_at_its_edge_from_both_sides() {
        // /dev/zero through a cap of 4096: refused; a FIFO-like stream of exactly the cap is
        // read whole (a pipe from a child process).
        let e = read_bounded(Path::new("/dev/zero"), 4096, "mesh").unwrap_err();
        assert!(e.to_string().contains("more than 4096 bytes"), "{e}");
        for (len, ok) in [(4096u64, true), (4097, false)] {
            let read = read_piped(len, 4096);
            assert_eq!(read.is_ok(), ok, "{len}: {read:?}");
            if ok {
                assert_eq!(read.unwrap().len() as u64, len);
            }
        }
    }

    /// `len` zero bytes from a pipe (another process's output), read with `limit`.
    fn read_piped(len: u64, limit: u64) -> Result<Vec<u8>> {
        let mut child = std::process::Command::new("head")
            .args(["-c", &len.to_string(), "/dev/zero"])
            .stdout(std::process::Stdio::piped())
            .spawn()
            .unwrap();
        let fd = child.stdout.take().unwrap();
        let path = PathBuf::from(format!("/proc/self/fd/{}", {
            use std::os::fd::AsRawFd;
            fd.as_raw_fd()
        }));
        let read = read_bounded(&path, limit, "mesh");
        drop(fd);
        child.wait().unwrap();
        read
    }

    /// The stream cap itself, from both sides: a pipe of exactly 1 GiB is read whole, one byte
    /// more is refused (1 GiB of memory for a moment).
    #[test]
    fn the_stream_cap_holds_at_one_gib() {
        for (len, ok) in [(MAX_STREAM_BYTES, true), (MAX_STREAM_BYTES + 1, false)] {
            match read_piped(len, u64::MAX) {
                Ok(bytes) => assert!(ok && bytes.len() as u64 == len, "{len}"),
                Err(e) => assert!(
                    !ok && e
                        .to_string()
                        .contains("more than 1073741824 bytes from a pipe"),
                    "{len}: {e}"
                ),
            }
        }
    }

    #[test]
    fn peeked_bytes_are_read_again() {
        let d = dir("peek");
        let f = d.join("a.bin");
        std::fs::write(&f, b"abcdefgh").unwrap();
        let mut input = InputFile::open(&f, "scene").unwrap();
        assert_eq!(input.peek(3).unwrap(), b"abc");
        assert_eq!(input.peek(100).unwrap(), b"abcdefgh");
        assert_eq!(input.read_all(8, "scene").unwrap(), b"abcdefgh");
        let mut input = InputFile::open(&f, "scene").unwrap();
        input.peek(2).unwrap();
        let (mut r, len) = input.into_sized_reader(100, "scene").unwrap();
        let mut s = Vec::new();
        r.read_to_end(&mut s).unwrap();
        assert_eq!((s.as_slice(), len), (&b"abcdefgh"[..], 8));
        std::fs::remove_dir_all(&d).ok();
    }

    #[test]
    fn side_files_stay_beside_their_owner_and_are_regular() {
        let d = dir("side");
        let owner = d.join("scene.gltf");
        std::fs::write(&owner, b"{}").unwrap();
        std::fs::write(d.join("a b.bin"), b"0123456789").unwrap();
        let f = side_file(&owner, false, "a%20b.bin", "buffer 0's uri").unwrap();
        assert_eq!(f, d.join("a b.bin"));
        // Declared length: exactly that many bytes, no more read; more than the file: refused.
        assert_eq!(read_side_file(&f, Some(4), 100, "buffer").unwrap(), b"0123");
        assert!(read_side_file(&f, Some(10), 100, "buffer").is_ok());
        let e = read_side_file(&f, Some(11), 100, "buffer").unwrap_err();
        assert!(e.to_string().contains("holds 10 bytes"), "{e}");
        let e = read_side_file(&f, Some(10), 9, "buffer").unwrap_err();
        assert!(e.to_string().contains("more than the 9"), "{e}");
        for bad in [
            "/etc/passwd",
            "../x.bin",
            "a/../../x",
            "file:///x",
            "c:\\x",
            "%2e%2e/x",
            "%zz",
        ] {
            let e = side_file(&owner, false, bad, "buffer 0's uri").unwrap_err();
            let s = e.to_string();
            assert!(
                s.contains("leaves") || s.contains("malformed"),
                "{bad}: {s}"
            );
        }
        // A symlink to a device, and a FIFO: refused by stat, nothing opened.
        std::os::unix::fs::symlink("/dev/zero", d.join("zero.bin")).unwrap();
        let e = side_file(&owner, false, "zero.bin", "buffer 0's uri").unwrap_err();
        assert!(e.to_string().contains("not a regular file"), "{e}");
        let fifo = d.join("fifo.bin");
        let c = std::ffi::CString::new(fifo.to_str().unwrap()).unwrap();
        // SAFETY: mkfifo with a valid NUL-terminated path.
        assert_eq!(unsafe { libc::mkfifo(c.as_ptr(), 0o600) }, 0);
        let e = side_file(&owner, false, "fifo.bin", "buffer 0's uri").unwrap_err();
        assert!(e.to_string().contains("not a regular file"), "{e}");
        let e = side_file(&owner, false, "missing.bin", "buffer 0's uri").unwrap_err();
        assert!(e.to_string().contains("missing.bin"), "{e}");
        std::fs::remove_dir_all(&d).ok();
    }
}
