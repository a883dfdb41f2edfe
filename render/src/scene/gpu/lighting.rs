//! The lighting record: set whole by the lights each frame, with the fields other techniques
//! own (bloom, auto-exposure, the display check, the level-of-detail lift, the shadow maps'
//! atlas) kept as they set them; uploaded only when it changed.

use super::*;

/// The particles' decal ring as the lighting record names it ([`GpuScene::set_decal_ring`]).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct DecalRingFields {
    /// Address of its records (`GpuDecal` per place).
    pub records: u64,
    /// Address of its boxes (`GpuAabb` per place).
    pub boxes: u64,
    /// Address of its TLAS (0: none).
    pub tlas: u64,
    /// Places of the ring.
    pub room: u32,
    /// Places in one BLAS of its structure.
    pub segment: u32,
}

impl GpuScene {
    /// Sets the lighting record; it is uploaded with the next sync only when it differs.
    pub fn set_lighting(&mut self, mut lighting: GpuLighting) {
        (lighting.culls, lighting.movers) = (self.lighting_cpu.culls, self.lighting_cpu.movers); // the upload's to set
        // The bloom pass's to set (`set_bloom`).
        (lighting.bloom, lighting.bloom_levels, lighting.bloom_intensity) =
            (self.lighting_cpu.bloom, self.lighting_cpu.bloom_levels, self.lighting_cpu.bloom_intensity);
        // And auto-exposure's (`set_exposure`), the display check's (`set_display_check`) and the
        // level-of-detail lift (`set_lod_lift`).
        let exposure = exposure_fields(&self.lighting_cpu);
        set_exposure_fields(&mut lighting, exposure);
        lighting.display_check = self.lighting_cpu.display_check;
        lighting.lod_lift = self.lighting_cpu.lod_lift;
        // And the particle system's state and decal ring (`set_particles`, `set_decal_ring`).
        lighting.particles = self.lighting_cpu.particles;
        let l = &self.lighting_cpu;
        (lighting.decal_ring, lighting.decal_ring_boxes, lighting.decal_ring_tlas, lighting.decal_ring_room, lighting.decal_ring_segment) =
            (l.decal_ring, l.decal_ring_boxes, l.decal_ring_tlas, l.decal_ring_room, l.decal_ring_segment);
        // And the shadow maps' atlas layout (`set_shadow_maps`).
        (lighting.shadow_map_tile, lighting.shadow_map_columns) = (self.lighting_cpu.shadow_map_tile, self.lighting_cpu.shadow_map_columns);
        if lighting != self.lighting_cpu {
            self.lighting_cpu = lighting;
            self.lighting_dirty = true;
        }
    }

    /// Sets the address of the particle system's state (`crate::particles`; 0: none). An
    /// unchanged address uploads nothing.
    pub fn set_particles(&mut self, address: u64) {
        if self.lighting_cpu.particles != address {
            self.lighting_cpu.particles = address;
            self.lighting_dirty = true;
        }
    }

    /// Sets the particles' decal ring (`crate::particles`; `None`: no ring, and the addresses
    /// then name this lighting record, which always exists, so that a load a shader compiler
    /// hoists out of its branch reads valid memory). An unchanged ring uploads nothing.
    pub fn set_decal_ring(&mut self, ring: Option<DecalRingFields>) {
        let here = self.lighting.address();
        let r = ring.unwrap_or(DecalRingFields { records: here, boxes: here, tlas: 0, room: 0, segment: 0 });
        let fields = (r.records, r.boxes, r.tlas, r.room, r.segment);
        let l = &mut self.lighting_cpu;
        if (l.decal_ring, l.decal_ring_boxes, l.decal_ring_tlas, l.decal_ring_room, l.decal_ring_segment) != fields {
            (l.decal_ring, l.decal_ring_boxes, l.decal_ring_tlas, l.decal_ring_room, l.decal_ring_segment) = fields;
            self.lighting_dirty = true;
        }
    }

    /// Sets the lighting record's bloom fields (`crate::bloom`): the pyramid's address and
    /// levels, and the intensity (0: no bloom). An unchanged setting uploads nothing.
    pub fn set_bloom(&mut self, address: u64, levels: u32, intensity: f32) {
        let l = &mut self.lighting_cpu;
        if (l.bloom, l.bloom_levels, l.bloom_intensity) != (address, levels, intensity) {
            (l.bloom, l.bloom_levels, l.bloom_intensity) = (address, levels, intensity);
            self.lighting_dirty = true;
        }
    }

    /// Sets the lighting record's auto-exposure fields (`crate::exposure`): its record's address
    /// (0: the camera's exposure) and its compensation, EV100 range and rate. An unchanged
    /// setting uploads nothing.
    pub fn set_exposure(&mut self, address: u64, [compensation, min_ev100, max_ev100, rate]: [f32; 4]) {
        let fields = (address, [compensation, min_ev100, max_ev100, rate]);
        if exposure_fields(&self.lighting_cpu) != fields {
            set_exposure_fields(&mut self.lighting_cpu, fields);
            self.lighting_dirty = true;
        }
    }

    /// Sets the lighting record's address of the display check's counter
    /// (`crate::present::check`; 0: no check), which every later lighting record keeps.
    pub fn set_display_check(&mut self, address: u64) {
        if self.lighting_cpu.display_check != address {
            self.lighting_cpu.display_check = address;
            self.lighting_dirty = true;
        }
    }

    /// Sets how far rays are lifted off rasterised surfaces for levels of detail
    /// (`GpuLighting::lod_lift`, `crate::lod::lift`), which every later lighting record keeps.
    pub fn set_lod_lift(&mut self, lift: f32) {
        if self.lighting_cpu.lod_lift != lift {
            self.lighting_cpu.lod_lift = lift;
            self.lighting_dirty = true;
        }
    }

    /// Sets the lighting record's shadow-map atlas layout (`crate::shadows::maps`): a tile's
    /// side in texels and the tiles across the atlas, which every later lighting record keeps.
    pub fn set_shadow_maps(&mut self, tile: u32, columns: u32) {
        let l = &mut self.lighting_cpu;
        if (l.shadow_map_tile, l.shadow_map_columns) != (tile, columns) {
            (l.shadow_map_tile, l.shadow_map_columns) = (tile, columns);
            self.lighting_dirty = true;
        }
    }

    /// The lighting record as last set.
    pub fn lighting_record(&self) -> &GpuLighting {
        &self.lighting_cpu
    }
}

/// Auto-exposure's fields of a lighting record: its address, then compensation, EV100 range and
/// rate.
pub(super) fn exposure_fields(l: &GpuLighting) -> (u64, [f32; 4]) {
    (l.exposure, [l.exposure_compensation, l.exposure_min_ev100, l.exposure_max_ev100, l.exposure_rate])
}

pub(super) fn set_exposure_fields(l: &mut GpuLighting, (address, [compensation, min_ev100, max_ev100, rate]): (u64, [f32; 4])) {
    (l.exposure, l.exposure_compensation, l.exposure_min_ev100, l.exposure_max_ev100, l.exposure_rate) =
        (address, compensation, min_ev100, max_ev100, rate);
}
