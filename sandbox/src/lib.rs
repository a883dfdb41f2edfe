//! The sandbox game: the reference example of the public API.

pub mod scene;
pub mod headless;
pub mod stats;
pub mod decal_textures;
pub mod scatter;
pub mod bench;
pub mod game;
pub mod overlay_ui;
pub mod window;
