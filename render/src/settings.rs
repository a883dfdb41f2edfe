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
    /// Ray-query decals in the shading pass (needs the ray query tier).
    #[default]
    RayQuery,
    /// Rasterised decal boxes blended into the G-buffer (deferred pipeline only; other
    /// pipelines fall back to ray-query decals where the device has ray queries). Needs no ray
    /// tracing at all.
    DeferredDecals,
    /// No decals.
    Off,
    /// Reported, never requested: the requested method cannot run on this device and pipeline
    /// and no other can, so no decal is applied (`none` in `--stats`).
    Unavailable,
}

impl DecalMethod {
    /// Every method that can be requested.
    pub const ALL: [DecalMethod; 3] = [DecalMethod::RayQuery, DecalMethod::DeferredDecals, DecalMethod::Off];

    /// The name used in `--stats` and on the command line.
    pub fn name(self) -> &'static str {
        match self {
            DecalMethod::RayQuery => "ray_query",
            DecalMethod::DeferredDecals => "deferred",
            DecalMethod::Off => "off",
            DecalMethod::Unavailable => "none",
        }
    }

    /// Parses [`DecalMethod::name`].
    pub fn from_name(name: &str) -> Option<Self> {
        Self::ALL.into_iter().find(|m| m.name() == name)
    }

    /// The method actually applied with `pipeline` on a device of `tier`: the requested one
    /// when it can run, else the best one that can (ray-query decals need the ray-query tier,
    /// deferred decals the deferred pipeline), else [`DecalMethod::Unavailable`]. Never
    /// nothing when something can run.
    pub fn effective(self, pipeline: PipelineKind, tier: Tier) -> DecalMethod {
        let ray_query = tier == Tier::RayQuery;
        let deferred = pipeline == PipelineKind::Deferred;
        match self {
            DecalMethod::Off => DecalMethod::Off,
            DecalMethod::RayQuery | DecalMethod::Unavailable if ray_query => DecalMethod::RayQuery,
            DecalMethod::DeferredDecals if deferred => DecalMethod::DeferredDecals,
            _ if deferred => DecalMethod::DeferredDecals,
            _ if ray_query => DecalMethod::RayQuery,
            _ => DecalMethod::Unavailable,
        }
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
        let rq = Tier::RayQuery;
        let rtp = Tier::RayTracingPipeline;
        let none = Tier::NoRayTracing;
        assert_eq!(RayQuery.effective(Forward, rq), RayQuery);
        assert_eq!(DeferredDecals.effective(Deferred, rq), DeferredDecals);
        assert_eq!(DeferredDecals.effective(Forward, rq), RayQuery, "deferred decals exist only in the deferred pipeline");
        assert_eq!(RayQuery.effective(Deferred, rtp), DeferredDecals, "no ray queries: deferred decals, not nothing");
        assert_eq!(RayQuery.effective(Deferred, none), DeferredDecals);
        assert_eq!(RayQuery.effective(Forward, rtp), Unavailable, "no method runs in forward without ray queries yet");
        assert_eq!(DeferredDecals.effective(VisBuffer, none), Unavailable);
        assert_eq!(Off.effective(Forward, rq), Off);
        assert_eq!(Unavailable.name(), "none");
        assert!(!DecalMethod::ALL.contains(&Unavailable), "reported, never requested");
    }
}
