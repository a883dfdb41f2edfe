//! Ray-query decals as ECS components (seed 000 §4, made dynamic).
//!
//! A [`Decal`] is a unit-cube projector placed by its entity's transform: the cube
//! `[-0.5, 0.5]³` in the entity's local space, projecting along local −Z onto whatever surface
//! lies inside it. Gameplay spawns, moves and despawns decals with ordinary `Commands` and
//! `Query`; a decal parented to a moving entity follows it through transform propagation.
//!
//! Extraction writes each decal into a stable GPU slot keyed by its entity, together with the
//! AABB of its box; the renderer refits the decal BLAS when only boxes moved and rebuilds it when
//! its capacity changed or refits have degraded it (see `render::decals`). The seed's renderer
//! handled only static, pre-placed decals and left decals on moving objects out.
//!
//! ```
//! use engine::prelude::*;
//! use plugins::decal::{Decal, DecalMaterial, DecalLifetime};
//!
//! fn spawn_bullet_hole(world: &mut World, hit: Vec3, normal: Vec3, material: Handle<DecalMaterial>) {
//!     // Project onto the surface: local −Z points into it, so look from the hit along −normal.
//!     let transform = Transform::from_translation(hit)
//!         .looking_at(hit - normal, if normal.y.abs() > 0.9 { Vec3::X } else { Vec3::Y })
//!         .with_scale(Vec3::new(0.15, 0.15, 0.1));
//!     world.spawn((Decal::new(material), transform, DecalLifetime::new(30.0, 2.0)));
//! }
//! ```

use bevy_ecs::prelude::*;
use engine::asset::Handle;
use engine::image::Image;
use engine::time::Time;
use glam::{Mat4, Vec2, Vec4};
use render::scene::{
    DECAL_ALBEDO, DECAL_METALLIC, DECAL_NORMAL, DECAL_ROUGHNESS, DecalDesc, GpuDecalMaterial, TEXTURE_FLAT_NORMAL, TEXTURE_WHITE,
};

/// What a decal does to the surfaces it covers. Every attribute is optional, so a decal can
/// change any subset: a puddle changes roughness and normals, a stain only albedo.
#[derive(Clone, Debug, PartialEq)]
pub struct DecalMaterial {
    /// RGBA texture: rgb is the albedo (when `base_color` is set), alpha is the decal's coverage
    /// for every attribute. Without it the coverage is 1 inside the box.
    pub base_color_texture: Option<Handle<Image>>,
    /// Albedo factor (linear rgb × texture rgb) and opacity (× texture alpha). `None` leaves
    /// albedo untouched while the texture's alpha still shapes the other attributes.
    pub base_color: Option<Vec4>,
    /// Tangent-space normal map (glTF convention, +Y up in the image). `None`: normals untouched.
    pub normal_texture: Option<Handle<Image>>,
    /// Strength of the normal map's XY.
    pub normal_scale: f32,
    /// Roughness to blend in (× the texture's G when `metallic_roughness_texture` is set).
    pub roughness: Option<f32>,
    /// Metallic to blend in (× the texture's B when `metallic_roughness_texture` is set).
    pub metallic: Option<f32>,
    /// Optional metallic (B) / roughness (G) texture.
    pub metallic_roughness_texture: Option<Handle<Image>>,
}

impl Default for DecalMaterial {
    fn default() -> Self {
        Self {
            base_color_texture: None,
            base_color: Some(Vec4::ONE),
            normal_texture: None,
            normal_scale: 1.0,
            roughness: None,
            metallic: None,
            metallic_roughness_texture: None,
        }
    }
}

/// Where a decal's texture comes from.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum DecalUv {
    /// A rectangle of the texture (for atlases): `min` at the box's top-left (local −X, +Y),
    /// `max` at its bottom-right.
    Rect {
        /// Top-left UV.
        min: Vec2,
        /// Bottom-right UV.
        max: Vec2,
    },
    /// Four corner UVs, bilinearly interpolated as in the seed (§4.1.3), for the box corners at
    /// local (−X,−Y), (+X,−Y), (+X,+Y), (−X,+Y).
    Corners([Vec2; 4]),
}

impl Default for DecalUv {
    fn default() -> Self {
        DecalUv::Rect { min: Vec2::ZERO, max: Vec2::ONE }
    }
}

impl DecalUv {
    /// The four corner UVs in the order of [`DecalUv::Corners`].
    pub fn corners(&self) -> [Vec2; 4] {
        match *self {
            DecalUv::Rect { min, max } => [Vec2::new(min.x, max.y), max, Vec2::new(max.x, min.y), min],
            DecalUv::Corners(c) => c,
        }
    }
}

/// Fades a decal out on surfaces that it hits at a grazing angle: full strength while the angle
/// between the surface normal and the projection axis is below `start`, none beyond `end`
/// (radians).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct AngleFade {
    /// Angle where fading begins.
    pub start: f32,
    /// Angle where the decal has vanished.
    pub end: f32,
}

impl Default for AngleFade {
    fn default() -> Self {
        Self { start: 60f32.to_radians(), end: 80f32.to_radians() }
    }
}

/// Receiver layers a decal lands on by default (all of them).
pub const ALL_RECEIVERS: u32 = u32::MAX;
/// Layers of a mesh without a [`DecalReceiver`] component.
pub const DEFAULT_RECEIVER_LAYERS: u32 = 1;

/// A decal projector. Needs a `Transform` (added automatically): translation is the box centre,
/// rotation orients it (projection along local −Z), scale is the box size.
#[derive(Component, Clone, Debug, PartialEq)]
#[require(engine::transform::Transform)]
pub struct Decal {
    /// What the decal applies.
    pub material: Handle<DecalMaterial>,
    /// Blending channel 0..=3: decals in one channel blend order-independently (weighted OIT),
    /// channels are alpha-blended over each other in order (§4.3.1).
    pub channel: u8,
    /// Weight within the channel (> 0): heavier decals dominate overlaps.
    pub weight: f32,
    /// Texture coordinates.
    pub uv: DecalUv,
    /// Receiver layers this decal lands on; matched against [`DecalReceiver`].
    pub receivers: u32,
    /// Grazing-angle fade; `None` projects at every angle (also onto back-facing surfaces).
    pub angle_fade: Option<AngleFade>,
    /// Overall opacity multiplier (the lifetime system drives it during fade-out).
    pub opacity: f32,
}

impl Decal {
    /// A decal with `material`, channel 0, weight 1, the whole texture, all receivers, the
    /// default angle fade and full opacity.
    pub fn new(material: Handle<DecalMaterial>) -> Self {
        Self {
            material,
            channel: 0,
            weight: 1.0,
            uv: DecalUv::default(),
            receivers: ALL_RECEIVERS,
            angle_fade: Some(AngleFade::default()),
            opacity: 1.0,
        }
    }
}

/// Which decal layers a mesh instance receives. Meshes without it are on
/// [`DEFAULT_RECEIVER_LAYERS`]; `DecalReceiver(0)` receives no decals at all.
#[derive(Component, Clone, Copy, Debug, PartialEq, Eq)]
pub struct DecalReceiver(pub u32);

/// Despawns a decal after `remaining` seconds, fading its opacity to zero over the last
/// `fade_out` seconds. Driven by [`update_decal_lifetimes`], which the render plugin adds.
#[derive(Component, Clone, Copy, Debug, PartialEq)]
pub struct DecalLifetime {
    /// Seconds left.
    pub remaining: f32,
    /// Length of the fade at the end.
    pub fade_out: f32,
    /// Opacity at spawn (the fade scales from it).
    pub initial_opacity: f32,
}

impl DecalLifetime {
    /// Lives `seconds`, fading over the last `fade_out` seconds.
    pub fn new(seconds: f32, fade_out: f32) -> Self {
        Self { remaining: seconds, fade_out: fade_out.max(0.0), initial_opacity: 1.0 }
    }
}

/// Counts down every [`DecalLifetime`], fades the decal's opacity over the last `fade_out`
/// seconds and despawns it when the time is up. Runs in `Update`.
pub fn update_decal_lifetimes(mut commands: Commands, time: Res<Time>, mut decals: Query<(Entity, &mut DecalLifetime, &mut Decal)>) {
    let dt = time.delta_secs();
    for (entity, mut life, mut decal) in &mut decals {
        life.remaining -= dt;
        if life.remaining <= 0.0 {
            // Silently, as the decal may be leaving this frame anyway with the entity it rides on.
            commands.entity(entity).try_despawn();
            continue;
        }
        if life.remaining < life.fade_out {
            let opacity = life.initial_opacity * (life.remaining / life.fade_out);
            // Written only when it changes, so a decal that is not fading is not re-extracted.
            if decal.opacity != opacity {
                decal.opacity = opacity;
            }
        }
    }
}

/// The decal as the renderer takes it, placed by `decal_to_world`.
pub(crate) fn decal_desc(decal: &Decal, decal_to_world: Mat4, material: u32) -> DecalDesc {
    DecalDesc {
        decal_to_world,
        material,
        uv_corners: decal.uv.corners(),
        channel: decal.channel as u32,
        weight: decal.weight,
        receivers: decal.receivers,
        opacity: decal.opacity,
        angle_fade: decal.angle_fade.map(|f| (f.start, f.end)),
    }
}

/// The GPU record of a decal material, with texture handles resolved to bindless slots.
pub(crate) fn gpu_decal_material(m: &DecalMaterial, texture: impl Fn(Option<Handle<Image>>, u32) -> u32) -> GpuDecalMaterial {
    let mut flags = 0;
    if m.base_color.is_some() {
        flags |= DECAL_ALBEDO;
    }
    if m.normal_texture.is_some() {
        flags |= DECAL_NORMAL;
    }
    if m.roughness.is_some() {
        flags |= DECAL_ROUGHNESS;
    }
    if m.metallic.is_some() {
        flags |= DECAL_METALLIC;
    }
    GpuDecalMaterial {
        base_color: m.base_color.unwrap_or(Vec4::ONE).to_array(),
        base_color_tex: texture(m.base_color_texture, TEXTURE_WHITE),
        normal_tex: texture(m.normal_texture, TEXTURE_FLAT_NORMAL),
        metallic_roughness_tex: texture(m.metallic_roughness_texture, TEXTURE_WHITE),
        flags,
        normal_scale: m.normal_scale,
        roughness: m.roughness.unwrap_or(0.0),
        metallic: m.metallic.unwrap_or(0.0),
        pad: 0.0,
    }
}
