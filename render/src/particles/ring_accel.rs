//! The acceleration structures of the particles' decal ring: what the ray-traced decal methods
//! and the reflection rays enumerate GPU-born decals in (the requirement that a landed
//! decal be traced the frame it lands; seed 000 §4.1's zero-length ray over decal boxes).
//!
//! **Why segments.** The ring is written in order, oldest place first, by the simulation on the
//! GPU. One BLAS over the whole ring (the first design, `crate::gpu::accel::AabbAccel`) had to
//! choose between two costs (`docs/experiments/particles-gpu.md`): refit it every frame and
//! rebuild it now and then (a build of 4,096 boxes costs 0.19 ms on the lent GPU, mostly
//! fixed: at 1,000 decals a frame the rebuilds alone were 0.14 ms a frame), or rebuild rarely
//! and let the refit tree, fitted to boxes long overwritten, slow every ray that enumerates it.
//! Here the ring is cut into segments of [`ring_segment`] places, each its own BLAS, instance
//! *k* of one TLAS holding places from *k* × segment on (shaders find the place from the
//! instance and the primitive: `decal_of_box` in `decals.glsl`). Every frame particles move,
//! all segments are refit in one build call (the boxes written this frame are covered, whatever
//! the GPU wrote). A segment is **rebuilt once after the ring's count has passed its end**,
//! that is, after every place of it was written anew, so that its tree is built over the boxes
//! it holds and no refit tree outlives a pass of the ring. The CPU learns the count a frame or
//! two late ([`crate::stats::ParticleCounts::decals_born`]); the refits cover a segment
//! meanwhile.
//!
//! Measured on the lent GPU, a build call costs 0.14 to 0.17 ms whether it rebuilds one segment
//! or twelve, so filled segments wait and are rebuilt together: once three quarters of the ring
//! is waiting, or after [`MAX_WAIT_FRAMES`] ([`REBUILD_WHEN_WAITING`] says what was measured).
//! The TLAS (one instance a segment, each BLAS at a fixed address) is updated in place.
//!
//! While nothing traces decals, nothing is refit; the frame something traces them again builds
//! every segment. After a second of frames unused, everything is released, like the other box
//! structures.

use ash::vk;
use gpu_allocator::MemoryLocation;

use crate::RenderError;
use crate::gpu::accel::{
    AccelStruct, Scratch, aabb_geometry, build_info, build_sizes, instance_bytes, instances_geometry, single_instance,
};
use crate::gpu::memory::{Buffer, Retired};
use crate::gpu::upload::{Shrink, Upload};
use crate::graph::{BufferUse, Frame, FrameGraph, PassKind, ResourceId};
use crate::layout::{DECAL_RING_SEGMENT, GpuAabb};

/// Most BLASes a ring is cut into: a larger ring has longer segments.
const MAX_SEGMENTS: usize = 64;

/// Places in one segment of a ring of `room` places (a power of two): [`DECAL_RING_SEGMENT`],
/// the whole ring when it is smaller, and longer when the ring would otherwise need more than
/// [`MAX_SEGMENTS`].
pub fn ring_segment(room: u32) -> u32 {
    room.min(DECAL_RING_SEGMENT).max(room / MAX_SEGMENTS as u32).max(1)
}

/// Marks in `rebuild` (one flag a segment of `segment` places) the segments whose last place
/// was written while the ring's count went from `seen` to `born`: every place of them was
/// written since they were last marked.
fn mark_filled(seen: u32, born: u32, segment: u32, rebuild: &mut [bool]) {
    let (from, to) = (seen / segment, born / segment);
    if to.saturating_sub(from) as usize >= rebuild.len() {
        rebuild.fill(true);
        return;
    }
    for filled in from..to {
        rebuild[filled as usize % rebuild.len()] = true;
    }
}

/// The share of the ring's segments that must be filled and waiting before they are rebuilt
/// together (a build call costs about the same for one segment as for many: 0.14 to 0.17 ms on
/// the lent GPU). `docs/experiments/particles-gpu.md` measured a quarter, a half, three quarters
/// and all: at 1,000 decals a frame, 0.142, 0.096, 0.078 and 0.070 ms a frame of building, with
/// the reflection rays no slower for the rarer builds (and 0.25 ms slower with no rebuild at
/// all).
const REBUILD_WHEN_WAITING: f32 = 0.75;

/// Frames a filled segment waits at most for its rebuild (a slow rain fills a segment now and
/// then: its refit tree would otherwise stay until three quarters of the ring filled).
const MAX_WAIT_FRAMES: u32 = 30;

/// Flags of the segments' builds: updatable (refit every frame), preferring a fast build (a
/// segment is rebuilt every time the ring passes it).
const SEGMENT_FLAGS: vk::BuildAccelerationStructureFlagsKHR = vk::BuildAccelerationStructureFlagsKHR::from_raw(
    vk::BuildAccelerationStructureFlagsKHR::PREFER_FAST_BUILD.as_raw() | vk::BuildAccelerationStructureFlagsKHR::ALLOW_UPDATE.as_raw(),
);

/// Flags of the TLAS: updatable (it is updated in place after every refit).
const TLAS_FLAGS: vk::BuildAccelerationStructureFlagsKHR = vk::BuildAccelerationStructureFlagsKHR::from_raw(
    vk::BuildAccelerationStructureFlagsKHR::PREFER_FAST_TRACE.as_raw() | vk::BuildAccelerationStructureFlagsKHR::ALLOW_UPDATE.as_raw(),
);

/// A frame's planned work on the ring's structures ([`RingAccel::prepare`]).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct RingPlan {
    /// Segments rebuilt this frame (the others are refit); all of them when the TLAS is built.
    pub rebuilt: u32,
    /// The TLAS is built (first use, or after frames that did not follow the boxes), not
    /// updated.
    pub build_tlas: bool,
}

/// The segment BLASes and the TLAS over them.
pub struct RingAccel {
    /// One BLAS a segment, all made at first use.
    segments: Vec<AccelStruct>,
    tlas: Option<AccelStruct>,
    /// The instance records (one a segment, host-written once).
    instances: Option<Buffer>,
    scratch: Scratch,
    /// Bytes of scratch each segment's build or refit has to itself in the one call.
    scratch_stride: u64,
    /// Bytes of scratch the builds need (every segment's, or the TLAS's if more).
    scratch_need: u64,
    /// Places a segment holds.
    segment: u32,
    /// Segments in the ring.
    count: u32,
    /// Every segment is built and the TLAS over them; the refits have followed the boxes.
    built: bool,
    /// Segments the ring passed the end of since their last build: rebuilt together once
    /// enough wait ([`REBUILD_WHEN_WAITING`], [`MAX_WAIT_FRAMES`]).
    rebuild: [bool; MAX_SEGMENTS],
    /// The ring's count (decals born) up to which filled segments were marked for a rebuild.
    born_seen: u32,
    /// The count the next full build starts from, when [`RingAccel::forget`] named one (a new
    /// pool's ring starts at 0 while the statistics still name the old pool's count).
    restart: Option<u32>,
    /// Frames planned since the first of the waiting segments was marked.
    waited: u32,
    shrink: Shrink,
    res: [ResourceId; 3],
}

impl RingAccel {
    /// For a ring of `room` places (a power of two); nothing is allocated until the first
    /// [`RingAccel::prepare`].
    pub fn new(ctx: &crate::gpu::device::GpuContext, graph: &mut FrameGraph, room: u32) -> Self {
        let segment = ring_segment(room);
        Self {
            segments: Vec::new(),
            tlas: None,
            instances: None,
            scratch: Scratch::new(ctx, "particle decal as scratch"),
            scratch_stride: 0,
            scratch_need: 0,
            segment,
            count: room.div_ceil(segment),
            built: false,
            rebuild: [false; MAX_SEGMENTS],
            born_seen: 0,
            waited: 0,
            restart: None,
            shrink: ctx.shrink_rule(),
            res: [
                graph.resource("particle decal tlas"),
                graph.resource("particle decal blas"),
                graph.resource("particle decal as scratch"),
            ],
        }
    }

    /// Segments (BLASes) the ring is cut into.
    pub fn segments(&self) -> u32 {
        self.count
    }

    /// Places a segment holds (the lighting record's `decal_ring_segment`).
    pub fn segment(&self) -> u32 {
        self.segment
    }

    /// What a pass that traces the ring reads: the TLAS and the segments' BLASes; `None` before
    /// the first [`RingAccel::prepare`] (whose frame builds them) and after they were released.
    pub fn traced(&self) -> Option<[ResourceId; 2]> {
        self.tlas.as_ref().map(|_| [self.res[0], self.res[1]])
    }

    /// Device address of the TLAS (0 before the first [`RingAccel::prepare`]).
    pub fn tlas_address(&self) -> vk::DeviceAddress {
        self.tlas.as_ref().map_or(0, |t| t.address)
    }

    /// Forgets the builds (a new pool's ring, or an abandoned frame): the next recorded frame
    /// builds every segment, and the ring's count starts again from `born`.
    pub fn forget(&mut self, born: u32) {
        self.built = false;
        self.restart = Some(born);
    }

    /// A frame that does not follow the ring's boxes (nothing traces decals). After
    /// [`crate::gpu::device::GpuContext::shrink_after_frames`] of them in a row everything is released.
    pub fn idle(&mut self, up: &mut Upload) {
        if self.tlas.is_none() || !self.shrink.unused() {
            return;
        }
        tracing::debug!("unused particle decal structures released");
        self.release(up);
    }

    /// Lets everything go (into the graveyard); the next [`RingAccel::prepare`] makes them anew.
    fn release(&mut self, up: &mut Upload) {
        for a in self.segments.drain(..).chain(self.tlas.take()) {
            up.count_shrink(a.buffer.size, 0);
            a.bury(up.graveyard, up.frame_value);
        }
        if let Some(old) = self.instances.take() {
            up.graveyard.bury(up.frame_value, Retired::Buffer(old));
        }
        self.scratch.release(up);
        self.built = false;
    }

    /// Plans the frame's work, the GPU having counted `born` decals by the last statistics that
    /// came back: every segment built when the structures are not built (or `stale`: boxes
    /// were written while nothing followed them), else every segment refit, and the segments
    /// the count passed the end of marked, then rebuilt together once enough are marked or the
    /// first has waited long enough. Makes the structures on first use; after this the TLAS
    /// address is final for the frame.
    pub fn prepare(&mut self, f: &mut Frame, born: u32, stale: bool) -> Result<RingPlan, RenderError> {
        self.shrink.reset();
        if stale {
            self.built = false;
        }
        if self.tlas.is_none() {
            // All or nothing: a failed allocation leaves nothing behind, and the next frame
            // tries again.
            self.built = false;
            if let Err(e) = self.allocate(f) {
                self.release(&mut f.upload);
                return Err(e);
            }
        }
        if !self.built {
            self.born_seen = self.restart.take().unwrap_or(born);
            return Ok(RingPlan { rebuilt: self.count, build_tlas: true });
        }
        // A count below the last seen is a new pool's (the statistics may name the old one's
        // for a frame or two after it was replaced).
        self.born_seen = self.born_seen.min(born);
        mark_filled(self.born_seen, born, self.segment, &mut self.rebuild[..self.count as usize]);
        self.born_seen = born;
        let waiting = self.rebuild[..self.count as usize].iter().filter(|&&r| r).count() as u32;
        self.waited = if waiting > 0 { self.waited + 1 } else { 0 };
        // A build call costs about the same for one segment as for many: the filled ones wait
        // until enough of the ring has filled, or long enough, and are rebuilt together.
        let due = waiting as f32 >= REBUILD_WHEN_WAITING * self.count as f32 || self.waited > MAX_WAIT_FRAMES;
        Ok(RingPlan { rebuilt: if due { waiting } else { 0 }, build_tlas: false })
    }

    /// Makes the segments (each sized for its boxes), the TLAS, the instance records and scratch
    /// for every segment's build at once.
    fn allocate(&mut self, f: &mut Frame) -> Result<(), RenderError> {
        let ctx = f.ctx;
        let geometry = aabb_geometry(0);
        let blas = build_sizes(ctx, vk::AccelerationStructureTypeKHR::BOTTOM_LEVEL, SEGMENT_FLAGS, &geometry, &[self.segment]);
        let tlas_sizes = build_sizes(ctx, vk::AccelerationStructureTypeKHR::TOP_LEVEL, TLAS_FLAGS, &[instances_geometry(0)], &[self.count]);
        self.scratch_stride = blas.build_scratch_size.max(blas.update_scratch_size).next_multiple_of(self.scratch.alignment());
        self.scratch_need =
            (self.scratch_stride * self.count as u64).max(tlas_sizes.build_scratch_size.max(tlas_sizes.update_scratch_size));
        let mut records = Vec::with_capacity(self.count as usize);
        for _ in 0..self.count {
            let s = AccelStruct::new(
                ctx,
                vk::AccelerationStructureTypeKHR::BOTTOM_LEVEL,
                blas.acceleration_structure_size,
                "particle decal blas",
            )?;
            records.push(single_instance(s.address, 1));
            self.segments.push(s);
        }
        let bytes = records.len() * std::mem::size_of::<vk::AccelerationStructureInstanceKHR>();
        let mut instances = Buffer::new(
            ctx,
            "particle decal instances",
            bytes as u64,
            vk::BufferUsageFlags::ACCELERATION_STRUCTURE_BUILD_INPUT_READ_ONLY_KHR | vk::BufferUsageFlags::SHADER_DEVICE_ADDRESS,
            MemoryLocation::CpuToGpu,
        )?;
        for (dst, r) in
            instances.mapped()[..bytes].chunks_exact_mut(std::mem::size_of::<vk::AccelerationStructureInstanceKHR>()).zip(&records)
        {
            dst.copy_from_slice(instance_bytes(r));
        }
        self.instances = Some(instances);
        self.scratch.ensure(ctx, f.upload.graveyard, f.upload.frame_value, self.scratch_need)?;
        // Last: a TLAS means everything is made.
        self.tlas = Some(AccelStruct::new(
            ctx,
            vk::AccelerationStructureTypeKHR::TOP_LEVEL,
            tlas_sizes.acceleration_structure_size,
            "particle decal tlas",
        )?);
        Ok(())
    }

    /// Records the planned work over the ring's boxes (`boxes`, from `address`), after the
    /// simulation that writes them: one build call that rebuilds or refits every segment, then
    /// the TLAS built or updated. Names its BLAS pass `particle_decal_blas_build` when some
    /// segment is rebuilt, `particle_decal_blas_update` when all are refit.
    pub fn record(&mut self, f: &mut Frame, boxes: ResourceId, address: vk::DeviceAddress, plan: &RingPlan) -> Result<(), RenderError> {
        let (Some(tlas), Some(instances)) = (self.tlas.as_ref(), self.instances.as_ref()) else {
            return Err(RenderError::Other("particle decal structures recorded without prepare".into()));
        };
        let scratch = self.scratch.ensure(f.ctx, f.upload.graveyard, f.upload.frame_value, self.scratch_need)?;
        let (segments, rebuild, built, rebuilding) = (&self.segments, &self.rebuild, self.built, plan.rebuilt > 0);
        let (stride, places, [tlas_res, blas_res, scratch_res]) = (self.scratch_stride, self.segment, self.res);
        let name = if plan.rebuilt > 0 { "particle_decal_blas_build" } else { "particle_decal_blas_update" };
        f.pass(name, PassKind::AccelBuild)
            .read(boxes, BufferUse::BuildInput)
            .write(blas_res, BufferUse::Accel)
            .write(scratch_res, BufferUse::Accel)
            .record(|p| {
                let n = segments.len();
                let mut geometries = [aabb_geometry(0)[0]; MAX_SEGMENTS];
                for (k, g) in geometries[..n].iter_mut().enumerate() {
                    *g = aabb_geometry(address + (k as u64 * places as u64) * std::mem::size_of::<GpuAabb>() as u64)[0];
                }
                let mut infos = [vk::AccelerationStructureBuildGeometryInfoKHR::default(); MAX_SEGMENTS];
                for (k, info) in infos[..n].iter_mut().enumerate() {
                    let update = built && !(rebuilding && rebuild[k]);
                    *info = build_info(
                        vk::AccelerationStructureTypeKHR::BOTTOM_LEVEL,
                        SEGMENT_FLAGS,
                        segments[k].raw,
                        update,
                        std::slice::from_ref(&geometries[k]),
                        scratch + k as u64 * stride,
                    );
                }
                let range = [vk::AccelerationStructureBuildRangeInfoKHR::default().primitive_count(places)];
                let ranges = [&range[..]; MAX_SEGMENTS];
                // Every segment's boxes lie in the ring (`places` each from its start), made
                // visible to builds by the pass's declaration; each build has its own scratch.
                p.cmd.build_acceleration_structures(&infos[..n], &ranges[..n]);
            })?;
        let (instances, count, update_tlas) = (instances.address, self.count, !plan.build_tlas);
        f.pass("particle_decal_tlas_build", PassKind::AccelBuild)
            .read(blas_res, BufferUse::Accel)
            .write(tlas_res, BufferUse::Accel)
            .write(scratch_res, BufferUse::Accel)
            .record(|p| {
                let geometry = [instances_geometry(instances)];
                let info = build_info(vk::AccelerationStructureTypeKHR::TOP_LEVEL, TLAS_FLAGS, tlas.raw, update_tlas, &geometry, scratch);
                let ranges = [vk::AccelerationStructureBuildRangeInfoKHR::default().primitive_count(count)];
                // The instance records are host-written once, before the first submission.
                p.cmd.build_acceleration_structures(&[info], &[&ranges[..]]);
            })?;
        if plan.rebuilt > 0 || !self.built {
            self.rebuild.fill(false);
            self.waited = 0;
        }
        self.built = true;
        Ok(())
    }

    /// Destroys everything; the GPU must be idle.
    pub fn destroy(self, ctx: &crate::gpu::device::GpuContext) {
        for a in self.segments.into_iter().chain(self.tlas) {
            a.destroy(ctx);
        }
        if let Some(b) = self.instances {
            b.destroy(ctx);
        }
        self.scratch.destroy(ctx);
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn segments_cut_the_ring_into_at_most_max_segments() {
        assert_eq!(ring_segment(2), 2, "a small ring is one segment");
        assert_eq!(ring_segment(4096), DECAL_RING_SEGMENT);
        assert_eq!(ring_segment(1 << 20) * MAX_SEGMENTS as u32, 1 << 20, "a large ring has longer segments");
        for room in (0..24).map(|b| 1u32 << b) {
            assert!(room.div_ceil(ring_segment(room)) as usize <= MAX_SEGMENTS);
            assert_eq!(room % ring_segment(room), 0, "{room}: whole segments");
        }
    }

    #[test]
    fn a_segment_is_rebuilt_once_the_ring_passed_its_end() {
        let marked = |seen, born| {
            let mut rebuild = [false; 4];
            mark_filled(seen, born, 256, &mut rebuild);
            rebuild
        };
        assert_eq!(marked(0, 255), [false; 4], "segment 0 not yet full");
        assert_eq!(marked(200, 256), [true, false, false, false], "segment 0 filled");
        assert_eq!(marked(256, 511), [false; 4], "segment 1 still filling");
        assert_eq!(marked(300, 800), [false, true, true, false], "two segments filled in one step");
        assert_eq!(marked(1000, 1100), [false, false, false, true], "segment 3 filled");
        assert_eq!(marked(1100, 1300), [true, false, false, false], "the ring wrapped: segment 0 again");
        assert_eq!(marked(0, 5000), [true; 4], "more than the ring: every segment");
        assert_eq!(marked(700, 700), [false; 4], "nothing born");
    }
}
