//! Dropping lights: key L places a point light of a random vivid colour where the player looks.
//!
//! The light goes [`GameSettings::light_offset`] in front of the surface under the
//! [`Crosshair`] (along its normal, but no farther than halfway to whatever is in front of it),
//! or [`GameSettings::light_fallback_distance`] ahead when the player looks at nothing. Lights
//! carry [`GameLight`], so [`super::LightCap`] keeps their number bounded, recycling the oldest.

use bevy_ecs::prelude::*;
use engine::camera::Camera;
use engine::input::{Input, Key};
use engine::light::PointLight;
use engine::scene::Name;
use engine::transform::{GlobalTransform, Transform};
use glam::Vec3;
use plugins::RenderSettings;

use super::decal_cap::{GameLight, SpawnOrder};
use super::player::Player;
use super::shooting::{Crosshair, render_aspect, screen_ray};
use super::{GameRng, GameSettings, GameStats};
use crate::scatter::SplitMix64;
use plugins::raycast::SceneRaycaster;

/// A fully saturated-ish, full-brightness colour of random hue (linear RGB, max component 1).
pub fn vivid_colour(rng: &mut SplitMix64) -> Vec3 {
    let hue = rng.next_f32() * 6.0;
    let saturation = rng.range_f32(0.75, 1.0);
    // HSV → RGB with value 1.
    let channel = |offset: f32| {
        let k = (offset + hue) % 6.0;
        1.0 - saturation * k.min(4.0 - k).clamp(0.0, 1.0)
    };
    Vec3::new(channel(5.0), channel(3.0), channel(1.0))
}

/// Where a light dropped along the ray from `origin` in `direction` goes (see the module docs).
pub fn light_position(raycaster: &SceneRaycaster, settings: &GameSettings, origin: Vec3, direction: Vec3) -> Vec3 {
    let Some(hit) = raycaster.cast(origin, direction, settings.max_shot_distance) else {
        return origin + direction * settings.light_fallback_distance;
    };
    let start = hit.point + hit.normal * 1e-3;
    let room = raycaster.cast(start, hit.normal, settings.light_offset * 2.0).map_or(settings.light_offset, |obstacle| 0.5 * obstacle.t);
    start + hit.normal * settings.light_offset.min(room)
}

/// On L, drops a [`PointLight`] with [`GameLight`] where the player looks.
#[allow(clippy::too_many_arguments)]
pub fn drop_light(
    mut commands: Commands,
    input: Res<Input>,
    crosshair: Res<Crosshair>,
    render_settings: Option<Res<RenderSettings>>,
    settings: Res<GameSettings>,
    raycaster: Res<SceneRaycaster>,
    mut rng: ResMut<GameRng>,
    mut order: ResMut<SpawnOrder<GameLight>>,
    mut stats: ResMut<GameStats>,
    players: Query<(&Camera, &Transform), With<Player>>,
) {
    if !input.just_pressed(Key::L) {
        return;
    }
    let Ok((camera, transform)) = players.single() else {
        return;
    };
    let aspect = render_aspect(render_settings.as_deref());
    let Some((origin, direction)) = screen_ray(camera, transform, aspect, crosshair.0) else {
        return;
    };
    let position = light_position(&raycaster, &settings, origin, direction);
    let light = PointLight { color: vivid_colour(&mut rng.0), intensity: settings.light_intensity, range: None, ..Default::default() };
    let transform = Transform::from_translation(position);
    let entity = commands.spawn((light, transform, GlobalTransform::from(transform), GameLight, Name::new("Dropped light"))).id();
    order.push(entity);
    stats.lights += 1;
}

#[cfg(test)]
mod tests {
    use super::*;
    use bevy_ecs::entity::Entity;
    use engine::mesh::shapes;
    use glam::Affine3A;

    #[test]
    fn colours_are_vivid_and_varied() {
        let mut rng = SplitMix64::new(3);
        let colours: Vec<Vec3> = (0..64).map(|_| vivid_colour(&mut rng)).collect();
        for c in &colours {
            assert!((c.max_element() - 1.0).abs() < 1e-6, "{c}");
            assert!(c.min_element() <= 0.25 + 1e-6, "saturated: {c}");
            assert!(c.min_element() >= 0.0);
        }
        let reddest = colours.iter().filter(|c| c.x == 1.0).count();
        let greenest = colours.iter().filter(|c| c.y == 1.0).count();
        let bluest = colours.iter().filter(|c| c.z == 1.0).count();
        assert!(reddest > 5 && greenest > 5 && bluest > 5, "{reddest} {greenest} {bluest}");
    }

    #[test]
    fn lights_float_in_front_of_surfaces() {
        let floor = shapes::plane(10.0, 10.0, 1, 1.0);
        let raycaster = SceneRaycaster::from_meshes([(Entity::from_raw_u32(1).unwrap(), &floor, Affine3A::IDENTITY)]);
        let settings = GameSettings::default();
        let p = light_position(&raycaster, &settings, Vec3::new(0.0, 2.0, 0.0), Vec3::new(0.0, -1.0, -1.0));
        assert!((p - Vec3::new(0.0, 1.0 + 1e-3, -2.0)).length() < 1e-4, "{p}");
        let p = light_position(&raycaster, &settings, Vec3::new(0.0, 2.0, 0.0), Vec3::Y);
        assert!((p - Vec3::new(0.0, 5.0, 0.0)).length() < 1e-5, "{p}");
    }
}
