//! Display transform: exposure (the camera's, or auto-exposure's, `crate::exposure`) and a tone mapper, from the HDR target
//! into an sRGB display image (the offscreen target or a swapchain image), anti-aliased with
//! FXAA when asked for (`shaders/include/fxaa.glsl`: Lottes's FXAA, NVIDIA 2009).
//!
//! FXAA runs in compute (`shaders/fxaa.comp`): it tone maps each of its taps from the HDR
//! target and writes the anti-aliased colour into a target of its own, which the display pass
//! then copies into the display image (compute cannot write an sRGB or swapchain image). FXAA
//! fused into the full-screen tone-mapping fragment pass took that pass from 0.15 to 1.08 ms on
//! the lent H100, whose fragment shading is slow; in compute it costs a fraction of that
//! (docs/experiments/notebook.md, "FXAA").

use ash::vk;

use crate::RenderError;
use crate::gpu::device::GpuContext;
use crate::gpu::pipeline::{GraphicsDesc, create_compute, create_graphics};
use crate::gpu::shaders;
use crate::graph::targets::{ANTIALIASED, HDR};
use crate::graph::{BufferUse, Frame, ImageRef, ImageUse, Load, PassKind, ResourceId};
use crate::scene::gpu::GpuScene;
use crate::settings::AntiAliasing;

/// The tone-mapping pass.
pub struct Tonemap {
    /// The display pass: tone mapping, or copying out FXAA's result.
    pipelines: [vk::Pipeline; 2],
    /// FXAA in compute.
    fxaa: vk::Pipeline,
    format: vk::Format,
}

impl Tonemap {
    /// Creates the pipelines (the display pass in both forms, and FXAA) for a display target of
    /// `format`.
    pub fn new(ctx: &GpuContext, layout: vk::PipelineLayout, format: vk::Format) -> Result<Self, RenderError> {
        let formats = [format];
        let pipelines = [
            create_graphics(ctx, layout, &GraphicsDesc::fullscreen("tonemap", shaders::TONEMAP_FRAG, &formats))?,
            create_graphics(ctx, layout, &GraphicsDesc::fullscreen("display (anti-aliased)", shaders::TONEMAP_FRAG_ANTIALIASED, &formats))?,
        ];
        let fxaa = create_compute(ctx, layout, "fxaa", shaders::FXAA_COMP)?;
        Ok(Self { pipelines, fxaa, format })
    }

    /// The display format this pipeline writes.
    pub fn format(&self) -> vk::Format {
        self.format
    }

    /// Reads the HDR target (and auto-exposure's record, `exposure`, when it runs), writes
    /// `display` (the offscreen display target or a swapchain image) with anti-aliasing `aa`:
    /// FXAA runs here; SMAA's passes (`crate::smaa`) ran before, and the display pass copies out
    /// what either wrote. `check` is the debug builds' counter of HDR pixels that are not
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
        let fxaa = aa == AntiAliasing::Fxaa;
        let antialiased = fxaa || aa == AntiAliasing::Smaa;
        if fxaa {
            let (pipeline, extent) = (self.fxaa, f.graph.extent());
            f.pass("fxaa", PassKind::Compute)
                .sample(&HDR)
                .read(scene.res.tables, BufferUse::Storage)
                .reads(exposure)
                .image(&ANTIALIASED, ImageUse::StorageWrite)
                .record(|p| {
                    p.bind(vk::PipelineBindPoint::COMPUTE, pipeline, &p.push);
                    p.cmd.dispatch(extent.width.div_ceil(8), extent.height.div_ceil(8), 1);
                })?;
        }
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
        for p in self.pipelines.into_iter().chain([self.fxaa]) {
            // SAFETY: the GPU is idle.
            unsafe { ctx.destroying().destroy_pipeline(p, None) };
        }
    }
}
