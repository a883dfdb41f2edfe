//! The decal pass and its decal buffer (seed 000 §4.2.2 and §4.3.1, moved out of the shading
//! passes): one pass per frame enumerates the decals at every pixel with a zero-length ray,
//! blends them per channel with weighted OIT, composites the channels in order and writes, per
//! attribute, the decal contribution and the weight remaining to the surface's own value
//! (`shaders/include/decal_buffer.glsl`). The shading passes of every pipeline then apply
//! `value = decal + value × remaining`, which is exactly the seed's final blending step, since
//! compositing channels one after another is an affine map of the surface value.
//!
//! Three passes write the same buffer: the two ray-traced ones here, and clustered decals
//! ([`super::clustered`]), which need no ray tracing at all. The ray-traced formulations:
//! - **ray-tracing pipeline** (`shaders/decal_pass.r*`), for devices with ray-tracing pipelines
//!   but no ray queries (the lent NVIDIA GPUs), when asked for (they fall back to clustered
//!   decals, the faster there: [`crate::DecalMethod::effective`]): a ray-generation shader
//!   traces the ray; an intersection shader runs the exact oriented-box test and the angle fade on each AABB the
//!   ray's origin lies in. Intersection shaders have no payload, so the two things they need
//!   from the pixel travel with the ray: its origin is the surface point, and its direction
//!   (free for a ray of length zero) is the geometric normal the fade needs.
//!
//!   Where the decals are blended is this pass's design choice. The seed blends in the any-hit
//!   shader, into per-channel sums carried in the payload (hit group 1 here, `DECAL_SBT_BLEND`).
//!   Here the first trace's any-hit shader (hit group 0, `DECAL_SBT_LIST`) only writes each
//!   decal's slot into the pixel's list in GPU memory ([`super::lists`]), and the
//!   ray-generation shader then tests, samples and blends them, all lanes of a warp running the
//!   same code together instead of one hit at a time. Only a pixel that finds more decals than
//!   its list has room for (room is reserved from what it found the frame before) is blended
//!   by a second trace the seed's way. Measured on the lent H100 (docs/experiments/decals-rt-floor.md,
//!   docs/experiments/decals-rt-lists.md), with the scattered decals: 5.11 →
//!   3.15 ms at 100,000 when an earlier round first collected the slots, in a 136-byte payload
//!   with room for 32 (what the reflection rays still do); then, with the lists in memory,
//!   3.16 → 2.91 ms at 100,000 and 46.6 → 28.6 ms at 1,000,000, where every pixel had more
//!   decals than that payload held.
//!
//!   Either way, weighted blended OIT is order-independent *within* a channel (sums and
//!   products commute) and the channels are composited in channel order at the end, so the
//!   arbitrary order in which traversal finds the decals gives what the ray-query loop gives
//!   (tests/tests/suite/decals.rs checks this against a CPU reference, with stacks deeper than the
//!   payload keeps, and against a shuffled spawn order).
//! - **ray queries in compute** (`shaders/decal_pass.comp`), the ray-query tier's counterpart,
//!   so the two can be compared on one device (lavapipe has both).
//!
//! The ray-tracing pipeline's **floor** (`DebugView::DecalFloor`, issue "decals at a million",
//! item 4): the same ray-generation and intersection shaders with a 4-byte payload and an
//! any-hit shader that only counts (`COUNT_ONLY`), so the pass's cost can be set against the
//! cost of enumerating the boxes alone, on the same scatter, in the same build. Made on first
//! use, since only benchmarks and tests ask for it; its time is `decal_pass_floor` in the stats.
//!
//! What the seed's any-hit blending cost beyond that floor, measured the same way: mostly the
//! per-channel blend state the any-hit shader reads and writes for every decal, not the
//! textures. Blending into a slot picked by a runtime index also kept that state in addressable
//! memory; the slot is now a constant in each branch (`BLEND_AT_SLOT` in
//! `shaders/include/blend.glsl`), which every decal method's blending gains from.
//!
//! Each pass reads the surface as its pipeline left it (`shaders/include/decal_surface.glsl`):
//! the G-buffer in the deferred pipeline, the visibility ids in the visibility-buffer pipeline,
//! and in the forward pipeline either the same ids, written by the depth prepass when a decal
//! must know its pixel's instance (or reflections and motion want them anyway: the prepass
//! becomes the visibility pass, the same depth plus 8 bytes a pixel), or depth alone, which
//! spares the prepass its ids: on the lent H100 0.74 → 0.27 ms in PEERS.md's scene. See that
//! include for the normals each source gives the decals.

use ash::vk;

use crate::RenderError;
use crate::decals::DecalFrame;
use crate::gpu::device::GpuContext;
use crate::gpu::pipeline::{HitGroup, RayTracingDesc, RayTracingPipeline, create_computes};
use crate::gpu::shaders;
use crate::graph::targets::{DECAL_BUFFER, DEPTH, GBUFFER_LAYERS, GBUFFER_NORMAL, Surface, VISIBILITY};
use crate::graph::{BufferUse, Frame, ImageUse, PassBuilder, PassKind};
use crate::scene::gpu::GpuScene;
use crate::settings::{DebugView, DecalMethod};

/// The decal passes this device can run.
pub struct DecalPasses {
    /// Ray-generation shaders by [`Surface`]: the G-buffer, the ids, depth.
    ray_pipeline: Option<RayTracingPipeline>,
    /// Ray-query compute, by [`Surface`].
    ray_query: Option<[vk::Pipeline; 3]>,
    /// The ray-tracing pipeline's count-only floor (`DebugView::DecalFloor`), made on first use.
    floor: Option<RayTracingPipeline>,
}

impl DecalPasses {
    /// Creates the passes the device supports (none without ray tracing).
    pub fn new(ctx: &GpuContext, layout: vk::PipelineLayout) -> Result<Self, RenderError> {
        let support = ctx.ray_support();
        let ray_pipeline = if support.ray_pipeline {
            Some(RayTracingPipeline::new(
                ctx,
                layout,
                &RayTracingDesc {
                    name: "decal pass (ray-tracing pipeline)",
                    raygen: &[shaders::DECAL_PASS_RGEN, shaders::DECAL_PASS_RGEN_VISIBILITY, shaders::DECAL_PASS_RGEN_DEPTH],
                    misses: &[shaders::DECAL_PASS_RMISS],
                    // DECAL_SBT_LIST and DECAL_SBT_BLEND (shaders/decal_pass.rgen).
                    hit_groups: &[
                        HitGroup::any_hit(shaders::DECAL_PASS_RAHIT_LIST, Some(shaders::DECAL_PASS_RINT)),
                        HitGroup::any_hit(shaders::DECAL_PASS_RAHIT, Some(shaders::DECAL_PASS_RINT)),
                    ],
                },
            )?)
        } else {
            None
        };
        let ray_query = if support.ray_query {
            let stages = [
                ("decal pass (ray query)", shaders::DECAL_PASS_COMP),
                ("decal pass (ray query, visibility)", shaders::DECAL_PASS_COMP_VISIBILITY),
                ("decal pass (ray query, depth)", shaders::DECAL_PASS_COMP_DEPTH),
            ];
            match create_computes(ctx, layout, stages) {
                Ok(pipelines) => Some(pipelines),
                Err(e) => {
                    if let Some(rt) = ray_pipeline {
                        rt.destroy(ctx); // never used
                    }
                    return Err(e);
                }
            }
        } else {
            None
        };
        Ok(Self { ray_pipeline, ray_query, floor: None })
    }

    /// Makes the count-only floor of the ray-tracing-pipeline pass, the first time it is asked for.
    fn floor(&mut self, ctx: &GpuContext, layout: vk::PipelineLayout) -> Result<(), RenderError> {
        if self.floor.is_none() {
            self.floor = Some(RayTracingPipeline::new(
                ctx,
                layout,
                &RayTracingDesc {
                    name: "decal pass floor (ray-tracing pipeline, count only)",
                    raygen: &[
                        shaders::DECAL_PASS_RGEN_COUNT_ONLY,
                        shaders::DECAL_PASS_RGEN_COUNT_ONLY_VISIBILITY,
                        shaders::DECAL_PASS_RGEN_COUNT_ONLY_DEPTH,
                    ],
                    misses: &[shaders::DECAL_PASS_RMISS],
                    hit_groups: &[HitGroup::any_hit(shaders::DECAL_PASS_RAHIT_COUNT_ONLY, Some(shaders::DECAL_PASS_RINT))],
                },
            )?);
        }
        Ok(())
    }

    /// Writes the decal buffer for this frame's decals, when the frame's method is a decal pass
    /// and there are decals; otherwise records nothing (the shading passes then read no buffer).
    /// Under `DebugView::DecalFloor` the ray-tracing-pipeline pass only counts the decals at
    /// each pixel and applies none. Returns whether it recorded a pass.
    pub fn record(&mut self, f: &mut Frame, scene: &GpuScene, frame: &DecalFrame, source: Surface) -> Result<bool, RenderError> {
        let Some(traced) = frame.traced.filter(|_| frame.buffered()) else { return Ok(false) };
        let extent = f.graph.extent();
        let variant = source as usize;
        let count_only = frame.method == DecalMethod::RayPipeline && f.push.debug_view == DebugView::DecalFloor as u32;
        let (name, kind) = match frame.method {
            DecalMethod::RayPipeline if count_only => ("decal_pass_floor", PassKind::RayTracing),
            DecalMethod::RayPipeline => ("decal_pass_ray_pipeline", PassKind::RayTracing),
            _ => ("decal_pass_ray_query", PassKind::Compute),
        };
        if count_only && self.ray_pipeline.is_some() {
            self.floor(f.ctx, f.layout)?;
        }
        // The scene's decal structures, and the particles' decal ring (its records, boxes and
        // structures, which the simulation and the ring's builds wrote this frame).
        let mut pass =
            declare_decal_surface(f.pass(name, kind), scene, source).reads(traced.map(|a| (a, BufferUse::Accel))).reads(frame.ring_reads());
        if let Some(lists) = frame.lists.filter(|_| frame.method == DecalMethod::RayPipeline && !count_only) {
            pass = pass.write(lists.res, BufferUse::Storage);
        }
        match frame.method {
            DecalMethod::RayPipeline => {
                let rt = if count_only { self.floor.as_ref() } else { self.ray_pipeline.as_ref() };
                let rt = rt.ok_or_else(|| unsupported(frame.method))?;
                pass.record(|p| {
                    p.bind(vk::PipelineBindPoint::RAY_TRACING_KHR, rt.pipeline, &p.push);
                    rt.trace(p.cmd, variant, extent);
                })?;
            }
            _ => {
                let pipelines = self.ray_query.ok_or_else(|| unsupported(frame.method))?;
                pass.record(|p| {
                    p.bind(vk::PipelineBindPoint::COMPUTE, pipelines[variant], &p.push);
                    p.cmd.dispatch(extent.width.div_ceil(8), extent.height.div_ceil(8), 1);
                })?;
            }
        }
        Ok(true)
    }

    /// Destroys the pipelines; the GPU must be idle.
    pub fn destroy(self, ctx: &GpuContext) {
        for rt in [self.ray_pipeline, self.floor].into_iter().flatten() {
            rt.destroy(ctx);
        }
        for p in self.ray_query.into_iter().flatten() {
            // SAFETY: the GPU is idle.
            unsafe { ctx.destroying().destroy_pipeline(p, None) };
        }
    }
}

/// Declares what every decal pass reads and writes: the surface from `source` (depth, and the
/// G-buffer or the visibility ids with the meshes), the decal records and textures, and the decal
/// buffer it writes.
pub fn declare_decal_surface<'f, 'a>(pass: PassBuilder<'f, 'a>, scene: &GpuScene, source: Surface) -> PassBuilder<'f, 'a> {
    let pass = pass.sample(&DEPTH).reads(scene.res.shaded());
    let pass = match source {
        Surface::GBuffer => pass.sample(&GBUFFER_NORMAL).sample(&GBUFFER_LAYERS),
        Surface::Visibility => pass.sample(&VISIBILITY).read(scene.res.meshes, BufferUse::Storage),
        Surface::Depth => pass,
    };
    DECAL_BUFFER.iter().fold(pass, |pass, &target| pass.image(target, ImageUse::StorageWrite))
}

/// Declares what a shading pass reads to apply this frame's decals: the decal buffer when a
/// decal pass wrote it, the cluster lists when it walks them itself, the acceleration
/// structures when it traces ray queries itself.
pub fn declare_decal_reads<'f, 'a>(pass: PassBuilder<'f, 'a>, frame: &DecalFrame) -> PassBuilder<'f, 'a> {
    // The particles' decal ring's records, which the decals' records lead to, and its
    // structures where decals are traced.
    let pass = pass.reads(frame.ring_reads());
    if frame.buffered() {
        DECAL_BUFFER.iter().fold(pass, |pass, &target| pass.image(target, ImageUse::StorageRead))
    } else if let Some(clusters) = frame.clusters.filter(|_| frame.clusters_in_shading()) {
        pass.read(clusters.res, BufferUse::Storage)
    } else {
        pass.reads(frame.traced.into_iter().flatten().map(|a| (a, BufferUse::Accel)))
    }
}

fn unsupported(method: DecalMethod) -> RenderError {
    RenderError::Other(format!("the decal method {} was applied without its pipeline", method.name()))
}
