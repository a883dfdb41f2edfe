//! Block compression at import: each texture compressed by what it is for (its
//! [`TextureRole`]), every level of a full mip chain made before compression.
//!
//! | role | format | why |
//! | --- | --- | --- |
//! | [`TextureRole::Color`] (base colour, emissive) | BC7, sRGB | 1 byte a texel, the best RGBA quality of the BC formats; alpha kept where any texel has it |
//! | [`TextureRole::Normal`] | BC5 | two independent 8-bit-grade channels (X, Y); the shader rebuilds Z, where BC7 would spend bits on a third channel it can derive |
//! | [`TextureRole::Data`] (metallic-roughness, packed occlusion) | BC7, linear | channels that vary independently need BC7's per-partition endpoints |
//! | [`TextureRole::Mask`] (occlusion alone) | BC4 | one channel, half a byte a texel |
//!
//! The encoder is Intel's ISPC Texture Compressor through the `intel_tex_2` crate (Traverse
//! Research): BC4, BC5 and BC7 from one well-kept dependency whose kernels ship prebuilt for
//! every desktop target, so nothing is compiled from C++ at build time (`ctt`, which Bevy 0.20
//! uses, wraps the same kernels among several C++ encoders). Its BC7 "basic" profile is the
//! quality/speed point its authors recommend for production assets. The kernels work on whole
//! 4×4 blocks: a level whose size is not a multiple of 4 is padded by repeating its last row and
//! column (the padded texels fall outside the texture and are never sampled). Rows of blocks are
//! compressed on every core (`std::thread::scope`).

use super::mips::MipFilter;
use super::*;

/// What a texture holds, which decides how it is filtered and compressed (see the module docs).
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub enum TextureRole {
    /// Colour in sRGB (base colour, emissive): BC7, with alpha when any texel has it.
    Color,
    /// A tangent-space normal map (`xyz = 2·rgb − 1`): BC5 of X and Y, mips renormalised; the
    /// shader rebuilds Z from them.
    Normal,
    /// Linear data in up to four channels (metallic-roughness, packed occlusion): BC7.
    Data,
    /// One linear channel, red (an occlusion map no other slot shares): BC4.
    Mask,
}

impl TextureRole {
    /// How its RGB channels are encoded.
    pub fn color_space(self) -> ColorSpace {
        match self {
            TextureRole::Color => ColorSpace::Srgb,
            TextureRole::Normal | TextureRole::Data | TextureRole::Mask => ColorSpace::Linear,
        }
    }

    /// The format it is compressed to.
    pub fn compressed_format(self) -> TexelFormat {
        match self {
            TextureRole::Color | TextureRole::Data => TexelFormat::Bc7,
            TextureRole::Normal => TexelFormat::Bc5,
            TextureRole::Mask => TexelFormat::Bc4,
        }
    }

    /// A short name, for cache keys and messages.
    pub fn name(self) -> &'static str {
        match self {
            TextureRole::Color => "color",
            TextureRole::Normal => "normal",
            TextureRole::Data => "data",
            TextureRole::Mask => "mask",
        }
    }

    fn mip_filter(self) -> MipFilter {
        if self == TextureRole::Normal { MipFilter::Normals } else { MipFilter::Plain }
    }
}

impl Image {
    /// An RGBA8 image with the mip chain `role` asks for (normal maps renormalised per level),
    /// not compressed: what a device without BC support samples.
    pub fn from_rgba8_for(width: u32, height: u32, data: Vec<u8>, role: TextureRole) -> Result<Image, ImageError> {
        Image::with_mips(width, height, data, role.color_space(), role.mip_filter())
    }

    /// Compresses an RGBA8 level 0 for `role` (see the module docs): the full mip chain is
    /// filtered from it, then every level is block-compressed.
    pub fn compress(width: u32, height: u32, data: Vec<u8>, role: TextureRole) -> Result<Image, ImageError> {
        let rgba = Image::from_rgba8_for(width, height, data, role)?;
        let format = role.compressed_format();
        let alpha = matches!(role, TextureRole::Color | TextureRole::Data) && rgba.mips[0].chunks_exact(4).any(|t| t[3] != 255);
        let mips = rgba
            .mips
            .iter()
            .enumerate()
            .map(|(level, texels)| {
                let (w, h) = rgba.mip_size(level as u32);
                compress_level(w, h, texels, format, alpha)
            })
            .collect();
        Image::from_blocks(width, height, role.color_space(), format, mips)
    }
}

/// One RGBA8 level of `width` × `height` texels compressed to `format` (BC4 takes red, BC5 red
/// and green, BC7 all four; `alpha` selects BC7's alpha modes).
fn compress_level(width: u32, height: u32, rgba: &[u8], format: TexelFormat, alpha: bool) -> Vec<u8> {
    let (pw, ph) = (width.next_multiple_of(4), height.next_multiple_of(4));
    let channels = match format {
        TexelFormat::Bc4 => 1,
        TexelFormat::Bc5 => 2,
        _ => 4,
    };
    // The level's channels, padded to whole blocks by repeating the last row and column.
    let mut texels = Vec::with_capacity(pw as usize * ph as usize * channels);
    for y in 0..ph as usize {
        let row = &rgba[y.min(height as usize - 1) * width as usize * 4..][..width as usize * 4];
        for x in 0..pw as usize {
            texels.extend_from_slice(&row[x.min(width as usize - 1) * 4..][..channels]);
        }
    }
    let block_bytes = format.level_bytes(4, 4).expect("one block");
    let blocks_per_row = pw as usize / 4;
    let block_rows = ph as usize / 4;
    let mut out = vec![0u8; blocks_per_row * block_rows * block_bytes];
    // Strips of whole block rows, one a thread; a small level is one strip.
    let threads = std::thread::available_parallelism().map_or(1, |n| n.get());
    let strips = if pw as usize * ph as usize >= 256 * 256 { threads.min(block_rows) } else { 1 };
    let rows_per_strip = block_rows.div_ceil(strips);
    let row_bytes = pw as usize * channels * 4;
    let settings = if alpha { ::intel_tex_2::bc7::alpha_basic_settings() } else { ::intel_tex_2::bc7::opaque_basic_settings() };
    std::thread::scope(|scope| {
        for (strip, blocks) in out.chunks_mut(rows_per_strip * blocks_per_row * block_bytes).enumerate() {
            let rows = blocks.len() / (blocks_per_row * block_bytes);
            let data = &texels[strip * rows_per_strip * row_bytes..][..rows * row_bytes];
            let (width, height) = (pw, rows as u32 * 4);
            let stride = pw * channels as u32;
            scope.spawn(move || match format {
                TexelFormat::Bc4 => {
                    ::intel_tex_2::bc4::compress_blocks_into(&::intel_tex_2::RSurface { data, width, height, stride }, blocks)
                }
                TexelFormat::Bc5 => {
                    ::intel_tex_2::bc5::compress_blocks_into(&::intel_tex_2::RgSurface { data, width, height, stride }, blocks)
                }
                _ => {
                    ::intel_tex_2::bc7::compress_blocks_into(&settings, &::intel_tex_2::RgbaSurface { data, width, height, stride }, blocks)
                }
            });
        }
    });
    out
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Decodes one BC4 block's 16 values (the BC4 reference decoder).
    fn bc4_block(block: &[u8]) -> [u8; 16] {
        let (r0, r1) = (block[0] as u32, block[1] as u32);
        let palette: Vec<u32> = if r0 > r1 {
            (0..8)
                .map(|i| match i {
                    0 => r0,
                    1 => r1,
                    i => ((8 - i) * r0 + (i - 1) * r1) / 7,
                })
                .collect()
        } else {
            (0..8)
                .map(|i| match i {
                    0 => r0,
                    1 => r1,
                    6 => 0,
                    7 => 255,
                    i => ((6 - i) * r0 + (i - 1) * r1) / 5,
                })
                .collect()
        };
        let bits = block[2..8].iter().rev().fold(0u64, |acc, &b| (acc << 8) | b as u64);
        std::array::from_fn(|t| palette[((bits >> (3 * t)) & 7) as usize] as u8)
    }

    #[test]
    fn roles_pick_their_formats_and_keep_every_level() {
        let gradient: Vec<u8> = (0..6 * 5).flat_map(|i| [(i * 8) as u8, 128, 255 - (i * 8) as u8, 255]).collect();
        for (role, format) in [
            (TextureRole::Color, TexelFormat::Bc7),
            (TextureRole::Normal, TexelFormat::Bc5),
            (TextureRole::Data, TexelFormat::Bc7),
            (TextureRole::Mask, TexelFormat::Bc4),
        ] {
            let image = Image::compress(6, 5, gradient.clone(), role).unwrap();
            assert_eq!((image.format, image.mip_count(), image.color_space), (format, 3, role.color_space()), "{role:?}");
        }
    }

    #[test]
    fn bc4_keeps_every_texel_within_half_a_palette_step() {
        // 6×5 of a red ramp: the second block column and row are padded.
        let ramp: Vec<u8> = (0..5).flat_map(|y| (0..6).flat_map(move |x| [(x * 40 + y * 5) as u8, 0, 0, 255])).collect();
        let image = Image::compress(6, 5, ramp.clone(), TextureRole::Mask).unwrap();
        let level0 = &image.mips[0];
        let source = |x: usize, y: usize| ramp[(y * 6 + x) * 4];
        for y in 0..5 {
            for x in 0..6 {
                let block = (y / 4) * 2 + x / 4;
                let decoded = bc4_block(&level0[block * 8..][..8])[(y % 4) * 4 + x % 4];
                // Eight levels span the block's range: half a step is a fourteenth of it.
                let texels: Vec<u8> = (0..5)
                    .flat_map(|v| (0..6).map(move |u| (u, v)))
                    .filter(|&(u, v)| (v / 4) * 2 + u / 4 == block)
                    .map(|(u, v)| source(u, v))
                    .collect();
                let range = texels.iter().max().unwrap() - texels.iter().min().unwrap();
                assert!(decoded.abs_diff(source(x, y)) <= range / 14 + 1, "({x}, {y}): {decoded} for {}", source(x, y));
            }
        }
    }

    #[test]
    fn normal_mips_stay_unit_length() {
        // Alternating tilted normals: a plain average would shorten them to cos(45°).
        let (a, b) = ([218u8, 128, 218, 255], [38u8, 128, 218, 255]);
        let data: Vec<u8> = (0..16).flat_map(|i| if (i + i / 4) % 2 == 0 { a } else { b }).collect();
        let image = Image::from_rgba8_for(4, 4, data, TextureRole::Normal).unwrap();
        let texel = &image.mips[1][..3];
        let v = texel.iter().map(|&c| c as f32 / 255.0 * 2.0 - 1.0).collect::<Vec<_>>();
        let length = (v[0] * v[0] + v[1] * v[1] + v[2] * v[2]).sqrt();
        assert!((length - 1.0).abs() < 0.02, "mip 1 normal {texel:?} has length {length}");
    }
}
