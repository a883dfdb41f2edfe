//! Staging memory for CPU→GPU copies.
//!
//! Each frame in flight owns one host-visible [`StagingRing`]; records written this frame are
//! packed into it and copied into device-local buffers by commands recorded at the start of the
//! frame. The ring only grows (geometrically, when a frame needs more than it has), so a steady
//! state allocates nothing. One-off bulk uploads (meshes, textures) use a [`Buffer`] of their own
//! that is released with the frame, so the rings stay small.

use ash::vk;
use gpu_allocator::MemoryLocation;

use crate::RenderError;
use crate::gpu::device::GpuContext;
use crate::gpu::memory::{Buffer, Graveyard, Retired};

/// What preparing a frame's uploads needs: the device, the frame slot's staging ring, the
/// graveyard for what a growing table replaces, the frame's timeline values, and the count of
/// bytes sent. Passed as one value instead of six arguments.
pub struct Upload<'a> {
    /// The device.
    pub ctx: &'a GpuContext,
    /// This frame slot's staging ring.
    pub staging: &'a mut StagingRing,
    /// Where replaced buffers wait for the GPU.
    pub graveyard: &'a mut Graveyard,
    /// Timeline value of the frame being prepared: what is buried now is freed after it.
    pub frame_value: u64,
    /// Highest timeline value the GPU has finished.
    pub completed: u64,
    /// Bytes copied to the GPU this frame.
    pub bytes: u64,
}

impl Upload<'_> {
    /// The staging ring's buffer (copy source).
    pub fn staging_buffer(&self) -> vk::Buffer {
        self.staging.buffer()
    }
}

/// Copies prepared on the CPU, recorded later by the frame's upload pass. Its vectors are
/// reused every frame, so once grown it allocates nothing.
#[derive(Default)]
pub struct CopyList {
    regions: Vec<vk::BufferCopy>,
    /// Source, destination and the end of its regions (each starts where the previous ends).
    buffers: Vec<(vk::Buffer, vk::Buffer, usize)>,
    image_regions: Vec<vk::BufferImageCopy>,
    /// Source, destination image, its whole range, and the end of its regions.
    images: Vec<(vk::Buffer, vk::Image, vk::ImageSubresourceRange, usize)>,
}

/// The regions of one buffer-to-buffer copy being added to a [`CopyList`].
pub struct BufferCopy<'a> {
    list: &'a mut CopyList,
    start: usize,
}

impl BufferCopy<'_> {
    /// Adds a region: `size` bytes from `src_offset` in the source to `dst_offset`.
    pub fn push(&mut self, src_offset: u64, dst_offset: u64, size: u64) {
        self.list.regions.push(vk::BufferCopy { src_offset, dst_offset, size });
        self.list.buffers.last_mut().expect("created with the copy").2 = self.list.regions.len();
    }

    /// Bytes this copy moves so far.
    pub fn bytes(&self) -> u64 {
        self.list.regions[self.start..].iter().map(|r| r.size).sum()
    }
}

impl CopyList {
    /// Forgets last frame's copies (keeps the capacity).
    pub fn clear(&mut self) {
        self.regions.clear();
        self.buffers.clear();
        self.image_regions.clear();
        self.images.clear();
    }

    /// Starts a copy from `src` to `dst`; add its regions with [`BufferCopy::push`].
    pub fn buffer_copy(&mut self, src: vk::Buffer, dst: vk::Buffer) -> BufferCopy<'_> {
        let start = self.regions.len();
        self.buffers.push((src, dst, start));
        BufferCopy { list: self, start }
    }

    /// Adds a copy from `src` into a new image (all of `range`) through `regions`.
    pub fn image_copy(
        &mut self,
        src: vk::Buffer,
        image: vk::Image,
        range: vk::ImageSubresourceRange,
        regions: impl IntoIterator<Item = vk::BufferImageCopy>,
    ) {
        self.image_regions.extend(regions);
        self.images.push((src, image, range, self.image_regions.len()));
    }

    /// The images the copies fill, with their ranges (for the pass's declaration).
    pub fn images(&self) -> impl Iterator<Item = (vk::Image, vk::ImageSubresourceRange)> + '_ {
        self.images.iter().map(|&(_, image, range, _)| (image, range))
    }

    /// True when there is nothing to copy.
    pub fn is_empty(&self) -> bool {
        self.regions.is_empty() && self.image_regions.is_empty()
    }

    /// Records every copy. The images must be in TRANSFER_DST_OPTIMAL (the frame graph puts them
    /// there from the upload pass's declaration).
    pub fn record(&self, ctx: &GpuContext, cmd: vk::CommandBuffer) {
        let mut start = 0;
        for &(src, dst, end) in &self.buffers {
            if end > start {
                // SAFETY: `cmd` is recording outside a rendering scope; the regions lie inside
                // both buffers, which live until the frame completes (graveyard).
                unsafe { ctx.device.cmd_copy_buffer(cmd, src, dst, &self.regions[start..end]) };
            }
            start = end;
        }
        let mut start = 0;
        for &(src, image, _, end) in &self.images {
            // SAFETY: as above; the image is in TRANSFER_DST_OPTIMAL by the pass's declaration.
            unsafe {
                ctx.device.cmd_copy_buffer_to_image(cmd, src, image, vk::ImageLayout::TRANSFER_DST_OPTIMAL, &self.image_regions[start..end])
            };
            start = end;
        }
    }
}

/// A host-visible buffer reused every time its frame slot comes round.
pub struct StagingRing {
    buffer: Buffer,
    used: u64,
}

const ALIGN: u64 = 16;

impl StagingRing {
    /// A ring of `capacity` bytes.
    pub fn new(ctx: &GpuContext, capacity: u64) -> Result<Self, RenderError> {
        Ok(Self { buffer: Self::create(ctx, capacity)?, used: 0 })
    }

    fn create(ctx: &GpuContext, capacity: u64) -> Result<Buffer, RenderError> {
        Buffer::new(ctx, "staging ring", capacity, vk::BufferUsageFlags::TRANSFER_SRC, MemoryLocation::CpuToGpu)
    }

    /// Empties the ring. Called when its frame slot's previous use has completed.
    pub fn reset(&mut self) {
        self.used = 0;
    }

    /// Makes room for `bytes` more this frame, growing (and burying the old buffer until the
    /// GPU is past `frame_value`) when needed. Must be called before the first `push` of a frame
    /// that might need more room, since growing invalidates earlier offsets.
    pub fn reserve(&mut self, ctx: &GpuContext, graveyard: &mut Graveyard, frame_value: u64, bytes: u64) -> Result<(), RenderError> {
        let need = self.used + bytes + ALIGN;
        if need <= self.buffer.size {
            return Ok(());
        }
        debug_assert_eq!(self.used, 0, "grow the ring before pushing into it");
        let capacity = need.next_power_of_two().max(self.buffer.size * 2);
        tracing::debug!(capacity, "staging ring grows");
        let old = std::mem::replace(&mut self.buffer, Self::create(ctx, capacity)?);
        graveyard.bury(frame_value, Retired::Buffer(old));
        Ok(())
    }

    /// Copies `bytes` in and returns their offset in [`StagingRing::buffer`].
    pub fn push(&mut self, bytes: &[u8]) -> u64 {
        let offset = self.used.next_multiple_of(ALIGN);
        let end = offset + bytes.len() as u64;
        assert!(end <= self.buffer.size, "staging ring overflow: reserve() first");
        self.buffer.mapped()[offset as usize..end as usize].copy_from_slice(bytes);
        self.used = end;
        offset
    }

    /// The Vulkan buffer to copy from.
    pub fn buffer(&self) -> vk::Buffer {
        self.buffer.raw
    }

    /// Capacity in bytes.
    pub fn capacity(&self) -> u64 {
        self.buffer.size
    }

    /// Destroys the ring; the GPU must be idle.
    pub fn destroy(self, ctx: &GpuContext) {
        self.buffer.destroy(ctx);
    }
}
