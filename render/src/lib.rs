//! The Vulkan layer: device and capability tiers, memory, uploads, pipelines, frame
//! synchronisation, timestamps, targets, and the passes of each pipeline.
//!
//! This crate knows nothing of the ECS. It takes plain data: a [`scene::SceneMirror`] of records
//! in stable slots that extraction keeps up to date, plus per-frame [`renderer::FrameSettings`].
//! `plugins` bridges the ECS to it.
//!
//! Quick start without the ECS (games use `plugins::GpuPlugin`, which does this for them):
//!
//! ```no_run
//! use render::{FrameSettings, Renderer, RendererSettings, SceneMirror};
//!
//! let mut renderer = Renderer::new(&RendererSettings::default(), 640, 480)?;
//! let mut mirror = SceneMirror::new(); // fill its tables: meshes, instances, lights, camera, decals
//! let report = renderer.render(&mut mirror, &FrameSettings::default())?; // upload what changed, record, submit
//! println!("frame {}: {} bytes uploaded", report.frame, report.counters.bytes_uploaded);
//! let rgba = renderer.read_display()?; // the tone-mapped image
//! # Ok::<(), render::RenderError>(())
//! ```
//!
//! | module | holds |
//! | --- | --- |
//! | [`gpu`] | the Vulkan core: device, memory, uploads, timestamps, shaders, pipeline creation |
//! | [`graph`] | the frame graph: passes declare their reads and writes, barriers are derived |
//! | [`layout`] | the records, push constants and constants Rust and GLSL share, described once |
//! | [`scene`] | the scene mirror (plain data: instances, meshes, poses, the environment) and its GPU tables |
//! | [`stats`] | what the techniques measured, as the frame reports it |
//! | [`decals`] | decal acceleration structures, deferred decals, decal debug views |
//! | [`accel`] | the scene's acceleration structures: a BLAS per mesh, refit for posed meshes, and the TLAS |
//! | [`lights`] | tiled light culling, ray-query lights and the lighting record |
//! | [`shadows`] | ray-traced shadows and shadow maps |
//! | [`occlusion`] | ambient occlusion: traced, or from the depth buffer, and its denoiser |
//! | [`fxaa`], [`smaa`] | post-process anti-aliasing, each a compute technique of its own |
//! | [`lod`] | levels of detail: simplified triangle lists made at upload, chosen per instance by culling |
//! | [`skinning`] | posed meshes: skinning in compute (the poses are scene data, [`scene::poses`]) |
//! | [`pipelines`] | forward, Forward+, deferred and visibility-buffer frames |
//! | [`present`] | tone mapping, overlay, window swapchain |
//! | [`renderer`] | frames in flight, submit |
//! | [`settings`] | per-frame settings: pipeline, decal method, debug view |
//!
//! **Layers.** The lower layers (`gpu`, `graph`, `layout`, `settings`, `stats`, `scene`) name no
//! technique: a frame's statistics live with its report ([`stats::FrameCounters`], which the
//! renderer starts afresh each frame and the frame function hands to each technique; the scene
//! mirror counts only the records written into it), the environment, the poses and the particle emitters a game sets are scene data
//! ([`scene::environment`], [`scene::poses`], [`scene::emitters`]), and what several techniques share is a utility of a lower layer (depth
//! pyramids in [`graph::pyramid`], shading variants in [`gpu::pipeline`]). A technique imports
//! another where the frame function hands it that technique's typed output:
//!
//! 1. `culling::Draws` (the lists a pass draws): shadows, transparency;
//! 2. `decals::DecalFrame` (how this frame's decals are applied): reflections, transparency;
//! 3. `lights::LightFrame` (this frame's lights, the shadow words and the structures traced):
//!    shadows, reflections, transparency, particles;
//! 4. the frames the lighting record is built from: `accel::SceneAccelFrame`,
//!    `environment::EnvironmentFrame`, `occlusion::OcclusionFrame`,
//!    `reflections::ReflectionFrame` (lights).
//!
//! What the render targets hold between passes is typed in the lower layer, so it flows
//! through the frame function without a technique import: the depth stage's
//! [`graph::targets::Surface`] (the G-buffer, the visibility ids or depth alone) and the motion
//! pass's [`graph::targets::MotionVectors`].
//!
//! The frame function owns every technique and hands each the others' typed outputs: it
//! prepares the scene's acceleration structures (`accel`), plans the ambient occlusion against
//! them, hands both to the lights, which write the lighting record, plans the shadows from the
//! lights' frame, and records each technique's passes in the order the frame needs them. MSAA only
//! sets the graph's multisampled targets, the renderer owning the multisampled forward passes;
//! the frame function records SMAA's and FXAA's passes before presenting.
#![recursion_limit = "256"] // layout! recurses once per record field (GpuLighting is long)

pub mod accel;
pub mod bloom;
pub mod culling;
pub mod decals;
pub mod environment;
pub mod error;
pub mod exposure;
pub mod fxaa;
pub mod gpu;
pub mod graph;
#[cfg(test)]
mod layering;
pub mod layout;
pub mod lights;
pub mod lod;
pub mod motion;
pub mod msaa;
pub mod occlusion;
pub mod particles;
pub mod pipelines;
pub mod present;
pub mod reflections;
pub mod renderer;
pub mod scene;
pub mod settings;
pub mod shadows;
pub mod skinning;
pub mod smaa;
pub mod stats;
pub mod taa;
pub mod transparency;

pub use culling::CullingStats;
pub use environment::{Environment, EnvironmentMap, EnvironmentSource, EnvironmentStats, MapProjection};
pub use error::RenderError;
pub use gpu::device::{Capabilities, DeviceSettings, Tier};
pub use gpu::timestamps::PassTimes;
pub use present::{overlay, window};
pub use renderer::{DebugView, DecalMethod, FinishedFrame, FrameReport, FrameSettings, PipelineKind, Renderer, RendererSettings};
pub use scene::SceneMirror;
pub use settings::{
    AntiAliasing, AutoExposure, BloomSettings, CullingMode, DepthNormals, DirectLight, LightMethod, LightSettings, OcclusionMethod,
    OcclusionSettings, RaySupport, ReflectionMode, ReflectionSettings, ShadowMapBudget, ShadowMethod, Tonemapper, TransparencyMethod,
};
pub use stats::FrameCounters;
