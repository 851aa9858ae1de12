//! Compute pipelines whose interface is a push-constant block of buffer addresses and, for the
//! kernels that need them, descriptor sets (an engine's storage image, texel views).

use std::ffi::CStr;

use ash::vk;

use super::context::Context;
use crate::error::{Result, VkContext};

/// The form of a kernel the device runs: `spirv` (a portable kernel of [`crate::shaders`]) or,
/// where the device runs 64-bit integers ([`crate::vk::DeviceInfo::shader_int64`]), its
/// `RARA_INT64` form. Every pipeline is made through here, so a call site names the portable
/// kernel and the choice is made once.
fn kernel_form<'a>(ctx: &Context, spirv: &'a [u32]) -> &'a [u32] {
    if !ctx.info().shader_int64 {
        return spirv;
    }
    crate::shaders::INT64_FORMS
        .iter()
        .find(|(portable, _)| *portable == spirv)
        .map_or(spirv, |&(_, int64)| int64)
}

/// One compute kernel: its pipeline and the layout of its push constants.
pub struct ComputePipeline {
    /// The pipeline handle.
    pub raw: vk::Pipeline,
    /// Its layout (push constants and the descriptor sets).
    pub layout: vk::PipelineLayout,
    /// Kernel name, used for debug labels.
    pub name: &'static CStr,
    ctx: Context,
}

impl ComputePipeline {
    /// Builds a pipeline from embedded SPIR-V with a push-constant block of `P`.
    pub fn new<P: bytemuck::Pod>(
        ctx: &Context,
        name: &'static CStr,
        spirv: &[u32],
    ) -> Result<Self> {
        Self::with_set_layout::<P>(ctx, name, spirv, None)
    }

    /// Like [`ComputePipeline::new`], with descriptor set 0 of layout `set_layout` when given.
    pub fn with_set_layout<P: bytemuck::Pod>(
        ctx: &Context,
        name: &'static CStr,
        spirv: &[u32],
        set_layout: Option<vk::DescriptorSetLayout>,
    ) -> Result<Self> {
        let set_layouts: Vec<vk::DescriptorSetLayout> = set_layout.into_iter().collect();
        Self::with_set_layouts::<P>(ctx, name, spirv, &set_layouts)
    }

    /// Like [`ComputePipeline::new`], with descriptor sets 0, 1, ... of `set_layouts`.
    pub fn with_set_layouts<P: bytemuck::Pod>(
        ctx: &Context,
        name: &'static CStr,
        spirv: &[u32],
        set_layouts: &[vk::DescriptorSetLayout],
    ) -> Result<Self> {
        Self::with_push_bytes(
            ctx,
            name,
            spirv,
            set_layouts,
            std::mem::size_of::<P>() as u32,
            &[],
        )
    }

    /// Like [`ComputePipeline::with_set_layouts`], with a push-constant block of `push_bytes`
    /// and the 32-bit specialization constants `constants` (constant id, value).
    fn with_push_bytes(
        ctx: &Context,
        name: &'static CStr,
        spirv: &[u32],
        set_layouts: &[vk::DescriptorSetLayout],
        push_bytes: u32,
        constants: &[(u32, u32)],
    ) -> Result<Self> {
        let device = ctx.device();
        let spirv = kernel_form(ctx, spirv);
        let module_info = vk::ShaderModuleCreateInfo::default().code(spirv);
        let module = unsafe { device.create_shader_module(&module_info, None) }
            .vk("vkCreateShaderModule")?;
        let ranges = [vk::PushConstantRange::default()
            .stage_flags(vk::ShaderStageFlags::COMPUTE)
            .offset(0)
            .size(push_bytes)];
        let layout_info = vk::PipelineLayoutCreateInfo::default()
            .push_constant_ranges(&ranges)
            .set_layouts(set_layouts);
        let layout = match unsafe { device.create_pipeline_layout(&layout_info, None) } {
            Ok(l) => l,
            Err(e) => {
                unsafe { device.destroy_shader_module(module, None) };
                return Err(e).vk("vkCreatePipelineLayout");
            }
        };
        let entries: Vec<vk::SpecializationMapEntry> = constants
            .iter()
            .enumerate()
            .map(|(k, &(id, _))| {
                vk::SpecializationMapEntry::default()
                    .constant_id(id)
                    .offset(4 * k as u32)
                    .size(4)
            })
            .collect();
        let data: Vec<u32> = constants.iter().map(|&(_, value)| value).collect();
        let specialization = vk::SpecializationInfo::default()
            .map_entries(&entries)
            .data(bytemuck::cast_slice(&data));
        let mut stage = vk::PipelineShaderStageCreateInfo::default()
            .stage(vk::ShaderStageFlags::COMPUTE)
            .module(module)
            .name(c"main");
        if !constants.is_empty() {
            stage = stage.specialization_info(&specialization);
        }
        let info = [vk::ComputePipelineCreateInfo::default()
            .stage(stage)
            .layout(layout)];
        let pipelines =
            unsafe { device.create_compute_pipelines(vk::PipelineCache::null(), &info, None) };
        unsafe { device.destroy_shader_module(module, None) };
        let raw = match pipelines {
            Ok(p) => p[0],
            Err((_, e)) => {
                unsafe { device.destroy_pipeline_layout(layout, None) };
                return Err(e).vk("vkCreateComputePipelines");
            }
        };
        Ok(ComputePipeline {
            raw,
            layout,
            name,
            ctx: ctx.clone(),
        })
    }

    fn bind(&self, cmd: vk::CommandBuffer, push: &[u8]) {
        let device = self.ctx.device();
        unsafe {
            device.cmd_bind_pipeline(cmd, vk::PipelineBindPoint::COMPUTE, self.raw);
            device.cmd_push_constants(cmd, self.layout, vk::ShaderStageFlags::COMPUTE, 0, push);
        }
    }

    /// Binds `set` as descriptor set 0 of this pipeline's layout.
    fn bind_set(&self, cmd: vk::CommandBuffer, set: vk::DescriptorSet) {
        self.bind_sets(cmd, &[set]);
    }

    /// Binds `sets` as descriptor sets 0, 1, ... of this pipeline's layout.
    fn bind_sets(&self, cmd: vk::CommandBuffer, sets: &[vk::DescriptorSet]) {
        if sets.is_empty() {
            return; // nothing to bind (descriptorSetCount must be > 0)
        }
        unsafe {
            self.ctx.device().cmd_bind_descriptor_sets(
                cmd,
                vk::PipelineBindPoint::COMPUTE,
                self.layout,
                0,
                sets,
                &[],
            )
        };
    }

    /// Records a dispatch of `groups` workgroups with descriptor sets 0, 1, ... bound to
    /// `sets`.
    pub fn dispatch_with_sets<P: bytemuck::Pod>(
        &self,
        cmd: vk::CommandBuffer,
        push: &P,
        sets: &[vk::DescriptorSet],
        groups: [u32; 3],
    ) {
        self.bind_sets(cmd, sets);
        self.dispatch(cmd, push, groups);
    }

    /// Records a dispatch of `groups` workgroups with descriptor set 0 bound to `set`.
    pub fn dispatch_with_set<P: bytemuck::Pod>(
        &self,
        cmd: vk::CommandBuffer,
        push: &P,
        set: vk::DescriptorSet,
        groups: [u32; 3],
    ) {
        self.bind_set(cmd, set);
        self.dispatch(cmd, push, groups);
    }

    /// Records a dispatch of `groups` workgroups, with descriptor set 0 bound to `set` when
    /// given.
    pub fn dispatch_in<P: bytemuck::Pod>(
        &self,
        cmd: vk::CommandBuffer,
        push: &P,
        set: Option<vk::DescriptorSet>,
        groups: [u32; 3],
    ) {
        match set {
            Some(set) => self.dispatch_with_set(cmd, push, set, groups),
            None => self.dispatch(cmd, push, groups),
        }
    }

    /// Records a dispatch of `groups` workgroups with push constants `push`.
    pub fn dispatch<P: bytemuck::Pod>(&self, cmd: vk::CommandBuffer, push: &P, groups: [u32; 3]) {
        if groups.contains(&0) {
            return;
        }
        self.bind(cmd, bytemuck::bytes_of(push));
        unsafe {
            self.ctx
                .device()
                .cmd_dispatch(cmd, groups[0], groups[1], groups[2])
        };
    }

    /// Like [`ComputePipeline::dispatch_indirect`], with descriptor set 0 bound to `set` when
    /// given.
    pub fn dispatch_indirect_in<P: bytemuck::Pod>(
        &self,
        cmd: vk::CommandBuffer,
        push: &P,
        set: Option<vk::DescriptorSet>,
        args: vk::Buffer,
        offset: u64,
    ) {
        if let Some(set) = set {
            self.bind_set(cmd, set);
        }
        self.dispatch_indirect(cmd, push, args, offset);
    }

    /// Like [`ComputePipeline::dispatch_indirect`], with descriptor sets 0, 1, ... bound to
    /// `sets`.
    pub fn dispatch_indirect_with_sets<P: bytemuck::Pod>(
        &self,
        cmd: vk::CommandBuffer,
        push: &P,
        sets: &[vk::DescriptorSet],
        args: vk::Buffer,
        offset: u64,
    ) {
        self.bind_sets(cmd, sets);
        self.dispatch_indirect(cmd, push, args, offset);
    }

    /// Records an indirect dispatch whose workgroup counts the GPU wrote at `args`+`offset`.
    pub fn dispatch_indirect<P: bytemuck::Pod>(
        &self,
        cmd: vk::CommandBuffer,
        push: &P,
        args: vk::Buffer,
        offset: u64,
    ) {
        self.bind(cmd, bytemuck::bytes_of(push));
        unsafe { self.ctx.device().cmd_dispatch_indirect(cmd, args, offset) };
    }
}

/// A compute pipeline built on first use ([`LazyPipeline::get`]). A CPU driver keeps each
/// pipeline's compiled code resident (lavapipe: about 2 MB a pipeline, 78 MB for a renderer's
/// kernels), and a frame runs one variant of each stage (one SH degree, one cutoff weight), so
/// the variants are built when a frame first needs them.
pub struct LazyPipeline {
    ctx: Context,
    name: &'static CStr,
    spirv: &'static [u32],
    set_layouts: Vec<vk::DescriptorSetLayout>,
    push_bytes: u32,
    constants: Vec<(u32, u32)>,
    built: std::sync::OnceLock<ComputePipeline>,
}

impl LazyPipeline {
    /// The pipeline of [`ComputePipeline::with_set_layout`], not built yet.
    pub fn new<P: bytemuck::Pod>(
        ctx: &Context,
        name: &'static CStr,
        spirv: &'static [u32],
        set_layout: Option<vk::DescriptorSetLayout>,
    ) -> Self {
        let layouts: Vec<vk::DescriptorSetLayout> = set_layout.into_iter().collect();
        Self::with_set_layouts::<P>(ctx, name, spirv, &layouts)
    }

    /// The pipeline of [`ComputePipeline::with_set_layouts`], not built yet.
    pub fn with_set_layouts<P: bytemuck::Pod>(
        ctx: &Context,
        name: &'static CStr,
        spirv: &'static [u32],
        set_layouts: &[vk::DescriptorSetLayout],
    ) -> Self {
        LazyPipeline {
            ctx: ctx.clone(),
            name,
            spirv,
            set_layouts: set_layouts.to_vec(),
            push_bytes: std::mem::size_of::<P>() as u32,
            constants: Vec::new(),
            built: std::sync::OnceLock::new(),
        }
    }

    /// This pipeline with the 32-bit specialization constants `constants` (constant id,
    /// value).
    pub fn specialized(mut self, constants: &[(u32, u32)]) -> Self {
        self.constants = constants.to_vec();
        self
    }

    /// The pipeline, built now if it was not.
    pub fn get(&self) -> Result<&ComputePipeline> {
        if let Some(p) = self.built.get() {
            return Ok(p);
        }
        let p = ComputePipeline::with_push_bytes(
            &self.ctx,
            self.name,
            self.spirv,
            &self.set_layouts,
            self.push_bytes,
            &self.constants,
        )?;
        // Another thread may have built it meanwhile: either is the same pipeline.
        let _ = self.built.set(p);
        Ok(self.built.get().expect("set above"))
    }

    /// The pipeline, which [`LazyPipeline::get`] must have built (a stage's `prepare`).
    pub fn built(&self) -> &ComputePipeline {
        self.built
            .get()
            .unwrap_or_else(|| panic!("{:?} used before it was built", self.name))
    }
}

impl Drop for ComputePipeline {
    fn drop(&mut self) {
        unsafe {
            self.ctx.device().destroy_pipeline(self.raw, None);
            self.ctx.device().destroy_pipeline_layout(self.layout, None);
        }
    }
}

/// Makes the writes of earlier compute dispatches (and transfers) visible to later dispatches
/// and indirect-argument reads.
pub fn compute_barrier(ctx: &Context, cmd: vk::CommandBuffer) {
    let barrier = vk::MemoryBarrier::default()
        .src_access_mask(vk::AccessFlags::SHADER_WRITE | vk::AccessFlags::TRANSFER_WRITE)
        .dst_access_mask(
            vk::AccessFlags::SHADER_READ
                | vk::AccessFlags::SHADER_WRITE
                | vk::AccessFlags::INDIRECT_COMMAND_READ
                | vk::AccessFlags::TRANSFER_READ
                | vk::AccessFlags::TRANSFER_WRITE,
        );
    unsafe {
        ctx.device().cmd_pipeline_barrier(
            cmd,
            vk::PipelineStageFlags::COMPUTE_SHADER | vk::PipelineStageFlags::TRANSFER,
            vk::PipelineStageFlags::COMPUTE_SHADER
                | vk::PipelineStageFlags::DRAW_INDIRECT
                | vk::PipelineStageFlags::TRANSFER,
            vk::DependencyFlags::empty(),
            &[barrier],
            &[],
            &[],
        )
    };
}

/// Makes transfer writes recorded before it visible to the host's reads once the submission's
/// fence is waited on (a fence's wait alone covers device accesses only: the Vulkan spec,
/// "Fences").
pub fn host_read_barrier(ctx: &Context, cmd: vk::CommandBuffer) {
    let barrier = vk::MemoryBarrier::default()
        .src_access_mask(vk::AccessFlags::TRANSFER_WRITE)
        .dst_access_mask(vk::AccessFlags::HOST_READ);
    unsafe {
        ctx.device().cmd_pipeline_barrier(
            cmd,
            vk::PipelineStageFlags::TRANSFER,
            vk::PipelineStageFlags::HOST,
            vk::DependencyFlags::empty(),
            &[barrier],
            &[],
            &[],
        )
    };
}
