//! The deferred decals' draw order (seed 000 §3.2): live decals sorted by channel, then weight,
//! split into runs that change the same attributes (each run picks the pipeline whose write masks
//! touch only those). Rebuilt only when decals or their materials change.

use crate::scene::gpu::GpuScene;
use crate::scene::{GpuDecal, GpuDecalMaterial, SceneMirror};

/// A run of consecutive decals in draw order that change the same attributes.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct DecalRun {
    /// Index of the run's first decal in the draw order.
    pub first: u32,
    /// Decals in the run.
    pub count: u32,
    /// `DECAL_*` flags of the run.
    pub flags: u32,
}

/// Sorts the live decals of `records` by channel, then weight (then slot, for stability) into
/// `slots`, and splits them into `runs` of equal attribute sets. `keys` is scratch space.
pub fn plan_deferred_decals(
    records: &[GpuDecal],
    materials: &[GpuDecalMaterial],
    keys: &mut Vec<(u32, f32, u32)>,
    slots: &mut Vec<u32>,
    runs: &mut Vec<DecalRun>,
) {
    keys.clear();
    keys.extend(records.iter().enumerate().filter(|(_, r)| r.receivers != 0).map(|(i, r)| (r.channel(), r.weight, i as u32)));
    keys.sort_unstable_by(|a, b| a.0.cmp(&b.0).then(a.1.total_cmp(&b.1)).then(a.2.cmp(&b.2)));
    slots.clear();
    slots.extend(keys.iter().map(|k| k.2));
    runs.clear();
    for (i, &slot) in slots.iter().enumerate() {
        let flags = materials.get(records[slot as usize].material() as usize).map_or(0, |m| m.flags & 15);
        match runs.last_mut() {
            Some(run) if run.flags == flags => run.count += 1,
            _ => runs.push(DecalRun { first: i as u32, count: 1, flags }),
        }
    }
}

/// The order and its runs, kept between frames.
#[derive(Default)]
pub struct DeferredDecalOrder {
    keys: Vec<(u32, f32, u32)>,
    slots: Vec<u32>,
    /// Runs of the current order.
    pub runs: Vec<DecalRun>,
    valid: bool,
    /// The decal slot count last seen.
    seen_slots: u32,
}

impl DeferredDecalOrder {
    /// Follows this frame's decal changes: rebuilds the order (and hands it to `scene` for upload)
    /// when deferred decals are `in_use` and anything changed since it was built; otherwise drops
    /// it as stale (an empty order for the scene, so its table can shrink). Call before the
    /// scene's upload, which consumes the change marks.
    pub fn follow(&mut self, mirror: &SceneMirror, scene: &mut GpuScene, in_use: bool) {
        // (A trim drops the dirty marks of the slots it removes; the slot count says it happened.)
        let slots = mirror.decals.records.slot_count();
        let trimmed = std::mem::replace(&mut self.seen_slots, slots) != slots;
        let changed = mirror.decals.records.dirty_count() > 0 || mirror.decal_materials.dirty_count() > 0 || trimmed;
        if in_use && (changed || !self.valid) {
            plan_deferred_decals(
                mirror.decals.records.records(),
                mirror.decal_materials.records(),
                &mut self.keys,
                &mut self.slots,
                &mut self.runs,
            );
            scene.set_decal_order(&self.slots);
            self.valid = true;
        } else if changed && self.valid {
            // Stale, and rebuilt before it is used again: let it go now, so that its table can
            // shrink when decals go away.
            self.valid = false;
            self.slots.clear();
            self.runs.clear();
            scene.set_decal_order(&self.slots);
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::scene::{DECAL_ALBEDO, DECAL_NORMAL, DECAL_ROUGHNESS};
    use bytemuck::Zeroable;

    #[test]
    fn decals_are_ordered_by_channel_then_weight_in_runs_of_equal_attributes() {
        let decal = |channel, weight, material| GpuDecal {
            material_channel: GpuDecal::pack_material_channel(material, channel),
            weight,
            receivers: 1,
            ..GpuDecal::zeroed()
        };
        let records = [
            decal(1, 1.0, 0),
            GpuDecal::zeroed(), // a free slot
            decal(0, 2.0, 1),
            decal(0, 0.5, 0),
            decal(1, 0.2, 0),
        ];
        let materials = [
            GpuDecalMaterial { flags: DECAL_ALBEDO, ..GpuDecalMaterial::zeroed() },
            GpuDecalMaterial { flags: DECAL_NORMAL | DECAL_ROUGHNESS, ..GpuDecalMaterial::zeroed() },
        ];
        let (mut keys, mut slots, mut runs) = (Vec::new(), Vec::new(), Vec::new());
        plan_deferred_decals(&records, &materials, &mut keys, &mut slots, &mut runs);
        assert_eq!(slots, vec![3, 2, 4, 0]);
        assert_eq!(
            runs,
            vec![
                DecalRun { first: 0, count: 1, flags: DECAL_ALBEDO },
                DecalRun { first: 1, count: 1, flags: DECAL_NORMAL | DECAL_ROUGHNESS },
                DecalRun { first: 2, count: 2, flags: DECAL_ALBEDO },
            ]
        );
    }
}
