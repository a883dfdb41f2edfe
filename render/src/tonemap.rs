//! Display transform: exposure and the Khronos PBR Neutral tone mapper, from the HDR target
//! into an sRGB display image (the offscreen target or a swapchain image).

use ash::vk;

use crate::RenderError;
use crate::device::GpuContext;
use crate::pass::{PassContext, color_attachment};
use crate::pipeline::{GraphicsDesc, create_graphics};
use crate::shaders;
use crate::sync::{Access, ImageState};
use crate::targets::Target;

/// The tone-mapping pass.
pub struct Tonemap {
    pipeline: vk::Pipeline,
    format: vk::Format,
}

impl Tonemap {
    /// Creates the pipeline for a display target of `format`.
    pub fn new(ctx: &GpuContext, layout: vk::PipelineLayout, format: vk::Format) -> Result<Self, RenderError> {
        let formats = [format];
        let pipeline = create_graphics(ctx, layout, &GraphicsDesc::fullscreen("tonemap", shaders::TONEMAP_FRAG, &formats))?;
        Ok(Self { pipeline, format })
    }

    /// The display format this pipeline writes.
    pub fn format(&self) -> vk::Format {
        self.format
    }

    /// Reads `hdr`, writes the display image (`view`, `extent`, tracked by `state`): the
    /// offscreen display target or a swapchain image.
    pub fn record(&self, p: &mut PassContext, hdr: &mut Target, view: vk::ImageView, extent: vk::Extent2D, state: &mut ImageState) {
        p.timed("tonemap", |p| {
            hdr.use_as(p.ctx, p.cmd, Access::FragmentSampled);
            crate::sync::transition(&p.ctx.device, p.cmd, state, Access::ColorAttachmentWrite, true);
            let color = [color_attachment(view, None)];
            p.begin_rendering(extent, &color, None);
            let push = crate::pipeline::ScenePush { texture_index: crate::targets::slots::HDR, ..p.push };
            p.bind_graphics(self.pipeline, &push);
            // SAFETY: `cmd` is recording inside the rendering scope with the pipeline bound.
            unsafe { p.ctx.device.cmd_draw(p.cmd, 3, 1, 0, 0) };
            p.end_rendering();
        });
    }

    /// Destroys the pipeline; the GPU must be idle.
    pub fn destroy(self, ctx: &GpuContext) {
        // SAFETY: the GPU is idle.
        unsafe { ctx.device.destroy_pipeline(self.pipeline, None) };
    }
}
