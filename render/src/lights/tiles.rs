//! Tiled light culling (seed 001 §4.2) in compute, for every pipeline: the screen is cut into
//! square tiles (8, 16 or 32 pixels, per frame); a first pass computes each tile's side planes
//! in view space (`shaders/light_tile_frusta.comp`), only when the projection, the view size or
//! the tile size changed; a second pass, one workgroup per tile, bounds the tile's depth from the
//! reverse-Z prepass depth and tests every light against the tile's volume
//! (`shaders/light_cull.comp`), writing the light grid (offset, count per tile) and the light
//! index list the shading passes and the shadow pass read (`shaders/include/light_tiles.glsl`).
//!
//! - **No CPU work per frame**: the culling reads the light records that change detection
//!   already keeps on the GPU, and the camera.
//! - **No light is dropped**: the seed capped a tile at 32 lights (one `u32` of visibility bits
//!   per pixel). Here the list is packed (one atomic per tile reserves its range) and the shadow
//!   bits come in rows of 32 entries, so a tile holds any number. When a frame needs more list
//!   entries or shadow rows than the buffers hold, the tiles that do not fit loop over every
//!   light without shadows that frame (correct lighting, no light missing), the overflow is
//!   counted ([`LightTileStats::overflowed`]), and when the CPU reads the needed totals back
//!   (two frames later, with no wait) the buffers grow to a quarter more than that. When the
//!   need (with that quarter) has stayed at or below a quarter of a buffer for a second (60
//!   frames by default, [`crate::gpu::device::GpuContext::shrink_after_frames`]), the buffer
//!   shrinks to its power of two, never below the floors (eight entries a tile, a shadow row a
//!   tile); after as long without tiled lights, or without shadows, the
//!   list or the shadow words are released ([`crate::gpu::upload::Shrink`]). The list is sized
//!   by the same code as the decals' list buffers ([`crate::gpu::room`]), with the same kind of
//!   ceiling, its own: it never takes more than [`crate::gpu::room::MEMORY_SHARE`] of the
//!   renderer's memory (nor 2³⁰ entries), and a need past that is warned about once; the tiles
//!   that do not fit then loop over every light without shadows in every frame, not just
//!   until the list grows.
//! - **Every light** ([`LightMethod::All`]) needs no culling; the shadow rows then hold every
//!   light for every tile, which is affordable up to [`MAX_ALL_LIGHT_SHADOW_BYTES`].

use ash::vk;
use glam::Mat4;
use gpu_allocator::MemoryLocation;

use crate::RenderError;
use crate::gpu::device::GpuContext;
use crate::gpu::memory::{Buffer, Retired};
use crate::gpu::pipeline::create_compute;
use crate::gpu::room::{Fitted, ListRoom, MEMORY_SHARE};
use crate::gpu::shaders;
use crate::gpu::upload::Shrink;
use crate::graph::readback::StatsReadback;
use crate::graph::targets::{DEPTH, TRANSPARENT_DEPTH};
use crate::graph::{BufferUse, Frame, FrameGraph, PassKind, ResourceId};
use crate::layout::{GpuTileFrustum, LIGHT_TILE_HEADER, SHADOW_TINT_SLOTS};
use crate::scene::gpu::GpuScene;
use crate::settings::LightMethod;

/// Most bytes of shadow words when every pixel loops over every light (a row per 32 lights for
/// every tile); with more lights, shadows need light culling.
pub const MAX_ALL_LIGHT_SHADOW_BYTES: u64 = 256 << 20;

pub use crate::stats::LightTileStats;

/// What a frame asks of light culling.
#[derive(Clone, Copy, Debug)]
pub struct TileRequest {
    /// The light method applied.
    pub method: LightMethod,
    /// Tile side in pixels.
    pub tile_size: u32,
    /// Light slots (the light table's high-water mark).
    pub light_slots: u32,
    /// The camera's projection (the tile frusta follow it).
    pub proj: Mat4,
    /// Whether shadow words are needed.
    pub shadows: bool,
    /// Whether transparent surfaces are drawn this frame by the forward transparency pass:
    /// culling then also reads their depth (`TRANSPARENT_DEPTH`), so the lists light the glass
    /// in front of the opaque surfaces, and with shadows the shadow words and tints get a second
    /// layer for the nearest glass ([`TileFrame::glass_layer`]).
    pub transparent: bool,
    /// Whether the shadow pass keeps the colours of light that crossed glass (coloured shadows
    /// with blended instances in the scene): the shadow tints then exist beside the words.
    pub tints: bool,
}

/// The light grid and index list as the GPU wrote them (for tests and tools).
#[derive(Clone, Debug)]
pub struct LightTileLists {
    /// Tile side in pixels.
    pub tile_size: u32,
    /// Tiles across and down.
    pub tiles: (u32, u32),
    /// Per tile: list offset, count (`LIGHT_TILE_OVERFLOW` set when it did not fit), first
    /// shadow row.
    pub grid: Vec<[u32; 3]>,
    /// The light index list.
    pub list: Vec<u32>,
}

impl LightTileLists {
    /// The light slots of the tile holding pixel (`x`, `y`); `None` when that tile overflowed
    /// (its pixels looped over every light).
    pub fn lights_at(&self, x: u32, y: u32) -> Option<&[u32]> {
        let tile = (y / self.tile_size) * self.tiles.0 + x / self.tile_size;
        let [offset, count, _] = self.grid[tile as usize];
        if count & crate::layout::LIGHT_TILE_OVERFLOW != 0 {
            return None;
        }
        self.list.get(offset as usize..(offset + count) as usize)
    }
}

/// Where this frame's light-culling data is.
#[derive(Clone, Copy, Debug, Default)]
pub struct TileFrame {
    /// The light tile buffer (0 unless tiled).
    pub light_tiles: vk::DeviceAddress,
    /// The tiles' frusta (0 unless tiled).
    pub tile_frusta: vk::DeviceAddress,
    /// The shadow words (0 without shadows).
    pub shadow_bits: vk::DeviceAddress,
    /// The shadow tints (0 without coloured shadows).
    pub shadow_tints: vk::DeviceAddress,
    /// Tile side in pixels.
    pub tile_size: u32,
    /// Tiles across and down.
    pub tiles: (u32, u32),
    /// List entries there is room for.
    pub list_capacity: u32,
    /// Shadow rows there is room for.
    pub shadow_rows: u32,
    /// Whether shadow words exist this frame.
    pub shadows: bool,
    /// Whether culling reads the transparent depth too.
    pub transparent: bool,
    /// Whether the shadow words and tints hold a second layer, for the nearest blended surface
    /// (the shadow pass runs again over the transparent depth; `GLASS_SHADOWS`).
    pub glass_layer: bool,
    rebuild_frusta: bool,
    tiled: bool,
}

/// The culling passes, the tile buffers and the statistics read back from them.
pub struct LightTiles {
    frusta_pipeline: vk::Pipeline,
    cull_pipeline: vk::Pipeline,
    /// Culling that also widens tiles by the transparent depth.
    cull_transparent_pipeline: vk::Pipeline,
    frusta: Option<Buffer>,
    /// Projection, view size and tile size the frusta were computed for.
    frusta_key: Option<([u32; 16], u32, u32, u32)>,
    /// The light tile buffer: the statistics header, the grid, then the list's entries.
    list: ListRoom,
    tiles_for: (u32, u32, u32),
    shadow: Option<Buffer>,
    shadow_rows: u32,
    shadow_row_words: u32,
    /// Layers of shadow words: 2 with the glass layer.
    shadow_layers: u32,
    /// Coloured shadows' per-pixel tints, and the view size and layers they were made for.
    tints: Option<(Buffer, vk::Extent2D, u32)>,
    readback: StatsReadback,
    latest: LightTileStats,
    /// Shadow rows the last measured frame needed.
    rows_needed: u64,
    /// Times the shadow words and tints grew or shrank (the list counts its own).
    grows: u64,
    shrinks: u64,
    shadow_shrink: Shrink,
    warned_all_shadows: bool,
    res: TileResources,
}

/// The graph resources of light culling.
#[derive(Clone, Copy, Debug)]
pub struct TileResources {
    /// The tiles' frusta.
    pub frusta: ResourceId,
    /// The light tile buffer (statistics, grid, list).
    pub tiles: ResourceId,
    /// The shadow words.
    pub shadow: ResourceId,
}

impl LightTiles {
    /// Creates the passes and the readback buffers; the tile buffers wait for first use.
    pub fn new(ctx: &GpuContext, graph: &mut FrameGraph, layout: vk::PipelineLayout) -> Result<Self, RenderError> {
        let readback = StatsReadback::new(ctx, graph, "light tile statistics", LIGHT_TILE_HEADER as u64 * 4)?;
        Ok(Self {
            frusta_pipeline: create_compute(ctx, layout, "light tile frusta", shaders::LIGHT_TILE_FRUSTA_COMP)?,
            cull_pipeline: create_compute(ctx, layout, "light culling", shaders::LIGHT_CULL_COMP)?,
            cull_transparent_pipeline: create_compute(ctx, layout, "light culling (transparency)", shaders::LIGHT_CULL_COMP_TRANSPARENT)?,
            frusta: None,
            frusta_key: None,
            list: ListRoom::new(ctx, "light tiles", 1024),
            tiles_for: (0, 0, 0),
            shadow: None,
            shadow_rows: 0,
            shadow_row_words: 0,
            shadow_layers: 0,
            tints: None,
            readback,
            latest: LightTileStats { measured_frame: u64::MAX, ..Default::default() },
            rows_needed: 0,
            grows: 0,
            shrinks: 0,
            shadow_shrink: ctx.shrink_rule(),
            warned_all_shadows: false,
            res: TileResources {
                frusta: graph.resource("light tile frusta"),
                tiles: graph.resource("light tiles"),
                shadow: graph.resource("shadow bits"),
            },
        })
    }

    /// The graph resources.
    pub fn resources(&self) -> TileResources {
        self.res
    }

    /// Reads back the statistics of the frame that last used this frame's slot, sizes the
    /// buffers for the `request`, and says where everything is. Call before the scene's upload (the
    /// lighting record carries the addresses).
    pub fn prepare(&mut self, f: &mut Frame, request: &TileRequest, stats: &mut LightTileStats) -> Result<TileFrame, RenderError> {
        let TileRequest { method, tile_size, light_slots, proj, shadows, transparent, tints } = *request;
        let ctx = f.ctx;
        let extent = f.graph.extent();
        let tiles = (extent.width.div_ceil(tile_size), extent.height.div_ceil(tile_size));
        let tile_count = tiles.0 * tiles.1;
        let tile_pixels = tile_size * tile_size;
        if let Some((frame, words)) = self.readback.take(f) {
            self.rows_needed = words[1] as u64;
            self.latest = LightTileStats {
                measured_frame: frame,
                tiles: self.tiles_for.0 as u64 * self.tiles_for.1 as u64,
                tile_size: self.tiles_for.2 as u64,
                entries: words[0] as u64,
                capacity: self.list.capacity as u64,
                overflowed: words[2] as u64,
                max_per_tile: words[3] as u64,
                tiles_used: words[4] as u64,
                sampled_tiles: words[5] as u64,
                grows: self.list.grows + self.grows,
                shrinks: self.list.shrinks + self.shrinks,
            };
        }
        let frame_value = f.upload.frame_value;
        let tiled = method == LightMethod::Tiled;
        let mut frame = TileFrame { tile_size, tiles, tiled, transparent: transparent && tiled, ..Default::default() };

        if tiled {
            // The list: room for what the last measured frame needed, and at first for eight
            // lights a tile (or every light, when there are fewer).
            self.list.set_initial(tile_count.saturating_mul(light_slots.min(8)).max(1024));
            let fixed = (LIGHT_TILE_HEADER as u64 + 3 * tile_count as u64) * 4;
            let limit = self.list.limit(ctx, fixed);
            let overflowed = self.latest.overflowed;
            let warning = |needed: u32| {
                format!(
                    "light culling needs {needed} list entries, past the ceiling of {limit} (1/{} of {} MiB of GPU memory): {overflowed} tiles loop over every light, without shadows, instead",
                    MEMORY_SHARE.1,
                    ctx.memory_limit() >> 20,
                )
            };
            let remake = self.tiles_for != (tiles.0, tiles.1, tile_size);
            if let Fitted::New { .. } = self.list.fit(f, (self.latest.entries, overflowed), (fixed, limit), remake, warning)? {
                // The frusta follow the tiles (their count may have changed with the buffer).
                let frusta = Buffer::new(
                    ctx,
                    "light tile frusta",
                    tile_count as u64 * std::mem::size_of::<GpuTileFrustum>() as u64,
                    vk::BufferUsageFlags::STORAGE_BUFFER | vk::BufferUsageFlags::SHADER_DEVICE_ADDRESS,
                    MemoryLocation::GpuOnly,
                )?;
                if let Some(old) = self.frusta.replace(frusta) {
                    f.upload.graveyard.bury(frame_value, Retired::Buffer(old));
                    self.frusta_key = None;
                }
                self.tiles_for = (tiles.0, tiles.1, tile_size);
            }
            let key = (proj.to_cols_array().map(f32::to_bits), extent.width, extent.height, tile_size);
            frame.rebuild_frusta = self.frusta_key != Some(key);
            self.frusta_key = Some(key);
            frame.light_tiles = self.list.buffer.as_ref().map_or(0, |b| b.address);
            frame.tile_frusta = self.frusta.as_ref().map_or(0, |b| b.address);
            frame.list_capacity = self.list.capacity;
        } else if self.list.idle(&mut f.upload) {
            // A second without tiled lights: the list went, and the frusta go with it.
            if let Some(old) = self.frusta.take() {
                f.upload.bury_shrunk(old, 0);
            }
            (self.frusta_key, self.tiles_for) = (None, (0, 0, 0));
            // The next culling starts again from the initial room, as the decals' lists do, and
            // what the list last measured goes with it.
            self.latest = LightTileStats { measured_frame: u64::MAX, ..Default::default() };
            self.readback.forget();
        }

        let mut shadow_used = false;
        let layers = if transparent { 2 } else { 1 };
        if shadows {
            let same_size = tile_pixels == self.shadow_row_words;
            // `rows`: what a new or grown buffer gets; `need`: what this frame needs at the least.
            let (rows, need) = if tiled {
                // A row per 32 entries of each tile's list: at first one per tile, then what the
                // last measured frame needed.
                // Rows measured at another tile size say nothing about this one.
                let floor = tile_count.max(64);
                let kept = if same_size { self.shadow_rows.max(floor) } else { floor };
                let needed = if same_size { self.rows_needed.min(u32::MAX as u64 / 2) as u32 } else { 0 };
                (if needed > kept { (needed + needed / 4).next_power_of_two() } else { kept }, floor.max(needed + needed / 4))
            } else {
                let rows = tile_count * light_slots.div_ceil(32).max(1);
                (rows, rows)
            };
            let smaller = self.shadow_shrink.check(self.shadow_rows as u64, need as u64, 0);
            let rows = if self.shadow.is_none() || !same_size || rows > self.shadow_rows {
                rows
            } else {
                smaller.map_or(self.shadow_rows, |r| r as u32)
            };
            let bytes = rows as u64 * tile_pixels as u64 * 4 * layers as u64;
            if !tiled && bytes > MAX_ALL_LIGHT_SHADOW_BYTES {
                if !self.warned_all_shadows {
                    self.warned_all_shadows = true;
                    tracing::warn!(
                        lights = light_slots,
                        "too many lights for shadows without light culling: no shadows (use tiled lights)"
                    );
                }
            } else {
                shadow_used = true;
                if self.shadow.is_none() || rows != self.shadow_rows || !same_size || layers != self.shadow_layers {
                    // (A smaller buffer after a tile-size change: `rows` came from the floor.)
                    let buffer = Buffer::new(
                        ctx,
                        "shadow bits",
                        bytes.max(4),
                        vk::BufferUsageFlags::STORAGE_BUFFER | vk::BufferUsageFlags::SHADER_DEVICE_ADDRESS,
                        MemoryLocation::GpuOnly,
                    )?;
                    if let Some(old) = self.shadow.replace(buffer) {
                        if bytes < old.size {
                            self.shrinks += 1;
                            f.upload.bury_shrunk(old, bytes);
                        } else {
                            self.grows += 1;
                            f.upload.graveyard.bury(frame_value, Retired::Buffer(old));
                        }
                    }
                    (self.shadow_rows, self.shadow_row_words, self.shadow_layers) = (rows, tile_pixels, layers);
                    self.shadow_shrink.reset();
                }
                frame.shadows = true;
                frame.shadow_bits = self.shadow.as_ref().map_or(0, |b| b.address);
                frame.shadow_rows = self.shadow_rows;
                frame.glass_layer = layers == 2;
            }
        }
        if shadow_used && tints {
            if self.tints.as_ref().is_none_or(|(_, e, l)| (*e, *l) != (extent, layers)) {
                let bytes = extent.width as u64 * extent.height as u64 * SHADOW_TINT_SLOTS as u64 * 4 * layers as u64;
                let usage = vk::BufferUsageFlags::STORAGE_BUFFER | vk::BufferUsageFlags::SHADER_DEVICE_ADDRESS;
                let buffer = Buffer::new(ctx, "shadow tints", bytes.max(4), usage, MemoryLocation::GpuOnly)?;
                if let Some((old, ..)) = self.tints.replace((buffer, extent, layers)) {
                    f.upload.graveyard.bury(frame_value, Retired::Buffer(old));
                }
                self.grows += 1;
            }
            frame.shadow_tints = self.tints.as_ref().map_or(0, |(b, ..)| b.address);
        } else if let Some((old, ..)) = self.tints.take() {
            // No glass (or no coloured shadows) this frame: the tints go at once; they are as
            // large as a G-buffer target and come back within a frame when needed.
            f.upload.bury_shrunk(old, 0);
            self.shrinks += 1;
        }
        if !shadow_used && self.shadow.is_some() && self.shadow_shrink.unused() {
            // A second without shadow words: they go.
            if let Some(old) = self.shadow.take() {
                f.upload.bury_shrunk(old, 0);
            }
            (self.shadow_rows, self.shadow_row_words, self.shadow_layers) = (0, 0, 0);
            self.shrinks += 1;
        }
        *stats = LightTileStats {
            tiles: tile_count as u64,
            tile_size: tile_size as u64,
            // The room held, used this frame or not (none once released).
            capacity: self.list.capacity as u64,
            grows: self.list.grows + self.grows,
            shrinks: self.list.shrinks + self.shrinks,
            ..self.latest
        };
        Ok(frame)
    }

    /// Culls the lights into the tiles (when tiled): the frusta when they changed, the grid and
    /// list from the depth, and a copy of the statistics for the CPU. Needs this frame's depth.
    pub fn cull(&mut self, f: &mut Frame, scene: &GpuScene, frame: &TileFrame) -> Result<(), RenderError> {
        if !frame.tiled {
            return Ok(());
        }
        let (Some(tiles), Some(_)) = (self.list.buffer.as_ref(), self.frusta.as_ref()) else { return Ok(()) };
        let res = self.res;
        let tile_count = frame.tiles.0 * frame.tiles.1;
        if frame.rebuild_frusta {
            let pipeline = self.frusta_pipeline;
            f.pass("light_tile_frusta", PassKind::Compute)
                .read(scene.res.tables, BufferUse::Storage)
                .write(res.frusta, BufferUse::Storage)
                .record(|p| {
                    p.bind(vk::PipelineBindPoint::COMPUTE, pipeline, &p.push);
                    p.cmd.dispatch(tile_count.div_ceil(64), 1, 1);
                })?;
        }
        let raw = tiles.raw;
        f.pass("light_tiles_clear", PassKind::Transfer).write(res.tiles, BufferUse::Transfer).record(|p| {
            // Not the last word: the GPU's frame count (`LSTAT_FRAME` in light_tiles.glsl).
            p.cmd.fill_buffer(raw, 0, (LIGHT_TILE_HEADER as u64 - 1) * 4, 0);
        })?;
        let pipeline = if frame.transparent { self.cull_transparent_pipeline } else { self.cull_pipeline };
        let pass = f.pass("light_cull", PassKind::Compute).sample(&DEPTH);
        let pass = if frame.transparent { pass.sample(&TRANSPARENT_DEPTH) } else { pass };
        pass.read(scene.res.tables, BufferUse::Storage).read(res.frusta, BufferUse::Storage).write(res.tiles, BufferUse::Storage).record(
            |p| {
                p.bind(vk::PipelineBindPoint::COMPUTE, pipeline, &p.push);
                p.cmd.dispatch(frame.tiles.0, frame.tiles.1, 1);
            },
        )?;
        self.readback.record(f, "light_tiles_statistics", res.tiles, raw)
    }

    /// The light grid and list the last culling wrote (waits for the GPU); `None` before any.
    pub fn read_back(&self, ctx: &GpuContext, graph: &mut FrameGraph) -> Result<Option<LightTileLists>, RenderError> {
        let Some(buffer) = self.list.buffer.as_ref() else { return Ok(None) };
        let (tx, ty, tile_size) = self.tiles_for;
        let size = (LIGHT_TILE_HEADER as u64 + 3 * (tx * ty) as u64 + self.list.capacity as u64) * 4;
        let bytes = graph.read_back_buffer(ctx, self.res.tiles, buffer.raw, size)?;
        let words: &[u32] = bytemuck::cast_slice(&bytes);
        let grid_start = LIGHT_TILE_HEADER as usize;
        let list_start = grid_start + 3 * (tx * ty) as usize;
        let grid = words[grid_start..list_start].chunks_exact(3).map(|g| [g[0], g[1], g[2]]).collect();
        Ok(Some(LightTileLists { tile_size, tiles: (tx, ty), grid, list: words[list_start..].to_vec() }))
    }

    /// Destroys everything; the GPU must be idle.
    pub fn destroy(self, ctx: &GpuContext) {
        for p in [self.frusta_pipeline, self.cull_pipeline, self.cull_transparent_pipeline] {
            // SAFETY: the GPU is idle.
            unsafe { ctx.destroying().destroy_pipeline(p, None) };
        }
        self.list.destroy(ctx);
        for b in [self.frusta, self.shadow, self.tints.map(|(b, ..)| b)].into_iter().flatten() {
            b.destroy(ctx);
        }
        self.readback.destroy(ctx);
    }
}
