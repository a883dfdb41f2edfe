//! The renderer: frames in flight and their submission. Each frame waits for its slot, records
//! the chosen pipeline's frame function (`crate::pipelines`) on the frame graph, and submits.
//!
//! Two frames are in flight. A timeline semaphore counts finished frames; before frame N reuses
//! its slot's command buffer, staging ring and timestamp pool, the CPU waits for frame N−2, reads
//! that frame's GPU times, and destroys what was buried for it.

use std::time::Instant;

use ash::vk;

use crate::RenderError;
use crate::bloom::Bloom;
use crate::culling::Culling;
use crate::decals::{DecalChoice, Decals};
use crate::environment::Environments;
use crate::exposure::Exposure;
use crate::gpu::commands::{CommandCache, Recorder, Recording};
use crate::gpu::device::{DeviceSettings, GpuContext, Tier};
use crate::gpu::memory::Graveyard;
use crate::gpu::pipeline::{ScenePush, create_layout};
use crate::gpu::timestamps::{GpuTimer, PassTimes};
use crate::gpu::upload::{StagingRing, Upload};
use crate::graph::targets::{DEPTH, DISPLAY, DISPLAY_FORMAT, HDR, f16_to_f32};
use crate::graph::{ACQUIRE_WAIT_STAGE, Frame, FrameGraph, ImageId, ImageRef, ImageUse};
use crate::lights::Lighting;
use crate::pipelines::deferred::DeferredPasses;
use crate::pipelines::forward::ForwardPasses;
use crate::pipelines::visbuffer::VisBufferPasses;
use crate::pipelines::{FrameParts, deferred_frame, forward_frame, forward_plus_frame, visbuffer_frame};
use crate::present::Present;
use crate::present::check::{DisplayCheck, DisplayCheckCounts};
use crate::present::overlay::{Overlay, OverlayFrame};
use crate::present::tonemap::Tonemap;
use crate::present::window::{AcquiredImage, WindowSurface};
use crate::reflections::Reflections;
use crate::scene::SceneMirror;
use crate::scene::gpu::GpuScene;
pub use crate::settings::{DebugView, DecalMethod, FrameSettings, LightMethod, PipelineKind, ShadowMethod};
use crate::stats::FrameCounters;
use crate::transparency::TransparencyPasses;

pub use crate::gpu::FRAMES_IN_FLIGHT;

/// How to create a [`Renderer`].
#[derive(Clone, Debug)]
pub struct RendererSettings {
    /// Device creation.
    pub device: DeviceSettings,
    /// Entries the clustered decals' buffer starts with room for (it grows when a frame needs
    /// more; see [`crate::decals::clustered`]).
    pub decal_cluster_capacity: u32,
    /// The shadow-map atlas.
    pub shadow_maps: crate::settings::ShadowMapBudget,
    /// Face size of the environment's cubes in texels (a power of two, 32 to 2048; default 512,
    /// an equirectangular map of 2048 texels across): what the sky and mirror reflections of
    /// an environment map show at most, and what filtering a new source costs.
    pub environment_resolution: u32,
    /// Bytes the scene's textures may hold on the GPU (0: no budget, the default). A scene over
    /// budget drops the finest levels of its largest textures as they upload, with one warning
    /// (see [`crate::scene::gpu`]'s texture budget); `counters.texture_budget` says what it did.
    pub texture_budget: u64,
    /// Particles the pool holds at once (default [`crate::particles::DEFAULT_CAPACITY`],
    /// 65,536: 3.7 MB, made the first frame an emitter exists). Particles started while it is
    /// full are dropped and counted (`counters.particles.dropped`).
    pub particle_capacity: u32,
    /// Places in the ring of decals that landing particles leave (default
    /// [`crate::particles::DEFAULT_DECAL_ROOM`], 4,096: 640 KB; rounded up to a power of two);
    /// the oldest is overwritten first.
    pub particle_decals: u32,
}

impl Default for RendererSettings {
    fn default() -> Self {
        Self {
            device: DeviceSettings::default(),
            decal_cluster_capacity: crate::decals::clustered::INITIAL_CAPACITY,
            shadow_maps: Default::default(),
            environment_resolution: 512,
            texture_budget: 0,
            particle_capacity: crate::particles::DEFAULT_CAPACITY,
            particle_decals: crate::particles::DEFAULT_DECAL_ROOM,
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
    /// The decal method applied (after [`DecalMethod::effective`]): what the frame shows, not
    /// what was asked for.
    pub decal_method: DecalMethod,
    /// Where the decal pass read each pixel's surface (`None` when no decal pass ran).
    pub decal_surface: Option<crate::graph::targets::Surface>,
    /// The light method applied (after [`LightMethod::effective`]).
    pub light_method: LightMethod,
    /// How the frame's shadows were made (`None` when none were traced).
    pub shadows: ShadowMethod,
    /// How the traced shadows of the pixels' light lists were made: a ray per light, or
    /// sampled (`crate::lights::sampling`); `None` when no list's shadows were traced.
    pub direct_light: Option<crate::settings::DirectLight>,
    /// Whether the shading pass staged its workgroups' light lists in shared memory (compute
    /// shading of long unshadowed lists: `crate::gpu::pipeline::Specialization::staged_lights`).
    pub staged_lights: bool,
    /// Whether light culling tested the tiles' depth masks (`LightSettings::cull_depth_mask`;
    /// off in frames that light particles from the tiles' lists).
    pub depth_mask: bool,
    /// How the frame's ambient light was occluded (`Off` when it was not).
    pub occlusion: crate::settings::OcclusionMethod,
    /// The anti-aliasing applied ([`crate::settings::AntiAliasing::applied`]: MSAA is TAA in the
    /// deferred pipelines and takes the sample counts the device offers; TAA is none under a
    /// debug view).
    pub aa: crate::settings::AntiAliasing,
    /// Work done for this frame (uploads, records, acceleration structures, live counts).
    pub counters: FrameCounters,
    /// CPU time spent uploading and recording, in milliseconds (not counting the wait for the
    /// frame slot's previous use to finish); the submission included.
    pub record_ms: f32,
    /// Of `record_ms`, the time ending the command buffer and in `vkQueueSubmit2` (the driver's).
    pub submit_ms: f32,
    /// Of `record_ms`, the time preparing the frame's data (skinning jobs, lights, culling) and
    /// writing the scene's uploads into staging memory, before any pass is recorded.
    pub prepare_ms: f32,
    /// CPU time spent waiting for the GPU before recording (the frame slot's previous use and its
    /// timestamps, the swapchain image), in milliseconds: what a whole-frame CPU time should
    /// leave out.
    pub wait_ms: f32,
    /// A frame that finished on the GPU while this one was being prepared, with its GPU times.
    pub finished: Option<FinishedFrame>,
}

struct FrameSlot {
    /// The slot's command buffer and the log it was recorded from (`crate::gpu::commands`).
    commands: CommandCache,
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
    graph: FrameGraph,
    /// The graph's name for the swapchain image being drawn.
    swapchain_image: ImageId,
    scene: GpuScene,
    culling: Culling,
    skinning: crate::skinning::Skinning,
    forward: ForwardPasses,
    deferred: DeferredPasses,
    visbuffer: VisBufferPasses,
    transparency: TransparencyPasses,
    reflections: Reflections,
    environment: Environments,
    bloom: Bloom,
    exposure: Exposure,
    motion: crate::motion::Motion,
    taa: crate::taa::Taa,
    msaa: crate::msaa::Msaa,
    /// The forward pipelines at MSAA's sample count, while it is on (`crate::msaa`).
    forward_ms: Option<ForwardPasses>,
    smaa: crate::smaa::Smaa,
    fxaa: crate::fxaa::Fxaa,
    occlusion: crate::occlusion::AmbientOcclusion,
    decals: Decals,
    particles: crate::particles::Particles,
    lighting: Lighting,
    accel: Option<crate::accel::SceneAccel>,
    shadows: crate::shadows::ShadowPass,
    tonemap: Tonemap,
    window_tonemap: Option<Tonemap>,
    /// The debug builds' check of the tone mapper's input (`None` in release builds).
    display_check: Option<DisplayCheck>,
    overlay: Option<(Overlay, vk::Format)>,
    graveyard: Graveyard,
    /// Decal-method fallbacks already logged (one bit per request and pipeline).
    warned_fallbacks: u32,
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
        check_size(width, height)?;
        let ctx = GpuContext::new(&settings.device)?;
        let res = Self::create_resources(&ctx, vk::Extent2D { width, height }, settings)?;
        Ok(Self { res: std::mem::ManuallyDrop::new(res), frame_number: 0, ctx })
    }

    fn create_resources(ctx: &GpuContext, extent: vk::Extent2D, settings: &RendererSettings) -> Result<Resources, RenderError> {
        let d = &ctx.device;
        let mut graph = FrameGraph::new(extent);
        let swapchain_image = graph.external_image("swapchain image");
        let mut scene = GpuScene::new(ctx, &mut graph)?;
        let display_check = DisplayCheck::new(ctx, &mut graph)?;
        scene.set_display_check(display_check.as_ref().map_or(0, DisplayCheck::address));
        scene.set_texture_budget(settings.texture_budget);
        scene.add_builtin_texture(crate::layout::TEXTURE_LTC, crate::lights::ltc::texture())?;
        let layout = create_layout(ctx, scene.set_layout)?;
        let mut type_info = vk::SemaphoreTypeCreateInfo::default().semaphore_type(vk::SemaphoreType::TIMELINE).initial_value(0);
        // SAFETY: valid create info; destroyed in Drop.
        let timeline = unsafe { d.create_semaphore(&vk::SemaphoreCreateInfo::default().push_next(&mut type_info), None) }?;
        let mut frames = Vec::with_capacity(FRAMES_IN_FLIGHT);
        for _ in 0..FRAMES_IN_FLIGHT {
            frames.push(FrameSlot {
                commands: CommandCache::new(ctx)?,
                staging: StagingRing::new(ctx, crate::gpu::upload::STAGING_FLOOR)?,
                timer: GpuTimer::new(ctx)?,
                value: 0,
                frame: 0,
            });
        }
        Ok(Resources {
            frames,
            timeline,
            layout,
            culling: Culling::new(ctx, &mut graph, scene.set_layout)?,
            skinning: crate::skinning::Skinning::new(ctx)?,
            forward: ForwardPasses::new(ctx, layout, 1)?,
            deferred: DeferredPasses::new(ctx, layout)?,
            visbuffer: VisBufferPasses::new(ctx, layout)?,
            transparency: TransparencyPasses::new(ctx, layout)?,
            reflections: Reflections::new(ctx, &mut graph, layout)?,
            environment: Environments::new(ctx, &mut graph, layout, settings.environment_resolution)?,
            bloom: Bloom::new(ctx, &mut graph, layout)?,
            exposure: Exposure::new(ctx, &mut graph, layout)?,
            motion: crate::motion::Motion::new(ctx, layout)?,
            taa: crate::taa::Taa::new(ctx, layout)?,
            msaa: crate::msaa::Msaa::new(ctx),
            forward_ms: None,
            smaa: crate::smaa::Smaa::new(ctx, layout)?,
            fxaa: crate::fxaa::Fxaa::new(ctx, layout)?,
            occlusion: crate::occlusion::AmbientOcclusion::new(ctx, layout)?,
            decals: Decals::new(ctx, &mut graph, layout, settings.decal_cluster_capacity)?,
            particles: crate::particles::Particles::new(ctx, &mut graph, layout, settings.particle_capacity, settings.particle_decals)?,
            lighting: Lighting::new(ctx, &mut graph, layout)?,
            accel: crate::accel::SceneAccel::new(ctx, &mut graph, layout)?,
            shadows: crate::shadows::ShadowPass::new(ctx, layout, settings.shadow_maps)?,
            tonemap: Tonemap::new(ctx, layout, DISPLAY_FORMAT)?,
            graph,
            swapchain_image,
            scene,
            window_tonemap: None,
            display_check,
            overlay: None,
            graveyard: Graveyard::default(),
            warned_fallbacks: 0,
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

    /// What the device offers decals (which [`DecalMethod`]s it can run).
    pub fn ray_support(&self) -> crate::settings::RaySupport {
        self.ctx.ray_support()
    }

    /// GPU memory allocated now, by what it holds (the frame's `counters.memory` is this at the
    /// frame's end); its total is [`Renderer::gpu_memory_in_use`] but for the allocator's
    /// alignment padding.
    pub fn gpu_memory(&self) -> crate::gpu::memory::MemoryCounts {
        self.ctx.memory()
    }

    /// The render size.
    pub fn size(&self) -> (u32, u32) {
        let e = self.res.graph.extent();
        (e.width, e.height)
    }

    /// Whether the Vulkan validation layer is active.
    pub fn validation_enabled(&self) -> bool {
        self.ctx.validation_enabled
    }

    /// Validation errors reported since the last call (always empty when validation is off).
    pub fn take_validation_errors(&self) -> Vec<String> {
        self.ctx.validation.take_errors()
    }

    /// Sets the texture budget in bytes (0: none; see [`RendererSettings::texture_budget`]):
    /// textures uploaded from now on are fitted to it.
    pub fn set_texture_budget(&mut self, bytes: u64) {
        self.res.scene.set_texture_budget(bytes);
    }

    /// Bytes of GPU memory allocated through the allocator (for leak checks; asking the
    /// allocator allocates, so not for every frame: [`Renderer::gpu_memory`] is free).
    pub fn gpu_memory_in_use(&self) -> u64 {
        self.ctx.allocator_bytes()
    }

    /// Bytes of GPU memory allocated through the allocator, summed by allocation name, largest
    /// first (to say what [`Renderer::gpu_memory_in_use`] is made of).
    pub fn gpu_memory_by_name(&self) -> Vec<(String, u64)> {
        let mut by_name: Vec<(String, u64)> = Vec::new();
        for a in self.ctx.allocator().generate_report().allocations {
            match by_name.iter_mut().find(|(name, _)| *name == a.name) {
                Some((_, bytes)) => *bytes += a.size,
                None => by_name.push((a.name, a.size)),
            }
        }
        by_name.sort_by(|a, b| b.1.cmp(&a.1).then_with(|| a.0.cmp(&b.0)));
        by_name
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
        let wait_start = Instant::now();
        if slot.value > 0 {
            let semaphores = [res.timeline];
            let values = [slot.value];
            // SAFETY: waiting on a live semaphore for a value a submitted batch will signal.
            unsafe { d.wait_semaphores(&vk::SemaphoreWaitInfo::default().semaphores(&semaphores).values(&values), u64::MAX) }
                .map_err(|e| RenderError::from(e).in_frame(frame, "waiting for the GPU to free a frame slot"))?;
        }
        let acquired = match &mut window {
            Some((surface, overlay)) => match res
                .acquire(ctx, surface, overlay.as_deref_mut(), slot_index)
                .map_err(|e| e.in_frame(frame, "acquiring the swapchain image"))?
            {
                Some(image) => Some(image),
                None => return Ok(None),
            },
            None => None,
        };
        let decal_choice = DecalChoice { requested: settings.decal_method, applied: res.decal_method(ctx, settings) };
        let aa = res.msaa.choose(settings);
        if let Some(samples) = res.msaa.prepare(ctx, &mut res.graph, aa) {
            // The GPU is idle: a change of sample count waited for it.
            if let Some(old) = res.forward_ms.take() {
                old.destroy(ctx);
            }
            if samples > 1 {
                let made = ForwardPasses::new(ctx, res.layout, samples).map_err(|e| e.in_frame(frame, "making the MSAA pipelines"))?;
                res.forward_ms = Some(made);
            }
        }
        let slot = &mut res.frames[slot_index];
        // Reading the slot's timestamps is where some drivers (lavapipe) do their waiting.
        let finished = slot.timer.collect(ctx).map(|gpu| FinishedFrame { frame: slot.frame, gpu });
        // SAFETY: the semaphore is live.
        let completed = unsafe { d.get_semaphore_counter_value(res.timeline) }
            .map_err(|e| RenderError::from(e).in_frame(frame, "reading the GPU's progress"))?;
        // CPU time is measured from here: waiting for the GPU is not recording.
        let start = Instant::now();
        let wait_ms = (start - wait_start).as_secs_f32() * 1e3;
        res.graveyard.collect(ctx, completed);
        slot.staging.reset();
        let frame_value = frame + 1;
        // The slot's previous submission has completed, so its command buffer may be recorded
        // again or submitted again.
        let cmd = Recorder::new(ctx, std::mem::take(&mut slot.commands), settings.reuse_commands);

        // The display image: the offscreen target, or the acquired swapchain image.
        let (target, tonemap, overlay): (ImageRef, &Tonemap, _) = match (&mut window, &acquired) {
            (Some((surface, overlay)), Some(image)) => {
                let i = image.index as usize;
                res.graph.import(res.swapchain_image, surface.images[i], surface.views[i], surface.extent, surface.states[i]);
                let egui = res.overlay.as_mut().map(|(o, _)| o).zip(overlay.as_deref());
                (res.swapchain_image.into(), res.window_tonemap.as_ref().expect("created at acquire"), egui)
            }
            _ => ((&DISPLAY).into(), &res.tonemap, None),
        };
        let mut f = Frame {
            ctx,
            cmd: &cmd,
            graph: &mut res.graph,
            timer: &mut slot.timer,
            layout: res.layout,
            bindless: res.scene.set,
            push: ScenePush::default(),
            upload: Upload {
                ctx,
                staging: &mut slot.staging,
                graveyard: &mut res.graveyard,
                frame_value,
                completed,
                bytes: 0,
                shrinks: 0,
                bytes_released: 0,
                prepare_ms: 0.0,
            },
        };
        // Free slots at the ends of the tables go before anything reads a slot count.
        mirror.trim();
        // This frame's statistics, which the techniques add to through the frame function.
        let mut counters = FrameCounters::default();
        let mut parts = FrameParts {
            counters: &mut counters,
            scene: &mut res.scene,
            culling: &mut res.culling,
            skinning: &mut res.skinning,
            decals: &mut res.decals,
            particles: &mut res.particles,
            lighting: &mut res.lighting,
            accel: res.accel.as_mut(),
            shadows: &mut res.shadows,
            occlusion: &res.occlusion,
            forward: res.forward_ms.as_ref().unwrap_or(&res.forward),
            deferred: &res.deferred,
            visbuffer: &res.visbuffer,
            transparency: &res.transparency,
            reflections: &mut res.reflections,
            environment: &mut res.environment,
            bloom: &mut res.bloom,
            exposure: &mut res.exposure,
            motion: &res.motion,
            taa: &mut res.taa,
            present: Present { tonemap, target, overlay, aa, check: res.display_check.as_mut() },
            smaa: &res.smaa,
            fxaa: &res.fxaa,
            decal_choice,
            aa,
            pixel_ids: crate::motion::PixelIds::None,
        };
        let lights = match settings.pipeline {
            PipelineKind::Forward => forward_frame(&mut f, &mut parts, mirror, settings),
            PipelineKind::ForwardPlus => forward_plus_frame(&mut f, &mut parts, mirror, settings),
            PipelineKind::Deferred => deferred_frame(&mut f, &mut parts, mirror, settings),
            PipelineKind::VisBuffer => visbuffer_frame(&mut f, &mut parts, mirror, settings),
        };
        let lights = match lights {
            Ok(lights) => lights,
            Err(e) => {
                // Nothing is submitted; the slot keeps its pool for the next frame.
                res.frames[slot_index].commands = cmd.abandon();
                res.particles.abandon(&mut mirror.emitters);
                return Err(e.in_frame(frame, "uploading the scene and recording the frame's passes"));
            }
        };
        counters.buffer_shrinks += f.upload.shrinks;
        let prepare_ms = f.upload.prepare_ms;
        counters.bytes_released += f.upload.bytes_released;
        if let (Some((surface, _)), Some(image)) = (&mut window, &acquired) {
            f.hand_over(res.swapchain_image, ImageUse::Present);
            surface.states[image.index as usize] = res.graph.state(res.swapchain_image);
        }
        // Targets created this frame go into the bindless set before the submit.
        for (bind, view) in res.graph.take_new_bindings() {
            res.scene.bind_target(ctx, bind, view);
        }
        counters.records_written = mirror.records_written;
        counters.memory = ctx.memory();
        counters.transparent = mirror.transparent_order().len() as u64;
        counters.instances = mirror.instances.len() as u64;
        counters.draw_calls = res.culling.draw_calls();
        counters.mesh_pool_bytes = res.scene.pool_bytes();
        counters.posed_mesh_bytes = res.scene.posed_bytes();
        counters.texture_budget = res.scene.texture_budget_report();
        counters.lights = mirror.lights.len() as u64;
        counters.environment = res.environment.stats;
        counters.decals = mirror.decals.len() as u64;
        let decal_method = decal_choice.applied;

        let submit_start = Instant::now();
        counters.command_words = cmd.words() as u64;
        let (commands, recording) = cmd.finish();
        let slot = &mut res.frames[slot_index];
        slot.commands = commands;
        let recording = match recording {
            Ok(r) => r,
            Err(e) => {
                // What the particles' passes would have written is written again next frame.
                res.particles.abandon(&mut mirror.emitters);
                return Err(RenderError::from(e).in_frame(frame, "recording the command buffer"));
            }
        };
        counters.commands_reused = recording == Recording::Reused;
        let cmd = slot.commands.cmd();
        // SAFETY: the buffer is recorded (now or by an earlier frame with the same commands, whose
        // submission has completed); the submit signals the timeline with this frame's value.
        let submitted: Result<(), vk::Result> = unsafe {
            let cmds = [vk::CommandBufferSubmitInfo::default().command_buffer(cmd)];
            // Fixed-size arrays, sliced: a steady-state frame allocates nothing.
            let timeline = vk::SemaphoreSubmitInfo::default()
                .semaphore(res.timeline)
                .value(frame_value)
                .stage_mask(vk::PipelineStageFlags2::ALL_COMMANDS);
            let (waits, signals, n) = match &acquired {
                Some(image) => (
                    [vk::SemaphoreSubmitInfo::default().semaphore(image.wait).stage_mask(ACQUIRE_WAIT_STAGE)],
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
            d.queue_submit2(ctx.queue, &[submit], vk::Fence::null())
        };
        let submit_ms = submit_start.elapsed().as_secs_f32() * 1e3;
        if let Err(e) = submitted {
            res.particles.abandon(&mut mirror.emitters);
            return Err(RenderError::from(e).in_frame(frame, "submitting the frame"));
        }
        // Submitted: the slot now waits for this frame, whatever presenting says.
        let slot = &mut res.frames[slot_index];
        slot.value = frame_value;
        slot.frame = frame;
        self.frame_number += 1;
        if let (Some((surface, _)), Some(image)) = (&mut window, &acquired) {
            surface.present(ctx, image).map_err(|e| e.in_frame(frame, "presenting the frame"))?;
        }
        Ok(Some(FrameReport {
            frame,
            decal_method,
            decal_surface: res.decals.surface(),
            light_method: lights.method,
            shadows: lights.shadows,
            direct_light: lights.direct_light,
            staged_lights: lights.staged(),
            depth_mask: lights.depth_mask,
            occlusion: lights.occlusion.method,
            aa,
            counters,
            record_ms: start.elapsed().as_secs_f32() * 1e3,
            submit_ms,
            prepare_ms,
            wait_ms,
            finished,
        }))
    }

    /// Waits until the GPU has finished everything submitted so far (what a headless benchmark
    /// does between frames where the GPU is emulated on the same cores: the sandbox's
    /// `--gpu-idle-between-frames`).
    pub fn wait_gpu_idle(&self) {
        self.ctx.wait_idle();
    }

    /// Waits for the GPU and returns the timings of every frame not yet reported, oldest first.
    pub fn finish(&mut self) -> Vec<FinishedFrame> {
        self.ctx.wait_idle();
        let mut slots: Vec<&mut FrameSlot> = self.res.frames.iter_mut().collect();
        slots.sort_by_key(|s| s.frame);
        let ctx = &self.ctx;
        slots.into_iter().filter_map(|s| s.timer.collect(ctx).map(|gpu| FinishedFrame { frame: s.frame, gpu })).collect()
    }

    /// What the debug builds' check of the tone mapper's input has counted so far: frames
    /// checked, and pixels whose HDR value was not finite (`crate::present::check`; a frame's
    /// count comes back two frames later). `None` in release builds, which leave the check out.
    pub fn display_check(&self) -> Option<DisplayCheckCounts> {
        self.res.display_check.as_ref().map(DisplayCheck::counts)
    }

    /// The tone-mapped image of the last frame as RGBA8 sRGB rows (waits for the GPU).
    pub fn read_display(&mut self) -> Result<Vec<u8>, RenderError> {
        self.ctx.wait_idle();
        self.res.graph.read_back(&self.ctx, &DISPLAY, 4)
    }

    /// The linear radiance of the last frame as RGBA f32 (waits for the GPU).
    pub fn read_hdr(&mut self) -> Result<Vec<[f32; 4]>, RenderError> {
        self.ctx.wait_idle();
        let bytes = self.res.graph.read_back(&self.ctx, &HDR, 8)?;
        Ok(bytes.chunks_exact(8).map(|px| std::array::from_fn(|c| f16_to_f32(u16::from_le_bytes([px[c * 2], px[c * 2 + 1]])))).collect())
    }

    /// Level `level` of the environment's radiance cube (`specular` false) or its specular cube
    /// (level i prefiltered for roughness i / (levels − 1)). `None` before an environment was
    /// used. Waits for the GPU; for tests.
    pub fn read_environment(&mut self, specular: bool, level: u32) -> Result<Option<crate::environment::CubeLevel>, RenderError> {
        self.ctx.wait_idle();
        let res = &mut *self.res;
        res.environment.read_level(&self.ctx, &mut res.graph, specular, level)
    }

    /// Auto-exposure's state after the last frame (waits for the GPU); `None` before it first
    /// ran.
    pub fn read_exposure(&mut self) -> Result<Option<crate::layout::GpuExposure>, RenderError> {
        self.ctx.wait_idle();
        let res = &mut *self.res;
        res.exposure.read_back(&self.ctx, &mut res.graph)
    }

    /// The motion vectors of the last frame that drew them (waits for the GPU), row by row:
    /// UV motion (xy), previous and current view depth (`crate::motion`).
    pub fn read_motion(&mut self) -> Result<Vec<[f32; 4]>, RenderError> {
        self.ctx.wait_idle();
        let bytes = self.res.graph.read_back(&self.ctx, &crate::graph::targets::MOTION, 8)?;
        Ok(bytes.chunks_exact(8).map(|px| std::array::from_fn(|c| f16_to_f32(u16::from_le_bytes([px[c * 2], px[c * 2 + 1]])))).collect())
    }

    /// The depth of the last frame (reverse-Z: 1 at the near plane, 0 at infinity).
    pub fn read_depth(&mut self) -> Result<Vec<f32>, RenderError> {
        self.ctx.wait_idle();
        let bytes = self.res.graph.read_back(&self.ctx, &DEPTH, 4)?;
        Ok(bytes.chunks_exact(4).map(|b| f32::from_le_bytes([b[0], b[1], b[2], b[3]])).collect())
    }

    /// The light grid and index list of the last frame with tiled lights (waits for the GPU);
    /// `None` before any.
    pub fn read_light_tiles(&mut self) -> Result<Option<crate::lights::tiles::LightTileLists>, RenderError> {
        self.ctx.wait_idle();
        let res = &mut *self.res;
        res.lighting.tiles.read_back(&self.ctx, &mut res.graph)
    }

    /// The depth pyramid occlusion culling built last (waits for the GPU); `None` without
    /// occlusion culling.
    pub fn read_depth_pyramid(&mut self) -> Result<Option<crate::culling::DepthPyramid>, RenderError> {
        self.ctx.wait_idle();
        let res = &mut *self.res;
        res.culling.read_pyramid(&self.ctx, &mut res.graph)
    }

    /// The instance slots the last frame's culling drew, list by list (waits for the GPU);
    /// `None` before any frame.
    pub fn read_culled_lists(&mut self) -> Result<Option<crate::culling::CulledLists>, RenderError> {
        self.ctx.wait_idle();
        let res = &mut *self.res;
        res.culling.read_back(&self.ctx, &mut res.graph)
    }

    /// The decals landing particles left that the GPU's ring still holds, oldest first
    /// ([`crate::particles::BornDecal`]; waits for the GPU): for a game that keeps them, for
    /// example in a save. Empty before any particle left one.
    pub fn read_particle_decals(&mut self) -> Result<Vec<crate::particles::BornDecal>, RenderError> {
        self.ctx.wait_idle();
        let res = &mut *self.res;
        res.particles.read_decals(&self.ctx, &mut res.graph)
    }

    /// Resizes the targets (waits for the GPU); they are created at the new size when next used.
    pub fn resize(&mut self, width: u32, height: u32) -> Result<(), RenderError> {
        check_size(width, height)?;
        self.ctx.wait_idle();
        self.res.graph.resize(vk::Extent2D { width, height });
        self.res.graph.destroy_retired(&self.ctx);
        Ok(())
    }
}

fn check_size(width: u32, height: u32) -> Result<(), RenderError> {
    if width == 0 || height == 0 || width > 16384 || height > 16384 {
        return Err(RenderError::Other(format!("render size {width}x{height} is out of range (1..=16384)")));
    }
    Ok(())
}

impl Resources {
    /// The decal method applied this frame; a request the device cannot run is logged once per
    /// request and pipeline, naming the tier and the method used instead.
    fn decal_method(&mut self, ctx: &GpuContext, settings: &FrameSettings) -> DecalMethod {
        let applied = settings.decal_method.effective(settings.pipeline, ctx.ray_support());
        let key = 1u32 << (settings.decal_method as u32 * PipelineKind::ALL.len() as u32 + settings.pipeline as u32);
        if applied != settings.decal_method && self.warned_fallbacks & key == 0 {
            self.warned_fallbacks |= key;
            tracing::warn!(
                requested = settings.decal_method.name(),
                pipeline = settings.pipeline.name(),
                tier = ctx.tier.name(),
                applied = applied.name(),
                "this device cannot apply the requested decal method in this pipeline"
            );
        }
        applied
    }

    /// Prepares the window's overlay and acquires its next image: `None` when nothing can be
    /// drawn this frame (minimised, swapchain rebuilt). Overlay textures are applied first, so
    /// they are not lost when no image can be drawn.
    fn acquire(
        &mut self,
        ctx: &GpuContext,
        surface: &mut WindowSurface,
        overlay: Option<&mut OverlayFrame>,
        slot_index: usize,
    ) -> Result<Option<AcquiredImage>, RenderError> {
        if let Some(frame) = overlay {
            if self.overlay.as_ref().is_none_or(|(_, f)| *f != surface.format) {
                ctx.wait_idle();
                if let Some((old, _)) = self.overlay.replace((Overlay::new(ctx, surface.format)?, surface.format)) {
                    old.destroy(ctx);
                }
            }
            self.overlay.as_mut().expect("created above").0.prepare(ctx, frame)?;
        }
        let Some(image) = surface.acquire(ctx, slot_index)? else { return Ok(None) };
        if self.window_tonemap.as_ref().is_none_or(|t| t.format() != surface.format) {
            ctx.wait_idle();
            if let Some(old) = self.window_tonemap.replace(Tonemap::new(ctx, self.layout, surface.format)?) {
                old.destroy(ctx);
            }
        }
        Ok(Some(image))
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
            graph,
            swapchain_image: _,
            scene,
            culling,
            skinning,
            forward,
            deferred,
            visbuffer,
            transparency,
            reflections,
            environment,
            bloom,
            exposure,
            motion,
            taa,
            msaa: _,
            forward_ms,
            smaa,
            fxaa,
            occlusion,
            decals,
            particles,
            lighting,
            accel,
            shadows,
            tonemap,
            window_tonemap,
            display_check,
            overlay,
            mut graveyard,
            warned_fallbacks: _,
        } = res;
        if let Some(t) = window_tonemap {
            t.destroy(ctx);
        }
        if let Some(c) = display_check {
            c.destroy(ctx);
        }
        if let Some((o, _)) = overlay {
            o.destroy(ctx);
        }
        for f in frames {
            f.staging.destroy(ctx);
            f.timer.destroy(ctx);
            f.commands.destroy(ctx);
        }
        graveyard.clear(ctx);
        decals.destroy(ctx);
        particles.destroy(ctx);
        lighting.destroy(ctx);
        if let Some(a) = accel {
            a.destroy(ctx);
        }
        shadows.destroy(ctx);
        culling.destroy(ctx);
        skinning.destroy(ctx);
        forward.destroy(ctx);
        deferred.destroy(ctx);
        visbuffer.destroy(ctx);
        transparency.destroy(ctx);
        reflections.destroy(ctx);
        environment.destroy(ctx);
        bloom.destroy(ctx);
        exposure.destroy(ctx);
        motion.destroy(ctx);
        taa.destroy(ctx);
        if let Some(f) = forward_ms {
            f.destroy(ctx);
        }
        smaa.destroy(ctx);
        fxaa.destroy(ctx);
        occlusion.destroy(ctx);
        tonemap.destroy(ctx);
        graph.destroy(ctx);
        scene.destroy(ctx);
        // SAFETY: idle GPU; nothing references these any more.
        unsafe {
            ctx.destroying().destroy_pipeline_layout(layout, None);
            ctx.device.destroy_semaphore(timeline, None);
        }
    }
}
