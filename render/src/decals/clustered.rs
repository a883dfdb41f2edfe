//! Clustered decals (seed 000 §3.3.2.1, DOOM 2016's clustered shading, which §6 names as the
//! comparison the seed did not make): decals with no ray tracing at all. Each frame, compute
//! passes bin the live decals' boxes into view clusters, and a decal pass walks each pixel's
//! cluster list and writes the same decal buffer as the ray-traced decal passes
//! ([`super::buffer`]), so the deferred and visibility-buffer shading apply it unchanged. The
//! layout of the cluster buffer, the binning and the statistics are in
//! `shaders/include/clusters.glsl`.
//!
//! - **Forward and Forward+** can walk the lists in the shading pass itself
//!   ([`crate::settings::FrameSettings::decals_in_forward_shading`],
//!   [`super::DecalFrame::clusters_in_shading`], `CLUSTERED_DECALS` in `shading.glsl`): the
//!   fragment's own position, normal-mapped normal and derivatives, no decal pass and no ids
//!   prepass (issue "decals at a million", item 5; Bevy applies its clustered decals the same
//!   way). A pixel first tests the boxes of its list without any blend state, and blends only
//!   when some decal lands, one channel at a time (`DECAL_BLEND_ONE_CHANNEL` in `blend.glsl`):
//!   the four channels' state in a forward shader cost the lent H100's forward pass more than
//!   the decals did. It is off by default because on that GPU, whose fragment shading is slow
//!   (the same lighting costs 25× more in the forward fragment pass than in deferred compute),
//!   the decal pass with its ids prepass is faster: about equal at 100 decals of PEERS.md's
//!   scene, 1 ms faster at 1,000, and 7 against 290 ms a frame at 100,000 decals on the
//!   courtyard (docs/experiments/decals-in-forward-shading.md). The per-pixel statistics (tested,
//!   applied) come only from the decal pass: the forward shading counts nothing.
//! - **Binning** bounds a box by its part in front of the camera's near plane (its corners
//!   there and where its edges cross the plane). It used to give any box reaching behind the
//!   camera the whole screen: in PEERS.md's decals-and-lights scene at 1,000 decals that was
//!   144,000 entries and 0.80 ms of binning on the lent H100, now 7,600 entries and 0.11 ms.
//!
//! - **Layout**: screen tiles of 32×32 pixels × 16 depth slices (`DECAL_CLUSTER_*` in
//!   `render/src/layout.rs`): 32,640 clusters at 1920×1080. Chosen by measuring tiles of 16, 32
//!   and 64 pixels and 16, 32 and 64 slices on an H200 in two of the seed's scenes
//!   (docs/experiments/decals-cluster-size.md): finer clusters shorten the lists each pixel walks but cost more
//!   binning (each decal lands in more clusters) and a longer prefix sum; 32 × 16 was fastest
//!   over both scenes (with the global slices below, before the depth bounds; not measured
//!   again since). The engines game programmers use cap their decals low (Bevy 1,024, Godot
//!   512 by default) because each cluster holds a bit mask or a fixed list; here the lists are
//!   packed back to back (count, allocate, fill), so no decal count is capped and no cluster
//!   has a budget of its own: the buffer has room for a total number of entries.
//! - **Depth bounds**: the slices of a tile cut the view distances its shaded pixels reach,
//!   which a compute pass reads from the depth target each frame (`decal_cluster_bounds.comp`,
//!   0.01 ms at 1080p), exponentially from the nearest, none thinner than 2 % of its distance.
//!   The slices were exponential from 0.1 m to 1 km for the whole screen before (DOOM's layout):
//!   a tile of ground seen at a slant then shared one slice, metres deep, with every decal
//!   anywhere in it, and a decal hanging in front of a wall was binned wherever its box
//!   projected. In the courtyard with 1,000,000 scattered decals on the lent H100, the decals a
//!   pixel tests fell from 1,940 to 840 (139 apply) and the pass from 23.7 to 14.3 ms (2.36 →
//!   1.48 at 100,000), for 0.02 ms more binning (docs/experiments/decals-cluster-depth-bounds.md);
//!   the lists hold more entries (a box now lands in several thin slices), 6.5 M at
//!   1,000,000 instead of 3.7 M, in the same room. Binning widens a box's distances a little
//!   before they meet a tile's (rounding), and by 1 % when the forward shading walks the lists
//!   (`WIDE` in `decal_clusters.comp`: under MSAA a fragment's position lies that far off the
//!   depth target's sample), which costs the dense scatters 8 %. A forward fragment under MSAA
//!   whose surface is more than that off every sample-0 depth of its tile (at an edge, where
//!   `msaa.glsl` reads the surface of a neighbouring pixel) can miss a decal; no other pixel
//!   can.
//! - **Overflow** never drops decals silently: entries that do not fit are counted
//!   ([`DecalClusterStats::dropped`]), and when the CPU reads the needed total back (two frames
//!   later, when that frame's slot comes round again) it grows the buffer to a quarter more than
//!   that, rounded to a power of two ([`DecalClusterStats::grows`]). Two frames is the soonest
//!   without making the CPU wait for the GPU; in between, the overflowing frames lack those
//!   entries and say so. When decals go away the buffer follows ([`DecalClusterStats::shrinks`],
//!   [`crate::gpu::upload::Shrink`]): once the need (with that quarter) has stayed at or below a
//!   quarter of the room for a second (60 frames), it shrinks to the need's power of two, never
//!   below the initial room; after a second without clustered decals to bin, it is released.
//! - **A ceiling**: the lists never take more than [`MEMORY_SHARE`] of the renderer's memory
//!   (the memory budget, or the largest device-local heap), nor more than 2³⁰ entries
//!   (4 GiB; [`DecalClusterStats::limit`]). A
//!   scene that needs more keeps the ceiling and drops the entries past it, every frame, which
//!   the statistics count and one warning names (again only after the need fitted in between).
//!   The growth's two-frame latency also drops entries, but growing ends it, so that is counted
//!   and not warned about. Measured on an H100 at 1920×1080
//!   (docs/experiments/decals-cluster-depth-bounds.md): the scatter of 100,000 decals needs 0.66 M entries and
//!   gets room for 1.0 M (4 MiB); 1,000,000 need 6.5 M and get 8.4 M (32 MiB), well under
//!   the 8 GiB ceiling there.
//! - **CPU work** is none per frame: the binning reads the decal boxes the GPU already holds
//!   (kept by change detection for the acceleration structures), and the camera, so the lists
//!   follow the view without any upload.
//! - **Order**: the per-channel weighted blending is order-independent within a channel, so the
//!   order of a cluster's list (whatever the atomics gave) does not matter, as for the ray-traced
//!   methods.

use ash::vk;

use crate::RenderError;
use crate::gpu::device::GpuContext;
use crate::gpu::pipeline::create_computes;
use crate::gpu::shaders;
use crate::graph::readback::StatsReadback;
use crate::graph::targets::DEPTH;
use crate::graph::targets::Surface;
use crate::graph::{BufferUse, Frame, FrameGraph, PassKind, ResourceId};
use crate::layout::{DECAL_BIN_ROW, DECAL_CLUSTER_HEADER, DECAL_CLUSTER_SLICES, DECAL_CLUSTER_TILE};
use crate::scene::gpu::GpuScene;
use crate::stats::DecalClusterStats;

use crate::gpu::room::{Fitted, ListRoom, MEMORY_SHARE};

/// Entries the cluster buffer starts with room for, unless the renderer's settings say
/// otherwise.
pub const INITIAL_CAPACITY: u32 = 1 << 16;

/// The cluster buffer this frame: where it is and what it holds room for (push constants).
#[derive(Clone, Copy, Debug)]
pub struct ClusterFrame {
    /// Its frame-graph resource (for the passes that read the lists).
    pub res: ResourceId,
    /// Device address of the cluster buffer.
    pub address: vk::DeviceAddress,
    /// Entries it has room for.
    pub capacity: u32,
    /// Screen tiles: x in the low 16 bits, y in the high.
    pub tiles: u32,
}

/// The clustered-decal pipelines, the cluster buffer and the statistics read back from it.
pub struct DecalClusters {
    /// Binning's count and fill, with the depth margin a decal pass needs and with the wider
    /// one of forward shading (`WIDE` in `decal_clusters.comp`).
    count: [vk::Pipeline; 2],
    scan: vk::Pipeline,
    fill: [vk::Pipeline; 2],
    /// The tiles' depth bounds (`decal_cluster_bounds.comp`).
    bounds: vk::Pipeline,
    /// Decal pass, by [`super::Surface`].
    pass: [vk::Pipeline; 3],
    /// The cluster buffer: a header, the cluster table, then the lists' entries.
    room: ListRoom,
    clusters: u32,
    /// The statistics, read back two frames later.
    readback: StatsReadback,
    latest: DecalClusterStats,
    /// The ceiling last computed (it follows the cluster count).
    limit: u32,
    res: ResourceId,
}

impl DecalClusters {
    /// Creates the pipelines and the readback buffers; the cluster buffer waits for first use,
    /// when it gets room for `initial_capacity` entries.
    pub fn new(ctx: &GpuContext, graph: &mut FrameGraph, layout: vk::PipelineLayout, initial_capacity: u32) -> Result<Self, RenderError> {
        let [count, scan, fill, count_wide, fill_wide, gbuffer, visibility, depth, bounds] = create_computes(
            ctx,
            layout,
            [
                ("decal clusters (count)", shaders::DECAL_CLUSTERS_COMP),
                ("decal clusters (scan)", shaders::DECAL_CLUSTER_SCAN_COMP),
                ("decal clusters (fill)", shaders::DECAL_CLUSTERS_COMP_FILL),
                ("decal clusters (count, wide)", shaders::DECAL_CLUSTERS_COMP_WIDE),
                ("decal clusters (fill, wide)", shaders::DECAL_CLUSTERS_COMP_FILL_WIDE),
                ("decal pass (clustered)", shaders::DECAL_PASS_CLUSTERED_COMP),
                ("decal pass (clustered, visibility)", shaders::DECAL_PASS_CLUSTERED_COMP_VISIBILITY),
                ("decal pass (clustered, depth)", shaders::DECAL_PASS_CLUSTERED_COMP_DEPTH),
                ("decal cluster bounds", shaders::DECAL_CLUSTER_BOUNDS_COMP),
            ],
        )?;
        let readback = match StatsReadback::new(ctx, graph, "decal cluster statistics", DECAL_CLUSTER_HEADER as u64 * 4) {
            Ok(readback) => readback,
            Err(e) => {
                for p in [count, scan, fill, count_wide, fill_wide, gbuffer, visibility, depth, bounds] {
                    // SAFETY: the pipelines were never used.
                    unsafe { ctx.destroying().destroy_pipeline(p, None) };
                }
                return Err(e);
            }
        };
        Ok(Self {
            count: [count, count_wide],
            scan,
            fill: [fill, fill_wide],
            bounds,
            pass: [gbuffer, visibility, depth],
            room: ListRoom::new(ctx, "decal clusters", initial_capacity),
            clusters: 0,
            readback,
            latest: DecalClusterStats { measured_frame: u64::MAX, ..Default::default() },
            limit: 0,
            res: graph.resource("decal clusters"),
        })
    }

    /// Reads back the statistics of the frame that last used this frame's slot, grows the
    /// cluster buffer when that frame needed more room (or the view's cluster count changed),
    /// and says where the buffer is. Call before the frame's push constants are set.
    pub fn prepare(&mut self, f: &mut Frame, stats: &mut DecalClusterStats) -> Result<ClusterFrame, RenderError> {
        let ctx = f.ctx;
        let tiles = screen_tiles(f);
        let clusters = tiles.0 * tiles.1 * DECAL_CLUSTER_SLICES;
        self.read_back(f);
        // The ceiling in entries: the share of memory, less the header and the cluster table.
        let fixed = (DECAL_CLUSTER_HEADER as u64 + 3 * clusters as u64 + 2 * (tiles.0 * tiles.1) as u64) * 4;
        let limit = self.room.limit(ctx, fixed);
        let warning = |needed: u32| {
            format!(
                "clustered decals need {needed} cluster entries, past the ceiling of {limit} (1/{} of {} MiB of GPU memory): {} entries are dropped each frame, so some decals are missing where many overlap",
                MEMORY_SHARE.1,
                ctx.memory_limit() >> 20,
                needed - limit
            )
        };
        let need = (self.latest.entries, self.latest.dropped);
        if self.room.fit(f, need, (fixed, limit), clusters != self.clusters, warning)? != Fitted::Kept {
            self.clusters = clusters;
        }
        self.limit = limit;
        *stats = self.report();
        let capacity = self.room.capacity;
        let address = self.room.buffer.as_ref().expect("allocated above").address;
        Ok(ClusterFrame { res: self.res, address, capacity, tiles: tiles.0 | tiles.1 << 16 })
    }

    /// A frame without clustered decals (another method, or no decal): after
    /// [`crate::gpu::device::GpuContext::shrink_after_frames`] of them in a row the cluster buffer is
    /// released, and the next frame that bins decals starts again from the initial room.
    /// Until then `stats` shows the room still held and the figures of the last frames that
    /// binned; once released, what it measured is forgotten too.
    pub fn idle(&mut self, f: &mut Frame, stats: &mut DecalClusterStats) {
        self.read_back(f);
        if self.room.idle(&mut f.upload) {
            self.clusters = 0;
            self.latest = DecalClusterStats { measured_frame: u64::MAX, ..Default::default() };
            self.readback.forget();
        }
        *stats = self.report();
    }

    /// Takes the statistics the frame that last used this frame's slot copied, if any.
    fn read_back(&mut self, f: &Frame) {
        if let Some((frame, words)) = self.readback.take(f) {
            let wide = |lo: usize| words[lo] as u64 | (words[lo + 1] as u64) << 32;
            // What the GPU measured; the room and its history come from `report`.
            self.latest = DecalClusterStats {
                measured_frame: frame,
                clusters_used: words[3] as u64,
                entries: words[0] as u64,
                dropped: words[1] as u64,
                max_per_cluster: words[2] as u64,
                pixels: words[7] as u64,
                tested: wide(4),
                max_tested: words[6] as u64,
                applied: wide(8),
                max_applied: words[10] as u64,
                ..Default::default()
            };
        }
    }

    /// The statistics this frame: the clusters and room held and their history, with the last
    /// measured figures.
    fn report(&self) -> DecalClusterStats {
        DecalClusterStats {
            clusters: self.clusters as u64,
            capacity: self.room.capacity as u64,
            limit: self.limit as u64,
            grows: self.room.grows,
            shrinks: self.room.shrinks,
            ..self.latest
        }
    }

    /// Bins `live` decal boxes into the clusters, runs the decal pass over the surface `source`
    /// (writing the decal buffer) unless there is none (the shading walks the lists itself),
    /// and copies the statistics for the CPU. The push constants must hold
    /// [`DecalClusters::prepare`]'s result. Returns whether it recorded the decal pass.
    pub fn record(
        &mut self,
        f: &mut Frame,
        scene: &GpuScene,
        live: u32,
        ring: Option<ResourceId>,
        source: Option<Surface>,
    ) -> Result<bool, RenderError> {
        let Some(buffer) = self.room.buffer.as_ref() else { return Ok(false) };
        let (raw, res, clusters) = (buffer.raw, self.res, self.clusters);
        let extent = f.graph.extent();
        let tiles = screen_tiles(f);
        let prefix = (DECAL_CLUSTER_HEADER as u64 + 3 * clusters as u64) * 4;
        f.pass("decal_clusters_clear", PassKind::Transfer).write(res, BufferUse::Transfer).record(|p| {
            p.cmd.fill_buffer(raw, 0, prefix, 0);
        })?;
        f.pass("decal_clusters_bounds", PassKind::Compute)
            .sample(&DEPTH)
            .read(scene.res.tables, BufferUse::Storage)
            .write(res, BufferUse::Storage)
            .record(|p| {
                p.bind(vk::PipelineBindPoint::COMPUTE, self.bounds, &p.push);
                p.cmd.dispatch(tiles.0, tiles.1, 1);
            })?;
        // Eight boxes a workgroup (eight lanes each), in rows of DECAL_BIN_ROW workgroups.
        let groups = live.div_ceil(8);
        let (columns, rows) = (groups.min(DECAL_BIN_ROW), groups.div_ceil(DECAL_BIN_ROW));
        let bin = |f: &mut Frame, name: &'static str, pipeline: vk::Pipeline| {
            f.pass(name, PassKind::Compute)
                .read(scene.res.tables, BufferUse::Storage)
                .reads(ring.map(|r| (r, BufferUse::Storage)))
                .write(res, BufferUse::Storage)
                .record(|p| {
                    p.bind(vk::PipelineBindPoint::COMPUTE, pipeline, &p.push);
                    p.cmd.dispatch(columns, rows, 1);
                })
        };
        // The forward shading's fragments need the wider depth margin (decal_clusters.comp).
        let wide = source.is_none() as usize;
        bin(f, "decal_clusters_count", self.count[wide])?;
        // One workgroup for each 256 clusters reserves their lists (32,640 clusters at 1080p:
        // 128 workgroups).
        f.pass("decal_clusters_scan", PassKind::Compute).read(scene.res.tables, BufferUse::Storage).write(res, BufferUse::Storage).record(
            |p| {
                p.bind(vk::PipelineBindPoint::COMPUTE, self.scan, &p.push);
                p.cmd.dispatch(clusters.div_ceil(256), 1, 1);
            },
        )?;
        bin(f, "decal_clusters_fill", self.fill[wide])?;

        if let Some(source) = source {
            let pipeline = self.pass[source as usize];
            let pass = super::buffer::declare_decal_surface(f.pass("decal_pass_clustered", PassKind::Compute), scene, source)
                .reads(ring.map(|r| (r, BufferUse::Storage)))
                .write(res, BufferUse::Storage);
            pass.record(|p| {
                p.bind(vk::PipelineBindPoint::COMPUTE, pipeline, &p.push);
                p.cmd.dispatch(extent.width.div_ceil(8), extent.height.div_ceil(8), 1);
            })?;
        }

        self.readback.record(f, "decal_clusters_statistics", res, raw)?;
        Ok(source.is_some())
    }

    /// Destroys everything; the GPU must be idle.
    pub fn destroy(self, ctx: &GpuContext) {
        for p in [self.scan, self.bounds].into_iter().chain(self.count).chain(self.fill).chain(self.pass) {
            // SAFETY: the GPU is idle.
            unsafe { ctx.destroying().destroy_pipeline(p, None) };
        }
        self.room.destroy(ctx);
        self.readback.destroy(ctx);
    }
}

/// The screen tiles across and down at the frame's size (`DECAL_CLUSTER_TILE` pixels each).
fn screen_tiles(f: &Frame) -> (u32, u32) {
    let extent = f.graph.extent();
    (extent.width.div_ceil(DECAL_CLUSTER_TILE), extent.height.div_ceil(DECAL_CLUSTER_TILE))
}
