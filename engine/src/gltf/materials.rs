//! glTF materials and the images they use: decoding once per (image, colour space), texture
//! transforms, and the forgiving handling of textures that cannot be loaded (see the parent
//! module's docs).

use super::*;
use crate::image::{ImageError, TexelFormat};

/// `KHR_texture_basisu`: a texture's image in a KTX2 container (`source` in the extension),
/// beside or instead of a PNG/JPEG one.
pub(super) const TEXTURE_BASISU: &str = "KHR_texture_basisu";

/// The image a texture samples: its `KHR_texture_basisu` KTX2 image when it has one, else its
/// own `source` (`None`: neither, a broken document).
pub(super) fn texture_image<'a>(texture: &::gltf::Texture<'a>, document: &'a Document) -> Option<::gltf::Image<'a>> {
    let ktx2 = texture.extension_value(TEXTURE_BASISU).and_then(|e| e.get("source")).and_then(::gltf::json::Value::as_u64);
    ktx2.and_then(|i| document.images().nth(i as usize)).or_else(|| texture.source())
}

/// Loads the images materials use, once per (image, role): KTX2 images as they are, PNG and
/// JPEG ones compressed through the cache or decoded to RGBA8 ([`LoadOptions::textures`]).
pub(super) struct ImageLoader<'a> {
    document: &'a Document,
    buffers: &'a [Vec<u8>],
    base: Option<&'a Path>,
    /// The glTF file, for messages about embedded images.
    file: &'a Path,
    pub(super) images: Vec<Image>,
    slots: HashMap<(usize, TextureRole), usize>,
    /// The slot of [`Image::missing_texture`], once a base colour texture needed it.
    placeholder: Option<usize>,
    /// `Some` when PNG and JPEG images are compressed; the cache, when there is one.
    compress: Option<Option<TextureCache>>,
    /// Images some material uses as its metallic-roughness texture: as occlusion too they stay
    /// BC7 data (one texture for both) rather than becoming a second, BC4 one.
    metallic_roughness: std::collections::HashSet<usize>,
    progress: Option<TextureProgress>,
    /// How many (image, role) pairs the materials use, and how many are done.
    total: usize,
    pub(super) stats: TextureImportStats,
}

impl<'a> ImageLoader<'a> {
    pub(super) fn new(
        document: &'a Document,
        buffers: &'a [Vec<u8>],
        base: Option<&'a Path>,
        file: &'a Path,
        options: &LoadOptions,
    ) -> ImageLoader<'a> {
        let metallic_roughness = document
            .materials()
            .filter_map(|m| m.pbr_metallic_roughness().metallic_roughness_texture())
            .flat_map(|info| [texture_image(&info.texture(), document).map(|i| i.index()), info.texture().source().map(|i| i.index())])
            .flatten()
            .collect();
        let compress = match &options.textures {
            TextureImport::Rgba8 => None,
            TextureImport::Compressed(location) => Some(location.cache()),
        };
        let mut loader = ImageLoader {
            document,
            buffers,
            base,
            file,
            images: Vec::new(),
            slots: HashMap::new(),
            placeholder: None,
            compress,
            metallic_roughness,
            progress: options.progress.clone(),
            total: 0,
            stats: TextureImportStats::default(),
        };
        let pairs: std::collections::HashSet<(usize, TextureRole)> = document
            .materials()
            .flat_map(|m| material_textures(&m))
            .filter_map(|(texture, role)| texture_image(&texture, document).map(|image| (image.index(), loader.role(role, image.index()))))
            .collect();
        loader.total = pairs.len();
        loader
    }

    /// The role an image is loaded in for a slot of `role`: occlusion that shares the
    /// metallic-roughness image is data.
    fn role(&self, role: TextureRole, image: usize) -> TextureRole {
        if role == TextureRole::Mask && self.metallic_roughness.contains(&image) { TextureRole::Data } else { role }
    }

    fn placeholder(&mut self) -> usize {
        *self.placeholder.get_or_insert_with(|| {
            self.images.push(Image::missing_texture());
            self.images.len() - 1
        })
    }

    fn get(&mut self, info: &::gltf::Texture<'_>, tex_coord: u32, role: TextureRole) -> Result<usize, GltfError> {
        if tex_coord != 0 {
            warn!(texture = info.index(), tex_coord, "only TEXCOORD_0 is supported; using it");
        }
        // A KTX2 image this loader cannot use (Basis Universal, supercompressed) falls back to the
        // texture's own PNG/JPEG source when it has one, with a warning; without one the
        // texture gets the placeholder, as an undecodable PNG does.
        let ktx2 = texture_image(info, self.document).filter(|image| info.source().is_none_or(|s| s.index() != image.index()));
        let fallback = info.source();
        let source = match (ktx2, fallback) {
            (Some(ktx2), fallback) => match self.get_image(&ktx2, role) {
                Ok(slot) => return Ok(slot),
                Err(error) => match fallback {
                    Some(fallback) => {
                        warn!(texture = info.index(), %error, "the texture's KTX2 image cannot be used; using its other source");
                        fallback
                    }
                    None => return Err(error),
                },
            },
            (None, Some(source)) => source,
            (None, None) => {
                return Err(GltfError::Image {
                    uri_or_index: format!("of texture #{} in {}", info.index(), self.file.display()),
                    source: ImageError::Ktx2 { what: format!("texture #{}", info.index()), reason: "the texture names no image".into() },
                });
            }
        };
        self.get_image(&source, role)
    }

    /// Loads `source` (a PNG, JPEG or KTX2 image) for `role`, once.
    fn get_image(&mut self, source: &::gltf::Image<'_>, role: TextureRole) -> Result<usize, GltfError> {
        let (index, role) = (source.index(), self.role(role, source.index()));
        if let Some(&slot) = self.slots.get(&(index, role)) {
            return Ok(slot);
        }
        let describe = describe_image(source, self.file);
        let error = |source| GltfError::Image { uri_or_index: describe.clone(), source };
        // As RGBA8, the same image in another role reuses the decoded level 0.
        let decoded = self
            .slots
            .iter()
            .filter(|((i, _), _)| *i == index)
            .map(|(_, &slot)| &self.images[slot])
            .find(|image| image.format == TexelFormat::Rgba8 && self.compress.is_none());
        let (image, how) = if let Some(decoded) = decoded {
            let image = Image::from_rgba8_for(decoded.width, decoded.height, decoded.mips[0].clone(), role).map_err(error)?;
            (image, TextureSource::Reused)
        } else {
            let bytes = match source.source() {
                ::gltf::image::Source::Uri { uri, .. } => read_uri(uri, self.base)?,
                ::gltf::image::Source::View { view, .. } => view_bytes(&view, self.buffers)
                    .ok_or_else(|| GltfError::BadBuffer {
                        buffer: format!("#{} of {}", view.buffer().index(), self.file.display()),
                        reason: format!("view {} of image {describe} lies outside the buffer", view.index()),
                    })?
                    .to_vec(),
            };
            let decode = || Image::decode_rgba8(&bytes);
            if bytes.starts_with(KTX2_IDENTIFIER) {
                (Image::from_ktx2_for(&bytes, role, &describe).map_err(error)?, TextureSource::Ktx2)
            } else {
                match &self.compress {
                    None => {
                        let (width, height, rgba) = decode().map_err(error)?;
                        (Image::from_rgba8_for(width, height, rgba, role).map_err(error)?, TextureSource::Rgba8)
                    }
                    Some(None) => {
                        let (width, height, rgba) = decode().map_err(error)?;
                        (Image::compress(width, height, rgba, role).map_err(error)?, TextureSource::Compressed)
                    }
                    Some(Some(cache)) => {
                        let (image, outcome) = cache.load_or_compress(&bytes, role, &describe, decode).map_err(error)?;
                        (image, TextureSource::from(&outcome))
                    }
                }
            }
        };
        self.images.push(image);
        let slot = self.images.len() - 1;
        self.slots.insert((index, role), slot);
        self.stats.count(how);
        if let Some(progress) = &self.progress {
            let done = self.slots.len();
            progress(&TextureEvent { done, total: self.total.max(done), image: &describe, import: how });
        }
        Ok(slot)
    }
}

/// The first bytes of every KTX2 file.
const KTX2_IDENTIFIER: &[u8] = &[0xAB, 0x4B, 0x54, 0x58, 0x20, 0x32, 0x30, 0xBB, 0x0D, 0x0A, 0x1A, 0x0A];

/// An image's URI, or its index and name in `file` when embedded.
pub(super) fn describe_image(image: &::gltf::Image<'_>, file: &Path) -> String {
    match (image.source(), image.name()) {
        (::gltf::image::Source::Uri { uri, .. }, _) => short_uri(uri),
        (_, Some(name)) => format!("#{} '{name}' in {}", image.index(), file.display()),
        (_, None) => format!("#{} in {}", image.index(), file.display()),
    }
}

/// The bytes of a buffer view, if they lie inside its buffer.
pub(super) fn view_bytes<'b>(view: &::gltf::buffer::View<'_>, buffers: &'b [Vec<u8>]) -> Option<&'b [u8]> {
    let buffer = buffers.get(view.buffer().index())?;
    let end = view.offset().checked_add(view.length())?;
    buffer.get(view.offset()..end)
}

/// A `KHR_texture_transform`: `uv' = T(offset) · R(rotation) · S(scale) · uv`.
#[derive(Clone, Copy, Debug, PartialEq)]
pub(super) struct UvTransform {
    offset: [f32; 2],
    rotation: f32,
    scale: [f32; 2],
}

impl UvTransform {
    const IDENTITY: UvTransform = UvTransform { offset: [0.0; 2], rotation: 0.0, scale: [1.0; 2] };

    /// The transform and its `texCoord` override.
    fn from_json(json: &::gltf::json::extensions::texture::TextureTransform) -> (UvTransform, Option<u32>) {
        (UvTransform { offset: json.offset.0, rotation: json.rotation.0, scale: json.scale.0 }, json.tex_coord)
    }

    /// The extension's matrix: rotation is counter-clockwise in UV space whose V points down,
    /// i.e. `[cos sin; -sin cos]`.
    pub(super) fn apply(&self, uv: [f32; 2]) -> [f32; 2] {
        let (sin, cos) = self.rotation.sin_cos();
        let (x, y) = (uv[0] * self.scale[0], uv[1] * self.scale[1]);
        [cos * x + sin * y + self.offset[0], -sin * x + cos * y + self.offset[1]]
    }
}

/// One texture reference of a material, before its image is loaded.
pub(super) struct TextureSlot<'a> {
    slot: &'static str,
    texture: ::gltf::Texture<'a>,
    tex_coord: u32,
    transform: Option<UvTransform>,
    role: TextureRole,
}

impl<'a> TextureSlot<'a> {
    /// `transform` is the parsed extension and its `texCoord` override.
    fn new(
        slot: &'static str,
        texture: ::gltf::Texture<'a>,
        tex_coord: u32,
        transform: Option<(UvTransform, Option<u32>)>,
        role: TextureRole,
    ) -> Self {
        let tex_coord = transform.and_then(|(_, set)| set).unwrap_or(tex_coord);
        TextureSlot { slot, texture, tex_coord, transform: transform.map(|(t, _)| t), role }
    }

    fn from_info(slot: &'static str, info: Option<::gltf::texture::Info<'a>>, role: TextureRole) -> Option<Self> {
        info.map(|i| {
            let transform = i
                .texture_transform()
                .map(|t| (UvTransform { offset: t.offset(), rotation: t.rotation(), scale: t.scale() }, t.tex_coord()));
            TextureSlot::new(slot, i.texture(), i.tex_coord(), transform, role)
        })
    }
}

/// A material's textures and the role each is loaded in (occlusion as a lone mask; see
/// [`ImageLoader::role`]).
fn material_textures<'a>(m: &::gltf::Material<'a>) -> impl Iterator<Item = (::gltf::Texture<'a>, TextureRole)> + use<'a> {
    let pbr = m.pbr_metallic_roughness();
    [
        pbr.base_color_texture().map(|i| (i.texture(), TextureRole::Color)),
        pbr.metallic_roughness_texture().map(|i| (i.texture(), TextureRole::Data)),
        m.normal_texture().map(|n| (n.texture(), TextureRole::Normal)),
        m.occlusion_texture().map(|o| (o.texture(), TextureRole::Mask)),
        m.emissive_texture().map(|i| (i.texture(), TextureRole::Color)),
    ]
    .into_iter()
    .flatten()
}

/// Whether a texture error may be replaced by a placeholder (the image's bytes are missing,
/// unreadable or undecodable) rather than refused (bad URIs, views outside their buffer).
pub(super) fn is_forgivable(error: &GltfError) -> bool {
    matches!(error, GltfError::MissingFile { .. } | GltfError::Io { .. } | GltfError::Image { .. })
}

pub(super) fn load_material(
    m: &::gltf::Material<'_>,
    document: &Document,
    images: &mut ImageLoader<'_>,
    options: &LoadOptions,
    faults: &mut Faults,
) -> Result<(GltfMaterial, Option<UvTransform>), GltfError> {
    let label = match (m.name(), m.index()) {
        (Some(name), Some(index)) => format!("'{name}' (#{index})"),
        (None, Some(index)) => format!("#{index}"),
        (Some(name), None) => format!("'{name}'"),
        (None, None) => "default".to_owned(),
    };
    // The gltf crate parses KHR_texture_transform on texture infos only; on the normal and
    // occlusion textures it stays among the unparsed extensions.
    let json = m.index().and_then(|i| document.as_json().materials.get(i));
    let parse_transform = |value: Option<&::gltf::json::Value>| {
        value.and_then(|v| match ::gltf::json::deserialize::from_value(v.clone()) {
            Ok(transform) => Some(UvTransform::from_json(&transform)),
            Err(error) => {
                warn!(material = %label, %error, "malformed KHR_texture_transform ignored");
                None
            }
        })
    };
    let normal_ext = json.and_then(|j| j.normal_texture.as_ref()).and_then(|t| t.extensions.as_ref());
    let normal_transform = parse_transform(normal_ext.and_then(|e| e.others.get("KHR_texture_transform")));
    let occlusion_ext = json.and_then(|j| j.occlusion_texture.as_ref()).and_then(|t| t.extensions.as_ref());
    let occlusion_transform = parse_transform(occlusion_ext.and_then(|e| e.others.get("KHR_texture_transform")));

    let pbr = m.pbr_metallic_roughness();
    let normal = m.normal_texture();
    let occlusion = m.occlusion_texture();
    let slots: [Option<TextureSlot<'_>>; 5] = [
        TextureSlot::from_info("base colour", pbr.base_color_texture(), TextureRole::Color),
        TextureSlot::from_info("metallic-roughness", pbr.metallic_roughness_texture(), TextureRole::Data),
        normal.as_ref().map(|n| TextureSlot::new("normal", n.texture(), n.tex_coord(), normal_transform, TextureRole::Normal)),
        occlusion.as_ref().map(|o| TextureSlot::new("occlusion", o.texture(), o.tex_coord(), occlusion_transform, TextureRole::Mask)),
        TextureSlot::from_info("emissive", m.emissive_texture(), TextureRole::Color),
    ];

    // One UV set serves every texture: bake the shared transform, or the first slot's (base
    // colour first) with one warning when they disagree.
    let transforms: Vec<UvTransform> = slots.iter().flatten().map(|s| s.transform.unwrap_or(UvTransform::IDENTITY)).collect();
    let uv_transform = transforms.first().copied().filter(|t| *t != UvTransform::IDENTITY);
    if transforms.windows(2).any(|w| w[0] != w[1]) {
        warn!(
            material = %label,
            "the material's textures use different KHR_texture_transforms; only one UV set exists, so the {} texture's is applied to all",
            slots.iter().flatten().next().map_or("", |s| s.slot)
        );
    }

    // Load each image; forgivable failures are gathered per file for one warning each.
    let mut failures: Vec<(String, String, Vec<&'static str>)> = Vec::new();
    let mut loaded = [None; 5];
    for (out, slot) in loaded.iter_mut().zip(&slots) {
        let Some(slot) = slot else { continue };
        match images.get(&slot.texture, slot.tex_coord, slot.role) {
            Ok(index) => *out = Some(index),
            Err(error) if !options.strict_textures && is_forgivable(&error) => {
                let file = texture_image(&slot.texture, images.document)
                    .map_or_else(|| format!("texture #{}", slot.texture.index()), |image| describe_image(&image, images.file));
                match failures.iter_mut().find(|(f, _, _)| *f == file) {
                    Some((_, _, slots)) => slots.push(slot.slot),
                    None => failures.push((file, error.to_string(), vec![slot.slot])),
                }
                if slot.slot == "base colour" {
                    *out = Some(images.placeholder());
                }
            }
            Err(error) => return Err(error),
        }
    }
    for (file, error, slots) in failures {
        let replacement = if slots.contains(&"base colour") {
            "the base colour uses a magenta/black checker, other textures from it are left out"
        } else {
            "the material is drawn as if it had no such texture"
        };
        warn!(file = %file, material = %label, textures = %slots.join(", "), %error, "glTF texture could not be loaded; {replacement}");
    }
    let [base_color_texture, metallic_roughness_texture, normal_texture, occlusion_texture, emissive_texture] = loaded;
    let mut material = GltfMaterial {
        name: m.name().map(str::to_owned),
        base_color: Vec4::from(pbr.base_color_factor()),
        base_color_texture,
        metallic: pbr.metallic_factor(),
        roughness: pbr.roughness_factor(),
        metallic_roughness_texture,
        normal_texture,
        normal_scale: normal.map_or(1.0, |n| n.scale()),
        occlusion_texture,
        occlusion_strength: occlusion.map_or(1.0, |o| o.strength()),
        emissive: Vec3::from(m.emissive_factor()) * m.emissive_strength().unwrap_or(1.0),
        emissive_texture,
        alpha_mode: match m.alpha_mode() {
            ::gltf::material::AlphaMode::Opaque => AlphaMode::Opaque,
            ::gltf::material::AlphaMode::Mask => AlphaMode::Mask(m.alpha_cutoff().unwrap_or(0.5)),
            ::gltf::material::AlphaMode::Blend => AlphaMode::Blend,
        },
        double_sided: m.double_sided(),
        ior: m.ior().unwrap_or(1.5),
        thickness: m.volume().map_or(0.0, |v| v.thickness_factor()),
    };
    let repaired = repair_factors(&mut material);
    if let (false, Some(index)) = (repaired.is_empty(), m.index()) {
        let part = GltfPart::Material { index, name: m.name().map(str::to_owned) };
        let problem = format!("its {} not finite", repaired.join(", "));
        faults.push(part, GltfFaultKind::BadMaterial, problem, "each takes glTF's default value");
    }
    Ok((material, uv_transform))
}

/// Replaces the material's factors that are not finite by glTF's defaults (base colour,
/// metallic, roughness, normal scale and occlusion strength 1, emissive 0, alpha cutoff 0.5,
/// index of refraction 1.5, thickness 0), and names them.
fn repair_factors(material: &mut GltfMaterial) -> Vec<&'static str> {
    let mut repaired = Vec::new();
    let mut repair = |finite: bool, name: &'static str| {
        if !finite {
            repaired.push(name);
        }
        !finite
    };
    if repair(material.base_color.is_finite(), "base colour") {
        material.base_color = Vec4::ONE;
    }
    if repair(material.metallic.is_finite(), "metallic factor") {
        material.metallic = 1.0;
    }
    if repair(material.roughness.is_finite(), "roughness factor") {
        material.roughness = 1.0;
    }
    if repair(material.normal_scale.is_finite(), "normal scale") {
        material.normal_scale = 1.0;
    }
    if repair(material.occlusion_strength.is_finite(), "occlusion strength") {
        material.occlusion_strength = 1.0;
    }
    if repair(material.emissive.is_finite(), "emissive factor (times its strength)") {
        material.emissive = Vec3::ZERO;
    }
    if let AlphaMode::Mask(cutoff) = material.alpha_mode
        && repair(cutoff.is_finite(), "alpha cutoff")
    {
        material.alpha_mode = AlphaMode::Mask(0.5);
    }
    if repair(material.ior.is_finite(), "index of refraction") {
        material.ior = 1.5;
    }
    if repair(material.thickness.is_finite(), "thickness") {
        material.thickness = 0.0;
    }
    repaired
}
