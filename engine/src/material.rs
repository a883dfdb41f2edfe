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
    /// Index of refraction (`KHR_materials_ior`; 1.5, glTF's default, for glass and plastics).
    pub ior: f32,
    /// Thickness of the volume under a blended surface in metres (`KHR_materials_volume`'s
    /// `thicknessFactor`; 0, glTF's default, is a thin wall). Blended surfaces displace the
    /// background seen through them by [`Material::refraction`].
    pub thickness: f32,
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
            ior: 1.5,
            thickness: 0.0,
        }
    }
}

impl Material {
    /// An untextured material with the given linear base colour, metallic and roughness.
    pub fn from_color(base_color: Vec4, metallic: f32, roughness: f32) -> Self {
        Material { base_color, metallic, roughness, ..Default::default() }
    }

    /// How far a blended surface displaces the background seen through it, in metres at the
    /// surface: `thickness × (1 − 1/ior)`, the lateral shift of a ray crossing a slab of that
    /// thickness at a grazing angle. Thin walls (thickness 0, glTF's default) and an ior of 1
    /// do not refract; non-finite or negative inputs give 0. The renderer holds up to 0.25 m.
    pub fn refraction(&self) -> f32 {
        let r = self.thickness * (1.0 - 1.0 / self.ior);
        if r.is_finite() && r > 0.0 { r } else { 0.0 }
    }
}
