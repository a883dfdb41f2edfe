//! The room of a buffer of lists that the GPU fills and the CPU sizes from what it reads back
//! two frames later: the decal clusters' lists ([`crate::decals::clustered`]), the
//! ray-tracing-pipeline decal pass's per-pixel lists ([`crate::decals::lists`]) and the light
//! tiles' index list ([`crate::lights::tiles`]). It grows to a quarter
//! more than the need, rounded to a power of two; it shrinks with [`Shrink`]'s hysteresis (never
//! below the initial room) and is released after a second unused (by default:
//! [`GpuContext::shrink_after_frames`]); it never takes more than
//! [`MEMORY_SHARE`] of the renderer's memory, and the first frame whose need stays past that
//! ceiling is warned about once (again only after the need fitted in between).

use ash::vk;
use gpu_allocator::MemoryLocation;

use crate::RenderError;
use crate::gpu::device::GpuContext;
use crate::gpu::memory::{Buffer, GPU_WRITTEN, Retired};
use crate::gpu::upload::{Shrink, Upload};
use crate::graph::Frame;

/// The share of the renderer's memory ([`GpuContext::memory_limit`]) a buffer of lists may take
/// at most: one eighth.
pub const MEMORY_SHARE: (u64, u64) = (1, 8);

/// The room a buffer of lists should have, in entries: a quarter more than `needed`, rounded
/// up to a power of two, when the current room is too small; `smaller` (the shrink policy's
/// verdict) when it has stayed far too large; otherwise the current room (at least
/// `initial`). Never more than `limit`.
fn plan_capacity(current: u32, needed: u32, initial: u32, smaller: Option<u64>, limit: u32) -> u32 {
    let mut capacity = current.max(initial);
    if needed > capacity {
        capacity = needed.saturating_add(needed / 4).checked_next_power_of_two().unwrap_or(u32::MAX);
    } else if let Some(smaller) = smaller {
        capacity = smaller.min(u32::MAX as u64) as u32;
    }
    capacity.min(limit)
}

/// What [`ListRoom::fit`] did.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub(crate) enum Fitted {
    /// The buffer stays.
    Kept,
    /// A new buffer replaced `previous` (none the first time), which lives until this frame
    /// has finished: this frame's commands may still copy from it.
    New { previous: Option<vk::Buffer> },
}

/// A buffer of 32-bit list entries after `fixed` bytes of its own, and how its room has changed.
pub(crate) struct ListRoom {
    name: &'static str,
    /// The buffer (none before first use, or once released).
    pub buffer: Option<Buffer>,
    /// Entries it has room for.
    pub capacity: u32,
    initial: u32,
    /// Times it grew, since the renderer started.
    pub grows: u64,
    /// Times it shrank or was released, since the renderer started.
    pub shrinks: u64,
    shrink: Shrink,
    warned_at_limit: bool,
}

impl ListRoom {
    /// No buffer yet; the first gets room for `initial` entries (within the ceiling).
    pub fn new(ctx: &GpuContext, name: &'static str, initial: u32) -> Self {
        Self {
            name,
            buffer: None,
            capacity: 0,
            initial: initial.max(1),
            grows: 0,
            shrinks: 0,
            shrink: ctx.shrink_rule(),
            warned_at_limit: false,
        }
    }

    /// Sets the least room the buffer keeps (and a new one gets, within the ceiling) from the
    /// next [`Self::fit`] on, for lists whose floor follows the frame (the light tiles: a few entries a tile).
    pub fn set_initial(&mut self, initial: u32) {
        self.initial = initial.max(1);
    }

    /// The most entries the buffer may hold beside its `fixed` bytes: never past 2³⁰, so that
    /// every word index a shader forms stays a positive 32-bit integer.
    pub fn limit(&self, ctx: &GpuContext, fixed: u64) -> u32 {
        let share = ctx.memory_limit() / MEMORY_SHARE.1 * MEMORY_SHARE.0;
        (share.saturating_sub(fixed) / 4).clamp(self.initial.min(1024) as u64, 1 << 30) as u32
    }

    /// Gives the buffer room for `needed` entries (within `limit`), a new buffer of `fixed`
    /// bytes plus its entries when the room changes or `remake` says the fixed part did.
    /// `dropped` is what the GPU could not fit in the frame that needed that much; past the
    /// ceiling, `warning` is logged once.
    pub fn fit(
        &mut self,
        f: &mut Frame,
        (needed, dropped): (u64, u64),
        (fixed, limit): (u64, u32),
        remake: bool,
        warning: impl FnOnce(u32) -> String,
    ) -> Result<Fitted, RenderError> {
        let needed = needed.min(u32::MAX as u64 / 2) as u32;
        let smaller = self.shrink.check(self.capacity as u64, (needed + needed / 4) as u64, self.initial as u64);
        let capacity = plan_capacity(self.capacity, needed, self.initial, smaller, limit);
        if needed > limit && dropped > 0 {
            if !self.warned_at_limit {
                self.warned_at_limit = true;
                tracing::warn!("{}", warning(needed));
            }
        } else if needed <= limit {
            self.warned_at_limit = false;
        }
        if self.buffer.is_some() && capacity == self.capacity && !remake {
            return Ok(Fitted::Kept);
        }
        let size = fixed + capacity as u64 * 4;
        let buffer = Buffer::new(f.ctx, self.name, size, GPU_WRITTEN, MemoryLocation::GpuOnly)?;
        let previous = self.buffer.as_ref().map(|b| b.raw);
        if let Some(old) = self.buffer.replace(buffer) {
            if capacity < self.capacity {
                self.shrinks += 1;
                f.upload.bury_shrunk(old, size);
            } else {
                if capacity > self.capacity {
                    self.grows += 1;
                }
                f.upload.graveyard.bury(f.upload.frame_value, Retired::Buffer(old));
            }
        }
        self.capacity = capacity;
        self.shrink.reset();
        Ok(Fitted::New { previous })
    }

    /// A frame that does not use the buffer: after [`crate::gpu::device::GpuContext::shrink_after_frames`]
    /// of them in a row it is released. Returns whether it was.
    pub fn idle(&mut self, up: &mut Upload) -> bool {
        if self.buffer.is_none() || !self.shrink.unused() {
            return false;
        }
        if let Some(old) = self.buffer.take() {
            up.bury_shrunk(old, 0);
        }
        self.capacity = 0;
        self.shrinks += 1;
        true
    }

    /// Destroys the buffer; the GPU must be idle.
    pub fn destroy(self, ctx: &GpuContext) {
        if let Some(b) = self.buffer {
            b.destroy(ctx);
        }
    }
}

#[cfg(test)]
mod tests {
    use super::plan_capacity;

    #[test]
    fn the_cluster_room_grows_with_a_quarter_to_spare_shrinks_when_told_and_stops_at_the_ceiling() {
        // Fits: stays (at least the initial room).
        assert_eq!(plan_capacity(0, 10, 64, None, 1 << 20), 64);
        assert_eq!(plan_capacity(4096, 1000, 64, None, 1 << 20), 4096);
        // Too small: a quarter more, to the next power of two.
        assert_eq!(plan_capacity(64, 100, 64, None, 1 << 20), 128);
        assert_eq!(plan_capacity(64, 1000, 64, None, 1 << 20), 2048);
        // The shrink policy's verdict.
        assert_eq!(plan_capacity(1 << 16, 10, 64, Some(64), 1 << 20), 64);
        // The ceiling caps growth, and a room above it (a lowered budget) comes down to it.
        assert_eq!(plan_capacity(64, 1 << 22, 64, None, 1 << 20), 1 << 20);
        assert_eq!(plan_capacity(1 << 21, 10, 64, None, 1 << 20), 1 << 20);
        // Near the top of u32 the growth saturates instead of overflowing, at the ceiling.
        assert_eq!(plan_capacity(64, u32::MAX / 2, 64, None, u32::MAX / 2), u32::MAX / 2);
    }
}
