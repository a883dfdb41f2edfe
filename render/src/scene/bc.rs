//! Block-compressed textures decoded to RGBA8, for a device that cannot sample BC formats
//! (`textureCompressionBC` off: none this renderer runs on, every desktop GPU has it; tests
//! reach this path with `DeviceSettings::without_texture_compression`). The decoder is the
//! `bcdec_rs` crate, a safe pure-Rust port of Sergii Kudlai's `bcdec` (from the `image_dds`
//! project), for BC1, BC3, BC4, BC5 and BC7. The texture then takes four times the memory
//! (eight times for BC1 and BC4) and samples as the same format would: BC4 as `(r, 0, 0, 1)`,
//! BC5 as `(r, g, 0, 1)`, BC1 without alpha opaque, sRGB formats as `R8G8B8A8_SRGB`.

use ash::vk;

use crate::scene::{TextureData, level_bytes};

/// Whether `format` is one [`decode_to_rgba8`] decodes.
pub fn is_block_compressed(format: vk::Format) -> bool {
    use vk::Format as F;
    matches!(
        format,
        F::BC1_RGB_UNORM_BLOCK
            | F::BC1_RGB_SRGB_BLOCK
            | F::BC1_RGBA_UNORM_BLOCK
            | F::BC1_RGBA_SRGB_BLOCK
            | F::BC3_UNORM_BLOCK
            | F::BC3_SRGB_BLOCK
            | F::BC4_UNORM_BLOCK
            | F::BC5_UNORM_BLOCK
            | F::BC7_UNORM_BLOCK
            | F::BC7_SRGB_BLOCK
    )
}

/// `texture` decoded to RGBA8 level by level (`None`: not a block-compressed format this
/// decodes, or a level of the wrong size).
pub fn decode_to_rgba8(texture: &TextureData) -> Option<TextureData> {
    use vk::Format as F;
    if !is_block_compressed(texture.format) {
        return None;
    }
    let srgb = matches!(texture.format, F::BC1_RGB_SRGB_BLOCK | F::BC1_RGBA_SRGB_BLOCK | F::BC3_SRGB_BLOCK | F::BC7_SRGB_BLOCK);
    let block_bytes = level_bytes(texture.format, 4, 4)? as usize;
    let mips = texture
        .mips
        .iter()
        .enumerate()
        .map(|(level, blocks)| {
            let (w, h) = ((texture.width >> level).max(1) as usize, (texture.height >> level).max(1) as usize);
            if blocks.len() as u64 != level_bytes(texture.format, w as u32, h as u32)? {
                return None;
            }
            let mut rgba = vec![0u8; w * h * 4];
            let mut block = [0u8; 64];
            for (i, data) in blocks.chunks_exact(block_bytes).enumerate() {
                let (bx, by) = (i % w.div_ceil(4) * 4, i / w.div_ceil(4) * 4);
                decode_block(texture.format, data, &mut block);
                for y in 0..4.min(h - by) {
                    for x in 0..4.min(w - bx) {
                        let at = ((by + y) * w + bx + x) * 4;
                        rgba[at..at + 4].copy_from_slice(&block[(y * 4 + x) * 4..][..4]);
                    }
                }
            }
            Some(rgba)
        })
        .collect::<Option<Vec<_>>>()?;
    let format = if srgb { F::R8G8B8A8_SRGB } else { F::R8G8B8A8_UNORM };
    Some(TextureData { width: texture.width, height: texture.height, format, mips })
}

/// One block of `format` decoded into 4×4 RGBA8 texels.
fn decode_block(format: vk::Format, data: &[u8], out: &mut [u8; 64]) {
    use vk::Format as F;
    match format {
        F::BC1_RGB_UNORM_BLOCK | F::BC1_RGB_SRGB_BLOCK => {
            bcdec_rs::bc1(data, out, 16);
            out.chunks_exact_mut(4).for_each(|t| t[3] = 255);
        }
        F::BC1_RGBA_UNORM_BLOCK | F::BC1_RGBA_SRGB_BLOCK => bcdec_rs::bc1(data, out, 16),
        F::BC3_UNORM_BLOCK | F::BC3_SRGB_BLOCK => bcdec_rs::bc3(data, out, 16),
        F::BC7_UNORM_BLOCK | F::BC7_SRGB_BLOCK => bcdec_rs::bc7(data, out, 16),
        F::BC4_UNORM_BLOCK => {
            let mut red = [0u8; 16];
            bcdec_rs::bc4(data, &mut red, 4, false);
            for (t, r) in out.chunks_exact_mut(4).zip(red) {
                t.copy_from_slice(&[r, 0, 0, 255]);
            }
        }
        _ => {
            let mut rg = [0u8; 32];
            bcdec_rs::bc5(data, &mut rg, 8, false);
            for (t, c) in out.chunks_exact_mut(4).zip(rg.chunks_exact(2)) {
                t.copy_from_slice(&[c[0], c[1], 0, 255]);
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn blocks_decode_to_their_colours_and_partial_blocks_are_clipped() {
        // BC1 with both endpoints 0x07FF (R5 0, G6 63, B5 31): cyan, opaque; a 6×3 level spans
        // 2×1 blocks, the second one clipped to 2×3 texels.
        let cyan = [0xFF, 0x07, 0xFF, 0x07, 0, 0, 0, 0];
        let texture = TextureData { width: 6, height: 3, format: vk::Format::BC1_RGB_SRGB_BLOCK, mips: vec![cyan.repeat(2)] };
        let rgba = decode_to_rgba8(&texture).expect("BC1 decodes");
        assert_eq!((rgba.format, rgba.mips[0].len()), (vk::Format::R8G8B8A8_SRGB, 6 * 3 * 4));
        assert!(rgba.mips[0].chunks_exact(4).all(|t| t == [0, 255, 255, 255]), "{:?}", &rgba.mips[0][..8]);

        // BC4 with both endpoints 200: red 200, samples as (r, 0, 0, 1).
        let red = TextureData { width: 4, height: 4, format: vk::Format::BC4_UNORM_BLOCK, mips: vec![vec![200, 200, 0, 0, 0, 0, 0, 0]] };
        assert!(decode_to_rgba8(&red).unwrap().mips[0].chunks_exact(4).all(|t| t == [200, 0, 0, 255]));

        assert!(decode_to_rgba8(&TextureData { mips: vec![cyan.to_vec()], ..texture.clone() }).is_none(), "a level one block short");
        let plain = TextureData { format: vk::Format::R8G8B8A8_UNORM, ..texture };
        assert!(decode_to_rgba8(&plain).is_none(), "RGBA8 is not decoded");
    }
}
