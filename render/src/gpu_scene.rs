//! The GPU side of the [`SceneMirror`]: device-local record tables, meshes and the bindless
//! texture array, kept in step with the mirror by copying only what is dirty.
//!
//! Tables are reached from shaders through buffer device addresses in push constants, so a table
//! that grows (geometrically) is simply replaced; no descriptor set changes. Textures live in one
//! update-after-bind array of combined image samplers (set 0, binding 0), indexed by the slots the
//! mirror hands out. A freed slot returns to the mirror only after the GPU has finished every
//! frame that could sample it, so a descriptor is never rewritten under a pending frame.

use ash::vk;
use bytemuck::Pod;
use gpu_allocator::MemoryLocation;

use crate::RenderError;
use crate::device::{GpuContext, Tier};
use crate::memory::{Buffer, Graveyard, Image, ImageDesc, Retired};
use crate::scene::{
    FrameCounters, GpuAabb, GpuCamera, GpuMeshInfo, MeshId, RESERVED_TEXTURES, SceneMirror, SlotTable, TEXTURE_FLAT_NORMAL, TEXTURE_WHITE,
    TextureData,
};
use crate::sync::{Access, ImageState, memory_barrier, transition};
use crate::upload::StagingRing;

/// Bindless array size.
pub const MAX_TEXTURES: u32 = 4096;
/// Size of the unsigned-integer array (render targets only).
pub const MAX_UINT_TEXTURES: u32 = 16;

/// A device-local array of records that grows geometrically.
pub struct GpuTable {
    name: &'static str,
    buffer: Buffer,
    capacity: u32,
    stride: u64,
    extra_usage: vk::BufferUsageFlags,
    /// Fill the slots past the mirror's high-water mark when the buffer is (re)created, for
    /// readers that consume the whole capacity (the decal BLAS build).
    fill_tail: bool,
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
        Ok(Self { name, buffer, capacity, stride, extra_usage, fill_tail })
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

    /// Makes room for `slots` records. Returns true when the buffer was replaced, in which case
    /// every record must be uploaded again.
    fn ensure(&mut self, ctx: &GpuContext, graveyard: &mut Graveyard, frame_value: u64, slots: u32) -> Result<bool, RenderError> {
        if slots <= self.capacity {
            return Ok(false);
        }
        let capacity = slots.next_power_of_two().max(self.capacity * 2);
        let old = std::mem::replace(&mut self.buffer, Self::create(ctx, self.name, self.stride * capacity as u64, self.extra_usage)?);
        graveyard.bury(frame_value, Retired::Buffer(old));
        self.capacity = capacity;
        Ok(true)
    }
}

/// Makes records for never-used slots `first..first + count` from the live records.
type TailFn<T> = fn(&[T], u32, u32) -> Box<dyn Iterator<Item = T> + '_>;

fn decal_parking(live: &[GpuAabb], first: u32, count: u32) -> Box<dyn Iterator<Item = GpuAabb> + '_> {
    Box::new(GpuAabb::parking(live, first, count))
}

/// Copies the dirty records of `table` (or all of them after a regrow) through `staging` into
/// `gpu`. Contiguous dirty slots become one copy region.
#[allow(clippy::too_many_arguments)]
fn upload_table<T: Pod>(
    ctx: &GpuContext,
    graveyard: &mut Graveyard,
    frame_value: u64,
    table: &mut SlotTable<T>,
    gpu: &mut GpuTable,
    staging: &mut StagingRing,
    regions: &mut Vec<vk::BufferCopy>,
    counters: &mut FrameCounters,
    tail: Option<TailFn<T>>,
) -> Result<Option<vk::Buffer>, RenderError> {
    let regrown = gpu.ensure(ctx, graveyard, frame_value, table.slot_count())?;
    if !regrown && table.dirty_count() == 0 {
        return Ok(None);
    }
    regions.clear();
    let stride = gpu.stride;
    let capacity = gpu.capacity;
    table.take_dirty(|dirty, records| {
        if regrown {
            let bytes = bytemuck::cast_slice(records);
            if !bytes.is_empty() {
                let src = staging.push(bytes);
                regions.push(vk::BufferCopy { src_offset: src, dst_offset: 0, size: bytes.len() as u64 });
            }
            if let Some(tail) = tail {
                // Only when the table grows (geometrically), so this allocation is rare.
                let first = records.len() as u32;
                let parked: Vec<T> = tail(records, first, capacity - first).collect();
                let bytes: &[u8] = bytemuck::cast_slice(&parked);
                if !bytes.is_empty() {
                    let src = staging.push(bytes);
                    regions.push(vk::BufferCopy { src_offset: src, dst_offset: first as u64 * stride, size: bytes.len() as u64 });
                }
            }
            return;
        }
        let mut i = 0;
        while i < dirty.len() {
            let first = dirty[i];
            let mut last = first;
            while i + 1 < dirty.len() && dirty[i + 1] == last + 1 {
                i += 1;
                last += 1;
            }
            let bytes = bytemuck::cast_slice(&records[first as usize..=last as usize]);
            let src = staging.push(bytes);
            regions.push(vk::BufferCopy { src_offset: src, dst_offset: first as u64 * stride, size: bytes.len() as u64 });
            i += 1;
        }
    });
    if regions.is_empty() {
        return Ok(None);
    }
    counters.bytes_uploaded += regions.iter().map(|r| r.size).sum::<u64>();
    Ok(Some(gpu.buffer()))
}

/// A [`SlotTable`] of any record type, as the uploader sees it.
trait DirtyTable {
    #[allow(clippy::too_many_arguments)]
    fn upload(
        &mut self,
        ctx: &GpuContext,
        graveyard: &mut Graveyard,
        frame_value: u64,
        gpu: &mut GpuTable,
        staging: &mut StagingRing,
        regions: &mut Vec<vk::BufferCopy>,
        counters: &mut FrameCounters,
    ) -> Result<Option<vk::Buffer>, RenderError>;
}

impl<T: Pod> DirtyTable for SlotTable<T> {
    fn upload(
        &mut self,
        ctx: &GpuContext,
        graveyard: &mut Graveyard,
        frame_value: u64,
        gpu: &mut GpuTable,
        staging: &mut StagingRing,
        regions: &mut Vec<vk::BufferCopy>,
        counters: &mut FrameCounters,
    ) -> Result<Option<vk::Buffer>, RenderError> {
        upload_table(ctx, graveyard, frame_value, self, gpu, staging, regions, counters, None)
    }
}

/// Uploads a whole array into `gpu` (growing it as needed). For small tables that change
/// rarely (the mesh table, the deferred decal order).
#[allow(clippy::too_many_arguments)]
fn upload_array(
    ctx: &GpuContext,
    graveyard: &mut Graveyard,
    frame_value: u64,
    gpu: &mut GpuTable,
    bytes: &[u8],
    staging: &mut StagingRing,
    regions: &mut Vec<vk::BufferCopy>,
    counters: &mut FrameCounters,
) -> Result<vk::Buffer, RenderError> {
    gpu.ensure(ctx, graveyard, frame_value, (bytes.len() as u64).div_ceil(gpu.stride) as u32)?;
    regions.clear();
    if !bytes.is_empty() {
        let src = staging.push(bytes);
        regions.push(vk::BufferCopy { src_offset: src, dst_offset: 0, size: bytes.len() as u64 });
        counters.bytes_uploaded += bytes.len() as u64;
    }
    Ok(gpu.buffer())
}

/// What [`GpuScene::sync`] did that later passes need to know.
#[derive(Clone, Copy, Debug, Default)]
pub struct SyncReport {
    /// Decal boxes rewritten this frame (drives the BLAS refit).
    pub decal_boxes_changed: u32,
}

/// Bytes the dirty records of `table` need in the staging ring (worst case: all of them).
fn staging_need<T: Pod>(table: &SlotTable<T>, gpu: &GpuTable) -> u64 {
    let stride = std::mem::size_of::<T>() as u64;
    if table.slot_count() > gpu.capacity {
        // The whole new capacity (records plus any tail), in one piece per slot at worst.
        table.slot_count().next_power_of_two().max(gpu.capacity * 2) as u64 * (stride + 16) + 16
    } else {
        table.dirty_count() as u64 * (stride + 16)
    }
}

/// Geometry on the GPU: vertices followed by indices in one buffer.
pub struct GpuMesh {
    /// The buffer.
    pub buffer: Buffer,
    /// Byte offset of the indices.
    pub index_offset: u64,
    /// Number of indices.
    pub index_count: u32,
    /// Number of vertices.
    pub vertex_count: u32,
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
    pub decal_order: GpuTable,
    decal_order_cpu: Vec<u32>,
    decal_order_dirty: bool,
    /// Meshes by [`MeshId`].
    pub meshes: Vec<Option<GpuMesh>>,
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
    regions: Vec<vk::BufferCopy>,
    mesh_usage: vk::BufferUsageFlags,
}

impl GpuScene {
    /// Creates empty tables, the bindless set and the built-in textures.
    pub fn new(ctx: &GpuContext) -> Result<Self, RenderError> {
        let d = &ctx.device;
        let bindless = vk::DescriptorBindingFlags::PARTIALLY_BOUND
            | vk::DescriptorBindingFlags::UPDATE_AFTER_BIND
            | vk::DescriptorBindingFlags::UPDATE_UNUSED_WHILE_PENDING;
        let binding_flags = [bindless, bindless];
        let mut flags_info = vk::DescriptorSetLayoutBindingFlagsCreateInfo::default().binding_flags(&binding_flags);
        let bindings = [
            vk::DescriptorSetLayoutBinding::default()
                .binding(0)
                .descriptor_type(vk::DescriptorType::COMBINED_IMAGE_SAMPLER)
                .descriptor_count(MAX_TEXTURES)
                .stage_flags(vk::ShaderStageFlags::ALL),
            // Unsigned-integer targets (G-buffer layers, visibility ids) need usampler2D.
            vk::DescriptorSetLayoutBinding::default()
                .binding(1)
                .descriptor_type(vk::DescriptorType::COMBINED_IMAGE_SAMPLER)
                .descriptor_count(MAX_UINT_TEXTURES)
                .stage_flags(vk::ShaderStageFlags::ALL),
        ];
        // SAFETY: create infos point at locals; the objects are destroyed in `destroy`.
        let (set_layout, pool, set, repeat_sampler, clamp_sampler) = unsafe {
            let set_layout = d.create_descriptor_set_layout(
                &vk::DescriptorSetLayoutCreateInfo::default()
                    .bindings(&bindings)
                    .flags(vk::DescriptorSetLayoutCreateFlags::UPDATE_AFTER_BIND_POOL)
                    .push_next(&mut flags_info),
                None,
            )?;
            let sizes = [vk::DescriptorPoolSize {
                ty: vk::DescriptorType::COMBINED_IMAGE_SAMPLER,
                descriptor_count: MAX_TEXTURES + MAX_UINT_TEXTURES,
            }];
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
            | vk::BufferUsageFlags::SHADER_DEVICE_ADDRESS;
        if ctx.tier >= Tier::RayTracingPipeline {
            mesh_usage |= vk::BufferUsageFlags::ACCELERATION_STRUCTURE_BUILD_INPUT_READ_ONLY_KHR;
        }
        let mut scene = Self {
            instances: GpuTable::new::<crate::scene::GpuInstance>(ctx, "instances", 64)?,
            materials: GpuTable::new::<crate::scene::GpuMaterial>(ctx, "materials", 64)?,
            lights: GpuTable::new::<crate::scene::GpuLight>(ctx, "lights", 16)?,
            camera: GpuTable::new::<GpuCamera>(ctx, "camera", 1)?,
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
            decal_order: GpuTable::new::<u32>(ctx, "decal order", 64)?,
            decal_order_cpu: Vec::new(),
            decal_order_dirty: false,
            meshes: Vec::new(),
            textures: (0..RESERVED_TEXTURES).map(|_| None).collect(),
            set_layout,
            pool,
            set,
            repeat_sampler,
            clamp_sampler,
            released_textures: Vec::new(),
            regions: Vec::with_capacity(64),
            mesh_usage,
        };
        let builtins = [(TEXTURE_WHITE, [255u8, 255, 255, 255]), (TEXTURE_FLAT_NORMAL, [128u8, 128, 255, 255])];
        let mut staging = Vec::new();
        ctx.run_once(|cmd| {
            for (slot, texel) in builtins {
                let data = TextureData { width: 1, height: 1, srgb: false, mips: vec![texel.to_vec()] };
                match scene.record_texture_upload(ctx, cmd, slot, &data) {
                    Ok(buf) => staging.push(buf),
                    Err(e) => tracing::error!("built-in texture: {e}"),
                }
            }
        })?;
        for b in staging {
            b.destroy(ctx);
        }
        if scene.textures[TEXTURE_WHITE as usize].is_none() {
            return Err(RenderError::Other("could not create the built-in textures".into()));
        }
        Ok(scene)
    }

    /// Writes a render target's `view` into bindless slot `slot` (of the unsigned-integer array
    /// when `uint`), with the clamp sampler. Only for slots no pending frame samples.
    pub fn bind_target(&self, ctx: &GpuContext, slot: u32, view: vk::ImageView, uint: bool) {
        self.write_descriptor_at(ctx, if uint { 1 } else { 0 }, slot, view, self.clamp_sampler, vk::ImageLayout::SHADER_READ_ONLY_OPTIMAL);
    }

    /// Writes the depth target into slot `slot`; passes sample it in `DEPTH_READ_ONLY_OPTIMAL`
    /// (`Access::DepthSampled`), so it can be a read-only depth attachment at the same time.
    pub fn bind_depth_target(&self, ctx: &GpuContext, slot: u32, view: vk::ImageView) {
        self.write_descriptor_at(ctx, 0, slot, view, self.clamp_sampler, vk::ImageLayout::DEPTH_READ_ONLY_OPTIMAL);
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
            .descriptor_type(vk::DescriptorType::COMBINED_IMAGE_SAMPLER)
            .image_info(&info);
        // SAFETY: the slot is not used by any pending command buffer (fresh, recycled after
        // completion, or a target rewritten after a wait for idle); the binding is
        // update-after-bind.
        unsafe { ctx.device.update_descriptor_sets(&[write], &[]) };
    }

    /// Creates the image for `data`, records its upload into `cmd` and returns the staging
    /// buffer, which must live until `cmd` has executed.
    fn record_texture_upload(
        &mut self,
        ctx: &GpuContext,
        cmd: vk::CommandBuffer,
        slot: u32,
        data: &TextureData,
    ) -> Result<Buffer, RenderError> {
        if slot >= MAX_TEXTURES {
            return Err(RenderError::Other(format!("texture slot {slot} exceeds the bindless array ({MAX_TEXTURES})")));
        }
        let total: usize = data.mips.iter().map(|m| m.len()).sum();
        let mut staging = Buffer::new(ctx, "texture staging", total as u64, vk::BufferUsageFlags::TRANSFER_SRC, MemoryLocation::CpuToGpu)?;
        let mut regions = Vec::with_capacity(data.mips.len());
        let mut offset = 0usize;
        let mapped = staging.mapped();
        for (level, mip) in data.mips.iter().enumerate() {
            let (w, h) = ((data.width >> level).max(1), (data.height >> level).max(1));
            if mip.len() != (w * h * 4) as usize {
                return Err(RenderError::Other(format!("texture mip {level} has {} bytes, expected {}", mip.len(), w * h * 4)));
            }
            mapped[offset..offset + mip.len()].copy_from_slice(mip);
            regions.push(vk::BufferImageCopy {
                buffer_offset: offset as u64,
                image_subresource: vk::ImageSubresourceLayers {
                    aspect_mask: vk::ImageAspectFlags::COLOR,
                    mip_level: level as u32,
                    base_array_layer: 0,
                    layer_count: 1,
                },
                image_extent: vk::Extent3D { width: w, height: h, depth: 1 },
                ..Default::default()
            });
            offset += mip.len();
        }
        let image = Image::new(
            ctx,
            &ImageDesc {
                name: "texture",
                format: if data.srgb { vk::Format::R8G8B8A8_SRGB } else { vk::Format::R8G8B8A8_UNORM },
                extent: vk::Extent2D { width: data.width, height: data.height },
                mip_levels: data.mips.len() as u32,
                usage: vk::ImageUsageFlags::SAMPLED | vk::ImageUsageFlags::TRANSFER_DST,
            },
        )?;
        let mut state = ImageState::new(image.raw, image.full_range());
        transition(&ctx.device, cmd, &mut state, Access::TransferWrite, true);
        // SAFETY: `cmd` is recording; buffer and image are live and the regions lie inside both.
        unsafe { ctx.device.cmd_copy_buffer_to_image(cmd, staging.raw, image.raw, vk::ImageLayout::TRANSFER_DST_OPTIMAL, &regions) };
        transition(&ctx.device, cmd, &mut state, Access::ShaderSampled, false);
        self.write_descriptor(ctx, slot, image.view, self.repeat_sampler);
        if self.textures.len() <= slot as usize {
            self.textures.resize_with(slot as usize + 1, || None);
        }
        if let Some(old) = self.textures[slot as usize].replace(image) {
            old.destroy(ctx); // only reachable for built-ins during setup
        }
        Ok(staging)
    }

    /// Brings the GPU scene up to date with `mirror`, recording copies into `cmd`. Only dirty
    /// records, new meshes and new textures are copied.
    #[allow(clippy::too_many_arguments)]
    pub fn sync(
        &mut self,
        ctx: &GpuContext,
        cmd: vk::CommandBuffer,
        mirror: &mut SceneMirror,
        staging: &mut StagingRing,
        graveyard: &mut Graveyard,
        frame_value: u64,
        completed_value: u64,
    ) -> Result<SyncReport, RenderError> {
        let mut report = SyncReport::default();
        // Slots whose last user has finished go back to the mirror for reuse.
        self.released_textures.retain(|&(after, slot)| {
            if after <= completed_value {
                mirror.recycle_texture_slot(slot);
                false
            } else {
                true
            }
        });
        for slot in mirror.released_textures.drain(..) {
            if let Some(img) = self.textures.get_mut(slot as usize).and_then(Option::take) {
                graveyard.bury(frame_value, Retired::Image(img));
            }
            self.released_textures.push((frame_value, slot));
        }
        for id in mirror.released_meshes.drain(..) {
            if let Some(mesh) = self.meshes.get_mut(id.0 as usize).and_then(Option::take) {
                graveyard.bury(frame_value, Retired::Buffer(mesh.buffer));
                self.mesh_info[id.0 as usize] = GpuMeshInfo::default();
                self.mesh_info_dirty = true;
            }
        }

        if mirror.is_clean() && !self.decal_order_dirty {
            return Ok(report);
        }
        let mut counters = mirror.counters;
        let camera_dirty = mirror.take_camera_dirty();
        let need = staging_need(&mirror.instances, &self.instances)
            + staging_need(&mirror.materials, &self.materials)
            + staging_need(&mirror.lights, &self.lights)
            + staging_need(&mirror.decals.records, &self.decals)
            + staging_need(&mirror.decals.aabbs, &self.decal_aabbs)
            + staging_need(&mirror.decal_materials, &self.decal_materials)
            + 2 * (std::mem::size_of::<GpuMeshInfo>() * (self.mesh_info.len() + mirror.pending_meshes.len())) as u64
            + 2 * (4 * self.decal_order_cpu.len()) as u64
            + 64
            + std::mem::size_of::<GpuCamera>() as u64
            + 64;
        staging.reserve(ctx, graveyard, frame_value, need)?;

        // Reads of the previous frames must finish before copies overwrite the tables.
        memory_barrier(
            &ctx.device,
            cmd,
            (vk::PipelineStageFlags2::ALL_GRAPHICS | vk::PipelineStageFlags2::COMPUTE_SHADER, vk::AccessFlags2::NONE),
            (vk::PipelineStageFlags2::COPY, vk::AccessFlags2::TRANSFER_WRITE),
        );

        self.upload_meshes(ctx, cmd, mirror, graveyard, frame_value, &mut counters)?;
        for (slot, data) in std::mem::take(&mut mirror.pending_textures) {
            let buf = self.record_texture_upload(ctx, cmd, slot, &data)?;
            counters.bytes_uploaded += data.mips.iter().map(|m| m.len() as u64).sum::<u64>();
            graveyard.bury(frame_value, Retired::Buffer(buf));
        }

        let mut regions = std::mem::take(&mut self.regions);
        report.decal_boxes_changed = mirror.decals.aabbs.dirty_count() as u32;
        let tables: [(&mut dyn DirtyTable, &mut GpuTable); 5] = [
            (&mut mirror.instances, &mut self.instances),
            (&mut mirror.materials, &mut self.materials),
            (&mut mirror.lights, &mut self.lights),
            (&mut mirror.decals.records, &mut self.decals),
            (&mut mirror.decal_materials, &mut self.decal_materials),
        ];
        for (table, gpu) in tables {
            let dst = table.upload(ctx, graveyard, frame_value, gpu, staging, &mut regions, &mut counters)?;
            record_copies(ctx, cmd, staging.buffer(), dst, &regions);
        }
        let parking: Option<TailFn<GpuAabb>> = self.decal_aabbs.fill_tail.then_some(decal_parking);
        let dst = upload_table(
            ctx,
            graveyard,
            frame_value,
            &mut mirror.decals.aabbs,
            &mut self.decal_aabbs,
            staging,
            &mut regions,
            &mut counters,
            parking,
        )?;
        record_copies(ctx, cmd, staging.buffer(), dst, &regions);
        if std::mem::take(&mut self.mesh_info_dirty) {
            let dst = upload_array(
                ctx,
                graveyard,
                frame_value,
                &mut self.mesh_table,
                bytemuck::cast_slice(&self.mesh_info),
                staging,
                &mut regions,
                &mut counters,
            )?;
            record_copies(ctx, cmd, staging.buffer(), Some(dst), &regions);
        }
        if std::mem::take(&mut self.decal_order_dirty) {
            let dst = upload_array(
                ctx,
                graveyard,
                frame_value,
                &mut self.decal_order,
                bytemuck::cast_slice(&self.decal_order_cpu),
                staging,
                &mut regions,
                &mut counters,
            )?;
            record_copies(ctx, cmd, staging.buffer(), Some(dst), &regions);
        }
        if camera_dirty {
            let src = staging.push(bytemuck::bytes_of(mirror.camera()));
            let region = [vk::BufferCopy { src_offset: src, dst_offset: 0, size: std::mem::size_of::<GpuCamera>() as u64 }];
            record_copies(ctx, cmd, staging.buffer(), Some(self.camera.buffer()), &region);
            counters.bytes_uploaded += region[0].size;
        }
        self.regions = regions;

        memory_barrier(
            &ctx.device,
            cmd,
            (vk::PipelineStageFlags2::COPY, vk::AccessFlags2::TRANSFER_WRITE),
            (
                vk::PipelineStageFlags2::ALL_GRAPHICS
                    | vk::PipelineStageFlags2::COMPUTE_SHADER
                    | vk::PipelineStageFlags2::ACCELERATION_STRUCTURE_BUILD_KHR,
                vk::AccessFlags2::SHADER_READ
                    | vk::AccessFlags2::VERTEX_ATTRIBUTE_READ
                    | vk::AccessFlags2::INDEX_READ
                    | vk::AccessFlags2::SHADER_STORAGE_READ,
            ),
        );
        mirror.counters = counters;
        Ok(report)
    }

    fn upload_meshes(
        &mut self,
        ctx: &GpuContext,
        cmd: vk::CommandBuffer,
        mirror: &mut SceneMirror,
        graveyard: &mut Graveyard,
        frame_value: u64,
        counters: &mut FrameCounters,
    ) -> Result<(), RenderError> {
        if mirror.pending_meshes.is_empty() {
            return Ok(());
        }
        let pending = std::mem::take(&mut mirror.pending_meshes);
        let total: u64 = pending
            .iter()
            .map(|(_, m)| (std::mem::size_of_val(m.vertices.as_slice()) + std::mem::size_of_val(m.indices.as_slice()) + 16) as u64)
            .sum();
        let mut staging = Buffer::new(ctx, "mesh staging", total, vk::BufferUsageFlags::TRANSFER_SRC, MemoryLocation::CpuToGpu)?;
        let mut offset = 0u64;
        for (id, data) in &pending {
            let vbytes: &[u8] = bytemuck::cast_slice(&data.vertices);
            let ibytes: &[u8] = bytemuck::cast_slice(&data.indices);
            let index_offset = (vbytes.len() as u64).next_multiple_of(16);
            let size = index_offset + ibytes.len() as u64;
            let buffer = Buffer::new(ctx, "mesh", size, self.mesh_usage, MemoryLocation::GpuOnly)?;
            let mapped = staging.mapped();
            let o = offset as usize;
            mapped[o..o + vbytes.len()].copy_from_slice(vbytes);
            mapped[o + index_offset as usize..o + index_offset as usize + ibytes.len()].copy_from_slice(ibytes);
            let region = [vk::BufferCopy { src_offset: offset, dst_offset: 0, size }];
            // SAFETY: `cmd` is recording; the region lies inside both buffers.
            unsafe { ctx.device.cmd_copy_buffer(cmd, staging.raw, buffer.raw, &region) };
            offset = (offset + size).next_multiple_of(16);
            counters.bytes_uploaded += vbytes.len() as u64 + ibytes.len() as u64;
            let slot = id.0 as usize;
            if self.meshes.len() <= slot {
                self.meshes.resize_with(slot + 1, || None);
            }
            if self.mesh_info.len() <= slot {
                self.mesh_info.resize(slot + 1, GpuMeshInfo::default());
            }
            self.mesh_info[slot] = GpuMeshInfo { vertices: buffer.address, indices: buffer.address + index_offset };
            self.mesh_info_dirty = true;
            let mesh = GpuMesh { buffer, index_offset, index_count: data.indices.len() as u32, vertex_count: data.vertices.len() as u32 };
            if let Some(old) = self.meshes[slot].replace(mesh) {
                graveyard.bury(frame_value, Retired::Buffer(old.buffer));
            }
        }
        graveyard.bury(frame_value, Retired::Buffer(staging));
        Ok(())
    }

    /// Sets the deferred decals' draw order (uploaded with the next sync).
    pub fn set_decal_order(&mut self, order: &[u32]) {
        self.decal_order_cpu.clear();
        self.decal_order_cpu.extend_from_slice(order);
        self.decal_order_dirty = true;
    }

    /// The mesh for `id`, once uploaded.
    pub fn mesh(&self, id: MeshId) -> Option<&GpuMesh> {
        self.meshes.get(id.0 as usize).and_then(Option::as_ref)
    }

    /// Destroys everything; the GPU must be idle.
    pub fn destroy(self, ctx: &GpuContext) {
        for t in [
            self.instances,
            self.materials,
            self.lights,
            self.camera,
            self.decals,
            self.decal_aabbs,
            self.decal_materials,
            self.mesh_table,
            self.decal_order,
        ] {
            t.buffer.destroy(ctx);
        }
        for m in self.meshes.into_iter().flatten() {
            m.buffer.destroy(ctx);
        }
        for t in self.textures.into_iter().flatten() {
            t.destroy(ctx);
        }
        // SAFETY: the GPU is idle; these objects belong to this device.
        unsafe {
            ctx.device.destroy_sampler(self.repeat_sampler, None);
            ctx.device.destroy_sampler(self.clamp_sampler, None);
            ctx.device.destroy_descriptor_pool(self.pool, None);
            ctx.device.destroy_descriptor_set_layout(self.set_layout, None);
        }
    }
}

fn record_copies(ctx: &GpuContext, cmd: vk::CommandBuffer, src: vk::Buffer, dst: Option<vk::Buffer>, regions: &[vk::BufferCopy]) {
    if let (Some(dst), false) = (dst, regions.is_empty()) {
        // SAFETY: `cmd` is recording; the regions lie inside both buffers.
        unsafe { ctx.device.cmd_copy_buffer(cmd, src, dst, regions) };
    }
}
