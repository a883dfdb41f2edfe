//! Shooting: a left click casts a ray from the player's camera through the [`Crosshair`] and
//! spawns a bullet-hole decal where it hits, and throws sparks off the surface there
//! ([`crate::effects::sparks`]), each leaving a small scorch mark where it first lands (a decal
//! the GPU writes: `plugins::particles::LeftDecal`).
//!
//! The ray goes through the crosshair's point on the screen as the renderer projects it (the
//! camera's projection at the aspect ratio of `RenderSettings::size`). The raycaster ignores the
//! player, so a shot never lands on it; the decal's receiver layers exclude [`PLAYER_LAYER`] as
//! well, so a hole next to the player's own meshes does not project onto them.
//!
//! The hole's box is [`GameSettings::bullet_hole_size`] wide and [`GameSettings::decal_depth`]
//! deep, centred on the hit point with local +Z along the surface normal (it projects along −Z
//! into the surface) and a random rotation about the normal, so repeated holes do not look
//! stamped. Holes live until [`super::DecalCap`] recycles them.
//!
//! [`PLAYER_LAYER`]: super::PLAYER_LAYER

use bevy_ecs::hierarchy::ChildOf;
use bevy_ecs::prelude::*;
use engine::camera::Camera;
use engine::input::{Input, MouseButton};
use engine::scene::Name;
use engine::transform::{GlobalTransform, Transform};
use glam::{Mat3, Quat, Vec2, Vec3};
use plugins::RenderSettings;
use plugins::decal::Decal;

use super::decal_cap::{GameDecal, SpawnOrder};
use super::player::Player;
use super::{GAME_DECAL_RECEIVERS, GameAssets, GameRng, GameSettings, GameStats};
use plugins::raycast::{Hit, SceneRaycaster};

/// Where the player aims, in normalised screen coordinates: (0, 0) is the top-left corner,
/// (1, 1) the bottom-right. The centre by default; scripts move it for a shot.
#[derive(Resource, Clone, Copy, Debug, PartialEq)]
pub struct Crosshair(pub Vec2);

impl Default for Crosshair {
    fn default() -> Self {
        Crosshair(Vec2::splat(0.5))
    }
}

/// Marks a bullet-hole decal.
#[derive(Component, Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct BulletHole;

/// The world-space ray through the normalised screen point `screen` ((0, 0) top-left, (1, 1)
/// bottom-right) of a camera at `camera_transform` (world space, scale ignored), for a viewport
/// of `aspect` = width / height: its origin (the eye) and unit direction. `None` for
/// non-finite input.
pub fn screen_ray(camera: &Camera, camera_transform: &Transform, aspect: f32, screen: Vec2) -> Option<(Vec3, Vec3)> {
    if !screen.is_finite() || !camera_transform.translation.is_finite() {
        return None;
    }
    let ndc = Vec2::new(2.0 * screen.x - 1.0, 1.0 - 2.0 * screen.y);
    // Reverse-Z: depth 1 is the near plane, the only finite one of an infinite projection.
    let near = camera.projection(aspect).inverse().project_point3(ndc.extend(1.0));
    let direction = (camera_transform.rotation.normalize() * near).try_normalize()?;
    Some((camera_transform.translation, direction))
}

/// The aspect ratio the renderer uses: from `RenderSettings::size`, or 16:9 without settings.
pub fn render_aspect(settings: Option<&RenderSettings>) -> f32 {
    settings.map_or(16.0 / 9.0, |s| s.size.0 as f32 / s.size.1.max(1) as f32)
}

/// The transform of a bullet hole at `hit`: `size` × `size` × `depth`, local +Z along the
/// normal, rotated by `angle` radians about it.
pub fn bullet_hole_transform(hit: &Hit, size: f32, depth: f32, angle: f32) -> Transform {
    let z = hit.normal;
    let x0 = z.any_orthonormal_vector();
    let x = x0 * angle.cos() + z.cross(x0) * angle.sin();
    let y = z.cross(x);
    Transform {
        translation: hit.point,
        rotation: Quat::from_mat3(&Mat3::from_cols(x, y, z)).normalize(),
        scale: Vec3::new(size, size, depth),
    }
}

/// On a left click, shoots from the player's camera through the [`Crosshair`] and spawns a
/// [`BulletHole`] decal at the hit (see the module docs), and a burst of
/// [`GameSettings::sparks`] sparks there. Counts shots and hits in
/// [`GameStats`].
#[allow(clippy::too_many_arguments)]
pub fn shoot(
    mut commands: Commands,
    input: Res<Input>,
    crosshair: Res<Crosshair>,
    render_settings: Option<Res<RenderSettings>>,
    settings: Res<GameSettings>,
    assets: Option<Res<GameAssets>>,
    raycaster: Res<SceneRaycaster>,
    mut rng: ResMut<GameRng>,
    mut order: ResMut<SpawnOrder<GameDecal>>,
    mut stats: ResMut<GameStats>,
    players: Query<(&Camera, &Transform), With<Player>>,
    globals: Query<&GlobalTransform>,
    (time, effects): (Res<engine::time::Time>, Option<Res<crate::effects::Effects>>),
) {
    if !input.button_just_pressed(MouseButton::Left) {
        return;
    }
    let (Some(assets), Ok((camera, transform))) = (assets, players.single()) else {
        return;
    };
    let aspect = render_aspect(render_settings.as_deref());
    let Some((origin, direction)) = screen_ray(camera, transform, aspect, crosshair.0) else {
        return;
    };
    stats.shots += 1;
    let Some(hit) = raycaster.cast(origin, direction, settings.max_shot_distance) else {
        return;
    };
    stats.hits += 1;
    if settings.sparks > 0 && effects.is_none_or(|e| e.0) {
        let (mut emitter, transform, keep) = crate::effects::sparks(hit.point, hit.normal, settings.sparks);
        // Each spark scorches where it first lands: a small dark mark, made on the GPU.
        emitter.leaves = Some(plugins::particles::LeftDecal::new(assets.bullet_hole, 0.06, 8.0));
        let until = time.elapsed_secs() + keep;
        commands.spawn((emitter, transform, crate::effects::Expires { until }, Name::new("Sparks")));
    }
    let angle = rng.0.range_f32(0.0, std::f32::consts::TAU);
    let mut decal = Decal::new(assets.bullet_hole);
    decal.receivers = GAME_DECAL_RECEIVERS;
    let entity = match (hit.rest, globals.get(hit.entity)) {
        // A skinned character: the hole goes on its skin, placed in its rest pose, so it stays
        // on the spot that was hit however the character moves (`Decal::on_skin`).
        (Some(rest), Ok(global)) => {
            let scale = global.0.matrix3.x_axis.length().max(1e-6);
            let at_rest = Hit { point: rest.point, normal: rest.normal, ..hit };
            let transform = bullet_hole_transform(&at_rest, settings.bullet_hole_size / scale, settings.decal_depth / scale, angle);
            commands.spawn((decal.on_skin(), transform, ChildOf(hit.entity), BulletHole, GameDecal, Name::new("Bullet hole (skin)"))).id()
        }
        _ => {
            let transform = bullet_hole_transform(&hit, settings.bullet_hole_size, settings.decal_depth, angle);
            commands.spawn((decal, transform, GlobalTransform::from(transform), BulletHole, GameDecal, Name::new("Bullet hole"))).id()
        }
    };
    order.push(entity);
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn screen_ray_matches_the_projection() {
        let camera = Camera::default();
        let transform = Transform::from_xyz(1.0, 2.0, 3.0).looking_at(Vec3::new(1.0, 2.0, -10.0), Vec3::Y);
        let aspect = 2.0;
        let (origin, centre) = screen_ray(&camera, &transform, aspect, Vec2::splat(0.5)).unwrap();
        assert_eq!(origin, transform.translation);
        assert!((centre - Vec3::NEG_Z).length() < 1e-5);
        // The top-right corner is at half the field of view up and (× aspect) to the right.
        let (_, corner) = screen_ray(&camera, &transform, aspect, Vec2::new(1.0, 0.0)).unwrap();
        let tan = (camera.fov_y * 0.5).tan();
        let expected = Vec3::new(tan * aspect, tan, -1.0).normalize();
        assert!((corner - expected).length() < 1e-5, "{corner} vs {expected}");
        // And projects back to that corner.
        let view_proj = camera.projection(aspect) * transform.compute_matrix().inverse();
        let ndc = view_proj.project_point3(origin + corner * 5.0);
        assert!((ndc.x - 1.0).abs() < 1e-4 && (ndc.y - 1.0).abs() < 1e-4);
        assert!(screen_ray(&camera, &transform, aspect, Vec2::NAN).is_none());
    }

    #[test]
    fn bullet_holes_face_out_of_the_surface() {
        let hit =
            Hit { t: 1.0, point: Vec3::new(0.0, 1.0, -2.0), normal: Vec3::new(0.0, 0.6, 0.8), entity: Entity::PLACEHOLDER, rest: None };
        for angle in [0.0, 1.0, 4.0] {
            let t = bullet_hole_transform(&hit, 0.25, 0.2, angle);
            assert!((t.rotation * Vec3::Z - hit.normal).length() < 1e-5);
            assert_eq!(t.translation, hit.point);
            assert_eq!(t.scale, Vec3::new(0.25, 0.25, 0.2));
        }
        let a = bullet_hole_transform(&hit, 0.25, 0.2, 0.0).rotation * Vec3::X;
        let b = bullet_hole_transform(&hit, 0.25, 0.2, 1.0).rotation * Vec3::X;
        assert!((a.dot(b) - 1f32.cos()).abs() < 1e-5, "rotated about the normal by the angle");
    }
}
