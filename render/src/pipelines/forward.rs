//! The forward pipeline: a reverse-Z depth prepass (seed 001 §4.1; alpha test only for masked
//! materials) and a shading pass that tests depth EQUAL, so each pixel is shaded once: decals
//! (found by a zero-length ray query in the shader, seed 000 §4.2.2; read from the decal buffer
//! a decal pass wrote, [`crate::decals::buffer`]; or, for clustered decals with
//! [`crate::settings::FrameSettings::decals_in_forward_shading`], found by walking the pixel's
//! cluster list in the shader, [`crate::decals::clustered`]) are blended into the surface
//! attributes, then every light is applied with the Frostbite BRDF of seed 000 §2.3. Decal
//! passes need the ids prepass (they run before shading, from the visibility ids); the
//! in-shader methods need a depth-only prepass.

use ash::vk;

use crate::RenderError;
use crate::culling::{Draws, Phase};
use crate::decals::{DecalFrame, declare_decal_reads};
use crate::gpu::device::GpuContext;
use crate::gpu::pipeline::{GraphicsDesc, create_graphics};
use crate::gpu::shaders;
use crate::graph::targets::{DEPTH, DEPTH_FORMAT, HDR, HDR_FORMAT};
use crate::graph::{Frame, ImageUse, Load, PassKind};
use crate::lights::{LightFrame, declare_light_reads};
use crate::pipelines::ShadeVariants;
use crate::scene::gpu::GpuScene;

/// Pipelines of the forward renderer.
pub struct ForwardPasses {
    prepass_opaque: vk::Pipeline,
    prepass_mask: vk::Pipeline,
    shade: ShadeVariants,
}

impl ForwardPasses {
    /// Creates the pipelines.
    pub fn new(ctx: &GpuContext, layout: vk::PipelineLayout) -> Result<Self, RenderError> {
        let prepass = GraphicsDesc::mesh("prepass", None, &[], DEPTH_FORMAT);
        let shade = |fragment: &[u8]| {
            let desc = GraphicsDesc {
                name: "forward",
                fragment: Some(fragment),
                color_formats: &[HDR_FORMAT],
                depth_compare: Some(vk::CompareOp::EQUAL),
                depth_write: false,
                ..prepass
            };
            create_graphics(ctx, layout, &desc)
        };
        Ok(Self {
            prepass_opaque: create_graphics(ctx, layout, &prepass)?,
            prepass_mask: create_graphics(ctx, layout, &GraphicsDesc { fragment: Some(shaders::PREPASS_MASK_FRAG), ..prepass })?,
            shade: ShadeVariants::new(
                ctx,
                [shaders::FORWARD_FRAG, shaders::FORWARD_FRAG_RAY_QUERY_DECALS, shaders::FORWARD_FRAG_DECAL_BUFFER],
                shade,
            )?
            .with_clustered(shaders::FORWARD_FRAG_CLUSTERED_DECALS, shade)?,
        })
    }

    /// Depth prepass: writes reverse-Z depth for the instances `draws` holds (one of the
    /// culling's `phase`s); masked materials discard.
    pub fn prepass(&self, f: &mut Frame, scene: &GpuScene, draws: &Draws, phase: Phase) -> Result<(), RenderError> {
        f.pass("prepass", PassKind::Graphics)
            .image(&DEPTH, ImageUse::DepthWrite(phase.depth_load()))
            .reads(scene.res.drawn())
            .reads(draws.reads())
            .record(|p| {
                let push = p.push;
                p.bind_graphics(self.prepass_opaque, &push);
                draws.opaque(p);
                p.bind_graphics(self.prepass_mask, &push);
                draws.masked(p);
            })
    }

    /// Shading: every visible pixel once, lit by every light, into the HDR target, with this
    /// frame's `decals`.
    pub fn shade(
        &self,
        f: &mut Frame,
        scene: &GpuScene,
        draws: &Draws,
        clear: [f32; 4],
        decals: &DecalFrame,
        lights: &LightFrame,
    ) -> Result<(), RenderError> {
        let pass = f
            .pass("forward", PassKind::Graphics)
            .image(&DEPTH, ImageUse::DepthTest)
            .color(&HDR, Load::Clear(clear))
            .reads(scene.res.drawn())
            .reads(draws.reads());
        declare_light_reads(declare_decal_reads(pass, decals), lights).record(|p| {
            let push = p.push;
            p.bind_graphics(self.shade.pick(decals), &push);
            draws.all_opaque(p);
        })
    }

    /// Destroys the pipelines; the GPU must be idle.
    pub fn destroy(self, ctx: &GpuContext) {
        for p in [self.prepass_opaque, self.prepass_mask] {
            // SAFETY: the GPU is idle.
            unsafe { ctx.device.destroy_pipeline(p, None) };
        }
        self.shade.destroy(ctx);
    }
}
