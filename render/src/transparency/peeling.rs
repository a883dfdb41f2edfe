//! Deferred depth peeling with two G-buffers (seed 002 `002_9638fcf4f713d316.txt` §4.1.2): the
//! full-resolution reference the interlaced method ([`super::interlaced`]) trades resolution
//! against, and a column of the seed's Tables 4.4 and 4.5.
//!
//! The deferred frame runs its layer passes twice ([`crate::pipelines::deferred_frame`]):
//! 1. the **opaque layer**: the G-buffer without blended surfaces, light culling and shadows
//!    over its depth, decals, lighting; [`Peeling::keep_background`] copies the lit image and
//!    the depth (the depth in compute, into R32F: a transfer copy of the depth target took
//!    0.44 ms at 1080p on the lent H100, against 0.01 ms for the colour copy);
//! 2. the **nearest layer**: the G-buffer with the blended instances drawn on every row with
//!    their opacity and refraction (`shaders/gbuffer.frag`, variant `GLASS`), culled, shadowed,
//!    decalled and lit again over its own depth, so the glass gets its own light lists and
//!    shadows at full resolution;
//! 3. [`Peeling::compose`] blends the glass over the opaque layer with refraction and the same
//!    depth check as the interlaced composition (`shaders/transparency_peeled.comp`).
//!
//! The seed peels its second layer by testing each fragment against the first layer's depth and
//! rejects transparent fragments there; its first layer is the nearest surface, glass included.
//! We light the opaque layer first and take no per-fragment peel test: where glass is nearest
//! the two are the same surfaces (every opaque fragment there lies behind the glass), and
//! elsewhere the seed's second layer holds surfaces hidden behind opaque ones, which only its
//! refracted lookups could reach, showing what is hidden; ours holds the visible surface,
//! which is what a refracted ray sees. Shadow maps are drawn once and read by both layers, as
//! in the seed. Like interlacing, it keeps one layer of glass: glass behind glass is not drawn.

use ash::vk;

use crate::RenderError;
use crate::gpu::device::GpuContext;
use crate::gpu::pipeline::create_compute;
use crate::gpu::shaders;
use crate::graph::targets::{BACKGROUND_DEPTH, DEPTH, HDR, TRANSPARENCY_SOURCE};
use crate::graph::{BufferUse, Frame, ImageUse};
use crate::scene::gpu::GpuScene;
use crate::transparency::{composition, compute_pass, copy_target};

/// The depth-peeling composition's pipeline.
pub struct Peeling {
    keep_depth: vk::Pipeline,
    compose: vk::Pipeline,
}

impl Peeling {
    /// Creates the pipeline.
    pub fn new(ctx: &GpuContext, layout: vk::PipelineLayout) -> Result<Self, RenderError> {
        Ok(Self {
            keep_depth: create_compute(ctx, layout, "depth peeling depth copy", shaders::PEELING_KEEP_DEPTH_COMP)?,
            compose: create_compute(ctx, layout, "depth peeling composition", shaders::TRANSPARENCY_PEELED_COMP)?,
        })
    }

    /// Keeps the lit opaque layer: copies the HDR target and the depth before the nearest
    /// layer's G-buffer replaces them.
    pub fn keep_background(&self, f: &mut Frame, scene: &GpuScene) -> Result<(), RenderError> {
        copy_target(f, "peeling_copy", &HDR, &TRANSPARENCY_SOURCE)?;
        compute_pass(f, "peeling_keep_depth", self.keep_depth, |pass| {
            pass.sample(&DEPTH).image(&BACKGROUND_DEPTH, ImageUse::StorageWrite).read(scene.res.tables, BufferUse::Storage)
        })
    }

    /// Blends the lit nearest layer's glass over the kept opaque layer, in the HDR target.
    pub fn compose(&self, f: &mut Frame, scene: &GpuScene) -> Result<(), RenderError> {
        compute_pass(f, "peeling_compose", self.compose, |pass| composition(pass, scene).sample(&BACKGROUND_DEPTH))
    }

    /// Destroys the pipeline; the GPU must be idle.
    pub fn destroy(self, ctx: &GpuContext) {
        for p in [self.keep_depth, self.compose] {
            // SAFETY: the GPU is idle.
            unsafe { ctx.destroying().destroy_pipeline(p, None) };
        }
    }
}
