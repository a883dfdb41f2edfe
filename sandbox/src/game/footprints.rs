//! Footprints: while the player walks, a footprint decal every [`GameSettings::stride`] metres,
//! alternating left and right feet.
//!
//! [`lay_footprints`] follows the path in [`PlayerMotion`] (from where the feet were at the
//! start of the frame to where they are now), so prints are spaced exactly one stride apart
//! along the path however long the frame was, and a fast frame may lay several. Each print sits
//! [`GameSettings::foot_offset`] to the side of the walking line on the floor found by a ray
//! cast straight down there (a print over nothing is skipped, but still counts as a step), toe
//! along the walking direction. The texture is a right shoe; the left foot mirrors it with a
//! [`DecalUv::Rect`] whose `min.x` and `max.x` are swapped.
//!
//! Prints carry [`DecalLifetime`] (fading over their last [`GameSettings::footprint_fade`]
//! seconds, despawned after [`GameSettings::footprint_lifetime`]) and [`GameDecal`], so the
//! decal cap also recycles them when the player shoots a lot.

use bevy_ecs::prelude::*;
use engine::scene::Name;
use engine::transform::{GlobalTransform, Transform};
use glam::{Vec2, Vec3};
use plugins::decal::{Decal, DecalLifetime, DecalUv};

use super::decal_cap::{GameDecal, SpawnOrder};
use super::player::{Player, PlayerController, PlayerMotion};
use super::{GAME_DECAL_RECEIVERS, GameAssets, GameSettings, GameStats, surface_rotation};
use plugins::raycast::SceneRaycaster;

/// Which foot a print belongs to.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash, Default)]
pub enum Foot {
    /// The left foot (mirrored texture, to the left of the walking line).
    #[default]
    Left,
    /// The right foot.
    Right,
}

impl Foot {
    /// The other foot.
    pub fn other(self) -> Foot {
        match self {
            Foot::Left => Foot::Right,
            Foot::Right => Foot::Left,
        }
    }

    /// +1 for the right foot, −1 for the left: the side of the walking line the print is on.
    pub fn side(self) -> f32 {
        match self {
            Foot::Left => -1.0,
            Foot::Right => 1.0,
        }
    }

    /// The texture coordinates of this foot's print: the whole right-shoe texture, mirrored
    /// horizontally for the left foot.
    pub fn uv(self) -> DecalUv {
        match self {
            Foot::Right => DecalUv::Rect { min: Vec2::ZERO, max: Vec2::ONE },
            Foot::Left => DecalUv::Rect { min: Vec2::new(1.0, 0.0), max: Vec2::new(0.0, 1.0) },
        }
    }
}

/// A footprint decal, with the foot it belongs to.
#[derive(Component, Clone, Copy, Debug, PartialEq, Eq)]
pub struct Footprint {
    /// The foot.
    pub foot: Foot,
}

/// The player's walking state for footprints.
#[derive(Component, Clone, Copy, Debug, Default, PartialEq)]
pub struct FootprintTrail {
    /// Horizontal distance walked since the last print (or since the player appeared).
    pub since_last: f32,
    /// The foot of the next print.
    pub next: Foot,
}

/// Lays footprints along each player's path this frame (see the module docs).
#[allow(clippy::too_many_arguments)]
pub fn lay_footprints(
    mut commands: Commands,
    settings: Res<GameSettings>,
    assets: Option<Res<GameAssets>>,
    raycaster: Res<SceneRaycaster>,
    mut order: ResMut<SpawnOrder<GameDecal>>,
    mut stats: ResMut<GameStats>,
    mut players: Query<(&PlayerMotion, &PlayerController, &mut FootprintTrail), With<Player>>,
) {
    let Some(assets) = assets else { return };
    let stride = settings.stride;
    if !(stride.is_finite() && stride > 0.0) {
        return;
    }
    for (motion, controller, mut trail) in &mut players {
        let path = (motion.to - motion.from).with_y(0.0);
        let length = path.length();
        if !(length > 1e-6 && length.is_finite()) {
            continue;
        }
        let direction = path / length;
        // Distance along this frame's path to the next print.
        let mut at = stride - trail.since_last;
        while at <= length {
            let centre = motion.from + direction * at;
            // Search from the higher end of the step, so a print on a ledge just climbed is found.
            let search_height = motion.from.y.max(motion.to.y) + controller.max_step;
            let foot = trail.next;
            let side = Vec3::Y.cross(direction) * -foot.side(); // Y × forward points left.
            let position = (centre + side * settings.foot_offset).with_y(search_height);
            if let Some(floor) = raycaster.cast(position, Vec3::NEG_Y, f32::INFINITY).filter(|hit| hit.normal.y > 0.5) {
                let transform = Transform {
                    translation: floor.point,
                    rotation: surface_rotation(floor.normal, direction),
                    scale: Vec3::new(settings.footprint_size, settings.footprint_size, settings.decal_depth),
                };
                let mut decal = Decal::new(assets.footprint);
                decal.uv = foot.uv();
                decal.receivers = GAME_DECAL_RECEIVERS;
                let entity = commands
                    .spawn((
                        decal,
                        transform,
                        GlobalTransform::from(transform),
                        DecalLifetime::new(settings.footprint_lifetime, settings.footprint_fade),
                        Footprint { foot },
                        GameDecal,
                        Name::new("Footprint"),
                    ))
                    .id();
                order.push(entity);
                stats.footprints += 1;
            }
            trail.next = foot.other();
            at += stride;
        }
        trail.since_last = length - (at - stride);
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn feet_alternate_and_mirror() {
        assert_eq!(Foot::Left.other(), Foot::Right);
        assert_eq!(Foot::Right.other().other(), Foot::Right);
        let (DecalUv::Rect { min: l0, max: l1 }, DecalUv::Rect { min: r0, max: r1 }) = (Foot::Left.uv(), Foot::Right.uv()) else {
            panic!("rect UVs expected");
        };
        assert_eq!((l0.x, l1.x), (r1.x, r0.x), "left mirrors right horizontally");
        assert_eq!((l0.y, l1.y), (r0.y, r1.y), "but not vertically");
        // Right of a walk along −Z is +X.
        let side = Vec3::Y.cross(Vec3::NEG_Z) * -Foot::Right.side();
        assert!((side - Vec3::X).length() < 1e-6);
    }
}
