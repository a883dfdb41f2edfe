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
//! run, frame by frame. Work per frame is proportional to the channels of the playing clips;
//! a paused or finished (clamped) player writes only values that changed: [`Transform`]s are
//! written with `set_if_neq`, so a still pose costs neither propagation nor extraction.
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

mod sample;

use bevy_ecs::prelude::*;
use glam::{Quat, Vec3};
use thiserror::Error;

use crate::app::{App, Plugin, PostUpdate};
use crate::asset::{Assets, Handle};
use crate::time::Time;
use crate::transform::{Transform, TransformSystems};

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

/// One animated property of one node.
#[derive(Clone, Debug, PartialEq)]
pub struct Channel {
    /// The node it animates: an index into [`AnimationTargets`].
    pub target: usize,
    /// Interpolation between keyframes.
    pub interpolation: Interpolation,
    /// Keyframe times in seconds, strictly increasing.
    pub times: Vec<f32>,
    /// The values.
    pub keyframes: Keyframes,
}

impl Channel {
    /// A channel (checked when it joins a clip, [`AnimationClip::new`]).
    pub fn new(target: usize, interpolation: Interpolation, times: Vec<f32>, keyframes: Keyframes) -> Self {
        Self { target, interpolation, times, keyframes }
    }

    fn check(&self) -> Result<(), AnimationError> {
        let bad = |reason: String| Err(AnimationError::BadChannel { target: self.target, reason });
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
#[derive(Clone, Debug, PartialEq)]
pub struct AnimationClip {
    /// The clip's name (glTF's animation name, or `animation N`).
    pub name: String,
    /// The channels.
    pub channels: Vec<Channel>,
    /// The last keyframe time over all channels, in seconds.
    pub duration: f32,
}

impl AnimationClip {
    /// A clip from checked channels: keyframe times finite and strictly increasing, as many
    /// values as the interpolation needs, every value finite.
    pub fn new(name: impl Into<String>, channels: Vec<Channel>) -> Result<Self, AnimationError> {
        for channel in &channels {
            channel.check()?;
        }
        let duration = channels.iter().filter_map(|c| c.times.last().copied()).fold(0.0, f32::max);
        Ok(Self { name: name.into(), channels, duration })
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
        app.add_systems(PostUpdate, (link_animation_targets, animate).chain().in_set(AnimationSystems).before(TransformSystems::Propagate));
        app.add_systems(PostUpdate, update_skin_poses.in_set(SkinPoseSystems).after(TransformSystems::Propagate));
    }
}

/// The skinning matrices of a skinned entity's current pose ([`Skin::joint_matrices`]: per
/// joint, in the entity's space), kept by [`update_skin_poses`] and changed only when the pose
/// changed, so the renderer's extraction and picking read them through change detection.
/// Added with every [`Skin`].
#[derive(Component, Clone, Debug, Default, PartialEq)]
pub struct SkinPose(pub Vec<glam::Mat4>);

/// Recomputes the [`SkinPose`] of every skinned entity whose pose changed ([`Skin::pose_changed`]),
/// in parallel across the entities (each reads its joints' global transforms and writes only its
/// own matrices).
pub fn update_skin_poses(
    mut skinned: Query<(Ref<Skin>, Ref<crate::transform::GlobalTransform>, &mut SkinPose)>,
    joints: Query<Ref<crate::transform::GlobalTransform>>,
) {
    skinned.par_iter_mut().for_each(|(skin, global, mut pose)| {
        if pose.0.len() != skin.joints.len() || Skin::pose_changed(&skin, &global, &joints) {
            skin.joint_matrices(&global, |j| joints.get(j).ok().map(|g| g.0), &mut pose.0);
        }
    });
}

/// A pose being accumulated for one target: each property with the total weight of the clips
/// blended into it so far, and its morph weights (a range of [`AnimationOutput::weights`]).
#[derive(Clone, Copy)]
struct Pose {
    translation: Option<(Vec3, f32)>,
    rotation: Option<(Quat, f32)>,
    scale: Option<(Vec3, f32)>,
    /// Start and length of its morph weights in the output, once a clip set them.
    morph: Option<(u32, u32)>,
    weights: f32,
}

/// What a player sampled this frame, written by [`animate`]'s parallel phase and applied to the
/// targets by its serial one (added with every [`AnimationPlayer`]; its buffers are reused, so a
/// steady frame allocates nothing).
#[derive(Component, Default)]
pub struct AnimationOutput {
    poses: Vec<(Entity, Pose)>,
    /// Per target node, its index in `poses` (`u32::MAX`: none yet).
    pose_of: Vec<u32>,
    /// Morph weights of every pose, back to back.
    weights: Vec<f32>,
    /// One channel's sampled morph weights.
    sampled: Vec<f32>,
}

/// What the last [`animate`] did: for statistics (`cpu_ms.animate` in the sandbox's `--stats`).
#[derive(Resource, Clone, Copy, Debug, Default, PartialEq)]
pub struct AnimationStats {
    /// CPU milliseconds it took: advancing the players, sampling and writing the poses.
    pub cpu_ms: f32,
    /// Players it advanced.
    pub players: u32,
}

/// Advances one player by `dt` and samples its clips (blended while cross-fading) into `out`.
fn sample_player(
    player: &mut AnimationPlayer,
    targets: &AnimationTargets,
    clips: &Assets<AnimationClip>,
    dt: f32,
    out: &mut AnimationOutput,
) {
    let AnimationOutput { poses, pose_of, weights, sampled } = out;
    poses.clear();
    weights.clear();
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
    let Some(clip) = clips.get(player.clip) else { return };
    let repeat = player.repeat;
    if repeat == Repeat::Clamp && clip.duration > 0.0 {
        // Keep the clock at the end, so that a later switch to Loop starts from there.
        player.time = player.time.clamp(0.0, clip.duration);
    }
    let blend = player.blend();
    let from = player.fade.and_then(|f| clips.get(f.from).map(|c| (c, wrap(f.from_time, c.duration, repeat), 1.0 - blend)));
    let layers = [Some((clip, wrap(player.time, clip.duration, repeat), blend)), from];
    pose_of.clear();
    pose_of.resize(targets.0.len(), u32::MAX);
    for (clip, t, weight) in layers.into_iter().flatten().filter(|l| l.2 > 0.0) {
        for channel in &clip.channels {
            let Some(&Some(entity)) = targets.0.get(channel.target) else { continue };
            let slot = &mut pose_of[channel.target];
            if *slot == u32::MAX {
                *slot = poses.len() as u32;
                poses.push((entity, Pose { translation: None, rotation: None, scale: None, morph: None, weights: 0.0 }));
            }
            let pose = &mut poses[*slot as usize].1;
            match sample_channel(channel, t, sampled) {
                Sampled::Translation(v) => accumulate(&mut pose.translation, v, weight, Vec3::lerp),
                Sampled::Scale(v) => accumulate(&mut pose.scale, v, weight, Vec3::lerp),
                Sampled::Rotation(q) => accumulate(&mut pose.rotation, q, weight, Quat::slerp),
                Sampled::Weights => {
                    // The first clip sets them, a later one mixes in by its share.
                    match pose.morph {
                        None => {
                            pose.morph = Some((weights.len() as u32, sampled.len() as u32));
                            weights.extend_from_slice(sampled);
                        }
                        Some((start, len)) => {
                            let share = weight / (pose.weights + weight);
                            let range = start as usize..(start + len) as usize;
                            for (a, &b) in weights[range].iter_mut().zip(sampled.iter()) {
                                *a += (b - *a) * share;
                            }
                        }
                    }
                    pose.weights += weight;
                }
            }
        }
    }
}

/// The player that animates an entity, and which of its [`AnimationTargets`] the entity is
/// (its node index): how [`animate`] writes poses in parallel, each target fetching its own.
/// Set by [`link_animation_targets`] when a player's targets are set; an entity two players
/// target follows the one linked last.
#[derive(Component, Clone, Copy, Debug, PartialEq, Eq)]
pub struct AnimatedBy {
    /// The entity with the [`AnimationPlayer`].
    pub player: Entity,
    /// The entity's index in the player's [`AnimationTargets`].
    pub node: u32,
}

/// Links the targets of players whose [`AnimationTargets`] were set to them ([`AnimatedBy`]).
/// Runs before [`animate`].
pub fn link_animation_targets(mut commands: Commands, players: Query<(Entity, &AnimationTargets), Changed<AnimationTargets>>) {
    for (player, targets) in &players {
        for (node, target) in targets.0.iter().enumerate() {
            if let Some(target) = *target {
                commands.entity(target).try_insert(AnimatedBy { player, node: node as u32 });
            }
        }
    }
}

/// Advances every player by the frame's time and writes the sampled pose into its targets'
/// [`Transform`]s and [`MorphWeights`]. A property the clip does not animate keeps its value;
/// during a cross-fade the two clips' values are blended by [`AnimationPlayer::blend`].
///
/// Two parallel phases: the players are advanced and sampled (each into its own
/// [`AnimationOutput`]: the clips are read-only, so players never contend), then every target
/// ([`AnimatedBy`]) fetches its pose from its player's output and writes its own `Transform`.
/// A crowd scales with the cores. Morph weights, rare, are written after, one player at a time.
pub fn animate(
    time: Res<Time>,
    clips: Option<Res<Assets<AnimationClip>>>,
    mut players: Query<(&mut AnimationPlayer, &AnimationTargets, &mut AnimationOutput)>,
    mut targets: Query<(Entity, &AnimatedBy, &mut Transform)>,
    mut morphs: Query<&mut MorphWeights>,
    stats: Option<ResMut<AnimationStats>>,
) {
    let Some(clips) = clips else { return };
    let started = std::time::Instant::now();
    let dt = time.delta_secs();
    let clips = &*clips;
    players.par_iter_mut().for_each(|(mut player, targets, mut out)| sample_player(&mut player, targets, clips, dt, &mut out));
    let outputs = &players;
    targets.par_iter_mut().for_each(|(entity, by, mut transform)| {
        let Ok((_, links, out)) = outputs.get(by.player) else { return };
        // Still this player's target, and posed this frame?
        if links.0.get(by.node as usize) != Some(&Some(entity)) {
            return;
        }
        let Some(&(_, pose)) = out.pose_of.get(by.node as usize).and_then(|&i| out.poses.get(i as usize)) else { return };
        if pose.translation.is_none() && pose.rotation.is_none() && pose.scale.is_none() {
            return;
        }
        let mut next = *transform;
        if let Some((v, _)) = pose.translation {
            next.translation = v;
        }
        if let Some((q, _)) = pose.rotation {
            next.rotation = q.normalize();
        }
        if let Some((v, _)) = pose.scale {
            next.scale = v;
        }
        transform.set_if_neq(next);
    });
    let mut advanced = 0;
    for (_, _, out) in &players {
        advanced += 1;
        for &(entity, pose) in &out.poses {
            if let Some((start, len)) = pose.morph
                && let Ok(mut morph) = morphs.get_mut(entity)
            {
                let values = &out.weights[start as usize..(start + len) as usize];
                // Written (and flagged changed) only when a value changes.
                if morph.bypass_change_detection().0 != values {
                    morph.0.clear();
                    morph.0.extend_from_slice(values);
                }
            }
        }
    }
    if let Some(mut stats) = stats {
        *stats = AnimationStats { cpu_ms: started.elapsed().as_secs_f32() * 1e3, players: advanced };
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
