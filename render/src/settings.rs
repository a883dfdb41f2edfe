//! What a frame can be asked for: the pipeline, the decal method, the debug view. Plain
//! settings that may change from one frame to the next.

use crate::gpu::device::Tier;

/// Which renderer draws the frame.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash, Default)]
pub enum PipelineKind {
    /// Forward shading with a reverse-Z depth prepass.
    #[default]
    Forward,
    /// Deferred shading: G-buffer, optional deferred decals, full-screen lighting.
    Deferred,
    /// Visibility-buffer deferred texturing.
    VisBuffer,
}

impl PipelineKind {
    /// Every pipeline.
    pub const ALL: [PipelineKind; 3] = [PipelineKind::Forward, PipelineKind::Deferred, PipelineKind::VisBuffer];

    /// The name used in `--stats` and on the command line.
    pub fn name(self) -> &'static str {
        match self {
            PipelineKind::Forward => "forward",
            PipelineKind::Deferred => "deferred",
            PipelineKind::VisBuffer => "visbuffer",
        }
    }

    /// Parses [`PipelineKind::name`].
    pub fn from_name(name: &str) -> Option<Self> {
        Self::ALL.into_iter().find(|p| p.name() == name)
    }
}

/// How decals are applied.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash, Default)]
pub enum DecalMethod {
    /// Ray-query decals in the shading pass (needs ray queries).
    #[default]
    RayQuery,
    /// A compute pass with ray queries writes the decal buffer the shading passes apply (needs
    /// ray queries): the ray-query tier's counterpart of [`DecalMethod::RayPipeline`].
    RayQueryCompute,
    /// A ray-tracing-pipeline pass writes the decal buffer the shading passes apply (needs
    /// acceleration structures and ray-tracing pipelines, no ray queries).
    RayPipeline,
    /// Clustered decals: compute passes bin the decals into view clusters and a decal pass walks
    /// each pixel's cluster list, writing the decal buffer the shading passes apply. Needs no ray
    /// tracing: runs on every device, and is the choice where there are no acceleration
    /// structures.
    Clustered,
    /// Rasterised decal boxes blended into the G-buffer (deferred pipeline only). Needs no ray
    /// tracing at all.
    DeferredDecals,
    /// No decals.
    Off,
    /// Reported, never requested: the requested method cannot run on this device and pipeline
    /// and no other can, so no decal is applied (`none` in `--stats`).
    Unavailable,
}

/// What a device offers decals (from its capability tier and extensions).
#[derive(Clone, Copy, Debug, PartialEq, Eq, Default)]
pub struct DecalSupport {
    /// Ray queries (the ray-query tier).
    pub ray_query: bool,
    /// Acceleration structures and ray-tracing pipelines.
    pub ray_pipeline: bool,
}

impl DecalSupport {
    /// What a device of `tier` offers when it has every extension of its tier (a ray-query
    /// device may lack ray-tracing pipelines; [`crate::Renderer`] reports the device's own).
    pub fn of_tier(tier: Tier) -> Self {
        Self { ray_query: tier == Tier::RayQuery, ray_pipeline: tier >= Tier::RayTracingPipeline }
    }
}

impl DecalMethod {
    /// Every method that can be requested.
    pub const ALL: [DecalMethod; 6] = [
        DecalMethod::RayQuery,
        DecalMethod::RayQueryCompute,
        DecalMethod::RayPipeline,
        DecalMethod::Clustered,
        DecalMethod::DeferredDecals,
        DecalMethod::Off,
    ];

    /// The name used in `--stats` and on the command line.
    pub fn name(self) -> &'static str {
        match self {
            DecalMethod::RayQuery => "ray_query",
            DecalMethod::RayQueryCompute => "ray_query_compute",
            DecalMethod::RayPipeline => "ray_pipeline",
            DecalMethod::Clustered => "clustered",
            DecalMethod::DeferredDecals => "deferred",
            DecalMethod::Off => "off",
            DecalMethod::Unavailable => "none",
        }
    }

    /// Parses [`DecalMethod::name`].
    pub fn from_name(name: &str) -> Option<Self> {
        Self::ALL.into_iter().find(|m| m.name() == name)
    }

    /// Whether the method traces the decal acceleration structures.
    pub fn traces(self) -> bool {
        matches!(self, DecalMethod::RayQuery | DecalMethod::RayQueryCompute | DecalMethod::RayPipeline)
    }

    /// Whether a decal pass writes the decal buffer that the shading passes apply.
    pub fn uses_decal_buffer(self) -> bool {
        matches!(self, DecalMethod::RayQueryCompute | DecalMethod::RayPipeline | DecalMethod::Clustered)
    }

    /// Whether this method can run with `pipeline` on a device offering `support`.
    pub fn runs(self, pipeline: PipelineKind, support: DecalSupport) -> bool {
        match self {
            DecalMethod::RayQuery | DecalMethod::RayQueryCompute => support.ray_query,
            DecalMethod::RayPipeline => support.ray_pipeline,
            DecalMethod::DeferredDecals => pipeline == PipelineKind::Deferred,
            DecalMethod::Clustered | DecalMethod::Off => true,
            DecalMethod::Unavailable => false,
        }
    }

    /// The method actually applied with `pipeline` on a device offering `support`: the
    /// requested one when it can run, else the best one that can (ray queries in the shading
    /// pass, then the ray-tracing-pipeline decal pass, then clustered decals, which run
    /// everywhere), so never nothing ([`DecalMethod::Unavailable`] remains for a device that
    /// could run none).
    pub fn effective(self, pipeline: PipelineKind, support: DecalSupport) -> DecalMethod {
        if self.runs(pipeline, support) {
            return self;
        }
        [DecalMethod::RayQuery, DecalMethod::RayPipeline, DecalMethod::Clustered]
            .into_iter()
            .find(|m| m.runs(pipeline, support))
            .unwrap_or(DecalMethod::Unavailable)
    }
}

/// What the shading pass writes: the lit image, or one of the inputs to lighting.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash, Default)]
#[repr(u32)]
pub enum DebugView {
    /// The lit image.
    #[default]
    Lit = crate::layout::DEBUG_LIT,
    /// Decals tested per pixel (boxes the ray query reported), as a heat map.
    DecalHeatmap = crate::layout::DEBUG_DECAL_HEATMAP,
    /// Albedo after decals (linear).
    Albedo = crate::layout::DEBUG_ALBEDO,
    /// World normal after decals, encoded n × 0.5 + 0.5.
    Normal = crate::layout::DEBUG_NORMAL,
    /// Roughness (R) and metallic (G) after decals.
    RoughnessMetallic = crate::layout::DEBUG_ROUGHNESS_METALLIC,
    /// Decals tested per pixel as a raw count in R (for tests).
    DecalCount = crate::layout::DEBUG_DECAL_COUNT,
}

/// Per-frame choices that may change from one frame to the next.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct FrameSettings {
    /// The pipeline to record.
    pub pipeline: PipelineKind,
    /// How decals are applied (see [`DecalMethod::effective`]).
    pub decal_method: DecalMethod,
    /// Radiance of pixels no geometry covers.
    pub clear_color: [f32; 4],
    /// What the shading pass outputs.
    pub debug_view: DebugView,
    /// Draw every decal's box (oriented, green) and AABB (yellow) over the image.
    pub show_decal_boxes: bool,
}

impl Default for FrameSettings {
    fn default() -> Self {
        Self {
            pipeline: PipelineKind::Forward,
            decal_method: DecalMethod::RayQuery,
            clear_color: [0.0, 0.0, 0.0, 1.0],
            debug_view: DebugView::Lit,
            show_decal_boxes: false,
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_applied_decal_method_is_the_best_one_the_device_can_run() {
        use DecalMethod::*;
        use PipelineKind::*;
        let rq = DecalSupport::of_tier(Tier::RayQuery);
        let rtp = DecalSupport::of_tier(Tier::RayTracingPipeline);
        let none = DecalSupport::of_tier(Tier::NoRayTracing);
        let rq_only = DecalSupport { ray_query: true, ray_pipeline: false };
        for p in PipelineKind::ALL {
            assert_eq!(RayQuery.effective(p, rq), RayQuery);
            assert_eq!(RayQueryCompute.effective(p, rq), RayQueryCompute);
            assert_eq!(RayPipeline.effective(p, rq), RayPipeline, "a ray-query device with ray-tracing pipelines runs both");
            assert_eq!(RayPipeline.effective(p, rq_only), RayQuery, "the best method this device has");
            assert_eq!(RayQuery.effective(p, rtp), RayPipeline, "no ray queries: the ray-tracing-pipeline pass, not nothing");
            assert_eq!(RayQueryCompute.effective(p, rtp), RayPipeline);
            assert_eq!(RayPipeline.effective(p, rtp), RayPipeline);
            assert_eq!(Off.effective(p, rq), Off);
        }
        assert_eq!(DeferredDecals.effective(Deferred, rq), DeferredDecals);
        assert_eq!(DeferredDecals.effective(Forward, rq), RayQuery, "deferred decals exist only in the deferred pipeline");
        assert_eq!(DeferredDecals.effective(Forward, rtp), RayPipeline);
        assert_eq!(RayQuery.effective(Deferred, none), Clustered, "no acceleration structures: clustered decals");
        assert_eq!(RayPipeline.effective(Forward, none), Clustered, "in every pipeline");
        assert_eq!(DeferredDecals.effective(VisBuffer, none), Clustered);
        assert_eq!(DeferredDecals.effective(Deferred, none), DeferredDecals, "deferred decals need no ray tracing");
        for p in PipelineKind::ALL {
            assert_eq!(Clustered.effective(p, none), Clustered, "clustered decals run everywhere");
        }
        assert_eq!(Unavailable.name(), "none");
        assert!(!DecalMethod::ALL.contains(&Unavailable), "reported, never requested");
        for m in DecalMethod::ALL {
            assert_eq!(DecalMethod::from_name(m.name()), Some(m));
        }
    }
}
