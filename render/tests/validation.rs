//! The validation harness itself: a deliberate misuse must be reported, or every "no validation
//! error" assertion elsewhere would prove nothing.

use ash::vk;
use render::gpu::device::{DeviceSettings, GpuContext};

#[test]
fn a_deliberate_misuse_is_reported() {
    let ctx = GpuContext::new(&DeviceSettings { validation: true, ..Default::default() }).expect("device");
    assert!(ctx.validation_enabled);
    assert_eq!(ctx.validation.error_count(), 0);
    // VUID-VkBufferCreateInfo-size-00912: size must be greater than 0.
    let info = vk::BufferCreateInfo::default().size(0).usage(vk::BufferUsageFlags::STORAGE_BUFFER);
    // SAFETY: deliberately invalid create info; the validation layer intercepts it. Whatever the
    // driver returns is destroyed straight away.
    unsafe {
        if let Ok(b) = ctx.device.create_buffer(&info, None) {
            ctx.device.destroy_buffer(b, None);
        }
    }
    let errors = ctx.validation.take_errors();
    assert!(errors.iter().any(|e| e.contains("00912") || e.contains("size")), "expected a size error, got {errors:?}");
}

#[test]
fn a_missing_barrier_is_reported() {
    use render::gpu::memory::Buffer;
    let ctx = GpuContext::new(&DeviceSettings { validation: true, ..Default::default() }).expect("device");
    let usage = vk::BufferUsageFlags::TRANSFER_SRC | vk::BufferUsageFlags::TRANSFER_DST;
    let a = Buffer::new(&ctx, "a", 256, usage, gpu_allocator::MemoryLocation::GpuOnly).expect("buffer");
    let b = Buffer::new(&ctx, "b", 256, usage, gpu_allocator::MemoryLocation::GpuOnly).expect("buffer");
    let region = [vk::BufferCopy { src_offset: 0, dst_offset: 0, size: 256 }];
    // A copy writes `b`, the next reads it with no barrier between: a read-after-write hazard
    // only synchronization validation sees.
    ctx.run_once(|_, cmd| {
        // SAFETY: both buffers are live and 256 bytes long; the hazard is deliberate.
        unsafe {
            ctx.device.cmd_copy_buffer(cmd, a.raw, b.raw, &region);
            ctx.device.cmd_copy_buffer(cmd, b.raw, a.raw, &region);
        }
    })
    .expect("submit");
    let errors = ctx.validation.take_errors();
    a.destroy(&ctx);
    b.destroy(&ctx);
    assert!(errors.iter().any(|e| e.contains("SYNC-HAZARD")), "expected a synchronization hazard, got {errors:?}");
}

/// Pipeline statistics are a profiling aid: asked for on a device without
/// `VK_KHR_pipeline_executable_properties` (lavapipe), the device is still made, without them;
/// where the device offers them they are on, and a pipeline made with them (its statistics
/// captured and logged) gives validation nothing to say either way.
#[test]
fn pipeline_statistics_are_on_only_where_the_device_offers_them() {
    for asked in [true, false] {
        let ctx = GpuContext::new(&DeviceSettings { validation: true, pipeline_statistics: asked, ..Default::default() }).expect("device");
        assert_eq!(ctx.pipeline_statistics, asked && ctx.capabilities.pipeline_executable_properties);
        let skinning = render::skinning::Skinning::new(&ctx).expect("a compute pipeline");
        skinning.destroy(&ctx);
        assert_eq!(ctx.validation.take_errors(), Vec::<String>::new());
    }
}
