//! The first-person controller: the player is a camera entity with [`Player`],
//! [`PlayerController`] and [`PlayerMotion`].
//!
//! Each frame [`move_player`] turns the view by the mouse motion in [`Input`], walks along the
//! horizontal direction of the held WASD keys (Shift sprints) and keeps the eye
//! [`PlayerController::eye_height`] above the floor. There is no gravity or velocity: the
//! controller is kinematic and resolves everything with ray casts against the
//! [`SceneRaycaster`] ([`PlayerController::walk`]):
//!
//! * **walls**: before moving, rays at knee, waist and eye height (from the body's centre line
//!   and from either side of it) look along the move; the player stops
//!   [`PlayerController::radius`] short of the nearest wall and slides along it with the rest of
//!   the move. Afterwards, rays in eight directions push the player back out to `radius` from
//!   any wall it still touches (corners);
//! * **floors**: a ray straight down from [`PlayerController::max_step`] above the feet finds
//!   the floor, so the player steps up ledges up to `max_step` high and down any drop. A move
//!   that would leave the player over nothing (or over ground steeper than 60°) is refused.
//!
//! The player's `Transform` is in world space: [`super::setup_game`] detaches the camera from
//! any parent.

use bevy_ecs::prelude::*;
use engine::input::{Input, Key};
use engine::time::Time;
use engine::transform::Transform;
use glam::{EulerRot, Quat, Vec3};

use plugins::raycast::{Hit, SceneRaycaster};

pub use super::markers::Player;

/// Largest pitch up or down, short of straight up/down so that yaw stays meaningful.
pub const MAX_PITCH: f32 = 89f32.to_radians();

/// Rays hitting surfaces whose normal is steeper than this (|n.y| above it) are floors or
/// ceilings, not walls; floors flatter than this (n.y below it) are too steep to stand on.
const WALKABLE_NORMAL_Y: f32 = 0.5;

/// How the player looks and moves.
#[derive(Component, Clone, Copy, Debug, PartialEq)]
pub struct PlayerController {
    /// Heading in radians, counter-clockwise seen from above; 0 looks along −Z.
    pub yaw: f32,
    /// Elevation in radians, positive up, within ±[`MAX_PITCH`].
    pub pitch: f32,
    /// Walking speed in metres per second.
    pub speed: f32,
    /// Speed multiplier while Shift is held.
    pub sprint_factor: f32,
    /// Height of the eye (the camera) above the floor, in metres.
    pub eye_height: f32,
    /// The body's radius: how close the eye's vertical line comes to walls, in metres.
    pub radius: f32,
    /// Highest ledge the player steps up onto, in metres.
    pub max_step: f32,
    /// Radians of turn per pixel of mouse motion.
    pub mouse_sensitivity: f32,
}

impl Default for PlayerController {
    fn default() -> Self {
        Self {
            yaw: 0.0,
            pitch: 0.0,
            speed: 3.0,
            sprint_factor: 2.0,
            eye_height: 1.7,
            radius: 0.3,
            max_step: 0.4,
            mouse_sensitivity: 0.0025,
        }
    }
}

/// What the player did this frame, written by [`move_player`].
#[derive(Component, Clone, Copy, Debug, Default, PartialEq)]
pub struct PlayerMotion {
    /// Where the feet were at the start of the frame.
    pub from: Vec3,
    /// Where the feet are now (on the floor when there is one).
    pub to: Vec3,
    /// The floor under the feet, if any.
    pub floor: Option<Hit>,
    /// Whether a wall or a missing floor cut this frame's move short.
    pub blocked: bool,
}

impl PlayerMotion {
    /// A player standing still at `feet`.
    pub fn standing(feet: Vec3, floor: Option<Hit>) -> Self {
        Self { from: feet, to: feet, floor, blocked: false }
    }

    /// The horizontal distance walked this frame.
    pub fn distance(&self) -> f32 {
        (self.to - self.from).with_y(0.0).length()
    }
}

/// The outcome of [`PlayerController::walk`].
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Step {
    /// The new eye position.
    pub eye: Vec3,
    /// The new feet position (`eye` minus the eye height).
    pub feet: Vec3,
    /// The floor under the feet, if any (the height is kept where there is none).
    pub floor: Option<Hit>,
    /// Whether a wall or a missing floor cut the move short.
    pub blocked: bool,
}

impl PlayerController {
    /// A default controller looking along `forward` (yaw and pitch from its direction; a zero
    /// or non-finite direction looks along −Z).
    pub fn looking_along(forward: Vec3) -> Self {
        let forward = forward.try_normalize().unwrap_or(Vec3::NEG_Z);
        Self {
            yaw: (-forward.x).atan2(-forward.z),
            pitch: forward.y.clamp(-1.0, 1.0).asin().clamp(-MAX_PITCH, MAX_PITCH),
            ..Default::default()
        }
    }

    /// The camera rotation for the current yaw and pitch (no roll).
    pub fn rotation(&self) -> Quat {
        Quat::from_euler(EulerRot::YXZ, self.yaw, self.pitch, 0.0)
    }

    /// The horizontal unit vector the player faces.
    pub fn forward_flat(&self) -> Vec3 {
        Vec3::new(-self.yaw.sin(), 0.0, -self.yaw.cos())
    }

    /// The horizontal unit vector to the player's right.
    pub fn right_flat(&self) -> Vec3 {
        Vec3::new(self.yaw.cos(), 0.0, -self.yaw.sin())
    }

    /// Turns the view by `motion` pixels of mouse motion (+X right turns right, +Y down looks
    /// down); pitch is clamped to ±[`MAX_PITCH`], yaw wrapped to (−π, π].
    pub fn look(&mut self, motion: glam::Vec2) {
        if !motion.is_finite() {
            return;
        }
        let yaw = self.yaw - motion.x * self.mouse_sensitivity;
        self.yaw = (yaw + std::f32::consts::PI).rem_euclid(std::f32::consts::TAU) - std::f32::consts::PI;
        self.pitch = (self.pitch - motion.y * self.mouse_sensitivity).clamp(-MAX_PITCH, MAX_PITCH);
    }

    /// The horizontal unit direction of the held movement keys (zero when none or opposing).
    pub fn wish_direction(&self, input: &Input) -> Vec3 {
        let axis = |positive: Key, negative: Key| input.pressed(positive) as i32 as f32 - input.pressed(negative) as i32 as f32;
        (self.forward_flat() * axis(Key::W, Key::S) + self.right_flat() * axis(Key::D, Key::A)).normalize_or_zero()
    }

    /// Moves the player whose eye is at `eye` by the horizontal displacement `displacement`
    /// (its vertical part is ignored), sliding along walls and following the floor as the
    /// module docs describe. A zero displacement just settles the eye on the floor. A
    /// non-finite `eye` stays where it is (blocked).
    pub fn walk(&self, raycaster: &SceneRaycaster, eye: Vec3, displacement: Vec3) -> Step {
        let start_feet = eye - Vec3::Y * self.eye_height;
        if !eye.is_finite() {
            return Step { eye, feet: start_feet, floor: None, blocked: true };
        }
        let mut feet = start_feet;
        let mut remaining = displacement.with_y(0.0);
        if !remaining.is_finite() {
            remaining = Vec3::ZERO;
        }
        let mut blocked = false;
        // Three passes: a move into a corner slides along one wall, then stops at the other.
        for _ in 0..3 {
            let length = remaining.length();
            if length < 1e-6 {
                break;
            }
            let direction = remaining / length;
            match self.wall_ahead(raycaster, feet, direction, length) {
                Some((allowed, normal)) if allowed < length => {
                    blocked = true;
                    let advance = allowed.max(0.0);
                    feet += direction * advance;
                    let rest = remaining - direction * advance;
                    // Keep the part of the move along the wall.
                    remaining = rest - normal * rest.dot(normal);
                }
                _ => {
                    feet += remaining;
                    break;
                }
            }
        }
        feet = self.push_out_of_walls(raycaster, feet);

        let (feet, floor) = match self.floor_below(raycaster, feet) {
            Some(floor) => (feet.with_y(floor.point.y), Some(floor)),
            None if feet != start_feet => {
                // Nothing to stand on there: stay where we were.
                blocked = true;
                let floor = self.floor_below(raycaster, start_feet);
                (floor.map_or(start_feet, |f| start_feet.with_y(f.point.y)), floor)
            }
            None => (feet, None),
        };
        Step { eye: feet + Vec3::Y * self.eye_height, feet, floor, blocked }
    }

    /// Heights above the feet at which walls are probed: just above a step, the waist, and
    /// just below the eye.
    fn probe_heights(&self) -> [f32; 3] {
        let knee = self.max_step + 0.05;
        let top = (self.eye_height - 0.05).max(knee);
        [knee, 0.5 * (knee + top), top]
    }

    /// The most restrictive wall in the way of a move of `length` along `direction`: how far
    /// the body may go before its centre line comes within `radius` of the wall's plane, and
    /// the wall's horizontal normal. Probes with horizontal rays from the centre line and both
    /// sides of the body at the probe heights; walls met at grazing angles beyond the probes'
    /// reach are left to [`Self::push_out_of_walls`].
    fn wall_ahead(&self, raycaster: &SceneRaycaster, feet: Vec3, direction: Vec3, length: f32) -> Option<(f32, Vec3)> {
        let side = Vec3::Y.cross(direction).normalize_or_zero() * (0.7 * self.radius);
        let reach = length + 4.0 * self.radius;
        let mut nearest: Option<(f32, Vec3)> = None;
        for height in self.probe_heights() {
            let centre = feet + Vec3::Y * height;
            for offset in [Vec3::ZERO, side, -side] {
                let Some(hit) = raycaster.cast(centre + offset, direction, reach) else {
                    continue;
                };
                let normal = hit.normal.with_y(0.0).normalize_or_zero();
                let approach = direction.dot(-normal);
                if !is_wall(&hit) || approach < 1e-3 {
                    continue;
                }
                let distance = (centre - hit.point).dot(normal);
                let allowed = (distance - self.radius) / approach;
                if nearest.is_none_or(|(a, _)| allowed < a) {
                    nearest = Some((allowed, normal));
                }
            }
        }
        nearest
    }

    /// Moves `feet` horizontally out to `radius` from every wall within reach (two passes over
    /// eight directions, for corners).
    fn push_out_of_walls(&self, raycaster: &SceneRaycaster, mut feet: Vec3) -> Vec3 {
        for _ in 0..2 {
            let mut push = Vec3::ZERO;
            for k in 0..8 {
                let angle = k as f32 * std::f32::consts::FRAC_PI_4;
                let direction = Vec3::new(angle.cos(), 0.0, angle.sin());
                for height in self.probe_heights() {
                    let origin = feet + Vec3::Y * height;
                    let Some(hit) = raycaster.cast(origin, direction, self.radius) else {
                        continue;
                    };
                    if is_wall(&hit) {
                        let normal = hit.normal.with_y(0.0).normalize_or_zero();
                        // Out along the wall's normal by what is missing to `radius` from its plane.
                        let depth = self.radius - (origin - hit.point).dot(normal);
                        if depth > push.dot(normal) {
                            push += normal * (depth - push.dot(normal));
                        }
                    }
                }
            }
            if push == Vec3::ZERO {
                break;
            }
            feet += push;
        }
        feet
    }

    /// The walkable floor under `feet`, searched from `max_step` above them downwards.
    fn floor_below(&self, raycaster: &SceneRaycaster, feet: Vec3) -> Option<Hit> {
        let origin = feet + Vec3::Y * (self.max_step + 0.01);
        raycaster.cast(origin, Vec3::NEG_Y, f32::INFINITY).filter(|hit| hit.normal.y >= WALKABLE_NORMAL_Y)
    }
}

/// Whether a horizontal probe's hit is a wall (not a floor or ceiling it grazed).
fn is_wall(hit: &Hit) -> bool {
    hit.normal.y.abs() < WALKABLE_NORMAL_Y
}

/// Moves every [`Player`] by [`Input`]: mouse look, WASD walking (Shift sprints) with floor
/// following and wall sliding ([`PlayerController::walk`]); records the move in
/// [`PlayerMotion`]. The transform is written only when it changes.
pub fn move_player(
    time: Res<Time>,
    input: Res<Input>,
    raycaster: Res<SceneRaycaster>,
    mut players: Query<(&mut Transform, &mut PlayerController, &mut PlayerMotion), With<Player>>,
) {
    let dt = time.delta_secs();
    for (mut transform, mut controller, mut motion) in &mut players {
        if input.mouse_motion != glam::Vec2::ZERO {
            controller.look(input.mouse_motion);
        }
        let speed = controller.speed * if input.pressed(Key::Shift) { controller.sprint_factor } else { 1.0 };
        let displacement = controller.wish_direction(&input) * speed * dt;
        let step = controller.walk(&raycaster, transform.translation, displacement);
        *motion = PlayerMotion {
            from: transform.translation - Vec3::Y * controller.eye_height,
            to: step.feet,
            floor: step.floor,
            blocked: step.blocked,
        };
        let rotation = controller.rotation();
        transform.set_if_neq(Transform { translation: step.eye, rotation, scale: Vec3::ONE });
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use bevy_ecs::entity::Entity;
    use engine::mesh::{Mesh, shapes};
    use glam::{Affine3A, Vec2};

    /// A 20 m floor at y = 0, a 0.3 m step at z < −3, and a wall (plane facing +X) at x = 2.
    fn room() -> SceneRaycaster {
        let floor = shapes::plane(20.0, 20.0, 1, 1.0);
        let step = shapes::cuboid(Vec3::new(4.0, 0.3, 4.0), 1.0);
        let wall: Mesh = shapes::cuboid(Vec3::new(0.2, 4.0, 20.0), 1.0);
        SceneRaycaster::from_meshes([
            (Entity::from_raw_u32(1).unwrap(), &floor, Affine3A::IDENTITY),
            (Entity::from_raw_u32(2).unwrap(), &step, Affine3A::from_translation(Vec3::new(0.0, 0.15, -5.0))),
            (Entity::from_raw_u32(3).unwrap(), &wall, Affine3A::from_translation(Vec3::new(2.1, 2.0, 0.0))),
        ])
    }

    #[test]
    fn look_directions_agree_with_the_rotation() {
        let mut controller = PlayerController::looking_along(Vec3::new(1.0, 0.5, -1.0));
        let forward = controller.rotation() * Vec3::NEG_Z;
        assert!((forward - Vec3::new(1.0, 0.5, -1.0).normalize()).length() < 1e-5);
        assert!((controller.forward_flat() - Vec3::new(1.0, 0.0, -1.0).normalize()).length() < 1e-5);
        assert!((controller.rotation() * Vec3::X - controller.right_flat()).length() < 1e-5);
        // Mouse right turns right (clockwise from above), mouse down looks down, pitch clamps.
        let before = controller.forward_flat();
        controller.look(Vec2::new(10.0, 0.0));
        assert!(before.cross(controller.forward_flat()).y < 0.0);
        controller.look(Vec2::new(0.0, 1e6));
        assert!((controller.pitch + MAX_PITCH).abs() < 1e-6);
        controller.look(Vec2::NAN);
        assert!(controller.yaw.is_finite());
    }

    #[test]
    fn follows_the_floor_and_steps_up() {
        let room = room();
        let controller = PlayerController::default();
        let step = controller.walk(&room, Vec3::new(0.0, 5.0, 0.0), Vec3::ZERO);
        assert!((step.eye.y - 1.7).abs() < 1e-5, "settles onto the floor: {step:?}");
        // Walk onto the 0.3 m step.
        let mut eye = step.eye;
        for _ in 0..40 {
            eye = controller.walk(&room, eye, Vec3::new(0.0, 0.0, -0.1)).eye;
        }
        assert!((eye.z + 4.0).abs() < 1e-4 && (eye.y - 2.0).abs() < 1e-5, "{eye}");
    }

    #[test]
    fn stops_at_walls_and_slides_along_them() {
        let room = room();
        let controller = PlayerController::default();
        let mut eye = Vec3::new(0.0, 1.7, 2.0);
        for _ in 0..30 {
            let step = controller.walk(&room, eye, Vec3::new(0.1, 0.0, 0.05));
            eye = step.eye;
        }
        // The wall's face is at x = 2.0: stopped one radius short, still sliding along +Z.
        assert!((eye.x - (2.0 - controller.radius)).abs() < 1e-3, "{eye}");
        assert!((eye.z - 3.5).abs() < 1e-3, "{eye}");
    }

    #[test]
    fn refuses_to_walk_off_the_world() {
        let room = room();
        let controller = PlayerController::default();
        let eye = Vec3::new(-9.95, 1.7, 0.0);
        let step = controller.walk(&room, eye, Vec3::new(-0.2, 0.0, 0.0));
        assert!(step.blocked);
        assert_eq!(step.eye, eye);
        let lost = controller.walk(&room, Vec3::NAN, Vec3::X);
        assert!(lost.blocked && lost.floor.is_none());
        let stuck = controller.walk(&room, eye, Vec3::new(f32::INFINITY, 0.0, 0.0));
        assert_eq!(stuck.eye, eye, "a non-finite move is no move");
    }
}
