//! glTF 2.0 loading (`.gltf` with external or `data:` buffers and images, and `.glb`).
//!
//! Loading is split from spawning: [`load`]/[`load_slice`] parse the document, resolve every
//! buffer and image themselves (so that a missing `.bin` or `.png` is reported by its resolved
//! path, which `gltf::import`'s all-in-one error does not do), validate and convert every
//! accessor into a [`GltfScene`]; only then does [`GltfScene::spawn`] touch the [`World`]. A bad
//! file is therefore rejected with a [`GltfError`] before anything was spawned.
//!
//! Supported: metallic-roughness materials (base colour, normal, metallic-roughness, occlusion
//! and emissive textures, `KHR_materials_emissive_strength`, alpha mask/blend, double-sided,
//! `KHR_materials_ior` and `KHR_materials_volume`'s thickness for the refraction of blended
//! materials),
//! `KHR_lights_punctual`, `KHR_mesh_quantization`, `KHR_texture_transform`, `MSFT_lod` (a
//! node's coarser levels of detail become its mesh's [`Mesh::lods`]), `EXT_meshopt_compression`
//! (compressed buffer views decoded as the buffers load, `ext_meshopt.rs`), `KHR_texture_basisu`
//! (KTX2 images in BC1, BC3, BC4, BC5, BC7 or RGBA8 used as their blocks are, Basis Universal
//! ones transcoded to the BC format of their role, [`crate::image::Image::from_ktx2_for`]; one
//! that cannot be read falls back to the texture's PNG/JPEG source, or the placeholder),
//! perspective cameras
//! (`zfar` ignored: the projection is infinite reverse-Z), node hierarchies with TRS or matrix
//! transforms, triangle lists/strips/fans. A document that *requires* any other extension (e.g.
//! `KHR_draco_mesh_compression`) is refused with [`GltfError::UnsupportedExtension`] naming it.
//!
//! Accessors are read by this module (with bounds checks, strides and sparse substitution);
//! only the component types below are accepted, anything else is an error naming the mesh and
//! attribute: `POSITION`/`NORMAL` float VEC3, `TEXCOORD_0` float or normalised u8/u16 VEC2,
//! `TANGENT` float VEC4, indices u8/u16/u32 scalars (or none: `0..n`). When the document uses
//! `KHR_mesh_quantization` (`extensionsUsed` or `extensionsRequired`), its types are accepted too: `POSITION` and
//! `TEXCOORD_0` as i8/u8/i16/u16, normalised (mapped to [-1, 1] or [0, 1]) or not (plain
//! integers, scaled by the node transform or the texture transform), `NORMAL`/`TANGENT` as
//! normalised i8/i16 (normals are renormalised after decoding). Missing normals are computed
//! smooth, missing UVs are zero, missing tangents are generated (MikkTSpace). Samplers and
//! texture coordinate sets other than 0 are ignored with a warning.
//!
//! `KHR_texture_transform` (offset, rotation, scale, `texCoord` override) is baked into each
//! primitive's `TEXCOORD_0`, since a material has one UV set for all its textures: when every
//! texture of the material has the same transform it is exact; otherwise the base colour's
//! transform (or the first textured slot's) is baked and one warning names the material.
//!
//! **Textures are block-compressed at import** ([`LoadOptions::textures`], on by default): each
//! PNG/JPEG image is compressed for the role its material slot gives it ([`TextureRole`]: BC7
//! for base colour, emissive and metallic-roughness, BC5 for normal maps, BC4 for an occlusion
//! map no metallic-roughness slot shares) with a full mip chain, through the user's texture
//! cache ([`crate::image::TextureCache`]), so that only the first load of a model pays for it;
//! [`GltfScene::texture_import`] counts what each load did, and [`LoadOptions::progress`] is told
//! of each image. [`TextureImport::Rgba8`] decodes to RGBA8 at every load instead.
//!
//! **Textures that cannot be loaded** (the file is missing or unreadable, or the bytes do not
//! decode) do not fail the model by default: the model loads and one warning per material and
//! file names both. A missing base-colour texture becomes [`Image::missing_texture`], a
//! magenta/black checker (still multiplied by the base colour factor), because a wrong albedo is
//! what a viewer must notice; a missing normal, metallic-roughness, occlusion or emissive map is
//! simply dropped, so the material behaves as if it had no such texture (flat normals, the
//! factors alone, no occlusion, the emissive factor alone): a checker there would shade as
//! garbage normals or random roughness, which hides the cause rather than showing it.
//! [`LoadOptions::strict_textures`] restores the refusal with the original error. Missing
//! buffers, malformed documents and unresolvable URIs are always errors.
//!
//! **Hostile files.** Loading never panics, and allocates in proportion to the bytes actually
//! present, never to a count the file merely declares: every accessor's offset, stride and count
//! are checked (with overflow-checked arithmetic) against its buffer view, and every view
//! against its buffer, before anything is read; an accessor without a buffer view (all zeros
//! plus sparse values) may declare at most [`MAX_UNBACKED_COMPONENTS`]; images decode under
//! the limits of [`crate::image`]. Any such problem is an error naming the file, the mesh and
//! primitive, and the attribute. **An index at or past the primitive's vertex count refuses the
//! file** with [`GltfError::Mesh`] (naming the mesh, the primitive, the position in the index
//! accessor, the index and the vertex count) rather than dropping the bad triangles: such a
//! file is corrupt, and a model with holes in it would hide that. A node hierarchy that is not
//! the forest glTF requires is repaired, with one warning for each kind of repair: a node that
//! is the child of several nodes keeps its first parent (lowest index), and a cycle is cut
//! above one of its nodes, which becomes a root; [`GltfNode::parent`] and
//! [`GltfNode::children`] then describe the same trees. Nothing walks the hierarchy
//! recursively, so a chain of any depth loads and spawns without overflowing the stack.
//!
//! **A broken part costs that part, never the scene.** Skins, animations, morph targets,
//! lights, cameras and material factors that are broken or degenerate are repaired or left out,
//! each with one warning naming the file, the object (by index and name) and what was done
//! instead, and one [`GltfFault`] in [`GltfScene::faults`] (its [`GltfFaultKind`] says which
//! fault; `docs/RELIABILITY.md` lists them all with their tests):
//!
//! - a skin that cannot deform its meshes (no joints, inverse bind matrices unreadable, not
//!   finite or not one per joint) is dropped: its meshes are drawn unskinned, in their rest
//!   pose; so is the mesh of a node whose vertices weight a joint past its skin's joints, or
//!   whose skin lists the node itself as a joint (a cycle of transforms);
//! - `JOINTS_0`/`WEIGHTS_0` that cannot be read leave their primitive rigid; a vertex whose
//!   weights are not finite or sum to zero follows its first joint alone (weight 1:
//!   [`SkinWeights::repaired`] says why that joint);
//! - an animation channel that cannot be sampled (cubic spline without tangents, sampler input
//!   and output counts that differ, keyframe times not finite or not increasing, accessors
//!   unreadable, a property animated twice) is dropped and the rest of its clip plays;
//!   keyframes whose values are not finite, and rotation keyframes of zero length, are dropped
//!   from their channel;
//! - a morph target with the wrong number of offsets, unreadable or not finite has zero
//!   offsets (no effect), so the other targets keep their index and apply;
//! - a node's translation, rotation or scale that is not finite (or a rotation of zero length)
//!   is the identity's, and morph weights that are not finite are 0;
//! - a light with a colour, intensity, range or cone that is not finite or out of range is left
//!   out; a camera's bad field of view or near plane is the default's; a material factor that
//!   is not finite is glTF's default.

use std::collections::HashMap;
use std::path::{Path, PathBuf};

use ::gltf::accessor::{DataType, Dimensions};
use ::gltf::mesh::Mode;
use ::gltf::{Accessor, Document, Gltf};
use bevy_ecs::prelude::*;
use glam::{Quat, Vec3, Vec4};
use thiserror::Error;
use tracing::{info, warn};

use crate::animation::{AnimatedRadius, AnimationClip, AnimationTargets, CompactSkeleton, MorphWeights, Skin, UnplacedBones};
use crate::asset::{Assets, Handle};
use crate::camera::Camera;
use crate::image::{Image, ImageError, TextureCache, TextureRole};
use crate::light::{DirectionalLight, PointLight, SpotLight};
use crate::material::{AlphaMode, Material};
use crate::mesh::{Mesh, MeshError, MorphTarget, SkinWeights, smooth_normals};
use crate::scene::{MeshInstance, Name};
use crate::transform::Transform;

mod animations;
mod ext_meshopt;
mod faults;
mod materials;
mod meshes;
mod nodes;
mod skins;

use animations::*;
use faults::Faults;
pub use faults::{GltfFault, GltfFaultKind, GltfPart};
use materials::*;
use meshes::*;
pub use meshes::{MAX_AUTHORED_LODS, MAX_UNBACKED_COMPONENTS};
use nodes::*;
pub use skins::GltfSkin;
use skins::*;

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
        /// The buffer's index and URI, and the glTF file.
        buffer: String,
        /// Why.
        reason: String,
    },
    /// An attribute has a type this engine does not accept.
    #[error("mesh {mesh}: attribute {attribute} is {found}, which is not supported")]
    UnsupportedAttribute {
        /// The mesh name (or index), the primitive and the glTF file.
        mesh: String,
        /// The attribute (`POSITION`, `NORMAL`, `TEXCOORD_0`, `TANGENT`, `indices`).
        attribute: String,
        /// The accessor's type, e.g. `Vec2 F32`.
        found: String,
    },
    /// The primitive is not made of triangles.
    #[error("mesh {mesh}: primitive mode {mode} is not supported (triangles only)")]
    UnsupportedPrimitiveMode {
        /// The mesh name (or index), the primitive and the glTF file.
        mesh: String,
        /// The glTF mode, e.g. `Lines`.
        mode: String,
    },
    /// A required attribute is absent.
    #[error("mesh {mesh}: required attribute {attribute} is missing")]
    MissingAttribute {
        /// The mesh name (or index), the primitive and the glTF file.
        mesh: String,
        /// The attribute.
        attribute: String,
    },
    /// An accessor's data lies outside its buffer, or counts disagree.
    #[error("mesh {mesh}: attribute {attribute}: {reason}")]
    BadAccessor {
        /// The mesh name (or index), the primitive and the glTF file.
        mesh: String,
        /// The attribute.
        attribute: String,
        /// Why.
        reason: String,
    },
    /// The assembled mesh failed validation (e.g. an index out of range).
    #[error("mesh {mesh}: {source}")]
    Mesh {
        /// The mesh name (or index), the primitive and the glTF file.
        mesh: String,
        /// The validation error.
        source: MeshError,
    },
    /// The document requires an extension this loader does not implement.
    #[error("glTF file {path} requires extension {extension}, which is not supported (supported: {supported})")]
    UnsupportedExtension {
        /// The file (`<memory>` for [`load_slice`]).
        path: PathBuf,
        /// The extension's name, e.g. `KHR_draco_mesh_compression`.
        extension: String,
        /// The extensions this loader implements, comma-separated.
        supported: String,
    },
    /// An image could not be read or decoded.
    #[error("image {uri_or_index}: {source}")]
    Image {
        /// The image's URI, or its index and name and the glTF file when embedded.
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
    /// `KHR_materials_ior` (1.5 without it).
    pub ior: f32,
    /// `KHR_materials_volume`'s thickness factor (0, a thin wall, without it).
    pub thickness: f32,
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
            ior: m.ior,
            thickness: m.thickness,
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
            ior: self.ior,
            thickness: self.thickness,
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
    /// Parent node index (the nodes form a forest: see the module docs for the repairs).
    pub parent: Option<usize>,
    /// Child node indices: exactly the nodes whose `parent` is this one.
    pub children: Vec<usize>,
    /// Index into [`GltfScene::meshes`].
    pub mesh: Option<usize>,
    /// Index into [`GltfScene::skins`]: the skin that deforms the node's mesh.
    pub skin: Option<usize>,
    /// The morph target weights of the node's mesh at rest (the node's, else the mesh's).
    pub weights: Vec<f32>,
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
    /// Images with mips, one per (glTF image, [`TextureRole`]) pair that materials use.
    pub images: Vec<Image>,
    /// How the images were imported (cache hits, compressions, …).
    pub texture_import: TextureImportStats,
    /// All nodes of the file, indexed as in the file.
    pub nodes: Vec<GltfNode>,
    /// The nodes of the default (or first) scene; all parentless nodes if there is no scene.
    pub roots: Vec<usize>,
    /// The skins (joint nodes and inverse bind matrices).
    pub skins: Vec<GltfSkin>,
    /// The animations, as clips over node indices.
    pub animations: Vec<AnimationClip>,
    /// What was broken in the file and what loading did instead, in the order found: a broken
    /// skin, channel, morph target, light, camera or material costs only itself (see the
    /// module docs); each was logged as one warning when the file was loaded. Empty for a
    /// healthy file.
    pub faults: Vec<GltfFault>,
}

/// The animation clips of a spawned glTF model, on its root entity (beside the
/// [`AnimationTargets`] that map their node indices to entities). Play one with
/// [`crate::animation::AnimationPlayer`].
#[derive(Component, Clone, Debug, Default, PartialEq)]
pub struct GltfAnimations(pub Vec<Handle<AnimationClip>>);

/// Extensions a document may require.
const SUPPORTED_EXTENSIONS: &[&str] = &[
    "KHR_lights_punctual",
    "KHR_materials_emissive_strength",
    "KHR_materials_ior",
    "KHR_materials_volume",
    "KHR_mesh_quantization",
    "KHR_texture_transform",
    "MSFT_lod",
    ext_meshopt::EXTENSION,
    materials::TEXTURE_BASISU,
];

/// How loading treats textures: how forgiving it is, and whether images are compressed.
#[derive(Clone, Default)]
pub struct LoadOptions {
    /// Refuse the model when a texture image is missing or undecodable (the pre-forgiving
    /// behaviour, with the same error). Off by default: such a texture is replaced (see the
    /// module docs) and a warning names the file and the material.
    pub strict_textures: bool,
    /// How PNG and JPEG images become textures: block-compressed through the user's cache by
    /// default.
    pub textures: TextureImport,
    /// Called after each texture image is imported, with how far the import is (for a progress
    /// bar on a long first import).
    pub progress: Option<TextureProgress>,
}

impl std::fmt::Debug for LoadOptions {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("LoadOptions")
            .field("strict_textures", &self.strict_textures)
            .field("textures", &self.textures)
            .field("progress", &self.progress.as_ref().map(|_| "…"))
            .finish()
    }
}

impl LoadOptions {
    /// Every texture must load.
    pub const STRICT: LoadOptions =
        LoadOptions { strict_textures: true, textures: TextureImport::Compressed(CacheLocation::User), progress: None };
}

/// How the PNG and JPEG images of a glTF become textures (KTX2 images are used as they are
/// either way).
#[derive(Clone, Debug, PartialEq, Eq)]
pub enum TextureImport {
    /// Decoded to RGBA8 with mips at every load, 4 bytes a texel.
    Rgba8,
    /// Block-compressed by role ([`TextureRole`]: BC7 colour and data, BC5 normals, BC4 lone
    /// occlusion), with mips, through a cache that later loads read directly
    /// ([`crate::image::TextureCache`]).
    Compressed(CacheLocation),
}

impl Default for TextureImport {
    fn default() -> TextureImport {
        TextureImport::Compressed(CacheLocation::User)
    }
}

/// Where compressed textures are cached.
#[derive(Clone, Debug, PartialEq, Eq)]
pub enum CacheLocation {
    /// The user's cache folder ([`TextureCache::user`]); no cache when it has none.
    User,
    /// This folder.
    At(PathBuf),
    /// No cache: textures are compressed at every load.
    Off,
}

impl CacheLocation {
    /// The cache this location names (`None`: off, or no user cache folder).
    pub fn cache(&self) -> Option<TextureCache> {
        match self {
            CacheLocation::User => TextureCache::user(),
            CacheLocation::At(dir) => Some(TextureCache::new(dir)),
            CacheLocation::Off => None,
        }
    }
}

/// A callback told of each texture image as it is imported.
pub type TextureProgress = std::sync::Arc<dyn Fn(&TextureEvent<'_>) + Send + Sync>;

/// One texture image imported.
#[derive(Clone, Debug)]
pub struct TextureEvent<'a> {
    /// How many of the model's texture images are done, this one included.
    pub done: usize,
    /// How many texture images the model's materials use.
    pub total: usize,
    /// The image (its URI, or its index and name in the file).
    pub image: &'a str,
    /// How it was imported.
    pub import: TextureSource,
}

/// How one texture image was imported.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum TextureSource {
    /// Read compressed from the cache.
    CacheHit,
    /// Decoded and compressed (and cached).
    Compressed,
    /// A cached file could not be used; decoded and compressed again.
    Rebuilt,
    /// Decoded to RGBA8 ([`TextureImport::Rgba8`]).
    Rgba8,
    /// A KTX2 image used as it is.
    Ktx2,
    /// Made from another slot's image already loaded (the same PNG in another role, as RGBA8).
    Reused,
}

/// What happened to a model's texture images at load: one count per [`TextureSource`].
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct TextureImportStats {
    /// Read compressed from the cache.
    pub cache_hits: u32,
    /// Decoded and compressed (cache misses).
    pub compressed: u32,
    /// Cached files that could not be used, compressed again.
    pub rebuilt: u32,
    /// Decoded to RGBA8.
    pub rgba8: u32,
    /// KTX2 images used as they are.
    pub ktx2: u32,
    /// Made from an image already loaded for another slot.
    pub reused: u32,
}

impl From<&crate::image::CacheOutcome> for TextureSource {
    fn from(outcome: &crate::image::CacheOutcome) -> TextureSource {
        match outcome {
            crate::image::CacheOutcome::Hit => TextureSource::CacheHit,
            crate::image::CacheOutcome::Compressed => TextureSource::Compressed,
            crate::image::CacheOutcome::Rebuilt(_) => TextureSource::Rebuilt,
        }
    }
}

impl std::ops::AddAssign<&TextureImportStats> for TextureImportStats {
    fn add_assign(&mut self, other: &TextureImportStats) {
        self.cache_hits += other.cache_hits;
        self.compressed += other.compressed;
        self.rebuilt += other.rebuilt;
        self.rgba8 += other.rgba8;
        self.ktx2 += other.ktx2;
        self.reused += other.reused;
    }
}

impl TextureImportStats {
    /// Counts one image imported as `source`.
    pub fn count(&mut self, source: TextureSource) {
        *match source {
            TextureSource::CacheHit => &mut self.cache_hits,
            TextureSource::Compressed => &mut self.compressed,
            TextureSource::Rebuilt => &mut self.rebuilt,
            TextureSource::Rgba8 => &mut self.rgba8,
            TextureSource::Ktx2 => &mut self.ktx2,
            TextureSource::Reused => &mut self.reused,
        } += 1;
    }
}

/// Packs a glTF JSON document and its binary chunk into a GLB container (version 2), padding
/// each chunk to 4 bytes; an empty `bin` writes no binary chunk. For tools and tests that build
/// or rewrite models in memory.
pub fn glb_container(json: &[u8], bin: &[u8]) -> Vec<u8> {
    let mut json = json.to_vec();
    json.resize(json.len().next_multiple_of(4), b' ');
    let mut bin = bin.to_vec();
    bin.resize(bin.len().next_multiple_of(4), 0);
    let total = 12 + 8 + json.len() + if bin.is_empty() { 0 } else { 8 + bin.len() };
    let mut out = b"glTF".to_vec();
    out.extend(2u32.to_le_bytes());
    out.extend((total as u32).to_le_bytes());
    out.extend((json.len() as u32).to_le_bytes());
    out.extend(b"JSON");
    out.extend(json);
    if !bin.is_empty() {
        out.extend((bin.len() as u32).to_le_bytes());
        out.extend(b"BIN\0");
        out.extend(bin);
    }
    out
}

/// Loads a `.gltf` or `.glb` file, resolving relative URIs against its directory, with the
/// default [`LoadOptions`] (missing or broken textures are replaced with a warning).
pub fn load(path: &Path) -> Result<GltfScene, GltfError> {
    load_with(path, &LoadOptions::default())
}

/// [`load`] with explicit options.
pub fn load_with(path: &Path, options: &LoadOptions) -> Result<GltfScene, GltfError> {
    let bytes = std::fs::read(path).map_err(|source| GltfError::Io { path: path.to_owned(), source })?;
    let base = path.parent().unwrap_or(Path::new(""));
    let name = path.file_stem().map_or_else(|| "glTF scene".to_owned(), |s| s.to_string_lossy().into_owned());
    load_impl(&bytes, Some(base), path, name, options)
}

/// Loads glTF or GLB bytes; relative URIs resolve against `base_dir` (without one, only
/// embedded and `data:` resources are allowed). Default [`LoadOptions`].
pub fn load_slice(bytes: &[u8], base_dir: Option<&Path>) -> Result<GltfScene, GltfError> {
    load_slice_with(bytes, base_dir, &LoadOptions::default())
}

/// [`load_slice`] with explicit options.
pub fn load_slice_with(bytes: &[u8], base_dir: Option<&Path>, options: &LoadOptions) -> Result<GltfScene, GltfError> {
    load_impl(bytes, base_dir, Path::new("<memory>"), "glTF scene".to_owned(), options)
}

/// Parses the container and JSON, refuses required extensions this loader does not implement
/// (by name), then runs the gltf crate's validation minus its own verdict on required
/// extensions (it does not know `KHR_mesh_quantization`, which this module decodes).
fn parse(bytes: &[u8], file: &Path) -> Result<Gltf, GltfError> {
    use ::gltf::json::validation::{Error as ValidationError, Validate};
    let parse_error = |source| GltfError::Parse { path: file.to_owned(), source };
    // The gltf crate computes `length - 12` from the GLB header unchecked, which overflows (a
    // panic in debug builds) when the header declares less than its own 12 bytes.
    if let Some(length) = bytes.strip_prefix(b"glTF").and_then(|rest| rest.get(4..8)).map(|l| u32::from_le_bytes([l[0], l[1], l[2], l[3]]))
        && length < 12
    {
        let reason = format!("the GLB header declares a total length of {length} bytes, less than the header's own 12");
        let io = std::io::Error::new(std::io::ErrorKind::InvalidData, reason);
        return Err(parse_error(::gltf::Error::Binary(::gltf::binary::Error::Io(io))));
    }
    let gltf = Gltf::from_slice_without_validation(bytes).map_err(parse_error)?;
    if let Some(extension) = gltf.document.extensions_required().find(|e| !SUPPORTED_EXTENSIONS.contains(e)) {
        return Err(GltfError::UnsupportedExtension {
            path: file.to_owned(),
            extension: extension.to_owned(),
            supported: SUPPORTED_EXTENSIONS.join(", "),
        });
    }
    let root = gltf.document.as_json();
    let mut errors = Vec::new();
    // gltf-json's primitive validation reads the POSITION accessor by index without a bounds
    // check (a panic when the index is out of range), so that index is checked first, and the
    // crate's validation runs only when it is in range everywhere.
    let positions = ::gltf::json::validation::Checked::Valid(::gltf::json::mesh::Semantic::Positions);
    for (m, mesh) in root.meshes.iter().enumerate() {
        for (p, primitive) in mesh.primitives.iter().enumerate() {
            if primitive.attributes.get(&positions).is_some_and(|index| index.value() >= root.accessors.len()) {
                let path = ::gltf::json::Path::new().field("meshes").index(m).field("primitives").index(p);
                errors.push((path.field("attributes").key("POSITION"), ValidationError::IndexOutOfBounds));
            }
        }
    }
    if errors.is_empty() {
        root.validate(root, ::gltf::json::Path::new, &mut |path, error| {
            let path = path();
            if !(error == ValidationError::Unsupported && path.as_str().starts_with("extensionsRequired")) {
                errors.push((path, error));
            }
        });
    }
    if errors.is_empty() { Ok(gltf) } else { Err(parse_error(::gltf::Error::Validation(errors))) }
}

fn load_impl(bytes: &[u8], base: Option<&Path>, file: &Path, name: String, options: &LoadOptions) -> Result<GltfScene, GltfError> {
    let Gltf { document, blob } = parse(bytes, file)?;
    let quantized = document.extensions_used().chain(document.extensions_required()).any(|e| e == "KHR_mesh_quantization");
    let buffers = load_buffers(&document, blob, base, file)?;
    let mut images = ImageLoader::new(&document, &buffers, base, file, options);
    let mut faults = Faults::new(file);
    let (mut materials, uv_transforms): (Vec<_>, Vec<_>) = document
        .materials()
        .map(|m| load_material(&m, &document, &mut images, options, &mut faults))
        .collect::<Result<Vec<_>, _>>()?
        .into_iter()
        .unzip();
    let mut default_material = None;
    let mut meshes = Vec::with_capacity(document.meshes().len());
    for mesh in document.meshes() {
        let mut primitives = Vec::new();
        for primitive in mesh.primitives() {
            let label = match mesh.name() {
                Some(name) => format!("'{name}' (#{}) primitive {} in {}", mesh.index(), primitive.index(), file.display()),
                None => format!("#{} primitive {} in {}", mesh.index(), primitive.index(), file.display()),
            };
            let uv_transform = primitive.material().index().and_then(|i| uv_transforms.get(i).copied().flatten());
            let part = PrimitivePart { mesh: mesh.index(), mesh_name: mesh.name().map(str::to_owned), primitive: primitive.index() };
            let converted = load_primitive(&primitive, &buffers, &label, &part, quantized, uv_transform, &mut faults)?;
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
    attach_authored_lods(&document, &mut meshes, file);
    let mut nodes = load_nodes(&document, &mut faults);
    let roots = match document.default_scene().or_else(|| document.scenes().next()) {
        Some(scene) => scene.nodes().map(|n| n.index()).collect(),
        None => (0..nodes.len()).filter(|&i| nodes[i].parent.is_none()).collect(),
    };
    let skins = load_skins(&document, &buffers, file, &mut nodes, &meshes, &mut faults);
    let animations = load_animations(&document, &buffers, file, &mut faults);
    let faults = faults.list;
    let texture_import = images.stats;
    let scene = GltfScene { name, meshes, materials, images: images.images, texture_import, nodes, roots, skins, animations, faults };
    info!(
        file = %file.display(),
        meshes = scene.meshes.len(),
        triangles = scene.triangle_count(),
        materials = scene.materials.len(),
        images = scene.images.len(),
        nodes = scene.nodes.len(),
        skins = scene.skins.len(),
        animations = scene.animations.len(),
        faults = scene.faults.len(),
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
    /// per primitive (with a [`Skin`] whose joints are the joint nodes' entities, when the node
    /// is skinned), light/camera components and [`MorphWeights`] on their nodes; the clips go to
    /// `Assets<AnimationClip>`, named on the root by [`GltfAnimations`] beside the
    /// [`AnimationTargets`] they animate. Returns the root entity. To spawn a model many times
    /// over the same assets, use [`GltfScene::into_prefab`].
    pub fn spawn(self, world: &mut World) -> Entity {
        self.into_prefab(world).spawn(world)
    }

    /// Adds the images, materials, meshes and clips to the world's `Assets` once, and keeps what
    /// spawning needs: [`GltfPrefab::spawn`] then spawns the scene as often as wanted, every copy
    /// sharing those assets (a crowd of one character: one mesh, one set of clips).
    pub fn into_prefab(self, world: &mut World) -> GltfPrefab {
        let radius = self.rest_radius();
        let image_handles: Vec<Handle<Image>> = {
            let mut assets = world.get_resource_or_init::<Assets<Image>>();
            self.images.into_iter().map(|image| assets.add(image)).collect()
        };
        let materials: Vec<Handle<Material>> = {
            let mut assets = world.get_resource_or_init::<Assets<Material>>();
            self.materials.iter().map(|m| assets.add(m.to_material(&image_handles))).collect()
        };
        let meshes: Vec<Vec<(Handle<Mesh>, usize)>> = {
            let mut assets = world.get_resource_or_init::<Assets<Mesh>>();
            self.meshes.into_iter().map(|prims| prims.into_iter().map(|(m, mat)| (assets.add(m), mat)).collect()).collect()
        };
        let clips: Vec<Handle<AnimationClip>> = {
            let mut assets = world.get_resource_or_init::<Assets<AnimationClip>>();
            self.animations.into_iter().map(|clip| assets.add(clip)).collect()
        };
        GltfPrefab {
            name: self.name,
            meshes,
            materials,
            nodes: self.nodes,
            roots: self.roots,
            skins: self.skins,
            clips,
            radius,
            compact_skeletons: true,
            unplaced_bones: false,
        }
    }

    /// The radius of a sphere about the root that holds every mesh of the scene in its rest
    /// pose (what [`AnimatedRadius`] says of a spawned model): each mesh's bounding box placed by
    /// its node's rest transform, a skinned one by its first joint's rest transform times that
    /// joint's inverse bind matrix (where glTF's skinning puts the bind pose).
    pub fn rest_radius(&self) -> f32 {
        // Rest transforms from the roots down (the nodes form a forest).
        let mut world = vec![None; self.nodes.len()];
        let mut stack: Vec<(usize, glam::Affine3A)> = self.roots.iter().map(|&n| (n, glam::Affine3A::IDENTITY)).collect();
        while let Some((index, parent)) = stack.pop() {
            let Some(node) = self.nodes.get(index).filter(|_| world[index].is_none()) else { continue };
            let affine = parent * node.transform.compute_affine();
            world[index] = Some(affine);
            stack.extend(node.children.iter().map(|&c| (c, affine)));
        }
        let mut radius = 0.0f32;
        for (node, placed) in self.nodes.iter().zip(&world) {
            let Some(placed) = *placed else { continue };
            let skinned = node.skin.and_then(|s| self.skins.get(s)).and_then(|skin| {
                let (&joint, ibm) = skin.joints.first().zip(skin.inverse_bind_matrices.first())?;
                Some(glam::Mat4::from(world.get(joint).copied().flatten()?) * *ibm)
            });
            let to_root = skinned.unwrap_or_else(|| placed.into());
            for (mesh, _) in node.mesh.and_then(|m| self.meshes.get(m)).into_iter().flatten() {
                let (min, max) = mesh.aabb();
                for corner in 0..8 {
                    let p = Vec3::new(
                        if corner & 1 == 0 { min.x } else { max.x },
                        if corner & 2 == 0 { min.y } else { max.y },
                        if corner & 4 == 0 { min.z } else { max.z },
                    );
                    let at = to_root.project_point3(p).length();
                    if at.is_finite() {
                        radius = radius.max(at);
                    }
                }
            }
        }
        radius
    }
}

/// A glTF scene whose assets are in the world, ready to spawn any number of times
/// ([`GltfScene::into_prefab`]).
#[derive(Clone, Debug)]
pub struct GltfPrefab {
    /// Name for each root entity.
    pub name: String,
    meshes: Vec<Vec<(Handle<Mesh>, usize)>>,
    materials: Vec<Handle<Material>>,
    nodes: Vec<GltfNode>,
    roots: Vec<usize>,
    skins: Vec<GltfSkin>,
    /// The animation clips, in the file's order.
    pub clips: Vec<Handle<AnimationClip>>,
    /// [`GltfScene::rest_radius`]: set on each spawned root with clips as its [`AnimatedRadius`].
    pub radius: f32,
    /// Whether spawned skins are [`CompactSkeleton`]s: each posed from the clips in one pass,
    /// which also places its bones' entities, rather than by animation, propagation and the skin
    /// matrices each going over the bones (`engine::animation`'s `compact` module says what it
    /// saves, and when a skin gives its bones back to those passes). On by default.
    pub compact_skeletons: bool,
    /// Whether compact skins leave their bones' entities unplaced ([`UnplacedBones`]: for crowds
    /// nothing reads the bones of). Off by default.
    pub unplaced_bones: bool,
}

impl GltfPrefab {
    /// Spawns one copy of the scene (as [`GltfScene::spawn`] describes) and returns its root.
    pub fn spawn(&self, world: &mut World) -> Entity {
        let (mesh_handles, material_handles) = (&self.meshes, &self.materials);
        let root = world.spawn((Transform::IDENTITY, Name(self.name.clone()))).id();
        let mut entities: Vec<Option<Entity>> = vec![None; self.nodes.len()];
        let mut skinned: Vec<(Entity, usize)> = Vec::new();
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
            if !node.weights.is_empty() {
                entity.insert(MorphWeights(node.weights.clone()));
            }
            let id = entity.id();
            entities[index] = Some(id);
            for &(mesh, material) in node.mesh.and_then(|m| mesh_handles.get(m)).into_iter().flatten() {
                let Some(&material) = material_handles.get(material) else {
                    continue;
                };
                let primitive = world.spawn((Transform::IDENTITY, MeshInstance { mesh, material }, ChildOf(id))).id();
                if let Some(skin) = node.skin {
                    skinned.push((primitive, skin));
                }
            }
            stack.extend(node.children.iter().rev().map(|&child| (child, id)));
        }
        // Skins once every joint has its entity.
        for (primitive, skin) in skinned {
            let Some(skin) = self.skins.get(skin) else { continue };
            match skin.joints.iter().map(|&j| entities.get(j).copied().flatten()).collect::<Option<Vec<Entity>>>() {
                Some(joints) => {
                    // Bones only: a joint node that also carries a light or camera stays listed.
                    for &joint in &joints {
                        let bare = world.get::<PointLight>(joint).is_none()
                            && world.get::<SpotLight>(joint).is_none()
                            && world.get::<DirectionalLight>(joint).is_none()
                            && world.get::<crate::camera::Camera>(joint).is_none();
                        if bare {
                            world.entity_mut(joint).insert(crate::transform::Joint);
                        }
                    }
                    let skin = Skin { joints, inverse_bind_matrices: skin.inverse_bind_matrices.clone().into() };
                    let mut primitive = world.entity_mut(primitive);
                    primitive.insert(skin);
                    if self.compact_skeletons {
                        primitive.insert(CompactSkeleton);
                        if self.unplaced_bones {
                            primitive.insert(UnplacedBones);
                        }
                    }
                }
                None => warn!(skin = ?skin.name, "a joint of this skin is not in the spawned scene; its mesh stays in its bind pose"),
            }
        }
        if !self.clips.is_empty() {
            world.entity_mut(root).insert((AnimationTargets(entities), GltfAnimations(self.clips.clone()), AnimatedRadius(self.radius)));
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

fn load_buffers(document: &Document, mut blob: Option<Vec<u8>>, base: Option<&Path>, file: &Path) -> Result<Vec<Vec<u8>>, GltfError> {
    let mut buffers = document
        .buffers()
        .map(|buffer| {
            if ext_meshopt::is_fallback(&buffer) {
                // Its views are decoded from compressed ones below, and it grows to hold them; a
                // URI, if any, is ignored.
                return Ok(Vec::new());
            }
            let (data, what) = match buffer.source() {
                ::gltf::buffer::Source::Bin => (
                    blob.take().ok_or_else(|| GltfError::BadBuffer {
                        buffer: format!("#{} (GLB BIN chunk) of {}", buffer.index(), file.display()),
                        reason: "the file has no BIN chunk".into(),
                    })?,
                    format!("#{} (GLB BIN chunk) of {}", buffer.index(), file.display()),
                ),
                ::gltf::buffer::Source::Uri(uri) => {
                    (read_uri(uri, base)?, format!("#{} ({}) of {}", buffer.index(), short_uri(uri), file.display()))
                }
            };
            if data.len() < buffer.length() {
                return Err(GltfError::BadBuffer {
                    buffer: what,
                    reason: format!("{} bytes declared, {} found", buffer.length(), data.len()),
                });
            }
            Ok(data)
        })
        .collect::<Result<Vec<_>, GltfError>>()?;
    ext_meshopt::decode_views(document, &mut buffers, file)?;
    Ok(buffers)
}

#[cfg(test)]
mod tests {
    use super::*;
    use ::gltf::json::Value;

    fn glb(json: &str, bin: &[u8]) -> Vec<u8> {
        super::glb_container(json.as_bytes(), bin)
    }

    /// One triangle: three float positions (36 bytes) and u16 indices 0, 1, 2 (6 bytes, padded).
    fn triangle_bin(indices: [u16; 3]) -> Vec<u8> {
        let positions: [f32; 9] = [0.0, 0.0, 0.0, 1.0, 0.0, 0.0, 0.0, 1.0, 0.0];
        let mut bin: Vec<u8> = positions.iter().flat_map(|f| f.to_le_bytes()).collect();
        bin.extend(indices.iter().flat_map(|i| i.to_le_bytes()));
        bin.extend([0, 0]);
        bin
    }

    fn triangle_json() -> Value {
        ::gltf::json::deserialize::from_str(
            r#"{"asset":{"version":"2.0"},
              "buffers":[{"byteLength":44}],
              "bufferViews":[{"buffer":0,"byteOffset":0,"byteLength":36},{"buffer":0,"byteOffset":36,"byteLength":6}],
              "accessors":[{"bufferView":0,"componentType":5126,"count":3,"type":"VEC3","min":[0,0,0],"max":[1,1,0]},
                           {"bufferView":1,"componentType":5123,"count":3,"type":"SCALAR"}],
              "meshes":[{"name":"Tri","primitives":[{"attributes":{"POSITION":0},"indices":1}]}],
              "nodes":[{"mesh":0}],"scenes":[{"nodes":[0]}],"scene":0}"#,
        )
        .unwrap()
    }

    /// Loads the triangle after `mutate` changed its JSON, with `bin` as its BIN chunk.
    fn load_mutated(bin: &[u8], mutate: impl FnOnce(&mut Value)) -> Result<GltfScene, GltfError> {
        let mut json = triangle_json();
        mutate(&mut json);
        load_slice(&glb(&::gltf::json::serialize::to_string(&json).unwrap(), bin), None)
    }

    #[test]
    fn the_test_triangle_loads() {
        let scene = load_mutated(&triangle_bin([0, 1, 2]), |_| {}).unwrap();
        assert_eq!(scene.triangle_count(), 1);
    }

    /// Asserts a `BadAccessor` error for `attribute` whose reason contains `reason`.
    fn assert_bad_accessor(result: Result<GltfScene, GltfError>, attribute: &str, reason: &str) {
        let error = result.unwrap_err();
        let message = error.to_string();
        assert!(
            matches!(&error, GltfError::BadAccessor { attribute: a, .. } if a == attribute),
            "expected a bad {attribute} accessor: {message}"
        );
        assert!(message.contains("'Tri' (#0) primitive 0 in <memory>") && message.contains(reason), "{message}");
    }

    #[test]
    fn bogus_accessor_ranges_are_errors_naming_mesh_and_attribute() {
        let bin = triangle_bin([0, 1, 2]);
        for count in [4u64, 1 << 31, u64::MAX >> 1] {
            assert_bad_accessor(load_mutated(&bin, |j| j["accessors"][0]["count"] = count.into()), "POSITION", "exceed buffer view 0");
            assert_bad_accessor(load_mutated(&bin, |j| j["accessors"][1]["count"] = count.into()), "indices", "exceed buffer view 1");
        }
        for offset in [4u64, 1 << 40, u64::MAX >> 1] {
            assert_bad_accessor(load_mutated(&bin, |j| j["accessors"][0]["byteOffset"] = offset.into()), "POSITION", "offset");
        }
        // A stride wider than the view holds for three elements, and one narrower than an element.
        assert_bad_accessor(load_mutated(&bin, |j| j["bufferViews"][0]["byteStride"] = 252.into()), "POSITION", "stride 252");
        assert_bad_accessor(
            load_mutated(&bin, |j| j["bufferViews"][0]["byteStride"] = 8.into()),
            "POSITION",
            "smaller than the element size 12",
        );
        // Views outside their buffer: past its end, or at an offset that overflows.
        assert_bad_accessor(load_mutated(&bin, |j| j["bufferViews"][1]["byteOffset"] = 40.into()), "indices", "lies outside its buffer");
        assert_bad_accessor(
            load_mutated(&bin, |j| j["bufferViews"][0]["byteOffset"] = (u64::MAX >> 1).into()),
            "POSITION",
            "lies outside its buffer",
        );
        assert_bad_accessor(
            load_mutated(&bin, |j| j["bufferViews"][1]["byteLength"] = (1u64 << 40).into()),
            "indices",
            "lies outside its buffer",
        );
        // The index view is too short for its three indices.
        assert_bad_accessor(load_mutated(&bin, |j| j["bufferViews"][1]["byteLength"] = 4.into()), "indices", "exceed buffer view 1");
        // A buffer declared longer than the BIN chunk.
        let error = load_mutated(&bin, |j| j["buffers"][0]["byteLength"] = (1u64 << 40).into()).unwrap_err();
        assert!(matches!(error, GltfError::BadBuffer { .. }), "{error}");
        assert!(error.to_string().contains("GLB BIN chunk) of <memory>"), "{error}");
    }

    /// Makes POSITION a sparse accessor without a buffer view: zeros, with element 0 replaced
    /// by the first position (also zero).
    fn unbacked(json: &mut Value) {
        let accessor = json["accessors"][0].as_object_mut().unwrap();
        accessor.remove("bufferView");
        accessor.insert(
            "sparse".into(),
            ::gltf::json::deserialize::from_str(r#"{"count":1,"indices":{"bufferView":1,"componentType":5123},"values":{"bufferView":0}}"#)
                .unwrap(),
        );
    }

    #[test]
    fn huge_counts_without_a_buffer_view_are_refused_before_allocating() {
        let bin = triangle_bin([0, 1, 2]);
        for count in [1u64 << 31, u64::MAX >> 1, (MAX_UNBACKED_COMPONENTS / 3 + 1) as u64] {
            let result = load_mutated(&bin, |j| {
                unbacked(j);
                j["accessors"][0]["count"] = count.into();
            });
            assert_bad_accessor(result, "POSITION", "without a buffer view exceed the limit");
        }
        // A small unbacked accessor is legal: all zeros.
        let scene = load_mutated(&bin, unbacked).unwrap();
        assert_eq!(scene.meshes[0][0].0.positions, vec![[0.0, 0.0, 0.0], [0.0; 3], [0.0; 3]]);
    }

    #[test]
    fn out_of_range_indices_refuse_the_file_naming_the_mesh() {
        for (indices, at, index) in [([0, 1, 3], 2, 3), ([65535, 0, 1], 0, 65535)] {
            let error = load_mutated(&triangle_bin(indices), |_| {}).unwrap_err();
            let message = error.to_string();
            assert!(
                matches!(&error, GltfError::Mesh { source: MeshError::IndexOutOfRange { at: a, index: i, vertices: 3 }, .. } if (*a, *i) == (at, index)),
                "{message}"
            );
            assert!(message.contains("'Tri' (#0) primitive 0 in <memory>") && message.contains("out of range for 3 vertices"), "{message}");
        }
    }

    #[test]
    fn glb_headers_declaring_less_than_themselves_are_parse_errors() {
        let mut bytes = glb(&::gltf::json::serialize::to_string(&triangle_json()).unwrap(), &triangle_bin([0, 1, 2]));
        for length in [0u32, 11] {
            bytes[8..12].copy_from_slice(&length.to_le_bytes());
            let error = load_slice(&bytes, None).unwrap_err();
            assert!(matches!(error, GltfError::Parse { .. }), "{error}");
            assert!(error.to_string().contains(&format!("declares a total length of {length} bytes")), "{error}");
            // Every shorter prefix is an error too, never a panic.
            for len in 0..24 {
                assert!(load_slice(&bytes[..len], None).is_err());
            }
        }
    }

    #[test]
    fn attributes_naming_missing_accessors_are_parse_errors() {
        // gltf-json's own validation would index past the accessors for POSITION.
        let bin = triangle_bin([0, 1, 2]);
        for (attribute, index) in [("POSITION", 2u64), ("POSITION", u32::MAX as u64), ("NORMAL", 7)] {
            let error = load_mutated(&bin, |j| j["meshes"][0]["primitives"][0]["attributes"][attribute] = index.into()).unwrap_err();
            assert!(matches!(error, GltfError::Parse { .. }), "{error}");
            let message = error.to_string();
            assert!(message.contains(&format!("meshes[0].primitives[0].attributes[\"{attribute}\"]")), "{message}");
        }
        let error = load_mutated(&bin, |j| j["accessors"] = Value::Array(Vec::new())).unwrap_err();
        assert!(matches!(error, GltfError::Parse { .. }), "{error}");
    }

    /// Nodes 0..count, each with `children(i)`, the scene's roots `roots` (no scene if `None`).
    fn nodes_json(count: usize, children: impl Fn(usize) -> Vec<usize>, roots: Option<&[usize]>) -> Vec<u8> {
        let nodes: Vec<String> = (0..count)
            .map(|i| {
                let c = children(i);
                if c.is_empty() { "{}".to_owned() } else { format!(r#"{{"children":{c:?}}}"#) }
            })
            .collect();
        let scenes = roots.map_or(String::new(), |r| format!(r#","scenes":[{{"nodes":{r:?}}}],"scene":0"#));
        format!(r#"{{"asset":{{"version":"2.0"}},"nodes":[{}]{scenes}}}"#, nodes.join(",")).into_bytes()
    }

    /// `parent` and `children` agree, and walking up from every node ends at a root.
    fn assert_forest(scene: &GltfScene) {
        for (i, node) in scene.nodes.iter().enumerate() {
            for &child in &node.children {
                assert_eq!(scene.nodes[child].parent, Some(i), "child {child} of {i}");
            }
            if let Some(parent) = node.parent {
                assert!(scene.nodes[parent].children.contains(&i), "{i} is among its parent {parent}'s children");
            }
            let mut up = node.parent;
            for _ in 0..scene.nodes.len() {
                up = up.and_then(|p| scene.nodes[p].parent);
            }
            assert_eq!(up, None, "walking up from {i} ends");
        }
    }

    /// Spawns the scene and counts the spawned node entities (those with a `Transform` other
    /// than the root's).
    fn spawned_nodes(scene: GltfScene) -> usize {
        let mut world = World::new();
        scene.spawn(&mut world);
        world.query::<&Transform>().iter(&world).count() - 1
    }

    #[test]
    fn cyclic_hierarchies_are_cut_into_trees() {
        // 0 → 1 → 2 → 0, 3 → 3, and 4 → 5 → 4 with no scene (so no parentless node there).
        let cycle = |i: usize| match i {
            0 => vec![1],
            1 => vec![2],
            2 => vec![0],
            3 => vec![3],
            4 => vec![5],
            5 => vec![4],
            _ => vec![],
        };
        let scene = load_slice(&nodes_json(6, cycle, Some(&[0, 3])), None).unwrap();
        assert_forest(&scene);
        assert_eq!(scene.nodes[0].parent, None, "the walk from 0 cuts the edge above 0");
        assert_eq!((scene.nodes[1].parent, scene.nodes[2].parent), (Some(0), Some(1)));
        assert_eq!((scene.nodes[3].parent, &scene.nodes[3].children), (None, &vec![]));
        assert_eq!(spawned_nodes(scene), 4, "nodes 0 to 3, each once");

        let scene = load_slice(&nodes_json(6, cycle, None), None).unwrap();
        assert_forest(&scene);
        assert_eq!(scene.roots, vec![0, 3, 4], "each cut cycle has a root");
        assert_eq!(spawned_nodes(scene), 6);
    }

    #[test]
    fn nodes_with_several_parents_keep_the_first() {
        // 0 → [2, 2], 1 → [2, 3], 3 → [0]: 2 keeps parent 0; 3 → 0 → 2.
        let children = |i: usize| match i {
            0 => vec![2, 2],
            1 => vec![2, 3],
            3 => vec![0],
            _ => vec![],
        };
        let scene = load_slice(&nodes_json(4, children, Some(&[1])), None).unwrap();
        assert_forest(&scene);
        assert_eq!(scene.nodes[0].children, vec![2]);
        assert_eq!(scene.nodes[1].children, vec![3]);
        assert_eq!(scene.nodes[0].parent, Some(3));
        assert_eq!(spawned_nodes(scene), 4);
    }

    #[test]
    fn a_hundred_thousand_nested_nodes_load_and_spawn() {
        const DEPTH: usize = 100_000;
        let chain = |i: usize| if i + 1 < DEPTH { vec![i + 1] } else { vec![] };
        let scene = load_slice(&nodes_json(DEPTH, chain, Some(&[0])), None).unwrap();
        assert_eq!(scene.nodes[DEPTH - 1].parent, Some(DEPTH - 2));
        assert_eq!(scene.roots, vec![0]);
        assert_forest_chain(&scene);
        assert_eq!(spawned_nodes(scene), DEPTH);
        // The same chain closed into a cycle, without a scene.
        let ring = |i: usize| vec![(i + 1) % DEPTH];
        let scene = load_slice(&nodes_json(DEPTH, ring, None), None).unwrap();
        assert_eq!(scene.roots, vec![0]);
        assert_eq!(spawned_nodes(scene), DEPTH);
    }

    /// [`assert_forest`] in linear time, for long chains.
    fn assert_forest_chain(scene: &GltfScene) {
        let roots = scene.nodes.iter().filter(|n| n.parent.is_none()).count();
        assert_eq!(roots, 1);
        for (i, node) in scene.nodes.iter().enumerate() {
            assert!(node.children.iter().all(|&c| scene.nodes[c].parent == Some(i)));
        }
    }
}
