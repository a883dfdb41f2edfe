//! The sandbox's particle effects (`plugins::particles`): sparks where a shot hits, dust at the
//! walking character's feet, rain that leaves wet spots (`--rain`), and the particle
//! benchmark's fountain. `--no-particles` (the [`Effects`] resource set to off) spawns none of
//! them.

use bevy_ecs::prelude::*;
use engine::asset::{Assets, Handle};
use engine::image::{ColorSpace, Image};
use engine::time::Time;
use engine::transform::Transform;
use glam::{Quat, Vec3};
use plugins::decal::DecalMaterial;
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

/// Rain emitters along each side of the square they cover ([`spawn_rain`]): each cell has one
/// of drops that only fall and die where they land, and one of drops that also leave a wet spot
/// ([`wet_spot`]) that dries over the last third of its 45 seconds.
const RAIN_GRID: usize = 4;
/// Drops a second each rain emitter starts.
const RAIN_RATE: f32 = 250.0;
/// Drops a second each wet-spot emitter starts, after a first burst that wets the ground at once.
const WET_RATE: f32 = 5.0;
/// The wet-spot emitters' first burst each.
const WET_BURST: u32 = 200;

/// Rain (`--rain`): drops falling over the `half`-metre square around `centre` (the courtyard),
/// streaked along their motion, dying where they land; some leave wet spots (a decal of low
/// roughness, so that the ray-traced reflections show the sky in them), made on the GPU where
/// the drop lands (`plugins::particles::LeftDecal`). Returns the emitters' entities.
pub fn spawn_rain(world: &mut World, centre: Vec3, half: f32) -> Vec<Entity> {
    let wet = wet_spot(world);
    let cell = 2.0 * half / RAIN_GRID as f32;
    // +Y (the launch cone's axis) pointing down.
    let down = Quat::from_rotation_x(std::f32::consts::PI);
    let drops = ParticleEmitter {
        rate: RAIN_RATE,
        lifetime: (2.5, 2.5),
        speed: (7.0, 9.0),
        cone_angle: 0.05,
        spawn_radius: 0.6 * cell,
        acceleration: Vec3::new(0.0, -9.81, 0.0),
        drag: 1.0,
        size: (0.012, 0.012),
        // Premultiplied: a pale grey-blue at a quarter coverage.
        color: (glam::Vec4::new(0.15, 0.16, 0.19, 0.25), glam::Vec4::new(0.15, 0.16, 0.19, 0.25)),
        contact: Contact::Die,
        softness: 0.02,
        lit: 0.6,
        stretch: 0.04,
        ..ParticleEmitter::default()
    };
    let wetting = ParticleEmitter {
        rate: WET_RATE,
        burst: WET_BURST,
        leaves: Some(plugins::particles::LeftDecal { material: wet, size: 0.9, depth: 0.4, lifetime: 45.0, fade: 15.0 }),
        ..drops.clone()
    };
    let mut spawned = Vec::with_capacity(2 * RAIN_GRID * RAIN_GRID);
    for i in 0..RAIN_GRID {
        for j in 0..RAIN_GRID {
            let at = centre + Vec3::new(-half + (i as f32 + 0.5) * cell, 14.0, -half + (j as f32 + 0.5) * cell);
            let transform = Transform::from_translation(at).with_rotation(down);
            spawned.push(world.spawn((drops.clone(), transform, bevy_ecs::name::Name::new("Rain"))).id());
            spawned.push(world.spawn((wetting.clone(), transform, bevy_ecs::name::Name::new("Rain (wet spots)"))).id());
        }
    }
    spawned
}

/// The wet spot rain leaves: a soft round patch ([`spot_texture`]) that darkens the surface and
/// lowers its roughness to 0.1, so that the reflections show in it.
pub fn wet_spot(world: &mut World) -> Handle<DecalMaterial> {
    let texture = spot_texture(world);
    let material = DecalMaterial {
        base_color_texture: Some(texture),
        // Wet stone is darker, and smooth: the reflections take over.
        base_color: Some(glam::Vec4::new(0.1, 0.1, 0.1, 1.0)),
        roughness: Some(0.1),
        ..Default::default()
    };
    world.resource_mut::<Assets<DecalMaterial>>().add(material)
}

/// A dark spot of soot: the patch of [`spot_texture`] in near black, roughness untouched.
pub fn soot_spot(world: &mut World) -> Handle<DecalMaterial> {
    let texture = spot_texture(world);
    let material =
        DecalMaterial { base_color_texture: Some(texture), base_color: Some(glam::Vec4::new(0.02, 0.02, 0.02, 1.0)), ..Default::default() };
    world.resource_mut::<Assets<DecalMaterial>>().add(material)
}

/// A soft round patch, 64×64: its coverage (alpha) falls off towards a rim that wanders a
/// little with the angle, so that the spots are not perfect discs; white.
pub fn spot_texture(world: &mut World) -> Handle<Image> {
    const SIDE: u32 = 64;
    let mut texels = Vec::with_capacity((SIDE * SIDE * 4) as usize);
    for y in 0..SIDE {
        for x in 0..SIDE {
            let p = glam::Vec2::new(x as f32 + 0.5, y as f32 + 0.5) / SIDE as f32 * 2.0 - glam::Vec2::ONE;
            let angle = p.y.atan2(p.x);
            let rim = 0.85 + 0.08 * (3.0 * angle).sin() + 0.05 * (7.0 * angle + 1.3).sin();
            let t = ((rim - p.length()) / 0.3).clamp(0.0, 1.0);
            let coverage = t * t * (3.0 - 2.0 * t);
            texels.extend_from_slice(&[255, 255, 255, (coverage * 255.0).round() as u8]);
        }
    }
    let image = Image::from_rgba8(SIDE, SIDE, texels, ColorSpace::Linear).expect("a 64×64 image of 64×64×4 bytes");
    world.resource_mut::<Assets<Image>>().add(image)
}
