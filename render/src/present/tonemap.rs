//! Display transform: exposure and the Khronos PBR Neutral tone mapper, from the HDR target
//! into an sRGB display image (the offscreen target or a swapchain image).

use ash::vk;

use crate::RenderError;
use crate::gpu::device::GpuContext;
use crate::gpu::pipeline::{GraphicsDesc, create_graphics};
use crate::gpu::shaders;
use crate::graph::targets::HDR;
use crate::graph::{BufferUse, Frame, ImageRef, Load, PassKind};
use crate::scene::gpu::GpuScene;

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

    /// Reads the HDR target, writes `display`: the offscreen display target or a swapchain
    /// image.
    pub fn record(&self, f: &mut Frame, scene: &GpuScene, display: impl Into<ImageRef>) -> Result<(), RenderError> {
        f.pass("tonemap", PassKind::Graphics).sample(&HDR).read(scene.res.tables, BufferUse::Storage).color(display, Load::Discard).record(
            |p| {
                let push = p.push;
                p.fullscreen(self.pipeline, &push);
            },
        )
    }

    /// Destroys the pipeline; the GPU must be idle.
    pub fn destroy(self, ctx: &GpuContext) {
        // SAFETY: the GPU is idle.
        unsafe { ctx.device.destroy_pipeline(self.pipeline, None) };
    }
}
