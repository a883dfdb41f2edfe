//! The animation update budget: characters small on screen, or off it, sample their clips every
//! second or fourth frame instead of every frame, staggered so that each frame samples an even
//! share of the crowd. Not a technique of the seeds: it is the update rate optimisation of
//! production engines (Unreal Engine's skeletal-mesh "URO" and its animation budget allocator),
//! chosen here because everything after sampling is already driven by change detection. A
//! player that is not sampled writes no `Transform`, so transform propagation, the skin
//! matrices, the pose extraction and upload, GPU skinning and the BLAS refits all skip its
//! model that frame: the whole crowd's cost, CPU and GPU, follows the poses that changed.
//!
//! **The rule.** A model's size on screen is the radius in pixels of its [`AnimatedRadius`]
//! sphere around its root, seen by the active camera in a viewport of
//! [`AnimationBudget::viewport`]. At [`AnimationBudget::full_rate_px`] or more it samples every
//! frame; below, every 2ⁿ-th frame, the smallest period whose product with its radius reaches
//! `full_rate_px`, up to [`AnimationBudget::max_period`]; a model outside the view (its shadow
//! may still be on screen) samples at `max_period`. A player's clock always advances, so a
//! sampled pose is the pose of the current time: **a pose is at most `period − 1` frames old**
//! (3 frames, 50 ms at 60 Hz, with the defaults, and only below 16 pixels or off screen). The
//! sizes are measured from the models' and the camera's global transforms of the frame before
//! (animation runs before propagation). Players without an [`AnimatedRadius`], or with the
//! budget off (the default), sample every frame.

use bevy_ecs::prelude::*;
use glam::{Affine3A, Vec2, Vec3};

use crate::camera::Camera;
use crate::transform::GlobalTransform;

/// The radius, in metres in its root's space, of a sphere about an animated model's root that
/// holds the model in its rest pose: what [`AnimationBudget`] measures the model's size on
/// screen by. The glTF spawner sets it on the root of every model with clips.
#[derive(Component, Clone, Copy, Debug, PartialEq)]
pub struct AnimatedRadius(pub f32);

/// How often models sample their clips by their size on screen (the module docs say the rule).
/// A resource of the [`AnimationPlugin`](super::AnimationPlugin); off by default.
#[derive(Resource, Clone, Copy, Debug, PartialEq)]
pub struct AnimationBudget {
    /// Whether small and off-screen models sample less often than every frame.
    pub enabled: bool,
    /// The radius on screen, in pixels, from which a model samples every frame.
    pub full_rate_px: f32,
    /// The longest period in frames: 1, 2, 4 or 8 (other values are taken as the next of those,
    /// 8 at most: the renderer skins a pose whole once it has been still for 8 frames, so a
    /// longer period would pay for every vertex each time; 1 turns the budget off). Off-screen
    /// models use it.
    pub max_period: u8,
    /// The viewport the active camera draws, in pixels (the render plugin keeps it in step with
    /// the render size).
    pub viewport: Vec2,
}

impl Default for AnimationBudget {
    fn default() -> Self {
        Self { enabled: false, full_rate_px: 32.0, max_period: 4, viewport: Vec2::new(1280.0, 720.0) }
    }
}

/// The active camera as [`AnimationBudget`] sees it: where it is and how large a metre looks.
#[derive(Clone, Copy, Debug)]
pub(super) struct BudgetView {
    /// World to view space.
    view: Affine3A,
    /// Pixels per metre at a distance of one metre (half the viewport height over `tan(fov / 2)`).
    px_per_metre: f32,
    /// The side planes' normals in view space (left, right, bottom, top; a point is inside when
    /// its dot product with each is at most 0).
    planes: [Vec3; 4],
    full_rate_px: f32,
    max_period: u8,
}

impl AnimationBudget {
    /// What the players are measured against this frame, or `None` when every player samples
    /// every frame (the budget off, no active camera, or a degenerate one).
    pub(super) fn view<'a>(&self, cameras: impl IntoIterator<Item = (&'a Camera, &'a GlobalTransform)>) -> Option<BudgetView> {
        if !self.enabled || self.max_period <= 1 || !(self.viewport.x > 0.0 && self.viewport.y > 0.0) {
            return None;
        }
        let (camera, transform) = cameras.into_iter().find(|(c, _)| c.active)?;
        let half_y = (camera.fov_y * 0.5).clamp(1e-3, 1.56);
        let half_x = (half_y.tan() * self.viewport.x / self.viewport.y).atan();
        let view = transform.0.inverse();
        view.is_finite().then(|| {
            let (sx, cx) = half_x.sin_cos();
            let (sy, cy) = half_y.sin_cos();
            BudgetView {
                view,
                px_per_metre: 0.5 * self.viewport.y / half_y.tan(),
                planes: [Vec3::new(-cx, 0.0, sx), Vec3::new(cx, 0.0, sx), Vec3::new(0.0, -cy, sy), Vec3::new(0.0, cy, sy)],
                full_rate_px: self.full_rate_px.max(0.0),
                max_period: self.max_period.clamp(1, 8).next_power_of_two(),
            }
        })
    }
}

impl BudgetView {
    /// The period, in frames, of a model whose sphere of `radius` (in its root's space) sits at
    /// its root placed by `root`.
    pub(super) fn period(&self, root: &GlobalTransform, radius: f32) -> u8 {
        let scale = root.0.matrix3.x_axis.length().max(root.0.matrix3.y_axis.length()).max(root.0.matrix3.z_axis.length());
        let radius = radius * scale;
        let centre = self.view.transform_point3(root.0.translation.into());
        if !(radius.is_finite() && centre.is_finite()) {
            return 1;
        }
        if centre.z > radius || self.planes.iter().any(|n| n.dot(centre) > radius) {
            return self.max_period; // behind the camera or outside a side plane
        }
        let distance = -centre.z;
        if distance <= radius {
            return 1; // the camera is inside it
        }
        let px = radius * self.px_per_metre / distance;
        let mut period = 1;
        while period < self.max_period && px * f32::from(period) < self.full_rate_px {
            period *= 2;
        }
        period
    }
}

/// A player's phase from its entity `index`: the top byte of a Fibonacci hash, so that players
/// spawned at any regular spacing (a model of 28 entities spawned 10,000 times puts every root at
/// the same index modulo 4) still spread evenly over every power-of-two period.
pub(super) fn stagger(index: u32) -> u32 {
    index.wrapping_mul(0x9E37_79B9) >> 24
}

/// Whether a player of `period` frames samples in `frame`: when its phase comes round (the
/// player's [`stagger`] spreads a crowd evenly over the period), or once `period` frames have
/// passed since it last sampled (so a period that changes never leaves a pose older than the
/// longer period).
pub(super) fn due(frame: u64, last: Option<u64>, period: u8, stagger: u32) -> bool {
    let period = u64::from(period.max(1));
    match last {
        None => true,
        Some(last) => period == 1 || (frame + u64::from(stagger)).is_multiple_of(period) || frame.saturating_sub(last) >= period,
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::transform::Transform;

    fn view(budget: AnimationBudget) -> BudgetView {
        let camera = Camera::default();
        let at = GlobalTransform::from(Transform::from_xyz(0.0, 0.0, 0.0).looking_at(Vec3::NEG_Z, Vec3::Y));
        budget.view([(&camera, &at)]).expect("an active camera with the budget on")
    }

    #[test]
    fn the_period_doubles_as_the_model_shrinks_and_is_longest_off_screen() {
        let v = view(AnimationBudget { enabled: true, viewport: Vec2::new(1920.0, 1080.0), ..Default::default() });
        // 60° vertical: 540 / tan 30° = 935 px a metre at 1 m.
        let at = |x: f32, z: f32| GlobalTransform::from(Transform::from_xyz(x, 0.0, z));
        assert_eq!(v.period(&at(0.0, -10.0), 0.5), 1, "46.8 px");
        assert_eq!(v.period(&at(0.0, -20.0), 0.5), 2, "23.4 px");
        assert_eq!(v.period(&at(0.0, -40.0), 0.5), 4, "11.7 px");
        assert_eq!(v.period(&at(0.0, -400.0), 0.5), 4, "the longest period");
        assert_eq!(v.period(&at(0.0, 5.0), 0.5), 4, "behind the camera");
        assert_eq!(v.period(&at(30.0, -10.0), 0.5), 4, "right of the view");
        assert_eq!(v.period(&at(0.0, -0.2), 0.5), 1, "the camera inside the sphere");
        // The root's scale scales the sphere.
        let big = GlobalTransform::from(Transform::from_xyz(0.0, 0.0, -40.0).with_scale(Vec3::splat(4.0)));
        assert_eq!(v.period(&big, 0.5), 1);
    }

    #[test]
    fn no_budget_without_a_camera_or_when_off() {
        let camera = Camera { active: false, ..Default::default() };
        let at = GlobalTransform::default();
        let on = AnimationBudget { enabled: true, ..Default::default() };
        assert!(on.view([(&camera, &at)]).is_none(), "no active camera");
        assert!(AnimationBudget::default().view([(&Camera::default(), &at)]).is_none(), "off by default");
        assert!(AnimationBudget { max_period: 1, ..on }.view([(&Camera::default(), &at)]).is_none());
        let longest = |max_period| AnimationBudget { max_period, ..on }.view([(&Camera::default(), &at)]).unwrap().max_period;
        assert_eq!([3, 8, 200, 255].map(longest), [4, 8, 8, 8], "a power of two, 8 at most");
    }

    #[test]
    fn players_spawned_at_a_regular_spacing_still_spread_over_the_period() {
        for spacing in [1u32, 4, 28, 64] {
            let mut per_phase = [0u32; 4];
            for i in 0..4000 {
                per_phase[(stagger(100 + i * spacing) % 4) as usize] += 1;
            }
            assert!(per_phase.iter().all(|&n| (800..1200).contains(&n)), "spacing {spacing}: {per_phase:?}");
        }
    }

    #[test]
    fn a_staggered_crowd_samples_an_even_share_each_frame_and_no_pose_gets_older_than_its_period() {
        let mut last: Vec<Option<u64>> = vec![None; 400];
        for frame in 0..64u64 {
            let period = if frame < 32 { 4 } else { 2 };
            let mut sampled = 0;
            for (i, last) in last.iter_mut().enumerate() {
                if let Some(l) = *last {
                    assert!(frame - l <= u64::from(period.max(4)), "frame {frame}: player {i} last sampled at {l}");
                }
                if due(frame, *last, period, i as u32) {
                    *last = Some(frame);
                    sampled += 1;
                }
            }
            // Frame 32 changes the period: the players whose new phase came round, and those
            // whose last pose would otherwise be older than the new period.
            match frame {
                0 => assert_eq!(sampled, 400, "every player samples on its first frame"),
                1..=31 => assert_eq!(sampled, 100, "frame {frame}: a quarter"),
                32 => assert_eq!(sampled, 300, "frame 32: the even half and the quarter last sampled 3 frames ago"),
                _ => assert_eq!(sampled, 200, "frame {frame}: a half"),
            }
        }
    }
}
