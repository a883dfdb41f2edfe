//! The glTF metallic-roughness material model, referencing textures by [`Handle<Image>`].
//!
//! Texture conventions follow glTF 2.0: base colour and emissive textures are sRGB; the
//! metallic-roughness texture stores roughness in G and metallic in B; occlusion is in R; the
//! normal map is a tangent-space map in linear RGB.

use glam::{Vec3, Vec4};

use crate::asset::Handle;
use crate::image::Image;

/// How a material's alpha is interpreted.
#[derive(Clone, Copy, Debug, PartialEq, Default)]
pub enum AlphaMode {
    /// Alpha is ignored.
    #[default]
    Opaque,
    /// Fragments with alpha below the cutoff are discarded; the rest are opaque.
    Mask(f32),
    /// Alpha blending (transparent pass).
    Blend,
}

/// A metallic-roughness PBR material. Texture values multiply their factors.
#[derive(Clone, Debug, PartialEq)]
pub struct Material {
    /// Linear RGBA base colour factor.
    pub base_color: Vec4,
    /// sRGB base colour texture.
    pub base_color_texture: Option<Handle<Image>>,
    /// Metallic factor in [0, 1].
    pub metallic: f32,
    /// Perceptual roughness factor in [0, 1].
    pub roughness: f32,
    /// Linear texture: G = roughness, B = metallic.
    pub metallic_roughness_texture: Option<Handle<Image>>,
    /// Linear tangent-space normal map.
    pub normal_texture: Option<Handle<Image>>,
    /// Scale of the normal map's XY.
    pub normal_scale: f32,
    /// Linear ambient-occlusion texture (R channel).
    pub occlusion_texture: Option<Handle<Image>>,
    /// Strength of the occlusion texture in [0, 1].
    pub occlusion_strength: f32,
    /// Linear emitted radiance factor (already multiplied by any emissive strength).
    pub emissive: Vec3,
    /// sRGB emissive texture.
    pub emissive_texture: Option<Handle<Image>>,
    /// Alpha interpretation.
    pub alpha_mode: AlphaMode,
    /// Whether back faces are rendered (and lit with the flipped normal).
    pub double_sided: bool,
}

impl Default for Material {
    fn default() -> Self {
        Material {
            base_color: Vec4::ONE,
            base_color_texture: None,
            metallic: 0.0,
            roughness: 0.5,
            metallic_roughness_texture: None,
            normal_texture: None,
            normal_scale: 1.0,
            occlusion_texture: None,
            occlusion_strength: 1.0,
            emissive: Vec3::ZERO,
            emissive_texture: None,
            alpha_mode: AlphaMode::Opaque,
            double_sided: false,
        }
    }
}

impl Material {
    /// An untextured material with the given linear base colour, metallic and roughness.
    pub fn from_color(base_color: Vec4, metallic: f32, roughness: f32) -> Self {
        Material { base_color, metallic, roughness, ..Default::default() }
    }
}
