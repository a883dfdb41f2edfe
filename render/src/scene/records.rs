//! Constructors and defaults of the GPU records the mirror holds (`crate::layout` defines
//! them once, for Rust and GLSL): instances, materials, lights, decals, boxes, the camera.

use bytemuck::Zeroable;
use glam::{Mat4, Vec2, Vec3};

use super::DecalDesc;
use crate::layout::{
    DECAL_CHANNEL_SHIFT, DECAL_CHANNELS, GpuAabb, GpuCamera, GpuDecal, GpuInstance, GpuLight, GpuMaterial, NO_DECAL, TEXTURE_FLAT_NORMAL,
    TEXTURE_WHITE,
};

impl GpuInstance {
    /// The record for an instance placed by `model`, shaded with the material in `material`,
    /// receiving decals on `decal_layers`.
    pub fn new(model: Mat4, material: u32, decal_layers: u32) -> Self {
        Self { model, normal_model: model.inverse().transpose(), material, decal_layers, mesh: 0, live: 1 }
    }
}

impl Default for GpuMaterial {
    fn default() -> Self {
        Self {
            base_color: [1.0; 4],
            emissive: [0.0; 3],
            normal_scale: 1.0,
            metallic: 0.0,
            roughness: 0.5,
            alpha_cutoff: 0.5,
            occlusion_strength: 1.0,
            base_color_tex: TEXTURE_WHITE,
            metallic_roughness_tex: TEXTURE_WHITE,
            normal_tex: TEXTURE_FLAT_NORMAL,
            occlusion_tex: TEXTURE_WHITE,
            emissive_tex: TEXTURE_WHITE,
            flags: 0,
            refraction: 0.0,
            pad: 0,
        }
    }
}

/// Light kinds as stored in [`GpuLight::kind`].
#[repr(u32)]
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum LightKind {
    /// An empty slot.
    None = crate::layout::LIGHT_NONE,
    /// Omnidirectional point light.
    Point = crate::layout::LIGHT_POINT,
    /// Cone-shaped spot light.
    Spot = crate::layout::LIGHT_SPOT,
    /// Infinitely distant light.
    Directional = crate::layout::LIGHT_DIRECTIONAL,
    /// One-sided rectangular area light.
    Rect = crate::layout::LIGHT_RECT,
    /// One-sided disk-shaped area light.
    Disk = crate::layout::LIGHT_DISK,
}

impl GpuLight {
    /// A point light at `position`.
    pub fn point(position: Vec3, color: Vec3, range: f32) -> Self {
        Self { position, range, color, kind: LightKind::Point as u32, ..Self::zeroed() }
    }

    /// A spot light at `position` shining along `direction`, with cone half-angles in radians.
    pub fn spot(position: Vec3, direction: Vec3, color: Vec3, range: f32, inner: f32, outer: f32) -> Self {
        let (cos_inner, cos_outer) = (inner.cos(), outer.cos());
        let spot_scale = 1.0 / (cos_inner - cos_outer).max(1e-4);
        let cone = outer.clamp(0.0, std::f32::consts::PI);
        Self {
            position,
            range,
            color,
            kind: LightKind::Spot as u32,
            direction: direction.normalize_or(Vec3::NEG_Z),
            spot_scale,
            spot_offset: -cos_outer * spot_scale,
            cone_cos: cone.cos(),
            cone_sin: cone.sin(),
            ..Self::zeroed()
        }
    }

    /// This light with size `size` ([`GpuLight::size`]: a sphere's radius, or a disc's angular
    /// radius's tangent); a negative or non-finite size counts as 0.
    pub fn with_size(self, size: f32) -> Self {
        Self { size: if size.is_finite() { size.max(0.0) } else { 0.0 }, ..self }
    }

    /// A one-sided rectangle centred on `position`, emitting along `direction` (its normal),
    /// with `right` its half-width vector (in its plane) and `half_height` the half of its other
    /// side, of radiance `color` (colour × luminance) and culling `range` from its centre.
    pub fn rect(position: Vec3, direction: Vec3, right: Vec3, half_height: f32, color: Vec3, range: f32) -> Self {
        let direction = direction.normalize_or(Vec3::NEG_Z);
        // In the plane, whatever rounding left of the normal.
        let right = right - direction * direction.dot(right);
        Self { position, range, color, kind: LightKind::Rect as u32, direction, size: half_height, ..Self::zeroed() }.with_right(right)
    }

    /// A one-sided disk of `radius` centred on `position`, emitting along `direction`, with
    /// `axis` a direction in its plane (where its polygon starts), as [`GpuLight::rect`].
    pub fn disk(position: Vec3, direction: Vec3, axis: Vec3, radius: f32, color: Vec3, range: f32) -> Self {
        let direction = direction.normalize_or(Vec3::NEG_Z);
        let axis = (axis - direction * direction.dot(axis)).try_normalize().unwrap_or_else(|| direction.any_orthonormal_vector());
        Self { position, range, color, kind: LightKind::Disk as u32, direction, size: radius, ..Self::zeroed() }.with_right(axis)
    }

    /// An area light's axis in its plane (the spot fields): a rectangle's half-width vector, a
    /// unit vector for a disk.
    pub fn area_right(&self) -> Vec3 {
        Vec3::new(self.spot_scale, self.spot_offset, self.cone_cos)
    }

    /// An area light's area in square metres (a rectangle's or a disk's face); 0 for other kinds.
    pub fn area(&self) -> f32 {
        match self.kind {
            k if k == LightKind::Rect as u32 => 4.0 * self.area_right().length() * self.size,
            k if k == LightKind::Disk as u32 => std::f32::consts::PI * self.size * self.size,
            _ => 0.0,
        }
    }

    fn with_right(self, right: Vec3) -> Self {
        Self { spot_scale: right.x, spot_offset: right.y, cone_cos: right.z, ..self }
    }

    /// A directional light travelling along `direction`.
    pub fn directional(direction: Vec3, color: Vec3) -> Self {
        Self {
            color,
            kind: LightKind::Directional as u32,
            direction: direction.normalize_or(Vec3::NEG_Y),
            range: f32::INFINITY,
            ..Self::zeroed()
        }
    }
}

impl GpuDecal {
    /// `material_channel` for a decal material slot and a channel (clamped below
    /// [`DECAL_CHANNELS`]). Slots reach 2³⁰, far past the decal material table's limit.
    pub fn pack_material_channel(material: u32, channel: u32) -> u32 {
        debug_assert!(material < 1 << DECAL_CHANNEL_SHIFT, "decal material slot {material} out of range");
        (material & ((1 << DECAL_CHANNEL_SHIFT) - 1)) | (channel.min(DECAL_CHANNELS - 1) << DECAL_CHANNEL_SHIFT)
    }

    /// The decal material slot.
    pub fn material(&self) -> u32 {
        self.material_channel & ((1 << DECAL_CHANNEL_SHIFT) - 1)
    }

    /// The blending channel.
    pub fn channel(&self) -> u32 {
        self.material_channel >> DECAL_CHANNEL_SHIFT
    }
}

impl GpuAabb {
    /// A zero-size box at `p` that belongs to no decal.
    pub fn point(p: Vec3) -> Self {
        Self { min: p.to_array(), max: p.to_array(), slot: NO_DECAL, owner: 0 }
    }

    /// The zero-size box at this box's centre.
    pub fn collapsed(&self) -> Self {
        Self::point((Vec3::from(self.min) + Vec3::from(self.max)) * 0.5)
    }

    /// Boxes for never-used entries `first..first + count` of the decal box table (the padding
    /// of a BLAS build): zero-size points, so no query ever lands on them, at the centres of the
    /// boxes in `boxes`, taken in turn, so the padding is spread like the decals themselves.
    /// How padding is placed decides what a build costs on NVIDIA's builder: parking it all on
    /// one point made builds 2.5–3.5× slower, and on a line of points 1 mm apart near the
    /// decals' centroid (our second version) 6 % of padding still doubled a build of 100,000
    /// boxes (docs/experiments/decals-count-exact-blas.md). (A despawn leaves the same kind of point: the moved box's
    /// centre.)
    pub fn parking(boxes: &[GpuAabb], first: u32, count: u32) -> impl Iterator<Item = GpuAabb> {
        (0..count).map(move |i| match boxes.len() {
            0 => Self::point(Vec3::new((first + i) as f32 * 1e-3, 0.0, 0.0)),
            n => boxes[i as usize % n].collapsed(),
        })
    }

    /// The box a decal's record in `slot` is found by: its unit box's AABB, or a point where it
    /// stands when its transform is invalid ([`DecalDesc::is_valid`]).
    pub fn of_decal(decal: &DecalDesc, slot: u32) -> Self {
        Self::of_checked_decal(decal, slot, decal.is_valid())
    }

    /// [`GpuAabb::of_decal`] of a decal whose validity is known.
    pub(crate) fn of_checked_decal(decal: &DecalDesc, slot: u32, valid: bool) -> Self {
        if valid {
            return Self { owner: decal.on_skin.map_or(0, |instance| instance + 1), ..Self::of_unit_box(decal.decal_to_world, slot) };
        }
        let at = decal.decal_to_world.w_axis.truncate();
        Self { slot, ..Self::point(if at.is_finite() { at } else { Vec3::ZERO }) }
    }

    /// The AABB of the box `[-0.5, 0.5]³` transformed by `decal_to_world`, for the record in
    /// `slot`.
    pub fn of_unit_box(decal_to_world: Mat4, slot: u32) -> Self {
        let centre = decal_to_world.w_axis.truncate();
        let half =
            (decal_to_world.x_axis.truncate().abs() + decal_to_world.y_axis.truncate().abs() + decal_to_world.z_axis.truncate().abs())
                * 0.5;
        Self { min: (centre - half).to_array(), max: (centre + half).to_array(), slot, owner: 0 }
    }
}

impl Default for GpuCamera {
    fn default() -> Self {
        Self { decal_fade: Vec2::splat(f32::INFINITY), ..Self::zeroed() }
    }
}
