//! SMAA 1x (Jimenez, Echevarria, Sousa and Gutierrez, "SMAA: Enhanced Subpixel Morphological
//! Antialiasing", Eurographics 2012), the morphological post-process anti-aliasing option beside
//! FXAA (issue: anti-aliasing, item 4), in every pipeline: three compute passes over the
//! displayed image (`shaders/include/smaa.glsl` says what each does), the last writing the
//! anti-aliased colour target that the display pass copies out, as FXAA's does.
//!
//! **Design.** Where FXAA blurs along whatever luma gradient it finds, SMAA reconstructs the
//! silhouette each stair step stands for (Reshetov's MLAA re-vectorisation: the edge's length
//! and the crossing edges at its ends tell an L, a Z or a U apart) and blends a pixel with its
//! neighbour across the edge by the area the silhouette cuts off: straight edges stay sharp
//! and text-like detail is left alone. The paper looks that area up in a precomputed texture;
//! here the shader computes it, since only edge pixels need it and the lent GPUs are fastest in
//! compute (the paper's passes are full-screen fragment passes with a stencil mask). Diagonal
//! patterns and corner rounding, optional in the paper, are left out, and so are its temporal
//! and multisampled modes (T2x, S2x): TAA and MSAA are modes of their own here.

use ash::vk;

use crate::RenderError;
use crate::gpu::device::GpuContext;
use crate::gpu::pipeline::create_compute;
use crate::gpu::shaders;
use crate::graph::targets::{ANTIALIASED, HDR, SMAA_EDGES, SMAA_WEIGHTS};
use crate::graph::{BufferUse, Frame, ImageUse, PassKind, ResourceId};
use crate::scene::gpu::GpuScene;

/// SMAA's three passes.
pub struct Smaa {
    edges: vk::Pipeline,
    weights: vk::Pipeline,
    blend: vk::Pipeline,
}

impl Smaa {
    /// Creates the pipelines.
    pub fn new(ctx: &GpuContext, layout: vk::PipelineLayout) -> Result<Self, RenderError> {
        Ok(Self {
            edges: create_compute(ctx, layout, "smaa edges", shaders::SMAA_EDGES_COMP)?,
            weights: create_compute(ctx, layout, "smaa weights", shaders::SMAA_WEIGHTS_COMP)?,
            blend: create_compute(ctx, layout, "smaa blend", shaders::SMAA_BLEND_COMP)?,
        })
    }

    /// Anti-aliases the displayed image (the HDR target through exposure, auto-exposure's
    /// record `exposure` when it runs, and the tone mapper) into the anti-aliased colour target.
    pub fn record(&self, f: &mut Frame, scene: &GpuScene, exposure: Option<(ResourceId, BufferUse)>) -> Result<(), RenderError> {
        let groups = {
            let extent = f.graph.extent();
            (extent.width.div_ceil(8), extent.height.div_ceil(8))
        };
        let dispatch = |p: &crate::graph::PassContext, pipeline| {
            p.bind(vk::PipelineBindPoint::COMPUTE, pipeline, &p.push);
            p.cmd.dispatch(groups.0, groups.1, 1);
        };
        f.pass("smaa_edges", PassKind::Compute)
            .sample(&HDR)
            .read(scene.res.tables, BufferUse::Storage)
            .reads(exposure)
            .image(&SMAA_EDGES, ImageUse::StorageWrite)
            .record(|p| dispatch(p, self.edges))?;
        f.pass("smaa_weights", PassKind::Compute)
            .image(&SMAA_EDGES, ImageUse::StorageRead)
            .image(&SMAA_WEIGHTS, ImageUse::StorageWrite)
            .record(|p| dispatch(p, self.weights))?;
        f.pass("smaa_blend", PassKind::Compute)
            .sample(&HDR)
            .read(scene.res.tables, BufferUse::Storage)
            .reads(exposure)
            .image(&SMAA_WEIGHTS, ImageUse::StorageRead)
            .image(&ANTIALIASED, ImageUse::StorageWrite)
            .record(|p| dispatch(p, self.blend))
    }

    /// Destroys the pipelines; the GPU must be idle.
    pub fn destroy(self, ctx: &GpuContext) {
        for p in [self.edges, self.weights, self.blend] {
            // SAFETY: the GPU is idle.
            unsafe { ctx.destroying().destroy_pipeline(p, None) };
        }
    }
}
