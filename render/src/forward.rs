//! The forward pipeline: a reverse-Z depth prepass (seed 001 §4.1; alpha test only for masked
//! materials) and a shading pass that tests depth EQUAL, so each pixel is shaded once: decals
//! found by a zero-length ray query (seed 000 §4.2.2) are blended into the surface attributes,
//! then every light is applied with the Frostbite BRDF of seed 000 §2.3.

use ash::vk;

use crate::RenderError;
use crate::device::{GpuContext, Tier};
use crate::gpu_scene::GpuScene;
use crate::pass::{PassContext, color_attachment, depth_attachment};
use crate::pipeline::{GraphicsDesc, create_graphics};
use crate::scene::DrawItem;
use crate::shaders;
use crate::sync::Access;
use crate::targets::{HDR_FORMAT, Targets};

/// Pipelines of the forward renderer.
pub struct ForwardPasses {
    prepass_opaque: vk::Pipeline,
    prepass_mask: vk::Pipeline,
    shade: vk::Pipeline,
}

impl ForwardPasses {
    /// Creates the pipelines.
    pub fn new(ctx: &GpuContext, layout: vk::PipelineLayout) -> Result<Self, RenderError> {
        let prepass = GraphicsDesc::mesh("prepass", None, &[]);
        Ok(Self {
            prepass_opaque: create_graphics(ctx, layout, &prepass)?,
            prepass_mask: create_graphics(ctx, layout, &GraphicsDesc { fragment: Some(shaders::PREPASS_MASK_FRAG), ..prepass })?,
            shade: create_graphics(
                ctx,
                layout,
                &GraphicsDesc {
                    name: "forward",
                    // Ray-query decals need the ray query tier; SPIR-V using ray queries cannot
                    // even be loaded on other devices.
                    fragment: Some(if ctx.tier == Tier::RayQuery { shaders::FORWARD_FRAG_RAY_QUERY_DECALS } else { shaders::FORWARD_FRAG }),
                    color_formats: &[HDR_FORMAT],
                    depth_compare: Some(vk::CompareOp::EQUAL),
                    depth_write: false,
                    ..prepass
                },
            )?,
        })
    }

    /// Depth prepass: writes reverse-Z depth for every instance; masked materials discard.
    pub fn prepass(&self, p: &mut PassContext, targets: &mut Targets, scene: &GpuScene, draws: &[Option<DrawItem>]) {
        p.timed("prepass", |p| {
            targets.depth.overwrite_as(p.ctx, p.cmd, Access::DepthAttachmentWrite);
            let depth = depth_attachment(targets.depth.image.view, Access::DepthAttachmentWrite.layout(), Some(0.0));
            p.begin_rendering(targets.extent, &[], Some(&depth));
            let push = p.push;
            p.bind_graphics(self.prepass_opaque, &push);
            p.draw_meshes(scene, draws, |d| !d.alpha_mask);
            p.bind_graphics(self.prepass_mask, &push);
            p.draw_meshes(scene, draws, |d| d.alpha_mask);
            p.end_rendering();
        });
    }

    /// Shading: every visible pixel once, lit by every light, into the HDR target.
    pub fn shade(&self, p: &mut PassContext, targets: &mut Targets, scene: &GpuScene, draws: &[Option<DrawItem>], clear: [f32; 4]) {
        p.timed("forward", |p| {
            targets.depth.use_as(p.ctx, p.cmd, Access::DepthAttachmentRead);
            targets.hdr.overwrite_as(p.ctx, p.cmd, Access::ColorAttachmentWrite);
            let color = [color_attachment(targets.hdr.image.view, Some(clear))];
            let depth = depth_attachment(targets.depth.image.view, Access::DepthAttachmentRead.layout(), None);
            p.begin_rendering(targets.extent, &color, Some(&depth));
            let push = p.push;
            p.bind_graphics(self.shade, &push);
            p.draw_meshes(scene, draws, |_| true);
            p.end_rendering();
        });
    }

    /// Destroys the pipelines; the GPU must be idle.
    pub fn destroy(self, ctx: &GpuContext) {
        for p in [self.prepass_opaque, self.prepass_mask, self.shade] {
            // SAFETY: the GPU is idle.
            unsafe { ctx.device.destroy_pipeline(p, None) };
        }
    }
}
