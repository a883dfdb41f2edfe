//! Windowed play: the sandbox's scene and game on the library's window runner
//! ([`plugins::window::WindowPlugin`]) with its debug overlay ([`plugins::overlay`]), plus the
//! sandbox's own overlay additions: a crosshair and buttons that spawn or clear decals and
//! lights.

use anyhow::{Context, Result, anyhow};
use bevy_ecs::prelude::{Component, Entity, IntoScheduleConfigs, Res, ResMut, Resource, With, World};
use engine::light::PointLight;
use engine::transform::Transform;
use glam::Vec3;
use plugins::GpuPlugin;
use plugins::decal::Decal;
use plugins::overlay::{OverlayExtension, OverlayPlugin};
use plugins::window::WindowPlugin;
use render::{DeviceSettings, RendererSettings};

pub use plugins::window::display_available;

use crate::headless::{HeadlessOptions, build_scene_app};

/// How to run the windowed sandbox.
#[derive(Clone, Debug)]
pub struct WindowOptions {
    /// Scene and rendering choices (frames = 0 runs until the window closes).
    pub base: HeadlessOptions,
    /// Exit after this many frames (for tests); `None` runs until closed.
    pub exit_after: Option<u32>,
    /// Resize the window to this size halfway through `exit_after` (for tests).
    pub resize_to: Option<(u32, u32)>,
}

/// Opens the window and plays until it closes (or `exit_after` frames).
pub fn run_windowed(opts: WindowOptions) -> Result<()> {
    let mut app = build_scene_app(&opts.base)?;
    let device = DeviceSettings { max_tier: opts.base.max_tier, ..Default::default() };
    let settings = RendererSettings {
        device,
        shadow_maps: opts.base.shadow_maps,
        environment_resolution: opts.base.environment_resolution,
        texture_budget: opts.base.texture_budget,
        particle_capacity: crate::headless::particle_capacity(&opts.base),
        ..Default::default()
    };
    app.add_plugins(GpuPlugin { settings });
    app.add_plugins(crate::game::GamePlugin);
    let camera = crate::game::find_camera(&mut app.world).context("the scene has no camera to play with")?;
    crate::game::setup_game(&mut app.world, camera)?;
    app.add_plugins(WindowPlugin {
        title: "ecs-decals sandbox".into(),
        size: Some(opts.base.size),
        grab_cursor_on_click: true,
        exit_after: opts.exit_after,
        resize_to: opts.resize_to,
    });
    app.add_plugins(OverlayPlugin::default().with(SandboxOverlay { spawn_count: 100, seed: 1 }));
    if let Some(path) = &opts.base.stats {
        let file = std::fs::File::create(path).with_context(|| format!("creating {}", path.display()))?;
        app.insert_resource(StatsFile { out: std::io::BufWriter::new(file), next_frame: 0, device: None });
        app.add_systems(engine::app::Render, note_device.after(plugins::RenderSystems::Collect).before(plugins::RenderSystems::Render));
        app.add_systems(engine::app::Render, write_stats.after(plugins::RenderSystems::Render));
    }
    app.run().map_err(|e| anyhow!("{e}"))
}

/// `--stats` in windowed play: one JSON line per finished frame, as headless runs write them.
#[derive(Resource)]
struct StatsFile {
    out: std::io::BufWriter<std::fs::File>,
    /// The first frame not yet written.
    next_frame: u64,
    /// The renderer's tier and device, once seen (pipelined, the renderer is on the render
    /// thread after the render schedule).
    device: Option<(&'static str, String)>,
}

/// Notes the renderer's tier and device once, while the renderer is in the world.
fn note_device(mut file: ResMut<StatsFile>, renderer: Option<Res<plugins::GpuRenderer>>) {
    if let Some(renderer) = renderer.filter(|_| file.device.is_none()) {
        file.device = Some((renderer.0.tier().name(), renderer.0.device_name().to_string()));
    }
}

fn write_stats(mut file: ResMut<StatsFile>, stats: Res<plugins::RenderStats>) {
    use std::io::Write;
    let StatsFile { out, next_frame, device } = &mut *file;
    let Some((tier, device)) = device else { return };
    let next = *next_frame;
    for s in stats.completed.iter().filter(|s| s.frame >= next) {
        if let Err(e) = writeln!(out, "{}", crate::stats::frame_json(s, tier, device)) {
            tracing::warn!("writing the stats file: {e}");
        }
        *next_frame = s.frame + 1;
    }
}

/// Marks lights spawned from the overlay (so "clear lights" leaves the scene's own alone).
#[derive(Component)]
pub struct OverlayLight;

/// The sandbox's additions to the overlay.
struct SandboxOverlay {
    spawn_count: usize,
    seed: u64,
}

impl OverlayExtension for SandboxOverlay {
    fn paint(&mut self, ctx: &egui::Context, _world: &mut World) {
        let centre = ctx.content_rect().center();
        let painter = ctx.layer_painter(egui::LayerId::new(egui::Order::Foreground, egui::Id::new("crosshair")));
        for (a, b) in [((-8.0, 0.0), (-3.0, 0.0)), ((3.0, 0.0), (8.0, 0.0)), ((0.0, -8.0), (0.0, -3.0)), ((0.0, 3.0), (0.0, 8.0))] {
            painter
                .line_segment([centre + egui::vec2(a.0, a.1), centre + egui::vec2(b.0, b.1)], egui::Stroke::new(2.0, egui::Color32::WHITE));
        }
    }

    fn controls(&mut self, ui: &mut egui::Ui, world: &mut World) {
        ui.separator();
        ui.add(egui::Slider::new(&mut self.spawn_count, 1..=5000).text("spawn count").logarithmic(true));
        ui.horizontal(|ui| {
            if ui.button("spawn decals").clicked() {
                self.spawn_decals(world);
            }
            if ui.button("clear decals").clicked() {
                despawn_all::<Decal>(world);
            }
        });
        ui.horizontal(|ui| {
            if ui.button("spawn lights").clicked() {
                self.spawn_lights(world);
            }
            if ui.button("clear lights").clicked() {
                despawn_all::<OverlayLight>(world);
            }
        });
    }
}

/// Despawns every entity with a `C`.
fn despawn_all<C: Component>(world: &mut World) {
    let entities: Vec<Entity> = world.query_filtered::<Entity, With<C>>().iter(world).collect();
    for e in entities {
        world.despawn(e);
    }
}

impl SandboxOverlay {
    fn spawn_decals(&mut self, world: &mut World) {
        let materials = crate::decal_textures::add_builtin_materials(world);
        self.seed += 1;
        crate::scatter::scatter_decals(world, self.spawn_count, self.seed, &materials);
    }

    fn spawn_lights(&mut self, world: &mut World) {
        self.seed += 1;
        let mut rng = crate::scatter::SplitMix64::new(self.seed);
        for _ in 0..self.spawn_count.min(256) {
            let colour = Vec3::new(rng.range_f32(0.2, 1.0), rng.range_f32(0.2, 1.0), rng.range_f32(0.2, 1.0));
            let at = Vec3::new(rng.range_f32(-20.0, 20.0), rng.range_f32(0.5, 4.0), rng.range_f32(-20.0, 20.0));
            world.spawn((
                PointLight { color: colour, intensity: 10.0, range: None, ..Default::default() },
                Transform::from_translation(at),
                OverlayLight,
            ));
        }
    }
}
