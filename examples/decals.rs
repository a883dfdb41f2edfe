//! Bullet holes: click to shoot whatever the cursor is on (the floor, the moving crate); each hole
//! fades out after a few seconds. A decal on the crate's lid rides with it (parented to it).
//!
//! `cargo run --example decals`; with `-- --headless` the gun fires by itself every few frames.

use engine::app::BoxError;
use engine::image::ColorSpace;
use engine::prelude::*;
use plugins::decal::{Decal, DecalLifetime, DecalMaterial};
use plugins::raycast::{RaycastPlugin, SceneRaycaster};
use plugins::run::RunPlugin;
use plugins::{GpuPlugin, RenderPlugin, RenderSettings};

/// The bullet-hole material, whether to fire by ourselves (headless runs), and frames so far.
#[derive(Resource)]
struct Gun {
    hole: Handle<DecalMaterial>,
    auto_fire: bool,
    frames: u32,
}

/// Marks the crate that slides back and forth.
#[derive(Component)]
struct Slide;

fn main() -> Result<(), BoxError> {
    let run = RunPlugin::from_args("decals");
    let mut app = App::new();
    app.add_plugins(RenderPlugin::new(RenderSettings::default()));
    app.add_plugins(GpuPlugin::default());
    app.add_plugins(engine::input::InputPlugin); // the window feeds mouse and keys into `Input`
    app.add_plugins(RaycastPlugin); // ray casts against the scene's triangles, kept up to date
    let auto_fire = run.is_headless();
    app.add_plugins(run);

    let world = &mut app.world;
    let floor = world.resource_mut::<Assets<Mesh>>().add(shapes::plane(10.0, 10.0, 1, 5.0));
    let crate_mesh = world.resource_mut::<Assets<Mesh>>().add(shapes::cuboid(Vec3::splat(0.8), 1.0));
    let grey = world.resource_mut::<Assets<Material>>().add(Material::from_color(Vec4::new(0.6, 0.6, 0.6, 1.0), 0.0, 0.8));
    let wood = world.resource_mut::<Assets<Material>>().add(Material::from_color(Vec4::new(0.55, 0.4, 0.25, 1.0), 0.0, 0.7));
    world.spawn((MeshInstance { mesh: floor, material: grey }, Transform::default()));
    world.spawn((
        DirectionalLight { illuminance: 3.0, ..Default::default() },
        Transform::default().looking_at(Vec3::new(-0.3, -1.0, -0.4), Vec3::Y),
    ));
    world.spawn((Camera::default(), Transform::from_xyz(0.0, 4.0, 6.0).looking_at(Vec3::ZERO, Vec3::Y)));

    // A decal material from a texture (alpha shapes the hole); the same one marks the crate.
    let assets = concat!(env!("CARGO_MANIFEST_DIR"), "/../assets/decals/");
    let albedo = Image::load(format!("{assets}bullet_hole_albedo.png").as_ref(), ColorSpace::Srgb)?;
    let albedo = world.resource_mut::<Assets<Image>>().add(albedo);
    let hole = DecalMaterial { base_color_texture: Some(albedo), roughness: Some(0.9), ..Default::default() };
    let hole = world.resource_mut::<Assets<DecalMaterial>>().add(hole);
    let crate_entity = world.spawn((MeshInstance { mesh: crate_mesh, material: wood }, Transform::from_xyz(0.0, 0.4, -1.0), Slide)).id();
    // On the crate's top face, projecting down into it; as its child it moves with it.
    let on_top = Transform::from_xyz(0.0, 0.45, 0.0).looking_at(Vec3::new(0.0, -1.0, 0.0), Vec3::Z).with_scale(Vec3::new(0.5, 0.5, 0.2));
    world.spawn((Decal::new(hole), on_top, ChildOf(crate_entity)));
    world.insert_resource(Gun { hole, auto_fire, frames: 0 });

    app.add_systems(Update, (shoot, slide));
    app.run()
}

/// On a click (or every 8th frame when firing by itself), a bullet hole where the aimed ray hits
/// the scene, projecting into the surface, living 5 s and fading over the last 2. A hole on the
/// crate becomes its child, so it moves with it.
fn shoot(
    mut commands: Commands,
    mut gun: ResMut<Gun>,
    input: Res<Input>,
    settings: Res<RenderSettings>,
    scene: Res<SceneRaycaster>,
    cameras: Query<(&Camera, &GlobalTransform)>,
    crates: Query<&GlobalTransform, With<Slide>>,
) {
    let viewport = settings.viewport();
    gun.frames += 1;
    let aim = if gun.auto_fire && gun.frames.is_multiple_of(8) {
        let t = gun.frames as f32 * 0.37;
        Some(viewport * Vec2::new(0.5 + 0.3 * t.sin(), 0.6 + 0.2 * t.cos()))
    } else if input.button_just_pressed(MouseButton::Left) {
        input.cursor
    } else {
        None
    };
    let (Some(cursor), Ok((camera, at))) = (aim, cameras.single()) else { return };
    let Some(hit) = camera.ray(at, cursor, viewport).and_then(|(origin, dir)| scene.cast(origin, dir, 100.0)) else { return };
    let up = if hit.normal.y.abs() > 0.9 { Vec3::Z } else { Vec3::Y };
    let mut hole = Transform::from_translation(hit.point).looking_at(hit.point - hit.normal, up).with_scale(Vec3::new(0.3, 0.3, 0.2));
    let mut decal = commands.spawn((Decal::new(gun.hole), DecalLifetime::new(5.0, 2.0)));
    if let Ok(on) = crates.get(hit.entity) {
        // In the crate's space, so that it rides along.
        hole = Transform::from_matrix(on.compute_matrix().inverse() * hole.compute_matrix());
        decal.insert(ChildOf(hit.entity));
    }
    decal.insert(hole);
}

/// Slides the crate back and forth along x.
fn slide(time: Res<Time>, mut crates: Query<&mut Transform, With<Slide>>) {
    for mut transform in &mut crates {
        transform.translation.x = 2.0 * (time.elapsed_secs() * 0.8).sin();
    }
}
