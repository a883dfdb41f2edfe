//! Scatters decals over the surfaces of a scene's meshes (the sandbox's `--decals N`).
//!
//! [`scatter_decals`] gathers every mesh instance that receives decals, transforms its triangles
//! to world space once, and builds a cumulative area table; each decal then picks a triangle by
//! area (binary search in the table) and a uniform point inside it, so decals are spread evenly
//! per square metre. Everything is driven by a small seeded [`SplitMix64`] generator, so the same
//! scene and seed always give the same decals.

use bevy_ecs::prelude::*;
use bevy_ecs::system::RunSystemOnce;
use engine::asset::{Assets, Handle};
use engine::mesh::Mesh;
use engine::scene::MeshInstance;
use engine::transform::{GlobalTransform, Static, Transform, propagate_transforms};
use glam::{Mat3, Quat, Vec3, Vec3A};
use plugins::decal::{Decal, DecalMaterial, DecalReceiver};

/// Smallest and largest decal width/height in metres.
pub const SIZE_RANGE: (f32, f32) = (0.3, 1.2);
/// Depth of a decal's box relative to its width.
pub const DEPTH_RATIO: f32 = 0.3;
/// Smallest and largest blending weight.
pub const WEIGHT_RANGE: (f32, f32) = (0.5, 2.0);

/// SplitMix64 (Steele, Lea and Flood): a tiny, fast, well-mixed 64-bit generator; good enough
/// for placement and fully reproducible from its seed.
#[derive(Clone, Debug)]
pub struct SplitMix64(u64);

impl SplitMix64 {
    /// A generator starting from `seed`.
    pub fn new(seed: u64) -> Self {
        SplitMix64(seed)
    }

    /// The next 64 random bits.
    pub fn next_u64(&mut self) -> u64 {
        self.0 = self.0.wrapping_add(0x9E37_79B9_7F4A_7C15);
        let mut z = self.0;
        z = (z ^ (z >> 30)).wrapping_mul(0xBF58_476D_1CE4_E5B9);
        z = (z ^ (z >> 27)).wrapping_mul(0x94D0_49BB_1331_11EB);
        z ^ (z >> 31)
    }

    /// Uniform in [0, 1) with 24 bits of precision.
    pub fn next_f32(&mut self) -> f32 {
        (self.next_u64() >> 40) as f32 / (1u64 << 24) as f32
    }

    /// Uniform in [0, 1) with 53 bits of precision.
    pub fn next_f64(&mut self) -> f64 {
        (self.next_u64() >> 11) as f64 / (1u64 << 53) as f64
    }

    /// Uniform in [`lo`, `hi`].
    pub fn range_f32(&mut self, lo: f32, hi: f32) -> f32 {
        lo + (hi - lo) * self.next_f32()
    }

    /// Uniform in `0..n` (`n` > 0; returns 0 for `n` = 0), without modulo bias worth noticing
    /// (Lemire's multiply-shift on 64 bits).
    pub fn below(&mut self, n: usize) -> usize {
        ((self.next_u64() as u128 * n as u128) >> 64) as usize
    }
}

/// A world-space triangle and its outward face normal.
#[derive(Clone, Copy, Debug)]
struct Triangle {
    a: Vec3A,
    ab: Vec3A,
    ac: Vec3A,
    normal: Vec3A,
}

/// World-space triangles of every decal-receiving mesh instance with their cumulative areas.
#[derive(Default)]
struct AreaTable {
    triangles: Vec<Triangle>,
    /// `cumulative[i]` is the total area of triangles `0..=i`.
    cumulative: Vec<f64>,
}

impl AreaTable {
    fn total(&self) -> f64 {
        self.cumulative.last().copied().unwrap_or(0.0)
    }

    fn push_mesh(&mut self, mesh: &Mesh, global: &GlobalTransform) {
        let affine = global.affine();
        // Normals transform with the inverse transpose; a singular transform flattens the mesh
        // to zero area anyway, so its triangles are skipped below.
        let normal_matrix = Mat3::from(affine.matrix3).inverse().transpose();
        let position = |i: u32| mesh.positions.get(i as usize).map(|&p| affine.transform_point3a(Vec3A::from(p)));
        let normal = |i: u32| mesh.normals.get(i as usize).map_or(Vec3A::ZERO, |&n| Vec3A::from(normal_matrix * Vec3::from(n)));
        let mut total = self.total();
        for tri in mesh.indices.chunks_exact(3) {
            let (Some(a), Some(b), Some(c)) = (position(tri[0]), position(tri[1]), position(tri[2])) else {
                continue;
            };
            let (ab, ac) = (b - a, c - a);
            let cross = ab.cross(ac);
            let double_area = cross.length();
            if !(double_area.is_finite() && double_area > 1e-12) {
                continue;
            }
            let mut face = cross / double_area;
            // Agree with the shading normals (mirroring transforms flip the winding).
            let shading = normal(tri[0]) + normal(tri[1]) + normal(tri[2]);
            if face.dot(shading) < 0.0 {
                face = -face;
            }
            total += 0.5 * double_area as f64;
            self.triangles.push(Triangle { a, ab, ac, normal: face });
            self.cumulative.push(total);
        }
    }

    /// A triangle picked with probability proportional to its area.
    fn pick(&self, rng: &mut SplitMix64) -> Option<&Triangle> {
        let target = rng.next_f64() * self.total();
        let i = self.cumulative.partition_point(|&c| c <= target);
        self.triangles.get(i.min(self.triangles.len().saturating_sub(1)))
    }
}

/// Brings `GlobalTransform`s up to date: runs `PostUpdate` (transform propagation) when the world
/// has that schedule, otherwise runs [`propagate_transforms`] once directly.
fn refresh_global_transforms(world: &mut World) {
    if world.try_run_schedule(engine::app::PostUpdate).is_err() {
        // Without schedules (a bare `World`), propagate directly; a world without transforms
        // simply has nothing to update.
        if let Err(error) = world.run_system_once(propagate_transforms) {
            tracing::warn!(%error, "could not propagate transforms before scattering decals");
        }
    }
}

/// Places `count` decals on the surfaces of the scene's meshes, deterministically from `seed`,
/// and returns how many were spawned (`count`, or 0 when there is no receiving surface or
/// `materials` is empty).
///
/// Surfaces are every entity with [`MeshInstance`] and [`GlobalTransform`] whose mesh is in
/// `Assets<Mesh>`, except those with `DecalReceiver(0)`. Points are uniform by area over all
/// of them. Each decal gets a material drawn from `materials`, channel 0..=3, weight in
/// [`WEIGHT_RANGE`], a random rotation about the surface normal, a square size in
/// [`SIZE_RANGE`] and a depth of [`DEPTH_RATIO`] × the size; its local +Z is the surface normal,
/// so it projects along −Z into the surface. Decals are spawned as [`Static`] roots (they sit on
/// their surfaces: the transform scan skips them) with their `GlobalTransform` already set.
pub fn scatter_decals(world: &mut World, count: usize, seed: u64, materials: &[Handle<DecalMaterial>]) -> usize {
    if count == 0 || materials.is_empty() {
        return 0;
    }
    refresh_global_transforms(world);
    let table = {
        let mut table = AreaTable::default();
        let mut instances = world.query::<(&MeshInstance, &GlobalTransform, Option<&DecalReceiver>)>();
        let Some(meshes) = world.get_resource::<Assets<Mesh>>() else {
            return 0;
        };
        for (instance, global, receiver) in instances.iter(world) {
            if receiver.is_some_and(|r| r.0 == 0) {
                continue;
            }
            if let Some(mesh) = meshes.get(instance.mesh) {
                table.push_mesh(mesh, global);
            }
        }
        table
    };
    if !(table.total() > 0.0 && table.total().is_finite()) {
        return 0;
    }

    let mut rng = SplitMix64::new(seed);
    let mut decals = Vec::with_capacity(count);
    for _ in 0..count {
        let Some(tri) = table.pick(&mut rng) else {
            break;
        };
        let (mut s, mut t) = (rng.next_f32(), rng.next_f32());
        if s + t > 1.0 {
            (s, t) = (1.0 - s, 1.0 - t);
        }
        let point = tri.a + tri.ab * s + tri.ac * t;
        let z = Vec3::from(tri.normal);
        let angle = rng.range_f32(0.0, std::f32::consts::TAU);
        let x0 = z.any_orthonormal_vector();
        let x = (x0 * angle.cos() + z.cross(x0) * angle.sin()).normalize();
        let y = z.cross(x);
        let rotation = Quat::from_mat3(&Mat3::from_cols(x, y, z)).normalize();
        let size = rng.range_f32(SIZE_RANGE.0, SIZE_RANGE.1);
        let transform = Transform { translation: Vec3::from(point), rotation, scale: Vec3::new(size, size, size * DEPTH_RATIO) };
        let mut decal = Decal::new(materials[rng.below(materials.len())]);
        decal.channel = rng.below(4) as u8;
        decal.weight = rng.range_f32(WEIGHT_RANGE.0, WEIGHT_RANGE.1);
        decals.push((decal, transform, GlobalTransform::from(transform), Static));
    }
    let spawned = decals.len();
    world.spawn_batch(decals);
    spawned
}

#[cfg(test)]
mod tests {
    use super::*;
    use engine::app::App;
    use engine::material::Material;
    use engine::mesh::shapes;
    use render::lod::closest_on_triangle;

    /// A 10 m ground plane and a rotated, mirrored, scaled, translated cube under a moved parent.
    fn plane_and_cube(world: &mut World) -> Vec<Handle<DecalMaterial>> {
        let (plane, cube) = {
            let mut meshes = world.get_resource_or_init::<Assets<Mesh>>();
            (meshes.add(shapes::plane(10.0, 10.0, 4, 1.0)), meshes.add(shapes::cuboid(Vec3::ONE, 1.0)))
        };
        let material = world.get_resource_or_init::<Assets<Material>>().add(Material::default());
        world.spawn((Transform::IDENTITY, MeshInstance { mesh: plane, material }));
        let parent = world.spawn(Transform::from_xyz(1.0, 0.0, -2.0)).id();
        world.spawn((
            Transform::from_xyz(0.5, 1.0, 0.5)
                .with_rotation(Quat::from_euler(glam::EulerRot::YXZ, 0.6, 0.3, -0.2))
                // Mirrored (negative X scale): the triangles' winding flips in world space, so
                // the face normal must follow the vertex normals to face outwards.
                .with_scale(Vec3::new(-1.5, 2.0, 1.0)),
            MeshInstance { mesh: cube, material },
            ChildOf(parent),
        ));
        let mut decal_materials = world.get_resource_or_init::<Assets<DecalMaterial>>();
        (0..3).map(|_| decal_materials.add(DecalMaterial::default())).collect()
    }

    fn app_with_scene() -> (App, Vec<Handle<DecalMaterial>>) {
        let mut app = App::new();
        let materials = plane_and_cube(&mut app.world);
        (app, materials)
    }

    /// World-space triangles of every mesh instance (after propagation), with outward normals.
    fn world_triangles(world: &mut World) -> Vec<([Vec3; 3], Vec3)> {
        let mut query = world.query::<(&MeshInstance, &GlobalTransform)>();
        let meshes = world.resource::<Assets<Mesh>>();
        let mut out = Vec::new();
        for (instance, global) in query.iter(world) {
            let mesh = meshes.get(instance.mesh).unwrap();
            let m = global.compute_matrix();
            for tri in mesh.indices.chunks_exact(3) {
                let p = [tri[0], tri[1], tri[2]].map(|i| m.transform_point3(Vec3::from(mesh.positions[i as usize])));
                let n = tri.iter().map(|&i| Vec3::from(mesh.normals[i as usize])).sum::<Vec3>();
                let world_n = Mat3::from_mat4(m).inverse().transpose() * n;
                let mut face = (p[1] - p[0]).cross(p[2] - p[0]).normalize();
                if face.dot(world_n) < 0.0 {
                    face = -face;
                }
                out.push((p, face));
            }
        }
        out
    }

    fn decals(world: &mut World) -> Vec<(Entity, Decal, Transform)> {
        let mut v: Vec<_> = world.query::<(Entity, &Decal, &Transform)>().iter(world).map(|(e, d, t)| (e, d.clone(), *t)).collect();
        v.sort_by_key(|(e, _, _)| *e);
        v
    }

    #[test]
    fn same_seed_same_decals_other_seed_other_decals() {
        let run = |seed| {
            let (mut app, materials) = app_with_scene();
            assert_eq!(scatter_decals(&mut app.world, 200, seed, &materials), 200);
            decals(&mut app.world).into_iter().map(|(_, d, t)| (d, t)).collect::<Vec<_>>()
        };
        let (a, b, c) = (run(7), run(7), run(8));
        assert_eq!(a, b);
        assert_ne!(a.iter().map(|x| x.1).collect::<Vec<_>>(), c.iter().map(|x| x.1).collect::<Vec<_>>());
    }

    #[test]
    fn decals_sit_on_the_surfaces_facing_out() {
        let (mut app, materials) = app_with_scene();
        assert_eq!(scatter_decals(&mut app.world, 2000, 1, &materials), 2000);
        let triangles = world_triangles(&mut app.world);
        let (mut on_cube, mut rotations) = (0, Vec::new());
        for (entity, decal, transform) in decals(&mut app.world) {
            let (distance, normal) = triangles
                .iter()
                .map(|&(tri, n)| (closest_on_triangle(transform.translation, tri[0], tri[1], tri[2]).distance(transform.translation), n))
                .min_by(|x, y| x.0.total_cmp(&y.0))
                .unwrap();
            assert!(distance < 1e-3, "decal at {} is {distance} m off", transform.translation);
            let z = transform.rotation * Vec3::Z;
            assert!((z.length() - 1.0).abs() < 1e-4);
            assert!(z.dot(normal) > 0.999, "local +Z {z} vs normal {normal}");
            // Projection along local −Z goes into the surface.
            assert!((transform.rotation * Vec3::NEG_Z).dot(normal) < -0.999);
            // Ranges.
            let size = transform.scale.x;
            assert!((SIZE_RANGE.0..=SIZE_RANGE.1).contains(&size) && transform.scale.y == size);
            assert!((transform.scale.z - size * DEPTH_RATIO).abs() < 1e-6);
            assert!(decal.channel <= 3);
            assert!((WEIGHT_RANGE.0..=WEIGHT_RANGE.1).contains(&decal.weight));
            assert!(materials.contains(&decal.material));
            // GlobalTransform is set at spawn.
            let global = app.world.get::<GlobalTransform>(entity).unwrap();
            assert!(global.translation().distance(transform.translation) < 1e-5);
            on_cube += (normal.dot(Vec3::Y) < 0.999 || transform.translation.y > 0.01) as usize;
            rotations.push(transform.rotation * Vec3::X);
        }
        // Area-proportional: the cube has 2·(1.5·2 + 1.5·1 + 2·1) = 13 m² next to 100 m² of plane
        // (minus its footprint, still counted: the plane is one mesh), so ~11.5 % of decals.
        let fraction = on_cube as f32 / 2000.0;
        assert!((0.08..0.15).contains(&fraction), "{fraction} of decals on the cube");
        // Rotations about the normal vary: tangents are not all alike.
        let spread = rotations.iter().filter(|x| x.dot(rotations[0]) < 0.0).count();
        assert!(spread > 200, "rotation barely varies ({spread})");
        // Every material, channel and a spread of sizes get used.
        let all = decals(&mut app.world);
        for m in &materials {
            assert!(all.iter().any(|(_, d, _)| d.material == *m));
        }
        for channel in 0..4 {
            assert!(all.iter().any(|(_, d, _)| d.channel == channel));
        }
        assert!(all.iter().any(|(_, _, t)| t.scale.x < 0.5) && all.iter().any(|(_, _, t)| t.scale.x > 1.0));
    }

    #[test]
    fn counts_and_degenerate_inputs() {
        let (mut app, materials) = app_with_scene();
        assert_eq!(scatter_decals(&mut app.world, 0, 3, &materials), 0);
        assert_eq!(scatter_decals(&mut app.world, 10, 3, &[]), 0);
        assert_eq!(decals(&mut app.world).len(), 0);
        assert_eq!(scatter_decals(&mut app.world, 37, 3, &materials), 37);
        assert_eq!(scatter_decals(&mut app.world, 5, 4, &materials), 5);
        assert_eq!(decals(&mut app.world).len(), 42);

        // Empty worlds: no schedules, no meshes, no assets at all.
        let mut empty = World::new();
        let handle = Assets::<DecalMaterial>::default().add(DecalMaterial::default());
        assert_eq!(scatter_decals(&mut empty, 100, 1, &[handle]), 0);
        let mut app = App::new();
        assert_eq!(scatter_decals(&mut app.world, 100, 1, &[handle]), 0);
        // An instance whose mesh is missing or has no triangles contributes nothing.
        let mesh = app.world.resource_mut::<Assets<Mesh>>().add(Mesh::default());
        let material = app.world.resource_mut::<Assets<Material>>().add(Material::default());
        app.world.spawn((Transform::IDENTITY, MeshInstance { mesh, material }));
        app.world.resource_mut::<Assets<Mesh>>().remove(mesh);
        assert_eq!(scatter_decals(&mut app.world, 100, 1, &[handle]), 0);
        assert_eq!(app.world.query::<&Decal>().iter(&app.world).count(), 0);
    }

    #[test]
    fn receivers_with_no_layers_get_nothing_and_bare_worlds_propagate() {
        // A bare World (no schedules): transforms are propagated directly, so the child cube
        // still lands where its parent puts it.
        let mut world = World::new();
        let materials = plane_and_cube(&mut world);
        let plane = world.query_filtered::<Entity, (With<MeshInstance>, Without<ChildOf>)>().single(&world).unwrap();
        world.entity_mut(plane).insert(DecalReceiver(0));
        assert_eq!(scatter_decals(&mut world, 500, 9, &materials), 500);
        let triangles = world_triangles(&mut world);
        let cube_only: Vec<_> = triangles.iter().filter(|(tri, _)| tri.iter().any(|p| p.y.abs() > 1e-4)).collect();
        for (_, _, transform) in decals(&mut world) {
            let distance = cube_only
                .iter()
                .map(|(tri, _)| closest_on_triangle(transform.translation, tri[0], tri[1], tri[2]).distance(transform.translation))
                .fold(f32::INFINITY, f32::min);
            assert!(distance < 1e-3, "decal at {} is not on the cube", transform.translation);
            assert!(transform.translation.x > -1.0, "cube moved by its parent (x ≥ ~-0.6)");
        }
        // Only the plane (layer 0): nothing.
        let mut world = World::new();
        let materials = plane_and_cube(&mut world);
        let mut q = world.query_filtered::<Entity, With<MeshInstance>>();
        for e in q.iter(&world).collect::<Vec<_>>() {
            world.entity_mut(e).insert(DecalReceiver(0));
        }
        assert_eq!(scatter_decals(&mut world, 50, 9, &materials), 0);
    }

    #[test]
    fn rng_is_uniform_enough() {
        let mut rng = SplitMix64::new(42);
        let mut buckets = [0u32; 10];
        for _ in 0..100_000 {
            let x = rng.next_f32();
            assert!((0.0..1.0).contains(&x));
            buckets[(x * 10.0) as usize] += 1;
        }
        assert!(buckets.iter().all(|&b| (9_500..10_500).contains(&b)), "{buckets:?}");
        assert!((0..1000).all(|_| rng.below(3) < 3));
        assert_eq!(rng.below(0), 0);
        // Known first output of SplitMix64 seeded with 0.
        assert_eq!(SplitMix64::new(0).next_u64(), 0xE220_A839_7B1D_CDAF);
    }

    #[test]
    fn hundred_thousand_decals_on_the_courtyard() {
        let mut app = App::new();
        crate::scene::spawn_courtyard(&mut app.world);
        let material = crate::decal_textures::decal_material(&crate::decal_textures::sigil(), &mut app.world);
        let handle = app.world.get_resource_or_init::<Assets<DecalMaterial>>().add(material);
        let start = std::time::Instant::now();
        assert_eq!(scatter_decals(&mut app.world, 100_000, 5, &[handle]), 100_000);
        let elapsed = start.elapsed();
        eprintln!("scattered 100k decals in {elapsed:?}");
        assert_eq!(app.world.query::<&Decal>().iter(&app.world).count(), 100_000);
        // Inside the courtyard's bounds (the ground is 44 m square).
        for (_, _, t) in decals(&mut app.world).iter().step_by(97) {
            assert!(t.translation.x.abs() <= 22.5 && t.translation.z.abs() <= 22.5, "{}", t.translation);
            assert!(t.translation.is_finite() && t.rotation.is_normalized());
        }
        app.update(); // The decals survive a frame with propagation.
    }
}
