//! What the frame's techniques measured, as the frame reports it
//! (the counters of `crate::renderer::FrameReport`): plain records, kept here, below the
//! techniques, so that the scene's counters and the report name them without importing the
//! techniques that fill them (`crate::culling`, `crate::lights::tiles`, `crate::reflections`,
//! `crate::environment`; each re-exports its own).

use crate::layout::LOD_LEVELS;
use crate::settings::{CullingMode, ReflectionMode};

/// What culling measured on the GPU for the main view, read back two frames later (like
/// [`LightTileStats`]).
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct CullingStats {
    /// Frame whose GPU figures these are (`u64::MAX` before any).
    pub measured_frame: u64,
    /// The mode culled with this frame.
    pub mode: CullingMode,
    /// Whether the culling view was frozen this frame.
    pub frozen: bool,
    /// The limit levels of detail were chosen by this frame, in pixels (0: off).
    pub lod_pixels: f32,
    /// Live instances tested for the main view (blended ones included).
    pub instances: u64,
    /// Of those, inside the view frustum (all of them with culling off).
    pub after_frustum: u64,
    /// Of those, drawn: not occluded (as many as `after_frustum` without occlusion culling).
    pub after_occlusion: u64,
    /// Draws lost because a list was full (never expected: the lists have room for every live
    /// instance of their batch).
    pub dropped: u64,
    /// Instances the main view drew at each level of detail, level 0 (full detail) first
    /// (`crate::lod`; every drawn instance is at level 0 with levels of detail off).
    pub lod_instances: [u64; LOD_LEVELS as usize + 1],
    /// Triangles the main view's lists drew (at their levels of detail; every phase and the
    /// glass).
    pub triangles: u64,
}

/// What light culling measured on the GPU, read back two frames later (like
/// [`crate::scene::DecalClusterStats`]).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct LightTileStats {
    /// Frame whose GPU figures these are (`u64::MAX` before any).
    pub measured_frame: u64,
    /// Tiles this frame.
    pub tiles: u64,
    /// Tile side in pixels this frame.
    pub tile_size: u64,
    /// List entries the tiles needed.
    pub entries: u64,
    /// List entries the buffer has room for this frame.
    pub capacity: u64,
    /// Tiles that did not fit (looped over every light, unshadowed, that frame).
    pub overflowed: u64,
    /// Most lights in one tile.
    pub max_per_tile: u64,
    /// Tiles holding any light.
    pub tiles_used: u64,
    /// Times the buffers grew, since the renderer started.
    pub grows: u64,
    /// Times the buffers shrank or were released (unused), since the renderer started.
    pub shrinks: u64,
}

/// What the reflection pass measured on the GPU, read back once its frame has finished (so a
/// frame reports the figures of the frame that last used its frame slot, two frames earlier).
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct ReflectionStats {
    /// The mode applied this frame (after [`ReflectionMode::effective`]).
    pub applied: ReflectionMode,
    /// Whether the rays were traced at half resolution this frame.
    pub half_resolution: bool,
    /// Whether the hit points looked for decals this frame (traced rays only: screen-space ones
    /// see the decals that are on screen, and no others).
    pub decals_at_hits: bool,
    /// Frame whose GPU figures these are (`u64::MAX` before any).
    pub measured_frame: u64,
    /// Pixels that reflect (smoother than the cut-off).
    pub pixels: u64,
    /// Reflection rays traced.
    pub rays: u64,
    /// Rays that hit geometry (the rest saw the sky).
    pub hits: u64,
    /// Decal candidates tested at the hit points (zero-length rays in the decal TLAS).
    pub decals_tested: u64,
    /// Lights found at the hit points (their TLAS, and the unbounded lights).
    pub lights_found: u64,
    /// Rays that crossed glass.
    pub through_glass: u64,
    /// The smallest roughness of any material, or of any decal material that blends roughness:
    /// reflections run only when it is under the cut-off.
    pub smoothest: f32,
}

/// Counters of the environment's work.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct EnvironmentStats {
    /// Times a source was filtered since the renderer started.
    pub filtered: u64,
    /// Face size of the cubes (0 before an environment is first used).
    pub resolution: u32,
}
