//! The renderer: frames in flight, the per-frame upload of what changed, and one recording
//! function per pipeline.
//!
//! Two frames are in flight. A timeline semaphore counts finished frames; before frame N reuses
//! its slot's command buffer, staging ring and timestamp pool, the CPU waits for frame N−2, reads
//! that frame's GPU times, and destroys what was buried for it.

use std::time::Instant;

use ash::vk;

use crate::RenderError;
use crate::decal_debug::DecalBoxes;
use crate::decals::DecalAccel;
use crate::deferred::{DecalRun, DeferredPasses, plan_deferred_decals};
use crate::device::{DeviceSettings, GpuContext, Tier};
use crate::forward::ForwardPasses;
use crate::gpu_scene::GpuScene;
use crate::memory::Graveyard;
use crate::overlay::{Overlay, OverlayFrame};
use crate::pass::PassContext;
use crate::pipeline::{ScenePush, create_layout};
use crate::scene::{FrameCounters, SceneMirror};
use crate::targets::{Targets, f16_to_f32, read_back, slots};
use crate::timestamps::{GpuTimer, PassTimes};
use crate::tonemap::Tonemap;
use crate::upload::StagingRing;
use crate::visbuffer::VisBufferPasses;
use crate::window::WindowSurface;

/// Frames the CPU may record ahead of the GPU.
pub const FRAMES_IN_FLIGHT: usize = 2;

/// Which renderer draws the frame.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash, Default)]
pub enum PipelineKind {
    /// Forward shading with a reverse-Z depth prepass.
    #[default]
    Forward,
    /// Deferred shading: G-buffer, optional deferred decals, full-screen lighting.
    Deferred,
    /// Visibility-buffer deferred texturing.
    VisBuffer,
}

impl PipelineKind {
    /// Every pipeline.
    pub const ALL: [PipelineKind; 3] = [PipelineKind::Forward, PipelineKind::Deferred, PipelineKind::VisBuffer];

    /// The name used in `--stats` and on the command line.
    pub fn name(self) -> &'static str {
        match self {
            PipelineKind::Forward => "forward",
            PipelineKind::Deferred => "deferred",
            PipelineKind::VisBuffer => "visbuffer",
        }
    }

    /// Parses [`PipelineKind::name`].
    pub fn from_name(name: &str) -> Option<Self> {
        Self::ALL.into_iter().find(|p| p.name() == name)
    }
}

/// How decals are applied.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash, Default)]
pub enum DecalMethod {
    /// Ray-query decals in the shading pass (needs the ray query tier).
    #[default]
    RayQuery,
    /// Rasterised decal boxes blended into the G-buffer (deferred pipeline only; other
    /// pipelines fall back to ray-query decals). Needs no ray tracing at all.
    DeferredDecals,
    /// No decals.
    Off,
}

impl DecalMethod {
    /// Every method.
    pub const ALL: [DecalMethod; 3] = [DecalMethod::RayQuery, DecalMethod::DeferredDecals, DecalMethod::Off];

    /// The name used in `--stats` and on the command line.
    pub fn name(self) -> &'static str {
        match self {
            DecalMethod::RayQuery => "ray_query",
            DecalMethod::DeferredDecals => "deferred",
            DecalMethod::Off => "off",
        }
    }

    /// Parses [`DecalMethod::name`].
    pub fn from_name(name: &str) -> Option<Self> {
        Self::ALL.into_iter().find(|m| m.name() == name)
    }

    /// The method actually used with `pipeline`: deferred decals exist only in the deferred
    /// pipeline.
    pub fn effective(self, pipeline: PipelineKind) -> DecalMethod {
        match (self, pipeline) {
            (DecalMethod::DeferredDecals, PipelineKind::Deferred) => DecalMethod::DeferredDecals,
            (DecalMethod::DeferredDecals, _) => DecalMethod::RayQuery,
            (m, _) => m,
        }
    }
}

/// How to create a [`Renderer`].
#[derive(Clone, Debug, Default)]
pub struct RendererSettings {
    /// Device creation.
    pub device: DeviceSettings,
}

/// What the shading pass writes: the lit image, or one of the inputs to lighting.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash, Default)]
#[repr(u32)]
pub enum DebugView {
    /// The lit image.
    #[default]
    Lit = crate::layout::DEBUG_LIT,
    /// Decals tested per pixel (boxes the ray query reported), as a heat map.
    DecalHeatmap = crate::layout::DEBUG_DECAL_HEATMAP,
    /// Albedo after decals (linear).
    Albedo = crate::layout::DEBUG_ALBEDO,
    /// World normal after decals, encoded n × 0.5 + 0.5.
    Normal = crate::layout::DEBUG_NORMAL,
    /// Roughness (R) and metallic (G) after decals.
    RoughnessMetallic = crate::layout::DEBUG_ROUGHNESS_METALLIC,
    /// Decals tested per pixel as a raw count in R (for tests).
    DecalCount = crate::layout::DEBUG_DECAL_COUNT,
}

/// Per-frame choices that may change from one frame to the next.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct FrameSettings {
    /// The pipeline to record.
    pub pipeline: PipelineKind,
    /// How decals are applied (see [`DecalMethod::effective`]).
    pub decal_method: DecalMethod,
    /// Radiance of pixels no geometry covers.
    pub clear_color: [f32; 4],
    /// What the shading pass outputs.
    pub debug_view: DebugView,
    /// Draw every decal's box (oriented, green) and AABB (yellow) over the image.
    pub show_decal_boxes: bool,
}

impl Default for FrameSettings {
    fn default() -> Self {
        Self {
            pipeline: PipelineKind::Forward,
            decal_method: DecalMethod::RayQuery,
            clear_color: [0.0, 0.0, 0.0, 1.0],
            debug_view: DebugView::Lit,
            show_decal_boxes: false,
        }
    }
}

/// GPU times of a frame that has finished executing.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct FinishedFrame {
    /// The frame's number (as returned in [`FrameReport::frame`]).
    pub frame: u64,
    /// Its passes' GPU times.
    pub gpu: PassTimes,
}

/// What [`Renderer::render`] reports about the frame it recorded.
#[derive(Clone, Copy, Debug)]
pub struct FrameReport {
    /// This frame's number, from 0.
    pub frame: u64,
    /// The decal method used (after [`DecalMethod::effective`]).
    pub decal_method: DecalMethod,
    /// Work done for this frame (uploads, records, acceleration structures, live counts).
    pub counters: FrameCounters,
    /// CPU time spent uploading and recording, in milliseconds (not counting the wait for the
    /// frame slot's previous use to finish).
    pub record_ms: f32,
    /// A frame that finished on the GPU while this one was being prepared, with its GPU times.
    pub finished: Option<FinishedFrame>,
}

struct FrameSlot {
    pool: vk::CommandPool,
    cmd: vk::CommandBuffer,
    staging: StagingRing,
    timer: GpuTimer,
    /// Timeline value that marks this slot's last submission done.
    value: u64,
    frame: u64,
}

struct Resources {
    frames: Vec<FrameSlot>,
    timeline: vk::Semaphore,
    layout: vk::PipelineLayout,
    scene: GpuScene,
    forward: ForwardPasses,
    tonemap: Tonemap,
    targets: Targets,
    deferred: DeferredPasses,
    visbuffer: VisBufferPasses,
    decal_accel: DecalAccel,
    decal_boxes: DecalBoxes,
    decal_order: DeferredDecalOrder,
    window_tonemap: Option<Tonemap>,
    overlay: Option<(Overlay, vk::Format)>,
    graveyard: Graveyard,
}

/// The renderer. It owns the device; create one per window or offscreen view.
pub struct Renderer {
    res: std::mem::ManuallyDrop<Resources>,
    frame_number: u64,
    ctx: GpuContext,
}

impl Renderer {
    /// Creates the device, pipelines and offscreen targets of `width`×`height`.
    pub fn new(settings: &RendererSettings, width: u32, height: u32) -> Result<Self, RenderError> {
        if width == 0 || height == 0 || width > 16384 || height > 16384 {
            return Err(RenderError::Other(format!("render size {width}x{height} is out of range (1..=16384)")));
        }
        let ctx = GpuContext::new(&settings.device)?;
        let res = Self::create_resources(&ctx, vk::Extent2D { width, height });
        match res {
            Ok(res) => Ok(Self { res: std::mem::ManuallyDrop::new(res), frame_number: 0, ctx }),
            Err(e) => Err(e),
        }
    }

    fn create_resources(ctx: &GpuContext, extent: vk::Extent2D) -> Result<Resources, RenderError> {
        let d = &ctx.device;
        let scene = GpuScene::new(ctx)?;
        let layout = create_layout(ctx, scene.set_layout)?;
        let forward = ForwardPasses::new(ctx, layout)?;
        let tonemap = Tonemap::new(ctx, layout, crate::targets::DISPLAY_FORMAT)?;
        let targets = Targets::new(ctx, extent)?;
        scene.bind_target(ctx, slots::HDR, targets.hdr.image.view, false);
        scene.bind_depth_target(ctx, slots::DEPTH, targets.depth.image.view);
        let deferred = DeferredPasses::new(ctx, layout)?;
        let visbuffer = VisBufferPasses::new(ctx, layout)?;
        let mut type_info = vk::SemaphoreTypeCreateInfo::default().semaphore_type(vk::SemaphoreType::TIMELINE).initial_value(0);
        // SAFETY: valid create info; destroyed in Drop.
        let timeline = unsafe { d.create_semaphore(&vk::SemaphoreCreateInfo::default().push_next(&mut type_info), None) }?;
        let mut frames = Vec::with_capacity(FRAMES_IN_FLIGHT);
        for _ in 0..FRAMES_IN_FLIGHT {
            // SAFETY: valid create infos; destroyed in Drop.
            let (pool, cmd) = unsafe {
                let pool = d.create_command_pool(
                    &vk::CommandPoolCreateInfo::default().queue_family_index(ctx.queue_family).flags(vk::CommandPoolCreateFlags::TRANSIENT),
                    None,
                )?;
                let cmd =
                    d.allocate_command_buffers(&vk::CommandBufferAllocateInfo::default().command_pool(pool).command_buffer_count(1))?[0];
                (pool, cmd)
            };
            frames.push(FrameSlot {
                pool,
                cmd,
                staging: StagingRing::new(ctx, 64 * 1024)?,
                timer: GpuTimer::new(ctx)?,
                value: 0,
                frame: 0,
            });
        }
        let decal_accel = DecalAccel::new(ctx);
        let decal_boxes = DecalBoxes::new(ctx, layout)?;
        Ok(Resources {
            frames,
            timeline,
            layout,
            scene,
            forward,
            tonemap,
            targets,
            deferred,
            visbuffer,
            decal_accel,
            decal_boxes,
            decal_order: DeferredDecalOrder::default(),
            window_tonemap: None,
            overlay: None,
            graveyard: Graveyard::default(),
        })
    }

    /// The device's name.
    pub fn device_name(&self) -> &str {
        &self.ctx.device_name
    }

    /// The ray tracing extensions the device offers (whatever tier is in use).
    pub fn capabilities(&self) -> crate::Capabilities {
        self.ctx.capabilities
    }

    /// The capability tier in use.
    pub fn tier(&self) -> Tier {
        self.ctx.tier
    }

    /// The render size.
    pub fn size(&self) -> (u32, u32) {
        (self.res.targets.extent.width, self.res.targets.extent.height)
    }

    /// Whether the Vulkan validation layer is active.
    pub fn validation_enabled(&self) -> bool {
        self.ctx.validation_enabled
    }

    /// Validation errors reported since the last call (always empty when validation is off).
    pub fn take_validation_errors(&self) -> Vec<String> {
        self.ctx.validation.take_errors()
    }

    /// Bytes of GPU memory allocated through the allocator (for leak checks).
    pub fn gpu_memory_in_use(&self) -> u64 {
        self.ctx.allocator().generate_report().total_allocated_bytes
    }

    /// Uploads what changed in `mirror` and records and submits one frame (offscreen).
    pub fn render(&mut self, mirror: &mut SceneMirror, settings: &FrameSettings) -> Result<FrameReport, RenderError> {
        Ok(self.render_inner(mirror, settings, None)?.expect("offscreen frames are never skipped"))
    }

    /// Creates a surface and swapchain for a window (the renderer must have been created with
    /// the window system's `surface_extensions`).
    pub fn create_window_surface(
        &self,
        display: raw_window_handle::RawDisplayHandle,
        window: raw_window_handle::RawWindowHandle,
        width: u32,
        height: u32,
    ) -> Result<WindowSurface, RenderError> {
        WindowSurface::new(&self.ctx, display, window, width, height)
    }

    /// Destroys a window surface (waits for the GPU).
    pub fn destroy_window_surface(&self, surface: WindowSurface) {
        surface.destroy(&self.ctx);
    }

    /// Like [`Renderer::render`], but into the window's next swapchain image, with the egui
    /// `overlay` drawn on top, then presented. Returns `None` when no image could be drawn this
    /// frame (minimised window, swapchain rebuilt): the scene's changes wait for the next frame.
    pub fn render_to_window(
        &mut self,
        mirror: &mut SceneMirror,
        settings: &FrameSettings,
        window: &mut WindowSurface,
        overlay: Option<&mut OverlayFrame>,
    ) -> Result<Option<FrameReport>, RenderError> {
        self.render_inner(mirror, settings, Some((window, overlay)))
    }

    fn render_inner(
        &mut self,
        mirror: &mut SceneMirror,
        settings: &FrameSettings,
        mut window: Option<(&mut WindowSurface, Option<&mut OverlayFrame>)>,
    ) -> Result<Option<FrameReport>, RenderError> {
        let frame = self.frame_number;
        let slot_index = (frame % FRAMES_IN_FLIGHT as u64) as usize;
        let ctx = &self.ctx;
        let res = &mut *self.res;
        let d = &ctx.device;

        // Wait for this slot's previous frame, then harvest its timings and free its garbage.
        let slot = &mut res.frames[slot_index];
        if slot.value > 0 {
            let semaphores = [res.timeline];
            let values = [slot.value];
            // SAFETY: waiting on a live semaphore for a value a submitted batch will signal.
            unsafe { d.wait_semaphores(&vk::SemaphoreWaitInfo::default().semaphores(&semaphores).values(&values), u64::MAX) }?;
        }
        let acquired = match &mut window {
            Some((surface, overlay)) => {
                // Overlay textures first: they must not be lost when no image can be drawn.
                if let Some(frame) = overlay {
                    if res.overlay.as_ref().is_none_or(|(_, f)| *f != surface.format) {
                        ctx.wait_idle();
                        if let Some((old, _)) = res.overlay.replace((Overlay::new(ctx, surface.format)?, surface.format)) {
                            old.destroy(ctx);
                        }
                    }
                    res.overlay.as_mut().expect("created above").0.prepare(ctx, frame)?;
                }
                match surface.acquire(ctx, slot_index)? {
                    Some(image) => {
                        if res.window_tonemap.as_ref().is_none_or(|t| t.format() != surface.format) {
                            ctx.wait_idle();
                            if let Some(old) = res.window_tonemap.replace(Tonemap::new(ctx, res.layout, surface.format)?) {
                                old.destroy(ctx);
                            }
                        }
                        Some(image)
                    }
                    None => return Ok(None),
                }
            }
            None => None,
        };
        let slot = &mut res.frames[slot_index];
        let finished = slot.timer.collect(ctx).map(|gpu| FinishedFrame { frame: slot.frame, gpu });
        // SAFETY: the semaphore is live.
        let completed = unsafe { d.get_semaphore_counter_value(res.timeline) }?;
        // CPU time is measured from here: waiting for the GPU is not recording.
        let start = Instant::now();
        res.graveyard.collect(ctx, completed);
        slot.staging.reset();
        let frame_value = frame + 1;

        // SAFETY: the slot's previous submission has completed, so its pool may be reset.
        unsafe {
            d.reset_command_pool(slot.pool, vk::CommandPoolResetFlags::empty())?;
            d.begin_command_buffer(slot.cmd, &vk::CommandBufferBeginInfo::default().flags(vk::CommandBufferUsageFlags::ONE_TIME_SUBMIT))?;
        }
        let cmd = slot.cmd;

        // Targets the pipeline needs (created once, on first use).
        {
            let (scene, ctx) = (&res.scene, ctx);
            let bind = |slot: u32, view: vk::ImageView, uint: bool| scene.bind_target(ctx, slot, view, uint);
            match settings.pipeline {
                PipelineKind::Forward => {}
                PipelineKind::Deferred => {
                    res.targets.gbuffer(ctx, bind)?;
                }
                PipelineKind::VisBuffer => {
                    res.targets.visibility(ctx, bind)?;
                }
            }
        }
        let decal_method = settings.decal_method.effective(settings.pipeline);
        // The deferred decals' draw order follows every change to decals or their materials.
        let decals_changed = mirror.decals.records.dirty_count() > 0 || mirror.decal_materials.dirty_count() > 0;
        if decal_method == DecalMethod::DeferredDecals && (decals_changed || !res.decal_order.valid) {
            res.decal_order.rebuild(mirror);
            res.scene.set_decal_order(&res.decal_order.slots);
        } else if decals_changed {
            res.decal_order.valid = false;
        }
        let sync = {
            let slot = &mut res.frames[slot_index];
            res.scene.sync(ctx, cmd, mirror, &mut slot.staging, &mut res.graveyard, frame_value, completed)?
        };
        mirror.counters.instances = mirror.instances.len() as u64;
        mirror.counters.lights = mirror.lights.len() as u64;
        mirror.counters.decals = mirror.decals.len() as u64;

        let slot = &mut res.frames[slot_index];
        let mut pass =
            PassContext { ctx, cmd, layout: res.layout, bindless: res.scene.set, push: ScenePush::default(), timer: &mut slot.timer };
        res.decal_accel.record(
            &mut pass,
            &mut res.graveyard,
            frame_value,
            res.scene.decal_aabbs.address(),
            if mirror.decals.records.slot_count() == 0 { 0 } else { res.scene.decal_aabbs.capacity() },
            sync.decal_boxes_changed,
            decal_method == DecalMethod::RayQuery,
            &mut mirror.counters,
        )?;
        let decals_enabled = decal_method == DecalMethod::RayQuery && ctx.tier == Tier::RayQuery && !mirror.decals.is_empty();
        pass.push = ScenePush {
            camera: res.scene.camera.address(),
            instances: res.scene.instances.address(),
            materials: res.scene.materials.address(),
            lights: res.scene.lights.address(),
            decals: res.scene.decals.address(),
            decal_materials: res.scene.decal_materials.address(),
            decal_tlas: if decals_enabled { res.decal_accel.tlas_address() } else { 0 },
            decal_aabbs: res.scene.decal_aabbs.address(),
            meshes: res.scene.mesh_table.address(),
            decal_order: res.scene.decal_order.address(),
            light_count: mirror.lights.slot_count(),
            texture_index: 0,
            debug_view: settings.debug_view as u32,
            decal_count: if decals_enabled { mirror.decals.len() as u32 } else { 0 },
        };
        let mut parts = FrameParts {
            targets: &mut res.targets,
            forward: &res.forward,
            deferred: &res.deferred,
            visbuffer: &res.visbuffer,
            tonemap: &res.tonemap,
            scene: &res.scene,
            decal_boxes: &res.decal_boxes,
            decal_runs: if decal_method == DecalMethod::DeferredDecals { &res.decal_order.runs } else { &[] },
        };
        match settings.pipeline {
            PipelineKind::Forward => record_forward(&mut pass, &mut parts, mirror, settings),
            PipelineKind::Deferred => record_deferred(&mut pass, &mut parts, mirror, settings),
            PipelineKind::VisBuffer => record_visbuffer(&mut pass, &mut parts, mirror, settings),
        }
        if settings.show_decal_boxes {
            parts.decal_boxes.record(&mut pass, &mut parts.targets.hdr, mirror.decals.records.slot_count());
        }
        match (&mut window, &acquired) {
            (Some((surface, overlay)), Some(image)) => {
                let i = image.index as usize;
                let (view, extent) = (surface.views[i], surface.extent);
                let tonemap = res.window_tonemap.as_ref().expect("created at acquire");
                tonemap.record(&mut pass, &mut parts.targets.hdr, view, extent, &mut surface.states[i]);
                if let (Some(frame), Some((egui, _))) = (overlay, res.overlay.as_mut()) {
                    let mut result = Ok(());
                    pass.timed("overlay", |p| {
                        let color = [crate::pass::color_attachment(view, None)];
                        p.begin_rendering(extent, &color, None);
                        result = egui.record(p.cmd, extent, frame);
                        p.end_rendering();
                    });
                    result?;
                }
                crate::sync::transition(&ctx.device, cmd, &mut surface.states[i], crate::sync::Access::Present, false);
            }
            _ => {
                let display = &mut parts.targets.display;
                let (view, extent) = (display.image.view, display.image.extent);
                parts.tonemap.record(&mut pass, &mut parts.targets.hdr, view, extent, &mut display.state);
            }
        }

        // SAFETY: recording is complete; the submit signals the timeline with this frame's value.
        unsafe {
            d.end_command_buffer(cmd)?;
            let cmds = [vk::CommandBufferSubmitInfo::default().command_buffer(cmd)];
            // Fixed-size arrays, sliced: a steady-state frame allocates nothing.
            let timeline = vk::SemaphoreSubmitInfo::default()
                .semaphore(res.timeline)
                .value(frame_value)
                .stage_mask(vk::PipelineStageFlags2::ALL_COMMANDS);
            let (waits, signals, n) = match &acquired {
                Some(image) => (
                    [vk::SemaphoreSubmitInfo::default().semaphore(image.wait).stage_mask(vk::PipelineStageFlags2::ALL_COMMANDS)],
                    [
                        timeline,
                        vk::SemaphoreSubmitInfo::default().semaphore(image.signal).stage_mask(vk::PipelineStageFlags2::ALL_COMMANDS),
                    ],
                    1,
                ),
                None => ([vk::SemaphoreSubmitInfo::default()], [timeline, vk::SemaphoreSubmitInfo::default()], 0),
            };
            let submit = vk::SubmitInfo2::default()
                .command_buffer_infos(&cmds)
                .wait_semaphore_infos(&waits[..n])
                .signal_semaphore_infos(&signals[..1 + n]);
            d.queue_submit2(ctx.queue, &[submit], vk::Fence::null())?;
        }
        if let (Some((surface, _)), Some(image)) = (&mut window, &acquired) {
            surface.present(ctx, image)?;
        }
        let slot = &mut res.frames[slot_index];
        slot.value = frame_value;
        slot.frame = frame;
        self.frame_number += 1;
        Ok(Some(FrameReport { frame, decal_method, counters: mirror.counters, record_ms: start.elapsed().as_secs_f32() * 1e3, finished }))
    }

    /// Waits for the GPU and returns the timings of every frame not yet reported, oldest first.
    pub fn finish(&mut self) -> Vec<FinishedFrame> {
        self.ctx.wait_idle();
        let mut slots: Vec<&mut FrameSlot> = self.res.frames.iter_mut().collect();
        slots.sort_by_key(|s| s.frame);
        let ctx = &self.ctx;
        slots.into_iter().filter_map(|s| s.timer.collect(ctx).map(|gpu| FinishedFrame { frame: s.frame, gpu })).collect()
    }

    /// The tone-mapped image of the last frame as RGBA8 sRGB rows (waits for the GPU).
    pub fn read_display(&mut self) -> Result<Vec<u8>, RenderError> {
        self.ctx.wait_idle();
        read_back(&self.ctx, &mut self.res.targets.display, 4)
    }

    /// The linear radiance of the last frame as RGBA f32 (waits for the GPU).
    pub fn read_hdr(&mut self) -> Result<Vec<[f32; 4]>, RenderError> {
        self.ctx.wait_idle();
        let bytes = read_back(&self.ctx, &mut self.res.targets.hdr, 8)?;
        Ok(bytes.chunks_exact(8).map(|px| std::array::from_fn(|c| f16_to_f32(u16::from_le_bytes([px[c * 2], px[c * 2 + 1]])))).collect())
    }

    /// The depth of the last frame (reverse-Z: 1 at the near plane, 0 at infinity).
    pub fn read_depth(&mut self) -> Result<Vec<f32>, RenderError> {
        self.ctx.wait_idle();
        let bytes = read_back(&self.ctx, &mut self.res.targets.depth, 4)?;
        Ok(bytes.chunks_exact(4).map(|b| f32::from_le_bytes([b[0], b[1], b[2], b[3]])).collect())
    }

    /// Recreates the targets at a new size (waits for the GPU).
    pub fn resize(&mut self, width: u32, height: u32) -> Result<(), RenderError> {
        if width == 0 || height == 0 || width > 16384 || height > 16384 {
            return Err(RenderError::Other(format!("render size {width}x{height} is out of range (1..=16384)")));
        }
        self.ctx.wait_idle();
        let targets = Targets::new(&self.ctx, vk::Extent2D { width, height })?;
        let old = std::mem::replace(&mut self.res.targets, targets);
        old.destroy(&self.ctx);
        self.res.scene.bind_target(&self.ctx, slots::HDR, self.res.targets.hdr.image.view, false);
        self.res.scene.bind_depth_target(&self.ctx, slots::DEPTH, self.res.targets.depth.image.view);
        Ok(())
    }
}

/// The parts of the renderer a pipeline's recording function uses.
struct FrameParts<'a> {
    targets: &'a mut Targets,
    forward: &'a ForwardPasses,
    deferred: &'a DeferredPasses,
    visbuffer: &'a VisBufferPasses,
    tonemap: &'a Tonemap,
    scene: &'a GpuScene,
    decal_boxes: &'a DecalBoxes,
    decal_runs: &'a [DecalRun],
}

/// Forward: depth prepass, then shading with depth EQUAL (ray-query decals included).
fn record_forward(p: &mut PassContext, f: &mut FrameParts, mirror: &SceneMirror, settings: &FrameSettings) {
    f.forward.prepass(p, f.targets, f.scene, &mirror.draws);
    f.forward.shade(p, f.targets, f.scene, &mirror.draws, settings.clear_color);
}

/// Deferred: G-buffer, deferred decals (when they are the method), full-screen lighting
/// (ray-query decals included when they are).
fn record_deferred(p: &mut PassContext, f: &mut FrameParts, mirror: &SceneMirror, settings: &FrameSettings) {
    f.deferred.geometry(p, f.targets, f.scene, &mirror.draws, settings.clear_color);
    f.deferred.decals(p, f.targets, f.decal_runs);
    f.deferred.lighting(p, f.targets);
}

/// Visibility buffer: ids and depth, then one full-screen pass that rebuilds and shades.
fn record_visbuffer(p: &mut PassContext, f: &mut FrameParts, mirror: &SceneMirror, settings: &FrameSettings) {
    f.visbuffer.visibility(p, f.targets, f.scene, &mirror.draws);
    f.visbuffer.shade(p, f.targets, settings.clear_color);
}

/// The deferred decals' draw order: live decal slots sorted by channel, then weight, and the
/// runs that share a set of attributes. Rebuilt only when decals or their materials change.
#[derive(Default)]
struct DeferredDecalOrder {
    keys: Vec<(u32, f32, u32)>,
    slots: Vec<u32>,
    runs: Vec<DecalRun>,
    valid: bool,
}

impl DeferredDecalOrder {
    fn rebuild(&mut self, mirror: &SceneMirror) {
        plan_deferred_decals(
            mirror.decals.records.records(),
            mirror.decal_materials.records(),
            &mut self.keys,
            &mut self.slots,
            &mut self.runs,
        );
        self.valid = true;
    }
}

impl Drop for Renderer {
    fn drop(&mut self) {
        self.ctx.wait_idle();
        // SAFETY: the GPU is idle; `res` is never used again.
        let res = unsafe { std::mem::ManuallyDrop::take(&mut self.res) };
        let ctx = &self.ctx;
        let Resources {
            frames,
            timeline,
            layout,
            scene,
            forward,
            tonemap,
            targets,
            deferred,
            visbuffer,
            decal_accel,
            decal_boxes,
            decal_order: _,
            window_tonemap,
            overlay,
            mut graveyard,
        } = res;
        if let Some(t) = window_tonemap {
            t.destroy(ctx);
        }
        if let Some((o, _)) = overlay {
            o.destroy(ctx);
        }
        for f in frames {
            f.staging.destroy(ctx);
            f.timer.destroy(ctx);
            // SAFETY: idle GPU; the pool frees its command buffer.
            unsafe { ctx.device.destroy_command_pool(f.pool, None) };
        }
        graveyard.clear(ctx);
        decal_accel.destroy(ctx);
        decal_boxes.destroy(ctx);
        forward.destroy(ctx);
        deferred.destroy(ctx);
        visbuffer.destroy(ctx);
        tonemap.destroy(ctx);
        targets.destroy(ctx);
        scene.destroy(ctx);
        // SAFETY: idle GPU; nothing references these any more.
        unsafe {
            ctx.device.destroy_pipeline_layout(layout, None);
            ctx.device.destroy_semaphore(timeline, None);
        }
    }
}
