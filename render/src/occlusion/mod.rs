//! Ambient occlusion of the environment's and the ambient colour's light (issue 26, item 3): the
//! share of a pixel's cosine-weighted hemisphere open to the sky within a radius, which shading
//! multiplies ambient light by (diffuse, and specular through the specular occlusion derived
//! from it; `shaders/include/environment.glsl`). The seeds light ambient surfaces with a
//! constant (seed 000 lists an ambient term among its renderer's options) and occlude nothing;
//! the techniques here are the field's standard ones:
//!
//! - **Traced** on both ray-tracing tiers: a few short rays a pixel (2 by default, 1 m) against
//!   the scene TLAS, cosine-distributed about the normal rebuilt from depth, as the shadow pass
//!   traces its rays: ray queries in compute on the ray-query tier, a ray-generation pass with
//!   the shadow pass's miss and any-hit shaders on the ray-tracing-pipeline tier (masked texels
//!   let rays through, glass lets its transmittance through). It sees what the screen does not:
//!   the underside of a table, an occluder behind the camera.
//! - **Screen space** on every device: ground-truth ambient occlusion (Jimenez et al. 2016,
//!   "Practical Real-Time Strategies for Accurate Indirect Occlusion"), two slices a pixel and
//!   six depth taps a side, the visible arc integrated in closed form. It sees only the depth
//!   buffer.
//!
//! Both work from depth alone, like the shadow pass, so one pair of passes serves every
//! pipeline. Each pixel of a 4×4 tile takes its own sixteenth of a stratified set of directions,
//! the same every frame; a denoiser averages each 4×4 neighbourhood, weighted by the distance to
//! the pixel's tangent plane so that the average stays on one surface. So the image is stable
//! without a temporal filter (there is no TAA yet), and each pixel's value rests on 32 rays.
//!
//! The passes run after the depth exists and before shading, which reads the denoised image
//! when the lighting record's `AMBIENT_OCCLUSION` flag says they ran
//! ([`crate::lights::declare_light_reads`] declares the read). Blended surfaces, and the hit
//! points of reflection rays, are not occluded (they are not in the depth the passes read).

use ash::vk;

use crate::RenderError;
use crate::gpu::device::GpuContext;
use crate::gpu::pipeline::{HitGroup, RayTracingDesc, RayTracingPipeline, create_compute};
use crate::gpu::shaders;
use crate::graph::targets::{DEPTH, OCCLUSION, OCCLUSION_RAW};
use crate::graph::{BufferUse, Frame, ImageUse, PassKind, ResourceId};
use crate::scene::gpu::GpuScene;
use crate::settings::{OcclusionMethod, OcclusionSettings};

/// The ambient occlusion passes this device can run.
pub struct AmbientOcclusion {
    /// Traced with ray queries (the ray-query tier).
    ray_query: Option<vk::Pipeline>,
    /// Traced by a ray-generation pass (devices with ray-tracing pipelines).
    ray_pipeline: Option<RayTracingPipeline>,
    screen_space: vk::Pipeline,
    denoise: vk::Pipeline,
}

/// How a frame's ambient occlusion is made.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct OcclusionFrame {
    /// The method applied: `Off` when it is not asked for or, traced, there is nothing to trace
    /// against yet.
    pub method: OcclusionMethod,
    /// The scene's TLAS and BLAS the rays read (traced only).
    traced: Option<[ResourceId; 2]>,
    /// The scene's meshes (masked and blended hits read their texture coordinates).
    meshes: Option<ResourceId>,
}

impl OcclusionFrame {
    /// Whether shading reads the occlusion image this frame.
    pub fn on(&self) -> bool {
        self.method != OcclusionMethod::Off
    }
}

/// What writes the raw occlusion: a compute pipeline or a ray-generation pass.
enum Tracer<'a> {
    Compute(vk::Pipeline),
    RayGen(&'a RayTracingPipeline),
}

impl AmbientOcclusion {
    /// Creates the passes the device supports.
    pub fn new(ctx: &GpuContext, layout: vk::PipelineLayout) -> Result<Self, RenderError> {
        let support = ctx.ray_support();
        let screen_space = create_compute(ctx, layout, "ambient occlusion (screen space)", shaders::OCCLUSION_COMP_SCREEN_SPACE)?;
        let denoise = create_compute(ctx, layout, "ambient occlusion denoiser", shaders::OCCLUSION_DENOISE_COMP)?;
        let mut made = Self { ray_query: None, ray_pipeline: None, screen_space, denoise };
        if support.ray_query {
            match create_compute(ctx, layout, "ambient occlusion (ray query)", shaders::OCCLUSION_COMP) {
                Ok(p) => made.ray_query = Some(p),
                Err(e) => {
                    made.destroy(ctx);
                    return Err(e);
                }
            }
        } else if support.ray_pipeline {
            let desc = RayTracingDesc {
                name: "ambient occlusion (ray-tracing pipeline)",
                raygen: &[shaders::OCCLUSION_RGEN],
                misses: &[shaders::SHADOWS_RMISS],
                hit_groups: &[HitGroup::any_hit(shaders::SHADOWS_RAHIT, None)],
            };
            match RayTracingPipeline::new(ctx, layout, &desc) {
                Ok(p) => made.ray_pipeline = Some(p),
                Err(e) => {
                    made.destroy(ctx);
                    return Err(e);
                }
            }
        }
        Ok(made)
    }

    /// Whether `settings` ask for traced occlusion on a device that can trace it (the scene's
    /// structures must then be kept).
    pub fn traces(&self, settings: &OcclusionSettings) -> bool {
        settings.runs() && settings.method == OcclusionMethod::RayTraced && (self.ray_query.is_some() || self.ray_pipeline.is_some())
    }

    /// This frame's method for `settings`: traced where the device traces rays and the scene's
    /// TLAS (`traced`, with the meshes) exists, screen space where it cannot trace at all, off
    /// when asked, when the settings cannot occlude, or while there is nothing to trace against.
    pub fn plan(&self, settings: &OcclusionSettings, traced: Option<[ResourceId; 2]>, meshes: ResourceId) -> OcclusionFrame {
        let can_trace = self.ray_query.is_some() || self.ray_pipeline.is_some();
        let method = match settings.method {
            _ if !settings.runs() => OcclusionMethod::Off,
            OcclusionMethod::RayTraced if !can_trace => OcclusionMethod::ScreenSpace,
            OcclusionMethod::RayTraced if traced.is_none() => OcclusionMethod::Off,
            m => m,
        };
        let traced = traced.filter(|_| method == OcclusionMethod::RayTraced);
        OcclusionFrame { method, traced, meshes: traced.map(|_| meshes) }
    }

    /// Records the occlusion passes (needs this frame's depth and, traced, its TLAS).
    pub fn record(&self, f: &mut Frame, scene: &GpuScene, frame: &OcclusionFrame) -> Result<(), RenderError> {
        if !frame.on() {
            return Ok(());
        }
        let extent = f.graph.extent();
        let groups = (extent.width.div_ceil(8), extent.height.div_ceil(8));
        // Ray queries where the device has them (the seed's way for shadows), else a
        // ray-generation pass; screen space needs neither.
        let tracer = match (frame.method, self.ray_query, &self.ray_pipeline) {
            (OcclusionMethod::RayTraced, Some(p), _) => Tracer::Compute(p),
            (OcclusionMethod::RayTraced, None, Some(rt)) => Tracer::RayGen(rt),
            (OcclusionMethod::RayTraced, None, None) => return Err(RenderError::Other("traced ambient occlusion without rays".into())),
            _ => Tracer::Compute(self.screen_space),
        };
        let kind = if matches!(tracer, Tracer::RayGen(_)) { PassKind::RayTracing } else { PassKind::Compute };
        let pass = f
            .pass("occlusion", kind)
            .sample(&DEPTH)
            .reads(scene.res.shaded())
            .reads(frame.traced.into_iter().flatten().map(|a| (a, BufferUse::Accel)))
            .reads(frame.meshes.map(|m| (m, BufferUse::Storage)))
            .image(&OCCLUSION_RAW, ImageUse::StorageWrite);
        match tracer {
            Tracer::RayGen(rt) => pass.record(|p| {
                p.bind(vk::PipelineBindPoint::RAY_TRACING_KHR, rt.pipeline, &p.push);
                rt.trace(p.cmd, 0, extent);
            })?,
            Tracer::Compute(pipeline) => pass.record(|p| {
                p.bind(vk::PipelineBindPoint::COMPUTE, pipeline, &p.push);
                p.cmd.dispatch(groups.0, groups.1, 1);
            })?,
        }
        f.pass("occlusion_denoise", PassKind::Compute)
            .sample(&DEPTH)
            .reads(scene.res.shaded())
            .image(&OCCLUSION_RAW, ImageUse::StorageRead)
            .image(&OCCLUSION, ImageUse::StorageWrite)
            .record(|p| {
                p.bind(vk::PipelineBindPoint::COMPUTE, self.denoise, &p.push);
                p.cmd.dispatch(groups.0, groups.1, 1);
            })
    }

    /// Destroys the pipelines; the GPU must be idle.
    pub fn destroy(self, ctx: &GpuContext) {
        for p in [Some(self.screen_space), Some(self.denoise), self.ray_query].into_iter().flatten() {
            // SAFETY: the GPU is idle (or the pipelines were never used).
            unsafe { ctx.destroying().destroy_pipeline(p, None) };
        }
        if let Some(rt) = self.ray_pipeline {
            rt.destroy(ctx);
        }
    }
}
