//! Headless play: render N frames of a scene offscreen, then write a screenshot and the
//! per-frame statistics. The CLI, the README's run command and the tests all go through here.

use std::io::Write;
use std::path::{Path, PathBuf};
use std::time::Duration;

use anyhow::{Context, Result, bail};
use bevy_ecs::entity::Entity;
use bevy_ecs::query::With;
use bevy_ecs::world::World;
use engine::app::App;
use engine::time::Time;
use engine::transform::{Static, Transform};
use glam::Vec3;
use plugins::{GpuRenderer, RenderPlugin, RenderSettings, RenderStats, finish_frames};
use render::{
    DebugView, DecalMethod, DepthNormals, DeviceSettings, LightMethod, LightSettings, PipelineKind, Renderer, RendererSettings, Tier,
};

use crate::scene;

/// Which scene to load.
#[derive(Clone, Debug, PartialEq)]
pub enum SceneSource {
    /// The generated courtyard.
    Default,
    /// A glTF or GLB file.
    Gltf(PathBuf),
}

impl SceneSource {
    /// `default` or a path.
    pub fn parse(s: &str) -> Self {
        if s == "default" { SceneSource::Default } else { SceneSource::Gltf(PathBuf::from(s)) }
    }
}

/// A headless run.
#[derive(Clone, Debug)]
pub struct HeadlessOptions {
    /// Frames to render.
    pub frames: u32,
    /// Render size.
    pub size: (u32, u32),
    /// The scene.
    pub scene: SceneSource,
    /// The character that walks the default scene, and the model of the `foxes` benchmark
    /// scene (`None`: no character).
    pub character: Option<PathBuf>,
    /// Bytes the scene's textures may hold on the GPU (0: no budget; `--texture-budget`).
    pub texture_budget: u64,
    /// How glTF files are loaded: textures compressed through the user's cache by default
    /// (`--textures`, `--asset-cache`).
    pub import: engine::gltf::LoadOptions,
    /// The clip the `foxes` benchmark scene plays (the first when the model has none of that
    /// name).
    pub character_clip: String,
    /// Where to write the last frame as PNG.
    pub screenshot: Option<PathBuf>,
    /// Where to write one JSON object per frame.
    pub stats: Option<PathBuf>,
    /// The pipeline.
    pub pipeline: PipelineKind,
    /// How decals are applied.
    pub decal_method: DecalMethod,
    /// Cap on the capability tier.
    pub max_tier: Tier,
    /// Decals to scatter over the scene's surfaces.
    pub decals: usize,
    /// Seed of the scatter.
    pub decal_seed: u64,
    /// What the shading pass shows.
    pub debug_view: DebugView,
    /// Draw decal boxes over the image.
    pub show_decal_boxes: bool,
    /// Percentage of decals nudged every frame (benchmarks refits).
    pub move_decals_percent: f32,
    /// Decals despawned and respawned (as new entities) every frame (benchmarks extraction).
    pub churn_decals: usize,
    /// Sway the camera sideways every frame (benchmarks a moving view).
    pub move_camera: bool,
    /// Replace the scene with one of the seed's benchmark scenarios.
    pub bench_scene: Option<crate::bench::BenchScene>,
    /// Run `frames` frames with every pipeline and decal method in turn (see [`COMPARE_SET`]).
    pub compare: bool,
    /// Run `frames` frames with every light method in turn, in `pipeline`.
    pub compare_light_methods: bool,
    /// Run `frames` frames with each light configuration of [`LIGHT_COMPARE_SET`] in turn.
    pub compare_lights: bool,
    /// Run `frames` frames with each run of [`transparency_compare_set`] in turn (seed 002's
    /// Tables 4.2, 4.4 and 4.5; the transparency bench scene).
    pub compare_transparency: bool,
    /// Light culling and shadows.
    pub lights: LightSettings,
    /// Deferred lighting and visibility-buffer shading in compute.
    pub compute_shading: bool,
    /// Forward and Forward+ walk clustered decals' lists in their shading pass.
    pub decals_in_forward_shading: bool,
    /// Anti-aliasing of the displayed image.
    pub aa: render::AntiAliasing,
    /// Temporal anti-aliasing's sharpening (0–1).
    pub taa_sharpen: f32,
    /// Reflections of smooth surfaces.
    pub reflections: render::ReflectionSettings,
    /// How blended surfaces are drawn.
    pub transparency: render::TransparencyMethod,
    /// The shadow-map atlas.
    pub shadow_maps: render::ShadowMapBudget,
    /// How instances are culled.
    pub culling: render::CullingMode,
    /// Levels of detail: the most pixels a coarser level's error may cover (0: off).
    pub lod_pixels: f32,
    /// Posed meshes shorter on screen than this are refit every other frame (0: every frame).
    pub refit_pixels: f32,
    /// Skin only the vertices of the level of detail a character will be drawn at.
    pub skin_levels: bool,
    /// Run `frames` frames with levels of detail off, on (at `lod_pixels`), then off again.
    pub compare_lod: bool,
    /// Submit a command buffer again when a frame's commands are exactly those it holds.
    pub reuse_commands: bool,
    /// Record each frame on a render thread while the next one is simulated
    /// (`plugins::RenderSettings::pipelined`).
    pub pipelined: bool,
    /// Animate characters small on screen or off it less often
    /// (`engine::animation::AnimationBudget`).
    pub animation_budget: bool,
    /// Pose the `foxes` and `crowd` scenes' skins through their bones' entities instead of as
    /// compact skeletons (`engine::animation::CompactSkeleton`).
    pub bone_entities: bool,
    /// Wait for the GPU to finish each frame before the next update starts (not pipelined).
    pub gpu_idle_between_frames: bool,
    /// Run `frames` frames with every culling mode in turn (off, frustum, occlusion).
    pub compare_culling: bool,
    /// What lights the scene from all around (default: the procedural sky).
    pub environment: engine::environment::Environment,
    /// Run `frames` frames with no environment, the procedural sky, then `environment` if it
    /// is a map, then none again (the first run warms up).
    pub compare_environment: bool,
    /// The display transform's tone mapper.
    pub tonemapper: render::Tonemapper,
    /// Bloom.
    pub bloom: render::BloomSettings,
    /// Ambient occlusion.
    pub occlusion: render::OcclusionSettings,
    /// Run `frames` frames with every ambient occlusion method in turn.
    pub compare_occlusion: bool,
    /// Run `frames` frames with each direct-light method, then exhaustive again.
    pub compare_direct_light: bool,
    /// Auto-exposure.
    pub exposure: render::AutoExposure,
    /// The camera's exposure as an EV100 (`None`: the scene's).
    pub ev100: Option<f32>,
    /// Face size of the environment's cubes ([`RendererSettings::environment_resolution`]).
    pub environment_resolution: u32,
    /// Run `frames` frames with reflections off, then at full and half resolution, each with and
    /// without the decals at their hit points, then in screen space, then off again (the first
    /// run warms up).
    pub compare_reflections: bool,
    /// Instances of the `many-instances` bench scene.
    pub instances: usize,
    /// Particles the `particles` bench scene keeps alive (and the pool's least capacity).
    pub particles: u32,
    /// Particle effects: sparks from shots, dust from the walking character (`--no-particles`
    /// turns them off).
    pub effects: bool,
    /// Rain over the courtyard, leaving wet spots ([`crate::effects::spawn_rain`]; needs
    /// `effects`).
    pub rain: bool,
    /// The particle scene's fountain leaves a small decal where each particle first lands
    /// (`--particle-decals`: GPU-born decals at the rate particles land).
    pub particle_decals: bool,
    /// Every point and spot light's radius, metres (`--light-radius`; `None`: as spawned).
    pub light_radius: Option<f32>,
}

/// The light configurations `--compare-lights` runs, in order, named after the rows of seed 001's
/// Table 5.1 (8×8 tiles, as the seed measured them), then Table 5.2's tile sizes with every
/// optimisation, then 16×16 tiles with the depth mask as well; each runs in the Forward+
/// pipeline, or in forward when light culling is off.
pub const LIGHT_COMPARE_SET: [(&str, LightSettings); 10] = {
    const fn lights(
        method: LightMethod,
        tile_size: u32,
        cull_aabb: bool,
        shadow_ray_culling: bool,
        normals: DepthNormals,
    ) -> LightSettings {
        LightSettings {
            method,
            tile_size,
            cull_aabb,
            // Not among the seed's optimisations: the last row adds it.
            cull_depth_mask: false,
            shadows: true,
            shadow_ray_culling,
            normals,
            coloured_shadows: true,
            shadow_maps: false,
            // The seed's tables trace a ray per light.
            direct_light: render::DirectLight::Exhaustive,
        }
    }
    use DepthNormals::{Improved, Naive};
    use LightMethod::{All, Tiled};
    [
        ("no optimisations", lights(All, 8, false, false, Naive)),
        ("light culling", lights(Tiled, 8, false, false, Naive)),
        ("light culling + AABB", lights(Tiled, 8, true, false, Naive)),
        ("light culling + AABB + shadow ray culling", lights(Tiled, 8, true, true, Naive)),
        ("light culling + AABB + improved shadow ray culling", lights(Tiled, 8, true, true, Improved)),
        ("improved shadow ray culling", lights(All, 8, false, true, Improved)),
        ("tiles 8x8", lights(Tiled, 8, true, true, Improved)),
        ("tiles 16x16", lights(Tiled, 16, true, true, Improved)),
        ("tiles 32x32", lights(Tiled, 32, true, true, Improved)),
        // Beyond the seed: 16×16 tiles with the depth mask (Harada 2012), today's default.
        ("tiles 16x16 + depth mask", LightSettings { cull_depth_mask: true, ..lights(Tiled, 16, true, true, Improved) }),
    ]
};

/// One run of a comparison: what the frames are drawn with.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Run {
    /// The pipeline.
    pub pipeline: PipelineKind,
    /// The decal method asked for.
    pub decal_method: DecalMethod,
    /// Light culling and shadows.
    pub lights: LightSettings,
    /// How blended surfaces are drawn.
    pub transparency: render::TransparencyMethod,
    /// Whether interlaced glass refracts.
    pub refraction: bool,
    /// The transparency scene's spot-light count (`None`: the scene's lights as they are).
    pub spot_lights: Option<usize>,
    /// How instances are culled.
    pub culling: render::CullingMode,
    /// Levels of detail's limit in pixels (0: off).
    pub lod_pixels: f32,
    /// Reflections.
    pub reflections: render::ReflectionSettings,
    /// The environment, as an index into the comparison's environments (`None`: as it is).
    pub environment: Option<usize>,
    /// Ambient occlusion.
    pub occlusion: render::OcclusionSettings,
}

/// Light counts of seed 002's Tables 4.2–4.5.
pub const TRANSPARENCY_LIGHT_COUNTS: [usize; 7] = [0, 2, 4, 8, 16, 32, 64];

/// The runs `--compare-transparency` makes, from `base`: for each light count of
/// [`TRANSPARENCY_LIGHT_COUNTS`], interlaced deferred with and without refraction and no
/// shadows (Table 4.2), then without shadows and with them (Tables 4.5 and 4.4) deferred with a
/// forward transparency pass, the forward pipeline, depth-peeled deferred, and interlaced
/// deferred with shadows;
/// then interlaced deferred with glass casting opaque shadows, and with shadow maps, coloured
/// and opaque (Table 4.3).
pub fn transparency_compare_set(base: Run) -> Vec<Run> {
    use render::TransparencyMethod::{DepthPeeling, Forward, Interlaced};
    let mut runs = Vec::new();
    for count in TRANSPARENCY_LIGHT_COUNTS {
        let run = |pipeline, transparency, refraction, shadows| Run {
            pipeline,
            transparency,
            refraction,
            spot_lights: Some(count),
            lights: LightSettings { shadows, ..base.lights },
            ..base
        };
        if runs.is_empty() {
            // Warm-up (clocks, first builds): the first run twice, which the summaries read as
            // one run and skip the start of.
            runs.push(run(PipelineKind::Deferred, Interlaced, false, false));
        }
        runs.push(run(PipelineKind::Deferred, Interlaced, false, false));
        // Also Table 4.5's interlaced column.
        runs.push(run(PipelineKind::Deferred, Interlaced, true, false));
        if count == 0 {
            continue;
        }
        runs.push(run(PipelineKind::Deferred, Forward, true, false));
        runs.push(run(PipelineKind::Forward, Forward, true, false));
        runs.push(run(PipelineKind::Deferred, DepthPeeling, true, false));
        runs.push(run(PipelineKind::Deferred, Interlaced, true, true));
        runs.push(run(PipelineKind::Deferred, Forward, true, true));
        runs.push(run(PipelineKind::Forward, Forward, true, true));
        runs.push(run(PipelineKind::Deferred, DepthPeeling, true, true));
        let interlaced = run(PipelineKind::Deferred, Interlaced, true, true);
        let opaque = |maps| Run { lights: LightSettings { coloured_shadows: false, shadow_maps: maps, ..interlaced.lights }, ..interlaced };
        runs.push(opaque(false));
        runs.push(Run { lights: LightSettings { shadow_maps: true, ..interlaced.lights }, ..interlaced });
        runs.push(opaque(true));
    }
    runs
}

/// The pipeline and decal-method pairs `--compare` runs, in order (those the device can run; see
/// [`compare_set`]): every pipeline without decals, with each ray-traced method and with
/// clustered decals, and the deferred pipeline with deferred decals.
pub const COMPARE_SET: [(PipelineKind, DecalMethod); 16] = [
    (PipelineKind::Forward, DecalMethod::Off),
    (PipelineKind::Forward, DecalMethod::RayQuery),
    (PipelineKind::Forward, DecalMethod::RayQueryCompute),
    (PipelineKind::Forward, DecalMethod::RayPipeline),
    (PipelineKind::Forward, DecalMethod::Clustered),
    (PipelineKind::Deferred, DecalMethod::Off),
    (PipelineKind::Deferred, DecalMethod::RayQuery),
    (PipelineKind::Deferred, DecalMethod::RayQueryCompute),
    (PipelineKind::Deferred, DecalMethod::RayPipeline),
    (PipelineKind::Deferred, DecalMethod::Clustered),
    (PipelineKind::Deferred, DecalMethod::DeferredDecals),
    (PipelineKind::VisBuffer, DecalMethod::Off),
    (PipelineKind::VisBuffer, DecalMethod::RayQuery),
    (PipelineKind::VisBuffer, DecalMethod::RayQueryCompute),
    (PipelineKind::VisBuffer, DecalMethod::RayPipeline),
    (PipelineKind::VisBuffer, DecalMethod::Clustered),
];

/// The pairs of [`COMPARE_SET`] a device offering `support` runs as asked (a method it cannot run
/// would fall back to another, measuring that one twice).
pub fn compare_set(support: render::RaySupport) -> Vec<(PipelineKind, DecalMethod)> {
    COMPARE_SET.into_iter().filter(|&(p, m)| m.effective(p, support) == m).collect()
}

impl Default for HeadlessOptions {
    fn default() -> Self {
        Self {
            frames: 3,
            size: (320, 240),
            scene: SceneSource::Default,
            character: crate::character::default_character(),
            import: engine::gltf::LoadOptions::default(),
            texture_budget: 0,
            character_clip: "Walk".to_owned(),
            screenshot: None,
            stats: None,
            pipeline: PipelineKind::Forward,
            decal_method: DecalMethod::RayQuery,
            max_tier: Tier::RayQuery,
            decals: 0,
            decal_seed: 1,
            debug_view: DebugView::Lit,
            show_decal_boxes: false,
            move_decals_percent: 0.0,
            move_camera: false,
            churn_decals: 0,
            bench_scene: None,
            compare: false,
            compare_lights: false,
            compare_transparency: false,
            compare_light_methods: false,
            lights: LightSettings::default(),
            compute_shading: true,
            decals_in_forward_shading: false,
            aa: render::AntiAliasing::None,
            taa_sharpen: 0.25,
            reflections: render::ReflectionSettings::default(),
            transparency: render::TransparencyMethod::Interlaced,
            shadow_maps: render::ShadowMapBudget::default(),
            culling: render::CullingMode::Occlusion,
            lod_pixels: render::lod::DEFAULT_LOD_PIXELS,
            refit_pixels: render::settings::DEFAULT_REFIT_PIXELS,
            skin_levels: true,
            compare_lod: false,
            reuse_commands: true,
            pipelined: false,
            animation_budget: false,
            bone_entities: false,
            gpu_idle_between_frames: false,
            compare_culling: false,
            environment: engine::environment::Environment::default(),
            compare_environment: false,
            tonemapper: render::Tonemapper::PbrNeutral,
            bloom: render::BloomSettings::default(),
            occlusion: render::OcclusionSettings::default(),
            compare_occlusion: false,
            compare_direct_light: false,
            exposure: render::AutoExposure::default(),
            ev100: None,
            environment_resolution: RendererSettings::default().environment_resolution,
            compare_reflections: false,
            instances: crate::bench::MANY_INSTANCES,
            particles: crate::bench::PARTICLES,
            effects: true,
            rain: false,
            particle_decals: false,
            light_radius: None,
        }
    }
}

/// What a run produced.
pub struct RunSummary {
    /// The app after the run (for tests to inspect).
    pub app: App,
    /// The last frame, RGBA8 sRGB.
    pub pixels: Vec<u8>,
    /// The statistics of every frame, oldest first.
    pub frames: Vec<serde_json::Value>,
    /// Validation errors reported during the run.
    pub validation_errors: Vec<String>,
}

/// Builds an app with the render plugin and a GPU renderer, and loads the scene into it.
pub fn build_app(opts: &HeadlessOptions) -> Result<App> {
    let settings = RendererSettings {
        device: DeviceSettings { max_tier: opts.max_tier, ..Default::default() },
        shadow_maps: opts.shadow_maps,
        environment_resolution: opts.environment_resolution,
        texture_budget: opts.texture_budget,
        particle_capacity: particle_capacity(opts),
        ..Default::default()
    };
    build_app_with(opts, &settings)
}

/// The particle pool's room: the default, or the particle scene's count when it needs more.
pub fn particle_capacity(opts: &HeadlessOptions) -> u32 {
    let scene = opts.bench_scene == Some(crate::bench::BenchScene::Particles);
    let need = if scene { opts.particles.saturating_add(opts.particles / 8) } else { 0 };
    need.next_power_of_two().max(render::particles::DEFAULT_CAPACITY)
}

/// [`build_app`] with explicit renderer settings.
pub fn build_app_with(opts: &HeadlessOptions, renderer_settings: &RendererSettings) -> Result<App> {
    let mut app = build_scene_app(opts)?;
    let (w, h) = opts.size;
    let renderer = Renderer::new(renderer_settings, w, h).context("could not start the renderer")?;
    app.insert_resource(GpuRenderer(renderer));
    Ok(app)
}

/// The app of [`build_app`] without its renderer (a window runner creates it for the window):
/// the render plugin with the options' settings, the scene, scattered and jittered decals.
pub fn build_scene_app(opts: &HeadlessOptions) -> Result<App> {
    let (w, h) = opts.size;
    if opts.frames == 0 {
        bail!("--frames must be at least 1");
    }
    let mut app = App::new();
    app.world.resource_mut::<Time>().set_fixed_step(Some(Duration::from_secs_f64(1.0 / 60.0)));
    app.add_plugins(RenderPlugin::new(RenderSettings {
        size: (w, h),
        pipeline: opts.pipeline,
        decal_method: opts.decal_method,
        debug_view: opts.debug_view,
        show_decal_boxes: opts.show_decal_boxes,
        lights: opts.lights,
        compute_shading: opts.compute_shading,
        decals_in_forward_shading: opts.decals_in_forward_shading,
        aa: opts.aa,
        taa_sharpen: opts.taa_sharpen,
        reflections: opts.reflections,
        transparency: opts.transparency,
        culling: opts.culling,
        lod_pixels: opts.lod_pixels,
        refit_pixels: opts.refit_pixels,
        skin_levels: opts.skin_levels,
        reuse_commands: opts.reuse_commands,
        pipelined: opts.pipelined,
        tonemapper: opts.tonemapper,
        bloom: opts.bloom,
        occlusion: opts.occlusion,
        exposure: opts.exposure,
        ..Default::default()
    }));
    app.insert_resource(opts.environment.clone());
    app.insert_resource(engine::animation::AnimationBudget { enabled: opts.animation_budget, ..Default::default() });
    app.insert_resource(crate::effects::Effects(opts.effects));
    app.add_systems(engine::app::Update, crate::effects::expire_effects);
    app.insert_resource(crate::assets::ImportOptions(opts.import.clone()));
    match opts.bench_scene {
        Some(crate::bench::BenchScene::ManyInstances) => crate::bench::spawn_city(&mut app.world, opts.instances),
        Some(crate::bench::BenchScene::BehindWall) => crate::bench::spawn_behind_wall(&mut app.world, opts.instances),
        Some(crate::bench::BenchScene::Particles) => crate::bench::spawn_particles(&mut app.world, opts.particles, opts.particle_decals),
        Some(scene @ (crate::bench::BenchScene::Foxes | crate::bench::BenchScene::Crowd)) => {
            let path = opts.character.as_deref().context("the foxes and crowd scenes need a character (--character PATH)")?;
            let eye_level = scene == crate::bench::BenchScene::Crowd;
            crate::bench::spawn_foxes(&mut app.world, path, &opts.character_clip, opts.instances, eye_level, !opts.bone_entities)?;
        }
        Some(scene) => crate::bench::spawn_bench_scene(&mut app.world, scene),
        None => load_scene(&mut app.world, &opts.scene, opts.character.as_deref())?,
    }
    app.add_systems(engine::app::Update, crate::character::walk_loops);
    if let Some(radius) = opts.light_radius {
        app.insert_resource(crate::light_size::LightRadius(radius));
        app.add_systems(engine::app::Update, crate::light_size::apply_light_radius);
    }
    if opts.rain && opts.effects {
        crate::effects::spawn_rain(&mut app.world, Vec3::ZERO, crate::scene::HALF_COURT);
    }
    if let Some(ev100) = opts.ev100 {
        for mut camera in app.world.query::<&mut engine::camera::Camera>().iter_mut(&mut app.world) {
            camera.exposure = engine::camera::Camera::exposure_from_ev100(ev100);
        }
    }
    if opts.decals > 0 {
        let materials = crate::decal_textures::add_builtin_materials(&mut app.world);
        let placed = crate::scatter::scatter_decals(&mut app.world, opts.decals, opts.decal_seed, &materials);
        tracing::info!(requested = opts.decals, placed, "scattered decals");
    }
    if opts.move_decals_percent > 0.0 {
        // Decals that move every frame are not static: the transform scan must see them.
        let scattered: Vec<Entity> =
            app.world.query_filtered::<Entity, (With<Static>, With<plugins::decal::Decal>)>().iter(&app.world).collect();
        for e in scattered {
            app.world.entity_mut(e).remove::<Static>();
        }
        app.insert_resource(DecalJitter::new(opts.move_decals_percent));
        app.add_systems(engine::app::Update, jitter_decals);
    }
    if opts.move_camera {
        app.add_systems(engine::app::Update, sway_camera);
    }
    if opts.churn_decals > 0 {
        let decals = app.world.query_filtered::<Entity, With<plugins::decal::Decal>>().iter(&app.world).collect();
        app.insert_resource(DecalChurn { per_frame: opts.churn_decals, oldest_first: decals });
        app.add_systems(engine::app::Update, churn_decals);
    }
    Ok(app)
}

/// Spawns the scene, adding a camera and a light when a glTF file brings none, and plays a
/// glTF's first animation on a loop. In the default courtyard, `character` (when given) walks a
/// loop in front of the camera ([`crate::character`]).
pub fn load_scene(world: &mut World, source: &SceneSource, character: Option<&std::path::Path>) -> Result<()> {
    match source {
        SceneSource::Default => {
            scene::spawn_courtyard(world);
            match character {
                // The courtyard stands without its walker: a character that cannot be loaded is
                // reported, not fatal.
                Some(path) => {
                    if let Err(error) = crate::character::spawn_walker(world, path, scene::WALKER_LOOP.0, scene::WALKER_LOOP.1) {
                        tracing::error!("{error:#}; the courtyard is shown without it");
                    }
                }
                None => {
                    tracing::info!("no character model found (../shared/assets/gltf/Fox/Fox.glb, or --character): the courtyard is empty")
                }
            }
        }
        SceneSource::Gltf(path) => {
            // Nothing of the file could be loaded: the only case that ends the run. A broken
            // part (a skin, a clip, a morph target…) costs that part: the loader has warned
            // about each, and the rest plays.
            let gltf = crate::assets::load_gltf(world, path).with_context(|| format!("could not load scene {}", path.display()))?;
            if !gltf.faults.is_empty() {
                tracing::warn!(
                    "scene {} loaded with {} broken parts left out or repaired (each named above); the rest plays",
                    path.display(),
                    gltf.faults.len()
                );
            }
            let root = gltf.spawn(world);
            let first = world.get::<engine::gltf::GltfAnimations>(root).and_then(|clips| clips.0.first().copied());
            if let Some(clip) = first {
                world.entity_mut(root).insert(engine::animation::AnimationPlayer::new(clip));
            }
            frame_scene(world);
        }
    }
    Ok(())
}

/// Runs the whole headless session.
pub fn run(opts: &HeadlessOptions) -> Result<RunSummary> {
    let mut app = build_app(opts)?;
    let mut stats_file = match &opts.stats {
        Some(p) => Some(std::io::BufWriter::new(create(p)?)),
        None => None,
    };
    let base = Run {
        pipeline: opts.pipeline,
        decal_method: opts.decal_method,
        lights: opts.lights,
        transparency: opts.transparency,
        refraction: true,
        spot_lights: None,
        culling: opts.culling,
        lod_pixels: opts.lod_pixels,
        reflections: opts.reflections,
        environment: None,
        occlusion: opts.occlusion,
    };
    let mut combos: Vec<Run> = Vec::new();
    // --compare-environment: none, the procedural sky, then the options' map if it is one.
    let mut environments = vec![
        engine::environment::Environment { source: engine::environment::EnvironmentSource::None, ..opts.environment.clone() },
        engine::environment::Environment { source: engine::environment::EnvironmentSource::Sky, ..opts.environment.clone() },
    ];
    if matches!(opts.environment.source, engine::environment::EnvironmentSource::Map(_)) {
        environments.push(opts.environment.clone());
    }
    if opts.compare {
        let set = compare_set(app.world.resource::<GpuRenderer>().0.ray_support());
        combos.extend(set.into_iter().map(|(pipeline, decal_method)| Run { pipeline, decal_method, ..base }));
    }
    if opts.compare_lights {
        combos.extend(LIGHT_COMPARE_SET.iter().map(|&(_, lights)| {
            let pipeline = if lights.method == LightMethod::Tiled { PipelineKind::ForwardPlus } else { PipelineKind::Forward };
            Run { pipeline, lights, ..base }
        }));
    }
    if opts.compare_light_methods {
        combos.extend(LightMethod::ALL.map(|method| Run { lights: LightSettings { method, ..opts.lights }, ..base }));
    }
    if opts.compare_transparency {
        combos.extend(transparency_compare_set(base));
    }
    if opts.compare_culling {
        combos.extend(render::CullingMode::ALL.map(|culling| Run { culling, ..base }));
    }
    if opts.compare_lod {
        // Off first and last: the first run also warms the GPU up.
        combos.extend([0.0, opts.lod_pixels, 0.0].map(|lod_pixels| Run { lod_pixels, ..base }));
    }
    if opts.compare_reflections {
        // Off first and last: the first run also warms the GPU's clocks up (on the lent H100 the
        // first 40 frames ran at a third of the speed).
        let on = render::ReflectionSettings { mode: render::ReflectionMode::RayTraced, ..opts.reflections };
        let off = Run { reflections: render::ReflectionSettings { mode: render::ReflectionMode::Off, ..on }, ..base };
        combos.push(off);
        for half_resolution in [false, true] {
            for decals_at_hits in [true, false] {
                combos.push(Run { reflections: render::ReflectionSettings { half_resolution, decals_at_hits, ..on }, ..base });
            }
        }
        let screen = render::ReflectionSettings { mode: render::ReflectionMode::ScreenSpace, ..on };
        combos.push(Run { reflections: screen, ..base });
        combos.push(off);
    }
    if opts.compare_environment {
        // None first and last: the first run also warms the GPU up.
        combos.extend((0..environments.len()).chain([0]).map(|i| Run { environment: Some(i), ..base }));
    }
    if opts.compare_occlusion {
        // Off first and last: the first run also warms the GPU up.
        let runs = render::OcclusionMethod::ALL.into_iter().chain([render::OcclusionMethod::Off]);
        combos.extend(runs.map(|method| Run { occlusion: render::OcclusionSettings { method, ..opts.occlusion }, ..base }));
    }
    if opts.compare_direct_light {
        // Exhaustive first and last: the first run also warms the GPU up.
        let runs = render::DirectLight::ALL.into_iter().chain([render::DirectLight::Exhaustive]);
        combos.extend(runs.map(|direct_light| Run { lights: LightSettings { direct_light, ..opts.lights }, ..base }));
    }
    let total = opts.frames as usize * combos.len().max(1);
    let mut frames = Vec::with_capacity(total);
    let renderer = &app.world.resource::<GpuRenderer>().0;
    let device = (renderer.tier().name(), renderer.device_name().to_string());
    for i in 0..total {
        if let Some(run) = combos.get(i / opts.frames as usize) {
            let mut settings = app.world.resource_mut::<plugins::RenderSettings>();
            settings.pipeline = run.pipeline;
            settings.decal_method = run.decal_method;
            settings.lights = run.lights;
            settings.transparency = run.transparency;
            settings.refraction = run.refraction;
            settings.culling = run.culling;
            settings.lod_pixels = run.lod_pixels;
            settings.reflections = run.reflections;
            settings.occlusion = run.occlusion;
            if let Some(i) = run.environment {
                app.insert_resource(environments[i].clone());
            }
            let spot_lights = app.world.query_filtered::<(), bevy_ecs::query::With<crate::bench::BenchSpot>>().iter(&app.world).count();
            if let Some(count) = run.spot_lights.filter(|&c| c != spot_lights) {
                crate::bench::set_spot_lights(&mut app.world, count);
            }
        }
        app.update();
        if let Some(e) = app.world.resource::<RenderStats>().last_error.clone() {
            bail!("rendering failed: {e}");
        }
        if opts.gpu_idle_between_frames {
            // Outside the frame's CPU time, which excludes the waits for the GPU anyway.
            app.world.resource::<GpuRenderer>().0.wait_gpu_idle();
        }
        drain_stats(&mut app, &device, &mut frames);
    }
    finish_frames(&mut app.world);
    // Pipelined, the last frame's error arrives with it.
    if let Some(e) = app.world.resource::<RenderStats>().last_error.clone() {
        bail!("rendering failed: {e}");
    }
    drain_stats(&mut app, &device, &mut frames);
    if let Some(f) = &mut stats_file {
        for v in &frames {
            writeln!(f, "{v}")?;
        }
        f.flush()?;
    }
    let renderer = &mut app.world.resource_mut::<GpuRenderer>().0;
    let pixels = renderer.read_display().context("reading back the frame")?;
    let validation_errors = renderer.take_validation_errors();
    if let Some(path) = &opts.screenshot {
        let (w, h) = opts.size;
        image::save_buffer(path, &pixels, w, h, image::ExtendedColorType::Rgba8).with_context(|| format!("writing {}", path.display()))?;
    }
    Ok(RunSummary { app, pixels, frames, validation_errors })
}

/// Moves the finished frames' statistics to `out`; `(tier, device)` names the renderer's (which
/// may be on the render thread).
fn drain_stats(app: &mut App, (tier, device): &(&str, String), out: &mut Vec<serde_json::Value>) {
    let imports = app.world.get_resource::<crate::assets::ImportTotals>().copied().unwrap_or_default().0;
    let mut stats = app.world.resource_mut::<RenderStats>();
    while let Some(s) = stats.completed.pop_front() {
        let mut value = crate::stats::frame_json(&s, tier, device);
        crate::stats::add_import_counters(&mut value, &imports);
        out.push(value);
    }
}

fn create(path: &Path) -> Result<std::fs::File> {
    if let Some(dir) = path.parent().filter(|d| !d.as_os_str().is_empty()) {
        std::fs::create_dir_all(dir).with_context(|| format!("creating {}", dir.display()))?;
    }
    std::fs::File::create(path).with_context(|| format!("creating {}", path.display()))
}

/// Frames a loaded model ([`engine::scene::frame_scene`]: a camera whose near plane follows the
/// model's size, and lights when it brings none); with `--environment none` metals would be black
/// but for their highlights, so a brighter ambient stands in when the lights were added.
pub fn frame_scene(world: &mut World) {
    if engine::scene::frame_scene(world).lights_spawned
        && let Some(mut settings) = world.get_resource_mut::<plugins::RenderSettings>()
    {
        settings.ambient = Vec3::splat(0.35);
    }
}

/// Replaces the oldest decals with new entities every frame, as bullet holes come and go.
#[derive(bevy_ecs::resource::Resource)]
pub struct DecalChurn {
    /// Decals despawned (and as many spawned) per frame.
    pub per_frame: usize,
    oldest_first: std::collections::VecDeque<Entity>,
}

fn churn_decals(world: &mut World) {
    world.resource_scope(|world, mut churn: bevy_ecs::world::Mut<DecalChurn>| {
        for _ in 0..churn.per_frame.min(churn.oldest_first.len()) {
            let Some(old) = churn.oldest_first.pop_front() else { break };
            let Some(copy) = world.get::<plugins::decal::Decal>(old).cloned() else { continue };
            let transform = world.get::<Transform>(old).copied().unwrap_or_default();
            let fixed = world.get::<Static>(old).is_some();
            world.despawn(old);
            let mut new = world.spawn((copy, transform));
            if fixed {
                new.insert(Static);
            }
            churn.oldest_first.push_back(new.id());
        }
    });
}

/// Sways every camera sideways, a couple of centimetres a frame at 60 Hz, back and forth.
fn sway_camera(time: bevy_ecs::system::Res<Time>, mut cameras: bevy_ecs::system::Query<&mut Transform, With<engine::camera::Camera>>) {
    let step = (time.elapsed_secs() * 0.5).cos() * 1.2 * time.delta_secs();
    for mut t in &mut cameras {
        t.translation.x += step;
    }
}

/// Moves a rotating window of decals a little every frame, so benchmarks see a steady stream
/// of refits (and the periodic rebuilds the policy triggers). A frame visits only the decals it
/// moves: the decals are listed once, in query order, and listed again only when their count
/// changes (a decal spawned in the frame another despawns waits for the next change of count).
#[derive(bevy_ecs::resource::Resource)]
pub struct DecalJitter {
    /// Percentage of decals moved per frame.
    pub percent: f32,
    cursor: usize,
    order: Vec<Entity>,
}

impl DecalJitter {
    /// Moves `percent` % of the decals a frame.
    pub fn new(percent: f32) -> Self {
        Self { percent, cursor: 0, order: Vec::new() }
    }
}

fn jitter_decals(
    mut jitter: bevy_ecs::system::ResMut<DecalJitter>,
    time: bevy_ecs::system::Res<Time>,
    mut decals: bevy_ecs::system::Query<(Entity, &mut Transform), With<plugins::decal::Decal>>,
) {
    // The length of an archetypal query is the sum of its tables' lengths: no walk.
    let total = decals.iter().len();
    if total == 0 {
        return;
    }
    let jitter = &mut *jitter;
    if jitter.order.len() != total {
        jitter.order.clear();
        jitter.order.extend(decals.iter().map(|(entity, _)| entity));
    }
    let moved = ((total as f32 * jitter.percent / 100.0).ceil() as usize).min(total);
    let start = jitter.cursor % total;
    let wobble = Vec3::new(time.elapsed_secs().sin(), 0.0, time.elapsed_secs().cos()) * 0.002;
    for k in 0..moved {
        if let Ok((_, mut t)) = decals.get_mut(jitter.order[(start + k) % total]) {
            t.translation += wobble;
        }
    }
    jitter.cursor = start + moved;
}

#[cfg(test)]
mod tests {
    use bevy_ecs::schedule::Schedule;

    use super::*;

    #[test]
    fn the_decal_mover_moves_its_share_of_the_decals_in_a_rotating_window() {
        let mut world = World::new();
        world.insert_resource(Time::default());
        world.insert_resource(DecalJitter::new(30.0));
        let material = engine::asset::Assets::<plugins::decal::DecalMaterial>::default().add(Default::default());
        let decals: Vec<Entity> = (0..10).map(|_| world.spawn((plugins::decal::Decal::new(material), Transform::default())).id()).collect();
        let mut schedule = Schedule::default();
        schedule.add_systems(jitter_decals);
        let moved = |world: &World| decals.iter().filter(|&&e| world.get::<Transform>(e).unwrap().translation != Vec3::ZERO).count();
        // 30 % of 10: three a frame, then the next three, until every decal has moved once.
        for (frame, expected) in [(1, 3), (2, 6), (3, 9), (4, 10)] {
            schedule.run(&mut world);
            assert_eq!(moved(&world), expected, "after frame {frame}");
        }
        // A despawned decal is skipped, the list follows the new count.
        world.despawn(decals[0]);
        schedule.run(&mut world);
        assert_eq!(world.resource::<DecalJitter>().order.len(), 9);
    }
}
