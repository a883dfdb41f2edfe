//! Visibility-buffer deferred texturing (seed 000 §3.4.1, §5.1.3): a pass writes only instance
//! and triangle ids (alpha-tested for masked materials, which the seed's renderer got wrong),
//! then one full-screen pass rebuilds each pixel's surface by intersecting its camera ray with
//! its triangle, with analytic attribute derivatives for texture filtering (the fix for the
//! seed's 2×2-quad derivative bug; see `shaders/visbuffer_shade.frag`), and shades it.

use ash::vk;

use crate::RenderError;
use crate::gpu::device::{GpuContext, Tier};
use crate::gpu::pipeline::{GraphicsDesc, create_graphics};
use crate::gpu::shaders;
use crate::graph::targets::{DEPTH, DEPTH_FORMAT, HDR, HDR_FORMAT, VISIBILITY, VISIBILITY_FORMAT};
use crate::graph::{BufferUse, Frame, ImageUse, Load, PassKind, ResourceId};
use crate::scene::DrawItem;
use crate::scene::gpu::GpuScene;

/// Pipelines of the visibility-buffer renderer.
pub struct VisBufferPasses {
    ids_opaque: vk::Pipeline,
    ids_mask: vk::Pipeline,
    shade: vk::Pipeline,
}

impl VisBufferPasses {
    /// Creates the pipelines.
    pub fn new(ctx: &GpuContext, layout: vk::PipelineLayout) -> Result<Self, RenderError> {
        let formats = [VISIBILITY_FORMAT];
        let ids = GraphicsDesc::mesh("visibility", Some(shaders::VISBUFFER_FRAG), &formats, DEPTH_FORMAT);
        let hdr = [HDR_FORMAT];
        let shade_fs =
            if ctx.tier == Tier::RayQuery { shaders::VISBUFFER_SHADE_FRAG_RAY_QUERY_DECALS } else { shaders::VISBUFFER_SHADE_FRAG };
        Ok(Self {
            ids_opaque: create_graphics(ctx, layout, &ids)?,
            ids_mask: create_graphics(ctx, layout, &GraphicsDesc { fragment: Some(shaders::VISBUFFER_FRAG_ALPHA_MASK), ..ids })?,
            shade: create_graphics(ctx, layout, &GraphicsDesc::fullscreen("visibility shading", shade_fs, &hdr))?,
        })
    }

    /// Writes depth and the instance/triangle ids.
    pub fn visibility(&self, f: &mut Frame, scene: &GpuScene, draws: &[Option<DrawItem>]) -> Result<(), RenderError> {
        f.pass("visibility", PassKind::Graphics)
            .image(&DEPTH, ImageUse::DepthWrite(Load::ClearDepth(0.0)))
            .color(&VISIBILITY, Load::Clear([0.0; 4]))
            .reads(scene.res.drawn())
            .record(|p| {
                let push = p.push;
                p.bind_graphics(self.ids_opaque, &push);
                scene.draw_meshes(p, draws, |d| !d.alpha_mask);
                p.bind_graphics(self.ids_mask, &push);
                scene.draw_meshes(p, draws, |d| d.alpha_mask);
            })
    }

    /// Rebuilds and shades every covered pixel into the HDR target; ray-query decals from
    /// `decals` (the decal TLAS and BLAS) when given.
    pub fn shade(&self, f: &mut Frame, scene: &GpuScene, clear: [f32; 4], decals: Option<[ResourceId; 2]>) -> Result<(), RenderError> {
        f.pass("visbuffer_shade", PassKind::Graphics)
            .sample(&DEPTH)
            .sample(&VISIBILITY)
            .color(&HDR, Load::Clear(clear))
            .reads(scene.res.shaded())
            .read(scene.res.meshes, BufferUse::Storage)
            .reads(decals.into_iter().flatten().map(|a| (a, BufferUse::Accel)))
            .record(|p| {
                let push = p.push;
                p.fullscreen(self.shade, &push);
            })
    }

    /// Destroys the pipelines; the GPU must be idle.
    pub fn destroy(self, ctx: &GpuContext) {
        for p in [self.ids_opaque, self.ids_mask, self.shade] {
            // SAFETY: the GPU is idle.
            unsafe { ctx.device.destroy_pipeline(p, None) };
        }
    }
}
