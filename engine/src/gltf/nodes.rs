//! glTF nodes: their transforms, meshes, lights and cameras, and the repair of hierarchies that
//! are not the forest glTF requires.

use super::*;

pub(super) fn load_nodes(document: &Document) -> Vec<GltfNode> {
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
                skin: node.skin().map(|s| s.index()),
                weights: node.weights().or_else(|| node.mesh().and_then(|m| m.weights())).map(<[f32]>::to_vec).unwrap_or_default(),
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
