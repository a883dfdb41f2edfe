//! Marker components that several game modules read. They live in this leaf module, which
//! depends on no other game module, so that their users need not depend on each other: the
//! raycaster ignores the [`Player`] without depending on the `player` controller, which casts
//! rays through the raycaster.

use bevy_ecs::prelude::*;

/// Marks the entity the player controls (a camera). The raycaster ignores it and its
/// descendants, so the player never stands on, collides with or shoots itself.
#[derive(Component, Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct Player;
