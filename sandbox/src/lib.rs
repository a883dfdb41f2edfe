//! The sandbox game: the reference example of the public API.

#![forbid(unsafe_code)]

pub mod bench;
pub mod charts;
pub mod decal_textures;
pub mod game;
pub mod headless;
pub mod scatter;
pub mod scene;
pub mod stats;
pub mod window;
