//! The smallest game: a spinning cube on a floor, a light and a camera, in a window.
//!
//! `cargo run --example minimal`; `cargo run --example minimal -- --headless --frames 10 --size 320x240
//! --screenshot minimal.png` renders offscreen instead (as CI does).

use engine::app::BoxError;
use engine::prelude::*;
use plugins::run::RunPlugin;
use plugins::{GpuPlugin, RenderPlugin, RenderSettings};

/// Marks the cube that spins.
#[derive(Component)]
struct Spin;

fn main() -> Result<(), BoxError> {
    let mut app = App::new();
    // Extraction and rendering, the Vulkan renderer, and a window (or --headless).
    app.add_plugins(RenderPlugin::new(RenderSettings::default()));
    app.add_plugins(GpuPlugin::default());
    app.add_plugins(RunPlugin::from_args("minimal"));

    let world = &mut app.world;
    let cube = world.resource_mut::<Assets<Mesh>>().add(shapes::cuboid(Vec3::ONE, 1.0));
    let floor = world.resource_mut::<Assets<Mesh>>().add(shapes::plane(8.0, 8.0, 1, 4.0));
    let red = world.resource_mut::<Assets<Material>>().add(Material::from_color(Vec4::new(0.8, 0.1, 0.1, 1.0), 0.0, 0.4));
    let grey = world.resource_mut::<Assets<Material>>().add(Material::from_color(Vec4::new(0.6, 0.6, 0.6, 1.0), 0.0, 0.8));
    world.spawn((MeshInstance { mesh: cube, material: red }, Transform::from_xyz(0.0, 0.5, 0.0), Spin));
    world.spawn((MeshInstance { mesh: floor, material: grey }, Transform::default()));
    world.spawn((PointLight { intensity: 40.0, ..Default::default() }, Transform::from_xyz(2.0, 3.0, 2.0)));
    world.spawn((Camera::default(), Transform::from_xyz(3.0, 2.5, 4.0).looking_at(Vec3::new(0.0, 0.5, 0.0), Vec3::Y)));

    app.add_systems(Update, spin);
    app.run()
}

/// Turns the cube half a turn a second.
fn spin(time: Res<Time>, mut cubes: Query<&mut Transform, With<Spin>>) {
    for mut transform in &mut cubes {
        transform.rotation *= Quat::from_rotation_y(std::f32::consts::PI * 0.5 * time.delta_secs());
    }
}
