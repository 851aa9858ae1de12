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
    /// An input file other than a scene (a cameras.json, a clip file) cannot be read as one:
    /// too large, a directory, not text.
    #[error("{path}: {message}")]
    Input {
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
    /// The device has no memory left for a resource, or the resource is larger than one
    /// allocation may be on this device.
    #[error(
        "out of GPU memory: {what} needs {bytes} bytes ({reason}); render smaller images \
         or fewer Gaussians, store SH in half precision, or use a device with more memory"
    )]
    OutOfDeviceMemory {
        /// The resource (buffer name) or Vulkan call.
        what: String,
        /// Bytes requested (0 when the failing call does not say).
        bytes: u64,
        /// What the driver or the device's limits said.
        reason: String,
    },
    /// The device was lost (a GPU hang or fault, a driver reset, the GPU removed). Nothing
    /// created on the device can be used any more.
    #[error(
        "the GPU device was lost during {call} (a GPU hang or fault, a driver reset, or the \
         GPU was removed); recreate the context to go on"
    )]
    DeviceLost {
        /// The Vulkan call that reported it.
        call: &'static str,
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
        self.map_err(|result| vk_error(call, result))
    }
}

/// The [`Error`] for a failing Vulkan call: lost devices and exhausted memory get variants of
/// their own, so callers (and users) can tell them from bugs.
pub(crate) fn vk_error(call: &'static str, result: vk::Result) -> Error {
    match result {
        vk::Result::ERROR_DEVICE_LOST => Error::DeviceLost { call },
        vk::Result::ERROR_OUT_OF_DEVICE_MEMORY | vk::Result::ERROR_OUT_OF_HOST_MEMORY => {
            Error::OutOfDeviceMemory {
                what: call.to_string(),
                bytes: 0,
                reason: format!("{call} returned {result}"),
            }
        }
        _ => Error::Vulkan { call, result },
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn lost_devices_and_exhausted_memory_are_named() {
        let lost = vk_error("vkQueueSubmit", vk::Result::ERROR_DEVICE_LOST);
        assert!(matches!(
            lost,
            Error::DeviceLost {
                call: "vkQueueSubmit"
            }
        ));
        assert!(lost
            .to_string()
            .contains("GPU device was lost during vkQueueSubmit"));
        let oom = vk_error("vkAllocateMemory", vk::Result::ERROR_OUT_OF_DEVICE_MEMORY);
        assert!(matches!(oom, Error::OutOfDeviceMemory { .. }));
        assert!(oom.to_string().starts_with("out of GPU memory"));
        let other = vk_error("vkCreateBuffer", vk::Result::ERROR_UNKNOWN);
        assert!(matches!(other, Error::Vulkan { .. }));
    }
}
