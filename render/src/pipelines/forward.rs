//! The forward pipeline: a reverse-Z depth prepass (seed 001 §4.1; alpha test only for masked
//! materials) and a shading pass that tests depth EQUAL, so each pixel is shaded once: decals
//! found by a zero-length ray query (seed 000 §4.2.2) are blended into the surface attributes,
//! then every light is applied with the Frostbite BRDF of seed 000 §2.3.

use ash::vk;

use crate::RenderError;
use crate::gpu::device::{GpuContext, Tier};
use crate::gpu::pipeline::{GraphicsDesc, create_graphics};
use crate::gpu::shaders;
use crate::graph::targets::{DEPTH, DEPTH_FORMAT, HDR, HDR_FORMAT};
use crate::graph::{BufferUse, Frame, ImageUse, Load, PassKind, ResourceId};
use crate::scene::DrawItem;
use crate::scene::gpu::GpuScene;

/// Pipelines of the forward renderer.
pub struct ForwardPasses {
    prepass_opaque: vk::Pipeline,
    prepass_mask: vk::Pipeline,
    shade: vk::Pipeline,
}

impl ForwardPasses {
    /// Creates the pipelines.
    pub fn new(ctx: &GpuContext, layout: vk::PipelineLayout) -> Result<Self, RenderError> {
        let prepass = GraphicsDesc::mesh("prepass", None, &[], DEPTH_FORMAT);
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
    pub fn prepass(&self, f: &mut Frame, scene: &GpuScene, draws: &[Option<DrawItem>]) -> Result<(), RenderError> {
        f.pass("prepass", PassKind::Graphics).image(&DEPTH, ImageUse::DepthWrite(Load::ClearDepth(0.0))).reads(scene.res.drawn()).record(
            |p| {
                let push = p.push;
                p.bind_graphics(self.prepass_opaque, &push);
                scene.draw_meshes(p, draws, |d| !d.alpha_mask);
                p.bind_graphics(self.prepass_mask, &push);
                scene.draw_meshes(p, draws, |d| d.alpha_mask);
            },
        )
    }

    /// Shading: every visible pixel once, lit by every light, into the HDR target; ray-query
    /// decals from `decals` (the decal TLAS and BLAS) when given.
    pub fn shade(
        &self,
        f: &mut Frame,
        scene: &GpuScene,
        draws: &[Option<DrawItem>],
        clear: [f32; 4],
        decals: Option<[ResourceId; 2]>,
    ) -> Result<(), RenderError> {
        f.pass("forward", PassKind::Graphics)
            .image(&DEPTH, ImageUse::DepthTest)
            .color(&HDR, Load::Clear(clear))
            .reads(scene.res.drawn())
            .reads(decals.into_iter().flatten().map(|a| (a, BufferUse::Accel)))
            .record(|p| {
                let push = p.push;
                p.bind_graphics(self.shade, &push);
                scene.draw_meshes(p, draws, |_| true);
            })
    }

    /// Destroys the pipelines; the GPU must be idle.
    pub fn destroy(self, ctx: &GpuContext) {
        for p in [self.prepass_opaque, self.prepass_mask, self.shade] {
            // SAFETY: the GPU is idle.
            unsafe { ctx.device.destroy_pipeline(p, None) };
        }
    }
}
