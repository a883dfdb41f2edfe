//! Visibility-buffer deferred texturing (seed 000 §3.4.1, §5.1.3): a pass writes only instance
//! and triangle ids (alpha-tested for masked materials, which the seed's renderer got wrong),
//! then one full-screen pass rebuilds each pixel's surface by intersecting its camera ray with
//! its triangle, with analytic attribute derivatives for texture filtering (the fix for the
//! seed's 2×2-quad derivative bug; see `shaders/visbuffer_shade.frag`), and shades it.

use ash::vk;

use crate::RenderError;
use crate::device::{GpuContext, Tier};
use crate::gpu_scene::GpuScene;
use crate::pass::{PassContext, color_attachment, depth_attachment};
use crate::pipeline::{GraphicsDesc, create_graphics};
use crate::scene::DrawItem;
use crate::shaders;
use crate::sync::Access;
use crate::targets::{HDR_FORMAT, Targets, VISIBILITY_FORMAT};

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
        let ids = GraphicsDesc::mesh("visibility", Some(shaders::VISBUFFER_FRAG), &formats);
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
    pub fn visibility(&self, p: &mut PassContext, targets: &mut Targets, scene: &GpuScene, draws: &[Option<DrawItem>]) {
        let Targets { extent, depth, visibility, .. } = targets;
        let ids = visibility.as_mut().expect("created by the renderer before recording");
        p.timed("visibility", |p| {
            depth.overwrite_as(p.ctx, p.cmd, Access::DepthAttachmentWrite);
            ids.overwrite_as(p.ctx, p.cmd, Access::ColorAttachmentWrite);
            let colors = [color_attachment(ids.image.view, Some([0.0; 4]))];
            let depth_info = depth_attachment(depth.image.view, Access::DepthAttachmentWrite.layout(), Some(0.0));
            p.begin_rendering(*extent, &colors, Some(&depth_info));
            let push = p.push;
            p.bind_graphics(self.ids_opaque, &push);
            p.draw_meshes(scene, draws, |d| !d.alpha_mask);
            p.bind_graphics(self.ids_mask, &push);
            p.draw_meshes(scene, draws, |d| d.alpha_mask);
            p.end_rendering();
        });
    }

    /// Rebuilds and shades every covered pixel into the HDR target.
    pub fn shade(&self, p: &mut PassContext, targets: &mut Targets, clear: [f32; 4]) {
        let Targets { extent, hdr, depth, visibility, .. } = targets;
        let ids = visibility.as_mut().expect("created by the renderer before recording");
        p.timed("visbuffer_shade", |p| {
            depth.use_as(p.ctx, p.cmd, Access::DepthSampled);
            ids.use_as(p.ctx, p.cmd, Access::FragmentSampled);
            hdr.overwrite_as(p.ctx, p.cmd, Access::ColorAttachmentWrite);
            let colors = [color_attachment(hdr.image.view, Some(clear))];
            p.begin_rendering(*extent, &colors, None);
            let push = p.push;
            p.bind_graphics(self.shade, &push);
            // SAFETY: `cmd` is recording inside the rendering scope with the pipeline bound.
            unsafe { p.ctx.device.cmd_draw(p.cmd, 3, 1, 0, 0) };
            p.end_rendering();
        });
    }

    /// Destroys the pipelines; the GPU must be idle.
    pub fn destroy(self, ctx: &GpuContext) {
        for p in [self.ids_opaque, self.ids_mask, self.shade] {
            // SAFETY: the GPU is idle.
            unsafe { ctx.device.destroy_pipeline(p, None) };
        }
    }
}
