//! Deferred shading (seed 000 §2.6, §5.1.2): a geometry pass writes material attributes into the
//! G-buffer, optional deferred decals (§3.2, §5.1.2.1) alpha-blend into it, and one lighting pass
//! applies decals and the pixel's lights (its tile's after culling) with their shadows. The
//! lighting runs in compute by default, adding to the HDR target through a storage binding: on
//! the lent H100 the same shading as a full-screen fragment pass took 4.6 ms against 0.17 ms
//! (docs/experiments/lights-compute-lighting.md); the fragment pass remains, selectable, and gives the same image.
//!
//! Decal normals: the seed transformed deferred decals' normals with the decal's
//! inverse-transpose and notes that this is wrong when the decal is oriented unlike the surface.
//! Instead of storing a compressed tangent frame in the G-buffer to fix that, we build the frame
//! the decal's normal map is read in from the decal's own axes projected onto the surface normal
//! (`shaders/include/decals.glsl`), which is right for any orientation and needs only the normal
//! the G-buffer already holds: the fix costs no G-buffer bytes. (Ray-query decals in the lighting
//! pass use the normal-mapped G-buffer normal; deferred decals, which cannot read the normal
//! target while blending into it, use the geometric normal reconstructed from depth.)
//!
//! The G-buffer's formats and the reasons for them are in `shaders/gbuffer.frag` (11 bytes a
//! pixel beside depth and the HDR target). Deferred
//! decals are drawn in channel-then-weight order as runs of instanced boxes; each run shares the
//! decal material's set of attributes, which selects one of 16 pipelines whose write masks touch
//! only those attributes. Emissive decals add their light to the HDR target, which holds the
//! surfaces' emission until the lighting pass adds to it.

use ash::vk;

use crate::RenderError;
use crate::culling::{Draws, Phase};
use crate::decals::{DecalFrame, DecalRun, DeferredRing, declare_decal_reads};
use crate::gpu::device::GpuContext;
use crate::gpu::pipeline::{Blend, GraphicsDesc, ScenePush, create_compute_specialized, create_graphics, create_graphics_specialized};
use crate::gpu::shaders;
use crate::graph::targets::Surface;
use crate::graph::targets::{
    DEPTH, DEPTH_FORMAT, GBUFFER_ALBEDO, GBUFFER_ALBEDO_FORMAT, GBUFFER_LAYERS, GBUFFER_LAYERS_FORMAT, GBUFFER_MATERIAL,
    GBUFFER_MATERIAL_FORMAT, GBUFFER_NORMAL, GBUFFER_NORMAL_FORMAT, HDR, HDR_FORMAT,
};
use crate::graph::{BufferUse, Frame, ImageUse, Load, PassKind};
use crate::layout::DECAL_RING_DRAW;
use crate::lights::{LightFrame, declare_light_reads};
use crate::pipelines::{RayLightShading, Shade, ShadeVariants};
use crate::scene::gpu::GpuScene;
use crate::scene::{DECAL_ALBEDO, DECAL_METALLIC, DECAL_NORMAL, DECAL_ROUGHNESS};
use crate::settings::LightMethod;

/// Pipelines of the deferred renderer.
pub struct DeferredPasses {
    gbuffer_opaque: vk::Pipeline,
    gbuffer_mask: vk::Pipeline,
    /// Blended surfaces on odd rows (`crate::transparency::interlaced`).
    gbuffer_interlaced: vk::Pipeline,
    /// Blended surfaces on every row (`crate::transparency::peeling`).
    gbuffer_glass: vk::Pipeline,
    lighting: ShadeVariants,
    lighting_compute: ShadeVariants,
    /// With ray-query lights.
    lighting_rays: RayLightShading,
    /// Indexed by `DECAL_*` flags (0..16).
    decals: Vec<vk::Pipeline>,
}

/// The blended surfaces a G-buffer holds besides the opaque ones, and how.
#[derive(Clone, Copy, Debug)]
pub enum GBufferGlass<'a> {
    /// None.
    None,
    /// These instances (slots) on odd rows: interlaced transparency
    /// (`crate::transparency::interlaced`).
    Interlaced(&'a [u32]),
    /// These instances on every row, with their opacity: depth peeling's nearest layer
    /// (`crate::transparency::peeling`).
    Full(&'a [u32]),
}

const GBUFFER_FORMATS: [vk::Format; 5] =
    [GBUFFER_ALBEDO_FORMAT, GBUFFER_NORMAL_FORMAT, GBUFFER_MATERIAL_FORMAT, GBUFFER_LAYERS_FORMAT, HDR_FORMAT];

impl DeferredPasses {
    /// Creates the pipelines.
    pub fn new(ctx: &GpuContext, layout: vk::PipelineLayout) -> Result<Self, RenderError> {
        let geometry = GraphicsDesc::mesh("gbuffer", Some(shaders::GBUFFER_FRAG), &GBUFFER_FORMATS, DEPTH_FORMAT);
        let decal_formats = [GBUFFER_ALBEDO_FORMAT, GBUFFER_NORMAL_FORMAT, GBUFFER_MATERIAL_FORMAT, HDR_FORMAT];
        let mut decals = Vec::with_capacity(16);
        for flags in 0..16u32 {
            use vk::ColorComponentFlags as C;
            let rgb = C::R | C::G | C::B;
            let masks = [
                if flags & DECAL_ALBEDO != 0 { rgb } else { C::empty() },
                if flags & DECAL_NORMAL != 0 { rgb } else { C::empty() },
                (if flags & DECAL_ROUGHNESS != 0 { C::R } else { C::empty() })
                    | (if flags & DECAL_METALLIC != 0 { C::G } else { C::empty() }),
                // Emission adds: a decal without it adds zero, so it needs no variants.
                rgb,
            ];
            decals.push(create_graphics(
                ctx,
                layout,
                &GraphicsDesc {
                    name: "deferred decals",
                    vertex: shaders::DECAL_BOX_VERT,
                    fragment: Some(shaders::DEFERRED_DECAL_FRAG),
                    mesh_vertices: false,
                    color_formats: &decal_formats,
                    // Front faces tested against the scene's depth (read-only): boxes hidden
                    // behind other geometry cost nothing. Boxes the camera is inside are drawn
                    // inside-out at the near plane instead (shaders/decal_box.vert).
                    depth_format: Some(DEPTH_FORMAT),
                    depth_compare: Some(vk::CompareOp::GREATER_OR_EQUAL),
                    depth_write: false,
                    topology: vk::PrimitiveTopology::TRIANGLE_LIST,
                    blend: Blend::AlphaThenAdditive,
                    write_masks: &masks,
                    samples: 1,
                },
            )?);
        }
        Ok(Self {
            gbuffer_opaque: create_graphics(ctx, layout, &geometry)?,
            gbuffer_mask: create_graphics(ctx, layout, &GraphicsDesc { fragment: Some(shaders::GBUFFER_FRAG_ALPHA_MASK), ..geometry })?,
            gbuffer_interlaced: create_graphics(
                ctx,
                layout,
                &GraphicsDesc { fragment: Some(shaders::GBUFFER_FRAG_INTERLACED), ..geometry },
            )?,
            gbuffer_glass: create_graphics(ctx, layout, &GraphicsDesc { fragment: Some(shaders::GBUFFER_FRAG_GLASS), ..geometry })?,
            lighting: ShadeVariants::new(
                ctx,
                [
                    shaders::DEFERRED_LIGHTING_FRAG,
                    shaders::DEFERRED_LIGHTING_FRAG_RAY_QUERY_DECALS,
                    shaders::DEFERRED_LIGHTING_FRAG_DECAL_BUFFER,
                ],
                move |ctx, fragment, spec| {
                    let desc = GraphicsDesc::fullscreen("deferred lighting", fragment, &[HDR_FORMAT]);
                    create_graphics_specialized(ctx, layout, &GraphicsDesc { blend: Blend::Additive, ..desc }, spec)
                },
            ),
            lighting_compute: ShadeVariants::new(
                ctx,
                [
                    shaders::DEFERRED_LIGHTING_COMP,
                    shaders::DEFERRED_LIGHTING_COMP_RAY_QUERY_DECALS,
                    shaders::DEFERRED_LIGHTING_COMP_DECAL_BUFFER,
                ],
                move |ctx, spirv, spec| create_compute_specialized(ctx, layout, "deferred lighting (compute)", spirv, spec),
            ),
            lighting_rays: RayLightShading::new(
                ctx,
                layout,
                "deferred lighting (ray-query lights)",
                [
                    shaders::DEFERRED_LIGHTING_COMP_RAY_QUERY_LIGHTS,
                    shaders::DEFERRED_LIGHTING_COMP_RAY_QUERY_LIGHTS_RAY_QUERY_DECALS,
                    shaders::DEFERRED_LIGHTING_COMP_RAY_QUERY_LIGHTS_DECAL_BUFFER,
                ],
                [shaders::DEFERRED_LIGHTING_RGEN, shaders::DEFERRED_LIGHTING_RGEN_DECAL_BUFFER],
                [shaders::DEFERRED_LIGHTING_RGEN_SAMPLED_LIGHTS, shaders::DEFERRED_LIGHTING_RGEN_SAMPLED_LIGHTS_DECAL_BUFFER],
            ),
            decals,
        })
    }

    /// Geometry pass: depth and every attribute of the instances `draws` holds (one of the
    /// culling's `phase`s), emitted radiance into the HDR target; then, in the last phase, the
    /// blended instances `glass` names, with their opacity and refraction. Returns what it wrote:
    /// the G-buffer.
    pub fn geometry(
        &self,
        f: &mut Frame,
        scene: &GpuScene,
        draws: &Draws,
        glass: GBufferGlass,
        clear: [f32; 4],
        phase: Phase,
    ) -> Result<Surface, RenderError> {
        f.pass("gbuffer", PassKind::Graphics)
            .image(&DEPTH, ImageUse::DepthWrite(phase.depth_load()))
            .color(&GBUFFER_ALBEDO, phase.color_load([0.0; 4]))
            .color(&GBUFFER_NORMAL, phase.color_load([0.5, 0.5, 1.0, 1.0]))
            .color(&GBUFFER_MATERIAL, phase.color_load([0.0, 0.0, 1.0, 0.0]))
            .color(&GBUFFER_LAYERS, phase.color_load([0.0; 4]))
            .color(&HDR, phase.color_load(clear))
            .reads(scene.res.drawn())
            .reads(draws.reads())
            .record(|p| {
                let push = p.push;
                p.bind_graphics(self.gbuffer_opaque, &push);
                draws.opaque(p);
                p.bind_graphics(self.gbuffer_mask, &push);
                draws.masked(p);
                let (pipeline, order) = match glass {
                    GBufferGlass::None => return,
                    GBufferGlass::Interlaced(order) => (self.gbuffer_interlaced, order),
                    GBufferGlass::Full(order) => (self.gbuffer_glass, order),
                };
                if phase.last && !order.is_empty() {
                    p.bind_graphics(pipeline, &push);
                    draws.glass(p);
                }
            })?;
        Ok(Surface::GBuffer)
    }

    /// Deferred decals: the boxes of `runs`, then those of the particles' decal `ring` (a draw
    /// of all its places for each attribute set its materials have, each place's vertices
    /// collapsed unless its decal has that set), blended into the G-buffer.
    pub fn decals(&self, f: &mut Frame, scene: &GpuScene, runs: &[DecalRun], ring: Option<DeferredRing>) -> Result<(), RenderError> {
        if runs.is_empty() && ring.is_none() {
            return Ok(());
        }
        f.pass("deferred_decals", PassKind::Graphics)
            .image(&DEPTH, ImageUse::DepthTestSampled)
            .sample(&GBUFFER_LAYERS)
            .color(&GBUFFER_ALBEDO, Load::Keep)
            .color(&GBUFFER_NORMAL, Load::Keep)
            .color(&GBUFFER_MATERIAL, Load::Keep)
            .color(&HDR, Load::Keep)
            .reads(scene.res.shaded())
            .reads(ring.map(|r| (r.res, BufferUse::Storage)))
            .record(|p| {
                let push = p.push;
                for run in runs {
                    p.bind_graphics(self.decals[(run.flags & 15) as usize], &push);
                    // The draw order table holds `first + count` entries.
                    p.cmd.set_cull_mode(vk::CullModeFlags::BACK);
                    p.cmd.draw(36, run.count, 0, run.first);
                }
                let Some(ring) = ring else { return };
                for flags in (0..16u32).filter(|f| ring.flags & (1 << f) != 0) {
                    p.bind_graphics(self.decals[flags as usize], &ScenePush { texture_index: DECAL_RING_DRAW | flags, ..push });
                    p.cmd.set_cull_mode(vk::CullModeFlags::BACK);
                    p.cmd.draw(36, ring.room, 0, 0);
                }
            })
    }

    /// Lighting: one pass over the G-buffer, added to the emitted radiance, with this frame's
    /// `decals` (in-shader ray queries or the decal buffer) and `lights`: a compute pass adding
    /// through a storage image when `compute`, else a full-screen fragment pass blending
    /// additively. Ray-query lights always add through the storage image, from a compute pass
    /// with ray queries or a ray-generation pass ([`RayLightShading`]).
    pub fn lighting(
        &self,
        f: &mut Frame,
        scene: &GpuScene,
        decals: &DecalFrame,
        lights: &LightFrame,
        compute: bool,
    ) -> Result<(), RenderError> {
        let ctx = f.ctx;
        let rays = if lights.method == LightMethod::RayQuery { self.lighting_rays.kind() } else { None };
        let kind = rays.unwrap_or(if compute { PassKind::Compute } else { PassKind::Graphics });
        let pass = f
            .pass("lighting", kind)
            .sample(&DEPTH)
            .sample(&GBUFFER_ALBEDO)
            .sample(&GBUFFER_NORMAL)
            .sample(&GBUFFER_MATERIAL)
            .sample(&GBUFFER_LAYERS)
            .reads(scene.res.shaded());
        let pass = if kind == PassKind::Graphics { pass.color(&HDR, Load::Keep) } else { pass.image(&HDR, ImageUse::StorageWrite) };
        let shade = match rays {
            Some(_) => Shade::Rays(self.lighting_rays.pick(ctx, decals, lights)?),
            None if compute => Shade::Compute(self.lighting_compute.pick(ctx, decals.variant(), lights.shading(true))?),
            None => Shade::Fullscreen(self.lighting.pick(ctx, decals.variant(), lights.shading(false))?),
        };
        declare_light_reads(declare_decal_reads(pass, decals), lights).record(|p| shade.run(p, decals))
    }

    /// Destroys the pipelines; the GPU must be idle.
    pub fn destroy(self, ctx: &GpuContext) {
        for p in [self.gbuffer_opaque, self.gbuffer_mask, self.gbuffer_interlaced, self.gbuffer_glass].into_iter().chain(self.decals) {
            // SAFETY: the GPU is idle.
            unsafe { ctx.destroying().destroy_pipeline(p, None) };
        }
        self.lighting.destroy(ctx);
        self.lighting_compute.destroy(ctx);
        self.lighting_rays.destroy(ctx);
    }
}
