//! The forward pipeline: a reverse-Z depth prepass (seed 001 §4.1; alpha test only for masked
//! materials) and a shading pass that tests depth EQUAL, so each pixel is shaded once: decals
//! (found by a zero-length ray query in the shader, seed 000 §4.2.2; read from the decal buffer
//! a decal pass wrote, [`crate::decals::buffer`]; or, for clustered decals with
//! [`crate::settings::FrameSettings::decals_in_forward_shading`], found by walking the pixel's
//! cluster list in the shader, [`crate::decals::clustered`]) are blended into the surface
//! attributes, then every light is applied with the Frostbite BRDF of seed 000 §2.3. Decal
//! passes run before shading, from the prepass's ids where a decal must know the pixel's
//! instance (receiver layers of its own, decals on a skin) or the ids are written anyway, and
//! from depth alone otherwise (`crate::decals::Surface`); the in-shader methods need
//! a depth-only prepass.

use ash::vk;

use crate::RenderError;
use crate::culling::{Draws, Phase};
use crate::decals::{DecalFrame, declare_decal_reads};
use crate::gpu::device::GpuContext;
use crate::gpu::pipeline::{GraphicsDesc, ShadeVariants, Specialization, create_graphics, create_graphics_specialized};
use crate::gpu::shaders;
use crate::graph::targets::Surface;
use crate::graph::targets::{
    DEPTH, DEPTH_FORMAT, DEPTH_MS, HDR, HDR_FORMAT, HDR_MS, REFLECTION_ADDED, TargetDesc, VISIBILITY, VISIBILITY_FORMAT, VISIBILITY_MS,
};
use crate::graph::{Frame, ImageUse, Load, PassKind};
use crate::lights::{LightFrame, declare_light_reads};
use crate::scene::gpu::GpuScene;

/// Pipelines of the forward renderer, at one count of samples a pixel: 1, or MSAA's
/// ([`crate::msaa`], which keeps a second set).
pub struct ForwardPasses {
    samples: u32,
    prepass_opaque: vk::Pipeline,
    prepass_mask: vk::Pipeline,
    /// The prepass that also writes instance and triangle ids (`shaders/visbuffer.frag`).
    ids_opaque: vk::Pipeline,
    ids_mask: vk::Pipeline,
    shade: ShadeVariants,
    /// Under MSAA, the shading that also adds the reflections resolved before it, per sample.
    shade_reflected: Option<ShadeVariants>,
}

impl ForwardPasses {
    /// Creates the pipelines for attachments of `samples` samples a pixel.
    pub fn new(ctx: &GpuContext, layout: vk::PipelineLayout, samples: u32) -> Result<Self, RenderError> {
        let prepass = GraphicsDesc { samples, ..GraphicsDesc::mesh("prepass", None, &[], DEPTH_FORMAT) };
        let ids_formats = [VISIBILITY_FORMAT];
        let ids = GraphicsDesc { samples, ..GraphicsDesc::mesh("prepass ids", Some(shaders::VISBUFFER_FRAG), &ids_formats, DEPTH_FORMAT) };
        let shade = move |ctx: &GpuContext, fragment: &'static [u8], spec: Specialization| {
            let desc = GraphicsDesc {
                name: "forward",
                fragment: Some(fragment),
                color_formats: &[HDR_FORMAT],
                depth_compare: Some(vk::CompareOp::EQUAL),
                depth_write: false,
                ..prepass
            };
            create_graphics_specialized(ctx, layout, &desc, spec)
        };
        let (variants, clustered) = if samples > 1 {
            (
                [shaders::FORWARD_FRAG_MSAA, shaders::FORWARD_FRAG_MSAA_RAY_QUERY_DECALS, shaders::FORWARD_FRAG_MSAA_DECAL_BUFFER],
                shaders::FORWARD_FRAG_MSAA_CLUSTERED_DECALS,
            )
        } else {
            (
                [shaders::FORWARD_FRAG, shaders::FORWARD_FRAG_RAY_QUERY_DECALS, shaders::FORWARD_FRAG_DECAL_BUFFER],
                shaders::FORWARD_FRAG_CLUSTERED_DECALS,
            )
        };
        let shade_reflected = if samples > 1 {
            let variants = [
                shaders::FORWARD_FRAG_MSAA_REFLECTED,
                shaders::FORWARD_FRAG_MSAA_REFLECTED_RAY_QUERY_DECALS,
                shaders::FORWARD_FRAG_MSAA_REFLECTED_DECAL_BUFFER,
            ];
            Some(ShadeVariants::new(ctx, variants, shade).with_clustered(shaders::FORWARD_FRAG_MSAA_REFLECTED_CLUSTERED_DECALS, shade))
        } else {
            None
        };
        Ok(Self {
            samples,
            prepass_opaque: create_graphics(ctx, layout, &prepass)?,
            prepass_mask: create_graphics(ctx, layout, &GraphicsDesc { fragment: Some(shaders::PREPASS_MASK_FRAG), ..prepass })?,
            ids_opaque: create_graphics(ctx, layout, &ids)?,
            ids_mask: create_graphics(ctx, layout, &GraphicsDesc { fragment: Some(shaders::VISBUFFER_FRAG_ALPHA_MASK), ..ids })?,
            shade: ShadeVariants::new(ctx, variants, shade).with_clustered(clustered, shade),
            shade_reflected,
        })
    }

    /// Samples a pixel of the attachments these pipelines draw into.
    pub fn samples(&self) -> u32 {
        self.samples
    }

    /// The depth, radiance and id attachments these pipelines draw into: the frame's targets,
    /// or MSAA's, which resolve into them.
    fn attachments(&self) -> [&'static TargetDesc; 3] {
        if self.samples > 1 { [&DEPTH_MS, &HDR_MS, &VISIBILITY_MS] } else { [&DEPTH, &HDR, &VISIBILITY] }
    }

    /// Depth prepass: writes reverse-Z depth (and, when `ids`, the instance and triangle ids the
    /// reflection rays, motion or a decal pass that must know the instance read) for the instances `draws` holds (one of the
    /// culling's `phase`s); masked materials discard. Under MSAA both resolve to sample 0 (one
    /// surface per pixel for every per-pixel pass that follows). Returns what it wrote.
    pub fn prepass(&self, f: &mut Frame, scene: &GpuScene, draws: &Draws, phase: Phase, ids: bool) -> Result<Surface, RenderError> {
        let ([depth, _, ids_target], ms) = (self.attachments(), self.samples > 1);
        let (opaque, mask) = if ids { (self.ids_opaque, self.ids_mask) } else { (self.prepass_opaque, self.prepass_mask) };
        f.pass("prepass", PassKind::Graphics)
            .image(depth, ImageUse::DepthWrite(phase.depth_load()))
            .when(ms, |p| p.resolve(&DEPTH))
            .when(ids, |p| p.color(ids_target, phase.color_load([0.0; 4])).when(ms, |p| p.resolve(&VISIBILITY)))
            .reads(scene.res.drawn())
            .reads(draws.reads())
            .record(|p| {
                let push = p.push;
                p.bind_graphics(opaque, &push);
                draws.opaque(p);
                p.bind_graphics(mask, &push);
                draws.masked(p);
            })?;
        Ok(if ids { Surface::Visibility } else { Surface::Depth })
    }

    /// Shading: every visible pixel once, lit by every light, into the HDR target (cleared to
    /// `clear`), with this frame's `decals`. Under MSAA it draws into the multisampled target
    /// (each sample its primitive's colour) and resolves it into the HDR target (the mean); a
    /// fragment reads the per-pixel inputs at the pixel of its own surface
    /// (`shaders/include/msaa.glsl`), and, when `reflected`, adds the reflections resolved before
    /// it ([`crate::reflections::Reflections::record_before_shading`]) the same way.
    #[allow(clippy::too_many_arguments)]
    pub fn shade(
        &self,
        f: &mut Frame,
        scene: &GpuScene,
        draws: &Draws,
        clear: [f32; 4],
        decals: &DecalFrame,
        lights: &LightFrame,
        reflected: bool,
    ) -> Result<(), RenderError> {
        let ctx = f.ctx;
        let ([depth, hdr, _], ms) = (self.attachments(), self.samples > 1);
        let variants = self.shade_reflected.as_ref().filter(|_| reflected).unwrap_or(&self.shade);
        let pass = f
            .pass("forward", PassKind::Graphics)
            .image(depth, ImageUse::DepthTest)
            .color(hdr, Load::Clear(clear))
            .when(ms, |p| p.resolve(&HDR).sample(&DEPTH))
            .when(reflected, |p| p.image(&REFLECTION_ADDED, ImageUse::StorageRead))
            .reads(scene.res.drawn())
            .reads(draws.reads());
        let pipeline = variants.pick(ctx, decals.variant(), lights.shading(false))?;
        declare_light_reads(declare_decal_reads(pass, decals), lights).record(|p| {
            let push = p.push;
            p.bind_graphics(pipeline, &push);
            draws.all_opaque(p);
        })
    }

    /// Destroys the pipelines; the GPU must be idle.
    pub fn destroy(self, ctx: &GpuContext) {
        for p in [self.prepass_opaque, self.prepass_mask, self.ids_opaque, self.ids_mask] {
            // SAFETY: the GPU is idle.
            unsafe { ctx.destroying().destroy_pipeline(p, None) };
        }
        self.shade.destroy(ctx);
        if let Some(v) = self.shade_reflected {
            v.destroy(ctx);
        }
    }
}
