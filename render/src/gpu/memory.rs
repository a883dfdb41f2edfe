//! Buffers and images with their memory (through `gpu-allocator`), and deferred destruction.
//!
//! Anything the GPU may still read when the CPU lets go of it goes into [`Graveyard`] with the
//! timeline value of the last frame that could use it, and is destroyed once the GPU has passed
//! that value.
//!
//! **Where the bytes go.** Every allocation is counted by what it holds ([`MemoryKind`]) in the
//! context's [`MemoryLedger`] as it is made and freed, textures also by format, so the frame's
//! report says where GPU memory goes without asking the allocator (whose report allocates).
//! The ledger counts the bytes each allocation asked for; the allocator's total adds the few
//! bytes of padding it leaves between sub-allocations to align them (a test holds the two within
//! half a percent). Not counted: the egui overlay's font atlas and vertex buffers, which
//! `egui-ash-renderer` allocates through the allocator itself (a window with the overlay open).

use ash::vk;
use gpu_allocator::MemoryLocation;
use gpu_allocator::vulkan::{Allocation, AllocationCreateDesc, AllocationScheme};

use crate::RenderError;
use crate::gpu::device::GpuContext;

/// The usage of a buffer that compute passes write by address, that a transfer clears and that
/// is copied out for the CPU (statistics at its head): light tiles, decal clusters, reflection
/// statistics.
pub const GPU_WRITTEN: vk::BufferUsageFlags = vk::BufferUsageFlags::from_raw(
    vk::BufferUsageFlags::STORAGE_BUFFER.as_raw()
        | vk::BufferUsageFlags::TRANSFER_DST.as_raw()
        | vk::BufferUsageFlags::TRANSFER_SRC.as_raw()
        | vk::BufferUsageFlags::SHADER_DEVICE_ADDRESS.as_raw(),
);

/// What a piece of GPU memory holds, for the memory report.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum MemoryKind {
    /// Sampled images the scene or a technique uploads or filters: material and decal textures,
    /// the environment's cubes, lookup tables.
    Textures,
    /// The mesh pool: every mesh's vertices and indices, skins, morph targets and posed copies.
    MeshPool,
    /// Acceleration structures (the scene's, the decals', the lights'), their scratch and
    /// instance records.
    AccelerationStructures,
    /// Render targets: depth, the G-buffer, HDR, histories, the techniques' images.
    Targets,
    /// The scene's record tables: instances, materials, lights, the camera, decals and their
    /// boxes, the mesh table, draw orders, the skinning input, movers.
    Tables,
    /// Other device-local buffers, most of them written by the GPU: light tiles, decal clusters
    /// and lists, culling records and draw commands, depth pyramids, bloom, statistics.
    Lists,
    /// Host-visible memory: staging rings, readbacks, per-frame parameters, shader binding tables.
    HostVisible,
}

impl MemoryKind {
    /// Every kind, in report order.
    pub const ALL: [MemoryKind; 7] = [
        MemoryKind::Textures,
        MemoryKind::MeshPool,
        MemoryKind::AccelerationStructures,
        MemoryKind::Targets,
        MemoryKind::Tables,
        MemoryKind::Lists,
        MemoryKind::HostVisible,
    ];

    /// Its key in statistics.
    pub fn name(self) -> &'static str {
        match self {
            MemoryKind::Textures => "textures",
            MemoryKind::MeshPool => "mesh_pool",
            MemoryKind::AccelerationStructures => "acceleration_structures",
            MemoryKind::Targets => "targets",
            MemoryKind::Tables => "tables",
            MemoryKind::Lists => "lists",
            MemoryKind::HostVisible => "host_visible",
        }
    }

    /// What a buffer of `usage` in `location` holds: host-visible memory, the mesh pool (the one
    /// index buffer), an acceleration structure or its build input (instance records), or a
    /// device-local list (record tables say so themselves: [`Buffer::of_kind`]).
    pub fn of_buffer(usage: vk::BufferUsageFlags, location: MemoryLocation) -> Self {
        if location != MemoryLocation::GpuOnly {
            MemoryKind::HostVisible
        } else if usage.contains(vk::BufferUsageFlags::INDEX_BUFFER) {
            MemoryKind::MeshPool
        } else if usage.intersects(
            vk::BufferUsageFlags::ACCELERATION_STRUCTURE_STORAGE_KHR
                | vk::BufferUsageFlags::ACCELERATION_STRUCTURE_BUILD_INPUT_READ_ONLY_KHR,
        ) {
            MemoryKind::AccelerationStructures
        } else {
            MemoryKind::Lists
        }
    }
}

/// Texture formats the ledger tells apart (more are counted with the last).
pub const TEXTURE_FORMATS: usize = 8;

/// Bytes of GPU memory by [`MemoryKind`], and the textures' by format: a plain copy for the
/// frame's report.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct MemoryCounts {
    /// Bytes by kind, in [`MemoryKind::ALL`]'s order.
    pub by_kind: [u64; MemoryKind::ALL.len()],
    /// The textures' bytes by format, the formats in the order they first appeared
    /// (`UNDEFINED`: unused).
    pub textures_by_format: [(vk::Format, u64); TEXTURE_FORMATS],
}

impl MemoryCounts {
    /// Bytes of `kind`.
    pub fn of(&self, kind: MemoryKind) -> u64 {
        self.by_kind[kind as usize]
    }

    /// Bytes of every kind.
    pub fn total(&self) -> u64 {
        self.by_kind.iter().sum()
    }

    /// The texture formats in use with their bytes.
    pub fn texture_formats(&self) -> impl Iterator<Item = (vk::Format, u64)> + '_ {
        self.textures_by_format.iter().copied().filter(|&(f, b)| f != vk::Format::UNDEFINED && b > 0)
    }
}

/// The context's count of allocated bytes by kind (see the module docs).
#[derive(Debug, Default)]
pub struct MemoryLedger {
    counts: MemoryCounts,
}

impl MemoryLedger {
    /// Counts `bytes` of `kind` (of `format`, for a texture) as allocated, or as `freed`.
    pub fn add(&mut self, kind: MemoryKind, format: vk::Format, bytes: u64, freed: bool) {
        let change = |v: &mut u64| *v = if freed { v.saturating_sub(bytes) } else { *v + bytes };
        change(&mut self.counts.by_kind[kind as usize]);
        if kind == MemoryKind::Textures {
            let formats = &mut self.counts.textures_by_format;
            let at = formats
                .iter()
                .position(|&(f, _)| f == format)
                .or_else(|| formats.iter().position(|&(f, _)| f == vk::Format::UNDEFINED))
                .unwrap_or(TEXTURE_FORMATS - 1);
            if formats[at].0 == vk::Format::UNDEFINED {
                formats[at].0 = format;
            }
            change(&mut formats[at].1);
        }
    }

    /// The bytes allocated now.
    pub fn counts(&self) -> MemoryCounts {
        self.counts
    }
}

/// A buffer and its memory.
pub struct Buffer {
    /// The Vulkan buffer.
    pub raw: vk::Buffer,
    allocation: Option<Allocation>,
    kind: MemoryKind,
    /// Size in bytes.
    pub size: u64,
    /// Device address (0 unless created with `SHADER_DEVICE_ADDRESS`).
    pub address: vk::DeviceAddress,
}

impl Buffer {
    /// Creates a buffer of `size` bytes in `location`, counted as [`MemoryKind::of_buffer`] says.
    pub fn new(
        ctx: &GpuContext,
        name: &str,
        size: u64,
        usage: vk::BufferUsageFlags,
        location: MemoryLocation,
    ) -> Result<Buffer, RenderError> {
        Self::of_kind(ctx, name, size, usage, location, MemoryKind::of_buffer(usage, location))
    }

    /// [`Buffer::new`], counted as `kind` (a buffer whose usage does not say what it holds:
    /// record tables, acceleration-structure scratch).
    pub fn of_kind(
        ctx: &GpuContext,
        name: &str,
        size: u64,
        usage: vk::BufferUsageFlags,
        location: MemoryLocation,
        kind: MemoryKind,
    ) -> Result<Buffer, RenderError> {
        let d = &ctx.device;
        let size = size.max(16);
        // SAFETY: a valid create info; the buffer is bound to memory below before any use.
        let raw = unsafe { d.create_buffer(&vk::BufferCreateInfo::default().size(size).usage(usage), None) }?;
        // SAFETY: `raw` is a live buffer of this device.
        let requirements = unsafe { d.get_buffer_memory_requirements(raw) };
        let allocation = ctx.allocate(
            &AllocationCreateDesc { name, requirements, location, linear: true, allocation_scheme: AllocationScheme::GpuAllocatorManaged },
            kind,
            vk::Format::UNDEFINED,
        );
        let allocation = match allocation {
            Ok(a) => a,
            Err(e) => {
                // SAFETY: the buffer was never used.
                unsafe { d.destroy_buffer(raw, None) };
                return Err(e);
            }
        };
        // SAFETY: the allocation satisfies the buffer's requirements and is not bound elsewhere.
        if let Err(e) = unsafe { d.bind_buffer_memory(raw, allocation.memory(), allocation.offset()) } {
            // SAFETY: the buffer was never used.
            unsafe { d.destroy_buffer(raw, None) };
            let _ = ctx.free(allocation, kind, vk::Format::UNDEFINED);
            return Err(e.into());
        }
        let address = if usage.contains(vk::BufferUsageFlags::SHADER_DEVICE_ADDRESS) {
            // SAFETY: the buffer is bound and was created with SHADER_DEVICE_ADDRESS.
            unsafe { d.get_buffer_device_address(&vk::BufferDeviceAddressInfo::default().buffer(raw)) }
        } else {
            0
        };
        Ok(Buffer { raw, allocation: Some(allocation), kind, size, address })
    }

    /// The CPU view of a host-visible buffer.
    pub fn mapped(&mut self) -> &mut [u8] {
        self.allocation.as_mut().and_then(|a| a.mapped_slice_mut()).expect("mapped() on a buffer that is not host-visible")
    }

    /// Destroys the buffer now. The caller guarantees the GPU no longer uses it.
    pub fn destroy(mut self, ctx: &GpuContext) {
        // SAFETY: guaranteed by the caller (directly or through the Graveyard).
        unsafe { ctx.destroying().destroy_buffer(self.raw, None) };
        if let Some(a) = self.allocation.take()
            && let Err(e) = ctx.free(a, self.kind, vk::Format::UNDEFINED)
        {
            tracing::error!("freeing buffer memory failed: {e}");
        }
    }
}

/// How to create an [`Image`].
#[derive(Clone, Copy, Debug)]
pub struct ImageDesc<'a> {
    /// Debug name.
    pub name: &'a str,
    /// Texel format.
    pub format: vk::Format,
    /// Size in pixels.
    pub extent: vk::Extent2D,
    /// Mip levels.
    pub mip_levels: u32,
    /// Usage.
    pub usage: vk::ImageUsageFlags,
    /// Samples a pixel (1 but for multisampled render targets).
    pub samples: u32,
    /// What it holds, for the memory report: a texture or a render target.
    pub kind: MemoryKind,
}

/// A 2D image (or a cube map: six layers), its memory and a view of all its mips.
pub struct Image {
    /// The Vulkan image.
    pub raw: vk::Image,
    /// A view of every mip level.
    pub view: vk::ImageView,
    allocation: Option<Allocation>,
    kind: MemoryKind,
    /// Texel format.
    pub format: vk::Format,
    /// Size of level 0.
    pub extent: vk::Extent2D,
    /// Mip levels.
    pub mip_levels: u32,
    /// Colour or depth aspect.
    pub aspect: vk::ImageAspectFlags,
    /// Array layers (6 for a cube map).
    pub layers: u32,
}

impl Image {
    /// Creates an image in device-local memory.
    pub fn new(ctx: &GpuContext, desc: &ImageDesc) -> Result<Image, RenderError> {
        Self::create(ctx, desc, 1)
    }

    /// Creates a cube map (six square layers of `desc.extent`), whose view is a cube.
    pub fn cube(ctx: &GpuContext, desc: &ImageDesc) -> Result<Image, RenderError> {
        Self::create(ctx, desc, 6)
    }

    fn create(ctx: &GpuContext, desc: &ImageDesc, layers: u32) -> Result<Image, RenderError> {
        let d = &ctx.device;
        let aspect = if is_depth_format(desc.format) { vk::ImageAspectFlags::DEPTH } else { vk::ImageAspectFlags::COLOR };
        let cube = layers == 6;
        let info = vk::ImageCreateInfo::default()
            .flags(if cube { vk::ImageCreateFlags::CUBE_COMPATIBLE } else { vk::ImageCreateFlags::empty() })
            .image_type(vk::ImageType::TYPE_2D)
            .format(desc.format)
            .extent(vk::Extent3D { width: desc.extent.width, height: desc.extent.height, depth: 1 })
            .mip_levels(desc.mip_levels)
            .array_layers(layers)
            .samples(vk::SampleCountFlags::from_raw(desc.samples))
            .tiling(vk::ImageTiling::OPTIMAL)
            .usage(desc.usage)
            .initial_layout(vk::ImageLayout::UNDEFINED);
        // SAFETY: a valid create info; bound to memory below before use.
        let raw = unsafe { d.create_image(&info, None) }?;
        // SAFETY: `raw` is a live image of this device.
        let requirements = unsafe { d.get_image_memory_requirements(raw) };
        let allocation = ctx.allocate(
            &AllocationCreateDesc {
                name: desc.name,
                requirements,
                location: MemoryLocation::GpuOnly,
                linear: false,
                allocation_scheme: AllocationScheme::GpuAllocatorManaged,
            },
            desc.kind,
            desc.format,
        );
        let allocation = match allocation {
            Ok(a) => a,
            Err(e) => {
                // SAFETY: never used.
                unsafe { d.destroy_image(raw, None) };
                return Err(e);
            }
        };
        // SAFETY: the allocation satisfies the image's requirements.
        if let Err(e) = unsafe { d.bind_image_memory(raw, allocation.memory(), allocation.offset()) } {
            // SAFETY: the image was never used.
            unsafe { d.destroy_image(raw, None) };
            let _ = ctx.free(allocation, desc.kind, desc.format);
            return Err(e.into());
        }
        let view_type = if cube { vk::ImageViewType::CUBE } else { vk::ImageViewType::TYPE_2D };
        let view_info = vk::ImageViewCreateInfo::default().image(raw).view_type(view_type).format(desc.format).subresource_range(
            vk::ImageSubresourceRange {
                aspect_mask: aspect,
                base_mip_level: 0,
                level_count: desc.mip_levels,
                base_array_layer: 0,
                layer_count: layers,
            },
        );
        // SAFETY: the image is bound and the range lies inside it.
        let view = match unsafe { d.create_image_view(&view_info, None) } {
            Ok(v) => v,
            Err(e) => {
                let image = Image {
                    raw,
                    view: vk::ImageView::null(),
                    allocation: Some(allocation),
                    kind: desc.kind,
                    format: desc.format,
                    extent: desc.extent,
                    mip_levels: 0,
                    aspect,
                    layers,
                };
                image.destroy(ctx);
                return Err(e.into());
            }
        };
        Ok(Image {
            raw,
            view,
            allocation: Some(allocation),
            kind: desc.kind,
            format: desc.format,
            extent: desc.extent,
            mip_levels: desc.mip_levels,
            aspect,
            layers,
        })
    }

    /// A view of one mip level's layers as a 2D array (a storage image a pass writes a cube
    /// level through); the caller destroys it before the image.
    pub fn level_view(&self, ctx: &GpuContext, level: u32) -> Result<vk::ImageView, RenderError> {
        let range = vk::ImageSubresourceRange { base_mip_level: level, level_count: 1, ..self.full_range() };
        let info = vk::ImageViewCreateInfo::default()
            .image(self.raw)
            .view_type(vk::ImageViewType::TYPE_2D_ARRAY)
            .format(self.format)
            .subresource_range(range);
        // SAFETY: the image is live and the range lies inside it.
        Ok(unsafe { ctx.device.create_image_view(&info, None) }?)
    }

    /// The subresource range covering every mip and layer.
    pub fn full_range(&self) -> vk::ImageSubresourceRange {
        vk::ImageSubresourceRange {
            aspect_mask: self.aspect,
            base_mip_level: 0,
            level_count: self.mip_levels,
            base_array_layer: 0,
            layer_count: self.layers,
        }
    }

    /// Destroys the image now. The caller guarantees the GPU no longer uses it.
    pub fn destroy(mut self, ctx: &GpuContext) {
        // SAFETY: guaranteed by the caller.
        unsafe {
            ctx.destroying().destroy_image_view(self.view, None);
            ctx.destroying().destroy_image(self.raw, None);
        }
        if let Some(a) = self.allocation.take()
            && let Err(e) = ctx.free(a, self.kind, self.format)
        {
            tracing::error!("freeing image memory failed: {e}");
        }
    }
}

/// True for depth formats.
pub fn is_depth_format(format: vk::Format) -> bool {
    matches!(format, vk::Format::D32_SFLOAT | vk::Format::D24_UNORM_S8_UINT | vk::Format::D16_UNORM | vk::Format::D32_SFLOAT_S8_UINT)
}

/// A resource waiting for the GPU to finish with it.
pub enum Retired {
    /// A buffer.
    Buffer(Buffer),
    /// An image.
    Image(Image),
    /// An acceleration structure and its storage.
    AccelerationStructure(ash::vk::AccelerationStructureKHR, Buffer),
}

/// Deferred destruction: resources wait here until the GPU's timeline passes their frame.
#[derive(Default)]
pub struct Graveyard {
    entries: Vec<(u64, Retired)>,
}

impl Graveyard {
    /// Destroys `resource` once the GPU timeline reaches `after`.
    pub fn bury(&mut self, after: u64, resource: Retired) {
        self.entries.push((after, resource));
    }

    /// Destroys everything the GPU has finished with.
    pub fn collect(&mut self, ctx: &GpuContext, completed: u64) {
        if self.entries.iter().all(|(after, _)| *after > completed) {
            return;
        }
        let mut i = 0;
        while i < self.entries.len() {
            if self.entries[i].0 <= completed {
                match self.entries.swap_remove(i).1 {
                    Retired::Buffer(b) => b.destroy(ctx),
                    Retired::Image(img) => img.destroy(ctx),
                    Retired::AccelerationStructure(raw, buffer) => {
                        if let Some(rt) = &ctx.ray_tracing {
                            ctx.note_destroyed();
                            // SAFETY: the GPU has passed the last frame that used it.
                            unsafe { rt.acceleration_structure.destroy_acceleration_structure(raw, None) };
                        }
                        buffer.destroy(ctx);
                    }
                }
            } else {
                i += 1;
            }
        }
    }

    /// Destroys everything; the caller has waited for the GPU to go idle.
    pub fn clear(&mut self, ctx: &GpuContext) {
        self.collect(ctx, u64::MAX);
    }

    /// Number of resources waiting.
    pub fn len(&self) -> usize {
        self.entries.len()
    }

    /// True when nothing waits.
    pub fn is_empty(&self) -> bool {
        self.entries.is_empty()
    }
}
