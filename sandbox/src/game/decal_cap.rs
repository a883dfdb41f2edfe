//! Caps on what gameplay spawns: at most [`DecalCap::max`] live game decals and
//! [`LightCap::max`] dropped lights, recycling the oldest first.
//!
//! Every entity with the [`GameDecal`] marker (bullet holes, footprints, and any decal a game
//! tags with it) is queued in spawn order in [`SpawnOrder<GameDecal>`]; when more are alive
//! than the cap, [`enforce_decal_cap`] despawns from the front of the queue. Entities that die
//! on their own (a footprint's lifetime ends) leave the queue. [`GameLight`] works the same way
//! with [`LightCap`].
//!
//! The game's own spawners push their entities into the queue as they spawn them, which fixes
//! the order exactly. Entities tagged elsewhere are picked up by the cap system the frame they
//! appear (in the order the ECS lists them, which is spawn order within one archetype).
//!
//! The renderer keeps every decal in a GPU slot that a despawned decal frees and the next spawn
//! reuses, so with the cap in place the decal buffer and BLAS stop growing at the cap: recycling
//! costs record rewrites and refits, not reallocations.

use std::collections::{HashSet, VecDeque};
use std::marker::PhantomData;

use bevy_ecs::prelude::*;

use super::GameStats;

/// Marks a decal spawned by gameplay and counted against [`DecalCap`].
#[derive(Component, Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct GameDecal;

/// Marks a light dropped by gameplay and counted against [`LightCap`].
#[derive(Component, Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct GameLight;

/// The most [`GameDecal`]s alive at once.
#[derive(Resource, Clone, Copy, Debug, PartialEq, Eq)]
pub struct DecalCap {
    /// The cap; 0 despawns every game decal at the end of the frame it appears.
    pub max: usize,
}

impl Default for DecalCap {
    fn default() -> Self {
        Self { max: 256 }
    }
}

/// The most [`GameLight`]s alive at once.
#[derive(Resource, Clone, Copy, Debug, PartialEq, Eq)]
pub struct LightCap {
    /// The cap.
    pub max: usize,
}

impl Default for LightCap {
    fn default() -> Self {
        Self { max: 8 }
    }
}

/// The live entities marked `M`, oldest first.
#[derive(Resource)]
pub struct SpawnOrder<M> {
    queue: VecDeque<Entity>,
    queued: HashSet<Entity>,
    _marker: PhantomData<fn() -> M>,
}

impl<M> Default for SpawnOrder<M> {
    fn default() -> Self {
        Self { queue: VecDeque::new(), queued: HashSet::new(), _marker: PhantomData }
    }
}

impl<M> SpawnOrder<M> {
    /// Appends a newly spawned entity (ignored if already queued).
    pub fn push(&mut self, entity: Entity) {
        if self.queued.insert(entity) {
            self.queue.push_back(entity);
        }
    }

    /// The queued entities, oldest first.
    pub fn iter(&self) -> impl ExactSizeIterator<Item = Entity> + '_ {
        self.queue.iter().copied()
    }

    /// Number of queued entities.
    pub fn len(&self) -> usize {
        self.queue.len()
    }

    /// Whether nothing is queued.
    pub fn is_empty(&self) -> bool {
        self.queue.is_empty()
    }

    /// Drops entities that no longer exist (or lost the marker).
    fn forget(&mut self, gone: &HashSet<Entity>) {
        if gone.is_empty() {
            return;
        }
        self.queue.retain(|e| !gone.contains(e));
        self.queued.retain(|e| !gone.contains(e));
    }

    /// Removes and returns the oldest entity.
    fn pop_oldest(&mut self) -> Option<Entity> {
        let entity = self.queue.pop_front()?;
        self.queued.remove(&entity);
        Some(entity)
    }
}

/// Brings `order` up to date (new entities in, vanished ones out) and despawns the oldest live
/// ones beyond `max`; returns how many it despawned.
fn recycle_oldest<M: Component>(
    commands: &mut Commands,
    order: &mut SpawnOrder<M>,
    max: usize,
    added: &Query<Entity, Added<M>>,
    live: &Query<(), With<M>>,
    removed: &mut RemovedComponents<M>,
) -> u64 {
    let gone: HashSet<Entity> = removed.read().filter(|&e| !live.contains(e)).collect();
    order.forget(&gone);
    for entity in added {
        order.push(entity);
    }
    let mut recycled = 0;
    while order.len() > max {
        let Some(oldest) = order.pop_oldest() else {
            break;
        };
        // An entry despawned this frame by someone else frees its place without our help.
        if live.contains(oldest) {
            commands.entity(oldest).try_despawn();
            recycled += 1;
        }
    }
    recycled
}

/// Keeps at most [`DecalCap::max`] [`GameDecal`]s alive, despawning the oldest first.
pub fn enforce_decal_cap(
    mut commands: Commands,
    cap: Res<DecalCap>,
    mut order: ResMut<SpawnOrder<GameDecal>>,
    added: Query<Entity, Added<GameDecal>>,
    live: Query<(), With<GameDecal>>,
    mut removed: RemovedComponents<GameDecal>,
    mut stats: ResMut<GameStats>,
) {
    stats.decals_recycled += recycle_oldest(&mut commands, &mut order, cap.max, &added, &live, &mut removed);
}

/// Keeps at most [`LightCap::max`] [`GameLight`]s alive, despawning the oldest first.
pub fn enforce_light_cap(
    mut commands: Commands,
    cap: Res<LightCap>,
    mut order: ResMut<SpawnOrder<GameLight>>,
    added: Query<Entity, Added<GameLight>>,
    live: Query<(), With<GameLight>>,
    mut removed: RemovedComponents<GameLight>,
    mut stats: ResMut<GameStats>,
) {
    stats.lights_recycled += recycle_oldest(&mut commands, &mut order, cap.max, &added, &live, &mut removed);
}

#[cfg(test)]
mod tests {
    use super::*;
    use engine::app::{App, Update};

    fn app(max: usize) -> App {
        let mut app = App::new();
        app.insert_resource(DecalCap { max })
            .insert_resource(GameStats::default())
            .insert_resource(SpawnOrder::<GameDecal>::default())
            .add_systems(Update, enforce_decal_cap);
        app
    }

    #[test]
    fn oldest_go_first() {
        let mut app = app(3);
        let first: Vec<Entity> = (0..3).map(|_| app.world.spawn(GameDecal).id()).collect();
        app.update();
        assert_eq!(app.world.resource::<SpawnOrder<GameDecal>>().iter().collect::<Vec<_>>(), first);
        let newer: Vec<Entity> = (0..2).map(|_| app.world.spawn(GameDecal).id()).collect();
        app.update();
        assert!(app.world.get_entity(first[0]).is_err() && app.world.get_entity(first[1]).is_err());
        let expected = [first[2], newer[0], newer[1]];
        assert_eq!(app.world.resource::<SpawnOrder<GameDecal>>().iter().collect::<Vec<_>>(), expected);
        assert_eq!(app.world.resource::<GameStats>().decals_recycled, 2);
    }

    #[test]
    fn entities_that_die_on_their_own_leave_the_queue() {
        let mut app = app(2);
        let a = app.world.spawn(GameDecal).id();
        let b = app.world.spawn(GameDecal).id();
        app.update();
        app.world.despawn(a);
        let c = app.world.spawn(GameDecal).id();
        app.update();
        // `a` died by itself: `b` and `c` fit under the cap, nothing was recycled.
        assert!(app.world.get_entity(b).is_ok() && app.world.get_entity(c).is_ok());
        assert_eq!(app.world.resource::<SpawnOrder<GameDecal>>().iter().collect::<Vec<_>>(), [b, c]);
        assert_eq!(app.world.resource::<GameStats>().decals_recycled, 0);
        // Losing the marker counts as leaving too.
        app.world.entity_mut(b).remove::<GameDecal>();
        app.update();
        assert_eq!(app.world.resource::<SpawnOrder<GameDecal>>().iter().collect::<Vec<_>>(), [c]);
    }
}
