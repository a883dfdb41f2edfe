//! Hundreds of moving coloured lights over a field of pillars, culled per tile and shadowed by
//! ray tracing where the GPU can (the overlay, F1, switches the light method and shadows).
//!
//! `cargo run --example lights`; `-- --headless` renders offscreen.

use engine::app::BoxError;
use engine::prelude::*;
use plugins::overlay::OverlayPlugin;
use plugins::run::RunPlugin;
use plugins::{GpuPlugin, RenderPlugin, RenderSettings};

/// A light circling the centre: its radius, height, speed and phase.
#[derive(Component)]
struct Orbit {
    radius: f32,
    height: f32,
    speed: f32,
    phase: f32,
}

fn main() -> Result<(), BoxError> {
    let mut app = App::new();
    let settings = RenderSettings { ambient: Vec3::splat(0.005), ..Default::default() };
    app.add_plugins(RenderPlugin::new(settings));
    app.add_plugins(GpuPlugin::default());
    app.add_plugins(OverlayPlugin::default()); // drawn in the window; nothing to draw on headless
    app.add_plugins(RunPlugin::from_args("lights"));

    let world = &mut app.world;
    let floor = world.resource_mut::<Assets<Mesh>>().add(shapes::plane(40.0, 40.0, 1, 10.0));
    let pillar = world.resource_mut::<Assets<Mesh>>().add(shapes::cylinder(0.3, 3.0, 16, 1.0));
    let stone = world.resource_mut::<Assets<Material>>().add(Material::from_color(Vec4::new(0.7, 0.7, 0.7, 1.0), 0.0, 0.6));
    world.spawn((MeshInstance { mesh: floor, material: stone }, Transform::default()));
    for x in -4..=4 {
        for z in -4..=4 {
            world.spawn((MeshInstance { mesh: pillar, material: stone }, Transform::from_xyz(x as f32 * 4.0, 1.5, z as f32 * 4.0)));
        }
    }
    // 400 small lights on orbits of every radius, with colours around the hue circle.
    for i in 0..400 {
        let f = i as f32 / 400.0;
        let turn = f * std::f32::consts::TAU;
        let hue =
            Vec3::new(turn, turn + std::f32::consts::TAU / 3.0, turn + 2.0 * std::f32::consts::TAU / 3.0).map(|a| 0.5 + 0.5 * a.cos());
        let orbit =
            Orbit { radius: 2.0 + 16.0 * f, height: 0.4 + (i % 5) as f32 * 0.3, speed: 0.2 + (i % 7) as f32 * 0.05, phase: i as f32 };
        world.spawn((PointLight { color: hue, intensity: 3.0, range: Some(3.0), ..Default::default() }, Transform::default(), orbit));
    }
    world.spawn((Camera::default(), Transform::from_xyz(0.0, 14.0, 22.0).looking_at(Vec3::ZERO, Vec3::Y)));

    app.add_systems(Update, circle);
    app.run()
}

/// Moves every light along its orbit.
fn circle(time: Res<Time>, mut lights: Query<(&Orbit, &mut Transform)>) {
    for (orbit, mut transform) in &mut lights {
        let angle = orbit.phase + time.elapsed_secs() * orbit.speed;
        transform.translation = Vec3::new(angle.cos() * orbit.radius, orbit.height, angle.sin() * orbit.radius);
    }
}
