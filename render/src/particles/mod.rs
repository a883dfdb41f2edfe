//! GPU particles: sparks, dust and debris that live, move, collide and draw without a trip
//! through the CPU. None of the seeds treats effects; seed 000 §3.2 and §5.1.2 give the
//! screen-space surface reconstruction (positions and normals from depth) that the collision
//! uses, and the drawing reads the tiled light lists of seed 001 §4.2.
//!
//! **What the CPU does.** Emitters live in the scene mirror ([`Emitters`], written by the ECS
//! extraction when an emitter is spawned, edited, moved or despawned). Each frame the CPU turns
//! their rates and bursts into a few *emission jobs* (one per emitting emitter: how many
//! particles, which invocations), and writes them with the frame's time step into a small
//! host-visible record of its frame slot. Nothing on the CPU is per particle: a frame costs the
//! same at 100 particles as at a million (the counters say so: `bytes_uploaded` is the jobs
//! and, when they change, the emitters).
//!
//! **What the GPU does** (one buffer for the state, one for the pool; `shaders/particles_*`):
//!
//! 1. *Input*: the record is copied into the state (only when it changed), and this frame's
//!    drawn list is emptied.
//! 2. *Emission* (`particles_emit.comp`, one invocation per new particle): each pops a slot off
//!    the free list (a stack with an atomic count; a pop that finds it empty counts a `dropped`
//!    particle) and starts it: position in the emitter's sphere, direction in its cone about +Y,
//!    speed and life between their bounds, from a hash of the job's seed.
//! 3. *Simulation* (`particle_simulate.glsl`, one invocation per pool slot, after the frame's
//!    opaque depth exists): ageing, a step of [`step`] (acceleration, drag), and collision:
//!    - *with the scene's acceleration structure*, on the ray-tracing tiers in a frame that
//!      traces it anyway (shadows, ambient occlusion or reflections: particles alone never wake
//!      the structure, whose refits a crowd pays for): the step is a ray, its first hit the
//!      contact, the hit triangle's normal the surface's (`particle_rays.glsl`; a ray query in
//!      `particles_simulate.comp`'s `RAY_QUERY_COLLISION` variant, a traced ray from
//!      `particles_simulate.rgen` on the lent GPUs, which have no ray queries). Particles land on
//!      what is off screen or hidden too;
//!    - *with the depth buffer* otherwise: a particle whose new position lies behind the visible
//!      surface, by less than a thickness (twice its step, at least 10 cm, so it does not collide
//!      with what merely hides it), touched that surface; the contact point is where its step
//!      crosses the surface's plane, whose normal is rebuilt from depth (`depth_normals.glsl`).
//!
//!    It then dies, bounces (restitution along the normal, friction along the surface) or
//!    sticks, as its emitter says. The dead are pushed back on the free list; the living are
//!    appended to the drawn list (in compute counted by subgroup, so that the count's atomic is
//!    taken once a subgroup). `counters.particles.ray_traced` says which collision a frame used.
//! 4. *Drawing* (`particle.vert`, `particle.frag`): one indirect draw of camera-facing sprites
//!    over the drawn list (one triangle each, around the sprite's quad or round dot: the lent
//!    GPU's drawing is bound by triangles, and two a sprite took 1.04 ms for 100,000, one 0.61;
//!    its vertex count written by the light pass from the drawn list's length), after every surface is shaded and before temporal anti-aliasing, bloom and
//!    exposure, so sparks glow and bloom like any bright surface. Colour and size follow the
//!    particle's age; the colour is premultiplied radiance (alpha 0 adds light, alpha 1 covers:
//!    [`crate::gpu::pipeline::Blend::Premultiplied`]), so glowing sparks need no sorting and smoke
//!    blends "over". Particles are depth-tested against the opaque depth, fade out near the
//!    surface behind them (soft particles), and take the lights of their pixel's tile (a matte
//!    sprite facing each light) as much as their emitter's `lit` says.
//!
//! **Statistics.** The GPU counts particles started, landed (first contact with a surface),
//! dropped (pool full) and alive; they come back two frames later with the frame that measured
//! them ([`ParticleCounts`], `counters.particles`).
//!
//! 5. *Motion* (under temporal anti-aliasing, `particle.frag`'s `MOTION` variant): where a sprite
//!    covers more than half a pixel, the particle's own motion (its quad now, and moved back by
//!    its velocity over the frame's step, which is exactly what the step moved it) replaces the
//!    motion of the surface behind, so the anti-aliasing follows a fast spark instead of
//!    smearing it along the background.
//!
//! **Not yet.** Without ray tracing, collision is with what the depth buffer shows: particles
//! off screen or behind other surfaces fly through. In the deferred pipeline with glass, the
//! depth the particles are tested, faded and (without ray tracing) collided against holds the
//! glass too (on its odd rows when interlaced, whole when depth-peeled), so a particle behind
//! glass is hidden there. Elsewhere blended glass is drawn before the particles, so a particle behind glass is
//! drawn over it. Particles leave no decals yet.

use ash::vk;
use gpu_allocator::MemoryLocation;

pub use crate::scene::emitters::{DecalRing, Emitter, Emitters, step};

mod ring_accel;

use ring_accel::{RingAccel, RingPlan};

use crate::RenderError;
use crate::gpu::FRAMES_IN_FLIGHT;
use crate::gpu::device::{GpuContext, Tier};
use crate::gpu::memory::{Buffer, Retired};
use crate::gpu::pipeline::{Blend, GraphicsDesc, HitGroup, RayTracingDesc, RayTracingPipeline, create_compute, create_graphics};
use crate::gpu::shaders;
use crate::graph::readback::StatsReadback;
use crate::graph::targets::{DEPTH, DEPTH_FORMAT, HDR, HDR_FORMAT, MotionVectors};
use crate::graph::{BufferUse, Frame, FrameGraph, ImageUse, Load, PassKind, ResourceId};
use crate::layout::{GpuAabb, GpuDecal, GpuEmission, GpuEmitter, GpuParticle, GpuParticleState, PARTICLE_GROUP};
use crate::lights::{LightFrame, declare_light_reads};
use crate::scene::gpu::{DecalRingFields, GpuScene};
use crate::stats::{FrameCounters, ParticleCounts};

/// A decal a landing particle left, as read back from the ring ([`Particles::read_decals`]):
/// what a game needs to keep it (to save it, or to make it a decal of its own).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct BornDecal {
    /// Where the particle landed (the box's centre), world space.
    pub position: glam::Vec3,
    /// The surface's normal there (the box's +Z, pointing out of the surface).
    pub normal: glam::Vec3,
    /// The box's local +X (turned about the normal at random), unit length.
    pub tangent: glam::Vec3,
    /// The box's side along the surface, metres.
    pub size: f32,
    /// The box's depth across the surface, metres.
    pub depth: f32,
    /// Its decal material's slot (`GpuEmitter::decal_material`).
    pub material: u32,
    /// When it has faded out, on the scene's clock (`GpuCamera::time`, seconds); `None`: it
    /// lasts until the ring overwrites it.
    pub expires: Option<f32>,
}

impl BornDecal {
    /// What a ring record says (`leave_decal` in `shaders/include/particle_simulate.glsl`
    /// writes it).
    fn from_record(r: &GpuDecal) -> Self {
        let to_world = r.world_to_decal.inverse();
        let (x, z) = (to_world.x_axis.truncate(), to_world.z_axis.truncate());
        // life = saturate(time × scale + offset) reaches 0 at −offset / scale.
        let expires = (r.life_scale < 0.0).then(|| -r.life_offset / r.life_scale);
        BornDecal {
            position: to_world.w_axis.truncate(),
            normal: z.normalize_or_zero(),
            tangent: x.normalize_or_zero(),
            size: x.length(),
            depth: z.length(),
            material: r.material_channel & ((1 << crate::layout::DECAL_CHANNEL_SHIFT) - 1),
            expires,
        }
    }
}

/// Pool slots when the settings name none.
pub const DEFAULT_CAPACITY: u32 = 1 << 16;

/// Places in the GPU-born decals' ring when the settings name none.
pub const DEFAULT_DECAL_ROOM: u32 = 4096;

/// Bytes of one place of the decal ring: its record and its box.
const DECAL_BYTES: u64 = (std::mem::size_of::<GpuDecal>() + std::mem::size_of::<GpuAabb>()) as u64;

/// Jobs the state's job array holds at first (it doubles when a frame has more).
const FIRST_JOB_ROOM: u32 = 64;

/// The GPU side: the state (frame input, counters, jobs, emitter table) and the pool (particles,
/// free list, drawn list), made the first frame an emitter exists.
struct ParticleBuffers {
    state: Buffer,
    pool: Buffer,
    /// Host-visible copies of the input, one per frame slot.
    inputs: Vec<Buffer>,
    job_room: u32,
    emitter_room: u32,
    /// The pool's slots have not been put on the free list yet.
    fresh: bool,
}

impl ParticleBuffers {
    fn new(ctx: &GpuContext, capacity: u32, decal_room: u32, job_room: u32, emitter_room: u32) -> Result<Self, RenderError> {
        let usage = vk::BufferUsageFlags::STORAGE_BUFFER
            | vk::BufferUsageFlags::SHADER_DEVICE_ADDRESS
            | vk::BufferUsageFlags::TRANSFER_DST
            | vk::BufferUsageFlags::TRANSFER_SRC;
        let input_bytes = input_bytes(job_room, emitter_room);
        let state =
            Buffer::new(ctx, "particle state", input_bytes, usage | vk::BufferUsageFlags::INDIRECT_BUFFER, MemoryLocation::GpuOnly)?;
        // Particles, then the free list, the drawn list (a word each) and the light (two words);
        // then the decal ring's records and boxes.
        let pool_bytes = capacity as u64 * (std::mem::size_of::<GpuParticle>() as u64 + 16) + decal_room as u64 * DECAL_BYTES;
        // The decal ring's boxes are its structures' build input.
        let build_input = match ctx.ray_tracing {
            Some(_) => vk::BufferUsageFlags::ACCELERATION_STRUCTURE_BUILD_INPUT_READ_ONLY_KHR,
            None => vk::BufferUsageFlags::empty(),
        };
        let pool = Buffer::new(ctx, "particle pool", pool_bytes, usage | build_input, MemoryLocation::GpuOnly)?;
        let mut inputs = Vec::with_capacity(FRAMES_IN_FLIGHT);
        for _ in 0..FRAMES_IN_FLIGHT {
            inputs.push(Buffer::new(ctx, "particle input", input_bytes, vk::BufferUsageFlags::TRANSFER_SRC, MemoryLocation::CpuToGpu)?);
        }
        Ok(Self { state, pool, inputs, job_room, emitter_room, fresh: true })
    }

    fn retire(self, f: &mut Frame) {
        for b in [self.state, self.pool].into_iter().chain(self.inputs) {
            f.upload.graveyard.bury(f.upload.frame_value, Retired::Buffer(b));
        }
    }

    fn destroy(self, ctx: &GpuContext) {
        for b in [self.state, self.pool].into_iter().chain(self.inputs) {
            b.destroy(ctx);
        }
    }
}

/// Bytes of the state: the record, the jobs, the emitter table.
fn input_bytes(job_room: u32, emitter_room: u32) -> u64 {
    emitters_offset(job_room) + emitter_room as u64 * std::mem::size_of::<GpuEmitter>() as u64
}

fn jobs_offset() -> u64 {
    std::mem::size_of::<GpuParticleState>() as u64
}

fn emitters_offset(job_room: u32) -> u64 {
    (jobs_offset() + job_room as u64 * std::mem::size_of::<GpuEmission>() as u64).next_multiple_of(16)
}

/// Address of the decal ring's boxes in the pool at `pool` (after the particles, their three
/// lists and the ring's records).
fn ring_boxes(pool: vk::DeviceAddress, capacity: u32, decal_room: u32) -> vk::DeviceAddress {
    pool + capacity as u64 * (std::mem::size_of::<GpuParticle>() as u64 + 16) + decal_room as u64 * std::mem::size_of::<GpuDecal>() as u64
}

/// Bytes of the record the CPU writes: up to the GPU's counters.
const RECORD_INPUT_BYTES: u64 = std::mem::offset_of!(GpuParticleState, free_count) as u64;

/// This frame's plan, from [`Particles::prepare`].
#[derive(Clone, Copy, Debug, Default)]
struct Plan {
    active: bool,
    spawn: u32,
    jobs: u32,
    /// The record or the jobs differ from what the state holds.
    copy_record: bool,
    /// The emitter table was rewritten.
    copy_emitters: u32,
}

/// The particle passes and their buffers.
pub struct Particles {
    init: vk::Pipeline,
    light: vk::Pipeline,
    emit: vk::Pipeline,
    simulate: vk::Pipeline,
    /// The simulation with ray-query collision (the ray-query tier).
    simulate_ray_query: Option<vk::Pipeline>,
    /// The simulation as a ray-generation pass (the ray-tracing-pipeline tier), made the first
    /// frame that traces; its layout.
    simulate_rays: Option<(std::sync::OnceLock<RayTracingPipeline>, vk::PipelineLayout)>,
    draw: vk::Pipeline,
    /// The drawing's motion-vector variant (under temporal anti-aliasing).
    motion: vk::Pipeline,
    capacity: u32,
    /// Places in the GPU-born decals' ring.
    decal_room: u32,
    gpu: Option<ParticleBuffers>,
    readback: StatsReadback,
    res: ResourceId,
    jobs: Vec<GpuEmission>,
    /// The record the state holds (its CPU-written part).
    record: GpuParticleState,
    plan: Plan,
    seed: u32,
    last: ParticleCounts,
    /// Particles the CPU did not ask for because a frame wanted more than the pool holds
    /// (counted as dropped).
    cut: u64,
    /// This frame recorded the new pool's initialisation.
    init_recorded: bool,
    /// A frame was abandoned after writing the record: the next copies it whatever it holds.
    force_copy: bool,
    /// The decal ring's BLASes and TLAS (devices with acceleration structures), and this
    /// frame's work on them (planned in `prepare`, recorded after the simulation wrote the
    /// boxes).
    ring_accel: Option<RingAccel>,
    ring_plan: Option<RingPlan>,
    /// Some emitter has left decals: the ring is enumerated with the scene's decals.
    ring_on: bool,
    /// Frames moved particles while the ring's structures were not followed (nothing traced
    /// decals): the next frame that traces them rebuilds them.
    ring_stale: bool,
}

impl Particles {
    /// Creates the pipelines; the buffers (`capacity` pool slots) are made the first frame an
    /// emitter exists.
    pub fn new(
        ctx: &GpuContext,
        graph: &mut FrameGraph,
        layout: vk::PipelineLayout,
        capacity: u32,
        decal_room: u32,
    ) -> Result<Self, RenderError> {
        let compute = |name, spirv| create_compute(ctx, layout, name, spirv);
        let desc = GraphicsDesc {
            name: "particles",
            vertex: shaders::PARTICLE_VERT,
            fragment: Some(shaders::PARTICLE_FRAG),
            mesh_vertices: false,
            color_formats: &[HDR_FORMAT],
            depth_format: Some(DEPTH_FORMAT),
            depth_compare: Some(vk::CompareOp::GREATER_OR_EQUAL),
            depth_write: false,
            topology: vk::PrimitiveTopology::TRIANGLE_LIST,
            blend: Blend::Premultiplied,
            write_masks: &[],
            samples: 1,
        };
        let counters = std::mem::size_of::<GpuParticleState>() as u64;
        Ok(Self {
            init: compute("particle pool init", shaders::PARTICLES_INIT_COMP)?,
            light: compute("particle light", shaders::PARTICLES_LIGHT_COMP)?,
            emit: compute("particle emission", shaders::PARTICLES_EMIT_COMP)?,
            simulate: compute("particle simulation", shaders::PARTICLES_SIMULATE_COMP)?,
            simulate_ray_query: match ctx.tier {
                Tier::RayQuery => Some(compute("particle simulation (ray queries)", shaders::PARTICLES_SIMULATE_COMP_RAY_QUERY_COLLISION)?),
                _ => None,
            },
            simulate_rays: (ctx.tier != Tier::RayQuery && ctx.ray_support().ray_pipeline).then(|| (std::sync::OnceLock::new(), layout)),
            draw: create_graphics(ctx, layout, &desc)?,
            motion: create_graphics(
                ctx,
                layout,
                &GraphicsDesc {
                    name: "particle motion",
                    vertex: shaders::PARTICLE_VERT_MOTION,
                    fragment: Some(shaders::PARTICLE_FRAG_MOTION),
                    blend: Blend::Replace,
                    ..desc
                },
            )?,
            capacity: capacity.max(PARTICLE_GROUP),
            decal_room: decal_room.max(1).next_power_of_two(),
            gpu: None,
            readback: StatsReadback::new(ctx, graph, "particle statistics", counters)?,
            res: graph.resource("particles"),
            jobs: Vec::new(),
            record: GpuParticleState::default(),
            plan: Plan::default(),
            seed: 0,
            last: ParticleCounts { measured_frame: u64::MAX, ..Default::default() },
            cut: 0,
            init_recorded: false,
            force_copy: false,
            // The ring's structures: segments rebuilt as the ring fills them, refit between
            // (`ring_accel`, which says why).
            ring_accel: ctx.ray_tracing.is_some().then(|| RingAccel::new(ctx, graph, decal_room.max(1).next_power_of_two())),
            ring_plan: None,
            ring_on: false,
            ring_stale: false,
        })
    }

    /// Before the scene's upload: advances the emitters by `delta` seconds into this frame's
    /// jobs, makes the buffers the first time an emitter exists (and grows the job and emitter
    /// arrays when they no longer fit), writes the frame's record into its slot's input and
    /// puts the state's address in the lighting record. Adds what came back from the GPU to
    /// `counters`. The decal ring's structures are refit after the simulation only when
    /// `decals_traced` (a ray-traced decal method, or reflections that show decals); a frame
    /// that traces them after frames that did not rebuilds them first.
    pub fn prepare(
        &mut self,
        f: &mut Frame,
        scene: &mut GpuScene,
        emitters: &mut Emitters,
        delta: f32,
        decals_traced: bool,
        counters: &mut FrameCounters,
    ) -> Result<(), RenderError> {
        self.init_recorded = false;
        self.read_counts(f);
        counters.particles = self.last;
        self.plan = Plan::default();
        self.ring_plan = None;
        let result = self.plan_frame(f, scene, emitters, delta, decals_traced, counters);
        scene.set_decal_ring(self.ring_fields());
        result
    }

    /// [`Particles::prepare`] but for the lighting record's decal ring.
    fn plan_frame(
        &mut self,
        f: &mut Frame,
        scene: &mut GpuScene,
        emitters: &mut Emitters,
        delta: f32,
        decals_traced: bool,
        counters: &mut FrameCounters,
    ) -> Result<(), RenderError> {
        if self.gpu.is_none() && emitters.slot_count() == 0 {
            scene.set_particles(0);
            return Ok(());
        }
        self.ring_on |= emitters.leaves_decals() && self.gpu.is_some();
        self.seed = self.seed.wrapping_add(1);
        let (spawn, cut) = emitters.advance(delta, self.seed, self.capacity, &mut self.jobs);
        self.cut += cut;
        if !emitters.active() && spawn == 0 {
            // No particle can be alive: nothing to move or draw, nothing written (what changed
            // waits in the emitters until a frame has particles). The decal ring's structures
            // may still have to catch up with boxes written while nothing traced them.
            return self.plan_ring(f, emitters.leaves_decals(), decals_traced, false);
        }
        let jobs = self.jobs.len() as u32;
        let (job_room, emitter_room) = match &self.gpu {
            Some(g) => (g.job_room, g.emitter_room),
            None => (FIRST_JOB_ROOM, 16),
        };
        let need = (jobs.max(1).next_power_of_two().max(job_room), emitters.slot_count().next_power_of_two().max(emitter_room));
        if self.gpu.is_none() || need != (job_room, emitter_room) {
            // Jobs or emitters outgrew their room (rare): the state and the pool are made again
            // and the particles alive are lost.
            if let Some(old) = self.gpu.take() {
                old.retire(f);
            }
            self.gpu = Some(ParticleBuffers::new(f.ctx, self.capacity, self.decal_room, need.0, need.1)?);
            self.readback.forget();
            emitters.mark_all_dirty();
            self.record = GpuParticleState::default();
            // The new pool's ring is empty, its count starts again.
            if let Some(accel) = self.ring_accel.as_mut() {
                accel.forget(0);
            }
        }
        self.ring_on |= emitters.leaves_decals();
        // The ring's structures, refit after this frame's simulation (which may write boxes).
        self.plan_ring(f, emitters.leaves_decals(), decals_traced, true)?;
        let gpu = self.gpu.as_mut().expect("made above");
        let pool = gpu.pool.address;
        let particle_bytes = self.capacity as u64 * std::mem::size_of::<GpuParticle>() as u64;
        let record = GpuParticleState {
            pool,
            free_list: pool + particle_bytes,
            alive_list: pool + particle_bytes + self.capacity as u64 * 4,
            light_list: pool + particle_bytes + self.capacity as u64 * 8,
            decals: pool + particle_bytes + self.capacity as u64 * 16,
            decal_boxes: ring_boxes(pool, self.capacity, self.decal_room),
            decal_room: self.decal_room,
            emitters: gpu.state.address + emitters_offset(gpu.job_room),
            capacity: self.capacity,
            job_count: jobs,
            spawn_count: spawn,
            delta: delta.max(0.0),
            collide: 1,
            ..Default::default()
        };
        let input = gpu.inputs[f.slot()].mapped();
        let mut copy_emitters = 0;
        if let Some(records) = emitters.take_dirty() {
            let at = emitters_offset(gpu.job_room) as usize;
            let room = gpu.emitter_room as usize * std::mem::size_of::<GpuEmitter>();
            let dst: &mut [GpuEmitter] = bytemuck::cast_slice_mut(&mut input[at..at + room]);
            for (d, r) in dst.iter_mut().zip(records) {
                *d = r;
                copy_emitters += 1;
            }
        }
        let copy_record = jobs > 0 || record != self.record || std::mem::take(&mut self.force_copy);
        let job_bytes = self.jobs.len() * std::mem::size_of::<GpuEmission>();
        if copy_record {
            input[..RECORD_INPUT_BYTES as usize].copy_from_slice(&bytemuck::bytes_of(&record)[..RECORD_INPUT_BYTES as usize]);
            let at = jobs_offset() as usize;
            input[at..at + job_bytes].copy_from_slice(bytemuck::cast_slice(&self.jobs));
            self.record = record;
            counters.bytes_uploaded += RECORD_INPUT_BYTES + job_bytes as u64;
        }
        counters.bytes_uploaded += copy_emitters as u64 * std::mem::size_of::<GpuEmitter>() as u64;
        self.plan = Plan { active: true, spawn, jobs, copy_record, copy_emitters };
        scene.set_particles(gpu.state.address);
        Ok(())
    }

    /// Plans this frame's work on the decal ring's structures (recorded after the simulation
    /// by [`Particles::simulate`]): none while no emitter leaves decals; while nothing traces
    /// decals, none (the structures are released after a while, like the scene's decal
    /// structures) but the ring is marked stale when particles `moving` may write boxes; while
    /// decals are traced, a refit each frame particles move with the segments the ring filled
    /// rebuilt ([`ring_accel`]), and a rebuild the first frame after boxes were written unseen.
    fn plan_ring(&mut self, f: &mut Frame, leaves_decals: bool, decals_traced: bool, moving: bool) -> Result<(), RenderError> {
        let (Some(accel), true) = (self.ring_accel.as_mut(), self.gpu.is_some()) else { return Ok(()) };
        if !leaves_decals {
            return Ok(());
        }
        if !decals_traced {
            self.ring_stale |= moving;
            accel.idle(&mut f.upload);
            return Ok(());
        }
        // Nothing wrote boxes since the structures followed them (which still exist).
        if !moving && !self.ring_stale && accel.traced().is_some() {
            return Ok(());
        }
        // Segments the ring filled since (by what the GPU counted a frame or two back) are
        // rebuilt, the others refit; every one after frames that did not follow the boxes.
        self.ring_plan = Some(accel.prepare(f, self.last.decals_born, std::mem::take(&mut self.ring_stale))?);
        Ok(())
    }

    /// The ring of decals that landing particles leave, once some emitter has left decals
    /// ([`DecalRing`]), which every pass that applies decals reads.
    pub fn decal_ring(&self) -> Option<DecalRing> {
        // What the state holds (the record copied by the last frame that moved particles), so
        // that the CPU's decal count and the GPU's ring agree.
        let traced = self.ring_accel.as_ref().and_then(RingAccel::traced);
        (self.gpu.is_some() && self.ring_on).then_some(DecalRing { room: self.decal_room, res: self.res, traced })
    }

    /// The decal ring as the lighting record names it: records, boxes, TLAS, places and the
    /// places of a segment of its structure.
    fn ring_fields(&self) -> Option<DecalRingFields> {
        let r = &self.record;
        let (tlas, segment) = self.ring_accel.as_ref().map_or((0, r.decal_room), |a| (a.tlas_address(), a.segment()));
        (self.gpu.is_some() && self.ring_on && r.decal_room > 0).then_some(DecalRingFields {
            records: r.decals,
            boxes: r.decal_boxes,
            tlas,
            room: r.decal_room,
            segment,
        })
    }

    /// Whether this frame has particles to move or draw.
    pub fn active(&self) -> bool {
        self.plan.active && self.gpu.is_some()
    }

    /// Once the frame's opaque depth exists: copies the frame's input into the state, starts
    /// this frame's particles, moves every particle and lists the living for drawing; copies the
    /// counters for the CPU. Particles collide with the scene's structure when the frame traces
    /// it (`traced`: the TLAS and BLAS resources) and the device traces rays, else with the depth
    /// buffer. Records nothing while no particle can be alive.
    pub fn simulate(
        &mut self,
        f: &mut Frame,
        scene: &GpuScene,
        traced: Option<[ResourceId; 2]>,
        counters: &mut FrameCounters,
    ) -> Result<(), RenderError> {
        if !self.active() {
            // No particle moves, but the decal ring's structures may catch up.
            return self.record_ring(f, counters);
        }
        let gpu = self.gpu.as_mut().expect("active");
        let (plan, res, slot) = (self.plan, self.res, f.slot());
        let (state, pool, input) = (gpu.state.raw, gpu.pool.raw, gpu.inputs[slot].raw);
        let emitters_at = emitters_offset(gpu.job_room);
        let fresh = std::mem::take(&mut gpu.fresh);
        self.init_recorded = fresh;
        let pool_bytes = gpu.pool.size;
        let draw_at = std::mem::offset_of!(GpuParticleState, draw_count) as u64;
        f.pass("particles_input", PassKind::Transfer).write(res, BufferUse::Transfer).record(|p| {
            // At most three regions, on the stack (a steady frame allocates nothing).
            let mut regions = [vk::BufferCopy::default(); 3];
            let mut n = 0;
            let mut region = |src_offset, size| {
                regions[n] = vk::BufferCopy { src_offset, dst_offset: src_offset, size };
                n += 1;
            };
            if plan.copy_record {
                let jobs = plan.jobs as u64 * std::mem::size_of::<GpuEmission>() as u64;
                region(0, RECORD_INPUT_BYTES);
                if jobs > 0 {
                    region(jobs_offset(), jobs);
                }
            }
            if plan.copy_emitters > 0 {
                region(emitters_at, plan.copy_emitters as u64 * std::mem::size_of::<GpuEmitter>() as u64);
            }
            if n > 0 {
                p.cmd.copy_buffer(input, state, &regions[..n]);
            }
            if fresh {
                // Every slot free (lifetime 0), the counters zero.
                p.cmd.fill_buffer(pool, 0, pool_bytes, 0);
                p.cmd.fill_buffer(state, RECORD_INPUT_BYTES, draw_at - RECORD_INPUT_BYTES, 0);
            }
            // This frame's drawn list starts empty (the simulation counts it in `draw[1]`; the
            // light pass turns that into the drawing's vertex count, `sprites`).
            p.cmd.update_buffer(state, draw_at, bytemuck::bytes_of(&[1u32, 0, 0, 0, 0, 0, 0]));
        })?;
        let groups = self.capacity.div_ceil(PARTICLE_GROUP);
        let pass = |f: &mut Frame, name, pipeline, groups: u32| {
            f.pass(name, PassKind::Compute).read(scene.res.tables, BufferUse::Storage).write(res, BufferUse::Storage).record(|p| {
                let push = p.push;
                p.bind(vk::PipelineBindPoint::COMPUTE, pipeline, &push);
                p.cmd.dispatch(groups, 1, 1);
            })
        };
        if fresh {
            pass(f, "particles_init", self.init, groups.max(self.decal_room.div_ceil(PARTICLE_GROUP)))?;
        }
        if plan.spawn > 0 {
            pass(f, "particles_emit", self.emit, plan.spawn.div_ceil(PARTICLE_GROUP))?;
        }
        let accel = traced.into_iter().flatten().map(|r| (r, BufferUse::Accel));
        let rays = match (&self.simulate_rays, traced) {
            (Some((made, layout)), Some(_)) => Some(match made.get() {
                Some(rays) => rays,
                None => {
                    let desc = RayTracingDesc {
                        name: "particle simulation (rays)",
                        raygen: &[shaders::PARTICLES_SIMULATE_RGEN],
                        misses: &[shaders::PARTICLES_RMISS],
                        hit_groups: &[HitGroup { closest_hit: Some(shaders::PARTICLES_RCHIT), any_hit: None, intersection: None }],
                    };
                    let rays = RayTracingPipeline::new(f.ctx, *layout, &desc)?;
                    made.get_or_init(|| rays)
                }
            }),
            _ => None,
        };
        let capacity = self.capacity;
        if let Some(rays) = rays {
            f.pass("particles_simulate", PassKind::RayTracing)
                .sample(&DEPTH)
                .read(scene.res.tables, BufferUse::Storage)
                .read(scene.res.meshes, BufferUse::Storage)
                .reads(accel)
                .write(res, BufferUse::Storage)
                .record(|p| {
                    let push = p.push;
                    p.bind(vk::PipelineBindPoint::RAY_TRACING_KHR, rays.pipeline, &push);
                    rays.trace(p.cmd, 0, vk::Extent2D { width: capacity, height: 1 });
                })?;
        } else {
            let queries = self.simulate_ray_query.filter(|_| traced.is_some());
            let pipeline = queries.unwrap_or(self.simulate);
            f.pass("particles_simulate", PassKind::Compute)
                .sample(&DEPTH)
                .read(scene.res.tables, BufferUse::Storage)
                .when(queries.is_some(), |p| p.read(scene.res.meshes, BufferUse::Storage))
                .reads(accel)
                .write(res, BufferUse::Storage)
                .record(|p| {
                    let push = p.push;
                    p.bind(vk::PipelineBindPoint::COMPUTE, pipeline, &push);
                    p.cmd.dispatch(groups, 1, 1);
                })?;
        }
        counters.particles.ray_traced = traced.is_some() && (self.simulate_ray_query.is_some() || self.simulate_rays.is_some());
        // The ring's structures follow the boxes the simulation just wrote.
        self.record_ring(f, counters)?;
        self.readback.record(f, "particles_statistics", res, state)
    }

    /// Records the decal ring's structures' work planned by [`Particles::prepare`], if any.
    fn record_ring(&mut self, f: &mut Frame, counters: &mut FrameCounters) -> Result<(), RenderError> {
        let (Some(accel), Some(plan), Some(gpu)) = (self.ring_accel.as_mut(), self.ring_plan.take(), self.gpu.as_ref()) else {
            return Ok(());
        };
        accel.record(f, self.res, ring_boxes(gpu.pool.address, self.capacity, self.decal_room), &plan)?;
        counters.blas_builds += u64::from(plan.rebuilt);
        counters.blas_updates += u64::from(accel.segments() - plan.rebuilt);
        counters.tlas_builds += 1;
        Ok(())
    }

    /// Lights the living particles by `lights` (in compute, a particle at a time), then draws
    /// them over the HDR target (before temporal anti-aliasing and bloom). Records nothing while
    /// no particle can be alive.
    pub fn draw(&self, f: &mut Frame, scene: &GpuScene, lights: &LightFrame) -> Result<(), RenderError> {
        if !self.active() {
            return Ok(());
        }
        let (light, groups, res) = (self.light, self.capacity.div_ceil(PARTICLE_GROUP), self.res);
        let pass = f.pass("particles_light", PassKind::Compute).reads(scene.res.shaded()).write(res, BufferUse::Storage);
        declare_light_reads(pass, lights).record(|p| {
            let push = p.push;
            p.bind(vk::PipelineBindPoint::COMPUTE, light, &push);
            p.cmd.dispatch(groups, 1, 1);
        })?;
        let gpu = self.gpu.as_ref().expect("active");
        let (pipeline, args, at) = (self.draw, gpu.state.raw, std::mem::offset_of!(GpuParticleState, sprites) as u64);
        let pass = f
            .pass("particles", PassKind::Graphics)
            .image(&DEPTH, ImageUse::DepthTestSampled)
            .color(&HDR, Load::Keep)
            .read(scene.res.tables, BufferUse::Storage)
            .read(scene.res.textures, BufferUse::SampledImages)
            .read(self.res, BufferUse::Storage)
            .read(self.res, BufferUse::Indirect);
        let count_at = std::mem::offset_of!(GpuParticleState, draw_count) as u64;
        declare_light_reads(pass, lights).record(|p| {
            let push = p.push;
            p.bind_graphics(pipeline, &push);
            p.cmd.set_cull_mode(vk::CullModeFlags::NONE);
            p.cmd.draw_indirect_one(args, at, args, count_at);
        })
    }

    /// Under temporal anti-aliasing, once the motion vectors exist: where a particle covers
    /// more than half a pixel, its own motion replaces the surface's (`motion`, which the
    /// anti-aliasing then reads). Records nothing while no particle can be alive.
    pub fn motion(&self, f: &mut Frame, scene: &GpuScene, motion: MotionVectors) -> Result<(), RenderError> {
        if !self.active() {
            return Ok(());
        }
        let gpu = self.gpu.as_ref().expect("active");
        let (pipeline, args) = (self.motion, gpu.state.raw);
        let (at, count_at) =
            (std::mem::offset_of!(GpuParticleState, sprites) as u64, std::mem::offset_of!(GpuParticleState, draw_count) as u64);
        f.pass("particles_motion", PassKind::Graphics)
            .image(&DEPTH, ImageUse::DepthTestSampled)
            .color(motion.target, Load::Keep)
            .read(scene.res.tables, BufferUse::Storage)
            .read(scene.res.textures, BufferUse::SampledImages)
            .read(self.res, BufferUse::Storage)
            .read(self.res, BufferUse::Indirect)
            .record(|p| {
                let push = p.push;
                p.bind_graphics(pipeline, &push);
                p.cmd.draw_indirect_one(args, at, args, count_at);
            })
    }

    /// A frame that was recorded but never submitted (an error after [`Particles::prepare`]):
    /// what it would have written into the state is written again by the next frame (the
    /// record, every emitter, and a new pool's initialisation).
    pub fn abandon(&mut self, emitters: &mut Emitters) {
        // Its ring work may not have run: the next frame that traces decals rebuilds.
        self.ring_plan = None;
        self.ring_stale = true;
        if let Some(accel) = self.ring_accel.as_mut() {
            accel.forget(self.last.decals_born);
        }
        self.force_copy = true;
        emitters.mark_all_dirty();
        if let Some(gpu) = self.gpu.as_mut().filter(|_| std::mem::take(&mut self.init_recorded)) {
            gpu.fresh = true;
        }
    }

    /// What the GPU counted in the frame whose statistics came back last.
    pub fn counts(&self) -> ParticleCounts {
        self.last
    }

    fn read_counts(&mut self, f: &Frame) {
        let Some((frame, words)) = self.readback.take(f) else { return };
        let state: GpuParticleState = bytemuck::pod_read_unaligned(bytemuck::cast_slice(words));
        let (spawned, landed, alive, decals_born) = (state.spawned, state.landed, state.draw[1], state.decals_born);
        let dropped = (state.dropped as u64 + self.cut).min(u32::MAX as u64) as u32;
        // The readback names the frame by its timeline value, one past its number.
        self.last = ParticleCounts {
            measured_frame: frame.saturating_sub(1),
            alive,
            spawned,
            landed,
            dropped,
            capacity: self.capacity,
            ray_traced: false,
            decals_born,
        };
    }

    /// The decals landing particles left that the ring still holds, oldest first, read back
    /// from the GPU (the GPU must be idle: [`crate::Renderer::read_particle_decals`] waits).
    /// Empty before any particle left one.
    pub fn read_decals(&self, ctx: &GpuContext, graph: &mut FrameGraph) -> Result<Vec<BornDecal>, RenderError> {
        let Some(gpu) = self.gpu.as_ref().filter(|_| self.ring_on) else { return Ok(Vec::new()) };
        let state = graph.read_back_buffer(ctx, self.res, gpu.state.raw, std::mem::size_of::<GpuParticleState>() as u64)?;
        let born = bytemuck::pod_read_unaligned::<GpuParticleState>(&state).decals_born;
        let room = self.decal_room;
        let at = self.capacity as u64 * (std::mem::size_of::<GpuParticle>() as u64 + 16);
        let bytes = graph.read_back_buffer_range(ctx, self.res, gpu.pool.raw, at, room as u64 * DECAL_BYTES)?;
        let (records, boxes) = bytes.split_at(room as usize * std::mem::size_of::<GpuDecal>());
        let held = born.min(room);
        // The oldest held is at the next place to be written once the ring has wrapped.
        let first = if born > room { born % room } else { 0 };
        let place = |i: u32| (first + i) % room;
        Ok((0..held)
            .map(place)
            .filter(|&k| {
                let b: GpuAabb =
                    bytemuck::pod_read_unaligned(&boxes[k as usize * std::mem::size_of::<GpuAabb>()..][..std::mem::size_of::<GpuAabb>()]);
                b.slot == (crate::layout::GPU_DECAL | k)
            })
            .map(|k| {
                BornDecal::from_record(&bytemuck::pod_read_unaligned(
                    &records[k as usize * std::mem::size_of::<GpuDecal>()..][..std::mem::size_of::<GpuDecal>()],
                ))
            })
            .collect())
    }

    /// Destroys the pipelines and buffers; the GPU must be idle.
    pub fn destroy(self, ctx: &GpuContext) {
        for p in [self.init, self.light, self.emit, self.simulate, self.draw, self.motion].into_iter().chain(self.simulate_ray_query) {
            // SAFETY: the GPU is idle.
            unsafe { ctx.destroying().destroy_pipeline(p, None) };
        }
        if let Some(rays) = self.simulate_rays.and_then(|(made, _)| made.into_inner()) {
            rays.destroy(ctx);
        }
        if let Some(g) = self.gpu {
            g.destroy(ctx);
        }
        if let Some(a) = self.ring_accel {
            a.destroy(ctx);
        }
        self.readback.destroy(ctx);
    }
}
