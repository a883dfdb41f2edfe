//! The sandbox's particle effects (`plugins::particles`): sparks where a shot hits, dust at the
//! walking character's feet, and the particle benchmark's fountain. `--no-particles` (the
//! [`Effects`] resource set to off) spawns none of them.

use bevy_ecs::prelude::*;
use engine::time::Time;
use engine::transform::Transform;
use glam::{Quat, Vec3};
use plugins::particles::{Contact, ParticleEmitter};

/// Whether the sandbox spawns particle effects (default on; `--no-particles` turns them off).
#[derive(Resource, Clone, Copy, Debug, PartialEq, Eq)]
pub struct Effects(pub bool);

impl Default for Effects {
    fn default() -> Self {
        Effects(true)
    }
}

/// Whether `world` wants effects.
pub fn effects_on(world: &World) -> bool {
    world.get_resource::<Effects>().is_none_or(|e| e.0)
}

/// An effect's emitter entity, despawned once its particles are gone: at `until` on the app's
/// clock ([`Time::elapsed_secs`]).
#[derive(Component, Clone, Copy, Debug, PartialEq)]
pub struct Expires {
    /// Seconds on the app's clock.
    pub until: f32,
}

/// Despawns the effects whose time is up.
pub fn expire_effects(mut commands: Commands, time: Res<Time>, effects: Query<(Entity, &Expires)>) {
    let now = time.elapsed_secs();
    for (entity, e) in &effects {
        if now >= e.until {
            commands.entity(entity).despawn();
        }
    }
}

/// A burst of `count` sparks thrown off a surface at `point` with normal `normal`, and how long
/// its entity is kept (its longest spark's life).
pub fn sparks(point: Vec3, normal: Vec3, count: u32) -> (ParticleEmitter, Transform, f32) {
    let emitter = ParticleEmitter::sparks(count);
    let rotation = Quat::from_rotation_arc(Vec3::Y, normal.try_normalize().unwrap_or(Vec3::Y));
    // Born 2 cm off the surface, so that the first step does not start behind it.
    let transform = Transform::from_translation(point + normal * 0.02).with_rotation(rotation);
    let keep = emitter.lifetime.1;
    (emitter, transform, keep)
}

/// Dust kicked up at a walking character's feet (a child of its root, so it follows it).
pub fn footstep_dust() -> ParticleEmitter {
    ParticleEmitter::dust(14.0)
}

/// The particle benchmark's fountain: enough particles a second to keep `alive` of them alive,
/// thrown up from `at` in a wide cone, bouncing on the ground until they die.
pub fn fountain(alive: u32) -> ParticleEmitter {
    let lifetime = (1.5, 2.5);
    ParticleEmitter {
        rate: alive as f32 / ((lifetime.0 + lifetime.1) * 0.5),
        lifetime,
        speed: (3.0, 6.0),
        cone_angle: 0.45,
        spawn_radius: 0.2,
        size: (0.03, 0.02),
        color: (glam::Vec4::new(0.4, 1.2, 3.0, 0.0), glam::Vec4::new(0.05, 0.1, 0.4, 0.0)),
        contact: Contact::Bounce { restitution: 0.3, friction: 0.8 },
        softness: 0.05,
        lit: 0.3,
        ..ParticleEmitter::default()
    }
}
