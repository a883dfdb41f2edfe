//! glTF 2.0 loading (`.gltf` with external or `data:` buffers and images, and `.glb`).
//!
//! Loading is split from spawning: [`load`]/[`load_slice`] parse the document, resolve every
//! buffer and image themselves (so that a missing `.bin` or `.png` is reported by its resolved
//! path, which `gltf::import`'s all-in-one error does not do), validate and convert every
//! accessor into a [`GltfScene`]; only then does [`GltfScene::spawn`] touch the [`World`]. A bad
//! file is therefore rejected with a [`GltfError`] before anything was spawned.
//!
//! Supported: metallic-roughness materials (base colour, normal, metallic-roughness, occlusion
//! and emissive textures, `KHR_materials_emissive_strength`, alpha mask/blend, double-sided),
//! `KHR_lights_punctual`, perspective cameras (`zfar` ignored: the projection is infinite
//! reverse-Z), node hierarchies with TRS or matrix transforms, triangle lists/strips/fans.
//! Accessors are read by this module (with bounds checks, strides and sparse substitution);
//! only the component types below are accepted, anything else is an error naming the mesh and
//! attribute: `POSITION`/`NORMAL` float VEC3, `TEXCOORD_0` float or normalised u8/u16 VEC2,
//! `TANGENT` float VEC4, indices u8/u16/u32 scalars (or none: `0..n`). Missing normals are
//! computed smooth, missing UVs are zero, missing tangents are generated (MikkTSpace). Samplers
//! and texture coordinate sets other than 0 are ignored with a warning.

use std::collections::HashMap;
use std::path::{Path, PathBuf};

use ::gltf::accessor::{DataType, Dimensions};
use ::gltf::mesh::Mode;
use ::gltf::{Accessor, Document, Gltf};
use bevy_ecs::prelude::*;
use glam::{Quat, Vec3, Vec4};
use thiserror::Error;
use tracing::{info, warn};

use crate::asset::{Assets, Handle};
use crate::camera::Camera;
use crate::image::{ColorSpace, Image, ImageError};
use crate::light::{DirectionalLight, PointLight, SpotLight};
use crate::material::{AlphaMode, Material};
use crate::mesh::{Mesh, MeshError, smooth_normals};
use crate::scene::{MeshInstance, Name};
use crate::transform::Transform;

/// Errors from loading a glTF file. Messages name the file, buffer, image, mesh or attribute.
#[derive(Error, Debug)]
pub enum GltfError {
    /// The glTF file itself could not be read.
    #[error("cannot read glTF file {path}: {source}")]
    Io {
        /// The file (or the resolved buffer/image path for non-"not found" errors).
        path: PathBuf,
        /// The OS error.
        source: std::io::Error,
    },
    /// The JSON or GLB container is malformed or fails glTF validation.
    #[error("cannot parse glTF file {path}: {source}")]
    Parse {
        /// The file (`<memory>` for [`load_slice`]).
        path: PathBuf,
        /// The parser's error.
        source: ::gltf::Error,
    },
    /// A buffer or image file referenced by the document does not exist.
    #[error("file referenced by the glTF document is missing: {path}")]
    MissingFile {
        /// The referenced URI resolved against the glTF file's directory.
        path: PathBuf,
    },
    /// A URI cannot be resolved (unsupported scheme, bad `data:` URI, or an external reference
    /// in a slice loaded without a base directory).
    #[error("cannot resolve URI {uri:?}: {reason}")]
    BadUri {
        /// The URI (truncated if it is a long `data:` URI).
        uri: String,
        /// Why.
        reason: String,
    },
    /// A buffer is missing or shorter than the document declares.
    #[error("buffer {buffer}: {reason}")]
    BadBuffer {
        /// The buffer's index and URI.
        buffer: String,
        /// Why.
        reason: String,
    },
    /// An attribute has a type this engine does not accept.
    #[error("mesh {mesh}: attribute {attribute} is {found}, which is not supported")]
    UnsupportedAttribute {
        /// The mesh name (or index) and primitive.
        mesh: String,
        /// The attribute (`POSITION`, `NORMAL`, `TEXCOORD_0`, `TANGENT`, `indices`).
        attribute: String,
        /// The accessor's type, e.g. `Vec2 F32`.
        found: String,
    },
    /// The primitive is not made of triangles.
    #[error("mesh {mesh}: primitive mode {mode} is not supported (triangles only)")]
    UnsupportedPrimitiveMode {
        /// The mesh name (or index) and primitive.
        mesh: String,
        /// The glTF mode, e.g. `Lines`.
        mode: String,
    },
    /// A required attribute is absent.
    #[error("mesh {mesh}: required attribute {attribute} is missing")]
    MissingAttribute {
        /// The mesh name (or index) and primitive.
        mesh: String,
        /// The attribute.
        attribute: String,
    },
    /// An accessor's data lies outside its buffer, or counts disagree.
    #[error("mesh {mesh}: attribute {attribute}: {reason}")]
    BadAccessor {
        /// The mesh name (or index) and primitive.
        mesh: String,
        /// The attribute.
        attribute: String,
        /// Why.
        reason: String,
    },
    /// The assembled mesh failed validation (e.g. an index out of range).
    #[error("mesh {mesh}: {source}")]
    Mesh {
        /// The mesh name (or index) and primitive.
        mesh: String,
        /// The validation error.
        source: MeshError,
    },
    /// An image could not be read or decoded.
    #[error("image {uri_or_index}: {source}")]
    Image {
        /// The image's URI, or its index and name when embedded.
        uri_or_index: String,
        /// The decoding error.
        source: ImageError,
    },
}

/// A material as loaded: like [`Material`], with textures as indices into [`GltfScene::images`].
#[derive(Clone, Debug, PartialEq)]
pub struct GltfMaterial {
    /// The material's name in the file.
    pub name: Option<String>,
    /// Linear RGBA base colour factor.
    pub base_color: Vec4,
    /// sRGB base colour image.
    pub base_color_texture: Option<usize>,
    /// Metallic factor.
    pub metallic: f32,
    /// Roughness factor.
    pub roughness: f32,
    /// Linear metallic (B) / roughness (G) image.
    pub metallic_roughness_texture: Option<usize>,
    /// Linear tangent-space normal map.
    pub normal_texture: Option<usize>,
    /// Normal map XY scale.
    pub normal_scale: f32,
    /// Linear occlusion image (R).
    pub occlusion_texture: Option<usize>,
    /// Occlusion strength.
    pub occlusion_strength: f32,
    /// Emissive factor times `KHR_materials_emissive_strength`.
    pub emissive: Vec3,
    /// sRGB emissive image.
    pub emissive_texture: Option<usize>,
    /// Alpha interpretation.
    pub alpha_mode: AlphaMode,
    /// Whether back faces are rendered.
    pub double_sided: bool,
}

impl Default for GltfMaterial {
    fn default() -> Self {
        let m = Material::default();
        GltfMaterial {
            name: None,
            base_color: m.base_color,
            base_color_texture: None,
            metallic: m.metallic,
            roughness: m.roughness,
            metallic_roughness_texture: None,
            normal_texture: None,
            normal_scale: m.normal_scale,
            occlusion_texture: None,
            occlusion_strength: m.occlusion_strength,
            emissive: m.emissive,
            emissive_texture: None,
            alpha_mode: m.alpha_mode,
            double_sided: m.double_sided,
        }
    }
}

impl GltfMaterial {
    /// The engine material, with image indices mapped through `images` (indices out of range
    /// become no texture).
    pub fn to_material(&self, images: &[Handle<Image>]) -> Material {
        let tex = |index: Option<usize>| index.and_then(|i| images.get(i).copied());
        Material {
            base_color: self.base_color,
            base_color_texture: tex(self.base_color_texture),
            metallic: self.metallic,
            roughness: self.roughness,
            metallic_roughness_texture: tex(self.metallic_roughness_texture),
            normal_texture: tex(self.normal_texture),
            normal_scale: self.normal_scale,
            occlusion_texture: tex(self.occlusion_texture),
            occlusion_strength: self.occlusion_strength,
            emissive: self.emissive,
            emissive_texture: tex(self.emissive_texture),
            alpha_mode: self.alpha_mode,
            double_sided: self.double_sided,
        }
    }
}

/// A `KHR_lights_punctual` light as the engine component it becomes.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum GltfLight {
    /// A point light.
    Point(PointLight),
    /// A spot light.
    Spot(SpotLight),
    /// A directional light.
    Directional(DirectionalLight),
}

/// A glTF node.
#[derive(Clone, Debug, PartialEq)]
pub struct GltfNode {
    /// The node's name in the file.
    pub name: Option<String>,
    /// Local transform (a matrix is decomposed into TRS).
    pub transform: Transform,
    /// Parent node index.
    pub parent: Option<usize>,
    /// Child node indices.
    pub children: Vec<usize>,
    /// Index into [`GltfScene::meshes`].
    pub mesh: Option<usize>,
    /// The node's light.
    pub light: Option<GltfLight>,
    /// The node's (perspective) camera.
    pub camera: Option<Camera>,
}

/// A fully loaded and validated glTF file, ready to [`spawn`](GltfScene::spawn).
#[derive(Clone, Debug)]
pub struct GltfScene {
    /// Name for the root entity: the file stem, or `glTF scene`.
    pub name: String,
    /// Per glTF mesh, its primitives as meshes with an index into [`GltfScene::materials`].
    pub meshes: Vec<Vec<(Mesh, usize)>>,
    /// The file's materials, plus a default material appended when a primitive has none.
    pub materials: Vec<GltfMaterial>,
    /// Decoded images with mips, one per (glTF image, colour space) pair that materials use.
    pub images: Vec<Image>,
    /// All nodes of the file, indexed as in the file.
    pub nodes: Vec<GltfNode>,
    /// The nodes of the default (or first) scene; all parentless nodes if there is no scene.
    pub roots: Vec<usize>,
}

/// Loads a `.gltf` or `.glb` file, resolving relative URIs against its directory.
pub fn load(path: &Path) -> Result<GltfScene, GltfError> {
    let bytes = std::fs::read(path).map_err(|source| GltfError::Io { path: path.to_owned(), source })?;
    let base = path.parent().unwrap_or(Path::new(""));
    let name = path.file_stem().map_or_else(|| "glTF scene".to_owned(), |s| s.to_string_lossy().into_owned());
    load_impl(&bytes, Some(base), path, name)
}

/// Loads glTF or GLB bytes; relative URIs resolve against `base_dir` (without one, only
/// embedded and `data:` resources are allowed).
pub fn load_slice(bytes: &[u8], base_dir: Option<&Path>) -> Result<GltfScene, GltfError> {
    load_impl(bytes, base_dir, Path::new("<memory>"), "glTF scene".to_owned())
}

fn load_impl(bytes: &[u8], base: Option<&Path>, file: &Path, name: String) -> Result<GltfScene, GltfError> {
    let Gltf { document, blob } = Gltf::from_slice(bytes).map_err(|source| GltfError::Parse { path: file.to_owned(), source })?;
    let buffers = load_buffers(&document, blob, base)?;
    let mut images = ImageLoader { buffers: &buffers, base, images: Vec::new(), slots: HashMap::new() };
    let mut materials = document.materials().map(|m| load_material(&m, &mut images)).collect::<Result<Vec<_>, _>>()?;
    let mut default_material = None;
    let mut meshes = Vec::with_capacity(document.meshes().len());
    for mesh in document.meshes() {
        let mut primitives = Vec::new();
        for primitive in mesh.primitives() {
            let label = match mesh.name() {
                Some(name) => format!("'{name}' (#{}) primitive {}", mesh.index(), primitive.index()),
                None => format!("#{} primitive {}", mesh.index(), primitive.index()),
            };
            let converted = load_primitive(&primitive, &buffers, &label)?;
            let material = match primitive.material().index() {
                Some(index) => index,
                None => *default_material.get_or_insert_with(|| {
                    materials.push(GltfMaterial::default());
                    materials.len() - 1
                }),
            };
            primitives.push((converted, material));
        }
        meshes.push(primitives);
    }
    let nodes = load_nodes(&document);
    let roots = match document.default_scene().or_else(|| document.scenes().next()) {
        Some(scene) => scene.nodes().map(|n| n.index()).collect(),
        None => (0..nodes.len()).filter(|&i| nodes[i].parent.is_none()).collect(),
    };
    let scene = GltfScene { name, meshes, materials, images: images.images, nodes, roots };
    info!(
        file = %file.display(),
        meshes = scene.meshes.len(),
        triangles = scene.triangle_count(),
        materials = scene.materials.len(),
        images = scene.images.len(),
        nodes = scene.nodes.len(),
        "loaded glTF"
    );
    Ok(scene)
}

impl GltfScene {
    /// Total triangles over all primitives (each mesh counted once, not per instance).
    pub fn triangle_count(&self) -> usize {
        self.meshes.iter().flatten().map(|(mesh, _)| mesh.triangle_count()).sum()
    }

    /// Adds the images, materials and meshes to the world's `Assets` (created if missing) and
    /// spawns the scene: a root entity (`Transform`, `Name`), one entity per node reachable from
    /// [`GltfScene::roots`] parented with `ChildOf`, one child entity with a [`MeshInstance`]
    /// per primitive, and light/camera components on their nodes. Returns the root entity.
    pub fn spawn(self, world: &mut World) -> Entity {
        let image_handles: Vec<Handle<Image>> = {
            let mut assets = world.get_resource_or_init::<Assets<Image>>();
            self.images.into_iter().map(|image| assets.add(image)).collect()
        };
        let material_handles: Vec<Handle<Material>> = {
            let mut assets = world.get_resource_or_init::<Assets<Material>>();
            self.materials.iter().map(|m| assets.add(m.to_material(&image_handles))).collect()
        };
        let mesh_handles: Vec<Vec<(Handle<Mesh>, usize)>> = {
            let mut assets = world.get_resource_or_init::<Assets<Mesh>>();
            self.meshes.into_iter().map(|prims| prims.into_iter().map(|(m, mat)| (assets.add(m), mat)).collect()).collect()
        };

        let root = world.spawn((Transform::IDENTITY, Name(self.name))).id();
        let mut visited = vec![false; self.nodes.len()];
        let mut stack: Vec<(usize, Entity)> = self.roots.iter().rev().map(|&n| (n, root)).collect();
        while let Some((index, parent)) = stack.pop() {
            let Some(node) = self.nodes.get(index) else {
                continue;
            };
            if std::mem::replace(&mut visited[index], true) {
                warn!(node = index, "glTF node reached twice; spawned once");
                continue;
            }
            let mut entity = world.spawn((node.transform, ChildOf(parent)));
            if let Some(name) = &node.name {
                entity.insert(Name(name.clone()));
            }
            match node.light {
                Some(GltfLight::Point(light)) => {
                    entity.insert(light);
                }
                Some(GltfLight::Spot(light)) => {
                    entity.insert(light);
                }
                Some(GltfLight::Directional(light)) => {
                    entity.insert(light);
                }
                None => {}
            }
            if let Some(camera) = node.camera {
                entity.insert(camera);
            }
            let id = entity.id();
            for &(mesh, material) in node.mesh.and_then(|m| mesh_handles.get(m)).into_iter().flatten() {
                let Some(&material) = material_handles.get(material) else {
                    continue;
                };
                world.spawn((Transform::IDENTITY, MeshInstance { mesh, material }, ChildOf(id)));
            }
            stack.extend(node.children.iter().rev().map(|&child| (child, id)));
        }
        root
    }
}

/// Shortens `data:` URIs for error messages.
fn short_uri(uri: &str) -> String {
    if uri.len() > 64 { format!("{}…", &uri[..uri.char_indices().nth(48).map_or(uri.len(), |(i, _)| i)]) } else { uri.to_owned() }
}

/// Decodes `%XX` escapes in a relative URI.
fn percent_decode(uri: &str) -> String {
    let bytes = uri.as_bytes();
    let mut out = Vec::with_capacity(bytes.len());
    let mut i = 0;
    while i < bytes.len() {
        let hex = bytes
            .get(i + 1..i + 3)
            .filter(|_| bytes[i] == b'%')
            .and_then(|h| std::str::from_utf8(h).ok())
            .and_then(|h| u8::from_str_radix(h, 16).ok());
        match hex {
            Some(byte) => {
                out.push(byte);
                i += 3;
            }
            None => {
                out.push(bytes[i]);
                i += 1;
            }
        }
    }
    String::from_utf8_lossy(&out).into_owned()
}

/// Reads the bytes a buffer or image URI refers to.
fn read_uri(uri: &str, base: Option<&Path>) -> Result<Vec<u8>, GltfError> {
    let bad = |reason: &str| GltfError::BadUri { uri: short_uri(uri), reason: reason.to_owned() };
    if uri.starts_with("data:") {
        // gltf's own base64 decoder (it pads the result to a multiple of 4 bytes, which
        // neither buffers nor PNG/JPEG decoders mind).
        return ::gltf::buffer::Data::from_source(::gltf::buffer::Source::Uri(uri), None)
            .map(|data| data.0)
            .map_err(|e| bad(&format!("invalid data URI: {e}")));
    }
    let relative = if let Some(path) = uri.strip_prefix("file://").or_else(|| uri.strip_prefix("file:")) {
        path
    } else if uri.contains(':') {
        return Err(bad("unsupported URI scheme"));
    } else {
        uri
    };
    let Some(base) = base else {
        return Err(bad("external file reference without a base directory"));
    };
    let path = base.join(percent_decode(relative));
    std::fs::read(&path).map_err(|source| {
        if source.kind() == std::io::ErrorKind::NotFound { GltfError::MissingFile { path } } else { GltfError::Io { path, source } }
    })
}

fn load_buffers(document: &Document, mut blob: Option<Vec<u8>>, base: Option<&Path>) -> Result<Vec<Vec<u8>>, GltfError> {
    document
        .buffers()
        .map(|buffer| {
            let (data, what) = match buffer.source() {
                ::gltf::buffer::Source::Bin => (
                    blob.take().ok_or_else(|| GltfError::BadBuffer {
                        buffer: format!("#{} (GLB BIN chunk)", buffer.index()),
                        reason: "the file has no BIN chunk".into(),
                    })?,
                    format!("#{} (GLB BIN chunk)", buffer.index()),
                ),
                ::gltf::buffer::Source::Uri(uri) => (read_uri(uri, base)?, format!("#{} ({})", buffer.index(), short_uri(uri))),
            };
            if data.len() < buffer.length() {
                return Err(GltfError::BadBuffer {
                    buffer: what,
                    reason: format!("{} bytes declared, {} found", buffer.length(), data.len()),
                });
            }
            Ok(data)
        })
        .collect()
}

/// Decodes the images materials use, once per (image, colour space).
struct ImageLoader<'a> {
    buffers: &'a [Vec<u8>],
    base: Option<&'a Path>,
    images: Vec<Image>,
    slots: HashMap<(usize, ColorSpace), usize>,
}

impl ImageLoader<'_> {
    fn get(&mut self, info: &::gltf::Texture<'_>, tex_coord: u32, cs: ColorSpace) -> Result<usize, GltfError> {
        if tex_coord != 0 {
            warn!(texture = info.index(), tex_coord, "only TEXCOORD_0 is supported; using it");
        }
        let source = info.source();
        let index = source.index();
        if let Some(&slot) = self.slots.get(&(index, cs)) {
            return Ok(slot);
        }
        // The same image in the other colour space: reuse the decoded level 0.
        let other = match cs {
            ColorSpace::Srgb => ColorSpace::Linear,
            ColorSpace::Linear => ColorSpace::Srgb,
        };
        let describe = || match (source.source(), source.name()) {
            (::gltf::image::Source::Uri { uri, .. }, _) => short_uri(uri),
            (_, Some(name)) => format!("#{index} '{name}'"),
            (_, None) => format!("#{index}"),
        };
        let image = if let Some(&slot) = self.slots.get(&(index, other)) {
            let decoded = &self.images[slot];
            Image::from_rgba8(decoded.width, decoded.height, decoded.mips[0].clone(), cs)
        } else {
            let bytes = match source.source() {
                ::gltf::image::Source::Uri { uri, .. } => read_uri(uri, self.base)?,
                ::gltf::image::Source::View { view, .. } => view_bytes(&view, self.buffers)
                    .ok_or_else(|| GltfError::BadBuffer {
                        buffer: format!("#{}", view.buffer().index()),
                        reason: format!("view {} of image {} lies outside the buffer", view.index(), describe()),
                    })?
                    .to_vec(),
            };
            Image::from_encoded(&bytes, cs)
        }
        .map_err(|source| GltfError::Image { uri_or_index: describe(), source })?;
        self.images.push(image);
        let slot = self.images.len() - 1;
        self.slots.insert((index, cs), slot);
        Ok(slot)
    }
}

/// The bytes of a buffer view, if they lie inside its buffer.
fn view_bytes<'b>(view: &::gltf::buffer::View<'_>, buffers: &'b [Vec<u8>]) -> Option<&'b [u8]> {
    let buffer = buffers.get(view.buffer().index())?;
    let end = view.offset().checked_add(view.length())?;
    buffer.get(view.offset()..end)
}

fn load_material(m: &::gltf::Material<'_>, images: &mut ImageLoader<'_>) -> Result<GltfMaterial, GltfError> {
    let pbr = m.pbr_metallic_roughness();
    let mut tex = |info: Option<(::gltf::Texture<'_>, u32)>, cs| -> Result<Option<usize>, GltfError> {
        info.map(|(texture, set)| images.get(&texture, set, cs)).transpose()
    };
    let base_color_texture = tex(pbr.base_color_texture().map(|i| (i.texture(), i.tex_coord())), ColorSpace::Srgb)?;
    let metallic_roughness_texture = tex(pbr.metallic_roughness_texture().map(|i| (i.texture(), i.tex_coord())), ColorSpace::Linear)?;
    let normal = m.normal_texture();
    let normal_texture = tex(normal.as_ref().map(|i| (i.texture(), i.tex_coord())), ColorSpace::Linear)?;
    let occlusion = m.occlusion_texture();
    let occlusion_texture = tex(occlusion.as_ref().map(|i| (i.texture(), i.tex_coord())), ColorSpace::Linear)?;
    let emissive_texture = tex(m.emissive_texture().map(|i| (i.texture(), i.tex_coord())), ColorSpace::Srgb)?;
    Ok(GltfMaterial {
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
    })
}

fn describe_accessor(accessor: &Accessor<'_>) -> String {
    format!("{:?} {:?}{}", accessor.dimensions(), accessor.data_type(), if accessor.normalized() { " normalized" } else { "" })
}

fn component_size(data_type: DataType) -> usize {
    match data_type {
        DataType::I8 | DataType::U8 => 1,
        DataType::I16 | DataType::U16 => 2,
        DataType::U32 | DataType::F32 => 4,
    }
}

/// One component as `f64` (exact for every glTF component type), normalised if asked.
fn decode_component(data_type: DataType, normalized: bool, b: &[u8]) -> f64 {
    let (value, max) = match data_type {
        DataType::I8 => (b[0] as i8 as f64, 127.0),
        DataType::U8 => (b[0] as f64, 255.0),
        DataType::I16 => (i16::from_le_bytes([b[0], b[1]]) as f64, 32767.0),
        DataType::U16 => (u16::from_le_bytes([b[0], b[1]]) as f64, 65535.0),
        DataType::U32 => (u32::from_le_bytes([b[0], b[1], b[2], b[3]]) as f64, 1.0),
        DataType::F32 => (f32::from_le_bytes([b[0], b[1], b[2], b[3]]) as f64, 1.0),
    };
    if normalized && !matches!(data_type, DataType::F32 | DataType::U32) { (value / max).max(-1.0) } else { value }
}

/// Upper bound on the elements of an accessor without a buffer view (sparse-only).
const MAX_UNBACKED_ELEMENTS: usize = 1 << 26;

/// Reads an accessor into `count × components` values, honouring offsets, strides and sparse
/// substitution, with every range checked against its buffer.
fn read_accessor(accessor: &Accessor<'_>, buffers: &[Vec<u8>], mesh: &str, attribute: &str) -> Result<Vec<f64>, GltfError> {
    let fail = |reason: String| GltfError::BadAccessor { mesh: mesh.to_owned(), attribute: attribute.to_owned(), reason };
    let (data_type, normalized) = (accessor.data_type(), accessor.normalized());
    let comps = accessor.dimensions().multiplicity();
    let csize = component_size(data_type);
    let elem = comps * csize;
    let count = accessor.count();
    let mut out;
    if let Some(view) = accessor.view() {
        let bytes = view_bytes(&view, buffers).ok_or_else(|| fail(format!("buffer view {} lies outside its buffer", view.index())))?;
        let stride = view.stride().unwrap_or(elem);
        if stride < elem {
            return Err(fail(format!("byte stride {stride} is smaller than the element size {elem}")));
        }
        let needed = match count {
            0 => Some(accessor.offset()),
            n => (n - 1).checked_mul(stride).and_then(|s| s.checked_add(accessor.offset())).and_then(|s| s.checked_add(elem)),
        };
        if needed.is_none_or(|n| n > bytes.len()) {
            return Err(fail(format!(
                "{count} elements of {elem} bytes (stride {stride}, offset {}) exceed buffer view {} of {} bytes",
                accessor.offset(),
                view.index(),
                bytes.len()
            )));
        }
        out = Vec::with_capacity(count * comps);
        for i in 0..count {
            let start = accessor.offset() + i * stride;
            out.extend((0..comps).map(|c| decode_component(data_type, normalized, &bytes[start + c * csize..])));
        }
    } else {
        if count > MAX_UNBACKED_ELEMENTS {
            return Err(fail(format!("{count} elements without a buffer view")));
        }
        out = vec![0.0; count * comps];
    }
    if let Some(sparse) = accessor.sparse() {
        let indices = sparse.indices();
        let isize = indices.index_type().size();
        let index_bytes = view_bytes(&indices.view(), buffers)
            .and_then(|b| b.get(indices.offset()..))
            .filter(|b| b.len() / isize >= sparse.count())
            .ok_or_else(|| fail("sparse indices exceed their buffer view".into()))?;
        let values = sparse.values();
        let value_bytes = view_bytes(&values.view(), buffers)
            .and_then(|b| b.get(values.offset()..))
            .filter(|b| b.len() / elem >= sparse.count())
            .ok_or_else(|| fail("sparse values exceed their buffer view".into()))?;
        let index_type = match isize {
            1 => DataType::U8,
            2 => DataType::U16,
            _ => DataType::U32,
        };
        for k in 0..sparse.count() {
            let target = decode_component(index_type, false, &index_bytes[k * isize..]) as usize;
            if target >= count {
                return Err(fail(format!("sparse index {target} is out of range for {count} elements")));
            }
            for c in 0..comps {
                out[target * comps + c] = decode_component(data_type, normalized, &value_bytes[k * elem + c * csize..]);
            }
        }
    }
    Ok(out)
}

/// Checks an attribute's type and reads it as `[f32; N]` elements.
fn read_attribute<const N: usize>(
    accessor: &Accessor<'_>,
    buffers: &[Vec<u8>],
    mesh: &str,
    attribute: &str,
    allowed: impl Fn(DataType, bool) -> bool,
) -> Result<Vec<[f32; N]>, GltfError> {
    if accessor.dimensions().multiplicity() != N
        || matches!(accessor.dimensions(), Dimensions::Mat2 | Dimensions::Mat3 | Dimensions::Mat4)
        || !allowed(accessor.data_type(), accessor.normalized())
    {
        return Err(GltfError::UnsupportedAttribute {
            mesh: mesh.to_owned(),
            attribute: attribute.to_owned(),
            found: describe_accessor(accessor),
        });
    }
    let values = read_accessor(accessor, buffers, mesh, attribute)?;
    Ok(values.chunks_exact(N).map(|c| std::array::from_fn(|i| c[i] as f32)).collect())
}

fn is_float(data_type: DataType, normalized: bool) -> bool {
    data_type == DataType::F32 && !normalized
}

fn load_primitive(primitive: &::gltf::Primitive<'_>, buffers: &[Vec<u8>], mesh: &str) -> Result<Mesh, GltfError> {
    let mode = primitive.mode();
    if !matches!(mode, Mode::Triangles | Mode::TriangleStrip | Mode::TriangleFan) {
        return Err(GltfError::UnsupportedPrimitiveMode { mesh: mesh.to_owned(), mode: format!("{mode:?}") });
    }
    let attribute = |semantic: ::gltf::Semantic| primitive.get(&semantic);
    let position_accessor = attribute(::gltf::Semantic::Positions)
        .ok_or_else(|| GltfError::MissingAttribute { mesh: mesh.to_owned(), attribute: "POSITION".into() })?;
    let positions: Vec<[f32; 3]> = read_attribute(&position_accessor, buffers, mesh, "POSITION", is_float)?;
    let n = positions.len();
    let same_count = |name: &str, len: usize| {
        if len == n {
            Ok(())
        } else {
            Err(GltfError::BadAccessor {
                mesh: mesh.to_owned(),
                attribute: name.to_owned(),
                reason: format!("{len} elements but POSITION has {n}"),
            })
        }
    };
    let normals = attribute(::gltf::Semantic::Normals).map(|a| read_attribute::<3>(&a, buffers, mesh, "NORMAL", is_float)).transpose()?;
    let uvs = attribute(::gltf::Semantic::TexCoords(0))
        .map(|a| {
            read_attribute::<2>(&a, buffers, mesh, "TEXCOORD_0", |t, norm| {
                is_float(t, norm) || (norm && matches!(t, DataType::U8 | DataType::U16))
            })
        })
        .transpose()?;
    let tangents =
        attribute(::gltf::Semantic::Tangents).map(|a| read_attribute::<4>(&a, buffers, mesh, "TANGENT", is_float)).transpose()?;
    let raw_indices: Vec<u32> = match primitive.indices() {
        Some(accessor) => {
            if accessor.dimensions() != Dimensions::Scalar
                || accessor.normalized()
                || !matches!(accessor.data_type(), DataType::U8 | DataType::U16 | DataType::U32)
            {
                return Err(GltfError::UnsupportedAttribute {
                    mesh: mesh.to_owned(),
                    attribute: "indices".into(),
                    found: describe_accessor(&accessor),
                });
            }
            read_accessor(&accessor, buffers, mesh, "indices")?.into_iter().map(|i| i as u32).collect()
        }
        None => (0..n as u32).collect(),
    };
    let indices = match mode {
        Mode::TriangleStrip => (0..raw_indices.len().saturating_sub(2))
            .flat_map(|i| {
                let (a, b, c) = (raw_indices[i], raw_indices[i + 1], raw_indices[i + 2]);
                if i % 2 == 0 { [a, b, c] } else { [b, a, c] }
            })
            .collect(),
        Mode::TriangleFan => {
            (1..raw_indices.len().saturating_sub(1)).flat_map(|i| [raw_indices[i], raw_indices[i + 1], raw_indices[0]]).collect()
        }
        _ => raw_indices,
    };
    if let Some(normals) = &normals {
        same_count("NORMAL", normals.len())?;
    }
    if let Some(uvs) = &uvs {
        same_count("TEXCOORD_0", uvs.len())?;
    }
    if let Some(tangents) = &tangents {
        same_count("TANGENT", tangents.len())?;
    }
    let normals = normals.unwrap_or_else(|| smooth_normals(&positions, &indices));
    let uvs = uvs.unwrap_or_else(|| vec![[0.0; 2]; n]);
    let result = match tangents {
        Some(tangents) => Mesh::from_parts(positions, normals, uvs, tangents, indices).map(|mut mesh| {
            mesh.orthonormalize_tangents();
            mesh
        }),
        None => Mesh::new(positions, normals, uvs, indices),
    };
    result.map_err(|source| GltfError::Mesh { mesh: mesh.to_owned(), source })
}

fn load_nodes(document: &Document) -> Vec<GltfNode> {
    let mut nodes: Vec<GltfNode> = document
        .nodes()
        .map(|node| {
            let (t, r, s) = node.transform().decomposed();
            let rotation = Quat::from_array(r);
            let transform = Transform {
                translation: Vec3::from(t),
                rotation: if rotation.is_finite() && rotation.length_squared() > 0.0 { rotation.normalize() } else { Quat::IDENTITY },
                scale: Vec3::from(s),
            };
            let light = node.light().map(|light| {
                let color = Vec3::from(light.color());
                match light.kind() {
                    ::gltf::khr_lights_punctual::Kind::Point => {
                        GltfLight::Point(PointLight { color, intensity: light.intensity(), range: light.range() })
                    }
                    ::gltf::khr_lights_punctual::Kind::Spot { inner_cone_angle, outer_cone_angle } => GltfLight::Spot(SpotLight {
                        color,
                        intensity: light.intensity(),
                        range: light.range(),
                        inner_angle: inner_cone_angle,
                        outer_angle: outer_cone_angle,
                    }),
                    ::gltf::khr_lights_punctual::Kind::Directional => {
                        GltfLight::Directional(DirectionalLight { color, illuminance: light.intensity() })
                    }
                }
            });
            let camera = node.camera().and_then(|camera| match camera.projection() {
                ::gltf::camera::Projection::Perspective(p) => Some(Camera { fov_y: p.yfov(), near: p.znear(), ..Default::default() }),
                ::gltf::camera::Projection::Orthographic(_) => {
                    warn!(camera = camera.index(), "orthographic glTF cameras are not supported; skipped");
                    None
                }
            });
            GltfNode {
                name: node.name().map(str::to_owned),
                transform,
                parent: None,
                children: node.children().map(|c| c.index()).collect(),
                mesh: node.mesh().map(|m| m.index()),
                light,
                camera,
            }
        })
        .collect();
    for parent in 0..nodes.len() {
        for child in nodes[parent].children.clone() {
            match nodes[child].parent {
                None => nodes[child].parent = Some(parent),
                Some(first) => warn!(child, first, parent, "glTF node has two parents; keeping the first"),
            }
        }
    }
    nodes
}
