//! Light components in physical units: punctual lights (glTF `KHR_lights_punctual` semantics)
//! and one-sided area lights ([`RectLight`], [`DiskLight`]; issue 52, item 1).
//!
//! Point and spot lights have an optional range; without one their culling range comes from
//! their intensity by seed 001 (Elagabani 2025), eq. 4.1: the distance at which the inverse
//! square falloff drops below [`MIN_LIGHT_INTENSITY`].

use bevy_ecs::prelude::*;
use glam::Vec3;

use crate::transform::Transform;

/// Intensity threshold below which a light's contribution is ignored (seed 001, eq. 4.1).
pub const MIN_LIGHT_INTENSITY: f32 = 0.02;

/// The culling range of a light of `intensity` candela: seed 001, eq. 4.1,
/// `I / D² = 0.02  ⇔  D = 50 · √(0.02 · I)` (which equals `√(I / 0.02)`).
/// Negative or non-finite intensities give 0.
pub fn range_from_intensity(intensity: f32) -> f32 {
    if intensity.is_finite() && intensity > 0.0 { 50.0 * (MIN_LIGHT_INTENSITY * intensity).sqrt() } else { 0.0 }
}

/// An omnidirectional light at its entity's position.
///
/// Immutable: change it by inserting a new value (the render extraction then finds it without
/// scanning; see [`crate::changes`]).
#[derive(Component, Clone, Copy, Debug, PartialEq)]
#[require(Transform)]
#[component(immutable, on_insert = crate::changes::note_inserted::<Self>)]
pub struct PointLight {
    /// Linear RGB colour.
    pub color: Vec3,
    /// Luminous intensity in candela.
    pub intensity: f32,
    /// Explicit range in metres; `None` derives it from the intensity.
    pub range: Option<f32>,
    /// Radius of the light's sphere in metres (0: a point, hard shadows). Ray-traced shadows
    /// aim each pixel's ray at a point of the sphere that changes from frame to frame, so that
    /// temporal anti-aliasing resolves a penumbra as wide as the sphere casts.
    pub radius: f32,
}

impl Default for PointLight {
    fn default() -> Self {
        PointLight { color: Vec3::ONE, intensity: 10.0, range: None, radius: 0.0 }
    }
}

impl PointLight {
    /// The explicit range, or [`range_from_intensity`] of the intensity.
    pub fn effective_range(&self) -> f32 {
        self.range.unwrap_or_else(|| range_from_intensity(self.intensity))
    }
}

/// A cone light at its entity's position, shining along its local -Z.
///
/// Immutable: change it by inserting a new value (the render extraction then finds it without
/// scanning; see [`crate::changes`]).
#[derive(Component, Clone, Copy, Debug, PartialEq)]
#[require(Transform)]
#[component(immutable, on_insert = crate::changes::note_inserted::<Self>)]
pub struct SpotLight {
    /// Linear RGB colour.
    pub color: Vec3,
    /// Luminous intensity in candela along the axis.
    pub intensity: f32,
    /// Explicit range in metres; `None` derives it from the intensity.
    pub range: Option<f32>,
    /// Angle from the axis (radians) inside which the intensity is full (glTF `innerConeAngle`).
    pub inner_angle: f32,
    /// Angle from the axis (radians) beyond which there is no light (glTF `outerConeAngle`).
    pub outer_angle: f32,
    /// Radius of the light's sphere in metres (0: a point, hard shadows), as for
    /// [`PointLight::radius`].
    pub radius: f32,
}

impl Default for SpotLight {
    fn default() -> Self {
        SpotLight {
            color: Vec3::ONE,
            intensity: 10.0,
            range: None,
            inner_angle: 0.0,
            outer_angle: std::f32::consts::FRAC_PI_4,
            radius: 0.0,
        }
    }
}

impl SpotLight {
    /// The explicit range, or [`range_from_intensity`] of the intensity.
    pub fn effective_range(&self) -> f32 {
        self.range.unwrap_or_else(|| range_from_intensity(self.intensity))
    }
}

/// A light infinitely far away, shining along its entity's local -Z.
///
/// Immutable: change it by inserting a new value (the render extraction then finds it without
/// scanning; see [`crate::changes`]).
#[derive(Component, Clone, Copy, Debug, PartialEq)]
#[require(Transform)]
#[component(immutable, on_insert = crate::changes::note_inserted::<Self>)]
pub struct DirectionalLight {
    /// Linear RGB colour.
    pub color: Vec3,
    /// Illuminance in lux on a surface facing the light.
    pub illuminance: f32,
    /// Angular diameter of the light's disc in radians (0: hard shadows; the sun's is
    /// [`SUN_ANGULAR_DIAMETER`], the default). Ray-traced shadows aim each pixel's ray at a
    /// point of the disc that changes from frame to frame, so that temporal anti-aliasing
    /// resolves the penumbra.
    pub angular_diameter: f32,
}

/// The sun's angular diameter seen from the earth, radians (0.53°).
pub const SUN_ANGULAR_DIAMETER: f32 = 0.53 * std::f32::consts::PI / 180.0;

impl Default for DirectionalLight {
    fn default() -> Self {
        DirectionalLight { color: Vec3::ONE, illuminance: 5.0, angular_diameter: SUN_ANGULAR_DIAMETER }
    }
}

/// A one-sided rectangular area light (a window, a screen, a ceiling panel) centred on its
/// entity, `width` along its local X and `height` along its local Y (both scaled by the
/// transform), emitting from its face that looks along its local -Z.
///
/// Shading integrates the rectangle as seen from each point (the cosine-weighted solid angle of
/// the polygon: linearly transformed cosines with the identity transform, Heitz et al. 2016), so
/// near a large panel the light is soft and wraps as a real one does; ray-traced shadows aim at
/// points spread over its face, so its shadows are soft (their penumbra resolves under temporal
/// anti-aliasing, as a sized [`PointLight`]'s does). Where shadows come from maps, it takes a point
/// light's cube of maps from its centre.
///
/// Immutable: change it by inserting a new value (see [`crate::changes`]).
#[derive(Component, Clone, Copy, Debug, PartialEq)]
#[require(Transform)]
#[component(immutable, on_insert = crate::changes::note_inserted::<Self>)]
pub struct RectLight {
    /// Linear RGB colour.
    pub color: Vec3,
    /// Luminance of its face in candela per square metre (nits), the same in every direction
    /// it emits to: a 1 m² panel of 10 nits seen face-on from afar lights as a 10 cd
    /// [`PointLight`] does.
    pub intensity: f32,
    /// Width in metres (along local X).
    pub width: f32,
    /// Height in metres (along local Y).
    pub height: f32,
    /// Explicit range in metres from its centre; `None` derives it from the intensity over its
    /// area ([`RectLight::effective_range`]).
    pub range: Option<f32>,
}

impl Default for RectLight {
    fn default() -> Self {
        RectLight { color: Vec3::ONE, intensity: 10.0, width: 1.0, height: 1.0, range: None }
    }
}

impl RectLight {
    /// The explicit range, or the range of a point light of its intensity × area
    /// ([`range_from_intensity`]: its face-on intensity in candela) plus its half diagonal.
    pub fn effective_range(&self) -> f32 {
        self.range.unwrap_or_else(|| area_range(self.intensity, self.width * self.height, 0.5 * self.width.hypot(self.height)))
    }
}

/// A one-sided disk-shaped area light (a round ceiling lamp, a spot's lens) of `radius` centred
/// on its entity, in its local XY plane (scaled by the larger of the transform's X and Y
/// scales), emitting from its face that looks along its local -Z. Shaded and shadowed as
/// [`RectLight`] is.
///
/// Immutable: change it by inserting a new value (see [`crate::changes`]).
#[derive(Component, Clone, Copy, Debug, PartialEq)]
#[require(Transform)]
#[component(immutable, on_insert = crate::changes::note_inserted::<Self>)]
pub struct DiskLight {
    /// Linear RGB colour.
    pub color: Vec3,
    /// Luminance of its face in candela per square metre (nits), as [`RectLight::intensity`].
    pub intensity: f32,
    /// Radius in metres.
    pub radius: f32,
    /// Explicit range in metres from its centre; `None` derives it as
    /// [`RectLight::effective_range`] does.
    pub range: Option<f32>,
}

impl Default for DiskLight {
    fn default() -> Self {
        DiskLight { color: Vec3::ONE, intensity: 10.0, radius: 0.5, range: None }
    }
}

impl DiskLight {
    /// The explicit range, or the range of a point light of its intensity × area plus its
    /// radius.
    pub fn effective_range(&self) -> f32 {
        self.range.unwrap_or_else(|| area_range(self.intensity, std::f32::consts::PI * self.radius * self.radius, self.radius))
    }
}

/// The culling range of an area light of `luminance` over `area`, reaching `reach` from its
/// centre: the range of a point light of its face-on intensity, plus the reach.
fn area_range(luminance: f32, area: f32, reach: f32) -> f32 {
    let range = range_from_intensity(luminance * area);
    if range > 0.0 && reach.is_finite() { range + reach.max(0.0) } else { range }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn range_matches_eq_4_1() {
        // D = sqrt(I / 0.02): I = 2 -> 10 m, I = 50 -> 50 m, I = 0.02 -> 1 m.
        assert!((range_from_intensity(2.0) - 10.0).abs() < 1e-4);
        assert!((range_from_intensity(50.0) - 50.0).abs() < 1e-3);
        assert!((range_from_intensity(0.02) - 1.0).abs() < 1e-5);
        let d = range_from_intensity(123.0);
        assert!((123.0 / (d * d) - MIN_LIGHT_INTENSITY).abs() < 1e-6);
        assert_eq!(range_from_intensity(-1.0), 0.0);
        assert_eq!(range_from_intensity(f32::NAN), 0.0);
    }

    #[test]
    fn explicit_range_wins() {
        let light = PointLight { range: Some(3.0), intensity: 1e6, ..Default::default() };
        assert_eq!(light.effective_range(), 3.0);
        let spot = SpotLight { intensity: 8.0, ..Default::default() };
        assert!((spot.effective_range() - 20.0).abs() < 1e-4);
    }

    #[test]
    fn area_lights_reach_as_far_as_a_point_light_of_their_power_plus_their_size() {
        // 2 nits over 1 m²: 2 cd face-on, 10 m; plus the half diagonal.
        let rect = RectLight { intensity: 2.0, width: 1.0, height: 1.0, ..Default::default() };
        assert!((rect.effective_range() - (10.0 + 0.5 * 2f32.sqrt())).abs() < 1e-4);
        let disk = DiskLight { intensity: 2.0 / std::f32::consts::PI, radius: 1.0, ..Default::default() };
        assert!((disk.effective_range() - 11.0).abs() < 1e-4);
        assert_eq!(RectLight { range: Some(3.0), ..rect }.effective_range(), 3.0);
        assert_eq!(RectLight { intensity: -1.0, ..rect }.effective_range(), 0.0, "a dark light reaches nothing");
    }
}
