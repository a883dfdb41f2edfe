//! The parallel walk of transform propagation: the subtrees below the changed entities are
//! recomputed on every core of the compute task pool. The one place in the engine crate where
//! `unsafe` is allowed (the crate denies it everywhere else), for one call.
//!
//! **Why `unsafe`.** Several tasks write `GlobalTransform`s through one query at once, each for
//! the entities of its own subtrees. `bevy_ecs` cannot prove from the types that those entity sets
//! are disjoint, so the walk fetches with [`Query::get_unchecked`] and proves it here instead, as
//! Bevy's own `bevy_transform` does. (Bevy's crate could not be taken as it is: it brings its own
//! `Transform` and `GlobalTransform`, and none of our [`Static`](super::Static) entities,
//! [`Joint`](super::Joint)s or [`TransformChanges`](super::TransformChanges) lists.)
//!
//! **Why it is sound.** Every entity is fetched by at most one task, at most once:
//! - The roots are the seeds of [`propagate_transforms`](super::propagate_transforms): changed
//!   entities none of whose ancestors (found by walking `ChildOf` up to a root, cycles and
//!   over-deep chains refused) is changed, each listed once. So no root is the ancestor of
//!   another root.
//! - From a node the walk descends only to the children whose own `ChildOf` names that node. An
//!   entity has one `ChildOf`, so it is reached from one parent only, and by induction from one
//!   root only, once: the subtrees are disjoint trees even if a `Children` list disagreed with
//!   the `ChildOf`s (`bevy_ecs` keeps them in step; the check costs nothing, the link is in the
//!   same fetch).
//! - Nothing else reads or writes the query's components meanwhile: the system holds the query
//!   mutably for the whole walk, and the roots' parents, which the roots' own transforms start
//!   from, were read before the walk began (a root's parent is in no subtree: it would make the
//!   root a descendant of another root).

// The audited exception to the crate's `deny(unsafe_code)`.
#![allow(unsafe_code)]

use bevy_ecs::prelude::*;
use bevy_tasks::TaskPool;
use bevy_utils::Parallel;
use glam::Affine3A;

use super::{GlobalTransform, Node};

/// The per-thread stacks and moved lists of [`walk`], kept between runs so that a warm walk
/// allocates nothing.
#[derive(Default)]
pub(super) struct Walks {
    stacks: Parallel<Vec<(Entity, Affine3A, Option<Entity>)>>,
    moved: Parallel<Vec<Entity>>,
}

/// Recomputes the subtrees below `roots` (each with its parent's global transform) on the tasks
/// of `pool`, and appends the entities whose global transform changed, [`Joint`](super::Joint)s
/// left out, to `moved`.
pub(super) fn walk(roots: &[(Entity, Affine3A)], nodes: &mut Query<Node>, moved: &mut Vec<Entity>, walks: &mut Walks, pool: &TaskPool) {
    if roots.is_empty() {
        return;
    }
    // A few batches a thread, so that uneven subtrees even out.
    let batch = roots.len().div_ceil(pool.thread_num() * 4).max(1);
    let nodes: &Query<Node> = nodes;
    let shared: &Walks = walks;
    pool.scope(|scope| {
        for chunk in roots.chunks(batch) {
            scope.spawn(async move {
                let mut stack = shared.stacks.borrow_local_mut();
                let mut moved = shared.moved.borrow_local_mut();
                for &(root, parent_affine) in chunk {
                    stack.push((root, parent_affine, None));
                    while let Some((entity, parent_affine, parent)) = stack.pop() {
                        // SAFETY: this entity is fetched by this task alone, once (the module
                        // docs): it is a root of this chunk, or a child reached from the one
                        // parent its `ChildOf` names, checked below before its subtree is walked;
                        // the query is held mutably by the calling system for the whole walk.
                        let Ok((transform, mut global, children, joint, child_of)) = (unsafe { nodes.get_unchecked(entity) }) else {
                            continue;
                        };
                        if parent.is_some_and(|parent| child_of.map(ChildOf::parent) != Some(parent)) {
                            continue; // a `Children` entry its `ChildOf` disowns
                        }
                        let affine = parent_affine * transform.compute_affine();
                        if global.set_if_neq(GlobalTransform(affine)) && !joint {
                            moved.push(entity);
                        }
                        if let Some(children) = children {
                            stack.extend(children.iter().map(|child| (child, affine, Some(entity))));
                        }
                    }
                }
            });
        }
    });
    for list in walks.moved.iter_mut() {
        moved.append(list);
    }
}
