//! Staging memory for CPU→GPU copies, and the rule by which GPU buffers that follow a count give
//! memory back ([`Shrink`]).
//!
//! Each frame in flight owns one host-visible [`StagingRing`]; records written this frame are
//! packed into it and copied into device-local buffers by commands recorded at the start of the
//! frame. The ring grows geometrically when a frame needs more than it has, and shrinks back by
//! the [`Shrink`] rule once the big uploads are over (to [`STAGING_FLOOR`] at the least), so a
//! steady state allocates nothing. One-off bulk uploads (meshes, textures) use a [`Buffer`] of
//! their own that is released with the frame, so the rings stay small.
//!
//! **Shrinking.** Every GPU buffer sized by something gameplay changes (record tables, the decal
//! and light acceleration structures and their scratch, light boxes, decal clusters, light tile
//! lists, the scene's TLAS, these rings) grows at once when it lacks room, and shrinks only when
//! what it needs has stayed at or below a quarter of its capacity for [`SHRINK_AFTER_FRAMES`]
//! frames in a row (the default of [`crate::DeviceSettings::shrink_after_frames`], which every
//! rule takes from [`GpuContext::shrink_rule`]): it is then replaced by one with room for the need's power of two (never
//! below the buffer's floor), through the graveyard, so the frames in flight keep reading the
//! old one. The factor of four and the wait keep a steady or oscillating size from shrinking and
//! regrowing in a loop: right after a shrink the need fills more than half the new buffer, and a
//! size that comes back within the wait never shrinks. Buffers that belong to one method (the
//! decal structures, ray-query lights, clusters, light tiles) are released altogether after the
//! same number of frames without use. Every shrink is counted in [`Upload::shrinks`] and the
//! frame's counters (`buffer_shrinks`, `bytes_released`).

use ash::vk;
use gpu_allocator::MemoryLocation;

use crate::RenderError;
use crate::gpu::commands::Recorder;
use crate::gpu::device::GpuContext;
use crate::gpu::memory::{Buffer, Graveyard, Retired};

/// Frames a buffer's need must stay at or below a quarter of its capacity (or the buffer go
/// unused) before it shrinks (or is released): a second at 60 frames a second.
pub const SHRINK_AFTER_FRAMES: u32 = 60;

/// Bytes a staging ring starts with and never shrinks below.
pub const STAGING_FLOOR: u64 = 64 * 1024;

/// The hysteresis of a buffer that shrinks: how many frames in a row its need has been low (see
/// the module docs). One per buffer; a frame that uses the buffer calls [`Shrink::check`], a
/// frame that does not [`Shrink::unused`].
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Shrink {
    low_frames: u32,
    after: u32,
}

impl Default for Shrink {
    fn default() -> Self {
        Self::after(SHRINK_AFTER_FRAMES)
    }
}

impl Shrink {
    /// A rule that acts after `calls` low calls in a row (the default: [`SHRINK_AFTER_FRAMES`]).
    pub const fn after(calls: u32) -> Self {
        Self { low_frames: 0, after: if calls == 0 { 1 } else { calls } }
    }

    /// A frame that needs `need` of the buffer's `capacity` (in any unit). Returns the capacity to
    /// shrink to, `need`'s power of two but at least `floor`, once `need` has stayed at or below a
    /// quarter of `capacity` for the rule's wait in a row ([`Shrink::after`]; the renderer's rules
    /// wait [`GpuContext::shrink_after_frames`] frames) and that is smaller than `capacity`;
    /// `None` otherwise.
    pub fn check(&mut self, capacity: u64, need: u64, floor: u64) -> Option<u64> {
        let target = need.max(floor).max(1).next_power_of_two();
        if need > capacity / 4 || target >= capacity {
            self.low_frames = 0;
            return None;
        }
        self.due().then_some(target)
    }

    /// A frame that does not use the buffer. Returns true once it has gone unused (or low) for
    /// the rule's wait of frames in a row: release it.
    pub fn unused(&mut self) -> bool {
        self.due()
    }

    /// Forgets the low frames (the buffer was just replaced or released).
    pub fn reset(&mut self) {
        self.low_frames = 0;
    }

    fn due(&mut self) -> bool {
        self.low_frames += 1;
        if self.low_frames < self.after {
            return false;
        }
        self.low_frames = 0;
        true
    }
}

/// What preparing a frame's uploads needs: the device, the frame slot's staging ring, the
/// graveyard for what a growing or shrinking buffer replaces, the frame's timeline values, and
/// the counts of bytes sent and of buffers shrunk. Passed as one value instead of eight
/// arguments.
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
    /// Buffers and acceleration structures replaced by smaller ones, or released, this frame.
    pub shrinks: u64,
    /// Bytes those shrinks hand back (freed once the GPU has finished the frames that used them).
    pub bytes_released: u64,
    /// CPU milliseconds the frame spent preparing its data and writing its uploads into this
    /// ring (set once the scene's upload is recorded).
    pub prepare_ms: f32,
}

impl Upload<'_> {
    /// The staging ring's buffer (copy source).
    pub fn staging_buffer(&self) -> vk::Buffer {
        self.staging.buffer()
    }

    /// Counts a shrink from `old` bytes to `new` (0 for a release).
    pub fn count_shrink(&mut self, old: u64, new: u64) {
        self.shrinks += 1;
        self.bytes_released += old.saturating_sub(new);
    }

    /// Buries `old`, which a smaller buffer (of `new` bytes, 0 when none) replaces, and counts
    /// the shrink.
    pub fn bury_shrunk(&mut self, old: Buffer, new: u64) {
        self.count_shrink(old.size, new);
        self.graveyard.bury(self.frame_value, Retired::Buffer(old));
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
    pub fn record(&self, ctx: &GpuContext, cmd: &Recorder) -> Result<(), RenderError> {
        let mut start = 0;
        for &(src, dst, end) in &self.buffers {
            if end > start {
                // The regions lie inside both buffers, which live until the frame completes
                // (graveyard).
                cmd.copy_buffer(src, dst, &self.regions[start..end]);
            }
            start = end;
        }
        if self.images.is_empty() {
            return Ok(());
        }
        // Image uploads (textures being loaded) are not logged: this frame records directly.
        let cmd = cmd.direct()?;
        let mut start = 0;
        for &(src, image, _, end) in &self.images {
            // SAFETY: `cmd` is recording outside a rendering scope; the regions lie inside both,
            // which live until the frame completes; the image is in TRANSFER_DST_OPTIMAL by the
            // pass's declaration.
            unsafe {
                ctx.device.cmd_copy_buffer_to_image(cmd, src, image, vk::ImageLayout::TRANSFER_DST_OPTIMAL, &self.image_regions[start..end])
            };
            start = end;
        }
        Ok(())
    }
}

/// A host-visible buffer reused every time its frame slot comes round.
pub struct StagingRing {
    buffer: Buffer,
    used: u64,
    shrink: Shrink,
}

const ALIGN: u64 = 16;

impl StagingRing {
    /// A ring of `capacity` bytes.
    pub fn new(ctx: &GpuContext, capacity: u64) -> Result<Self, RenderError> {
        let shrink = Shrink::after(ctx.shrink_after_frames.div_ceil(crate::gpu::FRAMES_IN_FLIGHT as u32));
        Ok(Self { buffer: Self::create(ctx, capacity)?, used: 0, shrink })
    }

    fn create(ctx: &GpuContext, capacity: u64) -> Result<Buffer, RenderError> {
        Buffer::new(ctx, "staging ring", capacity, vk::BufferUsageFlags::TRANSFER_SRC, MemoryLocation::CpuToGpu)
    }

    /// Empties the ring. Called when its frame slot's previous use has completed.
    pub fn reset(&mut self) {
        self.used = 0;
    }

    /// Makes room for this frame's `bytes` (0 for a frame that uploads nothing), like
    /// [`StagingRing::reserve`], after replacing the ring by a smaller one (at least
    /// [`STAGING_FLOOR`], and room for `bytes`) when its uses have needed at most a quarter of
    /// it for [`GpuContext::shrink_after_frames`] frames (each ring serves every
    /// [`crate::gpu::FRAMES_IN_FLIGHT`]th frame, so that many frames' worth of its uses). Called
    /// once per use, before the first push.
    pub fn fit(up: &mut Upload, bytes: u64) -> Result<(), RenderError> {
        let ring = &mut *up.staging;
        let need = ring.used + bytes + ALIGN;
        if let Some(capacity) = ring.shrink.check(ring.buffer.size, need, STAGING_FLOOR) {
            debug_assert_eq!(ring.used, 0, "shrink the ring before pushing into it");
            tracing::debug!(capacity, "staging ring shrinks");
            let old = std::mem::replace(&mut ring.buffer, Self::create(up.ctx, capacity)?);
            up.bury_shrunk(old, capacity);
        }
        up.staging.reserve(up.ctx, up.graveyard, up.frame_value, bytes)
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
        self.shrink.reset();
        Ok(())
    }

    /// Copies `bytes` in and returns their offset in [`StagingRing::buffer`].
    pub fn push(&mut self, bytes: &[u8]) -> u64 {
        self.push_with(bytes.len(), |dst| dst.copy_from_slice(bytes))
    }

    /// Takes `len` bytes (16-byte aligned), lets `fill` write them, and returns their offset in
    /// [`StagingRing::buffer`]: for records made on the fly, with no copy in between.
    pub fn push_with(&mut self, len: usize, fill: impl FnOnce(&mut [u8])) -> u64 {
        let offset = self.used.next_multiple_of(ALIGN);
        let end = offset + len as u64;
        assert!(end <= self.buffer.size, "staging ring overflow: reserve() first");
        fill(&mut self.buffer.mapped()[offset as usize..end as usize]);
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

#[cfg(test)]
mod tests {
    use super::*;

    /// Feeds `needs` to a rule over a buffer that starts at `capacity` and is replaced as the rule
    /// says (and grown to the need's power of two when the need passes it); returns the capacity
    /// after each frame.
    fn follow(capacity: u64, floor: u64, needs: impl IntoIterator<Item = u64>) -> Vec<u64> {
        let (mut rule, mut capacity) = (Shrink::default(), capacity);
        needs
            .into_iter()
            .map(|need| {
                let smaller = rule.check(capacity, need, floor);
                if need > capacity {
                    capacity = need.next_power_of_two();
                    rule.reset();
                } else if let Some(smaller) = smaller {
                    capacity = smaller;
                }
                capacity
            })
            .collect()
    }

    #[test]
    fn a_buffer_shrinks_after_a_second_at_a_quarter_or_less_never_below_its_floor() {
        let n = SHRINK_AFTER_FRAMES as usize;
        let caps = follow(4096, 64, std::iter::repeat_n(100, n + 5));
        assert!(caps[..n - 1].iter().all(|&c| c == 4096), "nothing before the wait: {caps:?}");
        assert_eq!(caps[n - 1], 128, "the need's power of two, after {n} low frames");
        assert!(caps[n..].iter().all(|&c| c == 128), "and it stays there: {caps:?}");
        assert_eq!(*follow(4096, 64, std::iter::repeat_n(0, n)).last().unwrap(), 64, "an empty need keeps the floor");
        assert_eq!(*follow(64, 64, std::iter::repeat_n(0, 3 * n)).last().unwrap(), 64, "a buffer at its floor stays");
        assert_eq!(*follow(4096, 64, std::iter::repeat_n(1025, 3 * n)).last().unwrap(), 4096, "over a quarter: no shrink");
    }

    #[test]
    fn no_size_shrinks_and_regrows_in_a_loop() {
        let n = SHRINK_AFTER_FRAMES as usize;
        // A steady need, whatever it is: at most one change, then none.
        for need in [1, 63, 64, 65, 100, 1000, 1024, 1025, 5000] {
            let caps = follow(1 << 20, 64, std::iter::repeat_n(need, 5 * n));
            assert!(caps[n..].windows(2).all(|w| w[0] == w[1]), "need {need}: {caps:?}");
            assert!(*caps.last().unwrap() >= need, "need {need}: room for it");
        }
        // A need that swings between small and large within the wait never shrinks.
        let swings = (0..10 * n).map(|i| if i % (n - 1) == 0 { 10_000 } else { 10 });
        let caps = follow(16_384, 64, swings);
        assert!(caps.iter().all(|&c| c == 16_384), "{caps:?}");
        // Unused frames count like low ones; a use that needs room resets them.
        let mut rule = Shrink::default();
        assert!((0..n - 1).all(|_| !rule.unused()));
        assert_eq!(rule.check(1000, 600, 0), None);
        assert!((0..n - 1).all(|_| !rule.unused()), "counting starts again");
        assert!(rule.unused(), "released after {n} unused frames in a row");
    }
}
