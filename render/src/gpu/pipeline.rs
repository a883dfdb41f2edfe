//! Graphics pipelines for dynamic rendering, described by a small builder, and the one pipeline
//! layout every pass shares: the bindless set plus [`ScenePush`] push constants.

use ash::vk;

use crate::RenderError;
use crate::gpu::commands::Recorder;
use crate::gpu::device::{GpuContext, Tier};
use crate::gpu::shaders;
use crate::layout::GpuVertex;

/// Push constants shared by every pass (defined with the GLSL block in [`crate::layout`]).
pub use crate::layout::ScenePush;

/// Creates the shared pipeline layout.
pub fn create_layout(ctx: &GpuContext, bindless: vk::DescriptorSetLayout) -> Result<vk::PipelineLayout, RenderError> {
    let ranges =
        [vk::PushConstantRange { stage_flags: vk::ShaderStageFlags::ALL, offset: 0, size: std::mem::size_of::<ScenePush>() as u32 }];
    let sets = [bindless];
    // SAFETY: valid create info pointing at locals.
    Ok(unsafe {
        ctx.device.create_pipeline_layout(&vk::PipelineLayoutCreateInfo::default().set_layouts(&sets).push_constant_ranges(&ranges), None)
    }?)
}

/// Describes a graphics pipeline.
#[derive(Clone, Copy)]
pub struct GraphicsDesc<'a> {
    /// Debug name.
    pub name: &'a str,
    /// Vertex shader SPIR-V.
    pub vertex: &'a [u8],
    /// Fragment shader SPIR-V (none for depth-only passes).
    pub fragment: Option<&'a [u8]>,
    /// Read [`GpuVertex`] from vertex buffer binding 0 (otherwise no vertex input).
    pub mesh_vertices: bool,
    /// Colour attachment formats.
    pub color_formats: &'a [vk::Format],
    /// Depth attachment format.
    pub depth_format: Option<vk::Format>,
    /// Depth comparison (None: depth test off).
    pub depth_compare: Option<vk::CompareOp>,
    /// Write depth.
    pub depth_write: bool,
    /// Primitive topology.
    pub topology: vk::PrimitiveTopology,
    /// How colour outputs combine with the attachments.
    pub blend: Blend,
    /// Per-attachment write masks (empty: RGBA everywhere).
    pub write_masks: &'a [vk::ColorComponentFlags],
    /// Samples a pixel of the attachments (1 but for MSAA, `crate::msaa`).
    pub samples: u32,
}

/// Colour blending of a pipeline's attachments.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Blend {
    /// Outputs replace the attachment.
    Replace,
    /// Outputs add to the attachment (lighting over emitted radiance).
    Additive,
    /// `src.rgb · src.a + dst.rgb · (1 − src.a)`; the attachment's alpha is kept.
    Alpha,
    /// [`Blend::Alpha`] into every attachment but the last, which [`Blend::Additive`] adds to
    /// (deferred decals: attributes into the G-buffer, emission into the HDR target).
    AlphaThenAdditive,
    /// `src.rgb + dst.rgb · (1 − src.a)`: colour premultiplied by its opacity, so one output
    /// covers (alpha 1) or glows (alpha 0) or anything between (particles); the attachment's
    /// alpha is kept.
    Premultiplied,
}

impl<'a> GraphicsDesc<'a> {
    /// A pass that draws the scene's meshes through `mesh.vert` with reverse-Z depth of
    /// `depth_format` (tested GREATER and written), so every such pass produces the same depth.
    pub fn mesh(name: &'a str, fragment: Option<&'a [u8]>, color_formats: &'a [vk::Format], depth_format: vk::Format) -> Self {
        Self {
            name,
            vertex: shaders::MESH_VERT,
            fragment,
            mesh_vertices: true,
            color_formats,
            depth_format: Some(depth_format),
            depth_compare: Some(vk::CompareOp::GREATER),
            depth_write: true,
            topology: vk::PrimitiveTopology::TRIANGLE_LIST,
            blend: Blend::Replace,
            write_masks: &[],
            samples: 1,
        }
    }

    /// A full-screen pass: no vertex input, no depth, one colour target.
    pub fn fullscreen(name: &'a str, fragment: &'a [u8], color_formats: &'a [vk::Format]) -> Self {
        Self {
            name,
            vertex: shaders::FULLSCREEN_VERT,
            fragment: Some(fragment),
            mesh_vertices: false,
            color_formats,
            depth_format: None,
            depth_compare: None,
            depth_write: false,
            topology: vk::PrimitiveTopology::TRIANGLE_LIST,
            blend: Blend::Replace,
            write_masks: &[],
            samples: 1,
        }
    }
}

/// The values of the shaders' specialization constants (`crate::layout::SPEC_*`), fixed when a
/// pipeline is made. The default keeps the area lights' code and stages no lights.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub struct Specialization {
    /// Whether the lighting code keeps the area lights' (`AREA_LIGHTS`, `SPEC_AREA_LIGHTS`).
    /// Without it the driver drops that code, and the registers it held: the many-lights
    /// scene's visibility-buffer shading took 5.11 ms with it and 3.75 without on the lent H200
    /// (driver 580.159.04, 1920×1080, `--bench-scene many-lights --light-radius 0.05`). A pipeline made without
    /// it shades a rect or disk light as a point light, so it may serve only scenes with none.
    pub area_lights: bool,
    /// Whether a compute shading pass reads its workgroup's long unshadowed light lists into
    /// shared memory a chunk at a time, keeping the lights that reach the workgroup's surface
    /// points (`STAGED_LIGHTS`, `SPEC_STAGED_LIGHTS`; `shaders/include/shading.glsl`). In the
    /// many-lights scene with sampled shadows, the visibility buffer's shading took 2.82 ms with
    /// it and 3.56 without on the lent H200 (driver 580.159.04, 1920×1080,
    /// `docs/experiments/lights-staged-lists.md`). Compiled in, its code and shared memory gave
    /// the whole pass 96 registers a thread, which slowed the lists walked a thread at a time
    /// (shadowed ones, and short ones) by up to 30 %; so the shading passes use it only in frames
    /// whose lists are unshadowed and can be longer than a chunk
    /// (`crate::lights::LightFrame::shading`). The image is the same either way.
    pub staged_lights: bool,
}

impl Default for Specialization {
    fn default() -> Self {
        Self { area_lights: true, staged_lights: false }
    }
}

impl Specialization {
    /// Calls `f` with the Vulkan description of these values (every stage of a pipeline gets
    /// it: an id a stage does not declare changes nothing in it).
    fn with_info<R>(self, f: impl FnOnce(&vk::SpecializationInfo) -> R) -> R {
        let data = [vk::Bool32::from(self.area_lights), vk::Bool32::from(self.staged_lights)];
        let size = std::mem::size_of::<vk::Bool32>();
        let mut entries = [crate::layout::SPEC_AREA_LIGHTS, crate::layout::SPEC_STAGED_LIGHTS]
            .map(|constant_id| vk::SpecializationMapEntry { constant_id, offset: 0, size });
        for (offset, entry) in (0u32..).step_by(size).zip(&mut entries) {
            entry.offset = offset; // the value's place in `data`
        }
        f(&vk::SpecializationInfo::default().map_entries(&entries).data(bytemuck::cast_slice(&data)))
    }
}

/// Creates a graphics pipeline. Viewport, scissor and cull mode are dynamic.
pub fn create_graphics(ctx: &GpuContext, layout: vk::PipelineLayout, desc: &GraphicsDesc) -> Result<vk::Pipeline, RenderError> {
    create_graphics_specialized(ctx, layout, desc, Specialization::default())
}

/// [`create_graphics`] with the specialization constants `spec`.
pub fn create_graphics_specialized(
    ctx: &GpuContext,
    layout: vk::PipelineLayout,
    desc: &GraphicsDesc,
    spec: Specialization,
) -> Result<vk::Pipeline, RenderError> {
    spec.with_info(|info| graphics_with(ctx, layout, desc, info))
}

fn graphics_with(
    ctx: &GpuContext,
    layout: vk::PipelineLayout,
    desc: &GraphicsDesc,
    spec: &vk::SpecializationInfo,
) -> Result<vk::Pipeline, RenderError> {
    let d = &ctx.device;
    let vs = shaders::module(ctx, desc.vertex)?;
    let fs = match desc.fragment.map(|f| shaders::module(ctx, f)).transpose() {
        Ok(fs) => fs,
        Err(e) => {
            // SAFETY: the module is unused.
            unsafe { d.destroy_shader_module(vs, None) };
            return Err(e);
        }
    };
    let stage =
        |stage, module| vk::PipelineShaderStageCreateInfo::default().stage(stage).module(module).name(c"main").specialization_info(spec);
    let mut stages = vec![stage(vk::ShaderStageFlags::VERTEX, vs)];
    if let Some(fs) = fs {
        stages.push(stage(vk::ShaderStageFlags::FRAGMENT, fs));
    }
    let bindings = [vk::VertexInputBindingDescription {
        binding: 0,
        stride: std::mem::size_of::<GpuVertex>() as u32,
        input_rate: vk::VertexInputRate::VERTEX,
    }];
    let attributes = [
        // The packed attributes (`crate::scene::vertex`): the octahedral normal and the UV are
        // unpacked by the vertex fetch; the tangent's sign bit needs the shader.
        (0, vk::Format::R32G32B32_SFLOAT, std::mem::offset_of!(GpuVertex, position)),
        (1, vk::Format::R16G16_SNORM, std::mem::offset_of!(GpuVertex, normal)),
        (2, vk::Format::R16G16_UNORM, std::mem::offset_of!(GpuVertex, uv)),
        (3, vk::Format::R32_UINT, std::mem::offset_of!(GpuVertex, tangent)),
    ]
    .map(|(location, format, offset)| vk::VertexInputAttributeDescription { location, binding: 0, format, offset: offset as u32 });
    let vertex_input = if desc.mesh_vertices {
        vk::PipelineVertexInputStateCreateInfo::default().vertex_binding_descriptions(&bindings).vertex_attribute_descriptions(&attributes)
    } else {
        vk::PipelineVertexInputStateCreateInfo::default()
    };
    let input_assembly = vk::PipelineInputAssemblyStateCreateInfo::default().topology(desc.topology);
    let viewport = vk::PipelineViewportStateCreateInfo::default().viewport_count(1).scissor_count(1);
    let raster = vk::PipelineRasterizationStateCreateInfo::default()
        .polygon_mode(vk::PolygonMode::FILL)
        .cull_mode(vk::CullModeFlags::NONE)
        .front_face(vk::FrontFace::COUNTER_CLOCKWISE)
        .line_width(1.0);
    let multisample = vk::PipelineMultisampleStateCreateInfo::default().rasterization_samples(vk::SampleCountFlags::from_raw(desc.samples));
    let depth = vk::PipelineDepthStencilStateCreateInfo::default()
        .depth_test_enable(desc.depth_compare.is_some())
        .depth_write_enable(desc.depth_write)
        .depth_compare_op(desc.depth_compare.unwrap_or(vk::CompareOp::ALWAYS));
    let blend_attachments: Vec<_> = (0..desc.color_formats.len())
        .map(|i| {
            let mask = desc.write_masks.get(i).copied().unwrap_or(vk::ColorComponentFlags::RGBA);
            let state = vk::PipelineColorBlendAttachmentState::default().color_write_mask(mask);
            let last = i + 1 == desc.color_formats.len();
            let blend = match desc.blend {
                Blend::AlphaThenAdditive if last => Blend::Additive,
                Blend::AlphaThenAdditive => Blend::Alpha,
                blend => blend,
            };
            match blend {
                Blend::Replace => state,
                Blend::Additive => state
                    .blend_enable(true)
                    .src_color_blend_factor(vk::BlendFactor::ONE)
                    .dst_color_blend_factor(vk::BlendFactor::ONE)
                    .color_blend_op(vk::BlendOp::ADD)
                    .src_alpha_blend_factor(vk::BlendFactor::ZERO)
                    .dst_alpha_blend_factor(vk::BlendFactor::ONE)
                    .alpha_blend_op(vk::BlendOp::ADD),
                Blend::Premultiplied => state
                    .blend_enable(true)
                    .src_color_blend_factor(vk::BlendFactor::ONE)
                    .dst_color_blend_factor(vk::BlendFactor::ONE_MINUS_SRC_ALPHA)
                    .color_blend_op(vk::BlendOp::ADD)
                    .src_alpha_blend_factor(vk::BlendFactor::ZERO)
                    .dst_alpha_blend_factor(vk::BlendFactor::ONE)
                    .alpha_blend_op(vk::BlendOp::ADD),
                Blend::Alpha | Blend::AlphaThenAdditive => state
                    .blend_enable(true)
                    .src_color_blend_factor(vk::BlendFactor::SRC_ALPHA)
                    .dst_color_blend_factor(vk::BlendFactor::ONE_MINUS_SRC_ALPHA)
                    .color_blend_op(vk::BlendOp::ADD)
                    .src_alpha_blend_factor(vk::BlendFactor::ZERO)
                    .dst_alpha_blend_factor(vk::BlendFactor::ONE)
                    .alpha_blend_op(vk::BlendOp::ADD),
            }
        })
        .collect();
    let blend = vk::PipelineColorBlendStateCreateInfo::default().attachments(&blend_attachments);
    let dynamic_states = [vk::DynamicState::VIEWPORT, vk::DynamicState::SCISSOR, vk::DynamicState::CULL_MODE];
    let dynamic = vk::PipelineDynamicStateCreateInfo::default().dynamic_states(&dynamic_states);
    let mut rendering = vk::PipelineRenderingCreateInfo::default()
        .color_attachment_formats(desc.color_formats)
        .depth_attachment_format(desc.depth_format.unwrap_or(vk::Format::UNDEFINED));
    let info = vk::GraphicsPipelineCreateInfo::default()
        .stages(&stages)
        .vertex_input_state(&vertex_input)
        .input_assembly_state(&input_assembly)
        .viewport_state(&viewport)
        .rasterization_state(&raster)
        .multisample_state(&multisample)
        .depth_stencil_state(&depth)
        .color_blend_state(&blend)
        .dynamic_state(&dynamic)
        .layout(layout)
        .flags(statistics_flags(ctx))
        .push_next(&mut rendering);
    // SAFETY: every state struct points at locals that outlive the call; the modules are
    // destroyed after pipeline creation, which the spec allows.
    let result = unsafe { d.create_graphics_pipelines(vk::PipelineCache::null(), &[info], None) };
    if let Ok(pipelines) = &result {
        log_statistics(ctx, pipelines[0], desc.name);
    }
    // SAFETY: modules are no longer needed once the pipeline exists (or failed).
    unsafe {
        d.destroy_shader_module(vs, None);
        if let Some(fs) = fs {
            d.destroy_shader_module(fs, None);
        }
    }
    let pipeline = result.map_err(|(_, e)| RenderError::Vulkan(e))?[0];
    tracing::debug!(name = desc.name, "pipeline created");
    Ok(pipeline)
}

/// Sets a viewport and scissor covering `extent`. The viewport is flipped (negative height,
/// Vulkan 1.1 core) so clip-space +Y points up as in glam's projections, and counter-clockwise
/// triangles stay front-facing.
pub fn set_viewport(cmd: &Recorder, extent: vk::Extent2D) {
    let (w, h) = (extent.width as f32, extent.height as f32);
    let viewport = vk::Viewport { x: 0.0, y: h, width: w, height: -h, min_depth: 0.0, max_depth: 1.0 };
    cmd.set_viewport(viewport, vk::Rect2D { offset: vk::Offset2D::default(), extent });
}

/// The creation flags that capture a pipeline's statistics, where
/// [`crate::gpu::DeviceSettings::pipeline_statistics`] turned them on.
fn statistics_flags(ctx: &GpuContext) -> vk::PipelineCreateFlags {
    if ctx.pipeline_statistics { vk::PipelineCreateFlags::CAPTURE_STATISTICS_KHR } else { vk::PipelineCreateFlags::empty() }
}

/// Logs what the driver reports of `pipeline`'s executables (one a stage on most drivers), one
/// `info` line each: its statistics by their names (on NVIDIA "Register Count", "Binary Size",
/// "Shared Memory Size"...). Nothing unless the context captures statistics.
fn log_statistics(ctx: &GpuContext, pipeline: vk::Pipeline, name: &str) {
    if !ctx.pipeline_statistics {
        return;
    }
    let loader = ash::khr::pipeline_executable_properties::Device::new(&ctx.instance, &ctx.device);
    // SAFETY: the pipeline was just made, with CAPTURE_STATISTICS, on a device with the
    // extension and its feature enabled.
    let executables = match unsafe { loader.get_pipeline_executable_properties(&vk::PipelineInfoKHR::default().pipeline(pipeline)) } {
        Ok(executables) => executables,
        Err(e) => {
            tracing::warn!(name, error = %e, "no pipeline statistics");
            return;
        }
    };
    for (index, executable) in executables.iter().enumerate() {
        let info = vk::PipelineExecutableInfoKHR::default().pipeline(pipeline).executable_index(index as u32);
        // SAFETY: as above; `index` is one of the executables just listed.
        let Ok(statistics) = (unsafe { loader.get_pipeline_executable_statistics(&info) }) else { continue };
        let text: Vec<String> = statistics.iter().map(statistic_text).collect();
        let stage = executable.name_as_c_str().map(|c| c.to_string_lossy().into_owned()).unwrap_or_default();
        tracing::info!(name, stage, statistics = text.join(", "), "pipeline statistics");
    }
}

/// "Name=value" of one pipeline statistic.
fn statistic_text(statistic: &vk::PipelineExecutableStatisticKHR) -> String {
    let name = statistic.name_as_c_str().map(|c| c.to_string_lossy().into_owned()).unwrap_or_default();
    // SAFETY: each arm reads the member of the value union that `format` says is set.
    let value = unsafe {
        match statistic.format {
            vk::PipelineExecutableStatisticFormatKHR::BOOL32 => (statistic.value.b32 != vk::FALSE).to_string(),
            vk::PipelineExecutableStatisticFormatKHR::INT64 => statistic.value.i64.to_string(),
            vk::PipelineExecutableStatisticFormatKHR::UINT64 => statistic.value.u64.to_string(),
            vk::PipelineExecutableStatisticFormatKHR::FLOAT64 => statistic.value.f64.to_string(),
            _ => "?".to_string(),
        }
    };
    format!("{name}={value}")
}

/// Creates a compute pipeline from `spirv` with the shared layout.
pub fn create_compute(ctx: &GpuContext, layout: vk::PipelineLayout, name: &str, spirv: &[u8]) -> Result<vk::Pipeline, RenderError> {
    create_compute_specialized(ctx, layout, name, spirv, Specialization::default())
}

/// [`create_compute`] with the specialization constants `spec`.
pub fn create_compute_specialized(
    ctx: &GpuContext,
    layout: vk::PipelineLayout,
    name: &str,
    spirv: &[u8],
    spec: Specialization,
) -> Result<vk::Pipeline, RenderError> {
    let module = shaders::module(ctx, spirv)?;
    let result = spec.with_info(|spec| {
        let stage = vk::PipelineShaderStageCreateInfo::default()
            .stage(vk::ShaderStageFlags::COMPUTE)
            .module(module)
            .name(c"main")
            .specialization_info(spec);
        let info = vk::ComputePipelineCreateInfo::default().stage(stage).layout(layout).flags(statistics_flags(ctx));
        // SAFETY: the create info points at locals; the module may be destroyed once the
        // pipeline exists (or failed).
        unsafe { ctx.device.create_compute_pipelines(vk::PipelineCache::null(), &[info], None) }
    });
    if let Ok(pipelines) = &result {
        log_statistics(ctx, pipelines[0], name);
    }
    // SAFETY: as above.
    unsafe { ctx.device.destroy_shader_module(module, None) };
    let pipeline = result.map_err(|(_, e)| RenderError::Vulkan(e))?[0];
    tracing::debug!(name, "compute pipeline created");
    Ok(pipeline)
}

/// What makes a [`LazyPipeline`].
type MakePipeline = dyn Fn(&GpuContext) -> Result<vk::Pipeline, RenderError> + Send + Sync;

/// A pipeline made the first time a frame asks for it ([`LazyPipeline::get`]), not with the
/// renderer: most of a renderer's variants (each way of applying decals, of lighting, of
/// tracing reflections) serve settings or scenes a run may never use, and on a software device
/// (lavapipe) making all of them took most of a renderer's start (about 3 of 4 seconds). A game
/// pays for a variant once, in the first frame that uses it.
pub struct LazyPipeline {
    made: std::sync::OnceLock<vk::Pipeline>,
    make: Box<MakePipeline>,
}

impl LazyPipeline {
    /// A pipeline that `make` creates when it is first asked for.
    pub fn new(make: impl Fn(&GpuContext) -> Result<vk::Pipeline, RenderError> + Send + Sync + 'static) -> Self {
        Self { made: std::sync::OnceLock::new(), make: Box::new(make) }
    }

    /// A compute pipeline of `spirv`, named `name`, made when first asked for.
    pub fn compute(layout: vk::PipelineLayout, name: &'static str, spirv: &'static [u8]) -> Self {
        Self::new(move |ctx| create_compute(ctx, layout, name, spirv))
    }

    /// The pipeline, made now if no frame asked for it before.
    pub fn get(&self, ctx: &GpuContext) -> Result<vk::Pipeline, RenderError> {
        if let Some(&made) = self.made.get() {
            return Ok(made);
        }
        let made = (self.make)(ctx)?;
        // Frames are recorded on one thread: nothing else can have set it since the check.
        let _ = self.made.set(made);
        Ok(made)
    }

    /// Destroys the pipeline if it was made; the GPU must be idle.
    pub fn destroy(self, ctx: &GpuContext) {
        if let Some(p) = self.made.into_inner() {
            // SAFETY: the GPU is idle.
            unsafe { ctx.destroying().destroy_pipeline(p, None) };
        }
    }
}

/// Creates one compute pipeline per `(name, SPIR-V)` of `stages`, in order; when one fails, the
/// ones made before it are destroyed.
pub fn create_computes<const N: usize>(
    ctx: &GpuContext,
    layout: vk::PipelineLayout,
    stages: [(&str, &[u8]); N],
) -> Result<[vk::Pipeline; N], RenderError> {
    let mut made = Vec::with_capacity(N);
    for (name, spirv) in stages {
        match create_compute(ctx, layout, name, spirv) {
            Ok(p) => made.push(p),
            Err(e) => {
                for p in made {
                    // SAFETY: the pipelines were never used.
                    unsafe { ctx.destroying().destroy_pipeline(p, None) };
                }
                return Err(e);
            }
        }
    }
    Ok(made.try_into().unwrap_or_else(|_| unreachable!("one pipeline per stage")))
}

/// One hit group of a ray-tracing pipeline: its shaders (procedural geometry when it has an
/// intersection shader, else triangles).
#[derive(Clone, Copy, Debug, Default)]
pub struct HitGroup<'a> {
    /// Closest-hit shader SPIR-V.
    pub closest_hit: Option<&'a [u8]>,
    /// Any-hit shader SPIR-V.
    pub any_hit: Option<&'a [u8]>,
    /// Intersection shader SPIR-V for procedural geometry; `None` for triangles.
    pub intersection: Option<&'a [u8]>,
}

impl<'a> HitGroup<'a> {
    /// A group with only an any-hit shader (and an intersection shader for procedural geometry).
    pub fn any_hit(any_hit: &'a [u8], intersection: Option<&'a [u8]>) -> Self {
        Self { closest_hit: None, any_hit: Some(any_hit), intersection }
    }
}

/// The shaders of a ray-tracing pipeline: ray-generation shaders (one shader-binding-table record
/// each, chosen per dispatch), miss shaders and hit groups, chosen by a traced ray's miss index
/// and hit-group offset (every instance's own offset is 0).
pub struct RayTracingDesc<'a> {
    /// Debug name.
    pub name: &'a str,
    /// Ray-generation shaders' SPIR-V.
    pub raygen: &'a [&'a [u8]],
    /// Miss shaders' SPIR-V.
    pub misses: &'a [&'a [u8]],
    /// Hit groups.
    pub hit_groups: &'a [HitGroup<'a>],
}

/// A ray-tracing pipeline and its shader binding table (written once, at creation).
pub struct RayTracingPipeline {
    /// The pipeline (shared layout).
    pub pipeline: vk::Pipeline,
    sbt: crate::gpu::memory::Buffer,
    raygen: Vec<vk::StridedDeviceAddressRegionKHR>,
    miss: vk::StridedDeviceAddressRegionKHR,
    hit: vk::StridedDeviceAddressRegionKHR,
}

impl RayTracingPipeline {
    /// Creates the pipeline (recursion depth 1) and its shader binding table: each record at a
    /// multiple of the device's base alignment, in the order raygen…, miss…, hit group….
    pub fn new<'a>(ctx: &GpuContext, layout: vk::PipelineLayout, desc: &RayTracingDesc<'a>) -> Result<Self, RenderError> {
        let rt = ctx.ray_tracing.as_ref().and_then(|rt| rt.ray_tracing_pipeline.as_ref());
        let rt = rt.ok_or_else(|| RenderError::Other(format!("{}: this device has no ray-tracing pipelines", desc.name)))?;
        let mut props = vk::PhysicalDeviceRayTracingPipelinePropertiesKHR::default();
        let mut props2 = vk::PhysicalDeviceProperties2::default().push_next(&mut props);
        // SAFETY: a valid physical device and a chain of locals.
        unsafe { ctx.instance.get_physical_device_properties2(ctx.physical, &mut props2) };

        use vk::ShaderStageFlags as S;
        let mut stages_spirv: Vec<(S, &[u8])> = desc.raygen.iter().map(|s| (S::RAYGEN_KHR, *s)).collect();
        stages_spirv.extend(desc.misses.iter().map(|s| (S::MISS_KHR, *s)));
        let general = |i: usize| {
            vk::RayTracingShaderGroupCreateInfoKHR::default()
                .ty(vk::RayTracingShaderGroupTypeKHR::GENERAL)
                .general_shader(i as u32)
                .closest_hit_shader(vk::SHADER_UNUSED_KHR)
                .any_hit_shader(vk::SHADER_UNUSED_KHR)
                .intersection_shader(vk::SHADER_UNUSED_KHR)
        };
        let (n, misses) = (desc.raygen.len(), desc.misses.len());
        let mut groups: Vec<_> = (0..n + misses).map(general).collect();
        for group in desc.hit_groups {
            let mut stage = |stage: S, spirv: Option<&'a [u8]>| match spirv {
                Some(spirv) => {
                    stages_spirv.push((stage, spirv));
                    stages_spirv.len() as u32 - 1
                }
                None => vk::SHADER_UNUSED_KHR,
            };
            let closest_hit = stage(S::CLOSEST_HIT_KHR, group.closest_hit);
            let any_hit = stage(S::ANY_HIT_KHR, group.any_hit);
            let intersection = stage(S::INTERSECTION_KHR, group.intersection);
            let ty = match group.intersection {
                Some(_) => vk::RayTracingShaderGroupTypeKHR::PROCEDURAL_HIT_GROUP,
                None => vk::RayTracingShaderGroupTypeKHR::TRIANGLES_HIT_GROUP,
            };
            groups.push(
                vk::RayTracingShaderGroupCreateInfoKHR::default()
                    .ty(ty)
                    .general_shader(vk::SHADER_UNUSED_KHR)
                    .closest_hit_shader(closest_hit)
                    .intersection_shader(intersection)
                    .any_hit_shader(any_hit),
            );
        }
        let mut modules = Vec::with_capacity(stages_spirv.len());
        for (_, spirv) in &stages_spirv {
            match shaders::module(ctx, spirv) {
                Ok(m) => modules.push(m),
                Err(e) => {
                    // SAFETY: the modules made so far are unused.
                    modules.iter().for_each(|&m| unsafe { ctx.device.destroy_shader_module(m, None) });
                    return Err(e);
                }
            }
        }
        let stages: Vec<_> = stages_spirv
            .iter()
            .zip(&modules)
            .map(|((stage, _), &module)| vk::PipelineShaderStageCreateInfo::default().stage(*stage).module(module).name(c"main"))
            .collect();
        let info = vk::RayTracingPipelineCreateInfoKHR::default()
            .stages(&stages)
            .groups(&groups)
            .max_pipeline_ray_recursion_depth(1)
            .layout(layout)
            .flags(statistics_flags(ctx));
        // SAFETY: the create info points at locals; modules may be destroyed afterwards.
        let result = unsafe { rt.create_ray_tracing_pipelines(vk::DeferredOperationKHR::null(), vk::PipelineCache::null(), &[info], None) };
        if let Ok(pipelines) = &result {
            log_statistics(ctx, pipelines[0], desc.name);
        }
        // SAFETY: the modules are no longer needed once the pipeline exists (or failed).
        modules.iter().for_each(|&m| unsafe { ctx.device.destroy_shader_module(m, None) });
        let pipeline = result.map_err(|(_, e)| RenderError::Vulkan(e))?[0];

        let handle_size = props.shader_group_handle_size as usize;
        let group_count = groups.len();
        // SAFETY: the pipeline was created with `group_count` groups.
        let handles = match unsafe { rt.get_ray_tracing_shader_group_handles(pipeline, 0, group_count as u32, handle_size * group_count) } {
            Ok(h) => h,
            Err(e) => {
                // SAFETY: the pipeline is unused.
                unsafe { ctx.destroying().destroy_pipeline(pipeline, None) };
                return Err(e.into());
            }
        };
        let record = (handle_size as u64).next_multiple_of(props.shader_group_handle_alignment as u64);
        let base = (props.shader_group_base_alignment as u64).max(record);
        let stride = record.next_multiple_of(base);
        let sbt = crate::gpu::memory::Buffer::new(
            ctx,
            desc.name,
            stride * group_count as u64 + base,
            vk::BufferUsageFlags::SHADER_BINDING_TABLE_KHR | vk::BufferUsageFlags::SHADER_DEVICE_ADDRESS,
            gpu_allocator::MemoryLocation::CpuToGpu,
        );
        let mut sbt = match sbt {
            Ok(b) => b,
            Err(e) => {
                // SAFETY: the pipeline is unused.
                unsafe { ctx.destroying().destroy_pipeline(pipeline, None) };
                return Err(e);
            }
        };
        // The buffer's address may be less aligned than the table needs: start at the first
        // aligned address inside it.
        let start = sbt.address.next_multiple_of(base) - sbt.address;
        let bytes = sbt.mapped();
        for (g, handle) in handles.chunks_exact(handle_size).enumerate() {
            let at = (start + g as u64 * stride) as usize;
            bytes[at..at + handle_size].copy_from_slice(handle);
        }
        let region = |g: usize, count: usize| vk::StridedDeviceAddressRegionKHR {
            device_address: sbt.address + start + g as u64 * stride,
            stride,
            size: stride * count as u64,
        };
        let hits = desc.hit_groups.len();
        Ok(Self { pipeline, raygen: (0..n).map(|g| region(g, 1)).collect(), miss: region(n, misses), hit: region(n + misses, hits), sbt })
    }

    /// Dispatches `extent` rays from ray-generation shader `raygen` (the pipeline must be bound).
    pub fn trace(&self, cmd: &Recorder, raygen: usize, extent: vk::Extent2D) {
        // The table's regions lie inside its live buffer.
        let none = vk::StridedDeviceAddressRegionKHR::default();
        cmd.trace_rays(&self.raygen[raygen], &self.miss, &self.hit, &none, extent.width, extent.height);
    }

    /// Destroys the pipeline and its table; the GPU must be idle.
    pub fn destroy(self, ctx: &GpuContext) {
        // SAFETY: the GPU is idle.
        unsafe { ctx.destroying().destroy_pipeline(self.pipeline, None) };
        self.sbt.destroy(ctx);
    }
}

/// How a shading pass applies this frame's decals, which picks its pipeline from its
/// [`ShadeVariants`].
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum ShadeVariant {
    /// No decals in the shading.
    Plain,
    /// In-shader ray queries through the decals' structure.
    RayQueryDecals,
    /// The decal buffer a decal pass wrote.
    DecalBuffer,
    /// The clustered decals' lists, walked in the shader.
    ClusteredDecals,
}

/// A shading pass's pipeline in each way it can apply decals: none, in-shader ray queries (on the
/// ray-query tier only: SPIR-V with ray queries cannot even be loaded elsewhere), the decal
/// buffer a decal pass wrote, or (the forward shading pass) the clustered decals' lists walked
/// in the shader (`DecalFrame::clusters_in_shading` in `crate::decals`); each with and without
/// the area lights' code ([`Specialization::area_lights`]), made the first frame that picks it.
/// The frame's decals say which they want ([`ShadeVariant`]), its lights whether any is an area
/// light.
pub struct ShadeVariants {
    /// By [`Specialization`]: without the area lights' code, then with it; each unstaged, then
    /// staged (see [`ShadeVariants::set`]).
    sets: [VariantSet; 4],
}

/// One [`ShadeVariants`] set, all made with one [`Specialization`].
struct VariantSet {
    plain: LazyPipeline,
    ray_query: Option<LazyPipeline>,
    decal_buffer: LazyPipeline,
    clustered: Option<LazyPipeline>,
}

impl ShadeVariants {
    /// The variants of the shaders `[plain, ray query, decal buffer]`, each made by `make` from
    /// its SPIR-V the first frame that picks it ([`LazyPipeline`]); the ray-query one only on
    /// the ray-query tier.
    pub fn new<M: MakeVariant>(ctx: &GpuContext, [plain, ray_query, decal_buffer]: [&'static [u8]; 3], make: M) -> Self {
        let sets = Self::SPECS.map(|spec| VariantSet {
            plain: variant(&make, plain, spec),
            ray_query: (ctx.tier == Tier::RayQuery).then(|| variant(&make, ray_query, spec)),
            decal_buffer: variant(&make, decal_buffer, spec),
            clustered: None,
        });
        Self { sets }
    }

    /// The specialization of each set, in [`ShadeVariants::set`]'s order.
    const SPECS: [Specialization; 4] = [
        Specialization { area_lights: false, staged_lights: false },
        Specialization { area_lights: false, staged_lights: true },
        Specialization { area_lights: true, staged_lights: false },
        Specialization { area_lights: true, staged_lights: true },
    ];

    /// The index of `spec`'s set.
    fn set(spec: Specialization) -> usize {
        usize::from(spec.area_lights) * 2 + usize::from(spec.staged_lights)
    }

    /// Adds the variant that walks the clustered decals' lists itself, made by `make` from
    /// `shader`.
    pub fn with_clustered<M: MakeVariant>(mut self, shader: &'static [u8], make: M) -> Self {
        for (set, spec) in self.sets.iter_mut().zip(Self::SPECS) {
            set.clustered = Some(variant(&make, shader, spec));
        }
        self
    }

    /// The variant `want` made with `spec` (the area lights' code when the scene has one; the
    /// staged lights in compute passes of frames that sample: `crate::lights::LightFrame::shading`),
    /// made now if no frame used it before: the plain one where this pass has no such variant
    /// (no clustered variant, or no ray queries on this tier).
    pub fn pick(&self, ctx: &GpuContext, want: ShadeVariant, spec: Specialization) -> Result<vk::Pipeline, RenderError> {
        let set = &self.sets[Self::set(spec)];
        let variant = match want {
            ShadeVariant::DecalBuffer => &set.decal_buffer,
            ShadeVariant::ClusteredDecals => set.clustered.as_ref().unwrap_or(&set.plain),
            ShadeVariant::RayQueryDecals => set.ray_query.as_ref().unwrap_or(&set.plain),
            ShadeVariant::Plain => &set.plain,
        };
        variant.get(ctx)
    }

    /// Destroys the pipelines that were made; the GPU must be idle.
    pub fn destroy(self, ctx: &GpuContext) {
        for set in self.sets {
            for p in [set.plain, set.decal_buffer].into_iter().chain(set.ray_query).chain(set.clustered) {
                p.destroy(ctx);
            }
        }
    }
}

/// Makes one of [`ShadeVariants`]' pipelines from its shader's SPIR-V, specialized so.
pub trait MakeVariant:
    Fn(&GpuContext, &'static [u8], Specialization) -> Result<vk::Pipeline, RenderError> + Clone + Send + Sync + 'static
{
}

impl<F: Fn(&GpuContext, &'static [u8], Specialization) -> Result<vk::Pipeline, RenderError> + Clone + Send + Sync + 'static> MakeVariant
    for F
{
}

fn variant<M: MakeVariant>(make: &M, spirv: &'static [u8], spec: Specialization) -> LazyPipeline {
    let make = make.clone();
    LazyPipeline::new(move |ctx| make(ctx, spirv, spec))
}
