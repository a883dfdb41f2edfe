//! The Vulkan layer: device and capability tiers, memory, uploads, pipelines, frame
//! synchronisation, timestamps, targets, and the passes of each pipeline.
//!
//! This crate knows nothing of the ECS. It takes plain data: a [`scene::SceneMirror`] of records
//! in stable slots that extraction keeps up to date, plus per-frame [`renderer::FrameSettings`].
//! `plugins` bridges the ECS to it.

pub mod decal_debug;
pub mod decals;
pub mod deferred;
pub mod device;
pub mod forward;
pub mod gpu_scene;
pub mod layout;
pub mod memory;
pub mod overlay;
pub mod pass;
pub mod pipeline;
pub mod renderer;
pub mod scene;
pub mod shaders;
pub mod sync;
pub mod targets;
pub mod timestamps;
pub mod tonemap;
pub mod upload;
pub mod visbuffer;
pub mod window;

pub use device::{Capabilities, DeviceSettings, Tier};
pub use renderer::{DebugView, DecalMethod, FinishedFrame, FrameReport, FrameSettings, PipelineKind, Renderer, RendererSettings};
pub use scene::{FrameCounters, SceneMirror};
pub use timestamps::PassTimes;

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
