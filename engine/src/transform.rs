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

use bevy_ecs::entity::EntityHashSet;
use bevy_ecs::lifecycle::HookContext;
use bevy_ecs::prelude::*;
use bevy_ecs::schedule::SystemSet;
use bevy_ecs::world::DeferredWorld;
use glam::{Affine3A, Mat3, Mat4, Quat, Vec3};
use tracing::warn;

use crate::app::{App, Plugin, PostUpdate};
use crate::time::Time;

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
    seeds: Vec<Entity>,
    /// The change lists used when the app has no [`TransformChanges`] resource.
    changes: TransformChanges,
}

/// What propagation reads and writes of each entity it visits.
type Node = (&'static Transform, &'static mut GlobalTransform, Option<&'static Children>, Has<Joint>);

/// Non-static entities whose own transform or parent link changed since the last run.
type Dirty = (With<Transform>, Without<Static>, Or<(Changed<Transform>, Changed<ChildOf>)>);

/// Updates [`GlobalTransform`] of every entity whose transform, parent link or ancestor changed,
/// and lists those whose global transform changed in [`TransformChanges`].
///
/// Roots get `GlobalTransform = Transform`; children get `parent_global * local`. An entity
/// whose parent has no [`GlobalTransform`] is treated as a root of its own. Without the
/// [`TransformChanges`] resource (no [`TransformPlugin`]), [`Static`] entities are not seen.
pub fn propagate_transforms(
    dirty: Query<Entity, Dirty>,
    parents: Query<&ChildOf>,
    mut nodes: Query<Node>,
    mut orphaned: RemovedComponents<ChildOf>,
    (changes, time): (Option<ResMut<TransformChanges>>, Option<Res<Time>>),
    mut scratch: Local<PropagationScratch>,
) {
    let PropagationScratch { stack, seeds, changes: own } = &mut *scratch;
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
    let is_dirty = |entity: Entity| dirty.contains(entity) || pending.contains(&entity);
    // Entities that lost their parent and are roots now (unless they are also dirty, in which
    // case the loop below handles them).
    for entity in orphaned.read() {
        if !is_dirty(entity) && !parents.contains(entity) && nodes.contains(entity) {
            stack.push((entity, Affine3A::IDENTITY));
        }
    }
    propagate_stack(stack, &mut nodes, moved);

    seeds.clear();
    seeds.extend(dirty.iter().chain(pending.iter().copied()));
    'seeds: for &entity in seeds.iter() {
        // Skip entities with a dirty ancestor: the ancestor's subtree pass recomputes them.
        let mut current = entity;
        let mut depth = 0;
        while let Ok(child_of) = parents.get(current) {
            current = child_of.parent();
            depth += 1;
            if depth > MAX_DEPTH || current == entity {
                warn!(?entity, "transform hierarchy is cyclic or too deep; not propagated");
                continue 'seeds;
            }
            if is_dirty(current) {
                continue 'seeds;
            }
        }
        let parent_affine = parents
            .get(entity)
            .ok()
            .and_then(|child_of| nodes.get(child_of.parent()).ok())
            .map_or(Affine3A::IDENTITY, |(_, global, _, _)| global.0);
        stack.push((entity, parent_affine));
        propagate_stack(stack, &mut nodes, moved);
    }
    pending.clear();
}

/// Recomputes the subtrees rooted at the entities on `stack`, depth first, emptying it, and
/// lists the entities whose global transform changed in `moved`.
fn propagate_stack(stack: &mut Vec<(Entity, Affine3A)>, nodes: &mut Query<Node>, moved: &mut Vec<Entity>) {
    while let Some((entity, parent_affine)) = stack.pop() {
        let Ok((transform, mut global, children, joint)) = nodes.get_mut(entity) else {
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
