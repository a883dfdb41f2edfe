//! Decals as the renderer takes them ([`DecalDesc`]) and the table that keeps each decal's
//! record and box in one slot ([`DecalTable`]).

use bytemuck::Zeroable;
use glam::{Mat4, Vec2};

use super::SlotTable;
use crate::layout::{DECAL_ON_SKIN, GpuAabb, GpuDecal, NO_DECAL};

/// A decal as the renderer takes it: plain data, no ECS types. Its GPU record and its box are
/// built from this in one place ([`DecalDesc::prepare`], which [`DecalTable::write`] calls).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct DecalDesc {
    /// Decal space (the unit box `[-0.5, 0.5]³`, projecting along −Z) to world.
    pub decal_to_world: Mat4,
    /// Slot in the decal material table.
    pub material: u32,
    /// UVs at the box corners (−x,−y), (+x,−y), (+x,+y), (−x,+y).
    pub uv_corners: [Vec2; 4],
    /// Blending channel; clamped to `0..DECAL_CHANNELS`.
    pub channel: u32,
    /// Weight within the channel (at least 1e-4).
    pub weight: f32,
    /// Receiver layers the decal lands on.
    pub receivers: u32,
    /// Overall opacity, clamped to 0..=1.
    pub opacity: f32,
    /// Angle fade: full strength up to the first angle (radians) between the surface normal and
    /// the projection axis, nothing from the second on; `None` disables it.
    pub angle_fade: Option<(f32, f32)>,
    /// Lifetime fade: full strength until the first time, nothing from the second on, in
    /// seconds on the clock of [`GpuCamera::time`](crate::layout::GpuCamera::time); `None` disables it.
    pub lifetime_fade: Option<(f32, f32)>,
    /// Distance fade: full strength nearer the camera than the first distance (metres),
    /// nothing beyond the second; `None` takes the camera's default ([`GpuCamera::decal_fade`](crate::layout::GpuCamera::decal_fade)).
    pub distance_fade: Option<(f32, f32)>,
    /// A decal on a skin: the slot of the skinned instance it sticks to. Its transform then
    /// places it on that instance's *rest pose* (the instance's model × rest-pose space), where
    /// the instance's pixels look it up, so it follows the skin as it deforms
    /// (`crate::skinning`). `None`: a decal in the world.
    pub on_skin: Option<u32>,
}

/// Two floats as half floats in one word (GLSL's `packHalf2x16`: the first in the low bits).
pub fn pack_half2(a: f32, b: f32) -> u32 {
    half::f16::from_f32(a).to_bits() as u32 | (half::f16::from_f32(b).to_bits() as u32) << 16
}

impl DecalDesc {
    /// Whether the decal's transform is finite and invertible. An invalid decal keeps its slot
    /// but lands nowhere (its record has no receiver layers, its box is a point), so a NaN or a
    /// zero scale from gameplay can neither corrupt the image nor stall the GPU's binning.
    pub fn is_valid(&self) -> bool {
        self.world_to_decal().is_some()
    }

    /// The inverse of `decal_to_world`, when the decal is valid ([`DecalDesc::is_valid`]).
    fn world_to_decal(&self) -> Option<Mat4> {
        let m = self.decal_to_world;
        let det = m.determinant();
        if !(m.is_finite() && det.is_finite() && det.abs() > 1e-12) {
            return None;
        }
        Some(m.inverse()).filter(|inverse| inverse.is_finite())
    }

    /// The GPU record.
    pub fn record(&self) -> GpuDecal {
        self.checked_record().0
    }

    /// The decal's record and box, ready for [`DecalTable::write_prepared`]: the arithmetic of
    /// a write (one inversion of the transform), apart from the table, so that an extraction
    /// visiting many decals can do it on every core and then only copy the results in.
    pub fn prepare(&self) -> PreparedDecal {
        let (record, valid) = self.checked_record();
        // The box's slot is the table's to fill in.
        PreparedDecal { record, aabb: GpuAabb::of_checked_decal(self, 0, valid), valid }
    }

    /// The GPU record, and whether the decal is valid ([`DecalDesc::is_valid`]): one inversion
    /// of the transform for both.
    fn checked_record(&self) -> (GpuDecal, bool) {
        let Some(world_to_decal) = self.world_to_decal() else {
            return (GpuDecal { receivers: 0, weight: 1.0, ..GpuDecal::zeroed() }, false);
        };
        let c = self.uv_corners;
        let (fade_scale, fade_offset) = match self.angle_fade {
            Some((start, end)) => {
                let (cos_start, cos_end) = (start.cos(), end.cos());
                let scale = 1.0 / (cos_start - cos_end).max(1e-4);
                (scale, -cos_end * scale)
            }
            None => (0.0, 1.0),
        };
        let (life_scale, life_offset) = match self.lifetime_fade {
            Some((start, end)) if end > start && start.is_finite() && end.is_finite() => {
                let scale = -1.0 / (end - start);
                (scale, -end * scale)
            }
            _ => (0.0, 1.0),
        };
        let record = GpuDecal {
            world_to_decal,
            uv01: [c[0].x, c[0].y, c[1].x, c[1].y],
            uv23: [c[2].x, c[2].y, c[3].x, c[3].y],
            material_channel: GpuDecal::pack_material_channel(self.material, self.channel),
            weight: self.weight.max(1e-4),
            receivers: (self.receivers & !DECAL_ON_SKIN) | if self.on_skin.is_some() { DECAL_ON_SKIN } else { 0 },
            opacity: if self.opacity.is_nan() { 0.0 } else { self.opacity.clamp(0.0, 1.0) },
            angle_fade: pack_half2(fade_scale, fade_offset),
            distance_fade: match self.distance_fade {
                // A fade that starts at 0 m would read as "the camera's default": start it just
                // past the camera instead.
                Some((start, end)) => pack_half2(start.max(1e-3), end.max(start).max(1e-3)),
                None => 0,
            },
            life_scale,
            life_offset,
        };
        (record, true)
    }
}

/// A decal's GPU record and box, made by [`DecalDesc::prepare`] (on any thread) and copied into
/// its slot by [`DecalTable::write_prepared`].
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct PreparedDecal {
    record: GpuDecal,
    aabb: GpuAabb,
    valid: bool,
}

impl PreparedDecal {
    /// Whether the decal was valid ([`DecalDesc::is_valid`]): one that is not lands nowhere.
    pub fn is_valid(&self) -> bool {
        self.valid
    }
}

/// Decal records in stable slots, and their boxes kept dense: box *i* (BLAS primitive *i*) holds
/// the slot of its record, and the first [`DecalTable::len`] boxes are exactly the live decals'.
/// A despawn moves the last box into the freed place (two box uploads), so the BLAS is built
/// over the live boxes only, never over the holes that gameplay leaves in the record slots.
#[derive(Default)]
pub struct DecalTable {
    /// Shading records.
    pub records: SlotTable<GpuDecal>,
    /// Boxes for the acceleration structure, dense: entries `0..len()` are live.
    pub aabbs: SlotTable<GpuAabb>,
    /// The box of each record slot.
    box_of: Vec<u32>,
    /// Live decals on a skin (`DECAL_ON_SKIN`).
    on_skin: u32,
}

impl DecalTable {
    /// Writes `decal` into `slot` (or a new slot): its record and its box.
    pub fn write(&mut self, slot: Option<u32>, decal: &DecalDesc) -> u32 {
        self.write_prepared(slot, &decal.prepare())
    }

    /// Writes a decal's record and box made by [`DecalDesc::prepare`] into `slot` (or a new
    /// slot): two copies, no arithmetic.
    pub fn write_prepared(&mut self, slot: Option<u32>, decal: &PreparedDecal) -> u32 {
        let PreparedDecal { record, aabb, .. } = *decal;
        self.on_skin += u32::from(record.receivers & DECAL_ON_SKIN != 0);
        match slot {
            Some(slot) => {
                self.forget_skin(slot);
                self.records.write(slot, record);
                self.aabbs.write(self.box_of[slot as usize], GpuAabb { slot, ..aabb });
                slot
            }
            None => {
                let slot = self.records.insert(record);
                let aabb = self.aabbs.insert(GpuAabb { slot, ..aabb });
                debug_assert_eq!(aabb as usize, self.records.len() - 1, "boxes stay dense");
                if self.box_of.len() <= slot as usize {
                    self.box_of.resize(slot as usize + 1, NO_DECAL);
                }
                self.box_of[slot as usize] = aabb;
                slot
            }
        }
    }

    /// Frees a slot: the record is zeroed (never applies); the last box moves into the freed
    /// box's place and the last place keeps a zero-size box that belongs to no decal, at its old
    /// centre (distinct from the others: see `render::decals::accel` on why).
    pub fn remove(&mut self, slot: u32) {
        let Some(&index) = self.box_of.get(slot as usize).filter(|_| self.records.get(slot).is_some()) else { return };
        self.forget_skin(slot);
        let last = self.records.len() as u32 - 1;
        let moved = *self.aabbs.get(last).expect("boxes are dense");
        if index != last {
            self.aabbs.write(index, moved);
            self.box_of[moved.slot as usize] = index;
        }
        self.aabbs.release_with(last, moved.collapsed());
        self.box_of[slot as usize] = NO_DECAL;
        self.records.remove(slot);
    }

    /// Whether some live decal sits on a skin.
    pub fn any_on_skin(&self) -> bool {
        self.on_skin > 0
    }

    fn forget_skin(&mut self, slot: u32) {
        if self.records.get(slot).is_some_and(|r| r.receivers & DECAL_ON_SKIN != 0) {
            self.on_skin -= 1;
        }
    }

    /// Drops the free record slots and box places at the ends of their tables
    /// ([`SlotTable::trim`]): the boxes, being dense, end at [`DecalTable::len`].
    pub fn trim(&mut self) {
        self.records.trim();
        self.aabbs.trim();
        self.box_of.truncate(self.records.slot_count() as usize);
    }

    /// Live decals.
    pub fn len(&self) -> usize {
        self.records.len()
    }

    /// True when no decal is live.
    pub fn is_empty(&self) -> bool {
        self.records.is_empty()
    }
}
