//! Local and global transforms and their propagation down the `bevy_ecs` hierarchy
//! ([`ChildOf`]/[`Children`]).
//!
//! [`propagate_transforms`] does work proportional to what changed: it starts only at entities
//! whose [`Transform`] or [`ChildOf`] changed (or that lost their parent), skips those that have
//! a changed ancestor (the ancestor's pass covers them), and recomputes each such subtree once,
//! top-down, with a reusable stack (no per-frame allocation once warm). [`GlobalTransform`] is
//! written with `set_if_neq`, so a frame in which nothing moved produces no
//! `Changed<GlobalTransform>` and the render extraction uploads nothing. Every entity whose
//! global transform did change is listed in [`TransformChanges::moved`], so that consumers
//! (the render extraction of decals) find what moved without visiting what did not.
//!
//! Finding the changed transforms is a scan of the change ticks of every entity with a
//! `Transform`, which costs about a millisecond per million entities. Entities that never move
//! on their own (bullet holes, footprints, level geometry) can carry [`Static`]: their archetype
//! is left out of the scan, and their transform is seen only when it is *inserted* (at spawn, or
//! re-inserted to move it: a component hook lists it) or when they are re-parented. What stays
//! proportional to what: the scan to the non-static entities, everything else to the entities
//! that moved (a static child still follows a moving parent: subtrees are walked from the
//! parent). Changing a static entity's `Transform` in place is not seen; debug builds warn
//! once when it happens.
//!
//! **On every core.** A crowd moves hundreds of thousands of joints a frame (10,000 foxes: about
//! 240,000), which one core walked alone. Both halves of the work now run on the compute task
//! pool: finding the changed entities that have no changed ancestor (read-only, a parallel query
//! that first marks every changed entity in a dense array, so that "did my parent change?" reads
//! one slot instead of looking the parent up) and walking the subtrees below them (disjoint, so
//! one task a batch of subtrees:
//! [`parallel`], one of the three modules of the crate allowed `unsafe`, says why that is sound). Bevy's
//! `bevy_transform` walks in parallel the same way, but it could not be taken as a dependency:
//! it brings its own transform components and has no [`Static`] entities, [`Joint`]s or
//! [`TransformChanges`] lists. [`propagate_transforms_serial`] is the one-thread reference the
//! parallel walk is tested against; [`TransformStats`] says what propagation cost a frame.

use bevy_ecs::entity::{Entities, EntityHashSet};
use bevy_ecs::lifecycle::HookContext;
use bevy_ecs::prelude::*;
use bevy_ecs::schedule::SystemSet;
use bevy_ecs::system::SystemParam;
use bevy_ecs::world::DeferredWorld;
use bevy_tasks::{ComputeTaskPool, TaskPool};
use bevy_utils::Parallel;
use glam::{Affine3A, Mat3, Mat4, Quat, Vec3};
use tracing::warn;

use crate::app::{App, Plugin, PostUpdate};
use crate::time::Time;

pub mod parallel;

/// Position, rotation and scale of an entity relative to its parent (or the world for roots).
#[derive(Component, Clone, Copy, Debug, PartialEq)]
#[require(GlobalTransform)]
#[component(on_insert = static_transform_inserted)]
pub struct Transform {
    /// Translation in the parent's space.
    pub translation: Vec3,
    /// Rotation in the parent's space.
    pub rotation: Quat,
    /// Per-axis scale.
    pub scale: Vec3,
}

impl Default for Transform {
    fn default() -> Self {
        Self::IDENTITY
    }
}

impl Transform {
    /// No translation, rotation or scale.
    pub const IDENTITY: Self = Transform { translation: Vec3::ZERO, rotation: Quat::IDENTITY, scale: Vec3::ONE };

    /// A translation by `(x, y, z)`.
    pub fn from_xyz(x: f32, y: f32, z: f32) -> Self {
        Self::from_translation(Vec3::new(x, y, z))
    }

    /// A pure translation.
    pub fn from_translation(translation: Vec3) -> Self {
        Transform { translation, ..Self::IDENTITY }
    }

    /// A pure rotation.
    pub fn from_rotation(rotation: Quat) -> Self {
        Transform { rotation, ..Self::IDENTITY }
    }

    /// A pure scale.
    pub fn from_scale(scale: Vec3) -> Self {
        Transform { scale, ..Self::IDENTITY }
    }

    /// The translation, rotation and scale of `matrix` (which should have no shear; for
    /// re-expressing a transform in a parent's space, `parent⁻¹ · child`).
    pub fn from_matrix(matrix: Mat4) -> Self {
        let (scale, rotation, translation) = matrix.to_scale_rotation_translation();
        Transform { translation, rotation, scale }
    }

    /// This transform with its translation replaced.
    pub fn with_translation(mut self, translation: Vec3) -> Self {
        self.translation = translation;
        self
    }

    /// This transform with its rotation replaced.
    pub fn with_rotation(mut self, rotation: Quat) -> Self {
        self.rotation = rotation;
        self
    }

    /// This transform with its scale replaced.
    pub fn with_scale(mut self, scale: Vec3) -> Self {
        self.scale = scale;
        self
    }

    /// This transform rotated so that its forward axis (-Z) points at `target` and its up axis
    /// (+Y) is as close to `up` as possible. Degenerate inputs (target at the translation, or
    /// `up` parallel to the view direction) keep the rotation or pick any valid up axis.
    pub fn looking_at(mut self, target: Vec3, up: Vec3) -> Self {
        let Some(dir) = (target - self.translation).try_normalize() else {
            return self;
        };
        let back = -dir;
        let right = up.cross(back).try_normalize().unwrap_or_else(|| back.any_orthonormal_vector());
        let up = back.cross(right);
        self.rotation = Quat::from_mat3(&Mat3::from_cols(right, up, back)).normalize();
        self
    }

    /// The local-to-parent affine transform.
    pub fn compute_affine(&self) -> Affine3A {
        Affine3A::from_scale_rotation_translation(self.scale, self.rotation, self.translation)
    }

    /// The local-to-parent matrix.
    pub fn compute_matrix(&self) -> Mat4 {
        Mat4::from_scale_rotation_translation(self.scale, self.rotation, self.translation)
    }

    /// The local forward direction (-Z) in the parent's space.
    pub fn forward(&self) -> Vec3 {
        self.rotation * Vec3::NEG_Z
    }
}

/// The world-space transform of an entity, written by [`propagate_transforms`]; read-only for
/// gameplay code.
#[derive(Component, Clone, Copy, Debug, PartialEq, Default)]
pub struct GlobalTransform(pub Affine3A);

impl From<Transform> for GlobalTransform {
    fn from(transform: Transform) -> Self {
        GlobalTransform(transform.compute_affine())
    }
}

impl GlobalTransform {
    /// The local-to-world affine transform.
    pub fn affine(&self) -> Affine3A {
        self.0
    }

    /// The local-to-world matrix.
    pub fn compute_matrix(&self) -> Mat4 {
        Mat4::from(self.0)
    }

    /// The world-space position of the entity's origin.
    pub fn translation(&self) -> Vec3 {
        self.0.translation.into()
    }

    /// Transforms a local point to world space.
    pub fn transform_point(&self, point: Vec3) -> Vec3 {
        self.0.transform_point3(point)
    }

    /// The world-space forward direction (local -Z), normalised (zero if the scale is zero).
    pub fn forward(&self) -> Vec3 {
        self.0.transform_vector3(Vec3::NEG_Z).normalize_or_zero()
    }
}

/// Marks an entity whose [`Transform`] does not change in place: transform propagation skips
/// its archetype when it scans for changes, so a million static decals cost the scan nothing.
///
/// Such an entity is still placed when spawned, follows its parent when the parent moves, and
/// moves when its `Transform` is re-inserted (`commands.entity(e).insert(new_transform)`) or
/// when it is re-parented. Writing its `Transform` through `&mut Transform` is *not* seen (debug
/// builds warn once); remove `Static` first for an entity that will move every frame.
#[derive(Component, Clone, Copy, Debug, Default, PartialEq, Eq)]
#[component(on_insert = static_inserted)]
pub struct Static;

/// A bone of a skeleton (the glTF spawner marks a skin's joint nodes): propagation moves it like
/// any entity but leaves it out of [`TransformChanges::moved`]. What reads that list looks for
/// mesh instances, lights and decals, which joints are not (a skinned mesh follows its joints
/// through [`crate::animation::Skin::pose_changed`]; meshes and decals hung on a bone are child
/// entities, listed when they move). So an animated crowd's tens of thousands of bones, moving
/// every frame, cost the change lists nothing. Do not put it on an entity that carries a mesh
/// instance or a light itself.
#[derive(Component, Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct Joint;

/// A bone posed by a compact skeleton (`crate::animation::CompactSkeleton`) on the skinned
/// entity it names, which samples, places and skins it in one pass: animation samples nothing
/// into it, and propagation neither visits it nor descends below it (its subtree is bones of the
/// same skin). Its `Transform` and `GlobalTransform` are written by that pass, after propagation
/// (or not at all, for a skin with `crate::animation::UnplacedBones`). Set and cleared with the
/// skin's rig.
#[derive(Component, Clone, Copy, Debug, PartialEq, Eq)]
pub struct PosedInSkin(pub Entity);

/// What transform propagation must look at besides its scan, and what it moved.
///
/// Kept by the [`TransformPlugin`]: component hooks list the [`Static`] entities whose transform
/// was inserted or whose parent changed, and [`propagate_transforms`] lists each entity whose
/// [`GlobalTransform`] it changed during the current frame (every propagation run of the frame
/// adds to the list; the first run of the next frame clears it).
#[derive(Resource, Default)]
pub struct TransformChanges {
    /// Static entities to propagate at the next run.
    pending: EntityHashSet,
    /// Entities whose global transform changed this frame.
    moved: Vec<Entity>,
    /// The frame (`Time::frame`) that `moved` belongs to.
    frame: u64,
}

impl TransformChanges {
    /// Entities whose [`GlobalTransform`] changed during the current frame, in propagation
    /// order (an entity moved by two propagation runs is listed twice), [`Joint`]s left out.
    pub fn moved(&self) -> &[Entity] {
        &self.moved
    }

    fn note_static(mut world: DeferredWorld, entity: Entity) {
        if let Some(mut changes) = world.get_resource_mut::<TransformChanges>() {
            changes.pending.insert(entity);
        }
    }
}

fn static_transform_inserted(world: DeferredWorld, ctx: HookContext) {
    if world.entity(ctx.entity).contains::<Static>() {
        TransformChanges::note_static(world, ctx.entity);
    }
}

fn static_inserted(world: DeferredWorld, ctx: HookContext) {
    TransformChanges::note_static(world, ctx.entity);
}

fn static_reparented(event: On<Insert<ChildOf>>, statics: Query<(), With<Static>>, mut changes: ResMut<TransformChanges>) {
    if statics.contains(event.entity) {
        changes.pending.insert(event.entity);
    }
}

/// System sets of the transform plugin.
#[derive(SystemSet, Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub enum TransformSystems {
    /// [`propagate_transforms`], in [`PostUpdate`].
    Propagate,
}

/// Adds [`propagate_transforms`] to [`PostUpdate`] in [`TransformSystems::Propagate`], and the
/// [`TransformChanges`] it keeps.
pub struct TransformPlugin;

impl Plugin for TransformPlugin {
    fn build(&self, app: &mut App) {
        app.world.init_resource::<TransformChanges>();
        app.world.init_resource::<TransformStats>();
        app.world.add_observer(static_reparented);
        app.add_systems(PostUpdate, propagate_transforms.in_set(TransformSystems::Propagate));
        #[cfg(debug_assertions)]
        app.add_systems(PostUpdate, warn_on_static_writes.before(TransformSystems::Propagate));
    }
}

/// Debug builds: warns once when a [`Static`] entity's `Transform` was written in place (which
/// propagation does not see). Scans the static entities, so release builds leave it out.
#[cfg(debug_assertions)]
fn warn_on_static_writes(
    written: Query<Entity, (With<Static>, Changed<Transform>)>,
    changes: Option<Res<TransformChanges>>,
    mut warned: Local<bool>,
) {
    if *warned {
        return;
    }
    let Some(changes) = changes else { return };
    if let Some(entity) = written.iter().find(|e| !changes.pending.contains(e)) {
        *warned = true;
        warn!(
            ?entity,
            "the Transform of a Static entity was changed in place, which transform propagation does not see: re-insert the Transform to move it, or remove Static from entities that move (warned once)"
        );
    }
}

/// Deepest ancestor chain walked before a hierarchy is reported as cyclic.
const MAX_DEPTH: usize = 1 << 16;

/// What [`propagate_transforms`] keeps between runs so that it allocates nothing once warm.
#[derive(Default)]
pub struct PropagationScratch {
    stack: Vec<(Entity, Affine3A)>,
    roots: Vec<(Entity, Affine3A)>,
    /// The seeds each thread found, with their parents' global transforms.
    found: Parallel<Vec<(Entity, Affine3A)>>,
    /// The parallel walk's per-thread stacks and lists.
    walks: parallel::Walks,
    /// The change lists used when the app has no [`TransformChanges`] resource.
    changes: TransformChanges,
    /// Which entities are dirty this run, by entity index ([`DirtyMarks`]).
    marks: DirtyMarks,
    /// The dirty entities each thread found while marking them, with their parents: the seeds
    /// are sought among these rather than by a second scan of every transform's change tick.
    dirty: Parallel<Vec<(Entity, Option<Entity>)>>,
    /// Those lists, joined.
    dirty_all: Vec<(Entity, Option<Entity>)>,
}

/// The dirty entities of one propagation run, marked by entity index, so that finding the
/// seeds asks "is my parent dirty?" of a dense array instead of the query (an entity lookup, its
/// table and two change ticks a time: in a crowd, once for every one of its 240,000 joints).
/// A slot holds the run's number and the entity's generation, so that no slot needs clearing
/// between runs and a slot of an older run, or of an older entity at the same index, reads as
/// not dirty.
#[derive(Default)]
struct DirtyMarks {
    slots: Vec<std::sync::atomic::AtomicU64>,
    run: u32,
}

impl DirtyMarks {
    /// Starts a run in which entity indices stay below `len`.
    fn start(&mut self, len: usize) {
        if self.slots.len() < len {
            self.slots.resize_with(len, Default::default);
        }
        // Run 0 is what a new slot holds: never a run's number.
        self.run = self.run.checked_add(1).unwrap_or_else(|| {
            self.slots.iter_mut().for_each(|slot| *slot.get_mut() = 0);
            1
        });
    }

    fn stamp(&self, entity: Entity) -> u64 {
        (u64::from(self.run) << 32) | u64::from(entity.generation().to_bits())
    }

    /// Marks `entity` dirty for this run (from any thread).
    ///
    /// Panics rather than skip an entity whose index is beyond the slots: a changed entity left
    /// unmarked would let its changed children be seeds inside its subtree, which the parallel
    /// walk's soundness forbids ([`parallel`]). It cannot happen: the slots cover
    /// `Entities::len()`, every index allocated when the run started, and the run spawns nothing.
    fn mark(&self, entity: Entity) {
        self.slots[entity.index_u32() as usize].store(self.stamp(entity), std::sync::atomic::Ordering::Relaxed);
    }

    /// Whether `entity` was marked in this run.
    fn is_marked(&self, entity: Entity) -> bool {
        self.slots
            .get(entity.index_u32() as usize)
            .is_some_and(|slot| slot.load(std::sync::atomic::Ordering::Relaxed) == self.stamp(entity))
    }
}

/// What propagation reads and writes of each entity it visits (its parent link too: the parallel
/// walk checks it).
type Node = (&'static Transform, &'static mut GlobalTransform, Option<&'static Children>, Has<Joint>, Option<&'static ChildOf>);

/// The entities propagation visits: every one with transforms but the bones of compact skeletons
/// ([`PosedInSkin`]); a walk that reaches one stops there.
type Visited = Without<PosedInSkin>;

/// Non-static entities whose own transform or parent link changed since the last run.
type Dirty = (With<Transform>, Without<Static>, Or<(Changed<Transform>, Changed<ChildOf>)>);

/// [`Dirty`]'s first half: non-static entities whose own transform changed (one change tick a
/// transform to test: the parallel scan's filter, cheaper than the two-way `Or`).
type MovedOwn = (Without<Static>, Changed<Transform>);

/// [`Dirty`]'s second half: non-static entities with a transform whose parent link changed.
type Relinked = (With<Transform>, Without<Static>, Changed<ChildOf>);

/// What propagation cost, for statistics (`cpu_ms.propagate` in the sandbox's `--stats`): kept by
/// the [`TransformPlugin`].
#[derive(Resource, Clone, Copy, Debug, Default, PartialEq)]
pub struct TransformStats {
    /// CPU milliseconds of the frame's propagation runs, added up.
    pub cpu_ms: f32,
    /// The frame (`Time::frame`) they belong to.
    pub frame: u64,
}

/// What one propagation run reads and writes, as system parameters.
#[derive(SystemParam)]
pub struct Propagation<'w, 's> {
    dirty: Query<'w, 's, (Entity, Option<&'static ChildOf>), Dirty>,
    moved_own: Query<'w, 's, (Entity, Option<&'static ChildOf>), MovedOwn>,
    relinked: Query<'w, 's, (Entity, &'static ChildOf), Relinked>,
    parents: Query<'w, 's, &'static ChildOf>,
    nodes: Query<'w, 's, Node, Visited>,
    orphaned: RemovedComponents<'w, 's, ChildOf>,
    entities: &'w Entities,
    changes: Option<ResMut<'w, TransformChanges>>,
    time: Option<Res<'w, Time>>,
    stats: Option<ResMut<'w, TransformStats>>,
    scratch: Local<'s, PropagationScratch>,
}

/// Updates [`GlobalTransform`] of every entity whose transform, parent link or ancestor changed,
/// and lists those whose global transform changed in [`TransformChanges`].
///
/// Roots get `GlobalTransform = Transform`; children get `parent_global * local`. An entity
/// whose parent has no [`GlobalTransform`] is treated as a root of its own. Without the
/// [`TransformChanges`] resource (no [`TransformPlugin`]), [`Static`] entities are not seen.
///
/// It uses every core of the compute task pool (when the app has one: [`crate::app::App`]
/// starts it): the changed entities are checked for a changed ancestor in parallel, and the
/// subtrees below the changed entities that have none are walked in parallel
/// ([`parallel`]'s module docs say why that is sound). The entities it moved are listed in
/// [`TransformChanges::moved`] in no particular order; [`propagate_transforms_serial`] does the
/// same work on one thread, in a fixed order.
pub fn propagate_transforms(p: Propagation) {
    let pool = ComputeTaskPool::try_get().map(|pool| &**pool).filter(|pool| pool.thread_num() > 1);
    propagate(p, pool);
}

/// [`propagate_transforms`] on the calling thread alone: the same global transforms and the same
/// entities listed as moved, in propagation order (depth first from each changed entity, in the
/// order the query finds them). The reference the parallel walk is tested against.
pub fn propagate_transforms_serial(p: Propagation) {
    propagate(p, None);
}

fn propagate(p: Propagation, pool: Option<&TaskPool>) {
    let started = std::time::Instant::now();
    let Propagation { dirty, moved_own, relinked, parents, mut nodes, mut orphaned, entities, changes, time, stats, mut scratch } = p;
    let PropagationScratch { stack, roots, found, walks, changes: own, marks, dirty: dirty_lists, dirty_all } = &mut *scratch;
    let changes = match changes {
        Some(changes) => changes.into_inner(),
        None => own,
    };
    let frame = time.map_or(0, |t| t.frame());
    if changes.frame != frame {
        changes.frame = frame;
        changes.moved.clear();
    }
    let TransformChanges { pending, moved, .. } = changes;
    marks.start(entities.len() as usize);
    let marks = &*marks;
    // The scan of every non-static transform's change tick, once: a million moving-capable
    // decals cost it about a millisecond a pass on one core, and the seeds below are sought
    // among what it found.
    match pool {
        Some(_) => {
            // The two halves of `Dirty` one after the other, so that an entity in both is listed
            // once (a seed listed twice would be walked by two tasks).
            moved_own.par_iter().for_each(|(entity, child_of)| {
                marks.mark(entity);
                dirty_lists.scope(|list| list.push((entity, child_of.map(ChildOf::parent))));
            });
            relinked.par_iter().for_each(|(entity, child_of)| {
                if !marks.is_marked(entity) {
                    marks.mark(entity);
                    dirty_lists.scope(|list| list.push((entity, Some(child_of.parent()))));
                }
            });
        }
        None => dirty.iter().for_each(|(entity, _)| marks.mark(entity)),
    }
    let is_dirty = |entity: Entity| marks.is_marked(entity) || (!pending.is_empty() && pending.contains(&entity));
    // Entities that lost their parent and are roots now (unless they are also dirty, in which
    // case the seeds below handle them). Few, and walked first, on this thread: a seed may lie in
    // their subtrees.
    for entity in orphaned.read() {
        if !is_dirty(entity) && !parents.contains(entity) && nodes.contains(entity) {
            stack.push((entity, Affine3A::IDENTITY));
        }
    }
    propagate_stack(stack, &mut nodes, moved);

    // The seeds: changed entities with no changed ancestor (the ancestor's subtree walk
    // recomputes them). No seed is another's ancestor, so their subtrees are disjoint. The
    // entity's own parent link comes with it (read in table order, not looked up), and an
    // ancestor's link is looked up only past a parent that did not change (in a crowd, nearly
    // every changed joint's parent changed too: one lookup decides it).
    let is_seed = |entity: Entity, parent: Option<Entity>| {
        let mut depth = 0;
        let mut parent = parent;
        while let Some(current) = parent {
            depth += 1;
            if depth > MAX_DEPTH || current == entity {
                warn!(?entity, "transform hierarchy is cyclic or too deep; not propagated");
                return false;
            }
            if is_dirty(current) {
                return false;
            }
            parent = parents.get(current).ok().map(ChildOf::parent);
        }
        true
    };
    // A seed's walk starts from its parent's global transform (read before any is written).
    let root = |entity: Entity, parent: Option<Entity>| {
        let parent = parent.and_then(|parent| nodes.get(parent).ok());
        (entity, parent.map_or(Affine3A::IDENTITY, |(_, global, ..)| global.0))
    };
    roots.clear();
    match pool {
        Some(pool) => {
            // The dirty entities the threads listed, a few chunks a thread.
            dirty_all.clear();
            for list in dirty_lists.iter_mut() {
                dirty_all.append(list);
            }
            let chunk = dirty_all.len().div_ceil(pool.thread_num() * 4).max(256);
            let (is_seed, root, seeds) = (&is_seed, &root, &*found);
            pool.scope(|scope| {
                for part in dirty_all.chunks(chunk) {
                    scope.spawn(async move {
                        seeds.scope(|roots| {
                            roots.extend(part.iter().filter(|&&(e, p)| is_seed(e, p)).map(|&(e, p)| root(e, p)));
                        });
                    });
                }
            });
            for list in found.iter_mut() {
                roots.append(list);
            }
        }
        None => roots.extend(
            dirty
                .iter()
                .map(|(entity, child_of)| (entity, child_of.map(ChildOf::parent)))
                .filter(|&(entity, parent)| is_seed(entity, parent))
                .map(|(entity, parent)| root(entity, parent)),
        ),
    }
    // Static entities (never also dirty: a seed is listed once).
    roots.extend(pending.iter().copied().filter(|&entity| !marks.is_marked(entity)).filter_map(|entity| {
        let parent = parents.get(entity).ok().map(ChildOf::parent);
        is_seed(entity, parent).then(|| root(entity, parent))
    }));
    match pool {
        Some(pool) => parallel::walk(roots, &mut nodes, moved, walks, pool),
        None => {
            for &root in roots.iter() {
                stack.push(root);
                propagate_stack(stack, &mut nodes, moved);
            }
        }
    }
    pending.clear();
    if let Some(mut stats) = stats {
        if stats.frame != frame {
            *stats = TransformStats { cpu_ms: 0.0, frame };
        }
        stats.cpu_ms += started.elapsed().as_secs_f32() * 1e3;
    }
}

/// Recomputes the subtrees rooted at the entities on `stack`, depth first, emptying it, and
/// lists the entities whose global transform changed in `moved`.
fn propagate_stack(stack: &mut Vec<(Entity, Affine3A)>, nodes: &mut Query<Node, Visited>, moved: &mut Vec<Entity>) {
    while let Some((entity, parent_affine)) = stack.pop() {
        let Ok((transform, mut global, children, joint, _)) = nodes.get_mut(entity) else {
            continue;
        };
        let affine = parent_affine * transform.compute_affine();
        if global.set_if_neq(GlobalTransform(affine)) && !joint {
            moved.push(entity);
        }
        if let Some(children) = children {
            stack.extend(children.iter().map(|child| (child, affine)));
        }
    }
}

#[cfg(test)]
mod tests {
    use bevy_ecs::schedule::Schedule;
    use bevy_tasks::TaskPoolBuilder;
    use proptest::prelude::*;

    use super::*;

    /// One change applied between frames to entity `target`.
    #[derive(Clone, Debug)]
    enum Change {
        Move(usize, Vec3),
        Reparent(usize, usize),
        Orphan(usize),
        Reinsert(usize, Vec3),
        /// A leaf despawned and an entity spawned in its place (at its index, a generation on),
        /// under the same parent.
        Respawn(usize, Vec3),
    }

    /// An entity of the random hierarchy: its parent (an earlier entity) if any, translation,
    /// rotation about Y, whether it is static, whether it is a joint.
    type NodeSpec = (Option<prop::sample::Index>, Vec3, f32, bool, bool);

    /// A random forest: each entity's parent is an earlier entity or none, with a few static
    /// entities and joints; then frames of random changes (an empty frame among them).
    fn hierarchies() -> impl Strategy<Value = (Vec<NodeSpec>, Vec<Vec<Change>>)> {
        let node = (
            prop::option::weighted(0.8, any::<prop::sample::Index>()),
            prop::array::uniform3(-3.0f32..3.0).prop_map(Vec3::from),
            -3.0f32..3.0,
            prop::bool::weighted(0.2),
            prop::bool::weighted(0.3),
        );
        let change = (0usize..5, any::<usize>(), any::<usize>(), prop::array::uniform3(-2.0f32..2.0).prop_map(Vec3::from)).prop_map(
            |(kind, a, b, v)| match kind {
                0 => Change::Move(a, v),
                1 => Change::Reparent(a, b),
                2 => Change::Orphan(a),
                3 => Change::Reinsert(a, v),
                _ => Change::Respawn(a, v),
            },
        );
        (prop::collection::vec(node, 1..120), prop::collection::vec(prop::collection::vec(change, 0..12), 1..5))
    }

    /// A world with the hierarchy and a schedule running `system`.
    fn world_with(nodes: &[NodeSpec]) -> (World, Vec<Entity>) {
        let mut world = World::new();
        world.init_resource::<TransformChanges>();
        world.init_resource::<Time>();
        world.add_observer(static_reparented);
        let mut entities: Vec<Entity> = Vec::new();
        for (i, (parent, translation, angle, is_static, joint)) in nodes.iter().enumerate() {
            let transform = Transform::from_translation(*translation).with_rotation(Quat::from_rotation_y(*angle));
            let mut e = world.spawn(transform);
            if let Some(parent) = parent.filter(|_| i > 0) {
                e.insert(ChildOf(entities[parent.index(i)]));
            }
            if *is_static {
                e.insert(Static);
            }
            if *joint {
                e.insert(Joint);
            }
            entities.push(e.id());
        }
        (world, entities)
    }

    fn apply(world: &mut World, entities: &mut [Entity], change: &Change) {
        let n = entities.len();
        match *change {
            Change::Move(a, v) => {
                let e = entities[a % n];
                if !world.entity(e).contains::<Static>() {
                    world.get_mut::<Transform>(e).unwrap().translation += v;
                }
            }
            // To an earlier entity only: the hierarchy stays a forest.
            Change::Reparent(a, b) if a % n > 0 => {
                let child = a % n;
                world.entity_mut(entities[child]).insert(ChildOf(entities[b % child]));
            }
            Change::Reparent(..) => {}
            Change::Orphan(a) => {
                world.entity_mut(entities[a % n]).remove::<ChildOf>();
            }
            Change::Reinsert(a, v) => {
                let e = entities[a % n];
                let t = *world.get::<Transform>(e).unwrap();
                world.entity_mut(e).insert(t.with_translation(t.translation + v));
            }
            Change::Respawn(a, v) => {
                let old = world.entity(entities[a % n]);
                if old.contains::<Children>() {
                    return;
                }
                let (parent, is_static, joint) =
                    (old.get::<ChildOf>().map(ChildOf::parent), old.contains::<Static>(), old.contains::<Joint>());
                // Its index again, a generation on (despawning frees an index for later).
                let reused = world.despawn_no_free(entities[a % n]).unwrap();
                let mut e = world.spawn_at(reused, Transform::from_translation(v)).unwrap();
                if let Some(parent) = parent {
                    e.insert(ChildOf(parent));
                }
                if is_static {
                    e.insert(Static);
                }
                if joint {
                    e.insert(Joint);
                }
                entities[a % n] = e.id();
            }
        }
    }

    fn frame(world: &mut World, schedule: &mut Schedule) -> Vec<Entity> {
        world.resource_mut::<Time>().advance();
        schedule.run(world);
        let mut moved = world.resource::<TransformChanges>().moved().to_vec();
        moved.sort();
        moved
    }

    proptest! {
        #![proptest_config(ProptestConfig { cases: 48, ..ProptestConfig::default() })]

        /// The parallel walk gives the global transforms and the moved entities of the serial
        /// one, frame after frame of random moves, re-insertions, re-parentings and orphanings
        /// of static and moving entities, and leaves despawned with another entity spawned at
        /// their index; both equal the product of each entity's local transforms up to its
        /// root; a frame with no change moves nothing.
        #[test]
        fn parallel_propagation_matches_the_serial_one((nodes, frames) in hierarchies()) {
            let pool = ComputeTaskPool::get_or_init(|| TaskPoolBuilder::new().num_threads(4).build());
            prop_assert!(pool.thread_num() > 1, "the parallel walk needs more than one thread to be tested");
            let (mut serial, mut entities) = world_with(&nodes);
            let (mut parallel, mut same) = world_with(&nodes);
            prop_assert_eq!(&entities, &same);
            let mut serial_schedule = Schedule::default();
            serial_schedule.add_systems(propagate_transforms_serial);
            let mut parallel_schedule = Schedule::default();
            parallel_schedule.add_systems(propagate_transforms);
            for (f, changes) in std::iter::once(&Vec::new()).chain(&frames).chain([&Vec::new()]).enumerate() {
                for change in changes {
                    apply(&mut serial, &mut entities, change);
                    apply(&mut parallel, &mut same, change);
                }
                prop_assert_eq!(&entities, &same, "frame {}: the same entities respawned", f);
                let (a, b) = (frame(&mut serial, &mut serial_schedule), frame(&mut parallel, &mut parallel_schedule));
                prop_assert_eq!(&a, &b, "frame {}: the same entities moved", f);
                for &e in &entities {
                    prop_assert_eq!(serial.get::<GlobalTransform>(e), parallel.get::<GlobalTransform>(e), "frame {}: {:?}", f, e);
                    // And both are right: the product of the local transforms up to the root.
                    let mut expected = Affine3A::IDENTITY;
                    let mut node = Some(e);
                    while let Some(current) = node {
                        expected = serial.get::<Transform>(current).unwrap().compute_affine() * expected;
                        node = serial.get::<ChildOf>(current).map(ChildOf::parent);
                    }
                    let global = serial.get::<GlobalTransform>(e).unwrap().0;
                    prop_assert!(global.abs_diff_eq(expected, 1e-3), "frame {}: {:?} is at {:?}, not {:?}", f, e, global, expected);
                }
                if f > 0 && changes.is_empty() {
                    prop_assert!(a.is_empty(), "frame {}: nothing changed, nothing moved: {:?}", f, a);
                }
            }
        }
    }
}
