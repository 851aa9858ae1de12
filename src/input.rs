//! Reading the small input files (cameras.json, clip files) within a size limit.
//!
//! The limit holds for what is read, not for what `stat` says: a pipe, a FIFO or a device
//! (`/dev/zero`, `/dev/urandom`) reports no size, so the file is read through a cap of
//! `limit + 1` bytes and refused when the cap is reached.

use std::io::Read;
use std::path::Path;

use crate::error::{Error, Result};

/// The text of `path`, a `what` (named in errors) of at most `limit` bytes.
pub fn read_text_limited(path: &Path, limit: u64, what: &'static str) -> Result<String> {
    let io = |source| Error::Io {
        path: path.to_path_buf(),
        source,
    };
    let file = std::fs::File::open(path).map_err(io)?;
    if file.metadata().map_err(io)?.is_dir() {
        return Err(Error::Input {
            path: path.to_path_buf(),
            message: format!("is a directory, not a {what}"),
        });
    }
    let mut bytes = Vec::new();
    file.take(limit + 1).read_to_end(&mut bytes).map_err(io)?;
    if bytes.len() as u64 > limit {
        return Err(Error::Input {
            path: path.to_path_buf(),
            message: format!(
                "more than {limit} bytes: too large for a {what} (is it the right file?)"
            ),
        });
    }
    String::from_utf8(bytes).map_err(|e| Error::Input {
        path: path.to_path_buf(),
        message: format!(
            "not UTF-8 text (byte {} is invalid): not a {what}",
            e.utf8_error().valid_up_to()
        ),
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn devices_and_pipes_are_read_through_the_cap() {
        // /dev/zero reports a size of 0 and never ends.
        let e = read_text_limited(Path::new("/dev/zero"), 1 << 16, "cameras.json").unwrap_err();
        assert!(e.to_string().contains("more than 65536 bytes"), "{e}");
        let dir = std::env::temp_dir().join(format!("rara-input-{}", std::process::id()));
        std::fs::create_dir_all(&dir).unwrap();
        let e = read_text_limited(&dir, 10, "clip file").unwrap_err();
        assert!(e.to_string().contains("is a directory"), "{e}");
        let exact = dir.join("exact.json");
        std::fs::write(&exact, "0123456789").unwrap();
        assert_eq!(
            read_text_limited(&exact, 10, "clip file").unwrap(),
            "0123456789"
        );
        assert!(read_text_limited(&exact, 9, "clip file").is_err());
        std::fs::write(&exact, b"[\xff]").unwrap();
        let e = read_text_limited(&exact, 10, "clip file").unwrap_err();
        assert!(e.to_string().contains("not UTF-8"), "{e}");
        std::fs::remove_dir_all(&dir).ok();
    }
}
