//! The sandbox game: the reference example of the public API. A first-person walk through a
//! courtyard (or any glTF) that shoots bullet holes, leaves footprints and drops lights, on the
//! library's window runner and overlay; headless, it renders benchmark scenes and writes
//! statistics and charts.
//!
//! Quick start: `cargo run --release -p sandbox` (a window; `--headless --frames 60 --screenshot
//! out.png --stats out.jsonl` without one; `--help` lists the rest). From code, a headless run:
//!
//! ```no_run
//! use sandbox::headless::{HeadlessOptions, run};
//!
//! let summary = run(&HeadlessOptions { frames: 10, size: (320, 240), ..Default::default() })?;
//! println!("{} frames, {} validation errors", summary.frames.len(), summary.validation_errors.len());
//! # Ok::<(), anyhow::Error>(())
//! ```

#![forbid(unsafe_code)]

pub mod assets;
pub mod bench;
pub mod character;
pub mod charts;
pub mod decal_textures;
pub mod effects;
pub mod game;
pub mod headless;
pub mod light_size;
pub mod scatter;
pub mod scene;
pub mod soak;
pub mod stats;
pub mod window;
