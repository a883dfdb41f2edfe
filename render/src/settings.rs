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
    /// Forward+ (seed 001): depth prepass, tiled light culling, ray-traced shadows, then forward
    /// shading over each tile's lights (the light method is always tiled).
    ForwardPlus,
}

impl PipelineKind {
    /// Every pipeline.
    pub const ALL: [PipelineKind; 4] = [PipelineKind::Forward, PipelineKind::Deferred, PipelineKind::VisBuffer, PipelineKind::ForwardPlus];

    /// The name used in `--stats` and on the command line.
    pub fn name(self) -> &'static str {
        match self {
            PipelineKind::Forward => "forward",
            PipelineKind::Deferred => "deferred",
            PipelineKind::VisBuffer => "visbuffer",
            PipelineKind::ForwardPlus => "forward_plus",
        }
    }

    /// Parses [`PipelineKind::name`].
    pub fn from_name(name: &str) -> Option<Self> {
        Self::ALL.into_iter().find(|p| p.name() == name)
    }

    /// Whether the pipeline shades in a forward pass over the prepass's depth (forward and
    /// Forward+), where decals found in the shader need no decal pass and no ids prepass.
    pub fn is_forward(self) -> bool {
        matches!(self, PipelineKind::Forward | PipelineKind::ForwardPlus)
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
    /// acceleration structures and ray-tracing pipelines, no ray queries). Runs only when asked
    /// for: a device without ray queries falls back to [`DecalMethod::Clustered`] (see
    /// [`DecalMethod::effective`]).
    RayPipeline,
    /// Clustered decals: compute passes bin the decals into view clusters and a decal pass walks
    /// each pixel's cluster list, writing the decal buffer the shading passes apply. Needs no ray
    /// tracing: runs on every device, and is the choice where there are no ray queries.
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

/// What a device offers the methods that trace rays (decals, ray-query lights), from its
/// capability tier and extensions.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Default)]
pub struct RaySupport {
    /// Ray queries (the ray-query tier).
    pub ray_query: bool,
    /// Acceleration structures and ray-tracing pipelines.
    pub ray_pipeline: bool,
}

impl RaySupport {
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
    pub fn runs(self, pipeline: PipelineKind, support: RaySupport) -> bool {
        match self {
            DecalMethod::RayQuery | DecalMethod::RayQueryCompute => support.ray_query,
            DecalMethod::RayPipeline => support.ray_pipeline,
            DecalMethod::DeferredDecals => pipeline == PipelineKind::Deferred,
            DecalMethod::Clustered | DecalMethod::Off => true,
            DecalMethod::Unavailable => false,
        }
    }

    /// The method actually applied with `pipeline` on a device offering `support`: the
    /// requested one when it can run, else the best one that can: ray queries in the shading
    /// pass, else clustered decals, which run everywhere, so never nothing
    /// ([`DecalMethod::Unavailable`] is what `--stats` would report if none could run).
    ///
    /// The ray-tracing-pipeline decal pass is never the fallback. A device with ray-tracing
    /// pipelines but no ray queries is, as far as we know, one without ray-tracing hardware. The
    /// only one measured, the lent NVIDIA H100 (it has no RT cores), ran clustered decals faster
    /// everywhere we measured (every pipeline at 100 and 1,000 decals, deferred at 10,000 to
    /// 1,000,000), in a fraction of the memory (`docs/experiments/decals-fallback-clustered.md`).
    /// Decals in traced reflections still come from the decal acceleration
    /// structures, whatever the method.
    pub fn effective(self, pipeline: PipelineKind, support: RaySupport) -> DecalMethod {
        if self.runs(pipeline, support) {
            return self;
        }
        [DecalMethod::RayQuery, DecalMethod::Clustered].into_iter().find(|m| m.runs(pipeline, support)).unwrap_or(DecalMethod::Unavailable)
    }
}

/// How blended (transparent) surfaces are drawn (`crate::transparency`).
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash, Default)]
pub enum TransparencyMethod {
    /// Seed 002's method in the deferred pipeline (§2.4.2, §3.1): the nearest blended surface
    /// goes into the G-buffer on odd rows, is lit with everything else, and a composition pass
    /// blends it over the opaque rows. Other pipelines draw blended surfaces forward.
    #[default]
    Interlaced,
    /// The seed's interlacing as published, for comparison: each pair of rows gets one blended
    /// colour (half the vertical resolution over glass), no depth checks, no refraction.
    InterlacedPairs,
    /// A forward pass over the opaque image, back to front, in every pipeline.
    Forward,
    /// Seed 002's full-resolution reference (§4.1.2, deferred pipeline): two G-buffers, the
    /// nearest opaque surface and the nearest surface of any kind, each lit in full; a
    /// composition pass blends the glass over the first with refraction (costs a second
    /// G-buffer, culling, shadow and lighting pass).
    DepthPeeling,
}

impl TransparencyMethod {
    /// Every method.
    pub const ALL: [TransparencyMethod; 4] = [
        TransparencyMethod::Interlaced,
        TransparencyMethod::InterlacedPairs,
        TransparencyMethod::Forward,
        TransparencyMethod::DepthPeeling,
    ];

    /// The name used in `--stats` and on the command line.
    pub fn name(self) -> &'static str {
        match self {
            TransparencyMethod::Interlaced => "interlaced",
            TransparencyMethod::InterlacedPairs => "interlaced_pairs",
            TransparencyMethod::Forward => "forward",
            TransparencyMethod::DepthPeeling => "depth_peeling",
        }
    }

    /// Parses [`TransparencyMethod::name`].
    pub fn from_name(name: &str) -> Option<Self> {
        Self::ALL.into_iter().find(|m| m.name() == name)
    }

    /// The method applied with `pipeline`: interlacing and depth peeling live in the deferred
    /// pipeline's G-buffers, so every other pipeline draws blended surfaces forward.
    pub fn effective(self, pipeline: PipelineKind) -> TransparencyMethod {
        if pipeline == PipelineKind::Deferred { self } else { TransparencyMethod::Forward }
    }

    /// Whether the G-buffer holds the blended surfaces on odd rows.
    pub fn interlaces(self) -> bool {
        matches!(self, TransparencyMethod::Interlaced | TransparencyMethod::InterlacedPairs)
    }

    /// Whether blended surfaces refract the background: in the compositions of interlacing
    /// (this crate's, not the seed's pairs) and depth peeling.
    pub fn refracts(self) -> bool {
        matches!(self, TransparencyMethod::Interlaced | TransparencyMethod::DepthPeeling)
    }
}

/// How lights are assigned to pixels.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash, Default)]
pub enum LightMethod {
    /// Every pixel loops over every light.
    All,
    /// Tiled light culling (seed 001 §4.2): each pixel loops over its tile's lights.
    #[default]
    Tiled,
    /// Ray-query lights (seed 000 §5.2.5, §6.1): each pixel finds the lights whose boxes hold
    /// it with a zero-length ray through the lights' own acceleration structure. Deferred and
    /// visibility-buffer lighting only, on devices with acceleration structures.
    RayQuery,
}

impl LightMethod {
    /// Every method.
    pub const ALL: [LightMethod; 3] = [LightMethod::All, LightMethod::Tiled, LightMethod::RayQuery];

    /// The name used in `--stats` and on the command line.
    pub fn name(self) -> &'static str {
        match self {
            LightMethod::All => "all",
            LightMethod::Tiled => "tiled",
            LightMethod::RayQuery => "ray_query",
        }
    }

    /// Parses [`LightMethod::name`].
    pub fn from_name(name: &str) -> Option<Self> {
        Self::ALL.into_iter().find(|m| m.name() == name)
    }

    /// The method applied with `pipeline` on a device offering `support`: Forward+ is always
    /// tiled, and ray-query lights, which live in the deferred and visibility-buffer lighting
    /// passes and need acceleration structures, fall back to tiled culling elsewhere.
    pub fn effective(self, pipeline: PipelineKind, support: RaySupport) -> LightMethod {
        match self {
            _ if pipeline == PipelineKind::ForwardPlus => LightMethod::Tiled,
            LightMethod::RayQuery
                if !matches!(pipeline, PipelineKind::Deferred | PipelineKind::VisBuffer)
                    || !(support.ray_query || support.ray_pipeline) =>
            {
                LightMethod::Tiled
            }
            m => m,
        }
    }
}

/// How the shadow pass reconstructs normals from depth (seed 001 §4.3.1).
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash, Default)]
pub enum DepthNormals {
    /// Three taps: the next pixel across and down.
    Naive,
    /// Five taps per axis, choosing the side on the pixel's surface.
    #[default]
    Improved,
}

/// How shadows were made in a frame.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash, Default)]
pub enum ShadowMethod {
    /// Shadow rays from a compute pass with ray queries.
    RayQuery,
    /// Shadow rays from a ray-tracing pipeline.
    RayPipeline,
    /// Shadow maps (devices without ray tracing, or asked for with
    /// [`LightSettings::shadow_maps`]): `shadows::maps`.
    Maps,
    /// No shadows (turned off).
    #[default]
    None,
}

impl ShadowMethod {
    /// The name used in `--stats`.
    pub fn name(self) -> &'static str {
        match self {
            ShadowMethod::RayQuery => "ray_query",
            ShadowMethod::RayPipeline => "ray_pipeline",
            ShadowMethod::Maps => "maps",
            ShadowMethod::None => "none",
        }
    }
}

/// How the traced shadows of a pixel's lights are found (`crate::lights::sampling`).
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash, Default)]
pub enum DirectLight {
    /// A shadow ray towards every light of the pixel's list (seed 001 §4.3): exact, and as
    /// costly as the lights a pixel has.
    Exhaustive,
    /// One shadow ray a pixel towards a light drawn from its list (or from the lights ray-query
    /// lights find) in proportion to its unshadowed light, and one to each of the first four
    /// directional lights; the drawn lights are shaded unshadowed and scaled by the share that
    /// got through (the ratio estimator of Heitz et al. 2018: denoised over neighbours for
    /// lists, a pixel's own for ray-query lights). Noisy where it is not averaged.
    Stochastic,
    /// Exhaustive where a pixel's list holds at most [`DirectLight::AUTO_EXHAUSTIVE_UP_TO`]
    /// lights, sampled where it holds more (ray-query lights: a ray to each of the first that
    /// many lights a pixel finds, the rest sampled).
    #[default]
    Auto,
}

impl DirectLight {
    /// `Auto`: the most lights a pixel's list may hold and still get a ray each.
    pub const AUTO_EXHAUSTIVE_UP_TO: u32 = 32;

    /// Every method.
    pub const ALL: [DirectLight; 3] = [DirectLight::Exhaustive, DirectLight::Stochastic, DirectLight::Auto];

    /// The name used in `--stats` and on the command line.
    pub fn name(self) -> &'static str {
        match self {
            DirectLight::Exhaustive => "exhaustive",
            DirectLight::Stochastic => "stochastic",
            DirectLight::Auto => "auto",
        }
    }

    /// The largest list length a pixel traces a ray per light for (`u32::MAX`: every list).
    pub fn exhaustive_up_to(self) -> u32 {
        match self {
            DirectLight::Exhaustive => u32::MAX,
            DirectLight::Stochastic => 0,
            DirectLight::Auto => Self::AUTO_EXHAUSTIVE_UP_TO,
        }
    }
}

/// Light culling and shadows, per frame.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct LightSettings {
    /// How lights are assigned to pixels (see [`LightMethod::effective`]).
    pub method: LightMethod,
    /// Light tile side in pixels: 8, 16 or 32 (other values are rounded to the nearest).
    pub tile_size: u32,
    /// Light culling also tests lights against each tile's AABB (seed 001 §4.2.2).
    pub cull_aabb: bool,
    /// Light culling also tests lights against each tile's depth mask: the tile's depth range cut
    /// in 32 slices, a light kept only if its sphere spans a slice some pixel lies in (Harada,
    /// "A 2.5D culling for Forward+", 2012). It removes the lights in the gap of a tile that
    /// straddles a near and a far surface, which the range and the AABB keep. Frames with live
    /// or emitting particles cull without it (particles are lit from the tiles' lists wherever
    /// they float); the frame report says what was applied.
    pub cull_depth_mask: bool,
    /// Shadows: traced rays on devices with ray tracing, shadow maps on others.
    pub shadows: bool,
    /// Shadow maps even where rays could be traced (to compare the two).
    pub shadow_maps: bool,
    /// No shadow ray towards lights the reconstructed normal faces away from.
    pub shadow_ray_culling: bool,
    /// How the shadow pass reconstructs normals.
    pub normals: DepthNormals,
    /// Blended surfaces cast coloured shadows: light that crosses glass is filtered by its
    /// colour × (1 − opacity) (seed 002 §3.2.1). False: glass blocks light like an opaque
    /// surface (the cheaper shadows of seed 002 Table 4.3).
    pub coloured_shadows: bool,
    /// Traced shadows towards every light of a pixel's list, or towards one sampled light
    /// (ray-traced shadows with tiled or every-light lists, and ray-query lights; shadow maps
    /// are always exhaustive, and ray-query lights on the ray-tracing-pipeline tier always
    /// sampled: `crate::lights::sampling`).
    pub direct_light: DirectLight,
}

impl Default for LightSettings {
    fn default() -> Self {
        Self {
            method: LightMethod::Tiled,
            tile_size: 16,
            cull_aabb: true,
            cull_depth_mask: true,
            shadows: true,
            shadow_maps: false,
            shadow_ray_culling: true,
            normals: DepthNormals::Improved,
            coloured_shadows: true,
            direct_light: DirectLight::Auto,
        }
    }
}

impl LightSettings {
    /// The tile size used: 8, 16 or 32.
    pub fn tile(&self) -> u32 {
        match self.tile_size {
            0..=11 => 8,
            12..=23 => 16,
            _ => 32,
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
    /// Lights in each pixel's list (its tile's after culling) as a heat map (seed 001 Fig. 5.2).
    LightHeatmap = crate::layout::DEBUG_LIGHT_HEATMAP,
    /// Shadow rays traced per pixel as a heat map.
    ShadowRays = crate::layout::DEBUG_SHADOW_RAYS,
    /// The normals the shadow pass reconstructed from depth (left half) next to the shading
    /// normals (right half).
    DepthNormals = crate::layout::DEBUG_DEPTH_NORMALS,
    /// Lights in each pixel's list as a raw count in R (for tests).
    LightCount = crate::layout::DEBUG_LIGHT_COUNT,
    /// The shadow bit of the first light of each pixel's list in R, the list's length in G,
    /// whether shadows were read in B (for tests).
    ShadowFirst = crate::layout::DEBUG_SHADOW_FIRST,
    /// The reflection rays: a heat map of their hit distance (0 to 16 m) where a pixel traced
    /// one, white where it missed, the lit image dimmed elsewhere.
    Reflections = crate::layout::DEBUG_REFLECTIONS,
    /// The ambient occlusion ambient light is multiplied by, as grey (white where it is off).
    AmbientOcclusion = crate::layout::DEBUG_AMBIENT_OCCLUSION,
    /// With ray-tracing-pipeline decals: the decals whose box holds each pixel's surface point
    /// (and whose angle and distance fades leave something) as a raw count in R, counted by a variant of the decal pass that only counts and applies
    /// nothing (the floor its lit pass is measured against). With other methods, the decals
    /// they tested, as [`DebugView::DecalCount`].
    DecalFloor = crate::layout::DEBUG_DECAL_FLOOR,
    /// Each surface in the colour of the level of detail its instance drew: level 0 white, then
    /// blue, green, yellow and red as the levels coarsen; meshes without levels dark grey
    /// (`crate::lod`).
    Lod = crate::layout::DEBUG_LOD,
}

impl DebugView {
    /// Whether the view shows what the shadow pass wrote to its debug image.
    pub fn reads_shadow_debug(self) -> bool {
        matches!(self, DebugView::ShadowRays | DebugView::DepthNormals)
    }
}

/// The shadow-map atlas (fixed when the renderer is created; allocated on the first frame that
/// uses shadow maps).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct ShadowMapBudget {
    /// A tile's side in texels (one view: a spot light, a cube face, a directional light).
    pub tile: u32,
    /// Tiles in the atlas. A spot or directional light takes one, a point light six; lights
    /// past the budget are unshadowed and counted (`shadow_maps_missing`): the atlas goes to the
    /// lights that bring what the camera sees the most light (`shadows::maps::map_priority`).
    pub tiles: u32,
    /// How far from the camera directional lights' maps reach, in metres (a map fitted to
    /// the view up to this distance).
    pub directional_distance: f32,
}

impl Default for ShadowMapBudget {
    /// 1024² tiles (the seed's maps), 24 of them (5 bytes a texel: 126 MB).
    fn default() -> Self {
        Self { tile: 1024, tiles: 24, directional_distance: 60.0 }
    }
}

/// Anti-aliasing of the displayed image. A mode a pipeline or device cannot run falls back
/// ([`AntiAliasing::applied`]); the renderer says so once and reports the mode applied.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash, Default)]
pub enum AntiAliasing {
    /// None: every edge shows its stair steps.
    #[default]
    None,
    /// Fast approximate anti-aliasing (`crate::fxaa`), a compute pass before the
    /// display pass, in every pipeline: edges found by luma contrast are blended along their
    /// stair steps.
    Fxaa,
    /// Subpixel morphological anti-aliasing, 1x (`crate::smaa`), three compute passes before the
    /// display pass, in every pipeline: each stair step's silhouette is reconstructed from the
    /// edge's length and the crossing edges at its ends, and pixels blend across the edge by
    /// the area it cuts off (straight edges stay sharp).
    Smaa,
    /// Temporal anti-aliasing (`crate::taa`), in every pipeline: a jittered view each frame,
    /// blended with the history reprojected by motion vectors (`crate::motion`). Applied as
    /// none while a debug view is shown (they are drawn unjittered).
    Taa,
    /// Multisample anti-aliasing with 2 samples a pixel (`crate::msaa`), in forward and
    /// Forward+; the deferred pipelines apply temporal anti-aliasing instead (seed 000 §2.6:
    /// deferred shading does not support MSAA).
    Msaa2,
    /// MSAA with 4 samples a pixel.
    Msaa4,
    /// MSAA with 8 samples a pixel (devices that offer fewer use the most they offer).
    Msaa8,
}

impl AntiAliasing {
    /// Every mode.
    pub const ALL: [AntiAliasing; 7] = [
        AntiAliasing::None,
        AntiAliasing::Fxaa,
        AntiAliasing::Smaa,
        AntiAliasing::Taa,
        AntiAliasing::Msaa2,
        AntiAliasing::Msaa4,
        AntiAliasing::Msaa8,
    ];

    /// The name used in `--stats` and on the command line.
    pub fn name(self) -> &'static str {
        match self {
            AntiAliasing::None => "none",
            AntiAliasing::Fxaa => "fxaa",
            AntiAliasing::Smaa => "smaa",
            AntiAliasing::Taa => "taa",
            AntiAliasing::Msaa2 => "msaa2",
            AntiAliasing::Msaa4 => "msaa4",
            AntiAliasing::Msaa8 => "msaa8",
        }
    }

    /// Parses [`AntiAliasing::name`].
    pub fn from_name(name: &str) -> Option<Self> {
        Self::ALL.into_iter().find(|m| m.name() == name)
    }

    /// Samples a pixel the scene is rasterised with: 1 but for MSAA.
    pub fn samples(self) -> u32 {
        match self {
            AntiAliasing::Msaa2 => 2,
            AntiAliasing::Msaa4 => 4,
            AntiAliasing::Msaa8 => 8,
            _ => 1,
        }
    }

    /// The MSAA mode with the most samples a pixel, up to `samples`, among the counts
    /// `supported` (a mask whose bit `n` stands for `n` samples, as Vulkan's sample-count
    /// flags); none when there is none.
    fn msaa(samples: u32, supported: u32) -> Self {
        match [8, 4, 2].into_iter().find(|&n| n <= samples && supported & n != 0) {
            Some(8) => AntiAliasing::Msaa8,
            Some(4) => AntiAliasing::Msaa4,
            Some(_) => AntiAliasing::Msaa2,
            None => AntiAliasing::None,
        }
    }

    /// The mode as it applies in `pipeline` with `debug_view` on a device whose render targets
    /// take the sample counts of the mask `supported` (bit `n`: `n` samples): MSAA in a
    /// deferred pipeline is temporal anti-aliasing (the G-buffer and the visibility buffer are
    /// shaded a pixel at a time), and takes the most samples the device offers up to those
    /// asked for; temporal anti-aliasing is none under a debug view (drawn unjittered,
    /// unresolved).
    pub fn applied(self, pipeline: PipelineKind, debug_view: DebugView, supported: u32) -> Self {
        let aa = match self {
            AntiAliasing::Msaa2 | AntiAliasing::Msaa4 | AntiAliasing::Msaa8 if !pipeline.is_forward() => AntiAliasing::Taa,
            AntiAliasing::Msaa2 | AntiAliasing::Msaa4 | AntiAliasing::Msaa8 => Self::msaa(self.samples(), supported),
            aa => aa,
        };
        match aa {
            AntiAliasing::Taa if debug_view != DebugView::Lit => AntiAliasing::None,
            aa => aa,
        }
    }
}

/// The tone mapper of the display transform (`shaders/include/color.glsl`).
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash, Default)]
#[repr(u32)]
pub enum Tonemapper {
    /// Khronos PBR Neutral: base colours stay recognisable up to the highlights, which compress
    /// towards white (the glTF sample viewer's).
    #[default]
    PbrNeutral = crate::layout::TONEMAP_PBR_NEUTRAL,
    /// Hill's fit of the ACES reference rendering and output transforms (with the customary
    /// 1/0.6 exposure bias): filmic contrast, saturated highlights bleach.
    AcesFitted = crate::layout::TONEMAP_ACES_FITTED,
    /// AgX (Sobotka), in Wrensch's minimal polynomial fit: gentle contrast, bright saturated
    /// colours desaturate towards white instead of skewing hue.
    AgX = crate::layout::TONEMAP_AGX,
}

impl Tonemapper {
    /// Every tone mapper.
    pub const ALL: [Tonemapper; 3] = [Tonemapper::PbrNeutral, Tonemapper::AcesFitted, Tonemapper::AgX];

    /// The name used in `--stats` and on the command line.
    pub fn name(self) -> &'static str {
        match self {
            Tonemapper::PbrNeutral => "neutral",
            Tonemapper::AcesFitted => "aces",
            Tonemapper::AgX => "agx",
        }
    }

    /// Parses [`Tonemapper::name`].
    pub fn from_name(name: &str) -> Option<Self> {
        Self::ALL.into_iter().find(|m| m.name() == name)
    }
}

/// Bloom (`crate::bloom`): light spreading around bright parts of the image, as a lens does.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct BloomSettings {
    /// Whether the bloom passes run.
    pub enabled: bool,
    /// How much of the image is replaced by its blurred copy (0 to 1; the blend keeps the
    /// image's energy).
    pub intensity: f32,
}

impl Default for BloomSettings {
    fn default() -> Self {
        Self { enabled: true, intensity: 0.04 }
    }
}

impl BloomSettings {
    /// No bloom.
    pub const OFF: BloomSettings = BloomSettings { enabled: false, intensity: 0.04 };

    /// Whether bloom runs with these settings (on, with a positive intensity).
    pub fn runs(&self) -> bool {
        self.enabled && self.intensity > 0.0 && self.intensity.is_finite()
    }
}

/// Auto-exposure (`crate::exposure`): the display's exposure follows the scene's luminance, as
/// an eye or a camera adapts, instead of the camera's fixed exposure.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct AutoExposure {
    /// Whether it runs (default off: the camera's exposure, `Camera::exposure`).
    pub enabled: bool,
    /// Stops added to the exposure it finds (positive brightens; default 0).
    pub compensation: f32,
    /// The darkest scene it exposes for, as an EV100 (default −4: darker scenes stay dark).
    pub min_ev100: f32,
    /// The brightest scene it exposes for, as an EV100 (default 16).
    pub max_ev100: f32,
    /// How fast it adapts: the share of the way covered in one second is 1 − e^−rate (default
    /// 3: 95 % in one second).
    pub rate: f32,
}

impl Default for AutoExposure {
    fn default() -> Self {
        Self { enabled: false, compensation: 0.0, min_ev100: -4.0, max_ev100: 16.0, rate: 3.0 }
    }
}

impl AutoExposure {
    /// Whether it runs with these settings: enabled, with finite settings and a range.
    pub fn runs(&self) -> bool {
        let finite = [self.compensation, self.min_ev100, self.max_ev100, self.rate].iter().all(|v| v.is_finite());
        self.enabled && finite && self.min_ev100 <= self.max_ev100 && self.rate >= 0.0
    }
}

/// How ambient light is occluded (`crate::occlusion`): the environment's and the
/// ambient colour's light, never the lights'.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash, Default)]
pub enum OcclusionMethod {
    /// No ambient occlusion (the material's occlusion texture only).
    Off,
    /// Short rays against the scene's TLAS, on either ray-tracing tier (ray queries, or a
    /// ray-tracing pipeline); without ray tracing, [`OcclusionMethod::ScreenSpace`] stands in.
    #[default]
    RayTraced,
    /// Ground-truth ambient occlusion over the depth buffer, on every device: it cannot see
    /// what is off screen or hidden behind the nearest surface.
    ScreenSpace,
}

impl OcclusionMethod {
    /// Every method, in the order of `--ao`'s names.
    pub const ALL: [OcclusionMethod; 3] = [OcclusionMethod::Off, OcclusionMethod::RayTraced, OcclusionMethod::ScreenSpace];

    /// The name `--ao` and `--stats` use.
    pub fn name(self) -> &'static str {
        match self {
            OcclusionMethod::Off => "off",
            OcclusionMethod::RayTraced => "ray_traced",
            OcclusionMethod::ScreenSpace => "screen_space",
        }
    }

    /// Parses [`OcclusionMethod::name`].
    pub fn from_name(name: &str) -> Option<Self> {
        Self::ALL.into_iter().find(|m| m.name() == name)
    }

    /// The method a device with `support` applies when this one is asked for: rays need an
    /// acceleration structure and a way to trace it, else screen space stands in.
    pub fn effective(self, support: RaySupport) -> OcclusionMethod {
        match self {
            OcclusionMethod::RayTraced if !(support.ray_query || support.ray_pipeline) => OcclusionMethod::ScreenSpace,
            m => m,
        }
    }
}

/// Ambient occlusion's settings.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct OcclusionSettings {
    /// How (default: traced, screen space without ray tracing).
    pub method: OcclusionMethod,
    /// How far an occluder counts, in metres (default 1): the length of the rays, the
    /// screen-space search's radius.
    pub radius: f32,
    /// Rays per pixel when traced (default 2; each 4×4 block of pixels shares 16× as many
    /// directions through the denoiser).
    pub rays: u32,
}

impl Default for OcclusionSettings {
    fn default() -> Self {
        Self { method: OcclusionMethod::default(), radius: 1.0, rays: 2 }
    }
}

impl OcclusionSettings {
    /// No ambient occlusion.
    pub const OFF: OcclusionSettings = OcclusionSettings { method: OcclusionMethod::Off, radius: 1.0, rays: 2 };

    /// Whether the settings can occlude anything: a method, a positive finite radius, a ray.
    pub fn runs(&self) -> bool {
        self.method != OcclusionMethod::Off && self.radius > 0.0 && self.radius.is_finite() && self.rays > 0
    }
}

/// Where reflections come from (`crate::reflections`).
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash, Default)]
pub enum ReflectionMode {
    /// None: smooth surfaces show the ambient colour.
    Off,
    /// A ray per pixel (or per 2×2 pixels) against the scene's TLAS, shaded at its hit point
    /// with the decals there, its lights and their shadows; the clear colour on a miss. Needs
    /// ray queries or ray-tracing pipelines (falls back to [`ReflectionMode::ScreenSpace`]
    /// without).
    #[default]
    RayTraced,
    /// Each ray marched through the depth buffer, seeing this frame's lit image: only what is on
    /// screen is reflected (decals included), the clear colour elsewhere. Runs everywhere.
    ScreenSpace,
}

impl ReflectionMode {
    /// Every mode.
    pub const ALL: [ReflectionMode; 3] = [ReflectionMode::Off, ReflectionMode::RayTraced, ReflectionMode::ScreenSpace];

    /// The name used in `--stats` and on the command line.
    pub fn name(self) -> &'static str {
        match self {
            ReflectionMode::Off => "off",
            ReflectionMode::RayTraced => "ray_traced",
            ReflectionMode::ScreenSpace => "screen_space",
        }
    }

    /// Parses [`ReflectionMode::name`].
    pub fn from_name(name: &str) -> Option<Self> {
        Self::ALL.into_iter().find(|m| m.name() == name)
    }

    /// The mode this device runs: ray-traced reflections need ray queries or ray-tracing
    /// pipelines, and fall back to screen-space ones.
    pub fn effective(self, support: RaySupport) -> Self {
        match self {
            ReflectionMode::RayTraced if !(support.ray_query || support.ray_pipeline) => ReflectionMode::ScreenSpace,
            m => m,
        }
    }
}

/// Reflections of smooth surfaces (`crate::reflections`).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct ReflectionSettings {
    /// Where they come from.
    pub mode: ReflectionMode,
    /// Surfaces at least this rough reflect nothing (their ambient term stays); below it the
    /// reflection fades in over a quarter of the cut-off. Mirrors (roughness under 0.05) trace
    /// exactly; glossy surfaces sample the GGX lobe and are filtered.
    pub roughness_cutoff: f32,
    /// One ray per 2×2 pixels, upsampled by depth (about a quarter of the rays).
    pub half_resolution: bool,
    /// The rays' hit points show the decals there (false only to measure what that costs).
    pub decals_at_hits: bool,
}

impl Default for ReflectionSettings {
    /// Ray-traced at full resolution, for surfaces smoother than 0.4.
    fn default() -> Self {
        Self { mode: ReflectionMode::RayTraced, roughness_cutoff: 0.4, half_resolution: false, decals_at_hits: true }
    }
}

impl ReflectionSettings {
    /// No reflections.
    pub const OFF: Self = Self { mode: ReflectionMode::Off, roughness_cutoff: 0.4, half_resolution: false, decals_at_hits: true };
}

/// How instances are culled on the GPU before they are drawn (`crate::culling`).
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash, Default)]
pub enum CullingMode {
    /// Every live instance is drawn (still through the same indirect draws).
    Off,
    /// Instances whose bounds lie outside the view frustum are skipped.
    Frustum,
    /// Frustum culling, then two-phase hierarchical-Z occlusion culling: what was visible last
    /// frame is drawn, a depth pyramid is built from it, and the rest is tested against it and
    /// drawn in the same frame when it shows.
    #[default]
    Occlusion,
}

impl CullingMode {
    /// Every mode.
    pub const ALL: [CullingMode; 3] = [CullingMode::Off, CullingMode::Frustum, CullingMode::Occlusion];

    /// The name used in `--stats` and on the command line.
    pub fn name(self) -> &'static str {
        match self {
            CullingMode::Off => "off",
            CullingMode::Frustum => "frustum",
            CullingMode::Occlusion => "occlusion",
        }
    }

    /// Parses [`CullingMode::name`].
    pub fn from_name(name: &str) -> Option<Self> {
        Self::ALL.into_iter().find(|m| m.name() == name)
    }
}

/// The default limit of a coarser level of detail's projected error, in pixels
/// ([`FrameSettings::lod_pixels`]).
pub const DEFAULT_LOD_PIXELS: f32 = 1.0;

/// An instance moves to a coarser level of detail only when that level's projected error is
/// within this fraction of the limit ([`FrameSettings::lod_pixels`]).
pub const LOD_HYSTERESIS: f32 = 0.75;

/// The default height on screen, in pixels, below which a posed character's acceleration
/// structure is refit only every other frame ([`FrameSettings::refit_pixels`]).
pub const DEFAULT_REFIT_PIXELS: f32 = 48.0;

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
    /// Light culling and shadows.
    pub lights: LightSettings,
    /// Deferred lighting and visibility-buffer shading run as compute passes (false: as
    /// full-screen fragment passes, for comparison).
    pub compute_shading: bool,
    /// Forward and Forward+ walk the clustered decals' lists in their shading pass (no decal
    /// pass, no ids prepass) instead of reading the decal buffer of a clustered decal pass.
    /// Off by default: on the lent H100, whose fragment shading is slow, Forward+ measured
    /// +0.89 ms at 100 decals of PEERS.md's scene (with the decal pass and its ids prepass:
    /// +0.86), +1.93 ms at 1,000 (+0.87) and 290 ms a frame at 100,000 decals on the courtyard
    /// (7 ms); docs/experiments/decals-in-forward-shading.md.
    pub decals_in_forward_shading: bool,
    /// Anti-aliasing of the displayed image.
    pub aa: AntiAliasing,
    /// Temporal anti-aliasing's sharpening of its output, 0 (none) to 1 (`crate::taa`).
    pub taa_sharpen: f32,
    /// The display transform's tone mapper.
    pub tonemapper: Tonemapper,
    /// Bloom.
    pub bloom: BloomSettings,
    /// Ambient occlusion.
    pub occlusion: OcclusionSettings,
    /// Auto-exposure.
    pub exposure: AutoExposure,
    /// Seconds since the previous frame (auto-exposure adapts over time; a headless run's fixed
    /// step makes it reproducible).
    pub delta_seconds: f32,
    /// Reflections of smooth surfaces.
    pub reflections: ReflectionSettings,
    /// How blended surfaces are drawn (see [`TransparencyMethod::effective`]).
    pub transparency: TransparencyMethod,
    /// Interlaced and depth-peeled transparency displace the background by the materials'
    /// refraction (false: straight through, for comparison).
    pub refraction: bool,
    /// How instances are culled before they are drawn.
    pub culling: CullingMode,
    /// Keep culling against the view of the frame this was first set in ("freeze culling"): fly
    /// out and see what that view culled. Visibility is not updated while frozen.
    pub freeze_culling: bool,
    /// Levels of detail (`render/src/lod`): the most pixels a coarser level's error may cover on
    /// screen for an instance to draw it (1 by default; 0 draws every instance in full).
    pub lod_pixels: f32,
    /// Skin only the vertices of the coarsest level of detail a posed mesh can be drawn at this
    /// frame (`render/src/skinning`): a far character skins a few dozen vertices instead of
    /// every one. On by default; off skins every vertex (for comparison).
    pub skin_levels: bool,
    /// Skinned and morphed meshes shorter on screen than this many pixels (48 by default) have
    /// their ray-tracing structure refit every other frame instead of each frame their pose
    /// changes: their shadows, occlusion and reflections lag their drawn pose by at most
    /// `crate::accel::MAX_REFIT_STALENESS` frames. The class is decided once every
    /// `crate::accel::REFIT_CLASS_FRAMES` frames, so a mesh that grows within them waits up to
    /// that long to be refit every frame, unless it grows past `crate::accel::REFIT_PROMOTE`
    /// times the limit. 0 refits every one each frame.
    pub refit_pixels: f32,
    /// Submit a frame slot's command buffer again when a frame logs exactly the commands it was
    /// recorded with, instead of recording it again (`crate::gpu::commands`). On by default;
    /// off records every frame (for comparison).
    pub reuse_commands: bool,
}

impl Default for FrameSettings {
    fn default() -> Self {
        Self {
            pipeline: PipelineKind::Forward,
            decal_method: DecalMethod::RayQuery,
            clear_color: [0.0, 0.0, 0.0, 1.0],
            debug_view: DebugView::Lit,
            show_decal_boxes: false,
            lights: LightSettings::default(),
            compute_shading: true,
            decals_in_forward_shading: false,
            aa: AntiAliasing::None,
            taa_sharpen: 0.25,
            tonemapper: Tonemapper::PbrNeutral,
            bloom: BloomSettings::default(),
            occlusion: OcclusionSettings::default(),
            exposure: AutoExposure::default(),
            delta_seconds: 1.0 / 60.0,
            reflections: ReflectionSettings::default(),
            transparency: TransparencyMethod::Interlaced,
            refraction: true,
            culling: CullingMode::Occlusion,
            freeze_culling: false,
            lod_pixels: DEFAULT_LOD_PIXELS,
            skin_levels: true,
            refit_pixels: DEFAULT_REFIT_PIXELS,
            reuse_commands: true,
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn msaa_falls_back_to_what_the_pipeline_and_device_can_run() {
        use AntiAliasing as A;
        let lit = DebugView::Lit;
        for p in [PipelineKind::Forward, PipelineKind::ForwardPlus] {
            let all = 1 | 2 | 4 | 8;
            assert_eq!([A::Msaa2, A::Msaa4, A::Msaa8].map(|m| m.applied(p, lit, all)), [A::Msaa2, A::Msaa4, A::Msaa8]);
            // Lavapipe offers 1 and 4 samples.
            assert_eq!(A::Msaa8.applied(p, lit, 1 | 4), A::Msaa4, "no more samples than the device offers");
            assert_eq!(A::Msaa2.applied(p, lit, 1 | 4), A::None, "and no count it does not offer");
            assert_eq!(A::Msaa2.applied(p, lit, 1), A::None);
            assert_eq!(A::Msaa4.applied(p, DebugView::Albedo, all), A::Msaa4, "debug views keep MSAA");
        }
        for p in [PipelineKind::Deferred, PipelineKind::VisBuffer] {
            assert_eq!(A::Msaa4.applied(p, lit, 15), A::Taa, "deferred shading takes TAA instead");
            assert_eq!(A::Msaa4.applied(p, DebugView::Albedo, 15), A::None, "and TAA is off under a debug view");
        }
        for m in A::ALL {
            assert_eq!(A::from_name(m.name()), Some(m));
        }
    }

    #[test]
    fn light_settings_round_to_the_tile_sizes_and_forward_plus_is_always_tiled() {
        let tile = |tile_size| LightSettings { tile_size, ..Default::default() }.tile();
        assert_eq!(
            [tile(0), tile(8), tile(11), tile(12), tile(16), tile(23), tile(24), tile(32), tile(1000)],
            [8, 8, 8, 16, 16, 16, 32, 32, 32]
        );
        let (rq, rtp, none) = (RaySupport::of_tier(Tier::RayQuery), RaySupport::of_tier(Tier::RayTracingPipeline), RaySupport::default());
        for p in PipelineKind::ALL {
            let expected = if p == PipelineKind::ForwardPlus { LightMethod::Tiled } else { LightMethod::All };
            assert_eq!(LightMethod::All.effective(p, rq), expected);
            assert_eq!(LightMethod::Tiled.effective(p, rq), LightMethod::Tiled);
            let deferred = matches!(p, PipelineKind::Deferred | PipelineKind::VisBuffer);
            for support in [rq, rtp] {
                let expected = if deferred { LightMethod::RayQuery } else { LightMethod::Tiled };
                assert_eq!(LightMethod::RayQuery.effective(p, support), expected, "{p:?}");
            }
            assert_eq!(LightMethod::RayQuery.effective(p, none), LightMethod::Tiled, "no acceleration structures: tiled");
            assert_eq!(PipelineKind::from_name(p.name()), Some(p));
        }
        for m in LightMethod::ALL {
            assert_eq!(LightMethod::from_name(m.name()), Some(m));
        }
    }

    #[test]
    fn the_applied_decal_method_is_the_best_one_the_device_can_run() {
        use DecalMethod::*;
        use PipelineKind::*;
        let rq = RaySupport::of_tier(Tier::RayQuery);
        let rtp = RaySupport::of_tier(Tier::RayTracingPipeline);
        let none = RaySupport::of_tier(Tier::NoRayTracing);
        let rq_only = RaySupport { ray_query: true, ray_pipeline: false };
        for p in PipelineKind::ALL {
            assert_eq!(RayQuery.effective(p, rq), RayQuery);
            assert_eq!(RayQueryCompute.effective(p, rq), RayQueryCompute);
            assert_eq!(RayPipeline.effective(p, rq), RayPipeline, "a ray-query device with ray-tracing pipelines runs both");
            assert_eq!(RayPipeline.effective(p, rq_only), RayQuery, "the best method this device has");
            assert_eq!(RayQuery.effective(p, rtp), Clustered, "no ray queries: clustered decals, the faster there, not nothing");
            assert_eq!(RayQueryCompute.effective(p, rtp), Clustered);
            assert_eq!(RayPipeline.effective(p, rtp), RayPipeline);
            assert_eq!(Off.effective(p, rq), Off);
        }
        assert_eq!(DeferredDecals.effective(Deferred, rq), DeferredDecals);
        assert_eq!(DeferredDecals.effective(Forward, rq), RayQuery, "deferred decals exist only in the deferred pipeline");
        assert_eq!(DeferredDecals.effective(Forward, rtp), Clustered);
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
