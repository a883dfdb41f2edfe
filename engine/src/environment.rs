//! The environment that lights a scene from all around: a procedural sky (the default, whose
//! sun is the scene's brightest directional light), an HDR map (an equirectangular Radiance
//! `.hdr`, or a KTX2 cube map or equirectangular map in a floating-point format), a uniform
//! radiance, or none (a flat ambient colour). `plugins` hands it to the renderer, which filters
//! a new source once (`render::environment`).

use std::path::Path;
use std::sync::Arc;

use bevy_ecs::prelude::*;
use glam::Vec3;

/// How an HDR image's texels cover the sphere of directions.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub enum Projection {
    /// Equirectangular: twice as wide as high, rows from the one looking up (+Y) to the one
    /// looking down, the middle column along +X and longitude growing towards +Z.
    #[default]
    Equirectangular,
    /// A cube map: six square faces stacked from top to bottom in the order +X, −X, +Y, −Y, +Z,
    /// −Z (the image is six times as high as wide), each oriented as Vulkan samples cube maps,
    /// rows downwards: as KTX2 stores them.
    CubeFaces,
}

/// An HDR environment image: linear RGB radiance.
#[derive(Clone, Debug)]
pub struct HdrImage {
    /// Texels across.
    pub width: u32,
    /// Texels down.
    pub height: u32,
    /// `width × height` RGB texels, row after row (shared: cloning the image copies nothing).
    pub texels: Arc<[[f32; 3]]>,
    /// How the texels cover the sphere of directions.
    pub projection: Projection,
}

/// Why an HDR environment could not be loaded.
#[derive(Debug, thiserror::Error)]
pub enum EnvironmentError {
    /// The file could not be read or decoded.
    #[error("cannot load the environment map {path}: {source}")]
    Load {
        /// The file.
        path: String,
        /// What went wrong.
        #[source]
        source: image::ImageError,
    },
    /// The file is not a KTX2 container this loader takes: not a valid container, supercompressed,
    /// an array or a volume, or in a format other than the floating-point ones of
    /// [`HdrImage::from_ktx2`].
    #[error("cannot load the environment map {path}: {reason}")]
    Ktx2 {
        /// The file.
        path: String,
        /// What is wrong with it.
        reason: String,
    },
    /// The file decoded, but not as an equirectangular map (twice as wide as high).
    #[error("the environment map {path} is {width}×{height}: an equirectangular map is twice as wide as it is high")]
    NotEquirectangular {
        /// The file.
        path: String,
        /// Its width.
        width: u32,
        /// Its height.
        height: u32,
    },
}

impl HdrImage {
    /// Loads a KTX2 container ([`HdrImage::from_ktx2`]) when the file's extension is `.ktx2`;
    /// otherwise a Radiance `.hdr` (or any format `image` decodes; LDR ones are taken as
    /// linear) as an equirectangular environment.
    ///
    /// Texels are made what the GPU's half floats hold, with one warning naming the file and
    /// counting them when any is changed: components brighter than [`MAX_RADIANCE`] (legal
    /// RGBE reaches 1.7 × 10³⁸) are clamped to it, and negative or non-finite ones are 0.
    /// Clamped rather than refused: such texels are a few of a capture's (the sun), and the
    /// rest of the map is good light; above 65504 a half float is infinite, and infinities
    /// turn the shading that meets a zero into NaN (a black picture).
    pub fn load(path: impl AsRef<Path>) -> Result<HdrImage, EnvironmentError> {
        let path = path.as_ref();
        let name = path.display().to_string();
        if path.extension().is_some_and(|e| e.eq_ignore_ascii_case("ktx2")) {
            let bytes =
                std::fs::read(path).map_err(|e| EnvironmentError::Load { path: name.clone(), source: image::ImageError::IoError(e) })?;
            return Self::from_ktx2(&bytes, &name);
        }
        let load = |source| EnvironmentError::Load { path: name.clone(), source };
        let image = image::ImageReader::open(path).map_err(|e| load(image::ImageError::IoError(e)))?;
        let image = image.with_guessed_format().map_err(|e| load(image::ImageError::IoError(e)))?.decode().map_err(load)?.into_rgb32f();
        let (width, height) = image.dimensions();
        if width != 2 * height {
            return Err(EnvironmentError::NotEquirectangular { path: name, width, height });
        }
        let texels = storable_texels(image.pixels().map(|p| p.0), &name);
        Ok(HdrImage { width, height, texels, projection: Projection::Equirectangular })
    }

    /// Reads level 0 of a KTX2 container (`name` names it in errors): a cube map (six faces) or
    /// an equirectangular map (one face twice as wide as high), uncompressed (no
    /// supercompression), in `R32G32B32A32_SFLOAT`, `R32G32B32_SFLOAT`, `R16G16B16A16_SFLOAT`,
    /// `R16G16B16_SFLOAT`, `B10G11R11_UFLOAT_PACK32` or `E5B9G9R9_UFLOAT_PACK32` (the formats
    /// HDR environment tools write). Other levels are ignored: the renderer filters its own.
    /// Texels are made storable as [`HdrImage::load`] says.
    pub fn from_ktx2(bytes: &[u8], name: &str) -> Result<HdrImage, EnvironmentError> {
        let fail = |reason: String| EnvironmentError::Ktx2 { path: name.to_string(), reason };
        let reader = ktx2::Reader::new(bytes).map_err(|e| fail(format!("not a valid KTX2 container ({e})")))?;
        let header = reader.header();
        if let Some(scheme) = header.supercompression_scheme {
            return Err(fail(format!("supercompressed ({scheme:?}); write it uncompressed")));
        }
        if header.layer_count > 1 || header.pixel_depth > 1 {
            return Err(fail("an array or volume texture, not an environment".to_string()));
        }
        let format = header.format.ok_or_else(|| fail("its format is undefined (a universal, transcoded format)".to_string()))?;
        let decode = texel_decoder(format).ok_or_else(|| fail(format!("its format {format:?} is not a floating-point RGB one")))?;
        let (width, height) = (header.pixel_width, header.pixel_height.max(1));
        let (projection, image_height) = match header.face_count {
            6 if width == height => (Projection::CubeFaces, 6 * height),
            1 if width == 2 * height => (Projection::Equirectangular, height),
            1 => return Err(EnvironmentError::NotEquirectangular { path: name.to_string(), width, height }),
            faces => return Err(fail(format!("{faces} faces of {width}×{height}: a cube map has six square ones"))),
        };
        let level = reader.levels().next().ok_or_else(|| fail("it holds no level".to_string()))?;
        let (bytes_per_texel, decode) = decode;
        let texel_count = width as usize * image_height as usize;
        let data =
            level.data.get(..texel_count * bytes_per_texel).ok_or_else(|| fail("its first level is shorter than its size".to_string()))?;
        let texels = storable_texels(data.chunks_exact(bytes_per_texel).map(decode), name);
        Ok(HdrImage { width, height: image_height, texels, projection })
    }
}

/// The brightest radiance an environment texel keeps: the largest finite half float, the format
/// the GPU filters environments in.
pub const MAX_RADIANCE: f32 = 65504.0;

/// The texels with every component in `0..=MAX_RADIANCE` (brighter ones clamped, negative and
/// non-finite ones 0), and one warning naming `name` when any was changed.
fn storable_texels(texels: impl Iterator<Item = [f32; 3]>, name: &str) -> Arc<[[f32; 3]]> {
    let (mut clamped, mut zeroed) = (0usize, 0usize);
    let texels: Arc<[[f32; 3]]> = texels
        .map(|texel| {
            if texel.iter().any(|c| c.is_finite() && *c > MAX_RADIANCE) {
                clamped += 1;
            }
            if texel.iter().any(|c| !c.is_finite() || *c < 0.0) {
                zeroed += 1;
            }
            texel.map(|c| if c.is_finite() { c.clamp(0.0, MAX_RADIANCE) } else { 0.0 })
        })
        .collect();
    if clamped + zeroed > 0 {
        tracing::warn!(
            file = name,
            clamped,
            zeroed,
            "environment map {name}: {clamped} texels brighter than half floats hold clamped to {MAX_RADIANCE}, {zeroed} negative or not finite set to 0"
        );
    }
    texels
}

/// A decoder of one texel of `format` to linear RGB, and the texel's size in bytes.
type TexelDecoder = (usize, fn(&[u8]) -> [f32; 3]);

fn texel_decoder(format: ktx2::Format) -> Option<TexelDecoder> {
    use ktx2::Format as F;
    fn float3(t: &[u8]) -> [f32; 3] {
        std::array::from_fn(|i| f32::from_le_bytes([t[4 * i], t[4 * i + 1], t[4 * i + 2], t[4 * i + 3]]))
    }
    fn half3(t: &[u8]) -> [f32; 3] {
        std::array::from_fn(|i| half::f16::from_le_bytes([t[2 * i], t[2 * i + 1]]).to_f32())
    }
    fn b10g11r11(t: &[u8]) -> [f32; 3] {
        let v = u32::from_le_bytes([t[0], t[1], t[2], t[3]]);
        [small_float(v & 0x7FF, 6), small_float((v >> 11) & 0x7FF, 6), small_float(v >> 22, 5)]
    }
    fn e5b9g9r9(t: &[u8]) -> [f32; 3] {
        let v = u32::from_le_bytes([t[0], t[1], t[2], t[3]]);
        let scale = 2f32.powi((v >> 27) as i32 - 15 - 9);
        [(v & 0x1FF) as f32 * scale, ((v >> 9) & 0x1FF) as f32 * scale, ((v >> 18) & 0x1FF) as f32 * scale]
    }
    Some(match format {
        F::R32G32B32A32_SFLOAT => (16, float3),
        F::R32G32B32_SFLOAT => (12, float3),
        F::R16G16B16A16_SFLOAT => (8, half3),
        F::R16G16B16_SFLOAT => (6, half3),
        F::B10G11R11_UFLOAT_PACK32 => (4, b10g11r11),
        F::E5B9G9R9_UFLOAT_PACK32 => (4, e5b9g9r9),
        _ => return None,
    })
}

/// An unsigned float of a 5-bit exponent (bias 15) and `mantissa_bits` of mantissa, as packed
/// formats store it; infinities and NaNs are returned as such (the caller zeroes them).
fn small_float(bits: u32, mantissa_bits: u32) -> f32 {
    let (exponent, mantissa) = (bits >> mantissa_bits, bits & ((1 << mantissa_bits) - 1));
    let fraction = mantissa as f32 / (1u32 << mantissa_bits) as f32;
    match exponent {
        0 => fraction * 2f32.powi(-14),
        31 => f32::NAN,
        e => (1.0 + fraction) * 2f32.powi(e as i32 - 15),
    }
}

/// Where the environment's radiance comes from.
#[derive(Clone, Debug, Default)]
pub enum EnvironmentSource {
    /// No environment: the flat ambient colour lights the scene and the clear colour is drawn
    /// behind it.
    None,
    /// The procedural sky, lit by the scene's brightest directional light.
    #[default]
    Sky,
    /// An HDR map ([`HdrImage::load`]).
    Map(HdrImage),
    /// The same radiance from every direction (a white furnace).
    Uniform(Vec3),
}

/// The environment (a resource; the render plugin inserts the default, the procedural sky).
/// Changing the source filters it once on the GPU; intensity and rotation cost nothing.
#[derive(Resource, Clone, Debug)]
pub struct Environment {
    /// Where the radiance comes from.
    pub source: EnvironmentSource,
    /// Multiplier of its radiance.
    pub intensity: f32,
    /// Turn about +Y in radians (maps and uniform sources; the sky follows its sun).
    pub rotation: f32,
}

impl Default for Environment {
    fn default() -> Self {
        Self { source: EnvironmentSource::Sky, intensity: 1.0, rotation: 0.0 }
    }
}

impl Environment {
    /// The environment of a `--environment` argument: `sky`, `none`, or a path to an HDR map. A
    /// map that cannot be loaded is reported (the error is returned beside the result) and the
    /// procedural sky stands in.
    pub fn from_argument(argument: &str) -> (Environment, Option<EnvironmentError>) {
        match argument {
            "sky" => (Environment::default(), None),
            "none" => (Environment { source: EnvironmentSource::None, ..Default::default() }, None),
            path => match HdrImage::load(path) {
                Ok(map) => (Environment { source: EnvironmentSource::Map(map), ..Default::default() }, None),
                Err(e) => (Environment::default(), Some(e)),
            },
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn packed_hdr_texels_decode_to_their_values() {
        let (size, decode) = texel_decoder(ktx2::Format::B10G11R11_UFLOAT_PACK32).unwrap();
        assert_eq!(size, 4);
        // R = 1.0 (exponent 15, 6-bit mantissa 0), G = 1.5 (mantissa 32), B = 0.5 (exponent 14).
        let v: u32 = (15 << 6) | (((15 << 6) | 32) << 11) | ((14 << 5) << 22);
        assert_eq!(decode(&v.to_le_bytes()), [1.0, 1.5, 0.5]);
        let (_, decode) = texel_decoder(ktx2::Format::E5B9G9R9_UFLOAT_PACK32).unwrap();
        // Shared exponent 16: a mantissa of 256 is 1.0, 128 is 0.5, 384 is 1.5.
        let v: u32 = 256 | (128 << 9) | (384 << 18) | (16 << 27);
        assert_eq!(decode(&v.to_le_bytes()), [1.0, 0.5, 1.5]);
        assert!(small_float(31 << 6, 6).is_nan(), "the all-ones exponent is not a number");
        assert_eq!(small_float(1, 6), 2f32.powi(-14) / 64.0, "denormals");
        assert!(texel_decoder(ktx2::Format::R8G8B8A8_UNORM).is_none());
    }
}
