//! Decoding PNG and JPEG into RGBA8 level 0, safely.
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

use super::*;
use ::image::ImageDecoder;

/// The limits every decode runs under (see [`MAX_IMAGE_DIMENSION`], [`MAX_DECODE_BYTES`]).
fn decode_limits() -> ::image::Limits {
    let mut limits = ::image::Limits::default();
    limits.max_image_width = Some(MAX_IMAGE_DIMENSION);
    limits.max_image_height = Some(MAX_IMAGE_DIMENSION);
    limits.max_alloc = Some(MAX_DECODE_BYTES);
    limits
}

/// Reads the header, checks the declared size against the limits, then decodes to RGBA8 and
/// builds the mip chain.
pub(super) fn decode(bytes: &[u8], color_space: ColorSpace, what: impl Fn() -> String) -> Result<Image, ImageError> {
    let (width, height, rgba) = decode_rgba8(bytes, what)?;
    Image::from_rgba8(width, height, rgba, color_space)
}

/// Reads the header, checks the declared size against the limits, then decodes level 0 to
/// RGBA8: width, height and texels.
pub(super) fn decode_rgba8(bytes: &[u8], what: impl Fn() -> String) -> Result<(u32, u32, Vec<u8>), ImageError> {
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
    Ok((width, height, rgba.into_raw()))
}

#[cfg(test)]
mod tests {
    use super::*;

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
