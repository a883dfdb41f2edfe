//! Decals (seed 000) on the renderer's side: the acceleration structures over decal boxes that
//! ray-traced decals enumerate (`accel`), the decal passes that write the decal buffer from them
//! (`buffer`, with the per-pixel lists of its ray-tracing-pipeline pass in `lists`), clustered decals, which write it with no ray tracing (`clustered`), the draw
//! order of deferred decals (`deferred`), and the debug view of decal boxes (`debug`). The decal records themselves live in the scene's
//! tables ([`crate::scene::DecalTable`]) and the shading math in `shaders/include/decals.glsl`.

pub mod accel;
pub mod buffer;
pub mod clustered;
pub mod debug;
pub mod deferred;
pub mod lists;

use ash::vk;

use crate::RenderError;
use crate::gpu::device::GpuContext;
use crate::graph::targets::Surface;
use crate::graph::{Frame, FrameGraph, ResourceId};
use crate::scene::SceneMirror;
use crate::scene::emitters::DecalRing;
use crate::scene::gpu::GpuScene;
use crate::settings::{DebugView, DecalMethod, FrameSettings};
use crate::stats::FrameCounters;
use accel::{DecalAccel, DecalBoxInput};
pub use buffer::{DecalPasses, declare_decal_reads};
use clustered::{ClusterFrame, DecalClusters};
use debug::DecalBoxes;
pub use deferred::{DecalRun, DeferredDecalOrder, plan_deferred_decals};
use lists::{DecalLists, ListFrame};

/// The renderer's decal state.
pub struct Decals {
    /// The BLAS and TLAS over decal boxes.
    pub accel: DecalAccel,
    /// The decal passes (ray-tracing pipeline, ray-query compute) that write the decal buffer.
    pub passes: DecalPasses,
    /// Clustered decals: the binning passes, the cluster buffer and their decal pass.
    pub clusters: DecalClusters,
    /// The ray-tracing-pipeline decal pass's per-pixel lists.
    pub lists: DecalLists,
    /// The box-drawing debug pass.
    pub boxes: DecalBoxes,
    /// Deferred decals' draw order.
    pub order: DeferredDecalOrder,
    /// Where this frame's decal pass read the surface (`None` when none ran).
    surface: Option<Surface>,
    /// The attribute sets (`DECAL_*` flags, a bit each) of the materials the particles' decal
    /// ring has been given: deferred decals draw the ring once for each.
    ring_flags: u16,
    /// Places of the particles' decal ring this frame (0: none).
    ring_room: u32,
}

/// Deferred decals' draws of the particles' decal ring ([`Decals::deferred_ring`]).
#[derive(Clone, Copy, Debug)]
pub struct DeferredRing {
    /// Places of the ring (the draws' instances).
    pub room: u32,
    /// The attribute sets of its materials, a bit per `DECAL_*` flags value: a draw each.
    pub flags: u16,
    /// The graph resource holding its records and boxes.
    pub res: ResourceId,
}

/// The decal method asked for and the one applied (see [`DecalMethod::effective`]).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct DecalChoice {
    /// What the frame's settings asked for.
    pub requested: DecalMethod,
    /// What this device and pipeline apply.
    pub applied: DecalMethod,
}

/// Which passes besides the method's own read this frame's decals.
#[derive(Clone, Copy, Debug, Default)]
pub struct DecalReaders {
    /// A forward shading pass walks clustered decals' lists itself
    /// ([`FrameSettings::decals_in_forward_shading`]).
    pub lists_in_shading: bool,
    /// The reflection rays look for decals at their hit points (`crate::reflections`).
    pub reflections: bool,
    /// The ring of decals landing particles leave (`crate::particles`), once there is one: its
    /// boxes follow the scene's decals' in the enumeration.
    pub ring: Option<DecalRing>,
}

/// What this frame does with decals, once the acceleration structures are up to date.
#[derive(Clone, Copy, Debug)]
pub struct DecalFrame {
    /// The method applied (after [`DecalMethod::effective`]).
    pub method: DecalMethod,
    /// The acceleration structures traced this frame (TLAS and BLAS), when a ray-traced method
    /// is applied and there are decals.
    pub traced: Option<[ResourceId; 2]>,
    /// Its device address (0 without).
    pub tlas_address: vk::DeviceAddress,
    /// Live decals the shading passes enumerate (0 skips the decal loop).
    pub count: u32,
    /// The cluster buffer, when clustered decals are applied this frame.
    pub clusters: Option<ClusterFrame>,
    /// The per-pixel list buffer, when the ray-tracing-pipeline decal pass runs this frame.
    pub lists: Option<ListFrame>,
    /// Whether the pipeline's shading walks the cluster lists itself (forward and Forward+ with
    /// [`FrameSettings::decals_in_forward_shading`]), so that no decal pass (and no ids
    /// prepass) runs: only the binning.
    pub lists_in_shading: bool,
    /// The acceleration structures (TLAS and BLAS) the reflection rays' hit points search
    /// (`crate::reflections`), whatever the on-screen method, when reflections run and there
    /// are decals.
    pub at_hits: Option<[ResourceId; 2]>,
    /// The particles' decal ring, when there is one: `count` includes its places (the decal
    /// slots past the scene's are `GPU_DECAL` ones), and every pass that applies decals reads
    /// its records (and, where decals are traced, its structures: ray-traced decals trace its
    /// TLAS after the scene's).
    pub ring: Option<DecalRing>,
}

impl DecalFrame {
    /// Whether a decal pass writes the decal buffer this frame (the shading passes apply it).
    pub fn buffered(&self) -> bool {
        self.method.uses_decal_buffer() && (self.traced.is_some() || self.clusters.is_some()) && !self.clusters_in_shading()
    }

    /// The shading pipeline variant that applies this frame's decals: the decal buffer, the
    /// clustered lists walked in the shading, in-shader ray queries, or none.
    pub fn variant(&self) -> crate::gpu::pipeline::ShadeVariant {
        use crate::gpu::pipeline::ShadeVariant;
        if self.buffered() {
            ShadeVariant::DecalBuffer
        } else if self.clusters_in_shading() {
            ShadeVariant::ClusteredDecals
        } else if self.traced.is_some() && self.method == crate::settings::DecalMethod::RayQuery {
            ShadeVariant::RayQueryDecals
        } else {
            ShadeVariant::Plain
        }
    }

    /// What a pass that applies this frame's decals reads of the particles' decal ring: its
    /// records and boxes, and its TLAS and BLAS once built.
    pub fn ring_reads(&self) -> impl Iterator<Item = (ResourceId, crate::graph::BufferUse)> + use<> {
        let ring = self.ring;
        let records = ring.map(|r| (r.res, crate::graph::BufferUse::Storage));
        let traced = ring.and_then(|r| r.traced).into_iter().flatten().map(|a| (a, crate::graph::BufferUse::Accel));
        records.into_iter().chain(traced)
    }

    /// Whether clustered decals are applied this frame by the shading pass itself, from the
    /// cluster lists.
    pub fn clusters_in_shading(&self) -> bool {
        self.lists_in_shading && self.clusters.is_some()
    }
}

impl Decals {
    /// Creates the decal passes and registers their graph resources; the clustered decals'
    /// buffer starts with room for `cluster_capacity` entries.
    pub fn new(ctx: &GpuContext, graph: &mut FrameGraph, layout: vk::PipelineLayout, cluster_capacity: u32) -> Result<Self, RenderError> {
        Ok(Self {
            accel: DecalAccel::new(ctx, graph),
            passes: DecalPasses::new(ctx, layout)?,
            clusters: DecalClusters::new(ctx, graph, layout, cluster_capacity)?,
            lists: DecalLists::new(ctx, graph, layout)?,
            boxes: DecalBoxes::new(ctx, layout)?,
            order: DeferredDecalOrder::default(),
            surface: None,
            ring_flags: 0,
            ring_room: 0,
        })
    }

    /// Keeps the deferred decals' draw order in step with this frame's decal changes. Call
    /// before the scene's upload (which consumes the change marks and uploads the order).
    pub fn follow_changes(&mut self, mirror: &SceneMirror, scene: &mut GpuScene, choice: DecalChoice) {
        self.order.follow(mirror, scene, choice.applied == DecalMethod::DeferredDecals);
    }

    /// Brings the acceleration structures (or the cluster buffer) up to date (`boxes_changed`
    /// boxes were uploaded this frame) and says what the shading passes apply, for the passes
    /// that `readers` names.
    #[allow(clippy::too_many_arguments)]
    pub fn build_accel(
        &mut self,
        f: &mut Frame,
        scene: &GpuScene,
        mirror: &mut SceneMirror,
        choice: DecalChoice,
        readers: DecalReaders,
        boxes_changed: u32,
        counters: &mut FrameCounters,
    ) -> Result<DecalFrame, RenderError> {
        let DecalReaders { lists_in_shading, reflections, ring } = readers;
        let method = choice.applied;
        self.surface = None;
        // Reflection rays find the decals at their hit points in the decal TLAS, whatever the
        // method on screen (unless decals are off).
        let at_hits = reflections && !matches!(method, DecalMethod::Off | DecalMethod::Unavailable);
        let input = DecalBoxInput {
            tables: scene.res.tables,
            address: scene.decal_aabbs.address(),
            live: mirror.decals.len() as u32,
            capacity: scene.decal_aabbs.capacity(),
            changed: boxes_changed,
        };
        // The structures follow the decals whenever a ray-traced method is applied (changes made
        // meanwhile wait for the next frame that traces them).
        self.accel.build(f, input, method.traces() || at_hits, counters)?;
        // The scene's decals' structures, and the particles' decal ring's: either may be traced
        // alone.
        let scene_traced = (!mirror.decals.is_empty()).then(|| self.accel.traced()).flatten();
        let ring_traced = ring.and_then(|r| r.traced);
        let shaded = method.traces() && (scene_traced.is_some() || ring_traced.is_some());
        let at_hits = at_hits.then(|| scene_traced.or(ring_traced)).flatten();
        let ring_room = ring.map_or(0, |r| r.room);
        self.ring_room = ring_room;
        if ring.is_some() {
            for material in mirror.emitters.decal_materials() {
                if let Some(m) = mirror.decal_materials.get(material) {
                    self.ring_flags |= 1 << (m.flags & 15);
                }
            }
        }
        let clustered = method == DecalMethod::Clustered && (!mirror.decals.is_empty() || ring_room > 0);
        let clusters = if clustered {
            Some(self.clusters.prepare(f, &mut counters.clusters)?)
        } else {
            self.clusters.idle(f, &mut counters.clusters);
            None
        };
        let lists = if shaded && method == DecalMethod::RayPipeline {
            Some(self.lists.prepare(f, &mut counters.decal_lists)?)
        } else {
            self.lists.idle(f, &mut counters.decal_lists);
            None
        };
        Ok(DecalFrame {
            method,
            traced: if shaded { scene_traced.or(ring_traced) } else { None },
            tlas_address: if (shaded || at_hits.is_some()) && scene_traced.is_some() { self.accel.tlas_address() } else { 0 },
            count: if shaded || clustered || at_hits.is_some() { mirror.decals.len() as u32 + ring_room } else { 0 },
            clusters,
            lists,
            lists_in_shading,
            at_hits,
            ring,
        })
    }

    /// Writes the decal buffer when this frame's method is a decal pass ([`buffer`], or
    /// [`clustered`] with its binning passes); bins the clustered decals only, when the shading
    /// walks their lists itself. [`Decals::surface`] then says where the pass read the surface.
    pub fn decal_pass(&mut self, f: &mut Frame, scene: &GpuScene, frame: &DecalFrame, source: Surface) -> Result<(), RenderError> {
        let ran = match frame.clusters {
            Some(_) => {
                self.clusters.record(f, scene, frame.count, frame.ring.map(|r| r.res), (!frame.clusters_in_shading()).then_some(source))?
            }
            // The lists serve the lit pass only: its count-only floor runs without them.
            None if frame.lists.is_some() && f.push.debug_view != DebugView::DecalFloor as u32 => {
                self.lists.record_offsets(f)?;
                let ran = self.passes.record(f, scene, frame, source)?;
                self.lists.record_statistics(f)?;
                ran
            }
            None => self.passes.record(f, scene, frame, source)?,
        };
        self.surface = ran.then_some(source);
        Ok(())
    }

    /// Where this frame's decal pass read each pixel's surface: the G-buffer, the prepass's ids
    /// or depth alone (`None` when no decal pass ran: no decals, in-shader or deferred decals).
    pub fn surface(&self) -> Option<Surface> {
        self.surface
    }

    /// The deferred decals to draw this frame (none unless they are the method).
    pub fn deferred_runs(&self, frame: &DecalFrame) -> &[DecalRun] {
        if frame.method == DecalMethod::DeferredDecals { &self.order.runs } else { &[] }
    }

    /// Deferred decals' draws of the particles' decal ring, when it is applied this frame: its
    /// places, the attribute sets its materials have (a bit per `DECAL_*` flags value), and its
    /// graph resource.
    pub fn deferred_ring(&self, frame: &DecalFrame) -> Option<DeferredRing> {
        let res = frame.ring.filter(|_| frame.method == DecalMethod::DeferredDecals)?.res;
        Some(DeferredRing { room: self.ring_room, flags: self.ring_flags, res })
    }

    /// The debug view of every decal's box and AABB, when asked for.
    pub fn draw_boxes(&self, f: &mut Frame, scene: &GpuScene, mirror: &SceneMirror, s: &FrameSettings) -> Result<(), RenderError> {
        if !s.show_decal_boxes {
            return Ok(());
        }
        self.boxes.record(f, scene, mirror.decals.len() as u32)
    }

    /// Destroys everything; the GPU must be idle.
    pub fn destroy(self, ctx: &GpuContext) {
        self.accel.destroy(ctx);
        self.passes.destroy(ctx);
        self.clusters.destroy(ctx);
        self.lists.destroy(ctx);
        self.boxes.destroy(ctx);
    }
}
