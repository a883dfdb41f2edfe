//! The scene mirror: plain data that describes what the GPU should hold.
//!
//! Extraction (in `plugins`) writes records into stable slots of [`SlotTable`]s and queues mesh and
//! texture uploads; the renderer drains only what is dirty into GPU buffers. Nothing here touches
//! Vulkan, so change detection, slot reuse and the "a quiet frame writes nothing" rule are
//! testable without a GPU. The `Gpu*` records and shared constants are defined once in
//! [`crate::layout`], which also generates their GLSL; they are re-exported here.
//!
//! | file | holds |
//! | --- | --- |
//! | `mod.rs` | the [`SceneMirror`]: its tables, the changes it queues, the blended instances' order |
//! | `slots.rs` | [`SlotTable`]: records in stable slots, dirty slots, trimming |
//! | `records.rs` | constructors of the `Gpu*` records (instances, materials, lights, decals, the camera) |
//! | `decals.rs` | [`DecalDesc`] and the [`DecalTable`] of decal records and boxes |
//! | `meshes.rs` | meshes and textures waiting for upload, [`MeshId`], [`DrawItem`] |
//! | [`poses`], [`environment`] | the poses and the environment a game sets |
//! | [`gpu`], [`pool`] | the GPU side: tables, the mesh pool, bindless textures |

pub mod bc;
mod decals;
pub mod emitters;
pub mod environment;
pub mod gpu;
mod meshes;
pub mod pool;
pub mod poses;
mod records;
mod slots;
pub mod vertex;

use std::collections::BTreeSet;

use bytemuck::Pod;
use glam::{Mat4, Vec2, Vec3};

pub use decals::{DecalDesc, DecalTable, PreparedDecal, pack_half2};
pub use meshes::{DrawItem, MeshData, MeshId, MeshLods, TextureData, level_bytes};
pub use records::LightKind;
pub use slots::SlotTable;
pub use vertex::{UvRange, Vertex};

pub use crate::layout::{
    CULL_BATCHES, CULL_DOUBLE_SIDED, CULL_LEVEL_MASK, CULL_LEVEL_SHIFT, CULL_LIVE, CULL_MASKED, CULL_TRANSPARENT, DECAL_ALBEDO,
    DECAL_CHANNEL_SHIFT, DECAL_CHANNELS, DECAL_DEFAULT_LAYERS, DECAL_EMISSIVE, DECAL_METALLIC, DECAL_NORMAL, DECAL_ON_SKIN,
    DECAL_ROUGHNESS, GpuAabb, GpuCamera, GpuCullRecord, GpuDecal, GpuDecalMaterial, GpuDrawCommand, GpuInstance, GpuJointMatrix, GpuLight,
    GpuMaterial, GpuMeshInfo, GpuMorphDelta, GpuMover, GpuSkinVertex, GpuVertex, LOD_LEVELS, MATERIAL_ALPHA_MASK, MATERIAL_BLEND,
    MATERIAL_DOUBLE_SIDED, NO_DECAL, RESERVED_TEXTURES, TEXTURE_FLAT_NORMAL, TEXTURE_WHITE,
};

/// Everything extraction produces for the renderer: the CPU copy of the GPU scene.
#[derive(Default)]
pub struct SceneMirror {
    /// Mesh instances.
    pub instances: SlotTable<GpuInstance>,
    /// What GPU culling knows of each instance slot: world bounds, mesh and batch flags, kept in
    /// step with `instances` (the same slots; written when the transform, mesh or draw changed).
    pub culls: SlotTable<GpuCullRecord>,
    /// Live instances in each opaque draw batch ([`DrawItem::batch`]), kept as draws change: the
    /// culling lists are laid out from them without visiting the instances.
    pub batch_counts: [u32; CULL_BATCHES as usize],
    /// Live instances whose mesh has coarser levels of detail (`render/src/lod`), kept as draws
    /// change: while there are none, rays leave surfaces unlifted by the level-of-detail limit.
    pub lod_instances: u32,
    /// By mesh id: whether the mesh has coarser levels of detail (a posed mesh: its source).
    mesh_has_levels: Vec<bool>,
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
    /// Particle emitters (`crate::particles` moves and draws their particles).
    pub emitters: emitters::Emitters,
    camera: GpuCamera,
    camera_dirty: bool,
    /// Temporal anti-aliasing's part of the camera record: this frame's jitter (NDC) and the
    /// previous frame's unjittered view-projection ([`SceneMirror::set_camera_temporal`]).
    temporal: (Vec2, Option<Mat4>, u32),
    /// Where (NDC, from the pixel's centre) the depth target's value of a pixel was taken:
    /// MSAA resolves depth to sample 0 ([`SceneMirror::set_depth_sample`]).
    depth_sample: Vec2,
    /// Set by [`SceneMirror::cut_camera`]: the view jumped, so history is thrown away.
    camera_cut: bool,
    /// Instances that moved since the last upload, and the transforms they had then (the
    /// motion-vector pass draws them: `crate::motion`).
    pub movers: Movers,
    /// By mesh id: the instance slot that draws a posed mesh (`u32::MAX`: none), so that its
    /// skinning makes it a mover.
    posed_slots: Vec<u32>,
    /// What lights the scene from all around (`None`: the flat ambient colour).
    environment: Option<environment::Environment>,
    /// Meshes waiting for upload.
    pub pending_meshes: Vec<(MeshId, MeshData)>,
    /// Posed meshes waiting for a place in the pool: (posed mesh, its skinned source).
    pub pending_posed: Vec<(MeshId, MeshId)>,
    /// Skinned meshes' joint bounds and posed meshes' joint matrices.
    pub poses: poses::PoseTable,
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
    /// Records written into the tables since [`SceneMirror::begin_frame`] (extraction's and the
    /// renderer's writes alike); the frame's report counts them (`FrameCounters::records_written`).
    pub records_written: u64,
    /// Set when an instance was added or removed or changed its mesh or material (not only its
    /// transform): the scene TLAS is then rebuilt rather than updated.
    instances_rearranged: bool,
    /// Live instances whose receiver layers are not `DECAL_DEFAULT_LAYERS`.
    layered_instances: u32,
    /// Object-space bounds (minimum and maximum corner) of each mesh, by mesh id: culling's
    /// world bounds come from them, and the transparent sort from their centres.
    mesh_bounds: Vec<(Vec3, Vec3)>,
    /// Slots of the transparent instances, kept as draws change, so the per-frame sort visits
    /// the glass only.
    transparent: BTreeSet<u32>,
    /// This frame's transparent instances as (distance from the eye, slot), and their slots back
    /// to front: kept so that sorting every frame allocates nothing once they have grown.
    transparent_keys: Vec<(f32, u32)>,
    transparent_order: Vec<u32>,
}

/// Instances that moved since the last upload, each once, with the transform it had at that
/// upload (what its motion vectors measure from). Kept without allocating once grown.
#[derive(Default)]
pub struct Movers {
    list: Vec<(u32, Mat4)>,
    /// By slot: its place in `list` + 1 (0: not there).
    place: Vec<u32>,
}

impl Movers {
    /// Notes that `slot` moved from `prev` (only its first move since the last upload counts).
    fn moved(&mut self, slot: u32, prev: Mat4) {
        let i = slot as usize;
        if self.place.len() <= i {
            self.place.resize(i + 1, 0);
        }
        if self.place[i] == 0 {
            self.list.push((slot, prev));
            self.place[i] = self.list.len() as u32;
        }
    }

    /// Drops `slot` from the list (its instance was removed).
    fn forget(&mut self, slot: u32) {
        let Some(&place) = self.place.get(slot as usize).filter(|&&p| p > 0) else { return };
        self.place[slot as usize] = 0;
        self.list.swap_remove(place as usize - 1);
        if let Some(&(moved, _)) = self.list.get(place as usize - 1) {
            self.place[moved as usize] = place;
        }
    }

    /// The previous transform of `slot`, if it moved.
    pub fn prev_model(&self, slot: u32) -> Option<Mat4> {
        let place = *self.place.get(slot as usize)?;
        (place > 0).then(|| self.list[place as usize - 1].1)
    }

    /// The instances that moved, with their previous transforms.
    pub fn iter(&self) -> impl Iterator<Item = (u32, Mat4)> + '_ {
        self.list.iter().copied()
    }

    /// How many moved.
    pub fn len(&self) -> usize {
        self.list.len()
    }

    /// Whether none moved.
    pub fn is_empty(&self) -> bool {
        self.list.is_empty()
    }

    /// Forgets them (after the upload that took them).
    pub fn clear(&mut self) {
        for &(slot, _) in &self.list {
            self.place[slot as usize] = 0;
        }
        self.list.clear();
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
        if let Some(slot) = slot {
            self.forget_layers(slot);
        }
        self.layered_instances += u32::from(Self::has_layers(&record, draw));
        let cull = self.cull_record(&record.model, draw);
        let slot = match slot {
            Some(slot) => {
                let same_material = self.instances.get(slot).is_some_and(|old| old.material == record.material);
                let old = self.draws.get(slot as usize).copied().flatten();
                self.instances_rearranged |= !(same_material && old == Some(draw));
                self.count_batch(old, -1);
                if let Some(prev) = self.instances.get(slot).map(|i| i.model).filter(|m| *m != record.model) {
                    self.movers.moved(slot, prev);
                }
                self.instances.write(slot, record);
                self.culls.write(slot, cull);
                slot
            }
            None => {
                self.instances_rearranged = true;
                let slot = self.instances.insert(record);
                let cull_slot = self.culls.insert(cull);
                debug_assert_eq!(slot, cull_slot, "the culling records keep the instances' slots");
                slot
            }
        };
        if self.draws.len() <= slot as usize {
            self.draws.resize(slot as usize + 1, None);
        }
        self.draws[slot as usize] = Some(draw);
        if self.poses.is_posed(draw.mesh) {
            let m = draw.mesh.0 as usize;
            if self.posed_slots.len() <= m {
                self.posed_slots.resize(m + 1, u32::MAX);
            }
            self.posed_slots[m] = slot;
        }
        self.count_batch(Some(draw), 1);
        self.note_transparency(slot, draw.transparent);
        self.records_written += 1;
        slot
    }

    /// Rewrites the culling record of a live instance slot from its mesh's current bounds (a
    /// posed mesh's follow its pose: [`SceneMirror::set_pose`]); nothing else is written.
    pub fn refresh_cull(&mut self, slot: u32) {
        let (Some(&record), Some(&Some(draw))) = (self.instances.get(slot), self.draws.get(slot as usize)) else { return };
        let cull = self.cull_record(&record.model, draw);
        if self.culls.get(slot) != Some(&cull) {
            self.culls.write(slot, cull);
            self.records_written += 1;
        }
    }

    /// The culling record of an instance placed by `model` and drawn as `draw`: its mesh's
    /// bounds in world space (an empty or unknown mesh gets an empty box at its origin).
    fn cull_record(&self, model: &Mat4, draw: DrawItem) -> GpuCullRecord {
        let (lo, hi) = self.mesh_bounds.get(draw.mesh.0 as usize).copied().unwrap_or((Vec3::ZERO, Vec3::ZERO));
        let center = model.transform_point3((lo + hi) * 0.5);
        let half = (hi - lo) * 0.5;
        let extent =
            model.x_axis.truncate().abs() * half.x + model.y_axis.truncate().abs() * half.y + model.z_axis.truncate().abs() * half.z;
        GpuCullRecord { min: center - extent, flags: self.cull_flags(draw), max: center + extent, mesh: draw.mesh.0 }
    }

    /// The culling flags of an instance drawn as `draw`: its batch's, and the finest level of
    /// detail its posed mesh's vertices hold.
    fn cull_flags(&self, draw: DrawItem) -> u32 {
        draw.cull_flags() | self.poses.drawable_level(draw.mesh).min(CULL_LEVEL_MASK) << CULL_LEVEL_SHIFT
    }

    /// Sets the level of detail whose vertices each of this frame's skinning jobs skins
    /// ([`poses::PoseTable::set_levels`]: `choose(posed mesh, its culling record, its source's levels)`
    /// for a job that may skin fewer), and rewrites the culling records of the instances whose
    /// finest drawable level changed. `changed` is scratch. Returns the most vertices a job
    /// skins.
    pub fn set_skin_levels(
        &mut self,
        mut choose: impl FnMut(MeshId, Option<&GpuCullRecord>, &poses::SkinLevels) -> u32,
        changed: &mut Vec<MeshId>,
    ) -> u32 {
        changed.clear();
        let (poses, culls, posed_slots) = (&mut self.poses, &self.culls, &self.posed_slots);
        let most = poses.set_levels(
            |mesh, levels| {
                let slot = posed_slots.get(mesh.0 as usize).copied().filter(|&s| s != u32::MAX);
                choose(mesh, slot.and_then(|s| culls.get(s)), levels)
            },
            changed,
        );
        for &mesh in changed.iter() {
            if let Some(slot) = self.posed_slot(mesh) {
                self.refresh_cull(slot);
            }
        }
        most
    }

    fn count_batch(&mut self, draw: Option<DrawItem>, delta: i32) {
        if draw.is_some_and(|d| self.mesh_has_levels.get(d.mesh.0 as usize).copied().unwrap_or(false)) {
            self.lod_instances = self.lod_instances.saturating_add_signed(delta);
        }
        if let Some(batch) = draw.and_then(|d| d.batch()) {
            self.batch_counts[batch] = self.batch_counts[batch].wrapping_add_signed(delta);
        }
    }

    /// Changes the draw item of a live instance slot in place (its material's alpha mode or
    /// sidedness changed); nothing is uploaded.
    pub fn update_draw(&mut self, slot: u32, update: impl FnOnce(&mut DrawItem)) {
        let Some(Some(draw)) = self.draws.get_mut(slot as usize) else { return };
        let old = *draw;
        update(draw);
        let new = *draw;
        if new == old {
            return;
        }
        if let Some(record) = self.instances.get(slot) {
            let (was, is) = (Self::has_layers(record, old), Self::has_layers(record, new));
            self.layered_instances = self.layered_instances + u32::from(is) - u32::from(was);
        }
        self.count_batch(Some(old), -1);
        self.count_batch(Some(new), 1);
        self.note_transparency(slot, new.transparent);
        // Culling must draw it in its new batch: only the flags of its record change.
        if let Some(&record) = self.culls.get(slot) {
            self.culls.write(slot, GpuCullRecord { flags: self.cull_flags(new), ..record });
        }
    }

    fn note_transparency(&mut self, slot: u32, transparent: bool) {
        if transparent {
            self.transparent.insert(slot);
        } else {
            self.transparent.remove(&slot);
        }
    }

    /// Frees an instance slot.
    pub fn remove_instance(&mut self, slot: u32) {
        self.instances_rearranged = true;
        self.forget_layers(slot);
        self.instances.remove(slot);
        self.culls.remove(slot);
        // A slot taken again this frame must not inherit the removed instance's motion.
        self.movers.forget(slot);
        if let Some(d) = self.draws.get_mut(slot as usize) {
            let old = d.take();
            self.count_batch(old, -1);
        }
        self.transparent.remove(&slot);
        self.records_written += 1;
    }

    /// Whether an instance counts in `layered_instances`: opaque (the decal pass sees only the
    /// prepass's surfaces; glass, which receives no decals by default, takes its decals in its
    /// own shading) with receiver layers of its own.
    fn has_layers(record: &GpuInstance, draw: DrawItem) -> bool {
        !draw.transparent && record.decal_layers != DECAL_DEFAULT_LAYERS
    }

    fn forget_layers(&mut self, slot: u32) {
        let (Some(record), Some(&Some(draw))) = (self.instances.get(slot), self.draws.get(slot as usize)) else { return };
        if Self::has_layers(record, draw) {
            self.layered_instances -= 1;
        }
    }

    /// Whether a decal pass must know each pixel's instance: some instance has receiver layers
    /// of its own, or some decal sits on a skin. Otherwise every pixel receives the decals of
    /// `DECAL_DEFAULT_LAYERS`, and the forward pipelines' decal pass reads depth alone, with no
    /// ids prepass (`crate::decals::Surface::Depth`).
    pub fn decals_need_instances(&self) -> bool {
        self.layered_instances > 0 || self.decals.any_on_skin()
    }

    /// Writes a record into a table, counting it in `records_written` (the mirror's, passed apart
    /// so that a table of the same mirror can be borrowed beside it).
    pub fn write<T: Pod>(records_written: &mut u64, table: &mut SlotTable<T>, slot: Option<u32>, record: T) -> u32 {
        *records_written += 1;
        match slot {
            Some(slot) => {
                table.write(slot, record);
                slot
            }
            None => table.insert(record),
        }
    }

    /// Returns whether instances were added, removed or given another mesh or material since
    /// the last call (not just moved), clearing the flag.
    pub fn take_instances_rearranged(&mut self) -> bool {
        std::mem::take(&mut self.instances_rearranged)
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
            self.records_written += 1;
        }
    }

    /// The environment ([`crate::environment`]); `None` lights with the flat ambient colour
    /// and draws the clear colour behind the scene.
    pub fn environment(&self) -> Option<&environment::Environment> {
        self.environment.as_ref()
    }

    /// Sets the environment. A new source (or, for the procedural sky, a new sun) is filtered
    /// once, on the next frame; intensity and rotation cost nothing.
    pub fn set_environment(&mut self, environment: Option<environment::Environment>) {
        self.environment = environment;
    }

    /// The camera record the GPU reads: [`SceneMirror::camera`] with temporal anti-aliasing's
    /// jitter applied to its projection and the previous frame's view-projection beside it.
    /// Its inverse rebuilds a pixel's position from depth where the depth was taken (the
    /// pixel's centre, or MSAA's sample 0).
    pub fn gpu_camera(&self) -> GpuCamera {
        let c = self.camera;
        let (jitter, prev, taa_frame) = self.temporal;
        let shift = Mat4::from_translation(jitter.extend(0.0));
        let view_proj = shift * c.view_proj;
        let inv_view_proj = match (jitter, self.depth_sample) {
            (Vec2::ZERO, Vec2::ZERO) => c.inv_view_proj,
            (_, sample) => view_proj.inverse() * Mat4::from_translation(sample.extend(0.0)),
        };
        GpuCamera {
            proj: shift * c.proj,
            view_proj,
            inv_view_proj,
            jitter,
            taa_frame,
            motion_view_proj: c.view_proj,
            prev_view_proj: prev.unwrap_or(c.view_proj),
            ..c
        }
    }

    /// Sets temporal anti-aliasing's part of the camera record: the sub-pixel `jitter` (NDC),
    /// the previous frame's unjittered view-projection (`None`: no history) and its frame
    /// count (`GpuCamera::taa_frame`; 0 without it). Uploads only when it changed.
    pub fn set_camera_temporal(&mut self, jitter: Vec2, prev_view_proj: Option<Mat4>, frame: u32) {
        if self.temporal != (jitter, prev_view_proj, frame) {
            self.temporal = (jitter, prev_view_proj, frame);
            self.camera_dirty = true;
        }
    }

    /// Sets where the depth target's value of a pixel is taken, as an offset from the pixel's
    /// centre in NDC (zero but under MSAA). Uploads only when it changed.
    pub fn set_depth_sample(&mut self, offset: Vec2) {
        if self.depth_sample != offset {
            self.depth_sample = offset;
            self.camera_dirty = true;
        }
    }

    /// Says that the view jumped (a cut to another shot, a teleport): the next frame throws
    /// temporal history away instead of smearing the old view into the new one.
    pub fn cut_camera(&mut self) {
        self.camera_cut = true;
    }

    /// Returns whether [`SceneMirror::cut_camera`] was called since the last call.
    pub fn take_camera_cut(&mut self) -> bool {
        std::mem::take(&mut self.camera_cut)
    }

    /// The instance slot that draws posed mesh `mesh`, if one does.
    pub fn posed_slot(&self, mesh: MeshId) -> Option<u32> {
        let slot = *self.posed_slots.get(mesh.0 as usize)?;
        (slot != u32::MAX && self.draws.get(slot as usize).copied().flatten().is_some_and(|d| d.mesh == mesh)).then_some(slot)
    }

    /// Returns whether the camera changed since the last call, clearing the flag.
    pub fn take_camera_dirty(&mut self) -> bool {
        std::mem::take(&mut self.camera_dirty)
    }

    fn new_mesh_id(&mut self, bounds: (Vec3, Vec3)) -> MeshId {
        let id = MeshId(self.free_meshes.pop().unwrap_or_else(|| {
            self.next_mesh += 1;
            self.next_mesh - 1
        }));
        if self.mesh_bounds.len() <= id.0 as usize {
            self.mesh_bounds.resize(id.0 as usize + 1, (Vec3::ZERO, Vec3::ZERO));
        }
        self.mesh_bounds[id.0 as usize] = bounds;
        self.set_has_levels(id, false);
        id
    }

    fn set_has_levels(&mut self, id: MeshId, levels: bool) {
        if self.mesh_has_levels.len() <= id.0 as usize {
            self.mesh_has_levels.resize(id.0 as usize + 1, false);
        }
        self.mesh_has_levels[id.0 as usize] = levels;
    }

    /// Queues geometry for upload and returns its id. A mesh with joints and weights
    /// ([`MeshData::skin`], one per vertex; otherwise they are dropped) can be posed.
    pub fn add_mesh(&mut self, mut data: MeshData) -> MeshId {
        let (lo, hi) = data.vertices.iter().fold((Vec3::INFINITY, Vec3::NEG_INFINITY), |(lo, hi), v| {
            let p = Vec3::from(v.position);
            (lo.min(p), hi.max(p))
        });
        let bounds = if lo.cmple(hi).all() && lo.is_finite() && hi.is_finite() { (lo, hi) } else { (Vec3::ZERO, Vec3::ZERO) };
        let id = self.new_mesh_id(bounds);
        if data.skin.len() != data.vertices.len() {
            data.skin.clear();
        }
        if data.morph_targets == 0 || data.morphs.len() != data.morph_targets as usize * data.vertices.len() {
            data.morphs.clear();
            data.morph_targets = 0;
        }
        if data.lods.as_ref().is_some_and(|lods| !lods.fits(data.vertices.len())) {
            tracing::warn!(
                "mesh {id:?}: its levels of detail do not fit its vertices (an index out of range, or counts that are not whole triangles or do not add up); drawn at full detail only"
            );
            data.lods = None;
        }
        self.set_has_levels(id, data.lods.as_ref().is_some_and(|l| l.levels() > 0));
        let posable = !data.skin.is_empty() || data.morph_targets > 0;
        let source = posable.then(|| {
            let vertices = data.vertices.iter().zip(&data.skin).map(|(v, s)| (Vec3::from(v.position), s.joints(), s.weights()));
            let reach = |target: &[GpuMorphDelta]| target.iter().map(|d| Vec3::from(d.position).length()).fold(0.0, f32::max);
            // A skinned mesh with levels (and no morph targets, which move vertices the levels
            // never saw move) can be skinned a level at a time.
            let levels = data.lods.as_ref().filter(|l| l.levels() > 0 && !data.skin.is_empty() && data.morph_targets == 0).map(|lods| {
                let of_vertex = lods.vertex_levels(data.vertices.len());
                poses::SkinLevels {
                    count: lods.levels() as u32,
                    errors: lods.errors,
                    vertices: std::array::from_fn(|level| of_vertex.iter().filter(|&&l| l as usize >= level).count() as u32),
                }
            });
            poses::SourceDesc {
                joint_bounds: poses::joint_bounds(vertices),
                vertices: data.vertices.len() as u32,
                rest_bounds: bounds,
                morph_reach: data.morphs.chunks(data.vertices.len().max(1)).map(reach).collect(),
                levels,
            }
        });
        self.poses.set_source(id, source);
        self.pending_meshes.push((id, data));
        id
    }

    /// A posed copy of skinned (or morphed) mesh `source` for one instance to draw: vertices
    /// of its own, written by the skinning pass from the joint matrices and morph weights
    /// [`SceneMirror::set_pose`] sets; indices, rest-pose vertices, weights and morph targets
    /// shared with `source` (`crate::skinning`). `None` when `source` has neither a skin nor
    /// morph targets. Free it with [`SceneMirror::remove_mesh`]; it draws its source's bind
    /// pose until it is first posed.
    pub fn add_posed_mesh(&mut self, source: MeshId) -> Option<MeshId> {
        if !self.poses.can_pose(source) {
            return None;
        }
        let bounds = self.mesh_bounds.get(source.0 as usize).copied().unwrap_or((Vec3::ZERO, Vec3::ZERO));
        let id = self.new_mesh_id(bounds);
        let levels = self.mesh_has_levels.get(source.0 as usize).copied().unwrap_or(false);
        self.set_has_levels(id, levels);
        self.poses.add(id, source);
        self.pending_posed.push((id, source));
        // Its first skinning is its bind pose: the joint matrices that leave every vertex where
        // it is, until a pose is set.
        let joints = self.poses.joint_count(source);
        self.poses.set(id, std::iter::repeat_n(Mat4::IDENTITY, joints), &[]);
        Some(id)
    }

    /// Sets the joint matrices of posed mesh `posed` (per joint of its skin: the joint's
    /// transform × its inverse bind matrix, in the space of the instance that draws it, i.e.
    /// the instance's world matrix inverse × joint world × inverse bind) and its morph weights
    /// (one per morph target; missing ones are 0). The pose's bounds
    /// become the mesh's: set the instance again ([`SceneMirror::set_instance`]) for culling to
    /// follow them. Returns false (nothing set) when `posed` is not a posed mesh.
    pub fn set_pose(&mut self, posed: MeshId, joints: impl IntoIterator<Item = Mat4>, morph_weights: &[f32]) -> bool {
        let Some(bounds) = self.poses.set(posed, joints, morph_weights) else { return false };
        if let (Some(bounds), Some(slot)) = (bounds, self.mesh_bounds.get_mut(posed.0 as usize)) {
            *slot = bounds;
        }
        true
    }

    /// Completes a batch of poses set on many threads ([`poses::PoseTable::chunks`]):
    /// the poses set wait to be skinned and their meshes' bounds follow them. The caller
    /// refreshes the culling records of the instances that draw them ([`SceneMirror::refresh_cull`]).
    pub fn finish_poses<T>(&mut self, batch: &[poses::PoseSet<T>]) {
        self.poses.finish(batch);
        for set in batch {
            if let (Some(bounds), Some(slot)) = (set.bounds(), self.mesh_bounds.get_mut(set.mesh.0 as usize)) {
                *slot = bounds;
            }
        }
    }

    /// Object-space bounds of mesh `id` (a posed mesh's follow its latest pose).
    pub fn mesh_bounds(&self, id: MeshId) -> Option<(Vec3, Vec3)> {
        self.mesh_bounds.get(id.0 as usize).copied()
    }

    /// The transparent instances' slots, back to front as seen from `eye`: ordered by the
    /// distance to the centre of each instance's mesh bounds (farthest first, ties by slot), the
    /// order the transparency passes blend them in. Sorting per instance, not per triangle, is
    /// exact for separate convex pieces of glass; intersecting or nested glass blends in
    /// instance order (see `crate::transparency`).
    pub fn sort_transparent(&mut self, eye: Vec3) -> &[u32] {
        self.transparent_keys.clear();
        for &slot in &self.transparent {
            let (Some(Some(draw)), Some(record)) = (self.draws.get(slot as usize), self.instances.get(slot)) else { continue };
            let center = self.mesh_bounds.get(draw.mesh.0 as usize).map_or(Vec3::ZERO, |(lo, hi)| (*lo + *hi) * 0.5);
            let distance = record.model.transform_point3(center).distance_squared(eye);
            // A non-finite distance (a broken transform, skipped by extraction anyway) sorts last.
            self.transparent_keys.push((if distance.is_finite() { distance } else { 0.0 }, slot));
        }
        self.transparent_keys.sort_unstable_by(|a, b| b.0.total_cmp(&a.0).then(a.1.cmp(&b.1)));
        self.transparent_order.clear();
        self.transparent_order.extend(self.transparent_keys.iter().map(|&(_, slot)| slot));
        &self.transparent_order
    }

    /// The order [`SceneMirror::sort_transparent`] last computed.
    pub fn transparent_order(&self) -> &[u32] {
        &self.transparent_order
    }

    /// Frees a mesh; the id is reused after the GPU has finished with it.
    pub fn remove_mesh(&mut self, id: MeshId) {
        self.pending_meshes.retain(|(m, _)| *m != id);
        self.pending_posed.retain(|(m, _)| *m != id);
        self.poses.remove(id);
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

    /// Starts a new frame's count of records written.
    pub fn begin_frame(&mut self) {
        self.records_written = 0;
    }

    /// Drops the free slots at the end of every table ([`SlotTable::trim`]) and the draws past
    /// the instances'. The renderer calls this at the start of each frame, so slot counts (and
    /// the GPU tables and passes that follow them) fall when the highest records go away.
    pub fn trim(&mut self) {
        self.instances.trim();
        self.culls.trim();
        self.draws.truncate(self.instances.slot_count() as usize);
        self.materials.trim();
        self.lights.trim();
        self.decals.trim();
        self.decal_materials.trim();
    }

    /// Forgets every pending upload, as if an uploader had trimmed the tables and copied it all
    /// (for uploaders other than the GPU renderer, and for tests without a GPU).
    pub fn clear_dirty(&mut self) {
        self.trim();
        self.instances.take_dirty(|_, _| {});
        self.culls.take_dirty(|_, _| {});
        self.materials.take_dirty(|_, _| {});
        self.lights.take_dirty(|_, _| {});
        self.decals.records.take_dirty(|_, _| {});
        self.decals.aabbs.take_dirty(|_, _| {});
        self.decal_materials.take_dirty(|_, _| {});
        self.camera_dirty = false;
        self.instances_rearranged = false;
        self.pending_meshes.clear();
        self.pending_posed.clear();
        self.poses.take_jobs();
        self.pending_textures.clear();
    }

    /// True when the renderer has nothing to upload.
    pub fn is_clean(&self) -> bool {
        self.instances.dirty_count() == 0
            && self.culls.dirty_count() == 0
            && self.materials.dirty_count() == 0
            && self.lights.dirty_count() == 0
            && self.decals.records.dirty_count() == 0
            && self.decals.aabbs.dirty_count() == 0
            && self.decal_materials.dirty_count() == 0
            && !self.camera_dirty
            && self.pending_meshes.is_empty()
            && self.pending_posed.is_empty()
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
    fn new_records_take_the_lowest_free_slot_and_a_trim_drops_the_free_tail() {
        let mut t = SlotTable::<u32>::default();
        for i in 0..8 {
            t.insert(i);
        }
        t.take_dirty(|_, _| {});
        for slot in [5, 2, 6] {
            t.remove(slot);
        }
        assert_eq!(t.insert(100), 2, "the lowest free slot, not the last freed");
        assert_eq!(t.insert(101), 5);
        t.remove(7);
        assert_eq!(t.slot_count(), 8, "until a trim, a released slot keeps its parked record");
        t.trim();
        assert_eq!(t.slot_count(), 6, "slots 6 and 7 are free at the end: dropped");
        assert_eq!(t.records().len(), 6, "the GPU buffer holds slot_count() records");
        assert_eq!(t.trimmed_tail(), 6..8, "the GPU still holds what was uploaded to slots 6 and 7");
        assert_eq!((t.get(0), t.get(4), t.get(5)), (Some(&0), Some(&4), Some(&101)), "live records stay where they are");
        let mut dirty = Vec::new();
        t.take_dirty(|slots, records| dirty.extend(slots.iter().map(|&s| (s, records[s as usize]))));
        assert_eq!(dirty, vec![(2, 100), (5, 101)], "the dropped slots' releases are not uploaded out of bounds");
        assert_eq!(t.trimmed_tail(), 6..6, "a drain brings the GPU up to the new count");
        assert_eq!(t.insert(200), 6, "past the end again: appended");
        assert_eq!(t.len(), 7);
        for slot in 0..7 {
            t.remove(slot);
        }
        t.trim();
        assert_eq!((t.slot_count(), t.len(), t.dirty_count()), (0, 0, 0), "an emptied table has no slots");
        assert_eq!(t.insert(300), 0);
    }

    #[test]
    fn under_churn_live_records_move_to_low_slots_and_the_slot_count_follows_them() {
        // Records live for a while and die oldest first (decals with a lifetime): 100 at once,
        // then 10. New records take the lowest free slots, so once the old ones have died the
        // 10 live records sit in slots 0..10 and a trim brings the slot count down to 10. (A
        // stack of freed slots hands a new record the slot the oldest just left, wherever it
        // is, and the count stays near 100.)
        let mut t = SlotTable::<u32>::default();
        let mut alive = std::collections::VecDeque::new();
        for i in 0..100 {
            alive.push_back(t.insert(i));
        }
        for round in 0..300u32 {
            let population = if round < 100 { 100 } else { 10 };
            while alive.len() >= population {
                t.remove(alive.pop_front().expect("not empty"));
            }
            alive.push_back(t.insert(round));
            t.trim();
            t.take_dirty(|_, _| {});
        }
        assert_eq!(t.len(), 10);
        assert_eq!(t.slot_count(), 10, "the live records are in the lowest slots");
        let mut slots: Vec<u32> = alive.iter().copied().collect();
        slots.sort_unstable();
        assert_eq!(slots, (0..10).collect::<Vec<u32>>());
    }

    /// A unit decal at `x` on the X axis.
    fn desc(x: f32) -> DecalDesc {
        DecalDesc {
            decal_to_world: Mat4::from_translation(Vec3::new(x, 0.0, 0.0)),
            material: 0,
            uv_corners: [Vec2::ZERO; 4],
            channel: 0,
            weight: 1.0,
            receivers: 1,
            opacity: 1.0,
            angle_fade: None,
            lifetime_fade: None,
            distance_fade: None,
            on_skin: None,
        }
    }

    #[test]
    fn a_trimmed_decal_table_keeps_its_boxes_dense() {
        let mut t = DecalTable::default();
        let slots: Vec<u32> = (0..6).map(|i| t.write(None, &desc(i as f32))).collect();
        t.records.take_dirty(|_, _| {});
        t.aabbs.take_dirty(|_, _| {});
        t.remove(slots[0]);
        t.remove(slots[5]);
        t.remove(slots[4]);
        t.trim();
        assert_eq!(t.records.slot_count(), 4, "record slots 4 and 5 are free at the end; 0 is a hole");
        assert_eq!(t.aabbs.slot_count(), 3, "the boxes end at the live count");
        assert_eq!(t.aabbs.trimmed_tail(), 3..6, "box places 3..6 are re-parked on the GPU");
        for i in 0..3 {
            let b = t.aabbs.get(i).expect("dense");
            assert_eq!((b.min[0] + b.max[0]) * 0.5, b.slot as f32, "box {i} is its record's");
        }
        let again = t.write(None, &desc(0.0));
        assert_eq!(again, 0, "the hole is reused first");
        t.write(Some(again), &desc(0.0));
        let next = t.write(None, &desc(4.0));
        assert_eq!(next, 4);
        assert_eq!((t.len(), t.aabbs.slot_count()), (5, 5));
        for slot in [0, 1, 2, 3, 4] {
            t.remove(slot);
        }
        t.trim();
        assert_eq!((t.records.slot_count(), t.aabbs.slot_count(), t.len()), (0, 0, 0));
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
    fn transparent_instances_sort_back_to_front_and_follow_draw_changes() {
        let mut m = SceneMirror::default();
        let mesh = m.add_mesh(MeshData {
            vertices: vec![Vertex { position: [1.0, 0.0, 0.0], normal: [0.0; 3], uv: [0.0; 2], tangent: [0.0; 4] }],
            indices: vec![0, 0, 0],
            ..Default::default()
        });
        let at = |z: f32| GpuInstance::new(Mat4::from_translation(Vec3::new(0.0, 0.0, z)), 0, 1);
        let glass = DrawItem { mesh, alpha_mask: false, double_sided: false, transparent: true };
        let near = m.set_instance(None, at(-1.0), glass);
        let opaque = m.set_instance(None, at(-2.0), DrawItem { transparent: false, ..glass });
        let far = m.set_instance(None, at(-5.0), glass);
        assert_eq!(m.sort_transparent(Vec3::ZERO), &[far, near]);
        assert_eq!(m.transparent_order().len(), 2);
        m.update_draw(opaque, |d| d.transparent = true);
        assert_eq!(m.sort_transparent(Vec3::ZERO), &[far, opaque, near]);
        m.update_draw(far, |d| d.transparent = false);
        m.remove_instance(near);
        assert_eq!(m.sort_transparent(Vec3::ZERO), &[opaque]);
        // From behind, the order turns round.
        m.update_draw(far, |d| d.transparent = true);
        assert_eq!(m.sort_transparent(Vec3::new(0.0, 0.0, -10.0)), &[opaque, far]);
    }

    #[test]
    fn movers_keep_their_first_previous_transform_and_forget_removed_slots() {
        let mut m = Movers::default();
        let at = |x: f32| Mat4::from_translation(Vec3::new(x, 0.0, 0.0));
        m.moved(3, at(1.0));
        m.moved(7, at(2.0));
        m.moved(3, at(9.0));
        assert_eq!(m.prev_model(3), Some(at(1.0)), "the transform at the last upload counts");
        m.forget(3);
        assert_eq!((m.prev_model(3), m.prev_model(7), m.len()), (None, Some(at(2.0)), 1));
        m.moved(3, at(4.0));
        m.clear();
        assert!(m.is_empty() && m.prev_model(3).is_none() && m.prev_model(7).is_none());
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
        assert_eq!(m.records_written, 0);
    }

    #[test]
    fn decal_boxes_stay_dense_and_point_at_their_records() {
        let mut t = DecalTable::default();
        let slots: Vec<u32> = (0..5).map(|i| t.write(None, &desc(i as f32))).collect();
        t.aabbs.take_dirty(|_, _| {});
        t.remove(slots[1]);
        let mut dirty = Vec::new();
        t.aabbs.take_dirty(|s, _| dirty.extend_from_slice(s));
        assert_eq!(dirty, vec![1, 4], "the last box moves into the hole: two box uploads");
        t.remove(slots[4]);
        let check = |t: &DecalTable| {
            for i in 0..t.len() as u32 {
                let b = t.aabbs.get(i).expect("the first len() boxes are live");
                let centre = (b.min[0] + b.max[0]) * 0.5;
                assert!(t.records.get(b.slot).is_some(), "box {i} points at a live record");
                assert_eq!(centre, b.slot as f32, "box {i} is its record's box");
            }
            assert_eq!(t.aabbs.len(), t.len());
        };
        check(&t);
        assert_eq!(t.aabbs.get(3), None, "the tail is free");
        assert_eq!(t.aabbs.records()[3].slot, NO_DECAL, "and its box belongs to no decal");
        let again = t.write(None, &desc(1.0));
        assert_eq!(again, slots[1], "the lowest free record slot");
        check(&t);
        t.write(Some(again), &desc(again as f32));
        check(&t);
        t.remove(slots[0]);
        t.remove(slots[0]);
        check(&t);
    }

    #[test]
    fn invalid_decal_transforms_give_records_that_never_apply() {
        let desc = |m: Mat4| DecalDesc {
            decal_to_world: m,
            material: 0,
            uv_corners: [Vec2::ZERO; 4],
            channel: 0,
            weight: f32::NAN,
            receivers: 1,
            opacity: f32::NAN,
            angle_fade: None,
            lifetime_fade: None,
            distance_fade: None,
            on_skin: None,
        };
        let good = desc(Mat4::from_scale(Vec3::splat(2.0)));
        assert!(good.is_valid());
        assert_eq!(
            (good.record().receivers, good.record().opacity, good.record().weight),
            (1, 0.0, 1e-4),
            "NaN opacity and weight are sanitised"
        );
        for m in [
            Mat4::from_translation(Vec3::new(f32::NAN, 0.0, 0.0)),
            Mat4::from_scale(Vec3::new(f32::INFINITY, 1.0, 1.0)),
            Mat4::from_scale(Vec3::new(1.0, 0.0, 1.0)),
        ] {
            let d = desc(m);
            assert!(!d.is_valid(), "{m:?}");
            let r = d.record();
            assert_eq!(r.receivers, 0, "never applies");
            assert!(bytemuck::cast_slice::<GpuDecal, f32>(&[r]).iter().all(|v| v.is_finite()), "no NaN reaches the GPU");
            let b = GpuAabb::of_decal(&d, 7);
            assert_eq!(b.slot, 7);
            assert!(b.min.iter().chain(&b.max).all(|v| v.is_finite()) && b.min == b.max, "a finite point box: {b:?}");
        }
    }

    #[test]
    fn decal_boxes_bound_their_oriented_box() {
        let m = Mat4::from_scale_rotation_translation(
            Vec3::new(2.0, 1.0, 0.5),
            glam::Quat::from_rotation_y(0.7) * glam::Quat::from_rotation_x(0.3),
            Vec3::new(1.0, 2.0, 3.0),
        );
        let aabb = GpuAabb::of_unit_box(m, 0);
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

    /// The batch counts a full scan of the draws gives, to compare with the kept ones.
    fn recount(m: &SceneMirror) -> [u32; CULL_BATCHES as usize] {
        let mut counts = [0; CULL_BATCHES as usize];
        for draw in m.draws.iter().flatten() {
            if let Some(b) = draw.batch() {
                counts[b] += 1;
            }
        }
        counts
    }

    #[test]
    fn decals_need_instances_only_while_some_instance_has_layers_or_some_decal_is_on_a_skin() {
        let mut m = SceneMirror::new();
        let mesh = m.add_mesh(MeshData {
            vertices: [Vec3::ZERO, Vec3::X, Vec3::Y]
                .map(|p| Vertex { position: p.into(), normal: [0.0, 0.0, 1.0], uv: [0.0; 2], tangent: [1.0, 0.0, 0.0, 1.0] })
                .to_vec(),
            indices: vec![0, 1, 2],
            ..Default::default()
        });
        let draw = DrawItem { mesh, alpha_mask: false, double_sided: false, transparent: false };
        let with_layers = |layers| GpuInstance::new(Mat4::IDENTITY, 0, layers);
        let plain = m.set_instance(None, with_layers(DECAL_DEFAULT_LAYERS), draw);
        assert!(!m.decals_need_instances(), "default layers");
        let layered = m.set_instance(None, with_layers(2), draw);
        assert!(m.decals_need_instances(), "an instance with layers of its own");
        m.set_instance(Some(layered), with_layers(2), draw);
        m.set_instance(Some(plain), with_layers(DECAL_DEFAULT_LAYERS), draw);
        assert_eq!(m.layered_instances, 1, "rewrites count once");
        m.set_instance(Some(layered), with_layers(DECAL_DEFAULT_LAYERS), draw);
        assert!(!m.decals_need_instances(), "its layers back to the default");
        m.set_instance(Some(plain), with_layers(0), draw);
        m.remove_instance(plain);
        m.remove_instance(plain);
        assert!(!m.decals_need_instances(), "a removed layered instance (removed twice) counts no more");

        let world = m.decals.write(None, &desc(0.0));
        let skin = m.decals.write(None, &DecalDesc { on_skin: Some(layered), ..desc(1.0) });
        assert!(m.decals_need_instances(), "a decal on a skin");
        m.decals.write(Some(skin), &DecalDesc { on_skin: Some(layered), ..desc(2.0) });
        m.decals.write(Some(world), &desc(3.0));
        m.decals.remove(skin);
        m.decals.remove(skin);
        assert!(!m.decals_need_instances(), "moved, then removed");
        m.decals.write(Some(world), &DecalDesc { on_skin: Some(layered), ..desc(3.0) });
        assert!(m.decals_need_instances(), "a world decal moved onto a skin");
        m.decals.write(Some(world), &desc(3.0));
        assert!(!m.decals_need_instances(), "and off it");

        // Glass takes its decals in its own shading: its layers (none, by default) do not count
        // until it becomes opaque.
        let glass = m.set_instance(None, with_layers(0), DrawItem { transparent: true, ..draw });
        assert!(!m.decals_need_instances(), "glass");
        m.update_draw(glass, |d| d.transparent = false);
        assert!(m.decals_need_instances(), "the glass made opaque");
        m.update_draw(glass, |d| d.transparent = true);
        assert!(!m.decals_need_instances(), "and glass again");
        m.remove_instance(glass);
        assert_eq!(m.layered_instances, 0);
    }

    #[test]
    fn culling_records_follow_spawns_moves_rematerials_and_despawns() {
        let mut m = SceneMirror::new();
        let cube = m.add_mesh(MeshData {
            vertices: [Vec3::splat(-0.5), Vec3::splat(0.5)]
                .map(|p| Vertex { position: p.into(), normal: [0.0, 1.0, 0.0], uv: [0.0; 2], tangent: [1.0, 0.0, 0.0, 1.0] })
                .to_vec(),
            indices: vec![0, 1, 0],
            ..Default::default()
        });
        let opaque = DrawItem { mesh: cube, alpha_mask: false, double_sided: false, transparent: false };
        let at = |x: f32| GpuInstance::new(Mat4::from_translation(Vec3::new(x, 0.0, 0.0)), 0, 1);
        let slots: Vec<u32> = (0..5).map(|i| m.set_instance(None, at(i as f32 * 3.0), opaque)).collect();
        assert_eq!(m.batch_counts, [5, 0, 0, 0]);
        let record = *m.culls.get(slots[2]).unwrap();
        assert_eq!((record.min, record.max), (Vec3::new(5.5, -0.5, -0.5), Vec3::new(6.5, 0.5, 0.5)));
        assert_eq!(record.flags, CULL_LIVE);

        // A move rewrites the record in place: a rotated, scaled box bounds its corners.
        m.clear_dirty();
        let turned = Mat4::from_scale_rotation_translation(Vec3::splat(2.0), glam::Quat::from_rotation_y(0.5), Vec3::Y);
        m.set_instance(Some(slots[1]), GpuInstance::new(turned, 0, 1), opaque);
        assert_eq!(m.culls.dirty_count(), 1, "only the moved slot is rewritten");
        let r = *m.culls.get(slots[1]).unwrap();
        let half = (0.5f32.cos() + 0.5f32.sin()) * 1.0; // a unit cube doubled, turned 0.5 rad
        assert!((r.max[0] - half).abs() < 1e-5 && (r.max[1] - 2.0).abs() < 1e-5, "{r:?}");

        // Material changes move instances between batches (and out of them for glass).
        m.update_draw(slots[3], |d| d.alpha_mask = true);
        m.update_draw(slots[4], |d| d.double_sided = true);
        m.update_draw(slots[0], |d| d.transparent = true);
        assert_eq!(m.batch_counts, recount(&m));
        assert_eq!(m.batch_counts, [2, 1, 1, 0]);
        assert_eq!(m.culls.get(slots[3]).unwrap().flags, CULL_LIVE | CULL_MASKED);
        assert_eq!(m.culls.get(slots[0]).unwrap().flags, CULL_LIVE | CULL_TRANSPARENT);
        m.set_instance(Some(slots[3]), at(1.0), DrawItem { double_sided: true, ..opaque });
        assert_eq!(m.batch_counts, recount(&m));

        // Despawns free the record; a new instance takes the lowest slot in both tables.
        m.remove_instance(slots[2]);
        assert_eq!(m.culls.get(slots[2]), None);
        assert_eq!(m.batch_counts, recount(&m));
        assert_eq!(m.set_instance(None, at(9.0), opaque), slots[2], "the freed slot is reused");
        m.remove_instance(slots[4]);
        m.trim();
        assert_eq!(m.culls.slot_count(), m.instances.slot_count());
        assert_eq!(m.batch_counts, recount(&m));
        assert_eq!(m.culls.len(), m.instances.len());
    }
}
