//! Scene components (a renderable mesh instance, a debug name) and [`frame_scene`], which puts
//! a camera and lights around whatever was loaded, at any scale.

use bevy_ecs::prelude::*;
use glam::Vec3;

use crate::app::PostUpdate;
use crate::asset::{Assets, Handle};
use crate::camera::Camera;
use crate::light::{DirectionalLight, DiskLight, PointLight, RectLight, SpotLight};
use crate::material::Material;
use crate::mesh::Mesh;
use crate::transform::{GlobalTransform, Transform};

/// Draws `mesh` with `material` at its entity's `GlobalTransform`.
///
/// Immutable: change it by inserting a new value (the render extraction then finds it without
/// scanning; see [`crate::changes`]).
#[derive(Component, Clone, Copy, Debug, PartialEq)]
#[require(Transform)]
#[component(immutable, on_insert = crate::changes::note_inserted::<Self>)]
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

/// What [`frame_scene`] found and added.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct FramedScene {
    /// Centre of the meshes' world-space bounds.
    pub centre: Vec3,
    /// Radius of the sphere around those bounds (at least 1 mm).
    pub radius: f32,
    /// A camera was spawned (the scene had no active one).
    pub camera_spawned: bool,
    /// Lights were spawned (the scene had none).
    pub lights_spawned: bool,
}

/// Frames what the world holds, whatever its scale (a 2 cm model or a 100 m level): the
/// world-space bounds of every mesh instance, a camera looking at them from outside when there
/// is no active camera, with its near plane a hundredth of the bounds' radius (at most the
/// default 5 cm, so a tiny model is not clipped away), and a key and a fill light scaled to the
/// bounds when there is no light. Propagates transforms first (runs [`PostUpdate`]).
pub fn frame_scene(world: &mut World) -> FramedScene {
    let _ = world.try_run_schedule(PostUpdate);
    let mut lo = Vec3::splat(f32::INFINITY);
    let mut hi = Vec3::splat(f32::NEG_INFINITY);
    let mut query = world.query::<(&MeshInstance, &GlobalTransform)>();
    let meshes = world.resource::<Assets<Mesh>>();
    for (inst, global) in query.iter(world) {
        let Some(mesh) = meshes.get(inst.mesh) else { continue };
        let (a, b) = mesh.aabb();
        for i in 0..8 {
            let corner =
                Vec3::new(if i & 1 == 0 { a.x } else { b.x }, if i & 2 == 0 { a.y } else { b.y }, if i & 4 == 0 { a.z } else { b.z });
            let p = global.transform_point(corner);
            if p.is_finite() {
                lo = lo.min(p);
                hi = hi.max(p);
            }
        }
    }
    if !lo.is_finite() || !hi.is_finite() {
        lo = Vec3::splat(-1.0);
        hi = Vec3::splat(1.0);
    }
    let centre = (lo + hi) * 0.5;
    let radius = ((hi - lo).length() * 0.5).max(1e-3);
    let camera_spawned = !world.query::<&Camera>().iter(world).any(|c| c.active);
    if camera_spawned {
        let defaults = Camera::default();
        let camera = Camera { near: (radius * 0.01).min(defaults.near), ..defaults };
        let distance = radius / (camera.fov_y * 0.5).sin() * 0.85;
        let eye = centre + Vec3::new(0.45, 0.35, 1.0).normalize() * distance;
        world.spawn((camera, Transform::from_translation(eye).looking_at(centre, Vec3::Y)));
    }
    let lights_spawned = world.query::<&PointLight>().iter(world).next().is_none()
        && world.query::<&SpotLight>().iter(world).next().is_none()
        && world.query::<&DirectionalLight>().iter(world).next().is_none()
        && world.query::<&RectLight>().iter(world).next().is_none()
        && world.query::<&DiskLight>().iter(world).next().is_none();
    if lights_spawned {
        world.spawn((
            DirectionalLight { color: Vec3::new(1.0, 0.96, 0.9), illuminance: 3.0, ..Default::default() },
            Transform::from_translation(centre).looking_at(centre + Vec3::new(-0.4, -1.0, -0.6), Vec3::Y),
        ));
        world.spawn((
            PointLight { color: Vec3::new(0.6, 0.7, 1.0), intensity: 4.0 * radius * radius, range: None, ..Default::default() },
            Transform::from_translation(centre + Vec3::new(-1.2, 0.6, 1.2) * radius),
        ));
    }
    FramedScene { centre, radius, camera_spawned, lights_spawned }
}
