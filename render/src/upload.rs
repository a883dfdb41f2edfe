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
use crate::device::GpuContext;
use crate::memory::{Buffer, Graveyard, Retired};

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
