//! Local and global transforms and their propagation down the `bevy_ecs` hierarchy
//! ([`ChildOf`]/[`Children`]).
//!
//! [`propagate_transforms`] does work proportional to what changed: it starts only at entities
//! whose [`Transform`] or [`ChildOf`] changed (or that lost their parent), skips those that have
//! a changed ancestor (the ancestor's pass covers them), and recomputes each such subtree once,
//! top-down, with a reusable stack (no per-frame allocation once warm). [`GlobalTransform`] is
//! written with `set_if_neq`, so a frame in which nothing moved produces no
//! `Changed<GlobalTransform>` and the render extraction uploads nothing.

use bevy_ecs::prelude::*;
use bevy_ecs::schedule::SystemSet;
use glam::{Affine3A, Mat3, Mat4, Quat, Vec3};
use tracing::warn;

use crate::app::{App, Plugin, PostUpdate};

/// Position, rotation and scale of an entity relative to its parent (or the world for roots).
#[derive(Component, Clone, Copy, Debug, PartialEq)]
#[require(GlobalTransform)]
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

/// System sets of the transform plugin.
#[derive(SystemSet, Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub enum TransformSystems {
    /// [`propagate_transforms`], in [`PostUpdate`].
    Propagate,
}

/// Adds [`propagate_transforms`] to [`PostUpdate`] in [`TransformSystems::Propagate`].
pub struct TransformPlugin;

impl Plugin for TransformPlugin {
    fn build(&self, app: &mut App) {
        app.add_systems(PostUpdate, propagate_transforms.in_set(TransformSystems::Propagate));
    }
}

/// Deepest ancestor chain walked before a hierarchy is reported as cyclic.
const MAX_DEPTH: usize = 1 << 16;

/// Entities whose own transform or parent link changed since the last run.
type Dirty = Or<(Changed<Transform>, Changed<ChildOf>)>;

/// Updates [`GlobalTransform`] of every entity whose transform, parent link or ancestor changed.
///
/// Roots get `GlobalTransform = Transform`; children get `parent_global * local`. An entity
/// whose parent has no [`GlobalTransform`] is treated as a root of its own.
pub fn propagate_transforms(
    dirty: Query<Entity, (With<Transform>, Dirty)>,
    parents: Query<&ChildOf>,
    mut nodes: Query<(&Transform, &mut GlobalTransform, Option<&Children>)>,
    mut orphaned: RemovedComponents<ChildOf>,
    mut stack: Local<Vec<(Entity, Affine3A)>>,
) {
    // Entities that lost their parent and are roots now (unless they are also dirty, in which
    // case the loop below handles them).
    for entity in orphaned.read() {
        if !dirty.contains(entity) && !parents.contains(entity) && nodes.contains(entity) {
            stack.push((entity, Affine3A::IDENTITY));
        }
    }
    propagate_stack(&mut stack, &mut nodes);

    'seeds: for entity in &dirty {
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
            if dirty.contains(current) {
                continue 'seeds;
            }
        }
        let parent_affine = parents
            .get(entity)
            .ok()
            .and_then(|child_of| nodes.get(child_of.parent()).ok())
            .map_or(Affine3A::IDENTITY, |(_, global, _)| global.0);
        stack.push((entity, parent_affine));
        propagate_stack(&mut stack, &mut nodes);
    }
}

/// Recomputes the subtrees rooted at the entities on `stack`, depth first, emptying it.
fn propagate_stack(stack: &mut Vec<(Entity, Affine3A)>, nodes: &mut Query<(&Transform, &mut GlobalTransform, Option<&Children>)>) {
    while let Some((entity, parent_affine)) = stack.pop() {
        let Ok((transform, mut global, children)) = nodes.get_mut(entity) else {
            continue;
        };
        let affine = parent_affine * transform.compute_affine();
        global.set_if_neq(GlobalTransform(affine));
        if let Some(children) = children {
            stack.extend(children.iter().map(|child| (child, affine)));
        }
    }
}
