//! The perspective camera component.
//!
//! Projection convention: right-handed view space looking down -Z, reverse-Z depth with an
//! infinite far plane (depth 1 at the near plane, 0 at infinity), depth range [0, 1] as Vulkan
//! expects. This is glam's `perspective_infinite_reverse_rh`, whose clip-space Y points up; the
//! renderer flips Y (negative viewport height) to match Vulkan's downward framebuffer Y.

use bevy_ecs::prelude::*;
use glam::{Mat4, Vec2, Vec3};

use crate::transform::{GlobalTransform, Transform};

/// A perspective camera; its view is the inverse of its entity's `GlobalTransform`.
#[derive(Component, Clone, Copy, Debug, PartialEq)]
#[require(Transform)]
pub struct Camera {
    /// Vertical field of view in radians.
    pub fov_y: f32,
    /// Distance to the near plane in metres (the far plane is at infinity).
    pub near: f32,
    /// Linear exposure multiplier applied to radiance before tonemapping (see
    /// [`Camera::exposure_from_ev100`] to set it from a photographic exposure value).
    pub exposure: f32,
    /// Whether this camera renders.
    pub active: bool,
}

impl Default for Camera {
    fn default() -> Self {
        Camera { fov_y: 60f32.to_radians(), near: 0.05, exposure: 1.0, active: true }
    }
}

impl Camera {
    /// The exposure multiplier of an exposure value at ISO 100 (EV100): the saturation-based
    /// sensitivity with the usual lens constant, `1 / (1.2 × 2^EV100)` (Lagarde and de Rousiers
    /// 2014, §5.1). EV100 15 suits a sunny day in real units (100,000 lux); 0 gives 0.83.
    pub fn exposure_from_ev100(ev100: f32) -> f32 {
        1.0 / (1.2 * ev100.exp2())
    }

    /// The projection matrix for a viewport of `aspect` = width / height. Non-finite or
    /// non-positive inputs are clamped to small positive values rather than producing NaN.
    pub fn projection(&self, aspect: f32) -> Mat4 {
        let fov = if self.fov_y.is_finite() { self.fov_y.clamp(1e-3, std::f32::consts::PI - 1e-3) } else { 60f32.to_radians() };
        let aspect = if aspect.is_finite() && aspect > 0.0 { aspect } else { 1.0 };
        let near = if self.near.is_finite() && self.near > 0.0 { self.near } else { 0.05 };
        Mat4::perspective_infinite_reverse_rh(fov, aspect, near)
    }

    /// The world-space ray through pixel position `cursor` (origin top-left, in pixels) of a
    /// `viewport` of this camera placed by `transform`: its origin on the near plane and its unit
    /// direction. `None` for a degenerate viewport or transform. What a click aims at.
    pub fn ray(&self, transform: &GlobalTransform, cursor: Vec2, viewport: Vec2) -> Option<(Vec3, Vec3)> {
        if !(viewport.x > 0.0 && viewport.y > 0.0) {
            return None;
        }
        let view_proj = self.projection(viewport.x / viewport.y) * transform.compute_matrix().inverse();
        let inverse = view_proj.inverse();
        let ndc = Vec2::new(cursor.x / viewport.x * 2.0 - 1.0, 1.0 - cursor.y / viewport.y * 2.0);
        let near = inverse.project_point3(ndc.extend(1.0));
        let far = inverse.project_point3(ndc.extend(0.5));
        let direction = (far - near).try_normalize()?;
        near.is_finite().then_some((near, direction))
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use glam::{Vec3, Vec4};

    #[test]
    fn the_ray_through_the_centre_is_the_view_direction() {
        let camera = Camera::default();
        let at = Transform::from_xyz(1.0, 2.0, 3.0).looking_at(Vec3::new(1.0, 0.0, 0.0), Vec3::Y);
        let global = GlobalTransform(at.compute_affine());
        let (origin, dir) = camera.ray(&global, Vec2::new(320.0, 240.0), Vec2::new(640.0, 480.0)).unwrap();
        assert!((dir - at.forward()).length() < 1e-4, "{dir}");
        assert!((origin - at.translation).length() < 0.1);
        // The top-left pixel's ray points up and to the left of the view direction.
        let (_, corner) = camera.ray(&global, Vec2::ZERO, Vec2::new(640.0, 480.0)).unwrap();
        let right = at.forward().cross(Vec3::Y).normalize();
        assert!(corner.dot(right) < 0.0 && corner.y > dir.y);
        assert!(camera.ray(&global, Vec2::ZERO, Vec2::ZERO).is_none());
    }

    #[test]
    fn reverse_z_depth() {
        let camera = Camera::default();
        let proj = camera.projection(16.0 / 9.0);
        let near = proj * Vec4::new(0.0, 0.0, -camera.near, 1.0);
        let far = proj * Vec4::new(0.0, 0.0, -1.0e6, 1.0);
        assert!((near.z / near.w - 1.0).abs() < 1e-5);
        assert!((far.z / far.w).abs() < 1e-6);
        // A point above the axis lands at positive clip Y (Y up before the viewport flip).
        let up = proj * Vec3::new(0.0, 1.0, -2.0).extend(1.0);
        assert!(up.y > 0.0);
    }
}
