//! CPU-side images with a full mip chain: RGBA8 decoded from PNG/JPEG or built in code, and
//! block-compressed (BCn) levels read from KTX2 or compressed here for the GPU.
//!
//! - `decode.rs`: PNG and JPEG into RGBA8, never panicking and never allocating in proportion to
//!   a size the file merely declares (the limits are [`MAX_IMAGE_DIMENSION`] and
//!   [`MAX_DECODE_BYTES`]).
//! - `mips.rs`: mip chains that follow Vulkan's size rule, filtered in linear space.
//! - `ktx2.rs`: KTX2 containers read ([`Image::from_ktx2`], [`Image::from_ktx2_for`], Basis
//!   Universal transcoded) and written ([`Image::to_ktx2`]).
//! - `compress.rs`: block compression by [`TextureRole`] ([`Image::compress`]).
//! - `cache.rs`: the texture import cache ([`TextureCache`]).

use std::path::{Path, PathBuf};

use thiserror::Error;

mod cache;
mod compress;
mod decode;
mod ktx2;
mod mips;

pub use cache::{CacheOutcome, TextureCache};
pub use compress::TextureRole;

/// Largest width or height, in pixels, accepted from an encoded image: 16384, the
/// `maxImageDimension2D` most desktop Vulkan drivers report (and the most a texture can use).
pub const MAX_IMAGE_DIMENSION: u32 = 16384;

/// Most bytes one decode may allocate (512 MiB): the decoder's own pixel buffer and working
/// memory (`image::Limits::max_alloc`), and separately the RGBA8 level 0 the result is converted
/// to. So 16384×8192 RGBA is the largest image (and 16384×16384 is refused); the mip chain then
/// adds a third, and building it needs about twice level 0 in floats for a moment.
pub const MAX_DECODE_BYTES: u64 = 512 * 1024 * 1024;

/// How an image's RGB channels are encoded (alpha is always linear).
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub enum ColorSpace {
    /// sRGB transfer function: colour textures (base colour, emissive).
    Srgb,
    /// Linear data: normal, metallic-roughness, occlusion maps.
    Linear,
}

/// Errors from building, reading or decoding an image.
#[derive(Error, Debug)]
pub enum ImageError {
    /// The pixel data does not match the stated size, or the size is zero.
    #[error("invalid image size {width}x{height}: expected {expected} bytes of RGBA8 data, got {actual}")]
    InvalidSize {
        /// Width in pixels.
        width: u32,
        /// Height in pixels.
        height: u32,
        /// Bytes required (0 when the size itself is invalid).
        expected: usize,
        /// Bytes supplied.
        actual: usize,
    },
    /// The file could not be read.
    #[error("cannot read image file {path}: {source}")]
    Io {
        /// The file.
        path: PathBuf,
        /// The OS error.
        source: std::io::Error,
    },
    /// The encoded image declares a width or height of zero.
    #[error("image {what} is empty: it declares {width}x{height} pixels")]
    Empty {
        /// The file path, or a description of the in-memory source.
        what: String,
        /// Declared width in pixels.
        width: u32,
        /// Declared height in pixels.
        height: u32,
    },
    /// The encoded image declares a size over [`MAX_IMAGE_DIMENSION`] or [`MAX_DECODE_BYTES`];
    /// nothing was decoded.
    #[error("image {what} is too large: {width}x{height} pixels, {limit}")]
    TooLarge {
        /// The file path, or a description of the in-memory source.
        what: String,
        /// Declared width in pixels.
        width: u32,
        /// Declared height in pixels.
        height: u32,
        /// Which limit it exceeds, with the numbers.
        limit: String,
    },
    /// A KTX2 container this loader cannot use: not a valid container, supercompressed, a
    /// universal (Basis) format to transcode, or a texel format other than BC1, BC3, BC4, BC5,
    /// BC7 and RGBA8.
    #[error("cannot use KTX2 image {what}: {reason}")]
    Ktx2 {
        /// The file path, or a description of the in-memory source.
        what: String,
        /// Why.
        reason: String,
    },
    /// The bytes are not a decodable PNG or JPEG (unknown format, truncated or corrupt data, or
    /// the decoder's allocation limit was reached).
    #[error("cannot decode image {what}: {source}")]
    Decode {
        /// The file path, or a description of the in-memory source.
        what: String,
        /// The decoder's error.
        source: ::image::ImageError,
    },
}

/// How an image's texels are stored: 8-bit RGBA (what decoding PNG and JPEG gives), or a
/// block-compressed format (4×4 texels a block) that the GPU samples as it is.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub enum TexelFormat {
    /// Four bytes a texel.
    #[default]
    Rgba8,
    /// BC1 with 1-bit alpha, 8 bytes a block (a three-colour block's fourth index is
    /// transparent).
    Bc1,
    /// BC1 without alpha (a three-colour block's fourth index is opaque black).
    Bc1Rgb,
    /// BC3: RGBA, 16 bytes a block.
    Bc3,
    /// BC4: one channel, 8 bytes a block.
    Bc4,
    /// BC5: two channels, 16 bytes a block.
    Bc5,
    /// BC7: RGBA, 16 bytes a block.
    Bc7,
}

impl TexelFormat {
    /// Bytes of one level of `width` × `height` texels (`None` past `usize`).
    pub fn level_bytes(self, width: u32, height: u32) -> Option<usize> {
        let (w, h) = (width as usize, height as usize);
        let blocks = w.div_ceil(4).checked_mul(h.div_ceil(4));
        match self {
            TexelFormat::Rgba8 => w.checked_mul(h)?.checked_mul(4),
            TexelFormat::Bc1 | TexelFormat::Bc1Rgb | TexelFormat::Bc4 => blocks?.checked_mul(8),
            TexelFormat::Bc3 | TexelFormat::Bc5 | TexelFormat::Bc7 => blocks?.checked_mul(16),
        }
    }
}

/// An image with its mip chain: RGBA8, with every level, when decoded from PNG or JPEG; or
/// block-compressed levels as a container file held them ([`Image::from_blocks`]).
#[derive(Clone, PartialEq)]
pub struct Image {
    /// Width of level 0 in pixels.
    pub width: u32,
    /// Height of level 0 in pixels.
    pub height: u32,
    /// Encoding of the RGB channels.
    pub color_space: ColorSpace,
    /// How the texels are stored.
    pub format: TexelFormat,
    /// Each level's texels (tightly packed rows, or blocks), level 0 first, down to 1×1 when
    /// complete.
    pub mips: Vec<Vec<u8>>,
}

impl std::fmt::Debug for Image {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("Image")
            .field("width", &self.width)
            .field("height", &self.height)
            .field("color_space", &self.color_space)
            .field("format", &self.format)
            .field("mip_count", &self.mips.len())
            .finish()
    }
}

/// A size and level count [`Image::from_blocks`] accepts: 1 to [`MAX_IMAGE_DIMENSION`] texels a
/// side, and 1 to the full chain's levels.
fn check_size(width: u32, height: u32, levels: usize) -> Result<(), ImageError> {
    let full_chain = 32 - width.max(height).max(1).leading_zeros();
    let sides = (1..=MAX_IMAGE_DIMENSION).contains(&width) && (1..=MAX_IMAGE_DIMENSION).contains(&height);
    if !sides || levels == 0 || levels as u32 > full_chain {
        return Err(ImageError::InvalidSize { width, height, expected: full_chain as usize, actual: levels });
    }
    Ok(())
}

impl Image {
    /// Builds an image and its mip chain from tightly packed RGBA8 level-0 data.
    pub fn from_rgba8(width: u32, height: u32, data: Vec<u8>, color_space: ColorSpace) -> Result<Image, ImageError> {
        Image::with_mips(width, height, data, color_space, mips::MipFilter::Plain)
    }

    /// An RGBA8 image from tightly packed level-0 data, its mip chain filtered as `filter` says.
    fn with_mips(width: u32, height: u32, data: Vec<u8>, color_space: ColorSpace, filter: mips::MipFilter) -> Result<Image, ImageError> {
        let expected = (width as usize).checked_mul(height as usize).and_then(|n| n.checked_mul(4)).filter(|&n| n > 0);
        if expected != Some(data.len()) {
            return Err(ImageError::InvalidSize { width, height, expected: expected.unwrap_or(0), actual: data.len() });
        }
        let mips = mips::build_mips(width, height, data, color_space, filter);
        Ok(Image { width, height, color_space, format: TexelFormat::Rgba8, mips })
    }

    /// An image of `format` from its levels as a container holds them (level 0 first, each of
    /// [`TexelFormat::level_bytes`]; at most a full chain).
    pub fn from_blocks(
        width: u32,
        height: u32,
        color_space: ColorSpace,
        format: TexelFormat,
        mips: Vec<Vec<u8>>,
    ) -> Result<Image, ImageError> {
        check_size(width, height, mips.len())?;
        for (level, data) in mips.iter().enumerate() {
            let (w, h) = mip_size(width, height, level as u32);
            match format.level_bytes(w, h) {
                Some(expected) if data.len() == expected => {}
                expected => {
                    return Err(ImageError::InvalidSize { width: w, height: h, expected: expected.unwrap_or(0), actual: data.len() });
                }
            }
        }
        Ok(Image { width, height, color_space, format, mips })
    }

    /// Reads and decodes a PNG or JPEG file (see the module docs for the limits and the
    /// conversions to RGBA8).
    pub fn load(path: &Path, color_space: ColorSpace) -> Result<Image, ImageError> {
        let bytes = std::fs::read(path).map_err(|source| ImageError::Io { path: path.to_owned(), source })?;
        decode::decode(&bytes, color_space, || path.display().to_string())
    }

    /// Decodes an in-memory PNG or JPEG (see the module docs for the limits and the conversions
    /// to RGBA8); errors name it `<N bytes in memory>`.
    pub fn from_encoded(bytes: &[u8], color_space: ColorSpace) -> Result<Image, ImageError> {
        decode::decode(bytes, color_space, || format!("<{} bytes in memory>", bytes.len()))
    }

    /// Decodes an in-memory PNG or JPEG to its RGBA8 level 0 alone (width, height, texels),
    /// under the same limits as [`Image::from_encoded`]: for callers that filter or compress the
    /// mip chain themselves ([`Image::compress`]).
    pub fn decode_rgba8(bytes: &[u8]) -> Result<(u32, u32, Vec<u8>), ImageError> {
        decode::decode_rgba8(bytes, || format!("<{} bytes in memory>", bytes.len()))
    }

    /// A 1×1 image of one colour.
    pub fn solid(rgba: [u8; 4], color_space: ColorSpace) -> Image {
        Image { width: 1, height: 1, color_space, format: TexelFormat::Rgba8, mips: vec![rgba.to_vec()] }
    }

    /// The stand-in for a colour texture that could not be loaded: a 16×16 sRGB checker of 4×4
    /// magenta and black cells (with mips), impossible to mistake for intended content.
    pub fn missing_texture() -> Image {
        const SIZE: u32 = 16;
        const CELL: u32 = 4;
        let data = (0..SIZE * SIZE)
            .flat_map(|i| {
                let (x, y) = (i % SIZE, i / SIZE);
                if (x / CELL + y / CELL).is_multiple_of(2) { [255, 0, 255, 255] } else { [0, 0, 0, 255] }
            })
            .collect();
        Image::from_rgba8(SIZE, SIZE, data, ColorSpace::Srgb).expect("the checker's size matches its data")
    }

    /// Number of mip levels (level 0 included).
    pub fn mip_count(&self) -> u32 {
        self.mips.len() as u32
    }

    /// Size of mip `level`: `max(1, size >> level)` per axis.
    pub fn mip_size(&self, level: u32) -> (u32, u32) {
        mip_size(self.width, self.height, level)
    }

    /// The mean of the texels as linear RGBA (sRGB channels decoded), taken over the smallest
    /// level held (the mean of the whole when the chain is complete, as its levels are box
    /// filtered); `None` for block-compressed texels.
    pub fn mean_color(&self) -> Option<[f32; 4]> {
        let level = self.mips.len().checked_sub(1)?;
        if self.format != TexelFormat::Rgba8 {
            return None;
        }
        let texels = &self.mips[level];
        let count = texels.len() / 4;
        if count == 0 {
            return None;
        }
        let decode = mips::srgb_tables();
        let mut sum = [0.0f64; 4];
        for texel in texels.chunks_exact(4) {
            for (c, &v) in texel.iter().enumerate() {
                let linear = if c < 3 && self.color_space == ColorSpace::Srgb { decode.decode[v as usize] } else { v as f32 / 255.0 };
                sum[c] += f64::from(linear);
            }
        }
        Some(sum.map(|s| (s / count as f64) as f32))
    }
}

/// The limits every decode runs under (see [`MAX_IMAGE_DIMENSION`], [`MAX_DECODE_BYTES`]).
fn mip_size(width: u32, height: u32, level: u32) -> (u32, u32) {
    let shrink = |size: u32| size.checked_shr(level).unwrap_or(0).max(1);
    (shrink(width), shrink(height))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_mean_colour_is_linear_and_compressed_images_have_none() {
        let image = Image::from_rgba8(2, 1, vec![255, 0, 0, 255, 0, 0, 0, 0], ColorSpace::Srgb).unwrap();
        let mean = image.mean_color().unwrap();
        // The 1×1 level: the mean in linear light, stored in 8 bits.
        assert!((mean[0] - 0.5).abs() < 0.01 && mean[1] == 0.0 && (mean[3] - 0.5).abs() < 0.01, "{mean:?}");
        let grey = Image::solid([188, 188, 188, 255], ColorSpace::Srgb).mean_color().unwrap();
        assert!((grey[0] - 0.5029).abs() < 1e-3, "sRGB 188 is about half in linear: {}", grey[0]);
        let block = Image::from_blocks(4, 4, ColorSpace::Srgb, TexelFormat::Bc1, vec![vec![0; 8], vec![0; 8], vec![0; 8]]).unwrap();
        assert!(block.mean_color().is_none());
    }

    #[test]
    fn block_compressed_levels_are_checked_against_their_size() {
        let block = vec![0u8; 8];
        // 8×8 in BC1: 2×2 blocks, then 1, 1, 1.
        let chain = vec![block.repeat(4), block.clone(), block.clone(), block.clone()];
        let image = Image::from_blocks(8, 8, ColorSpace::Srgb, TexelFormat::Bc1, chain).expect("a full BC1 chain");
        assert_eq!((image.format, image.mip_count()), (TexelFormat::Bc1, 4));
        assert_eq!(TexelFormat::Bc7.level_bytes(5, 3), Some(32), "partial blocks count whole");
        assert!(Image::from_blocks(8, 8, ColorSpace::Srgb, TexelFormat::Bc1, vec![block.clone()]).is_err(), "a level one block short");
        assert!(Image::from_blocks(4, 4, ColorSpace::Srgb, TexelFormat::Bc1, vec![block.clone(); 4]).is_err(), "more levels than 4×4 has");
        assert!(Image::from_blocks(0, 4, ColorSpace::Srgb, TexelFormat::Bc1, vec![block]).is_err(), "no texels");
    }
}
