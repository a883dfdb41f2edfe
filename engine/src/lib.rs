//! The engine layer of the rendering plugin: a small application shell over `bevy_ecs`
//! (schedules, plugins, time), window-independent keyboard and mouse state, transforms and their
//! hierarchy, cameras, lights, generational asset storage, CPU-side meshes, materials and
//! images, and glTF loading.
//!
//! Nothing in this crate knows about Vulkan: the `plugins` crate extracts the data defined here
//! (meshes, materials, images, transforms, lights) into the `render` crate's plain records.

#![warn(missing_docs)]
#![forbid(unsafe_code)]

pub mod app;
pub mod asset;
pub mod camera;
pub mod defaults;
pub mod gltf;
pub mod image;
pub mod input;
pub mod light;
pub mod material;
pub mod mesh;
pub mod prelude;
pub mod scene;
pub mod time;
pub mod transform;
