//! KTX2 containers (Khronos, KTX 2.0 specification): 2D textures read with their levels used as
//! they are, Basis Universal ones transcoded, and containers written (the texture import
//! cache's files, [`super::cache`]). The `ktx2` crate parses and validates containers and
//! serialises their header, level index and data format descriptor; this module lays them out.
//!
//! **Basis Universal** (`KHR_texture_basisu`'s payload: ETC1S with BasisLZ supercompression, or
//! UASTC, raw or Zstandard-supercompressed) is transcoded at load by the `basisu` crate, a
//! pure-Rust port of Binomial's reference transcoder that its author verified byte for byte
//! against it, to the format the texture's [`TextureRole`] asks for: BC7 for colour and data,
//! BC5 for two-channel normal maps (Basis Universal's layout, X in RGB and Y in alpha, which
//! `KHR_texture_basisu` recommends; BC7 for a three-channel one), BC4 for a lone occlusion map. The
//! `basis-universal` crate (bindings to the C++ library) was the alternative; its 0.3 bindings
//! transcode `.basis` files only, not KTX2 containers, and would add a C++ build to every CI run.

use super::*;
use ::ktx2::Format as F;

/// The Vulkan format a texel format and colour space is stored as (BC4 and BC5 have no sRGB
/// form: they hold linear data only).
fn ktx2_format(format: TexelFormat, color_space: ColorSpace) -> F {
    let srgb = color_space == ColorSpace::Srgb;
    match (format, srgb) {
        (TexelFormat::Rgba8, false) => F::R8G8B8A8_UNORM,
        (TexelFormat::Rgba8, true) => F::R8G8B8A8_SRGB,
        (TexelFormat::Bc1, false) => F::BC1_RGBA_UNORM_BLOCK,
        (TexelFormat::Bc1, true) => F::BC1_RGBA_SRGB_BLOCK,
        (TexelFormat::Bc1Rgb, false) => F::BC1_RGB_UNORM_BLOCK,
        (TexelFormat::Bc1Rgb, true) => F::BC1_RGB_SRGB_BLOCK,
        (TexelFormat::Bc3, false) => F::BC3_UNORM_BLOCK,
        (TexelFormat::Bc3, true) => F::BC3_SRGB_BLOCK,
        (TexelFormat::Bc4, _) => F::BC4_UNORM_BLOCK,
        (TexelFormat::Bc5, _) => F::BC5_UNORM_BLOCK,
        (TexelFormat::Bc7, false) => F::BC7_UNORM_BLOCK,
        (TexelFormat::Bc7, true) => F::BC7_SRGB_BLOCK,
    }
}

/// Transcodes a Basis Universal KTX2 container (a universal format: ETC1S or UASTC) to the BC
/// format of `role`, every level it holds.
fn transcode_basis(bytes: &[u8], role: TextureRole, what: &str) -> Result<Image, ImageError> {
    let fail = |reason: String| ImageError::Ktx2 { what: what.to_string(), reason };
    let transcoder =
        ::basisu::Transcoder::new(bytes).map_err(|e| fail(format!("not a Basis Universal texture the transcoder can read ({e:?})")))?;
    if transcoder.layer_count() > 1 || transcoder.face_count() > 1 || transcoder.is_video() {
        return Err(fail("a Basis Universal array, cube map or video, not a 2D texture".to_string()));
    }
    let (width, height) = transcoder.base_dimensions();
    let levels = transcoder.level_count().max(1);
    check_size(width, height, levels as usize).map_err(|e| fail(e.to_string()))?;
    // A two-channel normal map follows Basis Universal's layout (X in RGB, Y in alpha), which the
    // transcoder's BC5 reads; one without alpha holds X, Y and Z in RGB and stays BC7.
    let (target, format) = match role {
        TextureRole::Normal if transcoder.has_alpha() => (::basisu::TargetFormat::Bc5Rg, TexelFormat::Bc5),
        TextureRole::Color | TextureRole::Data | TextureRole::Normal => (::basisu::TargetFormat::Bc7Rgba, TexelFormat::Bc7),
        TextureRole::Mask => (::basisu::TargetFormat::Bc4R, TexelFormat::Bc4),
    };
    let mips = (0..levels)
        .map(|level| {
            transcoder
                .transcode(level, target, ::basisu::DecodeFlags::HIGH_QUALITY)
                .map_err(|e| fail(format!("level {level} cannot be transcoded to {target:?} ({e:?})")))
        })
        .collect::<Result<Vec<_>, _>>()?;
    Image::from_blocks(width, height, role.color_space(), format, mips).map_err(|e| fail(e.to_string()))
}

impl Image {
    /// Reads a KTX2 container of a 2D texture in BC1, BC3, BC4, BC5, BC7 or RGBA8 (its levels
    /// used as they are, as many as it holds) or in Basis Universal (transcoded to BC7);
    /// `color_space` is how the material uses it (the blocks are the same either way). Other
    /// formats and supercompressed non-Basis containers are refused with the reason; errors
    /// name `what`.
    pub fn from_ktx2(bytes: &[u8], color_space: ColorSpace, what: &str) -> Result<Image, ImageError> {
        let role = match color_space {
            ColorSpace::Srgb => TextureRole::Color,
            ColorSpace::Linear => TextureRole::Data,
        };
        Image::from_ktx2_for(bytes, role, what)
    }

    /// [`Image::from_ktx2`] for a texture of `role`: BC and RGBA8 levels are used as they are
    /// (in the role's colour space); Basis Universal ones are transcoded to the role's format
    /// (see the module docs).
    pub fn from_ktx2_for(bytes: &[u8], role: TextureRole, what: &str) -> Result<Image, ImageError> {
        let color_space = role.color_space();
        let fail = |reason: String| ImageError::Ktx2 { what: what.to_string(), reason };
        let reader = ::ktx2::Reader::new(bytes).map_err(|e| fail(format!("not a valid KTX2 container ({e})")))?;
        let header = reader.header();
        if header.format.is_none() {
            return transcode_basis(bytes, role, what);
        }
        if let Some(scheme) = header.supercompression_scheme {
            return Err(fail(format!(
                "a {:?} level supercompressed with {scheme:?}, which only Basis Universal containers may be",
                header.format
            )));
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
            None => unreachable!("universal formats are transcoded above"),
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

    /// This image as a KTX2 container: the Vulkan format of its texel format and colour space,
    /// every level it holds (smallest first in the file, as the specification orders them, each
    /// aligned to its block size), a basic data format descriptor, and `key_values` (besides
    /// `KTXwriter`) as UTF-8 metadata that [`Image::ktx2_value`] reads back.
    pub fn to_ktx2(&self, key_values: &[(&str, &str)]) -> Vec<u8> {
        let format = ktx2_format(self.format, self.color_space);
        let (basic, type_size) =
            ::ktx2::dfd::Basic::from_format(format).expect("the ktx2 crate describes every format TexelFormat maps to");
        let block = ::ktx2::dfd::Block::Basic(basic).to_vec();
        let mut dfd = ((4 + block.len()) as u32).to_le_bytes().to_vec();
        dfd.extend(block);

        let writer = concat!("ecs-decals engine ", env!("CARGO_PKG_VERSION"));
        let mut entries: Vec<(&str, &str)> = key_values.iter().copied().chain([("KTXwriter", writer)]).collect();
        entries.sort_by_key(|(key, _)| *key);
        let mut kvd = Vec::new();
        for (key, value) in entries {
            let length = key.len() + 1 + value.len() + 1;
            kvd.extend((length as u32).to_le_bytes());
            kvd.extend(key.as_bytes());
            kvd.push(0);
            kvd.extend(value.as_bytes());
            kvd.push(0);
            kvd.resize(kvd.len().next_multiple_of(4), 0);
        }

        let levels = self.mips.len();
        let dfd_offset = ::ktx2::Header::LENGTH + levels * ::ktx2::LevelIndex::LENGTH;
        let kvd_offset = dfd_offset + dfd.len();
        let alignment = match self.format {
            TexelFormat::Rgba8 => 4,
            TexelFormat::Bc1 | TexelFormat::Bc1Rgb | TexelFormat::Bc4 => 8,
            TexelFormat::Bc3 | TexelFormat::Bc5 | TexelFormat::Bc7 => 16,
        };
        let mut offset = kvd_offset + kvd.len();
        let mut index = vec![::ktx2::LevelIndex { byte_offset: 0, byte_length: 0, uncompressed_byte_length: 0 }; levels];
        for level in (0..levels).rev() {
            offset = offset.next_multiple_of(alignment);
            let length = self.mips[level].len() as u64;
            index[level] = ::ktx2::LevelIndex { byte_offset: offset as u64, byte_length: length, uncompressed_byte_length: length };
            offset += self.mips[level].len();
        }
        let header = ::ktx2::Header {
            format: Some(format),
            type_size,
            pixel_width: self.width,
            pixel_height: self.height,
            pixel_depth: 0,
            layer_count: 0,
            face_count: 1,
            level_count: levels as u32,
            supercompression_scheme: None,
            index: ::ktx2::Index {
                dfd_byte_offset: dfd_offset as u32,
                dfd_byte_length: dfd.len() as u32,
                kvd_byte_offset: if kvd.is_empty() { 0 } else { kvd_offset as u32 },
                kvd_byte_length: kvd.len() as u32,
                sgd_byte_offset: 0,
                sgd_byte_length: 0,
            },
        };
        let mut out = Vec::with_capacity(offset);
        out.extend(header.as_bytes());
        for entry in &index {
            out.extend(entry.as_bytes());
        }
        out.extend(dfd);
        out.extend(kvd);
        for level in (0..levels).rev() {
            out.resize(index[level].byte_offset as usize, 0);
            out.extend(&self.mips[level]);
        }
        out
    }

    /// The value of metadata `key` in a KTX2 container, as UTF-8 without its terminating NUL
    /// (`None`: not a container, no such key, or not UTF-8).
    pub fn ktx2_value(bytes: &[u8], key: &str) -> Option<String> {
        let reader = ::ktx2::Reader::new(bytes).ok()?;
        let value = reader.key_value_data().find(|(k, _)| *k == key)?.1;
        let value = value.strip_suffix(&[0]).unwrap_or(value);
        std::str::from_utf8(value).ok().map(str::to_owned)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn containers_written_read_back_level_for_level() {
        let block = |b: u8| vec![b; 16];
        // 8×4 in BC7: 2×1 blocks, then 1, 1, 1.
        let mips = vec![[block(1), block(2)].concat(), block(3), block(4), block(5)];
        let image = Image::from_blocks(8, 4, ColorSpace::Srgb, TexelFormat::Bc7, mips).unwrap();
        let bytes = image.to_ktx2(&[("ecs-decals.key", "abc")]);
        let reader = ::ktx2::Reader::new(&bytes[..]).expect("a valid container");
        assert_eq!(reader.header().format, Some(F::BC7_SRGB_BLOCK));
        assert_eq!(reader.transfer_function(), Some(::ktx2::TransferFunction::SRGB));
        assert_eq!(Image::from_ktx2(&bytes, ColorSpace::Srgb, "test").unwrap(), image);
        assert_eq!(Image::ktx2_value(&bytes, "ecs-decals.key").as_deref(), Some("abc"));
        assert_eq!(Image::ktx2_value(&bytes, "missing"), None);
        for level in reader.levels() {
            assert_eq!((level.data.as_ptr() as usize - bytes.as_ptr() as usize) % 16, 0, "each level is block-aligned");
        }

        let rgba = Image::from_rgba8(3, 5, (0..60).collect(), ColorSpace::Linear).unwrap();
        assert_eq!(Image::from_ktx2(&rgba.to_ktx2(&[]), ColorSpace::Linear, "test").unwrap(), rgba);
    }
}
