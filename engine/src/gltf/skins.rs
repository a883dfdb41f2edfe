//! glTF skins: the joint nodes and their inverse bind matrices, checked against the meshes they
//! deform (every vertex weighted to a joint the skin has).

use glam::Mat4;

use super::*;

/// A glTF skin.
#[derive(Clone, Debug, PartialEq)]
pub struct GltfSkin {
    /// The skin's name in the file.
    pub name: Option<String>,
    /// The joint nodes (indices into [`GltfScene::nodes`]), in the order vertices count them.
    pub joints: Vec<usize>,
    /// One per joint: the inverse of the joint's global transform in the bind pose (identity
    /// when the file gives none, as glTF specifies).
    pub inverse_bind_matrices: Vec<Mat4>,
}

fn label(skin: &::gltf::Skin<'_>, file: &Path) -> String {
    match skin.name() {
        Some(name) => format!("'{name}' (#{}) in {}", skin.index(), file.display()),
        None => format!("#{} in {}", skin.index(), file.display()),
    }
}

/// Loads and checks every skin, and that each skinned node's mesh uses only joints its skin
/// has.
pub(super) fn load_skins(
    document: &Document,
    buffers: &[Vec<u8>],
    file: &Path,
    nodes: &[GltfNode],
    meshes: &[Vec<(Mesh, usize)>],
) -> Result<Vec<GltfSkin>, GltfError> {
    let mut skins = Vec::with_capacity(document.skins().len());
    for skin in document.skins() {
        let name = label(&skin, file);
        let bad = |reason: String| GltfError::Skin { skin: name.clone(), reason };
        let joints: Vec<usize> = skin.joints().map(|j| j.index()).collect();
        if joints.is_empty() {
            return Err(bad("it has no joints".into()));
        }
        let inverse_bind_matrices = match skin.inverse_bind_matrices() {
            None => vec![Mat4::IDENTITY; joints.len()],
            Some(accessor) => {
                if accessor.dimensions() != Dimensions::Mat4 || accessor.data_type() != DataType::F32 {
                    return Err(bad(format!("inverse bind matrices are {}, not float MAT4", describe_accessor(&accessor))));
                }
                let values = read_accessor(&accessor, buffers, &name, "inverseBindMatrices")?;
                let matrices: Vec<Mat4> =
                    values.chunks_exact(16).map(|c| Mat4::from_cols_array(&std::array::from_fn(|i| c[i] as f32))).collect();
                if matrices.len() != joints.len() {
                    return Err(bad(format!("{} inverse bind matrices for {} joints", matrices.len(), joints.len())));
                }
                if let Some(i) = matrices.iter().position(|m| !m.is_finite()) {
                    return Err(bad(format!("inverse bind matrix {i} is not finite")));
                }
                matrices
            }
        };
        skins.push(GltfSkin { name: skin.name().map(str::to_owned), joints, inverse_bind_matrices });
    }
    for (index, node) in nodes.iter().enumerate() {
        let (Some(skin), Some(mesh)) = (node.skin, node.mesh) else { continue };
        let Some(skin) = skins.get(skin) else { continue };
        for (primitive, (mesh_data, _)) in meshes.get(mesh).into_iter().flatten().enumerate() {
            if let Some(max) = mesh_data.skin.as_ref().and_then(|s| s.max_joint())
                && max as usize >= skin.joints.len()
            {
                return Err(GltfError::Skin {
                    skin: format!("{} on node #{index}", skin.name.as_deref().unwrap_or("(unnamed)")),
                    reason: format!(
                        "mesh #{mesh} primitive {primitive} weights joint {max}, but the skin has {} joints",
                        skin.joints.len()
                    ),
                });
            }
        }
    }
    Ok(skins)
}
