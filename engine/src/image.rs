//! CPU-side RGBA8 images with a full mip chain, decoded from PNG/JPEG or built in code.
//!
//! Mip sizes follow Vulkan's rule, level `l` is `max(1, size >> l)` (so 5×3 → 2×1 → 1×1), which
//! lets the renderer copy each level into a `VkImage` of the level-0 extent directly. Each level
//! is an area-weighted box filter of the one above: a plain 2×2 average for even sizes; for an
//! odd size `2d + 1` each destination texel covers `2 + 1/d` source texels (up to three taps with
//! fractional edge weights), so no source texel is dropped or over-weighted. For sRGB images the colour channels are filtered in linear space (decoded through a
//! 256-entry table, re-encoded by a binary search over the 255 code midpoints, i.e. exact
//! round-to-nearest in sRGB); alpha is always linear. Levels are filtered from the previous
//! level's unquantised floats, so rounding does not accumulate down the chain.
//!
//! **Decoding hostile input.** [`Image::load`] and [`Image::from_encoded`] never panic and never
//! allocate in proportion to a size the file merely declares: the header is read first, and an
//! image of zero width or height is an [`ImageError::Empty`]; one wider or taller than
//! [`MAX_IMAGE_DIMENSION`], or whose decoded or RGBA8 pixels would take more than
//! [`MAX_DECODE_BYTES`], is an [`ImageError::TooLarge`], before any pixel buffer exists. The
//! decoder itself runs under the same [`::image::Limits`] (strict width and height, and
//! `max_alloc`). Truncated or corrupt data is an [`ImageError::Decode`]; every error names the
//! file (or `<N bytes in memory>`). Any 8- or 16-bit grey, grey-alpha, RGB or RGBA PNG and any
//! JPEG load: grey `g` becomes `(g, g, g, 255)`, a missing alpha is opaque, and 16-bit samples
//! are rounded to the nearest 8-bit value (`(v + 128) / 257`).

use std::path::{Path, PathBuf};
use std::sync::OnceLock;

use ::image::ImageDecoder;
use thiserror::Error;

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
        let expected = (width as usize).checked_mul(height as usize).and_then(|n| n.checked_mul(4)).filter(|&n| n > 0);
        if expected != Some(data.len()) {
            return Err(ImageError::InvalidSize { width, height, expected: expected.unwrap_or(0), actual: data.len() });
        }
        let mips = build_mips(width, height, data, color_space);
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
        decode(&bytes, color_space, || path.display().to_string())
    }

    /// Decodes an in-memory PNG or JPEG (see the module docs for the limits and the conversions
    /// to RGBA8); errors name it `<N bytes in memory>`.
    pub fn from_encoded(bytes: &[u8], color_space: ColorSpace) -> Result<Image, ImageError> {
        decode(bytes, color_space, || format!("<{} bytes in memory>", bytes.len()))
    }

    /// Reads a KTX2 container of a 2D texture in BC1, BC3, BC4, BC5, BC7 or RGBA8 (its levels
    /// used as they are, as many as it holds); `color_space` is how the material uses it (the
    /// blocks are the same either way). Supercompressed and Basis Universal containers are
    /// refused with the reason (transcoding them is not implemented yet); errors name `what`.
    pub fn from_ktx2(bytes: &[u8], color_space: ColorSpace, what: &str) -> Result<Image, ImageError> {
        use ktx2::Format as F;
        let fail = |reason: String| ImageError::Ktx2 { what: what.to_string(), reason };
        let reader = ktx2::Reader::new(bytes).map_err(|e| fail(format!("not a valid KTX2 container ({e})")))?;
        let header = reader.header();
        if let Some(scheme) = header.supercompression_scheme {
            return Err(fail(format!("supercompressed ({scheme:?}): Basis Universal and zstd are not transcoded yet")));
        }
        if header.layer_count > 1 || header.face_count > 1 || header.pixel_depth > 1 {
            return Err(fail("an array, cube or volume texture, not a 2D one".to_string()));
        }
        let format = match header.format {
            Some(F::BC1_RGB_UNORM_BLOCK | F::BC1_RGB_SRGB_BLOCK) => TexelFormat::Bc1Rgb,
            Some(F::BC1_RGBA_UNORM_BLOCK | F::BC1_RGBA_SRGB_BLOCK) => TexelFormat::Bc1,
            Some(F::BC3_UNORM_BLOCK | F::BC3_SRGB_BLOCK) => TexelFormat::Bc3,
            Some(F::BC4_UNORM_BLOCK) => TexelFormat::Bc4,
            Some(F::BC5_UNORM_BLOCK) => TexelFormat::Bc5,
            Some(F::BC7_UNORM_BLOCK | F::BC7_SRGB_BLOCK) => TexelFormat::Bc7,
            Some(F::R8G8B8A8_UNORM | F::R8G8B8A8_SRGB) => TexelFormat::Rgba8,
            None => return Err(fail("a universal format (Basis Universal) to transcode, which is not implemented yet".to_string())),
            Some(other) => return Err(fail(format!("its format {other:?} is not BC1, BC3, BC4, BC5, BC7 or RGBA8"))),
        };
        let (width, height) = (header.pixel_width, header.pixel_height.max(1));
        // Every level checked against its size before any is copied: a container may declare
        // many levels over the same bytes.
        check_size(width, height, header.level_count.max(1) as usize).map_err(|e| fail(e.to_string()))?;
        for (level, data) in reader.levels().enumerate() {
            let (w, h) = mip_size(width, height, level as u32);
            if Some(data.data.len()) != format.level_bytes(w, h) {
                return Err(fail(format!("level {level} holds {} bytes, not a {w}×{h} {format:?} level's", data.data.len())));
            }
        }
        let mips = reader.levels().map(|level| level.data.to_vec()).collect();
        Image::from_blocks(width, height, color_space, format, mips).map_err(|e| fail(e.to_string()))
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
}

/// The limits every decode runs under (see [`MAX_IMAGE_DIMENSION`], [`MAX_DECODE_BYTES`]).
fn decode_limits() -> ::image::Limits {
    let mut limits = ::image::Limits::default();
    limits.max_image_width = Some(MAX_IMAGE_DIMENSION);
    limits.max_image_height = Some(MAX_IMAGE_DIMENSION);
    limits.max_alloc = Some(MAX_DECODE_BYTES);
    limits
}

/// Reads the header, checks the declared size against the limits, then decodes to RGBA8.
fn decode(bytes: &[u8], color_space: ColorSpace, what: impl Fn() -> String) -> Result<Image, ImageError> {
    let decode_error = |source| ImageError::Decode { what: what(), source };
    let mut reader = ::image::ImageReader::new(std::io::Cursor::new(bytes))
        .with_guessed_format()
        .map_err(|e| decode_error(::image::ImageError::IoError(e)))?;
    // The header is parsed under the allocation limit only, so that a size over the strict
    // width/height limits is reported below with its numbers rather than as a bare limit error.
    let mut header_limits = ::image::Limits::default();
    header_limits.max_alloc = Some(MAX_DECODE_BYTES);
    reader.limits(header_limits);
    let mut decoder = reader.into_decoder().map_err(decode_error)?;
    let (width, height) = decoder.dimensions();
    let too_large = |limit: String| ImageError::TooLarge { what: what(), width, height, limit };
    if width == 0 || height == 0 {
        return Err(ImageError::Empty { what: what(), width, height });
    }
    if width > MAX_IMAGE_DIMENSION || height > MAX_IMAGE_DIMENSION {
        return Err(too_large(format!("over the limit of {MAX_IMAGE_DIMENSION} pixels per side")));
    }
    let rgba_bytes = u64::from(width) * u64::from(height) * 4;
    let decoded_bytes = decoder.total_bytes();
    if let Some(bytes) = [rgba_bytes, decoded_bytes].into_iter().find(|&b| b > MAX_DECODE_BYTES) {
        return Err(too_large(format!("{bytes} bytes decoded, over the limit of {MAX_DECODE_BYTES}")));
    }
    // As `ImageReader::decode` does: the output buffer counts against the allocation limit, the
    // rest of it is the decoder's working memory.
    let mut limits = decode_limits();
    limits.reserve(decoded_bytes).map_err(decode_error)?;
    decoder.set_limits(limits).map_err(decode_error)?;
    let rgba = ::image::DynamicImage::from_decoder(decoder).map_err(decode_error)?.into_rgba8();
    Image::from_rgba8(width, height, rgba.into_raw(), color_space)
}

fn mip_size(width: u32, height: u32, level: u32) -> (u32, u32) {
    let shrink = |size: u32| size.checked_shr(level).unwrap_or(0).max(1);
    (shrink(width), shrink(height))
}

/// sRGB code → linear value, and the linear values halfway between consecutive codes.
struct SrgbTables {
    decode: [f32; 256],
    midpoints: [f32; 255],
}

fn srgb_to_linear(c: f64) -> f64 {
    if c <= 0.04045 { c / 12.92 } else { ((c + 0.055) / 1.055).powf(2.4) }
}

fn srgb_tables() -> &'static SrgbTables {
    static TABLES: OnceLock<SrgbTables> = OnceLock::new();
    TABLES.get_or_init(|| SrgbTables {
        decode: std::array::from_fn(|i| srgb_to_linear(i as f64 / 255.0) as f32),
        midpoints: std::array::from_fn(|i| srgb_to_linear((i as f64 + 0.5) / 255.0) as f32),
    })
}

fn encode_linear(v: f32) -> u8 {
    (v * 255.0 + 0.5).clamp(0.0, 255.0) as u8
}

/// One destination texel's source coverage along an axis: up to three weighted source texels.
#[derive(Clone, Copy)]
struct Taps {
    first: usize,
    count: usize,
    weights: [f32; 3],
}

/// Area-weighted box-filter taps from `src` texels down to `dst` texels.
fn axis_taps(src: u32, dst: u32) -> Vec<Taps> {
    let scale = src as f64 / dst as f64;
    (0..dst)
        .map(|x| {
            let (start, end) = (x as f64 * scale, (x + 1) as f64 * scale);
            let first = start.floor() as usize;
            let last = (end.ceil() as usize).min(src as usize);
            let mut taps = Taps { first, count: 0, weights: [0.0; 3] };
            for i in first..last {
                let overlap = (end.min(i as f64 + 1.0) - start.max(i as f64)).max(0.0);
                if taps.count < 3 {
                    taps.weights[taps.count] = (overlap / scale) as f32;
                    taps.count += 1;
                }
            }
            taps
        })
        .collect()
}

/// Downsamples a `w`×`h` RGBA float image (read through `fetch(index)`) to `nw`×`nh`.
fn downsample(w: u32, h: u32, nw: u32, nh: u32, fetch: impl Fn(usize) -> f32) -> Vec<f32> {
    let (w, h, nw, nh) = (w as usize, h as usize, nw as usize, nh as usize);
    let tx = axis_taps(w as u32, nw as u32);
    let ty = axis_taps(h as u32, nh as u32);
    let mut rows = vec![0.0f32; nw * h * 4];
    for y in 0..h {
        for (x, taps) in tx.iter().enumerate() {
            let out = &mut rows[(y * nw + x) * 4..][..4];
            for k in 0..taps.count {
                let base = (y * w + taps.first + k) * 4;
                for (c, o) in out.iter_mut().enumerate() {
                    *o += taps.weights[k] * fetch(base + c);
                }
            }
        }
    }
    let mut out = vec![0.0f32; nw * nh * 4];
    for (y, taps) in ty.iter().enumerate() {
        let dst = &mut out[y * nw * 4..][..nw * 4];
        for k in 0..taps.count {
            let src = &rows[(taps.first + k) * nw * 4..][..nw * 4];
            for (d, s) in dst.iter_mut().zip(src) {
                *d += taps.weights[k] * s;
            }
        }
    }
    out
}

fn build_mips(width: u32, height: u32, level0: Vec<u8>, color_space: ColorSpace) -> Vec<Vec<u8>> {
    let tables = srgb_tables();
    let levels = 32 - width.max(height).leading_zeros();
    let mut mips = Vec::with_capacity(levels as usize);
    let mut previous: Vec<f32> = Vec::new();
    let (mut w, mut h) = (width, height);
    mips.push(level0);
    for level in 1..levels {
        let (nw, nh) = mip_size(width, height, level);
        let next = if level == 1 {
            let src = &mips[0];
            match color_space {
                ColorSpace::Srgb => {
                    downsample(w, h, nw, nh, |i| if i % 4 == 3 { src[i] as f32 / 255.0 } else { tables.decode[src[i] as usize] })
                }
                ColorSpace::Linear => downsample(w, h, nw, nh, |i| src[i] as f32 / 255.0),
            }
        } else {
            downsample(w, h, nw, nh, |i| previous[i])
        };
        let bytes = next
            .iter()
            .enumerate()
            .map(|(i, &v)| match color_space {
                ColorSpace::Srgb if i % 4 != 3 => tables.midpoints.partition_point(|&m| m <= v) as u8,
                _ => encode_linear(v),
            })
            .collect();
        mips.push(bytes);
        previous = next;
        (w, h) = (nw, nh);
    }
    mips
}

#[cfg(test)]
mod tests {
    use super::*;

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

    #[test]
    fn odd_sizes_follow_vulkan_mip_rule() {
        let image = Image::from_rgba8(5, 3, vec![200; 5 * 3 * 4], ColorSpace::Linear).unwrap();
        let sizes: Vec<_> = (0..image.mip_count()).map(|l| image.mip_size(l)).collect();
        assert_eq!(sizes, vec![(5, 3), (2, 1), (1, 1)]);
        for (level, data) in image.mips.iter().enumerate() {
            let (w, h) = sizes[level];
            assert_eq!(data.len(), (w * h * 4) as usize);
            assert!(data.iter().all(|&v| v == 200), "constant image stays constant");
        }
        let tall = Image::from_rgba8(1, 6, vec![0; 24], ColorSpace::Srgb).unwrap();
        assert_eq!(tall.mip_count(), 3);
        assert_eq!(tall.mips[2].len(), 4);
    }

    #[test]
    fn odd_filter_keeps_every_texel() {
        // A 3x1 row 0, 255, 0 (linear): the 1x1 mip is the area average 85, not 0 or 127.
        let data = [0u8, 255, 0].iter().flat_map(|&v| [v, v, v, 255]).collect();
        let image = Image::from_rgba8(3, 1, data, ColorSpace::Linear).unwrap();
        assert_eq!(image.mips[1], vec![85, 85, 85, 255]);
    }

    #[test]
    fn srgb_average_is_done_in_linear_space() {
        let (b, w) = ([0u8, 0, 0, 255], [255u8, 255, 255, 255]);
        let checker: Vec<u8> = [b, w, w, b].concat();
        let srgb = Image::from_rgba8(2, 2, checker.clone(), ColorSpace::Srgb).unwrap();
        assert_eq!(srgb.mip_count(), 2);
        assert_eq!(&srgb.mips[1][..3], &[188, 188, 188]);
        assert_eq!(srgb.mips[1][3], 255);
        let linear = Image::from_rgba8(2, 2, checker, ColorSpace::Linear).unwrap();
        assert_eq!(&linear.mips[1][..3], &[128, 128, 128]);
    }

    #[test]
    fn srgb_round_trip_is_exact() {
        let tables = srgb_tables();
        for code in 0..=255u8 {
            let v = tables.decode[code as usize];
            assert_eq!(tables.midpoints.partition_point(|&m| m <= v), code as usize);
        }
    }

    #[test]
    fn bad_sizes_are_errors() {
        assert!(matches!(
            Image::from_rgba8(2, 2, vec![0; 15], ColorSpace::Srgb),
            Err(ImageError::InvalidSize { expected: 16, actual: 15, .. })
        ));
        assert!(Image::from_rgba8(0, 4, vec![], ColorSpace::Srgb).is_err());
        assert!(matches!(Image::from_encoded(b"not a png", ColorSpace::Srgb), Err(ImageError::Decode { .. })));
    }

    #[test]
    fn encoded_png_round_trips() {
        let mut png = Vec::new();
        let pixels = ::image::RgbaImage::from_fn(4, 4, |x, y| ::image::Rgba([x as u8 * 60, y as u8 * 60, 7, 255]));
        pixels.write_to(&mut std::io::Cursor::new(&mut png), ::image::ImageFormat::Png).unwrap();
        let image = Image::from_encoded(&png, ColorSpace::Linear).unwrap();
        assert_eq!((image.width, image.height, image.mip_count()), (4, 4, 3));
        assert_eq!(&image.mips[0][4..8], &[60, 0, 7, 255]);
    }

    /// Encodes `image` as `format` with the `image` crate.
    fn encode(image: impl Into<::image::DynamicImage>, format: ::image::ImageFormat) -> Vec<u8> {
        let mut bytes = Vec::new();
        image.into().write_to(&mut std::io::Cursor::new(&mut bytes), format).unwrap();
        bytes
    }

    /// CRC-32 (ISO-HDLC, as PNG chunks use), bit by bit.
    fn crc32(bytes: &[u8]) -> u32 {
        let mut crc = !0u32;
        for &byte in bytes {
            crc ^= byte as u32;
            for _ in 0..8 {
                crc = if crc & 1 == 1 { (crc >> 1) ^ 0xEDB8_8320 } else { crc >> 1 };
            }
        }
        !crc
    }

    fn png_chunk(out: &mut Vec<u8>, kind: &[u8; 4], data: &[u8]) {
        out.extend((data.len() as u32).to_be_bytes());
        let start = out.len();
        out.extend(kind);
        out.extend(data);
        let crc = crc32(&out[start..]);
        out.extend(crc.to_be_bytes());
    }

    /// A PNG whose IHDR declares `width`×`height` RGBA8, followed by a tiny (wrong-sized) IDAT
    /// and IEND, all with valid CRCs: only the declared size is hostile.
    fn png_declaring(width: u32, height: u32) -> Vec<u8> {
        let mut png = b"\x89PNG\r\n\x1a\n".to_vec();
        let mut ihdr = Vec::new();
        ihdr.extend(width.to_be_bytes());
        ihdr.extend(height.to_be_bytes());
        ihdr.extend([8, 6, 0, 0, 0]);
        png_chunk(&mut png, b"IHDR", &ihdr);
        // zlib stream of one stored empty block.
        png_chunk(&mut png, b"IDAT", &[0x78, 0x01, 0x01, 0x00, 0x00, 0xff, 0xff, 0x00, 0x00, 0x00, 0x01]);
        png_chunk(&mut png, b"IEND", &[]);
        png
    }

    #[test]
    fn crc_matches_a_real_png() {
        let png = encode(::image::RgbaImage::new(3, 2), ::image::ImageFormat::Png);
        // IHDR: length at 8, type+data at 12..29, CRC at 29..33.
        assert_eq!(crc32(&png[12..29]).to_be_bytes(), png[29..33]);
    }

    #[test]
    fn absurd_declared_sizes_are_refused_before_decoding() {
        for (width, height) in [(100_000, 100_000), (16_385, 1), (1, 16_385), (100_000, 1)] {
            let error = Image::from_encoded(&png_declaring(width, height), ColorSpace::Srgb).unwrap_err();
            let message = error.to_string();
            assert!(
                matches!(error, ImageError::TooLarge { width: w, height: h, .. } if (w, h) == (width, height)),
                "{width}x{height}: {message}"
            );
            assert!(message.contains("bytes in memory") && message.contains(&format!("{width}x{height}")), "{message}");
            assert!(message.contains("16384 pixels per side"), "{message}");
        }
        // So wide that the PNG decoder's row buffer alone is over the allocation limit: it
        // refuses the header itself.
        let error = Image::from_encoded(&png_declaring(0x7fff_ffff, 1), ColorSpace::Srgb).unwrap_err();
        assert!(matches!(error, ImageError::Decode { source: ::image::ImageError::Limits(_), .. }), "{error}");
        assert!(error.to_string().contains("bytes in memory"), "{error}");
        // Within the per-side limit but 1 GiB of RGBA8.
        let error = Image::from_encoded(&png_declaring(16_384, 16_384), ColorSpace::Srgb).unwrap_err();
        assert!(matches!(error, ImageError::TooLarge { .. }), "{error}");
        assert!(error.to_string().contains(&format!("over the limit of {MAX_DECODE_BYTES}")), "{error}");
        // 2^31 is not a valid PNG width at all: refused by the decoder, still naming the source.
        let error = Image::from_encoded(&png_declaring(1 << 31, 1), ColorSpace::Srgb).unwrap_err();
        assert!(matches!(error, ImageError::Decode { .. } | ImageError::TooLarge { .. }), "{error}");
        assert!(error.to_string().contains("bytes in memory"), "{error}");
    }

    #[test]
    fn zero_sized_images_are_errors() {
        for (width, height) in [(0, 0), (0, 4), (4, 0)] {
            let error = Image::from_encoded(&png_declaring(width, height), ColorSpace::Linear).unwrap_err();
            // The PNG decoder refuses a zero dimension in IHDR itself.
            assert!(matches!(error, ImageError::Decode { .. }), "{error}");
            let message = error.to_string();
            assert!(message.contains("bytes in memory") && message.contains("dimensions"), "{message}");
        }
        // A JPEG whose frame header (SOF0: marker, length, precision, height, width) says 0×0.
        let mut jpeg = encode(::image::RgbImage::new(8, 8), ::image::ImageFormat::Jpeg);
        let sof = jpeg.windows(2).position(|w| w == [0xff, 0xc0]).expect("baseline JPEG");
        for (at, dimension) in [(5, "height"), (7, "width")] {
            jpeg[sof + at..sof + at + 2].copy_from_slice(&[0, 0]);
            let error = Image::from_encoded(&jpeg, ColorSpace::Srgb).unwrap_err();
            assert!(matches!(error, ImageError::Empty { .. } | ImageError::Decode { .. }), "zero {dimension}: {error}");
            let message = error.to_string();
            assert!(message.contains("bytes in memory") && message.contains("zero"), "{message}");
        }
    }

    #[test]
    fn errors_name_the_file() {
        let dir = std::env::temp_dir().join(format!("engine-image-test-{}", std::process::id()));
        std::fs::create_dir_all(&dir).unwrap();
        let path = dir.join("huge.png");
        std::fs::write(&path, png_declaring(100_000, 100_000)).unwrap();
        let error = Image::load(&path, ColorSpace::Srgb).unwrap_err();
        assert!(matches!(error, ImageError::TooLarge { .. }), "{error}");
        assert!(error.to_string().contains("huge.png"), "{error}");
        let missing = Image::load(&dir.join("missing.png"), ColorSpace::Srgb).unwrap_err();
        assert!(matches!(missing, ImageError::Io { .. }) && missing.to_string().contains("missing.png"), "{missing}");
        std::fs::remove_dir_all(&dir).ok();
    }

    /// A 16×16 RGB gradient with some structure, as PNG and JPEG.
    fn test_images() -> [(::image::ImageFormat, Vec<u8>); 2] {
        let pixels = ::image::RgbImage::from_fn(16, 16, |x, y| ::image::Rgb([x as u8 * 16, y as u8 * 16, (x * y) as u8]));
        [::image::ImageFormat::Png, ::image::ImageFormat::Jpeg].map(|format| (format, encode(pixels.clone(), format)))
    }

    #[test]
    fn truncated_and_corrupt_images_never_panic() {
        for (format, bytes) in test_images() {
            for len in (0..bytes.len()).step_by(7) {
                match Image::from_encoded(&bytes[..len], ColorSpace::Srgb) {
                    // A truncated PNG always fails (the IEND and CRCs are missing); JPEG decoders
                    // may fill in what is missing, but then the size is the declared one.
                    Ok(image) => {
                        assert_eq!(format, ::image::ImageFormat::Jpeg, "truncated PNG at {len} decoded");
                        assert_eq!((image.width, image.height), (16, 16));
                    }
                    Err(error) => assert!(error.to_string().contains("bytes in memory"), "{error}"),
                }
            }
            for at in (0..bytes.len()).step_by(3) {
                let mut corrupt = bytes.clone();
                corrupt[at] ^= 0x5a;
                if let Ok(image) = Image::from_encoded(&corrupt, ColorSpace::Linear) {
                    assert_eq!(image.mips[0].len(), (image.width * image.height * 4) as usize);
                }
            }
        }
        // A flipped byte inside a PNG chunk breaks its CRC.
        let (_, png) = &test_images()[0];
        let mut corrupt = png.clone();
        corrupt[20] ^= 1;
        assert!(matches!(Image::from_encoded(&corrupt, ColorSpace::Srgb), Err(ImageError::Decode { .. })));
    }

    #[test]
    fn grey_images_become_opaque_rgba() {
        let grey = ::image::GrayImage::from_fn(4, 2, |x, y| ::image::Luma([(x * 60 + y) as u8]));
        let image = Image::from_encoded(&encode(grey, ::image::ImageFormat::Png), ColorSpace::Linear).unwrap();
        assert_eq!((image.width, image.height), (4, 2));
        assert_eq!(&image.mips[0][4..8], &[60, 60, 60, 255]);
        assert_eq!(&image.mips[0][(4 + 3) * 4..][..4], &[181, 181, 181, 255]);

        let grey_alpha = ::image::GrayAlphaImage::from_fn(2, 2, |x, y| ::image::LumaA([x as u8 * 200, y as u8 * 100 + 1]));
        let image = Image::from_encoded(&encode(grey_alpha, ::image::ImageFormat::Png), ColorSpace::Linear).unwrap();
        assert_eq!(image.mips[0], [[0, 0, 0, 1], [200, 200, 200, 1], [0, 0, 0, 101], [200, 200, 200, 101]].concat());

        // A grey JPEG (lossy: a flat image stays flat within a code or two).
        let flat = ::image::GrayImage::from_pixel(8, 8, ::image::Luma([90]));
        let image = Image::from_encoded(&encode(flat, ::image::ImageFormat::Jpeg), ColorSpace::Srgb).unwrap();
        for texel in image.mips[0].chunks_exact(4) {
            assert!(texel[0].abs_diff(90) <= 2 && texel[0] == texel[1] && texel[1] == texel[2] && texel[3] == 255, "{texel:?}");
        }
    }

    #[test]
    fn sixteen_bit_images_are_rounded_to_eight_bits() {
        // v16 → round(v16 / 257): 128/257 = 0.498 → 0, 129/257 = 0.502 → 1, 0x1234 = 4660 →
        // 18.13 → 18, 65535 → 255, 33024/257 = 128.498 → 128, 33025/257 = 128.502 → 129.
        let values: [u16; 6] = [128, 129, 0x1234, 65535, 33024, 33025];
        let expected: [u8; 6] = [0, 1, 18, 255, 128, 129];
        let grey = ::image::ImageBuffer::<::image::Luma<u16>, _>::from_fn(6, 1, |x, _| ::image::Luma([values[x as usize]]));
        let image = Image::from_encoded(&encode(grey, ::image::ImageFormat::Png), ColorSpace::Linear).unwrap();
        let decoded: Vec<u8> = image.mips[0].chunks_exact(4).map(|t| t[0]).collect();
        assert_eq!(decoded, expected);
        assert!(image.mips[0].chunks_exact(4).all(|t| t[0] == t[1] && t[1] == t[2] && t[3] == 255));

        let rgb = ::image::ImageBuffer::<::image::Rgb<u16>, _>::from_fn(2, 1, |x, _| {
            let x = x as usize;
            ::image::Rgb([values[x], values[x + 2], values[x + 4]])
        });
        let image = Image::from_encoded(&encode(rgb, ::image::ImageFormat::Png), ColorSpace::Srgb).unwrap();
        assert_eq!(image.mips[0], vec![0, 18, 128, 255, 1, 255, 129, 255]);

        let rgba = ::image::ImageBuffer::<::image::Rgba<u16>, _>::from_pixel(1, 1, ::image::Rgba([129, 0x1234, 65535, 33025]));
        let image = Image::from_encoded(&encode(rgba, ::image::ImageFormat::Png), ColorSpace::Srgb).unwrap();
        assert_eq!(image.mips[0], vec![1, 18, 255, 129]);
    }
}
