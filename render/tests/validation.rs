//! The validation harness itself: a deliberate misuse must be reported, or every "no validation
//! error" assertion elsewhere would prove nothing.

use ash::vk;
use render::device::{DeviceSettings, GpuContext};

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
