//! The renderer's error type.

/// Everything that can go wrong in the renderer.
#[derive(Debug, thiserror::Error)]
pub enum RenderError {
    /// No usable Vulkan loader, driver or device; the message says what to install.
    #[error("{0}")]
    NoVulkan(String),
    /// A Vulkan call failed.
    #[error("Vulkan call failed: {0}")]
    Vulkan(#[from] ash::vk::Result),
    /// GPU memory could not be allocated.
    #[error("GPU memory allocation failed: {0}")]
    Allocation(#[from] gpu_allocator::AllocationError),
    /// Anything else, described.
    #[error("{0}")]
    Other(String),
}
