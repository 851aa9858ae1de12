//! The crate's one error type.

use std::path::PathBuf;

use ash::vk;

/// Everything that can go wrong for a caller: bad input files, a Vulkan device that lacks what
/// rara needs, a failing Vulkan call. Misuse of the API is a panic, not an `Error`.
#[derive(Debug, thiserror::Error)]
pub enum Error {
    /// A file could not be read or written.
    #[error("{path}: {source}")]
    Io {
        /// The file.
        path: PathBuf,
        /// What the OS said.
        source: std::io::Error,
    },
    /// A splat PLY file is malformed (names the file and what is wrong).
    #[error("{path}: {message}")]
    Ply {
        /// The file.
        path: PathBuf,
        /// What is wrong, naming the element/property where it applies.
        message: String,
    },
    /// A cameras.json file is malformed or does not hold the requested camera.
    #[error("{path}: {message}")]
    Cameras {
        /// The file.
        path: PathBuf,
        /// What is wrong.
        message: String,
    },
    /// A value given by the user (camera, size, option) is not usable.
    #[error("{0}")]
    InvalidInput(String),
    /// The Vulkan loader or driver could not be loaded.
    #[error("cannot load Vulkan: {0}")]
    Loading(String),
    /// No Vulkan device, or none that has what rara needs.
    #[error("{0}")]
    NoSuitableDevice(String),
    /// A device (or an engine's lent device) lacks a version, feature or property rara needs
    /// ([`crate::requirements()`]); the message names each missing piece.
    #[error("{0}")]
    MissingRequirement(String),
    /// A Vulkan call failed.
    #[error("{call} failed: {result}")]
    Vulkan {
        /// The Vulkan function that failed.
        call: &'static str,
        /// Its result code.
        result: vk::Result,
    },
    /// GPU memory could not be allocated.
    #[error("GPU memory allocation for {what} failed: {source}")]
    Allocation {
        /// The resource being allocated.
        what: String,
        /// gpu-allocator's error.
        source: gpu_allocator::AllocationError,
    },
    /// Writing an image failed.
    #[error("{path}: {source}")]
    Image {
        /// The file.
        path: PathBuf,
        /// The encoder's error.
        source: image::ImageError,
    },
}

/// `Result` with the crate's [`Error`].
pub type Result<T, E = Error> = std::result::Result<T, E>;

/// Adds the name of the failing Vulkan call to a `vk::Result`.
pub(crate) trait VkContext<T> {
    /// Maps the error to [`Error::Vulkan`] naming `call`.
    fn vk(self, call: &'static str) -> Result<T>;
}

impl<T> VkContext<T> for std::result::Result<T, vk::Result> {
    fn vk(self, call: &'static str) -> Result<T> {
        self.map_err(|result| Error::Vulkan { call, result })
    }
}
