//! Display transform: exposure and the Khronos PBR Neutral tone mapper, from the HDR target
//! into an sRGB display image (the offscreen target or a swapchain image), anti-aliased in the
//! same pass with FXAA when asked for (`shaders/include/fxaa.glsl`: Lottes's FXAA, NVIDIA 2009).
//! FXAA taps the image it anti-aliases about 20 times a pixel; fused into the tone mapper each
//! tap samples the HDR target and maps it, where a pass of its own would first write the
//! displayed image and then read it back (on the lent H100 a full-screen pass costs 0.15 ms
//! before it does anything).

use ash::vk;

use crate::RenderError;
use crate::gpu::device::GpuContext;
use crate::gpu::pipeline::{GraphicsDesc, create_graphics};
use crate::gpu::shaders;
use crate::graph::targets::HDR;
use crate::graph::{BufferUse, Frame, ImageRef, Load, PassKind};
use crate::scene::gpu::GpuScene;
use crate::settings::AntiAliasing;

/// The tone-mapping pass.
pub struct Tonemap {
    /// Without and with FXAA.
    pipelines: [vk::Pipeline; 2],
    format: vk::Format,
}

impl Tonemap {
    /// Creates the pipeline for a display target of `format`.
    pub fn new(ctx: &GpuContext, layout: vk::PipelineLayout, format: vk::Format) -> Result<Self, RenderError> {
        let formats = [format];
        let pipelines = [
            create_graphics(ctx, layout, &GraphicsDesc::fullscreen("tonemap", shaders::TONEMAP_FRAG, &formats))?,
            create_graphics(ctx, layout, &GraphicsDesc::fullscreen("tonemap (FXAA)", shaders::TONEMAP_FRAG_FXAA, &formats))?,
        ];
        Ok(Self { pipelines, format })
    }

    /// The display format this pipeline writes.
    pub fn format(&self) -> vk::Format {
        self.format
    }

    /// Reads the HDR target, writes `display` (the offscreen display target or a swapchain
    /// image) with anti-aliasing `aa`.
    pub fn record(&self, f: &mut Frame, scene: &GpuScene, display: impl Into<ImageRef>, aa: AntiAliasing) -> Result<(), RenderError> {
        let pipeline = self.pipelines[usize::from(aa == AntiAliasing::Fxaa)];
        f.pass("tonemap", PassKind::Graphics).sample(&HDR).read(scene.res.tables, BufferUse::Storage).color(display, Load::Discard).record(
            |p| {
                let push = p.push;
                p.fullscreen(pipeline, &push);
            },
        )
    }

    /// Destroys the pipeline; the GPU must be idle.
    pub fn destroy(self, ctx: &GpuContext) {
        for p in self.pipelines {
            // SAFETY: the GPU is idle.
            unsafe { ctx.device.destroy_pipeline(p, None) };
        }
    }
}
