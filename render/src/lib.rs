//! The Vulkan layer: device and capability tiers, memory, uploads, pipelines, frame
//! synchronisation, timestamps, targets, and the passes of each pipeline.
//!
//! This crate knows nothing of the ECS. It takes plain data: a [`scene::SceneMirror`] of records
//! in stable slots that extraction keeps up to date, plus per-frame [`renderer::FrameSettings`].
//! `plugins` bridges the ECS to it.
//!
//! | module | holds |
//! | --- | --- |
//! | [`gpu`] | the Vulkan core: device, memory, uploads, timestamps, shaders, pipeline creation |
//! | [`graph`] | the frame graph: passes declare their reads and writes, barriers are derived |
//! | [`layout`] | the records, push constants and constants Rust and GLSL share, described once |
//! | [`scene`] | the scene mirror (plain data) and its GPU tables |
//! | [`decals`] | decal acceleration structures, deferred decals, decal debug views |
//! | [`lights`] | tiled light culling and the lighting record |
//! | [`shadows`] | the scene's acceleration structures and ray-traced shadows |
//! | [`pipelines`] | forward, Forward+, deferred and visibility-buffer frames |
//! | [`present`] | tone mapping, overlay, window swapchain |
//! | [`renderer`] | frames in flight, submit |
//! | [`settings`] | per-frame settings: pipeline, decal method, debug view |

pub mod decals;
pub mod error;
pub mod gpu;
pub mod graph;
pub mod layout;
pub mod lights;
pub mod pipelines;
pub mod present;
pub mod renderer;
pub mod scene;
pub mod settings;
pub mod shadows;

pub use error::RenderError;
pub use gpu::device::{Capabilities, DeviceSettings, Tier};
pub use gpu::timestamps::PassTimes;
pub use present::{overlay, window};
pub use renderer::{DebugView, DecalMethod, FinishedFrame, FrameReport, FrameSettings, PipelineKind, Renderer, RendererSettings};
pub use scene::{FrameCounters, SceneMirror};
pub use settings::{DepthNormals, LightMethod, LightSettings, RaySupport, ShadowMethod};
