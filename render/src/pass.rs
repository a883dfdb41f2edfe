//! What every pass gets: the device, the command buffer being recorded, the shared pipeline
//! layout with its push constants, and the frame's GPU timer; plus the helpers passes share
//! (attachments, mesh draws).

use ash::vk;

use crate::device::GpuContext;
use crate::gpu_scene::GpuScene;
use crate::pipeline::ScenePush;
use crate::scene::DrawItem;
use crate::timestamps::GpuTimer;

/// The recording context handed to each pass function.
pub struct PassContext<'a> {
    /// The device.
    pub ctx: &'a GpuContext,
    /// The command buffer being recorded.
    pub cmd: vk::CommandBuffer,
    /// The layout shared by all pipelines.
    pub layout: vk::PipelineLayout,
    /// The bindless set.
    pub bindless: vk::DescriptorSet,
    /// Push constants for scene passes.
    pub push: ScenePush,
    /// This frame's GPU timer.
    pub timer: &'a mut GpuTimer,
}

impl PassContext<'_> {
    /// Records `body` as one timed pass.
    pub fn timed(&mut self, name: &'static str, body: impl FnOnce(&mut Self)) {
        self.timer.begin(self.ctx, self.cmd, name);
        body(self);
        self.timer.end(self.ctx, self.cmd);
    }

    /// Binds a graphics pipeline with the bindless set and push constants.
    pub fn bind_graphics(&self, pipeline: vk::Pipeline, push: &ScenePush) {
        let d = &self.ctx.device;
        // SAFETY: `cmd` is recording; pipeline, layout and set are live and compatible.
        unsafe {
            d.cmd_bind_pipeline(self.cmd, vk::PipelineBindPoint::GRAPHICS, pipeline);
            d.cmd_bind_descriptor_sets(self.cmd, vk::PipelineBindPoint::GRAPHICS, self.layout, 0, &[self.bindless], &[]);
            d.cmd_push_constants(self.cmd, self.layout, vk::ShaderStageFlags::ALL, 0, bytemuck::bytes_of(push));
        }
    }

    /// Begins dynamic rendering into the given attachments over `extent`.
    pub fn begin_rendering(
        &self,
        extent: vk::Extent2D,
        colors: &[vk::RenderingAttachmentInfo],
        depth: Option<&vk::RenderingAttachmentInfo>,
    ) {
        let mut info = vk::RenderingInfo::default()
            .render_area(vk::Rect2D { offset: vk::Offset2D::default(), extent })
            .layer_count(1)
            .color_attachments(colors);
        if let Some(depth) = depth {
            info = info.depth_attachment(depth);
        }
        // SAFETY (both blocks): `cmd` is recording; every pipeline has viewport, scissor and cull
        // mode dynamic, and this sets all three before any draw.
        unsafe { self.ctx.device.cmd_begin_rendering(self.cmd, &info) };
        crate::pipeline::set_viewport(self.ctx, self.cmd, extent);
        unsafe { self.ctx.device.cmd_set_cull_mode(self.cmd, vk::CullModeFlags::NONE) };
    }

    /// Ends dynamic rendering.
    pub fn end_rendering(&self) {
        // SAFETY: matches begin_rendering.
        unsafe { self.ctx.device.cmd_end_rendering(self.cmd) };
    }

    /// Draws every instance whose draw item passes `filter`; the instance slot is passed as
    /// `firstInstance`, so shaders find their record at `gl_InstanceIndex`.
    pub fn draw_meshes(&self, scene: &GpuScene, draws: &[Option<DrawItem>], filter: impl Fn(&DrawItem) -> bool) {
        let d = &self.ctx.device;
        let mut bound_mesh = None;
        let mut cull = Some(vk::CullModeFlags::NONE); // begin_rendering's default
        for (slot, draw) in draws.iter().enumerate() {
            let Some(draw) = draw.filter(|d| filter(d)) else { continue };
            let Some(mesh) = scene.mesh(draw.mesh) else { continue };
            // SAFETY: `cmd` is recording inside a rendering scope with a mesh pipeline bound;
            // the mesh buffer is live until the frame completes (deferred destruction).
            unsafe {
                if bound_mesh != Some(draw.mesh) {
                    d.cmd_bind_vertex_buffers(self.cmd, 0, &[mesh.buffer.raw], &[0]);
                    d.cmd_bind_index_buffer(self.cmd, mesh.buffer.raw, mesh.index_offset, vk::IndexType::UINT32);
                    bound_mesh = Some(draw.mesh);
                }
                let mode = if draw.double_sided { vk::CullModeFlags::NONE } else { vk::CullModeFlags::BACK };
                if cull != Some(mode) {
                    d.cmd_set_cull_mode(self.cmd, mode);
                    cull = Some(mode);
                }
                d.cmd_draw_indexed(self.cmd, mesh.index_count, 1, 0, 0, slot as u32);
            }
        }
    }
}

/// A colour attachment that is cleared (or loaded) and stored.
pub fn color_attachment(view: vk::ImageView, clear: Option<[f32; 4]>) -> vk::RenderingAttachmentInfo<'static> {
    vk::RenderingAttachmentInfo::default()
        .image_view(view)
        .image_layout(vk::ImageLayout::COLOR_ATTACHMENT_OPTIMAL)
        .load_op(if clear.is_some() { vk::AttachmentLoadOp::CLEAR } else { vk::AttachmentLoadOp::LOAD })
        .store_op(vk::AttachmentStoreOp::STORE)
        .clear_value(vk::ClearValue { color: vk::ClearColorValue { float32: clear.unwrap_or_default() } })
}

/// A depth attachment; `clear` clears to that depth, otherwise the contents are loaded.
pub fn depth_attachment(view: vk::ImageView, layout: vk::ImageLayout, clear: Option<f32>) -> vk::RenderingAttachmentInfo<'static> {
    vk::RenderingAttachmentInfo::default()
        .image_view(view)
        .image_layout(layout)
        .load_op(if clear.is_some() { vk::AttachmentLoadOp::CLEAR } else { vk::AttachmentLoadOp::LOAD })
        .store_op(vk::AttachmentStoreOp::STORE)
        .clear_value(vk::ClearValue { depth_stencil: vk::ClearDepthStencilValue { depth: clear.unwrap_or(0.0), stencil: 0 } })
}
