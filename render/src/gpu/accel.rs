//! Acceleration structures and their scratch memory, shared by the decal structures
//! (`crate::decals::accel`), the scene's (`crate::shadows::accel`) and the lights'
//! (`crate::lights::ray_query`).

use ash::vk;
use gpu_allocator::MemoryLocation;

use crate::RenderError;
use crate::gpu::device::GpuContext;
use crate::gpu::memory::{Buffer, Graveyard, Retired};

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
            let scratch = Buffer::new(
                ctx,
                self.name,
                need.next_power_of_two(),
                vk::BufferUsageFlags::STORAGE_BUFFER | vk::BufferUsageFlags::SHADER_DEVICE_ADDRESS,
                MemoryLocation::GpuOnly,
            )?;
            if let Some(old) = self.buffer.replace(scratch) {
                graveyard.bury(frame_value, Retired::Buffer(old));
            }
        }
        Ok(self.buffer.as_ref().expect("allocated above").address.next_multiple_of(self.alignment))
    }

    /// Destroys the buffer; the GPU must be idle.
    pub fn destroy(self, ctx: &GpuContext) {
        if let Some(b) = self.buffer {
            b.destroy(ctx);
        }
    }
}

/// The 64-byte instance record of a TLAS build holding one instance of `blas`, opaque.
pub fn single_instance(blas: vk::DeviceAddress) -> vk::AccelerationStructureInstanceKHR {
    vk::AccelerationStructureInstanceKHR {
        transform: vk::TransformMatrixKHR { matrix: [1.0, 0.0, 0.0, 0.0, 0.0, 1.0, 0.0, 0.0, 0.0, 0.0, 1.0, 0.0] },
        instance_custom_index_and_mask: vk::Packed24_8::new(0, 0xff),
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
