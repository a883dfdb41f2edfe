//! The render targets, described once (the frame graph creates them).
//!
//! The HDR colour target holds linear radiance (RGBA16F) and is what image tests compare against
//! CPU references; the display target holds the tone-mapped sRGB image that becomes the
//! screenshot. Depth is D32 with reverse-Z (cleared to 0, tested GREATER / EQUAL).

use ash::vk;

/// What a pipeline's depth stage wrote: the typed output its pass returns (the forward prepass,
/// the deferred G-buffer, the visibility pass) and the frame function hands to every pass that
/// rebuilds the opaque surface at a pixel from it (the decal pass, reflections). It is also the
/// index of those passes' pipeline variants.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Surface {
    /// The G-buffer (deferred pipeline): depth, normal, albedo, material, receiver layers.
    GBuffer,
    /// Depth and each pixel's instance and triangle ids (the visibility buffer, or the forward
    /// prepass when it writes ids).
    Visibility,
    /// Depth alone (the forward prepass without ids).
    Depth,
}

impl Surface {
    /// Where the forward pipelines' decal pass reads the surface: the ids when the decals need
    /// the instance ([`crate::scene::SceneMirror::decals_need_instances`]: the prepass then
    /// writes them), else depth alone, even in a frame whose prepass writes ids for reflections
    /// or motion, so that the decals' look (their normal frame) never changes with those.
    pub fn forward_decals(need_instances: bool) -> Self {
        if need_instances { Surface::Visibility } else { Surface::Depth }
    }

    /// Its name in statistics: `gbuffer`, `ids` or `depth`.
    pub fn name(self) -> &'static str {
        match self {
            Surface::GBuffer => "gbuffer",
            Surface::Visibility => "ids",
            Surface::Depth => "depth",
        }
    }
}

/// The motion vectors of this frame ([`MOTION`]), as the motion-vector pass returns them to the
/// frame function, which hands them to temporal anti-aliasing: a pass that reads them takes
/// this value, so it cannot be recorded in a frame that did not write them.
#[derive(Clone, Copy, Debug)]
pub struct MotionVectors {
    /// The target they are in.
    pub target: &'static TargetDesc,
}

/// HDR colour format.
pub const HDR_FORMAT: vk::Format = vk::Format::R16G16B16A16_SFLOAT;
/// Depth format.
pub const DEPTH_FORMAT: vk::Format = vk::Format::D32_SFLOAT;
/// Display (tone-mapped) format.
pub const DISPLAY_FORMAT: vk::Format = vk::Format::R8G8B8A8_SRGB;
/// G-buffer formats; shaders/gbuffer.frag says why each.
pub const GBUFFER_ALBEDO_FORMAT: vk::Format = vk::Format::R8G8B8A8_SRGB;
/// Shading normal × 0.5 + 0.5.
pub const GBUFFER_NORMAL_FORMAT: vk::Format = vk::Format::A2B10G10R10_UNORM_PACK32;
/// Roughness, metallic, opacity, refraction (shaders/gbuffer.frag).
pub const GBUFFER_MATERIAL_FORMAT: vk::Format = vk::Format::R8G8B8A8_UNORM;
/// Decal receiver layers (low 8 bits).
pub const GBUFFER_LAYERS_FORMAT: vk::Format = vk::Format::R32G32_UINT;
/// Visibility buffer: instance slot, triangle index.
pub const VISIBILITY_FORMAT: vk::Format = vk::Format::R32G32_UINT;

/// Decal buffer formats (`BINDING_DECAL_*` say what each holds).
pub const DECAL_BUFFER_FORMAT: vk::Format = vk::Format::R16G16B16A16_SFLOAT;
/// Decals tested per pixel.
pub const DECAL_TESTED_FORMAT: vk::Format = vk::Format::R32_UINT;

pub use crate::layout::{
    BINDING_ANTIALIASED, BINDING_ANTIALIASED_STORAGE, BINDING_BACKGROUND_DEPTH, BINDING_BACKGROUND_DEPTH_STORAGE, BINDING_DECAL_ALBEDO,
    BINDING_DECAL_EMISSIVE, BINDING_DECAL_NORMAL, BINDING_DECAL_SPEC, BINDING_DECAL_TESTED, BINDING_DEPTH, BINDING_GBUFFER_ALBEDO,
    BINDING_GBUFFER_LAYERS, BINDING_GBUFFER_MATERIAL, BINDING_GBUFFER_NORMAL, BINDING_HDR, BINDING_HDR_STORAGE, BINDING_MOTION,
    BINDING_OCCLUSION, BINDING_OCCLUSION_RAW, BINDING_REFLECTION, BINDING_REFLECTION_ADDED, BINDING_REFLECTION_RAYS,
    BINDING_REFLECTION_WEIGHT, BINDING_SHADOW_DEBUG, BINDING_SHADOW_MAP_DEPTH, BINDING_SHADOW_MAP_FILTER, BINDING_SHADOW_RATIO,
    BINDING_SHADOW_SAMPLES, BINDING_SMAA_EDGES, BINDING_SMAA_WEIGHTS, BINDING_TAA_HISTORY_A, BINDING_TAA_HISTORY_A_STORAGE,
    BINDING_TAA_HISTORY_B, BINDING_TAA_HISTORY_B_STORAGE, BINDING_TRANSPARENCY_SOURCE, BINDING_TRANSPARENT_DEPTH, BINDING_VISIBILITY,
};

/// Where a target is bound for sampling: its descriptor binding in set 0 (`BINDING_*`).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Bind {
    /// A colour target, sampled in SHADER_READ_ONLY_OPTIMAL.
    Color(u32),
    /// A depth target, sampled in DEPTH_READ_ONLY_OPTIMAL (so it can be a read-only depth
    /// attachment of the same pass).
    Depth(u32),
    /// A storage image, read and written in GENERAL.
    Storage(u32),
}

impl Bind {
    /// Whether the binding is a storage image.
    pub fn is_storage(self) -> bool {
        matches!(self, Bind::Storage(_))
    }
}

/// A render target, described once; the frame graph creates it at the view's size on first use,
/// keeps it across frames and recreates it after a resize.
#[derive(Debug)]
pub struct TargetDesc {
    /// Debug name.
    pub name: &'static str,
    /// Texel format.
    pub format: vk::Format,
    /// How it is used.
    pub usage: vk::ImageUsageFlags,
    /// Where shaders find it, if they sample it.
    pub bind: Option<Bind>,
    /// A second binding as a storage image (`BINDING_*_STORAGE`), for compute passes that write
    /// a target other passes sample or draw into.
    pub storage: Option<u32>,
    /// Made with the graph's samples a pixel ([`super::FrameGraph::set_samples`]): MSAA's
    /// attachments, which resolve into their single-sampled twins.
    pub multisampled: bool,
}

use vk::ImageUsageFlags as U;

const ATTACHMENT_SAMPLED: vk::ImageUsageFlags =
    vk::ImageUsageFlags::from_raw(U::COLOR_ATTACHMENT.as_raw() | U::SAMPLED.as_raw() | U::TRANSFER_SRC.as_raw());

/// Linear radiance (also a storage image, for lighting in compute).
pub static HDR: TargetDesc = TargetDesc {
    name: "hdr",
    format: HDR_FORMAT,
    usage: vk::ImageUsageFlags::from_raw(ATTACHMENT_SAMPLED.as_raw() | U::STORAGE.as_raw()),
    bind: Some(Bind::Color(BINDING_HDR)),
    storage: Some(BINDING_HDR_STORAGE),
    multisampled: false,
};
/// Reverse-Z depth.
pub static DEPTH: TargetDesc = TargetDesc {
    name: "depth",
    format: DEPTH_FORMAT,
    usage: vk::ImageUsageFlags::from_raw(U::DEPTH_STENCIL_ATTACHMENT.as_raw() | U::SAMPLED.as_raw() | U::TRANSFER_SRC.as_raw()),
    bind: Some(Bind::Depth(BINDING_DEPTH)),
    storage: None,
    multisampled: false,
};
/// Reverse-Z depth of the nearest transparent surface (the transparency depth pass writes it;
/// light culling samples it).
pub static TRANSPARENT_DEPTH: TargetDesc = TargetDesc {
    name: "transparent depth",
    format: DEPTH_FORMAT,
    usage: vk::ImageUsageFlags::from_raw(U::DEPTH_STENCIL_ATTACHMENT.as_raw() | U::SAMPLED.as_raw()),
    bind: Some(Bind::Depth(BINDING_TRANSPARENT_DEPTH)),
    storage: None,
    multisampled: false,
};
/// A copy of the lit HDR image that the transparency compositions read: interlacing's after
/// lighting, depth peeling's after lighting the opaque layer.
pub static TRANSPARENCY_SOURCE: TargetDesc = TargetDesc {
    name: "transparency source",
    format: HDR_FORMAT,
    usage: vk::ImageUsageFlags::from_raw(U::TRANSFER_DST.as_raw() | U::SAMPLED.as_raw()),
    bind: Some(Bind::Color(BINDING_TRANSPARENCY_SOURCE)),
    storage: None,
    multisampled: false,
};
/// Depth peeling's copy of the opaque layer's depth (the composition's refraction checks it).
/// A colour image written in compute: on the lent H100 a transfer copy of the D32 depth target
/// took 0.44 ms at 1920×1080.
pub static BACKGROUND_DEPTH: TargetDesc = TargetDesc {
    name: "background depth",
    format: vk::Format::R32_SFLOAT,
    usage: vk::ImageUsageFlags::from_raw(U::STORAGE.as_raw() | U::SAMPLED.as_raw()),
    bind: Some(Bind::Color(BINDING_BACKGROUND_DEPTH)),
    storage: Some(BINDING_BACKGROUND_DEPTH_STORAGE),
    multisampled: false,
};
/// The tone-mapped colour after FXAA (linear RGBA16F; the display pass copies it into the
/// display image, which compute cannot write).
pub static ANTIALIASED: TargetDesc = TargetDesc {
    name: "antialiased",
    format: HDR_FORMAT,
    usage: vk::ImageUsageFlags::from_raw(U::SAMPLED.as_raw() | U::STORAGE.as_raw()),
    bind: Some(Bind::Color(BINDING_ANTIALIASED)),
    storage: Some(BINDING_ANTIALIASED_STORAGE),
    multisampled: false,
};
/// Tone-mapped sRGB output (headless; a window presents the swapchain image instead).
pub static DISPLAY: TargetDesc = TargetDesc {
    name: "display",
    format: DISPLAY_FORMAT,
    usage: vk::ImageUsageFlags::from_raw(U::COLOR_ATTACHMENT.as_raw() | U::TRANSFER_SRC.as_raw()),
    bind: None,
    storage: None,
    multisampled: false,
};
/// G-buffer albedo and occlusion.
pub static GBUFFER_ALBEDO: TargetDesc = TargetDesc {
    name: "gbuffer albedo",
    format: GBUFFER_ALBEDO_FORMAT,
    usage: ATTACHMENT_SAMPLED,
    bind: Some(Bind::Color(BINDING_GBUFFER_ALBEDO)),
    storage: None,
    multisampled: false,
};
/// G-buffer shading normal.
pub static GBUFFER_NORMAL: TargetDesc = TargetDesc {
    name: "gbuffer normal",
    format: GBUFFER_NORMAL_FORMAT,
    usage: ATTACHMENT_SAMPLED,
    bind: Some(Bind::Color(BINDING_GBUFFER_NORMAL)),
    storage: None,
    multisampled: false,
};
/// G-buffer roughness and metallic.
pub static GBUFFER_MATERIAL: TargetDesc = TargetDesc {
    name: "gbuffer material",
    format: GBUFFER_MATERIAL_FORMAT,
    usage: ATTACHMENT_SAMPLED,
    bind: Some(Bind::Color(BINDING_GBUFFER_MATERIAL)),
    storage: None,
    multisampled: false,
};
/// G-buffer decal receiver layers.
pub static GBUFFER_LAYERS: TargetDesc = TargetDesc {
    name: "gbuffer layers",
    format: GBUFFER_LAYERS_FORMAT,
    usage: ATTACHMENT_SAMPLED,
    bind: Some(Bind::Color(BINDING_GBUFFER_LAYERS)),
    storage: None,
    multisampled: false,
};
/// The visibility buffer's instance and triangle ids.
pub static VISIBILITY: TargetDesc = TargetDesc {
    name: "visibility",
    format: VISIBILITY_FORMAT,
    usage: ATTACHMENT_SAMPLED,
    bind: Some(Bind::Color(BINDING_VISIBILITY)),
    storage: None,
    multisampled: false,
};

/// Format of the shadow-map atlas's filter (glass colour and opacity).
pub const SHADOW_MAP_FILTER_FORMAT: vk::Format = vk::Format::R8G8B8A8_UNORM;

/// The shadow-map atlas's depth (reverse-Z), one tile per shadow view. Sized by
/// [`crate::ShadowMapBudget`], not by the view: created with [`super::FrameGraph::fixed_target`].
pub static SHADOW_MAP_DEPTH: TargetDesc = TargetDesc {
    name: "shadow map depth",
    format: DEPTH_FORMAT,
    usage: vk::ImageUsageFlags::from_raw(U::DEPTH_STENCIL_ATTACHMENT.as_raw() | U::SAMPLED.as_raw()),
    bind: Some(Bind::Depth(BINDING_SHADOW_MAP_DEPTH)),
    storage: None,
    multisampled: false,
};
/// The shadow-map atlas's filter: glass colour and opacity on odd rows (seed 002 Table 3.3).
pub static SHADOW_MAP_FILTER: TargetDesc = TargetDesc {
    name: "shadow map filter",
    format: SHADOW_MAP_FILTER_FORMAT,
    usage: vk::ImageUsageFlags::from_raw(U::COLOR_ATTACHMENT.as_raw() | U::SAMPLED.as_raw()),
    bind: Some(Bind::Color(BINDING_SHADOW_MAP_FILTER)),
    storage: None,
    multisampled: false,
};

const STORAGE: vk::ImageUsageFlags = vk::ImageUsageFlags::from_raw(U::STORAGE.as_raw() | U::TRANSFER_SRC.as_raw());

/// Decal buffer: premultiplied decal albedo and the surface albedo's remaining weight.
pub static DECAL_ALBEDO: TargetDesc = TargetDesc {
    name: "decal albedo",
    format: DECAL_BUFFER_FORMAT,
    usage: STORAGE,
    bind: Some(Bind::Storage(BINDING_DECAL_ALBEDO)),
    storage: None,
    multisampled: false,
};
/// Decal buffer: decal normal and the surface normal's remaining weight.
pub static DECAL_NORMAL: TargetDesc = TargetDesc {
    name: "decal normal",
    format: DECAL_BUFFER_FORMAT,
    usage: STORAGE,
    bind: Some(Bind::Storage(BINDING_DECAL_NORMAL)),
    storage: None,
    multisampled: false,
};
/// Decal buffer: decal roughness and metallic and the surface's remaining weights.
pub static DECAL_SPEC: TargetDesc = TargetDesc {
    name: "decal spec",
    format: DECAL_BUFFER_FORMAT,
    usage: STORAGE,
    bind: Some(Bind::Storage(BINDING_DECAL_SPEC)),
    storage: None,
    multisampled: false,
};
/// Decal buffer: the radiance emissive decals add.
pub static DECAL_EMISSIVE: TargetDesc = TargetDesc {
    name: "decal emissive",
    format: DECAL_BUFFER_FORMAT,
    usage: STORAGE,
    bind: Some(Bind::Storage(BINDING_DECAL_EMISSIVE)),
    storage: None,
    multisampled: false,
};
/// Decal buffer: decals tested per pixel (debug views; where 0, the other images are not
/// written and the shading reads nothing more).
pub static DECAL_TESTED: TargetDesc = TargetDesc {
    name: "decal tested",
    format: DECAL_TESTED_FORMAT,
    usage: STORAGE,
    bind: Some(Bind::Storage(BINDING_DECAL_TESTED)),
    storage: None,
    multisampled: false,
};
/// The shadow pass's debug image: reconstructed normals and shadow rays per pixel.
pub static SHADOW_DEBUG: TargetDesc = TargetDesc {
    name: "shadow debug",
    format: DECAL_BUFFER_FORMAT,
    usage: STORAGE,
    bind: Some(Bind::Storage(BINDING_SHADOW_DEBUG)),
    storage: None,
    multisampled: false,
};
/// The sampled shadows' raw image: per sampling pixel, what its one shadow ray let through and
/// the unshadowed estimate it was drawn from (`crate::lights::sampling`).
pub static SHADOW_SAMPLES: TargetDesc = TargetDesc {
    name: "shadow samples",
    format: HDR_FORMAT,
    usage: STORAGE,
    bind: Some(Bind::Storage(BINDING_SHADOW_SAMPLES)),
    storage: None,
    multisampled: false,
};
/// The sampled shadows, denoised: the share of each sampling pixel's unshadowed light that
/// reaches it, which shading reads.
pub static SHADOW_RATIO: TargetDesc = TargetDesc {
    name: "shadow ratio",
    format: HDR_FORMAT,
    usage: STORAGE,
    bind: Some(Bind::Storage(BINDING_SHADOW_RATIO)),
    storage: None,
    multisampled: false,
};
/// What the reflection rays brought back (`crate::reflections`): radiance and the tracing
/// pixel's distance from the camera, per cell (a pixel, or a 2×2 block at half resolution: the
/// top-left quarter).
pub static REFLECTION: TargetDesc = TargetDesc {
    name: "reflection",
    format: HDR_FORMAT,
    usage: STORAGE,
    bind: Some(Bind::Storage(BINDING_REFLECTION)),
    storage: None,
    multisampled: false,
};
/// Each pixel's weight for the reflected radiance and its roughness (`crate::reflections`).
pub static REFLECTION_WEIGHT: TargetDesc = TargetDesc {
    name: "reflection weight",
    format: HDR_FORMAT,
    usage: STORAGE,
    bind: Some(Bind::Storage(BINDING_REFLECTION_WEIGHT)),
    storage: None,
    multisampled: false,
};
/// What each reflection ray found, one word per cell (`crate::reflections`).
pub static REFLECTION_RAYS: TargetDesc = TargetDesc {
    name: "reflection rays",
    format: vk::Format::R32_UINT,
    usage: STORAGE,
    bind: Some(Bind::Storage(BINDING_REFLECTION_RAYS)),
    storage: None,
    multisampled: false,
};
/// The ambient occlusion's raw (noisy) image (`crate::occlusion`).
pub static OCCLUSION_RAW: TargetDesc = TargetDesc {
    name: "occlusion raw",
    format: OCCLUSION_FORMAT,
    usage: STORAGE,
    bind: Some(Bind::Storage(BINDING_OCCLUSION_RAW)),
    storage: None,
    multisampled: false,
};
/// The denoised ambient occlusion that shading reads.
pub static OCCLUSION: TargetDesc = TargetDesc {
    name: "occlusion",
    format: OCCLUSION_FORMAT,
    usage: STORAGE,
    bind: Some(Bind::Storage(BINDING_OCCLUSION)),
    storage: None,
    multisampled: false,
};
/// Ambient occlusion's format: one float a pixel (R32F needs no extended storage formats).
pub const OCCLUSION_FORMAT: vk::Format = vk::Format::R32_SFLOAT;
/// Motion vectors (`crate::motion`): written in compute from depth, then over the movers by a
/// raster pass; temporal anti-aliasing reads them.
pub static MOTION: TargetDesc = TargetDesc {
    name: "motion",
    format: HDR_FORMAT,
    usage: vk::ImageUsageFlags::from_raw(U::STORAGE.as_raw() | U::COLOR_ATTACHMENT.as_raw() | U::TRANSFER_SRC.as_raw()),
    bind: Some(Bind::Storage(BINDING_MOTION)),
    storage: None,
    multisampled: false,
};
/// Temporal anti-aliasing's history (`crate::taa`): the resolve samples one and writes the other.
pub static TAA_HISTORY_A: TargetDesc = TargetDesc {
    name: "taa history a",
    format: HDR_FORMAT,
    usage: vk::ImageUsageFlags::from_raw(U::SAMPLED.as_raw() | U::STORAGE.as_raw()),
    bind: Some(Bind::Color(BINDING_TAA_HISTORY_A)),
    storage: Some(BINDING_TAA_HISTORY_A_STORAGE),
    multisampled: false,
};
/// The other history image.
pub static TAA_HISTORY_B: TargetDesc = TargetDesc {
    name: "taa history b",
    format: HDR_FORMAT,
    usage: vk::ImageUsageFlags::from_raw(U::SAMPLED.as_raw() | U::STORAGE.as_raw()),
    bind: Some(Bind::Color(BINDING_TAA_HISTORY_B)),
    storage: Some(BINDING_TAA_HISTORY_B_STORAGE),
    multisampled: false,
};
/// The reflections' resolved term, under MSAA (`BINDING_REFLECTION_ADDED`).
pub static REFLECTION_ADDED: TargetDesc = TargetDesc {
    name: "reflection added",
    format: HDR_FORMAT,
    usage: STORAGE,
    bind: Some(Bind::Storage(BINDING_REFLECTION_ADDED)),
    storage: None,
    multisampled: false,
};
/// SMAA's edges (`crate::smaa`).
pub static SMAA_EDGES: TargetDesc = TargetDesc {
    name: "smaa edges",
    format: vk::Format::R8G8B8A8_UNORM,
    usage: STORAGE,
    bind: Some(Bind::Storage(BINDING_SMAA_EDGES)),
    storage: None,
    multisampled: false,
};
/// SMAA's blending weights (`crate::smaa`).
pub static SMAA_WEIGHTS: TargetDesc = TargetDesc {
    name: "smaa weights",
    format: vk::Format::R8G8B8A8_UNORM,
    usage: STORAGE,
    bind: Some(Bind::Storage(BINDING_SMAA_WEIGHTS)),
    storage: None,
    multisampled: false,
};
/// MSAA's radiance (`crate::msaa`): the forward shading pass draws into it and resolves it into
/// [`HDR`] (the mean of the samples). Transient: only the resolve is kept (not stored).
pub static HDR_MS: TargetDesc = TargetDesc {
    name: "hdr (multisampled)",
    format: HDR_FORMAT,
    usage: vk::ImageUsageFlags::from_raw(U::COLOR_ATTACHMENT.as_raw() | U::TRANSIENT_ATTACHMENT.as_raw()),
    bind: None,
    storage: None,
    multisampled: true,
};
/// MSAA's depth: written by the prepass, which resolves it into [`DEPTH`] (sample 0, the
/// surface every per-pixel pass then works on), and tested by the shading pass.
pub static DEPTH_MS: TargetDesc = TargetDesc {
    name: "depth (multisampled)",
    format: DEPTH_FORMAT,
    usage: U::DEPTH_STENCIL_ATTACHMENT,
    bind: None,
    storage: None,
    multisampled: true,
};
/// MSAA's instance and triangle ids, resolved into [`VISIBILITY`] (sample 0, as depth).
pub static VISIBILITY_MS: TargetDesc = TargetDesc {
    name: "visibility (multisampled)",
    format: VISIBILITY_FORMAT,
    usage: U::COLOR_ATTACHMENT,
    bind: None,
    storage: None,
    multisampled: true,
};
/// The decal buffer's images, in binding order.
pub static DECAL_BUFFER: [&TargetDesc; 5] = [&DECAL_ALBEDO, &DECAL_NORMAL, &DECAL_SPEC, &DECAL_TESTED, &DECAL_EMISSIVE];

/// Converts an IEEE half float to f32.
pub fn f16_to_f32(h: u16) -> f32 {
    let sign = ((h >> 15) & 1) as u32;
    let exp = ((h >> 10) & 0x1f) as u32;
    let mant = (h & 0x3ff) as u32;
    let bits = match (exp, mant) {
        (0, 0) => sign << 31,
        (0, m) => {
            // Subnormal: renormalise.
            let shift = m.leading_zeros() - 21;
            let m = (m << shift) & 0x3ff;
            (sign << 31) | ((127 - 15 + 1 - shift) << 23) | (m << 13)
        }
        (0x1f, m) => (sign << 31) | (0xff << 23) | (m << 13),
        (e, m) => (sign << 31) | ((e + 127 - 15) << 23) | (m << 13),
    };
    f32::from_bits(bits)
}

#[cfg(test)]
mod tests {
    use super::f16_to_f32;

    #[test]
    fn half_floats_decode() {
        assert_eq!(f16_to_f32(0x3c00), 1.0);
        assert_eq!(f16_to_f32(0xc000), -2.0);
        assert_eq!(f16_to_f32(0x3555), 0.333_251_95);
        assert_eq!(f16_to_f32(0x0001), 5.960_464_5e-8);
        assert!(f16_to_f32(0x7e00).is_nan());
        assert_eq!(f16_to_f32(0x7c00), f32::INFINITY);
    }
}
