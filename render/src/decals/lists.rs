//! Per-pixel decal lists for the ray-tracing-pipeline decal pass (seed 000 §4.2.2, with the
//! enumeration split from the blending): the first trace's any-hit shader writes each decal it
//! finds into its pixel's list in GPU memory, and the ray-generation shader blends the list
//! after the trace (`shaders/decal_pass.rgen`, `shaders/include/decal_lists.glsl`).
//!
//! - **Why memory and not the payload**: collecting in the payload (the previous design, kept
//!   for the reflection rays) makes the payload as large as the room it keeps, and traversal
//!   carries it: 32 decals cost 136 bytes and a pixel with more had to blend in any-hit.
//!   Writing to memory keeps a 16-byte payload whatever the depth. Measured on the lent H100 at
//!   1920×1080 (docs/experiments/decals-rt-lists.md),
//!   collecting alone took 2.17 ms in the payload and 1.80 ms in memory at 100,000 decals. An
//!   intersection shader that writes the list itself, with no any-hit shader at all, was slower
//!   (1.92 ms): its count must live in memory too, behind an atomic.
//! - **Room from the last frame**: each frame a compute pass (`decal_list_offsets.comp`) gives
//!   each run of 8 pixels along a row one block, with room for the most that any of them found
//!   the frame before (an eighth more and two), its pixels' entries interleaved so that the
//!   lanes of a warp write and read neighbouring words; the blocks are packed back to back
//!   with one atomic add per workgroup of 256 pixels, as the decal clusters' lists are
//!   ([`super::clustered`]). Against lists packed pixel by pixel, each with its own room,
//!   this took the pass from 3.15 to 2.90 ms at 100,000 decals and from 30.4 to 28.6 ms at
//!   1,000,000, and cut the pixels that outgrow their room under the jittered view by two
//!   thirds to three quarters. A pixel that finds more than its room (a
//!   newly covered pixel, the first frame) is blended by a second trace whose any-hit shader
//!   blends, the seed's way, so no decal is ever dropped; the statistics count those pixels
//!   ([`DecalListStats::overflowed`]).
//! - **Memory**: the buffer holds a header, three words a pixel (the list's first entry, the
//!   decals found, its room) and the entries. A pixel asks for room for at most
//!   `DECAL_LIST_MOST` (4,096) decals; one with more blends the seed's way. It grows to a quarter more than the entries asked
//!   for, rounded to a power of two, read back two frames later (a new buffer takes over the
//!   decals each pixel found, so the frame after growing needs no second traces), and shrinks with the same
//!   hysteresis as the cluster buffer (never below the initial room; released after a second
//!   unused: [`crate::gpu::room`]). It never takes more than [`MEMORY_SHARE`] of the renderer's memory: a pixel
//!   whose room does not fit gets none and blends the seed's way ([`DecalListStats::denied`];
//!   one warning). Measured at 1920×1080 on the courtyard's scatter: 10,000 decals ask for
//!   3.8 M entries (room for 8.4 M, 32 MiB), 100,000 for 23 M (33.6 M, 128 MiB), 1,000,000 for
//!   204 M (268 M, 1 GiB), beside 24 MiB of per-pixel words; the cluster lists of clustered
//!   decals take 4 and 32 MiB at 100,000 and 1,000,000 since they are bounded by the depth.
//! - **What it costs where decals are few**: the allocation pass, 0.038 ms a frame at
//!   1920×1080 on the H100, whatever the decals; at 10,000 scattered decals the pass went from
//!   0.60 to 0.62 ms, and in PEERS.md's scene (100 and 1,000 decals) from 0.213 to 0.205 ms
//!   and 0.310 to 0.302 ms.

use ash::vk;

use crate::RenderError;
use crate::gpu::device::GpuContext;
use crate::gpu::pipeline::create_computes;
use crate::gpu::room::{Fitted, ListRoom, MEMORY_SHARE};
use crate::gpu::shaders;
use crate::graph::readback::StatsReadback;
use crate::graph::{BufferUse, Frame, FrameGraph, PassKind, ResourceId};
use crate::layout::DECAL_LIST_HEADER;
use crate::stats::DecalListStats;

/// Entries the list buffer starts with room for.
pub const INITIAL_CAPACITY: u32 = 1 << 16;

/// Header words (`shaders/include/decal_lists.glsl`): the statistics, the image's size, then the
/// reservation counter.
const LIST_NEEDED: usize = 0;
const LIST_DENIED: usize = 1;
const LIST_OVERFLOWED: usize = 2;
const LIST_WIDTH: u64 = 3;
const LIST_PIXELS: u64 = 4;

/// The list buffer this frame (push constants and the passes that use it).
#[derive(Clone, Copy, Debug)]
pub struct ListFrame {
    /// Its frame-graph resource.
    pub res: ResourceId,
    /// Device address of the list buffer.
    pub address: vk::DeviceAddress,
    /// Entries it has room for.
    pub capacity: u32,
}

/// The list allocation pass, the list buffer and the statistics read back from it.
pub struct DecalLists {
    offsets: vk::Pipeline,
    /// The list buffer: a header, three words a pixel, then the entries.
    room: ListRoom,
    /// The image the buffer's per-pixel words were made for: row width and pixels.
    image: (u32, u32),
    /// The per-pixel words are not yet zero (a new buffer for a new image).
    fresh: bool,
    /// The buffer a new one replaced this frame for the same image: the decals each pixel found
    /// are copied over, so that growing costs no frame of rooms sized from nothing.
    carry: Option<vk::Buffer>,
    readback: StatsReadback,
    latest: DecalListStats,
    /// The ceiling last computed (it follows the image's size).
    limit: u32,
    res: ResourceId,
}

impl DecalLists {
    /// Creates the allocation pass and the readback buffers; the list buffer waits for first use.
    pub fn new(ctx: &GpuContext, graph: &mut FrameGraph, layout: vk::PipelineLayout) -> Result<Self, RenderError> {
        let [offsets] = create_computes(ctx, layout, [("decal list offsets", shaders::DECAL_LIST_OFFSETS_COMP)])?;
        let readback = match StatsReadback::new(ctx, graph, "decal list statistics", DECAL_LIST_HEADER as u64 * 4) {
            Ok(readback) => readback,
            Err(e) => {
                // SAFETY: the pipeline was never used.
                unsafe { ctx.destroying().destroy_pipeline(offsets, None) };
                return Err(e);
            }
        };
        Ok(Self {
            offsets,
            room: ListRoom::new(ctx, "decal lists", INITIAL_CAPACITY),
            image: (0, 0),
            fresh: false,
            carry: None,
            readback,
            latest: DecalListStats { measured_frame: u64::MAX, ..Default::default() },
            limit: 0,
            res: graph.resource("decal lists"),
        })
    }

    /// Reads back the statistics of the frame that last used this frame's slot, grows (or
    /// shrinks) the list buffer to what that frame asked for, and says where the buffer is.
    /// Call before the frame's push constants are set.
    pub fn prepare(&mut self, f: &mut Frame, stats: &mut DecalListStats) -> Result<ListFrame, RenderError> {
        let ctx = f.ctx;
        let extent = f.graph.extent();
        let image = (extent.width, extent.width * extent.height);
        // A buffer replaced in a frame that did not record the lists (the floor's debug view) is
        // gone by now: zero the counts instead of copying them from it.
        if self.carry.take().is_some() {
            self.fresh = true;
        }
        self.read_back(f);
        let fixed = (DECAL_LIST_HEADER as u64 + 3 * image.1 as u64) * 4;
        let limit = self.room.limit(ctx, fixed);
        let denied = self.latest.denied;
        let warning = |needed: u32| {
            format!(
                "the ray-tracing-pipeline decal pass's lists need {needed} entries, past the ceiling of {limit} (1/{} of {} MiB of GPU memory): {denied} pixels blend their decals in the any-hit shader instead, which is slower",
                MEMORY_SHARE.1,
                ctx.memory_limit() >> 20,
            )
        };
        if let Fitted::New { previous } = self.room.fit(f, (self.latest.needed, denied), (fixed, limit), image != self.image, warning)? {
            self.carry = previous.filter(|_| image == self.image);
            (self.image, self.fresh) = (image, self.carry.is_none());
        }
        self.limit = limit;
        *stats = self.report();
        let capacity = self.room.capacity;
        let address = self.room.buffer.as_ref().expect("allocated above").address;
        Ok(ListFrame { res: self.res, address, capacity })
    }

    /// Takes the statistics the frame that last used this frame's slot copied, if any.
    fn read_back(&mut self, f: &Frame) {
        if let Some((frame, words)) = self.readback.take(f) {
            self.latest = DecalListStats {
                measured_frame: frame,
                needed: words[LIST_NEEDED] as u64,
                denied: words[LIST_DENIED] as u64,
                overflowed: words[LIST_OVERFLOWED] as u64,
                ..Default::default()
            };
        }
    }

    /// A frame without the ray-tracing-pipeline decal pass: after
    /// [`crate::gpu::device::GpuContext::shrink_after_frames`] of them in a row the list buffer is released,
    /// and what it measured is forgotten. Until then `stats` shows the room still held and the
    /// figures of the last frames that used it.
    pub fn idle(&mut self, f: &mut Frame, stats: &mut DecalListStats) {
        self.read_back(f);
        if self.room.idle(&mut f.upload) {
            self.image = (0, 0);
            // The next frame with the pass starts again from the initial room.
            self.latest = DecalListStats { measured_frame: u64::MAX, ..Default::default() };
            self.readback.forget();
        }
        *stats = self.report();
    }

    /// The statistics this frame: the room held and its history, with the last measured figures.
    fn report(&self) -> DecalListStats {
        DecalListStats {
            capacity: self.room.capacity as u64,
            limit: self.limit as u64,
            grows: self.room.grows,
            shrinks: self.room.shrinks,
            ..self.latest
        }
    }

    /// Clears the header (and a new buffer's per-pixel words) and reserves each pixel's room.
    /// Call before the decal pass; the push constants must hold [`DecalLists::prepare`]'s result.
    pub fn record_offsets(&mut self, f: &mut Frame) -> Result<(), RenderError> {
        let Some(buffer) = self.room.buffer.as_ref() else { return Ok(()) };
        let (raw, res, (width, pixels)) = (buffer.raw, self.res, self.image);
        // The statistics, the image's size, and in a new buffer the rest of the header and the
        // per-pixel words, or the decals each pixel found, from the buffer it replaced: ranges
        // that do not overlap, so no barrier is needed between them.
        let fresh = std::mem::take(&mut self.fresh).then_some((DECAL_LIST_HEADER as u64 + 3 * pixels as u64) * 4);
        let carry = self.carry.take();
        let found = vk::BufferCopy {
            src_offset: (DECAL_LIST_HEADER as u64 + pixels as u64) * 4,
            dst_offset: (DECAL_LIST_HEADER as u64 + pixels as u64) * 4,
            size: pixels as u64 * 4,
        };
        f.pass("decal_lists_clear", PassKind::Transfer).write(res, BufferUse::Transfer).record(|p| {
            p.cmd.fill_buffer(raw, 0, LIST_WIDTH * 4, 0);
            p.cmd.fill_buffer(raw, LIST_WIDTH * 4, 4, width);
            p.cmd.fill_buffer(raw, LIST_PIXELS * 4, 4, pixels);
            // The reservation counter and the spare words.
            p.cmd.fill_buffer(raw, (LIST_PIXELS + 1) * 4, (DECAL_LIST_HEADER as u64 - LIST_PIXELS - 1) * 4, 0);
            if let Some(end) = fresh {
                p.cmd.fill_buffer(raw, DECAL_LIST_HEADER as u64 * 4, end - DECAL_LIST_HEADER as u64 * 4, 0);
            } else if let Some(previous) = carry {
                p.cmd.copy_buffer(previous, raw, &[found]);
            }
        })?;
        let extent = f.graph.extent();
        let pipeline = self.offsets;
        f.pass("decal_list_offsets", PassKind::Compute).write(res, BufferUse::Storage).record(|p| {
            p.bind(vk::PipelineBindPoint::COMPUTE, pipeline, &p.push);
            p.cmd.dispatch(extent.width.div_ceil(16), extent.height.div_ceil(16), 1);
        })
    }

    /// Copies the statistics for the CPU; call after the decal pass.
    pub fn record_statistics(&mut self, f: &mut Frame) -> Result<(), RenderError> {
        let Some(buffer) = self.room.buffer.as_ref() else { return Ok(()) };
        let raw = buffer.raw;
        self.readback.record(f, "decal_lists_statistics", self.res, raw)
    }

    /// Destroys everything; the GPU must be idle.
    pub fn destroy(self, ctx: &GpuContext) {
        // SAFETY: the GPU is idle.
        unsafe { ctx.destroying().destroy_pipeline(self.offsets, None) };
        self.room.destroy(ctx);
        self.readback.destroy(ctx);
    }
}
