//! The renderer's error type.
//!
//! Errors that leave the device or its memory in a state the renderer cannot recover from
//! ([`RenderError::is_fatal`]: the device was lost, GPU or host memory ran out) are reported by
//! the frame as [`RenderError::Frame`], naming the frame number and the operation that failed,
//! so an app can log one clear line and exit instead of rendering garbage.

/// Everything that can go wrong in the renderer.
#[derive(Debug, thiserror::Error)]
pub enum RenderError {
    /// No usable Vulkan loader, driver or device; the message says what to install.
    #[error("{0}")]
    NoVulkan(String),
    /// A Vulkan call failed.
    #[error("Vulkan call failed: {0}")]
    Vulkan(ash::vk::Result),
    /// The GPU stopped responding or was removed (`VK_ERROR_DEVICE_LOST`).
    #[error("the GPU device was lost (driver reset, hang or removal)")]
    DeviceLost,
    /// GPU memory ran out: the driver refused an allocation, or it would pass the renderer's
    /// memory budget (`DeviceSettings::memory_budget`).
    #[error("out of GPU memory allocating {what} ({requested} bytes; {in_use} bytes in use{})", budget.map(|b| format!(", budget {b} bytes")).unwrap_or_default())]
    OutOfMemory {
        /// What was being allocated (the buffer's or image's name).
        what: String,
        /// Bytes requested.
        requested: u64,
        /// Bytes already allocated through the renderer's allocator.
        in_use: u64,
        /// The budget, when one is set.
        budget: Option<u64>,
    },
    /// GPU memory could not be allocated for another reason.
    #[error("GPU memory allocation failed: {0}")]
    Allocation(gpu_allocator::AllocationError),
    /// A frame failed: which frame, and what it was doing.
    #[error("frame {frame}: {operation} failed: {source}")]
    Frame {
        /// The frame number (0 for the first frame).
        frame: u64,
        /// What the frame was doing, e.g. "recording the deferred frame".
        operation: &'static str,
        /// The cause.
        source: Box<RenderError>,
    },
    /// Anything else, described.
    #[error("{0}")]
    Other(String),
}

impl From<ash::vk::Result> for RenderError {
    fn from(result: ash::vk::Result) -> Self {
        match result {
            ash::vk::Result::ERROR_DEVICE_LOST => RenderError::DeviceLost,
            other => RenderError::Vulkan(other),
        }
    }
}

impl From<gpu_allocator::AllocationError> for RenderError {
    fn from(error: gpu_allocator::AllocationError) -> Self {
        match error {
            gpu_allocator::AllocationError::OutOfMemory => {
                RenderError::OutOfMemory { what: "an allocation".into(), requested: 0, in_use: 0, budget: None }
            }
            other => RenderError::Allocation(other),
        }
    }
}

impl RenderError {
    /// Whether the renderer cannot go on after this error: the device was lost, or device or
    /// host memory ran out (the frame that failed left work half-recorded).
    pub fn is_fatal(&self) -> bool {
        use ash::vk::Result as R;
        match self {
            RenderError::DeviceLost | RenderError::OutOfMemory { .. } => true,
            RenderError::Vulkan(r) => matches!(*r, R::ERROR_OUT_OF_DEVICE_MEMORY | R::ERROR_OUT_OF_HOST_MEMORY | R::ERROR_DEVICE_LOST),
            RenderError::Frame { source, .. } => source.is_fatal(),
            _ => false,
        }
    }

    /// Wraps the error with the frame and operation it happened in.
    pub fn in_frame(self, frame: u64, operation: &'static str) -> RenderError {
        match self {
            already @ RenderError::Frame { .. } => already,
            source => RenderError::Frame { frame, operation, source: Box::new(source) },
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn device_loss_and_memory_exhaustion_are_fatal_and_name_the_frame() {
        let lost = RenderError::from(ash::vk::Result::ERROR_DEVICE_LOST).in_frame(42, "submitting the frame");
        assert!(lost.is_fatal());
        assert_eq!(lost.to_string(), "frame 42: submitting the frame failed: the GPU device was lost (driver reset, hang or removal)");
        assert!(RenderError::from(ash::vk::Result::ERROR_OUT_OF_DEVICE_MEMORY).is_fatal());
        assert!(RenderError::from(gpu_allocator::AllocationError::OutOfMemory).is_fatal());
        let oom = RenderError::OutOfMemory { what: "decal records".into(), requested: 4096, in_use: 100, budget: Some(1000) };
        assert!(oom.to_string().contains("decal records") && oom.to_string().contains("budget 1000"));
        assert!(!RenderError::Other("a bad size".into()).is_fatal());
        assert!(!RenderError::from(ash::vk::Result::ERROR_FORMAT_NOT_SUPPORTED).is_fatal());
    }
}
