//! glTF nodes: their transforms, meshes, lights and cameras, and the repair of hierarchies that
//! are not the forest glTF requires.

use super::*;

/// A node's transform, its degenerate parts (not finite, or a rotation of zero length) replaced
/// by the identity's, and what was replaced.
fn node_transform(node: &::gltf::Node<'_>) -> (Transform, Vec<&'static str>) {
    let (t, r, s) = node.transform().decomposed();
    let (translation, rotation, scale) = (Vec3::from(t), Quat::from_array(r), Vec3::from(s));
    let mut repaired = Vec::new();
    let translation = if translation.is_finite() {
        translation
    } else {
        repaired.push("a translation that is not finite (0 instead)");
        Vec3::ZERO
    };
    let rotation = if !rotation.is_finite() {
        repaired.push("a rotation that is not finite (none instead)");
        Quat::IDENTITY
    } else if rotation.length() < 1e-6 {
        repaired.push("a rotation of zero length (none instead)");
        Quat::IDENTITY
    } else {
        rotation.normalize()
    };
    let scale = if scale.is_finite() {
        scale
    } else {
        repaired.push("a scale that is not finite (1 instead)");
        Vec3::ONE
    };
    (Transform { translation, rotation, scale }, repaired)
}

/// The light, or why it cannot shine: a colour, intensity, range or size (`extras`) not finite
/// or negative, or a cone not within 0 ≤ inner < outer ≤ 90°.
fn node_light(light: &::gltf::khr_lights_punctual::Light<'_>) -> Result<GltfLight, String> {
    let color = Vec3::from(light.color());
    let intensity = light.intensity();
    if !color.is_finite() || color.min_element() < 0.0 {
        return Err(format!("its colour {color} is not finite and non-negative"));
    }
    if !intensity.is_finite() || intensity < 0.0 {
        return Err(format!("its intensity {intensity} is not finite and non-negative"));
    }
    if let Some(range) = light.range().filter(|r| !r.is_finite() || *r <= 0.0) {
        return Err(format!("its range {range} is not finite and positive"));
    }
    // Sizes are not in KHR_lights_punctual: a light's `extras` may give its sphere's `radius`
    // (metres) or, for a directional light, its disc's `angular_diameter` (radians); 0 (hard
    // shadows) without.
    let size = |key: &str| -> Result<f32, String> {
        let Some(raw) = light.extras() else { return Ok(0.0) };
        let value: serde_json::Value = serde_json::from_str(raw.get()).map_err(|e| format!("its extras are not JSON: {e}"))?;
        match value.get(key) {
            None => Ok(0.0),
            Some(v) => match v.as_f64().map(|v| v as f32).filter(|v| v.is_finite() && *v >= 0.0) {
                Some(v) => Ok(v),
                None => Err(format!("its extras' {key} {v} is not a finite non-negative number")),
            },
        }
    };
    Ok(match light.kind() {
        ::gltf::khr_lights_punctual::Kind::Point => {
            GltfLight::Point(PointLight { color, intensity, range: light.range(), radius: size("radius")? })
        }
        ::gltf::khr_lights_punctual::Kind::Spot { inner_cone_angle, outer_cone_angle } => {
            let ordered = 0.0 <= inner_cone_angle && inner_cone_angle < outer_cone_angle && outer_cone_angle <= std::f32::consts::FRAC_PI_2;
            if !ordered {
                return Err(format!("its cone angles {inner_cone_angle} and {outer_cone_angle} are not 0 ≤ inner < outer ≤ π/2"));
            }
            GltfLight::Spot(SpotLight {
                color,
                intensity,
                range: light.range(),
                inner_angle: inner_cone_angle,
                outer_angle: outer_cone_angle,
                radius: size("radius")?,
            })
        }
        ::gltf::khr_lights_punctual::Kind::Directional => {
            GltfLight::Directional(DirectionalLight { color, illuminance: intensity, angular_diameter: size("angular_diameter")? })
        }
    })
}

pub(super) fn load_nodes(document: &Document, faults: &mut Faults) -> Vec<GltfNode> {
    let mut nodes: Vec<GltfNode> = document
        .nodes()
        .map(|node| {
            let (transform, mut repaired) = node_transform(&node);
            let mut weights = node.weights().or_else(|| node.mesh().and_then(|m| m.weights())).map(<[f32]>::to_vec).unwrap_or_default();
            if weights.iter().any(|w| !w.is_finite()) {
                repaired.push("morph weights that are not finite (0 instead)");
                weights.iter_mut().filter(|w| !w.is_finite()).for_each(|w| *w = 0.0);
            }
            if !repaired.is_empty() {
                let part = GltfPart::Node { index: node.index(), name: node.name().map(str::to_owned) };
                let problem = format!("it has {}", repaired.join(", "));
                faults.push(part, GltfFaultKind::DegenerateTransform, problem, "those parts are replaced as said");
            }
            let light = node.light().and_then(|light| match node_light(&light) {
                Ok(loaded) => Some(loaded),
                Err(problem) => {
                    let part = GltfPart::Light { index: light.index(), name: light.name().map(str::to_owned) };
                    let fallback = format!("node #{} has no light", node.index());
                    faults.push(part, GltfFaultKind::BadLight, problem, fallback);
                    None
                }
            });
            let camera = node.camera().and_then(|camera| match camera.projection() {
                ::gltf::camera::Projection::Perspective(p) => {
                    let default = Camera::default();
                    let (fov_y, near) = (p.yfov(), p.znear());
                    let fov_ok = fov_y.is_finite() && fov_y > 0.0 && fov_y < std::f32::consts::PI;
                    let near_ok = near.is_finite() && near > 0.0;
                    if !fov_ok || !near_ok {
                        let part = GltfPart::Camera { index: camera.index(), name: camera.name().map(str::to_owned) };
                        let problem = format!(
                            "its vertical field of view {fov_y} or near plane {near} is not finite, positive (and the view under π)"
                        );
                        let fallback =
                            format!("the default {}° and {} stand in for what is wrong", default.fov_y.to_degrees().round(), default.near);
                        faults.push(part, GltfFaultKind::BadCamera, problem, fallback);
                    }
                    Some(Camera {
                        fov_y: if fov_ok { fov_y } else { default.fov_y },
                        near: if near_ok { near } else { default.near },
                        ..default
                    })
                }
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
                skin: node.skin().map(|s| s.index()),
                weights,
                light,
                camera,
            }
        })
        .collect();
    make_forest(&mut nodes);
    nodes
}

/// Repairs a node graph that is not a forest, as glTF requires, so that `parent` and
/// `children` describe the same trees and walking either terminates: a node listed as the
/// child of several nodes keeps its first parent (lowest index), and a cycle of parents is cut
/// above one of its nodes, which becomes a root. One warning for each kind of repair. Iterative
/// and linear in the number of nodes and child references, so arbitrarily deep or cyclic
/// hierarchies neither overflow the stack nor loop.
pub(super) fn make_forest(nodes: &mut [GltfNode]) {
    let count = nodes.len();
    let mut extra_parents = Vec::new();
    for parent in 0..count {
        let mut children = std::mem::take(&mut nodes[parent].children);
        children.retain(|&child| match nodes.get(child).map(|c| c.parent) {
            Some(None) => {
                nodes[child].parent = Some(parent);
                true
            }
            Some(Some(_)) => {
                extra_parents.push((child, parent));
                false
            }
            None => false,
        });
        nodes[parent].children = children;
    }
    if let Some(&(child, parent)) = extra_parents.first() {
        warn!(
            repairs = extra_parents.len(),
            first_child = child,
            kept_parent = nodes[child].parent,
            dropped_parent = parent,
            "glTF nodes listed as children of more than one node; each keeps its first parent"
        );
    }
    // Follow parent links from every node; meeting a node of the current walk again is a cycle.
    #[derive(Clone, Copy, PartialEq)]
    enum State {
        Unvisited,
        OnPath,
        Done,
    }
    let mut state = vec![State::Unvisited; count];
    let mut path = Vec::new();
    let mut cut = Vec::new();
    for start in 0..count {
        let mut current = Some(start);
        while let Some(node) = current.filter(|&n| state[n] == State::Unvisited) {
            state[node] = State::OnPath;
            path.push(node);
            current = nodes[node].parent;
        }
        if let Some(node) = current.filter(|&n| state[n] == State::OnPath) {
            if let Some(parent) = nodes[node].parent.take() {
                nodes[parent].children.retain(|&c| c != node);
            }
            cut.push(node);
        }
        for node in path.drain(..) {
            state[node] = State::Done;
        }
    }
    if !cut.is_empty() {
        warn!(cycles = cut.len(), first_root = cut[0], "glTF node hierarchy has cycles; each is cut above one node, which becomes a root");
    }
}
