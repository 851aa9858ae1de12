//! Vulkan plumbing: context, buffers, compute pipelines.

pub mod buffer;
pub mod context;
pub mod pipeline;

pub use buffer::{Buffer, MemoryLocation};
pub use context::{Context, ContextDesc, DeviceInfo, Validation};
pub use pipeline::{compute_barrier, ComputePipeline};
