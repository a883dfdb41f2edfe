//! The animated character: a skinned glTF model (by default the shared Fox: CC0 low-poly fox by
//! PixelMannen, CC-BY 4.0 rigging and animation by @tomkranis, glTF conversion by @AsoboStudio
//! and @scurest) that walks a loop in the default courtyard, playing its `Walk` clip, so the
//! player can shoot it and see the bullet holes stay on its skin ([`plugins::decal::Decal::on_skin`]),
//! and a crowd of them for the skinning benchmark (`--bench-scene foxes --instances N`).
//!
//! The model is never copied into the project: it is read from `../shared/assets` (or a path
//! given with `--character`); without it the courtyard has no character, and says so.

use std::path::{Path, PathBuf};

use anyhow::{Context, Result};
use bevy_ecs::prelude::{Component, Entity, Query, Res, World};
use engine::animation::{AnimationClip, AnimationPlayer};
use engine::asset::{Assets, Handle};
use engine::gltf::GltfPrefab;
use engine::time::Time;
use engine::transform::Transform;
use glam::{Quat, Vec3};

/// The Fox's size: its file is in centimetres.
pub const FOX_SCALE: f32 = 0.01;

/// Where the default character is looked for, in order: beside the checkout, and inside it.
pub fn default_character() -> Option<PathBuf> {
    ["../shared/assets/gltf/Fox/Fox.glb", "shared/assets/gltf/Fox/Fox.glb"].into_iter().map(PathBuf::from).find(|p| p.is_file())
}

/// Walks its entity round a circle in the XZ plane, facing the way it goes (local +Z forward).
#[derive(Component, Clone, Copy, Debug, PartialEq)]
pub struct Walker {
    /// Centre of the loop.
    pub center: Vec3,
    /// Radius, in metres.
    pub radius: f32,
    /// Speed along the loop, in metres per second (the Fox's `Walk` covers about 1 m/s).
    pub speed: f32,
    /// Where on the loop it is now, in radians.
    pub angle: f32,
}

impl Walker {
    /// The walker's transform at its angle (uniform `scale`).
    pub fn transform(&self, scale: f32) -> Transform {
        let (s, c) = self.angle.sin_cos();
        let at = self.center + Vec3::new(c, 0.0, s) * self.radius;
        // Counter-clockwise seen from above: the tangent is (-sin, 0, cos).
        let heading = Vec3::new(-s, 0.0, c);
        Transform { translation: at, rotation: Quat::from_rotation_arc(Vec3::Z, heading), scale: Vec3::splat(scale) }
    }
}

/// Moves every [`Walker`] along its loop by the frame's time.
pub fn walk_loops(time: Res<Time>, mut walkers: Query<(&mut Walker, &mut Transform)>) {
    let dt = time.delta_secs();
    for (mut walker, mut transform) in &mut walkers {
        walker.angle = (walker.angle + walker.speed * dt / walker.radius.max(1e-3)) % std::f32::consts::TAU;
        *transform = walker.transform(transform.scale.x);
    }
}

/// Loads a character model once (its assets shared by every copy spawned from it).
pub fn load_character(world: &mut World, path: &Path) -> Result<GltfPrefab> {
    let scene = crate::assets::load_gltf(world, path).with_context(|| format!("could not load the character {}", path.display()))?;
    Ok(scene.into_prefab(world))
}

/// The clip named `name`, or the first.
pub fn clip_named(world: &World, prefab: &GltfPrefab, name: &str) -> Option<Handle<AnimationClip>> {
    let clips = world.get_resource::<Assets<AnimationClip>>()?;
    prefab.clips.iter().copied().find(|&c| clips.get(c).is_some_and(|clip| clip.name() == name)).or(prefab.clips.first().copied())
}

/// Spawns the character walking a loop of `radius` round `center`, playing its `Walk` clip.
pub fn spawn_walker(world: &mut World, path: &Path, center: Vec3, radius: f32) -> Result<Entity> {
    let prefab = load_character(world, path)?;
    let root = prefab.spawn(world);
    let walker = Walker { center, radius, speed: 1.1, angle: 0.0 };
    world.entity_mut(root).insert((walker.transform(FOX_SCALE), walker));
    if let Some(walk) = clip_named(world, &prefab, "Walk") {
        world.entity_mut(root).insert(AnimationPlayer::new(walk));
    }
    if crate::effects::effects_on(world) {
        // Dust at its feet, following it as its child.
        world.spawn((crate::effects::footstep_dust(), Transform::default(), bevy_ecs::hierarchy::ChildOf(root)));
    }
    tracing::info!(character = %path.display(), "a character walks the courtyard");
    Ok(root)
}

/// Spawns `count` copies of the character in a grid facing +Z (2 m apart), each playing `clip`
/// from its own time, as compact skeletons whose bones' entities are left unplaced when
/// `compact` is set (nothing reads a crowd's bones), and returns the grid's half extent in
/// metres.
pub fn spawn_crowd(world: &mut World, path: &Path, clip: &str, count: usize, compact: bool) -> Result<f32> {
    let mut prefab = load_character(world, path)?;
    prefab.compact_skeletons = compact;
    prefab.unplaced_bones = compact;
    let walk = clip_named(world, &prefab, clip);
    let side = (count as f32).sqrt().ceil().max(1.0) as usize;
    let pitch = 2.0;
    let half = (side as f32 - 1.0) * pitch * 0.5;
    for i in 0..count {
        let root = prefab.spawn(world);
        let at = Vec3::new((i % side) as f32 * pitch - half, 0.0, (i / side) as f32 * pitch - half);
        world.entity_mut(root).insert(Transform::from_translation(at).with_scale(Vec3::splat(FOX_SCALE)));
        if let Some(walk) = walk {
            // Spread over the clip: every fox at its own time (a golden-ratio sequence).
            let mut player = AnimationPlayer::new(walk);
            player.seek((i as f32 * 0.618_034).fract() * 0.9);
            world.entity_mut(root).insert(player);
        }
    }
    Ok(half)
}
