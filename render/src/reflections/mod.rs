//! Ray-traced reflections in which decals appear. Seed 000 (`seeds/000`, §2.4 and Fig. 2.4) lists
//! ray-query reflections among its renderer's options and shows decals under them; its future
//! work (§6) proposes ray-query decals in real-time ray tracing. This is where enumerating decals
//! through an acceleration structure pays most: the decals at *any* point a ray reaches can be
//! found, including points the camera never sees, where deferred, clustered and screen-space
//! decals have nothing to offer (Unity HDRP's ray-traced reflections leave decals out).
//!
//! Two compute passes after the opaque shading, before blended surfaces:
//!
//! 1. **Rays** (`shaders/reflections.comp`). Each pixel rebuilds its surface as its pipeline's
//!    shading does (G-buffer, or visibility ids: the forward pipelines then draw the ids
//!    prepass), applies the frame's decals the same way, and stores the weight its reflection
//!    gets: the GGX lobe's pre-integrated reflectance (Karis's fit) × occlusion, faded out over
//!    the last quarter below the roughness cut-off. Surfaces below the cut-off trace a ray, every
//!    pixel at full resolution or one per 2×2 block at half: mirrors (roughness < 0.05) the exact
//!    mirror direction, glossy surfaces one drawn from the GGX distribution of visible normals.
//!    At the hit (`shaders/include/reflections.glsl`) the surface is rebuilt bindlessly with the
//!    visibility buffer's code, its decals found by the same zero-length ray in the decal TLAS as
//!    on screen (whatever the on-screen decal method), its lights by the ray-query lights' TLAS
//!    with their shadow rays, the clear colour on a miss; masked surfaces are alpha-tested and
//!    glass is blended over what lies behind it.
//! 2. **Resolve** (`shaders/reflections_resolve.comp`): a depth-aware Gaussian over the rays
//!    around each pixel, as wide as its roughness asks (none for a mirror at full resolution; the
//!    depth-aware upsample at half), added to the HDR target in place of the ambient term's
//!    specular part. There are no motion vectors yet, so glossy reflections are filtered in
//!    space only; the noise pattern is fixed per pixel, so a still frame stays still.
//!
//! Both ray-tracing tiers: in compute with ray queries, or as a ray-generation shader with five
//! hit groups (the reflection ray's closest hit with an any-hit for masked and blended surfaces,
//! the decal pass's two, which blend the decals at a hit point or collect them for the
//! ray-generation shader to blend, the ray-query lights' and the shadow pass's) on the
//! ray-tracing-pipeline tier, where the lights found at a hit point by an any-hit shader (which cannot trace) come
//! back four strongest apart, and those and the sun get their shadow rays from the
//! ray-generation shader; the rest are unshadowed. Work is per cell (a pixel, or a 2×2 block at
//! half resolution, traced by its first pixel that reflects), so neither needs shared memory.
//!
//! Devices without ray tracing (or `ReflectionMode::ScreenSpace`) march each ray through the
//! depth buffer instead (`shaders/screen_reflections.comp`) and see the lit image where it
//! crosses a surface: decals then appear in reflections only where they are on screen.
//!
//! Glass reflects too: the glass of the deferred G-buffer (interlaced rows, depth peeling's
//! layer) with the opaque surfaces, its reflection added as R / opacity so that the composition
//! by opacity keeps it whole; the glass the forward transparency pass drew, after that pass, from
//! a camera ray that finds the nearest pane (`GLASS_LAYER`; traced tiers only). Refraction is
//! unchanged.
//!
//! No pass runs while no material, nor any decal material that blends roughness, is smoother
//! than the cut-off (found again only when a material changes): a scene without smooth surfaces
//! pays nothing, not even the forward pipelines' ids prepass.

use ash::vk;
use gpu_allocator::MemoryLocation;

use crate::RenderError;
use crate::decals::{DecalFrame, declare_decal_reads};
use crate::gpu::device::{GpuContext, Tier};
use crate::gpu::memory::Buffer;
use crate::gpu::memory::Retired;
use crate::gpu::pipeline::ScenePush;
use crate::gpu::pipeline::ShadeVariants;
use crate::gpu::pipeline::{HitGroup, LazyPipeline, RayTracingDesc, RayTracingPipeline, create_compute_specialized};
use crate::gpu::shaders;
use crate::graph::pyramid::{dispatch_pyramid, hiz_levels, hiz_words};
use crate::graph::readback::StatsReadback;
use crate::graph::targets::Surface;
use crate::graph::targets::{
    DEPTH, GBUFFER_ALBEDO, GBUFFER_LAYERS, GBUFFER_MATERIAL, GBUFFER_NORMAL, HDR, REFLECTION, REFLECTION_ADDED, REFLECTION_RAYS,
    REFLECTION_WEIGHT, VISIBILITY,
};
use crate::graph::{BufferUse, Frame, FrameGraph, ImageUse, PassKind, ResourceId};
use crate::layout::{DECAL_ROUGHNESS, REFLECT_DECALS, REFLECT_HALF_RES, REFLECT_ON, REFLECT_SCREEN_SPACE, REFLECTION_STATS};
use crate::lights::LightFrame;
use crate::scene::SceneMirror;
use crate::scene::gpu::GpuScene;
use crate::settings::{DebugView, FrameSettings, ReflectionMode};
use crate::stats::FrameCounters;

/// The reflection rays' ray-generation shaders on the ray-tracing-pipeline tier: one for each
/// surface and way of applying the primary surface's decals (G-buffer: plain, decal buffer;
/// visibility ids: plain, decal buffer, cluster lists), then the nearest glass's.
const RAYGENS: [&[u8]; 6] = [
    shaders::REFLECTIONS_RGEN_GBUFFER,
    shaders::REFLECTIONS_RGEN_GBUFFER_DECAL_BUFFER,
    shaders::REFLECTIONS_RGEN,
    shaders::REFLECTIONS_RGEN_DECAL_BUFFER,
    shaders::REFLECTIONS_RGEN_CLUSTERED_DECALS,
    shaders::REFLECTIONS_RGEN_GLASS_LAYER,
];

pub use crate::stats::ReflectionStats;

/// This frame's reflections, decided before the lighting record is written.
#[derive(Clone, Copy, Debug, Default)]
pub struct ReflectionFrame {
    /// `REFLECT_*` flags for the lighting record (0 when off).
    pub flags: u32,
    /// The roughness cut-off.
    pub cutoff: f32,
    /// The statistics buffer's address (0 when off).
    pub stats: u64,
    /// Screen-space reflections' depth pyramid's address (0 when they do not run).
    pub hiz: u64,
}

impl ReflectionFrame {
    /// Whether the passes run (the mode applies on this device, the debug view shows them and
    /// some material is smooth enough).
    pub fn on(&self) -> bool {
        self.flags != 0
    }

    /// Whether they trace rays (so the lights' and decals' structures must be built).
    pub fn traced(&self) -> bool {
        self.on() && self.flags & REFLECT_SCREEN_SPACE == 0
    }
}

/// The reflection passes and their statistics.
pub struct Reflections {
    /// The ray pass over the G-buffer, in each way it applies the primary surface's decals.
    gbuffer: Option<ShadeVariants>,
    /// The ray pass over the visibility ids.
    visibility: Option<ShadeVariants>,
    /// Screen-space rays, over the G-buffer and over the visibility ids.
    screen: [ShadeVariants; 2],
    /// The ray passes on the ray-tracing-pipeline tier, a pipeline for each of [`RAYGENS`],
    /// each created the first frame that traces with it ([`Reflections::ray_pipeline`]).
    rays: [Option<RayTracingPipeline>; RAYGENS.len()],
    /// Whether this device traces reflections with [`Reflections::rays`] (the
    /// ray-tracing-pipeline tier).
    rays_possible: bool,
    /// The shared pipeline layout, for creating `rays`.
    layout: vk::PipelineLayout,
    /// The pipelines below are made the first frame that runs them ([`LazyPipeline`]).
    resolve: LazyPipeline,
    /// The resolve into its own target, before the shading pass (MSAA: [`Reflections::record_before_shading`]).
    resolve_separate: LazyPipeline,
    /// The ray pass over the nearest glass on the ray-query tier, and the resolve for it.
    glass: Option<LazyPipeline>,
    resolve_glass: LazyPipeline,
    stats: Buffer,
    stats_res: ResourceId,
    readback: StatsReadback,
    latest: ReflectionStats,
    /// [`ReflectionStats::smoothest`], kept until a material changes.
    smoothest: Option<f32>,
    /// Screen-space reflections' nearest-depth pyramid, its pass and the view size it is for.
    hiz: LazyPipeline,
    pyramid: Option<(Buffer, vk::Extent2D)>,
    hiz_res: ResourceId,
}

/// The smallest roughness factor of the live materials and of the live decal materials that
/// blend roughness (a texture can only make a surface rougher than its factor; a decal can make
/// it smoother): 1 when there is none.
fn smoothest(mirror: &SceneMirror) -> f32 {
    let materials = (0..mirror.materials.slot_count()).filter_map(|slot| mirror.materials.get(slot)).map(|m| m.roughness);
    let decals = (0..mirror.decal_materials.slot_count())
        .filter_map(|slot| mirror.decal_materials.get(slot))
        .filter(|m| m.flags & DECAL_ROUGHNESS != 0)
        .map(|m| m.roughness);
    materials.chain(decals).fold(1.0, f32::min)
}

impl Reflections {
    /// Creates the passes (the ray passes only on the ray-query tier) and the statistics
    /// buffers.
    pub fn new(ctx: &GpuContext, graph: &mut FrameGraph, layout: vk::PipelineLayout) -> Result<Self, RenderError> {
        let compute =
            move |ctx: &GpuContext, spirv: &'static [u8], spec| create_compute_specialized(ctx, layout, "reflection rays", spirv, spec);
        let (gbuffer, visibility) = if ctx.tier == Tier::RayQuery {
            (
                Some(ShadeVariants::new(
                    ctx,
                    [
                        shaders::REFLECTIONS_COMP_GBUFFER,
                        shaders::REFLECTIONS_COMP_GBUFFER_RAY_QUERY_DECALS,
                        shaders::REFLECTIONS_COMP_GBUFFER_DECAL_BUFFER,
                    ],
                    compute,
                )),
                Some(
                    ShadeVariants::new(
                        ctx,
                        [shaders::REFLECTIONS_COMP, shaders::REFLECTIONS_COMP_RAY_QUERY_DECALS, shaders::REFLECTIONS_COMP_DECAL_BUFFER],
                        compute,
                    )
                    .with_clustered(shaders::REFLECTIONS_COMP_CLUSTERED_DECALS, compute),
                ),
            )
        } else {
            (None, None)
        };
        let screen = move |ctx: &GpuContext, spirv: &'static [u8], spec| {
            create_compute_specialized(ctx, layout, "reflection rays (screen space)", spirv, spec)
        };
        let screen = [
            ShadeVariants::new(
                ctx,
                [
                    shaders::SCREEN_REFLECTIONS_COMP_GBUFFER,
                    shaders::SCREEN_REFLECTIONS_COMP_GBUFFER_RAY_QUERY_DECALS,
                    shaders::SCREEN_REFLECTIONS_COMP_GBUFFER_DECAL_BUFFER,
                ],
                screen,
            ),
            ShadeVariants::new(
                ctx,
                [
                    shaders::SCREEN_REFLECTIONS_COMP,
                    shaders::SCREEN_REFLECTIONS_COMP_RAY_QUERY_DECALS,
                    shaders::SCREEN_REFLECTIONS_COMP_DECAL_BUFFER,
                ],
                screen,
            )
            .with_clustered(shaders::SCREEN_REFLECTIONS_COMP_CLUSTERED_DECALS, screen),
        ];
        Ok(Self {
            gbuffer,
            visibility,
            screen,
            rays: Default::default(),
            rays_possible: ctx.tier != Tier::RayQuery && ctx.ray_support().ray_pipeline,
            layout,
            resolve: LazyPipeline::compute(layout, "reflection resolve", shaders::REFLECTIONS_RESOLVE_COMP),
            resolve_separate: LazyPipeline::compute(layout, "reflection resolve (separate)", shaders::REFLECTIONS_RESOLVE_COMP_SEPARATE),
            glass: (ctx.tier == Tier::RayQuery)
                .then(|| LazyPipeline::compute(layout, "reflection rays", shaders::REFLECTIONS_COMP_GLASS_LAYER)),
            resolve_glass: LazyPipeline::compute(layout, "glass reflection resolve", shaders::REFLECTIONS_RESOLVE_COMP_GLASS_LAYER),
            stats: Buffer::new(
                ctx,
                "reflection statistics",
                REFLECTION_STATS as u64 * 4,
                crate::gpu::memory::GPU_WRITTEN,
                MemoryLocation::GpuOnly,
            )?,
            stats_res: graph.resource("reflection statistics"),
            readback: StatsReadback::new(ctx, graph, "reflection statistics readback", REFLECTION_STATS as u64 * 4)?,
            latest: ReflectionStats { measured_frame: u64::MAX, ..Default::default() },
            smoothest: None,
            hiz: LazyPipeline::compute(layout, "reflection depth pyramid", shaders::REFLECTION_HIZ_COMP),
            pyramid: None,
            hiz_res: graph.resource("reflection depth pyramid"),
        })
    }

    /// The ray-tracing pipeline of the reflection rays with ray-generation shader `raygen` (of
    /// [`RAYGENS`]), created the first time a frame traces with it on a device without ray
    /// queries. A pipeline for each: lavapipe compiles a pipeline's every ray-generation shader
    /// into one shader, each of their `traceRayEXT`s with every hit group's any-hit and
    /// intersection shaders inlined, and with the six in one pipeline its LLVM was still compiling
    /// after 7 minutes on the 2-core machine (64 s for the one a frame needed, apart).
    fn ray_pipeline(ctx: &GpuContext, layout: vk::PipelineLayout, raygen: usize) -> Result<RayTracingPipeline, RenderError> {
        let desc = RayTracingDesc {
            name: "reflection rays (ray-tracing pipeline)",
            raygen: &[RAYGENS[raygen]],
            misses: &[
                shaders::REFLECTIONS_RMISS,
                shaders::DECAL_PASS_RMISS,
                shaders::LIGHT_RAYS_RMISS_SHADOWED_LIGHTS,
                shaders::SHADOWS_RMISS,
            ],
            hit_groups: &[
                HitGroup { closest_hit: Some(shaders::REFLECTIONS_RCHIT), any_hit: Some(shaders::REFLECTIONS_RAHIT), intersection: None },
                HitGroup::any_hit(shaders::DECAL_PASS_RAHIT, Some(shaders::DECAL_PASS_RINT)),
                HitGroup::any_hit(shaders::LIGHT_RAYS_RAHIT_SHADOWED_LIGHTS, Some(shaders::LIGHT_RAYS_RINT)),
                HitGroup::any_hit(shaders::SHADOWS_RAHIT, None),
                HitGroup::any_hit(shaders::DECAL_PASS_RAHIT_COLLECT, Some(shaders::DECAL_PASS_RINT)),
            ],
        };
        RayTracingPipeline::new(ctx, layout, &desc)
    }

    /// Decides this frame's reflections from `s` (the mode this device runs; none in debug views
    /// other than the lit image and the reflection rays, nor when no material is smoother than
    /// the cut-off: no pass, no ids prepass), reads back the statistics of the frame that last
    /// used this frame's slot into the frame's `counters`, and clears this frame's.
    pub fn prepare(
        &mut self,
        f: &mut Frame,
        s: &FrameSettings,
        mirror: &mut SceneMirror,
        counters: &mut FrameCounters,
    ) -> Result<ReflectionFrame, RenderError> {
        // Recomputed only when a material or decal material changed (before the upload takes
        // the change marks).
        if self.smoothest.is_none() || mirror.materials.dirty_count() > 0 || mirror.decal_materials.dirty_count() > 0 {
            self.smoothest = Some(smoothest(mirror));
        }
        let smoothest = self.smoothest.unwrap_or(1.0);
        if let Some((frame, words)) = self.readback.take(f) {
            let w = |i: usize| words[i] as u64;
            self.latest = ReflectionStats {
                measured_frame: frame,
                pixels: w(0),
                rays: w(1),
                hits: w(2),
                decals_tested: w(3),
                lights_found: w(4),
                through_glass: w(5),
                ..self.latest
            };
        }
        let applied = s.reflections.mode.effective(f.ctx.ray_support());
        let shown = matches!(s.debug_view, DebugView::Lit | DebugView::Reflections);
        let cutoff = s.reflections.roughness_cutoff.clamp(0.0, 1.0);
        let on = applied != ReflectionMode::Off && shown && smoothest < cutoff;
        let half = on && s.reflections.half_resolution;
        // Decals at hit points are looked up by traced rays; screen-space ones see what is on screen.
        let decals = on && s.reflections.decals_at_hits && applied == ReflectionMode::RayTraced;
        counters.reflections = ReflectionStats {
            applied: if on { applied } else { ReflectionMode::Off },
            half_resolution: half,
            decals_at_hits: decals,
            smoothest,
            ..self.latest
        };
        // The screen-space rays' depth pyramid, at the view's size, only while they run.
        let extent = f.graph.extent();
        if on && applied == ReflectionMode::ScreenSpace {
            if self.pyramid.as_ref().is_none_or(|(_, e)| *e != extent) {
                let bytes = hiz_words(extent, hiz_levels(extent)) * 4;
                let usage = vk::BufferUsageFlags::STORAGE_BUFFER | vk::BufferUsageFlags::SHADER_DEVICE_ADDRESS;
                let buffer = Buffer::new(f.ctx, "reflection depth pyramid", bytes, usage, MemoryLocation::GpuOnly)?;
                if let Some((old, _)) = self.pyramid.replace((buffer, extent)) {
                    f.upload.graveyard.bury(f.upload.frame_value, Retired::Buffer(old));
                }
            }
        } else if let Some((old, _)) = self.pyramid.take() {
            f.upload.graveyard.bury(f.upload.frame_value, Retired::Buffer(old));
        }
        if !on {
            return Ok(ReflectionFrame::default());
        }
        let (stats, stats_res) = (self.stats.raw, self.stats_res);
        f.pass("reflection_stats_clear", PassKind::Transfer).write(stats_res, BufferUse::Transfer).record(|p| {
            p.cmd.fill_buffer(stats, 0, vk::WHOLE_SIZE, 0);
        })?;
        Ok(ReflectionFrame {
            flags: REFLECT_ON
                | if half { REFLECT_HALF_RES } else { 0 }
                | if decals { REFLECT_DECALS } else { 0 }
                | if applied == ReflectionMode::ScreenSpace { REFLECT_SCREEN_SPACE } else { 0 },
            cutoff,
            stats: self.stats.address,
            hiz: self.pyramid.as_ref().map_or(0, |(b, _)| b.address),
        })
    }

    /// Traces and resolves this frame's reflections into the HDR target, over the surfaces of
    /// `source` with the frame's `decals` (the primary surface's, and the TLAS the hit points
    /// search) and `lights`; nothing when [`LightFrame::reflections`] says they are off.
    pub fn record(
        &mut self,
        f: &mut Frame,
        scene: &GpuScene,
        source: Surface,
        decals: &DecalFrame,
        lights: &LightFrame,
    ) -> Result<(), RenderError> {
        self.layer(f, scene, Some(source), decals, lights, false)
    }

    /// Whether, under MSAA, this frame's reflections are traced and resolved before the shading
    /// pass, into a target of their own that the shading pass adds to each sample from the pixel
    /// of the sample's surface (`crate::msaa`): traced reflections in the lit view.
    /// Screen-space reflections read the lit image and the reflections' debug view replaces
    /// it, so both stay after the resolve, per pixel.
    pub fn before_shading(lights: &LightFrame, view: DebugView) -> bool {
        lights.traced_reflections() && view == DebugView::Lit
    }

    /// [`Reflections::record`] before the shading pass, into the reflections' resolved term
    /// (`REFLECTION_ADDED`) instead of the HDR target, when [`Reflections::before_shading`].
    pub fn record_before_shading(
        &mut self,
        f: &mut Frame,
        scene: &GpuScene,
        source: Surface,
        decals: &DecalFrame,
        lights: &LightFrame,
    ) -> Result<(), RenderError> {
        self.layer(f, scene, Some(source), decals, lights, true)
    }

    /// The same for the nearest glass the forward transparency pass drew (`glass`: blended
    /// instances were drawn), found by a camera ray: traced reflections only (screen space has
    /// no glass surface to start from), and not where the deferred G-buffer interlaces glass
    /// (its glass rows reflected with the opaque surfaces).
    pub fn record_glass(
        &mut self,
        f: &mut Frame,
        scene: &GpuScene,
        decals: &DecalFrame,
        lights: &LightFrame,
        glass: bool,
    ) -> Result<(), RenderError> {
        if !glass || lights.interlaced() || !lights.traced_reflections() {
            return Ok(());
        }
        self.layer(f, scene, None, decals, lights, false)
    }

    /// Copies the statistics for the CPU, after every reflection pass of the frame.
    pub fn finish(&mut self, f: &mut Frame, lights: &LightFrame) -> Result<(), RenderError> {
        if !lights.reflections() {
            return Ok(());
        }
        self.readback.record(f, "reflection_statistics", self.stats_res, self.stats.raw)
    }

    /// The ray and resolve passes over `source`'s surfaces, or the nearest glass (`None`); the
    /// resolve adds to the HDR target, or (`separate`) stores the term apart.
    fn layer(
        &mut self,
        f: &mut Frame,
        scene: &GpuScene,
        source: Option<Surface>,
        decals: &DecalFrame,
        lights: &LightFrame,
        separate: bool,
    ) -> Result<(), RenderError> {
        if !lights.reflections() {
            return Ok(());
        }
        // The forward pipelines' prepass writes ids whenever reflections run: the reflections
        // rebuild their surfaces from them, never from depth alone (the `Depth` arms below are
        // never taken).
        if source == Some(Surface::Depth) {
            return Err(RenderError::Other("reflections need the G-buffer or the visibility ids, not depth alone".into()));
        }
        let screen = !lights.traced_reflections();
        let ctx = f.ctx;
        let compute = match source {
            Some(source) if screen => Some(self.screen[source as usize].pick(ctx, decals.variant(), lights.shading(false))?),
            Some(Surface::GBuffer) => self.gbuffer.as_ref().map(|v| v.pick(ctx, decals.variant(), lights.shading(false))).transpose()?,
            Some(Surface::Visibility | Surface::Depth) => {
                self.visibility.as_ref().map(|v| v.pick(ctx, decals.variant(), lights.shading(false))).transpose()?
            }
            None => self.glass.as_ref().map(|g| g.get(ctx)).transpose()?,
        };
        // The ray-generation shader for this surface and decal method (of `RAYGENS`).
        let raygen = match source {
            Some(Surface::GBuffer) => usize::from(decals.buffered()),
            Some(Surface::Visibility) if decals.buffered() => 3,
            Some(Surface::Visibility) if decals.clusters_in_shading() => 4,
            Some(Surface::Visibility | Surface::Depth) => 2,
            None => 5,
        };
        if compute.is_none() && self.rays_possible && self.rays[raygen].is_none() {
            self.rays[raygen] = Some(Self::ray_pipeline(ctx, self.layout, raygen)?);
        }
        let kind = match (compute, &self.rays[raygen]) {
            (Some(_), _) => PassKind::Compute,
            (None, Some(_)) => PassKind::RayTracing,
            (None, None) => return Ok(()),
        };
        let name = if source.is_some() { "reflection_rays" } else { "glass_reflection_rays" };
        if let Some((_, extent)) = self.pyramid.as_ref().filter(|_| screen && source.is_some()) {
            let (extent, hiz, hiz_res) = (*extent, self.hiz.get(ctx)?, self.hiz_res);
            f.pass("reflection_depth_pyramid", PassKind::Compute)
                .sample(&DEPTH)
                .reads(scene.res.shaded())
                .write(hiz_res, BufferUse::Storage)
                .record(|p| {
                    dispatch_pyramid(p, extent, hiz_levels(extent), |p, level| {
                        p.bind(vk::PipelineBindPoint::COMPUTE, hiz, &ScenePush { texture_index: level, ..p.push })
                    })
                })?;
        }
        let pass = f.pass(name, kind).sample(&DEPTH).reads(scene.res.shaded()).read(scene.res.meshes, BufferUse::Storage);
        let pass = match source {
            Some(Surface::GBuffer) => {
                pass.sample(&GBUFFER_ALBEDO).sample(&GBUFFER_NORMAL).sample(&GBUFFER_MATERIAL).sample(&GBUFFER_LAYERS)
            }
            Some(Surface::Visibility | Surface::Depth) => pass.sample(&VISIBILITY),
            None => pass,
        };
        // Screen-space rays see the lit image; traced ones the structures.
        let pass = if screen { pass.sample(&HDR).read(self.hiz_res, BufferUse::Storage) } else { pass };
        let (decals_at_hits, scene_accel, light_boxes) =
            if screen { (None, None, None) } else { (decals.at_hits, lights.scene_accel, lights.light_boxes) };
        let accel = |ids: Option<[ResourceId; 2]>| ids.into_iter().flatten().map(|a| (a, BufferUse::Accel));
        let half = lights.reflection_flags & REFLECT_HALF_RES != 0;
        let rays = self.rays[raygen].as_ref();
        let pass = if source.is_some() { declare_decal_reads(pass, decals) } else { pass };
        pass.reads(accel(decals_at_hits))
            .reads(decals_at_hits.map(|_| decals.ring_reads()).into_iter().flatten())
            .reads(lights.environment_reads())
            .reads(accel(scene_accel))
            .reads(accel(light_boxes.map(|[tlas, blas, _]| [tlas, blas])))
            .reads(light_boxes.map(|[_, _, boxes]| (boxes, BufferUse::Storage)))
            .image(&REFLECTION, ImageUse::StorageWrite)
            .image(&REFLECTION_WEIGHT, ImageUse::StorageWrite)
            .image(&REFLECTION_RAYS, ImageUse::StorageWrite)
            .record(|p| {
                let side = if half { 2 } else { 1 };
                let cells = vk::Extent2D { width: p.extent.width.div_ceil(side), height: p.extent.height.div_ceil(side) };
                if let Some(pipeline) = compute {
                    p.bind(vk::PipelineBindPoint::COMPUTE, pipeline, &p.push);
                    p.cmd.dispatch(cells.width.div_ceil(8), cells.height.div_ceil(8), 1);
                } else if let Some(rays) = rays {
                    p.bind(vk::PipelineBindPoint::RAY_TRACING_KHR, rays.pipeline, &p.push);
                    rays.trace(p.cmd, 0, cells);
                }
            })?;
        let resolve = match (source, separate) {
            (None, _) => &self.resolve_glass,
            (Some(_), true) => &self.resolve_separate,
            (Some(_), false) => &self.resolve,
        }
        .get(ctx)?;
        f.pass(if source.is_some() { "reflection_resolve" } else { "glass_reflection_resolve" }, PassKind::Compute)
            .sample(&DEPTH)
            .reads(scene.res.shaded())
            .image(&REFLECTION, ImageUse::StorageRead)
            .image(&REFLECTION_WEIGHT, ImageUse::StorageRead)
            .image(&REFLECTION_RAYS, ImageUse::StorageRead)
            .write(self.stats_res, BufferUse::Storage)
            .image(if separate { &REFLECTION_ADDED } else { &HDR }, ImageUse::StorageWrite)
            .record(|p| {
                p.bind(vk::PipelineBindPoint::COMPUTE, resolve, &p.push);
                p.cmd.dispatch(p.extent.width.div_ceil(8), p.extent.height.div_ceil(8), 1);
            })
    }

    /// Destroys the pipelines and buffers; the GPU must be idle.
    pub fn destroy(self, ctx: &GpuContext) {
        for v in [self.gbuffer, self.visibility].into_iter().flatten().chain(self.screen) {
            v.destroy(ctx);
        }
        for r in self.rays.into_iter().flatten() {
            r.destroy(ctx);
        }
        for p in [self.resolve, self.resolve_separate, self.resolve_glass, self.hiz].into_iter().chain(self.glass) {
            p.destroy(ctx);
        }
        if let Some((b, _)) = self.pyramid {
            b.destroy(ctx);
        }
        self.stats.destroy(ctx);
        self.readback.destroy(ctx);
    }
}
