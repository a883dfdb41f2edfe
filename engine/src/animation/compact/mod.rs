//! Compact skeletons: a skinned mesh posed in one pass from its clips, its bones' entities placed
//! as it goes. Not a technique of the seeds: it is what production engines offer for crowds (Unity's
//! "Optimize Game Objects" on an animator, which keeps a skeleton's bones out of the scene's
//! transform hierarchy unless exposed; Unreal's skeletal meshes, whose bones are never scene
//! components).
//!
//! **Why.** With bones as entities, every bone is moved by three passes:
//! [`animate`](super::animate) writes its `Transform`, transform propagation its
//! `GlobalTransform`, and [`update_skin_poses`](super::update_skin_poses) reads those back for
//! the skin matrices, each pass finding the bone again by its entity. For 10,000 foxes that is
//! 240,000 entities' transforms written and read three times a frame, most of the CPU frame on a
//! machine whose memory is the bottleneck (`docs/experiments/crowds-rig-posing.md` measured that
//! no order of those three passes moves fewer bytes). A skin with [`CompactSkeleton`] is posed
//! in one pass instead, from the clips straight to its [`SkinPose`]: its bones' local and global
//! transforms are composed in a few kilobytes of one task's scratch memory, and written to the
//! bones' entities as they are made. On the 2-core development machine `cargo bench -p engine
//! --bench animation -- '/10000$'` took 10.3–10.8 ms a frame this way, against 17.1–19.3 ms
//! with bones as entities and 6.1–6.6 ms with the bones left unplaced. So the glTF prefab spawns
//! skins compact by default (`GltfPrefab::compact_skeletons`).
//!
//! **What it changes.** Little, by design: the bones keep their entities, and each frame the
//! pose pass writes their `Transform` (the sampled local transform) and `GlobalTransform` (where
//! they are), as animation and propagation would ([`bones`] says how that is done from parallel
//! tasks). Transform propagation does not visit them ([`PosedInSkin`]), so a crowd that walks
//! costs it its models' few nodes, not their bones. The differences:
//! - The bones' transforms are written in [`SkinPoseSystems`](super::SkinPoseSystems), after
//!   propagation: a system that reads a bone's `GlobalTransform` in `PostUpdate` runs after that
//!   set to see this frame's.
//! - The pose pass writes a bone's `Transform` without flagging it changed (`Changed<Transform>`
//!   does not fire on compact bones; `Changed<GlobalTransform>` does), so that a write by the
//!   game stands out.
//! - A bone property the playing clips do not animate takes its rest value. With bones as
//!   entities it keeps the last value a clip wrote; the two differ only after a switch to a clip
//!   that animates fewer properties.
//! - **A bone's `Transform` written by the game** (inverse kinematics, a head turned to look)
//!   poses the skin that frame, as it would the bones' entities ([`pose_compact_skins`] finds
//!   it from the bones' change ticks), and the skin then gives its bones back to animation and
//!   propagation for good. In that one frame a property the game did not write keeps the
//!   previous frame's sampled value. A write in the one frame a skin's rig is made again (its
//!   player re-linked, say) is not seen; the next is.
//!
//! [`UnplacedBones`] leaves the bones' entities alone as well, for crowds nothing reads the bones
//! of: their `Transform` keeps the value it had when the skeleton was made compact and their
//! `GlobalTransform` the last value propagation wrote; neither says where the bone is, and
//! [`SkinPose::joint_world`] does. Writing a bone's `Transform` then does nothing.
//!
//! **When a skin cannot be compact.** It stays as it is, or gives its bones back, saying so (an
//! `info` event: compact skeletons are the default, and these are ordinary cases),
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
//! **Skins that share a skeleton** (a glTF mesh's primitives each have the mesh's skin) can all
//! be compact. The last made owns the bones' entities ([`PosedInSkin`] names it) and places
//! them; the others follow ([`SkinRig::follows`]): [`update_skin_poses`](super::update_skin_poses)
//! poses them from the placed bones, as it poses a skin without a rig. So they agree with the
//! owner in every frame, the game's writes included, and keep following the bones once the owner
//! gave them back. With [`UnplacedBones`] on the owner, each skin poses itself from the clips.
//!
//! **How.** [`build_compact_skins`] makes a [`SkinRig`] for each compact skin that has none: its
//! bones parents first, each with its parent's place in that list, its node index in the
//! player's clips and its rest transform. It does so again when a bone is re-linked to a player
//! (one added late, or targets changed) or re-parented. Every instance of a model has the same
//! rig, so the rigs are shared (one allocation for a crowd of one character: what a frame reads
//! of it stays in the cache). [`update_skin_poses`](super::update_skin_poses) then, in parallel
//! over the skins, samples each bone's channels at its player's time, composes the global
//! transforms down the list, writes `mesh⁻¹ × base × global × inverse bind` into the pose, and
//! places the bones it owns. The [`AnimationBudget`](super::AnimationBudget) applies as before:
//! a player that does not sample this frame leaves its skins' poses as they are, unless the base
//! moved relative to the mesh (a model that walks as a whole keeps its pose, and its bones'
//! entities are placed again from it).

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
use tracing::info;

mod bones;

use bones::{BoneTransforms, BoneWriter};

use super::{AnimatedBy, AnimationClip, AnimationOutput, Layer, MorphWeights, NodeSample, Skin, SkinPose, sample_layer};
use crate::asset::Assets;
use crate::camera::Camera;
use crate::light::{DirectionalLight, DiskLight, PointLight, RectLight, SpotLight};
use crate::scene::MeshInstance;
use crate::transform::{GlobalTransform, PosedInSkin, Transform};

/// On an entity with a [`Skin`]: pose it from its player's clips in one pass, which places its
/// bones' entities as it goes, rather than through animation and propagation of those entities
/// (the module docs say what that changes, and when a skin cannot be compact). The glTF prefab
/// puts it on every skin it spawns unless told not to.
#[derive(Component, Clone, Copy, Debug, Default, PartialEq, Eq)]
#[component(on_remove = compact_skeleton_removed)]
pub struct CompactSkeleton;

/// On a [`CompactSkeleton`] skin: its bones' entities are not written at all, neither their
/// `Transform` nor their `GlobalTransform` (the module docs say what that saves and what it
/// changes). For crowds nothing reads the bones of.
#[derive(Component, Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct UnplacedBones;

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
    /// Whether the game wrote one of the bones' `Transform`s since the last pose (set by
    /// [`pose_compact_skins`]): the skin is posed this frame from what was written, and then gives
    /// its bones back.
    written: bool,
    /// Whether another skin owns and places the bones: this one is then posed from them, by
    /// [`update_skin_poses`](super::update_skin_poses).
    follows: bool,
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

    /// Whether the skin follows bones another skin sharing its skeleton owns and places (it
    /// is then posed from their entities, as a skin without a rig is).
    pub fn follows(&self) -> bool {
        self.follows
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
    /// The inverses of [`Self::inverse_binds`] (`None` where that is `None` or cannot be
    /// inverted): a bone's transform in the mesh's space from its skin matrix, to place the
    /// bones' entities again when the model moves between two poses.
    binds: Vec<Option<Affine3A>>,
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
        info!(skin = ?ctx.entity, compact = ?owner, "a skin shares bones with a compact skeleton, which gives them back to animation");
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
/// saying so (the child needs its parent's `GlobalTransform`).
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
        info!(?child, ?skin, "an entity was hung on a bone of a compact skeleton, which gives its bones back to animation");
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
/// that cannot be compact (the module docs say when) loses its `CompactSkeleton`, saying why.
/// Runs after [`link_animation_targets`](super::link_animation_targets) and before
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
                commands.entity(entity).insert(SkinRig {
                    shape,
                    player,
                    base,
                    links,
                    last_base: Affine3A::NAN,
                    written: false,
                    follows: false,
                });
                for &joint in &skin.joints {
                    commands.entity(joint).try_insert(PosedInSkin(entity));
                }
            }
            Err(why) => {
                info!(?entity, "this skin cannot be a compact skeleton: {why}; its bones stay entities that animation moves");
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
    let inverse_binds: Vec<_> = skin.inverse_bind_matrices.iter().map(|m| (m.row(3) == Vec4::W).then(|| Affine3A::from_mat4(*m))).collect();
    let binds = inverse_binds.iter().map(|m| m.map(|m| m.inverse()).filter(|b| b.is_finite())).collect();
    let shape = RigShape { bones, inverse_binds, inverse_bind_matrices: skin.inverse_bind_matrices.clone(), binds };
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
    handed_back: Parallel<Vec<Entity>>,
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

/// What the pose pass reads and writes of a compact skin.
type CompactSkin = (Entity, &'static mut SkinRig, Ref<'static, GlobalTransform>, &'static mut SkinPose, &'static Skin, Has<UnplacedBones>);

/// The bones' transforms the game wrote since the pose pass last ran (inverse kinematics).
type WrittenBones = Query<'static, 'static, (&'static PosedInSkin, Ref<'static, Transform>), Changed<Transform>>;

/// Poses every compact skin whose player sampled this frame, or whose base moved relative to
/// the mesh, or whose pose is new, or one of whose bones the game wrote (the module docs say
/// how), and places the bones it owns. A skin whose player's targets were re-linked, or whose
/// player or base is gone, keeps its pose and has its rig made again. A skin that shares its
/// skeleton with another that owns and places the bones (a glTF mesh's other primitives) is
/// left to [`update_skin_poses`](super::update_skin_poses), which poses it from the placed
/// bones: so it follows whatever placed them, the game's writes included.
///
/// Runs after transform propagation, before [`update_skin_poses`](super::update_skin_poses),
/// and times itself into [`AnimationStats::skin_cpu_ms`](super::AnimationStats::skin_cpu_ms)
/// (which that system adds to).
#[allow(clippy::type_complexity, clippy::too_many_arguments)]
pub fn pose_compact_skins(
    mut skins: Query<CompactSkin, Without<PosedInSkin>>,
    globals: Query<Ref<GlobalTransform>, Without<PosedInSkin>>,
    mut bones: ParamSet<(BoneTransforms, WrittenBones)>,
    (owners, unplaced_owners): (Query<&'static PosedInSkin>, Query<(), With<UnplacedBones>>),
    (outputs, clips): (Query<&AnimationOutput>, Option<Res<Assets<AnimationClip>>>),
    mut scratch: Local<CompactScratch>,
    mut commands: Commands,
    stats: Option<ResMut<super::AnimationStats>>,
) {
    let started = std::time::Instant::now();
    // The game's writes, seen against this system's own last run (a few bytes of change ticks a
    // bone, only in the bones' archetypes).
    for (&PosedInSkin(owner), transform) in &bones.p1() {
        if transform.is_added() {
            continue;
        }
        if let Ok((_, mut rig, .., false)) = skins.get_mut(owner)
            && !rig.is_added()
        {
            rig.bypass_change_detection().written = true;
        }
    }
    let clips = clips.as_deref();
    let mut bone_transforms = bones.p0();
    let writer = BoneWriter::new(&mut bone_transforms, &owners);
    let CompactScratch { globals: scratches, stale, handed_back } = &mut *scratch;
    let (scratches, stale_ref, handed_back_ref) = (&*scratches, &*stale, &*handed_back);
    let posed = AtomicU32::new(0);
    // Several batches a thread, so that a thread held up elsewhere does not hold up the pass.
    let batching = BatchingStrategy::new().min_batch_size(16).batches_per_thread(4);
    let start = || Batch { bones: scratches.borrow_local_mut(), posed: 0, total: &posed };
    skins.par_iter_mut().batching_strategy(batching).for_each_init(
        start,
        |batch, (entity, mut rig, mesh_world, mut pose, skin, unplaced)| {
            // Another skin owns these bones and places them: this one follows them.
            let follows = !unplaced
                && skin.joints.first().is_some_and(|&bone| match owners.get(bone) {
                    Ok(&PosedInSkin(owner)) => owner != entity && !unplaced_owners.contains(owner),
                    Err(_) => true,
                });
            if rig.follows != follows {
                // Flagged changed: the pass that now poses the skin poses it again.
                rig.follows = follows;
            }
            if follows {
                return;
            }
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
            let to_base = if moved || rig.last_base.is_nan() {
                mesh_world.0.inverse() * base.map_or(Affine3A::IDENTITY, |b| b.0)
            } else {
                rig.last_base
            };
            let shifted = !to_base.abs_diff_eq(rig.last_base, 1e-6 * to_base.translation.abs().max_element().max(1.0));
            if !sampled && !shifted && !rig.written && !rig.is_changed() && pose.0.len() == rig.shape.inverse_binds.len() {
                // The pose stands; the bones' entities follow a model that moved.
                if moved && !unplaced {
                    place_bones(&rig.shape, entity, skin, mesh_world.0, &pose.0, &writer);
                }
                return;
            }
            let rig_state = rig.bypass_change_detection();
            let watch = std::mem::take(&mut rig_state.written);
            rig_state.last_base = to_base;
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
            let mut handed = false;
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
                let joint = bone.joint as usize;
                // The bone's entity, when this skin owns it, is placed too; a `Transform` the
                // game wrote poses the bone instead, and the skin then gives its bones back.
                let placed = match skin.joints.get(joint) {
                    Some(&bone_entity) if !unplaced => writer.place(entity, bone_entity, watch, local, parent, mesh_world.0),
                    _ => None,
                };
                let global = match placed {
                    Some((placed_local, global)) => {
                        handed |= placed_local != local;
                        global
                    }
                    None => parent * local.compute_affine(),
                };
                bones[slot] = global;
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
            if handed {
                handed_back_ref.borrow_local_mut().push(entity);
            }
        },
    );
    for list in stale.iter_mut() {
        for entity in list.drain(..) {
            commands.entity(entity).try_remove::<SkinRig>();
        }
    }
    for list in handed_back.iter_mut() {
        for entity in list.drain(..) {
            info!(skin = ?entity, "a bone of this compact skeleton was written by the game: its bones are entities that animation moves from now on");
            commands.entity(entity).try_remove::<CompactSkeleton>();
        }
    }
    if let Some(mut stats) = stats {
        stats.skin_cpu_ms = started.elapsed().as_secs_f32() * 1e3;
        (stats.compact_skins, stats.compact_posed) = (skins.iter().len() as u32, posed.into_inner());
    }
}

/// Places the bones' entities of a skin whose pose stands while its model moved: each bone
/// `skin`'s pose owns gets `mesh_world × pose × bind` as its `GlobalTransform` (a bone whose
/// inverse bind matrix is not affine or not invertible keeps its own).
fn place_bones(shape: &RigShape, entity: Entity, skin: &Skin, mesh_world: Affine3A, pose: &[Mat4], writer: &BoneWriter) {
    for (joint, (&bone, bind)) in skin.joints.iter().zip(&shape.binds).enumerate() {
        let (Some(bind), Some(matrix)) = (bind, pose.get(joint)) else { continue };
        let global = mesh_world * Affine3A::from_mat4(*matrix) * *bind;
        writer.place_world(entity, bone, global);
    }
}
