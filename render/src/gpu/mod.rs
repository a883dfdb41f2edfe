//! The Vulkan core every pass builds on: the device and its capability tiers, memory and
//! deferred destruction, staging uploads, timestamps, SPIR-V and pipeline creation, and the
//! sizing of GPU-filled list buffers from what they needed (`room`).

pub mod accel;
pub mod commands;
pub mod device;
pub mod memory;
pub mod pipeline;
pub mod room;
pub mod shaders;
pub mod timestamps;
pub mod upload;

/// Frames the CPU may record ahead of the GPU.
pub const FRAMES_IN_FLIGHT: usize = 2;
