//! glTF skins: the joint nodes and their inverse bind matrices, checked against the meshes they
//! deform. A skin that cannot deform its meshes costs only its meshes' pose: they are drawn
//! unskinned, in their rest pose, with one [`GltfFault`] (see the parent module's docs).

use glam::Mat4;

use super::*;

/// A glTF skin.
#[derive(Clone, Debug, PartialEq)]
pub struct GltfSkin {
    /// The skin's name in the file.
    pub name: Option<String>,
    /// The joint nodes (indices into [`GltfScene::nodes`]), in the order vertices count them.
    /// Empty for a skin refused on loading (a [`GltfFault`] says why): no node uses it.
    pub joints: Vec<usize>,
    /// One per joint: the inverse of the joint's global transform in the bind pose (identity
    /// when the file gives none, as glTF specifies).
    pub inverse_bind_matrices: Vec<Mat4>,
}

/// Reads one skin, or says why it cannot deform anything.
fn read_skin(skin: &::gltf::Skin<'_>, buffers: &[Vec<u8>], file: &Path) -> Result<GltfSkin, (GltfFaultKind, String)> {
    let joints: Vec<usize> = skin.joints().map(|j| j.index()).collect();
    if joints.is_empty() {
        return Err((GltfFaultKind::BadSkin, "it has no joints".into()));
    }
    let inverse_bind_matrices = match skin.inverse_bind_matrices() {
        None => vec![Mat4::IDENTITY; joints.len()],
        Some(accessor) => {
            if accessor.dimensions() != Dimensions::Mat4 || accessor.data_type() != DataType::F32 {
                let found = describe_accessor(&accessor);
                return Err((GltfFaultKind::BadSkin, format!("its inverse bind matrices are {found}, not float MAT4")));
            }
            let label = format!("skin #{} in {}", skin.index(), file.display());
            let values =
                read_accessor(&accessor, buffers, &label, "inverseBindMatrices").map_err(|e| (GltfFaultKind::BadSkin, e.to_string()))?;
            let matrices: Vec<Mat4> =
                values.chunks_exact(16).map(|c| Mat4::from_cols_array(&std::array::from_fn(|i| c[i] as f32))).collect();
            if matrices.len() != joints.len() {
                let problem = format!("{} inverse bind matrices for {} joints", matrices.len(), joints.len());
                return Err((GltfFaultKind::InverseBindMatrixCount, problem));
            }
            if let Some(i) = matrices.iter().position(|m| !m.is_finite()) {
                return Err((GltfFaultKind::BadSkin, format!("inverse bind matrix {i} is not finite")));
            }
            matrices
        }
    };
    Ok(GltfSkin { name: skin.name().map(str::to_owned), joints, inverse_bind_matrices })
}

/// Loads every skin, and checks each skinned node against its skin: its mesh weights only
/// joints the skin has, and it is not a joint of its own skin. A skin that cannot be read is
/// kept as an empty placeholder (indices stay those of the file) and every node loses it; a
/// node that fails its check loses its skin alone. One fault each.
pub(super) fn load_skins(
    document: &Document,
    buffers: &[Vec<u8>],
    file: &Path,
    nodes: &mut [GltfNode],
    meshes: &[Vec<(Mesh, usize)>],
    faults: &mut Faults,
) -> Vec<GltfSkin> {
    const UNSKINNED: &str = "the meshes it deforms are drawn unskinned, in their rest pose";
    let mut skins = Vec::with_capacity(document.skins().len());
    for skin in document.skins() {
        match read_skin(&skin, buffers, file) {
            Ok(loaded) => skins.push(Some(loaded)),
            Err((kind, problem)) => {
                faults.push(GltfPart::Skin { index: skin.index(), name: skin.name().map(str::to_owned) }, kind, problem, UNSKINNED);
                skins.push(None);
            }
        }
    }
    for (index, node) in nodes.iter_mut().enumerate() {
        let Some(skin_index) = node.skin else { continue };
        let Some(Some(skin)) = skins.get(skin_index) else {
            node.skin = None;
            continue;
        };
        let part = || GltfPart::Skin { index: skin_index, name: skin.name.clone() };
        let node_name = node.name.as_deref().map_or_else(|| format!("#{index}"), |n| format!("'{n}' (#{index})"));
        let fallback = format!("node {node_name}'s mesh is drawn unskinned, in its rest pose");
        if let Some(joint) = skin.joints.iter().position(|&j| j == index) {
            let part = GltfPart::Joint { skin: skin_index, skin_name: skin.name.clone(), joint, node: index };
            let problem = format!("the joint is node {node_name}, which its skin deforms (a cycle of transforms)");
            faults.push(part, GltfFaultKind::JointIsSkinnedNode, problem, fallback);
            node.skin = None;
            continue;
        }
        let Some(mesh) = node.mesh else { continue };
        let past = meshes.get(mesh).into_iter().flatten().enumerate().find_map(|(primitive, (mesh_data, _))| {
            let max = mesh_data.skin.as_ref().and_then(|s| s.max_joint())?;
            (max as usize >= skin.joints.len()).then_some((primitive, max))
        });
        if let Some((primitive, max)) = past {
            let problem = format!(
                "mesh #{mesh} primitive {primitive} on node {node_name} weights joint {max}, but the skin has {} joints",
                skin.joints.len()
            );
            faults.push(part(), GltfFaultKind::JointIndexOutOfRange, problem, fallback);
            node.skin = None;
        }
    }
    skins
        .into_iter()
        .zip(document.skins())
        .map(|(skin, source)| {
            skin.unwrap_or_else(|| GltfSkin {
                name: source.name().map(str::to_owned),
                joints: Vec::new(),
                inverse_bind_matrices: Vec::new(),
            })
        })
        .collect()
}
