//! The decal acceleration structures (seed 000 §4.2.1, made incremental): one BLAS of AABB
//! geometry over the decals' boxes, and a TLAS holding one instance of it.
//!
//! The seed built both once for static, pre-placed decals. Gameplay spawns and despawns decals
//! every frame, so here the boxes are kept dense ([`crate::scene::DecalTable`]: a despawn moves
//! the last box into the hole) and the BLAS is built over the live boxes rounded up to a
//! *granule* of 1/16 of the count's power of two (at least 64): the few boxes past the live ones
//! are zero-size points that belong to no decal. Spawning (into the next padding box),
//! despawning (moving the last box) and moving are then all a refit
//! (`VK_BUILD_ACCELERATION_STRUCTURE_MODE_UPDATE_KHR`, which cannot change the primitive count)
//! until the count leaves the built range, and a build costs what a build of the live boxes
//! costs (padding under 1/8). Our first version built over the table's power-of-two capacity
//! with every free slot parked: at 100,000 decals (131,072 built) an H100 took 1.33 ms per build
//! against 0.49 ms for a standalone build of the same boxes (docs/BENCHMARKS.md). Padding
//! boxes are zero-size points at decal centres ([`crate::scene::GpuAabb::parking`]): where they
//! lie matters to NVIDIA's builder far more than how many there are.
//!
//! Rebuild policy ([`plan_blas_work`]): a full build when the live count leaves the built range
//! (grows past it, or falls more than two granules below it), and when the boxes refitted since
//! the last build add up to a quarter of the built count: a refit keeps the tree's topology, so
//! as boxes move away from where they were when the tree was built its nodes grow and overlap,
//! and traversal slows. The BLAS is built with `PREFER_FAST_TRACE | ALLOW_UPDATE`; the TLAS is
//! rebuilt (one instance: microseconds) whenever the BLAS changed. A frame with no decal change
//! does no acceleration-structure work.

use ash::vk;
use gpu_allocator::MemoryLocation;

use crate::RenderError;
use crate::gpu::accel::{AccelStruct, Scratch, build_sizes, instance_bytes, single_instance};
use crate::gpu::device::GpuContext;
use crate::gpu::memory::{Buffer, Graveyard, Retired};
use crate::graph::{BufferUse, Frame, FrameGraph, PassKind, ResourceId};
use crate::scene::{FrameCounters, GpuAabb};

/// Fraction of the built boxes that may be refitted before the BLAS is rebuilt.
pub const REBUILD_AFTER_REFIT_FRACTION: f32 = 0.25;

/// The step the built primitive count moves in for `live` boxes: 1/16 of its power of two, at
/// least 64.
pub fn build_granule(live: u32) -> u32 {
    (live.next_power_of_two() / 16).max(64)
}

/// How many boxes a build over `live` boxes covers (the box table holds at least `capacity`):
/// `live` rounded up to its granule.
pub fn build_count(live: u32, capacity: u32) -> u32 {
    live.next_multiple_of(build_granule(live)).min(capacity)
}

/// What happened to the BLAS this frame.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum BlasWork {
    /// Nothing changed.
    None,
    /// Boxes moved, appeared or vanished within the built range: refit.
    Update,
    /// The live count left the built range, or refits degraded the tree: full build.
    Build,
}

/// Chooses the BLAS work for a frame with `live` boxes of which `changed` were rewritten, when
/// the last build covered `built` boxes (the rebuild policy, as a pure function).
pub fn plan_blas_work(built: Option<u32>, live: u32, changed: u32, refitted_since_build: u64) -> BlasWork {
    match built {
        None => BlasWork::Build,
        Some(b) if live > b || live + 2 * build_granule(live) < b => BlasWork::Build,
        _ if changed == 0 => BlasWork::None,
        Some(b) if (refitted_since_build + changed as u64) as f32 > b as f32 * REBUILD_AFTER_REFIT_FRACTION => BlasWork::Build,
        _ => BlasWork::Update,
    }
}

/// The decal BLAS and TLAS.
pub struct DecalAccel {
    blas: Option<AccelStruct>,
    tlas: Option<AccelStruct>,
    instances: Option<Buffer>,
    scratch: Scratch,
    /// Boxes the last build covered.
    built: Option<u32>,
    refitted_since_build: u64,
    pending_changes: u32,
    res: AccelResources,
}

/// The frame-graph resources of the decal acceleration structures.
#[derive(Clone, Copy, Debug)]
struct AccelResources {
    blas: ResourceId,
    tlas: ResourceId,
    scratch: ResourceId,
}

/// The decal boxes a build reads: at `address` in the scene's record tables, the first `live`
/// of them the live decals', the table holding `capacity` (padding boxes past the live ones);
/// `changed` were rewritten this frame.
#[derive(Clone, Copy, Debug)]
pub struct DecalBoxInput {
    /// The graph resource holding the boxes.
    pub tables: ResourceId,
    /// Device address of box 0.
    pub address: vk::DeviceAddress,
    /// Live decals (their boxes come first).
    pub live: u32,
    /// Boxes the table holds.
    pub capacity: u32,
    /// Boxes rewritten this frame.
    pub changed: u32,
}

impl DecalAccel {
    /// Empty; nothing is allocated until the first decal appears.
    pub fn new(ctx: &GpuContext, graph: &mut FrameGraph) -> Self {
        Self {
            blas: None,
            tlas: None,
            instances: None,
            scratch: Scratch::new(ctx, "decal scratch"),
            built: None,
            refitted_since_build: 0,
            pending_changes: 0,
            res: AccelResources {
                blas: graph.resource("decal blas"),
                tlas: graph.resource("decal tlas"),
                scratch: graph.resource("decal as scratch"),
            },
        }
    }

    /// What a pass that traces the decals reads: the TLAS and the BLAS its instance points at
    /// (traversal reads both); `None` before the first build.
    pub fn traced(&self) -> Option<[ResourceId; 2]> {
        self.tlas.as_ref().map(|_| [self.res.tlas, self.res.blas])
    }

    /// Device address of the TLAS (0 before the first build).
    pub fn tlas_address(&self) -> vk::DeviceAddress {
        self.tlas.as_ref().map_or(0, |t| t.address)
    }

    /// Refits or rebuilds the BLAS over the boxes of `input`, then rebuilds the TLAS, as the
    /// passes `blas_update` or `blas_build`, then `tlas_build`. Records nothing when nothing
    /// changed, or when ray-traced decals are not `in_use` this frame (the changes wait for the
    /// next frame that uses them).
    pub fn build(&mut self, f: &mut Frame, input: DecalBoxInput, in_use: bool, counters: &mut FrameCounters) -> Result<(), RenderError> {
        let ctx = f.ctx;
        let (graveyard, frame_value) = (&mut *f.upload.graveyard, f.upload.frame_value);
        let (aabbs, live, changed) = (input.address, input.live, input.changed);
        let Some(rt) = ctx.ray_tracing.as_ref() else { return Ok(()) };
        // Changes made while ray-traced decals are not in use are applied when they are again.
        self.pending_changes += changed;
        if live == 0 || !in_use {
            return Ok(());
        }
        let changed = std::mem::take(&mut self.pending_changes);
        let work = plan_blas_work(self.built, live, changed, self.refitted_since_build);
        if work == BlasWork::None {
            return Ok(());
        }
        // A refit covers what the last build covered (an update cannot change the count).
        let count = match (work, self.built) {
            (BlasWork::Update, Some(built)) => built,
            _ => build_count(live, input.capacity),
        };
        let asx = &rt.acceleration_structure;

        let geometry = [vk::AccelerationStructureGeometryKHR::default()
            .geometry_type(vk::GeometryTypeKHR::AABBS)
            .geometry(vk::AccelerationStructureGeometryDataKHR {
                aabbs: vk::AccelerationStructureGeometryAabbsDataKHR::default()
                    .data(vk::DeviceOrHostAddressConstKHR { device_address: aabbs })
                    .stride(std::mem::size_of::<GpuAabb>() as u64),
            })
            .flags(vk::GeometryFlagsKHR::OPAQUE)];
        let blas_flags = vk::BuildAccelerationStructureFlagsKHR::PREFER_FAST_TRACE | vk::BuildAccelerationStructureFlagsKHR::ALLOW_UPDATE;
        let blas_sizes = build_sizes(ctx, vk::AccelerationStructureTypeKHR::BOTTOM_LEVEL, blas_flags, &geometry, &[count]);
        let tlas_geometry_for = |address: vk::DeviceAddress| {
            [vk::AccelerationStructureGeometryKHR::default().geometry_type(vk::GeometryTypeKHR::INSTANCES).geometry(
                vk::AccelerationStructureGeometryDataKHR {
                    instances: vk::AccelerationStructureGeometryInstancesDataKHR::default()
                        .data(vk::DeviceOrHostAddressConstKHR { device_address: address }),
                },
            )]
        };
        let tlas_flags = vk::BuildAccelerationStructureFlagsKHR::PREFER_FAST_TRACE;
        let tlas_sizes = build_sizes(ctx, vk::AccelerationStructureTypeKHR::TOP_LEVEL, tlas_flags, &tlas_geometry_for(0), &[1]);

        // (Re)allocate for a larger count. The old structures may still be read by a frame in
        // flight, so they go to the graveyard.
        if work == BlasWork::Build && self.blas.as_ref().is_none_or(|b| b.buffer.size < blas_sizes.acceleration_structure_size) {
            let blas = AccelStruct::new(
                ctx,
                vk::AccelerationStructureTypeKHR::BOTTOM_LEVEL,
                blas_sizes.acceleration_structure_size,
                "decal blas",
            )?;
            if let Some(old) = self.blas.replace(blas) {
                old.bury(graveyard, frame_value);
            }
            self.write_instance(ctx, graveyard, frame_value)?;
        }
        if self.tlas.is_none() {
            self.tlas = Some(AccelStruct::new(
                ctx,
                vk::AccelerationStructureTypeKHR::TOP_LEVEL,
                tlas_sizes.acceleration_structure_size,
                "decal tlas",
            )?);
        }
        let scratch_need = blas_sizes.build_scratch_size.max(blas_sizes.update_scratch_size).max(tlas_sizes.build_scratch_size);
        let scratch_address = self.scratch.ensure(ctx, graveyard, frame_value, scratch_need)?;
        let blas = self.blas.as_ref().expect("built above");
        let tlas = self.tlas.as_ref().expect("created above");

        let update = work == BlasWork::Update;
        let res = self.res;
        f.pass(if update { "blas_update" } else { "blas_build" }, PassKind::AccelBuild)
            .read(input.tables, BufferUse::BuildInput)
            .write(res.blas, BufferUse::Accel)
            .write(res.scratch, BufferUse::Accel)
            .record(|p| {
                let mut info = vk::AccelerationStructureBuildGeometryInfoKHR::default()
                    .ty(vk::AccelerationStructureTypeKHR::BOTTOM_LEVEL)
                    .flags(blas_flags)
                    .mode(if update { vk::BuildAccelerationStructureModeKHR::UPDATE } else { vk::BuildAccelerationStructureModeKHR::BUILD })
                    .dst_acceleration_structure(blas.raw)
                    .geometries(&geometry)
                    .scratch_data(vk::DeviceOrHostAddressKHR { device_address: scratch_address });
                if update {
                    info = info.src_acceleration_structure(blas.raw);
                }
                let ranges = [vk::AccelerationStructureBuildRangeInfoKHR::default().primitive_count(count)];
                // SAFETY: `cmd` is recording; the AABB buffer holds at least `count` boxes, made visible
                // to builds by the pass's declaration; scratch is large enough.
                unsafe { asx.cmd_build_acceleration_structures(p.cmd, &[info], &[&ranges[..]]) };
            })?;
        let instances = self.instances.as_ref().expect("written with the BLAS").address;
        f.pass("tlas_build", PassKind::AccelBuild)
            .read(res.blas, BufferUse::Accel)
            .write(res.tlas, BufferUse::Accel)
            .write(res.scratch, BufferUse::Accel)
            .record(|p| {
                let geometry = tlas_geometry_for(instances);
                let info = vk::AccelerationStructureBuildGeometryInfoKHR::default()
                    .ty(vk::AccelerationStructureTypeKHR::TOP_LEVEL)
                    .flags(tlas_flags)
                    .mode(vk::BuildAccelerationStructureModeKHR::BUILD)
                    .dst_acceleration_structure(tlas.raw)
                    .geometries(&geometry)
                    .scratch_data(vk::DeviceOrHostAddressKHR { device_address: scratch_address });
                let ranges = [vk::AccelerationStructureBuildRangeInfoKHR::default().primitive_count(1)];
                // SAFETY: as above; the instance buffer is host-written before submission.
                unsafe { asx.cmd_build_acceleration_structures(p.cmd, &[info], &[&ranges[..]]) };
            })?;

        counters.tlas_builds += 1;
        if update {
            counters.blas_updates += 1;
            self.refitted_since_build += changed as u64;
        } else {
            counters.blas_builds += 1;
            self.refitted_since_build = 0;
            self.built = Some(count);
        }
        Ok(())
    }

    fn write_instance(&mut self, ctx: &GpuContext, graveyard: &mut Graveyard, frame_value: u64) -> Result<(), RenderError> {
        let blas = self.blas.as_ref().expect("called after the BLAS exists");
        let instance = single_instance(blas.address);
        // A new buffer rather than rewriting one a frame in flight may be reading.
        let mut buffer = Buffer::new(
            ctx,
            "decal tlas instance",
            std::mem::size_of::<vk::AccelerationStructureInstanceKHR>() as u64,
            vk::BufferUsageFlags::ACCELERATION_STRUCTURE_BUILD_INPUT_READ_ONLY_KHR | vk::BufferUsageFlags::SHADER_DEVICE_ADDRESS,
            MemoryLocation::CpuToGpu,
        )?;
        let bytes = instance_bytes(&instance);
        buffer.mapped()[..bytes.len()].copy_from_slice(bytes);
        if let Some(old) = self.instances.replace(buffer) {
            graveyard.bury(frame_value, Retired::Buffer(old));
        }
        Ok(())
    }

    /// Destroys everything; the GPU must be idle.
    pub fn destroy(self, ctx: &GpuContext) {
        for a in [self.blas, self.tlas].into_iter().flatten() {
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
    fn rebuild_policy() {
        assert_eq!(plan_blas_work(None, 50, 0, 0), BlasWork::Build, "first use builds");
        assert_eq!(plan_blas_work(Some(64), 50, 0, 10), BlasWork::None, "no change, no work");
        assert_eq!(plan_blas_work(Some(64), 50, 3, 0), BlasWork::Update, "moves refit");
        assert_eq!(plan_blas_work(Some(64), 64, 1, 0), BlasWork::Update, "a spawn into the padding refits");
        assert_eq!(plan_blas_work(Some(64), 65, 1, 0), BlasWork::Build, "growing past the built range rebuilds");
        assert_eq!(plan_blas_work(Some(64), 60, 8, 8), BlasWork::Update, "16 of 64 refitted: still a refit");
        assert_eq!(plan_blas_work(Some(64), 60, 9, 8), BlasWork::Build, "beyond a quarter: rebuild");
        assert_eq!(plan_blas_work(Some(4096), 3900, 1, 0), BlasWork::Update, "a despawn within the range refits");
        assert_eq!(plan_blas_work(Some(4096), 3000, 1, 0), BlasWork::Build, "far below the range: rebuild smaller");
    }

    #[test]
    fn builds_cover_the_live_boxes_and_little_more() {
        for live in [1, 63, 64, 65, 1000, 10_000, 100_000, 1_000_000] {
            let count = build_count(live, u32::MAX);
            assert!(count >= live && count - live < build_granule(live), "{live} live: {count} built");
            assert!(live < 1024 || count as f32 <= live as f32 * 1.125, "{live} live: {count} built, over 1/8 padding");
            assert_eq!(plan_blas_work(Some(count), live, 1, 0), BlasWork::Update, "{live}: a build's own count refits");
        }
        assert_eq!(build_count(100_000, 100_352), 100_352, "never past the table");
    }
}
