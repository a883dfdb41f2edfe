//! Skeletal and morph-target animation as ECS: clips as assets, an [`AnimationPlayer`] on the
//! entity that owns an animated hierarchy, and a system that samples the playing clips into the
//! joints' [`Transform`]s (and the meshes' [`MorphWeights`]) before transform propagation.
//!
//! Clips follow glTF 2.0's animation model (the specification's §3.11 and Appendix C):
//! channels target a node's translation, rotation, scale or morph weights, with keyframes
//! interpolated step-wise, linearly (rotations by shortest-path spherical interpolation) or by
//! cubic Hermite splines (tangents stored beside each value, rotations renormalised). A channel
//! names its target by *node index*; [`AnimationTargets`] maps those to the entities that the
//! glTF spawner created, so a clip can drive every instance of a model.
//!
//! Time comes from [`Time`], so headless runs with a fixed step animate the same way every
//! run, frame by frame. Work per frame is proportional to the animated nodes of the playing
//! players; a paused or finished (clamped) player writes only values that changed:
//! [`Transform`]s are written with `set_if_neq`, so a still pose costs neither propagation nor
//! extraction.
//!
//! **How a crowd is sampled.** Each animated node samples its own channels: [`animate`] first
//! advances every player's clock (a few words a player), then every target entity reads its
//! player's clock, finds its channels in the clip by node index and writes its own
//! `Transform`, in parallel. Everything heavy is worked out once per clip, when it is made, and
//! shared by every instance of the model: the channels indexed by node, the arc between
//! successive rotation keyframes (slerp then needs two short sine polynomials and no inverse
//! cosine, division or normalisation per sample), and whether all channels share their
//! keyframe times (then a player finds its time's keyframes once for all its nodes, at a guess
//! from the keyframe rate rather than by binary search). A first design sampled each player
//! into a buffer of its own and had the targets fetch from it; the targets' reads missed the
//! cache and the two phases traded cache lines between cores, so that two cores animated 1,000
//! foxes more slowly than one. Sampling where it is written halved the time (`cargo bench -p
//! engine --bench animation`, docs/experiments/animation-cpu.md).
//!
//! **Skeletons in one pass.** A skinned entity with [`CompactSkeleton`] (what the glTF prefab
//! spawns) is posed from its clips in one pass, straight into its [`SkinPose`], placing its
//! bones' entities as it goes instead of animating and propagating them ([`UnplacedBones`]: not
//! placing them at all, for a crowd whose bones nothing reads). The `compact` module says what it
//! saves and what it changes.
//!
//! **A crowd's far half.** With the [`AnimationBudget`] on, a model small on screen or off it
//! samples every second or fourth frame, its clock still keeping time (the `budget` module says
//! the rule and the bound on how old a pose gets); what is not sampled is not written, so
//! nothing downstream of it runs either.
//!
//! ```
//! use engine::prelude::*;
//! use engine::animation::{AnimationClip, AnimationPlayer, Channel, Interpolation, Keyframes, AnimationTargets};
//!
//! let mut app = App::new();
//! let joint = app.world.spawn(Transform::IDENTITY).id();
//! let clip = AnimationClip::new(
//!     "raise",
//!     vec![Channel::new(0, Interpolation::Linear, vec![0.0, 1.0], Keyframes::Translation(vec![Vec3::ZERO, Vec3::Y]))],
//! )
//! .unwrap();
//! let clip = app.world.resource_mut::<Assets<AnimationClip>>().add(clip);
//! app.world.spawn((AnimationPlayer::new(clip), AnimationTargets(vec![Some(joint)])));
//! app.update();
//! ```

mod budget;
mod compact;
mod sample;

use bevy_ecs::batching::BatchingStrategy;
use bevy_ecs::prelude::*;
use glam::{Quat, Vec3};
use thiserror::Error;

use crate::app::{App, Plugin, PostUpdate};
use crate::asset::{Assets, Handle};
use crate::camera::Camera;
use crate::time::Time;
use crate::transform::{GlobalTransform, Transform, TransformSystems};

pub use crate::transform::PosedInSkin;
pub use budget::{AnimatedRadius, AnimationBudget};
pub use compact::{CompactScratch, CompactSkeleton, RigShapes, SkinRig, UnplacedBones, build_compact_skins, pose_compact_skins};
pub use sample::{Sampled, sample_channel};

/// How values between two keyframes are found (glTF's `interpolation`).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Interpolation {
    /// The earlier keyframe's value until the next keyframe.
    Step,
    /// Linear (spherical for rotations).
    Linear,
    /// Cubic Hermite spline; each keyframe stores an in-tangent, the value and an out-tangent.
    CubicSpline,
}

/// The keyframe values of a channel. With [`Interpolation::CubicSpline`] each keyframe holds
/// three entries (in-tangent, value, out-tangent); morph weights hold one entry per target per
/// keyframe (three times that for cubic splines).
#[derive(Clone, Debug, PartialEq)]
pub enum Keyframes {
    /// Translations.
    Translation(Vec<Vec3>),
    /// Rotations (unit quaternions).
    Rotation(Vec<Quat>),
    /// Scales.
    Scale(Vec<Vec3>),
    /// Morph target weights, `targets` per keyframe.
    Weights {
        /// Weights per keyframe.
        targets: usize,
        /// The weights, keyframe after keyframe.
        values: Vec<f32>,
    },
}

impl Keyframes {
    fn len(&self) -> usize {
        match self {
            Keyframes::Translation(v) | Keyframes::Scale(v) => v.len(),
            Keyframes::Rotation(v) => v.len(),
            Keyframes::Weights { targets, values } => values.len() / (*targets).max(1),
        }
    }
}

/// One animated property of one node. Read-only once made: what sampling needs beyond the
/// keyframes (the keyframe rate that finds a time's keyframes at a guess, and the arcs between
/// rotation keyframes) is worked out here, once.
#[derive(Clone, Debug, PartialEq)]
pub struct Channel {
    target: usize,
    interpolation: Interpolation,
    times: Vec<f32>,
    keyframes: Keyframes,
    /// Keyframes a second, were they evenly spaced from the first to the last (0 with one).
    rate: f32,
    /// For linearly interpolated rotations, per interval between keyframes: the shortest arc.
    arcs: Vec<sample::Arc>,
}

impl Channel {
    /// A channel of `target`'s property that `keyframes` names, its values at `times` seconds
    /// (checked when it joins a clip, [`AnimationClip::new`]).
    pub fn new(target: usize, interpolation: Interpolation, times: Vec<f32>, keyframes: Keyframes) -> Self {
        let span = times.last().zip(times.first()).map_or(0.0, |(last, first)| last - first);
        let rate = if times.len() > 1 && span > 0.0 { (times.len() - 1) as f32 / span } else { 0.0 };
        let mut keyframes = keyframes;
        if let Keyframes::Rotation(v) = &mut keyframes {
            // Unit rotations, as glTF requires (normalised integers come close, not exactly);
            // a cubic spline's tangents (entries 3k and 3k + 2) are not rotations and keep
            // their length.
            let (first, step) = if interpolation == Interpolation::CubicSpline { (1, 3) } else { (0, 1) };
            v.iter_mut().skip(first).step_by(step).filter(|q| q.length_squared() > 0.0).for_each(|q| *q = q.normalize());
        }
        let arcs = match (&keyframes, interpolation) {
            (Keyframes::Rotation(v), Interpolation::Linear) => v.windows(2).map(|w| sample::Arc::between(w[0], w[1])).collect(),
            _ => Vec::new(),
        };
        Self { target, interpolation, times, keyframes, rate, arcs }
    }

    /// The node it animates: an index into [`AnimationTargets`].
    pub fn target(&self) -> usize {
        self.target
    }

    /// Interpolation between keyframes.
    pub fn interpolation(&self) -> Interpolation {
        self.interpolation
    }

    /// Keyframe times in seconds (strictly increasing in a clip).
    pub fn times(&self) -> &[f32] {
        &self.times
    }

    /// The values.
    pub fn keyframes(&self) -> &Keyframes {
        &self.keyframes
    }

    /// Checks what [`AnimationClip::new`] checks of each channel: a target within
    /// [`MAX_NODE`], keyframe times finite and strictly increasing, as many values as the
    /// interpolation needs, every value finite.
    pub(crate) fn check(&self) -> Result<(), AnimationError> {
        let bad = |reason: String| Err(AnimationError::BadChannel { target: self.target, reason });
        if self.target > MAX_NODE {
            return bad(format!("a clip animates nodes 0 to {MAX_NODE}"));
        }
        if self.times.is_empty() {
            return bad("no keyframes".into());
        }
        if let Some(i) = self.times.iter().position(|t| !t.is_finite()) {
            return bad(format!("keyframe {i}'s time is not finite"));
        }
        if let Some(i) = self.times.windows(2).position(|w| w[1] <= w[0]) {
            return bad(format!("keyframe times do not increase at keyframe {}", i + 1));
        }
        if let Keyframes::Weights { targets: 0, .. } = self.keyframes {
            return bad("morph weights for no targets".into());
        }
        let per_key = if self.interpolation == Interpolation::CubicSpline { 3 } else { 1 };
        if self.keyframes.len() != self.times.len() * per_key {
            return bad(format!(
                "{} values for {} keyframes ({} expected with {:?} interpolation)",
                self.keyframes.len(),
                self.times.len(),
                self.times.len() * per_key,
                self.interpolation
            ));
        }
        let finite = match &self.keyframes {
            Keyframes::Translation(v) | Keyframes::Scale(v) => v.iter().all(|x| x.is_finite()),
            Keyframes::Rotation(v) => v.iter().all(|q| q.is_finite()),
            Keyframes::Weights { values, .. } => values.iter().all(|x| x.is_finite()),
        };
        if !finite {
            return bad("a value is not finite".into());
        }
        Ok(())
    }
}

/// A problem with a clip's data.
#[derive(Debug, Error, PartialEq)]
pub enum AnimationError {
    /// A channel's keyframes cannot be sampled.
    #[error("animation channel for node {target}: {reason}")]
    BadChannel {
        /// The channel's target node.
        target: usize,
        /// What is wrong.
        reason: String,
    },
}

/// An animation: channels over the nodes of one model. An asset in `Assets<AnimationClip>`.
///
/// A clip is checked once, when it is made ([`AnimationClip::new`]), and read-only after:
/// its channels are indexed by node and property then, so that each animated node finds its
/// own channels without visiting the others. To change a clip, make a new one.
#[derive(Clone, Debug, PartialEq)]
pub struct AnimationClip {
    name: String,
    channels: Vec<Channel>,
    duration: f32,
    /// Per node up to the last animated one, its channel per [`Property`] (an index into
    /// `channels`, [`NO_CHANNEL`] where none).
    nodes: Vec<[u32; 4]>,
    /// Whether every channel has the same keyframe times (exporters that sample a clip at a
    /// fixed rate write them so): a player then finds a time's keyframes once for all.
    shared_times: bool,
}

/// What a [`Channel`] animates: a node's translation, rotation, scale or morph weights.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub enum Property {
    /// [`Transform::translation`].
    Translation,
    /// [`Transform::rotation`].
    Rotation,
    /// [`Transform::scale`].
    Scale,
    /// The node's [`MorphWeights`].
    Weights,
}

const NO_CHANNEL: u32 = u32::MAX;

/// The highest node index a clip may animate: its channels are indexed by node, 16 bytes a node
/// up to the highest it animates (16 MiB at most).
pub const MAX_NODE: usize = (1 << 20) - 1;

impl Keyframes {
    /// The property these keyframes animate.
    pub fn property(&self) -> Property {
        match self {
            Keyframes::Translation(_) => Property::Translation,
            Keyframes::Rotation(_) => Property::Rotation,
            Keyframes::Scale(_) => Property::Scale,
            Keyframes::Weights { .. } => Property::Weights,
        }
    }
}

impl AnimationClip {
    /// A clip from checked channels: keyframe times finite and strictly increasing, as many
    /// values as the interpolation needs, every value finite, and no property of a node
    /// animated twice (glTF 2.0 §3.11: a target and path appear once in an animation).
    pub fn new(name: impl Into<String>, channels: Vec<Channel>) -> Result<Self, AnimationError> {
        for channel in &channels {
            channel.check()?;
        }
        let duration = channels.iter().filter_map(|c| c.times.last().copied()).fold(0.0, f32::max);
        let mut nodes = vec![[NO_CHANNEL; 4]; channels.iter().map(|c| c.target + 1).max().unwrap_or(0)];
        for (i, channel) in channels.iter().enumerate() {
            let property = channel.keyframes.property();
            let slot = &mut nodes[channel.target][property as usize];
            if *slot != NO_CHANNEL {
                return Err(AnimationError::BadChannel {
                    target: channel.target,
                    reason: format!("its {property:?} is animated by two channels of the clip"),
                });
            }
            *slot = i as u32;
        }
        let shared_times = !channels.is_empty() && channels.windows(2).all(|w| w[0].times == w[1].times);
        Ok(Self { name: name.into(), channels, duration, nodes, shared_times })
    }

    /// A clip without channels: it plays nothing, for its whole duration of zero.
    pub fn empty(name: impl Into<String>) -> Self {
        Self { name: name.into(), channels: Vec::new(), duration: 0.0, nodes: Vec::new(), shared_times: false }
    }

    /// The clip's name (glTF's animation name, or `animation N`).
    pub fn name(&self) -> &str {
        &self.name
    }

    /// The channels, in the order they were given.
    pub fn channels(&self) -> &[Channel] {
        &self.channels
    }

    /// The last keyframe time over all channels, in seconds.
    pub fn duration(&self) -> f32 {
        self.duration
    }

    /// The channels animating `node`, per [`Property`] (`None` if the clip leaves it alone).
    fn channels_of(&self, node: usize) -> Option<[Option<&Channel>; 4]> {
        Some(self.nodes.get(node)?.map(|c| self.channels.get(c as usize)))
    }

    /// The channel animating `property` of `node`, if the clip has one.
    pub fn channel(&self, node: usize, property: Property) -> Option<&Channel> {
        self.channels_of(node)?[property as usize]
    }
}

/// The entities a clip's node indices stand for, on the entity that carries the
/// [`AnimationPlayer`] (the glTF spawner sets it on a model's root): `None` for nodes that were
/// not spawned.
#[derive(Component, Clone, Debug, Default, PartialEq)]
pub struct AnimationTargets(pub Vec<Option<Entity>>);

/// The joints that deform a skinned mesh: on the entity with the [`crate::scene::MeshInstance`],
/// the joints' entities (whose global transforms pose the mesh) and, per joint, the inverse of
/// its global transform in the bind pose. A vertex at rest `p` with joints `j` and weights `w`
/// is posed at `Σ w_i · joint_i · inverse_bind_i · p` (in the mesh's space, glTF §3.7.3).
#[derive(Component, Clone, Debug, PartialEq)]
#[require(SkinPose)]
#[component(on_insert = compact::skin_inserted, on_discard = compact::skin_replaced)]
pub struct Skin {
    /// The joints' entities, in the order the mesh's joint indices count.
    pub joints: Vec<Entity>,
    /// Inverse bind matrices, one per joint.
    pub inverse_bind_matrices: std::sync::Arc<[glam::Mat4]>,
}

impl Skin {
    /// The skinning matrices of the current pose into `out`, one per joint: `joint world ×
    /// inverse bind`, expressed in the space of the mesh entity (`mesh_world`'s inverse on the
    /// left), so that the entity's own transform places the posed mesh as it places a rigid one.
    /// (glTF ignores a skinned node's own transform; the inverse here cancels it.) A joint
    /// `joint_world` cannot place (despawned) keeps its bind pose.
    pub fn joint_matrices(
        &self,
        mesh_world: &crate::transform::GlobalTransform,
        joint_world: impl Fn(Entity) -> Option<glam::Affine3A>,
        out: &mut Vec<glam::Mat4>,
    ) {
        let to_mesh = mesh_world.0.inverse();
        out.clear();
        out.extend(self.joints.iter().zip(self.inverse_bind_matrices.iter()).map(|(&joint, ibm)| match joint_world(joint) {
            // Inverse bind matrices are affine (glTF's are): the product stays in affine form,
            // about half the arithmetic of a 4×4 product (the skin matrices of a crowd are a
            // tenth of its CPU frame).
            Some(world) if ibm.row(3) == glam::Vec4::W => glam::Mat4::from(to_mesh * world * glam::Affine3A::from_mat4(*ibm)),
            Some(world) => glam::Mat4::from(to_mesh * world) * *ibm,
            None => glam::Mat4::IDENTITY,
        }));
    }

    /// Whether the pose of the skinned entity with this skin and `global` transform may have
    /// changed since the calling system last ran: the entity moved, its skin was replaced, or a
    /// joint's global transform changed.
    pub fn pose_changed(
        skin: &Ref<Skin>,
        global: &Ref<crate::transform::GlobalTransform>,
        joints: &Query<Ref<crate::transform::GlobalTransform>>,
    ) -> bool {
        global.is_changed() || skin.is_changed() || skin.joints.iter().any(|&j| joints.get(j).is_ok_and(|g| g.is_changed()))
    }

    /// A point of the mesh posed on the CPU (linear blend skinning with the matrices of
    /// [`Skin::joint_matrices`]): `rest` moved by the weighted joints. For picking and tests;
    /// the renderer skins on the GPU.
    pub fn pose_point(matrices: &[glam::Mat4], rest: Vec3, joints: [u16; 4], weights: [f32; 4]) -> Vec3 {
        let mut posed = Vec3::ZERO;
        let mut total = 0.0;
        for (&joint, &weight) in joints.iter().zip(&weights) {
            if let Some(m) = matrices.get(joint as usize).filter(|_| weight > 0.0) {
                posed += weight * m.transform_point3(rest);
                total += weight;
            }
        }
        if total > 0.0 { posed / total } else { rest }
    }
}

/// Morph target weights of a mesh node, written by animation and read by skinning.
#[derive(Component, Clone, Debug, Default, PartialEq)]
pub struct MorphWeights(pub Vec<f32>);

/// What a player does at the end of its clip.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub enum Repeat {
    /// Starts again from the beginning.
    #[default]
    Loop,
    /// Holds the last pose.
    Clamp,
}

/// Plays one clip (and, while cross-fading, blends from the previous one) on the entities of
/// [`AnimationTargets`]. The sandbox plays a glTF's first clip on a loop.
#[derive(Component, Clone, Debug, PartialEq)]
#[require(AnimationTargets, AnimationOutput)]
pub struct AnimationPlayer {
    /// The clip playing.
    pub clip: Handle<AnimationClip>,
    /// Seconds into the clip.
    pub time: f32,
    /// Playback rate (negative plays backwards).
    pub speed: f32,
    /// Whether time stands still.
    pub paused: bool,
    /// What happens at the end.
    pub repeat: Repeat,
    fade: Option<CrossFade>,
}

/// A fade from the clip that played before.
#[derive(Clone, Copy, Debug, PartialEq)]
struct CrossFade {
    from: Handle<AnimationClip>,
    from_time: f32,
    from_speed: f32,
    duration: f32,
    elapsed: f32,
}

impl AnimationPlayer {
    /// Plays `clip` from its start, looping, at normal speed.
    pub fn new(clip: Handle<AnimationClip>) -> Self {
        Self { clip, time: 0.0, speed: 1.0, paused: false, repeat: Repeat::Loop, fade: None }
    }

    /// Jumps to `seconds` into the clip.
    pub fn seek(&mut self, seconds: f32) {
        self.time = if seconds.is_finite() { seconds } else { 0.0 };
    }

    /// Switches to `clip` from its start, blending from the current pose over `seconds` (0:
    /// at once). Both clips advance during the fade.
    pub fn cross_fade(&mut self, clip: Handle<AnimationClip>, seconds: f32) {
        self.fade = (seconds > 0.0 && seconds.is_finite()).then_some(CrossFade {
            from: self.clip,
            from_time: self.time,
            from_speed: self.speed,
            duration: seconds,
            elapsed: 0.0,
        });
        self.clip = clip;
        self.time = 0.0;
    }

    /// The weight of the clip playing (1 unless a cross-fade is under way).
    pub fn blend(&self) -> f32 {
        self.fade.map_or(1.0, |f| (f.elapsed / f.duration).clamp(0.0, 1.0))
    }
}

/// A time `t` within a clip of `duration`, after looping or clamping.
fn wrap(t: f32, duration: f32, repeat: Repeat) -> f32 {
    if duration <= 0.0 {
        return 0.0;
    }
    match repeat {
        Repeat::Loop => t.rem_euclid(duration),
        Repeat::Clamp => t.clamp(0.0, duration),
    }
}

/// Systems of the animation plugin.
#[derive(SystemSet, Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub struct AnimationSystems;

/// [`update_skin_poses`], after transform propagation: what reads [`SkinPose`] runs after it.
#[derive(SystemSet, Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub struct SkinPoseSystems;

/// Adds `Assets<AnimationClip>` and [`animate`], in [`PostUpdate`] before transform
/// propagation, and [`update_skin_poses`] after it.
pub struct AnimationPlugin;

impl Plugin for AnimationPlugin {
    fn build(&self, app: &mut App) {
        app.world.get_resource_or_init::<Assets<AnimationClip>>();
        app.world.init_resource::<AnimationStats>();
        app.world.init_resource::<AnimationBudget>();
        app.world.add_observer(compact::bone_relinked);
        app.world.add_observer(compact::bone_reparented);
        app.add_systems(
            PostUpdate,
            (link_animation_targets, build_compact_skins, animate).chain().in_set(AnimationSystems).before(TransformSystems::Propagate),
        );
        app.add_systems(
            PostUpdate,
            (compact::pose_compact_skins, update_skin_poses).chain().in_set(SkinPoseSystems).after(TransformSystems::Propagate),
        );
    }
}

/// The skinning matrices of a skinned entity's current pose ([`Skin::joint_matrices`]: per
/// joint, in the entity's space), kept by [`update_skin_poses`] and changed only when the pose
/// changed, so the renderer's extraction and picking read them through change detection.
/// Added with every [`Skin`].
#[derive(Component, Clone, Debug, Default, PartialEq)]
pub struct SkinPose(pub Vec<glam::Mat4>);

/// Recomputes the [`SkinPose`] of every skinned entity whose pose changed ([`Skin::pose_changed`])
/// from its joints' global transforms, in parallel across the entities (each reads its joints'
/// global transforms and writes only its own matrices): the skins without a [`SkinRig`], and the
/// compact skins that follow bones another compact skin places ([`SkinRig::follows`]). Runs
/// after [`compact::pose_compact_skins`], which poses the other compact skins.
///
/// Adds its time to [`AnimationStats::skin_cpu_ms`] (`cpu_ms.skin` in the sandbox's `--stats`).
#[allow(clippy::type_complexity)]
pub fn update_skin_poses(
    mut skinned: Query<(Ref<Skin>, Ref<GlobalTransform>, &mut SkinPose, Option<Ref<SkinRig>>)>,
    joints: Query<Ref<GlobalTransform>>,
    stats: Option<ResMut<AnimationStats>>,
) {
    let started = std::time::Instant::now();
    skinned.par_iter_mut().for_each(|(skin, global, mut pose, rig)| {
        if rig.as_ref().is_some_and(|rig| !rig.follows()) {
            return;
        }
        if pose.0.len() != skin.joints.len() || rig.is_some_and(|rig| rig.is_changed()) || Skin::pose_changed(&skin, &global, &joints) {
            skin.joint_matrices(&global, |j| joints.get(j).ok().map(|g| g.0), &mut pose.0);
        }
    });
    if let Some(mut stats) = stats {
        stats.skin_cpu_ms += started.elapsed().as_secs_f32() * 1e3;
    }
}

/// What a player's targets sample this frame, set by [`animate`]'s first phase (added with
/// every [`AnimationPlayer`]): up to two clips (the second while cross-fading), whether they
/// sample at all this frame ([`AnimationBudget`]), and the generation of the player's links to
/// its targets.
#[derive(Component, Clone, Copy, Debug, Default)]
pub struct AnimationOutput {
    layers: [Option<Layer>; 2],
    /// Whether the targets sample this frame.
    sample: bool,
    /// The player's period in frames this frame (1: every frame).
    period: u8,
    /// The frame the targets last sampled in.
    last: Option<u64>,
    /// Raised each time [`link_animation_targets`] links the player's targets: a target linked
    /// under an older generation is no longer among them.
    links: u32,
}

impl AnimationOutput {
    /// The player's period this frame, in frames: 1 when it samples every frame, more when the
    /// [`AnimationBudget`] found its model small on screen or off it.
    pub fn period(&self) -> u8 {
        self.period.max(1)
    }

    /// Whether the player's targets sampled their clips in the last [`animate`].
    pub fn sampled(&self) -> bool {
        self.sample
    }
}

/// One clip of a player's pose: the clip, the time in it (after looping or clamping), its
/// weight in the blend, and the time's keyframes when all the clip's channels share them.
#[derive(Clone, Copy, Debug)]
struct Layer {
    clip: Handle<AnimationClip>,
    time: f32,
    weight: f32,
    keys: Option<sample::Keys>,
}

impl Layer {
    fn new(clip_handle: Handle<AnimationClip>, clip: &AnimationClip, time: f32, weight: f32) -> Self {
        let keys = clip.shared_times.then(|| clip.channels[0].keys(time));
        Self { clip: clip_handle, time, weight, keys }
    }
}

/// What the last [`animate`] did: for statistics (`cpu_ms.animate` in the sandbox's `--stats`).
#[derive(Resource, Clone, Copy, Debug, Default, PartialEq)]
pub struct AnimationStats {
    /// CPU milliseconds it took: advancing the players, sampling and writing the poses.
    pub cpu_ms: f32,
    /// Players it advanced.
    pub players: u32,
    /// Of those, the players whose targets sampled their clips ([`AnimationBudget`] defers the
    /// others; without it, every player).
    pub sampled: u32,
    /// The longest period of any player, in frames (1 without the budget): its pose may be
    /// that many frames old less one.
    pub max_period: u8,
    /// CPU milliseconds [`update_skin_poses`] took: the skinned meshes' joint matrices (and the
    /// sampling of compact skeletons' bones, which happens there).
    pub skin_cpu_ms: f32,
    /// Skins posed as [`CompactSkeleton`]s.
    pub compact_skins: u32,
    /// Of those, the skins whose pose was computed in the last [`update_skin_poses`] (their
    /// player sampled, or their model moved).
    pub compact_posed: u32,
}

/// Advances one player by `dt`; returns the clips its targets sample (blended while
/// cross-fading), those with no weight left out.
fn advance(player: &mut AnimationPlayer, clips: &Assets<AnimationClip>, dt: f32) -> [Option<Layer>; 2] {
    if !player.paused {
        player.time += dt * player.speed;
        if let Some(fade) = &mut player.fade {
            fade.elapsed += dt;
            fade.from_time += dt * fade.from_speed;
        }
        if player.fade.is_some_and(|f| f.elapsed >= f.duration) {
            player.fade = None;
        }
    }
    let Some(clip) = clips.get(player.clip) else { return [None; 2] };
    let repeat = player.repeat;
    if repeat == Repeat::Clamp && clip.duration > 0.0 {
        // Keep the clock at the end, so that a later switch to Loop starts from there.
        player.time = player.time.clamp(0.0, clip.duration);
    }
    let blend = player.blend();
    let playing = Layer::new(player.clip, clip, wrap(player.time, clip.duration, repeat), blend);
    let from = player.fade.and_then(|f| {
        let from = clips.get(f.from)?;
        Some(Layer::new(f.from, from, wrap(f.from_time, from.duration, repeat), 1.0 - blend))
    });
    [Some(playing), from].map(|layer| layer.filter(|l| l.weight > 0.0))
}

/// The player that animates an entity, and which of its [`AnimationTargets`] the entity is
/// (its node index): how [`animate`] writes poses in parallel, each target sampling its own
/// channels. Set by [`link_animation_targets`] when a player's targets are set; an entity two
/// players target follows the one linked last.
#[derive(Component, Clone, Copy, Debug, PartialEq, Eq)]
pub struct AnimatedBy {
    /// The entity with the [`AnimationPlayer`].
    pub player: Entity,
    /// The entity's index in the player's [`AnimationTargets`].
    pub node: u32,
    /// The player's link generation when this link was made.
    links: u32,
}

/// Links the targets of players whose [`AnimationTargets`] were set to them ([`AnimatedBy`]).
/// Runs before [`animate`]. Entities dropped from a player's targets keep an [`AnimatedBy`] of
/// an older generation, which [`animate`] ignores.
#[allow(clippy::type_complexity)]
pub fn link_animation_targets(
    mut commands: Commands,
    mut players: Query<(Entity, &AnimationTargets, &mut AnimationOutput), Or<(Changed<AnimationTargets>, Added<AnimationOutput>)>>,
) {
    for (player, targets, mut out) in &mut players {
        out.links = out.links.wrapping_add(1);
        for (node, target) in targets.0.iter().enumerate() {
            if let Some(target) = *target {
                commands.entity(target).try_insert(AnimatedBy { player, node: node as u32, links: out.links });
            }
        }
    }
}

/// What [`animate`] reads and writes of a player: its clock, what its targets sample, and where
/// and how large its model is (for the [`AnimationBudget`]).
type Player =
    (Entity, &'static mut AnimationPlayer, &'static mut AnimationOutput, Option<&'static GlobalTransform>, Option<&'static AnimatedRadius>);

/// What [`animate`] writes of a target: its transform and morph weights (the bones of compact
/// skeletons left out: [`PosedInSkin`]).
type Target = (&'static AnimatedBy, Option<&'static mut Transform>, Option<&'static mut MorphWeights>);

/// Advances every player by the frame's time and writes the sampled pose into its targets'
/// [`Transform`]s and [`MorphWeights`]. A property the clip does not animate keeps its value;
/// during a cross-fade the two clips' values are blended by [`AnimationPlayer::blend`].
///
/// Two parallel phases. The players advance their clocks and name the clips to sample
/// ([`AnimationOutput`]); then every target ([`AnimatedBy`]) reads its player's few words,
/// finds its own channels in the clip (indexed by node when the clip was made) and samples them
/// into its own `Transform`. The clips are read-only and shared by every instance of a model,
/// so a crowd's targets read the same few kilobytes of keyframes and nothing per player
/// beyond its clock; the work scales with the animated nodes and the cores.
pub fn animate(
    time: Res<Time>,
    clips: Option<Res<Assets<AnimationClip>>>,
    mut players: Query<Player>,
    mut targets: Query<Target, Without<PosedInSkin>>,
    (budget, cameras): (Option<Res<AnimationBudget>>, Query<(&Camera, &GlobalTransform)>),
    stats: Option<ResMut<AnimationStats>>,
) {
    let Some(clips) = clips else { return };
    let started = std::time::Instant::now();
    let dt = time.delta_secs();
    let frame = time.frame();
    let clips = &*clips;
    let view = budget.and_then(|b| b.view(cameras));
    // Batches big enough that a small crowd does not wake every core for a few microseconds'
    // work (a player's clock is a few nanoseconds; a target's pose about a hundred).
    players.par_iter_mut().batching_strategy(BatchingStrategy::new().min_batch_size(1024)).for_each(
        |(entity, mut player, mut out, global, radius)| {
            out.layers = advance(&mut player, clips, dt);
            out.period = match (view, global, radius) {
                (Some(view), Some(global), Some(radius)) => view.period(global, radius.0),
                _ => 1,
            };
            out.sample = budget::due(frame, out.last, out.period, budget::stagger(entity.index_u32()));
            if out.sample {
                out.last = Some(frame);
            }
        },
    );
    let players = &players;
    // A model's nodes sit together in their tables, so a target's player is most often the
    // previous target's: each batch keeps the last one it fetched, by reference. (A copy of the
    // player's `AnimationOutput`, 120 bytes, copied again for every target, cost the 2-core
    // machine's 10,000 foxes 4.3 ms to walk their 240,000 targets posing none, against 2.8 ms
    // by reference; `animate/10000` 11.8–13.9 ms against 10.6–11.0 in alternating runs.)
    targets.par_iter_mut().batching_strategy(BatchingStrategy::new().min_batch_size(256)).for_each_init(
        || None,
        |last: &mut Option<(Entity, &AnimationOutput)>, (by, transform, morph)| {
            let out = match *last {
                Some((player, out)) if player == by.player => out,
                _ => {
                    let Ok((_, _, out, ..)) = players.get(by.player) else { return };
                    *last = Some((by.player, out));
                    out
                }
            };
            // Still this player's target, and its turn?
            if out.links == by.links && out.sample {
                pose_target(clips, &out.layers, by.node as usize, transform, morph);
            }
        },
    );
    if let Some(mut stats) = stats {
        let (mut sampled, mut max_period) = (0, 1);
        for (.., out, _, _) in players.iter() {
            sampled += u32::from(out.sample);
            max_period = max_period.max(out.period());
        }
        let players = players.iter().len() as u32;
        *stats = AnimationStats { cpu_ms: started.elapsed().as_secs_f32() * 1e3, players, sampled, max_period, ..*stats };
    }
}

/// What a node's channels give at the layers' times: each transform property a clip animates
/// (blended over the layers, with its total weight) and the morph weight channels with their
/// keyframes and weight.
struct NodeSample<'a> {
    translation: Option<(Vec3, f32)>,
    rotation: Option<(Quat, f32)>,
    scale: Option<(Vec3, f32)>,
    weights: [Option<(&'a Channel, sample::Keys, f32)>; 2],
}

impl NodeSample<'_> {
    /// `rest` with the properties the clips animate replaced, or `None` when they animate none.
    #[inline(always)]
    fn transform(&self, rest: Transform) -> Option<Transform> {
        if self.translation.is_none() && self.rotation.is_none() && self.scale.is_none() {
            return None;
        }
        let mut next = rest;
        if let Some((v, _)) = self.translation {
            next.translation = v;
        }
        if let Some((q, _)) = self.rotation {
            next.rotation = q;
        }
        if let Some((v, _)) = self.scale {
            next.scale = v;
        }
        Some(next)
    }
}

/// Samples node `node`'s channels in `layers` (blended while cross-fading).
#[inline(always)]
fn sample_node<'a>(clips: &'a Assets<AnimationClip>, layers: &[Option<Layer>; 2], node: usize) -> NodeSample<'a> {
    let mut out = NodeSample { translation: None, rotation: None, scale: None, weights: [None; 2] };
    for (i, layer) in layers.iter().flatten().enumerate() {
        if let Some(clip) = clips.get(layer.clip) {
            sample_layer(clip, layer, node, i, &mut out);
        }
    }
    out
}

/// Adds node `node`'s channels in `clip`, the `i`-th of the layers, to `out`.
#[inline(always)]
fn sample_layer<'a>(clip: &'a AnimationClip, layer: &Layer, node: usize, i: usize, out: &mut NodeSample<'a>) {
    let Some([t, r, s, w]) = clip.channels_of(node) else { return };
    let (time, weight) = (layer.time, layer.weight);
    let keys = |c: &Channel| layer.keys.unwrap_or_else(|| c.keys(time));
    // Each property sampled by its own typed path rather than through `Channel::value_at`'s
    // enum, which measured 10–15 % slower on one core at 1,000 foxes.
    if let Some(c @ Channel { keyframes: Keyframes::Translation(v), .. }) = t {
        accumulate(&mut out.translation, sample::vec3_at(c.interpolation, v, keys(c)), weight, Vec3::lerp);
    }
    if let Some(c @ Channel { keyframes: Keyframes::Rotation(v), .. }) = r {
        accumulate(&mut out.rotation, sample::rotation_at(c.interpolation, v, &c.arcs, keys(c)), weight, Quat::slerp);
    }
    if let Some(c @ Channel { keyframes: Keyframes::Scale(v), .. }) = s {
        accumulate(&mut out.scale, sample::vec3_at(c.interpolation, v, keys(c)), weight, Vec3::lerp);
    }
    out.weights[i] = w.map(|c| (c, keys(c), weight));
}

/// Samples node `node`'s channels in `layers` and writes them: the transform when a clip
/// animates it (flagged changed only if a value changed), and the morph weights likewise (an
/// entity may have either).
fn pose_target(
    clips: &Assets<AnimationClip>,
    layers: &[Option<Layer>; 2],
    node: usize,
    transform: Option<Mut<Transform>>,
    morph: Option<Mut<MorphWeights>>,
) {
    let sampled = sample_node(clips, layers, node);
    if let Some(mut transform) = transform
        && let Some(next) = sampled.transform(*transform)
    {
        transform.set_if_neq(next);
    }
    if let Some(mut morph) = morph {
        write_weights(&mut morph, sampled.weights);
    }
}

/// Writes the morph weights of up to two clips' channels: the first clip's sets them, the
/// second mixes in by its share of the weight. The component is flagged changed only when a
/// value changed, and a steady pose allocates nothing.
fn write_weights(morph: &mut Mut<MorphWeights>, channels: [Option<(&Channel, sample::Keys, f32)>; 2]) {
    let at = |(c, keys, _): (&Channel, sample::Keys, f32), j: usize| c.weight_at(keys, j);
    let (first, second) = match channels {
        [Some(a), b] => (a, b),
        [None, Some(b)] => (b, None),
        [None, None] => return,
    };
    let Keyframes::Weights { targets: n, .. } = first.0.keyframes else { return };
    let share = second.map_or(0.0, |b| b.2 / (first.2 + b.2));
    let out = &mut morph.bypass_change_detection().0;
    let mut changed = out.len() != n;
    out.resize(n, 0.0);
    for (j, out) in out.iter_mut().enumerate() {
        let mut v = at(first, j).unwrap_or(0.0);
        if let Some(b) = second.and_then(|b| at(b, j)) {
            v += (b - v) * share;
        }
        if *out != v {
            *out = v;
            changed = true;
        }
    }
    if changed {
        morph.set_changed();
    }
}

/// Weighted running average: the first value with its weight, later ones mixed in by their
/// share of the total.
fn accumulate<T: Copy>(slot: &mut Option<(T, f32)>, value: T, weight: f32, mix: impl Fn(T, T, f32) -> T) {
    *slot = Some(match *slot {
        None => (value, weight),
        Some((acc, w)) => (mix(acc, value, weight / (w + weight)), w + weight),
    });
}
