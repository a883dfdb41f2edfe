//! The parallel walk of transform propagation: the subtrees below the changed entities are
//! recomputed on every core of the compute task pool. The one place in the engine crate where
//! `unsafe` is allowed (the crate denies it everywhere else), for two calls: fetching through a
//! shared query, and the processor's prefetch hint.
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
//!   another root. (Whether an ancestor changed is read from marks every changed entity gets
//!   before the seeds are sought; marking one panics rather than skip it.)
//! - From a node the walk descends only to the children whose own `ChildOf` names that node. An
//!   entity has one `ChildOf`, so it is reached from one parent only, and by induction from one
//!   root only, once: the subtrees are disjoint trees even if a `Children` list disagreed with
//!   the `ChildOf`s (`bevy_ecs` keeps them in step; the check costs nothing, the link is in the
//!   same fetch).
//! - Nothing else reads or writes the query's components meanwhile: the system holds the query
//!   mutably for the whole walk, and the roots' parents, which the roots' own transforms start
//!   from, were read before the walk began (a root's parent is in no subtree: it would make the
//!   root a descendant of another root).
//! - A task fetches an entity up to three times (twice only to read addresses to prefetch), and
//!   never holds two of those fetches at once.

// The audited exception to the crate's `deny(unsafe_code)`.
#![allow(unsafe_code)]

use bevy_ecs::prelude::*;
use bevy_tasks::TaskPool;
use bevy_utils::Parallel;
use glam::Affine3A;

use super::{GlobalTransform, Node, Visited};

/// The per-thread frontiers and moved lists of [`walk`], kept between runs so that a warm walk
/// allocates nothing.
#[derive(Default)]
pub(super) struct Walks {
    frontiers: Parallel<(Vec<Visit>, Vec<Visit>)>,
    moved: Parallel<Vec<Entity>>,
}

/// How many subtrees a task walks level by level together. Few: what a level asks the memory
/// for must still be in the cache when the level is computed. (All of a task's batch at once,
/// 2,500 foxes' subtrees on the 2-core machine, asked for megabytes a level and found little of
/// it still cached: the walk of `cargo bench -p engine --bench animation -- propagate/10000`
/// took 10.8–12.1 ms against 6.2–7.6 ms four subtrees at a time, in alternating runs.)
const SUBTREES_AT_ONCE: usize = 4;

/// An entity to visit: its parent's global transform, and the parent it was reached from
/// (`None` for a root).
type Visit = (Entity, Affine3A, Option<Entity>);

/// Recomputes the subtrees below `roots` (each with its parent's global transform) on the tasks
/// of `pool`, and appends the entities whose global transform changed, [`Joint`](super::Joint)s
/// left out, to `moved`.
///
/// **Level by level, loads first.** A crowd's hierarchy does not fit in the cache: walked depth
/// first, nearly every visit waited on memory for the entity's `Transform`, its old
/// `GlobalTransform` and its `Children`, one after the other (`perf` on `cargo bench -p engine
/// --bench animation`: most of the walk's time on those three loads). So a task walks its batch
/// of subtrees one level at a time: it first asks the memory for everything the whole level will
/// read (a prefetch per component, no waiting: the components as each entity is found, then the
/// children's lists behind them), then computes the level, whose loads now hit the cache; a few
/// subtrees at a time ([`SUBTREES_AT_ONCE`]), so that what was asked for is still cached. The
/// same entities get the same transforms; only the order they are visited in (and listed in
/// `moved`) differs from the depth-first reference.
pub(super) fn walk(
    roots: &[(Entity, Affine3A)],
    nodes: &mut Query<Node, Visited>,
    moved: &mut Vec<Entity>,
    walks: &mut Walks,
    pool: &TaskPool,
) {
    if roots.is_empty() {
        return;
    }
    // A few batches a thread, so that uneven subtrees even out.
    let batch = roots.len().div_ceil(pool.thread_num() * 4).max(1);
    let nodes: &Query<Node, Visited> = nodes;
    let shared: &Walks = walks;
    pool.scope(|scope| {
        for chunk in roots.chunks(batch) {
            scope.spawn(async move {
                let mut frontiers = shared.frontiers.borrow_local_mut();
                let (level, next) = &mut *frontiers;
                let mut moved = shared.moved.borrow_local_mut();
                for few in chunk.chunks(SUBTREES_AT_ONCE) {
                    level.clear();
                    level.extend(few.iter().map(|&(root, parent_affine)| (root, parent_affine, None)));
                    for &(root, ..) in level.iter() {
                        ask(nodes, root);
                    }
                    while !level.is_empty() {
                        // The children's lists live on the heap, behind the `Children` asked for.
                        for &(entity, ..) in level.iter() {
                            // SAFETY: as below; this fetch only reads an address, and is dropped
                            // before the entity is fetched again.
                            if let Ok((_, _, Some(children), ..)) = unsafe { nodes.get_unchecked(entity) } {
                                prefetch_opt(children.first());
                            }
                        }
                        next.clear();
                        for &(entity, parent_affine, parent) in level.iter() {
                            // SAFETY: this entity is fetched by this task alone, once at a time (the
                            // module docs): it is a root of this chunk, or a child reached from the one
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
                                for child in children.iter() {
                                    ask(nodes, child);
                                    next.push((child, affine, Some(entity)));
                                }
                            }
                        }
                        std::mem::swap(level, next);
                    }
                }
            });
        }
    });
    for list in walks.moved.iter_mut() {
        moved.append(list);
    }
}

/// Asks the memory for what visiting `entity` reads (its transforms and its `Children`), without
/// waiting for it.
#[inline(always)]
fn ask(nodes: &Query<Node, Visited>, entity: Entity) {
    // SAFETY: the fetch only reads addresses and is dropped at once; the entity is fetched by
    // this task alone (see `walk`), and no other fetch of it by this task is alive meanwhile.
    if let Ok((transform, global, children, ..)) = unsafe { nodes.get_unchecked(entity) } {
        prefetch(transform);
        prefetch(&*global);
        prefetch_opt(children);
    }
}

/// Asks the memory for the cache line of `value` without waiting for it (a no-op where the
/// target has no prefetch instruction).
#[inline(always)]
fn prefetch<T>(value: &T) {
    #[cfg(target_arch = "x86_64")]
    // SAFETY: a prefetch is a hint: it never faults and changes no memory, whatever the address.
    unsafe {
        std::arch::x86_64::_mm_prefetch::<{ std::arch::x86_64::_MM_HINT_T0 }>((value as *const T).cast());
    }
    #[cfg(not(target_arch = "x86_64"))]
    let _ = value;
}

/// [`prefetch`] of an optional value.
#[inline(always)]
fn prefetch_opt<T>(value: Option<&T>) {
    if let Some(value) = value {
        prefetch(value);
    }
}
