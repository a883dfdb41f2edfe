//! Graphics pipelines for dynamic rendering, described by a small builder, and the one pipeline
//! layout every pass shares: the bindless set plus [`ScenePush`] push constants.

use ash::vk;

use crate::RenderError;
use crate::gpu::device::GpuContext;
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
}

/// Colour blending for every attachment of a pipeline.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Blend {
    /// Outputs replace the attachment.
    Replace,
    /// Outputs add to the attachment (lighting over emitted radiance).
    Additive,
    /// `src.rgb · src.a + dst.rgb · (1 − src.a)`; the attachment's alpha is kept.
    Alpha,
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
        }
    }
}

/// Creates a graphics pipeline. Viewport, scissor and cull mode are dynamic.
pub fn create_graphics(ctx: &GpuContext, layout: vk::PipelineLayout, desc: &GraphicsDesc) -> Result<vk::Pipeline, RenderError> {
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
    let mut stages = vec![vk::PipelineShaderStageCreateInfo::default().stage(vk::ShaderStageFlags::VERTEX).module(vs).name(c"main")];
    if let Some(fs) = fs {
        stages.push(vk::PipelineShaderStageCreateInfo::default().stage(vk::ShaderStageFlags::FRAGMENT).module(fs).name(c"main"));
    }
    let bindings = [vk::VertexInputBindingDescription {
        binding: 0,
        stride: std::mem::size_of::<GpuVertex>() as u32,
        input_rate: vk::VertexInputRate::VERTEX,
    }];
    let attributes = [
        (0, vk::Format::R32G32B32_SFLOAT, std::mem::offset_of!(GpuVertex, position)),
        (1, vk::Format::R32G32B32_SFLOAT, std::mem::offset_of!(GpuVertex, normal)),
        (2, vk::Format::R32G32_SFLOAT, std::mem::offset_of!(GpuVertex, uv)),
        (3, vk::Format::R32G32B32A32_SFLOAT, std::mem::offset_of!(GpuVertex, tangent)),
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
    let multisample = vk::PipelineMultisampleStateCreateInfo::default().rasterization_samples(vk::SampleCountFlags::TYPE_1);
    let depth = vk::PipelineDepthStencilStateCreateInfo::default()
        .depth_test_enable(desc.depth_compare.is_some())
        .depth_write_enable(desc.depth_write)
        .depth_compare_op(desc.depth_compare.unwrap_or(vk::CompareOp::ALWAYS));
    let blend_attachments: Vec<_> = (0..desc.color_formats.len())
        .map(|i| {
            let mask = desc.write_masks.get(i).copied().unwrap_or(vk::ColorComponentFlags::RGBA);
            let state = vk::PipelineColorBlendAttachmentState::default().color_write_mask(mask);
            match desc.blend {
                Blend::Replace => state,
                Blend::Additive => state
                    .blend_enable(true)
                    .src_color_blend_factor(vk::BlendFactor::ONE)
                    .dst_color_blend_factor(vk::BlendFactor::ONE)
                    .color_blend_op(vk::BlendOp::ADD)
                    .src_alpha_blend_factor(vk::BlendFactor::ZERO)
                    .dst_alpha_blend_factor(vk::BlendFactor::ONE)
                    .alpha_blend_op(vk::BlendOp::ADD),
                Blend::Alpha => state
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
        .push_next(&mut rendering);
    // SAFETY: every state struct points at locals that outlive the call; the modules are
    // destroyed after pipeline creation, which the spec allows.
    let result = unsafe { d.create_graphics_pipelines(vk::PipelineCache::null(), &[info], None) };
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
pub fn set_viewport(ctx: &GpuContext, cmd: vk::CommandBuffer, extent: vk::Extent2D) {
    let (w, h) = (extent.width as f32, extent.height as f32);
    let viewport = vk::Viewport { x: 0.0, y: h, width: w, height: -h, min_depth: 0.0, max_depth: 1.0 };
    // SAFETY: `cmd` is recording.
    unsafe {
        ctx.device.cmd_set_viewport(cmd, 0, &[viewport]);
        ctx.device.cmd_set_scissor(cmd, 0, &[vk::Rect2D { offset: vk::Offset2D::default(), extent }]);
    }
}
