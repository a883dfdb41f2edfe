//! GPU particles from gameplay: a grinder throws sparks off a spinning crate's corner, and a
//! click throws a burst of sparks where it hits, bouncing on the floor and glowing into bloom.
//! The particles live on the GPU; the game only spawns emitters.
//!
//! `cargo run --example sparks` (`-- --headless --click 80,90` renders offscreen and clicks).

use engine::prelude::*;
use plugins::particles::ParticleEmitter;
use plugins::raycast::{RaycastPlugin, SceneRaycaster};
use plugins::{GpuPlugin, RenderPlugin, RenderSettings, run::RunPlugin};

fn main() -> Result<(), engine::app::BoxError> {
    let mut app = App::new();
    app.add_plugins((RenderPlugin::new(RenderSettings::default()), GpuPlugin::default()));
    app.add_plugins((InputPlugin, RaycastPlugin, RunPlugin::from_args("sparks")));
    let world = &mut app.world;
    let floor = world.resource_mut::<Assets<Mesh>>().add(shapes::plane(12.0, 12.0, 1, 4.0));
    let crate_mesh = world.resource_mut::<Assets<Mesh>>().add(shapes::cuboid(Vec3::ONE, 1.0));
    let dark = world.resource_mut::<Assets<Material>>().add(Material::from_color(Vec4::new(0.2, 0.2, 0.22, 1.0), 0.0, 0.6));
    world.spawn((MeshInstance { mesh: floor, material: dark }, Transform::default()));
    let spinner = world.spawn((MeshInstance { mesh: crate_mesh, material: dark }, Transform::from_xyz(0.0, 0.5, 0.0))).id();
    // A steady stream off the crate's top corner, riding along as the crate turns.
    let grinder = ParticleEmitter { rate: 300.0, burst: 0, ..ParticleEmitter::sparks(0) };
    world.spawn((grinder, Transform::from_xyz(0.5, 0.5, 0.5).with_rotation(Quat::from_rotation_z(-0.8)), ChildOf(spinner)));
    world.spawn((PointLight { intensity: 20.0, ..Default::default() }, Transform::from_xyz(2.0, 3.0, 2.0)));
    // One emitter for the clicks: each click inserts it again where it hit, which starts its burst.
    let clicks = world.spawn((ParticleEmitter { rate: 0.0, ..ParticleEmitter::sparks(0) }, Transform::default())).id();
    world.insert_resource(Clicks(clicks));
    world.spawn((Camera::default(), Transform::from_xyz(3.0, 2.5, 4.0).looking_at(Vec3::new(0.0, 0.5, 0.0), Vec3::Y)));
    app.add_systems(Update, (spin, throw_sparks));
    app.run()
}

#[derive(Resource)]
struct Clicks(Entity);

/// Turns every mesh above the floor a quarter turn a second.
fn spin(time: Res<Time>, mut meshes: Query<&mut Transform, (With<MeshInstance>, Without<ChildOf>)>) {
    for mut t in meshes.iter_mut().filter(|t| t.translation.y > 0.0) {
        t.rotation *= Quat::from_rotation_y(std::f32::consts::FRAC_PI_2 * time.delta_secs());
    }
}

/// A click throws 60 sparks off the surface under the cursor (its normal is the cone's axis).
fn throw_sparks(
    mut commands: Commands,
    clicks: Res<Clicks>,
    input: Res<Input>,
    view: Res<RenderSettings>,
    scene: Res<SceneRaycaster>,
    cameras: Query<(&Camera, &GlobalTransform)>,
) {
    let (Some(cursor), true, Ok((camera, eye))) = (input.cursor, input.button_just_pressed(MouseButton::Left), cameras.single()) else {
        return;
    };
    let Some(hit) = scene.cast_from_cursor(camera, eye, cursor, view.viewport()) else { return };
    let axis = Quat::from_rotation_arc(Vec3::Y, hit.normal);
    let at = Transform::from_translation(hit.point + hit.normal * 0.02).with_rotation(axis);
    commands.entity(clicks.0).insert((ParticleEmitter::sparks(60), at));
}
