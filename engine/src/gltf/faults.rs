//! Faults of a glTF file that cost only the broken part: each is one warning when the file is
//! loaded and one [`GltfFault`] in [`GltfScene::faults`](super::GltfScene::faults), naming the
//! file, the object and what was done instead.

use std::fmt;
use std::path::{Path, PathBuf};

use tracing::warn;

/// The object of a glTF file a [`GltfFault`] concerns, by index (as in the file) and name.
#[derive(Clone, Debug, PartialEq, Eq)]
pub enum GltfPart {
    /// A skin.
    Skin {
        /// The skin's index.
        index: usize,
        /// Its name.
        name: Option<String>,
    },
    /// One joint of a skin.
    Joint {
        /// The skin's index.
        skin: usize,
        /// The skin's name.
        skin_name: Option<String>,
        /// The joint's position in the skin's joint list.
        joint: usize,
        /// The joint's node.
        node: usize,
    },
    /// The joints and weights (`JOINTS_0`, `WEIGHTS_0`) of a mesh primitive.
    SkinWeights {
        /// The mesh's index.
        mesh: usize,
        /// Its name.
        mesh_name: Option<String>,
        /// The primitive's index in the mesh.
        primitive: usize,
    },
    /// A channel of an animation, with the sampler it reads.
    Channel {
        /// The animation's index.
        animation: usize,
        /// Its name.
        animation_name: Option<String>,
        /// The channel's index in the animation.
        channel: usize,
        /// The index of the channel's sampler in the animation.
        sampler: usize,
    },
    /// A morph target of a mesh primitive.
    MorphTarget {
        /// The mesh's index.
        mesh: usize,
        /// Its name.
        mesh_name: Option<String>,
        /// The primitive's index in the mesh.
        primitive: usize,
        /// The target's index.
        target: usize,
    },
    /// A node (its transform).
    Node {
        /// The node's index.
        index: usize,
        /// Its name.
        name: Option<String>,
    },
    /// A `KHR_lights_punctual` light.
    Light {
        /// The light's index in the extension's list.
        index: usize,
        /// Its name.
        name: Option<String>,
    },
    /// A camera.
    Camera {
        /// The camera's index.
        index: usize,
        /// Its name.
        name: Option<String>,
    },
    /// A material.
    Material {
        /// The material's index.
        index: usize,
        /// Its name.
        name: Option<String>,
    },
}

/// `'name' (#index)`, or `#index` without a name.
fn named(f: &mut fmt::Formatter<'_>, index: usize, name: &Option<String>) -> fmt::Result {
    match name {
        Some(name) => write!(f, "'{name}' (#{index})"),
        None => write!(f, "#{index}"),
    }
}

impl fmt::Display for GltfPart {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        let (noun, index, name) = match self {
            GltfPart::Skin { index, name } => ("skin", index, name),
            GltfPart::Node { index, name } => ("node", index, name),
            GltfPart::Light { index, name } => ("light", index, name),
            GltfPart::Camera { index, name } => ("camera", index, name),
            GltfPart::Material { index, name } => ("material", index, name),
            GltfPart::Joint { skin, skin_name, joint, node } => {
                write!(f, "joint {joint} (node #{node}) of skin ")?;
                return named(f, *skin, skin_name);
            }
            GltfPart::SkinWeights { mesh, mesh_name, primitive } => {
                write!(f, "joints and weights of primitive {primitive} of mesh ")?;
                return named(f, *mesh, mesh_name);
            }
            GltfPart::Channel { animation, animation_name, channel, sampler } => {
                write!(f, "channel {channel} (sampler {sampler}) of animation ")?;
                return named(f, *animation, animation_name);
            }
            GltfPart::MorphTarget { mesh, mesh_name, primitive, target } => {
                write!(f, "morph target {target} of primitive {primitive} of mesh ")?;
                return named(f, *mesh, mesh_name);
            }
        };
        write!(f, "{noun} ")?;
        named(f, *index, name)
    }
}

/// What is wrong with the part. `docs/RELIABILITY.md` lists each kind, what the loader does with
/// it and the test that checks it.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub enum GltfFaultKind {
    /// A skin cannot be read: no joints, inverse bind matrices of the wrong type, outside their
    /// buffer or not finite. Its meshes are drawn unskinned, in their rest pose.
    BadSkin,
    /// A skin has fewer (or more) inverse bind matrices than joints. Its meshes are drawn
    /// unskinned.
    InverseBindMatrixCount,
    /// A vertex is weighted to a joint index past the skin's joints. That node's mesh is drawn
    /// unskinned.
    JointIndexOutOfRange,
    /// A joint of a skin is the skinned mesh's own node (a cycle of transforms: the mesh would
    /// move its own joint). That node's mesh is drawn unskinned.
    JointIsSkinnedNode,
    /// `JOINTS_0`/`WEIGHTS_0` cannot be read (one without the other, a wrong type or count).
    /// The primitive is drawn rigidly.
    BadSkinWeights,
    /// Vertices whose weights are not finite or sum to zero: each follows its first joint
    /// alone (weight 1).
    DegenerateWeights,
    /// A cubic-spline sampler without tangents (one value per keyframe, not three). The channel
    /// is dropped.
    CubicSplineWithoutTangents,
    /// A sampler's input (times) and output (values) counts do not match. The channel is
    /// dropped.
    SamplerCountMismatch,
    /// Keyframe times that do not increase. The channel is dropped.
    KeyframeTimesNotIncreasing,
    /// Keyframe times that are not finite (the channel is dropped) or keyframe values that are
    /// not finite (those keyframes are dropped; a channel left without any is dropped).
    NonFiniteKeyframes,
    /// Rotation keyframes of zero length, which name no rotation. Those keyframes are dropped.
    ZeroRotationKeyframes,
    /// Any other channel that cannot be sampled (an accessor outside its buffer or of the wrong
    /// type, no keyframes, a property animated twice). The channel is dropped.
    BadChannel,
    /// A morph target with fewer (or more) offsets than its mesh has vertices. Its offsets
    /// become zero: it has no effect, and the others keep their index and apply.
    MorphTargetLength,
    /// A morph target that cannot be read (wrong type, outside its buffer) or whose offsets are
    /// not finite. Its offsets become zero, as for [`GltfFaultKind::MorphTargetLength`].
    BadMorphTarget,
    /// A node's translation, rotation or scale not finite, or its rotation of zero length: the
    /// bad part is the identity's (translation 0, rotation none, scale 1).
    DegenerateTransform,
    /// A light with a colour, intensity, range or cone that is not finite or out of range. The
    /// node has no light.
    BadLight,
    /// A perspective camera whose field of view or near plane is not finite or out of range.
    /// The engine's default lens (60°, 0.05) stands in.
    BadCamera,
    /// A material factor that is not finite. It takes glTF's default value.
    BadMaterial,
}

/// One fault of a loaded glTF file: the part that was broken and what the loader did instead.
/// Its `Display` is the warning logged when the file was loaded.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct GltfFault {
    /// The glTF file (`<memory>` for [`load_slice`](super::load_slice)).
    pub file: PathBuf,
    /// The broken part.
    pub part: GltfPart,
    /// What kind of fault it is.
    pub kind: GltfFaultKind,
    /// What is wrong, in words.
    pub problem: String,
    /// What the loader did instead.
    pub fallback: String,
}

impl fmt::Display for GltfFault {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(f, "{}: {}: {}; {}", self.file.display(), self.part, self.problem, self.fallback)
    }
}

/// Gathers a file's faults, logging each as one warning.
pub(super) struct Faults {
    file: PathBuf,
    pub(super) list: Vec<GltfFault>,
}

impl Faults {
    pub(super) fn new(file: &Path) -> Self {
        Faults { file: file.to_owned(), list: Vec::new() }
    }

    /// Records a fault and logs it.
    pub(super) fn push(&mut self, part: GltfPart, kind: GltfFaultKind, problem: impl Into<String>, fallback: impl Into<String>) {
        let fault = GltfFault { file: self.file.clone(), part, kind, problem: problem.into(), fallback: fallback.into() };
        warn!(file = %fault.file.display(), part = %fault.part, kind = ?fault.kind, "glTF {}: {}; {}", fault.part, fault.problem, fault.fallback);
        self.list.push(fault);
    }
}
