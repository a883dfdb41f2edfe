//! The Vulkan device: instance, validation, physical-device choice, capability tier, queue and
//! memory allocator.
//!
//! We need Vulkan 1.3 with dynamic rendering, synchronization2, buffer device address, descriptor
//! indexing (bindless textures) and timeline semaphores. Ray tracing is optional and reported as
//! a [`Tier`] (DESIGN.md, "Capability tiers"); [`DeviceSettings::max_tier`] lowers it so one
//! device can exercise every tier. In debug builds and tests the Khronos validation layer is on,
//! synchronization validation included, and every error it reports is kept in a
//! [`ValidationLog`] that tests assert empty.

use std::ffi::{CStr, CString, c_void};
use std::mem::ManuallyDrop;
use std::sync::atomic::{AtomicU64, Ordering};
use std::sync::{Arc, Mutex};

use ash::{ext, khr, vk};
use gpu_allocator::vulkan::{Allocation, AllocationCreateDesc, Allocator, AllocatorCreateDesc};

use crate::RenderError;
use crate::gpu::commands::{CommandCache, Recorder};
use crate::gpu::memory::{MemoryCounts, MemoryKind, MemoryLedger};

/// What ray tracing the device can do, best first.
#[derive(Clone, Copy, Debug, PartialEq, Eq, PartialOrd, Ord, Hash)]
pub enum Tier {
    /// No acceleration structures: decals and lights go through compute-built lists.
    NoRayTracing,
    /// Acceleration structures and ray tracing pipelines, but no ray queries (NVIDIA here).
    RayTracingPipeline,
    /// Acceleration structures and ray queries from any shader stage (the seeds' way).
    RayQuery,
}

impl Tier {
    /// The name used in `--stats` and settings.
    pub fn name(self) -> &'static str {
        match self {
            Tier::NoRayTracing => "none",
            Tier::RayTracingPipeline => "ray_tracing_pipeline",
            Tier::RayQuery => "ray_query",
        }
    }

    /// Parses [`Tier::name`].
    pub fn from_name(name: &str) -> Option<Tier> {
        [Tier::NoRayTracing, Tier::RayTracingPipeline, Tier::RayQuery].into_iter().find(|t| t.name() == name)
    }
}

/// What a physical device offers beyond the renderer's requirements: ray tracing,
/// block-compressed textures, pipeline statistics.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct Capabilities {
    /// `VK_KHR_acceleration_structure` (with deferred host operations).
    pub acceleration_structure: bool,
    /// `VK_KHR_ray_query`.
    pub ray_query: bool,
    /// `VK_KHR_ray_tracing_pipeline`.
    pub ray_tracing_pipeline: bool,
    /// `textureCompressionBC`: block-compressed textures (BC1 to BC7) can be sampled.
    pub texture_compression_bc: bool,
    /// `VK_KHR_pipeline_executable_properties`: the driver reports what it compiled each
    /// pipeline into (registers, binary size): see [`DeviceSettings::pipeline_statistics`].
    pub pipeline_executable_properties: bool,
}

impl Capabilities {
    /// The best tier these extensions allow.
    pub fn best_tier(self) -> Tier {
        if self.acceleration_structure && self.ray_query {
            Tier::RayQuery
        } else if self.acceleration_structure && self.ray_tracing_pipeline {
            Tier::RayTracingPipeline
        } else {
            Tier::NoRayTracing
        }
    }
}

/// How to create the device.
#[derive(Clone, Debug)]
pub struct DeviceSettings {
    /// Turn on the Khronos validation layer and record its errors. Default: on in debug builds,
    /// or when `RENDER_VALIDATION=1`; off when `RENDER_VALIDATION=0`.
    pub validation: bool,
    /// Cap on the capability tier (the device's best tier is used when it is lower).
    pub max_tier: Tier,
    /// Instance extensions a window surface needs (empty when headless); see
    /// [`crate::present::window::required_extensions`].
    pub surface_extensions: Vec<&'static CStr>,
    /// Most bytes of GPU memory the renderer may allocate; an allocation that would pass it fails
    /// with [`RenderError::OutOfMemory`], as if the device had run out. `None` (the default):
    /// only the device limits. For sharing a GPU with other work, and for testing the
    /// out-of-memory path.
    pub memory_budget: Option<u64>,
    /// Use the device as if it could not sample block-compressed (BC) textures: they are then
    /// decoded to RGBA8 as they upload (`crate::scene::bc`). For testing that path, which no
    /// device this renderer runs on needs.
    pub without_texture_compression: bool,
    /// Frames a buffer that follows a count must need at most a quarter of its room (or go
    /// unused) before it gives memory back: see [`crate::gpu::upload::Shrink`]. Default:
    /// [`crate::gpu::upload::SHRINK_AFTER_FRAMES`] (a second at 60 frames a second). Lower lets a
    /// level change hand its memory back sooner; it is clamped to at least
    /// [`crate::gpu::FRAMES_IN_FLIGHT`] frames, so that every staging ring sees a frame of it.
    pub shrink_after_frames: u32,
    /// Log what the driver compiled each pipeline into (`VK_KHR_pipeline_executable_properties`:
    /// on NVIDIA its register count, binary size and shared memory) at `info` level as the
    /// pipeline is made, target `render::gpu::pipeline`. Registers decide how many invocations
    /// of a shader run at once, which a loop over hundreds of lights a pixel waits on. Ignored,
    /// with a warning, on a device without the extension (lavapipe). Default: off, or on when
    /// `RENDER_PIPELINE_STATISTICS=1`. A tool for profiling: it may make the driver keep more
    /// per pipeline, so leave it off when measuring memory.
    pub pipeline_statistics: bool,
}

impl Default for DeviceSettings {
    fn default() -> Self {
        let validation = match std::env::var("RENDER_VALIDATION").as_deref() {
            Ok("0") => false,
            Ok(_) => true,
            Err(_) => cfg!(debug_assertions),
        };
        Self {
            validation,
            max_tier: Tier::RayQuery,
            surface_extensions: Vec::new(),
            memory_budget: None,
            without_texture_compression: false,
            shrink_after_frames: crate::gpu::upload::SHRINK_AFTER_FRAMES,
            pipeline_statistics: std::env::var("RENDER_PIPELINE_STATISTICS").as_deref() == Ok("1"),
        }
    }
}

/// Validation messages of error severity, collected by the debug messenger.
#[derive(Default, Debug)]
pub struct ValidationLog {
    errors: Mutex<Vec<String>>,
}

impl ValidationLog {
    /// Removes and returns the errors reported so far.
    pub fn take_errors(&self) -> Vec<String> {
        std::mem::take(&mut *self.errors.lock().unwrap_or_else(|e| e.into_inner()))
    }

    /// Number of errors not yet taken.
    pub fn error_count(&self) -> usize {
        self.errors.lock().unwrap_or_else(|e| e.into_inner()).len()
    }
}

// SAFETY: called only by the Vulkan loader, with the callback data valid for the call and `user`
// set to the `ValidationLog` this module registered (see `GpuContext::new`).
unsafe extern "system" fn debug_callback(
    severity: vk::DebugUtilsMessageSeverityFlagsEXT,
    kind: vk::DebugUtilsMessageTypeFlagsEXT,
    data: *const vk::DebugUtilsMessengerCallbackDataEXT<'_>,
    user: *mut c_void,
) -> vk::Bool32 {
    // SAFETY: the loader passes a valid callback-data pointer for the duration of the call, and
    // `user` is the `ValidationLog` that `GpuContext` keeps alive (in an Arc) until the messenger
    // is destroyed.
    let (message, log) = unsafe {
        let msg = (*data).message_as_c_str().map(|m| m.to_string_lossy().into_owned()).unwrap_or_default();
        (msg, &*(user as *const ValidationLog))
    };
    if severity.contains(vk::DebugUtilsMessageSeverityFlagsEXT::ERROR) {
        tracing::error!(target: "vulkan", "{message}");
        log.errors.lock().unwrap_or_else(|e| e.into_inner()).push(message);
    } else if severity.contains(vk::DebugUtilsMessageSeverityFlagsEXT::WARNING)
        && !kind.contains(vk::DebugUtilsMessageTypeFlagsEXT::PERFORMANCE)
    {
        tracing::warn!(target: "vulkan", "{message}");
    }
    vk::FALSE
}

/// Extension loaders for the ray tracing tiers.
pub struct RayTracingFns {
    /// `VK_KHR_acceleration_structure`.
    pub acceleration_structure: khr::acceleration_structure::Device,
    /// `VK_KHR_ray_tracing_pipeline`, when the tier has it.
    pub ray_tracing_pipeline: Option<khr::ray_tracing_pipeline::Device>,
}

/// The device and everything created with it that lives as long as it.
pub struct GpuContext {
    /// The Vulkan loader.
    pub entry: ash::Entry,
    /// The instance.
    pub instance: ash::Instance,
    /// The physical device.
    pub physical: vk::PhysicalDevice,
    /// The logical device.
    pub device: ash::Device,
    /// The one graphics + compute + transfer queue.
    pub queue: vk::Queue,
    /// Its family.
    pub queue_family: u32,
    /// Memory for buffers and images.
    pub allocator: ManuallyDrop<Arc<Mutex<Allocator>>>,
    /// What the allocations hold ([`GpuContext::memory`]).
    ledger: Mutex<MemoryLedger>,
    /// Device name as the driver reports it.
    pub device_name: String,
    /// Extensions the device offers.
    pub capabilities: Capabilities,
    /// The tier in use (the best offered, capped by settings).
    pub tier: Tier,
    /// Nanoseconds per timestamp tick.
    pub timestamp_period_ns: f32,
    /// Ray tracing entry points (tiers above `NoRayTracing`).
    pub ray_tracing: Option<RayTracingFns>,
    /// Validation errors, when validation is on.
    pub validation: Arc<ValidationLog>,
    /// Whether the validation layer is active.
    pub validation_enabled: bool,
    /// Whether pipelines are made with their statistics captured and logged
    /// ([`DeviceSettings::pipeline_statistics`], where the device offers them).
    pub pipeline_statistics: bool,
    debug_utils: Option<(ext::debug_utils::Instance, vk::DebugUtilsMessengerEXT)>,
    /// Device limits.
    pub limits: vk::PhysicalDeviceLimits,
    /// [`DeviceSettings::memory_budget`].
    pub memory_budget: Option<u64>,
    /// Size of the device's largest device-local memory heap.
    pub device_local_bytes: u64,
    /// [`DeviceSettings::shrink_after_frames`] (clamped): the wait of every [`Shrink`] rule
    /// [`GpuContext::shrink_rule`] gives out.
    ///
    /// [`Shrink`]: crate::gpu::upload::Shrink
    pub shrink_after_frames: u32,
    /// Vulkan objects destroyed so far ([`GpuContext::objects_destroyed`]).
    destroyed: AtomicU64,
}

impl GpuContext {
    /// Creates the instance and device.
    pub fn new(settings: &DeviceSettings) -> Result<Self, RenderError> {
        // SAFETY: loading the Vulkan loader library runs its initialisation code; we trust the
        // system's libvulkan.so.1.
        let entry = unsafe { ash::Entry::load() }.map_err(|e| {
            RenderError::NoVulkan(format!(
                "could not load the Vulkan loader (libvulkan.so.1): {e}. On Debian run scripts/setup.sh \
                 or `apt-get install libvulkan1 mesa-vulkan-drivers`"
            ))
        })?;

        let validation_log = Arc::new(ValidationLog::default());
        let layer_name = c"VK_LAYER_KHRONOS_validation";
        // SAFETY: plain enumeration through a loaded entry.
        let layers = unsafe { entry.enumerate_instance_layer_properties() }?;
        let has_validation = layers.iter().any(|l| l.layer_name_as_c_str() == Ok(layer_name));
        let validation = settings.validation && has_validation;
        if settings.validation && !has_validation {
            return Err(RenderError::NoVulkan(
                "validation was requested but VK_LAYER_KHRONOS_validation is not installed \
                 (Debian: apt-get install vulkan-validationlayers, or set RENDER_VALIDATION=0)"
                    .into(),
            ));
        }

        let app_name = CString::new("ecs-decals").expect("no NUL");
        let app_info = vk::ApplicationInfo::default().application_name(&app_name).engine_name(&app_name).api_version(vk::API_VERSION_1_3);
        let mut instance_exts: Vec<*const i8> = settings.surface_extensions.iter().map(|e| e.as_ptr()).collect();
        if validation {
            instance_exts.push(ext::debug_utils::NAME.as_ptr());
            instance_exts.push(ext::validation_features::NAME.as_ptr());
        }
        let layer_ptrs = if validation { vec![layer_name.as_ptr()] } else { vec![] };
        let mut messenger_info = vk::DebugUtilsMessengerCreateInfoEXT::default()
            .message_severity(vk::DebugUtilsMessageSeverityFlagsEXT::ERROR | vk::DebugUtilsMessageSeverityFlagsEXT::WARNING)
            .message_type(
                vk::DebugUtilsMessageTypeFlagsEXT::GENERAL
                    | vk::DebugUtilsMessageTypeFlagsEXT::VALIDATION
                    | vk::DebugUtilsMessageTypeFlagsEXT::PERFORMANCE,
            )
            .pfn_user_callback(Some(debug_callback))
            .user_data(Arc::as_ptr(&validation_log) as *mut c_void);
        let mut instance_info = vk::InstanceCreateInfo::default()
            .application_info(&app_info)
            .enabled_extension_names(&instance_exts)
            .enabled_layer_names(&layer_ptrs);
        // Synchronization validation too: hazards between passes (a missing or too narrow
        // barrier) are errors like any other, and fail the tests.
        let enables = [vk::ValidationFeatureEnableEXT::SYNCHRONIZATION_VALIDATION];
        let mut features = vk::ValidationFeaturesEXT::default().enabled_validation_features(&enables);
        if validation {
            // Also catches errors in vkCreateInstance / vkDestroyInstance themselves.
            instance_info = instance_info.push_next(&mut messenger_info).push_next(&mut features);
        }
        // SAFETY: every pointer in the create info refers to locals that outlive the call.
        let instance = unsafe { entry.create_instance(&instance_info, None) }
            .map_err(|e| RenderError::NoVulkan(format!("vkCreateInstance failed: {e}")))?;

        let debug_utils = if validation {
            let loader = ext::debug_utils::Instance::new(&entry, &instance);
            // SAFETY: the instance is valid; the log pointer outlives the messenger (see Drop).
            let messenger = unsafe { loader.create_debug_utils_messenger(&messenger_info, None) }?;
            Some((loader, messenger))
        } else {
            None
        };

        let (physical, queue_family, mut caps, device_name) = pick_physical_device(&instance)?;
        caps.texture_compression_bc &= !settings.without_texture_compression;
        let tier = caps.best_tier().min(settings.max_tier);
        // SAFETY: `physical` came from this instance.
        let props = unsafe { instance.get_physical_device_properties(physical) };
        // SAFETY: `physical` was enumerated from this instance.
        let memory = unsafe { instance.get_physical_device_memory_properties(physical) };
        let device_local_bytes = memory.memory_heaps[..memory.memory_heap_count as usize]
            .iter()
            .filter(|heap| heap.flags.contains(vk::MemoryHeapFlags::DEVICE_LOCAL))
            .map(|heap| heap.size)
            .max()
            .unwrap_or(0);

        let mut extensions: Vec<&CStr> = Vec::new();
        if !settings.surface_extensions.is_empty() {
            extensions.push(khr::swapchain::NAME);
        }
        if tier >= Tier::RayTracingPipeline {
            extensions.push(khr::acceleration_structure::NAME);
            extensions.push(khr::deferred_host_operations::NAME);
            if caps.ray_tracing_pipeline {
                extensions.push(khr::ray_tracing_pipeline::NAME);
            }
        }
        if tier == Tier::RayQuery {
            extensions.push(khr::ray_query::NAME);
        }
        let pipeline_statistics = settings.pipeline_statistics && caps.pipeline_executable_properties;
        if settings.pipeline_statistics && !pipeline_statistics {
            tracing::warn!(device = %device_name, "pipeline statistics were asked for, but the device lacks VK_KHR_pipeline_executable_properties");
        }
        if pipeline_statistics {
            extensions.push(khr::pipeline_executable_properties::NAME);
        }
        let ext_ptrs: Vec<*const i8> = extensions.iter().map(|e| e.as_ptr()).collect();

        let features = vk::PhysicalDeviceFeatures::default()
            .sampler_anisotropy(true)
            .independent_blend(true)
            .geometry_shader(true) // gl_PrimitiveID in fragment shaders (visibility buffer)
            .multi_draw_indirect(true) // GPU culling's indirect draws (crate::culling)
            .draw_indirect_first_instance(true) // their firstInstance is the instance slot
            .shader_int64(true)
            .fragment_stores_and_atomics(true) // the display check's counter (crate::present::check)
            .fill_mode_non_solid(false)
            .texture_compression_bc(caps.texture_compression_bc); // block-compressed textures (crate::scene::level_bytes)
        let mut f12 = vk::PhysicalDeviceVulkan12Features::default()
            .buffer_device_address(true)
            .descriptor_indexing(true)
            .runtime_descriptor_array(true)
            .descriptor_binding_partially_bound(true)
            .descriptor_binding_variable_descriptor_count(true)
            .descriptor_binding_sampled_image_update_after_bind(true)
            .descriptor_binding_storage_image_update_after_bind(true)
            .descriptor_binding_update_unused_while_pending(true)
            .shader_sampled_image_array_non_uniform_indexing(true)
            .timeline_semaphore(true)
            .scalar_block_layout(true)
            .draw_indirect_count(true)
            .host_query_reset(true);
        let mut f13 = vk::PhysicalDeviceVulkan13Features::default().dynamic_rendering(true).synchronization2(true).maintenance4(true);
        let mut f_as = vk::PhysicalDeviceAccelerationStructureFeaturesKHR::default().acceleration_structure(true);
        let mut f_rq = vk::PhysicalDeviceRayQueryFeaturesKHR::default().ray_query(true);
        let mut f_rtp = vk::PhysicalDeviceRayTracingPipelineFeaturesKHR::default().ray_tracing_pipeline(true);
        let priorities = [1.0f32];
        let queue_info = [vk::DeviceQueueCreateInfo::default().queue_family_index(queue_family).queue_priorities(&priorities)];
        let mut device_info = vk::DeviceCreateInfo::default()
            .queue_create_infos(&queue_info)
            .enabled_extension_names(&ext_ptrs)
            .enabled_features(&features)
            .push_next(&mut f12)
            .push_next(&mut f13);
        if tier >= Tier::RayTracingPipeline {
            device_info = device_info.push_next(&mut f_as);
            if caps.ray_tracing_pipeline {
                device_info = device_info.push_next(&mut f_rtp);
            }
        }
        if tier == Tier::RayQuery {
            device_info = device_info.push_next(&mut f_rq);
        }
        let mut f_stats = vk::PhysicalDevicePipelineExecutablePropertiesFeaturesKHR::default().pipeline_executable_info(true);
        if pipeline_statistics {
            device_info = device_info.push_next(&mut f_stats);
        }
        // SAFETY: the create info and its chain point at locals alive for the call; the
        // physical device supports every feature requested (checked in pick_physical_device;
        // pipelineExecutableInfo is required of every device that offers its extension).
        let device = unsafe { instance.create_device(physical, &device_info, None) }?;
        // SAFETY: queue 0 of the family we created.
        let queue = unsafe { device.get_device_queue(queue_family, 0) };

        let allocator = Allocator::new(&AllocatorCreateDesc {
            instance: instance.clone(),
            device: device.clone(),
            physical_device: physical,
            debug_settings: Default::default(),
            buffer_device_address: true,
            allocation_sizes: Default::default(),
        })?;

        let ray_tracing = (tier >= Tier::RayTracingPipeline).then(|| RayTracingFns {
            acceleration_structure: khr::acceleration_structure::Device::new(&instance, &device),
            ray_tracing_pipeline: caps.ray_tracing_pipeline.then(|| khr::ray_tracing_pipeline::Device::new(&instance, &device)),
        });

        tracing::info!(device = %device_name, tier = tier.name(), validation, "Vulkan device ready");
        Ok(Self {
            entry,
            instance,
            physical,
            device,
            queue,
            queue_family,
            allocator: ManuallyDrop::new(Arc::new(Mutex::new(allocator))),
            ledger: Mutex::new(MemoryLedger::default()),
            device_name,
            capabilities: caps,
            tier,
            timestamp_period_ns: props.limits.timestamp_period,
            ray_tracing,
            validation: validation_log,
            validation_enabled: validation,
            pipeline_statistics,
            debug_utils,
            limits: props.limits,
            memory_budget: settings.memory_budget,
            device_local_bytes,
            shrink_after_frames: settings.shrink_after_frames.max(crate::gpu::FRAMES_IN_FLIGHT as u32),
            destroyed: AtomicU64::new(0),
        })
    }

    /// What this device offers decals: ray queries (the ray-query tier) and ray-tracing
    /// pipelines (enabled at either ray-tracing tier when the device has them).
    pub fn ray_support(&self) -> crate::settings::RaySupport {
        crate::settings::RaySupport {
            ray_query: self.tier == Tier::RayQuery,
            ray_pipeline: self.ray_tracing.as_ref().is_some_and(|rt| rt.ray_tracing_pipeline.is_some()),
        }
    }

    /// Locks the memory allocator.
    pub fn allocator(&self) -> std::sync::MutexGuard<'_, Allocator> {
        self.allocator.lock().unwrap_or_else(|e| e.into_inner())
    }

    /// The rule by which a buffer that follows a count shrinks or is released, waiting
    /// [`GpuContext::shrink_after_frames`] low frames.
    pub fn shrink_rule(&self) -> crate::gpu::upload::Shrink {
        crate::gpu::upload::Shrink::after(self.shrink_after_frames)
    }

    /// The memory the renderer may use: [`GpuContext::memory_budget`] when set, otherwise the
    /// largest device-local heap. Buffers that grow with the scene take stated shares of it.
    pub fn memory_limit(&self) -> u64 {
        self.memory_budget.unwrap_or(self.device_local_bytes)
    }

    /// Allocates memory through the allocator, within [`GpuContext::memory_budget`], and counts
    /// it as `kind` (of `format`, for a texture) in the [`GpuContext::memory`] ledger. Running out
    /// (of the budget or of the device) is [`RenderError::OutOfMemory`] naming the allocation.
    pub fn allocate(&self, desc: &AllocationCreateDesc<'_>, kind: MemoryKind, format: vk::Format) -> Result<Allocation, RenderError> {
        let allocation = self.allocate_uncounted(desc)?;
        self.ledger().add(kind, format, allocation.size(), false);
        Ok(allocation)
    }

    /// Frees what [`GpuContext::allocate`] gave for `kind` and `format`.
    pub fn free(&self, allocation: Allocation, kind: MemoryKind, format: vk::Format) -> Result<(), gpu_allocator::AllocationError> {
        let bytes = allocation.size();
        self.allocator().free(allocation)?;
        self.ledger().add(kind, format, bytes, true);
        Ok(())
    }

    /// The bytes allocated now, by kind ([`MemoryLedger`]).
    pub fn memory(&self) -> MemoryCounts {
        self.ledger().counts()
    }

    /// The bytes the allocator says are allocated (its report allocates: for tests and checks,
    /// not for every frame).
    pub fn allocator_bytes(&self) -> u64 {
        self.allocator().generate_report().total_allocated_bytes
    }

    fn ledger(&self) -> std::sync::MutexGuard<'_, MemoryLedger> {
        self.ledger.lock().unwrap_or_else(|e| e.into_inner())
    }

    fn allocate_uncounted(&self, desc: &AllocationCreateDesc<'_>) -> Result<Allocation, RenderError> {
        let mut allocator = self.allocator();
        let out_of_memory = |allocator: &Allocator, budget| RenderError::OutOfMemory {
            what: desc.name.to_owned(),
            requested: desc.requirements.size,
            in_use: allocator.generate_report().total_allocated_bytes,
            budget,
        };
        if let Some(budget) = self.memory_budget {
            let in_use = allocator.generate_report().total_allocated_bytes;
            if in_use.saturating_add(desc.requirements.size) > budget {
                return Err(out_of_memory(&allocator, Some(budget)));
            }
        }
        allocator.allocate(desc).map_err(|e| match e {
            gpu_allocator::AllocationError::OutOfMemory => out_of_memory(&allocator, self.memory_budget),
            other => RenderError::Allocation(other),
        })
    }

    /// How many Vulkan objects have been destroyed through [`GpuContext::destroying`] (or noted
    /// with [`GpuContext::note_destroyed`]). A command buffer recorded before the count last
    /// changed may name a destroyed object, or one whose handle a new object took: it is never
    /// submitted again (`crate::gpu::commands`). Every object a command can name is counted
    /// (buffers, images and their views, pipelines and layouts, samplers, descriptor objects,
    /// query pools, acceleration structures, the swapchain); objects no command names (shader
    /// modules, semaphores, fences, command pools) are destroyed through `device` directly.
    pub fn objects_destroyed(&self) -> u64 {
        self.destroyed.load(Ordering::Relaxed)
    }

    /// The device, for destroying an object with it: counts the destruction.
    pub fn destroying(&self) -> &ash::Device {
        self.note_destroyed();
        &self.device
    }

    /// Counts the destruction of an object destroyed through an extension's functions.
    pub fn note_destroyed(&self) {
        self.destroyed.fetch_add(1, Ordering::Relaxed);
    }

    /// Waits until the GPU is idle. Used before teardown, resizes and screenshots.
    pub fn wait_idle(&self) {
        // SAFETY: the device is valid; waiting has no other precondition.
        if let Err(e) = unsafe { self.device.device_wait_idle() } {
            tracing::error!("vkDeviceWaitIdle failed: {e}");
        }
    }

    /// Runs `record` in a one-off command buffer and waits for it. `record` gets the buffer
    /// both as a [`Recorder`] (recording directly) and raw, for commands the recorder does not
    /// have. For setup work, readbacks and tests only (never per frame).
    pub fn run_once(&self, record: impl FnOnce(&Recorder, vk::CommandBuffer)) -> Result<(), RenderError> {
        let recorder = Recorder::new(self, CommandCache::one_off(self)?, false);
        let recorded = recorder.direct().map(|cmd| record(&recorder, cmd));
        let (cache, finished) = recorder.finish();
        let result = recorded.and(finished).map_err(RenderError::from).and_then(|_| self.submit_once(cache.cmd()));
        cache.destroy(self);
        result
    }

    fn submit_once(&self, cmd: vk::CommandBuffer) -> Result<(), RenderError> {
        let d = &self.device;
        // SAFETY: the buffer is recorded and ended; the fence wait guarantees the GPU finished
        // before the fence (and, in `run_once`, the pool) is destroyed.
        unsafe {
            let fence = d.create_fence(&vk::FenceCreateInfo::default(), None)?;
            let cmds = [vk::CommandBufferSubmitInfo::default().command_buffer(cmd)];
            let submit = vk::SubmitInfo2::default().command_buffer_infos(&cmds);
            let result = d.queue_submit2(self.queue, &[submit], fence).and_then(|_| d.wait_for_fences(&[fence], true, u64::MAX));
            d.destroy_fence(fence, None);
            result?;
        }
        Ok(())
    }
}

impl Drop for GpuContext {
    fn drop(&mut self) {
        self.wait_idle();
        // SAFETY: the GPU is idle and every resource created from this device has been destroyed
        // by its owner (the renderer drops its resources before its context). The allocator
        // frees its memory blocks before the device goes, and the messenger before the instance.
        unsafe {
            // Everything sharing the allocator (the egui renderer) is dropped by now, so this is
            // the last reference and the memory blocks go before the device.
            ManuallyDrop::drop(&mut self.allocator);
            self.device.destroy_device(None);
            if let Some((loader, messenger)) = self.debug_utils.take() {
                loader.destroy_debug_utils_messenger(messenger, None);
            }
            self.instance.destroy_instance(None);
        }
    }
}

fn pick_physical_device(instance: &ash::Instance) -> Result<(vk::PhysicalDevice, u32, Capabilities, String), RenderError> {
    // SAFETY: enumeration on a valid instance.
    let devices = unsafe { instance.enumerate_physical_devices() }?;
    let mut best: Option<(i32, vk::PhysicalDevice, u32, Capabilities, String)> = None;
    let mut rejected = Vec::new();
    for pd in devices {
        // SAFETY: `pd` came from this instance.
        let props = unsafe { instance.get_physical_device_properties(pd) };
        let name = props.device_name_as_c_str().map(|s| s.to_string_lossy().into_owned()).unwrap_or_default();
        if props.api_version < vk::API_VERSION_1_3 {
            rejected.push(format!(
                "{name}: Vulkan {}.{} < 1.3",
                vk::api_version_major(props.api_version),
                vk::api_version_minor(props.api_version)
            ));
            continue;
        }
        // SAFETY: as above.
        let exts = unsafe { instance.enumerate_device_extension_properties(pd) }?;
        let has = |n: &CStr| exts.iter().any(|e| e.extension_name_as_c_str() == Ok(n));
        let mut f12 = vk::PhysicalDeviceVulkan12Features::default();
        let mut f13 = vk::PhysicalDeviceVulkan13Features::default();
        let base = {
            let mut f2 = vk::PhysicalDeviceFeatures2::default().push_next(&mut f12).push_next(&mut f13);
            // SAFETY: as above; the chain points at locals.
            unsafe { instance.get_physical_device_features2(pd, &mut f2) };
            f2.features
        };
        let required = [
            ("dynamicRendering", f13.dynamic_rendering),
            ("synchronization2", f13.synchronization2),
            ("bufferDeviceAddress", f12.buffer_device_address),
            ("timelineSemaphore", f12.timeline_semaphore),
            ("runtimeDescriptorArray", f12.runtime_descriptor_array),
            ("descriptorBindingPartiallyBound", f12.descriptor_binding_partially_bound),
            ("descriptorBindingSampledImageUpdateAfterBind", f12.descriptor_binding_sampled_image_update_after_bind),
            ("descriptorBindingStorageImageUpdateAfterBind", f12.descriptor_binding_storage_image_update_after_bind),
            ("shaderSampledImageArrayNonUniformIndexing", f12.shader_sampled_image_array_non_uniform_indexing),
            ("samplerAnisotropy", base.sampler_anisotropy),
            ("shaderInt64", base.shader_int64),
            ("fragmentStoresAndAtomics", base.fragment_stores_and_atomics),
            ("independentBlend", base.independent_blend),
            ("geometryShader", base.geometry_shader),
            ("multiDrawIndirect", base.multi_draw_indirect),
            ("drawIndirectFirstInstance", base.draw_indirect_first_instance),
            ("drawIndirectCount", f12.draw_indirect_count),
        ];
        if let Some((missing, _)) = required.iter().find(|(_, ok)| *ok == vk::FALSE) {
            rejected.push(format!("{name}: lacks {missing}"));
            continue;
        }
        // SAFETY: as above.
        let families = unsafe { instance.get_physical_device_queue_family_properties(pd) };
        let Some(family) = families
            .iter()
            .position(|f| f.queue_flags.contains(vk::QueueFlags::GRAPHICS | vk::QueueFlags::COMPUTE) && f.timestamp_valid_bits > 0)
        else {
            rejected.push(format!("{name}: no graphics queue with timestamps"));
            continue;
        };
        let caps = Capabilities {
            acceleration_structure: has(khr::acceleration_structure::NAME) && has(khr::deferred_host_operations::NAME),
            ray_query: has(khr::ray_query::NAME),
            ray_tracing_pipeline: has(khr::ray_tracing_pipeline::NAME),
            texture_compression_bc: base.texture_compression_bc == vk::TRUE,
            pipeline_executable_properties: has(khr::pipeline_executable_properties::NAME),
        };
        let score = match props.device_type {
            vk::PhysicalDeviceType::DISCRETE_GPU => 3,
            vk::PhysicalDeviceType::INTEGRATED_GPU => 2,
            vk::PhysicalDeviceType::CPU => 1,
            _ => 0,
        };
        if best.as_ref().is_none_or(|b| score > b.0) {
            best = Some((score, pd, family as u32, caps, name));
        }
    }
    best.map(|(_, pd, f, c, n)| (pd, f, c, n)).ok_or_else(|| {
        RenderError::NoVulkan(format!(
            "no Vulkan 1.3 device with the features we need ({}); on Debian 12 run scripts/setup.sh for Mesa lavapipe",
            if rejected.is_empty() { "no devices at all".to_string() } else { rejected.join("; ") }
        ))
    })
}
