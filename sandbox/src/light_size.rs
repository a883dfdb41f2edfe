//! `--light-radius METRES`: every point and spot light (the scene's, and those gameplay spawns
//! later) gets that radius, so that their ray-traced shadows soften by the same rule
//! (`engine::light::PointLight::radius`), for comparisons with hard shadows.

use bevy_ecs::prelude::*;
use engine::light::{PointLight, SpotLight};

/// The radius every point and spot light is given, metres.
#[derive(Resource, Clone, Copy, Debug, PartialEq)]
pub struct LightRadius(pub f32);

/// Gives the lights inserted since it last ran [`LightRadius`]'s radius: inserts each again with
/// it (lights are immutable components), once, as its radius then matches.
pub fn apply_light_radius(
    radius: Res<LightRadius>,
    points: Query<(Entity, &PointLight), Added<PointLight>>,
    spots: Query<(Entity, &SpotLight), Added<SpotLight>>,
    mut commands: Commands,
) {
    let r = radius.0;
    for (entity, light) in &points {
        if light.radius != r {
            commands.entity(entity).insert(PointLight { radius: r, ..*light });
        }
    }
    for (entity, light) in &spots {
        if light.radius != r {
            commands.entity(entity).insert(SpotLight { radius: r, ..*light });
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use bevy_ecs::system::RunSystemOnce;

    #[test]
    fn every_point_and_spot_light_gets_the_radius_once() {
        let mut world = World::new();
        world.insert_resource(LightRadius(0.3));
        let point = world.spawn(PointLight::default()).id();
        let spot = world.spawn(SpotLight { radius: 0.1, ..Default::default() }).id();
        world.run_system_once(apply_light_radius).unwrap();
        assert_eq!(world.get::<PointLight>(point).unwrap().radius, 0.3);
        assert_eq!(world.get::<SpotLight>(spot).unwrap().radius, 0.3);
        // A light that already has it is left alone (no endless re-insertion).
        let tick = world.change_tick();
        world.run_system_once(apply_light_radius).unwrap();
        assert!(!world.entity(point).get_ref::<PointLight>().unwrap().last_changed().is_newer_than(tick, world.change_tick()));
    }
}
