//! Vulkan plumbing: context (owned or borrowed from an engine), requirements, buffers,
//! compute pipelines, descriptor sets.

pub mod buffer;
pub mod context;
pub mod descriptors;
pub mod pipeline;
pub mod requirements;

pub use buffer::{Buffer, MemoryLocation};
pub use context::{BorrowedDevice, Context, ContextDesc, DeviceInfo, Validation};
pub use pipeline::{compute_barrier, host_read_barrier, ComputePipeline, LazyPipeline};
pub use requirements::{requirements, EnabledFeatures, Optional, Requirements};
