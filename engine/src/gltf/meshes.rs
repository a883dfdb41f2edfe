//! glTF accessors and mesh primitives: bounds-checked accessor reads (strides, sparse
//! substitution, quantized types) and the conversion of each primitive into a [`Mesh`].

use super::*;

pub(super) fn describe_accessor(accessor: &Accessor<'_>) -> String {
    format!("{:?} {:?}{}", accessor.dimensions(), accessor.data_type(), if accessor.normalized() { " normalized" } else { "" })
}

pub(super) fn component_size(data_type: DataType) -> usize {
    match data_type {
        DataType::I8 | DataType::U8 => 1,
        DataType::I16 | DataType::U16 => 2,
        DataType::U32 | DataType::F32 => 4,
    }
}

/// One component as `f64` (exact for every glTF component type), normalised if asked.
pub(super) fn decode_component(data_type: DataType, normalized: bool, b: &[u8]) -> f64 {
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

/// Most components (elements × components per element) an accessor without a buffer view may
/// declare: such an accessor is all zeros (plus sparse substitutions), so its memory is not
/// bounded by any bytes in the file. 2²² components is 32 MiB as decoded, about 1.4 million
/// `VEC3` elements; a larger declared count is a [`GltfError::BadAccessor`].
pub const MAX_UNBACKED_COMPONENTS: usize = 1 << 22;

/// Reads an accessor into `count × components` values, honouring offsets, strides and sparse
/// substitution, with every range checked against its buffer.
pub(super) fn read_accessor(accessor: &Accessor<'_>, buffers: &[Vec<u8>], mesh: &str, attribute: &str) -> Result<Vec<f64>, GltfError> {
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
        let components = count.checked_mul(comps).filter(|&n| n <= MAX_UNBACKED_COMPONENTS);
        let Some(components) = components else {
            return Err(fail(format!(
                "{count} elements of {comps} components without a buffer view exceed the limit of {MAX_UNBACKED_COMPONENTS} components"
            )));
        };
        out = vec![0.0; components];
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
pub(super) fn read_attribute<const N: usize>(
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

pub(super) fn is_float(data_type: DataType, normalized: bool) -> bool {
    data_type == DataType::F32 && !normalized
}

/// Small integer component types (`KHR_mesh_quantization`).
pub(super) fn is_small_int(data_type: DataType) -> bool {
    matches!(data_type, DataType::I8 | DataType::U8 | DataType::I16 | DataType::U16)
}

/// Which primitive of which mesh [`load_primitive`] reads, for its faults.
pub(super) struct PrimitivePart {
    pub(super) mesh: usize,
    pub(super) mesh_name: Option<String>,
    pub(super) primitive: usize,
}

/// `mesh` labels the primitive in errors, `part` in faults. `quantized`: the document uses
/// `KHR_mesh_quantization`, so its attribute types are accepted. `uv_transform`: the material's
/// `KHR_texture_transform`, baked into `TEXCOORD_0`. Joints and weights that cannot be read, and
/// morph targets that cannot be read or do not fit the mesh, are faults, not errors: the
/// primitive is drawn rigidly, or the target has no effect.
pub(super) fn load_primitive(
    primitive: &::gltf::Primitive<'_>,
    buffers: &[Vec<u8>],
    mesh: &str,
    part: &PrimitivePart,
    quantized: bool,
    uv_transform: Option<UvTransform>,
    faults: &mut Faults,
) -> Result<Mesh, GltfError> {
    let mode = primitive.mode();
    if !matches!(mode, Mode::Triangles | Mode::TriangleStrip | Mode::TriangleFan) {
        return Err(GltfError::UnsupportedPrimitiveMode { mesh: mesh.to_owned(), mode: format!("{mode:?}") });
    }
    let attribute = |semantic: ::gltf::Semantic| primitive.get(&semantic);
    let position_accessor = attribute(::gltf::Semantic::Positions)
        .ok_or_else(|| GltfError::MissingAttribute { mesh: mesh.to_owned(), attribute: "POSITION".into() })?;
    let position_ok = |t, norm| is_float(t, norm) || (quantized && is_small_int(t));
    // Signed normalised only: unit vectors need negative components.
    let direction_ok = |t, norm| is_float(t, norm) || (quantized && norm && matches!(t, DataType::I8 | DataType::I16));
    let uv_ok = |t, norm| is_float(t, norm) || (norm && matches!(t, DataType::U8 | DataType::U16)) || (quantized && is_small_int(t));
    let positions: Vec<[f32; 3]> = read_attribute(&position_accessor, buffers, mesh, "POSITION", position_ok)?;
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
    let normals = attribute(::gltf::Semantic::Normals)
        .map(|a| {
            let normals = read_attribute::<3>(&a, buffers, mesh, "NORMAL", direction_ok)?;
            // Quantised normals are only approximately unit length.
            Ok(if a.data_type() == DataType::F32 {
                normals
            } else {
                normals.into_iter().map(|n| Vec3::from(n).normalize_or(Vec3::Y).into()).collect()
            })
        })
        .transpose()?;
    let uvs = attribute(::gltf::Semantic::TexCoords(0)).map(|a| read_attribute::<2>(&a, buffers, mesh, "TEXCOORD_0", uv_ok)).transpose()?;
    let tangents =
        attribute(::gltf::Semantic::Tangents).map(|a| read_attribute::<4>(&a, buffers, mesh, "TANGENT", direction_ok)).transpose()?;
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
    // Out-of-range indices refuse the primitive (and so the file), naming the mesh, the
    // position in the index accessor and the vertex count, before any per-vertex work.
    if let Some((at, &index)) = raw_indices.iter().enumerate().find(|&(_, &i)| i as usize >= n) {
        return Err(GltfError::Mesh { mesh: mesh.to_owned(), source: MeshError::IndexOutOfRange { at, index, vertices: n } });
    }
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
    let mut uvs = uvs.unwrap_or_else(|| vec![[0.0; 2]; n]);
    if let Some(transform) = uv_transform {
        uvs.iter_mut().for_each(|uv| *uv = transform.apply(*uv));
    }
    let skin_part = || GltfPart::SkinWeights { mesh: part.mesh, mesh_name: part.mesh_name.clone(), primitive: part.primitive };
    let skin = match (attribute(::gltf::Semantic::Joints(0)), attribute(::gltf::Semantic::Weights(0))) {
        (Some(joints), Some(weights)) => {
            let read = || -> Result<SkinWeights, GltfError> {
                let joints =
                    read_attribute::<4>(&joints, buffers, mesh, "JOINTS_0", |t, norm| !norm && matches!(t, DataType::U8 | DataType::U16))?;
                let weights = read_attribute::<4>(&weights, buffers, mesh, "WEIGHTS_0", |t, norm| {
                    is_float(t, norm) || (norm && matches!(t, DataType::U8 | DataType::U16))
                })?;
                same_count("JOINTS_0", joints.len())?;
                same_count("WEIGHTS_0", weights.len())?;
                Ok(SkinWeights { joints: joints.into_iter().map(|j| j.map(|i| i as u16)).collect(), weights })
            };
            match read() {
                Ok(SkinWeights { joints, weights }) => {
                    let (skin, repaired) = SkinWeights::repaired(joints, weights);
                    if repaired.non_finite + repaired.zero > 0 {
                        let problem = format!(
                            "{} of {n} vertices have weights that are not finite and {} weights that sum to zero",
                            repaired.non_finite, repaired.zero
                        );
                        faults.push(
                            skin_part(),
                            GltfFaultKind::DegenerateWeights,
                            problem,
                            "each of them follows its first joint alone (weight 1)",
                        );
                    }
                    Some(skin)
                }
                Err(error) => {
                    faults.push(skin_part(), GltfFaultKind::BadSkinWeights, error.to_string(), "the primitive is drawn rigidly, unskinned");
                    None
                }
            }
        }
        (None, None) => None,
        (joints, _) => {
            let problem = format!(
                "{} without {}",
                if joints.is_some() { "JOINTS_0" } else { "WEIGHTS_0" },
                if joints.is_some() { "WEIGHTS_0" } else { "JOINTS_0" }
            );
            faults.push(skin_part(), GltfFaultKind::BadSkinWeights, problem, "the primitive is drawn rigidly, unskinned");
            None
        }
    };
    let mut morph_targets = Vec::new();
    for (i, target) in primitive.morph_targets().enumerate() {
        let label = |what: &str| format!("morph target {i} {what}");
        let read = |accessor: Option<Accessor<'_>>, what: &str| -> Result<Vec<[f32; 3]>, (GltfFaultKind, String)> {
            let Some(accessor) = accessor else { return Ok(Vec::new()) };
            let values = read_attribute::<3>(&accessor, buffers, mesh, &label(what), position_ok)
                .map_err(|e| (GltfFaultKind::BadMorphTarget, e.to_string()))?;
            if values.len() != n {
                let problem = format!("its {what} has {} offsets for {n} vertices", values.len());
                return Err((GltfFaultKind::MorphTargetLength, problem));
            }
            if let Some(v) = values.iter().position(|d| !Vec3::from(*d).is_finite()) {
                return Err((GltfFaultKind::BadMorphTarget, format!("its {what} offset of vertex {v} is not finite")));
            }
            Ok(values)
        };
        let read_target = || -> Result<MorphTarget, (GltfFaultKind, String)> {
            let positions = read(target.positions(), "POSITION")?;
            let normals = read(target.normals(), "NORMAL")?;
            Ok(MorphTarget { positions: if positions.is_empty() { vec![[0.0; 3]; n] } else { positions }, normals })
        };
        match read_target() {
            Ok(target) => morph_targets.push(target),
            Err((kind, problem)) => {
                let part =
                    GltfPart::MorphTarget { mesh: part.mesh, mesh_name: part.mesh_name.clone(), primitive: part.primitive, target: i };
                faults.push(part, kind, problem, "its offsets are zero (it has no effect); the other targets keep their index and apply");
                morph_targets.push(MorphTarget { positions: vec![[0.0; 3]; n], normals: Vec::new() });
            }
        }
    }
    let result = match tangents {
        Some(tangents) => Mesh::from_parts(positions, normals, uvs, tangents, indices).map(|mut mesh| {
            mesh.orthonormalize_tangents();
            mesh
        }),
        None => Mesh::new(positions, normals, uvs, indices),
    };
    result
        .and_then(|mut m| {
            m.skin = skin;
            m.morph_targets = morph_targets;
            m.validate().map(|()| m)
        })
        .map_err(|source| GltfError::Mesh { mesh: mesh.to_owned(), source })
}

/// Most coarser levels a mesh takes from `MSFT_lod` (the renderer draws up to four).
pub const MAX_AUTHORED_LODS: usize = 4;

/// Attaches the coarser levels that nodes name with `MSFT_lod` (`{"ids": [node, …]}`, finest
/// first) to their meshes: primitive `p` of each named node's mesh becomes a level of primitive
/// `p` of the node's own mesh ([`Mesh::lods`]). A named node without a mesh, a level with another
/// number of primitives, a level whose skin or morph targets differ from its mesh's, or more than
/// [`MAX_AUTHORED_LODS`] levels are left out with one warning each; a mesh several nodes name
/// levels for keeps the first node's. The levels' screen coverages (`MSFT_screencoverage`) are
/// not read: the renderer picks levels by their geometric error, as it does its own.
pub(super) fn attach_authored_lods(document: &::gltf::Document, meshes: &mut [Vec<(Mesh, usize)>], file: &Path) {
    let nodes: Vec<_> = document.nodes().collect();
    for node in &nodes {
        let Some(ids) = node.extensions().and_then(|e| e.get("MSFT_lod")).and_then(|lod| lod.get("ids")).and_then(|ids| ids.as_array())
        else {
            continue;
        };
        let Some(mesh) = node.mesh().map(|m| m.index()) else { continue };
        if meshes[mesh].iter().any(|(m, _)| !m.lods.is_empty()) {
            continue;
        }
        let mut levels = Vec::new();
        for id in ids {
            let level = id.as_u64().and_then(|i| nodes.get(i as usize)).and_then(|n| n.mesh()).map(|m| m.index());
            match level {
                Some(level) if level != mesh && meshes[level].len() == meshes[mesh].len() => levels.push(level),
                _ => warn!(
                    file = %file.display(),
                    node = node.index(),
                    "MSFT_lod names {id}, which is not a node whose mesh has as many primitives as this node's; that level is left out"
                ),
            }
        }
        if levels.len() > MAX_AUTHORED_LODS {
            warn!(file = %file.display(), node = node.index(), "MSFT_lod names {} levels; the first {MAX_AUTHORED_LODS} are kept", levels.len());
            levels.truncate(MAX_AUTHORED_LODS);
        }
        for p in 0..meshes[mesh].len() {
            let attached: Vec<Mesh> = levels
                .iter()
                .map(|&level| meshes[level][p].0.clone())
                .filter(|level| {
                    let base = &meshes[mesh][p].0;
                    let fits =
                        level.skin.is_some() == base.skin.is_some() && level.morph_targets.is_empty() && base.morph_targets.is_empty();
                    if !fits {
                        warn!(
                            file = %file.display(),
                            node = node.index(),
                            primitive = p,
                            "an MSFT_lod level's skin or morph targets differ from its mesh's; that level is left out"
                        );
                    }
                    fits
                })
                .collect();
            meshes[mesh][p].0.lods = attached;
        }
    }
}
