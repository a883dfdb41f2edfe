//! Runnable examples of the plugin as a game uses it, each one file in this folder:
//!
//! - `minimal`: a mesh, a light and a camera in a window;
//! - `shoot`: a glTF model, lit and framed, and a click shoots a fading bullet hole into it, in
//!   under 30 lines of its own code;
//! - `decals`: click to shoot bullet holes that fade out; a decal riding on a moving crate;
//! - `lights`: hundreds of moving coloured lights;
//! - `gltf_viewer`: any glTF or GLB, framed at any scale, with orbit controls;
//! - `headless_test`: the pattern for testing a game's own systems without a window;
//! - `sparks`: GPU particles from gameplay: a stream of sparks off a spinning crate, and a click
//!   throws a burst that bounces on the floor.
//!
//! `cargo run --example NAME` opens a window; `-- --headless [--frames N] [--size WxH]
//! [--screenshot PATH]` renders offscreen instead (how CI runs them all). This crate depends only
//! on `engine`, `plugins` and `render`, as a game would, so the examples also prove that a game
//! crate compiles with just those (the ECS derives included).

#![forbid(unsafe_code)]

/// The README's Rust snippets, compiled as doc tests so that "Using it from a game" stays true.
#[cfg(doctest)]
#[doc = include_str!("../README.md")]
pub struct ReadmeDoctests;
