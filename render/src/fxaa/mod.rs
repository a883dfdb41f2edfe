//! FXAA (Lottes, "FXAA", NVIDIA 2009; `shaders/include/fxaa.glsl`), the cheapest post-process
//! anti-aliasing option, in every pipeline: one compute pass (`shaders/fxaa.comp`) that tone maps
//! each of its taps from the HDR target and writes the anti-aliased colour into a target of its
//! own, which the display pass (`crate::present::tonemap`) then copies into the display image
//! (compute cannot write an sRGB or swapchain image), as it does SMAA's (`crate::smaa`).
//!
//! **Why compute.** FXAA fused into the full-screen tone-mapping fragment pass took that pass
//! from 0.15 to 1.08 ms on the lent H100, whose fragment shading is slow; in compute it costs a
//! fraction of that (docs/experiments/aa-fxaa.md).

use ash::vk;

use crate::RenderError;
use crate::gpu::device::GpuContext;
use crate::gpu::pipeline::create_compute;
use crate::gpu::shaders;
use crate::graph::targets::{ANTIALIASED, HDR};
use crate::graph::{BufferUse, Frame, ImageUse, PassKind, ResourceId};
use crate::scene::gpu::GpuScene;

/// The FXAA pass.
pub struct Fxaa {
    pipeline: vk::Pipeline,
}

impl Fxaa {
    /// Creates the pipeline (on the renderer's bindless `layout`).
    pub fn new(ctx: &GpuContext, layout: vk::PipelineLayout) -> Result<Self, RenderError> {
        Ok(Self { pipeline: create_compute(ctx, layout, "fxaa", shaders::FXAA_COMP)? })
    }

    /// Reads the HDR target (and auto-exposure's record, `exposure`, when it runs) and writes
    /// the anti-aliased display colour into the `ANTIALIASED` target.
    pub fn record(&self, f: &mut Frame, scene: &GpuScene, exposure: Option<(ResourceId, BufferUse)>) -> Result<(), RenderError> {
        let (pipeline, extent) = (self.pipeline, f.graph.extent());
        f.pass("fxaa", PassKind::Compute)
            .sample(&HDR)
            .read(scene.res.tables, BufferUse::Storage)
            .reads(exposure)
            .image(&ANTIALIASED, ImageUse::StorageWrite)
            .record(|p| {
                p.bind(vk::PipelineBindPoint::COMPUTE, pipeline, &p.push);
                p.cmd.dispatch(extent.width.div_ceil(8), extent.height.div_ceil(8), 1);
            })
    }

    /// Destroys the pipeline; the GPU must be idle.
    pub fn destroy(self, ctx: &GpuContext) {
        // SAFETY: the GPU is idle.
        unsafe { ctx.destroying().destroy_pipeline(self.pipeline, None) };
    }
}
