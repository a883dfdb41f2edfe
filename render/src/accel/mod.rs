//! The scene's acceleration structures, which shadow rays, traced ambient occlusion and traced
//! reflections are traced against (seed 001 §4.3 built them once for a static glTF scene; here
//! change detection keeps them): a triangle BLAS per mesh and one TLAS over the mesh instances.
//! A technique of its own because several read it: the frame function prepares it, hands its
//! [`SceneAccelFrame`] to the lights, the shadows, the occlusion and the skinning, and records
//! its builds after the scene's upload.
//!
//! - **BLAS per mesh**, built (`PREFER_FAST_TRACE | ALLOW_COMPACTION`) in the frame that uploads
//!   the mesh, then compacted: the build writes its compacted size into a query, and when that
//!   frame has finished (two frames later, with no wait) a copy into a structure of that size
//!   replaces it. A dropped mesh's BLAS goes to the graveyard.
//! - **TLAS** over every instance slot: instance *i* is slot *i*, its custom index the slot (so
//!   any-hit shaders find the instance record, its mesh and material), free slots and meshes
//!   without a BLAS are inactive (a null BLAS reference). The instance records are written on
//!   the GPU (`shaders/scene_instances.comp`) from the instance table the scene already uploads,
//!   so the CPU writes nothing per instance. It is *updated* when only transforms changed and
//!   rebuilt when instances were added or removed or changed mesh or material, when a BLAS
//!   changed (built, compacted, dropped), or when the updates since the last build add up to the
//!   instance count (updates keep the tree's topology and it degrades as things move).
//! - **Alpha-masked and blended materials**: opaque instances get `FORCE_OPAQUE`, masked and
//!   blended ones `FORCE_NO_OPAQUE`, so shadow rays run the any-hit test
//!   (`shaders/include/alpha_mask.glsl`) on exactly the geometry that needs it: foliage casts
//!   foliage-shaped shadows, and glass filters the light that crosses it (coloured shadows).
//!
//! A frame with no change records no acceleration-structure work (`scene_blas_builds`,
//! `scene_tlas_builds` and `scene_tlas_updates` in the counters say what each frame did).
//!
//! **Dormant while nothing traces the scene.** With ray-traced shadows, ray-traced ambient
//! occlusion and traced reflections all off (the frame's lighting decides: `wanted` in
//! [`SceneAccel::prepare`]), the structures are *dormant*: no BLAS is built, refit or compacted,
//! no TLAS built or updated, and none of it recorded, however many skinned characters move (a
//! crowd of 10,000 foxes refit 10,000 BLASes a frame that nothing read). What changes is still
//! followed (new and dropped meshes, the instance count), so the frame a consumer comes back
//! catches up at once: the meshes that arrived are built, every posed mesh is refit to the pose
//! the skinning pass last wrote (or rebuilt where refits would have degraded it), and the TLAS is
//! built anew; that frame traces the current scene. (A posed mesh whose last skinning wrote only
//! the vertices of its level of detail, `crate::scene::poses::REST_FRAMES`, is skinned whole the
//! next frame and refit then: its shadow shows its pose from before the dormancy for up to two
//! frames.)
//!
//! **Small characters wait.** A crowd's far characters cover a few pixels each, and refitting all
//! of them every frame was the structures' whole cost (10,000 foxes: 3.3 ms of GPU and a
//! millisecond of recording a frame). A posed mesh shorter on screen than
//! [`crate::settings::FrameSettings::refit_pixels`] (48 px by default; the height of the sphere
//! around its instance's bounds) is refit in the frames of one frame slot (one frame in two, the
//! meshes spread over the slots by id), never later than [`MAX_REFIT_STALENESS`] (1) frame after
//! its pose changed: its shadow, occlusion and reflections show a pose at most a frame (17 ms at
//! 60 frames a second) older than the drawn one, where the pose moves a pixel or two at most. Following
//! the slots keeps each slot's command buffer the same from frame to frame, so it is submitted
//! again as recorded: the driver's cost of recording thousands of refits is paid once. For the
//! same reason a mesh's class (every frame, or its slot's turn) is decided once in
//! [`REFIT_CLASS_FRAMES`] frames, not every frame: a walking crowd's characters cross the limit
//! a few a frame, and each crossing changed the commands (one that grows past twice the limit
//! is refit every frame at once, so a structure a frame behind is never drawn taller than
//! that). Its
//! vertices are already the new pose's, so a hit reads attributes a frame newer than the box it
//! hit; for a character this small (under twice the limit) that is a pixel or two. Characters off screen are
//! judged by size too (their shadows may fall in view). The counters say how many refits were
//! deferred and how far behind the stalest structure is.
//!
//! **Memory.** The TLAS and its instance records follow the instance table's slot count, which
//! falls when the highest instances go ([`crate::scene::SceneMirror::trim`]): grown to the
//! count's power of two when it passes the room, shrunk to it (never below 64 instances) when
//! it has stayed at or below a quarter of the room for a second (60 frames,
//! [`crate::gpu::upload::Shrink`]), and rebuilt then, the scratch following. With no instance
//! there is no TLAS to trace (nothing casts a shadow). A mesh's BLAS goes with its mesh.

use ash::vk;
use gpu_allocator::MemoryLocation;

use crate::RenderError;
use crate::gpu::FRAMES_IN_FLIGHT;
use crate::gpu::accel::{AccelStruct, Scratch, build_info, build_sizes, instances_geometry};
use crate::gpu::device::GpuContext;
use crate::gpu::memory::{Buffer, Graveyard, Retired};
use crate::gpu::pipeline::create_compute;
use crate::gpu::shaders;
use crate::gpu::upload::Shrink;
use crate::graph::{BufferUse, Frame, FrameGraph, PassKind, ResourceId};
use crate::scene::gpu::GpuScene;
use crate::scene::{GpuVertex, MeshId, SceneMirror};
use crate::stats::FrameCounters;

/// Compacted-size queries that can be pending at once (more new meshes in flight stay
/// uncompacted).
const QUERIES: u32 = 256;

struct MeshBlas {
    accel: AccelStruct,
    /// The query its compacted size goes to, until it is compacted.
    query: Option<u32>,
    /// Frame value whose completion makes the query's result available.
    built_in: u64,
    /// Built this frame; the build is recorded after the upload.
    needs_build: bool,
    /// A compacted copy made this frame from the structure in the graveyard: (source, dest).
    compact_from: Option<vk::AccelerationStructureKHR>,
    primitives: u32,
    /// A posed mesh's refit state (its BLAS allows updates and is never compacted).
    posed: Option<PosedBlas>,
}

/// How far a posed mesh's BLAS has drifted from the pose it was built for.
#[derive(Clone, Copy, Debug)]
struct PosedBlas {
    /// Refits since the build.
    refits: u32,
    /// Surface area of the posed bounds it was built for.
    built_area: f32,
    /// Surface area of the latest pose's bounds.
    area: f32,
    /// Refit this frame (after the skinning pass).
    needs_refit: bool,
    /// Scratch bytes a refit needs (asked of the driver once, at creation).
    update_scratch: u64,
    /// Its pose changed and it waits for a refit (listed in `SceneAccel::waiting`).
    waiting: bool,
    /// Frames its structure has held an older pose than the one drawn (deferred refits).
    stale: u32,
    /// Tall enough on screen to be refit every frame its pose changes (with hysteresis).
    large: bool,
    /// The [`REFIT_CLASS_FRAMES`] epoch `large` was decided in (`None`: not yet).
    classified: Option<u64>,
}

/// Refits recorded per `vkCmdBuildAccelerationStructuresKHR` call.
const REFIT_BATCH: usize = 64;

/// A posed mesh smaller on screen than [`crate::settings::FrameSettings::refit_pixels`] has its
/// refit deferred for at most this many frames: its shadow, occlusion and reflection show a pose
/// at most this many frames older than the one drawn (17 ms at 60 frames a second). One frame in
/// [`FRAMES_IN_FLIGHT`], the one of its frame slot, is its turn: so each slot's frames refit the
/// same structures and its command buffer is submitted again as recorded. (A turn of one frame
/// in four, not following the slots, was measured: its refits cost 0.58 instead of 3.34 ms of
/// GPU for 10,000 foxes, but every frame was recorded anew, and the driver took 5.6 ms more of
/// CPU for it.)
pub const MAX_REFIT_STALENESS: u32 = FRAMES_IN_FLIGHT as u32 - 1;

/// A posed mesh refit every frame stays so until it is shorter than this fraction of
/// `refit_pixels` on screen.
const REFIT_HYSTERESIS: f32 = 0.75;

/// Frames in which a posed mesh keeps its class (refit every frame, or on its slot's turn)
/// unless it grows past [`REFIT_PROMOTE`]: classes are decided once an epoch of this many frames
/// (the frame's timeline value divided by it), the first frame of the epoch the mesh waits for a
/// refit in. A crowd that walks has a few characters crossing `refit_pixels` every frame;
/// decided every frame, the set of every-frame refits changed with each of them and no frame's
/// commands matched an earlier one's (10,000 walking foxes at 1920×1080: 6,100 refits recorded
/// anew every frame, 9–12 ms of the driver's submission on the lent H200's host). Decided once
/// an epoch, each frame slot's refits repeat for the epoch's frames and its command buffers are
/// submitted again as recorded. Staleness is unaffected: a mesh that grew past the limit within
/// an epoch is still refit on its slot's turn, [`MAX_REFIT_STALENESS`] frames behind at most,
/// and one that grew past [`REFIT_PROMOTE`] times the limit (a camera cut, a character running
/// up to the camera) is refit every frame from then on; one that shrank is refit every frame
/// until the epoch ends. A multiple of `FRAMES_IN_FLIGHT`, so that both slots see each epoch's
/// classes.
pub const REFIT_CLASS_FRAMES: u64 = 16;
const _: () = assert!(REFIT_CLASS_FRAMES.is_multiple_of(FRAMES_IN_FLIGHT as u64));

/// Within an epoch, a mesh refit on its slot's turn is refit every frame as soon as it is this
/// many times `refit_pixels` tall on screen: a structure a frame behind its pose is never drawn
/// larger than twice the limit.
pub const REFIT_PROMOTE: f32 = 2.0;

/// A posed BLAS is rebuilt after this many refits at the latest.
pub const POSED_REBUILD_REFITS: u32 = 240;
/// ... or as soon as its pose's bounds have grown or shrunk by this factor in surface area since
/// the build: refits keep the tree's topology, so boxes that stretched over a limb that moved
/// away overlap more and more (a cheap stand-in for the tree's own surface area, which the API
/// does not report).
pub const POSED_REBUILD_AREA: f32 = 1.5;

/// Whether a posed BLAS refit `refits` times since its build for bounds of surface area
/// `built` should be rebuilt rather than refit now that its bounds have area `now`.
pub fn posed_needs_rebuild(refits: u32, built: f32, now: f32) -> bool {
    refits >= POSED_REBUILD_REFITS || now > built * POSED_REBUILD_AREA || now * POSED_REBUILD_AREA < built
}

/// The height on screen, in pixels, of the sphere around the world-space box `min`..`max` as
/// `camera` sees it (a perspective camera: at its centre's distance; an orthographic one: at any).
fn screen_height(camera: &crate::layout::GpuCamera, min: glam::Vec3, max: glam::Vec3) -> f32 {
    let radius = (max - min).length() * 0.5;
    let scale = camera.proj.y_axis.y.abs() * camera.viewport_size.y;
    if camera.proj.w_axis.w == 1.0 {
        return radius * scale; // orthographic
    }
    let distance = camera.view.transform_point3((min + max) * 0.5).z.abs().max(1e-4);
    if radius >= distance { f32::INFINITY } else { radius * scale / distance }
}

fn surface_area((lo, hi): (glam::Vec3, glam::Vec3)) -> f32 {
    let d = (hi - lo).max(glam::Vec3::ZERO);
    2.0 * (d.x * d.y + d.y * d.z + d.z * d.x)
}

/// What the scene's structures need this frame, worked out before the upload.
#[derive(Clone, Copy, Debug, Default)]
pub struct SceneAccelFrame {
    /// The TLAS's device address (0 without one).
    pub tlas_address: vk::DeviceAddress,
    /// The BLAS address table (u64 per mesh) the instance pass reads.
    pub blas_table: vk::DeviceAddress,
    /// The TLAS instance records the instance pass writes.
    pub instances: vk::DeviceAddress,
    /// Entries of the BLAS table.
    pub blas_count: u32,
    /// The graph resources a pass that traces the scene reads (the TLAS and every BLAS), when
    /// there is a TLAS to trace this frame.
    pub traced: Option<[ResourceId; 2]>,
    work: TlasWork,
    instance_count: u32,
}

/// What happens to the TLAS this frame.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub enum TlasWork {
    /// Nothing changed.
    #[default]
    None,
    /// Only transforms changed: update in place.
    Update,
    /// Instances, meshes or materials changed: full build.
    Build,
}

/// Chooses the TLAS work: a build when the `instance_count` differs from the `built` one, when
/// the instances were `rearranged`, or, in a frame of the first frame slot (`first_slot`), when
/// updates since the last build reach half the instance count; an update when only transforms
/// `moved` instances; else nothing. Degraded trees are rebuilt only in the first slot's frames so
/// that a crowd moving every frame builds in one slot and updates in the other, and each slot's
/// command buffer is submitted again as recorded (`crate::gpu::commands`); a tree is rebuilt at
/// the latest `FRAMES_IN_FLIGHT` frames after its updates reached the instance count.
pub fn plan_tlas_work(
    built: Option<u32>,
    instance_count: u32,
    rearranged: bool,
    moved: u32,
    updated_since_build: u64,
    first_slot: bool,
) -> TlasWork {
    match built {
        _ if instance_count == 0 => TlasWork::None,
        None => TlasWork::Build,
        Some(b) if b != instance_count || rearranged => TlasWork::Build,
        _ if moved == 0 => TlasWork::None,
        _ if first_slot && 2 * (updated_since_build + moved as u64) >= instance_count as u64 => TlasWork::Build,
        _ => TlasWork::Update,
    }
}

/// The scene's BLASes and TLAS.
pub struct SceneAccel {
    blas: Vec<Option<MeshBlas>>,
    blas_table: Option<Buffer>,
    blas_table_dirty: bool,
    tlas: Option<AccelStruct>,
    tlas_capacity: u32,
    instances: Option<Buffer>,
    built: Option<u32>,
    updated_since_build: u64,
    pending_rearranged: bool,
    pending_moved: u32,
    queries: vk::QueryPool,
    free_queries: Vec<u32>,
    scratch: Scratch,
    /// The TLAS shrank: the scratch follows at the next build.
    shrink_scratch: bool,
    /// When the TLAS has room for far more instances than there are.
    tlas_shrink: Shrink,
    instance_pass: vk::Pipeline,
    res: SceneAccelResources,
    /// This frame's skinned posed meshes, and their refits with scratch offsets (kept to reuse).
    refit_list: Vec<MeshId>,
    refits: Vec<(usize, u64)>,
    /// Posed meshes whose pose changed and whose refit was deferred.
    waiting: Vec<MeshId>,
    /// Per mesh id, the largest height on screen (pixels) of the instances drawing it, while
    /// refits are chosen.
    sizes: Vec<f32>,
    /// The `refit_pixels` the posed meshes' classes were decided with.
    classed_at: f32,

    /// No consumer wanted the structures last frame: what moved since is not in them.
    dormant: bool,
}

/// Instances the TLAS has room for at the least.
const TLAS_FLOOR: u32 = 64;

/// The frame-graph resources of the scene's structures.
#[derive(Clone, Copy, Debug)]
pub struct SceneAccelResources {
    /// Every mesh's BLAS.
    pub blas: ResourceId,
    /// The TLAS.
    pub tlas: ResourceId,
    /// The TLAS instance records.
    pub instances: ResourceId,
    scratch: ResourceId,
}

impl SceneAccel {
    /// Creates the instance pass and the query pool (on devices with acceleration structures;
    /// `None` elsewhere).
    pub fn new(ctx: &GpuContext, graph: &mut FrameGraph, layout: vk::PipelineLayout) -> Result<Option<Self>, RenderError> {
        if ctx.ray_tracing.is_none() {
            return Ok(None);
        }
        let info =
            vk::QueryPoolCreateInfo::default().query_type(vk::QueryType::ACCELERATION_STRUCTURE_COMPACTED_SIZE_KHR).query_count(QUERIES);
        // SAFETY: valid create info; destroyed in `destroy`.
        let queries = unsafe { ctx.device.create_query_pool(&info, None) }?;
        let instance_pass = match create_compute(ctx, layout, "scene instances", shaders::SCENE_INSTANCES_COMP) {
            Ok(p) => p,
            Err(e) => {
                // SAFETY: unused.
                unsafe { ctx.destroying().destroy_query_pool(queries, None) };
                return Err(e);
            }
        };
        Ok(Some(Self {
            blas: Vec::new(),
            blas_table: None,
            blas_table_dirty: false,
            tlas: None,
            tlas_capacity: 0,
            instances: None,
            built: None,
            updated_since_build: 0,
            pending_rearranged: false,
            pending_moved: 0,
            queries,
            free_queries: (0..QUERIES).rev().collect(),
            scratch: Scratch::new(ctx, "scene as scratch"),
            shrink_scratch: false,
            tlas_shrink: ctx.shrink_rule(),
            instance_pass,
            refit_list: Vec::new(),
            refits: Vec::new(),
            waiting: Vec::new(),
            sizes: Vec::new(),
            classed_at: 0.0,
            dormant: false,
            res: SceneAccelResources {
                blas: graph.resource("scene blas"),
                tlas: graph.resource("scene tlas"),
                instances: graph.resource("scene tlas instances"),
                scratch: graph.resource("scene as scratch"),
            },
        }))
    }

    /// The graph resources a pass that traces the scene reads: the TLAS and every BLAS.
    pub fn traced(&self) -> [ResourceId; 2] {
        [self.res.tlas, self.res.blas]
    }

    /// Follows this frame's changes in `mirror` before the scene's upload (which consumes the
    /// change marks): frees dropped meshes' BLASes, creates the new meshes' (their builds are
    /// recorded by [`SceneAccel::record`]), compacts BLASes whose size query has come back, and
    /// makes room for the instances. Returns the addresses the lighting record needs.
    ///
    /// `wanted`: whether any pass traces the scene this frame. Without one the structures stay
    /// dormant (see the module docs): nothing is planned or recorded and the frame has no TLAS.
    pub fn prepare(
        &mut self,
        f: &mut Frame,
        scene: &GpuScene,
        mirror: &mut SceneMirror,
        wanted: bool,
        refit_pixels: f32,
        counters: &mut FrameCounters,
    ) -> Result<SceneAccelFrame, RenderError> {
        let ctx = f.ctx;
        let (frame_value, completed) = (f.upload.frame_value, f.upload.completed);
        let graveyard = &mut *f.upload.graveyard;
        for &id in &mirror.released_meshes {
            if let Some(old) = self.blas.get_mut(id.0 as usize).and_then(Option::take) {
                self.free_queries.extend(old.query);
                old.accel.bury(graveyard, frame_value);
                self.blas_table_dirty = true;
            }
        }
        for (id, data) in &mirror.pending_meshes {
            let slot = id.0 as usize;
            self.vacate(slot, graveyard, frame_value);
            let primitives = (data.indices.len() / 3) as u32;
            if primitives == 0 || data.vertices.is_empty() {
                continue; // nothing to hit: the instance stays inactive
            }
            let geometry = [triangles(0, 0, data.vertices.len() as u32)];
            let sizes = build_sizes(ctx, vk::AccelerationStructureTypeKHR::BOTTOM_LEVEL, BLAS_FLAGS, &geometry, &[primitives]);
            let accel =
                AccelStruct::new(ctx, vk::AccelerationStructureTypeKHR::BOTTOM_LEVEL, sizes.acceleration_structure_size, "mesh blas")?;
            self.blas[slot] = Some(MeshBlas {
                accel,
                query: self.free_queries.pop(),
                built_in: frame_value,
                needs_build: true,
                compact_from: None,
                primitives,
                posed: None,
            });
        }
        // Posed meshes: a BLAS that can be refit, of their source's size.
        for &(id, source) in &mirror.pending_posed {
            let counts = mirror
                .pending_meshes
                .iter()
                .rev()
                .find(|(m, _)| *m == source)
                .map(|(_, d)| (d.vertices.len() as u32, d.indices.len() as u32 / 3));
            let Some((vertices, primitives)) = counts.or_else(|| scene.mesh(source).map(|m| (m.vertex_count, m.index_count / 3))) else {
                continue;
            };
            let slot = id.0 as usize;
            self.vacate(slot, graveyard, frame_value);
            if primitives == 0 {
                continue;
            }
            let sizes =
                build_sizes(ctx, vk::AccelerationStructureTypeKHR::BOTTOM_LEVEL, POSED_FLAGS, &[triangles(0, 0, vertices)], &[primitives]);
            let accel = AccelStruct::new(
                ctx,
                vk::AccelerationStructureTypeKHR::BOTTOM_LEVEL,
                sizes.acceleration_structure_size,
                "posed mesh blas",
            )?;
            let area = mirror.mesh_bounds(id).map_or(0.0, surface_area);
            let update_scratch = sizes.update_scratch_size.next_multiple_of(256);
            let posed = PosedBlas {
                refits: 0,
                built_area: area,
                area,
                needs_refit: false,
                update_scratch,
                waiting: false,
                stale: 0,
                large: true,
                classified: None,
            };
            self.blas[slot] = Some(MeshBlas {
                accel,
                query: None,
                built_in: frame_value,
                needs_build: true,
                compact_from: None,
                primitives,
                posed: Some(posed),
            });
        }
        // Posed meshes skinned this frame (every posed mesh the frame a dormant structure wakes:
        // any may have moved since): refit, or rebuilt once refits have degraded them.
        self.refit_list.clear();
        if !wanted {
            for &id in mirror.poses.jobs() {
                if let Some(posed) = self.blas.get_mut(id.0 as usize).and_then(Option::as_mut).and_then(|b| b.posed.as_mut()) {
                    posed.area = mirror.mesh_bounds(id).map_or(0.0, surface_area);
                }
            }
            self.forget_waiting(); // the wake refits every posed mesh
        } else if std::mem::take(&mut self.dormant) {
            // A posed mesh whose last skinning wrote only its level of detail (its pose changed
            // within `REST_FRAMES` frames and it is not skinned now) would be refit from vertices
            // of two poses: it is skinned whole next frame instead, and refit as a changed pose
            // (at most two frames late).
            let poses = &mut mirror.poses;
            for (i, b) in self.blas.iter().enumerate() {
                if b.as_ref().is_some_and(|b| b.posed.is_some()) {
                    let id = MeshId(i as u32);
                    if poses.whole_by_now(id) {
                        self.refit_list.push(id);
                    } else {
                        poses.skin_whole(id);
                    }
                }
            }
            self.pending_rearranged = true; // the instances moved unseen: a full build
            self.forget_waiting();
        } else {
            self.choose_refits(mirror, refit_pixels, frame_value, counters);
        }
        for &id in &self.refit_list {
            let Some(Some(b)) = self.blas.get_mut(id.0 as usize) else { continue };
            let Some(posed) = b.posed.as_mut() else { continue };
            (posed.waiting, posed.stale) = (false, 0);
            self.pending_moved = self.pending_moved.saturating_add(1);
            posed.area = mirror.mesh_bounds(id).map_or(0.0, surface_area);
            if b.needs_build {
                continue;
            }
            if posed_needs_rebuild(posed.refits, posed.built_area, posed.area) {
                b.needs_build = true; // in place: the TLAS still names it, and is updated
            } else {
                posed.needs_refit = true;
            }
        }
        // Compactions whose sizes are known: the copies are recorded this frame (not while
        // dormant: nothing is recorded then, and a compaction replaces the structure at once).
        for (slot, entry) in self.blas.iter_mut().enumerate().filter(|_| wanted) {
            let Some(b) = entry else { continue };
            let Some(query) = b.query.filter(|_| b.built_in <= completed && !b.needs_build) else { continue };
            let mut size = [0u64];
            // SAFETY: the query was written by a frame that has completed.
            let got = unsafe { ctx.device.get_query_pool_results(self.queries, query, &mut size, vk::QueryResultFlags::TYPE_64) };
            self.free_queries.push(query);
            b.query = None;
            // Copy only when it saves memory (lavapipe reports the built size; NVIDIA's drivers
            // report less).
            if got.is_err() || size[0] == 0 || size[0] >= b.accel.buffer.size {
                continue;
            }
            let compact = AccelStruct::new(ctx, vk::AccelerationStructureTypeKHR::BOTTOM_LEVEL, size[0], "mesh blas (compacted)")?;
            let old = std::mem::replace(&mut b.accel, compact);
            b.compact_from = Some(old.raw);
            old.bury(graveyard, frame_value);
            self.blas_table_dirty = true;
            tracing::trace!(mesh = slot, bytes = size[0], "mesh blas compacted");
        }
        if std::mem::take(&mut self.blas_table_dirty) {
            let table: Vec<u64> = self.blas.iter().map(|b| b.as_ref().map_or(0, |b| b.accel.address)).collect();
            let bytes: &[u8] = bytemuck::cast_slice(&table);
            let mut buffer = Buffer::new(
                ctx,
                "scene blas table",
                (bytes.len() as u64).max(8),
                vk::BufferUsageFlags::SHADER_DEVICE_ADDRESS,
                MemoryLocation::CpuToGpu,
            )?;
            buffer.mapped()[..bytes.len()].copy_from_slice(bytes);
            if let Some(old) = self.blas_table.replace(buffer) {
                graveyard.bury(frame_value, Retired::Buffer(old));
            }
            self.pending_rearranged = true;
        }

        // The instances: what changed, and room for them (`shrunk`: old and new sizes of what a
        // shrink replaces).
        let mut shrunk = [(0u64, 0u64); 2];
        self.pending_rearranged |= mirror.take_instances_rearranged() || mirror.materials.dirty_count() > 0;
        self.pending_moved = self.pending_moved.saturating_add(mirror.instances.dirty_count() as u32);
        let count = mirror.instances.slot_count();
        if count == 0 {
            // Nothing to trace (the TLAS may name BLASes that are gone): no TLAS until there is.
            self.built = None;
        }
        let first_slot = frame_value % FRAMES_IN_FLIGHT as u64 == 0;
        let work = plan_tlas_work(self.built, count, self.pending_rearranged, self.pending_moved, self.updated_since_build, first_slot);
        let smaller = self.tlas_shrink.check(self.tlas_capacity as u64, count as u64, TLAS_FLOOR as u64).map(|c| c as u32);
        if count > self.tlas_capacity || smaller.is_some() {
            let capacity = smaller.unwrap_or(count.next_power_of_two().max(TLAS_FLOOR));
            let geometry = [instances_geometry(0)];
            let sizes = build_sizes(ctx, vk::AccelerationStructureTypeKHR::TOP_LEVEL, TLAS_FLAGS, &geometry, &[capacity]);
            let tlas = AccelStruct::new(ctx, vk::AccelerationStructureTypeKHR::TOP_LEVEL, sizes.acceleration_structure_size, "scene tlas")?;
            let tlas_bytes = tlas.buffer.size;
            if let Some(old) = self.tlas.replace(tlas) {
                shrunk[0] = (old.buffer.size, tlas_bytes);
                old.bury(graveyard, frame_value);
            }
            let instances = Buffer::new(
                ctx,
                "scene tlas instances",
                capacity as u64 * std::mem::size_of::<vk::AccelerationStructureInstanceKHR>() as u64,
                vk::BufferUsageFlags::STORAGE_BUFFER
                    | vk::BufferUsageFlags::SHADER_DEVICE_ADDRESS
                    | vk::BufferUsageFlags::ACCELERATION_STRUCTURE_BUILD_INPUT_READ_ONLY_KHR,
                MemoryLocation::GpuOnly,
            )?;
            let instance_bytes = instances.size;
            if let Some(old) = self.instances.replace(instances) {
                shrunk[1] = (old.size, instance_bytes);
                graveyard.bury(frame_value, Retired::Buffer(old));
            }
            self.tlas_capacity = capacity;
            self.built = None; // a new structure: the next work is a build
            self.tlas_shrink.reset();
            self.shrink_scratch |= smaller.is_some();
        }
        if smaller.is_some() {
            for (old, new) in shrunk {
                f.upload.count_shrink(old, new);
            }
        }
        let work = if self.built.is_none() && count > 0 { TlasWork::Build } else { work };
        if !wanted {
            self.dormant = true;
            return Ok(SceneAccelFrame {
                blas_table: self.blas_table.as_ref().map_or(0, |b| b.address),
                instances: self.instances.as_ref().map_or(0, |b| b.address),
                blas_count: self.blas.len() as u32,
                instance_count: count,
                ..SceneAccelFrame::default()
            });
        }
        let tlas_address = if self.built.is_some() || work == TlasWork::Build { self.tlas.as_ref().map_or(0, |t| t.address) } else { 0 };
        Ok(SceneAccelFrame {
            tlas_address,
            traced: (tlas_address != 0).then(|| self.traced()),
            blas_table: self.blas_table.as_ref().map_or(0, |b| b.address),
            instances: self.instances.as_ref().map_or(0, |b| b.address),
            blas_count: self.blas.len() as u32,
            work,
            instance_count: count,
        })
    }

    /// The posed meshes whose structures are refit (or rebuilt) this frame, once planned: the
    /// skinning pass skins every vertex of these (`crate::skinning`).
    pub fn refits(&self) -> &[MeshId] {
        &self.refit_list
    }

    /// Lists this frame's refits in `refit_list`: the posed meshes skinned this frame join those
    /// waiting; each is refit now if it is at least `refit_pixels` tall on screen (every one when
    /// `refit_pixels` is 0; decided once an epoch of [`REFIT_CLASS_FRAMES`] frames), if its
    /// structure is [`MAX_REFIT_STALENESS`] frames behind, or if
    /// this is its turn (the frames of one frame slot, spread over the meshes by id; `frame` is
    /// this frame's timeline value); the rest wait a frame more. Counts the deferred refits and
    /// the stalest structure.
    fn choose_refits(&mut self, mirror: &mut SceneMirror, refit_pixels: f32, frame: u64, counters: &mut FrameCounters) {
        for &id in mirror.poses.jobs() {
            if let Some(posed) = self.blas.get_mut(id.0 as usize).and_then(Option::as_mut).and_then(|b| b.posed.as_mut())
                && !posed.waiting
            {
                posed.waiting = true;
                self.waiting.push(id);
            }
        }
        if self.waiting.is_empty() {
            return;
        }
        // Classes are decided once an epoch (`REFIT_CLASS_FRAMES`), and again at once when the
        // limit changed (compared by bits: a NaN limit is not "changed" every frame).
        let epoch = frame / REFIT_CLASS_FRAMES;
        if self.classed_at.to_bits() != refit_pixels.to_bits() {
            self.classed_at = refit_pixels;
            for b in self.blas.iter_mut().flatten() {
                if let Some(posed) = b.posed.as_mut() {
                    posed.classified = None;
                }
            }
        }
        // Each posed mesh's height on screen: the largest of the instances that draw it (one,
        // for a skinned instance), from their culling records' world bounds.
        self.sizes.clear();
        if refit_pixels > 0.0 {
            self.sizes.resize(self.blas.len(), 0.0);
            let camera = mirror.camera();
            for slot in 0..mirror.culls.slot_count() {
                let Some(record) = mirror.culls.get(slot) else { continue };
                let Some(size) = self.sizes.get_mut(record.mesh as usize) else { continue };
                *size = size.max(screen_height(camera, record.min, record.max));
            }
        }
        let (mut deferred, mut stalest) = (0, 0);
        let turn = frame % FRAMES_IN_FLIGHT as u64;
        let (blas, sizes, refit_list) = (&mut self.blas, &self.sizes, &mut self.refit_list);
        self.waiting.retain(|&id| {
            let Some(b) = blas.get_mut(id.0 as usize).and_then(Option::as_mut) else { return false };
            let Some(posed) = b.posed.as_mut() else { return false };
            // Hysteresis: a mesh changes class only well past the limit, so that a crowd whose
            // poses sway about it keeps the same refits, and the same command buffers, frame to
            // frame.
            let size = sizes.get(id.0 as usize).copied().unwrap_or(0.0);
            if posed.classified != Some(epoch) {
                posed.classified = Some(epoch);
                posed.large = refit_pixels <= 0.0 || size >= refit_pixels || (posed.large && size >= REFIT_HYSTERESIS * refit_pixels);
            } else if !posed.large && size >= REFIT_PROMOTE * refit_pixels {
                posed.large = true;
            }
            let large = posed.large;
            if b.needs_build || large || posed.stale >= MAX_REFIT_STALENESS || u64::from(id.0) % FRAMES_IN_FLIGHT as u64 == turn {
                refit_list.push(id);
                return false;
            }
            posed.stale += 1;
            deferred += 1;
            stalest = stalest.max(posed.stale);
            true
        });
        // In mesh order, not in the order the meshes began to wait (which follows which were
        // deferred before): equal sets of refits record equal commands.
        refit_list.sort_unstable();
        counters.scene_blas_refits_deferred = deferred;
        counters.scene_blas_stalest = stalest.into();
    }

    /// Forgets the deferred refits (the structures are dormant, or every posed mesh is refit).
    fn forget_waiting(&mut self) {
        for id in self.waiting.drain(..) {
            if let Some(posed) = self.blas.get_mut(id.0 as usize).and_then(Option::as_mut).and_then(|b| b.posed.as_mut()) {
                (posed.waiting, posed.stale) = (false, 0);
            }
        }
    }

    /// Makes room for mesh `slot`'s BLAS, burying the one it replaces (the table is rewritten).
    fn vacate(&mut self, slot: usize, graveyard: &mut Graveyard, frame_value: u64) {
        if self.blas.len() <= slot {
            self.blas.resize_with(slot + 1, || None);
        }
        if let Some(old) = self.blas[slot].take() {
            self.free_queries.extend(old.query);
            old.accel.bury(graveyard, frame_value);
        }
        self.blas_table_dirty = true;
    }

    /// Records this frame's work after the upload: new meshes' BLAS builds and their size
    /// queries, compaction copies, the instance records and the TLAS build or update.
    pub fn record(
        &mut self,
        f: &mut Frame,
        scene: &GpuScene,
        frame: &SceneAccelFrame,
        counters: &mut FrameCounters,
    ) -> Result<(), RenderError> {
        let ctx = f.ctx;
        let Some(rt) = ctx.ray_tracing.as_ref() else { return Ok(()) };
        if self.dormant {
            return Ok(()); // nothing traces the scene: builds and refits wait until something does
        }
        let asx = &rt.acceleration_structure;
        let frame_value = f.upload.frame_value;

        // New BLASes, each with its own piece of scratch.
        let mut builds: Vec<(usize, u64)> = Vec::new();
        let mut scratch_need = 0u64;
        for (slot, b) in self.blas.iter().enumerate() {
            let Some(b) = b.as_ref().filter(|b| b.needs_build) else { continue };
            let Some((vertices, indices, vertex_count)) = scene.mesh_geometry(MeshId(slot as u32)) else { continue };
            let geometry = [triangles(vertices, indices, vertex_count)];
            let sizes = build_sizes(ctx, vk::AccelerationStructureTypeKHR::BOTTOM_LEVEL, b.flags(), &geometry, &[b.primitives]);
            builds.push((slot, scratch_need));
            scratch_need += sizes.build_scratch_size.next_multiple_of(256);
        }
        // This frame's refits (the posed meshes skinned: `mirror.poses.jobs()`, listed in
        // `prepare`), each with its own piece of scratch.
        let mut refits = std::mem::take(&mut self.refits);
        refits.clear();
        for &id in &self.refit_list {
            let Some(posed) = self.blas.get(id.0 as usize).and_then(Option::as_ref).filter(|b| !b.needs_build).and_then(|b| b.posed) else {
                continue;
            };
            if posed.needs_refit && scene.mesh_geometry(id).is_some() {
                refits.push((id.0 as usize, scratch_need));
                scratch_need += posed.update_scratch;
            }
        }
        let scratch = if builds.is_empty() && refits.is_empty() && frame.work == TlasWork::None {
            0
        } else {
            // Asked only when something is built: the query is a driver call that cost a still
            // frame 17 µs of its recording on the H100 machine's host.
            let tlas_sizes = build_sizes(
                ctx,
                vk::AccelerationStructureTypeKHR::TOP_LEVEL,
                TLAS_FLAGS,
                &[instances_geometry(0)],
                &[frame.instance_count.max(1)],
            );
            let scratch_need = scratch_need.max(tlas_sizes.build_scratch_size).max(tlas_sizes.update_scratch_size);
            if std::mem::take(&mut self.shrink_scratch) {
                self.scratch.shrink_to(&mut f.upload, scratch_need)?;
            }
            self.scratch.ensure(ctx, f.upload.graveyard, frame_value, scratch_need)?
        };
        let res = self.res;
        if !builds.is_empty() {
            let (blas, queries) = (&self.blas, self.queries);
            f.pass("scene_blas_build", PassKind::AccelBuild)
                .read(scene.res.meshes, BufferUse::BuildInput)
                .write(res.blas, BufferUse::Accel)
                .write(res.scratch, BufferUse::Accel)
                .record(|p| {
                    for &(slot, offset) in &builds {
                        let b = blas[slot].as_ref().expect("listed above");
                        let (vertices, indices, vertex_count) = scene.mesh_geometry(MeshId(slot as u32)).expect("listed above");
                        let geometry = [triangles(vertices, indices, vertex_count)];
                        let info = build_info(
                            vk::AccelerationStructureTypeKHR::BOTTOM_LEVEL,
                            b.flags(),
                            b.accel.raw,
                            false,
                            &geometry,
                            scratch + offset,
                        );
                        let ranges = [vk::AccelerationStructureBuildRangeInfoKHR::default().primitive_count(b.primitives)];
                        // The mesh buffer was uploaded earlier this frame (declared); each build
                        // has its own scratch range.
                        p.cmd.build_acceleration_structures(&[info], &[&ranges[..]]);
                    }
                })?;
            f.pass("scene_blas_query", PassKind::AccelBuild).read(res.blas, BufferUse::Accel).record(|p| {
                let cmd = p.cmd.direct()?;
                for &(slot, _) in &builds {
                    let b = blas[slot].as_ref().expect("listed above");
                    let Some(query) = b.query else { continue };
                    // SAFETY: `cmd` is recording outside a rendering scope; the BLAS was built
                    // above (the declaration orders the build before this read).
                    unsafe {
                        p.ctx.device.cmd_reset_query_pool(cmd, queries, query, 1);
                        asx.cmd_write_acceleration_structures_properties(
                            cmd,
                            &[b.accel.raw],
                            vk::QueryType::ACCELERATION_STRUCTURE_COMPACTED_SIZE_KHR,
                            queries,
                            query,
                        );
                    }
                }
                Ok::<(), RenderError>(())
            })??;
            counters.scene_blas_builds += builds.len() as u64;
        }
        if !refits.is_empty() {
            let blas = &self.blas;
            f.pass("scene_blas_refit", PassKind::AccelBuild)
                .read(scene.res.meshes, BufferUse::BuildInput)
                .write(res.blas, BufferUse::Accel)
                .write(res.scratch, BufferUse::Accel)
                .record(|p| {
                    // In batches, from arrays on the stack: a crowd's thousands of refits take a
                    // few calls (one each cost the driver far more) and allocate nothing.
                    for chunk in refits.chunks(REFIT_BATCH) {
                        let mut geometries = [[vk::AccelerationStructureGeometryKHR::default(); 1]; REFIT_BATCH];
                        let mut ranges = [[vk::AccelerationStructureBuildRangeInfoKHR::default(); 1]; REFIT_BATCH];
                        for (i, &(slot, _)) in chunk.iter().enumerate() {
                            let (vertices, indices, vertex_count) = scene.mesh_geometry(MeshId(slot as u32)).expect("listed above");
                            geometries[i] = [triangles(vertices, indices, vertex_count)];
                            let primitives = blas[slot].as_ref().expect("listed above").primitives;
                            ranges[i] = [vk::AccelerationStructureBuildRangeInfoKHR::default().primitive_count(primitives)];
                        }
                        let infos: [vk::AccelerationStructureBuildGeometryInfoKHR; REFIT_BATCH] =
                            std::array::from_fn(|i| match chunk.get(i) {
                                Some(&(slot, offset)) => {
                                    let b = blas[slot].as_ref().expect("listed above");
                                    let kind = vk::AccelerationStructureTypeKHR::BOTTOM_LEVEL;
                                    build_info(kind, POSED_FLAGS, b.accel.raw, true, &geometries[i], scratch + offset)
                                }
                                None => vk::AccelerationStructureBuildGeometryInfoKHR::default(),
                            });
                        let range_refs: [&[vk::AccelerationStructureBuildRangeInfoKHR]; REFIT_BATCH] =
                            std::array::from_fn(|i| &ranges[i][..]);
                        // The skinning pass wrote the vertices earlier this frame (declared); each
                        // structure was built with ALLOW_UPDATE from the same geometry; each refit
                        // has its own scratch range; only the chunk's entries are passed.
                        p.cmd.build_acceleration_structures(&infos[..chunk.len()], &range_refs[..chunk.len()]);
                    }
                })?;
            counters.scene_blas_refits += refits.len() as u64;
        }
        for &(slot, _) in &refits {
            let posed = self.blas[slot].as_mut().and_then(|b| b.posed.as_mut()).expect("listed above");
            posed.refits += 1;
            posed.needs_refit = false;
        }
        self.refits = refits;
        for &(slot, _) in &builds {
            let b = self.blas[slot].as_mut().expect("listed above");
            b.needs_build = false;
            b.built_in = frame_value;
            if let Some(posed) = b.posed.as_mut() {
                *posed = PosedBlas { refits: 0, built_area: posed.area, needs_refit: false, ..*posed };
            }
        }
        let compactions: Vec<(vk::AccelerationStructureKHR, vk::AccelerationStructureKHR)> =
            self.blas.iter_mut().flatten().filter_map(|b| b.compact_from.take().map(|src| (src, b.accel.raw))).collect();
        if !compactions.is_empty() {
            f.pass("scene_blas_compact", PassKind::AccelBuild).write(res.blas, BufferUse::Accel).record(|p| {
                let cmd = p.cmd.direct()?;
                for &(src, dst) in &compactions {
                    let info = vk::CopyAccelerationStructureInfoKHR::default()
                        .src(src)
                        .dst(dst)
                        .mode(vk::CopyAccelerationStructureModeKHR::COMPACT);
                    // SAFETY: `cmd` is recording; the source is alive until this frame completes
                    // (in the graveyard) and was built by a completed frame.
                    unsafe { asx.cmd_copy_acceleration_structure(cmd, &info) };
                }
                Ok::<(), RenderError>(())
            })??;
            counters.scene_blas_compactions += compactions.len() as u64;
        }

        if frame.work == TlasWork::None {
            return Ok(());
        }
        let (tlas, count) = (self.tlas.as_ref().expect("allocated in prepare"), frame.instance_count);
        let pipeline = self.instance_pass;
        f.pass("scene_instances", PassKind::Compute)
            .read(scene.res.tables, BufferUse::Storage)
            .write(res.instances, BufferUse::Storage)
            .record(|p| {
                p.bind(vk::PipelineBindPoint::COMPUTE, pipeline, &p.push);
                p.cmd.dispatch(count.div_ceil(64), 1, 1);
            })?;
        let update = frame.work == TlasWork::Update;
        let instances = frame.instances;
        f.pass(if update { "scene_tlas_update" } else { "scene_tlas_build" }, PassKind::AccelBuild)
            .read(res.instances, BufferUse::BuildInput)
            .read(res.blas, BufferUse::Accel)
            .write(res.tlas, BufferUse::Accel)
            .write(res.scratch, BufferUse::Accel)
            .record(|p| {
                let geometry = [instances_geometry(instances)];
                let info = build_info(vk::AccelerationStructureTypeKHR::TOP_LEVEL, TLAS_FLAGS, tlas.raw, update, &geometry, scratch);
                let ranges = [vk::AccelerationStructureBuildRangeInfoKHR::default().primitive_count(count)];
                // The instance records were written by the pass above (declared); the TLAS was
                // sized for at least `count` instances.
                p.cmd.build_acceleration_structures(&[info], &[&ranges[..]]);
            })?;
        if update {
            counters.scene_tlas_updates += 1;
            self.updated_since_build += self.pending_moved as u64;
        } else {
            counters.scene_tlas_builds += 1;
            self.updated_since_build = 0;
            self.built = Some(count);
        }
        self.pending_moved = 0;
        self.pending_rearranged = false;
        Ok(())
    }

    /// Destroys everything; the GPU must be idle.
    pub fn destroy(self, ctx: &GpuContext) {
        for b in self.blas.into_iter().flatten() {
            b.accel.destroy(ctx);
        }
        if let Some(t) = self.tlas {
            t.destroy(ctx);
        }
        for b in [self.blas_table, self.instances].into_iter().flatten() {
            b.destroy(ctx);
        }
        self.scratch.destroy(ctx);
        // SAFETY: the GPU is idle.
        unsafe {
            ctx.destroying().destroy_query_pool(self.queries, None);
            ctx.destroying().destroy_pipeline(self.instance_pass, None);
        }
    }
}

const BLAS_FLAGS: vk::BuildAccelerationStructureFlagsKHR = vk::BuildAccelerationStructureFlagsKHR::from_raw(
    vk::BuildAccelerationStructureFlagsKHR::PREFER_FAST_TRACE.as_raw() | vk::BuildAccelerationStructureFlagsKHR::ALLOW_COMPACTION.as_raw(),
);
/// Posed meshes' BLASes: refit after every skinning, so built fast and never compacted.
const POSED_FLAGS: vk::BuildAccelerationStructureFlagsKHR = vk::BuildAccelerationStructureFlagsKHR::from_raw(
    vk::BuildAccelerationStructureFlagsKHR::PREFER_FAST_BUILD.as_raw() | vk::BuildAccelerationStructureFlagsKHR::ALLOW_UPDATE.as_raw(),
);
impl MeshBlas {
    fn flags(&self) -> vk::BuildAccelerationStructureFlagsKHR {
        if self.posed.is_some() { POSED_FLAGS } else { BLAS_FLAGS }
    }
}

const TLAS_FLAGS: vk::BuildAccelerationStructureFlagsKHR = vk::BuildAccelerationStructureFlagsKHR::from_raw(
    vk::BuildAccelerationStructureFlagsKHR::PREFER_FAST_TRACE.as_raw() | vk::BuildAccelerationStructureFlagsKHR::ALLOW_UPDATE.as_raw(),
);

/// A mesh's triangles as a BLAS geometry: positions at the start of each [`GpuVertex`], 32-bit
/// indices. Not opaque: each instance's flags decide (masked materials run the any-hit test).
fn triangles(vertices: vk::DeviceAddress, indices: vk::DeviceAddress, vertex_count: u32) -> vk::AccelerationStructureGeometryKHR<'static> {
    vk::AccelerationStructureGeometryKHR::default()
        .geometry_type(vk::GeometryTypeKHR::TRIANGLES)
        .geometry(vk::AccelerationStructureGeometryDataKHR {
            triangles: vk::AccelerationStructureGeometryTrianglesDataKHR::default()
                .vertex_format(vk::Format::R32G32B32_SFLOAT)
                .vertex_data(vk::DeviceOrHostAddressConstKHR { device_address: vertices })
                .vertex_stride(std::mem::size_of::<GpuVertex>() as u64)
                .max_vertex(vertex_count.saturating_sub(1))
                .index_type(vk::IndexType::UINT32)
                .index_data(vk::DeviceOrHostAddressConstKHR { device_address: indices }),
        })
        .flags(vk::GeometryFlagsKHR::NO_DUPLICATE_ANY_HIT_INVOCATION)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn posed_blases_are_rebuilt_after_many_refits_or_a_big_change_of_bounds() {
        assert!(!posed_needs_rebuild(0, 10.0, 10.0), "a fresh build is refit");
        assert!(!posed_needs_rebuild(POSED_REBUILD_REFITS - 1, 10.0, 14.0), "bounds within 1.5x: refit");
        assert!(posed_needs_rebuild(POSED_REBUILD_REFITS, 10.0, 10.0), "too many refits");
        assert!(posed_needs_rebuild(3, 10.0, 15.5), "a limb stretched out");
        assert!(posed_needs_rebuild(3, 10.0, 6.0), "curled up");
    }

    #[test]
    fn tlas_policy() {
        assert_eq!(plan_tlas_work(None, 0, false, 0, 0, true), TlasWork::None, "nothing to build over");
        assert_eq!(plan_tlas_work(None, 5, false, 0, 0, false), TlasWork::Build, "first use builds");
        assert_eq!(plan_tlas_work(Some(5), 5, false, 0, 0, true), TlasWork::None, "a still scene does nothing");
        assert_eq!(plan_tlas_work(Some(5), 5, false, 1, 0, true), TlasWork::Update, "a move updates");
        assert_eq!(plan_tlas_work(Some(5), 6, false, 1, 0, false), TlasWork::Build, "a spawn rebuilds");
        assert_eq!(plan_tlas_work(Some(5), 5, true, 1, 0, false), TlasWork::Build, "a new mesh or material rebuilds");
        assert_eq!(plan_tlas_work(Some(10), 10, false, 1, 4, true), TlasWork::Build, "updates degrade the tree: rebuild");
        assert_eq!(plan_tlas_work(Some(10), 10, false, 1, 40, false), TlasWork::Update, "only in the first slot's frames");
    }
}
