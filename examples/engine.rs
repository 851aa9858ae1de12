//! rara inside an engine that owns everything: this program plays the engine.
//!
//! It creates its own Vulkan instance (with the validation layer when installed), device,
//! queue, command pool, colour and depth images, lends the device to rara with
//! `Context::borrowed`, and renders frames with two in flight. Each frame, in one command
//! buffer of the engine's: a mesh pass of its own (a lit cube, drawn by a graphics pipeline
//! into colour and depth attachments, depth-tested), a rara draw composited over it with the
//! depth test against the cube's depth (SPEC section 9) and a clip plane that moves from frame
//! to frame, a small compute pass of the engine's own (a vignette), and copies for read-back.
//! Each finished frame is written as `engine_frame_<i>.png`.
//!
//! Run: `cargo run --release --example engine [OUTPUT_DIR] [--ray]` (default
//! `target/engine-out`, so that nothing lands in the checkout; `--ray` draws with the ray
//! tracer, SPEC section 7, through the same `record`). Works headless on lavapipe. At the end it tears rara
//! down, checks that rara's allocator reports no live allocation, destroys its own objects, and
//! prints the validation messages (none).

use std::error::Error;
use std::ffi::{c_void, CStr};
use std::path::{Path, PathBuf};
use std::sync::Mutex;

use ash::vk;
use glam::Vec3;
use rara::clip::{Clip, ClipRegion, Plane};
use rara::timing::{PassTimer, MAX_PASSES};
use rara::{
    BorrowedDevice, Camera, Composite, Context, EnabledFeatures, FrameSlot, GpuScene,
    RenderOptions, Renderer, Target, TargetFormat,
};

/// Frames in flight, each with its own command buffer, fence, image, read-back buffer and
/// rara frame slot.
const IN_FLIGHT: usize = 2;
const WIDTH: u32 = 320;
const HEIGHT: u32 = 240;
const FORMAT: vk::Format = vk::Format::R8G8B8A8_UNORM;
const DEPTH_FORMAT: vk::Format = vk::Format::D32_SFLOAT;
/// The engine's projection planes (standard depth: 0 at the near plane, 1 at the far plane).
pub const NEAR: f32 = 0.1;
/// See [`NEAR`].
pub const FAR: f32 = 20.0;
/// The engine's clear colour: the rara draw goes over it.
const CLEAR: [f32; 4] = [0.10, 0.12, 0.20, 1.0];

/// The engine's own compute pass: darkens the image towards its corners.
const VIGNETTE_GLSL: &str = r#"
#version 450
layout(local_size_x = 16, local_size_y = 16) in;
layout(set = 0, binding = 0, rgba8) uniform image2D img;
void main() {
    ivec2 p = ivec2(gl_GlobalInvocationID.xy);
    ivec2 size = imageSize(img);
    if (p.x >= size.x || p.y >= size.y) return;
    vec2 d = (vec2(p) + 0.5) / vec2(size) - 0.5;
    vec4 c = imageLoad(img, p);
    imageStore(img, p, vec4(c.rgb * (1.0 - 0.8 * dot(d, d)), c.a));
}
"#;

/// The engine's mesh pass: a cube of half size 1 made from the vertex index (36 vertices, no
/// vertex buffer), transformed by the push constants.
const CUBE_VERT_GLSL: &str = r#"
#version 450
layout(push_constant) uniform Push { mat4 clip_from_model; mat4 world_from_model; } pc;
layout(location = 0) out vec3 normal;
const vec3 NORMALS[6] = vec3[](vec3(1, 0, 0), vec3(-1, 0, 0), vec3(0, 1, 0), vec3(0, -1, 0),
                               vec3(0, 0, 1), vec3(0, 0, -1));
const vec2 CORNERS[6] = vec2[](vec2(-1, -1), vec2(1, -1), vec2(1, 1), vec2(-1, -1), vec2(1, 1),
                               vec2(-1, 1));
void main() {
    vec3 n = NORMALS[gl_VertexIndex / 6];
    vec2 c = CORNERS[gl_VertexIndex % 6];
    vec3 a = abs(n.x) > 0.5 ? vec3(0, 1, 0) : vec3(1, 0, 0);
    vec3 b = cross(n, a);
    vec3 p = n + c.x * a + c.y * b;
    gl_Position = pc.clip_from_model * vec4(p, 1.0);
    normal = mat3(pc.world_from_model) * n;
}
"#;

/// Lambert shading of the cube under one directional light, plus ambient.
const CUBE_FRAG_GLSL: &str = r#"
#version 450
layout(location = 0) in vec3 normal;
layout(location = 0) out vec4 color;
void main() {
    vec3 light = normalize(vec3(-0.4, -0.8, -0.45));
    float lit = 0.25 + 0.75 * max(dot(normalize(normal), light), 0.0);
    color = vec4(vec3(0.35, 0.75, 0.9) * lit, 1.0);
}
"#;

/// The cube's model matrix: half size 0.3, turned 35 degrees about y and 20 about x, its
/// centre inside the demo scene's shell, beside its core.
pub fn cube_model() -> glam::Mat4 {
    glam::Mat4::from_scale_rotation_translation(
        Vec3::splat(0.3),
        glam::Quat::from_rotation_y(35f32.to_radians())
            * glam::Quat::from_rotation_x(20f32.to_radians()),
        Vec3::new(0.35, 0.1, 0.05),
    )
}

/// The engine's projection for rara's camera (SPEC section 2): camera space is x right, y
/// down, z forward, which is Vulkan's clip space up to the focal lengths; depth is standard,
/// `d = FAR (z - NEAR) / (z (FAR - NEAR))`, what `rara::DepthProjection` undoes.
pub fn clip_from_world(camera: &Camera) -> glam::Mat4 {
    let (w, h) = (camera.width as f32, camera.height as f32);
    let projection = glam::Mat4::from_cols(
        glam::Vec4::new(2.0 * camera.fx / w, 0.0, 0.0, 0.0),
        glam::Vec4::new(0.0, 2.0 * camera.fy / h, 0.0, 0.0),
        glam::Vec4::new(0.0, 0.0, FAR / (FAR - NEAR), 1.0),
        glam::Vec4::new(0.0, 0.0, -FAR * NEAR / (FAR - NEAR), 0.0),
    );
    let r = camera.rotation.transpose();
    let view = glam::Mat4::from_mat3(r) * glam::Mat4::from_translation(-camera.position);
    projection * view
}

/// The depth projection rara is told of.
pub fn depth_projection() -> rara::DepthProjection {
    rara::DepthProjection {
        near: NEAR,
        far: FAR,
        reversed: false,
        infinite: false,
    }
}

/// What a run did, for the caller (and the test that runs this example).
pub struct EngineReport {
    /// The PNGs written, in frame order.
    pub frames: Vec<PathBuf>,
    /// rara's counters per frame: (visible, cutoff, intersections, complete, and for the ray
    /// tracer the hits its rays composited).
    pub stats: Vec<(u32, u32, u32, bool, u64)>,
    /// rara's GPU milliseconds per frame (sum of its passes; 0 without timestamps).
    pub gpu_ms: Vec<f64>,
    /// Live allocations of rara's allocator after rara's objects were dropped.
    pub leaks: Vec<(String, u64)>,
    /// Validation warnings and errors seen by the engine's messenger, teardown included.
    pub validation_messages: Vec<String>,
    /// Whether the validation layer was on.
    pub validation: bool,
    /// Per frame, what the mesh pass left before rara drew: the colour image and the depth
    /// values (D32, rows top first).
    pub mesh: Vec<(image::RgbaImage, Vec<f32>)>,
}

static MESSAGES: Mutex<Vec<String>> = Mutex::new(Vec::new());

unsafe extern "system" fn on_message(
    severity: vk::DebugUtilsMessageSeverityFlagsEXT,
    _types: vk::DebugUtilsMessageTypeFlagsEXT,
    data: *const vk::DebugUtilsMessengerCallbackDataEXT<'_>,
    _user: *mut c_void,
) -> vk::Bool32 {
    let text = if data.is_null() || (*data).p_message.is_null() {
        "(no message)".to_string()
    } else {
        CStr::from_ptr((*data).p_message)
            .to_string_lossy()
            .into_owned()
    };
    eprintln!("engine: validation [{severity:?}] {text}");
    MESSAGES.lock().unwrap().push(text);
    vk::FALSE
}

/// The engine's Vulkan objects.
pub struct Engine {
    _entry: ash::Entry,
    /// The instance.
    pub instance: ash::Instance,
    debug: Option<(ash::ext::debug_utils::Instance, vk::DebugUtilsMessengerEXT)>,
    /// The physical device.
    pub physical_device: vk::PhysicalDevice,
    /// The device.
    pub device: ash::Device,
    /// A graphics and compute queue family.
    pub queue_family: u32,
    /// Its first queue.
    pub queue: vk::Queue,
    /// Whether the device was created with shaderInt64 (rara's faster kernels), which rara is
    /// told in `EnabledFeatures::optional`.
    pub shader_int64: bool,
}

impl Engine {
    /// Creates the instance and device; `merge_rara_requirements` false leaves rara's features
    /// out (the tests use it to see rara refuse such a device).
    pub fn new(merge_rara_requirements: bool) -> Result<Engine, Box<dyn Error>> {
        let entry = unsafe { ash::Entry::load()? };
        let validation_layer = c"VK_LAYER_KHRONOS_validation";
        let has_layer = unsafe { entry.enumerate_instance_layer_properties()? }
            .iter()
            .any(|l| l.layer_name_as_c_str() == Ok(validation_layer));
        let layers: Vec<*const i8> = if has_layer {
            vec![validation_layer.as_ptr()]
        } else {
            vec![]
        };
        let extensions = [ash::ext::debug_utils::NAME.as_ptr()];
        let requirements = rara::requirements();
        let app = vk::ApplicationInfo::default()
            .application_name(c"engine example")
            .api_version(requirements.api_version);
        let info = vk::InstanceCreateInfo::default()
            .application_info(&app)
            .enabled_layer_names(&layers)
            .enabled_extension_names(&extensions);
        let instance = unsafe { entry.create_instance(&info, None)? };
        let debug = if has_layer {
            let loader = ash::ext::debug_utils::Instance::new(&entry, &instance);
            let info = vk::DebugUtilsMessengerCreateInfoEXT::default()
                .message_severity(
                    vk::DebugUtilsMessageSeverityFlagsEXT::WARNING
                        | vk::DebugUtilsMessageSeverityFlagsEXT::ERROR,
                )
                .message_type(
                    vk::DebugUtilsMessageTypeFlagsEXT::VALIDATION
                        | vk::DebugUtilsMessageTypeFlagsEXT::GENERAL,
                )
                .pfn_user_callback(Some(on_message));
            let messenger = unsafe { loader.create_debug_utils_messenger(&info, None)? };
            Some((loader, messenger))
        } else {
            None
        };

        // The first device that meets rara's requirements, and a graphics and compute queue on
        // it.
        let mut chosen = None;
        for pd in unsafe { instance.enumerate_physical_devices()? } {
            if unsafe { requirements.check_physical_device(&instance, pd) }.is_err() {
                continue;
            }
            let families = unsafe { instance.get_physical_device_queue_family_properties(pd) };
            if let Some(f) = families.iter().position(|f| {
                f.queue_flags
                    .contains(vk::QueueFlags::COMPUTE | vk::QueueFlags::GRAPHICS)
            }) {
                chosen = Some((pd, f as u32));
                break;
            }
        }
        let (physical_device, queue_family) =
            chosen.ok_or("no Vulkan device meets rara's requirements")?;

        // The engine's own features, with rara's merged in.
        let mut features = vk::PhysicalDeviceFeatures::default();
        let mut features12 = vk::PhysicalDeviceVulkan12Features::default();
        if merge_rara_requirements {
            let supported = unsafe { instance.get_physical_device_features(physical_device) };
            requirements.enable_features(&mut features, &supported);
            requirements.enable_vulkan12_features(&mut features12);
        }
        let shader_int64 = features.shader_int64 == vk::TRUE;
        let priorities = [1.0f32];
        let queues = [vk::DeviceQueueCreateInfo::default()
            .queue_family_index(queue_family)
            .queue_priorities(&priorities)];
        let info = vk::DeviceCreateInfo::default()
            .queue_create_infos(&queues)
            .enabled_features(&features)
            .push_next(&mut features12);
        let device = unsafe { instance.create_device(physical_device, &info, None)? };
        let queue = unsafe { device.get_device_queue(queue_family, 0) };
        Ok(Engine {
            _entry: entry,
            instance,
            debug,
            physical_device,
            device,
            queue_family,
            queue,
            shader_int64,
        })
    }

    /// Destroys the device, the messenger and the instance.
    ///
    /// # Safety
    /// Every object made on the device is destroyed and the device is idle.
    pub unsafe fn destroy(self) {
        self.device.destroy_device(None);
        if let Some((loader, messenger)) = &self.debug {
            loader.destroy_debug_utils_messenger(*messenger, None);
        }
        self.instance.destroy_instance(None);
    }

    fn memory_type(&self, bits: u32, flags: vk::MemoryPropertyFlags) -> Option<u32> {
        let props = unsafe {
            self.instance
                .get_physical_device_memory_properties(self.physical_device)
        };
        (0..props.memory_type_count).find(|&i| {
            bits & (1 << i) != 0
                && props.memory_types[i as usize]
                    .property_flags
                    .contains(flags)
        })
    }

    /// A `WIDTH` x `HEIGHT` 2D image of `format` and `usage` in device memory, and a view of
    /// `range`.
    fn image(
        &self,
        format: vk::Format,
        usage: vk::ImageUsageFlags,
        range: vk::ImageSubresourceRange,
    ) -> Result<(vk::Image, vk::DeviceMemory, vk::ImageView), Box<dyn Error>> {
        let device = &self.device;
        let image = unsafe {
            device.create_image(
                &vk::ImageCreateInfo::default()
                    .image_type(vk::ImageType::TYPE_2D)
                    .format(format)
                    .extent(vk::Extent3D {
                        width: WIDTH,
                        height: HEIGHT,
                        depth: 1,
                    })
                    .mip_levels(1)
                    .array_layers(1)
                    .samples(vk::SampleCountFlags::TYPE_1)
                    .tiling(vk::ImageTiling::OPTIMAL)
                    .usage(usage),
                None,
            )?
        };
        let memory = self.allocate(
            unsafe { device.get_image_memory_requirements(image) },
            vk::MemoryPropertyFlags::DEVICE_LOCAL,
        )?;
        unsafe { device.bind_image_memory(image, memory, 0)? };
        let view = unsafe {
            device.create_image_view(
                &vk::ImageViewCreateInfo::default()
                    .image(image)
                    .view_type(vk::ImageViewType::TYPE_2D)
                    .format(format)
                    .subresource_range(range),
                None,
            )?
        };
        Ok((image, memory, view))
    }

    /// A host-visible buffer of `size` bytes that copies land in.
    fn host_buffer(&self, size: u64) -> Result<(vk::Buffer, vk::DeviceMemory), Box<dyn Error>> {
        let device = &self.device;
        let buffer = unsafe {
            device.create_buffer(
                &vk::BufferCreateInfo::default()
                    .size(size)
                    .usage(vk::BufferUsageFlags::TRANSFER_DST),
                None,
            )?
        };
        let memory = self.allocate(
            unsafe { device.get_buffer_memory_requirements(buffer) },
            vk::MemoryPropertyFlags::HOST_VISIBLE | vk::MemoryPropertyFlags::HOST_COHERENT,
        )?;
        unsafe { device.bind_buffer_memory(buffer, memory, 0)? };
        Ok((buffer, memory))
    }

    fn allocate(
        &self,
        requirements: vk::MemoryRequirements,
        flags: vk::MemoryPropertyFlags,
    ) -> Result<vk::DeviceMemory, Box<dyn Error>> {
        let index = self
            .memory_type(requirements.memory_type_bits, flags)
            .ok_or("no suitable memory type")?;
        let info = vk::MemoryAllocateInfo::default()
            .allocation_size(requirements.size)
            .memory_type_index(index);
        Ok(unsafe { self.device.allocate_memory(&info, None)? })
    }
}

/// One frame in flight's worth of engine objects.
struct FrameObjects {
    cmd: vk::CommandBuffer,
    fence: vk::Fence,
    image: vk::Image,
    image_memory: vk::DeviceMemory,
    view: vk::ImageView,
    readback: vk::Buffer,
    readback_memory: vk::DeviceMemory,
    depth_image: vk::Image,
    depth_memory: vk::DeviceMemory,
    depth_view: vk::ImageView,
    framebuffer: vk::Framebuffer,
    /// The mesh pass's colour and depth, copied out before rara draws.
    mesh_readback: vk::Buffer,
    mesh_readback_memory: vk::DeviceMemory,
    vignette_set: vk::DescriptorSet,
    /// The frame index this slot last rendered, not yet written out.
    pending: Option<usize>,
}

/// Runs the engine for `frame_count` frames, writing PNGs to `out_dir`.
pub fn run(
    out_dir: &Path,
    frame_count: usize,
    tracer: rara::Tracer,
) -> Result<EngineReport, Box<dyn Error>> {
    std::fs::create_dir_all(out_dir)?;
    MESSAGES.lock().unwrap().clear();
    let engine = Engine::new(true)?;
    let device = &engine.device;
    let validation = engine.debug.is_some();

    // The engine's command pool, per-frame images, fences and its vignette pipeline.
    let pool = unsafe {
        device.create_command_pool(
            &vk::CommandPoolCreateInfo::default()
                .queue_family_index(engine.queue_family)
                .flags(vk::CommandPoolCreateFlags::RESET_COMMAND_BUFFER),
            None,
        )?
    };
    let cmds = unsafe {
        device.allocate_command_buffers(
            &vk::CommandBufferAllocateInfo::default()
                .command_pool(pool)
                .level(vk::CommandBufferLevel::PRIMARY)
                .command_buffer_count(IN_FLIGHT as u32),
        )?
    };
    let set_layout = unsafe {
        let bindings = [vk::DescriptorSetLayoutBinding::default()
            .binding(0)
            .descriptor_type(vk::DescriptorType::STORAGE_IMAGE)
            .descriptor_count(1)
            .stage_flags(vk::ShaderStageFlags::COMPUTE)];
        device.create_descriptor_set_layout(
            &vk::DescriptorSetLayoutCreateInfo::default().bindings(&bindings),
            None,
        )?
    };
    let descriptor_pool = unsafe {
        let sizes = [vk::DescriptorPoolSize {
            ty: vk::DescriptorType::STORAGE_IMAGE,
            descriptor_count: IN_FLIGHT as u32,
        }];
        device.create_descriptor_pool(
            &vk::DescriptorPoolCreateInfo::default()
                .max_sets(IN_FLIGHT as u32)
                .pool_sizes(&sizes),
            None,
        )?
    };
    let pipeline_layout = unsafe {
        let layouts = [set_layout];
        device.create_pipeline_layout(
            &vk::PipelineLayoutCreateInfo::default().set_layouts(&layouts),
            None,
        )?
    };
    let vignette = {
        let compiler = shaderc::Compiler::new()?;
        let spirv = compiler.compile_into_spirv(
            VIGNETTE_GLSL,
            shaderc::ShaderKind::Compute,
            "vignette.comp",
            "main",
            None,
        )?;
        let module = unsafe {
            device.create_shader_module(
                &vk::ShaderModuleCreateInfo::default().code(spirv.as_binary()),
                None,
            )?
        };
        let stage = vk::PipelineShaderStageCreateInfo::default()
            .stage(vk::ShaderStageFlags::COMPUTE)
            .module(module)
            .name(c"main");
        let info = [vk::ComputePipelineCreateInfo::default()
            .stage(stage)
            .layout(pipeline_layout)];
        let pipeline =
            unsafe { device.create_compute_pipelines(vk::PipelineCache::null(), &info, None) };
        unsafe { device.destroy_shader_module(module, None) };
        pipeline.map_err(|(_, e)| e)?[0]
    };
    // A timestamp pool of the engine's, one range of queries per frame in flight for rara.
    let queries_per_frame = MAX_PASSES + 1;
    let query_pool = unsafe {
        device.create_query_pool(
            &vk::QueryPoolCreateInfo::default()
                .query_type(vk::QueryType::TIMESTAMP)
                .query_count(queries_per_frame * IN_FLIGHT as u32),
            None,
        )?
    };

    // The mesh pass: a render pass that clears colour and depth and leaves both in GENERAL for
    // the compute passes and copies after it, and the cube's graphics pipeline.
    let render_pass = unsafe {
        let attachments = [
            vk::AttachmentDescription::default()
                .format(FORMAT)
                .samples(vk::SampleCountFlags::TYPE_1)
                .load_op(vk::AttachmentLoadOp::CLEAR)
                .store_op(vk::AttachmentStoreOp::STORE)
                .initial_layout(vk::ImageLayout::UNDEFINED)
                .final_layout(vk::ImageLayout::GENERAL),
            vk::AttachmentDescription::default()
                .format(DEPTH_FORMAT)
                .samples(vk::SampleCountFlags::TYPE_1)
                .load_op(vk::AttachmentLoadOp::CLEAR)
                .store_op(vk::AttachmentStoreOp::STORE)
                .initial_layout(vk::ImageLayout::UNDEFINED)
                .final_layout(vk::ImageLayout::GENERAL),
        ];
        let color_ref = [vk::AttachmentReference {
            attachment: 0,
            layout: vk::ImageLayout::COLOR_ATTACHMENT_OPTIMAL,
        }];
        let depth_ref = vk::AttachmentReference {
            attachment: 1,
            layout: vk::ImageLayout::DEPTH_STENCIL_ATTACHMENT_OPTIMAL,
        };
        let subpasses = [vk::SubpassDescription::default()
            .pipeline_bind_point(vk::PipelineBindPoint::GRAPHICS)
            .color_attachments(&color_ref)
            .depth_stencil_attachment(&depth_ref)];
        // In: the previous frame's copies and compute passes on these images are done before
        // the attachments are cleared. Out: the attachments' writes are visible to rara's
        // compute passes (the depth prepare pass reads the depth, write target the colour) and
        // to the copies.
        let dependencies = [
            vk::SubpassDependency::default()
                .src_subpass(vk::SUBPASS_EXTERNAL)
                .dst_subpass(0)
                .src_stage_mask(
                    vk::PipelineStageFlags::TRANSFER | vk::PipelineStageFlags::COMPUTE_SHADER,
                )
                .src_access_mask(vk::AccessFlags::empty())
                .dst_stage_mask(
                    vk::PipelineStageFlags::COLOR_ATTACHMENT_OUTPUT
                        | vk::PipelineStageFlags::EARLY_FRAGMENT_TESTS,
                )
                .dst_access_mask(
                    vk::AccessFlags::COLOR_ATTACHMENT_WRITE
                        | vk::AccessFlags::DEPTH_STENCIL_ATTACHMENT_WRITE,
                ),
            vk::SubpassDependency::default()
                .src_subpass(0)
                .dst_subpass(vk::SUBPASS_EXTERNAL)
                .src_stage_mask(
                    vk::PipelineStageFlags::COLOR_ATTACHMENT_OUTPUT
                        | vk::PipelineStageFlags::LATE_FRAGMENT_TESTS,
                )
                .src_access_mask(
                    vk::AccessFlags::COLOR_ATTACHMENT_WRITE
                        | vk::AccessFlags::DEPTH_STENCIL_ATTACHMENT_WRITE,
                )
                .dst_stage_mask(
                    vk::PipelineStageFlags::COMPUTE_SHADER | vk::PipelineStageFlags::TRANSFER,
                )
                .dst_access_mask(
                    vk::AccessFlags::SHADER_READ
                        | vk::AccessFlags::SHADER_WRITE
                        | vk::AccessFlags::TRANSFER_READ,
                ),
        ];
        device.create_render_pass(
            &vk::RenderPassCreateInfo::default()
                .attachments(&attachments)
                .subpasses(&subpasses)
                .dependencies(&dependencies),
            None,
        )?
    };
    let mesh_layout = unsafe {
        let ranges = [vk::PushConstantRange::default()
            .stage_flags(vk::ShaderStageFlags::VERTEX)
            .offset(0)
            .size(128)];
        device.create_pipeline_layout(
            &vk::PipelineLayoutCreateInfo::default().push_constant_ranges(&ranges),
            None,
        )?
    };
    let mesh_pipeline = {
        let compiler = shaderc::Compiler::new()?;
        let mut modules = Vec::new();
        for (source, kind, name) in [
            (CUBE_VERT_GLSL, shaderc::ShaderKind::Vertex, "cube.vert"),
            (CUBE_FRAG_GLSL, shaderc::ShaderKind::Fragment, "cube.frag"),
        ] {
            let spirv = compiler.compile_into_spirv(source, kind, name, "main", None)?;
            modules.push(unsafe {
                device.create_shader_module(
                    &vk::ShaderModuleCreateInfo::default().code(spirv.as_binary()),
                    None,
                )?
            });
        }
        let stages = [
            vk::PipelineShaderStageCreateInfo::default()
                .stage(vk::ShaderStageFlags::VERTEX)
                .module(modules[0])
                .name(c"main"),
            vk::PipelineShaderStageCreateInfo::default()
                .stage(vk::ShaderStageFlags::FRAGMENT)
                .module(modules[1])
                .name(c"main"),
        ];
        let vertex_input = vk::PipelineVertexInputStateCreateInfo::default();
        let assembly = vk::PipelineInputAssemblyStateCreateInfo::default()
            .topology(vk::PrimitiveTopology::TRIANGLE_LIST);
        let viewports = [vk::Viewport {
            x: 0.0,
            y: 0.0,
            width: WIDTH as f32,
            height: HEIGHT as f32,
            min_depth: 0.0,
            max_depth: 1.0,
        }];
        let scissors = [vk::Rect2D {
            offset: vk::Offset2D { x: 0, y: 0 },
            extent: vk::Extent2D {
                width: WIDTH,
                height: HEIGHT,
            },
        }];
        let viewport = vk::PipelineViewportStateCreateInfo::default()
            .viewports(&viewports)
            .scissors(&scissors);
        let raster = vk::PipelineRasterizationStateCreateInfo::default()
            .polygon_mode(vk::PolygonMode::FILL)
            .cull_mode(vk::CullModeFlags::NONE)
            .line_width(1.0);
        let multisample = vk::PipelineMultisampleStateCreateInfo::default()
            .rasterization_samples(vk::SampleCountFlags::TYPE_1);
        let depth = vk::PipelineDepthStencilStateCreateInfo::default()
            .depth_test_enable(true)
            .depth_write_enable(true)
            .depth_compare_op(vk::CompareOp::LESS);
        let blend_attachments = [vk::PipelineColorBlendAttachmentState::default()
            .color_write_mask(vk::ColorComponentFlags::RGBA)];
        let blend =
            vk::PipelineColorBlendStateCreateInfo::default().attachments(&blend_attachments);
        let info = [vk::GraphicsPipelineCreateInfo::default()
            .stages(&stages)
            .vertex_input_state(&vertex_input)
            .input_assembly_state(&assembly)
            .viewport_state(&viewport)
            .rasterization_state(&raster)
            .multisample_state(&multisample)
            .depth_stencil_state(&depth)
            .color_blend_state(&blend)
            .layout(mesh_layout)
            .render_pass(render_pass)
            .subpass(0)];
        let pipeline =
            unsafe { device.create_graphics_pipelines(vk::PipelineCache::null(), &info, None) };
        for m in modules {
            unsafe { device.destroy_shader_module(m, None) };
        }
        pipeline.map_err(|(_, e)| e)?[0]
    };

    let mut frames = Vec::new();
    for &cmd in &cmds {
        let (image, image_memory, view) = engine.image(
            FORMAT,
            vk::ImageUsageFlags::STORAGE
                | vk::ImageUsageFlags::COLOR_ATTACHMENT
                | vk::ImageUsageFlags::TRANSFER_SRC
                | vk::ImageUsageFlags::TRANSFER_DST,
            color_range(),
        )?;
        let (readback, readback_memory) = engine.host_buffer(WIDTH as u64 * HEIGHT as u64 * 4)?;
        // The depth attachment, sampled by rara's depth test and copied out for the test.
        let (depth_image, depth_memory, depth_view) = engine.image(
            DEPTH_FORMAT,
            vk::ImageUsageFlags::DEPTH_STENCIL_ATTACHMENT
                | vk::ImageUsageFlags::SAMPLED
                | vk::ImageUsageFlags::TRANSFER_SRC,
            depth_range(),
        )?;
        let framebuffer = unsafe {
            let attachments = [view, depth_view];
            device.create_framebuffer(
                &vk::FramebufferCreateInfo::default()
                    .render_pass(render_pass)
                    .attachments(&attachments)
                    .width(WIDTH)
                    .height(HEIGHT)
                    .layers(1),
                None,
            )?
        };
        let (mesh_readback, mesh_readback_memory) =
            engine.host_buffer(WIDTH as u64 * HEIGHT as u64 * 8)?;
        let vignette_set = unsafe {
            let layouts = [set_layout];
            device.allocate_descriptor_sets(
                &vk::DescriptorSetAllocateInfo::default()
                    .descriptor_pool(descriptor_pool)
                    .set_layouts(&layouts),
            )?[0]
        };
        let images = [vk::DescriptorImageInfo::default()
            .image_view(view)
            .image_layout(vk::ImageLayout::GENERAL)];
        unsafe {
            device.update_descriptor_sets(
                &[vk::WriteDescriptorSet::default()
                    .dst_set(vignette_set)
                    .dst_binding(0)
                    .descriptor_type(vk::DescriptorType::STORAGE_IMAGE)
                    .image_info(&images)],
                &[],
            )
        };
        let fence = unsafe {
            device.create_fence(
                &vk::FenceCreateInfo::default().flags(vk::FenceCreateFlags::SIGNALED),
                None,
            )?
        };
        frames.push(FrameObjects {
            cmd,
            fence,
            image,
            image_memory,
            view,
            readback,
            readback_memory,
            depth_image,
            depth_memory,
            depth_view,
            framebuffer,
            mesh_readback,
            mesh_readback_memory,
            vignette_set,
            pending: None,
        });
    }

    // rara on the engine's device: a scene, a renderer, and one frame slot and timer per frame
    // in flight.
    let mut report = EngineReport {
        frames: Vec::new(),
        stats: Vec::new(),
        gpu_ms: Vec::new(),
        leaks: Vec::new(),
        validation_messages: Vec::new(),
        validation,
        mesh: Vec::new(),
    };
    {
        let ctx = unsafe {
            Context::borrowed(BorrowedDevice {
                instance: engine.instance.clone(),
                physical_device: engine.physical_device,
                device: engine.device.clone(),
                queue_family: engine.queue_family,
                queue: engine.queue,
                enabled: EnabledFeatures {
                    optional: rara::vk::Optional {
                        shader_int64: engine.shader_int64,
                        pipeline_statistics_query: false,
                        debug_utils: true,
                    },
                    ..EnabledFeatures::default()
                },
            })?
        };
        let renderer = Renderer::new(&ctx)?;
        let scene = GpuScene::new(&ctx, &rara::synth::demo_scene())?;
        let camera = camera()?;
        let mut slots = Vec::new();
        let mut timers = Vec::new();
        for k in 0..IN_FLIGHT {
            slots.push(FrameSlot::new(&ctx)?);
            // SAFETY: the pool is the engine's, on this device, holds queries_per_frame queries
            // per slot, and outlives the timers (destroyed after them below).
            timers.push(unsafe {
                PassTimer::with_engine_pool(&ctx, query_pool, k as u32 * queries_per_frame)
            });
        }

        let finish = |f: &mut FrameObjects,
                      slot: &mut FrameSlot,
                      timer: &PassTimer,
                      report: &mut EngineReport|
         -> Result<(), Box<dyn Error>> {
            let Some(index) = f.pending.take() else {
                return Ok(());
            };
            let stats = slot.stats()?;
            let gpu_ms: f64 = timer.read()?.iter().map(|p| p.ms).sum();
            let bytes = unsafe {
                let ptr = device.map_memory(
                    f.readback_memory,
                    0,
                    vk::WHOLE_SIZE,
                    vk::MemoryMapFlags::empty(),
                )?;
                let len = WIDTH as usize * HEIGHT as usize * 4;
                let bytes = std::slice::from_raw_parts(ptr as *const u8, len).to_vec();
                device.unmap_memory(f.readback_memory);
                bytes
            };
            let mesh = unsafe {
                let ptr = device.map_memory(
                    f.mesh_readback_memory,
                    0,
                    vk::WHOLE_SIZE,
                    vk::MemoryMapFlags::empty(),
                )?;
                let len = WIDTH as usize * HEIGHT as usize * 4;
                let bytes = std::slice::from_raw_parts(ptr as *const u8, 2 * len);
                let color = image::RgbaImage::from_raw(WIDTH, HEIGHT, bytes[..len].to_vec())
                    .ok_or("image size")?;
                let depth: Vec<f32> = bytemuck::pod_collect_to_vec(&bytes[len..]);
                device.unmap_memory(f.mesh_readback_memory);
                (color, depth)
            };
            report.mesh.push(mesh);
            let path = out_dir.join(format!("engine_frame_{index}.png"));
            image::RgbaImage::from_raw(WIDTH, HEIGHT, bytes)
                .ok_or("image size")?
                .save(&path)?;
            let counts = match &stats.trace {
                Some(t) => format!(
                    "ray traced, {:.1} hits per ray, {} rounds",
                    t.walked_per_ray(),
                    t.rounds
                ),
                None => format!(
                    "{} visible, {} cutoff, {} tile pairs",
                    stats.visible, stats.cutoff, stats.intersections
                ),
            };
            println!(
                "frame {index}: {counts}{}, rara GPU {gpu_ms:.1} ms -> {}",
                if stats.complete { "" } else { " (incomplete)" },
                path.display()
            );
            report.frames.push(path);
            report.stats.push((
                stats.visible,
                stats.cutoff,
                stats.intersections,
                stats.complete,
                stats.trace.as_ref().map_or(0, |t| t.hits_walked),
            ));
            report.gpu_ms.push(gpu_ms);
            Ok(())
        };

        for index in 0..frame_count {
            let k = index % IN_FLIGHT;
            let f = &mut frames[k];
            // The engine's frame pacing: wait until this slot's previous frame is done.
            unsafe { device.wait_for_fences(&[f.fence], true, u64::MAX)? };
            finish(f, &mut slots[k], &timers[k], &mut report)?;
            unsafe { device.reset_fences(&[f.fence])? };

            let options = frame_options(&camera, index, frame_count, tracer)?;
            let cmd = f.cmd;
            unsafe {
                device.reset_command_buffer(cmd, vk::CommandBufferResetFlags::empty())?;
                device.begin_command_buffer(
                    cmd,
                    &vk::CommandBufferBeginInfo::default()
                        .flags(vk::CommandBufferUsageFlags::ONE_TIME_SUBMIT),
                )?;
                // The mesh pass: the cube into the cleared colour and depth attachments, both
                // left in GENERAL (the render pass's dependency makes its writes visible to the
                // compute passes and copies that follow).
                let clears = [
                    vk::ClearValue {
                        color: vk::ClearColorValue { float32: CLEAR },
                    },
                    vk::ClearValue {
                        depth_stencil: vk::ClearDepthStencilValue {
                            depth: 1.0,
                            stencil: 0,
                        },
                    },
                ];
                device.cmd_begin_render_pass(
                    cmd,
                    &vk::RenderPassBeginInfo::default()
                        .render_pass(render_pass)
                        .framebuffer(f.framebuffer)
                        .render_area(vk::Rect2D {
                            offset: vk::Offset2D { x: 0, y: 0 },
                            extent: vk::Extent2D {
                                width: WIDTH,
                                height: HEIGHT,
                            },
                        })
                        .clear_values(&clears),
                    vk::SubpassContents::INLINE,
                );
                device.cmd_bind_pipeline(cmd, vk::PipelineBindPoint::GRAPHICS, mesh_pipeline);
                let model = cube_model();
                let push = [clip_from_world(&camera) * model, model];
                device.cmd_push_constants(
                    cmd,
                    mesh_layout,
                    vk::ShaderStageFlags::VERTEX,
                    0,
                    bytemuck::cast_slice(&push),
                );
                device.cmd_draw(cmd, 36, 1, 0, 0);
                device.cmd_end_render_pass(cmd);
                // What the mesh pass drew, copied out for the test (colour, then depth).
                device.cmd_copy_image_to_buffer(
                    cmd,
                    f.image,
                    vk::ImageLayout::GENERAL,
                    f.mesh_readback,
                    &[copy_region(vk::ImageAspectFlags::COLOR, 0)],
                );
                device.cmd_copy_image_to_buffer(
                    cmd,
                    f.depth_image,
                    vk::ImageLayout::GENERAL,
                    f.mesh_readback,
                    &[copy_region(
                        vk::ImageAspectFlags::DEPTH,
                        WIDTH as u64 * HEIGHT as u64 * 4,
                    )],
                );
                // rara's contract: the target in GENERAL with the engine's writes visible to
                // compute; the copies' reads done before rara writes the colour.
                image_barrier(
                    device,
                    cmd,
                    f.image,
                    vk::ImageLayout::GENERAL,
                    (
                        vk::PipelineStageFlags::TRANSFER,
                        vk::AccessFlags::TRANSFER_READ,
                    ),
                    (
                        vk::PipelineStageFlags::COMPUTE_SHADER,
                        vk::AccessFlags::SHADER_READ | vk::AccessFlags::SHADER_WRITE,
                    ),
                );
            }
            let mut options = options;
            options.depth_test = Some(rara::DepthTest {
                source: rara::DepthSource::Image {
                    view: f.depth_view,
                    layout: vk::ImageLayout::GENERAL,
                },
                projection: depth_projection(),
            });
            renderer.record(
                cmd,
                &mut slots[k],
                &scene,
                &camera,
                &options,
                &Target::Image {
                    view: f.view,
                    format: TargetFormat::Rgba8Unorm,
                    width: WIDTH,
                    height: HEIGHT,
                },
                Some(&mut timers[k]),
            )?;
            unsafe {
                // rara's last access was a compute write: order the engine's pass after it.
                image_barrier(
                    device,
                    cmd,
                    f.image,
                    vk::ImageLayout::GENERAL,
                    (
                        vk::PipelineStageFlags::COMPUTE_SHADER,
                        vk::AccessFlags::SHADER_WRITE,
                    ),
                    (
                        vk::PipelineStageFlags::COMPUTE_SHADER,
                        vk::AccessFlags::SHADER_READ | vk::AccessFlags::SHADER_WRITE,
                    ),
                );
                device.cmd_bind_pipeline(cmd, vk::PipelineBindPoint::COMPUTE, vignette);
                device.cmd_bind_descriptor_sets(
                    cmd,
                    vk::PipelineBindPoint::COMPUTE,
                    pipeline_layout,
                    0,
                    &[f.vignette_set],
                    &[],
                );
                device.cmd_dispatch(cmd, WIDTH.div_ceil(16), HEIGHT.div_ceil(16), 1);
                image_barrier(
                    device,
                    cmd,
                    f.image,
                    vk::ImageLayout::GENERAL,
                    (
                        vk::PipelineStageFlags::COMPUTE_SHADER,
                        vk::AccessFlags::SHADER_WRITE,
                    ),
                    (
                        vk::PipelineStageFlags::TRANSFER,
                        vk::AccessFlags::TRANSFER_READ,
                    ),
                );
                device.cmd_copy_image_to_buffer(
                    cmd,
                    f.image,
                    vk::ImageLayout::GENERAL,
                    f.readback,
                    &[copy_region(vk::ImageAspectFlags::COLOR, 0)],
                );
                device.cmd_pipeline_barrier(
                    cmd,
                    vk::PipelineStageFlags::TRANSFER,
                    vk::PipelineStageFlags::HOST,
                    vk::DependencyFlags::empty(),
                    &[vk::MemoryBarrier::default()
                        .src_access_mask(vk::AccessFlags::TRANSFER_WRITE)
                        .dst_access_mask(vk::AccessFlags::HOST_READ)],
                    &[],
                    &[],
                );
                device.end_command_buffer(cmd)?;
                let cmds = [cmd];
                device.queue_submit(
                    engine.queue,
                    &[vk::SubmitInfo::default().command_buffers(&cmds)],
                    f.fence,
                )?;
            }
            f.pending = Some(index);
        }
        // Drain: write out the frames still in flight, oldest first.
        let mut order: Vec<usize> = (0..IN_FLIGHT).collect();
        order.sort_by_key(|&k| frames[k].pending);
        for k in order {
            let f = &mut frames[k];
            unsafe { device.wait_for_fences(&[f.fence], true, u64::MAX)? };
            finish(f, &mut slots[k], &timers[k], &mut report)?;
        }

        // Tear rara down (the GPU is idle: every fence waited) and check its allocator.
        drop(timers);
        drop(slots);
        drop(scene);
        drop(renderer);
        report.leaks = ctx.live_allocations();
        drop(ctx);
    }

    // The engine destroys its own objects; rara destroyed none of them.
    unsafe {
        device.device_wait_idle()?;
        for f in &frames {
            device.destroy_fence(f.fence, None);
            device.destroy_image_view(f.view, None);
            device.destroy_image(f.image, None);
            device.free_memory(f.image_memory, None);
            device.destroy_buffer(f.readback, None);
            device.free_memory(f.readback_memory, None);
            device.destroy_framebuffer(f.framebuffer, None);
            device.destroy_image_view(f.depth_view, None);
            device.destroy_image(f.depth_image, None);
            device.free_memory(f.depth_memory, None);
            device.destroy_buffer(f.mesh_readback, None);
            device.free_memory(f.mesh_readback_memory, None);
        }
        device.destroy_pipeline(mesh_pipeline, None);
        device.destroy_pipeline_layout(mesh_layout, None);
        device.destroy_render_pass(render_pass, None);
        device.destroy_query_pool(query_pool, None);
        device.destroy_pipeline(vignette, None);
        device.destroy_pipeline_layout(pipeline_layout, None);
        device.destroy_descriptor_pool(descriptor_pool, None);
        device.destroy_descriptor_set_layout(set_layout, None);
        device.destroy_command_pool(pool, None);
        engine.destroy();
    }
    report.validation_messages = std::mem::take(&mut *MESSAGES.lock().unwrap());
    Ok(report)
}

/// The engine's camera.
pub fn camera() -> rara::Result<Camera> {
    Camera::look_at(
        Vec3::new(0.0, -0.6, -2.6),
        Vec3::ZERO,
        Vec3::NEG_Y,
        50.0,
        WIDTH,
        HEIGHT,
    )
}

/// Frame `index` of `count`: drawn over the cleared image, rara-clipped by a plane facing the
/// camera that sweeps from in front of the scene to behind it.
pub fn frame_options(
    camera: &Camera,
    index: usize,
    count: usize,
    tracer: rara::Tracer,
) -> rara::Result<RenderOptions> {
    let t = index as f32 / (count.max(2) - 1) as f32;
    let depth = -1.1 + 2.2 * t;
    let plane = Plane::new(camera.forward(), -depth)?;
    Ok(RenderOptions {
        composite: Composite::Over,
        clip: Clip::rara(ClipRegion::planes(vec![plane])?),
        tracer,
        ..RenderOptions::default()
    })
}

/// The engine's vignette, on the CPU: the factor its pass applies to pixel (x, y).
pub fn vignette_factor(x: u32, y: u32) -> f32 {
    let dx = (x as f32 + 0.5) / WIDTH as f32 - 0.5;
    let dy = (y as f32 + 0.5) / HEIGHT as f32 - 0.5;
    1.0 - 0.8 * (dx * dx + dy * dy)
}

/// The engine's clear colour.
pub const CLEAR_COLOR: [f32; 4] = CLEAR;

/// The copy of a whole image's `aspect` into a buffer from byte `offset`.
fn copy_region(aspect: vk::ImageAspectFlags, offset: u64) -> vk::BufferImageCopy {
    vk::BufferImageCopy::default()
        .buffer_offset(offset)
        .image_subresource(vk::ImageSubresourceLayers {
            aspect_mask: aspect,
            mip_level: 0,
            base_array_layer: 0,
            layer_count: 1,
        })
        .image_extent(vk::Extent3D {
            width: WIDTH,
            height: HEIGHT,
            depth: 1,
        })
}

fn depth_range() -> vk::ImageSubresourceRange {
    vk::ImageSubresourceRange {
        aspect_mask: vk::ImageAspectFlags::DEPTH,
        base_mip_level: 0,
        level_count: 1,
        base_array_layer: 0,
        layer_count: 1,
    }
}

fn color_range() -> vk::ImageSubresourceRange {
    vk::ImageSubresourceRange {
        aspect_mask: vk::ImageAspectFlags::COLOR,
        base_mip_level: 0,
        level_count: 1,
        base_array_layer: 0,
        layer_count: 1,
    }
}

/// A barrier on the whole colour image, ending in `GENERAL`.
unsafe fn image_barrier(
    device: &ash::Device,
    cmd: vk::CommandBuffer,
    image: vk::Image,
    old_layout: vk::ImageLayout,
    src: (vk::PipelineStageFlags, vk::AccessFlags),
    dst: (vk::PipelineStageFlags, vk::AccessFlags),
) {
    let barrier = vk::ImageMemoryBarrier::default()
        .image(image)
        .old_layout(old_layout)
        .new_layout(vk::ImageLayout::GENERAL)
        .src_access_mask(src.1)
        .dst_access_mask(dst.1)
        .src_queue_family_index(vk::QUEUE_FAMILY_IGNORED)
        .dst_queue_family_index(vk::QUEUE_FAMILY_IGNORED)
        .subresource_range(color_range());
    device.cmd_pipeline_barrier(
        cmd,
        src.0,
        dst.0,
        vk::DependencyFlags::empty(),
        &[],
        &[],
        &[barrier],
    );
}

#[allow(dead_code)] // the test that includes this file calls `run` instead
fn main() -> Result<(), Box<dyn Error>> {
    let args: Vec<String> = std::env::args().skip(1).collect();
    let tracer = if args.iter().any(|a| a == "--ray") {
        rara::Tracer::Ray
    } else {
        rara::Tracer::Raster
    };
    let out_dir = args
        .iter()
        .find(|a| !a.starts_with("--"))
        .map_or_else(|| PathBuf::from("target/engine-out"), PathBuf::from);
    let report = run(&out_dir, 6, tracer)?;
    println!(
        "rara allocator after teardown: {} live allocations; validation {}: {} messages",
        report.leaks.len(),
        if report.validation {
            "on"
        } else {
            "off (layer not installed)"
        },
        report.validation_messages.len()
    );
    if !report.leaks.is_empty() || !report.validation_messages.is_empty() {
        return Err("leaks or validation messages (see above)".into());
    }
    Ok(())
}
