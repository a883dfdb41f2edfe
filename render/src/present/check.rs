//! The debug builds' check of the tone mapper's input (issue 55): no frame may pass on a value
//! that is not finite, and every pass that writes radiance into the HDR target clamps it to
//! what half floats hold (`shaders/include/storable.glsl`); this check says whether one slipped
//! through anyway.
//!
//! The display pass (`shaders/tonemap.frag`) tests each pixel's HDR value once and, where it is
//! not finite, adds one to a counter on the GPU (an atomic add behind a branch that ordinary
//! pixels never take); the tone mapper then maps what it reads as storable radiance, so the
//! picture stays finite. Each frame clears the counter and copies it back without waiting
//! ([`StatsReadback`]); the CPU adds it up two frames later, logs a warning naming the frame
//! (at most one every 256 frames) and keeps the totals for tests ([`DisplayCheckCounts`]). It
//! costs a 4-byte clear, a 4-byte copy and a well-predicted branch per pixel, and release builds
//! leave it out altogether (the lighting record's address is 0 and the branch is never taken).

use ash::vk;
use gpu_allocator::MemoryLocation;

use crate::RenderError;
use crate::gpu::device::GpuContext;
use crate::gpu::memory::Buffer;
use crate::graph::readback::StatsReadback;
use crate::graph::{BufferUse, Frame, FrameGraph, PassKind, ResourceId};

/// What the check has counted since the renderer started.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct DisplayCheckCounts {
    /// Frames whose count came back (two frames behind the latest).
    pub frames: u64,
    /// Pixels whose HDR value was not finite when the tone mapper read it, over those frames.
    pub non_finite_pixels: u64,
}

/// The counter, its per-frame copy for the CPU, and the totals.
pub struct DisplayCheck {
    counter: Buffer,
    res: ResourceId,
    readback: StatsReadback,
    counts: DisplayCheckCounts,
    warned: Option<u64>,
}

impl DisplayCheck {
    /// The check in debug builds (`None` in release builds).
    pub fn new(ctx: &GpuContext, graph: &mut FrameGraph) -> Result<Option<Self>, RenderError> {
        if !cfg!(debug_assertions) {
            return Ok(None);
        }
        let usage = vk::BufferUsageFlags::STORAGE_BUFFER
            | vk::BufferUsageFlags::SHADER_DEVICE_ADDRESS
            | vk::BufferUsageFlags::TRANSFER_DST
            | vk::BufferUsageFlags::TRANSFER_SRC;
        let counter = Buffer::new(ctx, "display check", 16, usage, MemoryLocation::GpuOnly)?;
        let readback = match StatsReadback::new(ctx, graph, "display check readback", 4) {
            Ok(r) => r,
            Err(e) => {
                counter.destroy(ctx);
                return Err(e);
            }
        };
        Ok(Some(Self { counter, res: graph.resource("display check"), readback, counts: DisplayCheckCounts::default(), warned: None }))
    }

    /// The counter's address, for the lighting record (`GpuLighting::display_check`).
    pub fn address(&self) -> u64 {
        self.counter.address
    }

    /// Adds up the count of the frame that last used this frame slot (warning when it found
    /// pixels that were not finite), and clears the counter for this frame.
    pub fn begin(&mut self, f: &mut Frame) -> Result<(), RenderError> {
        if let Some((frame, words)) = self.readback.take(f) {
            let found = u64::from(words[0]);
            self.counts.frames += 1;
            self.counts.non_finite_pixels += found;
            if found > 0 && self.warned.is_none_or(|w| frame >= w + 256) {
                self.warned = Some(frame);
                tracing::warn!(
                    frame,
                    pixels = found,
                    total = self.counts.non_finite_pixels,
                    "debug check: pixels that are not finite reached the tone mapper (a pass wrote radiance without storable_radiance); they are displayed as clamped radiance"
                );
            }
        }
        let (raw, res) = (self.counter.raw, self.res);
        f.pass("display_check_clear", PassKind::Transfer).write(res, BufferUse::Transfer).record(|p| {
            p.cmd.fill_buffer(raw, 0, vk::WHOLE_SIZE, 0);
        })
    }

    /// What the display pass declares: it adds to the counter.
    pub fn writes(&self) -> (ResourceId, BufferUse) {
        (self.res, BufferUse::Storage)
    }

    /// Copies this frame's count for the CPU, after the display pass.
    pub fn finish(&mut self, f: &mut Frame) -> Result<(), RenderError> {
        self.readback.record(f, "display_check_readback", self.res, self.counter.raw)
    }

    /// The totals so far.
    pub fn counts(&self) -> DisplayCheckCounts {
        self.counts
    }

    /// Destroys the buffers; the GPU must be idle.
    pub fn destroy(self, ctx: &GpuContext) {
        self.counter.destroy(ctx);
        self.readback.destroy(ctx);
    }
}
