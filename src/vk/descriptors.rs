//! Descriptor plumbing shared by the kernels that bind a set: a pool with its one set (or
//! several), and texel-buffer views written into a set.

use ash::vk;

use super::{Buffer, Context};
use crate::error::{Result, VkContext};

/// A descriptor pool of `sizes` and `layouts.len()` sets of those layouts, allocated from it.
/// On failure nothing is left behind (the layouts stay the caller's).
pub fn allocate_sets(
    ctx: &Context,
    sizes: &[vk::DescriptorPoolSize],
    layouts: &[vk::DescriptorSetLayout],
) -> Result<(vk::DescriptorPool, Vec<vk::DescriptorSet>)> {
    let device = ctx.device();
    let info = vk::DescriptorPoolCreateInfo::default()
        .max_sets(layouts.len() as u32)
        .pool_sizes(sizes);
    let pool =
        unsafe { device.create_descriptor_pool(&info, None) }.vk("vkCreateDescriptorPool")?;
    let alloc = vk::DescriptorSetAllocateInfo::default()
        .descriptor_pool(pool)
        .set_layouts(layouts);
    match unsafe { device.allocate_descriptor_sets(&alloc) } {
        Ok(sets) => Ok((pool, sets)),
        Err(e) => {
            unsafe { device.destroy_descriptor_pool(pool, None) };
            Err(e).vk("vkAllocateDescriptorSets")
        }
    }
}

/// Makes a view of the first `range` bytes of `buffer` as texels of `format`, and writes it
/// into `binding` of `set` as a descriptor of type `ty` (a uniform or storage texel buffer).
/// The caller owns the view.
pub fn write_texel_view(
    ctx: &Context,
    buffer: &Buffer,
    format: vk::Format,
    range: u64,
    set: vk::DescriptorSet,
    binding: u32,
    ty: vk::DescriptorType,
) -> Result<vk::BufferView> {
    let device = ctx.device();
    let info = vk::BufferViewCreateInfo::default()
        .buffer(buffer.raw)
        .format(format)
        .offset(0)
        .range(range);
    let view = unsafe { device.create_buffer_view(&info, None) }.vk("vkCreateBufferView")?;
    let views = [view];
    let write = vk::WriteDescriptorSet::default()
        .dst_set(set)
        .dst_binding(binding)
        .descriptor_type(ty)
        .texel_buffer_view(&views);
    unsafe { device.update_descriptor_sets(&[write], &[]) };
    Ok(view)
}
