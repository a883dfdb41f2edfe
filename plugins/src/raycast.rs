//! CPU ray casts against the scene: [`SceneRaycaster`] holds the world-space triangles of every
//! solid [`MeshInstance`] in a bounding volume hierarchy and answers nearest-hit queries.
//!
//! The BVH comes from the [`obvhs`] crate (a PLOC builder with reinsertion optimisation, and a
//! stack-based closest-hit traversal); this module supplies the triangles and the ray–triangle
//! test (Möller–Trumbore, double-sided, edges inclusive so that a ray along a shared edge of a
//! floor does not slip through). obvhs 0.3 is used because it is the release line that accepts
//! glam 0.30, the version of the rest of the workspace (0.4 requires glam 0.33); vectors cross
//! the boundary as arrays, so this module also builds if obvhs resolves to a newer glam.
//!
//! Solid means: every entity with a `MeshInstance` and a `GlobalTransform` whose mesh is in
//! `Assets<Mesh>`, except entities marked [`RaycastIgnore`] and their descendants (a player's own
//! body, which it never shoots or stands on) and meshes with `DecalReceiver(0)` (pure decoration
//! that takes no decals, such as a skybox or a glass pane, is not solid for a game either).
//!
//! The raycaster is a snapshot. [`RaycastPlugin`] adds it as a resource and [`rebuild_raycaster`]
//! (in `PostUpdate`, after transform propagation), which rebuilds it when a solid instance was
//! added, removed, moved or changed its mesh or receiver layers; for a static level that is once.
//! Edits of a mesh asset in place are not tracked: call [`SceneRaycaster::mark_stale`] after
//! them.
//!
//! **Skinned instances** (with an [`engine::animation::Skin`] and a skinned mesh) are hit where
//! they are posed now, not in the BVH: they move every frame, so [`pose_skinned_solids`] only
//! keeps each one's joint matrices and posed bounds (from per-joint rest boxes) up to date, and a
//! cast that reaches those bounds poses that instance's triangles on the CPU (linear blend
//! skinning, as the GPU does) and tests them. A hit on a skin also says where it is in the rest
//! pose ([`Hit::rest`]): what a decal that stays on the skin is placed with
//! ([`crate::decal::Decal::on_skin`]). Morph targets are not applied to picking (the renderer
//! applies them): a cast hits the skinned but unmorphed surface.
//!
//! ```
//! use engine::prelude::*;
//! use plugins::raycast::{RaycastPlugin, SceneRaycaster};
//!
//! let mut app = App::new();
//! app.add_plugins(RaycastPlugin);
//! let floor = app.world.resource_mut::<Assets<Mesh>>().add(shapes::plane(10.0, 10.0, 1, 1.0));
//! let material = app.world.resource_mut::<Assets<Material>>().add(Material::default());
//! app.world.spawn((MeshInstance { mesh: floor, material }, Transform::default()));
//! app.update();
//! let hit = app.world.resource::<SceneRaycaster>().cast(Vec3::new(1.0, 5.0, 2.0), Vec3::NEG_Y, f32::INFINITY).unwrap();
//! assert_eq!((hit.point, hit.normal), (Vec3::new(1.0, 0.0, 2.0), Vec3::Y));
//! ```

use std::collections::HashMap;
use std::sync::Arc;
use std::time::Duration;

use bevy_ecs::change_detection::Tick;
use bevy_ecs::entity::EntityHashMap;
use bevy_ecs::prelude::*;
use bevy_ecs::system::{RunSystemOnce, SystemChangeTick};
use engine::animation::{Skin, SkinPose, SkinPoseSystems};
use engine::app::{App, Plugin, PostUpdate};
use engine::asset::{Assets, Handle};
use engine::mesh::Mesh;
use engine::scene::MeshInstance;
use engine::transform::{GlobalTransform, TransformSystems, propagate_transforms};
use glam::{Affine3A, Mat4, Vec2, Vec3, Vec3A};
use obvhs::BvhBuildParams;
use obvhs::bvh2::Bvh2;
use obvhs::bvh2::builder::build_bvh2_from_tris;
use obvhs::ray::{Ray, RayHit};

use crate::decal::DecalReceiver;
use crate::extract::InstanceChanges;

/// Ray casts pass through this entity and its descendants (a player's own body).
#[derive(Component, Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct RaycastIgnore;

/// Adds the [`SceneRaycaster`] resource and keeps it up to date ([`rebuild_raycaster`]).
pub struct RaycastPlugin;

impl Plugin for RaycastPlugin {
    fn build(&self, app: &mut App) {
        app.world.init_resource::<SceneRaycaster>();
        app.add_message::<engine::changes::Inserted<DecalReceiver>>();
        app.add_systems(
            PostUpdate,
            (rebuild_raycaster, pose_skinned_solids).chain().after(TransformSystems::Propagate).after(SkinPoseSystems),
        );
    }
}

/// The nearest intersection of a ray with the scene.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Hit {
    /// Distance along the (normalised) ray, in metres.
    pub t: f32,
    /// The world-space hit point.
    pub point: Vec3,
    /// The unit geometric normal of the triangle hit, turned to face the ray's origin.
    pub normal: Vec3,
    /// The mesh instance hit.
    pub entity: Entity,
    /// For a skinned instance: the hit point and the triangle's normal (turned like `normal`)
    /// in its rest pose, in the instance's own space: a decal child of the instance placed
    /// there with [`crate::decal::Decal::on_skin`] stays on this spot of the skin.
    pub rest: Option<RestHit>,
}

/// Where a hit on a skinned instance is in its rest pose ([`Hit::rest`]).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct RestHit {
    /// The point, in the instance's space.
    pub point: Vec3,
    /// The unit triangle normal there, in the instance's space.
    pub normal: Vec3,
}

/// A skinned mesh as picking needs it: rest positions, triangles, joints and weights, and each
/// joint's rest box. Shared by every instance of the mesh.
struct SkinnedShape {
    positions: Vec<Vec3>,
    indices: Vec<u32>,
    joints: Vec<[u16; 4]>,
    weights: Vec<[f32; 4]>,
    joint_bounds: Vec<(Vec3, Vec3)>,
}

impl SkinnedShape {
    fn of(mesh: &Mesh) -> Option<SkinnedShape> {
        let skin = mesh.skin.as_ref().filter(|s| s.joints.len() == mesh.positions.len() && s.weights.len() == mesh.positions.len())?;
        let positions: Vec<Vec3> = mesh.positions.iter().map(|&p| Vec3::from(p)).collect();
        let vertices = positions.iter().zip(skin.joints.iter().zip(&skin.weights)).map(|(&p, (&j, &w))| (p, j, w));
        let joint_bounds = render::scene::poses::joint_bounds(vertices);
        Some(SkinnedShape {
            positions,
            indices: mesh.indices.clone(),
            joints: skin.joints.clone(),
            weights: skin.weights.clone(),
            joint_bounds,
        })
    }
}

/// A skinned instance in its current pose.
struct SkinnedSolid {
    entity: Entity,
    shape: Arc<SkinnedShape>,
    to_world: Affine3A,
    /// Joint matrices in the instance's space (its [`SkinPose`]).
    matrices: Vec<Mat4>,
    /// World bounds of the pose (none: not posed yet, or nothing to hit).
    bounds: Option<(Vec3, Vec3)>,
    /// The posed vertices, reused between casts.
    posed: std::sync::Mutex<Vec<Vec3>>,
}

impl SkinnedSolid {
    fn pose(&mut self, pose: &SkinPose, global: &GlobalTransform) {
        self.matrices.clone_from(&pose.0);
        self.to_world = global.0;
        let local = render::scene::poses::posed_bounds(self.shape.joint_bounds.iter().copied(), self.matrices.iter().copied());
        self.bounds = local.map(|(lo, hi)| {
            let m = Mat4::from(self.to_world);
            let (center, half) = (m.transform_point3((lo + hi) * 0.5), (hi - lo) * 0.5);
            let extent = m.x_axis.truncate().abs() * half.x + m.y_axis.truncate().abs() * half.y + m.z_axis.truncate().abs() * half.z;
            (center - extent, center + extent)
        });
    }

    /// The nearest hit of the ray within `max_t` on the posed triangles: (t, world normal, rest hit).
    fn cast(&self, from: Vec3A, along: Vec3A, max_t: f32) -> Option<(f32, Vec3, RestHit)> {
        let (lo, hi) = self.bounds?;
        let inv = along.recip();
        let (t0, t1) = ((Vec3A::from(lo) - from) * inv, (Vec3A::from(hi) - from) * inv);
        let (near, far) = (t0.min(t1).max_element().max(0.0), t0.max(t1).min_element().min(max_t));
        if near > far {
            return None;
        }
        let shape = &*self.shape;
        let mut posed = self.posed.lock().unwrap_or_else(|e| e.into_inner());
        posed.clear();
        posed.extend((0..shape.positions.len()).map(|i| {
            let p = Skin::pose_point(&self.matrices, shape.positions[i], shape.joints[i], shape.weights[i]);
            self.to_world.transform_point3(p)
        }));
        let mut best: Option<(f32, usize)> = None;
        for (k, tri) in shape.indices.chunks_exact(3).enumerate() {
            let (Some(&v0), Some(&v1), Some(&v2)) = (posed.get(tri[0] as usize), posed.get(tri[1] as usize), posed.get(tri[2] as usize))
            else {
                continue;
            };
            let triangle = Triangle { v0: v0.into(), e1: (v1 - v0).into(), e2: (v2 - v0).into(), owner: 0 };
            let t = triangle.intersect(from, along, 0.0, best.map_or(max_t, |b| b.0));
            if t.is_finite() {
                best = Some((t, k));
            }
        }
        let (t, k) = best?;
        let tri = &shape.indices[k * 3..k * 3 + 3];
        let [p0, p1, p2] = [0, 1, 2].map(|i| posed[tri[i] as usize]);
        let hit = Vec3::from(from + along * t);
        let (u, v) = barycentric(hit, p0, p1, p2);
        let [r0, r1, r2] = [0, 1, 2].map(|i| shape.positions[tri[i] as usize]);
        let mut normal = (p1 - p0).cross(p2 - p0).normalize_or_zero();
        let mut rest_normal = (r1 - r0).cross(r2 - r0).normalize_or_zero();
        if normal.dot(Vec3::from(along)) > 0.0 {
            normal = -normal;
            rest_normal = -rest_normal;
        }
        Some((t, normal, RestHit { point: r0 + (r1 - r0) * u + (r2 - r0) * v, normal: rest_normal }))
    }
}

/// Barycentric coordinates (of the second and third corner) of `p` in triangle (a, b, c).
fn barycentric(p: Vec3, a: Vec3, b: Vec3, c: Vec3) -> (f32, f32) {
    let (e1, e2, d) = (b - a, c - a, p - a);
    let (d11, d12, d22) = (e1.dot(e1), e1.dot(e2), e2.dot(e2));
    let (d1, d2) = (d.dot(e1), d.dot(e2));
    let det = d11 * d22 - d12 * d12;
    if det.abs() <= f32::MIN_POSITIVE {
        return (0.0, 0.0);
    }
    ((d22 * d1 - d12 * d2) / det, (d11 * d2 - d12 * d1) / det)
}

/// A world-space triangle prepared for intersection.
#[derive(Clone, Copy, Debug)]
struct Triangle {
    v0: Vec3A,
    e1: Vec3A,
    e2: Vec3A,
    /// Index into [`SceneRaycaster::entities`].
    owner: u32,
}

impl Triangle {
    /// Distance to the intersection of the ray from `origin` along `direction` within
    /// `[tmin, tmax]`, or infinity.
    fn intersect(&self, origin: Vec3A, direction: Vec3A, tmin: f32, tmax: f32) -> f32 {
        let p = direction.cross(self.e2);
        let det = self.e1.dot(p);
        // Parallel to the plane, degenerate, or NaN: no hit.
        if det.is_nan() || det.abs() <= f32::MIN_POSITIVE {
            return f32::INFINITY;
        }
        let inv_det = 1.0 / det;
        let s = origin - self.v0;
        let u = s.dot(p) * inv_det;
        if !(0.0..=1.0).contains(&u) {
            return f32::INFINITY;
        }
        let q = s.cross(self.e1);
        let v = direction.dot(q) * inv_det;
        if !(v >= 0.0 && u + v <= 1.0) {
            return f32::INFINITY;
        }
        let t = self.e2.dot(q) * inv_det;
        if t >= tmin && t <= tmax { t } else { f32::INFINITY }
    }
}

/// Ray casts against the scene's solid triangles (see the module docs). A resource; the empty
/// default hits nothing.
#[derive(Resource, Default)]
pub struct SceneRaycaster {
    bvh: Bvh2,
    /// Triangles in the BVH's primitive order, so a leaf's range indexes them directly.
    triangles: Vec<Triangle>,
    /// The mesh-instance entity of each `Triangle::owner`.
    entities: Vec<Entity>,
    /// The world change tick the snapshot reflects; `None` forces a rebuild.
    built: Option<Tick>,
    /// Skinned instances, hit where they are posed now.
    skinned: Vec<SkinnedSolid>,
    /// Their index in `skinned`.
    skinned_index: EntityHashMap<usize>,
    /// Skinned meshes by handle, kept across rebuilds.
    shapes: HashMap<Handle<Mesh>, Arc<SkinnedShape>>,
}

impl SceneRaycaster {
    /// Builds a raycaster over the solid mesh instances of `world`, first bringing every
    /// `GlobalTransform` up to date (transform propagation runs once).
    pub fn build(world: &mut World) -> SceneRaycaster {
        if let Err(error) = world.run_system_once(propagate_transforms) {
            tracing::warn!(%error, "could not propagate transforms before building the raycaster");
        }
        world.init_resource::<Assets<Mesh>>();
        let mut raycaster = match world.run_system_once(collect_solids) {
            Ok(raycaster) => raycaster,
            Err(error) => {
                tracing::warn!(%error, "could not gather the scene's meshes for ray casts");
                SceneRaycaster::default()
            }
        };
        // Changes made after this point get a newer tick, so `rebuild_raycaster` sees them.
        raycaster.built = Some(world.increment_change_tick());
        raycaster
    }

    /// Builds a raycaster over `instances`: each mesh placed by its local-to-world transform
    /// and reported as its entity when hit. Degenerate and non-finite triangles are skipped.
    pub fn from_meshes<'a>(instances: impl IntoIterator<Item = (Entity, &'a Mesh, Affine3A)>) -> SceneRaycaster {
        let mut triangles = Vec::new();
        let mut entities = Vec::new();
        for (entity, mesh, to_world) in instances {
            let owner = entities.len() as u32;
            let before = triangles.len();
            let position = |i: u32| mesh.positions.get(i as usize).map(|&p| to_world.transform_point3a(Vec3A::from(p)));
            for tri in mesh.indices.chunks_exact(3) {
                let (Some(v0), Some(v1), Some(v2)) = (position(tri[0]), position(tri[1]), position(tri[2])) else {
                    continue;
                };
                let (e1, e2) = (v1 - v0, v2 - v0);
                let area = e1.cross(e2).length_squared();
                if v0.is_finite() && area.is_finite() && area > 1e-16 {
                    triangles.push(Triangle { v0, e1, e2, owner });
                }
            }
            if triangles.len() > before {
                entities.push(entity);
            }
        }
        if triangles.is_empty() {
            return SceneRaycaster::default();
        }
        let boxes: Vec<obvhs::triangle::Triangle> = triangles
            .iter()
            .map(|t| obvhs::triangle::Triangle {
                // `into` from arrays: whichever glam version obvhs is built with.
                v0: t.v0.to_array().into(),
                v1: (t.v0 + t.e1).to_array().into(),
                v2: (t.v0 + t.e2).to_array().into(),
            })
            .collect();
        let bvh = build_bvh2_from_tris(&boxes, BvhBuildParams::medium_build(), &mut Duration::default());
        // Reorder once so traversal indexes the triangles without the indirection.
        let triangles = bvh.primitive_indices.iter().map(|&i| triangles[i as usize]).collect();
        SceneRaycaster { bvh, triangles, entities, ..Default::default() }
    }

    /// The nearest hit under the cursor: the ray through pixel position `cursor` (origin
    /// top-left) of a `viewport` seen by `camera` at `eye` ([`engine::camera::Camera::ray`]),
    /// as far as it goes. What a click in a game hits.
    pub fn cast_from_cursor(&self, camera: &engine::camera::Camera, eye: &GlobalTransform, cursor: Vec2, viewport: Vec2) -> Option<Hit> {
        camera.ray(eye, cursor, viewport).and_then(|(from, dir)| self.cast(from, dir, f32::INFINITY))
    }

    /// The nearest hit of the ray from `origin` along `direction` (normalised here, so `t` is
    /// in metres) no farther than `max_t` (which may be infinite), or `None`. Non-finite
    /// origins, zero or non-finite directions and non-positive `max_t` hit nothing.
    pub fn cast(&self, origin: Vec3, direction: Vec3, max_t: f32) -> Option<Hit> {
        let direction = direction.try_normalize()?;
        if self.is_empty() || !origin.is_finite() || max_t.is_nan() || max_t <= 0.0 {
            return None;
        }
        let (from, along) = (Vec3A::from(origin), Vec3A::from(direction));
        let mut nearest = self.cast_static(origin, direction, max_t);
        for solid in &self.skinned {
            let limit = nearest.map_or(max_t, |h| h.t);
            if let Some((t, normal, rest)) = solid.cast(from, along, limit) {
                nearest = Some(Hit { t, point: origin + direction * t, normal, entity: solid.entity, rest: Some(rest) });
            }
        }
        nearest
    }

    fn cast_static(&self, origin: Vec3, direction: Vec3, max_t: f32) -> Option<Hit> {
        if self.triangles.is_empty() {
            return None;
        }
        let ray = Ray::new(origin.to_array().into(), direction.to_array().into(), 0.0, max_t);
        let (from, along) = (Vec3A::from(origin), Vec3A::from(direction));
        let mut hit = RayHit::none();
        // obvhs shrinks the ray's `tmax` to the nearest hit so far as it traverses.
        let found = self.bvh.ray_traverse(ray, &mut hit, |ray, i| self.triangles[i].intersect(from, along, ray.tmin, ray.tmax));
        if !found {
            return None;
        }
        let triangle = self.triangles.get(hit.primitive_id as usize)?;
        let normal = Vec3::from(triangle.e1.cross(triangle.e2)).normalize_or_zero();
        let normal = if normal.dot(direction) > 0.0 { -normal } else { normal };
        Some(Hit { t: hit.t, point: origin + direction * hit.t, normal, entity: self.entities[triangle.owner as usize], rest: None })
    }

    /// Number of triangles in the BVH.
    pub fn triangle_count(&self) -> usize {
        self.triangles.len()
    }

    /// Number of mesh instances with at least one triangle in the BVH.
    pub fn instance_count(&self) -> usize {
        self.entities.len()
    }

    /// Number of skinned instances, hit where they are posed.
    pub fn skinned_count(&self) -> usize {
        self.skinned.len()
    }

    /// Whether there is nothing to hit.
    pub fn is_empty(&self) -> bool {
        self.triangles.is_empty() && self.skinned.is_empty()
    }

    /// Makes [`rebuild_raycaster`] rebuild at its next run (after editing a mesh asset in
    /// place, which it cannot detect).
    pub fn mark_stale(&mut self) {
        self.built = None;
    }
}

/// Mesh instances as [`collect_solids`] and [`rebuild_raycaster`] read them.
type Instances<'w, 's> =
    Query<'w, 's, (Entity, Ref<'static, MeshInstance>, Ref<'static, GlobalTransform>, Option<Ref<'static, DecalReceiver>>, Has<Skin>)>;

/// Whether `entity` or one of its ancestors is marked [`RaycastIgnore`].
fn is_ignored(entity: Entity, ignored: &Query<Ref<RaycastIgnore>>, parents: &Query<&ChildOf>) -> bool {
    // Hierarchies deeper than this are not expected; stopping keeps a corrupt (cyclic) one
    // from hanging the game.
    const MAX_DEPTH: usize = 256;
    let mut current = entity;
    for _ in 0..MAX_DEPTH {
        if ignored.contains(current) {
            return true;
        }
        match parents.get(current) {
            Ok(child_of) => current = child_of.parent(),
            Err(_) => return false,
        }
    }
    false
}

/// Builds a raycaster over the solid instances (see the module docs), keeping `shapes`.
fn gather(
    instances: &Instances,
    ignored: &Query<Ref<RaycastIgnore>>,
    parents: &Query<&ChildOf>,
    meshes: &Assets<Mesh>,
    mut shapes: HashMap<Handle<Mesh>, Arc<SkinnedShape>>,
) -> SceneRaycaster {
    let solid =
        |(entity, instance, _, receiver, _): &(Entity, Ref<MeshInstance>, Ref<GlobalTransform>, Option<Ref<DecalReceiver>>, bool)| {
            receiver.as_ref().is_none_or(|r| r.0 != 0) && !is_ignored(*entity, ignored, parents) && meshes.contains(instance.mesh)
        };
    let skinned_mesh = |handle: Handle<Mesh>| meshes.get(handle).is_some_and(|m| m.skin.is_some());
    let mut raycaster = SceneRaycaster::from_meshes(
        instances
            .iter()
            .filter(solid)
            .filter(|i| !(i.4 && skinned_mesh(i.1.mesh)))
            .filter_map(|(entity, instance, global, _, _)| Some((entity, meshes.get(instance.mesh)?, global.affine()))),
    );
    shapes.retain(|handle, _| meshes.contains(*handle));
    for (entity, instance, global, _, _) in instances.iter().filter(solid).filter(|i| i.4 && skinned_mesh(i.1.mesh)) {
        let shape = match shapes.get(&instance.mesh) {
            Some(shape) => shape.clone(),
            None => match meshes.get(instance.mesh).and_then(SkinnedShape::of) {
                Some(shape) => shapes.entry(instance.mesh).or_insert(Arc::new(shape)).clone(),
                None => continue,
            },
        };
        raycaster.skinned_index.insert(entity, raycaster.skinned.len());
        let to_world = global.affine();
        raycaster.skinned.push(SkinnedSolid { entity, shape, to_world, matrices: Vec::new(), bounds: None, posed: Default::default() });
    }
    raycaster.shapes = shapes;
    raycaster
}

/// [`gather`] as a one-shot system for [`SceneRaycaster::build`].
fn collect_solids(
    instances: Instances,
    ignored: Query<Ref<RaycastIgnore>>,
    parents: Query<&ChildOf>,
    meshes: Res<Assets<Mesh>>,
    skins: Query<(Ref<SkinPose>, &GlobalTransform)>,
) -> SceneRaycaster {
    let mut raycaster = gather(&instances, &ignored, &parents, &meshes, HashMap::new());
    raycaster.pose_all(&skins, true);
    raycaster
}

/// Rebuilds the [`SceneRaycaster`] when the solid geometry changed since it was built: a mesh
/// instance added, removed or moved, its mesh handle or receiver layers changed, or a
/// [`RaycastIgnore`] added or removed (changes to ignored meshes are ignored). Runs in `PostUpdate`
/// after transform propagation, so the next frame's `Update` casts against the current scene.
#[allow(clippy::too_many_arguments)]
pub fn rebuild_raycaster(
    mut raycaster: ResMut<SceneRaycaster>,
    instances: Instances,
    ignored: Query<Ref<RaycastIgnore>>,
    parents: Query<&ChildOf>,
    meshes: Option<Res<Assets<Mesh>>>,
    (mut changes, mut listed): (InstanceChanges, Local<Vec<Entity>>),
    mut removed_instances: RemovedComponents<MeshInstance>,
    mut removed_receivers: RemovedComponents<DecalReceiver>,
    mut removed_ignored: RemovedComponents<RaycastIgnore>,
    ticks: SystemChangeTick,
) {
    // Drain every reader each frame, whether or not a rebuild follows. What changed comes from
    // change lists (inserts, moves, removals), so a still frame visits no instance.
    let removed = removed_instances.read().count() + removed_receivers.read().count() + removed_ignored.read().count() > 0;
    let solid = |entity: Entity| instances.contains(entity) && !is_ignored(entity, &ignored, &parents);
    listed.clear();
    changes.drain_into(&mut listed, |entity| instances.contains(entity));
    let Some(meshes) = meshes else { return };
    // A skinned instance moving is its pose changing ([`pose_skinned_solids`]), not a rebuild.
    let known_skin = |entity: Entity| instances.get(entity).is_ok_and(|i| i.4) && raycaster.skinned_index.contains_key(&entity);
    let stale = match raycaster.built {
        None => true,
        Some(built) => removed || ignored.iter().any(|i| i.is_added_after(built)) || listed.iter().any(|&e| solid(e) && !known_skin(e)),
    };
    if stale {
        let shapes = std::mem::take(&mut raycaster.shapes);
        *raycaster = gather(&instances, &ignored, &parents, &meshes, shapes);
        raycaster.built = Some(ticks.this_run());
        tracing::debug!(triangles = raycaster.triangle_count(), instances = raycaster.instance_count(), "rebuilt the scene raycaster");
    }
}

/// Keeps the skinned instances of the [`SceneRaycaster`] in their current pose: joint matrices
/// (their [`SkinPose`]) and posed bounds of those whose pose changed (or that are new to it), so
/// a cast hits a character where it is drawn. Runs after [`rebuild_raycaster`].
pub fn pose_skinned_solids(mut raycaster: ResMut<SceneRaycaster>, skins: Query<(Ref<SkinPose>, &GlobalTransform)>) {
    if !raycaster.skinned.is_empty() {
        raycaster.pose_all(&skins, false);
    }
}

impl SceneRaycaster {
    /// Poses the skinned instances whose [`SkinPose`] changed (all of them with `all`, and those
    /// never posed).
    fn pose_all(&mut self, skins: &Query<(Ref<SkinPose>, &GlobalTransform)>, all: bool) {
        for solid in &mut self.skinned {
            let Ok((pose, global)) = skins.get(solid.entity) else { continue };
            if all || solid.matrices.is_empty() || pose.is_changed() {
                solid.pose(&pose, global);
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use engine::app::App;
    use engine::material::Material;
    use engine::mesh::shapes;
    use engine::transform::Transform;

    fn spawn_mesh(world: &mut World, mesh: Mesh, transform: Transform) -> Entity {
        let mesh = world.resource_mut::<Assets<Mesh>>().add(mesh);
        let material = world.resource_mut::<Assets<Material>>().add(Material::default());
        world.spawn((transform, MeshInstance { mesh, material })).id()
    }

    #[test]
    fn skinned_instances_are_hit_where_they_are_posed_and_say_where_that_is_at_rest() {
        let mut app = App::new();
        app.add_plugins(RaycastPlugin);
        // A quad 2 m tall whose top edge follows joint 1, its bottom edge joint 0.
        let positions = vec![[0.0, 0.0, 0.0], [1.0, 0.0, 0.0], [0.0, 2.0, 0.0], [1.0, 2.0, 0.0]];
        let mut mesh = Mesh::new(positions, vec![[0.0, 0.0, 1.0]; 4], vec![[0.0; 2]; 4], vec![0, 1, 3, 0, 3, 2]).unwrap();
        let weights = vec![[1.0, 0.0, 0.0, 0.0], [1.0, 0.0, 0.0, 0.0], [0.0, 1.0, 0.0, 0.0], [0.0, 1.0, 0.0, 0.0]];
        mesh.skin = Some(engine::mesh::SkinWeights::normalized(vec![[0, 1, 0, 0]; 4], weights));
        let root = app.world.spawn(Transform::default()).id();
        let top = app.world.spawn(Transform::from_xyz(0.0, 0.0, 1.0)).id();
        let quad = spawn_mesh(&mut app.world, mesh, Transform::default());
        let ibm: Arc<[Mat4]> = vec![Mat4::IDENTITY; 2].into();
        app.world.entity_mut(quad).insert(Skin { joints: vec![root, top], inverse_bind_matrices: ibm });
        app.update();
        let raycaster = app.world.resource::<SceneRaycaster>();
        assert_eq!((raycaster.skinned_count(), raycaster.triangle_count()), (1, 0), "posed, not in the BVH");
        // The top edge leans out to z = 1: at y = 1 the quad is at z = 0.5.
        let hit = raycaster.cast(Vec3::new(0.5, 1.0, 5.0), Vec3::NEG_Z, f32::INFINITY).expect("the posed quad");
        assert!((hit.t - 4.5).abs() < 1e-4, "{hit:?}");
        assert_eq!(hit.entity, quad);
        let rest = hit.rest.expect("a hit on a skin knows its rest pose");
        assert!(rest.point.distance(Vec3::new(0.5, 1.0, 0.0)) < 1e-4 && rest.normal.distance(Vec3::Z) < 1e-4, "{rest:?}");
        // Moving the joint moves what is hit, without rebuilding the BVH.
        app.world.entity_mut(top).insert(Transform::from_xyz(0.0, 0.0, 2.0));
        app.update();
        let hit = app.world.resource::<SceneRaycaster>().cast(Vec3::new(0.5, 1.0, 5.0), Vec3::NEG_Z, f32::INFINITY).unwrap();
        assert!((hit.t - 4.0).abs() < 1e-4, "{hit:?}");
        assert!(app.world.resource::<SceneRaycaster>().cast(Vec3::new(0.5, 3.0, 5.0), Vec3::NEG_Z, f32::INFINITY).is_none());
    }

    #[test]
    fn hits_the_nearest_surface_with_a_facing_normal() {
        let mut app = App::new();
        let ground = spawn_mesh(&mut app.world, shapes::plane(10.0, 10.0, 3, 1.0), Transform::IDENTITY);
        let cube = spawn_mesh(&mut app.world, shapes::cuboid(Vec3::ONE, 1.0), Transform::from_xyz(0.0, 0.5, 0.0));
        let raycaster = SceneRaycaster::build(&mut app.world);
        assert_eq!(raycaster.instance_count(), 2);

        let down = raycaster.cast(Vec3::new(0.2, 5.0, 0.1), Vec3::NEG_Y * 3.0, f32::INFINITY).unwrap();
        assert_eq!(down.entity, cube);
        assert!((down.t - 4.0).abs() < 1e-5 && (down.point.y - 1.0).abs() < 1e-5);
        assert!((down.normal - Vec3::Y).length() < 1e-5);

        let beside = raycaster.cast(Vec3::new(3.0, 5.0, 0.0), Vec3::NEG_Y, f32::INFINITY).unwrap();
        assert_eq!(beside.entity, ground);
        // From below, the ground's normal faces down, towards the ray.
        let below = raycaster.cast(Vec3::new(3.0, -1.0, 0.0), Vec3::Y, f32::INFINITY).unwrap();
        assert!((below.normal - Vec3::NEG_Y).length() < 1e-5);
        // Out of range, bad input, away from everything.
        assert!(raycaster.cast(Vec3::new(3.0, 5.0, 0.0), Vec3::NEG_Y, 4.9).is_none());
        assert!(raycaster.cast(Vec3::new(3.0, 5.0, 0.0), Vec3::ZERO, 10.0).is_none());
        assert!(raycaster.cast(Vec3::NAN, Vec3::NEG_Y, 10.0).is_none());
        assert!(raycaster.cast(Vec3::new(3.0, 5.0, 0.0), Vec3::Y, f32::INFINITY).is_none());
        assert!(SceneRaycaster::default().cast(Vec3::ZERO, Vec3::NEG_Y, 1.0).is_none());
    }

    #[test]
    fn ignored_entities_and_non_receivers_are_not_solid() {
        let mut app = App::new();
        let ground = spawn_mesh(&mut app.world, shapes::plane(10.0, 10.0, 1, 1.0), Transform::IDENTITY);
        let player = app.world.spawn((RaycastIgnore, Transform::from_xyz(0.0, 1.0, 0.0))).id();
        let body = spawn_mesh(&mut app.world, shapes::cuboid(Vec3::splat(0.5), 1.0), Transform::IDENTITY);
        app.world.entity_mut(body).insert(ChildOf(player));
        let glass = spawn_mesh(&mut app.world, shapes::plane(10.0, 10.0, 1, 1.0), Transform::from_xyz(0.0, 3.0, 0.0));
        app.world.entity_mut(glass).insert(DecalReceiver(0));
        let raycaster = SceneRaycaster::build(&mut app.world);
        assert_eq!(raycaster.instance_count(), 1);
        let hit = raycaster.cast(Vec3::new(0.0, 5.0, 0.0), Vec3::NEG_Y, 10.0).unwrap();
        assert_eq!(hit.entity, ground);
    }

    #[test]
    fn rebuilds_only_when_solid_geometry_changes() {
        let mut app = App::new();
        app.add_plugins(RaycastPlugin);
        let cube = spawn_mesh(&mut app.world, shapes::cuboid(Vec3::ONE, 1.0), Transform::IDENTITY);
        let player = app.world.spawn((RaycastIgnore, Transform::IDENTITY)).id();
        let body = spawn_mesh(&mut app.world, shapes::cuboid(Vec3::ONE, 1.0), Transform::IDENTITY);
        app.world.entity_mut(body).insert(ChildOf(player));
        let hit_x =
            |app: &App| app.world.resource::<SceneRaycaster>().cast(Vec3::new(0.0, 0.0, 10.0), Vec3::NEG_Z, 100.0).map(|h| h.point.z);
        app.update();
        assert_eq!(app.world.resource::<SceneRaycaster>().instance_count(), 1);
        assert_eq!(hit_x(&app), Some(0.5));
        // Moving the player (and with it its body) does not rebuild: mark the snapshot so a
        // rebuild would be visible as a different `built` tick.
        let built = app.world.resource::<SceneRaycaster>().built;
        app.world.get_mut::<Transform>(player).unwrap().translation.x = 3.0;
        app.update();
        assert_eq!(app.world.resource::<SceneRaycaster>().built, built);
        // Moving a solid instance does.
        app.world.get_mut::<Transform>(cube).unwrap().translation.z = -2.0;
        app.update();
        assert_eq!(hit_x(&app), Some(-1.5));
        // Despawning it too.
        app.world.despawn(cube);
        app.update();
        assert_eq!(hit_x(&app), None);
    }
}
