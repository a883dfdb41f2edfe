//! The pipelines, one function each, reading as the whole frame from top to bottom: upload what
//! changed (and filter a new environment), acceleration-structure work, the pipeline's passes
//! (light culling and shadows once depth exists; the sky behind the opaque shading), bloom,
//! debug overlays, tone mapping and the egui overlay. Each returns what it did
//! with lights, for the frame's report. Every pass is declared on the frame graph ([`crate::graph`]), which derives
//! the barriers between them.
//!
//! The data flow is in the values each function hands on: `begin` plans the scene's
//! acceleration structures, the occlusion, the lights and the shadows, each from what the one
//! before returned, and returns the decals', lights' and shadows' frames; the depth stage returns
//! what it wrote ([`Surface`]: the G-buffer, the visibility ids or depth alone), which the decal
//! pass and the reflections take; the motion-vector pass returns the [`MotionVectors`] that
//! temporal anti-aliasing takes.

pub mod deferred;
pub mod forward;
pub mod visbuffer;

use ash::vk;

use crate::RenderError;
use crate::accel::{SceneAccel, SceneAccelFrame};
use crate::bloom::Bloom;
use crate::culling::{Culling, Draws, Phase};
use crate::decals::{DecalChoice, DecalFrame, DecalReaders, Decals};
use crate::environment::Environments;
use crate::exposure::Exposure;
use crate::gpu::device::{GpuContext, Tier};
use crate::gpu::pipeline::{HitGroup, RayTracingDesc, RayTracingPipeline, ScenePush};
pub use crate::gpu::pipeline::{MakeVariant, ShadeVariants};
use crate::gpu::shaders;
use crate::graph::pass::PassContext;
use crate::graph::targets::{MotionVectors, Surface};
use crate::graph::{Frame, PassKind};
use crate::lights::{LightFrame, Lighting};
use crate::motion::PixelIds;
use crate::present::Present;
use crate::reflections::Reflections;
use crate::scene::SceneMirror;
use crate::scene::gpu::{GpuScene, MotionUpload};
use crate::settings::{FrameSettings, TransparencyMethod};
use crate::shadows::{ShadowFrame, ShadowPass};
use crate::transparency::TransparencyPasses;
use deferred::GBufferGlass;

/// The renderer's parts a frame function draws with.
pub struct FrameParts<'a> {
    /// This frame's statistics, which each technique adds to.
    pub counters: &'a mut crate::stats::FrameCounters,
    /// The GPU scene (tables, meshes, textures).
    pub scene: &'a mut GpuScene,
    /// GPU culling and the indirect draws every mesh pass records.
    pub culling: &'a mut Culling,
    /// Posed meshes' skinning.
    pub skinning: &'a mut crate::skinning::Skinning,
    /// Decal acceleration structures, deferred-decal order, debug boxes.
    pub decals: &'a mut Decals,
    /// GPU particles: emitted and moved once depth exists, drawn before the image is finished.
    pub particles: &'a mut crate::particles::Particles,
    /// Light culling and the ray-query lights.
    pub lighting: &'a mut Lighting,
    /// The scene's BLASes and TLAS (devices with acceleration structures).
    pub accel: Option<&'a mut SceneAccel>,
    /// The shadow passes: rays, or shadow maps.
    pub shadows: &'a mut ShadowPass,
    /// Ambient occlusion, traced against the scene's structures or from depth.
    pub occlusion: &'a crate::occlusion::AmbientOcclusion,
    /// Forward passes.
    pub forward: &'a forward::ForwardPasses,
    /// Deferred passes.
    pub deferred: &'a deferred::DeferredPasses,
    /// Visibility-buffer passes.
    pub visbuffer: &'a visbuffer::VisBufferPasses,
    /// Blended transparency, drawn over every pipeline's opaque shading.
    pub transparency: &'a TransparencyPasses,
    /// Ray-traced reflections, added to every pipeline's opaque shading.
    pub reflections: &'a mut Reflections,
    /// The environment's filtering and the sky pass.
    pub environment: &'a mut Environments,
    /// Bloom over the finished HDR image.
    pub bloom: &'a mut Bloom,
    /// Auto-exposure from the finished HDR image.
    pub exposure: &'a mut Exposure,
    /// Motion vectors, once the opaque depth is final (when temporal anti-aliasing runs).
    pub motion: &'a crate::motion::Motion,
    /// Temporal anti-aliasing of the finished HDR image.
    pub taa: &'a mut crate::taa::Taa,
    /// Tone mapping and overlay into the frame's display image.
    pub present: Present<'a>,
    /// SMAA's passes, before the display pass copies out what they wrote.
    pub smaa: &'a crate::smaa::Smaa,
    /// FXAA's pass, likewise.
    pub fxaa: &'a crate::fxaa::Fxaa,
    /// The decal method asked for and the one this device and pipeline apply.
    pub decal_choice: DecalChoice,
    /// The anti-aliasing applied ([`crate::settings::AntiAliasing::applied`]).
    pub aa: crate::settings::AntiAliasing,
    /// Where this frame's motion pass finds each pixel's instance (`motion_ids`), set by `begin`.
    pub pixel_ids: PixelIds,
}

/// What every frame's passes start from: how decals are applied, the lights, the shadows.
struct Begun {
    decals: DecalFrame,
    lights: LightFrame,
    shadows: ShadowFrame,
    /// The scene's structure, when this frame traces it (particles collide with it then).
    scene_traced: Option<[crate::graph::ResourceId; 2]>,
}

/// What every frame does before its passes: follow the decals' and lights' changes, plan the
/// scene's acceleration structures (kept only while something traces them), the ambient
/// occlusion, the lights and the shadows, upload what changed, skin the posed meshes whose pose
/// changed, bring the acceleration structures up to date, set the push constants, and cull the
/// instances into the first phase's draw lists (`crate::culling`).
fn begin(f: &mut Frame, r: &mut FrameParts, mirror: &mut SceneMirror, s: &FrameSettings) -> Result<Begun, RenderError> {
    let started = std::time::Instant::now();
    mirror.sort_transparent(mirror.camera().position);
    let motion_wanted = r.taa.prepare(mirror, s, r.aa, f.graph.extent());
    mirror.set_depth_sample(crate::msaa::Msaa::depth_sample(r.aa.samples(), f.graph.extent()));
    r.decals.follow_changes(mirror, r.scene, r.decal_choice);
    r.skinning.prepare(mirror, r.scene, r.counters);
    r.pixel_ids = motion_ids(r, s, mirror, f.graph.extent());
    let motion_upload = MotionUpload { wanted: motion_wanted, posed_per_pixel: r.pixel_ids != PixelIds::None };
    let reflections = r.reflections.prepare(f, s, mirror, r.counters)?;
    // The particles' decal ring keeps its structures up to date only while decals are traced.
    let decals_traced = r.decal_choice.applied.traces() || (reflections.traced() && s.reflections.decals_at_hits);
    r.particles.prepare(f, r.scene, &mut mirror.emitters, s.delta_seconds, decals_traced, r.counters)?;
    let environment = r.environment.prepare(f, r.scene, mirror)?;
    let traced = r.shadows.traces(&s.lights) || r.occlusion.traces(&s.occlusion) || reflections.traced();
    let accel = match r.accel.as_deref_mut() {
        Some(a) => a.prepare(f, r.scene, mirror, traced, s.refit_pixels, r.counters)?,
        None => SceneAccelFrame::default(),
    };
    let occlusion = r.occlusion.plan(&s.occlusion, accel.traced, r.scene.res.meshes);
    let device_shadows = r.shadows.method();
    let particles = r.particles.active();
    let lights =
        r.lighting.prepare(f, r.scene, mirror, s, &accel, device_shadows, occlusion, &reflections, &environment, particles, r.counters)?;
    let shadows = r.shadows.plan(r.scene, mirror, &lights, s.pipeline == crate::settings::PipelineKind::Deferred, r.counters);
    // How much of each pose to skin, once the refits (which read every vertex) are known.
    r.skinning.choose_levels(mirror, s, r.accel.as_deref().map_or(&[], |a| a.refits()), r.counters);
    // Rays leave rasterised surfaces lifted by the level-of-detail limit while some instance
    // can be drawn at a coarser level (crate::lod).
    let lift = if mirror.lod_instances > 0 { crate::lod::lift(s.lod_pixels, mirror.camera().proj, f.graph.extent().height) } else { 0.0 };
    r.scene.set_lod_lift(lift);
    r.counters.culling = r.culling.prepare(f, r.scene, mirror, s, shadows.map_views())?;
    r.bloom.prepare(f, r.scene, s.bloom)?;
    r.exposure.prepare(f, r.scene, &s.exposure, s.delta_seconds)?;
    let boxes_changed = r.scene.upload(f, mirror, motion_upload, r.counters)?;
    f.upload.prepare_ms = started.elapsed().as_secs_f32() * 1e3;
    r.skinning.record(f, r.scene)?;
    let in_shading = s.pipeline.is_forward() && s.decals_in_forward_shading;
    let readers = DecalReaders {
        lists_in_shading: in_shading,
        reflections: lights.traced_reflections() && s.reflections.decals_at_hits,
        ring: r.particles.decal_ring(),
    };
    let decals = r.decals.build_accel(f, r.scene, mirror, r.decal_choice, readers, boxes_changed, r.counters)?;
    f.push = scene_push(r.scene, s, &decals);
    r.environment.record(f, r.scene, &environment)?;
    if let Some(a) = r.accel.as_deref_mut() {
        a.record(f, r.scene, &accel, r.counters)?;
    }
    r.lighting.build(f, r.scene, &lights, r.counters)?;
    r.counters.bytes_uploaded += r.culling.cull(f, r.scene)?;
    Ok(Begun { decals, lights, shadows, scene_traced: accel.traced })
}

/// Forward: depth prepass (also writing ids when the reflection rays follow, or a decal pass
/// that must know each pixel's instance: otherwise the decal pass reads depth alone),
/// light culling and shadows when asked for, the decal pass (or, for clustered decals with
/// `decals_in_forward_shading`, only their binning: the shading walks the lists), shading with
/// depth EQUAL, the sky, reflections, then the blended surfaces back to front. Under MSAA
/// (`crate::msaa`) the prepass and the shading draw into multisampled targets and resolve them
/// (depth and ids to sample 0, radiance to the mean), traced reflections are resolved before the
/// shading, which adds them per sample, and the sky fills the uncovered samples' share.
pub fn forward_frame(f: &mut Frame, r: &mut FrameParts, mirror: &mut SceneMirror, s: &FrameSettings) -> Result<LightFrame, RenderError> {
    let Begun { decals, lights, shadows, scene_traced } = begin(f, r, mirror, s)?;
    let (scene, forward) = (&*r.scene, r.forward);
    let need_instances = mirror.decals_need_instances();
    let ids = (decals.buffered() && need_instances) || lights.reflections() || r.pixel_ids == PixelIds::Visibility;
    let prepass = r.culling.depth_passes(f, scene, |f, draws, phase| forward.prepass(f, scene, &draws, phase, ids))?;
    let motion = motion(f, r)?;
    r.particles.simulate(f, r.scene, scene_traced, r.counters)?;
    // The decals read the ids when they need the instance (the prepass wrote them then), else
    // depth alone; the reflections read what the prepass wrote (the ids whenever they run).
    let source = Surface::forward_decals(need_instances);
    let draws = r.culling.draws();
    transparent_depth(f, r, &draws, mirror, &lights)?;
    r.occlusion.record(f, r.scene, &lights.occlusion)?;
    r.lighting.record(f, r.scene, &lights)?;
    r.shadows.record(f, r.scene, &draws, &shadows)?;
    r.decals.decal_pass(f, r.scene, &decals, source)?;
    // Under MSAA traced reflections are resolved before the shading, which adds them to each
    // sample from its own surface's pixel; the multisampled target is cleared transparent, so
    // the resolved alpha is the covered fraction of each pixel, which the sky fills
    // (crate::msaa).
    let msaa = r.forward.samples() > 1;
    let reflected = msaa && Reflections::before_shading(&lights, s.debug_view);
    if reflected {
        r.reflections.record_before_shading(f, r.scene, prepass, &decals, &lights)?;
    }
    let sky = r.environment.draws_sky(lights.environment, s.debug_view);
    let [red, green, blue, _] = s.clear_color;
    let clear = match (msaa, sky) {
        (false, _) => s.clear_color,
        (true, false) => [red, green, blue, 0.0],
        (true, true) => [0.0; 4],
    };
    r.forward.shade(f, r.scene, &draws, clear, &decals, &lights, reflected)?;
    r.environment.sky(f, r.scene, lights.environment, s.debug_view, msaa)?;
    if !reflected {
        r.reflections.record(f, r.scene, prepass, &decals, &lights)?;
    }
    r.transparency.shade(f, r.scene, &draws, mirror.transparent_order(), &decals, &lights)?;
    glass_reflections(f, r, mirror, &decals, &lights)?;
    present(f, r, mirror, s, &lights, motion)?;
    Ok(lights)
}

/// Forward+ (seed 001 §4, Fig. 4.1): reverse-Z depth prepass, tiled light culling, ray-traced
/// shadows, then forward shading with depth EQUAL over each tile's lights. It is the forward
/// frame with the light method fixed to tiled ([`crate::settings::LightMethod::effective`]).
pub fn forward_plus_frame(
    f: &mut Frame,
    r: &mut FrameParts,
    mirror: &mut SceneMirror,
    s: &FrameSettings,
) -> Result<LightFrame, RenderError> {
    forward_frame(f, r, mirror, s)
}

/// Deferred: G-buffer (with the blended surfaces on odd rows when transparency is interlaced),
/// light culling and shadows, deferred decals or the decal pass (whichever is the method),
/// lighting in compute (or a full-screen fragment pass; in-shader ray-query decals included
/// when they are the method), then the interlaced composition or a forward transparency pass.
/// Depth peeling runs those layer passes twice, the opaque layer and then the nearest, and
/// composes the two.
pub fn deferred_frame(f: &mut Frame, r: &mut FrameParts, mirror: &mut SceneMirror, s: &FrameSettings) -> Result<LightFrame, RenderError> {
    let begun = begin(f, r, mirror, s)?;
    let (decals, lights) = (&begun.decals, &begun.lights);
    let glass = mirror.transparent_order();
    let motion = if s.transparency.effective(s.pipeline) == TransparencyMethod::DepthPeeling && !glass.is_empty() {
        let motion = deferred_layer(f, r, mirror, GBufferGlass::None, s, &begun, false)?;
        r.transparency.peeling.keep_background(f, r.scene)?;
        deferred_layer(f, r, mirror, GBufferGlass::Full(glass), s, &begun, true)?;
        r.transparency.peeling.compose(f, r.scene)?;
        motion
    } else if lights.interlaced() {
        let motion = deferred_layer(f, r, mirror, GBufferGlass::Interlaced(glass), s, &begun, false)?;
        r.transparency.interlaced.compose(f, r.scene, s.transparency)?;
        motion
    } else {
        let motion = deferred_layer(f, r, mirror, GBufferGlass::None, s, &begun, false)?;
        r.transparency.shade(f, r.scene, &r.culling.draws(), glass, decals, lights)?;
        r.reflections.record_glass(f, r.scene, decals, lights, !glass.is_empty())?;
        motion
    };
    r.reflections.finish(f, lights)?;
    present(f, r, mirror, s, lights, motion)?;
    Ok(begun.lights)
}

/// The deferred pipeline's passes over one G-buffer: geometry (with `glass`), light culling
/// and shadows (`again`: a second layer this frame, whose shadow maps are drawn), decals,
/// lighting, reflections. Returns the motion vectors when the first layer wrote them.
fn deferred_layer(
    f: &mut Frame,
    r: &mut FrameParts,
    mirror: &SceneMirror,
    glass: GBufferGlass,
    s: &FrameSettings,
    Begun { decals, lights, shadows, scene_traced }: &Begun,
    again: bool,
) -> Result<Option<MotionVectors>, RenderError> {
    let (scene, deferred) = (&*r.scene, r.deferred);
    let (gbuffer, motion) = if again {
        // The second layer draws what the first phase and the second found.
        (deferred.geometry(f, scene, &r.culling.draws(), glass, s.clear_color, Phase::WHOLE)?, None)
    } else {
        let gbuffer =
            r.culling.depth_passes(f, scene, |f, draws, phase| deferred.geometry(f, scene, &draws, glass, s.clear_color, phase))?;
        let motion = motion(f, r)?;
        r.particles.simulate(f, r.scene, *scene_traced, r.counters)?;
        (gbuffer, motion)
    };
    let draws = r.culling.draws();
    // The ambient occlusion of this layer's depth, then its lights and shadows.
    r.occlusion.record(f, r.scene, &lights.occlusion)?;
    if again {
        r.lighting.record(f, r.scene, lights)?;
        r.shadows.record_again(f, r.scene, &draws, shadows)?;
    } else {
        transparent_depth(f, r, &draws, mirror, lights)?;
        r.lighting.record(f, r.scene, lights)?;
        r.shadows.record(f, r.scene, &draws, shadows)?;
    }
    r.deferred.decals(f, r.scene, r.decals.deferred_runs(decals), r.decals.deferred_ring(decals))?;
    r.decals.decal_pass(f, r.scene, decals, gbuffer)?;
    r.deferred.lighting(f, r.scene, decals, lights, s.compute_shading)?;
    r.environment.sky(f, r.scene, lights.environment, s.debug_view, false)?;
    r.reflections.record(f, r.scene, gbuffer, decals, lights)?;
    Ok(motion)
}

/// Visibility buffer: ids and depth, light culling and shadows, the decal pass, one pass
/// (compute, or full-screen fragment) that rebuilds and shades, reflections, then the blended
/// surfaces in a forward pass.
pub fn visbuffer_frame(f: &mut Frame, r: &mut FrameParts, mirror: &mut SceneMirror, s: &FrameSettings) -> Result<LightFrame, RenderError> {
    let Begun { decals, lights, shadows, scene_traced } = begin(f, r, mirror, s)?;
    let (scene, visbuffer) = (&*r.scene, r.visbuffer);
    let visibility = r.culling.depth_passes(f, scene, |f, draws, phase| visbuffer.visibility(f, scene, &draws, phase))?;
    let motion = motion(f, r)?;
    r.particles.simulate(f, r.scene, scene_traced, r.counters)?;
    let draws = r.culling.draws();
    transparent_depth(f, r, &draws, mirror, &lights)?;
    r.occlusion.record(f, r.scene, &lights.occlusion)?;
    r.lighting.record(f, r.scene, &lights)?;
    r.shadows.record(f, r.scene, &draws, &shadows)?;
    r.decals.decal_pass(f, r.scene, &decals, visibility)?;
    r.visbuffer.shade(f, r.scene, s.clear_color, &decals, &lights, s.compute_shading)?;
    r.environment.sky(f, r.scene, lights.environment, s.debug_view, false)?;
    r.reflections.record(f, r.scene, visibility, &decals, &lights)?;
    r.transparency.shade(f, r.scene, &draws, mirror.transparent_order(), &decals, &lights)?;
    glass_reflections(f, r, mirror, &decals, &lights)?;
    present(f, r, mirror, s, &lights, motion)?;
    Ok(lights)
}

/// Motion vectors, when temporal anti-aliasing runs, right after the opaque depth (before any
/// later layer, glass's, replaces it).
fn motion(f: &mut Frame, r: &FrameParts) -> Result<Option<MotionVectors>, RenderError> {
    if !r.taa.runs() {
        return Ok(None);
    }
    r.motion.record(f, r.scene, r.pixel_ids).map(Some)
}

/// About how many pixels' ids cost what drawing one posed vertex again as a mover costs
/// ([`motion_ids`]).
const MOVER_VERTEX_PIXELS: u64 = 3;

/// Where this frame's motion pass finds each pixel's instance and triangle, for the motion of
/// posed meshes' skin per pixel (`crate::motion`): the visibility buffer, the G-buffer's layers,
/// or, in the forward pipelines under temporal anti-aliasing with posed meshes in the scene,
/// the prepass's ids when the settings ask for reflection rays or a decal pass (the prepass then
/// writes them even in a frame with no reflecting surface or decal), or when the posed meshes
/// skinned this frame hold more than a third as many vertices as the image has pixels: drawing
/// them again as movers would cost more than the ids. (The lent H100 at 1920×1080: the ids
/// added 0.48 ms to the prepass, 0.23 ns a pixel; 10,000 foxes of 1,728 vertices took 12.5 ms
/// as movers, 0.72 ns a vertex. At 64×48 on lavapipe the same foxes took 1.7 s a frame as
/// movers.) The choice is made once the frame's skinning jobs are known and before the scene's
/// upload, which must know whether posed meshes are movers. Otherwise the forward prepass keeps
/// no ids for motion and posed meshes are drawn again as movers; a scene without posed meshes
/// never pays for ids it has no use for.
fn motion_ids(r: &FrameParts, s: &FrameSettings, mirror: &SceneMirror, extent: vk::Extent2D) -> PixelIds {
    let decal_pass = r.decal_choice.applied.uses_decal_buffer() && !s.decals_in_forward_shading;
    let rays = s.reflections.mode != crate::settings::ReflectionMode::Off;
    let taa = r.aa == crate::settings::AntiAliasing::Taa;
    let many_posed = mirror.poses.job_vertices() * MOVER_VERTEX_PIXELS > extent.width as u64 * extent.height as u64;
    let forward_ids = s.pipeline.is_forward() && taa && mirror.poses.any_posed() && (decal_pass || rays || many_posed);
    PixelIds::of(s.pipeline, forward_ids)
}

/// The end of every frame: the particles over the shaded image, temporal anti-aliasing, bloom
/// over the finished HDR image,
/// auto-exposure's measurement of it, the decal boxes when shown (not blurred, not measured),
/// then tone mapping into the display image and the overlay.
fn present(
    f: &mut Frame,
    r: &mut FrameParts,
    mirror: &SceneMirror,
    s: &FrameSettings,
    lights: &LightFrame,
    motion: Option<MotionVectors>,
) -> Result<(), RenderError> {
    // Debug views show the surfaces' attributes: particles would cover them.
    if matches!(s.debug_view, crate::settings::DebugView::Lit) {
        r.particles.draw(f, r.scene, lights)?;
        if let Some(motion) = motion {
            r.particles.motion(f, r.scene, motion)?;
        }
    }
    let interlaced = s.pipeline == crate::settings::PipelineKind::Deferred && lights.interlaced() && !mirror.transparent_order().is_empty();
    r.taa.record(f, r.scene, motion, interlaced, s.taa_sharpen)?;
    r.bloom.record(f, r.scene)?;
    r.exposure.record(f, r.scene)?;
    r.decals.draw_boxes(f, r.scene, mirror, s)?;
    // Post-process anti-aliasing writes its own target from the lit image, which the display
    // pass copies out.
    match r.aa {
        crate::settings::AntiAliasing::Smaa => r.smaa.record(f, r.scene, r.exposure.reads())?,
        crate::settings::AntiAliasing::Fxaa => r.fxaa.record(f, r.scene, r.exposure.reads())?,
        _ => {}
    }
    r.present.record(f, r.scene, r.exposure.reads())
}

/// Reflections on the glass the forward transparency pass drew, then the reflection statistics'
/// copy for the CPU.
fn glass_reflections(
    f: &mut Frame,
    r: &mut FrameParts,
    mirror: &SceneMirror,
    decals: &DecalFrame,
    lights: &LightFrame,
) -> Result<(), RenderError> {
    r.reflections.record_glass(f, r.scene, decals, lights, !mirror.transparent_order().is_empty())?;
    r.reflections.finish(f, lights)
}

/// The transparent depth, when light culling or the glass shadows read it this frame (before
/// both).
fn transparent_depth(f: &mut Frame, r: &FrameParts, draws: &Draws, mirror: &SceneMirror, lights: &LightFrame) -> Result<(), RenderError> {
    if !lights.reads_transparent_depth() {
        return Ok(());
    }
    r.transparency.depth(f, r.scene, draws, mirror.transparent_order())
}

/// A lighting pass with ray-query lights (`crate::lights::ray_query`): on the ray-query tier
/// the compute variants whose lights come from ray queries, in each way they apply decals; on
/// the ray-tracing-pipeline tier a ray-generation pipeline (`[plain, decal buffer]`) whose
/// lights come from a traced zero-length ray, shaded in its any-hit shader, and another for
/// frames with shadows, whose any-hit shader draws one of the lights for the ray-generation
/// shader's one shadow ray (`shaders/include/ray_pipeline_lights.glsl`).
pub struct RayLightShading {
    compute: Option<ShadeVariants>,
    rays: Option<LazyRays>,
    shadowed: Option<LazyRays>,
}

impl RayLightShading {
    /// Prepares what this device can run: the compute shaders `[plain, ray-query decals, decal
    /// buffer]` with ray queries, else the ray-generation shaders `raygen` with ray-tracing
    /// pipelines, else nothing. Each is made the first frame that uses it.
    pub fn new(
        ctx: &GpuContext,
        layout: vk::PipelineLayout,
        name: &'static str,
        compute: [&'static [u8]; 3],
        raygen: [&'static [u8]; 2],
        raygen_shadowed: [&'static [u8]; 2],
    ) -> Self {
        if ctx.tier == Tier::RayQuery {
            let compute = ShadeVariants::new(ctx, compute, move |ctx, spirv, spec| {
                crate::gpu::pipeline::create_compute_specialized(ctx, layout, name, spirv, spec)
            });
            return Self { compute: Some(compute), rays: None, shadowed: None };
        }
        if !ctx.ray_support().ray_pipeline {
            return Self { compute: None, rays: None, shadowed: None };
        }
        let lazy = |raygen, shadows| LazyRays { made: std::sync::OnceLock::new(), layout, name, raygen, shadows };
        Self { compute: None, rays: Some(lazy(raygen, false)), shadowed: Some(lazy(raygen_shadowed, true)) }
    }

    /// The kind of pass it records, `None` on a device that has neither.
    pub fn kind(&self) -> Option<PassKind> {
        match (&self.compute, &self.rays) {
            (Some(_), _) => Some(PassKind::Compute),
            (None, Some(_)) => Some(PassKind::RayTracing),
            (None, None) => None,
        }
    }

    /// The pipeline that shades with this frame's `decals` and `lights` (made now if no frame
    /// used it before), `None` on a device that has neither kind. The ray-generation pipelines
    /// always keep the area lights' code (one pipeline each, with its shader binding table):
    /// the one with shadow rays in frames whose shading traces them
    /// ([`LightFrame::inline_shadows`]).
    pub fn pick(&self, ctx: &GpuContext, decals: &DecalFrame, lights: &LightFrame) -> Result<Option<RayLightPass<'_>>, RenderError> {
        if let Some(compute) = &self.compute {
            return Ok(Some(RayLightPass { pipeline: compute.pick(ctx, decals.variant(), lights.shading(false))?, rays: None }));
        }
        let lazy = if lights.inline_shadows.is_some() { &self.shadowed } else { &self.rays };
        let Some(lazy) = lazy else { return Ok(None) };
        let rays = match lazy.made.get() {
            Some(rays) => rays,
            None => {
                // Shadow rays take the shadow pass's miss and any-hit shaders, at index 1.
                let (misses, hit_groups) = if lazy.shadows {
                    (
                        &[shaders::LIGHT_RAYS_RMISS_SAMPLED_LIGHTS, shaders::SHADOWS_RMISS][..],
                        &[
                            HitGroup::any_hit(shaders::LIGHT_RAYS_RAHIT_SAMPLED_LIGHTS, Some(shaders::LIGHT_RAYS_RINT)),
                            HitGroup::any_hit(shaders::SHADOWS_RAHIT, None),
                        ][..],
                    )
                } else {
                    (&[shaders::LIGHT_RAYS_RMISS][..], &[HitGroup::any_hit(shaders::LIGHT_RAYS_RAHIT, Some(shaders::LIGHT_RAYS_RINT))][..])
                };
                let desc = RayTracingDesc { name: lazy.name, raygen: &lazy.raygen, misses, hit_groups };
                let made = RayTracingPipeline::new(ctx, lazy.layout, &desc)?;
                lazy.made.get_or_init(|| made)
            }
        };
        Ok(Some(RayLightPass { pipeline: rays.pipeline, rays: Some(rays) }))
    }

    /// Destroys the pipelines that were made; the GPU must be idle.
    pub fn destroy(self, ctx: &GpuContext) {
        if let Some(c) = self.compute {
            c.destroy(ctx);
        }
        for lazy in [self.rays, self.shadowed].into_iter().flatten() {
            if let Some(r) = lazy.made.into_inner() {
                r.destroy(ctx);
            }
        }
    }
}

/// How a full-screen shading pass (deferred lighting, visibility-buffer shading) runs this
/// frame, with the pipeline it picked.
pub enum Shade<'a> {
    /// Ray-query lights ([`RayLightShading`]).
    Rays(Option<RayLightPass<'a>>),
    /// A compute dispatch over the pixels, adding through a storage image.
    Compute(vk::Pipeline),
    /// A full-screen fragment pass.
    Fullscreen(vk::Pipeline),
}

impl Shade<'_> {
    /// Shades every pixel of the pass.
    pub fn run(&self, p: &PassContext, decals: &DecalFrame) {
        match self {
            Shade::Rays(rays) => {
                if let Some(rays) = rays {
                    rays.run(p, decals);
                }
            }
            Shade::Compute(pipeline) => {
                p.bind(vk::PipelineBindPoint::COMPUTE, *pipeline, &p.push);
                p.cmd.dispatch(p.extent.width.div_ceil(8), p.extent.height.div_ceil(8), 1);
            }
            Shade::Fullscreen(pipeline) => p.fullscreen(*pipeline, &p.push),
        }
    }
}

/// A ray-generation pipeline of a [`RayLightShading`], made the first frame that uses it.
struct LazyRays {
    made: std::sync::OnceLock<RayTracingPipeline>,
    layout: vk::PipelineLayout,
    name: &'static str,
    raygen: [&'static [u8]; 2],
    /// Whether it traces shadow rays (its lights drawn from: `SAMPLED_LIGHTS`).
    shadows: bool,
}

/// The pipeline a [`RayLightShading`] picked for a frame.
pub struct RayLightPass<'a> {
    pipeline: vk::Pipeline,
    /// The ray-tracing pipeline, when it traces rays (its shader binding table).
    rays: Option<&'a RayTracingPipeline>,
}

impl RayLightPass<'_> {
    /// Binds the pipeline and shades every pixel of the pass.
    pub fn run(&self, p: &PassContext, decals: &DecalFrame) {
        match self.rays {
            None => {
                p.bind(vk::PipelineBindPoint::COMPUTE, self.pipeline, &p.push);
                p.cmd.dispatch(p.extent.width.div_ceil(8), p.extent.height.div_ceil(8), 1);
            }
            Some(rays) => {
                p.bind(vk::PipelineBindPoint::RAY_TRACING_KHR, self.pipeline, &p.push);
                rays.trace(p.cmd, usize::from(decals.buffered()), p.extent);
            }
        }
    }
}

/// The push constants every scene pass of the frame shares.
fn scene_push(scene: &GpuScene, s: &FrameSettings, decals: &DecalFrame) -> ScenePush {
    ScenePush {
        camera: scene.camera.address(),
        instances: scene.instances.address(),
        materials: scene.materials.address(),
        lights: scene.lights.address(),
        decals: scene.decals.address(),
        decal_materials: scene.decal_materials.address(),
        decal_tlas: decals.tlas_address,
        decal_aabbs: scene.decal_aabbs.address(),
        meshes: scene.mesh_table.address(),
        decal_order: scene.decal_order.address(),
        pad: 0,
        texture_index: 0,
        debug_view: s.debug_view as u32,
        decal_count: decals.count,
        decal_lists: decals.clusters.map(|c| c.address).or(decals.lists.map(|l| l.address)).unwrap_or(0),
        decal_list_capacity: decals.clusters.map(|c| c.capacity).or(decals.lists.map(|l| l.capacity)).unwrap_or(0),
        decal_cluster_tiles: decals.clusters.map_or(0, |c| c.tiles),
        lighting: scene.lighting.address(),
        shadow_views: scene.shadow_views.address(),
    }
}
