//! Soak: hours of gameplay compressed into thousands of frames, under the Vulkan validation layer
//! with synchronization validation, to show that long play keeps working, stays clean and gives
//! its memory back.
//!
//! Gameplay is an ordinary system ([`soak_gameplay`]) driven by a seeded generator, so a run is
//! deterministic: each frame it spawns, moves, reparents and despawns decals (some with a
//! lifetime, some riding on meshes), point, spot and directional lights and mesh instances, and
//! now and then adds or removes meshes, materials (a third of them blended glass, some
//! refracting), textures and decal materials, including ones still in use. Between frames the
//! driver ([`run`]) switches the pipeline, decal method, light method, transparency method,
//! culling mode (and freezes or thaws the culling view), anti-aliasing, reflections, the
//! environment (none, the procedural sky, a uniform radiance: each new one is filtered on the
//! GPU that frame), the tone mapper, bloom, auto-exposure and the ambient occlusion method,
//! decals in forward shading and debug view and
//! resizes the target (down to 1×1). The run is split into cycles;
//! each cycle starts a new renderer on a randomly chosen capability tier
//! ([`plugins::restart_renderer`], which re-extracts the scene), and ends with everything the
//! cycle spawned despawned.
//!
//! What it measures, and what [`SoakReport::failures`] checks:
//! - validation errors (the harness turns validation on itself, through
//!   `DeviceSettings::validation`; the device then enables synchronization validation with
//!   `VkValidationFeaturesEXT`): none allowed;
//! - every frame's HDR image is read back: every pixel must be finite;
//! - GPU memory in use (gpu-allocator's report) at the start of each cycle, with nothing
//!   spawned, and at its end after everything was despawned and the renderer settled in the same
//!   configuration: the end may exceed the start by at most [`GPU_BOUND`];
//! - the engine's CPU memory: every byte the Rust code holds, counted by a counting global
//!   allocator that the binary installs (`cap`, passed in as [`SoakConfig::heap_bytes`]), at
//!   the end of each cycle: it may exceed the end of the first cycle by at most [`HEAP_BOUND`];
//! - resident memory (`/proc/self/statm`) is reported too, but not bounded: it includes the
//!   driver's and the validation layer's own memory, and with validation on the layer's grows by
//!   about 15 KB a frame under this churn (3,000 frames of one cycle on lavapipe: +45 MB with
//!   validation, within ±6 MB without it: `sandbox --soak --frames 3000 --soak-cycles 1 --tier
//!   ray_tracing_pipeline [--soak-without-validation]`), which is not ours to fix.

use std::collections::HashSet;
use std::time::Instant;

use anyhow::{Result, bail};
use bevy_ecs::prelude::*;
use engine::image::{ColorSpace, Image};
use engine::prelude::*;
use plugins::decal::{Decal, DecalLifetime, DecalMaterial};
use plugins::{GpuRenderer, RenderPlugin, RenderSettings, RenderStats, restart_renderer};
use render::{DebugView, DecalMethod, LightMethod, PipelineKind, RendererSettings, Tier, TransparencyMethod};
use serde::Serialize;

use crate::scatter::SplitMix64;

/// How far GPU memory in use may stay above a cycle's starting level once everything the cycle
/// spawned is despawned: 1 MiB. What remains is capacity the renderer keeps on purpose (the
/// minimum sizes of its tables and rings); see `render::scene::gpu` and `render::gpu::upload`.
pub const GPU_BOUND: u64 = 1 << 20;

/// How far the engine's heap may grow from the end of the first cycle to the end of any later
/// one: 2 MiB (a leak of one small record per frame over a 10,000-frame run would pass it).
pub const HEAP_BOUND: u64 = 2 << 20;

/// How many low frames the soak's renderers wait before a buffer gives memory back
/// ([`render::DeviceSettings::shrink_after_frames`]): 8 instead of the default 60, so that a
/// cycle's end settles in a few dozen frames (and gameplay shrinks and regrows buffers more often,
/// which the soak wants to see too).
pub const SHRINK_AFTER_FRAMES: u32 = 8;

/// Frames rendered in the base configuration before each memory measurement, so that buffers
/// left unused shrink and retired ones are freed: two waits of [`SHRINK_AFTER_FRAMES`] (a shrink
/// can leave another buffer's need low, which then waits its own turn) and a margin of 20 frames
/// for the frames in flight and the graveyard.
pub const SETTLE_FRAMES: u32 = 2 * SHRINK_AFTER_FRAMES + 20;

/// What a soak run does.
#[derive(Clone, Debug)]
pub struct SoakConfig {
    /// Seed of every random choice.
    pub seed: u64,
    /// Gameplay frames in all (settling frames come on top).
    pub frames: u32,
    /// The frames are split into this many cycles.
    pub cycles: u32,
    /// The base render size (resizes happen in between).
    pub size: (u32, u32),
    /// Each cycle runs on one of these tiers, chosen at random (the device may offer less).
    pub tiers: Vec<Tier>,
    /// Most live decals, lights and mesh instances the gameplay keeps.
    pub max_live: (usize, usize, usize),
    /// Run under the validation layer with synchronization validation (the default; off only to
    /// measure the layer's own cost).
    pub validation: bool,
    /// Bytes the Rust code holds right now, from a counting global allocator the binary
    /// installs (e.g. `cap::Cap::allocated`); `None` skips the heap check.
    pub heap_bytes: Option<fn() -> u64>,
}

impl Default for SoakConfig {
    fn default() -> Self {
        Self {
            seed: 1,
            frames: 2000,
            cycles: 4,
            size: (48, 32),
            tiers: vec![Tier::RayQuery, Tier::RayTracingPipeline, Tier::NoRayTracing],
            max_live: (300, 40, 60),
            validation: true,
            heap_bytes: None,
        }
    }
}

/// One cycle of a soak run.
#[derive(Clone, Debug, Default, Serialize)]
pub struct CycleReport {
    /// The tier the cycle ran on.
    pub tier: &'static str,
    /// Gameplay frames.
    pub frames: u32,
    /// GPU bytes in use at the start, with nothing spawned.
    pub gpu_before: u64,
    /// Most GPU bytes in use at any frame of the cycle (sampled every 8 frames).
    pub gpu_peak: u64,
    /// GPU bytes in use after everything the cycle spawned was despawned.
    pub gpu_after: u64,
    /// Resident CPU bytes at the start of the cycle (after its renderer started and settled).
    pub rss_before: u64,
    /// Resident CPU bytes at the end of the cycle.
    pub rss_after: u64,
    /// Resident CPU bytes every 250 gameplay frames.
    pub rss_samples: Vec<u64>,
    /// Heap bytes the engine holds at the end of the cycle (0 without [`SoakConfig::heap_bytes`]).
    pub heap_after: u64,
    /// Heap bytes every 250 gameplay frames.
    pub heap_samples: Vec<u64>,
    /// Most decals, lights and mesh instances live at once.
    pub peak_live: (u64, u64, u64),
}

/// What a soak run did and saw.
#[derive(Clone, Debug, Default, Serialize)]
pub struct SoakReport {
    /// The seed.
    pub seed: u64,
    /// Frames rendered, settling included.
    pub frames_rendered: u64,
    /// Per cycle.
    pub cycles: Vec<CycleReport>,
    /// Validation errors reported (synchronization hazards included).
    pub validation_errors: usize,
    /// The first few of them.
    pub first_validation_errors: Vec<String>,
    /// Frames whose HDR image held a NaN or an infinity.
    pub non_finite_frames: u64,
    /// Entities and assets the gameplay created and destroyed.
    pub gameplay: GameplayCounts,
    /// Switches the driver made.
    pub switches: SwitchCounts,
    /// Wall-clock seconds.
    pub seconds: f64,
}

/// Counts of gameplay actions.
#[derive(Clone, Copy, Debug, Default, Serialize)]
pub struct GameplayCounts {
    /// Decals spawned.
    pub decals_spawned: u64,
    /// Lights spawned.
    pub lights_spawned: u64,
    /// Mesh instances spawned.
    pub instances_spawned: u64,
    /// Entities despawned by the gameplay (not counting lifetimes and the end of cycles).
    pub despawned: u64,
    /// Entities moved.
    pub moved: u64,
    /// Decals and lights attached to or detached from a mesh instance.
    pub reparented: u64,
    /// Meshes, materials, textures and decal materials added.
    pub assets_added: u64,
    /// Meshes, materials, textures and decal materials removed (possibly still in use).
    pub assets_removed: u64,
}

/// Counts of configuration switches.
#[derive(Clone, Copy, Debug, Default, Serialize)]
pub struct SwitchCounts {
    /// Pipeline changes.
    pub pipeline: u64,
    /// Decal method changes (and forward shading walking clustered decals, or not).
    pub decal_method: u64,
    /// Anti-aliasing changes.
    pub aa: u64,
    /// Reflection changes (on or off, full or half resolution).
    pub reflections: u64,
    /// Environment changes (none, the procedural sky, a uniform radiance: each new source is
    /// filtered that frame).
    pub environment: u64,
    /// Tone mapper, bloom, auto-exposure and ambient occlusion changes.
    pub display: u64,
    /// Light method changes.
    pub light_method: u64,
    /// Transparency method changes.
    pub transparency: u64,
    /// Culling mode changes and culling-view freezes or thaws.
    pub culling: u64,
    /// Debug view changes.
    pub debug_view: u64,
    /// Render size changes.
    pub resize: u64,
    /// Renderer restarts on another tier.
    pub tier: u64,
}

impl SoakReport {
    /// What went wrong, one line each; empty when the run passed.
    pub fn failures(&self) -> Vec<String> {
        let mut failures = Vec::new();
        if self.validation_errors > 0 {
            failures.push(format!("{} validation errors, first: {:?}", self.validation_errors, self.first_validation_errors.first()));
        }
        if self.non_finite_frames > 0 {
            failures.push(format!("{} frames had non-finite pixels", self.non_finite_frames));
        }
        for (i, c) in self.cycles.iter().enumerate() {
            if c.gpu_after > c.gpu_before + GPU_BOUND {
                failures.push(format!(
                    "cycle {i} ({}): GPU memory {} bytes after despawning everything, {} before (bound {GPU_BOUND})",
                    c.tier, c.gpu_after, c.gpu_before
                ));
            }
        }
        if let Some(first) = self.cycles.first().filter(|c| c.heap_after > 0) {
            for (i, c) in self.cycles.iter().enumerate().skip(1) {
                if c.heap_after > first.heap_after + HEAP_BOUND {
                    failures.push(format!(
                        "cycle {i}: the engine holds {} heap bytes, {} after the first cycle (bound {HEAP_BOUND})",
                        c.heap_after, first.heap_after
                    ));
                }
            }
        }
        failures
    }
}

/// Marks everything the soak's gameplay spawned.
#[derive(Component)]
pub struct Soaked;

/// The gameplay's state: its generator, caps, asset pools and counts.
#[derive(Resource)]
pub struct SoakGameplay {
    rng: SplitMix64,
    /// Whether the gameplay acts this frame (off while the driver settles and measures).
    pub active: bool,
    max_live: (usize, usize, usize),
    meshes: Vec<Handle<Mesh>>,
    materials: Vec<Handle<Material>>,
    textures: Vec<Handle<Image>>,
    decal_materials: Vec<Handle<DecalMaterial>>,
    /// What it did.
    pub counts: GameplayCounts,
    /// Most decals, lights and instances live at once since the last reset.
    pub peak_live: (u64, u64, u64),
}

impl SoakGameplay {
    fn pick<T: Copy>(rng: &mut SplitMix64, items: &[T]) -> Option<T> {
        (!items.is_empty()).then(|| items[(rng.next_u64() % items.len() as u64) as usize])
    }

    fn chance(&mut self, p: f32) -> bool {
        self.rng.next_f32() < p
    }

    fn below(&mut self, n: u64) -> u64 {
        self.rng.next_u64() % n.max(1)
    }

    /// Takes a random handle out of a pool that holds more than two, counting the removal.
    fn take_one<T>(&mut self, pool: impl Fn(&mut Self) -> &mut Vec<T>) -> Option<T> {
        let len = pool(self).len() as u64;
        if len <= 2 {
            return None;
        }
        let i = self.below(len) as usize;
        self.counts.assets_removed += 1;
        Some(pool(self).swap_remove(i))
    }

    fn point(&mut self, half: f32, y: (f32, f32)) -> Vec3 {
        Vec3::new(self.rng.range_f32(-half, half), self.rng.range_f32(y.0, y.1), self.rng.range_f32(-half, half))
    }
}

type LiveQueries<'w, 's> = (
    Query<'w, 's, Entity, (With<Decal>, With<Soaked>)>,
    Query<'w, 's, Entity, (Or<(With<PointLight>, With<SpotLight>, With<DirectionalLight>)>, With<Soaked>)>,
    Query<'w, 's, Entity, (With<MeshInstance>, With<Soaked>)>,
);

type SoakAssets<'w> =
    (ResMut<'w, Assets<Mesh>>, ResMut<'w, Assets<Material>>, ResMut<'w, Assets<Image>>, ResMut<'w, Assets<DecalMaterial>>);

/// One frame of random gameplay (see the module docs). Runs in `Update` while
/// [`SoakGameplay::active`].
pub fn soak_gameplay(
    mut commands: Commands,
    mut state: ResMut<SoakGameplay>,
    (decals, lights, instances): LiveQueries,
    mut transforms: Query<&mut Transform, With<Soaked>>,
    mut assets: SoakAssets,
) {
    if !state.active {
        return;
    }
    let s = &mut *state;
    let decals: Vec<Entity> = decals.iter().collect();
    let lights: Vec<Entity> = lights.iter().collect();
    let instances: Vec<Entity> = instances.iter().collect();
    s.peak_live =
        (s.peak_live.0.max(decals.len() as u64), s.peak_live.1.max(lights.len() as u64), s.peak_live.2.max(instances.len() as u64));
    let (meshes, materials, images, decal_materials) = &mut assets;

    // Assets come and go, sometimes while in use (users then fall back or warn once).
    if s.chance(0.03) || s.meshes.is_empty() {
        let mesh = match s.below(3) {
            0 => shapes::cuboid(Vec3::new(s.rng.range_f32(0.2, 1.5), s.rng.range_f32(0.2, 1.5), s.rng.range_f32(0.2, 1.5)), 1.0),
            1 => shapes::uv_sphere(s.rng.range_f32(0.2, 0.8), 8 + s.below(8) as u32, 6 + s.below(6) as u32),
            _ => shapes::cylinder(s.rng.range_f32(0.1, 0.6), s.rng.range_f32(0.3, 2.0), 6 + s.below(10) as u32, 1.0),
        };
        s.meshes.push(meshes.add(mesh));
        s.counts.assets_added += 1;
    }
    if s.chance(0.03) || s.textures.is_empty() {
        let size = 1 + s.below(16) as u32;
        let pixels: Vec<u8> = (0..size * size * 4).map(|_| s.below(256) as u8).collect();
        if let Ok(image) = Image::from_rgba8(size, size, pixels, ColorSpace::Srgb) {
            s.textures.push(images.add(image));
            s.counts.assets_added += 1;
        }
    }
    if s.chance(0.03) || s.materials.is_empty() {
        let color = Vec4::new(s.rng.next_f32(), s.rng.next_f32(), s.rng.next_f32(), 1.0);
        let texture = if s.chance(0.5) { SoakGameplay::pick(&mut s.rng, &s.textures) } else { None };
        let mut material =
            Material { base_color_texture: texture, ..Material::from_color(color, s.rng.next_f32(), s.rng.range_f32(0.1, 1.0)) };
        // A third are glass: drawn by the transparency passes, refracting now and then.
        if s.chance(0.33) {
            material.alpha_mode = AlphaMode::Blend;
            material.base_color.w = s.rng.range_f32(0.1, 0.9);
            material.thickness = if s.chance(0.5) { s.rng.range_f32(0.0, 0.5) } else { 0.0 };
        }
        s.materials.push(materials.add(material));
        s.counts.assets_added += 1;
    }
    if s.chance(0.03) || s.decal_materials.is_empty() {
        let color = Vec4::new(s.rng.next_f32(), s.rng.next_f32(), s.rng.next_f32(), s.rng.range_f32(0.3, 1.0));
        let texture = if s.chance(0.5) { SoakGameplay::pick(&mut s.rng, &s.textures) } else { None };
        let roughness = s.chance(0.5).then(|| s.rng.next_f32());
        s.decal_materials.push(decal_materials.add(DecalMaterial {
            base_color: Some(color),
            base_color_texture: texture,
            roughness,
            ..Default::default()
        }));
        s.counts.assets_added += 1;
    }
    if s.chance(0.01)
        && let Some(h) = s.take_one(|s| &mut s.meshes)
    {
        meshes.remove(h);
    }
    if s.chance(0.01)
        && let Some(h) = s.take_one(|s| &mut s.textures)
    {
        images.remove(h);
    }
    if s.chance(0.01)
        && let Some(h) = s.take_one(|s| &mut s.materials)
    {
        materials.remove(h);
    }
    if s.chance(0.01)
        && let Some(h) = s.take_one(|s| &mut s.decal_materials)
    {
        decal_materials.remove(h);
    }

    // Despawns first, remembered so that nothing is attached to an entity leaving this frame.
    let mut leaving = HashSet::new();
    let despawns = [(s.below(8), &decals), (s.below(3), &lights), (s.below(2), &instances)];
    for (n, pool) in despawns {
        for _ in 0..n {
            if let Some(e) = SoakGameplay::pick(&mut s.rng, pool) {
                commands.entity(e).try_despawn();
                leaving.insert(e);
                s.counts.despawned += 1;
            }
        }
    }
    let staying = |pool: &[Entity]| pool.iter().copied().filter(|e| !leaving.contains(e)).collect::<Vec<_>>();
    let parents = staying(&instances);

    // Spawns, up to the caps.
    let (max_decals, max_lights, max_instances) = s.max_live;
    for _ in 0..s.below(10).min(max_decals.saturating_sub(decals.len()) as u64) {
        let Some(material) = SoakGameplay::pick(&mut s.rng, &s.decal_materials) else { break };
        let size = s.rng.range_f32(0.1, 1.5);
        let at = s.point(5.0, (-0.2, 1.5));
        let transform = Transform::from_translation(at)
            .with_rotation(Quat::from_euler(glam::EulerRot::XYZ, s.rng.range_f32(-3.2, 3.2), s.rng.range_f32(-3.2, 3.2), 0.0))
            .with_scale(Vec3::new(size, size, s.rng.range_f32(0.1, 1.0)));
        let mut decal = Decal::new(material);
        decal.channel = s.below(4) as u8;
        decal.weight = s.rng.range_f32(0.1, 4.0);
        let mut entity = commands.spawn((decal, transform, Soaked));
        if s.chance(0.3) {
            entity.insert(DecalLifetime::new(s.rng.range_f32(0.05, 2.0), 0.5));
        }
        if s.chance(0.2)
            && let Some(parent) = SoakGameplay::pick(&mut s.rng, &parents)
        {
            entity.insert(ChildOf(parent));
        }
        s.counts.decals_spawned += 1;
    }
    for _ in 0..s.below(3).min(max_lights.saturating_sub(lights.len()) as u64) {
        let color = Vec3::new(s.rng.next_f32(), s.rng.next_f32(), s.rng.next_f32());
        let at = Transform::from_translation(s.point(5.0, (0.2, 3.0))).looking_at(s.point(3.0, (0.0, 0.0)), Vec3::Y);
        let range = s.chance(0.5).then(|| s.rng.range_f32(0.5, 8.0));
        let intensity = s.rng.range_f32(0.5, 40.0);
        match s.below(10) {
            0 => commands.spawn((DirectionalLight { color, illuminance: s.rng.range_f32(0.1, 3.0), ..Default::default() }, at, Soaked)),
            1..=4 => {
                let outer = s.rng.range_f32(0.1, 1.5);
                let light =
                    SpotLight { color, intensity, range, inner_angle: outer * s.rng.next_f32(), outer_angle: outer, ..Default::default() };
                commands.spawn((light, at, Soaked))
            }
            _ => commands.spawn((PointLight { color, intensity, range, ..Default::default() }, at, Soaked)),
        };
        s.counts.lights_spawned += 1;
    }
    for _ in 0..s.below(3).min(max_instances.saturating_sub(instances.len()) as u64) {
        let (Some(mesh), Some(material)) = (SoakGameplay::pick(&mut s.rng, &s.meshes), SoakGameplay::pick(&mut s.rng, &s.materials)) else {
            break;
        };
        let at = Transform::from_translation(s.point(5.0, (0.0, 2.0))).with_rotation(Quat::from_rotation_y(s.rng.range_f32(0.0, 6.3)));
        commands.spawn((MeshInstance { mesh, material }, at, Soaked));
        s.counts.instances_spawned += 1;
    }

    // Movement and reparenting of entities that stay.
    for pool in [staying(&decals), staying(&lights), parents.clone()] {
        for _ in 0..s.below(6) {
            if let Some(e) = SoakGameplay::pick(&mut s.rng, &pool)
                && let Ok(mut t) = transforms.get_mut(e)
            {
                t.translation += Vec3::new(s.rng.range_f32(-0.2, 0.2), s.rng.range_f32(-0.1, 0.1), s.rng.range_f32(-0.2, 0.2));
                t.translation = t.translation.clamp(Vec3::new(-6.0, -0.5, -6.0), Vec3::new(6.0, 4.0, 6.0));
                s.counts.moved += 1;
            }
        }
    }
    // Only decals and lights get parents (instances stay roots), so no cycle can form.
    let leaves: Vec<Entity> = staying(&decals).into_iter().chain(staying(&lights)).collect();
    if s.chance(0.3)
        && let Some(child) = SoakGameplay::pick(&mut s.rng, &leaves)
    {
        match SoakGameplay::pick(&mut s.rng, &parents).filter(|_| s.chance(0.6)) {
            Some(parent) => commands.entity(child).try_insert(ChildOf(parent)),
            None => commands.entity(child).try_remove::<ChildOf>(),
        };
        s.counts.reparented += 1;
    }
}

/// Resident set size of this process in bytes (Linux; 0 elsewhere).
pub fn resident_bytes() -> u64 {
    std::fs::read_to_string("/proc/self/statm")
        .ok()
        .and_then(|s| s.split_whitespace().nth(1).and_then(|pages| pages.parse::<u64>().ok()))
        .map_or(0, |pages| pages * 4096)
}

const DEBUG_VIEWS: [DebugView; 12] = [
    DebugView::Lit,
    DebugView::DecalHeatmap,
    DebugView::Albedo,
    DebugView::Normal,
    DebugView::RoughnessMetallic,
    DebugView::LightHeatmap,
    DebugView::ShadowRays,
    DebugView::DepthNormals,
    DebugView::Reflections,
    DebugView::AmbientOcclusion,
    DebugView::DecalFloor,
    DebugView::Lod,
];

const SIZES: [(u32, u32); 6] = [(1, 1), (2, 3), (17, 9), (48, 32), (33, 61), (64, 48)];

/// The configuration every measurement is taken in.
fn base_settings(settings: &mut RenderSettings, size: (u32, u32)) {
    settings.pipeline = PipelineKind::Deferred;
    settings.decal_method = DecalMethod::RayQuery;
    settings.lights.method = LightMethod::Tiled;
    settings.debug_view = DebugView::Lit;
    settings.bloom = render::BloomSettings::default();
    settings.occlusion = render::OcclusionSettings::default();
    settings.exposure = render::AutoExposure { enabled: true, ..Default::default() };
    settings.size = size;
}

/// Renders one frame and checks it: no rendering error, a finite image.
fn frame(app: &mut App, report: &mut SoakReport) -> Result<()> {
    app.update();
    report.frames_rendered += 1;
    if let Some(e) = app.world.resource::<RenderStats>().last_error.clone() {
        bail!("frame {}: {e}", report.frames_rendered);
    }
    let Some(mut renderer) = app.world.get_resource_mut::<GpuRenderer>() else {
        bail!("no renderer");
    };
    let hdr = renderer.0.read_hdr()?;
    let bad = hdr.iter().filter(|p| p.iter().any(|c| !c.is_finite())).count();
    if bad > 0 {
        report.non_finite_frames += 1;
        let tier = renderer.0.tier().name();
        let s = app.world.resource::<RenderSettings>();
        tracing::error!(
            frame = report.frames_rendered,
            pixels = bad,
            tier,
            pipeline = s.pipeline.name(),
            decals = s.decal_method.name(),
            lights = s.lights.method.name(),
            transparency = s.transparency.name(),
            culling = s.culling.name(),
            aa = s.aa.name(),
            reflections = s.reflections.mode.name(),
            half_res_reflections = s.reflections.half_resolution,
            in_shading = s.decals_in_forward_shading,
            view = ?s.debug_view,
            size = ?s.size,
            "non-finite pixels"
        );
    }
    Ok(())
}

fn settle(app: &mut App, report: &mut SoakReport, size: (u32, u32)) -> Result<u64> {
    base_settings(&mut app.world.resource_mut::<RenderSettings>(), size);
    // The sky's cubes, the bloom pyramid, the occlusion images and auto-exposure's record exist
    // before and after a cycle alike.
    app.insert_resource(engine::environment::Environment::default());
    for _ in 0..SETTLE_FRAMES {
        frame(app, report)?;
    }
    let renderer = &mut app.world.resource_mut::<GpuRenderer>().0;
    renderer.finish();
    Ok(renderer.gpu_memory_in_use())
}

fn collect_validation(app: &mut App, report: &mut SoakReport) {
    if let Some(renderer) = app.world.get_resource_mut::<GpuRenderer>() {
        let errors = renderer.0.take_validation_errors();
        report.validation_errors += errors.len();
        let room = 5usize.saturating_sub(report.first_validation_errors.len());
        report.first_validation_errors.extend(errors.into_iter().take(room));
    }
}

/// Runs a soak (see the module docs). Errors are things that stop the run (no device, a frame
/// that failed); what the run measured, failures included, is in the report.
pub fn run(config: &SoakConfig) -> Result<SoakReport> {
    let started = Instant::now();
    let mut report = SoakReport { seed: config.seed, ..Default::default() };
    let mut app = App::new();
    app.world.resource_mut::<Time>().set_fixed_step(Some(std::time::Duration::from_millis(16)));
    app.add_plugins(RenderPlugin::new(RenderSettings { size: config.size, ..Default::default() }));
    app.insert_resource(SoakGameplay {
        rng: SplitMix64::new(config.seed),
        active: false,
        max_live: config.max_live,
        meshes: Vec::new(),
        materials: Vec::new(),
        textures: Vec::new(),
        decal_materials: Vec::new(),
        counts: GameplayCounts::default(),
        peak_live: (0, 0, 0),
    });
    app.add_systems(Update, soak_gameplay);
    // The scene that stays: ground, a wall, a light, the camera.
    let ground = app.world.resource_mut::<Assets<Mesh>>().add(shapes::plane(14.0, 14.0, 1, 4.0));
    let wall = app.world.resource_mut::<Assets<Mesh>>().add(shapes::cuboid(Vec3::new(6.0, 3.0, 0.3), 1.0));
    let grey = app.world.resource_mut::<Assets<Material>>().add(Material::from_color(Vec4::new(0.6, 0.6, 0.6, 1.0), 0.0, 0.7));
    app.world.spawn((MeshInstance { mesh: ground, material: grey }, Transform::default()));
    app.world.spawn((MeshInstance { mesh: wall, material: grey }, Transform::from_xyz(0.0, 1.5, -3.0)));
    app.world.spawn((PointLight { intensity: 30.0, ..Default::default() }, Transform::from_xyz(0.0, 3.0, 1.0)));
    app.world.spawn((Camera::default(), Transform::from_xyz(0.0, 5.0, 7.0).looking_at(Vec3::new(0.0, 0.5, 0.0), Vec3::Y)));

    let mut rng = SplitMix64::new(config.seed ^ 0x5EED_5EED);
    let cycles = config.cycles.max(1);
    for cycle in 0..cycles {
        let tier = config.tiers[(rng.next_u64() % config.tiers.len().max(1) as u64) as usize % config.tiers.len().max(1)];
        let mut renderer_settings = RendererSettings::default();
        renderer_settings.device.validation = config.validation;
        renderer_settings.device.max_tier = tier;
        renderer_settings.device.shrink_after_frames = SHRINK_AFTER_FRAMES;
        // Gameplay's directional lights move the sky's sun, and each move refilters the sky: small
        // cubes keep that quick on lavapipe (the passes and their synchronization are the same).
        renderer_settings.environment_resolution = 64;
        restart_renderer(&mut app.world, renderer_settings)?;
        report.switches.tier += u64::from(cycle > 0);
        let applied_tier = app.world.resource::<GpuRenderer>().0.tier().name();
        let gpu_before = settle(&mut app, &mut report, config.size)?;
        let rss_before = resident_bytes();

        app.world.resource_mut::<SoakGameplay>().active = true;
        app.world.resource_mut::<SoakGameplay>().peak_live = (0, 0, 0);
        let frames = config.frames / cycles + u32::from(cycle < config.frames % cycles);
        let mut gpu_peak = gpu_before;
        let mut rss_samples = Vec::new();
        let mut heap_samples = Vec::new();
        let heap = || config.heap_bytes.map_or(0, |f| f());
        for f in 0..frames {
            if rng.next_u64().is_multiple_of(79) {
                use engine::environment::{Environment, EnvironmentSource};
                let source = match rng.next_u64() % 3 {
                    0 => EnvironmentSource::None,
                    1 => EnvironmentSource::Sky,
                    _ => EnvironmentSource::Uniform(Vec3::splat((rng.next_u64() % 8) as f32 * 0.1)),
                };
                app.insert_resource(Environment { source, ..Default::default() });
                report.switches.environment += 1;
            }
            let mut settings = app.world.resource_mut::<RenderSettings>();
            if rng.next_u64().is_multiple_of(83) {
                settings.tonemapper = render::Tonemapper::ALL[(rng.next_u64() % 3) as usize];
                settings.bloom.enabled = !settings.bloom.enabled;
                settings.exposure.enabled = !settings.exposure.enabled;
                settings.occlusion.method = render::OcclusionMethod::ALL[(rng.next_u64() % 3) as usize];
                report.switches.display += 1;
            }
            if rng.next_u64().is_multiple_of(37) {
                settings.pipeline = PipelineKind::ALL[(rng.next_u64() % 4) as usize];
                report.switches.pipeline += 1;
            }
            if rng.next_u64().is_multiple_of(41) {
                settings.decal_method = DecalMethod::ALL[(rng.next_u64() % DecalMethod::ALL.len() as u64) as usize];
                report.switches.decal_method += 1;
            }
            if rng.next_u64().is_multiple_of(43) {
                settings.lights.method = LightMethod::ALL[(rng.next_u64() % 3) as usize];
                report.switches.light_method += 1;
            }
            if rng.next_u64().is_multiple_of(53) {
                settings.transparency = TransparencyMethod::ALL[(rng.next_u64() % TransparencyMethod::ALL.len() as u64) as usize];
                report.switches.transparency += 1;
            }
            if rng.next_u64().is_multiple_of(59) {
                settings.culling = render::CullingMode::ALL[(rng.next_u64() % 3) as usize];
                report.switches.culling += 1;
            }
            if rng.next_u64().is_multiple_of(61) {
                settings.freeze_culling = !settings.freeze_culling;
                report.switches.culling += 1;
            }
            if rng.next_u64().is_multiple_of(47) {
                settings.debug_view = DEBUG_VIEWS[(rng.next_u64() % DEBUG_VIEWS.len() as u64) as usize];
                report.switches.debug_view += 1;
            }
            if rng.next_u64().is_multiple_of(67) {
                settings.decals_in_forward_shading = !settings.decals_in_forward_shading;
                report.switches.decal_method += 1;
            }
            if rng.next_u64().is_multiple_of(71) {
                settings.aa = render::AntiAliasing::ALL[(rng.next_u64() % render::AntiAliasing::ALL.len() as u64) as usize];
                report.switches.aa += 1;
            }
            if rng.next_u64().is_multiple_of(73) {
                let r = &mut settings.reflections;
                (r.mode, r.half_resolution) = match rng.next_u64() % 3 {
                    0 => (render::ReflectionMode::Off, false),
                    1 => (render::ReflectionMode::RayTraced, false),
                    _ => (render::ReflectionMode::RayTraced, true),
                };
                report.switches.reflections += 1;
            }
            if rng.next_u64().is_multiple_of(89) {
                settings.size = SIZES[(rng.next_u64() % SIZES.len() as u64) as usize];
                report.switches.resize += 1;
            }
            frame(&mut app, &mut report)?;
            if f % 8 == 0 {
                gpu_peak = gpu_peak.max(app.world.resource::<GpuRenderer>().0.gpu_memory_in_use());
            }
            if f % 100 == 0 {
                collect_validation(&mut app, &mut report);
            }
            if f % 250 == 249 {
                rss_samples.push(resident_bytes());
                heap_samples.push(heap());
            }
        }

        // The end of the cycle: everything it spawned goes, then the renderer settles.
        app.world.resource_mut::<SoakGameplay>().active = false;
        let soaked: Vec<Entity> = app.world.query_filtered::<Entity, With<Soaked>>().iter(&app.world).collect();
        for e in soaked {
            if let Ok(entity) = app.world.get_entity_mut(e) {
                entity.despawn();
            }
        }
        let gameplay = &mut *app.world.resource_mut::<SoakGameplay>();
        let peak_live = gameplay.peak_live;
        let (meshes, materials, textures, decal_materials) = (
            std::mem::take(&mut gameplay.meshes),
            std::mem::take(&mut gameplay.materials),
            std::mem::take(&mut gameplay.textures),
            std::mem::take(&mut gameplay.decal_materials),
        );
        for h in meshes {
            app.world.resource_mut::<Assets<Mesh>>().remove(h);
        }
        for h in materials {
            app.world.resource_mut::<Assets<Material>>().remove(h);
        }
        for h in textures {
            app.world.resource_mut::<Assets<Image>>().remove(h);
        }
        for h in decal_materials {
            app.world.resource_mut::<Assets<DecalMaterial>>().remove(h);
        }
        let gpu_after = settle(&mut app, &mut report, config.size)?;
        collect_validation(&mut app, &mut report);
        report.cycles.push(CycleReport {
            tier: applied_tier,
            frames,
            gpu_before,
            gpu_peak,
            gpu_after,
            rss_before,
            rss_after: resident_bytes(),
            rss_samples,
            heap_after: heap(),
            heap_samples,
            peak_live,
        });
        tracing::info!(cycle, tier = applied_tier, gpu_before, gpu_peak, gpu_after, "soak cycle done");
    }
    report.gameplay = app.world.resource::<SoakGameplay>().counts;
    report.seconds = started.elapsed().as_secs_f64();
    Ok(report)
}
