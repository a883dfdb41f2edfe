//! Visibility-buffer deferred texturing (seed 000 §3.4.1, §5.1.3): a pass writes only instance
//! and triangle ids (alpha-tested for masked materials, which the seed's renderer got wrong),
//! then one full-screen pass rebuilds each pixel's surface by intersecting its camera ray with
//! its triangle, with analytic attribute derivatives for texture filtering (the fix for the
//! seed's 2×2-quad derivative bug; see `shaders/include/visibility.glsl`), and shades it. That
//! pass runs in compute by default (see [`super::deferred`] on why), or as a full-screen fragment
//! pass.

use ash::vk;

use crate::RenderError;
use crate::culling::{Draws, Phase};
use crate::decals::{DecalFrame, declare_decal_reads};
use crate::gpu::device::GpuContext;
use crate::gpu::pipeline::{GraphicsDesc, create_compute_specialized, create_graphics, create_graphics_specialized};
use crate::gpu::shaders;
use crate::graph::targets::Surface;
use crate::graph::targets::{DEPTH, DEPTH_FORMAT, HDR, HDR_FORMAT, VISIBILITY, VISIBILITY_FORMAT};
use crate::graph::{BufferUse, Frame, ImageUse, Load, PassKind};
use crate::lights::{LightFrame, declare_light_reads};
use crate::pipelines::{RayLightShading, Shade, ShadeVariants};
use crate::scene::gpu::GpuScene;
use crate::settings::LightMethod;

/// Pipelines of the visibility-buffer renderer.
pub struct VisBufferPasses {
    ids_opaque: vk::Pipeline,
    ids_mask: vk::Pipeline,
    shade: ShadeVariants,
    shade_compute: ShadeVariants,
    /// With ray-query lights.
    shade_rays: RayLightShading,
}

impl VisBufferPasses {
    /// Creates the pipelines.
    pub fn new(ctx: &GpuContext, layout: vk::PipelineLayout) -> Result<Self, RenderError> {
        let formats = [VISIBILITY_FORMAT];
        let ids = GraphicsDesc::mesh("visibility", Some(shaders::VISBUFFER_FRAG), &formats, DEPTH_FORMAT);
        Ok(Self {
            ids_opaque: create_graphics(ctx, layout, &ids)?,
            ids_mask: create_graphics(ctx, layout, &GraphicsDesc { fragment: Some(shaders::VISBUFFER_FRAG_ALPHA_MASK), ..ids })?,
            shade: ShadeVariants::new(
                ctx,
                [shaders::VISBUFFER_SHADE_FRAG, shaders::VISBUFFER_SHADE_FRAG_RAY_QUERY_DECALS, shaders::VISBUFFER_SHADE_FRAG_DECAL_BUFFER],
                move |ctx, fragment, spec| {
                    create_graphics_specialized(ctx, layout, &GraphicsDesc::fullscreen("visibility shading", fragment, &[HDR_FORMAT]), spec)
                },
            ),
            shade_compute: ShadeVariants::new(
                ctx,
                [shaders::VISBUFFER_SHADE_COMP, shaders::VISBUFFER_SHADE_COMP_RAY_QUERY_DECALS, shaders::VISBUFFER_SHADE_COMP_DECAL_BUFFER],
                move |ctx, spirv, spec| create_compute_specialized(ctx, layout, "visibility shading (compute)", spirv, spec),
            ),
            shade_rays: RayLightShading::new(
                ctx,
                layout,
                "visibility shading (ray-query lights)",
                [
                    shaders::VISBUFFER_SHADE_COMP_RAY_QUERY_LIGHTS,
                    shaders::VISBUFFER_SHADE_COMP_RAY_QUERY_LIGHTS_RAY_QUERY_DECALS,
                    shaders::VISBUFFER_SHADE_COMP_RAY_QUERY_LIGHTS_DECAL_BUFFER,
                ],
                [shaders::VISBUFFER_SHADE_RGEN, shaders::VISBUFFER_SHADE_RGEN_DECAL_BUFFER],
                [shaders::VISBUFFER_SHADE_RGEN_SAMPLED_LIGHTS, shaders::VISBUFFER_SHADE_RGEN_SAMPLED_LIGHTS_DECAL_BUFFER],
            ),
        })
    }

    /// Writes depth and the instance/triangle ids of the instances `draws` holds (one of the
    /// culling's `phase`s). Returns what it wrote.
    pub fn visibility(&self, f: &mut Frame, scene: &GpuScene, draws: &Draws, phase: Phase) -> Result<Surface, RenderError> {
        f.pass("visibility", PassKind::Graphics)
            .image(&DEPTH, ImageUse::DepthWrite(phase.depth_load()))
            .color(&VISIBILITY, phase.color_load([0.0; 4]))
            .reads(scene.res.drawn())
            .reads(draws.reads())
            .record(|p| {
                let push = p.push;
                p.bind_graphics(self.ids_opaque, &push);
                draws.opaque(p);
                p.bind_graphics(self.ids_mask, &push);
                draws.masked(p);
            })?;
        Ok(Surface::Visibility)
    }

    /// Rebuilds and shades every covered pixel into the HDR target, with this frame's `decals`
    /// and `lights`: when `compute`, a compute pass that stores every pixel (the clear colour,
    /// from the lighting record, where no geometry is: a clearing render pass alone cost 0.3 ms
    /// at 1080p on the lent H100); else one full-screen fragment pass clearing to `clear`.
    /// Ray-query lights always store through the storage image, from a compute pass with ray
    /// queries or a ray-generation pass ([`RayLightShading`]).
    pub fn shade(
        &self,
        f: &mut Frame,
        scene: &GpuScene,
        clear: [f32; 4],
        decals: &DecalFrame,
        lights: &LightFrame,
        compute: bool,
    ) -> Result<(), RenderError> {
        let ctx = f.ctx;
        let rays = if lights.method == LightMethod::RayQuery { self.shade_rays.kind() } else { None };
        let kind = rays.unwrap_or(if compute { PassKind::Compute } else { PassKind::Graphics });
        let pass = f
            .pass("visbuffer_shade", kind)
            .sample(&DEPTH)
            .sample(&VISIBILITY)
            .reads(scene.res.shaded())
            .read(scene.res.meshes, BufferUse::Storage);
        let pass = if kind == PassKind::Graphics { pass.color(&HDR, Load::Clear(clear)) } else { pass.image(&HDR, ImageUse::StorageWrite) };
        let shade = match rays {
            Some(_) => Shade::Rays(self.shade_rays.pick(ctx, decals, lights)?),
            None if compute => Shade::Compute(self.shade_compute.pick(ctx, decals.variant(), lights.shading(true))?),
            None => Shade::Fullscreen(self.shade.pick(ctx, decals.variant(), lights.shading(false))?),
        };
        declare_light_reads(declare_decal_reads(pass, decals), lights).record(|p| shade.run(p, decals))
    }

    /// Destroys the pipelines; the GPU must be idle.
    pub fn destroy(self, ctx: &GpuContext) {
        for p in [self.ids_opaque, self.ids_mask] {
            // SAFETY: the GPU is idle.
            unsafe { ctx.destroying().destroy_pipeline(p, None) };
        }
        self.shade.destroy(ctx);
        self.shade_compute.destroy(ctx);
        self.shade_rays.destroy(ctx);
    }
}
