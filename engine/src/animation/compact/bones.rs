//! Writing a compact skeleton's bones back to their entities, from the tasks that pose the skins
//! in parallel. The third module of the engine crate allowed `unsafe` (the crate denies it
//! everywhere else), for one call: fetching a bone mutably through a shared query.
//!
//! **Why `unsafe`.** The skins are posed by several tasks at once ([`Query::par_iter_mut`] over
//! the skins), and each writes its own bones' `Transform` and `GlobalTransform` as it composes
//! them. The bones are other entities than the skins, fetched by id, so `bevy_ecs` cannot prove
//! that two tasks never fetch the same bone; [`Query::get_unchecked`] is the call that lets the
//! caller prove it instead (as `transform::parallel` does for propagation's subtrees).
//!
//! **Why it is sound.** A bone is fetched mutably only by the task that poses its owner, once at
//! a time:
//! - [`BoneWriter::write`] fetches a bone only after reading, through a read-only query, that its
//!   [`PosedInSkin`] mark names the skin being posed. An entity has one such mark, so it names one
//!   skin; and the marks are not changed while the system runs (they are inserted and removed by
//!   commands and hooks, outside it).
//! - Each skin is posed by one task, once a frame: the skins are the items of one
//!   `par_iter_mut`.
//! - A fetch lives within one call of [`BoneWriter::place`] or [`BoneWriter::place_world`],
//!   which call nothing that could reach the writer again, so a task never holds two fetches of
//!   one bone, even if a `Skin` listed that bone twice.
//! - Nothing else reads or writes the bones' transforms meanwhile: the writer's query is held by
//!   the calling system for the whole pass, and the system's other queries of `Transform` and
//!   `GlobalTransform` filter the marked entities out (`Without<PosedInSkin>`).

// The audited exception to the crate's `deny(unsafe_code)`.
#![allow(unsafe_code)]

use bevy_ecs::prelude::*;
use glam::Affine3A;

use crate::transform::{GlobalTransform, PosedInSkin, Transform};

/// The bones of compact skeletons, as their entities' transforms.
pub(crate) type BoneTransforms<'w, 's> = Query<'w, 's, (&'static mut Transform, &'static mut GlobalTransform), With<PosedInSkin>>;

/// Writes bones' transforms from the tasks that pose their skins (the module docs say why that
/// is sound). Copied into each task: it is two references.
#[derive(Clone, Copy)]
pub(crate) struct BoneWriter<'q, 'w, 's, 'ow, 'os> {
    bones: &'q BoneTransforms<'w, 's>,
    owners: &'q Query<'ow, 'os, &'static PosedInSkin>,
}

impl<'q, 'w, 's, 'ow, 'os> BoneWriter<'q, 'w, 's, 'ow, 'os> {
    /// A writer through `bones`, which the caller holds mutably (so no other fetch of them is
    /// alive), checking ownership through `owners`.
    pub(crate) fn new(bones: &'q mut BoneTransforms<'w, 's>, owners: &'q Query<'ow, 'os, &'static PosedInSkin>) -> Self {
        BoneWriter { bones, owners }
    }

    /// Places `bone`, if it is marked as posed by `skin`: its `Transform` becomes `local`
    /// (without a change flag) and its `GlobalTransform` `mesh_world × parent × local` (flagged
    /// only if it changed). With `watch`, a `Transform` the game wrote since the calling system
    /// last ran is kept and poses the bone instead. Returns the local transform and the
    /// transform in the mesh's space the bone was placed with, or `None` for a bone another skin
    /// owns (or gone).
    #[inline(always)]
    pub(crate) fn place(
        &self,
        skin: Entity,
        bone: Entity,
        watch: bool,
        local: Transform,
        parent: Affine3A,
        mesh_world: Affine3A,
    ) -> Option<(Transform, Affine3A)> {
        if self.owners.get(bone).ok()? != &PosedInSkin(skin) {
            return None;
        }
        // SAFETY: `bone` is marked as posed by `skin`, and only the one task posing `skin` this
        // frame gets here for it; the fetch is dropped before this call returns and nothing
        // here can call the writer again; the writer's query is held mutably by the calling
        // system, whose other transform queries leave the marked entities out (the module docs).
        let (mut transform, mut world) = unsafe { self.bones.get_unchecked(bone) }.ok()?;
        let local = if watch && transform.is_changed() && !transform.is_added() {
            *transform
        } else {
            if *transform != local {
                *transform.bypass_change_detection() = local;
            }
            local
        };
        let global = parent * local.compute_affine();
        world.set_if_neq(GlobalTransform(mesh_world * global));
        Some((local, global))
    }

    /// Sets `bone`'s `GlobalTransform` to `world` (flagged only if it changed), if it is marked
    /// as posed by `skin`.
    #[inline(always)]
    pub(crate) fn place_world(&self, skin: Entity, bone: Entity, world: Affine3A) {
        if self.owners.get(bone).ok() != Some(&PosedInSkin(skin)) {
            return;
        }
        // SAFETY: as in `place`.
        if let Ok((_, mut global)) = unsafe { self.bones.get_unchecked(bone) } {
            global.set_if_neq(GlobalTransform(world));
        }
    }
}
