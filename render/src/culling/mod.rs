//! GPU-driven drawing: every mesh pass draws through compacted indirect commands that compute
//! passes write from culling records, so the CPU records a handful of
//! `vkCmdDrawIndexedIndirectCount` calls a frame however many instances exist. The design
//! follows Haar and Aaltonen's "GPU-Driven Rendering Pipelines" (SIGGRAPH 2015: culling on the
//! GPU, one draw per batch from a shared mesh buffer) and the two-phase occlusion culling of
//! Bevy 0.16 and of Kubisch's and Kapoulkine's renderers; the seeds' own renderers draw every
//! instance (`../shared/seeds/001`, §4.1 has no culling at all).
//!
//! - **Culling records, kept by change detection**: per instance slot its world bounds, mesh
//!   and batch flags (`GpuCullRecord`, [`crate::scene::SceneMirror::culls`]), written only when
//!   the transform, mesh or draw changed, uploaded with the other tables. A frame where nothing
//!   changed uploads nothing.
//! - **One mesh pool** ([`crate::scene::pool`]): every command names its mesh by `firstIndex`
//!   and `vertexOffset` in the one bound buffer, and its instance by `firstInstance` (shaders
//!   read their record at `gl_InstanceIndex`, as before).
//! - **Batches**: the opaque passes draw four lists, opaque or alpha-tested × back-face culled or
//!   double-sided (pipeline and cull mode are the only state that changes between them). Each
//!   list has room for the live instances of its batch, which the mirror counts as draws change,
//!   so no CPU work visits the instances.
//! - **Two-phase occlusion** ([`CullingMode::Occlusion`]): the first phase draws what was
//!   visible last frame (one bit per slot) inside the frustum; a depth pyramid is built from
//!   that depth (`shaders/hiz.comp`, reverse Z: each texel the farthest below it); the second
//!   phase tests every instance in the frustum against the pyramid, updates its bit, and draws
//!   the newly visible ones into the same depth, in the same frame, so nothing pops in a frame
//!   late. Every later pass of the frame draws both lists.
//! - **Glass keeps its order**: the blended instances are culled (frustum only) into one command
//!   each, in the back-to-front order the CPU sorts (per instance, visiting the glass only),
//!   with an instance count of 0 when culled, and drawn in that order, one draw per run of
//!   equal cull mode.
//! - **Shadow maps** get a list per view, every live instance against that view's frustum.
//! - **Levels of detail** ([`crate::lod`]): the first phase picks each instance's level in
//!   the frustum (by its error projected at the nearest point of its bounds, with a hysteresis
//!   band kept in a word per slot), the second phase and the glass draw at the level picked,
//!   shadow views pick by their own projection; the command's `firstIndex` and index count are
//!   the level's and its `firstInstance` carries the level above the slot.
//! - **Ray tracing keeps everything**: the scene TLAS is built from the instance table, so
//!   instances off screen still cast shadows.
//!
//! Memory: 32 bytes of culling record and 40 bytes of commands (two lists of 20) per instance,
//! one visibility bit, a word for its level of detail, 20 bytes per instance per shadow-map view, and a depth pyramid of about a
//! third of the depth target's pixels (4 bytes each).
//!
//! Statistics ([`CullingStats`]) are read back without waiting, like the light tiles'.

use std::sync::atomic::{AtomicU64, Ordering};

use ash::vk;
use glam::Mat4;
use gpu_allocator::MemoryLocation;

use crate::RenderError;
use crate::gpu::FRAMES_IN_FLIGHT;
use crate::gpu::device::GpuContext;
use crate::gpu::memory::{Buffer, Retired};
use crate::gpu::pipeline::create_compute;
use crate::gpu::shaders;
use crate::gpu::upload::Shrink;
use crate::graph::pass::PassContext;
use crate::graph::pyramid::{dispatch_pyramid, hiz_levels, hiz_words};
use crate::graph::readback::StatsReadback;
use crate::graph::targets::DEPTH;
use crate::graph::{BufferUse, Frame, FrameGraph, Load, PassKind, ResourceId};
use crate::layout::{
    CULL_BATCHES, CULL_HEADER, CULL_MODE_FRUSTUM, CULL_MODE_OCCLUSION, CULL_MODE_OFF, CULL_ORDERED, CULL_PASS_FIRST, CULL_PASS_ORDERED,
    CULL_PASS_SECOND, CULL_PASS_SHADOW_VIEWS, CULL_STAT_DROPPED, CULL_STAT_FRUSTUM, CULL_STAT_LOD, CULL_STAT_TESTED, CULL_STAT_TRIANGLES,
    CULL_STAT_VISIBLE, GpuCullParams, GpuCullPush, GpuDrawCommand,
};
use crate::scene::SceneMirror;
use crate::scene::gpu::GpuScene;
use crate::settings::{CullingMode, FrameSettings};

const BATCHES: usize = CULL_BATCHES as usize;
const COMMAND_BYTES: u64 = std::mem::size_of::<GpuDrawCommand>() as u64;
/// The smallest draw buffer, in bytes.
const DRAWS_FLOOR: u64 = 16 * 1024;

pub use crate::stats::CullingStats;

/// The instance slots culling put in a frame's lists ([`Culling::read_back`], for tests and
/// tools).
#[derive(Clone, Debug, Default, PartialEq, Eq)]
pub struct CulledLists {
    /// The first phase's list (every batch), the only one without occlusion culling.
    pub first: Vec<u32>,
    /// The second phase's list: instances found visible against this frame's depth pyramid that
    /// the first phase had not drawn.
    pub second: Vec<u32>,
    /// The blended instances in back-to-front order, and whether each is drawn.
    pub glass: Vec<(u32, bool)>,
    /// Each shadow-map view's list.
    pub shadow_views: Vec<Vec<u32>>,
}

/// Which of the two phases' lists a pass draws.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
enum Lists {
    First,
    Second,
    Both,
}

/// Where a depth-writing pass stands in the frame's culling phases.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Phase {
    /// The pass clears its targets (the first or only time it runs this frame).
    pub clears: bool,
    /// The pass is the last of the frame's depth passes (draws what comes after the opaque
    /// instances: the glass in the G-buffer).
    pub last: bool,
}

impl Phase {
    /// The pass runs once.
    pub const WHOLE: Phase = Phase { clears: true, last: true };

    /// How the pass loads its depth.
    pub fn depth_load(self) -> Load {
        if self.clears { Load::ClearDepth(0.0) } else { Load::Keep }
    }

    /// How the pass loads a colour target it clears to `clear`.
    pub fn color_load(self, clear: [f32; 4]) -> Load {
        if self.clears { Load::Clear(clear) } else { Load::Keep }
    }
}

/// A run of blended instances with the same cull mode, in their order.
#[derive(Clone, Copy, Debug)]
struct GlassRun {
    first: u32,
    count: u32,
    double_sided: bool,
}

/// This frame's lists: where each batch's commands and counts are.
#[derive(Clone, Copy, Debug, Default)]
struct CullFrame {
    draws: vk::Buffer,
    pool: Option<vk::Buffer>,
    /// Byte offset of the commands.
    commands: u64,
    list_stride: u32,
    batch_start: [u32; BATCHES],
    batch_capacity: [u32; BATCHES],
    ordered_first: u32,
    shadow_first: u32,
    shadow_stride: u32,
    shadow_count: u32,
    slots: u32,
    glass: u32,
    header_words: u32,
    two_phase: bool,
    reads_visibility: bool,
    fresh_visibility: bool,
    /// Levels of detail are chosen (their buffer exists).
    lods: bool,
    fresh_lods: bool,
    hiz_levels: u32,
    extent: vk::Extent2D,
}

/// The graph resources of culling.
#[derive(Clone, Copy, Debug)]
struct CullResources {
    params: ResourceId,
    draws: ResourceId,
    visibility: ResourceId,
    lods: ResourceId,
    hiz: ResourceId,
}

/// The culling passes, their buffers and statistics.
pub struct Culling {
    layout: vk::PipelineLayout,
    cull: vk::Pipeline,
    hiz: vk::Pipeline,
    draws: Option<Buffer>,
    draws_shrink: Shrink,
    visibility: Option<Buffer>,
    visibility_shrink: Shrink,
    lods: Option<Buffer>,
    lods_shrink: Shrink,
    pyramid: Option<(Buffer, vk::Extent2D)>,
    readback: StatsReadback,
    latest: CullingStats,
    frozen: Option<Mat4>,
    frame: CullFrame,
    /// This frame's parameters (addresses filled in by [`Culling::cull`]), and per frame slot
    /// the host-visible buffer the passes read them from with what it holds, rewritten only
    /// when they change. Written by the CPU, not copied by a command: the view changes them
    /// every frame the camera moves, and the frame's commands stay the same
    /// (`crate::gpu::commands`).
    params: GpuCullParams,
    params_buffers: Vec<(Buffer, Option<GpuCullParams>)>,
    /// The previous frame's parameters: a change is counted once, in the frame it happens (the
    /// other slots' copies catch up with data already counted).
    params_last: Option<GpuCullParams>,
    glass_runs: Vec<GlassRun>,
    /// Draw calls recorded this frame (an atomic only so the renderer stays `Sync`; one thread
    /// records).
    draw_calls: AtomicU64,
    res: CullResources,
}

impl Culling {
    /// Creates the passes (with a pipeline layout of their own: the bindless set and
    /// [`GpuCullPush`]); the buffers wait for the first frame.
    pub fn new(ctx: &GpuContext, graph: &mut FrameGraph, bindless: vk::DescriptorSetLayout) -> Result<Self, RenderError> {
        let ranges = [vk::PushConstantRange {
            stage_flags: vk::ShaderStageFlags::COMPUTE,
            offset: 0,
            size: std::mem::size_of::<GpuCullPush>() as u32,
        }];
        let sets = [bindless];
        // SAFETY: valid create info pointing at locals; destroyed in `destroy`.
        let layout = unsafe {
            ctx.device
                .create_pipeline_layout(&vk::PipelineLayoutCreateInfo::default().set_layouts(&sets).push_constant_ranges(&ranges), None)
        }?;
        let pipelines = create_compute(ctx, layout, "culling", shaders::CULL_COMP).and_then(|cull| {
            match create_compute(ctx, layout, "depth pyramid", shaders::HIZ_COMP) {
                Ok(hiz) => Ok((cull, hiz)),
                Err(e) => {
                    // SAFETY: never used.
                    unsafe { ctx.destroying().destroy_pipeline(cull, None) };
                    Err(e)
                }
            }
        });
        let (cull, hiz) = match pipelines {
            Ok(p) => p,
            Err(e) => {
                // SAFETY: never used.
                unsafe { ctx.destroying().destroy_pipeline_layout(layout, None) };
                return Err(e);
            }
        };
        let readback = StatsReadback::new(ctx, graph, "culling statistics", CULL_HEADER as u64 * 4)?;
        let mut params_buffers = Vec::with_capacity(FRAMES_IN_FLIGHT);
        for _ in 0..FRAMES_IN_FLIGHT {
            let usage = vk::BufferUsageFlags::STORAGE_BUFFER | vk::BufferUsageFlags::SHADER_DEVICE_ADDRESS;
            let size = std::mem::size_of::<GpuCullParams>() as u64;
            params_buffers.push((Buffer::new(ctx, "culling parameters", size, usage, MemoryLocation::CpuToGpu)?, None));
        }
        let res = CullResources {
            // Written by the host before the frame's submission (visible to all of it without a
            // barrier); declared by the passes that read it, to say what they read.
            params: graph.resource("culling parameters"),
            draws: graph.resource("draw commands"),
            visibility: graph.resource("culling visibility"),
            lods: graph.resource("levels of detail"),
            hiz: graph.resource("depth pyramid"),
        };
        Ok(Self {
            layout,
            cull,
            hiz,
            draws: None,
            draws_shrink: ctx.shrink_rule(),
            visibility: None,
            visibility_shrink: ctx.shrink_rule(),
            lods: None,
            lods_shrink: ctx.shrink_rule(),
            pyramid: None,
            readback,
            latest: CullingStats { measured_frame: u64::MAX, ..Default::default() },
            frozen: None,
            frame: CullFrame::default(),
            params: GpuCullParams::default(),
            params_buffers,
            params_last: None,
            glass_runs: Vec::new(),
            draw_calls: AtomicU64::new(0),
            res,
        })
    }

    /// Reads back the statistics of the frame that last used this frame's slot, lays out this
    /// frame's lists from the mirror's batch counts (no instance is visited), sizes the buffers,
    /// and hands the scene this frame's culling parameters and the blended order (uploaded with
    /// its next sync, only when they changed). Call before the scene's upload, after the
    /// shadow-map views are planned (`shadow_views` of them).
    pub fn prepare(
        &mut self,
        f: &mut Frame,
        scene: &mut GpuScene,
        mirror: &SceneMirror,
        s: &FrameSettings,
        shadow_views: u32,
    ) -> Result<CullingStats, RenderError> {
        if let Some((frame, words)) = self.readback.take(f) {
            self.latest = CullingStats {
                measured_frame: frame,
                instances: words[CULL_STAT_TESTED as usize] as u64,
                after_frustum: words[CULL_STAT_FRUSTUM as usize] as u64,
                after_occlusion: words[CULL_STAT_VISIBLE as usize] as u64,
                dropped: words[CULL_STAT_DROPPED as usize] as u64,
                lod_instances: std::array::from_fn(|level| words[CULL_STAT_LOD as usize + level] as u64),
                triangles: words[CULL_STAT_TRIANGLES as usize] as u64,
                ..self.latest
            };
        }
        self.draw_calls.store(0, Ordering::Relaxed);
        let ctx = f.ctx;
        let frame_value = f.upload.frame_value;
        let extent = f.graph.extent();
        let camera = mirror.camera().view_proj;
        let view_proj = if s.freeze_culling { *self.frozen.get_or_insert(camera) } else { camera };
        if !s.freeze_culling {
            self.frozen = None;
        }

        // The lists' layout: per batch room for its live instances; the blended order; a list
        // per shadow view with room for every live instance.
        let counts = mirror.batch_counts;
        let mut batch_start = [0u32; BATCHES];
        let mut list_stride = 0u32;
        for (start, &count) in batch_start.iter_mut().zip(&counts) {
            *start = list_stride;
            list_stride += count;
        }
        let order = mirror.transparent_order();
        let glass = order.len() as u32;
        let ordered_first = 2 * list_stride;
        let shadow_first = ordered_first + glass;
        let shadow_stride = mirror.instances.len() as u32;
        let header_words = (CULL_HEADER + shadow_views).next_multiple_of(4);
        let commands = shadow_first as u64 + shadow_views as u64 * shadow_stride as u64;
        let bytes = header_words as u64 * 4 + commands * COMMAND_BYTES;

        let usage = vk::BufferUsageFlags::STORAGE_BUFFER
            | vk::BufferUsageFlags::INDIRECT_BUFFER
            | vk::BufferUsageFlags::TRANSFER_DST
            | vk::BufferUsageFlags::TRANSFER_SRC
            | vk::BufferUsageFlags::SHADER_DEVICE_ADDRESS;
        let capacity = self.draws.as_ref().map_or(0, |b| b.size);
        let smaller = self.draws_shrink.check(capacity, bytes, DRAWS_FLOOR);
        let size = if bytes > capacity { bytes.next_power_of_two().max(DRAWS_FLOOR) } else { smaller.unwrap_or(capacity) };
        if size != capacity {
            let buffer = Buffer::new(ctx, "draw commands", size, usage, MemoryLocation::GpuOnly)?;
            if let Some(old) = self.draws.replace(buffer) {
                if size < capacity {
                    f.upload.bury_shrunk(old, size);
                } else {
                    f.upload.graveyard.bury(frame_value, Retired::Buffer(old));
                }
            }
            self.draws_shrink.reset();
        }

        // A visibility bit per slot; a new buffer starts cleared (nothing was visible: the second
        // phase finds everything that is).
        let occlusion = s.culling == CullingMode::Occlusion;
        let slots = mirror.instances.slot_count() as u64;
        let bits = slots.div_ceil(32).max(1) * 4;
        let fresh_visibility =
            per_slot_buffer(f, &mut self.visibility, &mut self.visibility_shrink, "culling visibility", occlusion, bits)?;
        // The level of detail each slot drew last (for the hysteresis); a new buffer starts
        // cleared (level 0).
        let lod = s.lod_pixels > 0.0 && s.lod_pixels.is_finite();
        let fresh_lods = per_slot_buffer(f, &mut self.lods, &mut self.lods_shrink, "levels of detail", lod, slots.max(1) * 4)?;

        // The depth pyramid, for the viewport.
        let two_phase = occlusion && !s.freeze_culling;
        let levels = hiz_levels(extent);
        if two_phase {
            if self.pyramid.as_ref().is_none_or(|(_, e)| *e != extent) {
                let bytes = hiz_words(extent, levels) * 4;
                // TRANSFER_SRC: `read_pyramid` copies it out.
                let usage =
                    vk::BufferUsageFlags::STORAGE_BUFFER | vk::BufferUsageFlags::SHADER_DEVICE_ADDRESS | vk::BufferUsageFlags::TRANSFER_SRC;
                let buffer = Buffer::new(ctx, "depth pyramid", bytes, usage, MemoryLocation::GpuOnly)?;
                if let Some((old, _)) = self.pyramid.replace((buffer, extent)) {
                    f.upload.graveyard.bury(frame_value, Retired::Buffer(old));
                }
            }
        } else if let Some((old, _)) = self.pyramid.take() {
            f.upload.bury_shrunk(old, 0);
        }

        let draws = self.draws.as_ref().expect("created above");
        // The scene's addresses are filled in after its upload (its tables may be replaced).
        self.params = GpuCullParams {
            view_proj,
            records: 0,
            meshes: 0,
            draws: draws.address,
            visibility: self.visibility.as_ref().map_or(0, |b| b.address),
            hiz: self.pyramid.as_ref().map_or(0, |(b, _)| b.address),
            order: 0,
            shadow_views: 0,
            count: mirror.culls.slot_count(),
            mode: match s.culling {
                CullingMode::Off => CULL_MODE_OFF,
                CullingMode::Frustum => CULL_MODE_FRUSTUM,
                CullingMode::Occlusion => CULL_MODE_OCCLUSION,
            },
            commands: header_words,
            list_stride,
            ordered_first,
            ordered_count: glass,
            shadow_first,
            shadow_stride,
            shadow_count: shadow_views,
            hiz_levels: levels,
            viewport: glam::Vec2::new(extent.width as f32, extent.height as f32),
            batch_start,
            batch_capacity: counts,
            frozen: u32::from(s.freeze_culling),
            lods: self.lods.as_ref().filter(|_| lod).map_or(0, |b| b.address),
            lod_pixels: if lod { s.lod_pixels } else { 0.0 },
            lod_coarsen_pixels: if lod { s.lod_pixels * crate::settings::LOD_HYSTERESIS } else { 0.0 },
            pad: 0,
        };
        scene.glass_order.set(order);
        // Runs of equal cull mode in the blended order (a draw each).
        self.glass_runs.clear();
        for (i, &slot) in order.iter().enumerate() {
            let double_sided = mirror.draws.get(slot as usize).copied().flatten().is_some_and(|d| d.double_sided);
            match self.glass_runs.last_mut() {
                Some(run) if run.double_sided == double_sided => run.count += 1,
                _ => self.glass_runs.push(GlassRun { first: i as u32, count: 1, double_sided }),
            }
        }
        self.frame = CullFrame {
            draws: draws.raw,
            pool: None,
            commands: header_words as u64 * 4,
            list_stride,
            batch_start,
            batch_capacity: counts,
            ordered_first,
            shadow_first,
            shadow_stride,
            shadow_count: shadow_views,
            slots: mirror.culls.slot_count(),
            glass,
            header_words,
            two_phase,
            reads_visibility: occlusion,
            fresh_visibility,
            lods: lod,
            fresh_lods,
            hiz_levels: levels,
            extent,
        };
        Ok(CullingStats { mode: s.culling, frozen: s.freeze_culling, lod_pixels: self.params.lod_pixels, ..self.latest })
    }

    fn bind(&self, p: &PassContext, pipeline: vk::Pipeline, params: vk::DeviceAddress, pass: u32, level: u32) {
        let push = GpuCullPush { params, pass, level };
        // The layout is this pipeline's, and its set 0 is the bindless set's layout.
        p.cmd.bind_pipeline(vk::PipelineBindPoint::COMPUTE, pipeline);
        p.cmd.bind_set(vk::PipelineBindPoint::COMPUTE, self.layout, p.bindless);
        p.cmd.push_constants(self.layout, vk::ShaderStageFlags::COMPUTE, 0, bytemuck::bytes_of(&push));
    }

    /// Writes the parameters into this frame slot's buffer (when they differ from what it
    /// holds), then records the first phase: the counts cleared, the main view's first list,
    /// the blended order and the shadow views' lists. Needs this frame's upload (the scene's
    /// tables and mesh pool as they are now). Returns the bytes of parameters sent: their size
    /// in a frame where they changed, 0 otherwise (a slot's copy catching up with a change
    /// already counted is not counted again).
    pub fn cull(&mut self, f: &mut Frame, scene: &GpuScene) -> Result<u64, RenderError> {
        self.frame.pool = scene.pool_buffer();
        self.params.records = scene.culls.address();
        self.params.meshes = scene.mesh_table.address();
        self.params.order = scene.glass_order.address();
        self.params.shadow_views = scene.shadow_views.address();
        // The slot's previous frame has finished: its buffer may be written.
        let (buffer, holds) = &mut self.params_buffers[f.slot()];
        if *holds != Some(self.params) {
            let bytes = bytemuck::bytes_of(&self.params);
            buffer.mapped()[..bytes.len()].copy_from_slice(bytes);
            *holds = Some(self.params);
        }
        let params = buffer.address;
        let changed = self.params_last.replace(self.params) != Some(self.params);
        let frame = self.frame;
        let res = self.res;
        let visibility = self.visibility.as_ref().map(|b| b.raw).filter(|_| frame.fresh_visibility);
        let lods = self.lods.as_ref().map(|b| b.raw).filter(|_| frame.fresh_lods);
        f.pass("cull_clear", PassKind::Transfer)
            .write(res.draws, BufferUse::Transfer)
            .when(visibility.is_some(), |p| p.write(res.visibility, BufferUse::Transfer))
            .when(lods.is_some(), |p| p.write(res.lods, BufferUse::Transfer))
            .record(|p| {
                // The ranges lie in the buffers.
                p.cmd.fill_buffer(frame.draws, 0, frame.header_words as u64 * 4, 0);
                for buffer in [visibility, lods].into_iter().flatten() {
                    p.cmd.fill_buffer(buffer, 0, vk::WHOLE_SIZE, 0);
                }
            })?;
        f.pass("cull", PassKind::Compute)
            .read(scene.res.tables, BufferUse::Storage)
            .read(res.params, BufferUse::Storage)
            .when(frame.reads_visibility, |p| p.read(res.visibility, BufferUse::Storage))
            .when(frame.lods, |p| p.write(res.lods, BufferUse::Storage))
            .write(res.draws, BufferUse::Storage)
            .record(|p| {
                let dispatch = |pass: u32, x: u32, y: u32| {
                    if x > 0 && y > 0 {
                        self.bind(p, self.cull, params, pass, 0);
                        p.cmd.dispatch(x.div_ceil(64), y, 1);
                    }
                };
                dispatch(CULL_PASS_FIRST, frame.slots, 1);
                dispatch(CULL_PASS_ORDERED, frame.glass, 1);
                dispatch(CULL_PASS_SHADOW_VIEWS, frame.slots, frame.shadow_count);
            })?;
        if !frame.two_phase {
            self.read_statistics(f)?;
        }
        Ok(if changed { std::mem::size_of::<GpuCullParams>() as u64 } else { 0 })
    }

    fn read_statistics(&mut self, f: &mut Frame) -> Result<(), RenderError> {
        let raw = self.frame.draws;
        self.readback.record(f, "culling_statistics", self.res.draws, raw)
    }

    /// Records the frame's depth-writing pass (the prepass, the G-buffer or the visibility
    /// pass) in the culling's phases: with two-phase occlusion, once over the first list, then
    /// the depth pyramid and the second phase, then again over the newly visible instances;
    /// otherwise once.
    pub fn depth_passes<T>(
        &mut self,
        f: &mut Frame,
        scene: &GpuScene,
        mut pass: impl FnMut(&mut Frame, Draws<'_>, Phase) -> Result<T, RenderError>,
    ) -> Result<T, RenderError> {
        if !self.frame.two_phase {
            return pass(f, self.draws(), Phase::WHOLE);
        }
        pass(f, self.lists(Lists::First), Phase { clears: true, last: false })?;
        self.second_phase(f, scene)?;
        pass(f, self.lists(Lists::Second), Phase { clears: false, last: true })
    }

    fn second_phase(&mut self, f: &mut Frame, scene: &GpuScene) -> Result<(), RenderError> {
        let frame = self.frame;
        let res = self.res;
        let params = self.params_buffers[f.slot()].0.address;
        f.pass("depth_pyramid", PassKind::Compute)
            .sample(&DEPTH)
            .read(res.params, BufferUse::Storage)
            .write(res.hiz, BufferUse::Storage)
            .record(|p| dispatch_pyramid(p, frame.extent, frame.hiz_levels, |p, level| self.bind(p, self.hiz, params, 0, level)))?;
        f.pass("cull_second", PassKind::Compute)
            .read(scene.res.tables, BufferUse::Storage)
            .read(res.params, BufferUse::Storage)
            .read(res.hiz, BufferUse::Storage)
            .when(frame.lods, |p| p.read(res.lods, BufferUse::Storage))
            .write(res.visibility, BufferUse::Storage)
            .write(res.draws, BufferUse::Storage)
            .record(|p| {
                if frame.slots > 0 {
                    self.bind(p, self.cull, params, CULL_PASS_SECOND, 0);
                    p.cmd.dispatch(frame.slots.div_ceil(64), 1, 1);
                }
            })?;
        self.read_statistics(f)
    }

    /// What every pass after the depth passes draws: both phases' lists.
    pub fn draws(&self) -> Draws<'_> {
        self.lists(Lists::Both)
    }

    fn lists(&self, lists: Lists) -> Draws<'_> {
        let lists = if self.frame.two_phase { lists } else { Lists::First };
        Draws { frame: &self.frame, res: self.res.draws, lists, calls: &self.draw_calls, glass: &self.glass_runs }
    }

    /// The depth pyramid the last two-phase frame built (waits for the GPU); `None` without
    /// occlusion culling.
    pub fn read_pyramid(&self, ctx: &GpuContext, graph: &mut FrameGraph) -> Result<Option<DepthPyramid>, RenderError> {
        let Some((buffer, extent)) = self.pyramid.as_ref() else { return Ok(None) };
        let bytes = graph.read_back_buffer(ctx, self.res.hiz, buffer.raw, buffer.size)?;
        let depths = bytes.chunks_exact(4).map(|b| f32::from_le_bytes([b[0], b[1], b[2], b[3]])).collect();
        Ok(Some(DepthPyramid { depths, width: extent.width, height: extent.height }))
    }

    /// The lists the last frame's culling wrote, as instance slots (waits for the GPU); `None`
    /// before any frame.
    pub fn read_back(&self, ctx: &GpuContext, graph: &mut FrameGraph) -> Result<Option<CulledLists>, RenderError> {
        let Some(buffer) = self.draws.as_ref() else { return Ok(None) };
        let f = self.frame;
        let bytes = graph.read_back_buffer(ctx, self.res.draws, buffer.raw, buffer.size)?;
        let words: &[u32] = bytemuck::cast_slice(&bytes);
        let command = |i: u32| -> &[u32] {
            let o = (f.commands / 4) as usize + i as usize * 5;
            &words[o..o + 5]
        };
        let mut lists = CulledLists::default();
        for list in 0..2u32 {
            for b in 0..BATCHES {
                let count = words[list as usize * BATCHES + b].min(f.batch_capacity[b]);
                let slots = (0..count).map(|n| command(list * f.list_stride + f.batch_start[b] + n)[4]);
                if list == 0 { lists.first.extend(slots) } else { lists.second.extend(slots) }
            }
        }
        lists.glass = (0..f.glass).map(|i| command(f.ordered_first + i)).map(|c| (c[4], c[1] == 1)).collect();
        lists.shadow_views = (0..f.shadow_count)
            .map(|v| {
                let count = words[(CULL_HEADER + v) as usize].min(f.shadow_stride);
                (0..count).map(|n| command(f.shadow_first + v * f.shadow_stride + n)[4]).collect()
            })
            .collect();
        Ok(Some(lists))
    }

    /// Indirect draw calls recorded this frame, every pass.
    pub fn draw_calls(&self) -> u64 {
        self.draw_calls.load(Ordering::Relaxed)
    }

    /// Destroys everything; the GPU must be idle.
    pub fn destroy(self, ctx: &GpuContext) {
        // SAFETY: the GPU is idle.
        unsafe {
            ctx.destroying().destroy_pipeline(self.cull, None);
            ctx.destroying().destroy_pipeline(self.hiz, None);
            ctx.destroying().destroy_pipeline_layout(self.layout, None);
        }
        for (b, _) in self.params_buffers {
            b.destroy(ctx);
        }
        for b in [self.draws, self.visibility, self.lods, self.pyramid.map(|(b, _)| b)].into_iter().flatten() {
            b.destroy(ctx);
        }
        self.readback.destroy(ctx);
    }
}

/// A depth pyramid read back ([`crate::Renderer::read_depth_pyramid`]).
#[derive(Clone, Debug, PartialEq)]
pub struct DepthPyramid {
    /// Its levels one after another, rows top to bottom (`shaders/include/depth_pyramid.glsl`).
    pub depths: Vec<f32>,
    /// Width of the depth it was built from, in pixels.
    pub width: u32,
    /// Height of the depth it was built from, in pixels.
    pub height: u32,
}

/// The lists a pass draws this frame, and the calls that draw them. Declare
/// [`Draws::reads`] on the pass.
#[derive(Clone, Copy)]
pub struct Draws<'a> {
    frame: &'a CullFrame,
    res: ResourceId,
    lists: Lists,
    calls: &'a AtomicU64,
    glass: &'a [GlassRun],
}

impl Draws<'_> {
    /// What a pass that draws these lists reads besides the scene: the commands.
    pub fn reads(&self) -> [(ResourceId, BufferUse); 1] {
        [(self.res, BufferUse::Indirect)]
    }

    fn bind_pool(&self, p: &PassContext) -> bool {
        let Some(pool) = self.frame.pool else { return false };
        p.bind_mesh_pool(pool);
        true
    }

    fn set_cull(p: &PassContext, double_sided: bool) {
        let mode = if double_sided { vk::CullModeFlags::NONE } else { vk::CullModeFlags::BACK };
        p.cmd.set_cull_mode(mode);
    }

    /// One `vkCmdDrawIndexedIndirectCount` over at most `max` commands from command
    /// `first_command`, its count in header word `count_word`.
    fn draw_count(&self, p: &PassContext, first_command: u32, count_word: u32, max: u32) {
        let f = self.frame;
        // Inside a rendering scope with a mesh pipeline and the pool bound; the commands and the
        // count lie in the draw buffer, which the culling passes wrote before this pass
        // (declared through `reads`).
        let commands = f.commands + first_command as u64 * COMMAND_BYTES;
        p.cmd.draw_indexed_indirect_count(f.draws, commands, f.draws, count_word as u64 * 4, max, COMMAND_BYTES as u32);
        self.calls.fetch_add(1, Ordering::Relaxed);
    }

    fn batches(&self, p: &PassContext, batches: std::ops::Range<usize>) {
        if !self.bind_pool(p) {
            return;
        }
        let f = self.frame;
        let lists: &[u32] = match self.lists {
            Lists::First => &[0],
            Lists::Second => &[1],
            Lists::Both => &[0, 1],
        };
        for &list in lists {
            for b in batches.clone() {
                if f.batch_capacity[b] == 0 {
                    continue;
                }
                Self::set_cull(p, b & 1 == 1);
                self.draw_count(p, list * f.list_stride + f.batch_start[b], list * CULL_BATCHES + b as u32, f.batch_capacity[b]);
            }
        }
    }

    /// Draws the opaque instances without an alpha test.
    pub fn opaque(&self, p: &PassContext) {
        self.batches(p, 0..2);
    }

    /// Draws the alpha-tested opaque instances.
    pub fn masked(&self, p: &PassContext) {
        self.batches(p, 2..4);
    }

    /// Draws every opaque instance, alpha-tested or not, with one pipeline.
    pub fn all_opaque(&self, p: &PassContext) {
        self.batches(p, 0..BATCHES);
    }

    /// Draws the blended instances back to front (those culled draw nothing): one multi-draw
    /// per run of equal cull mode, in order. It is a count-draw too, whose count (the order's
    /// length, which the ordered culling writes) is never below the run's: on Mesa lavapipe 25 a
    /// plain indirect draw recorded after a count-draw took its draw count from that earlier
    /// draw's count buffer.
    pub fn glass(&self, p: &PassContext) {
        if self.glass.is_empty() || !self.bind_pool(p) {
            return;
        }
        let f = self.frame;
        for run in self.glass {
            Self::set_cull(p, run.double_sided);
            self.draw_count(p, f.ordered_first + run.first, CULL_ORDERED, run.count);
        }
    }

    /// Whether any blended instance is drawn this frame.
    pub fn has_glass(&self) -> bool {
        self.frame.glass > 0
    }

    /// Draws every live instance inside shadow-map view `view`, both faces.
    pub fn shadow_view(&self, p: &PassContext, view: u32) {
        let f = self.frame;
        if view >= f.shadow_count || f.shadow_stride == 0 || !self.bind_pool(p) {
            return;
        }
        Self::set_cull(p, true);
        // The view's count word follows the header's.
        self.draw_count(p, f.shadow_first + view * f.shadow_stride, CULL_HEADER + view, f.shadow_stride);
    }
}

/// Keeps a per-slot buffer of at least `bytes` while `wanted` (grown to the next power of two,
/// shrunk when it has stayed four times too large; released once unwanted for as long).
/// Returns whether a new buffer was made: its contents are undefined until cleared.
fn per_slot_buffer(
    f: &mut Frame,
    buffer: &mut Option<Buffer>,
    shrink: &mut Shrink,
    name: &str,
    wanted: bool,
    bytes: u64,
) -> Result<bool, RenderError> {
    if !wanted {
        if buffer.is_some()
            && shrink.unused()
            && let Some(old) = buffer.take()
        {
            f.upload.bury_shrunk(old, 0);
        }
        return Ok(false);
    }
    let capacity = buffer.as_ref().map_or(0, |b| b.size);
    let smaller = shrink.check(capacity, bytes, 256);
    let size = if bytes > capacity { bytes.next_power_of_two().max(256) } else { smaller.unwrap_or(capacity) };
    if size == capacity {
        return Ok(false);
    }
    let usage = vk::BufferUsageFlags::STORAGE_BUFFER | vk::BufferUsageFlags::TRANSFER_DST | vk::BufferUsageFlags::SHADER_DEVICE_ADDRESS;
    let new = Buffer::new(f.ctx, name, size, usage, MemoryLocation::GpuOnly)?;
    if let Some(old) = buffer.replace(new) {
        f.upload.bury_shrunk(old, size.min(capacity));
    }
    shrink.reset();
    Ok(true)
}
