//! Ray-query decals as ECS components (seed 000 §4, made dynamic).
//!
//! A [`Decal`] is a unit-cube projector placed by its entity's transform: the cube
//! `[-0.5, 0.5]³` in the entity's local space, projecting along local −Z onto whatever surface
//! lies inside it. Gameplay spawns, moves and despawns decals with ordinary `Commands` and
//! `Query`; a decal parented to a moving entity follows it through transform propagation.
//!
//! Extraction writes each decal into a stable GPU slot keyed by its entity, together with the
//! AABB of its box. It visits only the decals that changed, never the others: [`Decal`] and
//! [`DecalLifetime`] are immutable components (edit a decal by inserting a new one: the compiler
//! refuses `&mut Decal`), so component hooks list every spawn and edit as
//! [`engine::changes::Inserted`] messages, as for mesh instances and lights;
//! transform propagation lists what moved ([`engine::transform::TransformChanges`]); despawns
//! arrive as removal events. Decals that never move can carry [`engine::transform::Static`], so
//! that the transform scan skips them too: a frame in which a million static decals sit still
//! costs the CPU nothing per decal. A lifetime's fade is evaluated on the GPU from the scene
//! clock (`GpuCamera::time`), and expiry pops a time-ordered queue ([`DecalLifetimes`]), so
//! ageing decals are neither visited nor re-uploaded. The renderer refits the decal BLAS when
//! only boxes moved and rebuilds it when its capacity changed or refits have degraded it (see
//! `render::decals`). The seed's renderer handled only static, pre-placed decals and left decals
//! on moving objects out.
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
//!     // A bullet hole never moves on its own: `Static` keeps it out of the transform scan.
//!     world.spawn((Decal::new(material), transform, Static, DecalLifetime::new(30.0, 2.0)));
//! }
//! ```
//!
//! To edit a decal, insert a changed copy: `commands.entity(e).insert(Decal { opacity: 0.5,
//! ..decal.clone() })`.

use std::cmp::Reverse;
use std::collections::BinaryHeap;
use std::time::Duration;

use bevy_ecs::entity::EntityHashMap;
use bevy_ecs::lifecycle::HookContext;
use bevy_ecs::prelude::*;
use bevy_ecs::world::DeferredWorld;
use engine::asset::Handle;
use engine::image::Image;
use engine::time::Time;
use glam::{Mat4, Vec2, Vec3, Vec4};
use render::scene::{
    DECAL_ALBEDO, DECAL_EMISSIVE, DECAL_METALLIC, DECAL_NORMAL, DECAL_ROUGHNESS, DecalDesc, GpuDecalMaterial, TEXTURE_FLAT_NORMAL,
    TEXTURE_WHITE,
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
    /// Emitted radiance (linear rgb, in the units of the scene's lights, so 1.0 is as bright as
    /// a white surface under light of 1; values above 1 glow, and bloom spreads them), × the
    /// emissive texture's rgb and the decal's coverage. `None`: no light. Emission adds to the
    /// surface's own (embers round a bullet hole, a neon sign, lava footprints) and is added
    /// whatever the decal's channel; negative or non-finite values count as 0.
    pub emissive: Option<Vec3>,
    /// Optional emissive texture (rgb; sRGB images are decoded as colours).
    pub emissive_texture: Option<Handle<Image>>,
    /// Whether a decal of this material that emits also lights the scene (issue 52, item 3): a
    /// one-sided rectangle light of its box's size on the box's mid-plane (where a decal
    /// placed at a surface point has the surface), lifted 1 % of its shorter side and looking
    /// out of the surface (the box's +Z), of the radiance it shows on average: `emissive` × the
    /// emissive texture's mean × the coverage's mean (`base_color`'s alpha × its texture's) ×
    /// the decal's opacity, so that a uniform decal sends the power it emits (a textured one
    /// about it: the mean of the product is what it shows). It is then shaded, culled,
    /// shadowed and sampled as a [`engine::light::RectLight`], and counts against the light
    /// limit (a decal that finds the table full glows but lights nothing, with a warning, until
    /// it is next visited). Off by default: a light costs what any light costs, and small
    /// embers light little. Decals on a skin, and decals that particles leave, do not light
    /// (their place is known on the GPU only); a lifetime's fade, receiver layers and distance
    /// fades do not touch the light, which goes with the decal. A change of the material or its
    /// textures reaches the light when the decal is next visited (moved or inserted again).
    pub emits_light: bool,
}

impl DecalMaterial {
    /// Every texture the material samples.
    pub fn textures(&self) -> [Option<Handle<Image>>; 4] {
        [self.base_color_texture, self.normal_texture, self.metallic_roughness_texture, self.emissive_texture]
    }
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
            emissive: None,
            emissive_texture: None,
            emits_light: false,
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

/// Fades a decal out with its distance from the camera: full strength nearer than `start`
/// metres, none beyond `end`, linear between (measured at each shaded point).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct DistanceFade {
    /// Distance where fading begins.
    pub start: f32,
    /// Distance where the decal has vanished.
    pub end: f32,
}

impl DistanceFade {
    /// Never fades (to exempt a decal from [`crate::RenderSettings::decal_distance_fade`]).
    pub const NEVER: DistanceFade = DistanceFade { start: f32::INFINITY, end: f32::INFINITY };
}

/// Receiver layers a decal lands on by default (all of them).
pub const ALL_RECEIVERS: u32 = u32::MAX;
/// Layers of a mesh without a [`DecalReceiver`] component.
pub const DEFAULT_RECEIVER_LAYERS: u32 = render::layout::DECAL_DEFAULT_LAYERS;

/// A decal projector. Needs a `Transform` (added automatically): translation is the box centre,
/// rotation orients it (projection along local −Z), scale is the box size.
///
/// Immutable: to edit a decal, insert a new `Decal` on its entity (a hook then lists it for
/// extraction, which is how extraction avoids visiting the decals that did not change).
#[derive(Component, Clone, Debug, PartialEq)]
#[require(engine::transform::Transform)]
#[component(immutable, on_insert = engine::changes::note_inserted::<Self>)]
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
    /// Distance fade; `None` takes [`crate::RenderSettings::decal_distance_fade`].
    pub distance_fade: Option<DistanceFade>,
    /// Overall opacity multiplier (a [`DecalLifetime`] fades it further on the GPU).
    pub opacity: f32,
    /// Stick to the skin of the skinned mesh instance this decal is a child of (`ChildOf`): its
    /// transform is then read in that mesh's *rest pose* (the parent's space as the mesh stands
    /// unposed), and the decal follows the skin exactly however the mesh deforms, where a decal
    /// parented to a joint moves rigidly and swims where the skin blends between joints.
    /// [`crate::raycast::Hit::rest`] gives the rest-pose point and normal a hit on a posed mesh
    /// came from. Such a decal lands only on its own instance's skin. Deferred decals (boxes
    /// rasterised into the G-buffer) cannot draw it: its box is in the rest pose, which the
    /// camera does not see; every other method does. A decal whose parent is not a skinned
    /// instance is placed in the world (with a warning).
    pub on_skin: bool,
}

impl Decal {
    /// A decal with `material`, channel 0, weight 1, the whole texture, all receivers, the
    /// default angle fade, the global distance fade and full opacity.
    pub fn new(material: Handle<DecalMaterial>) -> Self {
        Self {
            material,
            channel: 0,
            weight: 1.0,
            uv: DecalUv::default(),
            receivers: ALL_RECEIVERS,
            angle_fade: Some(AngleFade::default()),
            distance_fade: None,
            opacity: 1.0,
            on_skin: false,
        }
    }

    /// The same decal, stuck to the skin of the skinned instance it is a child of
    /// ([`Decal::on_skin`]).
    pub fn on_skin(self) -> Self {
        Self { on_skin: true, ..self }
    }
}

/// Which decal layers a mesh instance receives. Meshes without it are on
/// [`DEFAULT_RECEIVER_LAYERS`]; `DecalReceiver(0)` receives no decals at all. Immutable: insert
/// a new one to change the layers.
#[derive(Component, Clone, Copy, Debug, PartialEq, Eq)]
#[component(immutable, on_insert = engine::changes::note_inserted::<Self>)]
pub struct DecalReceiver(pub u32);

/// Despawns a decal `seconds` after it was inserted, fading it out over the last `fade_out`
/// seconds. The fade is evaluated on the GPU and expiry pops a time-ordered queue
/// ([`DecalLifetimes`]), so an ageing decal costs nothing per frame. Immutable: insert a new
/// lifetime to restart it; remove it to keep the decal.
#[derive(Component, Clone, Copy, Debug, PartialEq)]
#[component(immutable, on_insert = lifetime_inserted, on_remove = lifetime_removed)]
pub struct DecalLifetime {
    /// Seconds the decal lives from the moment the lifetime is inserted.
    pub seconds: f32,
    /// Length of the fade at the end, in seconds.
    pub fade_out: f32,
}

impl DecalLifetime {
    /// Lives `seconds`, fading over the last `fade_out` seconds (both clamped to ≥ 0; a fade
    /// longer than the life starts at once).
    pub fn new(seconds: f32, fade_out: f32) -> Self {
        Self { seconds, fade_out }
    }

    /// The fade window (start, end) of a lifetime inserted at `now`.
    fn window(&self, now: Duration) -> (Duration, Duration) {
        let secs = |s: f32| Duration::try_from_secs_f32(s.max(0.0)).unwrap_or(Duration::MAX / 4);
        let end = now.saturating_add(secs(self.seconds));
        (end.saturating_sub(secs(self.fade_out)).max(now), end)
    }
}

/// The lifetimes of living decals on the scene clock (`Time::elapsed`): each decal's fade window
/// and a queue ordered by expiry, so that expiring decals are found without visiting the others.
#[derive(Resource, Default)]
pub struct DecalLifetimes {
    windows: EntityHashMap<(Duration, Duration)>,
    /// (end, entity): popped when the end has passed; stale when the window changed.
    expiry: BinaryHeap<Reverse<(Duration, Entity)>>,
    /// (start, entity): the earliest fade start of a live window at the top (stale ones popped).
    fades: BinaryHeap<Reverse<(Duration, Entity)>>,
    fading: bool,
}

impl DecalLifetimes {
    /// The fade window (start, end) of a decal's lifetime on the scene clock, if it has one.
    pub fn fade_window(&self, entity: Entity) -> Option<(Duration, Duration)> {
        self.windows.get(&entity).copied()
    }

    /// Whether some decal's fade had begun at the last [`expire_decals`]: the scene clock is
    /// handed to the GPU only then, so frames in which decals merely age upload nothing.
    pub fn fading(&self) -> bool {
        self.fading
    }

    /// Decals with a lifetime.
    pub fn len(&self) -> usize {
        self.windows.len()
    }

    /// True when no decal has a lifetime.
    pub fn is_empty(&self) -> bool {
        self.windows.is_empty()
    }

    fn insert(&mut self, entity: Entity, window: (Duration, Duration)) {
        self.windows.insert(entity, window);
        self.expiry.push(Reverse((window.1, entity)));
        self.fades.push(Reverse((window.0, entity)));
    }
}

fn lifetime_inserted(mut world: DeferredWorld, ctx: HookContext) {
    let Some(&life) = world.get::<DecalLifetime>(ctx.entity) else { return };
    let now = world.get_resource::<Time>().map_or(Duration::ZERO, |t| t.elapsed());
    if let Some(mut lifetimes) = world.get_resource_mut::<DecalLifetimes>() {
        lifetimes.insert(ctx.entity, life.window(now));
    }
    // The decal's record carries its fade: list it as changed.
    engine::changes::note_inserted::<Decal>(world, ctx);
}

fn lifetime_removed(mut world: DeferredWorld, ctx: HookContext) {
    if let Some(mut lifetimes) = world.get_resource_mut::<DecalLifetimes>() {
        // Its queue entries go stale and are dropped when they reach the top.
        lifetimes.windows.remove(&ctx.entity);
    }
    engine::changes::note_inserted::<Decal>(world, ctx);
}

/// Despawns the decals whose [`DecalLifetime`] ran out, popping the expiry queue (work
/// proportional to the decals expiring), and notes whether any decal is fading. Runs in
/// `Update`; the render plugin adds it.
pub fn expire_decals(mut commands: Commands, time: Res<Time>, mut lifetimes: ResMut<DecalLifetimes>) {
    let now = time.elapsed();
    let DecalLifetimes { windows, expiry, fades, fading } = &mut *lifetimes;
    while let Some(&Reverse((end, entity))) = expiry.peek() {
        if end > now {
            break;
        }
        expiry.pop();
        if windows.get(&entity).is_some_and(|w| w.1 == end) {
            windows.remove(&entity);
            // Silently, as the decal may be leaving this frame anyway with the entity it rides on.
            commands.entity(entity).try_despawn();
        }
    }
    while let Some(&Reverse((start, entity))) = fades.peek() {
        if windows.get(&entity).is_some_and(|w| w.0 == start) {
            break;
        }
        fades.pop();
    }
    *fading = fades.peek().is_some_and(|Reverse((start, _))| *start <= now);
}

/// The decal as the renderer takes it, placed by `decal_to_world`, fading over `lifetime`
/// (on the scene clock).
pub(crate) fn decal_desc(decal: &Decal, decal_to_world: Mat4, material: u32, lifetime: Option<(Duration, Duration)>) -> DecalDesc {
    DecalDesc {
        on_skin: None,
        lifetime_fade: lifetime.map(|(start, end)| (start.as_secs_f32(), end.as_secs_f32())),
        distance_fade: decal.distance_fade.map(|f| (f.start, f.end)),
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

/// The radiance an emitting decal of material `m` and `opacity` shows on average over its box's
/// face, for its light ([`DecalMaterial::emits_light`]): `None` unless the material asks for a
/// light and emits. The emission's mean × the coverage's mean (not the mean of their product,
/// which the GPU shows), each texture's over the whole image (whatever part `DecalUv` shows); a
/// texture not loaded counts by its factor alone. Emission and opacity are clamped as the GPU
/// clamps them.
pub(crate) fn decal_light_radiance(m: &DecalMaterial, opacity: f32, images: &engine::asset::Assets<Image>) -> Option<Vec3> {
    let emissive = m.emissive.filter(|_| m.emits_light)?;
    let emissive = Vec3::from_array(emissive.to_array().map(|c| if c.is_finite() { c.max(0.0) } else { 0.0 }));
    let opacity = if opacity.is_finite() { opacity.clamp(0.0, 1.0) } else { 0.0 };
    let mean = |h: Option<Handle<Image>>| h.and_then(|h| images.get(h)).and_then(image_mean).unwrap_or(Vec4::ONE);
    let coverage = m.base_color.map_or(1.0, |c| c.w.clamp(0.0, 1.0)) * mean(m.base_color_texture).w;
    let radiance = emissive * mean(m.emissive_texture).truncate() * coverage * opacity;
    (radiance.is_finite() && radiance.max_element() > 0.0).then_some(radiance)
}

/// The mean linear RGBA of `image` ([`Image::mean_color`]); a block-compressed image's smallest
/// level decoded first (one block).
fn image_mean(image: &Image) -> Option<Vec4> {
    if let Some(mean) = image.mean_color() {
        return Some(Vec4::from_array(mean));
    }
    let level = image.mips.len().checked_sub(1)?;
    let (width, height) = image.mip_size(level as u32);
    let format = crate::extract::vk_format(image.format, image.color_space);
    let smallest = render::scene::TextureData { width, height, format, mips: vec![image.mips[level].clone()] };
    let decoded = render::scene::bc::decode_to_rgba8(&smallest)?;
    let rgba = Image { width, height, color_space: image.color_space, format: engine::image::TexelFormat::Rgba8, mips: decoded.mips };
    rgba.mean_color().map(Vec4::from_array)
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
    let emissive = m.emissive.map(|e| Vec3::from_array(e.to_array().map(|c| if c.is_finite() { c.max(0.0) } else { 0.0 })));
    if emissive.is_some_and(|e| e != Vec3::ZERO) {
        flags |= DECAL_EMISSIVE;
    }
    GpuDecalMaterial {
        base_color: m.base_color.unwrap_or(Vec4::ONE).to_array(),
        base_color_tex: texture(m.base_color_texture, TEXTURE_WHITE),
        normal_tex: texture(m.normal_texture, TEXTURE_FLAT_NORMAL),
        metallic_roughness_tex: texture(m.metallic_roughness_texture, TEXTURE_WHITE),
        emissive: emissive.unwrap_or(Vec3::ZERO).to_array(),
        emissive_tex: texture(m.emissive_texture, TEXTURE_WHITE),
        flags,
        normal_scale: m.normal_scale,
        roughness: m.roughness.unwrap_or(0.0),
        metallic: m.metallic.unwrap_or(0.0),
        pad: 0.0,
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use engine::image::{ColorSpace, TexelFormat};

    #[test]
    fn a_decal_light_takes_its_textures_means_also_from_compressed_ones() {
        let mut images = engine::asset::Assets::<Image>::default();
        // One BC1 block of pure red (RGB565 0xF800 as colour 0, every index 0), sRGB.
        let red = vec![0x00, 0xF8, 0x00, 0x00, 0, 0, 0, 0];
        let block = Image::from_blocks(4, 4, ColorSpace::Srgb, TexelFormat::Bc1, vec![red.clone(), red.clone(), red]).unwrap();
        let texture = images.add(block);
        let material =
            DecalMaterial { emissive: Some(Vec3::splat(2.0)), emissive_texture: Some(texture), emits_light: true, ..Default::default() };
        let radiance = decal_light_radiance(&material, 0.5, &images).expect("an emitting decal");
        assert!((radiance - Vec3::new(1.0, 0.0, 0.0)).length() < 1e-3, "2 × red × opacity 0.5: {radiance}");
        assert_eq!(decal_light_radiance(&DecalMaterial { emits_light: false, ..material }, 1.0, &images), None);
        let clamped = decal_light_radiance(&material, 3.0, &images).unwrap();
        assert!((clamped.x - 2.0).abs() < 1e-3, "opacity clamped to 1 as on the GPU: {clamped}");
        let negative = DecalMaterial { emissive: Some(Vec3::new(-1.0, 0.0, 0.0)), emissive_texture: None, ..material };
        assert_eq!(decal_light_radiance(&negative, 1.0, &images), None, "negative emission counts as none");
    }
}
