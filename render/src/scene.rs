//! The scene mirror: plain data that describes what the GPU should hold.
//!
//! Extraction (in `plugins`) writes records into stable slots of [`SlotTable`]s and queues mesh and
//! texture uploads; the renderer drains only what is dirty into GPU buffers. Nothing here touches
//! Vulkan, so change detection, slot reuse and the "a quiet frame writes nothing" rule are
//! testable without a GPU. Each `Gpu*` struct is `#[repr(C)]` and mirrored field for field in
//! `shaders/include/scene.glsl` (std430).

use bytemuck::{Pod, Zeroable};
use glam::{Mat4, Vec2, Vec3};

/// The camera as the shaders see it.
#[repr(C)]
#[derive(Clone, Copy, Debug, Pod, Zeroable, PartialEq)]
pub struct GpuCamera {
    /// World to view.
    pub view: Mat4,
    /// View to clip (reverse-Z, infinite far plane).
    pub proj: Mat4,
    /// World to clip.
    pub view_proj: Mat4,
    /// Clip to world.
    pub inv_view_proj: Mat4,
    /// Camera position in world space.
    pub position: Vec3,
    /// Multiplier applied to radiance before tone mapping.
    pub exposure: f32,
    /// Render target size in pixels.
    pub viewport_size: Vec2,
    /// 1 / viewport size.
    pub inv_viewport_size: Vec2,
    /// Uniform ambient radiance (scaled by material occlusion).
    pub ambient: Vec3,
    /// Padding to 16 bytes.
    pub pad: u32,
}

/// One drawn mesh instance.
#[repr(C)]
#[derive(Clone, Copy, Debug, Pod, Zeroable, PartialEq)]
pub struct GpuInstance {
    /// Object to world.
    pub model: Mat4,
    /// Inverse-transpose of `model`, for normals.
    pub normal_model: Mat4,
    /// Slot of the instance's material in the material table.
    pub material: u32,
    /// Decal receiver layers: a decal lands here when its mask shares a bit with these.
    pub decal_layers: u32,
    /// The instance's mesh (its index in the renderer's mesh table; set by the mirror).
    pub mesh: u32,
    /// Padding to 16 bytes.
    pub pad: u32,
}

impl GpuInstance {
    /// The record for an instance placed by `model`, shaded with the material in `material`,
    /// receiving decals on `decal_layers`.
    pub fn new(model: Mat4, material: u32, decal_layers: u32) -> Self {
        Self { model, normal_model: model.inverse().transpose(), material, decal_layers, mesh: 0, pad: 0 }
    }
}

/// Material flag: alpha-tested against `alpha_cutoff`.
pub const MATERIAL_ALPHA_MASK: u32 = 1;
/// Material flag: both faces are drawn and lit.
pub const MATERIAL_DOUBLE_SIDED: u32 = 2;

/// Bindless slot of the built-in 1×1 white texture (a material without a texture samples this).
pub const TEXTURE_WHITE: u32 = 0;
/// Bindless slot of the built-in flat normal map.
pub const TEXTURE_FLAT_NORMAL: u32 = 1;
/// Number of bindless slots the renderer reserves for itself (built-ins and render targets;
/// see `targets::slots`).
pub const RESERVED_TEXTURES: u32 = 16;

/// A metallic-roughness material.
#[repr(C)]
#[derive(Clone, Copy, Debug, Pod, Zeroable, PartialEq)]
pub struct GpuMaterial {
    /// Linear base colour and alpha.
    pub base_color: [f32; 4],
    /// Emitted radiance.
    pub emissive: [f32; 3],
    /// Strength of the normal map's XY.
    pub normal_scale: f32,
    /// Metallic factor.
    pub metallic: f32,
    /// Perceptual roughness factor.
    pub roughness: f32,
    /// Alpha below which masked materials are discarded.
    pub alpha_cutoff: f32,
    /// How much the occlusion texture darkens ambient light.
    pub occlusion_strength: f32,
    /// Bindless slot of the base colour texture (sRGB).
    pub base_color_tex: u32,
    /// Bindless slot of the metallic (B) / roughness (G) texture.
    pub metallic_roughness_tex: u32,
    /// Bindless slot of the tangent-space normal map.
    pub normal_tex: u32,
    /// Bindless slot of the occlusion texture (R).
    pub occlusion_tex: u32,
    /// Bindless slot of the emissive texture (sRGB).
    pub emissive_tex: u32,
    /// `MATERIAL_*` flags.
    pub flags: u32,
    /// Padding to 16 bytes.
    pub pad: [u32; 2],
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
            pad: [0; 2],
        }
    }
}

/// Light kinds as stored in [`GpuLight::kind`].
#[repr(u32)]
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum LightKind {
    /// An empty slot.
    None = 0,
    /// Omnidirectional point light.
    Point = 1,
    /// Cone-shaped spot light.
    Spot = 2,
    /// Infinitely distant light.
    Directional = 3,
}

/// One punctual light.
#[repr(C)]
#[derive(Clone, Copy, Debug, Pod, Zeroable, PartialEq)]
pub struct GpuLight {
    /// World position (point, spot).
    pub position: Vec3,
    /// Distance at which the light's contribution reaches zero.
    pub range: f32,
    /// Colour × intensity (candela; lux for directional lights).
    pub color: Vec3,
    /// A [`LightKind`].
    pub kind: u32,
    /// Direction the light travels (spot, directional), unit length.
    pub direction: Vec3,
    /// 1 / (cos inner − cos outer).
    pub spot_scale: f32,
    /// −cos outer × `spot_scale`.
    pub spot_offset: f32,
    /// Padding to 16 bytes.
    pub pad: [f32; 3],
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
        Self {
            position,
            range,
            color,
            kind: LightKind::Spot as u32,
            direction: direction.normalize_or(Vec3::NEG_Z),
            spot_scale,
            spot_offset: -cos_outer * spot_scale,
            ..Self::zeroed()
        }
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

/// One decal projector (seed 000 §4.1, "reduced form for shading"). The decal's box is
/// `[-0.5, 0.5]³` in decal space; it projects along −Z. A zeroed record (a free slot) has no
/// receiver bits and so never applies.
#[repr(C)]
#[derive(Clone, Copy, Debug, Pod, Zeroable, PartialEq)]
pub struct GpuDecal {
    /// World to decal space.
    pub world_to_decal: Mat4,
    /// UVs of the box corners at local (−x,−y) and (+x,−y).
    pub uv01: [f32; 4],
    /// UVs of the corners at (+x,+y) and (−x,+y).
    pub uv23: [f32; 4],
    /// Slot in the decal material table.
    pub material: u32,
    /// Blending channel 0..=3.
    pub channel: u32,
    /// Weight within the channel.
    pub weight: f32,
    /// Receiver layers the decal lands on.
    pub receivers: u32,
    /// Overall opacity.
    pub opacity: f32,
    /// Angle fade: fade = saturate(cos θ × scale + offset); (0, 1) disables it.
    pub fade_scale: f32,
    /// See `fade_scale`.
    pub fade_offset: f32,
    /// Padding to 16 bytes.
    pub pad: u32,
}

/// Decal material flag: blends albedo.
pub const DECAL_ALBEDO: u32 = 1;
/// Decal material flag: blends normals.
pub const DECAL_NORMAL: u32 = 2;
/// Decal material flag: blends roughness.
pub const DECAL_ROUGHNESS: u32 = 4;
/// Decal material flag: blends metallic.
pub const DECAL_METALLIC: u32 = 8;

/// What a decal applies.
#[repr(C)]
#[derive(Clone, Copy, Debug, Pod, Zeroable, PartialEq)]
pub struct GpuDecalMaterial {
    /// Albedo factor (rgb) and opacity (a).
    pub base_color: [f32; 4],
    /// Bindless slot of the RGBA texture (alpha is coverage).
    pub base_color_tex: u32,
    /// Bindless slot of the normal map.
    pub normal_tex: u32,
    /// Bindless slot of the metallic (B) / roughness (G) texture.
    pub metallic_roughness_tex: u32,
    /// `DECAL_*` flags.
    pub flags: u32,
    /// Normal map XY strength.
    pub normal_scale: f32,
    /// Roughness to blend in.
    pub roughness: f32,
    /// Metallic to blend in.
    pub metallic: f32,
    /// Padding.
    pub pad: f32,
}

/// An axis-aligned box as acceleration-structure builds read it (`VkAabbPositionsKHR`).
#[repr(C)]
#[derive(Clone, Copy, Debug, Pod, Zeroable, PartialEq)]
pub struct GpuAabb {
    /// Minimum corner.
    pub min: [f32; 3],
    /// Maximum corner.
    pub max: [f32; 3],
}

impl GpuAabb {
    /// A zero-size box at `p`.
    pub fn point(p: Vec3) -> Self {
        Self { min: p.to_array(), max: p.to_array() }
    }

    /// The zero-size box at this box's centre.
    pub fn collapsed(&self) -> Self {
        Self::point((Vec3::from(self.min) + Vec3::from(self.max)) * 0.5)
    }

    /// Boxes for never-used slots `first..first + count` of the decal BLAS: distinct points 1 mm
    /// apart on a line through the centroid of `live` (zero-size, so no query ever lands on
    /// them, and near the decals, so a slot's first refit does not stretch the tree across the
    /// world). Coincident padding boxes made NVIDIA's BLAS builds 2.5–3.5× slower (see
    /// docs/BENCHMARKS.md).
    pub fn parking(live: &[GpuAabb], first: u32, count: u32) -> impl Iterator<Item = GpuAabb> {
        let centroid = if live.is_empty() {
            Vec3::ZERO
        } else {
            live.iter().map(|b| (Vec3::from(b.min) + Vec3::from(b.max)) * 0.5).sum::<Vec3>() / live.len() as f32
        };
        (first..first + count).map(move |i| Self::point(centroid + Vec3::new(i as f32 * 1e-3, 0.0, 0.0)))
    }

    /// The AABB of the box `[-0.5, 0.5]³` transformed by `decal_to_world`.
    pub fn of_unit_box(decal_to_world: Mat4) -> Self {
        let centre = decal_to_world.w_axis.truncate();
        let half =
            (decal_to_world.x_axis.truncate().abs() + decal_to_world.y_axis.truncate().abs() + decal_to_world.z_axis.truncate().abs())
                * 0.5;
        Self { min: (centre - half).to_array(), max: (centre + half).to_array() }
    }
}

/// Decal records and their boxes, in the same stable slots: the BLAS primitive index of a box
/// is the index of its record.
#[derive(Default)]
pub struct DecalTable {
    /// Shading records.
    pub records: SlotTable<GpuDecal>,
    /// Boxes for the acceleration structure.
    pub aabbs: SlotTable<GpuAabb>,
}

impl DecalTable {
    /// Writes a decal placed by `decal_to_world` into `slot` (or a new slot).
    pub fn write(&mut self, slot: Option<u32>, decal_to_world: Mat4, mut record: GpuDecal) -> u32 {
        record.world_to_decal = decal_to_world.inverse();
        let aabb = GpuAabb::of_unit_box(decal_to_world);
        match slot {
            Some(slot) => {
                self.records.write(slot, record);
                self.aabbs.write(slot, aabb);
                slot
            }
            None => {
                let slot = self.records.insert(record);
                let aabb_slot = self.aabbs.insert(aabb);
                debug_assert_eq!(slot, aabb_slot, "records and boxes share slots");
                slot
            }
        }
    }

    /// Frees a slot: the record is zeroed (never applies) and the box collapses to its centre,
    /// so the BLAS keeps its primitive count (a refit, not a build) and free boxes stay distinct
    /// and where they were (see `render::decals` on why coincident boxes are avoided).
    pub fn remove(&mut self, slot: u32) {
        if let Some(aabb) = self.aabbs.get(slot).copied() {
            self.aabbs.release_with(slot, aabb.collapsed());
        }
        self.records.remove(slot);
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

/// Where a mesh's vertices and indices live (the visibility buffer fetches them).
#[repr(C)]
#[derive(Clone, Copy, Debug, Default, Pod, Zeroable, PartialEq)]
pub struct GpuMeshInfo {
    /// Device address of the first vertex.
    pub vertices: u64,
    /// Device address of the first index.
    pub indices: u64,
}

/// One vertex as the mesh pipelines read it (binding 0, interleaved).
#[repr(C)]
#[derive(Clone, Copy, Debug, Pod, Zeroable, PartialEq)]
pub struct GpuVertex {
    /// Object-space position.
    pub position: [f32; 3],
    /// Object-space normal.
    pub normal: [f32; 3],
    /// Texture coordinate 0.
    pub uv: [f32; 2],
    /// Object-space tangent; w is the bitangent sign.
    pub tangent: [f32; 4],
}

/// Geometry to upload: interleaved vertices and a triangle list.
#[derive(Clone, Debug, Default)]
pub struct MeshData {
    /// Vertices.
    pub vertices: Vec<GpuVertex>,
    /// Triangle list indices.
    pub indices: Vec<u32>,
}

/// Pixels to upload: RGBA8, a full or partial mip chain, level 0 first.
#[derive(Clone, Debug)]
pub struct TextureData {
    /// Width of level 0.
    pub width: u32,
    /// Height of level 0.
    pub height: u32,
    /// Whether texels are sRGB-encoded colour (sampled as linear by the hardware).
    pub srgb: bool,
    /// One RGBA8 buffer per mip level.
    pub mips: Vec<Vec<u8>>,
}

/// Identifies an uploaded mesh.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash, PartialOrd, Ord)]
pub struct MeshId(pub u32);

/// What the renderer draws for one instance slot.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct DrawItem {
    /// The geometry.
    pub mesh: MeshId,
    /// Alpha-tested in the depth prepass.
    pub alpha_mask: bool,
    /// Drawn without back-face culling.
    pub double_sided: bool,
}

/// Work counters for one frame. Tests, `--stats` and the overlay read these; keys never change
/// meaning.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct FrameCounters {
    /// Bytes copied from the CPU to GPU memory this frame (records, meshes, textures).
    pub bytes_uploaded: u64,
    /// Records (instances, materials, lights, camera, decals) written this frame.
    pub records_written: u64,
    /// Bottom-level acceleration structure builds.
    pub blas_builds: u64,
    /// Bottom-level acceleration structure updates (refits).
    pub blas_updates: u64,
    /// Top-level acceleration structure builds.
    pub tlas_builds: u64,
    /// Live mesh instances.
    pub instances: u64,
    /// Live lights.
    pub lights: u64,
    /// Live decals.
    pub decals: u64,
}

/// Records in stable slots with a free list, plus the set of slots written since the last drain.
///
/// `alloc` reuses the lowest freed slot first (a binary heap would be overkill: the free list is
/// a stack, which keeps recently freed, cache-warm slots in use). A slot is dirty from `write`
/// or `free` until [`SlotTable::take_dirty`] hands it to the uploader.
#[derive(Clone, Debug)]
pub struct SlotTable<T: Pod> {
    records: Vec<T>,
    live: Vec<bool>,
    free: Vec<u32>,
    dirty: Vec<u32>,
    is_dirty: Vec<bool>,
    live_count: usize,
}

impl<T: Pod> Default for SlotTable<T> {
    fn default() -> Self {
        Self { records: Vec::new(), live: Vec::new(), free: Vec::new(), dirty: Vec::new(), is_dirty: Vec::new(), live_count: 0 }
    }
}

impl<T: Pod> SlotTable<T> {
    /// Takes a free slot (or appends one) and writes `record` into it.
    pub fn insert(&mut self, record: T) -> u32 {
        let slot = match self.free.pop() {
            Some(slot) => slot,
            None => {
                self.records.push(T::zeroed());
                self.live.push(false);
                self.is_dirty.push(false);
                (self.records.len() - 1) as u32
            }
        };
        self.live[slot as usize] = true;
        self.live_count += 1;
        self.write(slot, record);
        slot
    }

    /// Overwrites a live slot. Panics on a slot that was never allocated (a bug in the caller).
    pub fn write(&mut self, slot: u32, record: T) {
        let i = slot as usize;
        debug_assert!(self.live[i], "write to a free slot {slot}");
        self.records[i] = record;
        self.mark_dirty(slot);
    }

    /// Releases a slot; its record is zeroed (an empty light, an unused instance) and uploaded.
    pub fn remove(&mut self, slot: u32) {
        self.release_with(slot, T::zeroed());
    }

    /// Releases a slot, leaving `parked` in it (uploaded like any record) until it is reused.
    pub fn release_with(&mut self, slot: u32, parked: T) {
        let i = slot as usize;
        if !self.live.get(i).copied().unwrap_or(false) {
            return;
        }
        self.live[i] = false;
        self.live_count -= 1;
        self.records[i] = parked;
        self.mark_dirty(slot);
        self.free.push(slot);
    }

    fn mark_dirty(&mut self, slot: u32) {
        let flag = &mut self.is_dirty[slot as usize];
        if !*flag {
            *flag = true;
            self.dirty.push(slot);
        }
    }

    /// The record in `slot`.
    pub fn get(&self, slot: u32) -> Option<&T> {
        self.live.get(slot as usize).copied().unwrap_or(false).then(|| &self.records[slot as usize])
    }

    /// All slots, live or free, as one contiguous array (what the GPU buffer holds).
    pub fn records(&self) -> &[T] {
        &self.records
    }

    /// Number of slots ever allocated (the GPU buffer must hold this many).
    pub fn slot_count(&self) -> u32 {
        self.records.len() as u32
    }

    /// Number of live records.
    pub fn len(&self) -> usize {
        self.live_count
    }

    /// True when no record is live.
    pub fn is_empty(&self) -> bool {
        self.live_count == 0
    }

    /// Number of slots written since the last drain.
    pub fn dirty_count(&self) -> usize {
        self.dirty.len()
    }

    /// Sorts the dirty slots, passes them to `f` (which copies them out), then clears them.
    pub fn take_dirty(&mut self, mut f: impl FnMut(&[u32], &[T])) {
        self.dirty.sort_unstable();
        f(&self.dirty, &self.records);
        for &slot in &self.dirty {
            self.is_dirty[slot as usize] = false;
        }
        self.dirty.clear();
    }
}

/// Everything extraction produces for the renderer: the CPU copy of the GPU scene.
#[derive(Default)]
pub struct SceneMirror {
    /// Mesh instances.
    pub instances: SlotTable<GpuInstance>,
    /// What to draw for each instance slot (`None` for free slots).
    pub draws: Vec<Option<DrawItem>>,
    /// Materials.
    pub materials: SlotTable<GpuMaterial>,
    /// Lights.
    pub lights: SlotTable<GpuLight>,
    /// Decals and their boxes.
    pub decals: DecalTable,
    /// Decal materials.
    pub decal_materials: SlotTable<GpuDecalMaterial>,
    camera: GpuCamera,
    camera_dirty: bool,
    /// Meshes waiting for upload.
    pub pending_meshes: Vec<(MeshId, MeshData)>,
    /// Meshes to free once the GPU is done with them.
    pub released_meshes: Vec<MeshId>,
    /// Textures waiting for upload, by bindless slot.
    pub pending_textures: Vec<(u32, TextureData)>,
    /// Bindless slots to free once the GPU is done with them.
    pub released_textures: Vec<u32>,
    next_mesh: u32,
    free_meshes: Vec<u32>,
    next_texture: u32,
    free_textures: Vec<u32>,
    /// This frame's counters; extraction adds `records_written`, the renderer the rest.
    pub counters: FrameCounters,
}

impl Default for GpuCamera {
    fn default() -> Self {
        Self::zeroed()
    }
}

impl SceneMirror {
    /// An empty scene.
    pub fn new() -> Self {
        Self { next_texture: RESERVED_TEXTURES, ..Default::default() }
    }

    /// Adds or replaces the draw of an instance slot.
    pub fn set_instance(&mut self, slot: Option<u32>, mut record: GpuInstance, draw: DrawItem) -> u32 {
        record.mesh = draw.mesh.0;
        let slot = match slot {
            Some(slot) => {
                self.instances.write(slot, record);
                slot
            }
            None => self.instances.insert(record),
        };
        if self.draws.len() <= slot as usize {
            self.draws.resize(slot as usize + 1, None);
        }
        self.draws[slot as usize] = Some(draw);
        self.counters.records_written += 1;
        slot
    }

    /// Frees an instance slot.
    pub fn remove_instance(&mut self, slot: u32) {
        self.instances.remove(slot);
        if let Some(d) = self.draws.get_mut(slot as usize) {
            *d = None;
        }
        self.counters.records_written += 1;
    }

    /// Writes a record into a table, counting it.
    pub fn write<T: Pod>(counters: &mut FrameCounters, table: &mut SlotTable<T>, slot: Option<u32>, record: T) -> u32 {
        counters.records_written += 1;
        match slot {
            Some(slot) => {
                table.write(slot, record);
                slot
            }
            None => table.insert(record),
        }
    }

    /// The camera record.
    pub fn camera(&self) -> &GpuCamera {
        &self.camera
    }

    /// Replaces the camera record if it differs; an unchanged camera uploads nothing.
    pub fn set_camera(&mut self, camera: GpuCamera) {
        if camera != self.camera {
            self.camera = camera;
            self.camera_dirty = true;
            self.counters.records_written += 1;
        }
    }

    /// Returns whether the camera changed since the last call, clearing the flag.
    pub fn take_camera_dirty(&mut self) -> bool {
        std::mem::take(&mut self.camera_dirty)
    }

    /// Queues geometry for upload and returns its id.
    pub fn add_mesh(&mut self, data: MeshData) -> MeshId {
        let id = MeshId(self.free_meshes.pop().unwrap_or_else(|| {
            self.next_mesh += 1;
            self.next_mesh - 1
        }));
        self.pending_meshes.push((id, data));
        id
    }

    /// Frees a mesh; the id is reused after the GPU has finished with it.
    pub fn remove_mesh(&mut self, id: MeshId) {
        self.pending_meshes.retain(|(m, _)| *m != id);
        self.released_meshes.push(id);
        self.free_meshes.push(id.0);
    }

    /// Queues pixels for upload and returns their bindless slot.
    pub fn add_texture(&mut self, data: TextureData) -> u32 {
        let slot = self.free_textures.pop().unwrap_or_else(|| {
            self.next_texture += 1;
            self.next_texture - 1
        });
        self.pending_textures.push((slot, data));
        slot
    }

    /// Frees a bindless slot. The renderer hands it back through
    /// [`SceneMirror::recycle_texture_slot`] once no frame in flight can sample it.
    pub fn remove_texture(&mut self, slot: u32) {
        self.pending_textures.retain(|(s, _)| *s != slot);
        self.released_textures.push(slot);
    }

    /// Makes a released bindless slot available again (called by the renderer).
    pub fn recycle_texture_slot(&mut self, slot: u32) {
        self.free_textures.push(slot);
    }

    /// Starts a new frame's counters.
    pub fn begin_frame(&mut self) {
        self.counters = FrameCounters::default();
    }

    /// Forgets every pending upload, as if an uploader had copied it all (for uploaders other
    /// than the GPU renderer, and for tests without a GPU).
    pub fn clear_dirty(&mut self) {
        self.instances.take_dirty(|_, _| {});
        self.materials.take_dirty(|_, _| {});
        self.lights.take_dirty(|_, _| {});
        self.decals.records.take_dirty(|_, _| {});
        self.decals.aabbs.take_dirty(|_, _| {});
        self.decal_materials.take_dirty(|_, _| {});
        self.camera_dirty = false;
        self.pending_meshes.clear();
        self.pending_textures.clear();
    }

    /// True when the renderer has nothing to upload.
    pub fn is_clean(&self) -> bool {
        self.instances.dirty_count() == 0
            && self.materials.dirty_count() == 0
            && self.lights.dirty_count() == 0
            && self.decals.records.dirty_count() == 0
            && self.decals.aabbs.dirty_count() == 0
            && self.decal_materials.dirty_count() == 0
            && !self.camera_dirty
            && self.pending_meshes.is_empty()
            && self.pending_textures.is_empty()
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn slots_are_stable_and_reused() {
        let mut t = SlotTable::<u32>::default();
        let a = t.insert(1);
        let b = t.insert(2);
        let c = t.insert(3);
        assert_eq!((a, b, c), (0, 1, 2));
        t.remove(b);
        assert_eq!(t.get(b), None);
        assert_eq!(t.get(c), Some(&3), "other slots keep their place");
        assert_eq!(t.insert(4), b, "a freed slot is reused");
        assert_eq!(t.len(), 3);
    }

    #[test]
    fn dirty_slots_are_deduplicated_sorted_and_cleared() {
        let mut t = SlotTable::<u32>::default();
        for i in 0..5 {
            t.insert(i);
        }
        t.take_dirty(|_, _| {});
        t.write(3, 30);
        t.write(1, 10);
        t.write(3, 31);
        let mut seen = Vec::new();
        t.take_dirty(|slots, records| seen.extend(slots.iter().map(|&s| (s, records[s as usize]))));
        assert_eq!(seen, vec![(1, 10), (3, 31)]);
        assert_eq!(t.dirty_count(), 0);
    }

    #[test]
    fn unchanged_camera_is_not_dirty() {
        let mut m = SceneMirror::new();
        let cam = GpuCamera { exposure: 1.0, ..Default::default() };
        m.set_camera(cam);
        assert!(m.take_camera_dirty());
        m.begin_frame();
        m.set_camera(cam);
        assert!(!m.take_camera_dirty());
        assert_eq!(m.counters.records_written, 0);
    }

    #[test]
    fn record_sizes_match_the_shaders() {
        // std430 sizes of the structs in shaders/include/scene.glsl.
        assert_eq!(std::mem::size_of::<GpuCamera>(), 4 * 64 + 48);
        assert_eq!(std::mem::size_of::<GpuInstance>(), 144);
        assert_eq!(std::mem::size_of::<GpuMaterial>(), 80);
        assert_eq!(std::mem::size_of::<GpuLight>(), 64);
        assert_eq!(std::mem::size_of::<GpuVertex>(), 48);
        assert_eq!(std::mem::size_of::<GpuDecal>(), 128);
        assert_eq!(std::mem::size_of::<GpuDecalMaterial>(), 48);
        assert_eq!(std::mem::size_of::<GpuAabb>(), 24);
    }

    #[test]
    fn decal_boxes_bound_their_oriented_box() {
        let m = Mat4::from_scale_rotation_translation(
            Vec3::new(2.0, 1.0, 0.5),
            glam::Quat::from_rotation_y(0.7) * glam::Quat::from_rotation_x(0.3),
            Vec3::new(1.0, 2.0, 3.0),
        );
        let aabb = GpuAabb::of_unit_box(m);
        for i in 0..8 {
            let c =
                Vec3::new(if i & 1 == 0 { -0.5 } else { 0.5 }, if i & 2 == 0 { -0.5 } else { 0.5 }, if i & 4 == 0 { -0.5 } else { 0.5 });
            let p = m.transform_point3(c);
            for a in 0..3 {
                assert!(p[a] >= aabb.min[a] - 1e-5 && p[a] <= aabb.max[a] + 1e-5, "corner {p} inside {aabb:?}");
            }
        }
        // Tight: some corner touches each face.
        for a in 0..3 {
            let touches = (0..8).any(|i| {
                let c = Vec3::new(
                    if i & 1 == 0 { -0.5 } else { 0.5 },
                    if i & 2 == 0 { -0.5 } else { 0.5 },
                    if i & 4 == 0 { -0.5 } else { 0.5 },
                );
                (m.transform_point3(c)[a] - aabb.max[a]).abs() < 1e-5
            });
            assert!(touches, "axis {a} is tight");
        }
    }
}
