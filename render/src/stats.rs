//! What a frame did and what its techniques measured, as the frame reports it: the
//! [`FrameCounters`] of `crate::renderer::FrameReport`, which the renderer starts afresh each
//! frame and hands to the techniques through the frame function, and the plain records they
//! hold. Kept here, below the techniques, so that the report names them without importing the
//! techniques that fill them (`crate::culling`, `crate::lights::tiles`, `crate::reflections`,
//! `crate::environment`, `crate::decals`; each re-exports its own). The scene mirror holds no
//! statistics: it counts only the records written into it ([`crate::scene::SceneMirror::records_written`]).

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
/// [`DecalClusterStats`]).
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
    /// Tiles whose pixels sampled their lights' shadows instead of tracing a ray per light
    /// (`crate::lights::sampling`; with `DirectLight::Auto`, those listing more than 32 lights).
    pub sampled_tiles: u64,
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

/// Work counters for one frame. Tests, `--stats` and the overlay read these; keys never change
/// meaning.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct FrameCounters {
    /// Bytes copied from the CPU to GPU memory this frame (records, meshes, textures; culling's
    /// parameters in the frame they change, though each frame slot's copy of them is written).
    pub bytes_uploaded: u64,
    /// Records (instances, materials, lights, camera, decals) written this frame.
    pub records_written: u64,
    /// Bottom-level acceleration structure builds.
    pub blas_builds: u64,
    /// Bottom-level acceleration structure updates (refits).
    pub blas_updates: u64,
    /// Top-level acceleration structure builds.
    pub tlas_builds: u64,
    /// Scene BLAS builds (one per mesh loaded).
    pub scene_blas_builds: u64,
    /// Scene BLAS compactions (one per mesh, a few frames after its build).
    pub scene_blas_compactions: u64,
    /// Scene TLAS builds (instances added or removed, meshes or materials changed).
    pub scene_tlas_builds: u64,
    /// Scene TLAS updates (only transforms changed).
    pub scene_tlas_updates: u64,
    /// Ray-query lights' BLAS builds (the light slots left the built range, or refits degraded it).
    pub light_blas_builds: u64,
    /// Ray-query lights' BLAS refits (lights changed within the built range).
    pub light_blas_updates: u64,
    /// GPU buffers and acceleration structures replaced by smaller ones, or released after going
    /// unused, this frame (record tables, decal and light structures and their scratch, light
    /// boxes, decal clusters, light tiles, the scene TLAS, staging rings: see
    /// [`crate::gpu::upload::Shrink`]).
    pub buffer_shrinks: u64,
    /// Bytes of GPU memory those shrinks hand back (freed once the GPU has finished the frames
    /// that used the old buffers).
    pub bytes_released: u64,
    /// Live mesh instances.
    pub instances: u64,
    /// Live lights.
    pub lights: u64,
    /// Live decals.
    pub decals: u64,
    /// Blended (transparent) instances drawn back to front this frame.
    pub transparent: u64,
    /// Shadow-map views drawn this frame (a spot or directional light's one, a point light's
    /// six; zero unless shadows came from maps).
    pub shadow_map_views: u64,
    /// Lights left without a shadow map this frame because the atlas was full
    /// (`RendererSettings::shadow_maps`).
    pub shadow_maps_missing: u64,
    /// Clustered decals, as measured on the GPU. Frames without them still show the room held
    /// (until it is released, a second later) beside the figures of the last frames that binned;
    /// a released buffer forgets those figures (zero, `measured_frame` `u64::MAX`).
    pub clusters: DecalClusterStats,
    /// The ray-tracing-pipeline decal pass's per-pixel lists, as measured on the GPU; frames
    /// without that pass as for [`Self::clusters`].
    pub decal_lists: DecalListStats,
    /// Tiled light culling, as measured on the GPU; frames without it as for [`Self::clusters`].
    pub light_tiles: LightTileStats,
    /// Instance culling for the main view, as measured on the GPU (`crate::culling`).
    pub culling: CullingStats,
    /// Draw commands the CPU recorded this frame, every pass (indirect draws: each covers a
    /// batch of instances).
    pub draw_calls: u64,
    /// Whether this frame's command buffer was submitted again as an earlier frame recorded it,
    /// the frame's commands being exactly the same (`crate::gpu::commands`).
    pub commands_reused: bool,
    /// Words in the frame's command log (every command and its arguments).
    pub command_words: u64,
    /// Bytes of the mesh pool's buffer (`crate::scene::pool`).
    pub mesh_pool_bytes: u64,
    /// Of those, the bytes posed meshes' copies hold (`crate::skinning`).
    pub posed_mesh_bytes: u64,
    /// The texture budget: its bytes, the scene textures' bytes on the GPU, and the levels (and
    /// their bytes) dropped to fit it since the start.
    pub texture_budget: crate::scene::gpu::TextureBudgetReport,
    /// Posed meshes the skinning pass wrote this frame (`crate::skinning`).
    pub skinned_meshes: u64,
    /// Vertices it skinned.
    pub skinned_vertices: u64,
    /// Instances the motion-vector pass drew over the camera's motion this frame: those that
    /// moved or were posed (`crate::motion`; zero unless temporal anti-aliasing runs).
    pub motion_movers: u64,
    /// Scene BLAS refits (posed meshes skinned this frame, or deferred before).
    pub scene_blas_refits: u64,
    /// Posed meshes whose refit waits: smaller on screen than `refit_pixels`, their structures
    /// hold an older pose (`crate::accel`).
    pub scene_blas_refits_deferred: u64,
    /// The most frames one of them has waited (at most `MAX_REFIT_STALENESS`).
    pub scene_blas_stalest: u64,
    /// Particles: what the GPU counted in the last frame whose counts came back
    /// (`crate::particles`).
    pub particles: ParticleCounts,
    /// Reflections: the mode applied, and what the GPU measured (`crate::reflections`).
    pub reflections: ReflectionStats,
    /// The environment: sources filtered so far and the cubes' face size (`crate::environment`).
    pub environment: EnvironmentStats,
    /// GPU memory allocated at the end of the frame, by what it holds, textures also by format
    /// (`crate::gpu::memory`).
    pub memory: crate::gpu::memory::MemoryCounts,
}

/// What clustered decals measured on the GPU. The GPU writes these into the cluster buffer and
/// the CPU reads them once that frame has finished, so a frame reports the statistics of the
/// frame that last used its frame slot (two frames earlier), beside the capacity and growth of
/// its own.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct DecalClusterStats {
    /// Frame whose GPU figures these are (`u64::MAX` before any).
    pub measured_frame: u64,
    /// Clusters (screen tiles × depth slices).
    pub clusters: u64,
    /// Clusters holding at least one decal.
    pub clusters_used: u64,
    /// Entries the clusters needed (decal references over every list).
    pub entries: u64,
    /// Entries the cluster buffer has room for this frame.
    pub capacity: u64,
    /// The most entries it may ever have room for: [`crate::gpu::room::MEMORY_SHARE`]
    /// of the renderer's memory ([`crate::gpu::device::GpuContext::memory_limit`]).
    pub limit: u64,
    /// Entries that did not fit (their decals were missing from those clusters that frame).
    pub dropped: u64,
    /// Times the cluster buffer grew, since the renderer started.
    pub grows: u64,
    /// Times the cluster buffer shrank or was released (unused), since the renderer started.
    pub shrinks: u64,
    /// Most decals in one cluster.
    pub max_per_cluster: u64,
    /// Shaded pixels the decal pass visited.
    pub pixels: u64,
    /// Decals tested over those pixels (list entries walked).
    pub tested: u64,
    /// Most decals tested at one pixel.
    pub max_tested: u64,
    /// Decals applied over those pixels (their box held the pixel).
    pub applied: u64,
    /// Most decals applied at one pixel.
    pub max_applied: u64,
}

/// The ray-tracing-pipeline decal pass's per-pixel decal lists (`crate::decals::lists`): the
/// room they asked for and had, and the pixels that had to blend the seed's way.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct DecalListStats {
    /// Frame whose GPU figures these are (`u64::MAX` before any).
    pub measured_frame: u64,
    /// Entries the list buffer has room for this frame.
    pub capacity: u64,
    /// The most entries it may ever have room for: [`crate::gpu::room::MEMORY_SHARE`]
    /// of the renderer's memory.
    pub limit: u64,
    /// Entries the pixels' lists asked for: each run of 8 pixels along a row, 8 times the most
    /// that one of them asks for (what it found the frame before, an eighth more and two).
    pub needed: u64,
    /// Pixels that found decals the frame before but got no room this frame, the buffer being
    /// full (they blended their decals the seed's way).
    pub denied: u64,
    /// Pixels that found more decals than their room (they traced a second time to blend them).
    pub overflowed: u64,
    /// Times the list buffer grew, since the renderer started.
    pub grows: u64,
    /// Times the list buffer shrank or was released (unused), since the renderer started.
    pub shrinks: u64,
}

/// What the particle system measured in one frame (`crate::particles`, read back two frames
/// later).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct ParticleCounts {
    /// The frame that measured them (`u64::MAX`: none yet).
    pub measured_frame: u64,
    /// Particles alive after that frame's simulation.
    pub alive: u32,
    /// Particles started since the system was created.
    pub spawned: u32,
    /// Particles that touched a surface since the system was created (once each).
    pub landed: u32,
    /// Particles not started because the pool was full, since the system was created.
    pub dropped: u32,
    /// Slots of the pool (0 before the first emitter).
    pub capacity: u32,
    /// Decals landing particles left since the pool was made (the ring keeps the latest
    /// `RendererSettings::particle_decals` of them; a pool made again, when the emitters
    /// outgrow its tables, starts with an empty ring).
    pub decals_born: u32,
    /// This frame's particles collided with the scene's acceleration structure (on a
    /// ray-tracing tier, in a frame that traces it), not with the depth buffer.
    pub ray_traced: bool,
}
