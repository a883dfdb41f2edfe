//! Ray-traced shadows (seed 001 §4.3; hard there, soft here where a light has a size and
//! temporal anti-aliasing averages the rays: `shadow_ray_sampled` in
//! `shaders/include/lighting.glsl`) for point, spot and directional lights, as one pass
//! that serves every pipeline because it works from depth alone: per pixel, the world position
//! and the normal come from depth (naive 3-tap or improved 5-tap reconstruction, §4.3.1), and a
//! shadow ray goes towards each light of the pixel's list that can reach it, unless shadow-ray
//! culling finds the normal facing away. The result is a visibility bit per pixel and list entry
//! (`shaders/include/shadow_pass.glsl`, `light_tiles.glsl`), which shading reads in every
//! pipeline.
//!
//! - **Ray-query tier**: a compute pass with ray queries (`shaders/shadows.comp`), as the seed
//!   wrote it.
//! - **Ray-tracing-pipeline tier** (the lent GPUs, which have no ray queries): a ray-generation
//!   pass (`shaders/shadows.rgen`) whose rays skip closest-hit shaders, end at the first hit, and
//!   mark themselves unblocked in the miss shader.
//! - **Alpha-masked materials** are non-opaque instances in the scene TLAS (`crate::accel`); their
//!   candidate hits run the mask test (`shaders/include/alpha_mask.glsl`) in the ray-query loop
//!   or the any-hit shader.
//! - **Coloured shadows** (seed 002 §3.2.1, issue item 4, on the ray-tracing tiers): blended
//!   instances are non-opaque too, and a candidate hit on glass multiplies the light the ray
//!   carries by the glass colour × (1 − opacity) and lets it go on, so point, spot and
//!   directional lights alike throw coloured shadows (the seed had spot lights only), and panes
//!   in a row multiply. A pixel keeps the colour of up to `SHADOW_TINT_SLOTS` (2) tinted lights
//!   beside its shadow bits (`GpuLighting::shadow_tints`, 8 bytes a pixel, allocated only while
//!   the scene holds glass); more are lit or shadowed by their tint's luminance. Why slots and
//!   not a colour per light and pixel: the bits cost 1 bit per list entry, a colour 24, and at
//!   1080p with 64 lights a tile that is 400 MB; a ray rarely crosses glass to more than two
//!   lights. With `LightSettings::coloured_shadows` off glass blocks light like opaque surfaces
//!   (the cheaper shadows of seed 002 Table 4.3).
//! - **No ray tracing** (or asked for with `LightSettings::shadow_maps`): shadow maps
//!   ([`maps`]) answer the same question per pixel and light, into the same bits and tints.
//! - **The glass layer** ([`ShadowInputs::glass`]): where the forward transparency pass draws
//!   glass, every method runs once more over the transparent depth (the nearest blended
//!   surface), into a second layer of bits and tints (variant `GLASS_LAYER`), so the glass is
//!   shaded with its own shadows. Glass in the deferred G-buffer (interlaced, depth peeling) is
//!   in the depth target already.
//!
//! The frame function asks [`ShadowPass::traces`] whether the scene's structures are needed,
//! plans the frame with [`ShadowPass::plan`] from the lights' [`LightFrame`] (the method applied,
//! the shadow words, the light tiles), and records [`ShadowPass::record`] after light culling.

pub mod maps;

use ash::vk;

use crate::RenderError;
use crate::culling::Draws;
use crate::gpu::device::{GpuContext, Tier};
use crate::gpu::pipeline::{HitGroup, RayTracingDesc, RayTracingPipeline, create_compute};
use crate::gpu::shaders;
use crate::graph::targets::{DEPTH, GBUFFER_ALBEDO, GBUFFER_MATERIAL, GBUFFER_NORMAL, SHADOW_DEBUG, SHADOW_SAMPLES, TRANSPARENT_DEPTH};
use crate::graph::{BufferUse, Frame, ImageUse, PassKind, ResourceId};
use crate::lights::LightFrame;
use crate::lights::sampling::ShadowSampling;
use crate::scene::SceneMirror;
use crate::scene::gpu::GpuScene;
use crate::settings::{LightSettings, ShadowMapBudget, ShadowMethod};
use crate::stats::FrameCounters;
use maps::{ShadowMapPlan, ShadowMaps};

/// The shadow passes this device can run.
pub struct ShadowPass {
    /// `[depth target, glass layer, depth target with the G-buffer's material]`.
    ray_query: Option<[vk::Pipeline; 3]>,
    /// Its ray-generation shaders are `[depth target, glass layer, depth target with the
    /// G-buffer's material]`.
    ray_pipeline: Option<RayTracingPipeline>,
    /// Shadow maps (every device).
    pub maps: ShadowMaps,
    /// The sampled shadows' denoiser.
    sampling: ShadowSampling,
}

/// What the shadow pass reads and writes this frame.
#[derive(Clone, Copy, Debug)]
pub struct ShadowInputs {
    /// How the rays are traced.
    pub method: ShadowMethod,
    /// The scene TLAS and BLASes (rays only).
    pub traced: Option<[ResourceId; 2]>,
    /// The light tile buffer, when lights are tiled.
    pub light_tiles: Option<ResourceId>,
    /// The shadow words it writes.
    pub shadow_bits: ResourceId,
    /// Whether it also writes the sampled shadows (pixels with many lights sample them,
    /// `crate::lights::sampling`), which the denoiser then averages.
    pub sampled: bool,
    /// Whether it also writes the shadow debug image.
    pub debug: bool,
    /// The glass layer: over the transparent depth (the nearest blended surface the forward
    /// transparency pass draws) into the second layer of words and tints, instead of over the
    /// depth target.
    pub glass: bool,
    /// Whether the sampled shadows weigh their draws through the surface's whole BRDF, read from
    /// the G-buffer (the deferred pipeline's, written before its shadows); otherwise by the light
    /// a diffuse surface receives (`shaders/include/direct_sampling.glsl`).
    pub material: bool,
}

/// What the shadow passes do this frame, planned before the scene's upload.
#[derive(Clone, Copy, Debug, Default)]
pub struct ShadowFrame {
    /// The shadow-map views drawn (culling makes a draw list for each).
    pub maps: ShadowMapPlan,
    /// The pass's inputs, when it runs (shadows traced or mapped into the shadow words, and a
    /// structure to trace against when traced).
    inputs: Option<ShadowInputs>,
    /// Whether it runs again over the transparent depth (the glass layer).
    glass: bool,
}

impl ShadowFrame {
    /// Shadow-map views drawn this frame.
    pub fn map_views(&self) -> u32 {
        self.maps.views
    }
}

impl ShadowPass {
    /// Creates the passes the device supports.
    pub fn new(ctx: &GpuContext, layout: vk::PipelineLayout, budget: ShadowMapBudget) -> Result<Self, RenderError> {
        let maps = ShadowMaps::new(ctx, layout, budget)?;
        let sampling = match ShadowSampling::new(ctx, layout) {
            Ok(s) => s,
            Err(e) => {
                maps.destroy(ctx);
                return Err(e);
            }
        };
        let ray_query = if ctx.tier == Tier::RayQuery {
            Some([
                create_compute(ctx, layout, "shadows (ray query)", shaders::SHADOWS_COMP)?,
                create_compute(ctx, layout, "glass shadows (ray query)", shaders::SHADOWS_COMP_GLASS_LAYER)?,
                create_compute(ctx, layout, "shadows from the G-buffer (ray query)", shaders::SHADOWS_COMP_SHADOW_MATERIAL)?,
            ])
        } else {
            None
        };
        let ray_pipeline = if ctx.ray_support().ray_pipeline {
            match RayTracingPipeline::new(
                ctx,
                layout,
                &RayTracingDesc {
                    name: "shadows (ray-tracing pipeline)",
                    raygen: &[shaders::SHADOWS_RGEN, shaders::SHADOWS_RGEN_GLASS_LAYER, shaders::SHADOWS_RGEN_SHADOW_MATERIAL],
                    misses: &[shaders::SHADOWS_RMISS],
                    hit_groups: &[HitGroup::any_hit(shaders::SHADOWS_RAHIT, None)],
                },
            ) {
                Ok(p) => Some(p),
                Err(e) => {
                    for p in ray_query.into_iter().flatten() {
                        // SAFETY: unused.
                        unsafe { ctx.destroying().destroy_pipeline(p, None) };
                    }
                    maps.destroy(ctx);
                    sampling.destroy(ctx);
                    return Err(e);
                }
            }
        } else {
            None
        };
        Ok(Self { ray_query, ray_pipeline, maps, sampling })
    }

    /// How this device makes shadows by default: ray queries where it has them, else the
    /// ray-tracing pipeline, else shadow maps.
    pub fn method(&self) -> ShadowMethod {
        if self.ray_query.is_some() {
            ShadowMethod::RayQuery
        } else if self.ray_pipeline.is_some() {
            ShadowMethod::RayPipeline
        } else {
            ShadowMethod::Maps
        }
    }

    /// Whether this frame's shadows, as `lights` asks for them, trace the scene's acceleration
    /// structures (`crate::accel`, which stay dormant while nothing traces them).
    pub fn traces(&self, lights: &LightSettings) -> bool {
        lights.shadows && !lights.shadow_maps && self.method() != ShadowMethod::Maps
    }

    /// Plans this frame's passes from the lights' frame: draws the shadow maps' views when
    /// shadows are mapped (handing them to the scene, and sets the lighting record's atlas
    /// layout), and names what the pass reads and writes. `gbuffer`: the pipeline writes a
    /// G-buffer before its shadows, which the sampled shadows then weigh their draws by. Before
    /// the scene's upload.
    pub fn plan(
        &mut self,
        scene: &mut GpuScene,
        mirror: &SceneMirror,
        lights: &LightFrame,
        gbuffer: bool,
        counters: &mut FrameCounters,
    ) -> ShadowFrame {
        scene.set_shadow_maps(self.maps.tile(), self.maps.columns());
        let maps = if lights.shadows == ShadowMethod::Maps {
            self.maps.plan(scene, mirror.lights.records(), mirror.camera())
        } else {
            ShadowMapPlan::default()
        };
        counters.shadow_map_views = maps.views as u64;
        counters.shadow_maps_missing = maps.missing as u64;
        let inputs = lights.shadow_bits.and_then(|shadow_bits| {
            let traced = match lights.shadows {
                ShadowMethod::Maps => None,
                _ => Some(lights.scene_accel?), // no instance yet: nothing to trace against
            };
            let method = lights.shadows;
            let sampled = lights.samples();
            let material = sampled && gbuffer;
            Some(ShadowInputs {
                method,
                traced,
                light_tiles: lights.light_tiles,
                shadow_bits,
                sampled,
                debug: lights.debug,
                glass: false,
                material,
            })
        });
        ShadowFrame { maps, inputs, glass: lights.glass_shadows() }
    }

    /// Makes this frame's shadows (tracing rays, or drawing `draws` into shadow maps and
    /// reading them) into the shadow words, and again over the glass layer when it has one.
    /// Needs this frame's depth and, when lights are tiled, the culled lists.
    pub fn record(&self, f: &mut Frame, scene: &GpuScene, draws: &Draws, frame: &ShadowFrame) -> Result<(), RenderError> {
        self.record_layer(f, scene, draws, frame, frame.maps)
    }

    /// [`ShadowPass::record`] again, over a second layer of depth written since (depth peeling,
    /// `crate::transparency::peeling`), reading the shadow maps the first call drew instead of
    /// drawing them twice.
    pub fn record_again(&self, f: &mut Frame, scene: &GpuScene, draws: &Draws, frame: &ShadowFrame) -> Result<(), RenderError> {
        self.record_layer(f, scene, draws, frame, ShadowMapPlan { views: 0, ..frame.maps })
    }

    fn record_layer(
        &self,
        f: &mut Frame,
        scene: &GpuScene,
        draws: &Draws,
        frame: &ShadowFrame,
        maps: ShadowMapPlan,
    ) -> Result<(), RenderError> {
        let Some(inputs) = frame.inputs else { return Ok(()) };
        self.record_pass(f, scene, draws, maps, &inputs)?;
        if frame.glass {
            // The glass layer: the same over the transparent depth, reading the maps just drawn.
            let glass = ShadowInputs { debug: false, sampled: false, glass: true, material: false, ..inputs };
            self.record_pass(f, scene, draws, ShadowMapPlan { views: 0, ..maps }, &glass)?;
        }
        Ok(())
    }

    /// Whether this device can trace shadows with `method`.
    pub fn supports(&self, method: ShadowMethod) -> bool {
        match method {
            ShadowMethod::RayQuery => self.ray_query.is_some(),
            ShadowMethod::RayPipeline => self.ray_pipeline.is_some(),
            ShadowMethod::Maps | ShadowMethod::None => true,
        }
    }

    /// Traces one layer's shadow rays (or draws and reads its shadow maps, as `plan` says) into
    /// the shadow words.
    fn record_pass(
        &self,
        f: &mut Frame,
        scene: &GpuScene,
        draws: &Draws,
        plan: ShadowMapPlan,
        inputs: &ShadowInputs,
    ) -> Result<(), RenderError> {
        match inputs.method {
            ShadowMethod::None => return Ok(()),
            ShadowMethod::Maps => return self.maps.record(f, scene, draws, plan, inputs),
            _ => {}
        }
        if !self.supports(inputs.method) {
            return Err(unsupported(inputs.method));
        }
        let extent = f.graph.extent();
        let kind = if inputs.method == ShadowMethod::RayPipeline { PassKind::RayTracing } else { PassKind::Compute };
        let name = match (kind, inputs.glass) {
            (PassKind::RayTracing, false) => "shadows_ray_pipeline",
            (PassKind::RayTracing, true) => "glass_shadows_ray_pipeline",
            (_, false) => "shadows_ray_query",
            (_, true) => "glass_shadows_ray_query",
        };
        // The pipeline's variant: the glass layer's, the G-buffer's, or the plain one.
        let layer = if inputs.glass {
            1
        } else if inputs.material {
            2
        } else {
            0
        };
        let pass = f
            .pass(name, kind)
            .sample(if inputs.glass { &TRANSPARENT_DEPTH } else { &DEPTH })
            .reads(scene.res.shaded())
            .read(scene.res.meshes, BufferUse::Storage)
            .reads(inputs.traced.into_iter().flatten().map(|a| (a, BufferUse::Accel)))
            .reads(inputs.light_tiles.map(|t| (t, BufferUse::Storage)))
            .write(inputs.shadow_bits, BufferUse::Storage)
            .when(inputs.sampled, |p| p.image(&SHADOW_SAMPLES, ImageUse::StorageWrite))
            .when(inputs.material, |p| p.sample(&GBUFFER_ALBEDO).sample(&GBUFFER_NORMAL).sample(&GBUFFER_MATERIAL))
            .when(inputs.debug, |p| p.image(&SHADOW_DEBUG, ImageUse::StorageWrite));
        match inputs.method {
            ShadowMethod::RayPipeline => {
                let rt = self.ray_pipeline.as_ref().ok_or_else(|| unsupported(inputs.method))?;
                pass.record(|p| {
                    p.bind(vk::PipelineBindPoint::RAY_TRACING_KHR, rt.pipeline, &p.push);
                    rt.trace(p.cmd, layer, extent);
                })?;
            }
            ShadowMethod::RayQuery => {
                let pipeline = self.ray_query.ok_or_else(|| unsupported(inputs.method))?[layer];
                pass.record(|p| {
                    p.bind(vk::PipelineBindPoint::COMPUTE, pipeline, &p.push);
                    p.cmd.dispatch(extent.width.div_ceil(8), extent.height.div_ceil(8), 1);
                })?;
            }
            ShadowMethod::Maps | ShadowMethod::None => {}
        }
        if inputs.sampled {
            self.sampling.record(f, scene, inputs.light_tiles)?;
        }
        Ok(())
    }

    /// Destroys the pipelines; the GPU must be idle.
    pub fn destroy(self, ctx: &GpuContext) {
        for p in self.ray_query.into_iter().flatten() {
            // SAFETY: the GPU is idle.
            unsafe { ctx.destroying().destroy_pipeline(p, None) };
        }
        if let Some(rt) = self.ray_pipeline {
            rt.destroy(ctx);
        }
        self.maps.destroy(ctx);
        self.sampling.destroy(ctx);
    }
}

fn unsupported(method: ShadowMethod) -> RenderError {
    RenderError::Other(format!("shadows by {} were asked for without their pipeline", method.name()))
}
