//! The GPU side of the [`SceneMirror`]: device-local record tables, meshes and the bindless
//! texture array, kept in step with the mirror by copying only what is dirty.
//!
//! Tables are reached from shaders through buffer device addresses in push constants, so a table
//! that grows (geometrically) is simply replaced; no descriptor set changes. Textures live in one
//! update-after-bind array of combined image samplers (set 0, binding 0), indexed by the slots the
//! mirror hands out. A freed slot returns to the mirror only after the GPU has finished every
//! frame that could sample it, so a descriptor is never rewritten under a pending frame.
//!
//! **Giving memory back.** The mirror's tables take the lowest free slot and are trimmed at the
//! start of every frame ([`SceneMirror::trim`]), so their slot counts fall when the highest
//! records go; a table whose slot count has stayed at or below a quarter of its capacity for
//! [`crate::gpu::device::GpuContext::shrink_after_frames`] frames is replaced by one with room for the
//! count's power of two (through the graveyard, like a grow) and every record is uploaded again
//! ([`crate::gpu::upload::Shrink`]). Never below the table's initial capacity, its floor: 64
//! instances, materials, decals, decal boxes, meshes and decal-order entries, 16 lights and
//! decal materials, one camera and one lighting record (about 20 KiB in all). Kept as they are:
//! the bindless texture array (its textures are freed with their assets), the samplers and the
//! descriptor set. The decal boxes past the slot count are padding a BLAS build may read, so the
//! places a trim drops are re-parked ([`SlotTable::trimmed_tail`]). The mirror's CPU vectors keep
//! their capacity.
//!
//! | file | holds |
//! | --- | --- |
//! | `mod.rs` | the [`GpuScene`]: creation, the frame's upload of what is dirty, the movers |
//! | `tables.rs` | [`GpuTable`], [`WordArray`], [`SkinInput`]: record tables and how dirty records reach them |
//! | `meshes.rs` | the mesh pool: [`GpuMesh`], growing, repacking and releasing the pool, the mesh table |
//! | `textures.rs` | the bindless set: textures and the render targets bound after them |
//! | `lighting.rs` | the lighting record and the fields other techniques own in it |

mod lighting;
mod meshes;
mod tables;
mod textures;
pub use textures::TextureBudgetReport;

use ash::vk;
use bytemuck::{Pod, Zeroable};
use gpu_allocator::MemoryLocation;

use crate::RenderError;
use crate::gpu::device::{GpuContext, Tier};
use crate::gpu::memory::{Buffer, Image, ImageDesc, MemoryKind, Retired};
use crate::gpu::upload::{CopyList, Shrink, StagingRing, Upload};
use crate::graph::{Bind, BufferUse, Frame, FrameGraph, PassKind, ResourceId};
use crate::layout::{GpuDrawCommand, GpuLighting, GpuMover, LOD_LEVELS};
use crate::scene::pool::{POOL_FLOOR, RangeAllocator, footprint};
use crate::scene::{
    GpuAabb, GpuCamera, GpuMeshInfo, GpuSkinVertex, MeshData, MeshId, RESERVED_TEXTURES, SceneMirror, SlotTable, TEXTURE_FLAT_NORMAL,
    TEXTURE_WHITE, TextureData,
};
use crate::stats::FrameCounters;
pub use lighting::DecalRingFields;
pub use meshes::GpuMesh;
use meshes::*;
use tables::*;
pub use tables::{GpuTable, SkinInput, WordArray};
use textures::*;
pub use textures::{MAX_TEXTURES, TARGET_BINDINGS};

/// What the frame's motion-vector pass needs of the upload (`crate::motion`), decided before it.
#[derive(Clone, Copy, Debug, Default)]
pub struct MotionUpload {
    /// Whether this frame draws motion vectors: only then are movers uploaded.
    pub wanted: bool,
    /// Whether this frame's pipeline finds posed meshes' motion per pixel: then they are movers
    /// only when they moved as a whole.
    pub posed_per_pixel: bool,
}

/// The frame-graph resources the GPU scene is tracked as.
#[derive(Clone, Copy, Debug)]
pub struct SceneResources {
    /// Every record table (instances, materials, lights, camera, decals and their boxes, the
    /// mesh table, the deferred decal order): uploaded together, read by every pass.
    pub tables: ResourceId,
    /// Vertex and index buffers.
    pub meshes: ResourceId,
    /// The bindless material and decal textures.
    pub textures: ResourceId,
}

impl SceneResources {
    /// What a pass that draws the scene's meshes reads: the records, the vertices and indices,
    /// and the material textures.
    pub fn drawn(&self) -> [(ResourceId, BufferUse); 3] {
        [(self.tables, BufferUse::Storage), (self.meshes, BufferUse::Vertices), (self.textures, BufferUse::SampledImages)]
    }

    /// What a pass that shades without drawing meshes reads: the records and the textures.
    pub fn shaded(&self) -> [(ResourceId, BufferUse); 2] {
        [(self.tables, BufferUse::Storage), (self.textures, BufferUse::SampledImages)]
    }
}

/// The GPU scene.
pub struct GpuScene {
    /// Instance records.
    pub instances: GpuTable,
    /// Material records.
    pub materials: GpuTable,
    /// Light records.
    pub lights: GpuTable,
    /// The camera record.
    pub camera: GpuTable,
    /// The lighting record.
    pub lighting: GpuTable,
    lighting_cpu: GpuLighting,
    lighting_dirty: bool,
    /// Decal records.
    pub decals: GpuTable,
    /// Decal boxes (acceleration-structure build input), over the whole capacity.
    pub decal_aabbs: GpuTable,
    /// Decal materials.
    pub decal_materials: GpuTable,
    /// Vertex and index addresses per mesh.
    pub mesh_table: GpuTable,
    mesh_info: Vec<GpuMeshInfo>,
    mesh_info_dirty: bool,
    /// Deferred decals' draw order (decal slots).
    pub decal_order: WordArray,
    /// Shadow maps' views and the first view of each light slot (`shaders/include/shadow_maps.glsl`).
    pub shadow_views: WordArray,
    /// Culling records (world bounds, mesh, batch flags per instance slot).
    pub culls: GpuTable,
    /// The blended instances' back-to-front order (instance slots), culled into ordered draws.
    pub glass_order: WordArray,
    /// This frame's skinning jobs and joint matrices (`crate::skinning`).
    pub skin_input: SkinInput,
    /// This frame's movers (`GpuMover` each), which the motion-vector pass draws
    /// (`crate::motion`).
    pub movers: GpuTable,
    /// Their draws (`GpuDrawCommand` each, `first_instance` naming the mover), after a first
    /// command's place whose first word is their count.
    pub mover_draws: GpuTable,
    /// Movers uploaded this frame.
    pub mover_count: u32,
    mover_records: Vec<GpuMover>,
    mover_commands: Vec<GpuDrawCommand>,
    /// Meshes by [`MeshId`], placed in the pool.
    pub meshes: Vec<Option<GpuMesh>>,
    /// Bytes of the pool the posed meshes among them hold.
    posed_bytes: u64,
    /// The mesh pool's buffer (none before the first mesh, or after a while without any).
    mesh_pool: Option<Buffer>,
    ranges: RangeAllocator,
    /// Ranges of freed meshes, returned to `ranges` once the frame value has completed.
    released_ranges: Vec<(u64, u64, u64)>,
    pool_shrink: Shrink,
    textures: Vec<Option<Image>>,
    /// Bindless set layout (set 0).
    pub set_layout: vk::DescriptorSetLayout,
    pool: vk::DescriptorPool,
    /// The bindless set.
    pub set: vk::DescriptorSet,
    /// Repeat, trilinear, anisotropic: for material textures.
    pub repeat_sampler: vk::Sampler,
    /// Clamp-to-edge, linear: for render targets sampled by full-screen passes.
    pub clamp_sampler: vk::Sampler,
    released_textures: Vec<(u64, u32)>,
    copies: CopyList,
    /// Built-in textures, uploaded with the first frame.
    builtins: Vec<(u32, TextureData)>,
    /// The texture budget and what it did (`textures.rs`).
    texture_budget: textures::TextureBudgetReport,
    /// Bytes of each scene texture slot on the GPU.
    texture_sizes: Vec<u64>,
    /// Whether the budget has warned (it warns once).
    budget_warned: bool,
    /// Whether decoding block-compressed textures for a device without BC has warned (once).
    decode_warned: bool,
    /// The graph resources the scene's buffers and textures are tracked as.
    pub res: SceneResources,
    mesh_usage: vk::BufferUsageFlags,
}

impl GpuScene {
    /// Creates empty tables, the bindless set and the built-in textures.
    pub fn new(ctx: &GpuContext, graph: &mut FrameGraph) -> Result<Self, RenderError> {
        let d = &ctx.device;
        let bindless = vk::DescriptorBindingFlags::PARTIALLY_BOUND
            | vk::DescriptorBindingFlags::UPDATE_AFTER_BIND
            | vk::DescriptorBindingFlags::UPDATE_UNUSED_WHILE_PENDING;
        // Binding 0: the material and decal textures. Bindings 1..=TARGET_BINDINGS: one
        // sampled render target each (`BINDING_*`), so shaders statically use only the targets
        // they sample; then the storage images: the decal buffer's, the shadow debug image, the
        // HDR target.
        let binding_flags = [bindless; BINDINGS];
        let mut flags_info = vk::DescriptorSetLayoutBindingFlagsCreateInfo::default().binding_flags(&binding_flags);
        let bindings: [vk::DescriptorSetLayoutBinding; BINDINGS] = std::array::from_fn(|i| {
            vk::DescriptorSetLayoutBinding::default()
                .binding(i as u32)
                .descriptor_type(descriptor_type(i as u32))
                .descriptor_count(descriptor_count(i as u32))
                .stage_flags(vk::ShaderStageFlags::ALL)
        });
        // SAFETY: create infos point at locals; the objects are destroyed in `destroy`.
        let (set_layout, pool, set, repeat_sampler, clamp_sampler) = unsafe {
            let set_layout = d.create_descriptor_set_layout(
                &vk::DescriptorSetLayoutCreateInfo::default()
                    .bindings(&bindings)
                    .flags(vk::DescriptorSetLayoutCreateFlags::UPDATE_AFTER_BIND_POOL)
                    .push_next(&mut flags_info),
                None,
            )?;
            let count = |ty| (0..BINDINGS as u32).filter(|&b| descriptor_type(b) == ty).map(descriptor_count).sum();
            let sizes = [vk::DescriptorType::COMBINED_IMAGE_SAMPLER, vk::DescriptorType::STORAGE_IMAGE]
                .map(|ty| vk::DescriptorPoolSize { ty, descriptor_count: count(ty) });
            let pool = d.create_descriptor_pool(
                &vk::DescriptorPoolCreateInfo::default()
                    .max_sets(1)
                    .pool_sizes(&sizes)
                    .flags(vk::DescriptorPoolCreateFlags::UPDATE_AFTER_BIND),
                None,
            )?;
            let layouts = [set_layout];
            let set = d.allocate_descriptor_sets(&vk::DescriptorSetAllocateInfo::default().descriptor_pool(pool).set_layouts(&layouts))?[0];
            let repeat_sampler = d.create_sampler(
                &vk::SamplerCreateInfo::default()
                    .mag_filter(vk::Filter::LINEAR)
                    .min_filter(vk::Filter::LINEAR)
                    .mipmap_mode(vk::SamplerMipmapMode::LINEAR)
                    .address_mode_u(vk::SamplerAddressMode::REPEAT)
                    .address_mode_v(vk::SamplerAddressMode::REPEAT)
                    .address_mode_w(vk::SamplerAddressMode::REPEAT)
                    .anisotropy_enable(true)
                    .max_anisotropy(ctx.limits.max_sampler_anisotropy.min(8.0))
                    .max_lod(vk::LOD_CLAMP_NONE),
                None,
            )?;
            let clamp_sampler = d.create_sampler(
                &vk::SamplerCreateInfo::default()
                    .mag_filter(vk::Filter::LINEAR)
                    .min_filter(vk::Filter::LINEAR)
                    .mipmap_mode(vk::SamplerMipmapMode::NEAREST)
                    .address_mode_u(vk::SamplerAddressMode::CLAMP_TO_EDGE)
                    .address_mode_v(vk::SamplerAddressMode::CLAMP_TO_EDGE)
                    .address_mode_w(vk::SamplerAddressMode::CLAMP_TO_EDGE),
                None,
            )?;
            (set_layout, pool, set, repeat_sampler, clamp_sampler)
        };
        let mut mesh_usage = vk::BufferUsageFlags::VERTEX_BUFFER
            | vk::BufferUsageFlags::INDEX_BUFFER
            | vk::BufferUsageFlags::STORAGE_BUFFER
            | vk::BufferUsageFlags::TRANSFER_DST
            | vk::BufferUsageFlags::TRANSFER_SRC
            | vk::BufferUsageFlags::SHADER_DEVICE_ADDRESS;
        if ctx.tier >= Tier::RayTracingPipeline {
            mesh_usage |= vk::BufferUsageFlags::ACCELERATION_STRUCTURE_BUILD_INPUT_READ_ONLY_KHR;
        }
        let mut scene = Self {
            instances: GpuTable::new::<crate::scene::GpuInstance>(ctx, "instances", 64)?,
            materials: GpuTable::new::<crate::scene::GpuMaterial>(ctx, "materials", 64)?,
            lights: GpuTable::new::<crate::scene::GpuLight>(ctx, "lights", 16)?,
            camera: GpuTable::new::<GpuCamera>(ctx, "camera", 1)?,
            lighting: GpuTable::new::<GpuLighting>(ctx, "lighting", 1)?,
            lighting_cpu: GpuLighting::default(),
            lighting_dirty: true,
            decals: GpuTable::new::<crate::scene::GpuDecal>(ctx, "decals", 64)?,
            decal_aabbs: GpuTable::with_usage::<crate::scene::GpuAabb>(
                ctx,
                "decal boxes",
                64,
                if ctx.tier >= Tier::RayTracingPipeline {
                    vk::BufferUsageFlags::ACCELERATION_STRUCTURE_BUILD_INPUT_READ_ONLY_KHR
                } else {
                    vk::BufferUsageFlags::empty()
                },
                true,
            )?,
            decal_materials: GpuTable::new::<crate::scene::GpuDecalMaterial>(ctx, "decal materials", 16)?,
            mesh_table: GpuTable::new::<GpuMeshInfo>(ctx, "mesh table", 64)?,
            mesh_info: Vec::new(),
            mesh_info_dirty: false,
            decal_order: WordArray::new(ctx, "decal order")?,
            shadow_views: WordArray::new(ctx, "shadow map views")?,
            culls: GpuTable::new::<crate::scene::GpuCullRecord>(ctx, "culling records", 64)?,
            glass_order: WordArray::new(ctx, "glass order")?,
            skin_input: SkinInput { table: GpuTable::new::<u32>(ctx, "skinning jobs", 64)?, words: 0, dirty: false },
            movers: GpuTable::new::<GpuMover>(ctx, "movers", 16)?,
            mover_draws: GpuTable::with_usage::<GpuDrawCommand>(ctx, "mover draws", 16, vk::BufferUsageFlags::INDIRECT_BUFFER, false)?,
            mover_count: 0,
            mover_records: Vec::new(),
            mover_commands: Vec::new(),
            meshes: Vec::new(),
            posed_bytes: 0,
            mesh_pool: None,
            ranges: RangeAllocator::default(),
            released_ranges: Vec::new(),
            pool_shrink: ctx.shrink_rule(),
            textures: (0..RESERVED_TEXTURES).map(|_| None).collect(),
            set_layout,
            pool,
            set,
            repeat_sampler,
            clamp_sampler,
            released_textures: Vec::new(),
            copies: CopyList::default(),
            builtins: Vec::new(),
            texture_budget: Default::default(),
            texture_sizes: Vec::new(),
            budget_warned: false,
            decode_warned: false,
            res: SceneResources {
                tables: graph.resource("scene tables"),
                meshes: graph.resource("meshes"),
                textures: graph.resource("textures"),
            },
            mesh_usage,
        };
        // The built-in textures go up with the first frame's upload, like any other texture.
        let texel = |rgba: [u8; 4]| TextureData { width: 1, height: 1, format: vk::Format::R8G8B8A8_UNORM, mips: vec![rgba.to_vec()] };
        let (white, flat_normal) = (texel([255; 4]), texel([128, 128, 255, 255]));
        scene.builtins = vec![(TEXTURE_WHITE, white), (TEXTURE_FLAT_NORMAL, flat_normal)];
        Ok(scene)
    }

    /// Adds a texture of the renderer's own (a technique's table, such as the area lights'
    /// `crate::lights::ltc`) at a reserved bindless slot: it goes up with the next upload, which
    /// does not count it among the scene's uploaded bytes.
    pub fn add_builtin_texture(&mut self, slot: u32, data: TextureData) -> Result<(), RenderError> {
        if slot < RESERVED_TEXTURES {
            self.builtins.push((slot, data));
            Ok(())
        } else {
            Err(RenderError::Other(format!("built-in texture slot {slot} is not below RESERVED_TEXTURES ({RESERVED_TEXTURES})")))
        }
    }

    /// Brings the GPU scene up to date with `mirror`: prepares copies of what is dirty (only
    /// dirty records, new meshes and new textures) and records them as the frame's `upload`
    /// pass. Returns the number of decal boxes rewritten (they drive the BLAS refit).
    pub fn upload(
        &mut self,
        f: &mut Frame,
        mirror: &mut SceneMirror,
        motion: MotionUpload,
        counters: &mut FrameCounters,
    ) -> Result<u32, RenderError> {
        let up = &mut f.upload;
        // Slots whose last user has finished go back to the mirror for reuse.
        let completed = up.completed;
        self.released_textures.retain(|&(after, slot)| {
            if after <= completed {
                mirror.recycle_texture_slot(slot);
                false
            } else {
                true
            }
        });
        for slot in mirror.released_textures.drain(..) {
            if let Some(img) = self.textures.get_mut(slot as usize).and_then(Option::take) {
                up.graveyard.bury(up.frame_value, Retired::Image(img));
            }
            self.release_texture_bytes(slot);
            self.released_textures.push((up.frame_value, slot));
        }
        let mut released_source = false;
        for id in mirror.released_meshes.drain(..) {
            if let Some(mesh) = self.meshes.get_mut(id.0 as usize).and_then(Option::take) {
                self.released_ranges.push((up.frame_value, mesh.offset, mesh.bytes));
                if mesh.source.is_some() {
                    self.posed_bytes -= mesh.bytes;
                }
                self.mesh_info[id.0 as usize] = GpuMeshInfo::default();
                self.mesh_info_dirty = true;
                released_source |= mesh.skinned || mesh.morph_targets > 0;
            }
        }
        if let Some(pool) = self.mesh_pool.as_ref().map(|p| p.address).filter(|_| released_source) {
            // Posed copies of a skinned mesh that went draw nothing.
            self.refresh_infos(pool, |m| m.source.is_some());
        }
        let incoming = self.incoming_sizes(mirror);
        let pool_plan = self.plan_pool(completed, &incoming);

        // Once a frame, whether or not anything changed: the tables (and below, the ring) grow
        // or shrink.
        let mut replaced = false;
        let tables: [(&mut GpuTable, u32); 7] = [
            (&mut self.instances, mirror.instances.slot_count()),
            (&mut self.culls, mirror.culls.slot_count()),
            (&mut self.materials, mirror.materials.slot_count()),
            (&mut self.lights, mirror.lights.slot_count()),
            (&mut self.decals, mirror.decals.records.slot_count()),
            (&mut self.decal_aabbs, mirror.decals.aabbs.slot_count()),
            (&mut self.decal_materials, mirror.decal_materials.slot_count()),
        ];
        for (gpu, slots) in tables {
            replaced |= gpu.plan(slots);
        }
        self.mover_count = 0;
        let posed_movers = if motion.posed_per_pixel { 0 } else { mirror.poses.jobs().len() };
        let movers = if motion.wanted { (mirror.movers.len() + posed_movers) as u32 } else { 0 };
        if movers > 0 {
            self.movers.plan(movers);
            self.mover_draws.plan(movers + 1);
        }
        let ids = mirror.pending_meshes.iter().map(|(id, _)| *id).chain(mirror.pending_posed.iter().map(|(id, _)| *id));
        let meshes = ids.map(|id| id.0 as usize + 1).fold(self.mesh_info.len(), usize::max);
        if self.mesh_table.plan(meshes as u32) {
            self.mesh_info_dirty = true;
        }
        for words in [&mut self.decal_order, &mut self.shadow_views, &mut self.glass_order] {
            words.plan();
        }
        self.skin_input.plan();
        let trimmed_boxes = !mirror.decals.aabbs.trimmed_tail().is_empty();
        if mirror.is_clean()
            && !replaced
            && !trimmed_boxes
            && !self.mesh_info_dirty
            && !self.decal_order.dirty
            && !self.shadow_views.dirty
            && !self.glass_order.dirty
            && !self.skin_input.dirty
            && pool_plan == PoolPlan::Keep
            && !self.lighting_dirty
            && self.builtins.is_empty()
            && movers == 0
        {
            mirror.movers.clear();
            StagingRing::fit(up, 0)?;
            return Ok(0);
        }
        let camera_dirty = mirror.take_camera_dirty();
        let need = staging_need(&mirror.instances, &self.instances)
            + staging_need(&mirror.culls, &self.culls)
            + staging_need(&mirror.materials, &self.materials)
            + staging_need(&mirror.lights, &self.lights)
            + staging_need(&mirror.decals.records, &self.decals)
            + staging_need(&mirror.decals.aabbs, &self.decal_aabbs)
            + staging_need(&mirror.decal_materials, &self.decal_materials)
            + 2 * (std::mem::size_of::<GpuMeshInfo>() * (self.mesh_info.len() + incoming.len())) as u64
            + self.decal_order.staging_need()
            + self.shadow_views.staging_need()
            + self.glass_order.staging_need()
            + self.skin_input.staging_need()
            + 64
            + std::mem::size_of::<GpuCamera>() as u64
            + (movers as u64 + 1) * (std::mem::size_of::<GpuMover>() + std::mem::size_of::<GpuDrawCommand>()) as u64
            + std::mem::size_of::<GpuLighting>() as u64
            + 96;
        StagingRing::fit(up, need)?;

        let mut copies = std::mem::take(&mut self.copies);
        copies.clear();
        let new_meshes = !incoming.is_empty() || pool_plan != PoolPlan::Keep;
        self.prepare_meshes(up, &mut copies, mirror, pool_plan)?;
        let scene_bytes = up.bytes;
        for (slot, data) in std::mem::take(&mut self.builtins) {
            self.prepare_texture(up, &mut copies, slot, &data)?;
        }
        up.bytes = scene_bytes; // the renderer's own textures are not the scene's uploads
        let mut pending = std::mem::take(&mut mirror.pending_textures);
        self.apply_texture_budget(&mut pending, up.ctx.capabilities.texture_compression_bc);
        for (slot, data) in pending {
            self.prepare_texture(up, &mut copies, slot, &data)?;
        }
        // Boxes rewritten, counting the places a trim dropped (re-parked below), as a refit
        // must pick those up too.
        let trimmed = mirror.decals.aabbs.trimmed_tail();
        let decal_boxes_changed = mirror.decals.aabbs.dirty_count() as u32 + (trimmed.end - trimmed.start);
        let tables: [(&mut dyn DirtyTable, &mut GpuTable); 6] = [
            (&mut mirror.instances, &mut self.instances),
            (&mut mirror.culls, &mut self.culls),
            (&mut mirror.materials, &mut self.materials),
            (&mut mirror.lights, &mut self.lights),
            (&mut mirror.decals.records, &mut self.decals),
            (&mut mirror.decal_materials, &mut self.decal_materials),
        ];
        for (table, gpu) in tables {
            table.upload(up, &mut copies, gpu)?;
        }
        let parking: Option<TailFn<GpuAabb>> = self.decal_aabbs.fill_tail.then_some(decal_parking);
        upload_table(up, &mut copies, &mut mirror.decals.aabbs, &mut self.decal_aabbs, parking)?;
        if std::mem::take(&mut self.mesh_info_dirty) {
            upload_array(up, &mut copies, &mut self.mesh_table, bytemuck::cast_slice(&self.mesh_info))?;
        }
        for words in [&mut self.decal_order, &mut self.shadow_views, &mut self.glass_order] {
            if std::mem::take(&mut words.dirty) {
                upload_array(up, &mut copies, &mut words.table, bytemuck::cast_slice(&words.cpu))?;
            }
        }
        if std::mem::take(&mut self.skin_input.dirty) {
            let table = &mut self.skin_input.table;
            table.apply(up)?;
            let len = self.skin_input.words * 4;
            let src = up.staging.push_with(len, |dst| mirror.poses.write_input(dst));
            copies.buffer_copy(up.staging_buffer(), table.buffer()).push(src, 0, len as u64);
            up.bytes += len as u64;
        }
        if movers > 0 {
            self.upload_movers(up, &mut copies, mirror)?;
            counters.motion_movers = self.mover_count as u64;
        }
        mirror.movers.clear();
        if self.lighting_cpu.movers != self.movers.address() {
            self.lighting_cpu.movers = self.movers.address();
            self.lighting_dirty = true;
        }
        if camera_dirty {
            let camera = mirror.gpu_camera();
            let bytes = bytemuck::bytes_of(&camera);
            let src = up.staging.push(bytes);
            copies.buffer_copy(up.staging.buffer(), self.camera.buffer()).push(src, 0, bytes.len() as u64);
            up.bytes += bytes.len() as u64;
        }
        // The culling records' address (their table may have been replaced above).
        if self.lighting_cpu.culls != self.culls.address() {
            self.lighting_cpu.culls = self.culls.address();
            self.lighting_dirty = true;
        }
        if std::mem::take(&mut self.lighting_dirty) {
            let bytes = bytemuck::bytes_of(&self.lighting_cpu);
            let src = up.staging.push(bytes);
            copies.buffer_copy(up.staging.buffer(), self.lighting.buffer()).push(src, 0, bytes.len() as u64);
            up.bytes += bytes.len() as u64;
        }
        counters.bytes_uploaded += std::mem::take(&mut up.bytes);

        let res = self.res;
        let result = f
            .pass("upload", PassKind::Transfer)
            .write(res.tables, BufferUse::Transfer)
            .when(new_meshes, |p| p.write(res.meshes, BufferUse::Transfer))
            .upload_images(res.textures, copies.images())
            .record(|p| copies.record(p.ctx, p.cmd))?;
        self.copies = copies;
        result.map(|()| decal_boxes_changed)
    }

    /// Lists this frame's movers and their draws for the motion-vector pass: the instances that
    /// moved (with their previous transforms) and, unless the pipeline finds their motion per
    /// pixel, those whose posed mesh was skinned (whose previous positions then differ), each
    /// once.
    fn upload_movers(&mut self, up: &mut Upload, copies: &mut CopyList, mirror: &mut SceneMirror) -> Result<(), RenderError> {
        self.mover_records.clear();
        self.mover_commands.clear();
        // The first command's place holds the count (the draw is a count-draw: see
        // `crate::motion`).
        self.mover_commands.push(GpuDrawCommand::zeroed());
        let posed =
            mirror.poses.jobs().iter().filter_map(|&mesh| mirror.posed_slot(mesh)).filter(|&slot| mirror.movers.prev_model(slot).is_none());
        let still = |slot: u32| mirror.instances.get(slot).map(|i| i.model);
        let rigid = mirror.movers.iter().map(|(slot, prev)| (slot, Some(prev)));
        for (slot, prev) in rigid.chain(posed.map(|slot| (slot, None))) {
            // Blended surfaces write no motion (what is behind them keeps its own).
            let Some(Some(draw)) = mirror.draws.get(slot as usize).filter(|d| d.is_some_and(|d| !d.transparent)) else { continue };
            let (Some(info), Some(prev_model)) = (self.mesh_info.get(draw.mesh.0 as usize), prev.or_else(|| still(slot))) else { continue };
            if info.index_count == 0 {
                continue;
            }
            let previous = if mirror.poses.is_posed(draw.mesh) {
                info.vertices + crate::scene::vertex::previous_positions_offset(info.vertex_count)
            } else {
                0
            };
            self.mover_commands.push(GpuDrawCommand {
                index_count: info.index_count,
                instance_count: 1,
                first_index: info.first_index,
                vertex_offset: info.vertex_offset,
                first_instance: self.mover_records.len() as u32,
            });
            self.mover_records.push(GpuMover { prev_model, slot, vertex_offset: info.vertex_offset, previous });
        }
        self.mover_count = self.mover_records.len() as u32;
        self.mover_commands[0].index_count = self.mover_count;
        upload_array(up, copies, &mut self.movers, bytemuck::cast_slice(&self.mover_records))?;
        upload_array(up, copies, &mut self.mover_draws, bytemuck::cast_slice(&self.mover_commands))
    }

    /// Sets the deferred decals' draw order (uploaded with the next sync when it changed).
    pub fn set_decal_order(&mut self, order: &[u32]) {
        self.decal_order.set(order);
    }

    /// Destroys everything; the GPU must be idle.
    pub fn destroy(self, ctx: &GpuContext) {
        for t in [
            self.instances,
            self.materials,
            self.lights,
            self.camera,
            self.lighting,
            self.decals,
            self.decal_aabbs,
            self.decal_materials,
            self.mesh_table,
            self.decal_order.table,
            self.shadow_views.table,
            self.culls,
            self.glass_order.table,
            self.skin_input.table,
            self.movers,
            self.mover_draws,
        ] {
            t.buffer.destroy(ctx);
        }
        if let Some(pool) = self.mesh_pool {
            pool.destroy(ctx);
        }
        for t in self.textures.into_iter().flatten() {
            t.destroy(ctx);
        }
        // SAFETY: the GPU is idle; these objects belong to this device.
        unsafe {
            ctx.destroying().destroy_sampler(self.repeat_sampler, None);
            ctx.destroying().destroy_sampler(self.clamp_sampler, None);
            ctx.destroying().destroy_descriptor_pool(self.pool, None);
            ctx.destroying().destroy_descriptor_set_layout(self.set_layout, None);
        }
    }
}
