//! The Vulkan context: instance, device, queue and memory allocator.

use std::ffi::{c_void, CStr, CString};
use std::mem::ManuallyDrop;
use std::sync::{Arc, Mutex, MutexGuard};

use ash::vk;
use gpu_allocator::vulkan::{Allocator, AllocatorCreateDesc};

use crate::error::{Error, Result, VkContext};

const VALIDATION_LAYER: &CStr = c"VK_LAYER_KHRONOS_validation";

/// Whether to enable the Khronos validation layer.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Validation {
    /// Never.
    Off,
    /// When `VK_LAYER_KHRONOS_validation` is installed; silently without it otherwise.
    IfAvailable,
    /// Always; creating the context fails when the layer is missing.
    Required,
}

impl Validation {
    /// `Required` when the environment sets `RARA_VALIDATION=1`, else `Off`.
    pub fn from_env() -> Self {
        match std::env::var("RARA_VALIDATION").as_deref() {
            Ok("1") | Ok("true") | Ok("on") => Validation::Required,
            _ => Validation::Off,
        }
    }
}

/// How to create a headless [`Context`].
#[derive(Clone, Debug)]
pub struct ContextDesc {
    /// Validation layer policy.
    pub validation: Validation,
    /// Pick the first device whose name contains this (case-insensitive); `None` picks by type
    /// (discrete > integrated > virtual > CPU). [`ContextDesc::from_env`] reads `RARA_DEVICE`.
    pub device_name: Option<String>,
    /// Enable `shaderInt64` where the device has it, for the kernels' faster form
    /// ([`DeviceInfo::shader_int64`]); false runs the portable form everywhere (the same
    /// frames; [`ContextDesc::from_env`] reads `RARA_INT64=0`).
    pub shader_int64: bool,
}

impl ContextDesc {
    /// Validation from `RARA_VALIDATION`, device from `RARA_DEVICE`, `RARA_INT64=0` for the
    /// portable kernels on any device.
    pub fn from_env() -> Self {
        ContextDesc {
            validation: Validation::from_env(),
            device_name: std::env::var("RARA_DEVICE").ok().filter(|s| !s.is_empty()),
            shader_int64: std::env::var("RARA_INT64").map_or(true, |v| v.trim() != "0"),
        }
    }
}

impl Default for ContextDesc {
    fn default() -> Self {
        ContextDesc {
            validation: Validation::Off,
            device_name: None,
            shader_int64: true,
        }
    }
}

/// What is known about the chosen device.
#[derive(Clone, Debug)]
pub struct DeviceInfo {
    /// `VkPhysicalDeviceProperties::deviceName`.
    pub name: String,
    /// Physical device type.
    pub device_type: vk::PhysicalDeviceType,
    /// Driver name and version string (`VkPhysicalDeviceDriverProperties`).
    pub driver: String,
    /// Nanoseconds per timestamp tick.
    pub timestamp_period_ns: f32,
    /// Whether the queue writes timestamps.
    pub timestamps: bool,
    /// Largest storage-buffer binding; rara uses device addresses and never binds, but reports it.
    pub max_storage_buffer_range: u32,
    /// Subgroup size of compute shaders.
    pub subgroup_size: u32,
    /// Largest single memory allocation (`maxMemoryAllocationSize`): a buffer larger than this
    /// is refused with [`crate::Error::OutOfDeviceMemory`] before Vulkan is asked.
    pub max_memory_allocation_size: u64,
    /// `maxTexelBufferElements`: the most texels a buffer view holds.
    pub max_texel_buffer_elements: u32,
    /// Size of the largest device-local memory heap (lavapipe reports 2 GiB but does not
    /// enforce it: its memory is the host's).
    pub device_local_heap_bytes: u64,
    /// Whether pipeline-statistics queries are enabled (compute invocations per pass).
    pub pipeline_statistics: bool,
    /// Whether the kernels run in their form with 64-bit integers: the device has
    /// `shaderInt64` and it is enabled (by rara for its own device unless
    /// [`ContextDesc::shader_int64`] is false, by the engine for a borrowed one:
    /// [`crate::vk::Optional::shader_int64`]). Otherwise the portable form, the same frames.
    pub shader_int64: bool,
}

impl DeviceInfo {
    /// The form of the kernels the device runs, as reports name it: `"int64"` (the form with
    /// 64-bit integers, [`DeviceInfo::shader_int64`]) or `"portable"`.
    pub fn kernel_form(&self) -> &'static str {
        if self.shader_int64 {
            "int64"
        } else {
            "portable"
        }
    }
}

/// The instance-level objects of a context that rara created itself (headless).
struct OwnedInstance {
    _entry: ash::Entry,
    debug: Option<(ash::ext::debug_utils::Instance, vk::DebugUtilsMessengerEXT)>,
}

pub(crate) struct ContextShared {
    /// `None` when the instance and device are borrowed from an engine: then rara destroys only
    /// what it made (its allocator's memory, its command pool), never the engine's objects.
    owned: Option<OwnedInstance>,
    pub(crate) instance: ash::Instance,
    pub(crate) physical_device: vk::PhysicalDevice,
    pub(crate) device: ash::Device,
    pub(crate) queue: vk::Queue,
    pub(crate) queue_family: u32,
    pub(crate) info: DeviceInfo,
    allocator: ManuallyDrop<Mutex<Allocator>>,
    pub(crate) debug_device: Option<ash::ext::debug_utils::Device>,
    // Boxed so the pointer handed to the debug callback stays valid.
    messages: Box<Mutex<Vec<String>>>,
    upload_pool: Mutex<vk::CommandPool>,
}

/// A Vulkan device with its queue and rara's memory allocator.
///
/// Either **owned** ([`Context::headless`]: rara creates the instance and device, as the CLI
/// does) or **borrowed** ([`Context::borrowed`]: an engine lends its instance, device and queue
/// and keeps ownership of them).
///
/// Cheap to clone: clones share the device. Resources made from it (renderers, scenes, frame
/// slots, buffers) keep it alive; once the last of them is dropped, an owned context destroys
/// its device and instance, a borrowed one only what rara created on the engine's device.
#[derive(Clone)]
pub struct Context {
    pub(crate) shared: Arc<ContextShared>,
}

/// An engine's Vulkan objects, lent to [`Context::borrowed`].
#[derive(Clone)]
pub struct BorrowedDevice {
    /// The engine's instance (function table and handle; rara never destroys it).
    pub instance: ash::Instance,
    /// The physical device the engine's device was created from.
    pub physical_device: vk::PhysicalDevice,
    /// The engine's device (rara never destroys it).
    pub device: ash::Device,
    /// A queue family with compute support; rara's command buffers are recorded for it.
    pub queue_family: u32,
    /// A queue of that family. rara submits to it only inside calls that upload or read back
    /// (scene upload, [`Context::run_commands`], the headless [`crate::Renderer::render`]);
    /// [`crate::Renderer::record`] never submits.
    pub queue: vk::Queue,
    /// What the engine enabled at instance and device creation.
    pub enabled: super::EnabledFeatures,
}

unsafe extern "system" fn debug_callback(
    severity: vk::DebugUtilsMessageSeverityFlagsEXT,
    _types: vk::DebugUtilsMessageTypeFlagsEXT,
    data: *const vk::DebugUtilsMessengerCallbackDataEXT<'_>,
    user: *mut c_void,
) -> vk::Bool32 {
    let messages = &*(user as *const Mutex<Vec<String>>);
    let text = if data.is_null() || (*data).p_message.is_null() {
        String::from("(no message)")
    } else {
        CStr::from_ptr((*data).p_message)
            .to_string_lossy()
            .into_owned()
    };
    let text = format!("[{severity:?}] {text}");
    eprintln!("rara: Vulkan validation: {text}");
    if let Ok(mut m) = messages.lock() {
        m.push(text);
    }
    vk::FALSE
}

fn type_rank(t: vk::PhysicalDeviceType) -> u32 {
    match t {
        vk::PhysicalDeviceType::DISCRETE_GPU => 0,
        vk::PhysicalDeviceType::INTEGRATED_GPU => 1,
        vk::PhysicalDeviceType::VIRTUAL_GPU => 2,
        vk::PhysicalDeviceType::CPU => 3,
        _ => 4,
    }
}

impl Context {
    /// A headless context configured from the environment (`RARA_VALIDATION`, `RARA_DEVICE`).
    pub fn from_env() -> Result<Self> {
        Self::headless(&ContextDesc::from_env())
    }

    /// Creates an instance and a device of its own, with no surface.
    pub fn headless(desc: &ContextDesc) -> Result<Self> {
        let entry = unsafe { ash::Entry::load() }.map_err(|e| Error::Loading(e.to_string()))?;
        let layers = unsafe { entry.enumerate_instance_layer_properties() }
            .vk("vkEnumerateInstanceLayerProperties")?;
        let has_validation = layers
            .iter()
            .any(|l| l.layer_name_as_c_str().is_ok_and(|n| n == VALIDATION_LAYER));
        let validation = match desc.validation {
            Validation::Off => false,
            Validation::IfAvailable => has_validation,
            Validation::Required if !has_validation => {
                return Err(Error::Loading(
                    "the validation layer VK_LAYER_KHRONOS_validation is not installed \
                     (Debian: apt-get install vulkan-validationlayers)"
                        .into(),
                ))
            }
            Validation::Required => true,
        };
        let extensions = unsafe { entry.enumerate_instance_extension_properties(None) }
            .vk("vkEnumerateInstanceExtensionProperties")?;
        let has_debug_utils = extensions.iter().any(|e| {
            e.extension_name_as_c_str()
                .is_ok_and(|n| n == ash::ext::debug_utils::NAME)
        });

        let app_name = CString::new("rara").unwrap();
        let app = vk::ApplicationInfo::default()
            .application_name(&app_name)
            .engine_name(&app_name)
            .api_version(vk::API_VERSION_1_2);
        let layer_ptrs: Vec<*const i8> = if validation {
            vec![VALIDATION_LAYER.as_ptr()]
        } else {
            vec![]
        };
        let ext_ptrs: Vec<*const i8> = if has_debug_utils {
            vec![ash::ext::debug_utils::NAME.as_ptr()]
        } else {
            vec![]
        };
        let instance_info = vk::InstanceCreateInfo::default()
            .application_info(&app)
            .enabled_layer_names(&layer_ptrs)
            .enabled_extension_names(&ext_ptrs);
        let instance = match unsafe { entry.create_instance(&instance_info, None) } {
            // The loader found no driver that answers: say which to install.
            Err(vk::Result::ERROR_INCOMPATIBLE_DRIVER) => {
                return Err(Error::NoSuitableDevice(NO_DRIVER_HINT.into()))
            }
            other => other.vk("vkCreateInstance")?,
        };

        let messages: Box<Mutex<Vec<String>>> = Box::default();
        let debug = if validation && has_debug_utils {
            let loader = ash::ext::debug_utils::Instance::new(&entry, &instance);
            let info = vk::DebugUtilsMessengerCreateInfoEXT::default()
                .message_severity(
                    vk::DebugUtilsMessageSeverityFlagsEXT::WARNING
                        | vk::DebugUtilsMessageSeverityFlagsEXT::ERROR,
                )
                .message_type(
                    vk::DebugUtilsMessageTypeFlagsEXT::VALIDATION
                        | vk::DebugUtilsMessageTypeFlagsEXT::PERFORMANCE,
                )
                .pfn_user_callback(Some(debug_callback))
                .user_data(&*messages as *const Mutex<Vec<String>> as *mut c_void);
            match unsafe { loader.create_debug_utils_messenger(&info, None) } {
                Ok(m) => Some((loader, m)),
                Err(e) => {
                    unsafe { instance.destroy_instance(None) };
                    return Err(Error::Vulkan {
                        call: "vkCreateDebugUtilsMessengerEXT",
                        result: e,
                    });
                }
            }
        } else {
            None
        };

        // On failure create_device destroys the instance and messenger too.
        Self::create_device(entry, instance, debug, messages, desc, has_debug_utils)
    }

    /// Wraps an engine's instance, device and queue. rara then allocates its memory with an
    /// allocator of its own on that device, records into the engine's command buffers
    /// ([`crate::Renderer::record`]) and, when the context and everything made from it are
    /// dropped, destroys what it created and nothing of the engine's.
    ///
    /// Fails with [`Error::MissingRequirement`] when the physical device cannot meet
    /// [`crate::requirements()`] or `enabled` says the engine did not enable a required feature.
    ///
    /// # Safety
    /// - `instance`, `physical_device`, `device` and `queue` are valid, the device was created
    ///   from that physical device of that instance, and `queue` belongs to `queue_family` of
    ///   that device, a family with compute support;
    /// - `enabled` tells the truth about what the instance and device were created with;
    /// - the instance and device outlive this context and everything made from it (the
    ///   engine destroys them only after dropping every rara object and after the GPU finished
    ///   the work rara recorded);
    /// - while a rara call that submits runs (see [`BorrowedDevice::queue`]), no other thread
    ///   uses `queue` (Vulkan requires host synchronisation of a queue).
    pub unsafe fn borrowed(lent: BorrowedDevice) -> Result<Self> {
        let requirements = super::requirements();
        requirements.check_physical_device(&lent.instance, lent.physical_device)?;
        requirements.check_enabled(&lent.enabled)?;
        let families = lent
            .instance
            .get_physical_device_queue_family_properties(lent.physical_device);
        let family = families.get(lent.queue_family as usize).ok_or_else(|| {
            Error::InvalidInput(format!(
                "queue family {} does not exist ({} families)",
                lent.queue_family,
                families.len()
            ))
        })?;
        if !family.queue_flags.contains(vk::QueueFlags::COMPUTE) {
            return Err(Error::MissingRequirement(format!(
                "queue family {} has no compute support",
                lent.queue_family
            )));
        }
        let mut info = device_info_of(&lent.instance, lent.physical_device, lent.queue_family);
        info.pipeline_statistics &= lent.enabled.optional.pipeline_statistics_query;
        info.shader_int64 &= lent.enabled.optional.shader_int64;
        let allocator = Allocator::new(&AllocatorCreateDesc {
            instance: lent.instance.clone(),
            device: lent.device.clone(),
            physical_device: lent.physical_device,
            debug_settings: Default::default(),
            buffer_device_address: true,
            allocation_sizes: Default::default(),
        })
        .map_err(|e| Error::Allocation {
            what: "the allocator".into(),
            source: e,
        })?;
        let pool_info = vk::CommandPoolCreateInfo::default()
            .queue_family_index(lent.queue_family)
            .flags(vk::CommandPoolCreateFlags::RESET_COMMAND_BUFFER);
        let upload_pool = lent
            .device
            .create_command_pool(&pool_info, None)
            .vk("vkCreateCommandPool")?;
        let debug_device = lent
            .enabled
            .optional
            .debug_utils
            .then(|| ash::ext::debug_utils::Device::new(&lent.instance, &lent.device));
        Ok(Context {
            shared: Arc::new(ContextShared {
                owned: None,
                instance: lent.instance,
                physical_device: lent.physical_device,
                device: lent.device,
                queue: lent.queue,
                queue_family: lent.queue_family,
                info,
                allocator: ManuallyDrop::new(Mutex::new(allocator)),
                debug_device,
                messages: Box::default(),
                upload_pool: Mutex::new(upload_pool),
            }),
        })
    }

    fn create_device(
        entry: ash::Entry,
        instance: ash::Instance,
        debug: Option<(ash::ext::debug_utils::Instance, vk::DebugUtilsMessengerEXT)>,
        messages: Box<Mutex<Vec<String>>>,
        desc: &ContextDesc,
        has_debug_utils: bool,
    ) -> Result<Self> {
        let destroy_instance = |debug: &Option<(
            ash::ext::debug_utils::Instance,
            vk::DebugUtilsMessengerEXT,
        )>| unsafe {
            if let Some((loader, m)) = debug {
                loader.destroy_debug_utils_messenger(*m, None);
            }
            instance.destroy_instance(None);
        };
        let chosen = match choose_physical_device(&instance, desc.device_name.as_deref()) {
            Ok(c) => c,
            Err(e) => {
                destroy_instance(&debug);
                return Err(e);
            }
        };
        let (physical_device, queue_family) = chosen;

        let priorities = [1.0f32];
        let queue_info = [vk::DeviceQueueCreateInfo::default()
            .queue_family_index(queue_family)
            .queue_priorities(&priorities)];
        let mut features12 = vk::PhysicalDeviceVulkan12Features::default();
        super::requirements().enable_vulkan12_features(&mut features12);
        let supported = unsafe { instance.get_physical_device_features(physical_device) };
        let mut features = vk::PhysicalDeviceFeatures::default()
            .pipeline_statistics_query(supported.pipeline_statistics_query == vk::TRUE);
        if desc.shader_int64 {
            super::requirements().enable_features(&mut features, &supported);
        }
        let device_info = vk::DeviceCreateInfo::default()
            .queue_create_infos(&queue_info)
            .enabled_features(&features)
            .push_next(&mut features12);
        let device = match unsafe { instance.create_device(physical_device, &device_info, None) } {
            Ok(d) => d,
            Err(e) => {
                destroy_instance(&debug);
                return Err(Error::Vulkan {
                    call: "vkCreateDevice",
                    result: e,
                });
            }
        };
        let queue = unsafe { device.get_device_queue(queue_family, 0) };
        let mut info = device_info_of(&instance, physical_device, queue_family);
        info.shader_int64 &= features.shader_int64 == vk::TRUE;

        let allocator = match Allocator::new(&AllocatorCreateDesc {
            instance: instance.clone(),
            device: device.clone(),
            physical_device,
            debug_settings: Default::default(),
            buffer_device_address: true,
            allocation_sizes: Default::default(),
        }) {
            Ok(a) => a,
            Err(e) => {
                unsafe { device.destroy_device(None) };
                destroy_instance(&debug);
                return Err(Error::Allocation {
                    what: "the allocator".into(),
                    source: e,
                });
            }
        };
        let pool_info = vk::CommandPoolCreateInfo::default()
            .queue_family_index(queue_family)
            .flags(vk::CommandPoolCreateFlags::RESET_COMMAND_BUFFER);
        let upload_pool =
            unsafe { device.create_command_pool(&pool_info, None) }.vk("vkCreateCommandPool")?;
        let debug_device =
            has_debug_utils.then(|| ash::ext::debug_utils::Device::new(&instance, &device));

        Ok(Context {
            shared: Arc::new(ContextShared {
                owned: Some(OwnedInstance {
                    _entry: entry,
                    debug,
                }),
                instance,
                physical_device,
                device,
                queue,
                queue_family,
                info,
                allocator: ManuallyDrop::new(Mutex::new(allocator)),
                debug_device,
                messages,
                upload_pool: Mutex::new(upload_pool),
            }),
        })
    }

    /// The logical device.
    pub fn device(&self) -> &ash::Device {
        &self.shared.device
    }

    /// The queue rara submits to in headless use.
    pub fn queue(&self) -> vk::Queue {
        self.shared.queue
    }

    /// Its queue family.
    pub fn queue_family(&self) -> u32 {
        self.shared.queue_family
    }

    /// Facts about the device (name, driver, timestamp period, ...).
    pub fn info(&self) -> &DeviceInfo {
        &self.shared.info
    }

    /// The instance (the engine's when borrowed).
    pub fn instance(&self) -> &ash::Instance {
        &self.shared.instance
    }

    /// The physical device.
    pub fn physical_device(&self) -> vk::PhysicalDevice {
        self.shared.physical_device
    }

    /// Whether the instance and device are an engine's ([`Context::borrowed`]).
    pub fn is_borrowed(&self) -> bool {
        self.shared.owned.is_none()
    }

    /// Whether the validation layer is reporting to this context (owned contexts only; a
    /// borrowed context's messages go to the engine's messenger).
    pub fn validation_enabled(&self) -> bool {
        self.shared
            .owned
            .as_ref()
            .is_some_and(|o| o.debug.is_some())
    }

    /// Live allocations of rara's allocator, as (name, bytes): empty once every scene,
    /// renderer, frame slot and buffer made from this context is dropped. Use it to check for
    /// leaks before tearing down.
    pub fn live_allocations(&self) -> Vec<(String, u64)> {
        self.allocator()
            .generate_report()
            .allocations
            .into_iter()
            .map(|a| (a.name, a.size))
            .collect()
    }

    /// Takes the validation warnings and errors reported so far (owned contexts).
    pub fn take_validation_messages(&self) -> Vec<String> {
        std::mem::take(&mut *self.shared.messages.lock().unwrap())
    }

    pub(crate) fn allocator(&self) -> MutexGuard<'_, Allocator> {
        self.shared.allocator.lock().unwrap()
    }

    /// Records commands with `record` into a fresh command buffer, submits it and waits.
    pub fn run_commands<R>(&self, record: impl FnOnce(vk::CommandBuffer) -> R) -> Result<R> {
        let device = &self.shared.device;
        let pool = self.shared.upload_pool.lock().unwrap();
        let alloc = vk::CommandBufferAllocateInfo::default()
            .command_pool(*pool)
            .level(vk::CommandBufferLevel::PRIMARY)
            .command_buffer_count(1);
        let cmd =
            unsafe { device.allocate_command_buffers(&alloc) }.vk("vkAllocateCommandBuffers")?[0];
        let result = (|| {
            let begin = vk::CommandBufferBeginInfo::default()
                .flags(vk::CommandBufferUsageFlags::ONE_TIME_SUBMIT);
            unsafe { device.begin_command_buffer(cmd, &begin) }.vk("vkBeginCommandBuffer")?;
            let value = record(cmd);
            unsafe { device.end_command_buffer(cmd) }.vk("vkEndCommandBuffer")?;
            self.submit_and_wait(cmd)?;
            Ok(value)
        })();
        unsafe { device.free_command_buffers(*pool, &[cmd]) };
        result
    }

    /// Submits a recorded command buffer to the queue and waits for it on a fence. A wait past
    /// `RARA_GPU_WARN_S` seconds (60 by default; 0: never) says so on stderr once and goes on
    /// waiting: the work may still end, and what it uses must not be freed before it does.
    pub fn submit_and_wait(&self, cmd: vk::CommandBuffer) -> Result<()> {
        let device = &self.shared.device;
        let fence = unsafe { device.create_fence(&vk::FenceCreateInfo::default(), None) }
            .vk("vkCreateFence")?;
        let cmds = [cmd];
        let submit = [vk::SubmitInfo::default().command_buffers(&cmds)];
        let warn_after = gpu_warn_seconds();
        let first_wait = if warn_after > 0.0 {
            (warn_after * 1e9).min(u64::MAX as f64) as u64
        } else {
            u64::MAX
        };
        let result = unsafe { device.queue_submit(self.shared.queue, &submit, fence) }
            .vk("vkQueueSubmit")
            .and_then(|_| {
                match unsafe { device.wait_for_fences(&[fence], true, first_wait) } {
                    Err(vk::Result::TIMEOUT) => {
                        eprintln!(
                            "rara: the GPU has not finished a submission after {warn_after} s; \
                             still waiting (a kernel that does not end, or a device far too \
                             slow for the work)"
                        );
                        unsafe { device.wait_for_fences(&[fence], true, u64::MAX) }
                    }
                    other => other,
                }
                .vk("vkWaitForFences")
            });
        unsafe { device.destroy_fence(fence, None) };
        result
    }

    /// Opens a named region for debuggers (RenderDoc, Nsight) when `VK_EXT_debug_utils` is on.
    pub fn begin_label(&self, cmd: vk::CommandBuffer, name: &CStr) {
        if let Some(d) = &self.shared.debug_device {
            let label = vk::DebugUtilsLabelEXT::default().label_name(name);
            unsafe { d.cmd_begin_debug_utils_label(cmd, &label) };
        }
    }

    /// Closes the region opened by [`Context::begin_label`].
    pub fn end_label(&self, cmd: vk::CommandBuffer) {
        if let Some(d) = &self.shared.debug_device {
            unsafe { d.cmd_end_debug_utils_label(cmd) };
        }
    }
}

impl Drop for ContextShared {
    fn drop(&mut self) {
        unsafe {
            let _ = self.device.device_wait_idle();
            self.device
                .destroy_command_pool(*self.upload_pool.get_mut().unwrap(), None);
            ManuallyDrop::drop(&mut self.allocator);
            // A borrowed device and instance stay the engine's to destroy.
            if let Some(owned) = &self.owned {
                self.device.destroy_device(None);
                if let Some((loader, messenger)) = &owned.debug {
                    loader.destroy_debug_utils_messenger(*messenger, None);
                }
                self.instance.destroy_instance(None);
            }
        }
    }
}

fn choose_physical_device(
    instance: &ash::Instance,
    wanted_name: Option<&str>,
) -> Result<(vk::PhysicalDevice, u32)> {
    let devices =
        unsafe { instance.enumerate_physical_devices() }.vk("vkEnumeratePhysicalDevices")?;
    let mut candidates = Vec::new();
    let mut rejected = Vec::new();
    for pd in devices {
        let props = unsafe { instance.get_physical_device_properties(pd) };
        let name = props
            .device_name_as_c_str()
            .map(|n| n.to_string_lossy().into_owned())
            .unwrap_or_default();
        if let Some(wanted) = wanted_name {
            if !name.to_lowercase().contains(&wanted.to_lowercase()) {
                rejected.push(format!("{name} (name does not match RARA_DEVICE={wanted})"));
                continue;
            }
        }
        if let Err(e) = unsafe { super::requirements().check_physical_device(instance, pd) } {
            rejected.push(format!("({e})"));
            continue;
        }
        let families = unsafe { instance.get_physical_device_queue_family_properties(pd) };
        let Some(family) = families
            .iter()
            .position(|f| f.queue_flags.contains(vk::QueueFlags::COMPUTE))
        else {
            rejected.push(format!("{name} (no compute queue)"));
            continue;
        };
        candidates.push((type_rank(props.device_type), pd, family as u32));
    }
    candidates.sort_by_key(|c| c.0);
    candidates.first().map(|c| (c.1, c.2)).ok_or_else(|| {
        Error::NoSuitableDevice(if rejected.is_empty() {
            "no Vulkan device found (on Debian: apt-get install mesa-vulkan-drivers for lavapipe)"
                .into()
        } else {
            format!("no suitable Vulkan device: {}", rejected.join("; "))
        })
    })
}

fn device_info_of(instance: &ash::Instance, pd: vk::PhysicalDevice, family: u32) -> DeviceInfo {
    let mut driver = vk::PhysicalDeviceDriverProperties::default();
    let mut subgroup = vk::PhysicalDeviceSubgroupProperties::default();
    let mut maintenance3 = vk::PhysicalDeviceMaintenance3Properties::default();
    let mut props2 = vk::PhysicalDeviceProperties2::default()
        .push_next(&mut driver)
        .push_next(&mut subgroup)
        .push_next(&mut maintenance3);
    unsafe { instance.get_physical_device_properties2(pd, &mut props2) };
    let props = props2.properties;
    let memory = unsafe { instance.get_physical_device_memory_properties(pd) };
    let device_local_heap_bytes = memory.memory_heaps[..memory.memory_heap_count as usize]
        .iter()
        .filter(|h| h.flags.contains(vk::MemoryHeapFlags::DEVICE_LOCAL))
        .map(|h| h.size)
        .max()
        .unwrap_or(0);
    let families = unsafe { instance.get_physical_device_queue_family_properties(pd) };
    let features = unsafe { instance.get_physical_device_features(pd) };
    let driver_name = driver
        .driver_name_as_c_str()
        .map(|c| c.to_string_lossy().into_owned())
        .unwrap_or_default();
    let driver_info = driver
        .driver_info_as_c_str()
        .map(|c| c.to_string_lossy().into_owned())
        .unwrap_or_default();
    DeviceInfo {
        name: props
            .device_name_as_c_str()
            .map(|n| n.to_string_lossy().into_owned())
            .unwrap_or_default(),
        device_type: props.device_type,
        driver: format!("{driver_name} {driver_info}").trim().to_owned(),
        timestamp_period_ns: props.limits.timestamp_period,
        timestamps: families[family as usize].timestamp_valid_bits > 0,
        max_storage_buffer_range: props.limits.max_storage_buffer_range,
        subgroup_size: subgroup.subgroup_size,
        max_memory_allocation_size: maintenance3.max_memory_allocation_size,
        max_texel_buffer_elements: props.limits.max_texel_buffer_elements,
        device_local_heap_bytes,
        pipeline_statistics: features.pipeline_statistics_query == vk::TRUE,
        shader_int64: features.shader_int64 == vk::TRUE,
    }
}

/// The error of a Vulkan loader that found no driver (vkCreateInstance:
/// VK_ERROR_INCOMPATIBLE_DRIVER).
const NO_DRIVER_HINT: &str = "no Vulkan driver found (vkCreateInstance: \
    VK_ERROR_INCOMPATIBLE_DRIVER). On the CPU, Mesa's lavapipe: apt-get install \
    mesa-vulkan-drivers. With an NVIDIA GPU: its driver's Vulkan ICD, and glvnd's libraries \
    (apt-get install libglvnd0 libglx0), without which NVIDIA's ICD gives the loader no \
    vkCreateInstance (a bare container). VK_LOADER_DEBUG=driver shows what the loader tried.";

/// After how long [`Context::submit_and_wait`] says that it is still waiting for the GPU:
/// `RARA_GPU_WARN_S` seconds (fractions allowed; 0: never), else 60, far past the longest
/// submission of the suite or the benches on lavapipe (seconds), so that a process held up by
/// the GPU says so rather than hanging in silence.
fn gpu_warn_seconds() -> f64 {
    const DEFAULT_SECONDS: f64 = 60.0;
    match std::env::var("RARA_GPU_WARN_S") {
        Ok(v) => match v.trim().parse::<f64>() {
            Ok(s) if s >= 0.0 && s.is_finite() => s,
            _ => DEFAULT_SECONDS,
        },
        Err(_) => DEFAULT_SECONDS,
    }
}
