//! What rara needs from a Vulkan device, for an engine to merge into its own device creation,
//! and the checks that turn a missing piece into a clear [`Error::MissingRequirement`].

use ash::vk;

use crate::constants::{LINEAR_WORKGROUP, MIN_SUBGROUP_SIZE};
use crate::error::{Error, Result};

/// The Vulkan version, extensions, features and properties rara needs ([`requirements`]).
///
/// An engine that creates its own device merges these before `vkCreateDevice`:
///
/// ```no_run
/// # use ash::vk;
/// # fn f(instance: &ash::Instance, physical_device: vk::PhysicalDevice) {
/// let req = rara::requirements();
/// // Ask for at least req.api_version in VkApplicationInfo, then:
/// let supported = unsafe { instance.get_physical_device_features(physical_device) };
/// let mut features = vk::PhysicalDeviceFeatures::default();
/// req.enable_features(&mut features, &supported);
/// let mut features12 = vk::PhysicalDeviceVulkan12Features::default();
/// req.enable_vulkan12_features(&mut features12);
/// // ... features as the engine's VkDeviceCreateInfo::pEnabledFeatures, push_next(&mut
/// // features12) onto it, and list req.device_extensions (none today) with the engine's own;
/// // then tell rara what was enabled:
/// let enabled = rara::EnabledFeatures {
///     optional: rara::vk::Optional {
///         shader_int64: features.shader_int64 == vk::TRUE,
///         ..Default::default()
///     },
///     ..Default::default()
/// };
/// # }
/// ```
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct Requirements {
    /// Lowest Vulkan API version of the instance and device (`VK_API_VERSION_1_2`).
    pub api_version: u32,
    /// Device extensions to enable (none: everything rara uses is core in Vulkan 1.2).
    pub device_extensions: Vec<&'static std::ffi::CStr>,
    /// `VkPhysicalDeviceVulkan12Features::bufferDeviceAddress`: every kernel reaches its
    /// buffers through device addresses.
    pub buffer_device_address: bool,
    /// `VkPhysicalDeviceVulkan12Features::vulkanMemoryModel` and
    /// `vulkanMemoryModelDeviceScope`: the ray tracer's BVH build orders its bottom-up walk with
    /// acquire/release atomics (`glsl/bvh_bounds.comp`; a memory barrier in divergent control
    /// flow is not honoured by every driver).
    pub vulkan_memory_model: bool,
    /// Subgroup operations the kernels use in compute shaders (basic and arithmetic, for the
    /// prefix sums and the sort); a property of the device, not something to enable.
    pub subgroup_operations: vk::SubgroupFeatureFlags,
    /// The smallest compute subgroup size (4): the sort's scatter and the workgroup scan keep
    /// one shared-memory slot per subgroup, sized for subgroups of 4 or more; nothing else
    /// depends on the size (SwiftShader runs 4, lavapipe 8, NVIDIA 32, AMD 32 or 64).
    pub min_subgroup_size: u32,
    /// The workgroup size the largest kernels take, along x and in all (256, past Vulkan's
    /// guaranteed 128: `maxComputeWorkGroupInvocations`, `maxComputeWorkGroupSize[0]`).
    pub workgroup_invocations: u32,
}

/// Optional capabilities: rara uses them when the engine enabled them and works without.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct Optional {
    /// `VkPhysicalDeviceFeatures::shaderInt64`: the kernels then run in their form with 64-bit
    /// integers ([`crate::vk::DeviceInfo::shader_int64`]), which moves 16-byte records as two
    /// 64-bit words and halves the scalar per-lane loops a CPU driver makes of each load and
    /// store (see `load_vec4` in `glsl/common.glsl`); the same frame, faster on lavapipe.
    /// Without it (SwiftShader, many mobile GPUs) they add addresses as two 32-bit words.
    /// [`Requirements::enable_features`] turns it on where the device has it.
    pub shader_int64: bool,
    /// `VkPhysicalDeviceFeatures::pipelineStatisticsQuery`: compute invocations per pass in
    /// the pass timings.
    pub pipeline_statistics_query: bool,
    /// The instance has `VK_EXT_debug_utils` enabled: passes get labels for RenderDoc / Nsight
    /// and buffers get names.
    pub debug_utils: bool,
}

/// What rara needs from a device; see [`Requirements`].
pub fn requirements() -> Requirements {
    Requirements {
        api_version: vk::API_VERSION_1_2,
        device_extensions: Vec::new(),
        buffer_device_address: true,
        vulkan_memory_model: true,
        subgroup_operations: vk::SubgroupFeatureFlags::BASIC | vk::SubgroupFeatureFlags::ARITHMETIC,
        min_subgroup_size: MIN_SUBGROUP_SIZE,
        workgroup_invocations: LINEAR_WORKGROUP,
    }
}

impl Requirements {
    /// Turns on, in an engine's `VkPhysicalDeviceFeatures`, the Vulkan 1.0 features rara uses
    /// where `supported` (the physical device's) has them, and leaves the others as they are.
    /// rara needs none; it runs faster with `shaderInt64` ([`Optional::shader_int64`]: tell
    /// rara whether it was enabled).
    pub fn enable_features(
        &self,
        features: &mut vk::PhysicalDeviceFeatures,
        supported: &vk::PhysicalDeviceFeatures,
    ) {
        if supported.shader_int64 == vk::TRUE {
            features.shader_int64 = vk::TRUE;
        }
    }

    /// Turns on, in an engine's feature chain, the Vulkan 1.2 features rara needs (leaves the
    /// others as they are).
    pub fn enable_vulkan12_features(&self, features: &mut vk::PhysicalDeviceVulkan12Features) {
        if self.buffer_device_address {
            features.buffer_device_address = vk::TRUE;
        }
        if self.vulkan_memory_model {
            features.vulkan_memory_model = vk::TRUE;
            features.vulkan_memory_model_device_scope = vk::TRUE;
        }
    }

    /// Checks that a physical device can meet the requirements; the error names each piece it
    /// lacks.
    ///
    /// # Safety
    /// `physical_device` must be a valid handle enumerated from `instance`.
    pub unsafe fn check_physical_device(
        &self,
        instance: &ash::Instance,
        physical_device: vk::PhysicalDevice,
    ) -> Result<()> {
        let mut subgroup = vk::PhysicalDeviceSubgroupProperties::default();
        let mut props2 = vk::PhysicalDeviceProperties2::default().push_next(&mut subgroup);
        instance.get_physical_device_properties2(physical_device, &mut props2);
        let props = props2.properties;
        let mut f12 = vk::PhysicalDeviceVulkan12Features::default();
        let mut f2 = vk::PhysicalDeviceFeatures2::default().push_next(&mut f12);
        instance.get_physical_device_features2(physical_device, &mut f2);
        let name = props
            .device_name_as_c_str()
            .map(|n| n.to_string_lossy().into_owned())
            .unwrap_or_default();
        let mut missing = Vec::new();
        if props.api_version < self.api_version {
            missing.push(format!(
                "Vulkan {}.{} (the device has {}.{})",
                vk::api_version_major(self.api_version),
                vk::api_version_minor(self.api_version),
                vk::api_version_major(props.api_version),
                vk::api_version_minor(props.api_version)
            ));
        }
        if self.buffer_device_address && f12.buffer_device_address != vk::TRUE {
            missing.push("the bufferDeviceAddress feature".into());
        }
        if self.vulkan_memory_model
            && (f12.vulkan_memory_model != vk::TRUE
                || f12.vulkan_memory_model_device_scope != vk::TRUE)
        {
            missing.push("the vulkanMemoryModel and vulkanMemoryModelDeviceScope features".into());
        }
        if !subgroup
            .supported_stages
            .contains(vk::ShaderStageFlags::COMPUTE)
            || !subgroup
                .supported_operations
                .contains(self.subgroup_operations)
        {
            missing.push(format!(
                "subgroup operations {:?} in compute shaders",
                self.subgroup_operations
            ));
        }
        // Shared memory: at most 11 KiB a workgroup, within Vulkan's guaranteed 16 KiB.
        let limits = &props.limits;
        let wanted = self.workgroup_invocations;
        if limits.max_compute_work_group_invocations < wanted
            || limits.max_compute_work_group_size[0] < wanted
        {
            missing.push(format!(
                "workgroups of {wanted} invocations (the device has \
                 maxComputeWorkGroupInvocations {}, maxComputeWorkGroupSize.x {})",
                limits.max_compute_work_group_invocations, limits.max_compute_work_group_size[0]
            ));
        }
        // The kernels are SPIR-V 1.5 without varying-size pipelines, so `subgroupSize` is the
        // size they run at.
        if subgroup.subgroup_size < self.min_subgroup_size {
            missing.push(format!(
                "a subgroup size of {} or more (the device has {})",
                self.min_subgroup_size, subgroup.subgroup_size
            ));
        }
        if missing.is_empty() {
            Ok(())
        } else {
            Err(Error::MissingRequirement(format!(
                "{name} lacks {}",
                missing.join(", ")
            )))
        }
    }

    /// Checks what an engine says it enabled on its device against the requirements.
    pub fn check_enabled(&self, enabled: &EnabledFeatures) -> Result<()> {
        let mut missing = Vec::new();
        if enabled.api_version < self.api_version {
            missing.push(format!(
                "an instance and device of Vulkan {}.{} or later (apiVersion {}.{} was given)",
                vk::api_version_major(self.api_version),
                vk::api_version_minor(self.api_version),
                vk::api_version_major(enabled.api_version),
                vk::api_version_minor(enabled.api_version)
            ));
        }
        if self.buffer_device_address && !enabled.buffer_device_address {
            missing.push(
                "VkPhysicalDeviceVulkan12Features::bufferDeviceAddress enabled at \
                 vkCreateDevice"
                    .to_string(),
            );
        }
        if self.vulkan_memory_model && !enabled.vulkan_memory_model {
            missing.push(
                "VkPhysicalDeviceVulkan12Features::vulkanMemoryModel and \
                 vulkanMemoryModelDeviceScope enabled at vkCreateDevice"
                    .into(),
            );
        }
        if missing.is_empty() {
            Ok(())
        } else {
            Err(Error::MissingRequirement(format!(
                "the engine's device lacks what rara needs: {} (merge rara::requirements() \
                 into the device's creation)",
                missing.join("; ")
            )))
        }
    }
}

/// What an engine enabled when it created the instance and device it lends to rara
/// ([`crate::vk::BorrowedDevice`]). Vulkan cannot be asked which features a device was created
/// with, so the engine states them.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct EnabledFeatures {
    /// `VkApplicationInfo::apiVersion` of the instance (rara needs 1.2 or later).
    pub api_version: u32,
    /// `VkPhysicalDeviceVulkan12Features::bufferDeviceAddress`.
    pub buffer_device_address: bool,
    /// `VkPhysicalDeviceVulkan12Features::vulkanMemoryModel` and
    /// `vulkanMemoryModelDeviceScope`.
    pub vulkan_memory_model: bool,
    /// Optional capabilities the engine enabled.
    pub optional: Optional,
}

impl Default for EnabledFeatures {
    /// Everything rara requires, no optional capability.
    fn default() -> Self {
        EnabledFeatures {
            api_version: vk::API_VERSION_1_2,
            buffer_device_address: true,
            vulkan_memory_model: true,
            optional: Optional::default(),
        }
    }
}
