//! Compact skeletons: a crowd's skinned meshes posed without writing their bones' entities.
//! Not a technique of the seeds: it is what production engines offer for crowds (Unity's
//! "Optimize Game Objects" on an animator, which keeps a skeleton's bones out of the scene's
//! transform hierarchy unless exposed; Unreal's skeletal meshes, whose bones are never scene
//! components).
//!
//! **Why.** By default every bone is an entity: [`animate`](super::animate) writes its
//! `Transform`, transform propagation its `GlobalTransform`, and
//! [`update_skin_poses`](super::update_skin_poses) reads those back for the skin matrices. For
//! 10,000 foxes that is 240,000 entities' transforms written and read three times a frame, most of
//! the CPU frame on a machine whose memory is the bottleneck (`docs/experiments/
//! crowds-rig-posing.md` measured that no order of those three passes moves fewer bytes). A skin
//! with [`CompactSkeleton`] is posed in one pass instead, from the clips straight to its
//! [`SkinPose`]: its bones' local and global transforms live in a few kilobytes of one task's
//! scratch memory, and the only bytes written per bone are its skin matrix.
//!
//! **What it changes.** The bones' entities stay (their names, their `Joint` mark), but
//! animation no longer moves them and transform propagation does not descend into them
//! ([`PosedInSkin`]), so a crowd that walks costs it its models' few nodes, not their bones.
//! - Their `Transform` keeps the value it had when the skeleton was made compact (the rest pose,
//!   for a model just spawned), and their `GlobalTransform` the last value propagation wrote
//!   (the identity, for a model spawned compact): neither says where the bone is. Its posed
//!   world transform is one call away, [`SkinPose::joint_world`].
//! - Writing a bone's `Transform` (inverse kinematics, a head turned to look) does nothing while
//!   the skeleton is compact.
//! - A bone property the playing clips do not animate takes its rest value. With bones as
//!   entities it keeps the last value a clip wrote; the two differ only after a switch to a clip
//!   that animates fewer properties.
//!
//! **When a skin cannot be compact.** It stays as it is, or gives its bones back, with a warning,
//! when something needs the bones' entities moved:
//! - a bone carries anything that is not a bone of the same skin: a child (a sword in a hand,
//!   checked when the rig is made and whenever a child is hung on a bone later), or a light,
//!   camera, mesh or morph weights on the bone itself;
//! - a bone is also a joint of a skin posed from its joints' entities (one sharing the skeleton,
//!   now or later); skins that share a skeleton can all be compact;
//! - the bones are animated by more than one player, or the root bones hang from different
//!   parents.
//!
//! Removing [`CompactSkeleton`], or replacing the [`Skin`], gives the bones back to animation
//! and propagation, which place them all again.
//!
//! **How.** [`build_compact_skins`] makes a [`SkinRig`] for each compact skin that has none: its
//! bones parents first, each with its parent's place in that list, its node index in the
//! player's clips and its rest transform. It does so again when a bone is re-linked to a player
//! (one added late, or targets changed) or re-parented. Every instance of a model has the same
//! rig, so the rigs are shared (one allocation for a crowd of one character: what a frame reads
//! of it stays in the cache). [`update_skin_poses`](super::update_skin_poses) then, in parallel
//! over the skins, samples each bone's channels at its player's time, composes the global
//! transforms down the list, and writes `mesh⁻¹ × base × global × inverse bind` into the pose.
//! The [`AnimationBudget`](super::AnimationBudget) applies as before: a player that does not
//! sample this frame leaves its skins' poses as they are, unless the base moved relative to the
//! mesh (a model that walks as a whole keeps its pose).

use std::collections::HashMap;
use std::hash::{Hash, Hasher};
use std::ops::DerefMut;
use std::sync::Arc;
use std::sync::atomic::{AtomicU32, Ordering};

use bevy_ecs::batching::BatchingStrategy;
use bevy_ecs::entity::EntityHashSet;
use bevy_ecs::lifecycle::HookContext;
use bevy_ecs::prelude::*;
use bevy_ecs::system::SystemParam;
use bevy_ecs::world::DeferredWorld;
use bevy_utils::Parallel;
use glam::{Affine3A, Mat4, Vec4};
use tracing::warn;

use super::{AnimatedBy, AnimationClip, AnimationOutput, Layer, MorphWeights, NodeSample, Skin, SkinPose, sample_layer};
use crate::asset::Assets;
use crate::camera::Camera;
use crate::light::{DirectionalLight, DiskLight, PointLight, RectLight, SpotLight};
use crate::scene::MeshInstance;
use crate::transform::{GlobalTransform, PosedInSkin, Transform};

/// On an entity with a [`Skin`]: pose it from its player's clips in one pass, without moving its
/// bones' entities (the module docs say what that changes, and when a skin cannot be compact).
#[derive(Component, Clone, Copy, Debug, Default, PartialEq, Eq)]
#[component(on_remove = compact_skeleton_removed)]
pub struct CompactSkeleton;

/// The rig of a compact skin, made by [`build_compact_skins`]: the shape every instance of a
/// model shares, and this instance's player and the entity its root bones hang from.
#[derive(Component, Clone, Debug)]
pub struct SkinRig {
    shape: Arc<RigShape>,
    /// The player animating the bones (`None`: no bone is animated; the pose is the rest pose).
    player: Option<Entity>,
    /// The parent of the root bones (`None`: they are roots of the world).
    base: Option<Entity>,
    /// The player's link generation the rig was made under.
    links: u32,
    /// The base in the mesh's space when the skin was last posed (NaN before): a model that
    /// moves as a whole leaves it, and a pose not due is then left as it is.
    last_base: Affine3A,
}

impl SkinRig {
    /// How many bones the rig poses.
    pub fn len(&self) -> usize {
        self.shape.bones.len()
    }

    /// Whether the rig poses no bone.
    pub fn is_empty(&self) -> bool {
        self.shape.bones.is_empty()
    }

    /// The player animating the bones, if any.
    pub fn player(&self) -> Option<Entity> {
        self.player
    }
}

/// What every instance of a model shares of a compact skin's rig.
#[derive(Debug, PartialEq)]
struct RigShape {
    /// The bones, parents first.
    bones: Vec<RigBone>,
    /// The skin's inverse bind matrices (by the skin's joint order), in affine form where they
    /// are affine (glTF's are): `None` for one that is not.
    inverse_binds: Vec<Option<Affine3A>>,
    /// The same matrices as given.
    inverse_bind_matrices: Arc<[Mat4]>,
}

/// One bone of a [`RigShape`].
#[derive(Clone, Copy, Debug, PartialEq)]
struct RigBone {
    /// Its place in the skin's joints (and in the pose).
    joint: u32,
    /// Its parent's place in [`RigShape::bones`] (always earlier), or [`NO_PARENT`]: it hangs
    /// from the rig's base.
    parent: u32,
    /// Its node index in the player's clips, or [`NO_PARENT`] when no player animates it.
    node: u32,
    /// Its `Transform` when the rig was made: what the clips do not animate keeps this.
    rest: Transform,
}

/// The parent of a root bone, and the node of a bone no player animates.
const NO_PARENT: u32 = u32::MAX;

impl SkinPose {
    /// The world transform of joint `joint` of a skinned entity posed by this pose (whether by
    /// bones' entities or by a [`CompactSkeleton`]): `mesh_world × pose × inverse bind⁻¹`.
    /// `None` for a joint out of range or whose inverse bind matrix cannot be inverted.
    pub fn joint_world(&self, skin: &Skin, mesh_world: &GlobalTransform, joint: usize) -> Option<Affine3A> {
        let pose = self.0.get(joint)?;
        let bind = skin.inverse_bind_matrices.get(joint)?;
        let bind_inverse = bind.inverse();
        if !bind_inverse.is_finite() {
            return None;
        }
        Some(mesh_world.0 * Affine3A::from_mat4(*pose * bind_inverse))
    }
}

/// When [`CompactSkeleton`] is removed, the rig goes too and the bones return to animation and
/// propagation.
fn compact_skeleton_removed(mut world: DeferredWorld, ctx: HookContext) {
    if let Some(joints) = world.get::<Skin>(ctx.entity).map(|skin| skin.joints.clone()) {
        release_bones(&mut world, ctx.entity, joints);
    }
}

/// When a compact skin's [`Skin`] is replaced or removed, its old bones return to animation and
/// propagation (a new `Skin` gets a new rig). A `Skin` inserted whose joints a compact skeleton
/// poses makes that skeleton give them back: a skin posed from its joints' entities needs them
/// moved.
pub(super) fn skin_replaced(mut world: DeferredWorld, ctx: HookContext) {
    if world.get::<SkinRig>(ctx.entity).is_some()
        && let Some(joints) = world.get::<Skin>(ctx.entity).map(|skin| skin.joints.clone())
    {
        release_bones(&mut world, ctx.entity, joints);
    }
}

/// See [`skin_replaced`].
pub(super) fn skin_inserted(mut world: DeferredWorld, ctx: HookContext) {
    if world.get::<CompactSkeleton>(ctx.entity).is_some() {
        return;
    }
    let Some(skin) = world.get::<Skin>(ctx.entity) else { return };
    let owners: Vec<Entity> =
        skin.joints.iter().filter_map(|&j| world.get::<PosedInSkin>(j).map(|p| p.0)).filter(|&o| o != ctx.entity).collect();
    for owner in owners {
        warn!(skin = ?ctx.entity, compact = ?owner, "a skin shares bones with a compact skeleton, which gives them back to animation");
        world.commands().entity(owner).try_remove::<CompactSkeleton>();
    }
}

/// Removes `mesh`'s rig and gives its bones back: each bone it marked loses [`PosedInSkin`] and
/// is flagged changed, so that propagation places every one of them again (those no clip
/// animates too: they missed every move of their model meanwhile).
fn release_bones(world: &mut DeferredWorld, mesh: Entity, joints: Vec<Entity>) {
    world.commands().queue(move |world: &mut World| {
        if let Ok(mut mesh) = world.get_entity_mut(mesh) {
            mesh.remove::<SkinRig>();
        }
        for joint in joints {
            if let Ok(mut joint) = world.get_entity_mut(joint)
                && joint.get::<PosedInSkin>().is_some_and(|p| p.0 == mesh)
            {
                joint.remove::<PosedInSkin>();
                if let Some(mut transform) = joint.get_mut::<Transform>() {
                    transform.set_changed();
                }
            }
        }
    });
}

/// A compact skin whose bones were re-linked to a player, or re-parented, is made again; one
/// whose bone was given a child that is not a bone of it (an attachment) stops being compact,
/// with a warning (the child needs its parent's `GlobalTransform`).
pub(super) fn bone_relinked(event: On<Insert<AnimatedBy>>, posed: Query<&PosedInSkin>, mut commands: Commands) {
    if let Ok(&PosedInSkin(skin)) = posed.get(event.entity) {
        commands.entity(skin).try_remove::<SkinRig>();
    }
}

/// See [`bone_relinked`].
pub(super) fn bone_reparented(event: On<Insert<ChildOf>>, parents: Query<&ChildOf>, posed: Query<&PosedInSkin>, mut commands: Commands) {
    let child = event.entity;
    if let Ok(&PosedInSkin(skin)) = posed.get(child) {
        commands.entity(skin).try_remove::<SkinRig>();
        return;
    }
    if let Some(&PosedInSkin(skin)) = parents.get(child).ok().and_then(|c| posed.get(c.parent()).ok()) {
        warn!(?child, ?skin, "an entity was hung on a bone of a compact skeleton, which gives its bones back to animation");
        commands.entity(skin).try_remove::<CompactSkeleton>();
    }
}

/// What [`build_compact_skins`] reads of a bone.
type BoneQuery = (&'static Transform, Option<&'static ChildOf>, Option<&'static AnimatedBy>, Option<&'static Children>);

/// Bones a compact skeleton refuses: they carry something that needs their entity moved.
type Carrier = Or<(
    With<PointLight>,
    With<SpotLight>,
    With<DirectionalLight>,
    With<RectLight>,
    With<DiskLight>,
    With<Camera>,
    With<MeshInstance>,
    With<MorphWeights>,
)>;

/// What [`build_compact_skins`] looks up to make a rig.
#[derive(SystemParam)]
pub struct RigLookups<'w, 's> {
    bones: Query<'w, 's, BoneQuery>,
    carriers: Query<'w, 's, (), Carrier>,
    placed: Query<'w, 's, (), With<GlobalTransform>>,
    outputs: Query<'w, 's, &'static AnimationOutput>,
}

/// The rig shapes made so far, by a hash of their contents: instances of one model share one.
#[derive(Default)]
pub struct RigShapes(HashMap<u64, Vec<Arc<RigShape>>>);

impl RigShapes {
    /// The shared shape equal to `shape`, kept if new.
    fn share(&mut self, shape: RigShape) -> Arc<RigShape> {
        let mut hasher = std::collections::hash_map::DefaultHasher::new();
        for bone in &shape.bones {
            (bone.joint, bone.parent, bone.node).hash(&mut hasher);
            let rest = bone.rest;
            for x in rest.translation.to_array().into_iter().chain(rest.rotation.to_array()).chain(rest.scale.to_array()) {
                x.to_bits().hash(&mut hasher);
            }
        }
        for m in shape.inverse_bind_matrices.iter() {
            m.to_cols_array().map(f32::to_bits).hash(&mut hasher);
        }
        let same = self.0.entry(hasher.finish()).or_default();
        // Shapes no rig uses any more are dropped as others are made.
        same.retain(|s| Arc::strong_count(s) > 1);
        if let Some(found) = same.iter().find(|s| ***s == shape) {
            return found.clone();
        }
        let shape = Arc::new(shape);
        same.push(shape.clone());
        shape
    }
}

/// Makes the [`SkinRig`] of each [`CompactSkeleton`] skin that has none (new, its bones
/// re-linked or re-parented, its `Skin` replaced), and marks its bones [`PosedInSkin`]. A skin
/// that cannot be compact (the module docs say when) loses its `CompactSkeleton`, with a
/// warning. Runs after [`link_animation_targets`](super::link_animation_targets) and before
/// [`animate`](super::animate).
#[allow(clippy::type_complexity)]
pub fn build_compact_skins(
    mut commands: Commands,
    pending: Query<(Entity, &Skin), (With<CompactSkeleton>, Without<SkinRig>)>,
    skins: Query<(&Skin, Has<CompactSkeleton>)>,
    lookups: RigLookups,
    (mut shapes, mut shared): (Local<RigShapes>, Local<EntityHashSet>),
) {
    if pending.is_empty() {
        return;
    }
    // Bones that a skin posed from its joints' entities also uses (a frame that makes rigs only).
    shared.clear();
    shared.extend(skins.iter().filter(|(_, compact)| !compact).flat_map(|(skin, _)| skin.joints.iter().copied()));
    for (entity, skin) in &pending {
        match make_rig(skin, &lookups, &shared) {
            Ok((shape, player, base, links)) => {
                let shape = shapes.share(shape);
                commands.entity(entity).insert(SkinRig { shape, player, base, links, last_base: Affine3A::NAN });
                for &joint in &skin.joints {
                    commands.entity(joint).try_insert(PosedInSkin(entity));
                }
            }
            Err(why) => {
                warn!(?entity, "this skin cannot be a compact skeleton: {why}; its bones stay entities that animation moves");
                commands.entity(entity).remove::<CompactSkeleton>();
            }
        }
    }
}

/// The rig of `skin`: its shape, player, base and the player's link generation.
/// `shared`: bones that some skin not compact also uses.
fn make_rig(skin: &Skin, lookups: &RigLookups, shared: &EntityHashSet) -> Result<(RigShape, Option<Entity>, Option<Entity>, u32), String> {
    let RigLookups { bones, carriers, placed, outputs } = lookups;
    let joints = &skin.joints;
    if joints.len() != skin.inverse_bind_matrices.len() {
        return Err(format!("it has {} joints and {} inverse bind matrices", joints.len(), skin.inverse_bind_matrices.len()));
    }
    if joints.len() >= NO_PARENT as usize {
        return Err("it has too many joints".into());
    }
    let place = |e: Entity| joints.iter().position(|&j| j == e);
    let mut player: Option<(Entity, u32)> = None;
    let mut base: Option<Option<Entity>> = None;
    let mut parents = Vec::with_capacity(joints.len());
    let mut nodes = Vec::with_capacity(joints.len());
    let mut rests = Vec::with_capacity(joints.len());
    for (i, &joint) in joints.iter().enumerate() {
        if joints[..i].contains(&joint) {
            return Err(format!("joint {joint} is listed twice"));
        }
        let (rest, child_of, by, children) = bones.get(joint).map_err(|_| format!("joint {joint} has no Transform"))?;
        if carriers.contains(joint) {
            return Err(format!("joint {joint} carries a light, camera, mesh or morph weights"));
        }
        if shared.contains(&joint) {
            return Err(format!("joint {joint} is also a joint of a skin that is not compact"));
        }
        if let Some(other) = children.into_iter().flat_map(|c| c.iter()).find(|&c| place(c).is_none()) {
            return Err(format!("joint {joint} carries {other}, which is not a joint of the skin"));
        }
        // A parent without a global transform is no parent: propagation takes the bone as a root.
        let parent_entity = child_of.map(ChildOf::parent).filter(|&p| placed.contains(p));
        let parent = parent_entity.and_then(place);
        if parent.is_none() {
            match base {
                None => base = Some(parent_entity),
                Some(b) if b == parent_entity => {}
                Some(_) => return Err("its root joints hang from different parents".into()),
            }
        }
        let node = match by {
            Some(by) => {
                let links = outputs.get(by.player).map(|out| out.links);
                if links != Ok(by.links) {
                    NO_PARENT // a stale link: the player is gone or no longer animates this joint
                } else {
                    match player {
                        None => player = Some((by.player, by.links)),
                        Some((p, _)) if p == by.player => {}
                        Some(_) => return Err("its joints are animated by more than one player".into()),
                    }
                    by.node
                }
            }
            None => NO_PARENT,
        };
        parents.push(parent);
        nodes.push(node);
        rests.push(*rest);
    }
    // Parents first: each bone after its chain of ancestors within the skin.
    let mut depth = vec![None::<u32>; joints.len()];
    for i in 0..joints.len() {
        let mut chain = vec![i];
        while let Some(&top) = chain.last() {
            if depth[top].is_some() {
                break;
            }
            match parents[top] {
                Some(p) if chain.contains(&p) => return Err("its joints' parents form a cycle".into()),
                Some(p) => chain.push(p),
                None => {
                    depth[top] = Some(0);
                    break;
                }
            }
        }
        for &j in chain.iter().rev() {
            if depth[j].is_none() {
                depth[j] = depth[parents[j].expect("a joint without depth has a parent")].map(|d| d + 1);
            }
        }
    }
    let mut order: Vec<usize> = (0..joints.len()).collect();
    order.sort_by_key(|&i| depth[i]);
    let mut slot = vec![0u32; joints.len()];
    for (k, &i) in order.iter().enumerate() {
        slot[i] = k as u32;
    }
    let bones = order
        .iter()
        .map(|&i| RigBone { joint: i as u32, parent: parents[i].map_or(NO_PARENT, |p| slot[p]), node: nodes[i], rest: rests[i] })
        .collect();
    let inverse_binds = skin.inverse_bind_matrices.iter().map(|m| (m.row(3) == Vec4::W).then(|| Affine3A::from_mat4(*m))).collect();
    let shape = RigShape { bones, inverse_binds, inverse_bind_matrices: skin.inverse_bind_matrices.clone() };
    let (player, links) = player.map_or((None, 0), |(p, l)| (Some(p), l));
    Ok((shape, player, base.flatten(), links))
}

/// What the posing of compact skins keeps between frames (a `Local` of
/// [`update_skin_poses`](super::update_skin_poses)): per-thread scratch for the bones' global
/// transforms (grown to the largest rig a thread posed) and the skins whose rig went stale, so
/// that a warm frame allocates nothing.
#[derive(Default)]
pub struct CompactScratch {
    globals: Parallel<Vec<Affine3A>>,
    stale: Parallel<Vec<Entity>>,
}

/// What a task keeps while it poses a batch of skins: the bones' global transforms, in its
/// thread's [`CompactScratch`] (borrowed once a batch: a per-thread cell borrowed for every
/// skin would put every task's borrow flag in the same cache lines, written for every skin),
/// and the skins it posed, added to the frame's count when the batch ends. It is small: the
/// query's fold moves it for every skin (a 4 KB array of bones kept in it had cost 40 MB of
/// copies a frame at 10,000 foxes, 5 % of the pass).
struct Batch<'a, B: DerefMut<Target = Vec<Affine3A>>> {
    bones: B,
    posed: u32,
    total: &'a AtomicU32,
}

impl<B: DerefMut<Target = Vec<Affine3A>>> Drop for Batch<'_, B> {
    fn drop(&mut self) {
        self.total.fetch_add(self.posed, Ordering::Relaxed);
    }
}

/// Poses every compact skin whose player sampled this frame, or whose base moved relative to
/// the mesh, or whose pose is new (the module docs say how). A skin whose player's targets were
/// re-linked, or whose player or base is gone, keeps its pose and has its rig made again.
/// Runs after transform propagation, with [`update_skin_poses`](super::update_skin_poses).
/// Returns how many compact skins there are and how many it posed.
#[allow(clippy::type_complexity)]
pub(super) fn pose_compact_skins(
    skins: &mut Query<(Entity, &mut SkinRig, Ref<GlobalTransform>, &mut SkinPose)>,
    globals: &Query<Ref<GlobalTransform>>,
    outputs: &Query<&AnimationOutput>,
    clips: Option<&Assets<AnimationClip>>,
    scratch: &mut CompactScratch,
    commands: &mut Commands,
) -> (u32, u32) {
    let CompactScratch { globals: scratches, stale } = scratch;
    let (scratches, stale_ref) = (&*scratches, &*stale);
    let posed = AtomicU32::new(0);
    // Several batches a thread, so that a thread held up elsewhere does not hold up the pass.
    let batching = BatchingStrategy::new().min_batch_size(16).batches_per_thread(4);
    let start = || Batch { bones: scratches.borrow_local_mut(), posed: 0, total: &posed };
    skins.par_iter_mut().batching_strategy(batching).for_each_init(start, |batch, (entity, mut rig, mesh_world, mut pose)| {
        let output = match rig.player {
            Some(player) => match outputs.get(player) {
                Ok(out) if out.links == rig.links => Some(out),
                _ => {
                    stale_ref.borrow_local_mut().push(entity);
                    return;
                }
            },
            None => None,
        };
        let base = match rig.base {
            Some(base) => match globals.get(base) {
                Ok(base) => Some(base),
                Err(_) => {
                    stale_ref.borrow_local_mut().push(entity);
                    return;
                }
            },
            None => None,
        };
        let sampled = output.is_some_and(|out| out.sample);
        // The pose is in the mesh's space: a model that moves as a whole (mesh and base
        // together) keeps it, to rounding.
        let moved = mesh_world.is_changed() || base.as_ref().is_some_and(|b| b.is_changed());
        let to_base =
            if moved || rig.last_base.is_nan() { mesh_world.0.inverse() * base.map_or(Affine3A::IDENTITY, |b| b.0) } else { rig.last_base };
        let shifted = !to_base.abs_diff_eq(rig.last_base, 1e-6 * to_base.translation.abs().max_element().max(1.0));
        if !sampled && !shifted && !rig.is_changed() && pose.0.len() == rig.shape.inverse_binds.len() {
            return;
        }
        rig.bypass_change_detection().last_base = to_base;
        batch.posed += 1;
        // The layers' clips, found once for the skin rather than once a bone.
        let mut layers: [Option<(&AnimationClip, &Layer)>; 2] = [None; 2];
        if let (Some(out), Some(clips)) = (output, clips) {
            for (slot, layer) in layers.iter_mut().zip(out.layers.iter().flatten()) {
                *slot = clips.get(layer.clip).map(|clip| (clip, layer));
            }
        }
        let count = rig.shape.bones.len();
        if batch.bones.len() < count {
            batch.bones.resize(count, Affine3A::IDENTITY);
        }
        let bones = &mut batch.bones[..count];
        // Written in place and flagged changed only if a matrix changed: a paused player's
        // skins cost nothing downstream.
        let mut changed = pose.0.len() != rig.shape.inverse_binds.len();
        let matrices = &mut pose.bypass_change_detection().0;
        matrices.resize(rig.shape.inverse_binds.len(), Mat4::IDENTITY);
        for (slot, bone) in rig.shape.bones.iter().enumerate() {
            let local = if bone.node == NO_PARENT {
                bone.rest
            } else {
                let mut sampled = NodeSample { translation: None, rotation: None, scale: None, weights: [None; 2] };
                for (i, (clip, layer)) in layers.iter().flatten().enumerate() {
                    sample_layer(clip, layer, bone.node as usize, i, &mut sampled);
                }
                sampled.transform(bone.rest).unwrap_or(bone.rest)
            };
            let parent = if bone.parent == NO_PARENT { to_base } else { bones[bone.parent as usize] };
            let global = parent * local.compute_affine();
            bones[slot] = global;
            let joint = bone.joint as usize;
            let matrix = match rig.shape.inverse_binds[joint] {
                Some(bind) => Mat4::from(global * bind),
                None => Mat4::from(global) * rig.shape.inverse_bind_matrices[joint],
            };
            if matrices[joint] != matrix {
                matrices[joint] = matrix;
                changed = true;
            }
        }
        if changed {
            pose.set_changed();
        }
    });
    for list in stale.iter_mut() {
        for entity in list.drain(..) {
            commands.entity(entity).try_remove::<SkinRig>();
        }
    }
    (skins.iter().len() as u32, posed.into_inner())
}
