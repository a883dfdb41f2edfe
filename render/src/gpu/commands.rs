//! Command buffers recorded once and submitted again while the frame stays the same.
//!
//! A GPU-driven frame (`crate::culling`) changes its *data* every frame (the camera, the
//! instances, the lights: buffers the GPU reads) but rarely its *commands*: the same passes bind
//! the same pipelines, dispatch the same grids and draw through the same indirect buffers. Yet
//! the driver's fixed costs of recording them (beginning six-attachment renderings, the first
//! ray-tracing dispatch of a command buffer, resetting the pool, ending the buffer) were most of
//! issue 24's CPU record time on the lent H100 (`docs/experiments/culling-record-cuts.md`).
//! Vulkan lets a command buffer be submitted again once its previous submission has
//! completed (it is recorded without `ONE_TIME_SUBMIT`), so recording it again is work that
//! follows nothing that changed. The technique is the "static command buffer" of GPU-driven
//! renderers (Haar and Aaltonen, "GPU-Driven Rendering Pipelines", SIGGRAPH 2015: the CPU's
//! part of a frame no longer depends on the scene); this module makes it automatic and exact.
//!
//! How: every pass records through a [`Recorder`], which writes each command and all its
//! arguments (handles, counts, push-constant bytes, barriers, attachments) as words into a
//! log instead of calling the driver. At the end of the frame, [`Recorder::finish`] compares the
//! log with those its frame slot's command buffers were recorded from (the last one submitted and
//! [`KEPT`] more, for commands that come round every few frames). Equal to one, and no Vulkan
//! object destroyed since ([`GpuContext::objects_destroyed`]: a new object may reuse a destroyed
//! one's handle), that command buffer is submitted as it is; otherwise the slot's buffer used
//! longest ago is reset and the log replayed into it. Acceleration-structure builds and refits are logged too, so a skinned
//! character's refits repeat like the rest. A command the log does not hold (image uploads,
//! readbacks, a BLAS compaction and its size query, the overlay's drawing) asks for
//! [`Recorder::direct`]: the log so far is replayed, everything after it goes straight to the
//! driver, and that frame's command buffer is never reused. Data the GPU reads from buffers
//! (staging copies read the staging ring at execution, culling's parameters are written by the
//! host) never enters the log, so a moving camera still reuses; an upload of another shape, a
//! new pass, a resized target or another push constant records again.
//!
//! What it costs: a frame that records writes the log, then replays it into the driver, about
//! 0.03 ms more than recording directly on the lent H100's host; a reused frame skips the driver
//! entirely (`docs/experiments/culling-command-reuse.md`).

use std::cell::RefCell;

use ash::vk;
use ash::vk::Handle;

use crate::gpu::device::GpuContext;

/// Command buffers a frame slot keeps besides the one it submitted last: a frame whose commands
/// come round in a cycle longer than one frame (a crowd posed by the animation budget every
/// fourth frame refits another quarter of its characters each frame, so a slot's frames
/// alternate between two sets of thousands of refits) still finds them recorded. Each is a pool
/// and its buffer.
pub const KEPT: usize = 3;

/// A command pool and its one primary buffer, with the log the buffer was recorded from.
#[derive(Default)]
struct Recorded {
    pool: vk::CommandPool,
    cmd: vk::CommandBuffer,
    recorded: Vec<u64>,
    /// The destroyed-object count when `recorded` was recorded; `None` when the buffer holds
    /// commands the log does not (or nothing).
    recorded_at: Option<u64>,
    /// The slot's frame count when it was last submitted (which kept buffer a new recording
    /// replaces: the one used longest ago).
    used: u64,
}

/// A frame slot's command buffers (the one submitted last and [`KEPT`] more, each with the log
/// it was recorded from), and this frame's log. Lives as long as the renderer; a [`Recorder`]
/// holds it for one frame. All the slot's buffers were submitted in the slot's earlier frames,
/// which have completed when the slot's next frame starts, so any of them may be reset or
/// submitted again. The default is an empty placeholder (null handles) for a slot whose cache a
/// recorder holds.
#[derive(Default)]
pub struct CommandCache {
    /// The buffer this frame records into or submits again.
    current: Recorded,
    kept: Vec<Recorded>,
    /// Frames this slot has ended.
    frames: u64,
    log: Vec<u64>,
    images: Vec<vk::ImageMemoryBarrier2<'static>>,
    attachments: Vec<vk::RenderingAttachmentInfo<'static>>,
    regions: Vec<vk::BufferCopy>,
    image_copies: Vec<vk::ImageCopy>,
    geometries: Vec<vk::AccelerationStructureGeometryKHR<'static>>,
    builds: Vec<vk::AccelerationStructureBuildGeometryInfoKHR<'static>>,
    ranges: Vec<vk::AccelerationStructureBuildRangeInfoKHR>,
}

impl CommandCache {
    /// Creates the slot's pools, each with its one primary command buffer.
    pub fn new(ctx: &GpuContext) -> Result<Self, vk::Result> {
        Self::with_kept(ctx, KEPT)
    }

    /// A cache of one command buffer, for commands recorded once ([`GpuContext::run_once`]).
    pub fn one_off(ctx: &GpuContext) -> Result<Self, vk::Result> {
        Self::with_kept(ctx, 0)
    }

    fn with_kept(ctx: &GpuContext, kept: usize) -> Result<Self, vk::Result> {
        let mut all = Vec::with_capacity(kept + 1);
        for _ in 0..=kept {
            match Recorded::new(ctx) {
                Ok(r) => all.push(r),
                Err(e) => {
                    for r in all {
                        r.destroy(ctx);
                    }
                    return Err(e);
                }
            }
        }
        let current = all.pop().expect("kept + 1 made");
        Ok(Self {
            current,
            kept: all,
            frames: 0,
            log: Vec::new(),
            images: Vec::new(),
            attachments: Vec::new(),
            regions: Vec::new(),
            image_copies: Vec::new(),
            geometries: Vec::new(),
            builds: Vec::new(),
            ranges: Vec::new(),
        })
    }

    /// The command buffer (submitted after [`Recorder::finish`]).
    pub fn cmd(&self) -> vk::CommandBuffer {
        self.current.cmd
    }

    /// Destroys the pools; the GPU must be idle.
    pub fn destroy(self, ctx: &GpuContext) {
        for r in std::iter::once(self.current).chain(self.kept) {
            r.destroy(ctx);
        }
    }

    /// Makes the buffer to record into the current one: the current one itself when it can never
    /// be submitted again as it is (it holds commands the log does not, or names an object
    /// destroyed since, `destroyed`), else a kept one that cannot, else the kept one used longest
    /// ago (the current one is kept instead).
    fn take_oldest(&mut self, destroyed: u64) {
        let spent = |r: &Recorded| r.recorded_at != Some(destroyed);
        if spent(&self.current) {
            return;
        }
        if let Some(oldest) = self.kept.iter_mut().min_by_key(|r| (!spent(r), r.used)) {
            std::mem::swap(&mut self.current, oldest);
        }
    }

    /// Makes a buffer recorded from exactly this frame's log, with no Vulkan object destroyed
    /// since (`destroyed`), the current one; whether there was one.
    fn find(&mut self, destroyed: u64) -> bool {
        let matches = |r: &Recorded| r.recorded_at == Some(destroyed) && r.recorded == self.log;
        if matches(&self.current) {
            return true;
        }
        match self.kept.iter().position(matches) {
            Some(i) => {
                std::mem::swap(&mut self.current, &mut self.kept[i]);
                true
            }
            None => false,
        }
    }
}

impl Recorded {
    fn new(ctx: &GpuContext) -> Result<Self, vk::Result> {
        let d = &ctx.device;
        // SAFETY: valid create infos; destroyed in `destroy`.
        unsafe {
            let pool = d.create_command_pool(&vk::CommandPoolCreateInfo::default().queue_family_index(ctx.queue_family), None)?;
            let allocate = vk::CommandBufferAllocateInfo::default().command_pool(pool).command_buffer_count(1);
            match d.allocate_command_buffers(&allocate) {
                Ok(cmds) => Ok(Self { pool, cmd: cmds[0], ..Default::default() }),
                Err(e) => {
                    d.destroy_command_pool(pool, None);
                    Err(e)
                }
            }
        }
    }

    fn destroy(self, ctx: &GpuContext) {
        // SAFETY: the GPU is idle, so no submission uses the buffer. (A pool no command names:
        // not counted by `GpuContext::objects_destroyed`.)
        unsafe { ctx.device.destroy_command_pool(self.pool, None) };
    }
}

/// What [`Recorder::finish`] did with the frame's commands.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Recording {
    /// The slot's command buffer already held exactly these commands: submitted again.
    Reused,
    /// Recorded from the log (reusable by a later frame with the same commands).
    Recorded,
    /// Recorded with commands the log does not hold (not reusable).
    Direct,
}

struct State {
    cache: CommandCache,
    /// Whether commands go to the driver as they come (the log up to `replayed` is recorded).
    direct: bool,
    replayed: usize,
    /// The driver's refusal to begin the buffer, reported by [`Recorder::finish`].
    failed: Option<vk::Result>,
}

/// Records one frame's commands into a log, or straight into the command buffer after
/// [`Recorder::direct`]. Shared by reference (`&Recorder`) by everything that records.
pub struct Recorder<'a> {
    ctx: &'a GpuContext,
    state: RefCell<State>,
}

// The log's opcodes.
const BIND_PIPELINE: u64 = 1;
const BIND_SET: u64 = 2;
const PUSH: u64 = 3;
const BARRIER: u64 = 4;
const BEGIN_RENDERING: u64 = 5;
const END_RENDERING: u64 = 6;
const VIEWPORT: u64 = 7;
const CULL_MODE: u64 = 8;
const DRAW: u64 = 9;
const DRAW_INDIRECT_COUNT: u64 = 10;
const BIND_GEOMETRY: u64 = 11;
const DISPATCH: u64 = 12;
const FILL: u64 = 13;
const UPDATE: u64 = 14;
const COPY: u64 = 15;
const COPY_IMAGE: u64 = 16;
const TIMESTAMP: u64 = 17;
const TRACE: u64 = 18;
const BUILD_ACCEL: u64 = 19;
const DRAW_INDIRECT_ONE: u64 = 20;

/// Builds a replayed `vkCmdBuildAccelerationStructuresKHR` passes to the driver at once (a
/// logged call with more is replayed as several: builds in one call may run concurrently
/// anyway, so the split orders nothing).
const BUILDS_PER_CALL: usize = 64;

/// Words an attachment of `BEGIN_RENDERING` takes.
const ATTACHMENT_WORDS: usize = 7;

fn h(x: impl Handle) -> u64 {
    x.as_raw()
}

fn pair(a: u32, b: u32) -> u64 {
    a as u64 | (b as u64) << 32
}

fn split(w: u64) -> (u32, u32) {
    (w as u32, (w >> 32) as u32)
}

fn flag(f: i32) -> u64 {
    f as u32 as u64
}

/// Words of a byte string: its length, then the bytes eight to a word.
fn push_bytes(log: &mut Vec<u64>, bytes: &[u8]) {
    log.push(bytes.len() as u64);
    for chunk in bytes.chunks(8) {
        let mut w = [0u8; 8];
        w[..chunk.len()].copy_from_slice(chunk);
        log.push(u64::from_ne_bytes(w));
    }
}

/// The byte string [`push_bytes`] wrote at `w`, and the words it takes after its length.
fn read_bytes(w: &[u64]) -> (&[u8], usize) {
    let len = w[0] as usize;
    let words = len.div_ceil(8);
    let bytes: &[u8] = bytemuck::cast_slice(&w[1..1 + words]);
    (&bytes[..len], words)
}

fn subresource(log: &mut Vec<u64>, s: vk::ImageSubresourceLayers) {
    log.extend([pair(s.aspect_mask.as_raw(), s.mip_level), pair(s.base_array_layer, s.layer_count)]);
}

fn read_subresource(w: &[u64]) -> vk::ImageSubresourceLayers {
    let ((aspect, mip), (layer, count)) = (split(w[0]), split(w[1]));
    vk::ImageSubresourceLayers {
        aspect_mask: vk::ImageAspectFlags::from_raw(aspect),
        mip_level: mip,
        base_array_layer: layer,
        layer_count: count,
    }
}

fn offset3(o: vk::Offset3D) -> [u64; 2] {
    [pair(o.x as u32, o.y as u32), o.z as u32 as u64]
}

fn read_offset3(w: &[u64]) -> vk::Offset3D {
    let (x, y) = split(w[0]);
    vk::Offset3D { x: x as i32, y: y as i32, z: w[1] as u32 as i32 }
}

fn region(log: &mut Vec<u64>, r: &vk::StridedDeviceAddressRegionKHR) {
    log.extend([r.device_address, r.stride, r.size]);
}

fn read_region(w: &[u64]) -> vk::StridedDeviceAddressRegionKHR {
    vk::StridedDeviceAddressRegionKHR { device_address: w[0], stride: w[1], size: w[2] }
}

impl<'a> Recorder<'a> {
    /// Starts a frame's log in `cache` (given back by [`Recorder::finish`]). With `reuse` off,
    /// every command goes to the driver as it comes (the frame is recorded the ordinary way).
    pub fn new(ctx: &'a GpuContext, mut cache: CommandCache, reuse: bool) -> Self {
        cache.log.clear();
        let r = Self { ctx, state: RefCell::new(State { cache, direct: false, replayed: 0, failed: None }) };
        if !reuse {
            // A refusal is kept and reported by `finish`.
            let _ = r.direct();
        }
        r
    }

    /// The command buffer, for commands the log does not hold: what was logged so far is
    /// recorded first, and the rest of the frame goes straight to the driver (the frame's
    /// buffer will not be reused). Fails only when the driver cannot begin the buffer.
    pub fn direct(&self) -> Result<vk::CommandBuffer, vk::Result> {
        let mut s = self.state.borrow_mut();
        if let Some(e) = s.failed {
            return Err(e);
        }
        if !s.direct {
            s.cache.take_oldest(self.ctx.objects_destroyed());
            if let Err(e) = begin(self.ctx, &mut s.cache) {
                s.failed = Some(e);
                return Err(e);
            }
            s.direct = true;
            replay(self.ctx, &mut s);
        }
        Ok(s.cache.current.cmd)
    }

    /// Words logged so far this frame (every command and its arguments).
    pub fn words(&self) -> usize {
        self.state.borrow().cache.log.len()
    }

    /// Ends the frame's commands: keeps the slot's buffer when it holds exactly them (to be
    /// submitted again), records them otherwise. Gives the cache back, whose
    /// [`CommandCache::cmd`] is then ready to submit unless this failed.
    pub fn finish(self) -> (CommandCache, Result<Recording, vk::Result>) {
        let ctx = self.ctx;
        let mut s = self.state.into_inner();
        let result = Self::end(ctx, &mut s);
        (s.cache, result)
    }

    /// Gives the cache back after a frame that failed before its end: nothing is submitted, and
    /// the buffer is recorded afresh next time.
    /// (A frame that went direct reset the pool, which cleared `recorded_at`; one that did not
    /// left the buffer as it was.)
    pub fn abandon(self) -> CommandCache {
        self.state.into_inner().cache
    }

    fn end(ctx: &GpuContext, s: &mut State) -> Result<Recording, vk::Result> {
        if let Some(e) = s.failed {
            return Err(e);
        }
        let destroyed = ctx.objects_destroyed();
        s.cache.frames += 1;
        let how = if s.direct {
            Recording::Direct
        } else if s.cache.find(destroyed) {
            s.cache.current.used = s.cache.frames;
            return Ok(Recording::Reused);
        } else {
            s.cache.take_oldest(destroyed);
            begin(ctx, &mut s.cache)?;
            replay(ctx, s);
            Recording::Recorded
        };
        s.cache.current.used = s.cache.frames;
        // SAFETY: the buffer is recording (begun above or at `direct`) outside a rendering scope.
        unsafe { ctx.device.end_command_buffer(s.cache.current.cmd) }?;
        if how == Recording::Recorded {
            // Reusable from now on (a buffer whose end failed never is: `begin` cleared this).
            let c = &mut s.cache;
            std::mem::swap(&mut c.log, &mut c.current.recorded);
            c.current.recorded_at = Some(destroyed);
        }
        Ok(how)
    }

    /// Appends one command; in direct mode, records it at once.
    fn log(&self, write: impl FnOnce(&mut Vec<u64>)) {
        let mut s = self.state.borrow_mut();
        write(&mut s.cache.log);
        if s.direct && s.failed.is_none() {
            replay(self.ctx, &mut s);
        }
    }

    /// Binds `pipeline` at `point`.
    pub fn bind_pipeline(&self, point: vk::PipelineBindPoint, pipeline: vk::Pipeline) {
        self.log(|l| l.extend([BIND_PIPELINE, flag(point.as_raw()), h(pipeline)]));
    }

    /// Binds `set` as set 0 of `layout` (no dynamic offsets).
    pub fn bind_set(&self, point: vk::PipelineBindPoint, layout: vk::PipelineLayout, set: vk::DescriptorSet) {
        self.log(|l| l.extend([BIND_SET, flag(point.as_raw()), h(layout), h(set)]));
    }

    /// Sets push constants (the bytes enter the log: a push that changes records again).
    pub fn push_constants(&self, layout: vk::PipelineLayout, stages: vk::ShaderStageFlags, offset: u32, bytes: &[u8]) {
        self.log(|l| {
            l.extend([PUSH, h(layout), pair(stages.as_raw(), offset)]);
            push_bytes(l, bytes);
        });
    }

    /// A pipeline barrier of at most one global memory barrier and any image barriers (the only
    /// kinds the graph places; queue-family transfers, `p_next` chains and dependency flags are
    /// not used).
    pub fn barrier(&self, memory: &[vk::MemoryBarrier2], images: &[vk::ImageMemoryBarrier2]) {
        assert!(memory.len() <= 1, "one global memory barrier at most");
        self.log(|l| {
            l.extend([BARRIER, pair(memory.len() as u32, images.len() as u32)]);
            for m in memory {
                l.extend([m.src_stage_mask.as_raw(), m.src_access_mask.as_raw(), m.dst_stage_mask.as_raw(), m.dst_access_mask.as_raw()]);
            }
            for b in images {
                let r = b.subresource_range;
                l.extend([
                    b.src_stage_mask.as_raw(),
                    b.src_access_mask.as_raw(),
                    b.dst_stage_mask.as_raw(),
                    b.dst_access_mask.as_raw(),
                    pair(b.old_layout.as_raw() as u32, b.new_layout.as_raw() as u32),
                    h(b.image),
                    pair(r.aspect_mask.as_raw(), r.base_mip_level),
                    pair(r.level_count, r.base_array_layer),
                    r.layer_count as u64,
                    pair(b.src_queue_family_index, b.dst_queue_family_index),
                ]);
            }
        });
    }

    /// Begins dynamic rendering over `extent` from the origin, one layer, into `colors` and
    /// `depth` (attachments without `p_next`; their clear values are copied bit for bit).
    pub fn begin_rendering(
        &self,
        extent: vk::Extent2D,
        colors: &[vk::RenderingAttachmentInfo],
        depth: Option<&vk::RenderingAttachmentInfo>,
    ) {
        self.log(|l| {
            l.extend([BEGIN_RENDERING, pair(extent.width, extent.height), pair(colors.len() as u32, depth.is_some() as u32)]);
            for a in colors.iter().chain(depth) {
                // SAFETY: a clear value is 16 bytes either way; reading it as four words copies
                // it bit for bit whichever member was written.
                let c = unsafe { a.clear_value.color.uint32 };
                let words: [u64; ATTACHMENT_WORDS] = [
                    h(a.image_view),
                    pair(a.image_layout.as_raw() as u32, a.resolve_image_layout.as_raw() as u32),
                    h(a.resolve_image_view),
                    a.resolve_mode.as_raw() as u64,
                    pair(a.load_op.as_raw() as u32, a.store_op.as_raw() as u32),
                    pair(c[0], c[1]),
                    pair(c[2], c[3]),
                ];
                l.extend(words);
            }
        });
    }

    /// Ends dynamic rendering.
    pub fn end_rendering(&self) {
        self.log(|l| l.push(END_RENDERING));
    }

    /// Sets the viewport and scissor.
    pub fn set_viewport(&self, viewport: vk::Viewport, scissor: vk::Rect2D) {
        let v =
            [viewport.x, viewport.y, viewport.width, viewport.height, viewport.min_depth, viewport.max_depth].map(|x| x.to_bits() as u64);
        let (o, e) = (scissor.offset, scissor.extent);
        self.log(|l| {
            l.push(VIEWPORT);
            l.extend(v);
            l.extend([pair(o.x as u32, o.y as u32), pair(e.width, e.height)]);
        });
    }

    /// Sets the cull mode.
    pub fn set_cull_mode(&self, mode: vk::CullModeFlags) {
        self.log(|l| l.extend([CULL_MODE, mode.as_raw() as u64]));
    }

    /// Draws without an index buffer.
    pub fn draw(&self, vertices: u32, instances: u32, first_vertex: u32, first_instance: u32) {
        self.log(|l| l.extend([DRAW, pair(vertices, instances), pair(first_vertex, first_instance)]));
    }

    /// `vkCmdDrawIndexedIndirectCount`.
    pub fn draw_indexed_indirect_count(&self, draws: vk::Buffer, offset: u64, count: vk::Buffer, count_offset: u64, max: u32, stride: u32) {
        self.log(|l| l.extend([DRAW_INDIRECT_COUNT, h(draws), offset, h(count), count_offset, pair(max, stride)]));
    }

    /// One non-indexed draw whose arguments (`VkDrawIndirectCommand`) are at `offset` in `args`,
    /// drawn if the word at `count_offset` in `count` is 1 (`vkCmdDrawIndirectCount` with at most
    /// one draw: lavapipe 25.0's `vkCmdDrawIndirect` draws nothing).
    pub fn draw_indirect_one(&self, args: vk::Buffer, offset: u64, count: vk::Buffer, count_offset: u64) {
        self.log(|l| l.extend([DRAW_INDIRECT_ONE, h(args), offset, h(count), count_offset]));
    }

    /// Binds `buffer` as vertex buffer 0 at `vertex_offset` and as the index buffer at
    /// `index_offset` (the mesh pool holds both).
    pub fn bind_geometry(&self, buffer: vk::Buffer, vertex_offset: u64, index_offset: u64, index_type: vk::IndexType) {
        self.log(|l| l.extend([BIND_GEOMETRY, h(buffer), vertex_offset, index_offset, flag(index_type.as_raw())]));
    }

    /// Dispatches a compute grid.
    pub fn dispatch(&self, x: u32, y: u32, z: u32) {
        self.log(|l| l.extend([DISPATCH, pair(x, y), z as u64]));
    }

    /// Fills `size` bytes of `buffer` from `offset` with the word `data`.
    pub fn fill_buffer(&self, buffer: vk::Buffer, offset: u64, size: u64, data: u32) {
        self.log(|l| l.extend([FILL, h(buffer), offset, size, data as u64]));
    }

    /// `vkCmdUpdateBuffer` (the bytes enter the log): at most 65,536 bytes, a multiple of 4,
    /// at an offset that is one too.
    pub fn update_buffer(&self, buffer: vk::Buffer, offset: u64, bytes: &[u8]) {
        debug_assert!(bytes.len() <= 65536 && bytes.len().is_multiple_of(4) && offset.is_multiple_of(4), "vkCmdUpdateBuffer's limits");
        self.log(|l| {
            l.extend([UPDATE, h(buffer), offset]);
            push_bytes(l, bytes);
        });
    }

    /// Copies `regions` from `src` to `dst`.
    pub fn copy_buffer(&self, src: vk::Buffer, dst: vk::Buffer, regions: &[vk::BufferCopy]) {
        self.log(|l| {
            l.extend([COPY, h(src), h(dst), regions.len() as u64]);
            for r in regions {
                l.extend([r.src_offset, r.dst_offset, r.size]);
            }
        });
    }

    /// Copies `regions` between images.
    pub fn copy_image(
        &self,
        src: vk::Image,
        src_layout: vk::ImageLayout,
        dst: vk::Image,
        dst_layout: vk::ImageLayout,
        regions: &[vk::ImageCopy],
    ) {
        self.log(|l| {
            l.extend([COPY_IMAGE, h(src), h(dst), pair(src_layout.as_raw() as u32, dst_layout.as_raw() as u32), regions.len() as u64]);
            for r in regions {
                subresource(l, r.src_subresource);
                l.extend(offset3(r.src_offset));
                subresource(l, r.dst_subresource);
                l.extend(offset3(r.dst_offset));
                l.extend([pair(r.extent.width, r.extent.height), r.extent.depth as u64]);
            }
        });
    }

    /// Writes a timestamp at `stage` into query `query` of `pool`.
    pub fn write_timestamp(&self, stage: vk::PipelineStageFlags2, pool: vk::QueryPool, query: u32) {
        self.log(|l| l.extend([TIMESTAMP, stage.as_raw(), h(pool), query as u64]));
    }

    /// Traces `width`×`height` rays through a bound ray-tracing pipeline's shader binding table.
    pub fn trace_rays(
        &self,
        raygen: &vk::StridedDeviceAddressRegionKHR,
        miss: &vk::StridedDeviceAddressRegionKHR,
        hit: &vk::StridedDeviceAddressRegionKHR,
        callable: &vk::StridedDeviceAddressRegionKHR,
        width: u32,
        height: u32,
    ) {
        self.log(|l| {
            l.push(TRACE);
            for r in [raygen, miss, hit, callable] {
                region(l, r);
            }
            l.push(pair(width, height));
        });
    }
}

impl Recorder<'_> {
    /// `vkCmdBuildAccelerationStructuresKHR` with device addresses, geometries given through
    /// `p_geometries` (not `pp_geometries`) and no `p_next` chains: what
    /// [`crate::gpu::accel::build_info`] makes. `ranges[i]` holds one range per geometry of
    /// `infos[i]`. The addresses enter the log: a refit of the same structures from the same
    /// buffers every frame (a skinned mesh, moving instances) repeats its commands.
    pub fn build_acceleration_structures(
        &self,
        infos: &[vk::AccelerationStructureBuildGeometryInfoKHR],
        ranges: &[&[vk::AccelerationStructureBuildRangeInfoKHR]],
    ) {
        assert_eq!(infos.len(), ranges.len(), "a range list per build");
        self.log(|l| {
            l.extend([BUILD_ACCEL, infos.len() as u64]);
            for (info, ranges) in infos.iter().zip(ranges) {
                assert!(info.pp_geometries.is_null() && info.p_next.is_null(), "geometries through p_geometries, no p_next");
                assert_eq!(ranges.len(), info.geometry_count as usize, "a range per geometry");
                // SAFETY: the builds run on the device, so the scratch is a device address.
                let scratch = unsafe { info.scratch_data.device_address };
                l.extend([
                    pair(info.ty.as_raw() as u32, info.flags.as_raw()),
                    info.mode.as_raw() as u32 as u64,
                    h(info.src_acceleration_structure),
                    h(info.dst_acceleration_structure),
                    info.geometry_count as u64,
                    scratch,
                ]);
                let geometries: &[vk::AccelerationStructureGeometryKHR] = if info.geometry_count == 0 {
                    &[]
                } else {
                    // SAFETY: the caller's info points at `geometry_count` live geometries.
                    unsafe { std::slice::from_raw_parts(info.p_geometries, info.geometry_count as usize) }
                };
                for (g, r) in geometries.iter().zip(ranges.iter()) {
                    assert!(g.p_next.is_null(), "no p_next");
                    l.extend([pair(g.geometry_type.as_raw() as u32, g.flags.as_raw())]);
                    // SAFETY: the union member read is the one `geometry_type` names, with device
                    // addresses (the builds run on the device).
                    unsafe {
                        match g.geometry_type {
                            vk::GeometryTypeKHR::TRIANGLES => {
                                let t = g.geometry.triangles;
                                assert!(t.p_next.is_null(), "no p_next");
                                l.extend([
                                    pair(t.vertex_format.as_raw() as u32, t.index_type.as_raw() as u32),
                                    t.vertex_data.device_address,
                                    t.vertex_stride,
                                    t.max_vertex as u64,
                                    t.index_data.device_address,
                                    t.transform_data.device_address,
                                ]);
                            }
                            vk::GeometryTypeKHR::AABBS => {
                                let a = g.geometry.aabbs;
                                assert!(a.p_next.is_null(), "no p_next");
                                l.extend([a.data.device_address, a.stride]);
                            }
                            vk::GeometryTypeKHR::INSTANCES => {
                                let i = g.geometry.instances;
                                assert!(i.p_next.is_null(), "no p_next");
                                l.extend([i.array_of_pointers as u64, i.data.device_address]);
                            }
                            other => panic!("geometry type {other:?} is not logged"),
                        }
                    }
                    l.extend([pair(r.primitive_count, r.primitive_offset), pair(r.first_vertex, r.transform_offset)]);
                }
            }
        });
    }
}

/// The cache's vectors a replayed build is decoded into (reused: a replay allocates nothing
/// once they have grown).
struct Builds<'a> {
    geometries: &'a mut Vec<vk::AccelerationStructureGeometryKHR<'static>>,
    builds: &'a mut Vec<vk::AccelerationStructureBuildGeometryInfoKHR<'static>>,
    ranges: &'a mut Vec<vk::AccelerationStructureBuildRangeInfoKHR>,
}

/// Decodes a logged `BUILD_ACCEL` (`w` follows the opcode) into the cache's `geometries`,
/// `builds` and `ranges` and records it; returns the words it took.
///
/// # Safety
///
/// `cmd` is recording outside a rendering scope on a device with acceleration structures, and
/// `w` was written by [`Recorder::build_acceleration_structures`] from builds valid to record.
unsafe fn replay_builds(ctx: &GpuContext, cmd: vk::CommandBuffer, c: Builds, w: &[u64]) -> usize {
    let count = w[0] as usize;
    c.geometries.clear();
    c.builds.clear();
    c.ranges.clear();
    let mut at = 1;
    for _ in 0..count {
        let b = &w[at..at + 6];
        at += 6;
        let (ty, flags) = split(b[0]);
        let mut info = vk::AccelerationStructureBuildGeometryInfoKHR::default()
            .ty(vk::AccelerationStructureTypeKHR::from_raw(ty as i32))
            .flags(vk::BuildAccelerationStructureFlagsKHR::from_raw(flags))
            .mode(vk::BuildAccelerationStructureModeKHR::from_raw(b[1] as u32 as i32))
            .src_acceleration_structure(vk::AccelerationStructureKHR::from_raw(b[2]))
            .dst_acceleration_structure(vk::AccelerationStructureKHR::from_raw(b[3]))
            .scratch_data(vk::DeviceOrHostAddressKHR { device_address: b[5] });
        // Where its geometries start in `c.geometries` (pointed at once all are decoded: the
        // vector may move while it grows).
        info.p_geometries = c.geometries.len() as *const _;
        info.geometry_count = b[4] as u32;
        for _ in 0..b[4] {
            let (ty, flags) = split(w[at]);
            let ty = vk::GeometryTypeKHR::from_raw(ty as i32);
            at += 1;
            let geometry = match ty {
                vk::GeometryTypeKHR::TRIANGLES => {
                    let t = &w[at..at + 6];
                    at += 6;
                    let (vertex_format, index_type) = split(t[0]);
                    vk::AccelerationStructureGeometryDataKHR {
                        triangles: vk::AccelerationStructureGeometryTrianglesDataKHR::default()
                            .vertex_format(vk::Format::from_raw(vertex_format as i32))
                            .vertex_data(vk::DeviceOrHostAddressConstKHR { device_address: t[1] })
                            .vertex_stride(t[2])
                            .max_vertex(t[3] as u32)
                            .index_type(vk::IndexType::from_raw(index_type as i32))
                            .index_data(vk::DeviceOrHostAddressConstKHR { device_address: t[4] })
                            .transform_data(vk::DeviceOrHostAddressConstKHR { device_address: t[5] }),
                    }
                }
                vk::GeometryTypeKHR::AABBS => {
                    at += 2;
                    vk::AccelerationStructureGeometryDataKHR {
                        aabbs: vk::AccelerationStructureGeometryAabbsDataKHR::default()
                            .data(vk::DeviceOrHostAddressConstKHR { device_address: w[at - 2] })
                            .stride(w[at - 1]),
                    }
                }
                _ => {
                    at += 2;
                    vk::AccelerationStructureGeometryDataKHR {
                        instances: vk::AccelerationStructureGeometryInstancesDataKHR::default()
                            .array_of_pointers(w[at - 2] != 0)
                            .data(vk::DeviceOrHostAddressConstKHR { device_address: w[at - 1] }),
                    }
                }
            };
            c.geometries.push(
                vk::AccelerationStructureGeometryKHR::default()
                    .geometry_type(ty)
                    .geometry(geometry)
                    .flags(vk::GeometryFlagsKHR::from_raw(flags)),
            );
            let ((primitive_count, primitive_offset), (first_vertex, transform_offset)) = (split(w[at]), split(w[at + 1]));
            at += 2;
            c.ranges.push(vk::AccelerationStructureBuildRangeInfoKHR { primitive_count, primitive_offset, first_vertex, transform_offset });
        }
        c.builds.push(info);
    }
    let base = c.geometries.as_ptr();
    for info in c.builds.iter_mut() {
        // SAFETY: the offset was a count of decoded geometries, inside `c.geometries`.
        info.p_geometries = unsafe { base.add(info.p_geometries as usize) };
    }
    let asx = &ctx.ray_tracing.as_ref().expect("builds are logged only with acceleration structures").acceleration_structure;
    let (mut build, mut range) = (0, 0);
    while build < c.builds.len() {
        let n = (c.builds.len() - build).min(BUILDS_PER_CALL);
        // Pointers to each build's ranges, in a fixed array: ash's wrapper collects them into a
        // vector, and a replay allocates nothing.
        let mut refs: [*const vk::AccelerationStructureBuildRangeInfoKHR; BUILDS_PER_CALL] = [std::ptr::null(); BUILDS_PER_CALL];
        for (i, info) in c.builds[build..build + n].iter().enumerate() {
            let len = info.geometry_count as usize;
            refs[i] = c.ranges[range..range + len].as_ptr();
            range += len;
        }
        // SAFETY: the caller's contract; the infos point into `c.geometries` and each range
        // pointer into `c.ranges` (geometry_count ranges each), unchanged until the next replay.
        unsafe { (asx.fp().cmd_build_acceleration_structures_khr)(cmd, n as u32, c.builds[build..].as_ptr(), refs.as_ptr()) };
        build += n;
    }
    at
}

/// Resets the pool and begins its buffer (reusable: no `ONE_TIME_SUBMIT`).
fn begin(ctx: &GpuContext, cache: &mut CommandCache) -> Result<(), vk::Result> {
    // Whatever the buffer held is gone once the pool is reset.
    cache.current.recorded_at = None;
    // SAFETY: the slot's previous submissions have completed (the renderer waits for the last
    // before starting a frame, and every buffer of the slot was submitted in its frames), so
    // the pool may be reset and its buffer begun.
    unsafe {
        ctx.device.reset_command_pool(cache.current.pool, vk::CommandPoolResetFlags::empty())?;
        ctx.device.begin_command_buffer(cache.current.cmd, &vk::CommandBufferBeginInfo::default())
    }
}

/// Records the log from `replayed` to its end into the command buffer.
fn replay(ctx: &GpuContext, s: &mut State) {
    let d = &ctx.device;
    let c = &mut s.cache;
    let (log, cmd) = (&c.log, c.current.cmd);
    let mut i = s.replayed;
    // SAFETY: (the whole replay) `cmd` is recording (begun by `begin`). Every command was
    // logged by a `Recorder` method from a pass that names live objects of this device and
    // records in order (inside a rendering scope or outside one, as each command needs): the
    // contract each pass documented when it called the driver itself. The words are exactly
    // those arguments, so replaying them records what the pass asked for, in order.
    unsafe {
        while i < log.len() {
            let w = &log[i + 1..];
            i += 1 + match log[i] {
                BIND_PIPELINE => {
                    let point = vk::PipelineBindPoint::from_raw(w[0] as i32);
                    d.cmd_bind_pipeline(cmd, point, vk::Pipeline::from_raw(w[1]));
                    2
                }
                BIND_SET => {
                    let point = vk::PipelineBindPoint::from_raw(w[0] as i32);
                    d.cmd_bind_descriptor_sets(
                        cmd,
                        point,
                        vk::PipelineLayout::from_raw(w[1]),
                        0,
                        &[vk::DescriptorSet::from_raw(w[2])],
                        &[],
                    );
                    3
                }
                PUSH => {
                    let (stages, offset) = split(w[1]);
                    let (bytes, words) = read_bytes(&w[2..]);
                    let layout = vk::PipelineLayout::from_raw(w[0]);
                    d.cmd_push_constants(cmd, layout, vk::ShaderStageFlags::from_raw(stages), offset, bytes);
                    3 + words
                }
                BARRIER => {
                    let (memory, images) = split(w[0]);
                    let mut at = 1;
                    let mut mem = [vk::MemoryBarrier2::default()];
                    if memory == 1 {
                        mem[0] = vk::MemoryBarrier2::default()
                            .src_stage_mask(vk::PipelineStageFlags2::from_raw(w[1]))
                            .src_access_mask(vk::AccessFlags2::from_raw(w[2]))
                            .dst_stage_mask(vk::PipelineStageFlags2::from_raw(w[3]))
                            .dst_access_mask(vk::AccessFlags2::from_raw(w[4]));
                        at += 4;
                    }
                    c.images.clear();
                    for _ in 0..images {
                        let b = &w[at..at + 10];
                        let (old, new) = split(b[4]);
                        let (src_family, dst_family) = split(b[9]);
                        let ((aspect, mip), (levels, layer)) = (split(b[6]), split(b[7]));
                        c.images.push(
                            vk::ImageMemoryBarrier2::default()
                                .src_stage_mask(vk::PipelineStageFlags2::from_raw(b[0]))
                                .src_access_mask(vk::AccessFlags2::from_raw(b[1]))
                                .dst_stage_mask(vk::PipelineStageFlags2::from_raw(b[2]))
                                .dst_access_mask(vk::AccessFlags2::from_raw(b[3]))
                                .old_layout(vk::ImageLayout::from_raw(old as i32))
                                .new_layout(vk::ImageLayout::from_raw(new as i32))
                                .image(vk::Image::from_raw(b[5]))
                                .subresource_range(vk::ImageSubresourceRange {
                                    aspect_mask: vk::ImageAspectFlags::from_raw(aspect),
                                    base_mip_level: mip,
                                    level_count: levels,
                                    base_array_layer: layer,
                                    layer_count: b[8] as u32,
                                })
                                .src_queue_family_index(src_family)
                                .dst_queue_family_index(dst_family),
                        );
                        at += 10;
                    }
                    let info = vk::DependencyInfo::default().memory_barriers(&mem[..memory as usize]).image_memory_barriers(&c.images);
                    d.cmd_pipeline_barrier2(cmd, &info);
                    at
                }
                BEGIN_RENDERING => {
                    let (width, height) = split(w[0]);
                    let (colors, depth) = split(w[1]);
                    c.attachments.clear();
                    let mut at = 2;
                    for _ in 0..colors + depth {
                        let a = &w[at..at + ATTACHMENT_WORDS];
                        let (layout, resolve_layout) = split(a[1]);
                        let mode = a[3] as u32;
                        let (load, store) = split(a[4]);
                        let (c0, c1) = split(a[5]);
                        let (c2, c3) = split(a[6]);
                        c.attachments.push(
                            vk::RenderingAttachmentInfo::default()
                                .image_view(vk::ImageView::from_raw(a[0]))
                                .image_layout(vk::ImageLayout::from_raw(layout as i32))
                                .resolve_image_view(vk::ImageView::from_raw(a[2]))
                                .resolve_image_layout(vk::ImageLayout::from_raw(resolve_layout as i32))
                                .resolve_mode(vk::ResolveModeFlags::from_raw(mode))
                                .load_op(vk::AttachmentLoadOp::from_raw(load as i32))
                                .store_op(vk::AttachmentStoreOp::from_raw(store as i32))
                                .clear_value(vk::ClearValue { color: vk::ClearColorValue { uint32: [c0, c1, c2, c3] } }),
                        );
                        at += ATTACHMENT_WORDS;
                    }
                    let extent = vk::Extent2D { width, height };
                    let mut info = vk::RenderingInfo::default()
                        .render_area(vk::Rect2D { offset: vk::Offset2D::default(), extent })
                        .layer_count(1)
                        .color_attachments(&c.attachments[..colors as usize]);
                    if depth == 1 {
                        info = info.depth_attachment(&c.attachments[colors as usize]);
                    }
                    d.cmd_begin_rendering(cmd, &info);
                    at
                }
                END_RENDERING => {
                    d.cmd_end_rendering(cmd);
                    0
                }
                VIEWPORT => {
                    let f = |x: u64| f32::from_bits(x as u32);
                    let viewport =
                        vk::Viewport { x: f(w[0]), y: f(w[1]), width: f(w[2]), height: f(w[3]), min_depth: f(w[4]), max_depth: f(w[5]) };
                    let (sx, sy) = split(w[6]);
                    let (sw, sh) = split(w[7]);
                    let scissor =
                        vk::Rect2D { offset: vk::Offset2D { x: sx as i32, y: sy as i32 }, extent: vk::Extent2D { width: sw, height: sh } };
                    d.cmd_set_viewport(cmd, 0, &[viewport]);
                    d.cmd_set_scissor(cmd, 0, &[scissor]);
                    8
                }
                CULL_MODE => {
                    d.cmd_set_cull_mode(cmd, vk::CullModeFlags::from_raw(w[0] as u32));
                    1
                }
                DRAW => {
                    let ((vertices, instances), (first_vertex, first_instance)) = (split(w[0]), split(w[1]));
                    d.cmd_draw(cmd, vertices, instances, first_vertex, first_instance);
                    2
                }
                DRAW_INDIRECT_COUNT => {
                    let (max, stride) = split(w[4]);
                    let (draws, count) = (vk::Buffer::from_raw(w[0]), vk::Buffer::from_raw(w[2]));
                    d.cmd_draw_indexed_indirect_count(cmd, draws, w[1], count, w[3], max, stride);
                    5
                }
                DRAW_INDIRECT_ONE => {
                    let (args, count) = (vk::Buffer::from_raw(w[0]), vk::Buffer::from_raw(w[2]));
                    d.cmd_draw_indirect_count(cmd, args, w[1], count, w[3], 1, 16);
                    4
                }
                BIND_GEOMETRY => {
                    let buffer = vk::Buffer::from_raw(w[0]);
                    d.cmd_bind_vertex_buffers(cmd, 0, &[buffer], &[w[1]]);
                    d.cmd_bind_index_buffer(cmd, buffer, w[2], vk::IndexType::from_raw(w[3] as i32));
                    4
                }
                DISPATCH => {
                    let (x, y) = split(w[0]);
                    d.cmd_dispatch(cmd, x, y, w[1] as u32);
                    2
                }
                FILL => {
                    let (data, _) = split(w[3]);
                    d.cmd_fill_buffer(cmd, vk::Buffer::from_raw(w[0]), w[1], w[2], data);
                    4
                }
                UPDATE => {
                    let (bytes, words) = read_bytes(&w[2..]);
                    d.cmd_update_buffer(cmd, vk::Buffer::from_raw(w[0]), w[1], bytes);
                    3 + words
                }
                COPY => {
                    let n = w[2] as usize;
                    c.regions.clear();
                    c.regions.extend(w[3..3 + 3 * n].chunks(3).map(|r| vk::BufferCopy { src_offset: r[0], dst_offset: r[1], size: r[2] }));
                    d.cmd_copy_buffer(cmd, vk::Buffer::from_raw(w[0]), vk::Buffer::from_raw(w[1]), &c.regions);
                    3 + 3 * n
                }
                COPY_IMAGE => {
                    let (src_layout, dst_layout) = split(w[2]);
                    let n = w[3] as usize;
                    c.image_copies.clear();
                    c.image_copies.extend(w[4..4 + 10 * n].chunks(10).map(|r| vk::ImageCopy {
                        src_subresource: read_subresource(&r[0..2]),
                        src_offset: read_offset3(&r[2..4]),
                        dst_subresource: read_subresource(&r[4..6]),
                        dst_offset: read_offset3(&r[6..8]),
                        extent: {
                            let (width, height) = split(r[8]);
                            vk::Extent3D { width, height, depth: r[9] as u32 }
                        },
                    }));
                    d.cmd_copy_image(
                        cmd,
                        vk::Image::from_raw(w[0]),
                        vk::ImageLayout::from_raw(src_layout as i32),
                        vk::Image::from_raw(w[1]),
                        vk::ImageLayout::from_raw(dst_layout as i32),
                        &c.image_copies,
                    );
                    4 + 10 * n
                }
                TIMESTAMP => {
                    d.cmd_write_timestamp2(cmd, vk::PipelineStageFlags2::from_raw(w[0]), vk::QueryPool::from_raw(w[1]), w[2] as u32);
                    3
                }
                TRACE => {
                    let rt = ctx.ray_tracing.as_ref().and_then(|rt| rt.ray_tracing_pipeline.as_ref());
                    let rt = rt.expect("traces are logged only with ray-tracing pipelines");
                    let (width, height) = split(w[12]);
                    rt.cmd_trace_rays(
                        cmd,
                        &read_region(&w[0..3]),
                        &read_region(&w[3..6]),
                        &read_region(&w[6..9]),
                        &read_region(&w[9..12]),
                        width,
                        height,
                        1,
                    );
                    13
                }
                BUILD_ACCEL => {
                    let vectors = Builds { geometries: &mut c.geometries, builds: &mut c.builds, ranges: &mut c.ranges };
                    replay_builds(ctx, cmd, vectors, w)
                }
                op => unreachable!("unknown command word {op}"),
            };
        }
    }
    s.replayed = i;
}
