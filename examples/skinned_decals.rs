//! Bullet holes that stay on a character's skin: a skinned glTF model (the shared Fox, or any
//! given) walks on the spot, and each shot that hits it leaves a hole *on its skin*: the hit
//! reports where it is in the model's rest pose ([`plugins::raycast::Hit::rest`]), and a decal
//! placed there with [`Decal::on_skin`] as the model's child follows the skin however it bends.
//! With `--world`, the same holes are ordinary world decals: they stay where the shots landed
//! and the fox walks out from under them (what projected decals do in other engines).
//!
//! `cargo run --example skinned_decals -- [MODEL.glb] [--world]` (click to shoot; `--headless`
//! fires by itself at the model a few times, then lets it walk).

use engine::animation::AnimationPlayer;
use engine::gltf::GltfAnimations;
use engine::prelude::*;
use plugins::decal::{Decal, DecalMaterial};
use plugins::raycast::{Hit, RaycastPlugin, SceneRaycaster};
use plugins::{GpuPlugin, RenderPlugin, RenderSettings, run::RunPlugin};

/// The hole material, whether holes go on the skin, and the automatic gun of headless runs.
#[derive(Resource)]
struct Gun {
    hole: Handle<DecalMaterial>,
    on_skin: bool,
    auto_fire: bool,
    frames: u32,
}

fn main() -> Result<(), engine::app::BoxError> {
    let run = RunPlugin::from_args("skinned_decals");
    let auto_fire = run.is_headless();
    let mut app = App::new();
    app.add_plugins((RenderPlugin::new(RenderSettings::default()), GpuPlugin::default()));
    app.add_plugins((InputPlugin, RaycastPlugin, run));
    if auto_fire {
        // Headless: a fixed 1/60 s a frame, so that every run shoots the same holes.
        app.world.resource_mut::<Time>().set_fixed_step(Some(std::time::Duration::from_secs_f64(1.0 / 60.0)));
    }
    let args: Vec<String> = std::env::args().collect();
    let model = args.iter().skip(1).find(|a| a.ends_with(".glb") || a.ends_with(".gltf")).cloned();
    let model = model.unwrap_or_else(|| concat!(env!("CARGO_MANIFEST_DIR"), "/../../shared/assets/gltf/Fox/Fox.glb").to_owned());
    let root = engine::gltf::load(model.as_ref())?.spawn(&mut app.world);
    // Play its walk (or first) clip, on the spot.
    let clips = app.world.get::<GltfAnimations>(root).map(|c| c.0.clone()).unwrap_or_default();
    let names = app.world.resource::<Assets<engine::animation::AnimationClip>>();
    let walk = clips.iter().copied().find(|&c| names.get(c).is_some_and(|clip| clip.name() == "Walk")).or(clips.first().copied());
    if let Some(walk) = walk {
        app.world.entity_mut(root).insert(AnimationPlayer::new(walk));
    }
    engine::scene::frame_scene(&mut app.world); // a camera and lights around it, at any scale
    let hole = DecalMaterial { base_color: Some(Vec4::new(0.03, 0.02, 0.02, 1.0)), roughness: Some(1.0), ..Default::default() };
    let hole = app.world.resource_mut::<Assets<DecalMaterial>>().add(hole);
    let on_skin = !args.iter().any(|a| a == "--world");
    app.insert_resource(Gun { hole, on_skin, auto_fire, frames: 0 }).add_systems(Update, shoot);
    app.run()
}

/// Bones the headless gun aims at, in turn: legs (which swing) and the body.
const TARGETS: [&str; 6] =
    ["b_LeftForeArm_010", "b_RightLeg02_020", "b_Spine02_03", "b_RightForeArm_07", "b_LeftLeg02_016", "b_Tail02_013"];

/// A click (or, headless, a shot every 4th frame for the first 48 at the Fox's bones in turn)
/// fires along the cursor's ray; a hit on a skinned model leaves a hole on its skin.
#[allow(clippy::too_many_arguments)]
fn shoot(
    mut commands: Commands,
    mut gun: ResMut<Gun>,
    input: Res<Input>,
    view: Res<RenderSettings>,
    scene: Res<SceneRaycaster>,
    cameras: Query<(&Camera, &GlobalTransform)>,
    globals: Query<&GlobalTransform>,
    bones: Query<(&Name, &GlobalTransform)>,
) {
    gun.frames += 1;
    let viewport = view.viewport();
    let aim = if gun.auto_fire && gun.frames <= 48 && gun.frames.is_multiple_of(4) {
        // Where the bone is on screen (the ray through it hits the skin in front of it).
        let target = TARGETS[(gun.frames / 4) as usize % TARGETS.len()];
        let bone = bones.iter().find(|(name, _)| name.0 == target).map(|(_, g)| g.translation());
        let (Some(bone), Ok((camera, eye))) = (bone, cameras.single()) else { return };
        let clip = camera.projection(viewport.x / viewport.y) * eye.compute_matrix().inverse() * bone.extend(1.0);
        let ndc = clip.truncate() / clip.w;
        Some(Vec2::new(ndc.x + 1.0, 1.0 - ndc.y) * 0.5 * viewport)
    } else if input.button_just_pressed(MouseButton::Left) {
        input.cursor
    } else {
        None
    };
    let (Some(cursor), Ok((camera, eye))) = (aim, cameras.single()) else { return };
    let Some(hit) = scene.cast_from_cursor(camera, eye, cursor, viewport) else { return };
    let size = 0.04 * hit.t;
    let decal = Decal::new(gun.hole);
    match (hit.rest, globals.get(hit.entity)) {
        // On the skin: placed in the model's rest pose, as its child.
        (Some(rest), Ok(model)) if gun.on_skin => {
            let scale = model.compute_matrix().x_axis.truncate().length().max(1e-6);
            let at = facing(&Hit { point: rest.point, normal: rest.normal, ..hit }, size / scale);
            commands.spawn((decal.on_skin(), at, ChildOf(hit.entity)));
        }
        _ => {
            commands.spawn((decal, facing(&hit, size)));
        }
    }
}

/// A decal box `size` wide at the hit, projecting into the surface.
fn facing(hit: &Hit, size: f32) -> Transform {
    Transform::from_translation(hit.point)
        .looking_at(hit.point - hit.normal, hit.normal.any_orthonormal_vector())
        .with_scale(Vec3::new(size, size, size))
}
