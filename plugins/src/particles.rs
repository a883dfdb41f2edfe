//! GPU particles as ECS components: a [`ParticleEmitter`] on any entity starts particles where
//! its transform puts it (following its parent like anything else), and the renderer moves,
//! collides and draws them on the GPU (`render::particles`): the CPU does nothing per particle.
//!
//! Like decals and lights, an emitter is an immutable component: to change one, insert a new
//! one (a hook lists the entity for extraction, which visits only the emitters that changed or
//! moved). Inserting an emitter with a `burst` starts the burst; inserting it again starts it
//! again (so does a renderer restart, which starts every emitter afresh with an empty pool).
//! Despawning an emitter (or removing the component) stops it; its particles live out their
//! lives. A sprite texture whose image arrives later, or is replaced, is picked up when it
//! uploads.
//!
//! ```
//! use engine::prelude::*;
//! use plugins::particles::ParticleEmitter;
//!
//! // Sparks where a shot hits, thrown off the surface (+Y of the transform is the cone's axis).
//! fn sparks_at(commands: &mut Commands, hit: Vec3, normal: Vec3) {
//!     let axis = Quat::from_rotation_arc(Vec3::Y, normal);
//!     commands.spawn((ParticleEmitter::sparks(40), Transform::from_translation(hit).with_rotation(axis)));
//! }
//! ```

use bevy_ecs::prelude::*;
use engine::asset::Handle;
use engine::changes::Inserted;
use engine::image::Image;
use engine::transform::GlobalTransform;
use glam::{Vec3, Vec4};
use render::layout::{
    GpuEmitter, NO_DECAL, PARTICLE_CONTACT_BOUNCE, PARTICLE_CONTACT_DIE, PARTICLE_CONTACT_NONE, PARTICLE_CONTACT_STICK, TEXTURE_WHITE,
};

use crate::decal::DecalMaterial;
use render::particles::Emitter;

use crate::{MirrorSlots, RenderMirror, RenderStats};

/// What a particle does when it touches a surface (the surface the depth buffer shows).
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Contact {
    /// It passes through.
    None,
    /// It dies there.
    Die,
    /// It bounces: `restitution` is the share of its speed along the normal it keeps, `friction`
    /// the share of its speed along the surface.
    Bounce {
        /// Share of the normal speed kept (0: no bounce, 1: elastic).
        restitution: f32,
        /// Share of the speed along the surface kept (1: frictionless).
        friction: f32,
    },
    /// It stops where it touched and stays for the rest of its life.
    Stick,
}

/// The decal a landing particle leaves where it first touches a surface
/// ([`ParticleEmitter::leaves`]): scorch marks from sparks, wet spots from rain. The GPU writes
/// it into a ring of `RendererSettings::particle_decals` places (the oldest overwritten first),
/// and every decal method applies it from the same frame on, like any decal.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct LeftDecal {
    /// What it applies (a decal material of `Assets<DecalMaterial>`).
    pub material: Handle<DecalMaterial>,
    /// Its box's side along the surface, metres (turned about the normal at random; 0: no
    /// decal).
    pub size: f32,
    /// Its box's depth across the surface, metres.
    pub depth: f32,
    /// Seconds it lives, its fade included (0: until the ring overwrites it).
    pub lifetime: f32,
    /// Seconds over which it fades out at the end of its life.
    pub fade: f32,
}

impl LeftDecal {
    /// A decal of `material`, `size` metres across, as deep as wide, fading out over the last
    /// quarter of `lifetime` seconds.
    pub fn new(material: Handle<DecalMaterial>, size: f32, lifetime: f32) -> Self {
        Self { material, size, depth: size, lifetime, fade: lifetime * 0.25 }
    }
}

/// Starts particles where its entity's transform puts it: at a rate, in bursts, or both. The
/// launch cone is about the transform's +Y. Needs a `Transform` (added automatically).
///
/// Colours are premultiplied linear radiance: `color_start.xyz` is the light the particle adds
/// where its sprite covers (values above 1 glow and bloom), and `w` how much of what is behind
/// it hides (0: light added, nothing hidden, as for sparks; 1: covering, as for debris).
#[derive(Component, Clone, Debug, PartialEq)]
#[require(engine::transform::Transform)]
#[component(immutable, on_insert = engine::changes::note_inserted::<Self>)]
pub struct ParticleEmitter {
    /// Particles a second (0: bursts only).
    pub rate: f32,
    /// Particles started at once when the component is inserted.
    pub burst: u32,
    /// Life in seconds: shortest and longest (each particle draws one between them).
    pub lifetime: (f32, f32),
    /// Launch speed in m/s: slowest and fastest.
    pub speed: (f32, f32),
    /// Half-angle of the launch cone about +Y, radians (0: straight along +Y, π: every way).
    pub cone_angle: f32,
    /// Radius of the sphere particles are born in, metres.
    pub spawn_radius: f32,
    /// Acceleration in m/s² (gravity, wind); default (0, −9.81, 0).
    pub acceleration: Vec3,
    /// Drag: the share of velocity lost per second is 1 − e^−drag.
    pub drag: f32,
    /// Quad side in metres at birth and at death.
    pub size: (f32, f32),
    /// Premultiplied colour at birth and at death (see the type's docs).
    pub color: (Vec4, Vec4),
    /// Sprite texture (alpha is coverage); `None`: a soft round dot.
    pub texture: Option<Handle<Image>>,
    /// Flipbook frames across and down the texture, played once over a particle's life.
    pub flipbook: (u32, u32),
    /// What a particle does when it touches a surface.
    pub contact: Contact,
    /// How far (metres) in front of the surface behind it a particle fades out (0: a hard
    /// edge where it meets the surface).
    pub softness: f32,
    /// How much of the scene's light it takes, 0 to 1 (0: its colour alone, as for sparks; 1:
    /// lit like a matte sprite facing each light, as for dust).
    pub lit: f32,
    /// Streaks: each quad is drawn along its particle's motion on screen, as long as the
    /// distance it covers in this many seconds plus its size (0: square quads; sparks 0.02).
    pub stretch: f32,
    /// The decal each particle leaves where it first touches a surface (`None`: none).
    pub leaves: Option<LeftDecal>,
}

impl Default for ParticleEmitter {
    fn default() -> Self {
        Self {
            rate: 20.0,
            burst: 0,
            lifetime: (1.0, 2.0),
            speed: (1.0, 2.0),
            cone_angle: 0.3,
            spawn_radius: 0.0,
            acceleration: Vec3::new(0.0, -9.81, 0.0),
            drag: 0.0,
            size: (0.05, 0.05),
            color: (Vec4::new(1.0, 1.0, 1.0, 1.0), Vec4::new(1.0, 1.0, 1.0, 1.0)),
            texture: None,
            flipbook: (1, 1),
            contact: Contact::Bounce { restitution: 0.4, friction: 0.8 },
            softness: 0.05,
            lit: 1.0,
            stretch: 0.0,
            leaves: None,
        }
    }
}

impl ParticleEmitter {
    /// A burst of `count` glowing sparks: fast, in a wide cone, bouncing, cooling from white-hot
    /// orange to nothing in under a second.
    pub fn sparks(count: u32) -> Self {
        Self {
            rate: 0.0,
            burst: count,
            lifetime: (0.4, 0.9),
            speed: (2.5, 6.0),
            cone_angle: 1.1,
            drag: 1.0,
            size: (0.025, 0.01),
            color: (Vec4::new(12.0, 6.0, 2.0, 0.0), Vec4::new(1.5, 0.2, 0.0, 0.0)),
            contact: Contact::Bounce { restitution: 0.35, friction: 0.7 },
            softness: 0.0,
            lit: 0.0,
            stretch: 0.02,
            ..Self::default()
        }
    }

    /// Dust kicked up off the ground: slow, lit, fading, settling under light drag.
    pub fn dust(rate: f32) -> Self {
        Self {
            rate,
            lifetime: (0.8, 1.6),
            speed: (0.3, 0.9),
            cone_angle: 0.9,
            spawn_radius: 0.1,
            acceleration: Vec3::new(0.0, -0.6, 0.0),
            drag: 2.0,
            size: (0.08, 0.3),
            color: (Vec4::new(0.35, 0.3, 0.25, 0.35), Vec4::ZERO),
            contact: Contact::Stick,
            softness: 0.15,
            lit: 1.0,
            ..Self::default()
        }
    }

    /// The renderer's record of this emitter at `transform` (`texture`: the sprite's bindless
    /// slot; `decal_material`: the slot of [`ParticleEmitter::leaves`]' material, `None` for no
    /// decal). Out-of-range values are clamped: negative times, speeds and sizes count as 0,
    /// bounds given the wrong way round are swapped, `lit` is kept within 0 to 1.
    pub fn emitter(&self, transform: glam::Mat4, texture: u32, decal_material: Option<u32>) -> Emitter {
        let ordered = |(a, b): (f32, f32)| {
            let (a, b) = (finite_or(a, 0.0).max(0.0), finite_or(b, 0.0).max(0.0));
            (a.min(b), a.max(b))
        };
        let (lifetime_min, lifetime_max) = ordered(self.lifetime);
        let (speed_min, speed_max) = ordered(self.speed);
        let (contact, restitution, friction) = match self.contact {
            Contact::None => (PARTICLE_CONTACT_NONE, 0.0, 0.0),
            Contact::Die => (PARTICLE_CONTACT_DIE, 0.0, 0.0),
            Contact::Bounce { restitution, friction } => {
                (PARTICLE_CONTACT_BOUNCE, finite_or(restitution, 0.0).clamp(0.0, 1.0), finite_or(friction, 1.0).clamp(0.0, 1.0))
            }
            Contact::Stick => (PARTICLE_CONTACT_STICK, 0.0, 0.0),
        };
        let colour = |c: Vec4| if c.is_finite() { c.max(Vec4::ZERO) } else { Vec4::ZERO };
        let (cells_x, cells_y) = (self.flipbook.0.clamp(1, 0xFFFF), self.flipbook.1.clamp(1, 0xFFFF));
        Emitter {
            record: GpuEmitter {
                transform,
                color_start: colour(self.color.0),
                color_end: colour(self.color.1),
                acceleration: if self.acceleration.is_finite() { self.acceleration } else { Vec3::ZERO },
                drag: finite_or(self.drag, 0.0).max(0.0),
                size_start: finite_or(self.size.0, 0.0).max(0.0),
                size_end: finite_or(self.size.1, 0.0).max(0.0),
                speed_min,
                speed_max,
                lifetime_min,
                lifetime_max,
                cone_cos: finite_or(self.cone_angle, 0.0).clamp(0.0, std::f32::consts::PI).cos(),
                spawn_radius: finite_or(self.spawn_radius, 0.0).max(0.0),
                contact,
                restitution,
                friction,
                texture,
                flipbook: cells_x | cells_y << 16,
                softness: finite_or(self.softness, 0.0).max(0.0),
                lit: finite_or(self.lit, 0.0).clamp(0.0, 1.0),
                stretch: finite_or(self.stretch, 0.0).max(0.0),
                decal_material: decal_material.filter(|_| self.leaves.is_some()).unwrap_or(NO_DECAL),
                decal_size: self.leaves.map_or(0.0, |d| finite_or(d.size, 0.0).max(0.0)),
                decal_depth: self.leaves.map_or(0.0, |d| finite_or(d.depth, 0.0).max(0.0)),
                decal_lifetime: self.leaves.map_or(0.0, |d| finite_or(d.lifetime, 0.0).max(0.0)),
                decal_fade: self.leaves.map_or(0.0, |d| finite_or(d.fade, 0.0).max(0.0)),
                decal_pad: [0; 3],
            },
            rate: finite_or(self.rate, 0.0).max(0.0),
            burst: self.burst,
        }
    }
}

fn finite_or(x: f32, fallback: f32) -> f32 {
    if x.is_finite() { x } else { fallback }
}

/// Emitters whose global transform changed.
type MovedEmitters = (With<ParticleEmitter>, Changed<GlobalTransform>);

/// Mirrors the emitters: inserted ones are written (their bursts start), moved ones get their
/// new transform (a scan of the emitters alone, whose global transform changed), despawned ones
/// stop. Work is proportional to the emitters, never to their particles.
pub fn extract_emitters(
    mut inserted: MessageReader<Inserted<ParticleEmitter>>,
    emitters: Query<(&ParticleEmitter, &GlobalTransform)>,
    textured: Query<(Entity, &ParticleEmitter)>,
    moved: Query<(Entity, &GlobalTransform), MovedEmitters>,
    mut removed: RemovedComponents<ParticleEmitter>,
    (mut mirror, mut slots): (ResMut<RenderMirror>, ResMut<MirrorSlots>),
    mut stats: ResMut<RenderStats>,
) {
    let mirror = &mut mirror.0;
    for entity in removed.read() {
        if emitters.contains(entity) {
            continue;
        }
        if let Some(slot) = slots.emitters.remove(&entity) {
            mirror.emitters.remove(slot);
        }
    }
    let mut visited = 0;
    for message in inserted.read() {
        let Ok((emitter, global)) = emitters.get(message.entity) else { continue };
        visited += 1;
        let texture = emitter.texture.and_then(|t| slots.texture(t)).unwrap_or(TEXTURE_WHITE);
        let decal_material = emitter.leaves.and_then(|d| slots.decal_material(d.material));
        let record = emitter.emitter(global.compute_matrix(), texture, decal_material);
        match slots.emitters.get(&message.entity) {
            Some(&slot) => mirror.emitters.write(slot, record),
            None => {
                let slot = mirror.emitters.insert(record);
                slots.emitters.insert(message.entity, slot);
            }
        }
    }
    for (entity, global) in &moved {
        if let Some(&slot) = slots.emitters.get(&entity) {
            mirror.emitters.set_transform(slot, global.compute_matrix());
        }
    }
    // A sprite whose image arrived after its emitter, or was replaced (its bindless slot then
    // changes): a look-up per textured emitter, which are few.
    for (entity, emitter) in &textured {
        let (Some(texture), Some(&slot)) = (emitter.texture, slots.emitters.get(&entity)) else { continue };
        let now = slots.texture(texture).unwrap_or(TEXTURE_WHITE);
        mirror.emitters.set_texture(slot, now);
    }
    stats.visited.emitters = visited;
}

/// A decal landing particles left, as read back from the GPU by [`read_left_decals`]: enough
/// to keep it (in a save) or to make it a CPU decal of its own.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct LeftDecalState {
    /// Where the particle landed, world space.
    pub position: Vec3,
    /// The surface's normal there.
    pub normal: Vec3,
    /// The box's +X along the surface (turned about the normal at random).
    pub tangent: Vec3,
    /// Its box's side along the surface, metres ([`LeftDecal::size`]).
    pub size: f32,
    /// Its box's depth across the surface, metres ([`LeftDecal::depth`]).
    pub depth: f32,
    /// Its material (`None` if that material has since been removed).
    pub material: Option<Handle<DecalMaterial>>,
    /// When it has faded out, seconds on the app's clock (`Time::elapsed_secs`, the renderer's
    /// decal clock); `None`: it lasts until newer decals overwrite it.
    pub expires: Option<f32>,
}

/// The decals landing particles left that the GPU's ring still holds (the newest
/// `RendererSettings::particle_decals` of them, expired ones included: compare
/// [`LeftDecalState::expires`] with the clock), oldest first. Waits for the GPU, so call it
/// on request (saving a game), not every frame. Empty without a renderer or before any
/// particle left a decal.
pub fn read_left_decals(world: &mut World) -> Result<Vec<LeftDecalState>, render::RenderError> {
    crate::pipelined::collect_frame(world);
    let Some(mut renderer) = world.get_resource_mut::<crate::GpuRenderer>() else { return Ok(Vec::new()) };
    let born = renderer.0.read_particle_decals()?;
    let slots = world.resource::<MirrorSlots>();
    Ok(born
        .into_iter()
        .map(|d| LeftDecalState {
            position: d.position,
            normal: d.normal,
            tangent: d.tangent,
            size: d.size,
            depth: d.depth,
            material: slots.decal_material_handle(d.material),
            expires: d.expires,
        })
        .collect())
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn bad_values_are_clamped_not_sent() {
        let e = ParticleEmitter {
            rate: f32::NAN,
            lifetime: (3.0, -1.0),
            speed: (f32::INFINITY, 2.0),
            cone_angle: 7.0,
            size: (-1.0, 0.2),
            color: (Vec4::splat(f32::NAN), Vec4::new(-1.0, 2.0, 0.0, 1.0)),
            lit: 4.0,
            flipbook: (0, 70_000),
            ..ParticleEmitter::default()
        }
        .emitter(glam::Mat4::IDENTITY, 5, Some(3));
        let r = e.record;
        assert_eq!((e.rate, r.lifetime_min, r.lifetime_max), (0.0, 0.0, 3.0));
        assert_eq!((r.speed_min, r.speed_max), (0.0, 2.0));
        assert!((r.cone_cos + 1.0).abs() < 1e-6, "π at most: every way");
        assert_eq!((r.size_start, r.size_end, r.lit), (0.0, 0.2, 1.0));
        assert_eq!((r.color_start, r.color_end), (Vec4::ZERO, Vec4::new(0.0, 2.0, 0.0, 1.0)));
        assert_eq!(r.flipbook, 1 | 0xFFFF << 16);
        assert_eq!(r.texture, 5);
    }
}
