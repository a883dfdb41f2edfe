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
//! against 0.49 ms for a standalone build of the same boxes (docs/experiments/decals-accel-structures.md). Padding
//! boxes are zero-size points at decal centres ([`crate::scene::GpuAabb::parking`]): where they
//! lie matters to NVIDIA's builder far more than how many there are.
//!
//! The structure itself and its rebuild policy are shared with the ray-query lights
//! ([`crate::gpu::accel::AabbAccel`], [`crate::gpu::accel::plan_blas_work`]): a full build when
//! the live count leaves the built range or refits have degraded the tree, a refit otherwise. A
//! frame with no decal change does no acceleration-structure work. Memory follows the decals
//! (see [`crate::gpu::accel`]): after a second (60 frames) with no decal to trace, or without a
//! ray-traced method, the structures and their scratch are released; after a second of live
//! decals needing a quarter of the BLAS storage or less, the BLAS is rebuilt into storage of its
//! own size.

use ash::vk;

use crate::RenderError;
use crate::gpu::accel::{AabbAccel, AabbAccelDesc, AabbInput, BlasWork};
use crate::gpu::device::GpuContext;
use crate::graph::{Frame, FrameGraph, ResourceId};
use crate::stats::FrameCounters;

/// The decal BLAS and TLAS.
pub struct DecalAccel {
    accel: AabbAccel,
    /// Box changes not yet applied (made while ray-traced decals were not in use).
    pending_changes: u32,
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
        let names = AabbAccelDesc {
            blas: "decal blas",
            tlas: "decal tlas",
            scratch: "decal as scratch",
            build_pass: "blas_build",
            update_pass: "blas_update",
            tlas_pass: "tlas_build",
        };
        Self { accel: AabbAccel::new(ctx, graph, names), pending_changes: 0 }
    }

    /// What a pass that traces the decals reads: the TLAS and the BLAS its instance points at
    /// (traversal reads both); `None` before the first build.
    pub fn traced(&self) -> Option<[ResourceId; 2]> {
        self.accel.traced()
    }

    /// Device address of the TLAS (0 before the first build).
    pub fn tlas_address(&self) -> vk::DeviceAddress {
        self.accel.tlas_address()
    }

    /// Refits or rebuilds the BLAS over the boxes of `input`, then rebuilds the TLAS. Records
    /// nothing when nothing changed, or when ray-traced decals are not `in_use` this frame (the
    /// changes wait for the next frame that uses them).
    pub fn build(&mut self, f: &mut Frame, input: DecalBoxInput, in_use: bool, counters: &mut FrameCounters) -> Result<(), RenderError> {
        if f.ctx.ray_tracing.is_none() {
            return Ok(());
        }
        // Changes made while ray-traced decals are not in use are applied when they are again.
        self.pending_changes += input.changed;
        if input.live == 0 || !in_use {
            self.accel.idle(&mut f.upload);
            return Ok(());
        }
        let boxes = AabbInput {
            boxes: input.tables,
            address: input.address,
            live: input.live,
            capacity: input.capacity,
            changed: std::mem::take(&mut self.pending_changes),
        };
        let plan = self.accel.prepare(f, &boxes)?;
        self.accel.record(f, &boxes, &plan)?;
        match plan.work {
            BlasWork::None => return Ok(()),
            BlasWork::Update => counters.blas_updates += 1,
            BlasWork::Build => counters.blas_builds += 1,
        }
        counters.tlas_builds += 1;
        Ok(())
    }

    /// Destroys everything; the GPU must be idle.
    pub fn destroy(self, ctx: &GpuContext) {
        self.accel.destroy(ctx);
    }
}
