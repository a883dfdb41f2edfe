//! Display transform: exposure (the camera's, or auto-exposure's, `crate::exposure`) and a tone
//! mapper, from the HDR target into an sRGB display image (the offscreen target or a swapchain
//! image); or, after post-process anti-aliasing (`crate::fxaa`, `crate::smaa`), which tone maps
//! into a target of its own from compute (which cannot write an sRGB or swapchain image), a copy
//! of that target.

use ash::vk;

use crate::RenderError;
use crate::gpu::device::GpuContext;
use crate::gpu::pipeline::{GraphicsDesc, create_graphics};
use crate::gpu::shaders;
use crate::graph::targets::{ANTIALIASED, HDR};
use crate::graph::{BufferUse, Frame, ImageRef, Load, PassKind, ResourceId};
use crate::scene::gpu::GpuScene;
use crate::settings::AntiAliasing;

/// The tone-mapping pass.
pub struct Tonemap {
    /// The display pass: tone mapping, or copying out the anti-aliased target.
    pipelines: [vk::Pipeline; 2],
    format: vk::Format,
}

impl Tonemap {
    /// Creates the pipelines (the display pass in both forms) for a display target of `format`.
    pub fn new(ctx: &GpuContext, layout: vk::PipelineLayout, format: vk::Format) -> Result<Self, RenderError> {
        let formats = [format];
        let pipelines = [
            create_graphics(ctx, layout, &GraphicsDesc::fullscreen("tonemap", shaders::TONEMAP_FRAG, &formats))?,
            create_graphics(ctx, layout, &GraphicsDesc::fullscreen("display (anti-aliased)", shaders::TONEMAP_FRAG_ANTIALIASED, &formats))?,
        ];
        Ok(Self { pipelines, format })
    }

    /// The display format this pipeline writes.
    pub fn format(&self) -> vk::Format {
        self.format
    }

    /// Reads the HDR target (and auto-exposure's record, `exposure`, when it runs), writes
    /// `display` (the offscreen display target or a swapchain image) with anti-aliasing `aa`:
    /// FXAA's or SMAA's passes ran before (`crate::fxaa`, `crate::smaa`), and the display pass
    /// copies out what they wrote. `check` is the debug builds' counter of HDR pixels that are not
    /// finite (`crate::present::check`), which the display pass adds to.
    pub fn record(
        &self,
        f: &mut Frame,
        scene: &GpuScene,
        display: impl Into<ImageRef>,
        aa: AntiAliasing,
        exposure: Option<(ResourceId, BufferUse)>,
        check: Option<(ResourceId, BufferUse)>,
    ) -> Result<(), RenderError> {
        let antialiased = matches!(aa, AntiAliasing::Fxaa | AntiAliasing::Smaa);
        let pipeline = self.pipelines[usize::from(antialiased)];
        let mut pass = f.pass("tonemap", PassKind::Graphics).read(scene.res.tables, BufferUse::Storage).reads(exposure);
        if let Some((res, use_)) = check {
            pass = pass.write(res, use_);
        }
        // The HDR target: tone mapped here, or (anti-aliased) checked here.
        let pass = if antialiased { pass.sample(&ANTIALIASED).sample(&HDR) } else { pass.sample(&HDR) };
        pass.color(display, Load::Discard).record(|p| {
            let push = p.push;
            p.fullscreen(pipeline, &push);
        })
    }

    /// Destroys the pipeline; the GPU must be idle.
    pub fn destroy(self, ctx: &GpuContext) {
        for p in self.pipelines {
            // SAFETY: the GPU is idle.
            unsafe { ctx.destroying().destroy_pipeline(p, None) };
        }
    }
}
