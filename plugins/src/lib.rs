//! The bridge between the ECS and the renderer, and the plugins a game starts from.
//!
//! - [`RenderPlugin`] adds the extraction systems (change detection into the [`RenderMirror`])
//!   and the frame system that hands the mirror to the GPU [`render::Renderer`] when one is
//!   present as [`GpuRenderer`]. Without a `GpuRenderer` everything but the GPU work still runs,
//!   which is how headless ECS tests check extraction.
//! - [`GpuPlugin`] creates that renderer: offscreen before the first frame, or, with the
//!   [`window::WindowPlugin`], for the window once it is open. Without a suitable Vulkan device
//!   the app exits with an error that says so ([`engine::app::AppExit::Error`]).
//! - [`window::WindowPlugin`] opens a winit window and runs the app's event loop
//!   (`app.run()`); [`overlay::OverlayPlugin`] draws the egui debug overlay on it.
//!
//! Quick start, headless (a window needs only `WindowPlugin` added, see [`window`]):
//!
//! ```no_run
//! use engine::prelude::*;
//! use plugins::{GpuPlugin, RenderPlugin, RenderSettings};
//!
//! let mut app = App::new();
//! app.add_plugins(RenderPlugin::new(RenderSettings { size: (320, 240), ..Default::default() }));
//! app.add_plugins(GpuPlugin::default());
//! app.world.spawn((Camera::default(), Transform::from_xyz(0.0, 1.5, 4.0).looking_at(Vec3::ZERO, Vec3::Y)));
//! app.update(); // creates the renderer, then: extract, upload what changed, record, submit
//! ```

#![forbid(unsafe_code)]

pub mod decal;
pub mod extract;
pub mod overlay;
pub mod particles;
pub mod pipelined;
pub mod raycast;
pub mod run;
pub mod validate;
pub mod window;

use std::collections::VecDeque;
use std::time::Instant;

use bevy_ecs::prelude::*;
use engine::app::{App, AppExit, Plugin, Render};
use glam::Vec3;
use render::scene::GpuMaterial;
use render::{DebugView, DecalMethod, FrameCounters, FrameSettings, PassTimes, PipelineKind, Renderer, SceneMirror};

pub use extract::MirrorSlots;

/// Render configuration; change it between frames to switch pipelines.
#[derive(Resource, Clone, Debug)]
pub struct RenderSettings {
    /// The pipeline that draws the frame.
    pub pipeline: PipelineKind,
    /// How decals are applied.
    pub decal_method: DecalMethod,
    /// Render size in pixels (sets the camera's aspect ratio).
    pub size: (u32, u32),
    /// Uniform ambient radiance.
    pub ambient: Vec3,
    /// Radiance where no geometry is drawn.
    pub clear_color: [f32; 4],
    /// What the shading pass shows (the lit image, or a debug view).
    pub debug_view: DebugView,
    /// Draw decal boxes over the image.
    pub show_decal_boxes: bool,
    /// Light culling and shadows.
    pub lights: render::LightSettings,
    /// Deferred lighting and visibility-buffer shading in compute (false: full-screen fragment
    /// passes).
    pub compute_shading: bool,
    /// Forward and Forward+ apply clustered decals in their shading pass, with no decal pass
    /// and no ids prepass ([`render::FrameSettings::decals_in_forward_shading`]: off by default,
    /// slower on the lent H100).
    pub decals_in_forward_shading: bool,
    /// Anti-aliasing of the displayed image (default none; FXAA, SMAA and temporal
    /// anti-aliasing in every pipeline, MSAA in forward and Forward+; the sandbox defaults to
    /// temporal). A mode a pipeline or device cannot run falls back with one warning
    /// ([`render::AntiAliasing::applied`]); the stats report the mode applied.
    pub aa: render::AntiAliasing,
    /// Temporal anti-aliasing's sharpening, 0 to 1 (default 0.25).
    pub taa_sharpen: f32,
    /// The display transform's tone mapper (default Khronos PBR Neutral).
    pub tonemapper: render::Tonemapper,
    /// Bloom (default on, intensity 0.04).
    pub bloom: render::BloomSettings,
    /// Ambient occlusion (default: two 1 m rays a pixel where the device traces rays, screen
    /// space where it cannot).
    pub occlusion: render::OcclusionSettings,
    /// Auto-exposure (default off: the camera's exposure).
    pub exposure: render::AutoExposure,
    /// Reflections of smooth surfaces (default: ray-traced where the device has ray queries, at
    /// full resolution, below roughness 0.4).
    pub reflections: render::ReflectionSettings,
    /// How blended (glass) surfaces are drawn: interlaced into the deferred G-buffer (the
    /// default, deferred pipeline only), forward over the opaque image, or depth-peeled into a
    /// second G-buffer (deferred only; the full-resolution reference, at about twice the cost).
    pub transparency: render::TransparencyMethod,
    /// Glass refracts the background by its material's refraction (false: straight through), in
    /// interlaced and depth-peeled transparency.
    pub refraction: bool,
    /// How instances are culled on the GPU before they are drawn (default: frustum and
    /// two-phase occlusion culling).
    pub culling: render::CullingMode,
    /// Keep culling against the view of the frame this was set in, to fly out and see what it
    /// culled (a debug option: engines call it "freeze culling").
    pub freeze_culling: bool,
    /// Levels of detail (`render::lod`): the most pixels a coarser level's error may cover on
    /// screen for an instance to draw it (default 1; 0 draws everything in full).
    pub lod_pixels: f32,
    /// Skinned meshes shorter on screen than this many pixels have their ray-tracing structure
    /// refit every other frame, not every frame (default 48; 0: every frame;
    /// `render::FrameSettings::refit_pixels`).
    pub refit_pixels: f32,
    /// Skin only the vertices of the level of detail a character will be drawn at (default on;
    /// `render::FrameSettings::skin_levels`).
    pub skin_levels: bool,
    /// Submit a command buffer again when a frame's commands are exactly those it was recorded
    /// with (default on; `render::FrameSettings::reuse_commands`).
    pub reuse_commands: bool,
    /// Record and submit each frame on a render thread while the main thread simulates the next
    /// one (default off; the sandbox's `--pipelined`). The CPU frame is then the longer of the
    /// simulation with extraction and the recording, not their sum; the renderer and the mirror
    /// are out of the world between updates, and statistics arrive an update later
    /// ([`pipelined`] says what else changes).
    pub pipelined: bool,
    /// How many mesh instances, lights and decals the scene tables hold at most.
    pub limits: SceneLimits,
    /// The distance fade of decals without their own ([`decal::Decal::distance_fade`]):
    /// `None` (the default) never fades.
    pub decal_distance_fade: Option<decal::DistanceFade>,
}

/// How many mesh instances, lights and decals the renderer's tables hold. An entity that would
/// pass its limit is not drawn: it waits, and gets a slot as soon as others are despawned, in
/// the order it arrived. Reaching a limit logs one warning (again only after everything fitted
/// in between); [`RenderStats::over_limit`] counts the entities waiting.
///
/// The defaults are [`SceneLimits::MAX`]: instances are capped at 2²⁴ because a ray-tracing
/// instance's custom index, which carries its slot, has 24 bits; lights and decals at 2²⁰ (a
/// million), where their tables, boxes and acceleration structures take about 200 and
/// 300 MiB of GPU memory. Lower limits bound memory on smaller GPUs; higher ones are clamped
/// to `MAX`. Memory that runs out before a limit is reached ends the app with an error naming
/// the frame and the allocation ([`render::RenderError::OutOfMemory`]).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct SceneLimits {
    /// Mesh instances.
    pub instances: u32,
    /// Point, spot and directional lights together.
    pub lights: u32,
    /// Decals.
    pub decals: u32,
}

impl SceneLimits {
    /// The largest limits (and the defaults).
    pub const MAX: SceneLimits = SceneLimits { instances: 1 << 24, lights: 1 << 20, decals: 1 << 20 };

    /// These limits, each at most [`SceneLimits::MAX`]'s.
    pub fn clamped(self) -> SceneLimits {
        SceneLimits {
            instances: self.instances.min(Self::MAX.instances),
            lights: self.lights.min(Self::MAX.lights),
            decals: self.decals.min(Self::MAX.decals),
        }
    }
}

impl Default for SceneLimits {
    fn default() -> Self {
        Self::MAX
    }
}

impl RenderSettings {
    /// The render size as a vector (what [`engine::camera::Camera::ray`] takes as its viewport).
    pub fn viewport(&self) -> glam::Vec2 {
        glam::Vec2::new(self.size.0 as f32, self.size.1 as f32)
    }
}

impl Default for RenderSettings {
    fn default() -> Self {
        Self {
            pipeline: PipelineKind::Forward,
            decal_method: DecalMethod::RayQuery,
            size: (1280, 720),
            ambient: Vec3::splat(0.03),
            clear_color: [0.35, 0.45, 0.6, 1.0],
            debug_view: DebugView::Lit,
            show_decal_boxes: false,
            lights: render::LightSettings::default(),
            compute_shading: true,
            decals_in_forward_shading: false,
            aa: render::AntiAliasing::None,
            taa_sharpen: 0.25,
            tonemapper: render::Tonemapper::PbrNeutral,
            bloom: render::BloomSettings::default(),
            occlusion: render::OcclusionSettings::default(),
            exposure: render::AutoExposure::default(),
            reflections: render::ReflectionSettings::default(),
            transparency: render::TransparencyMethod::Interlaced,
            refraction: true,
            culling: render::CullingMode::Occlusion,
            freeze_culling: false,
            lod_pixels: render::lod::DEFAULT_LOD_PIXELS,
            refit_pixels: render::settings::DEFAULT_REFIT_PIXELS,
            skin_levels: true,
            reuse_commands: true,
            pipelined: false,
            limits: SceneLimits::MAX,
            decal_distance_fade: None,
        }
    }
}

/// How [`GpuPlugin`] (or the window runner) creates the renderer.
#[derive(Resource, Clone, Debug, Default)]
pub struct RendererConfig(pub render::RendererSettings);

/// Present while a window runner will create the renderer for its window, so that
/// [`GpuPlugin`] does not create an offscreen one first.
#[derive(Resource, Clone, Copy, Debug, Default)]
pub struct RendererFromWindow;

/// Creates the GPU renderer ([`GpuRenderer`]) before the first frame: offscreen at
/// [`RenderSettings::size`], unless a window runner creates it for its window
/// ([`RendererFromWindow`]). A device that cannot be opened (no Vulkan, no suitable GPU) ends the
/// app with [`AppExit::Error`] naming the problem, kept also in [`RenderStats::last_error`].
/// Add it after [`RenderPlugin`].
#[derive(Clone, Debug, Default)]
pub struct GpuPlugin {
    /// Device and renderer settings.
    pub settings: render::RendererSettings,
}

impl Plugin for GpuPlugin {
    fn build(&self, app: &mut App) {
        app.insert_resource(RendererConfig(self.settings.clone()));
        app.add_systems(Render, start_offscreen_renderer.after(RenderSystems::Collect).before(RenderSystems::Extract));
    }
}

fn start_offscreen_renderer(world: &mut World) {
    if world.contains_resource::<GpuRenderer>() || world.contains_resource::<RendererFromWindow>() || world.contains_resource::<AppExit>() {
        return;
    }
    if let Err(e) = start_renderer(world, Vec::new()) {
        let message = format!("could not start the renderer: {e}");
        tracing::error!("{message}");
        world.resource_mut::<RenderStats>().last_error = Some(message.clone());
        world.insert_resource(AppExit::Error(message));
    }
}

/// Creates the renderer from [`RendererConfig`] (defaults when absent) at
/// [`RenderSettings::size`], with the instance extensions a window surface needs, and inserts it
/// as [`GpuRenderer`].
pub fn start_renderer(world: &mut World, surface_extensions: Vec<&'static std::ffi::CStr>) -> Result<(), render::RenderError> {
    let mut settings = world.get_resource::<RendererConfig>().map(|c| c.0.clone()).unwrap_or_default();
    settings.device.surface_extensions = surface_extensions;
    let (w, h) = world.get_resource::<RenderSettings>().map_or((1280, 720), |s| s.size);
    let renderer = Renderer::new(&settings, w.max(1), h.max(1))?;
    world.insert_resource(GpuRenderer(renderer));
    Ok(())
}

/// Replaces the offscreen renderer with one made from `settings` (another tier, another device,
/// validation on or off) and re-extracts the whole scene into it: the mirror starts empty and
/// every asset and every mirrored component is marked changed, so the next frame uploads
/// everything, as a first frame does. The old renderer is dropped first (it waits for its GPU
/// work). On error the app has no renderer; [`RenderStats::last_error`] holds the reason.
pub fn restart_renderer(world: &mut World, settings: render::RendererSettings) -> Result<(), render::RenderError> {
    pipelined::collect_frame(world);
    drop(world.remove_resource::<GpuRenderer>());
    world.insert_resource(RendererConfig(settings));
    reset_mirror(world);
    // The new renderer numbers its frames from 0 again: frames of the old one will never finish.
    world.resource_mut::<RenderStats>().pending.clear();
    let started = start_renderer(world, Vec::new());
    if let Err(e) = &started {
        world.resource_mut::<RenderStats>().last_error = Some(format!("could not restart the renderer: {e}"));
    }
    started
}

/// Empties the [`RenderMirror`] and marks every asset and every mirrored entity for the next
/// extraction, which then rebuilds the whole mirror as a first frame does (what a renderer
/// restart needs, and the reference that incremental extraction is tested against).
pub fn reset_mirror(world: &mut World) {
    // A frame on the render thread would bring the old mirror back.
    pipelined::collect_frame(world);
    let (mirror, slots) = fresh_mirror();
    world.insert_resource(mirror);
    world.insert_resource(slots);
    fn touch_assets<T: Send + Sync + 'static>(world: &mut World) {
        if let Some(mut assets) = world.get_resource_mut::<engine::asset::Assets<T>>() {
            assets.touch_all();
        }
    }
    // Instances, lights and decals are immutable: their change lists name them all instead.
    fn list_all<C: Component>(world: &mut World) {
        let entities: Vec<Entity> = world.query_filtered::<Entity, With<C>>().iter(world).collect();
        world.write_message_batch(entities.into_iter().map(engine::changes::Inserted::<C>::new));
    }
    touch_assets::<engine::image::Image>(world);
    touch_assets::<engine::material::Material>(world);
    touch_assets::<engine::mesh::Mesh>(world);
    touch_assets::<decal::DecalMaterial>(world);
    list_all::<engine::scene::MeshInstance>(world);
    list_all::<engine::light::PointLight>(world);
    list_all::<engine::light::SpotLight>(world);
    list_all::<engine::light::DirectionalLight>(world);
    list_all::<engine::light::RectLight>(world);
    list_all::<engine::light::DiskLight>(world);
    list_all::<decal::Decal>(world);
    list_all::<particles::ParticleEmitter>(world);
}

/// The CPU copy of the GPU scene that extraction writes.
#[derive(Resource)]
pub struct RenderMirror(pub SceneMirror);

/// The GPU renderer. Insert it to draw; leave it out for ECS-only tests.
#[derive(Resource)]
pub struct GpuRenderer(pub Renderer);

/// A window to present to. When present, frames go to the window's swapchain (with the
/// [`OverlayInput`] drawn on top) instead of the offscreen display target. Remove it and hand it
/// to [`Renderer::destroy_window_surface`] before the window closes.
#[derive(Resource)]
pub struct WindowTarget(pub render::window::WindowSurface);

/// The egui overlay for the next frame (taken by the render system).
#[derive(Resource, Default)]
pub struct OverlayInput(pub Option<render::overlay::OverlayFrame>);

/// Statistics of one frame, complete once its GPU times are known.
#[derive(Clone, Copy, Debug)]
pub struct FrameStats {
    /// Frame number, from 0.
    pub frame: u64,
    /// The pipeline that drew it.
    pub pipeline: PipelineKind,
    /// The decal method it used.
    pub decal_method: DecalMethod,
    /// Where its decal pass read each pixel's surface (`None` when no decal pass ran).
    pub decal_surface: Option<render::graph::targets::Surface>,
    /// The light method it used.
    pub light_method: render::LightMethod,
    /// How its shadows were made.
    pub shadows: render::ShadowMethod,
    /// How the traced shadows of its light lists were made (`None`: none were).
    pub direct_light: Option<render::DirectLight>,
    /// Whether its shading staged the workgroups' light lists in shared memory (compute shading
    /// of long unshadowed lists).
    pub staged_lights: bool,
    /// Whether its light culling tested the tiles' depth masks (the setting, off in frames that
    /// light particles).
    pub depth_mask: bool,
    /// How its blended surfaces were drawn (the method applied).
    pub transparency: render::TransparencyMethod,
    /// Whether glass refracted (interlaced and depth-peeled transparency refract).
    pub refraction: bool,
    /// The anti-aliasing it was displayed with.
    pub aa: render::AntiAliasing,
    /// The tone mapper of the display transform.
    pub tonemapper: render::Tonemapper,
    /// Whether bloom ran.
    pub bloom: bool,
    /// How ambient light was occluded (the method applied).
    pub occlusion: render::OcclusionMethod,
    /// Whether auto-exposure set the exposure.
    pub auto_exposure: bool,
    /// The light settings it was drawn with.
    pub lights: render::LightSettings,
    /// Render size.
    pub size: (u32, u32),
    /// Per-pass GPU milliseconds.
    pub gpu: PassTimes,
    /// CPU milliseconds in the extraction systems.
    pub cpu_extract_ms: f32,
    /// CPU milliseconds animating (sampling clips into joint transforms,
    /// [`engine::animation::AnimationStats`]) in the update that drew the frame.
    pub cpu_animate_ms: f32,
    /// CPU milliseconds propagating transforms down the hierarchy
    /// ([`engine::transform::TransformStats`]) in the update that drew the frame.
    pub cpu_propagate_ms: f32,
    /// CPU milliseconds computing skinned meshes' joint matrices
    /// ([`engine::animation::AnimationStats::skin_cpu_ms`]) in the update that drew the frame.
    pub cpu_skin_ms: f32,
    /// What animation did in the update that drew the frame: players advanced, those sampled
    /// (the [`engine::animation::AnimationBudget`] defers the rest), the longest period.
    pub animation: engine::animation::AnimationStats,
    /// CPU milliseconds uploading and recording (the submission included).
    pub cpu_record_ms: f32,
    /// Of those, CPU milliseconds in the driver's queue submission.
    pub cpu_submit_ms: f32,
    /// Of those, CPU milliseconds preparing the frame's data and writing the scene's uploads
    /// into staging memory, before the passes are recorded.
    pub cpu_prepare_ms: f32,
    /// CPU milliseconds of the whole app update that drew the frame, every schedule from its
    /// start to the frame's submission, the waits for the GPU excluded. Pipelined
    /// ([`RenderSettings::pipelined`]): the main thread's, from the update's start to the
    /// frame's hand-off to the render thread, the wait for the previous frame included (less
    /// the part of it the render thread spent waiting for the GPU); `cpu_record_ms` ran on the
    /// render thread meanwhile.
    pub cpu_frame_ms: f32,
    /// Whether the frame was recorded on the render thread ([`RenderSettings::pipelined`]).
    pub pipelined: bool,
    /// Milliseconds from the previous frame's submission to this one's (0 for the first): the
    /// time a frame takes as the game sees it, CPU, waits for the GPU and all. Pipelined, from
    /// the previous frame's collection from the render thread to this one's (as steady).
    pub wall_ms: f32,
    /// Entities its extraction visited.
    pub visited: VisitCounts,
    /// Work counters.
    pub counters: FrameCounters,
}

/// How many entities of each kind wait for room (see [`SceneLimits`]).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct OverLimitCounts {
    /// Mesh instances.
    pub instances: u64,
    /// Lights.
    pub lights: u64,
    /// Decals.
    pub decals: u64,
}

/// How many entities of each kind the last extraction visited: the changed ones only, for the
/// kinds extracted from change lists.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct VisitCounts {
    /// Mesh instances (spawned, changed, moved or retried after waiting for room).
    pub instances: u64,
    /// Lights (likewise).
    pub lights: u64,
    /// Decals (likewise).
    pub decals: u64,
    /// Skinned instances posed (their joints or they moved).
    pub poses: u64,
    /// Particle emitters inserted (spawned or edited; moves are not counted).
    pub emitters: u64,
}

/// Counters of the last frame and a queue of finished frames' statistics.
#[derive(Resource, Default)]
pub struct RenderStats {
    /// Counters of the most recent frame (also without a GPU).
    pub last: FrameCounters,
    /// Frames recorded but not yet finished on the GPU.
    pending: VecDeque<FrameStats>,
    /// Frames whose GPU times are known, oldest first. Consumers drain it; it keeps at most
    /// [`RenderStats::MAX_COMPLETED`] entries.
    pub completed: VecDeque<FrameStats>,
    /// The last error the renderer reported, if any.
    pub last_error: Option<String>,
    /// Entities waiting for room because their table is at its [`SceneLimits`] limit.
    pub over_limit: OverLimitCounts,
    /// Entities the extraction visited in the last frame.
    pub visited: VisitCounts,
    extract_started: Option<Instant>,
    extract_ms: f32,
    /// When the last frame was submitted ([`FrameStats::wall_ms`]).
    last_submitted: Option<Instant>,
    /// A fatal error stopped drawing.
    failed: bool,
    /// The offscreen size last refused (reported once).
    bad_size: Option<(u32, u32)>,
    /// Pipelined: how long this update waited for the render thread's wait for the GPU (set
    /// by the render schedule's collection each update).
    main_gpu_wait_ms: f32,
}

impl RenderStats {
    /// Completed frames kept when nobody drains them.
    pub const MAX_COMPLETED: usize = 256;
    /// The most frames kept waiting for their GPU times (far more than are ever in flight).
    pub const MAX_PENDING: usize = 16;

    /// The statistics of the frame recorded last, whether or not its GPU times are known yet
    /// (its [`FrameStats::gpu`] is empty until they are).
    pub fn latest(&self) -> Option<&FrameStats> {
        self.pending.back().or(self.completed.back())
    }

    fn complete(&mut self, frame: u64, gpu: PassTimes) {
        while let Some(front) = self.pending.front() {
            if front.frame > frame {
                break;
            }
            let mut stats = self.pending.pop_front().expect("front exists");
            if stats.frame == frame {
                stats.gpu = gpu;
                if self.completed.len() == Self::MAX_COMPLETED {
                    self.completed.pop_front();
                }
                self.completed.push_back(stats);
            }
        }
    }
}

/// System sets of the render schedule, in order.
#[derive(SystemSet, Clone, Debug, PartialEq, Eq, Hash)]
pub enum RenderSystems {
    /// Takes the frame the render thread drew back ([`pipelined::collect_frame`]; nothing when
    /// rendering is not pipelined).
    Collect,
    /// Change detection into the mirror.
    Extract,
    /// Upload, record and submit.
    Render,
}

/// Adds extraction and rendering to an app.
pub struct RenderPlugin {
    settings: RenderSettings,
}

impl RenderPlugin {
    /// A plugin with these settings.
    pub fn new(settings: RenderSettings) -> Self {
        Self { settings }
    }
}

/// An empty mirror holding only the default material, and its slot maps.
fn fresh_mirror() -> (RenderMirror, MirrorSlots) {
    let mut mirror = SceneMirror::new();
    let default_material = mirror.materials.insert(GpuMaterial::default());
    (RenderMirror(mirror), MirrorSlots::new(default_material))
}

impl Plugin for RenderPlugin {
    fn build(&self, app: &mut App) {
        let (mirror, slots) = fresh_mirror();
        app.insert_resource(self.settings.clone()).insert_resource(mirror).insert_resource(slots).insert_resource(RenderStats::default());
        app.schedule_mut(Render).configure_sets((RenderSystems::Collect, RenderSystems::Extract, RenderSystems::Render).chain());
        app.add_systems(
            Render,
            (
                begin_frame,
                extract::extract_images,
                extract::extract_materials,
                extract::extract_meshes,
                extract::extract_decal_materials,
                extract::extract_instances,
                extract::extract_poses,
                extract::extract_decals,
                particles::extract_emitters,
                extract::extract_lights,
                extract::extract_camera,
                extract::extract_environment,
                end_extract,
            )
                .chain()
                .in_set(RenderSystems::Extract),
        );
        app.add_systems(Render, render_frame.in_set(RenderSystems::Render));
        app.add_systems(Render, pipelined::collect_in_update.in_set(RenderSystems::Collect));
        app.insert_resource(engine::asset::Assets::<decal::DecalMaterial>::default());
        app.add_message::<engine::changes::Inserted<decal::Decal>>();
        app.add_message::<engine::changes::Inserted<decal::DecalReceiver>>();
        app.add_message::<engine::changes::Inserted<particles::ParticleEmitter>>();
        app.world.init_resource::<decal::DecalLifetimes>();
        app.world.init_resource::<engine::environment::Environment>();
        app.add_systems(engine::app::Update, decal::expire_decals);
        app.add_systems(engine::app::PostUpdate, sync_animation_viewport.before(engine::animation::AnimationSystems));
    }
}

/// Keeps the [`engine::animation::AnimationBudget`]'s viewport at the render size, which it
/// measures models on screen in (written only when the size changed).
fn sync_animation_viewport(settings: Res<RenderSettings>, budget: Option<ResMut<engine::animation::AnimationBudget>>) {
    if let Some(mut budget) = budget {
        let viewport = settings.viewport();
        if budget.viewport != viewport {
            budget.viewport = viewport;
        }
    }
}

fn begin_frame(mut mirror: ResMut<RenderMirror>, mut stats: ResMut<RenderStats>) {
    mirror.0.begin_frame();
    stats.extract_started = Some(Instant::now());
}

fn end_extract(mut stats: ResMut<RenderStats>, mirror: Res<RenderMirror>, renderer: Option<Res<GpuRenderer>>) {
    stats.extract_ms = stats.extract_started.take().map_or(0.0, |t| t.elapsed().as_secs_f32() * 1e3);
    // Without a GPU (headless ECS tests) these are the frame's counters. With one, the report
    // sets them (in place, later in this update; pipelined, the frame collected before
    // extraction set them already).
    if renderer.is_none() {
        stats.last = FrameCounters { records_written: mirror.0.records_written, ..FrameCounters::default() };
    }
}

/// Hands the mirror to the renderer: uploads what changed, records and submits the frame, here
/// or, with [`RenderSettings::pipelined`], on the render thread ([`pipelined`]).
fn render_frame(world: &mut World) {
    if world.resource::<RenderSettings>().pipelined {
        pipelined::hand_off_frame(world);
        return;
    }
    let Some(settings) = prepare_frame(world) else { return };
    let context = frame_context(world, false);
    let overlay = world.get_resource_mut::<OverlayInput>().and_then(|mut o| o.0.take());
    let result = world.resource_scope(|world, mut renderer: Mut<GpuRenderer>| {
        world.resource_scope(|world, mut mirror: Mut<RenderMirror>| match world.get_resource_mut::<WindowTarget>() {
            Some(mut window) => {
                let mut overlay = overlay;
                renderer.0.render_to_window(&mut mirror.0, &settings, &mut window.0, overlay.as_mut())
            }
            None => renderer.0.render(&mut mirror.0, &settings).map(Some),
        })
    });
    if let Some(exit) = file_report(&mut world.resource_mut::<RenderStats>(), result, context) {
        world.insert_resource(exit);
    }
}

/// This frame's [`FrameSettings`], once the renderer is ready for it: `None` without a
/// renderer or mirror, after a fatal error, or while the offscreen size is refused. Offscreen,
/// the render target follows [`RenderSettings::size`] (a window follows its surface); a size
/// the renderer refuses (zero, or past the device's limit) renders nothing and is reported once,
/// and the scene's changes wait in the mirror for a valid size.
fn prepare_frame(world: &mut World) -> Option<FrameSettings> {
    if world.resource::<RenderStats>().failed || !world.contains_resource::<RenderMirror>() {
        return None;
    }
    let settings = world.resource::<RenderSettings>().clone();
    let windowed = world.contains_resource::<WindowTarget>();
    let mut renderer = world.get_resource_mut::<GpuRenderer>()?;
    let mut refused = None;
    if !windowed && settings.size != renderer.0.size() {
        let (w, h) = settings.size;
        refused = renderer.0.resize(w, h).err();
    }
    let mut stats = world.resource_mut::<RenderStats>();
    if let Some(e) = refused {
        if stats.bad_size != Some(settings.size) {
            let (w, h) = settings.size;
            tracing::warn!("render size {w}x{h} refused ({e}); nothing is rendered until the size is valid");
            stats.bad_size = Some(settings.size);
        }
        return None;
    }
    if !windowed {
        stats.bad_size = None;
    }
    let delta_seconds = world.resource::<engine::time::Time>().delta_secs();
    Some(FrameSettings {
        pipeline: settings.pipeline,
        decal_method: settings.decal_method,
        clear_color: settings.clear_color,
        debug_view: settings.debug_view,
        show_decal_boxes: settings.show_decal_boxes,
        lights: settings.lights,
        compute_shading: settings.compute_shading,
        decals_in_forward_shading: settings.decals_in_forward_shading,
        aa: settings.aa,
        taa_sharpen: settings.taa_sharpen,
        tonemapper: settings.tonemapper,
        bloom: settings.bloom,
        occlusion: settings.occlusion,
        exposure: settings.exposure,
        delta_seconds,
        reflections: settings.reflections,
        transparency: settings.transparency,
        refraction: settings.refraction,
        culling: settings.culling,
        freeze_culling: settings.freeze_culling,
        lod_pixels: settings.lod_pixels,
        refit_pixels: settings.refit_pixels,
        skin_levels: settings.skin_levels,
        reuse_commands: settings.reuse_commands,
    })
}

/// What the main thread knows of a frame when it hands the frame to the renderer: what its
/// statistics ([`FrameStats`]) need besides the renderer's report.
pub(crate) struct FrameContext {
    settings: RenderSettings,
    size: (u32, u32),
    extract_ms: f32,
    visited: VisitCounts,
    animate_ms: f32,
    propagate_ms: f32,
    skin_ms: f32,
    animation: engine::animation::AnimationStats,
    update_started: Option<Instant>,
    /// Pipelined: the main thread's CPU frame, measured at the hand-off.
    main_frame_ms: Option<f32>,
}

/// The context of the frame about to be drawn (before the renderer leaves the world).
fn frame_context(world: &World, pipelined: bool) -> FrameContext {
    let stats = world.resource::<RenderStats>();
    let animation = world.get_resource::<engine::animation::AnimationStats>();
    let update_started = world.resource::<engine::time::Time>().update_started();
    FrameContext {
        settings: world.resource::<RenderSettings>().clone(),
        size: world.get_resource::<GpuRenderer>().map_or((0, 0), |r| r.0.size()),
        extract_ms: stats.extract_ms,
        visited: stats.visited,
        animate_ms: animation.map_or(0.0, |a| a.cpu_ms),
        propagate_ms: world.get_resource::<engine::transform::TransformStats>().map_or(0.0, |p| p.cpu_ms),
        skin_ms: animation.map_or(0.0, |a| a.skin_cpu_ms),
        animation: animation.copied().unwrap_or_default(),
        update_started,
        main_frame_ms: pipelined
            .then(|| update_started.map_or(0.0, |t| (t.elapsed().as_secs_f32() * 1e3 - stats.main_gpu_wait_ms).max(0.0))),
    }
}

/// Files a frame's report in `stats`; an error is logged and kept in
/// [`RenderStats::last_error`], and a fatal one (device lost, memory exhausted) stops drawing
/// and returns the [`AppExit`] that ends the app: the failed frame left work half-recorded, so
/// no later frame is drawn. Any other error is reported and the next frame tries again.
fn file_report(
    stats: &mut RenderStats,
    result: Result<Option<render::FrameReport>, render::RenderError>,
    c: FrameContext,
) -> Option<AppExit> {
    let report = match result {
        Ok(Some(report)) => report,
        Ok(None) => return None, // nothing drawn (minimised window); the changes wait for the next frame
        Err(e) => {
            tracing::error!("rendering failed: {e}");
            stats.last_error = Some(e.to_string());
            if e.is_fatal() {
                stats.failed = true;
                return Some(AppExit::Error(format!("rendering failed: {e}")));
            }
            return None;
        }
    };
    stats.last = report.counters;
    let now = Instant::now();
    let wall_ms = stats.last_submitted.replace(now).map_or(0.0, |t| (now - t).as_secs_f32() * 1e3);
    let settings = &c.settings;
    let transparency = settings.transparency.effective(settings.pipeline);
    stats.pending.push_back(FrameStats {
        frame: report.frame,
        pipeline: settings.pipeline,
        decal_method: report.decal_method,
        decal_surface: report.decal_surface,
        light_method: report.light_method,
        shadows: report.shadows,
        direct_light: report.direct_light,
        staged_lights: report.staged_lights,
        depth_mask: report.depth_mask,
        transparency,
        refraction: settings.refraction && transparency.refracts(),
        aa: report.aa,
        tonemapper: settings.tonemapper,
        bloom: settings.bloom.runs(),
        occlusion: report.occlusion,
        auto_exposure: settings.exposure.runs(),
        lights: settings.lights,
        size: c.size,
        gpu: PassTimes::default(),
        cpu_extract_ms: c.extract_ms,
        cpu_animate_ms: c.animate_ms,
        cpu_propagate_ms: c.propagate_ms,
        cpu_skin_ms: c.skin_ms,
        animation: c.animation,
        cpu_record_ms: report.record_ms,
        cpu_submit_ms: report.submit_ms,
        cpu_prepare_ms: report.prepare_ms,
        visited: c.visited,
        cpu_frame_ms: c
            .main_frame_ms
            .unwrap_or_else(|| c.update_started.map_or(0.0, |t| (t.elapsed().as_secs_f32() * 1e3 - report.wait_ms).max(0.0))),
        pipelined: c.main_frame_ms.is_some(),
        wall_ms,
        counters: report.counters,
    });
    if let Some(done) = report.finished {
        stats.complete(done.frame, done.gpu);
    }
    // Frames whose timings never come (their renderer was replaced, or they were read by
    // `Renderer::finish` directly) must not pile up.
    while stats.pending.len() > RenderStats::MAX_PENDING {
        stats.pending.pop_front();
    }
    None
}

/// Waits for the GPU and moves every pending frame's statistics to `completed`. Call before
/// reading the final statistics or a screenshot.
pub fn finish_frames(world: &mut World) {
    pipelined::collect_frame(world);
    let Some(mut renderer) = world.get_resource_mut::<GpuRenderer>() else { return };
    let finished = renderer.0.finish();
    let mut stats = world.resource_mut::<RenderStats>();
    for f in finished {
        stats.complete(f.frame, f.gpu);
    }
}
