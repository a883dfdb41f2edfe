//! Lights on the renderer's side: which lights each pixel loops over (every light, its tile's
//! after tiled light culling, [`tiles`], or those a zero-length ray finds, [`ray_query`]), and
//! the lighting record, which names what the frame function planned before: the scene's
//! acceleration structures (`crate::accel`), the shadow method (`crate::shadows`, which then
//! plans its passes from this frame's [`LightFrame`]), the ambient occlusion (`crate::occlusion`),
//! the reflections and the environment. The light records themselves live in the scene's
//! tables, kept by change detection, and the shading math in `shaders/include/lighting.glsl`
//! and `shading.glsl` (area lights' in `area_lights.glsl`, with the fitted table [`ltc`]). Seed
//! 001 §4.2 (tiled light culling), seed 000 §5.2.5 (ray-query lights).
//!
//! Each frame function calls, in order: [`Lighting::prepare`] before the scene's upload (it sizes
//! the buffers and writes the lighting record the shaders find them through), [`Lighting::build`]
//! after it (the ray-query lights' acceleration structures), and [`Lighting::record`] once the
//! frame's depth exists (light culling; the frame function records the shadow pass after it).
//! The shading passes then declare [`declare_light_reads`].

pub mod ltc;
pub mod ray_query;
pub mod sampling;
pub mod tiles;

use ash::vk;

use crate::RenderError;
use crate::accel::SceneAccelFrame;
use crate::environment::EnvironmentFrame;
use crate::gpu::device::GpuContext;
use crate::gpu::pipeline::Specialization;
use crate::graph::targets::{OCCLUSION, SHADOW_DEBUG, SHADOW_RATIO};
use crate::graph::{BufferUse, Frame, FrameGraph, ImageUse, PassBuilder, ResourceId};
use crate::layout::{
    AMBIENT_OCCLUSION, COLOURED_SHADOWS, GLASS_SHADOWS, GpuLighting, INTERLACED, LIGHT_CULL_AABB, LIGHT_CULL_DEPTH_MASK, LIGHTS_ALL,
    LIGHTS_RAY_QUERY, LIGHTS_TILED, REFLECT_SCREEN_SPACE, REFRACTION, SHADOW_DEBUG as SHADOW_DEBUG_FLAG, SHADOW_NORMALS_IMPROVED,
    SHADOW_RAY_CULLING, SHADOWS_TRACED, STAGED_LIGHTS_CHUNK,
};
use crate::occlusion::OcclusionFrame;
use crate::reflections::ReflectionFrame;
use crate::scene::SceneMirror;
use crate::scene::gpu::GpuScene;
use crate::settings::{DepthNormals, DirectLight, FrameSettings, LightMethod, ShadowMethod, TransparencyMethod};
use crate::stats::FrameCounters;
use ray_query::{RayQueryLightFrame, RayQueryLights};
use tiles::{LightTiles, TileFrame, TileRequest};

/// The renderer's lighting state: light culling and the ray-query lights.
pub struct Lighting {
    /// Tiled light culling and the shadow words.
    pub tiles: LightTiles,
    /// Ray-query lights' boxes and structures (devices with acceleration structures).
    pub ray_query: Option<RayQueryLights>,
    /// The directional lights sampling pixels trace apart, found again when lights change.
    search: sampling::LightSearch,
}

/// What this frame does with lights.
#[derive(Clone, Debug)]
pub struct LightFrame {
    /// The light method applied.
    pub method: LightMethod,
    /// How shadows are made this frame.
    pub shadows: ShadowMethod,
    /// The light tile buffer, when lights are tiled.
    pub light_tiles: Option<ResourceId>,
    /// The shadow words, when shadows are traced.
    pub shadow_bits: Option<ResourceId>,
    /// Whether the shadow pass writes (and shading reads) the shadow debug image.
    pub debug: bool,
    /// Pixels whose list holds more lights than this sample their shadows ([`sampling`];
    /// `u32::MAX`: none does).
    pub sampled_lights_above: u32,
    /// How the traced shadows of light lists were made (`None`: none were).
    pub direct_light: Option<DirectLight>,
    /// Whether light culling tested the tiles' depth masks ([`crate::settings::LightSettings::cull_depth_mask`],
    /// off in frames that light particles from the lists).
    pub depth_mask: bool,
    /// With ray-query lights: the lights' TLAS, BLAS and box buffer (its unbounded-light list).
    pub light_accel: Option<[ResourceId; 3]>,
    /// When shading traces shadow rays itself (ray-query lights with shadows, on either
    /// ray-tracing tier; on the ray-tracing-pipeline tier it also picks the lighting pipeline
    /// with shadow rays): the scene's TLAS, BLAS and meshes (alpha-masked hits read their
    /// texture coordinates).
    pub inline_shadows: Option<[ResourceId; 3]>,
    /// The `REFLECT_*` flags of the lighting record (0 when off).
    pub reflection_flags: u32,
    /// The scene's TLAS and BLAS, once built.
    pub scene_accel: Option<[ResourceId; 2]>,
    /// The ray-query lights' TLAS, BLAS and box buffer, when they are built this frame (for
    /// ray-query lights, or for the reflection rays' hit points).
    pub light_boxes: Option<[ResourceId; 3]>,
    /// The environment's images and record, when an environment lights the frame
    /// (`crate::environment`): every shading pass samples them.
    pub environment: Option<[ResourceId; 2]>,
    /// How ambient light is occluded this frame.
    pub occlusion: OcclusionFrame,
    /// Whether the shadow pass runs again over the transparent depth (the glass layer: blended
    /// surfaces drawn by the forward transparency pass, with tiled lights).
    pub glass_layer: bool,
    /// Whether a light of the scene is an area light: the shading passes then use their
    /// pipelines with the area lights' code (`crate::gpu::pipeline::Specialization`).
    pub area_lights: bool,
    interlaced: bool,
    /// The scene's live lights: no list is longer.
    live_lights: u32,
    /// Whether a shading pass was specialized to stage its lists ([`LightFrame::shading`]).
    staged: std::cell::Cell<bool>,
    tiles: TileFrame,
    ray_query: RayQueryLightFrame,
}

impl LightFrame {
    /// What a pass that lights surfaces reads of the environment (nothing without one).
    pub fn environment_reads(&self) -> impl Iterator<Item = (ResourceId, BufferUse)> {
        crate::environment::environment_reads(self.environment)
    }

    /// Whether some pixels may sample their lights' shadows this frame: the shadow pass writes
    /// the sampled shadows, the denoiser runs and shading reads its ratio.
    pub fn samples(&self) -> bool {
        self.sampled_lights_above != u32::MAX
    }

    /// How a shading pass's pipeline is specialized this frame: with the area lights' code when
    /// the scene has an area light, and, for a pass in `compute`, staging its unshadowed lists
    /// (`Specialization::staged_lights` says why only then) when a list can be longer than one
    /// chunk ([`STAGED_LIGHTS_CHUNK`]) and lists are unshadowed: pixels sample their shadows,
    /// or no shadows are made. [`LightFrame::staged`] then says so.
    pub fn shading(&self, compute: bool) -> Specialization {
        let unshadowed = self.samples() || self.shadows == ShadowMethod::None;
        let staged_lights = compute && unshadowed && self.method != LightMethod::RayQuery && self.live_lights > STAGED_LIGHTS_CHUNK;
        self.staged.set(self.staged.get() || staged_lights);
        Specialization { area_lights: self.area_lights, staged_lights }
    }

    /// Whether a shading pass of this frame staged its lights ([`LightFrame::shading`]).
    pub fn staged(&self) -> bool {
        self.staged.get()
    }

    /// Whether the reflection pass runs this frame (`crate::reflections`: asked for, and the
    /// scene's TLAS exists to trace against when it traces).
    pub fn reflections(&self) -> bool {
        self.reflection_flags != 0
    }

    /// Whether it traces rays (rather than marching the depth buffer in screen space).
    pub fn traced_reflections(&self) -> bool {
        self.reflections() && self.reflection_flags & REFLECT_SCREEN_SPACE == 0
    }

    /// Whether light culling or the shadow pass's glass layer reads the transparent depth this
    /// frame (blended instances drawn by the forward transparency pass, with tiled lights or
    /// shadows), so the transparency depth pass must run before them.
    pub fn reads_transparent_depth(&self) -> bool {
        self.tiles.transparent || self.glass_shadows()
    }

    /// Whether the forward transparency pass shades the nearest blended surface with its own
    /// shadows: the shadow pass ran again over the transparent depth (its glass layer).
    pub fn glass_shadows(&self) -> bool {
        self.glass_layer && self.shadow_bits.is_some()
    }

    /// Whether the deferred G-buffer interlaces blended surfaces this frame (the deferred
    /// pipeline, interlaced transparency and blended instances to draw): passes that rebuild
    /// surfaces from depth then step two rows.
    pub fn interlaced(&self) -> bool {
        self.interlaced
    }
}

impl Lighting {
    /// Creates the passes.
    pub fn new(ctx: &GpuContext, graph: &mut FrameGraph, layout: vk::PipelineLayout) -> Result<Self, RenderError> {
        Ok(Self {
            tiles: LightTiles::new(ctx, graph, layout)?,
            ray_query: RayQueryLights::new(ctx, graph, layout)?,
            search: Default::default(),
        })
    }

    /// Sizes this frame's buffers and sets the lighting record, before the scene's upload. The
    /// frame function hands in what it planned before: the scene's structures (`accel`), this
    /// device's shadow method (`device_shadows`, `crate::shadows`), the ambient occlusion, the
    /// reflections, the environment, and whether particles are lit this frame (`particles`).
    #[allow(clippy::too_many_arguments)]
    pub fn prepare(
        &mut self,
        f: &mut Frame,
        scene: &mut GpuScene,
        mirror: &mut SceneMirror,
        s: &FrameSettings,
        accel: &SceneAccelFrame,
        device_shadows: ShadowMethod,
        occlusion: OcclusionFrame,
        reflections: &ReflectionFrame,
        environment: &EnvironmentFrame,
        particles: bool,
        counters: &mut FrameCounters,
    ) -> Result<LightFrame, RenderError> {
        let l = &s.lights;
        let method = l.method.effective(s.pipeline, f.ctx.ray_support());
        let enumerated = method == LightMethod::RayQuery;
        let ray_query = match self.ray_query.as_mut() {
            Some(r) => r.prepare(f, mirror, enumerated || reflections.traced())?,
            None => RayQueryLightFrame::default(),
        };
        let traced = match device_shadows {
            _ if !l.shadows => ShadowMethod::None,
            ShadowMethod::Maps => ShadowMethod::Maps,
            _ if l.shadow_maps => ShadowMethod::Maps,
            _ if accel.tlas_address == 0 => ShadowMethod::None, // nothing to trace against yet
            m => m,
        };
        let light_slots = mirror.lights.slot_count();
        let mut stats = counters.light_tiles;
        let glass = !mirror.transparent_order().is_empty();
        let request = TileRequest {
            method,
            tile_size: l.tile(),
            light_slots,
            proj: mirror.camera().proj,
            shadows: traced != ShadowMethod::None && !enumerated,
            transparent: glass && s.transparency.effective(s.pipeline) == TransparencyMethod::Forward,
            tints: glass && l.coloured_shadows,
        };
        let tiles = self.tiles.prepare(f, &request, &mut stats)?;
        counters.light_tiles = stats;
        // Ray-query lights trace their shadow rays while shading: a ray each on the ray-query
        // tier, one to a light drawn from those found on the ray-tracing-pipeline tier.
        let shadows = match traced {
            ShadowMethod::RayQuery | ShadowMethod::RayPipeline if enumerated => traced,
            _ if enumerated => ShadowMethod::None,
            t if tiles.shadows => t,
            _ => ShadowMethod::None,
        };
        let debug = shadows != ShadowMethod::None && !enumerated && s.debug_view.reads_shadow_debug();
        // What shading draws from: the light lists, or the lights the ray-query lights find
        // (which sample inline, with no shadow pass, denoiser or ratio: `sampled_lights_above`
        // stays `u32::MAX` for the passes, and the GPU record gets the walk's threshold).
        let sampled_gpu = sampling::sampled_lights_above(l.direct_light, shadows, mirror.lights.len() as u32);
        let sampled_lights_above = if enumerated { u32::MAX } else { sampled_gpu };
        let rays = matches!(shadows, ShadowMethod::RayQuery | ShadowMethod::RayPipeline);
        // Searched every frame (a comparison while lights are still), so that no change is missed.
        let found = self.search.find(&mirror.lights);
        let suns = if sampled_gpu == u32::MAX { sampling::Suns::default() } else { found };
        // An any-hit shader cannot trace: on the ray-tracing-pipeline tier ray-query lights always
        // draw (`shaders/include/ray_pipeline_lights.glsl`, which reads no threshold), and say so.
        let direct_light = match shadows {
            ShadowMethod::RayPipeline if enumerated => Some(DirectLight::Stochastic),
            _ => sampling::applied(sampled_gpu, rays),
        };
        let interlaced = glass && s.transparency.effective(s.pipeline).interlaces();
        let reflect = reflections.on() && (!reflections.traced() || accel.tlas_address != 0);
        // A particle is lit from the list of the tile its centre falls in, wherever it floats
        // (`shaders/particles_light.comp`): the depth mask would drop the lights of its gap.
        let depth_mask = l.cull_depth_mask && method == LightMethod::Tiled && !particles;
        let mut flags = 0;
        for (on, flag) in [
            (l.cull_aabb, LIGHT_CULL_AABB),
            (depth_mask, LIGHT_CULL_DEPTH_MASK),
            (l.shadow_ray_culling, SHADOW_RAY_CULLING),
            (l.normals == DepthNormals::Improved, SHADOW_NORMALS_IMPROVED),
            (shadows != ShadowMethod::None, SHADOWS_TRACED),
            (debug, SHADOW_DEBUG_FLAG),
            (interlaced, INTERLACED),
            (s.refraction, REFRACTION),
            (l.coloured_shadows, COLOURED_SHADOWS),
            (tiles.glass_layer && shadows != ShadowMethod::None && !enumerated, GLASS_SHADOWS),
            (occlusion.on(), AMBIENT_OCCLUSION),
        ] {
            if on {
                flags |= flag;
            }
        }
        scene.set_lighting(GpuLighting {
            light_tiles: tiles.light_tiles,
            tile_frusta: tiles.tile_frusta,
            shadow_bits: tiles.shadow_bits,
            scene_tlas: accel.tlas_address,
            light_tlas: ray_query.tlas,
            light_boxes: ray_query.boxes,
            unbounded_lights: ray_query.unbounded,
            scene_blas_table: accel.blas_table,
            scene_instances: accel.instances,
            shadow_tints: tiles.shadow_tints,
            mode: match method {
                LightMethod::All => LIGHTS_ALL,
                LightMethod::Tiled => LIGHTS_TILED,
                LightMethod::RayQuery => LIGHTS_RAY_QUERY,
            },
            tile_size: tiles.tile_size,
            tiles_x: tiles.tiles.0,
            tiles_y: tiles.tiles.1,
            list_capacity: tiles.list_capacity,
            shadow_rows: tiles.shadow_rows,
            flags,
            instance_count: mirror.instances.slot_count(),
            blas_count: accel.blas_count,
            light_box_count: ray_query.box_count,
            shadow_map_tile: 0, // the shadows' to set (`GpuScene::set_shadow_maps`)
            shadow_map_columns: 0,
            clear_color: s.clear_color.into(),
            culls: 0, // the scene's upload sets it
            reflection_stats: if reflect { reflections.stats } else { 0 },
            reflection_cutoff: reflections.cutoff,
            reflection_flags: if reflect { reflections.flags } else { 0 },
            reflection_hiz: if reflect { reflections.hiz } else { 0 },
            environment: environment.record,
            environment_job: environment.job,
            environment_rotation: environment.rotation,
            environment_intensity: environment.intensity,
            environment_flags: environment.flags,
            environment_max_level: environment.max_level,
            tonemapper: s.tonemapper as u32,
            bloom_intensity: 0.0, // the bloom pass's to set
            bloom_levels: 0,
            bloom: 0,
            occlusion_radius: s.occlusion.radius,
            occlusion_rays: s.occlusion.rays,
            // Auto-exposure's to set (`crate::exposure`).
            exposure: 0,
            exposure_compensation: 0.0,
            exposure_min_ev100: 0.0,
            exposure_max_ev100: 0.0,
            exposure_rate: 0.0,
            display_check: 0, // the renderer's to set (`GpuScene::set_display_check`)
            movers: 0,        // the upload's to set
            lod_lift: 0.0,    // the frame's to set (`GpuScene::set_lod_lift`)
            sampled_lights_above: sampled_gpu,
            particles: 0, // the particles' to set (`GpuScene::set_particles`, `set_decal_ring`)
            decal_ring: 0,
            decal_ring_boxes: 0,
            decal_ring_tlas: 0,
            decal_ring_room: 0,
            decal_ring_segment: 0,
            light_count: mirror.lights.slot_count(),
            sun_count: suns.count,
            suns: suns.slots,
        });
        let res = self.tiles.resources();
        let inline_shadows = match accel.traced {
            Some([tlas, blas]) if enumerated && shadows != ShadowMethod::None => Some([tlas, blas, scene.res.meshes]),
            _ => None,
        };
        let light_boxes = if ray_query.tlas != 0 { self.ray_query.as_ref().and_then(|r| r.reads()) } else { None };
        let light_accel = light_boxes.filter(|_| enumerated);
        Ok(LightFrame {
            method,
            shadows,
            light_tiles: (method == LightMethod::Tiled).then_some(res.tiles),
            shadow_bits: (shadows != ShadowMethod::None && !enumerated).then_some(res.shadow),
            debug,
            sampled_lights_above,
            direct_light,
            depth_mask,
            light_accel,
            inline_shadows,
            reflection_flags: if reflect { reflections.flags } else { 0 },
            scene_accel: accel.traced,
            light_boxes,
            environment: environment.reads,
            occlusion,
            glass_layer: tiles.glass_layer,
            area_lights: self.search.area_lights(),
            interlaced,
            live_lights: mirror.lights.len() as u32,
            staged: std::cell::Cell::new(false),
            tiles,
            ray_query,
        })
    }

    /// Records the ray-query lights' acceleration-structure work (after the scene's upload).
    pub fn build(&mut self, f: &mut Frame, scene: &GpuScene, frame: &LightFrame, counters: &mut FrameCounters) -> Result<(), RenderError> {
        if let Some(r) = self.ray_query.as_mut() {
            r.record(f, scene, &frame.ray_query, counters)?;
        }
        Ok(())
    }

    /// Culls the lights into tiles; needs this frame's depth (and, for a second layer of depth
    /// written since, culls anew over it: depth peeling, `crate::transparency::peeling`).
    pub fn record(&mut self, f: &mut Frame, scene: &GpuScene, frame: &LightFrame) -> Result<(), RenderError> {
        self.tiles.cull(f, scene, &frame.tiles)
    }

    /// Destroys everything; the GPU must be idle.
    pub fn destroy(self, ctx: &GpuContext) {
        self.tiles.destroy(ctx);
        if let Some(r) = self.ray_query {
            r.destroy(ctx);
        }
    }
}

/// Declares what a shading pass reads to light this frame: the light tile buffer when lights
/// are tiled, the shadow words when shadows were traced, the sampled shadows' ratio when pixels
/// may sample, the shadow debug image in its views;
/// with ray-query lights their structures and list, and the scene's when it traces shadows; the
/// environment, and the ambient occlusion when it ran.
pub fn declare_light_reads<'f, 'a>(pass: PassBuilder<'f, 'a>, frame: &LightFrame) -> PassBuilder<'f, 'a> {
    let accel = |ids: Option<[ResourceId; 3]>| ids.into_iter().flat_map(|[a, b, _]| [(a, BufferUse::Accel), (b, BufferUse::Accel)]);
    let storage = |ids: Option<[ResourceId; 3]>| ids.map(|[_, _, c]| (c, BufferUse::Storage));
    pass.reads(frame.light_tiles.map(|t| (t, BufferUse::Storage)))
        .reads(frame.shadow_bits.map(|t| (t, BufferUse::Storage)))
        .reads(accel(frame.light_accel))
        .reads(storage(frame.light_accel))
        .reads(accel(frame.inline_shadows))
        .reads(storage(frame.inline_shadows))
        .when(frame.debug, |p| p.image(&SHADOW_DEBUG, ImageUse::StorageRead))
        .when(frame.samples(), |p| p.image(&SHADOW_RATIO, ImageUse::StorageRead))
        .reads(frame.environment_reads())
        .when(frame.occlusion.on(), |p| p.image(&OCCLUSION, ImageUse::StorageRead))
}
