//! Interlaced single-layer transparency in the deferred pipeline (seed 002
//! `002_9638fcf4f713d316.txt` §2.4.2, §3.1, eq. 3.3; refraction with a depth check, §3.3).
//!
//! The G-buffer pass draws the blended instances after the opaque ones with the `INTERLACED`
//! variant of `shaders/gbuffer.frag`: on odd rows only, with the same depth test and writes,
//! their opacity and refraction in the material target's B and A. So on odd rows the nearest
//! glass replaces the opaque surface behind it in depth and in every attribute, and everything
//! downstream treats it as a surface: light culling's depth ranges hold it, the shadow pass
//! traces its shadows, decals land on it when its receiver layers say so, and the one lighting
//! pass lights it (the point of the method: glass costs no second lighting path). Passes that
//! rebuild surfaces from depth step two rows while the frame interlaces (`INTERLACED`, `row_step`
//! in `shaders/include/depth.glsl`), so their vertical neighbours lie on the same layer.
//!
//! After lighting, [`Interlaced::compose`] copies the lit image and `shaders/transparency_compose.comp`
//! rewrites every pixel as `α·T + (1 − α)·O`. Where the seed blends each pair of rows into one
//! colour (halving vertical resolution over glass), each pixel here keeps its own sample for
//! the layer its row holds and interpolates only the other layer from the rows above and below,
//! checked by depth: glass is never blended over an opaque surface in front of it, and a
//! refracted background sample in front of the glass is rejected.

use ash::vk;

use crate::RenderError;
use crate::gpu::device::GpuContext;
use crate::gpu::pipeline::create_compute;
use crate::gpu::shaders;
use crate::graph::Frame;
use crate::graph::targets::{HDR, TRANSPARENCY_SOURCE};
use crate::scene::gpu::GpuScene;
use crate::settings::TransparencyMethod;
use crate::transparency::{composition, compute_pass, copy_target};

/// The composition pass's pipeline.
pub struct Interlaced {
    compose: vk::Pipeline,
    /// The seed's pairwise composition ([`TransparencyMethod::InterlacedPairs`]).
    compose_pairs: vk::Pipeline,
}

impl Interlaced {
    /// Creates the pipeline.
    pub fn new(ctx: &GpuContext, layout: vk::PipelineLayout) -> Result<Self, RenderError> {
        Ok(Self {
            compose: create_compute(ctx, layout, "transparency composition", shaders::TRANSPARENCY_COMPOSE_COMP)?,
            compose_pairs: create_compute(
                ctx,
                layout,
                "transparency composition (seed pairs)",
                shaders::TRANSPARENCY_COMPOSE_COMP_SEED_PAIRS,
            )?,
        })
    }

    /// Copies the lit HDR image and composes the interlaced glass over the opaque rows into the
    /// HDR target. Runs after the lighting pass of a frame whose G-buffer interlaced glass.
    /// `method` picks this module's composition or the seed's pairs.
    pub fn compose(&self, f: &mut Frame, scene: &GpuScene, method: TransparencyMethod) -> Result<(), RenderError> {
        copy_target(f, "transparency_copy", &HDR, &TRANSPARENCY_SOURCE)?;
        let pipeline = if method == TransparencyMethod::InterlacedPairs { self.compose_pairs } else { self.compose };
        compute_pass(f, "transparency_compose", pipeline, |pass| composition(pass, scene))
    }

    /// Destroys the pipeline; the GPU must be idle.
    pub fn destroy(self, ctx: &GpuContext) {
        for p in [self.compose, self.compose_pairs] {
            // SAFETY: the GPU is idle.
            unsafe { ctx.destroying().destroy_pipeline(p, None) };
        }
    }
}
