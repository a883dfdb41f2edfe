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
//! [`crate::gpu::upload::SHRINK_AFTER_FRAMES`] frames is replaced by one with room for the
//! count's power of two (through the graveyard, like a grow) and every record is uploaded again
//! ([`crate::gpu::upload::Shrink`]). Never below the table's initial capacity, its floor: 64
//! instances, materials, decals, decal boxes, meshes and decal-order entries, 16 lights and
//! decal materials, one camera and one lighting record (about 20 KiB in all). Kept as they are:
//! the bindless texture array (its textures are freed with their assets), the samplers and the
//! descriptor set. The decal boxes past the slot count are padding a BLAS build may read, so the
//! places a trim drops are re-parked ([`SlotTable::trimmed_tail`]). The mirror's CPU vectors keep
//! their capacity.

use ash::vk;
use bytemuck::{Pod, Zeroable};
use gpu_allocator::MemoryLocation;

use crate::RenderError;
use crate::gpu::device::{GpuContext, Tier};
use crate::gpu::memory::{Buffer, Image, ImageDesc, Retired};
use crate::gpu::upload::{CopyList, Shrink, StagingRing, Upload};
use crate::graph::{Bind, BufferUse, Frame, FrameGraph, PassKind, ResourceId};
use crate::layout::{GpuDrawCommand, GpuLighting, GpuMover, LOD_LEVELS};
use crate::scene::pool::{POOL_FLOOR, RangeAllocator, footprint};
use crate::scene::{
    GpuAabb, GpuCamera, GpuMeshInfo, GpuSkinVertex, MeshData, MeshId, RESERVED_TEXTURES, SceneMirror, SlotTable, TEXTURE_FLAT_NORMAL,
    TEXTURE_WHITE, TextureData,
};
use crate::stats::FrameCounters;

/// Bindless array size.
pub const MAX_TEXTURES: u32 = 4096;
/// Descriptor bindings after the texture array, one per sampled render target (`BINDING_*`).
pub const TARGET_BINDINGS: u32 = crate::layout::BINDING_ANTIALIASED;
/// Storage-image bindings after those: the decal buffer (`BINDING_DECAL_*`), the shadow debug
/// image, depth peeling's background depth, the HDR target, the anti-aliased colour and the
/// reflection pass's three images; then the environment's (`crate::environment`: its two cubes
/// and the BRDF table sampled, the cubes' levels and the table as storage images); then the
/// decal buffer's emission and the ambient occlusion's two images, storage images again; then
/// the motion vectors (storage) and temporal anti-aliasing's two history images, sampled and as
/// storage images; then SMAA's edges and weights and the reflections' resolved term (storage).
const _: () = assert!(crate::layout::BINDING_DECAL_ALBEDO == TARGET_BINDINGS + 1, "storage bindings follow the sampled targets");
const _: () = assert!(crate::layout::BINDING_ENVIRONMENT == crate::layout::BINDING_REFLECTION_RAYS + 1, "the environment follows them");
/// The sampled bindings among the storage images': the environment's cubes and BRDF table, and
/// temporal anti-aliasing's history.
const SAMPLED_LATE: [u32; 5] = [
    crate::layout::BINDING_ENVIRONMENT,
    crate::layout::BINDING_ENVIRONMENT_SOURCE,
    crate::layout::BINDING_BRDF_LUT,
    crate::layout::BINDING_TAA_HISTORY_A,
    crate::layout::BINDING_TAA_HISTORY_B,
];
const BINDINGS: usize = 1 + crate::layout::BINDING_REFLECTION_ADDED as usize;

/// A device-local array of records that grows geometrically and shrinks by the
/// [`Shrink`] rule, never below its initial capacity.
pub struct GpuTable {
    name: &'static str,
    buffer: Buffer,
    capacity: u32,
    /// The initial capacity, which it never shrinks below.
    floor: u32,
    stride: u64,
    extra_usage: vk::BufferUsageFlags,
    /// Fill the slots past the mirror's high-water mark when the buffer is (re)created, and
    /// those a trim drops, for readers that go past it (the decal BLAS build).
    fill_tail: bool,
    shrink: Shrink,
    /// The capacity this frame replaces the buffer with ([`GpuTable::plan`]).
    planned: Option<u32>,
}

impl GpuTable {
    fn new<T: Pod>(ctx: &GpuContext, name: &'static str, capacity: u32) -> Result<Self, RenderError> {
        Self::with_usage::<T>(ctx, name, capacity, vk::BufferUsageFlags::empty(), false)
    }

    fn with_usage<T: Pod>(
        ctx: &GpuContext,
        name: &'static str,
        capacity: u32,
        extra_usage: vk::BufferUsageFlags,
        fill_tail: bool,
    ) -> Result<Self, RenderError> {
        let stride = std::mem::size_of::<T>() as u64;
        let buffer = Self::create(ctx, name, stride * capacity as u64, extra_usage)?;
        Ok(Self { name, buffer, capacity, floor: capacity, stride, extra_usage, fill_tail, shrink: Shrink::default(), planned: None })
    }

    fn create(ctx: &GpuContext, name: &str, size: u64, extra_usage: vk::BufferUsageFlags) -> Result<Buffer, RenderError> {
        Buffer::new(
            ctx,
            name,
            size,
            vk::BufferUsageFlags::STORAGE_BUFFER
                | vk::BufferUsageFlags::TRANSFER_DST
                | vk::BufferUsageFlags::SHADER_DEVICE_ADDRESS
                | extra_usage,
            MemoryLocation::GpuOnly,
        )
    }

    /// Number of records the buffer holds.
    pub fn capacity(&self) -> u32 {
        self.capacity
    }

    /// Device address of record 0.
    pub fn address(&self) -> vk::DeviceAddress {
        self.buffer.address
    }

    /// The Vulkan buffer.
    pub fn buffer(&self) -> vk::Buffer {
        self.buffer.raw
    }

    /// Decides, once a frame, whether the buffer is replaced this frame for `slots` records:
    /// grown (geometrically) when they do not fit, shrunk by the [`Shrink`] rule. Returns
    /// true when it will be (every record must then be uploaded again).
    fn plan(&mut self, slots: u32) -> bool {
        let smaller = self.shrink.check(self.capacity as u64, slots as u64, self.floor as u64);
        self.planned =
            if slots > self.capacity { Some(slots.next_power_of_two().max(self.capacity * 2)) } else { smaller.map(|c| c as u32) };
        self.planned.is_some()
    }

    /// Replaces the buffer as planned (the old one waits in the graveyard for the frames that
    /// use it). Returns true when it did, in which case every record must be uploaded again.
    fn apply(&mut self, up: &mut Upload) -> Result<bool, RenderError> {
        let Some(capacity) = self.planned.take() else { return Ok(false) };
        let size = self.stride * capacity as u64;
        let old = std::mem::replace(&mut self.buffer, Self::create(up.ctx, self.name, size, self.extra_usage)?);
        if capacity < self.capacity {
            tracing::debug!(table = self.name, from = self.capacity, to = capacity, "table shrinks");
            up.bury_shrunk(old, size);
        } else {
            up.graveyard.bury(up.frame_value, Retired::Buffer(old));
        }
        self.shrink.reset();
        self.capacity = capacity;
        Ok(true)
    }

    /// The capacity the buffer has once this frame's plan is applied.
    fn planned_capacity(&self) -> u32 {
        self.planned.unwrap_or(self.capacity)
    }
}

/// Fills `out` with records for unused slots from `first` on, made from the live records.
type TailFn<T> = fn(&[T], u32, &mut [T]);

fn decal_parking(live: &[GpuAabb], first: u32, out: &mut [GpuAabb]) {
    for (slot, parked) in out.iter_mut().zip(GpuAabb::parking(live, first, u32::MAX)) {
        *slot = parked;
    }
}

/// Copies the dirty records of `table` (or all of them after the buffer was replaced) through
/// the staging ring into `gpu`. Contiguous dirty slots become one copy region. With a `tail`,
/// the slots past the table's count are filled with its records when the buffer is replaced,
/// and those a trim dropped are filled again.
fn upload_table<T: Pod>(
    up: &mut Upload,
    copies: &mut CopyList,
    table: &mut SlotTable<T>,
    gpu: &mut GpuTable,
    tail: Option<TailFn<T>>,
) -> Result<(), RenderError> {
    let replaced = gpu.apply(up)?;
    let capacity = gpu.capacity;
    let trimmed = table.trimmed_tail();
    let refill = match tail {
        Some(_) if !replaced => trimmed.start.min(capacity)..trimmed.end.min(capacity),
        _ => 0..0,
    };
    if !replaced && table.dirty_count() == 0 && refill.is_empty() {
        return Ok(());
    }
    let stride = gpu.stride;
    let mut copy = copies.buffer_copy(up.staging.buffer(), gpu.buffer());
    let staging = &mut *up.staging;
    table.take_dirty(|dirty, records| {
        // Records `tail` makes for slots `range`, written straight into the staging ring.
        let mut park = |range: std::ops::Range<u32>| {
            let Some(tail) = tail.filter(|_| !range.is_empty()) else { return };
            let len = (range.end - range.start) as u64 * stride;
            let src = staging.push_with(len as usize, |dst| tail(records, range.start, bytemuck::cast_slice_mut(dst)));
            copy.push(src, range.start as u64 * stride, len);
        };
        if replaced {
            park(records.len() as u32..capacity);
            let bytes = bytemuck::cast_slice(records);
            if !bytes.is_empty() {
                copy.push(staging.push(bytes), 0, bytes.len() as u64);
            }
            return;
        }
        park(refill.clone());
        let mut i = 0;
        while i < dirty.len() {
            let first = dirty[i];
            let mut last = first;
            while i + 1 < dirty.len() && dirty[i + 1] == last + 1 {
                i += 1;
                last += 1;
            }
            let bytes = bytemuck::cast_slice(&records[first as usize..=last as usize]);
            copy.push(staging.push(bytes), first as u64 * stride, bytes.len() as u64);
            i += 1;
        }
    });
    up.bytes += copy.bytes();
    Ok(())
}

/// A [`SlotTable`] of any record type, as the uploader sees it.
trait DirtyTable {
    fn upload(&mut self, up: &mut Upload, copies: &mut CopyList, gpu: &mut GpuTable) -> Result<(), RenderError>;
}

impl<T: Pod> DirtyTable for SlotTable<T> {
    fn upload(&mut self, up: &mut Upload, copies: &mut CopyList, gpu: &mut GpuTable) -> Result<(), RenderError> {
        upload_table(up, copies, self, gpu, None)
    }
}

/// Uploads a whole array into `gpu` (replaced first when planned: [`GpuTable::plan`] with the
/// array's length). For small tables that change rarely (the mesh table, the deferred decal
/// order).
fn upload_array(up: &mut Upload, copies: &mut CopyList, gpu: &mut GpuTable, bytes: &[u8]) -> Result<(), RenderError> {
    gpu.apply(up)?;
    if !bytes.is_empty() {
        let src = up.staging.push(bytes);
        copies.buffer_copy(up.staging_buffer(), gpu.buffer()).push(src, 0, bytes.len() as u64);
        up.bytes += bytes.len() as u64;
    }
    Ok(())
}

/// An array of 32-bit words the CPU rewrites whole (a draw order, a list of views), uploaded
/// with the next sync only when its contents changed.
pub struct WordArray {
    /// The GPU copy.
    pub table: GpuTable,
    cpu: Vec<u32>,
    dirty: bool,
}

impl WordArray {
    fn new(ctx: &GpuContext, name: &'static str) -> Result<Self, RenderError> {
        Ok(Self { table: GpuTable::new::<u32>(ctx, name, 64)?, cpu: Vec::new(), dirty: false })
    }

    /// Replaces the words; they are uploaded with the next sync if they differ.
    pub fn set(&mut self, words: &[u32]) {
        if self.cpu != words {
            self.cpu.clear();
            self.cpu.extend_from_slice(words);
            self.dirty = true;
        }
    }

    /// The buffer's address.
    pub fn address(&self) -> vk::DeviceAddress {
        self.table.address()
    }

    fn plan(&mut self) {
        if self.table.plan(self.cpu.len() as u32) {
            self.dirty = true;
        }
    }

    fn staging_need(&self) -> u64 {
        if self.dirty { 2 * (4 * self.cpu.len()) as u64 } else { 0 }
    }
}

/// The skinning pass's input (`crate::skinning`): rewritten whole in each frame that skins,
/// by the pose table straight into the staging memory, so the poses' matrices are copied once on
/// the CPU (10,000 foxes: 11.5 MB a frame).
pub struct SkinInput {
    /// The GPU copy.
    pub table: GpuTable,
    words: usize,
    dirty: bool,
}

impl SkinInput {
    /// Uploads `words` 32-bit words of input with the next sync (none: nothing to upload).
    pub fn set_len(&mut self, words: usize) {
        self.words = words;
        self.dirty = words > 0;
    }

    /// The buffer's address.
    pub fn address(&self) -> vk::DeviceAddress {
        self.table.address()
    }

    fn plan(&mut self) {
        // A replaced buffer needs nothing copied over: the input is this frame's alone.
        self.table.plan(self.words as u32);
    }

    fn staging_need(&self) -> u64 {
        if self.dirty { (4 * self.words) as u64 } else { 0 }
    }
}

/// Bytes the dirty records of `table` need in the staging ring (worst case: all of them), after
/// the frame's [`GpuTable::plan`].
fn staging_need<T: Pod>(table: &SlotTable<T>, gpu: &GpuTable) -> u64 {
    let stride = std::mem::size_of::<T>() as u64;
    if gpu.planned.is_some() {
        // The whole new capacity (records plus any tail), in two pieces.
        gpu.planned_capacity() as u64 * stride + 48
    } else {
        // Contiguous slots share a piece; a trimmed tail to re-park is one more.
        let trimmed = if gpu.fill_tail { table.trimmed_tail() } else { 0..0 };
        table.dirty_count() as u64 * (stride + 16) + (trimmed.end - trimmed.start) as u64 * stride + 16
    }
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

/// A mesh's place in the mesh pool ([`crate::scene::pool`]): its vertices, then its indices,
/// then (for a skinned mesh) its joints and weights; a posed mesh's vertices, then their
/// previous positions (its indices and skin are its source's).
#[derive(Clone, Copy, Debug)]
pub struct GpuMesh {
    /// Byte offset of the first vertex in the pool buffer.
    pub offset: u64,
    /// Bytes of its range.
    pub bytes: u64,
    /// Number of indices.
    pub index_count: u32,
    /// Number of vertices.
    pub vertex_count: u32,
    /// Whether joints and weights follow the indices.
    pub skinned: bool,
    /// Morph targets (their offsets follow the skin).
    pub morph_targets: u32,
    /// The skinned mesh a posed mesh copies.
    pub source: Option<MeshId>,
    /// Indices of each coarser level of detail (`crate::lod`), which follow level 0's.
    pub lod_counts: [u32; LOD_LEVELS as usize],
    /// Each coarser level's error (a fraction of the mesh's bounds' diagonal).
    pub lod_errors: [f32; LOD_LEVELS as usize],
    /// Bytes of the skinning pass's table of its levels' vertices (`MeshLods::skin_table`),
    /// which follows the skin; 0 without.
    pub skin_table_bytes: u64,
}

impl GpuMesh {
    /// Byte offset of the first index in the pool buffer (a posed mesh's are its source's).
    pub fn index_offset(&self) -> u64 {
        self.offset + self.vertex_count as u64 * std::mem::size_of::<crate::scene::GpuVertex>() as u64
    }

    /// Indices of every level together (level 0 and the coarser levels after it).
    fn all_indices(&self) -> u64 {
        self.index_count as u64 + self.lod_counts.iter().map(|&c| c as u64).sum::<u64>()
    }

    /// Byte offset of the joints and weights of a skinned mesh (after every level's indices).
    fn skin_offset(&self) -> u64 {
        (self.index_offset() + self.all_indices() * 4).next_multiple_of(16)
    }

    /// Byte offset of the skinning pass's table of its levels' vertices (after the skin).
    fn skin_table_offset(&self) -> u64 {
        let skin = if self.skinned { self.vertex_count as u64 * std::mem::size_of::<GpuSkinVertex>() as u64 } else { 0 };
        (self.skin_offset() + skin).next_multiple_of(16)
    }

    /// Byte offset of the morph targets' offsets (after the skin and its levels' table, if
    /// any).
    fn morph_offset(&self) -> u64 {
        (self.skin_table_offset() + self.skin_table_bytes).next_multiple_of(16)
    }

    /// The table entry of a mesh that is not posed.
    fn info(&self, pool: vk::DeviceAddress) -> GpuMeshInfo {
        let vertices = pool + self.offset;
        GpuMeshInfo {
            vertices,
            indices: pool + self.index_offset(),
            first_index: (self.index_offset() / 4) as u32,
            index_count: self.index_count,
            vertex_offset: (self.offset / std::mem::size_of::<crate::scene::GpuVertex>() as u64) as u32,
            vertex_count: self.vertex_count,
            rest: vertices,
            skin: if self.skinned { pool + self.skin_offset() } else { 0 },
            morphs: if self.morph_targets > 0 { pool + self.morph_offset() } else { 0 },
            morph_targets: self.morph_targets,
            lod_levels: self.lod_counts.iter().take_while(|&&c| c > 0).count() as u32,
            pad: [0; 2],
            lod_first: std::array::from_fn(|level| {
                let before: u64 = self.index_count as u64 + self.lod_counts[..level].iter().map(|&c| c as u64).sum::<u64>();
                (self.index_offset() / 4 + before) as u32
            }),
            lod_count: self.lod_counts,
            lod_error: self.lod_errors.into(),
            vertex_levels: if self.skin_table_bytes > 0 { pool + self.skin_table_offset() } else { 0 },
        }
    }

    /// The table entry of a posed mesh: its own vertices over its source's indices, rest
    /// vertices and skin. Nothing to draw or skin when the source is gone or no longer has its
    /// vertex count (it was replaced).
    fn posed_info(&self, pool: vk::DeviceAddress, source: Option<&GpuMesh>) -> GpuMeshInfo {
        let posable = |s: &&GpuMesh| (s.skinned || s.morph_targets > 0) && s.vertex_count == self.vertex_count;
        let Some(source) = source.filter(posable) else { return GpuMeshInfo::default() };
        let vertices = pool + self.offset;
        GpuMeshInfo {
            vertices,
            vertex_offset: (self.offset / std::mem::size_of::<crate::scene::GpuVertex>() as u64) as u32,
            ..source.info(pool)
        }
    }
}

/// The bytes a posed mesh of `vertices` takes: its vertices and a previous position (vec4) each.
fn posed_bytes(vertices: u32) -> u64 {
    vertices as u64 * (std::mem::size_of::<crate::scene::GpuVertex>() as u64 + 16)
}

/// The bytes a mesh takes in the pool: vertices, indices, then (each 16-byte aligned) its skin
/// and its morph targets.
/// The skinning pass's table of a skinned mesh's levels (`MeshLods::skin_table`; empty without).
fn skin_table(m: &MeshData) -> Vec<u32> {
    match &m.lods {
        Some(lods) if !m.skin.is_empty() => lods.skin_table(m.vertices.len()),
        _ => Vec::new(),
    }
}

fn mesh_bytes(m: &MeshData) -> u64 {
    let mut bytes = RangeAllocator::mesh_bytes(m.vertices.len(), m.indices.len() + m.lods.as_ref().map_or(0, |l| l.indices.len()));
    if !m.skin.is_empty() {
        bytes = bytes.next_multiple_of(16) + (m.skin.len() * std::mem::size_of::<GpuSkinVertex>()) as u64;
        bytes = bytes.next_multiple_of(16) + skin_table(m).len() as u64 * 4;
    }
    if !m.morphs.is_empty() {
        bytes = bytes.next_multiple_of(16) + std::mem::size_of_val(m.morphs.as_slice()) as u64;
    }
    bytes
}

/// What the mesh pool does this frame.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
enum PoolPlan {
    Keep,
    /// Repack the live meshes into a buffer of this many bytes.
    Repack(u64),
    /// No mesh has been live for a while: the buffer goes.
    Release,
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
    /// Whether this frame draws motion vectors (set before the upload): only then are movers
    /// uploaded.
    pub motion_wanted: bool,
    /// Whether this frame's pipeline finds posed meshes' motion per pixel (`crate::motion`):
    /// then they are movers only when they moved as a whole.
    pub posed_motion_per_pixel: bool,
    mover_records: Vec<GpuMover>,
    mover_commands: Vec<GpuDrawCommand>,
    /// Meshes by [`MeshId`], placed in the pool.
    pub meshes: Vec<Option<GpuMesh>>,
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
    /// The graph resources the scene's buffers and textures are tracked as.
    pub res: SceneResources,
    mesh_usage: vk::BufferUsageFlags,
}

/// The descriptor type of a binding of set 0.
fn descriptor_type(binding: u32) -> vk::DescriptorType {
    let storage = binding > TARGET_BINDINGS && !SAMPLED_LATE.contains(&binding);
    if storage { vk::DescriptorType::STORAGE_IMAGE } else { vk::DescriptorType::COMBINED_IMAGE_SAMPLER }
}

/// How many descriptors a binding of set 0 holds.
fn descriptor_count(binding: u32) -> u32 {
    match binding {
        0 => MAX_TEXTURES,
        crate::layout::BINDING_ENVIRONMENT_LEVELS => crate::layout::ENVIRONMENT_LEVEL_VIEWS,
        _ => 1,
    }
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
            motion_wanted: false,
            posed_motion_per_pixel: false,
            mover_records: Vec::new(),
            mover_commands: Vec::new(),
            meshes: Vec::new(),
            mesh_pool: None,
            ranges: RangeAllocator::default(),
            released_ranges: Vec::new(),
            pool_shrink: Shrink::default(),
            textures: (0..RESERVED_TEXTURES).map(|_| None).collect(),
            set_layout,
            pool,
            set,
            repeat_sampler,
            clamp_sampler,
            released_textures: Vec::new(),
            copies: CopyList::default(),
            builtins: Vec::new(),
            res: SceneResources {
                tables: graph.resource("scene tables"),
                meshes: graph.resource("meshes"),
                textures: graph.resource("textures"),
            },
            mesh_usage,
        };
        // The built-in textures go up with the first frame's upload, like any other texture.
        let white = TextureData { width: 1, height: 1, srgb: false, mips: vec![vec![255, 255, 255, 255]] };
        let flat_normal = TextureData { width: 1, height: 1, srgb: false, mips: vec![vec![128, 128, 255, 255]] };
        scene.builtins = vec![(TEXTURE_WHITE, white), (TEXTURE_FLAT_NORMAL, flat_normal)];
        Ok(scene)
    }

    /// Writes a render target's `view` into its bindless slot, with the clamp sampler. Only for
    /// slots no pending frame samples. Depth is sampled in `DEPTH_READ_ONLY_OPTIMAL`, so it can be
    /// a read-only depth attachment in the same pass.
    pub fn bind_target(&self, ctx: &GpuContext, bind: Bind, view: vk::ImageView) {
        let (binding, layout) = match bind {
            Bind::Color(binding) => (binding, vk::ImageLayout::SHADER_READ_ONLY_OPTIMAL),
            Bind::Depth(binding) => (binding, vk::ImageLayout::DEPTH_READ_ONLY_OPTIMAL),
            Bind::Storage(binding) => (binding, vk::ImageLayout::GENERAL),
        };
        let sampler = if bind.is_storage() { vk::Sampler::null() } else { self.clamp_sampler };
        self.write_descriptor_at(ctx, binding, 0, view, sampler, layout);
    }

    /// Writes `view` into element `index` of `binding` in the GENERAL layout (the environment's
    /// images, which its passes write as storage and shading samples), with `sampler` (null for a
    /// storage binding). Only for elements no pending frame uses.
    pub fn bind_general(&self, ctx: &GpuContext, binding: u32, index: u32, view: vk::ImageView, sampler: vk::Sampler) {
        self.write_descriptor_at(ctx, binding, index, view, sampler, vk::ImageLayout::GENERAL);
    }

    fn write_descriptor(&self, ctx: &GpuContext, slot: u32, view: vk::ImageView, sampler: vk::Sampler) {
        self.write_descriptor_at(ctx, 0, slot, view, sampler, vk::ImageLayout::SHADER_READ_ONLY_OPTIMAL);
    }

    fn write_descriptor_at(
        &self,
        ctx: &GpuContext,
        binding: u32,
        slot: u32,
        view: vk::ImageView,
        sampler: vk::Sampler,
        layout: vk::ImageLayout,
    ) {
        let info = [vk::DescriptorImageInfo { sampler, image_view: view, image_layout: layout }];
        let write = vk::WriteDescriptorSet::default()
            .dst_set(self.set)
            .dst_binding(binding)
            .dst_array_element(slot)
            .descriptor_type(descriptor_type(binding))
            .image_info(&info);
        // SAFETY: the slot is not used by any pending command buffer (fresh, recycled after
        // completion, or a target rewritten after a wait for idle); the binding is
        // update-after-bind.
        unsafe { ctx.device.update_descriptor_sets(&[write], &[]) };
    }

    /// Creates the image for `data` and prepares its upload: the staging buffer is buried with
    /// this frame, the copy goes into `copies`.
    fn prepare_texture(&mut self, up: &mut Upload, copies: &mut CopyList, slot: u32, data: &TextureData) -> Result<(), RenderError> {
        let ctx = up.ctx;
        if slot >= MAX_TEXTURES {
            return Err(RenderError::Other(format!("texture slot {slot} exceeds the bindless array ({MAX_TEXTURES})")));
        }
        let mut offset = 0usize;
        for (level, mip) in data.mips.iter().enumerate() {
            let (w, h) = ((data.width >> level).max(1), (data.height >> level).max(1));
            if mip.len() != (w * h * 4) as usize {
                return Err(RenderError::Other(format!("texture mip {level} has {} bytes, expected {}", mip.len(), w * h * 4)));
            }
            offset += mip.len();
        }
        let mut staging = Buffer::new(ctx, "texture staging", offset as u64, vk::BufferUsageFlags::TRANSFER_SRC, MemoryLocation::CpuToGpu)?;
        let src = staging.raw;
        let mapped = staging.mapped();
        let mut offset = 0usize;
        let regions = data.mips.iter().enumerate().map(|(level, mip)| {
            mapped[offset..offset + mip.len()].copy_from_slice(mip);
            let region = vk::BufferImageCopy {
                buffer_offset: offset as u64,
                image_subresource: vk::ImageSubresourceLayers {
                    aspect_mask: vk::ImageAspectFlags::COLOR,
                    mip_level: level as u32,
                    base_array_layer: 0,
                    layer_count: 1,
                },
                image_extent: vk::Extent3D { width: (data.width >> level).max(1), height: (data.height >> level).max(1), depth: 1 },
                ..Default::default()
            };
            offset += mip.len();
            region
        });
        let image = Image::new(
            ctx,
            &ImageDesc {
                name: "texture",
                format: if data.srgb { vk::Format::R8G8B8A8_SRGB } else { vk::Format::R8G8B8A8_UNORM },
                extent: vk::Extent2D { width: data.width, height: data.height },
                mip_levels: data.mips.len() as u32,
                usage: vk::ImageUsageFlags::SAMPLED | vk::ImageUsageFlags::TRANSFER_DST,
                samples: 1,
            },
        )?;
        copies.image_copy(src, image.raw, image.full_range(), regions);
        up.bytes += offset as u64;
        up.graveyard.bury(up.frame_value, Retired::Buffer(staging));
        self.write_descriptor(ctx, slot, image.view, self.repeat_sampler);
        if self.textures.len() <= slot as usize {
            self.textures.resize_with(slot as usize + 1, || None);
        }
        if let Some(old) = self.textures[slot as usize].replace(image) {
            old.destroy(ctx); // only reachable for built-ins during setup
        }
        Ok(())
    }

    /// Brings the GPU scene up to date with `mirror`: prepares copies of what is dirty (only
    /// dirty records, new meshes and new textures) and records them as the frame's `upload`
    /// pass. Returns the number of decal boxes rewritten (they drive the BLAS refit).
    pub fn upload(&mut self, f: &mut Frame, mirror: &mut SceneMirror, counters: &mut FrameCounters) -> Result<u32, RenderError> {
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
            self.released_textures.push((up.frame_value, slot));
        }
        let mut released_source = false;
        for id in mirror.released_meshes.drain(..) {
            if let Some(mesh) = self.meshes.get_mut(id.0 as usize).and_then(Option::take) {
                self.released_ranges.push((up.frame_value, mesh.offset, mesh.bytes));
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
        let posed_movers = if self.posed_motion_per_pixel { 0 } else { mirror.poses.jobs().len() };
        let movers = if self.motion_wanted { (mirror.movers.len() + posed_movers) as u32 } else { 0 };
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
        for (slot, data) in std::mem::take(&mut mirror.pending_textures) {
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
        let vertex_bytes = std::mem::size_of::<crate::scene::GpuVertex>() as u64;
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
            let previous = if mirror.poses.is_posed(draw.mesh) { info.vertices + info.vertex_count as u64 * vertex_bytes } else { 0 };
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

    /// Once a frame: returns ranges whose frames have completed, and decides whether the pool
    /// is repacked (to fit `incoming`, or smaller by the shrink rule) or released.
    fn plan_pool(&mut self, completed: u64, incoming: &[u64]) -> PoolPlan {
        let ranges = &mut self.ranges;
        self.released_ranges.retain(|&(after, offset, bytes)| {
            let done = after <= completed;
            if done {
                ranges.free(offset, bytes);
            }
            !done
        });
        let live: u64 = self.meshes.iter().flatten().map(|m| footprint(m.bytes)).sum();
        if !incoming.is_empty() {
            let sizes = incoming.iter().copied();
            let mut trial = self.ranges.clone();
            if self.mesh_pool.is_some() && sizes.clone().all(|size| trial.alloc(size).is_some()) {
                return PoolPlan::Keep;
            }
            let need = live + sizes.map(footprint).sum::<u64>();
            return PoolPlan::Repack(need.next_power_of_two().max(POOL_FLOOR).max(self.ranges.capacity()));
        }
        let Some(pool) = self.mesh_pool.as_ref() else { return PoolPlan::Keep };
        if live == 0 {
            return if self.pool_shrink.unused() { PoolPlan::Release } else { PoolPlan::Keep };
        }
        match self.pool_shrink.check(pool.size, live, POOL_FLOOR) {
            Some(capacity) => PoolPlan::Repack(capacity),
            None => PoolPlan::Keep,
        }
    }

    /// Carries out the pool's `plan` (the live meshes copied into a new buffer, back to back),
    /// then places the pending meshes and prepares their copies.
    fn prepare_meshes(
        &mut self,
        up: &mut Upload,
        copies: &mut CopyList,
        mirror: &mut SceneMirror,
        plan: PoolPlan,
    ) -> Result<(), RenderError> {
        let ctx = up.ctx;
        match plan {
            PoolPlan::Keep => {}
            PoolPlan::Release => {
                if let Some(old) = self.mesh_pool.take() {
                    up.bury_shrunk(old, 0);
                }
                self.ranges = RangeAllocator::default();
                self.released_ranges.clear();
                self.pool_shrink.reset();
            }
            PoolPlan::Repack(capacity) => {
                let new = Buffer::new(ctx, "mesh pool", capacity, self.mesh_usage, MemoryLocation::GpuOnly)?;
                let mut end = 0u64;
                if let Some(old) = self.mesh_pool.as_ref() {
                    let mut copy = copies.buffer_copy(old.raw, new.raw);
                    for mesh in self.meshes.iter_mut().flatten() {
                        copy.push(mesh.offset, end, mesh.bytes);
                        mesh.offset = end;
                        end += footprint(mesh.bytes);
                    }
                }
                self.refresh_infos(new.address, |_| true);
                if let Some(old) = self.mesh_pool.replace(new) {
                    if capacity < old.size {
                        up.bury_shrunk(old, capacity);
                    } else {
                        up.graveyard.bury(up.frame_value, Retired::Buffer(old));
                    }
                }
                tracing::debug!(bytes = capacity, live = end, "mesh pool repacked");
                self.ranges = RangeAllocator::packed(capacity, end);
                self.released_ranges.clear();
                self.pool_shrink.reset();
            }
        }
        if mirror.pending_meshes.is_empty() && mirror.pending_posed.is_empty() {
            return Ok(());
        }
        let pending = std::mem::take(&mut mirror.pending_meshes);
        let total: u64 = pending.iter().map(|(_, m)| mesh_bytes(m) + 16).sum();
        let pool = self.mesh_pool.as_ref().expect("planned for the pending meshes");
        let pool_address = pool.address;
        let mut placed = Vec::with_capacity(pending.len() + mirror.pending_posed.len());
        if total > 0 {
            let mut staging = Buffer::new(ctx, "mesh staging", total, vk::BufferUsageFlags::TRANSFER_SRC, MemoryLocation::CpuToGpu)?;
            let mut offset = 0u64;
            for (id, data) in &pending {
                let vbytes: &[u8] = bytemuck::cast_slice(&data.vertices);
                let ibytes: &[u8] = bytemuck::cast_slice(&data.indices);
                let lods = data.lods.clone().unwrap_or_default();
                let lbytes: &[u8] = bytemuck::cast_slice(&lods.indices);
                let size = mesh_bytes(data);
                let table = skin_table(data);
                let place = self.ranges.alloc(size).expect("the plan made room for every pending mesh");
                let mesh = GpuMesh {
                    offset: place,
                    bytes: size,
                    index_count: data.indices.len() as u32,
                    vertex_count: data.vertices.len() as u32,
                    skinned: !data.skin.is_empty(),
                    morph_targets: data.morph_targets,
                    source: None,
                    lod_counts: lods.counts,
                    lod_errors: lods.errors,
                    skin_table_bytes: table.len() as u64 * 4,
                };
                let mapped = staging.mapped();
                let o = offset as usize;
                mapped[o..o + vbytes.len()].copy_from_slice(vbytes);
                let o = o + vbytes.len();
                mapped[o..o + ibytes.len()].copy_from_slice(ibytes);
                let o = o + ibytes.len();
                mapped[o..o + lbytes.len()].copy_from_slice(lbytes);
                let o = offset as usize;
                // The skin, its levels' table and the morph targets where the mesh's offsets say
                // (relative to it).
                for (at, bytes) in [
                    (mesh.skin_offset(), bytemuck::cast_slice::<_, u8>(&data.skin)),
                    (mesh.skin_table_offset(), bytemuck::cast_slice(&table)),
                    (mesh.morph_offset(), bytemuck::cast_slice(&data.morphs)),
                ] {
                    let s = o + (at - place) as usize;
                    mapped[s..s + bytes.len()].copy_from_slice(bytes);
                }
                if size > 0 {
                    copies.buffer_copy(staging.raw, pool.raw).push(offset, place, size);
                }
                offset = (offset + size).next_multiple_of(16);
                up.bytes += size;
                placed.push((*id, mesh));
            }
            up.graveyard.bury(up.frame_value, Retired::Buffer(staging));
        }
        for (slot, mesh) in placed.drain(..) {
            self.place(slot, mesh, up.frame_value);
        }
        // Posed meshes: room only (the skinning pass writes them before anything reads them).
        for (id, source) in std::mem::take(&mut mirror.pending_posed) {
            let Some(src) = self.mesh(source).copied() else { continue };
            let size = posed_bytes(src.vertex_count);
            let place = self.ranges.alloc(size).expect("the plan made room for every posed mesh");
            let mesh = GpuMesh {
                offset: place,
                bytes: size,
                index_count: src.index_count,
                vertex_count: src.vertex_count,
                skinned: false,
                morph_targets: 0,
                source: Some(source),
                lod_counts: [0; LOD_LEVELS as usize],
                lod_errors: [0.0; LOD_LEVELS as usize],
                skin_table_bytes: 0,
            };
            self.place(id, mesh, up.frame_value);
        }
        self.refresh_infos(pool_address, |_| true);
        Ok(())
    }

    /// The pool bytes this frame's new meshes and posed meshes ask for (a posed mesh of a
    /// source not uploaded asks nothing: it is skipped).
    fn incoming_sizes(&self, mirror: &SceneMirror) -> Vec<u64> {
        if mirror.pending_meshes.is_empty() && mirror.pending_posed.is_empty() {
            return Vec::new();
        }
        let mut sizes: Vec<u64> = mirror.pending_meshes.iter().map(|(_, m)| mesh_bytes(m)).collect();
        for &(_, source) in &mirror.pending_posed {
            let pending = mirror.pending_meshes.iter().rev().find(|(id, _)| *id == source).map(|(_, m)| m.vertices.len() as u32);
            if let Some(vertices) = pending.or_else(|| self.mesh(source).map(|m| m.vertex_count)) {
                sizes.push(posed_bytes(vertices));
            }
        }
        sizes
    }

    /// Records mesh `id`'s place, releasing the range it replaces.
    fn place(&mut self, id: MeshId, mesh: GpuMesh, frame_value: u64) {
        let slot = id.0 as usize;
        if self.meshes.len() <= slot {
            self.meshes.resize_with(slot + 1, || None);
        }
        if self.mesh_info.len() <= slot {
            self.mesh_info.resize(slot + 1, GpuMeshInfo::default());
        }
        if let Some(old) = self.meshes[slot].replace(mesh) {
            self.released_ranges.push((frame_value, old.offset, old.bytes));
        }
    }

    /// Rewrites the table entries of the meshes `which` picks (posed ones from their sources).
    fn refresh_infos(&mut self, pool: vk::DeviceAddress, which: impl Fn(&GpuMesh) -> bool) {
        for slot in 0..self.meshes.len() {
            let Some(mesh) = self.meshes[slot].filter(|m| which(m)) else { continue };
            self.mesh_info[slot] = match mesh.source {
                Some(source) => mesh.posed_info(pool, self.mesh(source)),
                None => mesh.info(pool),
            };
        }
        self.mesh_info_dirty = true;
    }

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
        // And the shadow maps' atlas layout (`set_shadow_maps`).
        (lighting.shadow_map_tile, lighting.shadow_map_columns) = (self.lighting_cpu.shadow_map_tile, self.lighting_cpu.shadow_map_columns);
        if lighting != self.lighting_cpu {
            self.lighting_cpu = lighting;
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

    /// Sets the deferred decals' draw order (uploaded with the next sync when it changed).
    pub fn set_decal_order(&mut self, order: &[u32]) {
        self.decal_order.set(order);
    }

    /// The mesh for `id`, once uploaded.
    pub fn mesh(&self, id: MeshId) -> Option<&GpuMesh> {
        self.meshes.get(id.0 as usize).and_then(Option::as_ref)
    }

    /// The addresses of the vertices and indices of mesh `id` and its vertex count, once
    /// uploaded (acceleration-structure builds read them).
    pub fn mesh_geometry(&self, id: MeshId) -> Option<(vk::DeviceAddress, vk::DeviceAddress, u32)> {
        let (mesh, info) = (self.mesh(id)?, self.mesh_info.get(id.0 as usize)?);
        // A posed mesh's indices are its source's; one whose source went has nothing to build.
        (info.index_count > 0 || mesh.index_count == 0).then_some((info.vertices, info.indices, mesh.vertex_count))
    }

    /// The mesh pool's buffer, which every mesh draw binds as its vertex and index buffer.
    pub fn pool_buffer(&self) -> Option<vk::Buffer> {
        self.mesh_pool.as_ref().map(|b| b.raw)
    }

    /// Bytes of the mesh pool's buffer (0 without one).
    pub fn pool_bytes(&self) -> u64 {
        self.mesh_pool.as_ref().map_or(0, |b| b.size)
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

/// Auto-exposure's fields of a lighting record: its address, then compensation, EV100 range and
/// rate.
fn exposure_fields(l: &GpuLighting) -> (u64, [f32; 4]) {
    (l.exposure, [l.exposure_compensation, l.exposure_min_ev100, l.exposure_max_ev100, l.exposure_rate])
}

fn set_exposure_fields(l: &mut GpuLighting, (address, [compensation, min_ev100, max_ev100, rate]): (u64, [f32; 4])) {
    (l.exposure, l.exposure_compensation, l.exposure_min_ev100, l.exposure_max_ev100, l.exposure_rate) =
        (address, compensation, min_ev100, max_ev100, rate);
}
