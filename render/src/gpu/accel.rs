//! Acceleration structures and their scratch memory, shared by the decal structures
//! (`crate::decals::accel`), the scene's (`crate::accel`), the lights'
//! (`crate::lights::ray_query`) and the particles' decal ring's (`crate::particles`); and [`AabbAccel`], the one-BLAS-of-boxes structure the decals
//! and the ray-query lights both enumerate with a zero-length ray, with its rebuild policy
//! ([`plan_blas_work`]).
//!
//! **Memory.** An [`AabbAccel`]'s BLAS storage grows when a build needs more. It is rebuilt
//! into storage of its own size when the boxes a build would cover have stayed at or below a
//! quarter of what the storage was sized for through a second of frames that used it (60:
//! [`Shrink`]), its scratch following. When it has not been brought up to date for that many
//! frames (no boxes, or the method that traces them not in use), the BLAS, the TLAS, the
//! instance record and the scratch are all released, the next use building them anew. A BLAS is
//! also rebuilt, never refitted, when the box table no longer holds the boxes it was built over
//! (the table shrank below them).

use ash::vk;
use gpu_allocator::MemoryLocation;

use crate::RenderError;
use crate::gpu::device::GpuContext;
use crate::gpu::memory::{Buffer, Graveyard, MemoryKind, Retired};
use crate::gpu::upload::{Shrink, Upload};
use crate::graph::{BufferUse, Frame, FrameGraph, PassKind, ResourceId};
use crate::layout::GpuAabb;

/// An acceleration structure and its storage.
pub struct AccelStruct {
    /// The Vulkan handle.
    pub raw: vk::AccelerationStructureKHR,
    /// Its storage.
    pub buffer: Buffer,
    /// Its device address (for TLAS instances and shaders).
    pub address: vk::DeviceAddress,
}

impl AccelStruct {
    /// Creates an acceleration structure of `ty` with `size` bytes of storage.
    pub fn new(ctx: &GpuContext, ty: vk::AccelerationStructureTypeKHR, size: u64, name: &str) -> Result<Self, RenderError> {
        let rt = ctx.ray_tracing.as_ref().ok_or_else(|| RenderError::Other("acceleration structures need the ray tracing tier".into()))?;
        let buffer = Buffer::new(
            ctx,
            name,
            size,
            vk::BufferUsageFlags::ACCELERATION_STRUCTURE_STORAGE_KHR | vk::BufferUsageFlags::SHADER_DEVICE_ADDRESS,
            MemoryLocation::GpuOnly,
        )?;
        let info = vk::AccelerationStructureCreateInfoKHR::default().buffer(buffer.raw).size(size).ty(ty);
        // SAFETY: the buffer is live, bound, and large enough (size from the build-size query).
        let raw = match unsafe { rt.acceleration_structure.create_acceleration_structure(&info, None) } {
            Ok(raw) => raw,
            Err(e) => {
                buffer.destroy(ctx);
                return Err(e.into());
            }
        };
        // SAFETY: `raw` was just created on this device.
        let address = unsafe {
            rt.acceleration_structure.get_acceleration_structure_device_address(
                &vk::AccelerationStructureDeviceAddressInfoKHR::default().acceleration_structure(raw),
            )
        };
        Ok(Self { raw, buffer, address })
    }

    /// Destroys it once the GPU has passed `frame_value`.
    pub fn bury(self, graveyard: &mut Graveyard, frame_value: u64) {
        graveyard.bury(frame_value, Retired::AccelerationStructure(self.raw, self.buffer));
    }

    /// Destroys it; the GPU must no longer use it.
    pub fn destroy(self, ctx: &GpuContext) {
        if let Some(rt) = &ctx.ray_tracing {
            ctx.note_destroyed();
            // SAFETY: the caller guarantees the GPU no longer uses it.
            unsafe { rt.acceleration_structure.destroy_acceleration_structure(self.raw, None) };
        }
        self.buffer.destroy(ctx);
    }
}

/// The sizes a build of `geometries` with `counts` primitives needs.
pub fn build_sizes(
    ctx: &GpuContext,
    ty: vk::AccelerationStructureTypeKHR,
    flags: vk::BuildAccelerationStructureFlagsKHR,
    geometries: &[vk::AccelerationStructureGeometryKHR],
    counts: &[u32],
) -> vk::AccelerationStructureBuildSizesInfoKHR<'static> {
    let mut sizes = vk::AccelerationStructureBuildSizesInfoKHR::default();
    if let Some(rt) = &ctx.ray_tracing {
        // SAFETY: a size query with a geometry description of the caller's locals.
        unsafe {
            rt.acceleration_structure.get_acceleration_structure_build_sizes(
                vk::AccelerationStructureBuildTypeKHR::DEVICE,
                &vk::AccelerationStructureBuildGeometryInfoKHR::default().ty(ty).flags(flags).geometries(geometries),
                counts,
                &mut sizes,
            )
        };
    }
    sizes
}

/// The description of a build of `dst` of type `ty` over `geometries` (a refit in place when
/// `update`), with scratch memory at `scratch`.
pub fn build_info<'a>(
    ty: vk::AccelerationStructureTypeKHR,
    flags: vk::BuildAccelerationStructureFlagsKHR,
    dst: vk::AccelerationStructureKHR,
    update: bool,
    geometries: &'a [vk::AccelerationStructureGeometryKHR<'a>],
    scratch: vk::DeviceAddress,
) -> vk::AccelerationStructureBuildGeometryInfoKHR<'a> {
    let mode = if update { vk::BuildAccelerationStructureModeKHR::UPDATE } else { vk::BuildAccelerationStructureModeKHR::BUILD };
    let info = vk::AccelerationStructureBuildGeometryInfoKHR::default()
        .ty(ty)
        .flags(flags)
        .mode(mode)
        .dst_acceleration_structure(dst)
        .geometries(geometries)
        .scratch_data(vk::DeviceOrHostAddressKHR { device_address: scratch });
    if update { info.src_acceleration_structure(dst) } else { info }
}

/// Scratch memory for builds, grown to the largest need and aligned as the device asks.
pub struct Scratch {
    buffer: Option<Buffer>,
    alignment: u64,
    name: &'static str,
}

impl Scratch {
    /// No memory until the first [`Scratch::ensure`].
    pub fn new(ctx: &GpuContext, name: &'static str) -> Self {
        let mut as_props = vk::PhysicalDeviceAccelerationStructurePropertiesKHR::default();
        if ctx.ray_tracing.is_some() {
            let mut props = vk::PhysicalDeviceProperties2::default().push_next(&mut as_props);
            // SAFETY: a valid physical device and a chain of locals.
            unsafe { ctx.instance.get_physical_device_properties2(ctx.physical, &mut props) };
        }
        Self { buffer: None, alignment: (as_props.min_acceleration_structure_scratch_offset_alignment as u64).max(1), name }
    }

    /// Makes room for `size` bytes (the old buffer waits in the graveyard for the frames that
    /// use it) and returns the aligned device address.
    pub fn ensure(&mut self, ctx: &GpuContext, graveyard: &mut Graveyard, frame_value: u64, size: u64) -> Result<u64, RenderError> {
        let need = size + self.alignment;
        if self.buffer.as_ref().is_none_or(|s| s.size < need) {
            let scratch = Self::create(ctx, self.name, need.next_power_of_two())?;
            if let Some(old) = self.buffer.replace(scratch) {
                graveyard.bury(frame_value, Retired::Buffer(old));
            }
        }
        Ok(self.buffer.as_ref().expect("allocated above").address.next_multiple_of(self.alignment))
    }

    /// The alignment the device asks of scratch addresses.
    pub fn alignment(&self) -> u64 {
        self.alignment
    }

    /// Replaces the buffer by one for `size` bytes when that needs at most a quarter of it (its
    /// owner has shrunk); the old one waits in the graveyard.
    pub fn shrink_to(&mut self, up: &mut Upload, size: u64) -> Result<(), RenderError> {
        let need = (size + self.alignment).next_power_of_two();
        if self.buffer.as_ref().is_none_or(|b| need > b.size / 4) {
            return Ok(());
        }
        let scratch = Self::create(up.ctx, self.name, need)?;
        if let Some(old) = self.buffer.replace(scratch) {
            up.bury_shrunk(old, need);
        }
        Ok(())
    }

    /// Lets the buffer go (into the graveyard); the next [`Scratch::ensure`] allocates anew.
    pub fn release(&mut self, up: &mut Upload) {
        if let Some(old) = self.buffer.take() {
            up.bury_shrunk(old, 0);
        }
    }

    fn create(ctx: &GpuContext, name: &str, size: u64) -> Result<Buffer, RenderError> {
        Buffer::of_kind(
            ctx,
            name,
            size,
            vk::BufferUsageFlags::STORAGE_BUFFER | vk::BufferUsageFlags::SHADER_DEVICE_ADDRESS,
            MemoryLocation::GpuOnly,
            MemoryKind::AccelerationStructures,
        )
    }

    /// Destroys the buffer; the GPU must be idle.
    pub fn destroy(self, ctx: &GpuContext) {
        if let Some(b) = self.buffer {
            b.destroy(ctx);
        }
    }
}

/// The 64-byte instance record of a TLAS build holding one instance of `blas`, opaque, with
/// `custom_index` (what shaders tell the structure's hits apart by).
pub fn single_instance(blas: vk::DeviceAddress, custom_index: u32) -> vk::AccelerationStructureInstanceKHR {
    vk::AccelerationStructureInstanceKHR {
        transform: vk::TransformMatrixKHR { matrix: [1.0, 0.0, 0.0, 0.0, 0.0, 1.0, 0.0, 0.0, 0.0, 0.0, 1.0, 0.0] },
        instance_custom_index_and_mask: vk::Packed24_8::new(custom_index, 0xff),
        instance_shader_binding_table_record_offset_and_flags: vk::Packed24_8::new(
            0,
            vk::GeometryInstanceFlagsKHR::FORCE_OPAQUE.as_raw() as u8,
        ),
        acceleration_structure_reference: vk::AccelerationStructureReferenceKHR { device_handle: blas },
    }
}

/// The bytes of an instance record.
pub fn instance_bytes(instance: &vk::AccelerationStructureInstanceKHR) -> &[u8] {
    // SAFETY: AccelerationStructureInstanceKHR is a plain #[repr(C)] struct of 64 bytes with no
    // padding; viewing it as bytes is sound.
    unsafe {
        std::slice::from_raw_parts((instance as *const vk::AccelerationStructureInstanceKHR).cast::<u8>(), std::mem::size_of_val(instance))
    }
}

/// Fraction of the built boxes that may be refitted before a box BLAS is rebuilt.
pub const REBUILD_AFTER_REFIT_FRACTION: f32 = 0.25;

/// The step the built primitive count of a box BLAS moves in for `live` boxes: 1/16 of its
/// power of two, at least 64.
pub fn build_granule(live: u32) -> u32 {
    (live.next_power_of_two() / 16).max(64)
}

/// How many boxes a build over `live` boxes covers (the box table holds at least `capacity`):
/// `live` rounded up to its granule.
pub fn build_count(live: u32, capacity: u32) -> u32 {
    live.next_multiple_of(build_granule(live)).min(capacity)
}

/// What happens to a box BLAS in a frame.
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
/// the last build covered `built` boxes (the rebuild policy, as a pure function): a build when
/// the live count leaves the built range (grows past it, or falls more than two granules below
/// it), and when the boxes refitted since the last build add up to
/// [`REBUILD_AFTER_REFIT_FRACTION`] of the built count (a refit keeps the tree's topology, so as
/// boxes move away from where they were built its nodes grow and overlap, and traversal slows).
pub fn plan_blas_work(built: Option<u32>, live: u32, changed: u32, refitted_since_build: u64) -> BlasWork {
    match built {
        None => BlasWork::Build,
        Some(b) if live > b || live + 2 * build_granule(live) < b => BlasWork::Build,
        _ if changed == 0 => BlasWork::None,
        Some(b) if (refitted_since_build + changed as u64) as f32 > b as f32 * REBUILD_AFTER_REFIT_FRACTION => BlasWork::Build,
        _ => BlasWork::Update,
    }
}

/// One BLAS of AABB geometry ([`GpuAabb`] boxes, stride 32) and a TLAS holding one instance of
/// it: what a zero-length ray enumerates decals or lights in. Built with `PREFER_FAST_TRACE |
/// ALLOW_UPDATE`; the TLAS (one instance) is built after a BLAS build and updated in place
/// after a refit.
pub struct AabbAccel {
    blas: Option<AccelStruct>,
    tlas: Option<AccelStruct>,
    instances: Option<Buffer>,
    scratch: Scratch,
    built: Option<u32>,
    refitted_since_build: u64,
    /// Boxes the BLAS storage was sized for.
    sized_for: u32,
    /// When the storage holds far more than the builds need, or nothing uses it.
    shrink: Shrink,
    res: AabbAccelResources,
    names: AabbAccelDesc,
}

/// What an [`AabbAccel`] is: its parts' and passes' debug names.
#[derive(Clone, Copy, Debug)]
pub struct AabbAccelDesc {
    /// The BLAS (also its buffer's name).
    pub blas: &'static str,
    /// The TLAS.
    pub tlas: &'static str,
    /// The scratch buffer.
    pub scratch: &'static str,
    /// The BLAS build pass.
    pub build_pass: &'static str,
    /// The BLAS refit pass.
    pub update_pass: &'static str,
    /// The TLAS build pass.
    pub tlas_pass: &'static str,
}

/// The frame-graph resources of an [`AabbAccel`].
#[derive(Clone, Copy, Debug)]
struct AabbAccelResources {
    blas: ResourceId,
    tlas: ResourceId,
    scratch: ResourceId,
}

/// A frame's planned work on an [`AabbAccel`] ([`AabbAccel::prepare`]).
#[derive(Clone, Copy, Debug)]
pub struct AabbPlan {
    /// Build, refit or nothing.
    pub work: BlasWork,
    /// Boxes the build or refit covers (the box buffer must hold them valid).
    pub count: u32,
    scratch: vk::DeviceAddress,
}

/// The boxes a build or refit of an [`AabbAccel`] reads.
#[derive(Clone, Copy, Debug)]
pub struct AabbInput {
    /// The graph resource holding the boxes.
    pub boxes: ResourceId,
    /// Device address of box 0.
    pub address: vk::DeviceAddress,
    /// Boxes in use (a build covers them rounded up to [`build_granule`]).
    pub live: u32,
    /// Boxes the buffer holds; those past `live` up to the build's count must be valid boxes
    /// that belong to nothing (zero-size points).
    pub capacity: u32,
    /// Boxes rewritten since the structure was last brought up to date.
    pub changed: u32,
}

impl AabbAccel {
    /// Empty; nothing is allocated until the first build.
    pub fn new(ctx: &GpuContext, graph: &mut FrameGraph, names: AabbAccelDesc) -> Self {
        Self {
            blas: None,
            tlas: None,
            instances: None,
            scratch: Scratch::new(ctx, names.scratch),
            built: None,
            refitted_since_build: 0,
            sized_for: 0,
            shrink: ctx.shrink_rule(),
            res: AabbAccelResources {
                blas: graph.resource(names.blas),
                tlas: graph.resource(names.tlas),
                scratch: graph.resource(names.scratch),
            },
            names,
        }
    }

    /// What a pass that traces the boxes reads: the TLAS and the BLAS its instance points at
    /// (traversal reads both); `None` before the first build.
    pub fn traced(&self) -> Option<[ResourceId; 2]> {
        self.tlas.as_ref().map(|_| [self.res.tlas, self.res.blas])
    }

    /// Device address of the TLAS (0 before the first build).
    pub fn tlas_address(&self) -> vk::DeviceAddress {
        self.tlas.as_ref().map_or(0, |t| t.address)
    }

    /// Plans the frame's work for `input` and makes room for it: a larger BLAS for a build that
    /// needs one, or a smaller one when the storage has long been four times what builds need
    /// (the old one waits in the graveyard for the frames that read it), the TLAS on first use,
    /// scratch. After this the TLAS address is final for the frame.
    pub fn prepare(&mut self, f: &mut Frame, input: &AabbInput) -> Result<AabbPlan, RenderError> {
        let need = build_count(input.live, input.capacity);
        let shrink = self.blas.is_some() && self.shrink.check(self.sized_for as u64, need as u64, 0).is_some();
        let mut work = plan_blas_work(self.built, input.live, input.changed, self.refitted_since_build);
        // A refit covers what the last build covered, which the box table must still hold.
        if shrink || self.built.is_some_and(|built| built > input.capacity) {
            work = BlasWork::Build;
        }
        let count = match (work, self.built) {
            // A refit covers what the last build covered (an update cannot change the count).
            (BlasWork::Update, Some(built)) => built,
            _ => need,
        };
        if work == BlasWork::None {
            return Ok(AabbPlan { work, count, scratch: 0 });
        }
        let ctx = f.ctx;
        let up = &mut f.upload;
        let geometry = aabb_geometry(input.address);
        let blas_sizes = build_sizes(ctx, vk::AccelerationStructureTypeKHR::BOTTOM_LEVEL, self.blas_flags(), &geometry, &[count]);
        let tlas_sizes = build_sizes(ctx, vk::AccelerationStructureTypeKHR::TOP_LEVEL, BOX_TLAS_FLAGS, &one_instance_geometry(0), &[1]);
        let scratch_need = blas_sizes
            .build_scratch_size
            .max(blas_sizes.update_scratch_size)
            .max(tlas_sizes.build_scratch_size)
            .max(tlas_sizes.update_scratch_size);
        if work == BlasWork::Build && (shrink || self.blas.as_ref().is_none_or(|b| b.buffer.size < blas_sizes.acceleration_structure_size))
        {
            let size = blas_sizes.acceleration_structure_size;
            let blas = AccelStruct::new(ctx, vk::AccelerationStructureTypeKHR::BOTTOM_LEVEL, size, self.names.blas)?;
            let instance = Self::instance_buffer(ctx, blas.address, self.names.tlas)?;
            if let Some(old) = self.blas.replace(blas) {
                if shrink {
                    tracing::debug!(blas = self.names.blas, from = self.sized_for, to = count, "box BLAS shrinks");
                    up.count_shrink(old.buffer.size, size);
                }
                old.bury(up.graveyard, up.frame_value);
            }
            if let Some(old) = self.instances.replace(instance) {
                up.graveyard.bury(up.frame_value, Retired::Buffer(old));
            }
            self.sized_for = count;
            self.shrink.reset();
            if shrink {
                self.scratch.shrink_to(up, scratch_need)?;
            }
        }
        if self.tlas.is_none() {
            self.tlas = Some(AccelStruct::new(
                ctx,
                vk::AccelerationStructureTypeKHR::TOP_LEVEL,
                tlas_sizes.acceleration_structure_size,
                self.names.tlas,
            )?);
        }
        let scratch = self.scratch.ensure(ctx, up.graveyard, up.frame_value, scratch_need)?;
        Ok(AabbPlan { work, count, scratch })
    }

    /// A frame that does not bring the structure up to date (nothing to trace, or the method
    /// that traces it not in use). After [`crate::gpu::device::GpuContext::shrink_after_frames`] of them in
    /// a row, everything is released (into the graveyard); the next [`AabbAccel::prepare`]
    /// builds anew.
    pub fn idle(&mut self, up: &mut Upload) {
        if self.blas.is_none() && self.tlas.is_none() {
            return;
        }
        if !self.shrink.unused() {
            return;
        }
        tracing::debug!(blas = self.names.blas, "unused box structures released");
        for a in [self.blas.take(), self.tlas.take()].into_iter().flatten() {
            up.count_shrink(a.buffer.size, 0);
            a.bury(up.graveyard, up.frame_value);
        }
        if let Some(old) = self.instances.take() {
            up.graveyard.bury(up.frame_value, Retired::Buffer(old));
        }
        self.scratch.release(up);
        self.forget();
        self.sized_for = 0;
    }

    /// Forgets the last build, so the next work is a full build (for owners that replaced the
    /// boxes' buffer).
    pub fn forget(&mut self) {
        self.built = None;
        self.refitted_since_build = 0;
    }

    /// Records the planned work over the boxes of `input` (which must hold `plan.count` valid
    /// boxes by then): the BLAS build or refit pass, then the TLAS pass (a build after a
    /// build, an update after a refit).
    pub fn record(&mut self, f: &mut Frame, input: &AabbInput, plan: &AabbPlan) -> Result<(), RenderError> {
        if plan.work == BlasWork::None {
            return Ok(());
        }
        if f.ctx.ray_tracing.is_none() {
            return Err(RenderError::Other(format!("{}: no acceleration structures", self.names.blas)));
        }
        let (Some(blas), Some(tlas), Some(instances)) = (self.blas.as_ref(), self.tlas.as_ref(), self.instances.as_ref()) else {
            return Err(RenderError::Other(format!("{}: recorded without prepare", self.names.blas)));
        };
        let (count, scratch_address, instances) = (plan.count, plan.scratch, instances.address);
        let update = plan.work == BlasWork::Update;
        let (res, names, blas_flags) = (self.res, self.names, self.blas_flags());
        f.pass(if update { names.update_pass } else { names.build_pass }, PassKind::AccelBuild)
            .read(input.boxes, BufferUse::BuildInput)
            .write(res.blas, BufferUse::Accel)
            .write(res.scratch, BufferUse::Accel)
            .record(|p| {
                let geometry = aabb_geometry(input.address);
                let info =
                    build_info(vk::AccelerationStructureTypeKHR::BOTTOM_LEVEL, blas_flags, blas.raw, update, &geometry, scratch_address);
                let ranges = [vk::AccelerationStructureBuildRangeInfoKHR::default().primitive_count(count)];
                // The box buffer holds at least `count` boxes, made visible to builds by the pass's
                // declaration; scratch was sized in `prepare`.
                p.cmd.build_acceleration_structures(&[info], &[&ranges[..]]);
            })?;
        f.pass(names.tlas_pass, PassKind::AccelBuild)
            .read(res.blas, BufferUse::Accel)
            .write(res.tlas, BufferUse::Accel)
            .write(res.scratch, BufferUse::Accel)
            .record(|p| {
                let geometry = one_instance_geometry(instances);
                // After a refit the TLAS is updated in place (its one instance's BLAS is the
                // one it was built over); after a build it is built.
                let info =
                    build_info(vk::AccelerationStructureTypeKHR::TOP_LEVEL, BOX_TLAS_FLAGS, tlas.raw, update, &geometry, scratch_address);
                let ranges = [vk::AccelerationStructureBuildRangeInfoKHR::default().primitive_count(1)];
                // The instance buffer is host-written before submission.
                p.cmd.build_acceleration_structures(&[info], &[&ranges[..]]);
            })?;
        if update {
            self.refitted_since_build += input.changed as u64;
        } else {
            self.refitted_since_build = 0;
            self.built = Some(count);
        }
        Ok(())
    }

    /// Flags of its BLAS builds: updatable, preferring a fast trace.
    fn blas_flags(&self) -> vk::BuildAccelerationStructureFlagsKHR {
        vk::BuildAccelerationStructureFlagsKHR::PREFER_FAST_TRACE | vk::BuildAccelerationStructureFlagsKHR::ALLOW_UPDATE
    }

    /// A new host-written buffer holding the one instance of `blas` (new rather than rewritten:
    /// a frame in flight may be reading the old one).
    fn instance_buffer(ctx: &GpuContext, blas: vk::DeviceAddress, name: &str) -> Result<Buffer, RenderError> {
        let instance = single_instance(blas, 0);
        let mut buffer = Buffer::new(
            ctx,
            name,
            std::mem::size_of::<vk::AccelerationStructureInstanceKHR>() as u64,
            vk::BufferUsageFlags::ACCELERATION_STRUCTURE_BUILD_INPUT_READ_ONLY_KHR | vk::BufferUsageFlags::SHADER_DEVICE_ADDRESS,
            MemoryLocation::CpuToGpu,
        )?;
        let bytes = instance_bytes(&instance);
        buffer.mapped()[..bytes.len()].copy_from_slice(bytes);
        Ok(buffer)
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

/// Flags of the one-instance TLAS builds (updatable: a BLAS refit updates it).
const BOX_TLAS_FLAGS: vk::BuildAccelerationStructureFlagsKHR = vk::BuildAccelerationStructureFlagsKHR::from_raw(
    vk::BuildAccelerationStructureFlagsKHR::PREFER_FAST_TRACE.as_raw() | vk::BuildAccelerationStructureFlagsKHR::ALLOW_UPDATE.as_raw(),
);

/// The geometry of a build over [`GpuAabb`] boxes from `address`. Its any-hit shaders
/// accumulate (decals blend, lights add), so each box must reach them once per ray: without
/// `NO_DUPLICATE_ANY_HIT_INVOCATION` the specification lets an implementation run any-hit twice
/// for one primitive, and a decal would be blended twice.
pub fn aabb_geometry(address: vk::DeviceAddress) -> [vk::AccelerationStructureGeometryKHR<'static>; 1] {
    [vk::AccelerationStructureGeometryKHR::default()
        .geometry_type(vk::GeometryTypeKHR::AABBS)
        .geometry(vk::AccelerationStructureGeometryDataKHR {
            aabbs: vk::AccelerationStructureGeometryAabbsDataKHR::default()
                .data(vk::DeviceOrHostAddressConstKHR { device_address: address })
                .stride(std::mem::size_of::<GpuAabb>() as u64),
        })
        .flags(vk::GeometryFlagsKHR::OPAQUE | vk::GeometryFlagsKHR::NO_DUPLICATE_ANY_HIT_INVOCATION)]
}

/// The geometry of a TLAS build over the instance records at `address`.
pub fn instances_geometry(address: vk::DeviceAddress) -> vk::AccelerationStructureGeometryKHR<'static> {
    vk::AccelerationStructureGeometryKHR::default().geometry_type(vk::GeometryTypeKHR::INSTANCES).geometry(
        vk::AccelerationStructureGeometryDataKHR {
            instances: vk::AccelerationStructureGeometryInstancesDataKHR::default()
                .data(vk::DeviceOrHostAddressConstKHR { device_address: address }),
        },
    )
}

/// The geometry of a TLAS build over one instance record at `address`.
fn one_instance_geometry(address: vk::DeviceAddress) -> [vk::AccelerationStructureGeometryKHR<'static>; 1] {
    [instances_geometry(address)]
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
