//! Scene components: a renderable mesh instance and a debug name.

use bevy_ecs::prelude::*;

use crate::asset::Handle;
use crate::material::Material;
use crate::mesh::Mesh;
use crate::transform::Transform;

/// Draws `mesh` with `material` at its entity's `GlobalTransform`.
#[derive(Component, Clone, Copy, Debug, PartialEq)]
#[require(Transform)]
pub struct MeshInstance {
    /// The mesh in `Assets<Mesh>`.
    pub mesh: Handle<Mesh>,
    /// The material in `Assets<Material>`.
    pub material: Handle<Material>,
}

/// A human-readable entity name (glTF node names, debug UI).
#[derive(Component, Clone, Debug, PartialEq, Eq, Hash, Default)]
pub struct Name(pub String);

impl Name {
    /// A name from anything string-like.
    pub fn new(name: impl Into<String>) -> Self {
        Name(name.into())
    }

    /// The name as a string slice.
    pub fn as_str(&self) -> &str {
        &self.0
    }
}

impl std::fmt::Display for Name {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.write_str(&self.0)
    }
}
