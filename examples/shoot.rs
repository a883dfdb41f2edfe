//! A glTF model in a window, lit, and a click shoots a fading bullet hole into whatever is under
//! the cursor: the whole game in under 30 lines of its own code.
//!
//! `cargo run --example shoot -- path/to/model.glb` (`--headless` renders offscreen).

use engine::prelude::*;
use plugins::decal::{Decal, DecalLifetime, DecalMaterial};
use plugins::raycast::{RaycastPlugin, SceneRaycaster};
use plugins::{GpuPlugin, RenderPlugin, RenderSettings, run::RunPlugin};

#[derive(Resource)]
struct Hole(Handle<DecalMaterial>);

fn main() -> Result<(), engine::app::BoxError> {
    let mut app = App::new();
    app.add_plugins((RenderPlugin::new(RenderSettings::default()), GpuPlugin::default()));
    app.add_plugins((InputPlugin, RaycastPlugin, RunPlugin::from_args("shoot")));
    let model = std::env::args().skip(1).find(|a| a.ends_with(".glb") || a.ends_with(".gltf")).ok_or("usage: shoot MODEL.glb")?;
    engine::gltf::load(model.as_ref())?.spawn(&mut app.world);
    engine::scene::frame_scene(&mut app.world); // a camera and lights around it, at any scale
    let hole = DecalMaterial { base_color: Some(Vec4::new(0.02, 0.02, 0.02, 1.0)), roughness: Some(1.0), ..Default::default() };
    let hole = app.world.resource_mut::<Assets<DecalMaterial>>().add(hole);
    app.insert_resource(Hole(hole)).add_systems(Update, shoot);
    app.run()
}

fn shoot(
    mut commands: Commands,
    hole: Res<Hole>,
    input: Res<Input>,
    view: Res<RenderSettings>,
    scene: Res<SceneRaycaster>,
    cameras: Query<(&Camera, &GlobalTransform)>,
) {
    let (Some(cursor), true, Ok((camera, eye))) = (input.cursor, input.button_just_pressed(MouseButton::Left), cameras.single()) else {
        return;
    };
    let Some(hit) = scene.cast_from_cursor(camera, eye, cursor, view.viewport()) else { return };
    let at = Transform::from_translation(hit.point).looking_at(hit.point - hit.normal, hit.normal.any_orthonormal_vector());
    commands.spawn((Decal::new(hole.0), at.with_scale(Vec3::splat(0.02 * hit.t)), DecalLifetime::new(10.0, 2.0)));
}
