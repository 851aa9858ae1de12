//! An MP4 of a command's frames (`sweep`, `render-sequence`) through Debian's `ffmpeg`, where
//! it is installed: each frame is piped to it as raw RGBA as it is rendered (no frame kept in
//! memory), H.264 in yuv420p (what players take), into a part file that is renamed into place
//! only when every frame has gone in.

use std::io::Write;
use std::path::{Path, PathBuf};
use std::process::{Child, Command, Stdio};

use rara::{Error, Result};

/// An MP4 being written by an `ffmpeg` process.
pub struct Mp4Writer {
    child: Option<Child>,
    part: PathBuf,
    out: PathBuf,
    size: (u32, u32),
}

/// Whether `ffmpeg` runs here.
fn ffmpeg_found() -> bool {
    Command::new("ffmpeg")
        .arg("-version")
        .stdout(Stdio::null())
        .stderr(Stdio::null())
        .status()
        .is_ok_and(|s| s.success())
}

impl Mp4Writer {
    /// Starts `ffmpeg` writing `out` from frames of `width` x `height` shown `delay_ms` each;
    /// `None` (and a line saying so) where ffmpeg is not installed.
    pub fn start(out: &Path, width: u32, height: u32, delay_ms: u32) -> Result<Option<Mp4Writer>> {
        if !ffmpeg_found() {
            eprintln!(
                "no MP4: ffmpeg is not installed (apt-get install ffmpeg); the PNG frames and the \
                 GIF are written"
            );
            return Ok(None);
        }
        let part = out.with_extension("mp4.part");
        let fps = format!("{:.6}", 1000.0 / delay_ms.max(1) as f64);
        let child = Command::new("ffmpeg")
            .args([
                "-y",
                "-loglevel",
                "error",
                "-f",
                "rawvideo",
                "-pix_fmt",
                "rgba",
                "-s",
            ])
            .arg(format!("{width}x{height}"))
            .args([
                "-framerate",
                &fps,
                "-i",
                "-",
                "-c:v",
                "libx264",
                "-pix_fmt",
                "yuv420p",
            ])
            // yuv420p needs even sides.
            .args(["-vf", "pad=ceil(iw/2)*2:ceil(ih/2)*2", "-f", "mp4"])
            .arg(&part)
            .stdin(Stdio::piped())
            .stdout(Stdio::null())
            .stderr(Stdio::piped())
            .spawn()
            .map_err(|source| Error::Io {
                path: PathBuf::from("ffmpeg"),
                source,
            })?;
        Ok(Some(Mp4Writer {
            child: Some(child),
            part,
            out: out.to_path_buf(),
            size: (width, height),
        }))
    }

    /// Adds a frame (of the size given at the start).
    pub fn add(&mut self, frame: &image::RgbaImage) -> Result<()> {
        if frame.dimensions() != self.size {
            return Err(Error::InvalidInput(format!(
                "an MP4 frame of {:?}, where the video is {:?}",
                frame.dimensions(),
                self.size
            )));
        }
        let child = self.child.as_mut().expect("a running ffmpeg");
        let stdin = child.stdin.as_mut().expect("ffmpeg's stdin");
        stdin.write_all(frame.as_raw()).map_err(|source| Error::Io {
            path: self.part.clone(),
            source,
        })
    }

    /// Ends the video: waits for ffmpeg and renames the part file into place.
    pub fn finish(mut self) -> Result<PathBuf> {
        let mut child = self.child.take().expect("a running ffmpeg");
        drop(child.stdin.take());
        let out = child.wait_with_output().map_err(|source| Error::Io {
            path: self.part.clone(),
            source,
        })?;
        if !out.status.success() {
            return Err(Error::InvalidInput(format!(
                "ffmpeg failed writing {}: {}",
                self.out.display(),
                String::from_utf8_lossy(&out.stderr).trim()
            )));
        }
        std::fs::rename(&self.part, &self.out).map_err(|source| Error::Io {
            path: self.out.clone(),
            source,
        })?;
        Ok(self.out.clone())
    }
}

impl Drop for Mp4Writer {
    /// A video not finished (an error before the last frame) leaves no file behind.
    fn drop(&mut self) {
        if let Some(mut child) = self.child.take() {
            drop(child.stdin.take());
            let _ = child.kill();
            let _ = child.wait();
            let _ = std::fs::remove_file(&self.part);
        }
    }
}
