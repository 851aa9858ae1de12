//! Buffers reached by device address.

use ash::vk;
use gpu_allocator::vulkan::{Allocation, AllocationCreateDesc, AllocationScheme};
pub use gpu_allocator::MemoryLocation;

use super::context::Context;
use crate::error::{Error, Result, VkContext};

/// The [`Error`] for a failed allocation of buffer `name`: running out of device memory gets
/// its own variant, naming the buffer, its size and the device's heap.
fn allocation_error(
    name: &str,
    size: u64,
    heap_bytes: u64,
    source: gpu_allocator::AllocationError,
) -> Error {
    match source {
        gpu_allocator::AllocationError::OutOfMemory => Error::OutOfDeviceMemory {
            what: format!("buffer '{name}'"),
            bytes: size,
            reason: format!(
                "the device has no free memory of that size; its device-local heap is \
                 {heap_bytes} bytes"
            ),
        },
        source => Error::Allocation {
            what: format!("buffer '{name}' ({size} bytes)"),
            source,
        },
    }
}

/// Most bytes one upload stages at a time ([`Buffer::upload_with`]).
pub const STAGING_CHUNK: u64 = 32 << 20;

/// A named GPU buffer with its memory and device address, freed when dropped.
///
/// Every buffer can be used as a storage buffer through its device address and as a transfer
/// source and destination.
pub struct Buffer {
    /// The Vulkan handle.
    pub raw: vk::Buffer,
    /// Size in bytes.
    pub size: u64,
    /// `vkGetBufferDeviceAddress` of the buffer, what kernels receive in push constants.
    pub address: u64,
    allocation: Option<Allocation>,
    ctx: Context,
}

impl Buffer {
    /// Creates a buffer of `size` bytes (at least 4) in `location`, named for leak reports and
    /// debuggers.
    pub fn new(ctx: &Context, name: &str, size: u64, location: MemoryLocation) -> Result<Self> {
        let size = size.max(4).next_multiple_of(4);
        let max = ctx.info().max_memory_allocation_size;
        if size > max {
            return Err(Error::OutOfDeviceMemory {
                what: format!("buffer '{name}'"),
                bytes: size,
                reason: format!("larger than the {max} bytes one allocation may have on this device (maxMemoryAllocationSize)"),
            });
        }
        let device = ctx.device();
        // Uniform texel buffer: the strips rasterizer reads the projected splats, sorted pairs
        // and cutoff records through texel-buffer views (`stages::rasterize`).
        let info = vk::BufferCreateInfo::default()
            .size(size)
            .usage(
                vk::BufferUsageFlags::STORAGE_BUFFER
                    | vk::BufferUsageFlags::SHADER_DEVICE_ADDRESS
                    | vk::BufferUsageFlags::TRANSFER_SRC
                    | vk::BufferUsageFlags::TRANSFER_DST
                    | vk::BufferUsageFlags::INDIRECT_BUFFER
                    | vk::BufferUsageFlags::UNIFORM_TEXEL_BUFFER
                    | vk::BufferUsageFlags::STORAGE_TEXEL_BUFFER,
            )
            .sharing_mode(vk::SharingMode::EXCLUSIVE);
        let raw = unsafe { device.create_buffer(&info, None) }.vk("vkCreateBuffer")?;
        let mut requirements = unsafe { device.get_buffer_memory_requirements(raw) };
        // The kernels move 16-byte records as 64-bit words at 16-byte aligned addresses
        // (`load_vec4` in glsl/common.glsl); a driver may ask for less.
        requirements.alignment = requirements.alignment.max(16);
        let allocation = ctx.allocator().allocate(&AllocationCreateDesc {
            name,
            requirements,
            location,
            linear: true,
            allocation_scheme: AllocationScheme::GpuAllocatorManaged,
        });
        let allocation = match allocation {
            Ok(a) => a,
            Err(source) => {
                unsafe { device.destroy_buffer(raw, None) };
                return Err(allocation_error(
                    name,
                    size,
                    ctx.info().device_local_heap_bytes,
                    source,
                ));
            }
        };
        let bind =
            unsafe { device.bind_buffer_memory(raw, allocation.memory(), allocation.offset()) };
        if let Err(e) = bind {
            let _ = ctx.allocator().free(allocation);
            unsafe { device.destroy_buffer(raw, None) };
            return Err(crate::error::vk_error("vkBindBufferMemory", e));
        }
        let address = unsafe {
            device.get_buffer_device_address(&vk::BufferDeviceAddressInfo::default().buffer(raw))
        };
        if let Some(debug) = &ctx.shared.debug_device {
            if let Ok(cname) = std::ffi::CString::new(name) {
                let info = vk::DebugUtilsObjectNameInfoEXT::default()
                    .object_handle(raw)
                    .object_name(&cname);
                let _ = unsafe { debug.set_debug_utils_object_name(&info) };
            }
        }
        Ok(Buffer {
            raw,
            size,
            address,
            allocation: Some(allocation),
            ctx: ctx.clone(),
        })
    }

    /// The context the buffer was made with.
    pub fn context(&self) -> &Context {
        &self.ctx
    }

    /// A device-local buffer holding `data`, uploaded through a staging buffer.
    pub fn from_slice<T: bytemuck::Pod>(ctx: &Context, name: &str, data: &[T]) -> Result<Self> {
        let bytes: &[u8] = bytemuck::cast_slice(data);
        let buffer = Buffer::new(ctx, name, bytes.len() as u64, MemoryLocation::GpuOnly)?;
        buffer.upload(bytes)?;
        Ok(buffer)
    }

    /// Copies `bytes` to the start of the buffer (through [`Buffer::upload_with`]; waits).
    pub fn upload(&self, bytes: &[u8]) -> Result<()> {
        self.upload_with(bytes.len() as u64, 1, |offset, chunk| {
            let offset = offset as usize;
            chunk.copy_from_slice(&bytes[offset..offset + chunk.len()]);
        })
    }

    /// Fills the first `len` bytes of the buffer from the host in chunks of at most
    /// [`STAGING_CHUNK`] bytes, through one reused staging buffer: `fill(offset, chunk)` writes
    /// bytes `offset..offset + chunk.len()`, and every chunk but the last is a multiple of
    /// `granule` bytes (the size of the caller's records). So a scene of any size is uploaded
    /// while holding one chunk of host-visible memory, not a second copy of the scene. Waits
    /// for each copy.
    pub fn upload_with(
        &self,
        len: u64,
        granule: u64,
        fill: impl FnMut(u64, &mut [u8]),
    ) -> Result<()> {
        if len == 0 {
            return Ok(());
        }
        assert!(len <= self.size, "upload larger than the buffer");
        let granule = granule.max(1);
        let chunk = (STAGING_CHUNK / granule).max(1) * granule;
        let mut staging = Buffer::new(
            &self.ctx,
            "staging (upload)",
            chunk.min(len),
            MemoryLocation::CpuToGpu,
        )?;
        self.upload_range_with(&mut staging, 0, len, granule, fill)
    }

    /// [`Buffer::upload_with`] of bytes `at..at + len` through the caller's host-visible
    /// `staging` buffer (reused across calls, as a streaming loader does): `fill(offset,
    /// chunk)` writes the bytes from `at + offset`, in chunks of at most the staging buffer's
    /// size, each but the last a multiple of `granule` bytes. Waits for each copy.
    pub fn upload_range_with(
        &self,
        staging: &mut Buffer,
        at: u64,
        len: u64,
        granule: u64,
        mut fill: impl FnMut(u64, &mut [u8]),
    ) -> Result<()> {
        assert!(at + len <= self.size, "upload past the end of the buffer");
        let granule = granule.max(1);
        // Whole records per chunk; a staging buffer smaller than a record only holds an upload
        // that is smaller still (an empty scene's 16-byte placeholder).
        let chunk = ((staging.size / granule).max(1) * granule).min(staging.size);
        assert!(
            chunk % granule == 0 || len <= staging.size,
            "a staging buffer smaller than one record"
        );
        let mut offset = 0;
        while offset < len {
            let n = chunk.min(len - offset);
            fill(offset, &mut staging.mapped_mut()[..n as usize]);
            self.ctx.run_commands(|cmd| unsafe {
                let region = vk::BufferCopy {
                    src_offset: 0,
                    dst_offset: at + offset,
                    size: n,
                };
                self.ctx
                    .device()
                    .cmd_copy_buffer(cmd, staging.raw, self.raw, &[region]);
            })?;
            offset += n;
        }
        Ok(())
    }

    /// Reads the first `len` bytes back (vkCmdCopyBuffer to a host buffer, waits).
    pub fn download(&self, len: u64) -> Result<Vec<u8>> {
        assert!(len <= self.size, "download larger than the buffer");
        if len == 0 {
            return Ok(Vec::new());
        }
        let readback = Buffer::new(
            &self.ctx,
            "staging (readback)",
            len,
            MemoryLocation::GpuToCpu,
        )?;
        self.ctx.run_commands(|cmd| unsafe {
            let region = vk::BufferCopy {
                src_offset: 0,
                dst_offset: 0,
                size: len,
            };
            self.ctx
                .device()
                .cmd_copy_buffer(cmd, self.raw, readback.raw, &[region]);
            super::host_read_barrier(&self.ctx, cmd);
        })?;
        Ok(readback.mapped()[..len as usize].to_vec())
    }

    /// Reads back `count` elements of `T`.
    pub fn download_as<T: bytemuck::Pod>(&self, count: usize) -> Result<Vec<T>> {
        let bytes = self.download((count * std::mem::size_of::<T>()) as u64)?;
        Ok(bytemuck::pod_collect_to_vec(&bytes))
    }

    /// The host mapping of a `CpuToGpu`/`GpuToCpu` buffer. Panics for unmapped memory.
    pub fn mapped(&self) -> &[u8] {
        self.allocation
            .as_ref()
            .and_then(|a| a.mapped_slice())
            .expect("buffer is not host-mapped")
    }

    /// Mutable host mapping; see [`Buffer::mapped`].
    pub fn mapped_mut(&mut self) -> &mut [u8] {
        self.allocation
            .as_mut()
            .and_then(|a| a.mapped_slice_mut())
            .expect("buffer is not host-mapped")
    }
}

impl Drop for Buffer {
    fn drop(&mut self) {
        if let Some(allocation) = self.allocation.take() {
            let _ = self.ctx.allocator().free(allocation);
        }
        unsafe { self.ctx.device().destroy_buffer(self.raw, None) };
    }
}

/// Records a copy of the first `bytes` of `source`, written by earlier compute passes, into
/// the host-visible `readback`, with the barriers that order the compute writes before the
/// copy and the copy before host reads (after the fence). Only rara's own buffers are involved.
pub(crate) fn copy_to_host(
    ctx: &Context,
    cmd: vk::CommandBuffer,
    source: &Buffer,
    readback: &Buffer,
    bytes: u64,
) {
    copy_regions_to_host(ctx, cmd, &[(source, 0, bytes)], readback);
}

/// [`copy_to_host`] of several whole buffers, each to its offset in `readback`.
pub(crate) fn copy_parts_to_host(
    ctx: &Context,
    cmd: vk::CommandBuffer,
    parts: &[(&Buffer, u64)],
    readback: &Buffer,
) {
    let regions: Vec<(&Buffer, u64, u64)> = parts.iter().map(|&(b, at)| (b, at, b.size)).collect();
    copy_regions_to_host(ctx, cmd, &regions, readback);
}

/// Copies `(source, offset in readback, bytes)` regions, with the barriers of [`copy_to_host`].
fn copy_regions_to_host(
    ctx: &Context,
    cmd: vk::CommandBuffer,
    regions: &[(&Buffer, u64, u64)],
    readback: &Buffer,
) {
    let device = ctx.device();
    let to_transfer = vk::MemoryBarrier::default()
        .src_access_mask(vk::AccessFlags::SHADER_WRITE | vk::AccessFlags::TRANSFER_WRITE)
        .dst_access_mask(vk::AccessFlags::TRANSFER_READ);
    unsafe {
        device.cmd_pipeline_barrier(
            cmd,
            vk::PipelineStageFlags::COMPUTE_SHADER | vk::PipelineStageFlags::TRANSFER,
            vk::PipelineStageFlags::TRANSFER,
            vk::DependencyFlags::empty(),
            &[to_transfer],
            &[],
            &[],
        );
        for &(source, at, bytes) in regions {
            let region = [vk::BufferCopy {
                src_offset: 0,
                dst_offset: at,
                size: bytes,
            }];
            device.cmd_copy_buffer(cmd, source.raw, readback.raw, &region);
        }
    }
    crate::vk::host_read_barrier(ctx, cmd);
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn an_exhausted_heap_is_out_of_device_memory() {
        let e = allocation_error(
            "sort keys A",
            1 << 33,
            1 << 32,
            gpu_allocator::AllocationError::OutOfMemory,
        );
        assert!(
            matches!(e, Error::OutOfDeviceMemory { bytes, .. } if bytes == 1 << 33),
            "{e:?}"
        );
        let text = e.to_string();
        assert!(text.starts_with("out of GPU memory: buffer 'sort keys A' needs 8589934592 bytes"));
        assert!(
            text.contains("device-local heap is 4294967296 bytes"),
            "{text}"
        );
        let other = allocation_error(
            "x",
            4,
            0,
            gpu_allocator::AllocationError::InvalidAllocationCreateDesc,
        );
        assert!(matches!(other, Error::Allocation { .. }));
    }
}
