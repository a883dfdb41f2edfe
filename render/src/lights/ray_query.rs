//! Ray-query lights (seed 000 §5.2.5, §6.1): the third way to assign lights to pixels, beside
//! every light and tiled culling. Every light with a finite range gets an axis-aligned box
//! around its reach in the lights' own acceleration structure (one BLAS of boxes, one TLAS:
//! [`AabbAccel`], shared with the decals), and the lighting pass finds a pixel's lights with a
//! zero-length ray from its surface point, as the decals are found. Lights no box can hold
//! (directional lights, unbounded ranges) are listed apart and every pixel loops over them.
//!
//! - **Boxes on the GPU.** `shaders/light_boxes.comp` writes box *i* for light slot *i* from the
//!   light table change detection already keeps, and the list of unbounded lights, in frames
//!   where a light changed; the BLAS is then refitted, or rebuilt by the shared policy
//!   ([`crate::gpu::accel::plan_blas_work`]) when the slot count leaves the built range. A frame
//!   with no light change does no light-structure work (`light_blas_builds`,
//!   `light_blas_updates` in `--stats`). Changes made while the method is not in use wait for
//!   the next frame that uses it.
//! - **Memory** follows the light slots: when the boxes the BLAS covers have needed a quarter of
//!   the box buffer or less for a second (60 frames), the buffer is replaced by one of their
//!   power of two and everything rebuilt; after a second without ray-query lights (or without
//!   lights) the buffer and the structures are released ([`crate::gpu::upload::Shrink`]).
//! - **No box seams.** The seed cut each light off at its box and saw box-shaped artifacts
//!   around every light (§5.2.5, §6.1). Our lights' contribution reaches zero at their range
//!   (`shaders/include/lighting.glsl`), and the box holds the range sphere (for a spot light
//!   narrower than a hemisphere, the part of it inside the cone), so the box never cuts a light:
//!   the image matches tiled culling's.
//! - **Shading.** On the ray-query tier the deferred and visibility-buffer lighting compute
//!   passes run the query and trace the found lights' shadow rays inline, a ray each or one to
//!   a light drawn from them as `--direct-light` says (`shaders/include/ray_query_lights.glsl`).
//!   On the ray-tracing-pipeline tier (the lent GPUs) the lighting pass is a ray-generation
//!   shader whose any-hit shader shades each light found
//!   (`shaders/include/ray_pipeline_lights.glsl`); an any-hit shader cannot trace, so there it
//!   offers each light to a draw, and the ray-generation shader traces one shadow ray to the
//!   drawn light ([`crate::lights::sampling`]; `"shadows":"ray_pipeline"` and
//!   `"direct_light":"stochastic"` in `--stats`).

use ash::vk;
use gpu_allocator::MemoryLocation;

use crate::RenderError;
use crate::gpu::accel::{AabbAccel, AabbAccelDesc, AabbInput, AabbPlan, BlasWork, build_count};
use crate::gpu::device::GpuContext;
use crate::gpu::memory::{Buffer, Retired};
use crate::gpu::pipeline::create_compute;
use crate::gpu::shaders;
use crate::gpu::upload::{Shrink, Upload};
use crate::graph::{BufferUse, Frame, FrameGraph, PassKind, ResourceId};
use crate::layout::GpuAabb;
use crate::scene::SceneMirror;
use crate::scene::gpu::GpuScene;
use crate::stats::FrameCounters;

const BOX_BYTES: u64 = std::mem::size_of::<GpuAabb>() as u64;

/// The lights' boxes, their acceleration structures and the pass that writes the boxes.
pub struct RayQueryLights {
    /// Boxes (`capacity` of them), then the unbounded lights' count and slots.
    buffer: Option<Buffer>,
    capacity: u32,
    box_pass: vk::Pipeline,
    accel: AabbAccel,
    /// Light records changed since the structures were last brought up to date.
    pending_changes: u32,
    /// The light slot count last seen.
    seen_slots: u32,
    /// When the box buffer is far larger than the lights need, or unused.
    shrink: Shrink,
    boxes: ResourceId,
}

/// What ray-query lights do this frame.
#[derive(Clone, Copy, Debug, Default)]
pub struct RayQueryLightFrame {
    /// Device address of the lights' TLAS (0 when there is none: no lights, or not in use).
    pub tlas: vk::DeviceAddress,
    /// Device address of box 0.
    pub boxes: vk::DeviceAddress,
    /// Device address of the unbounded lights' list.
    pub unbounded: vk::DeviceAddress,
    /// Boxes the box pass writes and the BLAS covers.
    pub box_count: u32,
    work: Option<(AabbInput, AabbPlan)>,
}

impl RayQueryLights {
    /// Creates the box pass; `None` on a device without acceleration structures.
    pub fn new(ctx: &GpuContext, graph: &mut FrameGraph, layout: vk::PipelineLayout) -> Result<Option<Self>, RenderError> {
        if ctx.ray_tracing.is_none() {
            return Ok(None);
        }
        let names = AabbAccelDesc {
            blas: "light blas",
            tlas: "light tlas",
            scratch: "light as scratch",
            build_pass: "light_blas_build",
            update_pass: "light_blas_update",
            tlas_pass: "light_tlas_build",
        };
        Ok(Some(Self {
            buffer: None,
            capacity: 0,
            box_pass: create_compute(ctx, layout, "light boxes", shaders::LIGHT_BOXES_COMP)?,
            accel: AabbAccel::new(ctx, graph, names),
            pending_changes: 0,
            seen_slots: 0,
            shrink: ctx.shrink_rule(),
            boxes: graph.resource("light boxes"),
        }))
    }

    /// Follows the lights' changes (before the scene's upload consumes their marks) and, when
    /// the method is `in_use`, plans this frame's structure work and makes room for it.
    pub fn prepare(&mut self, f: &mut Frame, mirror: &SceneMirror, in_use: bool) -> Result<RayQueryLightFrame, RenderError> {
        let slots = mirror.lights.slot_count();
        // A slot count that moved (lights appended, or free slots trimmed off the end) changes
        // which boxes are padding even where no record changed.
        let moved = slots.abs_diff(std::mem::replace(&mut self.seen_slots, slots));
        self.pending_changes = self.pending_changes.saturating_add(mirror.lights.dirty_count() as u32).saturating_add(moved);
        if !in_use || slots == 0 {
            self.idle(&mut f.upload);
            return Ok(RayQueryLightFrame::default());
        }
        let need = build_count(slots, u32::MAX);
        let smaller = self.shrink.check(self.capacity as u64, need as u64, 0).map(|c| c as u32);
        if need > self.capacity || smaller.is_some() {
            // Room for the build and some growth; the boxes are all rewritten by the next build,
            // which a new buffer forces.
            let capacity = smaller.unwrap_or(need.next_power_of_two());
            let buffer = Buffer::new(f.ctx, "light boxes", Self::size(capacity), Self::USAGE, MemoryLocation::GpuOnly)?;
            if let Some(old) = self.buffer.replace(buffer) {
                match smaller {
                    Some(_) => f.upload.bury_shrunk(old, Self::size(capacity)),
                    None => f.upload.graveyard.bury(f.upload.frame_value, Retired::Buffer(old)),
                }
            }
            self.capacity = capacity;
            self.shrink.reset();
            self.accel.forget();
        }
        let address = self.buffer.as_ref().expect("allocated above").address;
        let input = AabbInput { boxes: self.boxes, address, live: slots, capacity: self.capacity, changed: self.pending_changes };
        let plan = self.accel.prepare(f, &input)?;
        self.pending_changes = 0;
        Ok(RayQueryLightFrame {
            tlas: self.accel.tlas_address(),
            boxes: address,
            unbounded: address + self.capacity as u64 * BOX_BYTES,
            box_count: plan.count,
            work: Some((input, plan)),
        })
    }

    /// A frame without ray-query lights: after [`crate::gpu::device::GpuContext::shrink_after_frames`] of
    /// them in a row the boxes and the structures are released.
    fn idle(&mut self, up: &mut Upload) {
        self.accel.idle(up);
        if self.buffer.is_some() && self.shrink.unused() {
            if let Some(old) = self.buffer.take() {
                up.bury_shrunk(old, 0);
            }
            self.capacity = 0;
        }
    }

    /// Bytes of a box buffer for `capacity` boxes: the boxes, then the unbounded lights' count
    /// and slots.
    fn size(capacity: u32) -> u64 {
        capacity as u64 * BOX_BYTES + 4 * (capacity as u64 + 1)
    }

    const USAGE: vk::BufferUsageFlags = vk::BufferUsageFlags::from_raw(
        vk::BufferUsageFlags::STORAGE_BUFFER.as_raw()
            | vk::BufferUsageFlags::TRANSFER_DST.as_raw()
            | vk::BufferUsageFlags::SHADER_DEVICE_ADDRESS.as_raw()
            | vk::BufferUsageFlags::ACCELERATION_STRUCTURE_BUILD_INPUT_READ_ONLY_KHR.as_raw(),
    );

    /// Writes the boxes and brings the structures up to date (after the scene's upload): the
    /// passes `light_unbounded_clear`, `light_boxes`, then the BLAS and TLAS builds.
    pub fn record(
        &mut self,
        f: &mut Frame,
        scene: &GpuScene,
        frame: &RayQueryLightFrame,
        counters: &mut FrameCounters,
    ) -> Result<(), RenderError> {
        let Some((input, plan)) = frame.work else { return Ok(()) };
        if plan.work == BlasWork::None {
            return Ok(());
        }
        let Some(buffer) = self.buffer.as_ref() else { return Ok(()) };
        let (raw, list_offset) = (buffer.raw, self.capacity as u64 * BOX_BYTES);
        f.pass("light_unbounded_clear", PassKind::Transfer).write(self.boxes, BufferUse::Transfer).record(|p| {
            p.cmd.fill_buffer(raw, list_offset, 4, 0);
        })?;
        let (pipeline, count) = (self.box_pass, plan.count);
        f.pass("light_boxes", PassKind::Compute).read(scene.res.tables, BufferUse::Storage).write(self.boxes, BufferUse::Storage).record(
            |p| {
                p.bind(vk::PipelineBindPoint::COMPUTE, pipeline, &p.push);
                p.cmd.dispatch(count.div_ceil(64), 1, 1);
            },
        )?;
        self.accel.record(f, &input, &plan)?;
        match plan.work {
            BlasWork::Build => counters.light_blas_builds += 1,
            BlasWork::Update => counters.light_blas_updates += 1,
            BlasWork::None => {}
        }
        Ok(())
    }

    /// What the lighting pass reads: the TLAS and BLAS, and the boxes' buffer (for the unbounded
    /// lights' list).
    pub fn reads(&self) -> Option<[ResourceId; 3]> {
        self.accel.traced().map(|[tlas, blas]| [tlas, blas, self.boxes])
    }

    /// Destroys everything; the GPU must be idle.
    pub fn destroy(self, ctx: &GpuContext) {
        self.accel.destroy(ctx);
        if let Some(b) = self.buffer {
            b.destroy(ctx);
        }
        // SAFETY: the GPU is idle.
        unsafe { ctx.destroying().destroy_pipeline(self.box_pass, None) };
    }
}
