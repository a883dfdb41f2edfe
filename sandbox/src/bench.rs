//! Benchmark scenes: the seed's first three test scenarios (seed 000 §5.2.2–5.2.4) rebuilt on
//! the courtyard, so Figures 5.1–5.3 can be redone side by side with `--compare`, which runs
//! every pipeline and decal method on the same scene in one process.
//!
//! | scene | seed | here |
//! | --- | --- | --- |
//! | `few-blended-decals` | §5.2.2: Sun Temple, 6 large decals in two groups (weights 1, 100, 1000), 3 lights | two groups of sigil, leaves and puddle (weights 1, 100, 1000; the left group's puddle in channel 1), 4 m wide, filling a downward view; the courtyard's 5 lights |
//! | `decals-and-lights` | §5.2.3: Bistro, 100 puddle decals, 28 lights | 100 puddles (cubical boxes, 1.5–3 m) on the ground, 28 point and spot lights |
//! | `many-decals` | §5.2.4: Emerald Square, 100,000 leaf decals on the ground, 1 light | 100,000 leaf decals (0.2–0.6 m) on the ground, the sun alone |
//! | `ten-point-lights` | seed 001 §5: Sponza, ten point lights of varied intensity, colour and range, a fixed central camera | the courtyard with its lights replaced by ten point lights (5–60 cd, ranges from eq. 4.1 or 6–14 m) around the fountain, the courtyard's camera |
//! | `many-lights` | seed 000 §5.2.5: Emerald Square, 28,587 small point lights, no decals | 28,587 small point lights (0.05–0.4 cd, eq. 4.1 ranges of 1.6–4.5 m) over the courtyard's ground and walls, the sun |
//! | `many-instances` | issue 24 (GPU-driven scene): none of the seeds culls | a city of [`MANY_INSTANCES`] (`--instances`) props on a grid of blocks walled in by 12 m buildings, most props inside the blocks, a few along the streets; the camera at street level looking down a street, so nearly everything is behind a wall ([`spawn_city`]) |
//! | `behind-wall` | `../shared/PEERS.md`, "many instances behind a wall" (Bevy measured on our GPU) | a wall 6 m in front of the camera, `--instances` 0.6 m boxes on a grid behind it (most also outside the view), 20 boxes in front of it, a floor and the sun ([`spawn_behind_wall`]; run it with `--no-shadows` as the peer's was) |
//! | `transparency` | seed 002 §4.2: one scene of about 60,000 polygons (38,812 opaque, 20,832 transparent), 2 to 64 spot lights | not the courtyard (48,340 opaque triangles on its own) but a stone floor and a field of opaque balls (38,812 opaque triangles in all, + less than one ball), a row of glass balls (refracting, 35 % opaque) and three glass panes in front of them (20,832 transparent triangles, + less than one ball), [`TRANSPARENCY_LIGHTS`] spot lights ([`set_spot_lights`] changes the count) and no other light |
//!
//! The courtyard stands in for the seeds' scenes (Sponza, Emerald Square, Bistro), which are not
//! among the models this project may use; the counts and kinds of lights and decals are the
//! seeds'.

use anyhow::{Result, bail};
use bevy_ecs::prelude::*;
use engine::asset::{Assets, Handle};

use engine::light::{DirectionalLight, DiskLight, PointLight, RectLight, SpotLight};
use engine::transform::{Static, Transform};
use glam::{Quat, Vec3};
use plugins::decal::{Decal, DecalMaterial};

use crate::decal_textures;
use crate::scatter::SplitMix64;
use crate::scene::spawn_courtyard;

/// The benchmark scenes.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum BenchScene {
    /// Seed 000 §5.2.2.
    FewBlendedDecals,
    /// Seed 000 §5.2.3.
    DecalsAndLights,
    /// Seed 000 §5.2.4.
    ManyDecals,
    /// Seed 001 §5 (Tables 5.1 and 5.2).
    TenPointLights,
    /// Seed 000 §5.2.5.
    ManyLights,
    /// Seed 002 §4.2.
    Transparency,
    /// Issue 24: a city of `--instances` props behind walls, seen from the street.
    ManyInstances,
    /// PEERS.md's "many instances behind a wall": `--instances` boxes in a grid behind a wall.
    BehindWall,
    /// Issue 25: `--instances` animated foxes (the `--character`), each at its own time.
    Foxes,
    /// The crowd issue's plaza: `--instances` animated foxes seen from eye height at the
    /// plaza's edge (near ones large, far ones a few pixels), with the sun's shadows.
    Crowd,
    /// The particles issue's fountain: the courtyard with an emitter keeping `--particles`
    /// particles alive, bouncing on the ground ([`crate::effects::fountain`]).
    Particles,
    /// Issue 52's dark corridor: glowing sigils on its walls that light it
    /// (`DecalMaterial::emits_light`), a rectangle light on its ceiling and a disk lamp at its
    /// end, and nothing else ([`spawn_corridor`]).
    Corridor,
}

impl BenchScene {
    /// Parses the command-line name.
    pub fn parse(name: &str) -> Result<Self> {
        Ok(match name {
            "few-blended-decals" => BenchScene::FewBlendedDecals,
            "decals-and-lights" => BenchScene::DecalsAndLights,
            "many-decals" => BenchScene::ManyDecals,
            "ten-point-lights" => BenchScene::TenPointLights,
            "many-lights" => BenchScene::ManyLights,
            "transparency" => BenchScene::Transparency,
            "many-instances" => BenchScene::ManyInstances,
            "behind-wall" => BenchScene::BehindWall,
            "foxes" => BenchScene::Foxes,
            "crowd" => BenchScene::Crowd,
            "particles" => BenchScene::Particles,
            "corridor" => BenchScene::Corridor,
            _ => bail!(
                "unknown bench scene {name:?} (few-blended-decals, decals-and-lights, many-decals, ten-point-lights, many-lights, transparency, many-instances, behind-wall, foxes, crowd, particles, corridor)"
            ),
        })
    }
}

fn material(world: &mut World, set: decal_textures::DecalTextureSet) -> Handle<DecalMaterial> {
    let m = decal_textures::decal_material(&set, world);
    world.resource_mut::<Assets<DecalMaterial>>().add(m)
}

/// A decal lying on the ground (y = 0), projecting down, turned by `yaw`.
fn ground_decal(
    material: Handle<DecalMaterial>,
    centre: Vec3,
    size: f32,
    depth: f32,
    yaw: f32,
    channel: u8,
    weight: f32,
) -> (Decal, Transform) {
    let mut decal = Decal::new(material);
    decal.channel = channel;
    decal.weight = weight;
    let transform = Transform::from_translation(centre)
        .with_rotation(Quat::from_rotation_y(yaw) * Quat::from_rotation_x(-std::f32::consts::FRAC_PI_2))
        .with_scale(Vec3::new(size, size, depth));
    (decal, transform)
}

/// Spawns `scene` into `world` (which has the render plugin).
pub fn spawn_bench_scene(world: &mut World, scene: BenchScene) {
    match scene {
        BenchScene::Transparency => return spawn_transparency_scene(world),
        BenchScene::ManyInstances => return spawn_city(world, MANY_INSTANCES),
        BenchScene::BehindWall => return spawn_behind_wall(world, MANY_INSTANCES),
        BenchScene::Foxes | BenchScene::Crowd => {
            tracing::warn!("the foxes and crowd scenes need a character model: spawn them with spawn_foxes");
            return;
        }
        BenchScene::Particles => return spawn_particles(world, PARTICLES, false),
        BenchScene::Corridor => return spawn_corridor(world),
        _ => {}
    }
    let info = spawn_courtyard(world);
    let mut rng = SplitMix64::new(5);
    match scene {
        BenchScene::FewBlendedDecals => {
            let sigil = material(world, decal_textures::sigil());
            let leaves = material(world, decal_textures::leaves());
            let puddle = material(world, decal_textures::puddle());
            for (x, puddle_channel) in [(-6.5f32, 1u8), (-1.5, 0)] {
                for (i, (m, weight)) in [(sigil, 1.0), (leaves, 100.0), (puddle, 1000.0)].into_iter().enumerate() {
                    let channel = if weight == 1000.0 { puddle_channel } else { 0 };
                    let centre = Vec3::new(x + i as f32 * 0.6, 0.0, 6.0 + i as f32 * 0.4);
                    world.spawn(ground_decal(m, centre, 4.0, 1.0, i as f32 * 0.4, channel, weight));
                }
            }
            *world.get_mut::<Transform>(info.camera).expect("courtyard camera") =
                Transform::from_xyz(-3.5, 7.0, 12.5).looking_at(Vec3::new(-3.5, 0.0, 6.5), Vec3::Y);
        }
        BenchScene::DecalsAndLights => {
            let puddle = material(world, decal_textures::puddle());
            let batch: Vec<_> = (0..100)
                .map(|_| {
                    let size = rng.range_f32(1.5, 3.0);
                    let centre = Vec3::new(rng.range_f32(-19.0, 19.0), 0.0, rng.range_f32(-19.0, 19.0));
                    ground_decal(puddle, centre, size, size, rng.range_f32(0.0, std::f32::consts::TAU), 0, 1.0)
                })
                .collect();
            world.spawn_batch(batch);
            let existing = world.query::<&PointLight>().iter(world).count()
                + world.query::<&SpotLight>().iter(world).count()
                + world.query::<&DirectionalLight>().iter(world).count();
            for i in 0..28usize.saturating_sub(existing) {
                let angle = i as f32 / 23.0 * std::f32::consts::TAU;
                let colour = Vec3::new(1.0, 0.75 + 0.2 * (i % 3) as f32 / 2.0, 0.5 + 0.4 * (i % 2) as f32);
                world.spawn((
                    PointLight { color: colour, intensity: 12.0, range: None, ..Default::default() },
                    Transform::from_xyz(angle.cos() * 15.0, 2.6, angle.sin() * 15.0),
                ));
            }
        }
        BenchScene::ManyDecals => {
            let leaves = material(world, decal_textures::leaves());
            let batch: Vec<_> = (0..100_000)
                .map(|_| {
                    let size = rng.range_f32(0.2, 0.6);
                    let centre = Vec3::new(rng.range_f32(-21.5, 21.5), 0.0, rng.range_f32(-21.5, 21.5));
                    ground_decal(leaves, centre, size, 0.2, rng.range_f32(0.0, std::f32::consts::TAU), 0, 1.0)
                })
                .collect();
            world.spawn_batch(batch);
            despawn_local_lights(world);
        }
        BenchScene::TenPointLights => {
            despawn_local_lights(world);
            let sun: Vec<Entity> = world.query_filtered::<Entity, With<DirectionalLight>>().iter(world).collect();
            for e in sun {
                world.despawn(e);
            }
            for i in 0..10 {
                let angle = i as f32 / 10.0 * std::f32::consts::TAU + 0.3;
                let radius = if i % 2 == 0 { 6.0 } else { 11.0 };
                let colour = Vec3::new(1.0, 0.6 + 0.4 * rng.next_f32(), 0.4 + 0.6 * rng.next_f32());
                let intensity = rng.range_f32(5.0, 60.0);
                let range = if i % 3 == 0 { Some(rng.range_f32(6.0, 14.0)) } else { None };
                world.spawn((
                    PointLight { color: colour, intensity, range, ..Default::default() },
                    Transform::from_xyz(angle.cos() * radius, rng.range_f32(0.8, 3.5), angle.sin() * radius),
                ));
            }
        }
        BenchScene::ManyLights => {
            despawn_local_lights(world);
            let batch: Vec<_> = (0..MANY_LIGHTS)
                .map(|i| {
                    let colour = Vec3::new(rng.range_f32(0.3, 1.0), rng.range_f32(0.3, 1.0), rng.range_f32(0.3, 1.0));
                    let light = PointLight { color: colour, intensity: rng.range_f32(0.05, 0.4), range: None, ..Default::default() };
                    // Two in three over the ground, the rest along the walls.
                    let at = if i % 3 != 2 {
                        Vec3::new(rng.range_f32(-21.0, 21.0), rng.range_f32(0.2, 1.5), rng.range_f32(-21.0, 21.0))
                    } else {
                        let along = rng.range_f32(-21.0, 21.0);
                        let side = if rng.next_f32() < 0.5 { -21.5 } else { 21.5 };
                        let y = rng.range_f32(0.5, 5.5);
                        if i % 2 == 0 { Vec3::new(along, y, side) } else { Vec3::new(side, y, along) }
                    };
                    (light, Transform::from_translation(at))
                })
                .collect();
            world.spawn_batch(batch);
        }
        BenchScene::Transparency => unreachable!("spawned above"),
        BenchScene::ManyInstances
        | BenchScene::BehindWall
        | BenchScene::Foxes
        | BenchScene::Crowd
        | BenchScene::Particles
        | BenchScene::Corridor => {
            unreachable!("spawned above")
        }
    }
}

/// The skinning benchmark (issue 25): `count` foxes from `character` on a ground, each playing
/// `clip` (its walk, or PEERS.md's run) from its own time (so every pose differs and is skinned
/// every frame), a sun, and a camera: above, seeing the whole crowd (`eye_level` false: the
/// `foxes` scene), or at eye height at the plaza's edge looking across it (`crowd`: near foxes
/// large, far ones a few pixels, what levels of detail are for). With `compact`, the characters
/// are compact skeletons (`engine::animation::CompactSkeleton`: posed in one pass) whose bones'
/// entities are left unplaced (`engine::animation::UnplacedBones`).
pub fn spawn_foxes(
    world: &mut World,
    character: &std::path::Path,
    clip: &str,
    count: usize,
    eye_level: bool,
    compact: bool,
) -> anyhow::Result<()> {
    use engine::camera::Camera;
    use engine::material::Material;
    use engine::mesh::{Mesh, shapes};
    use engine::scene::MeshInstance;

    let half = crate::character::spawn_crowd(world, character, clip, count, compact)?;
    let ground = world.resource_mut::<Assets<Mesh>>().add(shapes::plane(2.0 * half + 8.0, 2.0 * half + 8.0, 1, 1.0));
    let grey = world.resource_mut::<Assets<Material>>().add(Material::from_color(Vec3::new(0.5, 0.5, 0.48).extend(1.0), 0.0, 0.8));
    world.spawn((MeshInstance { mesh: ground, material: grey }, Transform::default(), Static));
    world.spawn((
        engine::light::DirectionalLight { illuminance: 4.0, ..Default::default() },
        Transform::default().looking_at(Vec3::new(0.3, -1.0, -0.4), Vec3::Z),
    ));
    let camera = if eye_level {
        Transform::from_xyz(0.0, 1.7, half + 3.0).looking_at(Vec3::new(0.0, 0.4, 0.0), Vec3::Y)
    } else {
        let distance = 3.0 + half * 1.6;
        Transform::from_xyz(0.0, distance * 0.6, distance).looking_at(Vec3::ZERO, Vec3::Y)
    };
    world.spawn((Camera::default(), camera));
    Ok(())
}

/// Props of the `many-instances` scene unless `--instances` says otherwise.
pub const MANY_INSTANCES: usize = 10_000;
/// Props in each block of the city (the last block may hold fewer).
pub const PROPS_PER_BLOCK: usize = 100;
/// A block's side, in metres.
pub const BLOCK: f32 = 20.0;
/// The width of the streets between blocks, in metres.
pub const STREET: f32 = 6.0;

/// The `many-instances` scene: `props` small meshes (boxes, balls, pillars, crates in four
/// materials, randomly turned and scaled) in square blocks of [`PROPS_PER_BLOCK`], each block
/// walled in by four 12 m buildings (the occluders), one prop in ten standing on the street
/// along its block instead; a ground; the sun; the camera at eye height in the middle of the
/// city, looking down a street. Instances: `props` + 4 per block + 1.
pub fn spawn_city(world: &mut World, props: usize) {
    use engine::camera::Camera;
    use engine::material::Material;
    use engine::mesh::{Mesh, shapes};
    use engine::scene::MeshInstance;

    let blocks = props.div_ceil(PROPS_PER_BLOCK).max(1);
    let side = (blocks as f32).sqrt().ceil() as usize;
    let pitch = BLOCK + STREET;
    let extent = side as f32 * pitch;
    let (ground, wall, shapes) = {
        let mut meshes = world.resource_mut::<Assets<Mesh>>();
        let ground = meshes.add(shapes::plane(extent + 2.0 * STREET, extent + 2.0 * STREET, 1, extent / 4.0));
        let wall = meshes.add(shapes::cuboid(Vec3::new(BLOCK, 12.0, 1.0), 1.0));
        let shapes = [
            meshes.add(shapes::cuboid(Vec3::splat(1.0), 1.0)),
            meshes.add(shapes::uv_sphere(0.5, 16, 8)),
            meshes.add(shapes::cylinder(0.3, 2.0, 12, 1.0)),
            meshes.add(shapes::cuboid(Vec3::new(1.6, 0.8, 1.0), 1.0)),
        ];
        (ground, wall, shapes)
    };
    let (stone, colours) = {
        let mut materials = world.resource_mut::<Assets<Material>>();
        let stone = materials.add(Material::from_color(Vec3::new(0.55, 0.52, 0.48).extend(1.0), 0.0, 0.8));
        let colours: Vec<_> = [Vec3::new(0.8, 0.3, 0.2), Vec3::new(0.2, 0.6, 0.3), Vec3::new(0.25, 0.35, 0.8), Vec3::new(0.8, 0.75, 0.6)]
            .into_iter()
            .map(|c| materials.add(Material::from_color(c.extend(1.0), 0.0, 0.5)))
            .collect();
        (stone, colours)
    };
    // A city does not move: Static keeps its million props out of the transform scan.
    world.spawn((MeshInstance { mesh: ground, material: stone }, Transform::default(), Static));
    let origin = -extent / 2.0;
    let mut rng = SplitMix64::new(24);
    let mut batch = Vec::with_capacity(props + 4 * blocks);
    for b in 0..blocks {
        let corner = Vec3::new(origin + (b % side) as f32 * pitch + STREET / 2.0, 0.0, origin + (b / side) as f32 * pitch + STREET / 2.0);
        let centre = corner + Vec3::new(BLOCK / 2.0, 0.0, BLOCK / 2.0);
        for (offset, turn) in [(Vec3::new(0.0, 6.0, -BLOCK / 2.0), 0.0), (Vec3::new(0.0, 6.0, BLOCK / 2.0), 0.0)]
            .into_iter()
            .chain([(Vec3::new(-BLOCK / 2.0, 6.0, 0.0), 1.0), (Vec3::new(BLOCK / 2.0, 6.0, 0.0), 1.0)])
        {
            let rotation = Quat::from_rotation_y(turn * std::f32::consts::FRAC_PI_2);
            batch.push((
                MeshInstance { mesh: wall, material: stone },
                Transform::from_translation(centre + offset).with_rotation(rotation),
                Static,
            ));
        }
        for _ in 0..PROPS_PER_BLOCK.min(props - b * PROPS_PER_BLOCK) {
            let kind = (rng.next_u64() % 4) as usize;
            let on_street = rng.next_u64().is_multiple_of(10);
            let (u, v) = (rng.next_f32(), rng.next_f32());
            let at = if on_street {
                // Along the block's north side, in the street.
                corner + Vec3::new(u * BLOCK, 0.0, -STREET / 2.0 + v * 1.5 + 0.5)
            } else {
                corner + Vec3::new(1.5 + u * (BLOCK - 3.0), 0.0, 1.5 + v * (BLOCK - 3.0))
            };
            let scale = 0.6 + rng.next_f32() * 0.8;
            let transform = Transform::from_translation(at + Vec3::Y * 0.5 * scale)
                .with_rotation(Quat::from_rotation_y(rng.next_f32() * std::f32::consts::TAU))
                .with_scale(Vec3::splat(scale));
            batch.push((MeshInstance { mesh: shapes[kind], material: colours[(rng.next_u64() % 4) as usize] }, transform, Static));
        }
    }
    world.spawn_batch(batch);
    world.spawn((
        DirectionalLight { illuminance: 4.0, ..Default::default() },
        Transform::default().looking_at(Vec3::new(0.35, -1.0, 0.25), Vec3::Z),
    ));
    // In the street south of the middle row of blocks, looking east along it.
    let row = (side / 2) as f32;
    let street_z = origin + row * pitch;
    let eye = Vec3::new(origin + pitch * 0.5, 1.7, street_z);
    world.spawn((Camera::default(), Transform::from_translation(eye).looking_at(eye + Vec3::new(1.0, -0.02, 0.0), Vec3::Y)));
}

/// PEERS.md's "many instances behind a wall": a floor, the sun, the camera at eye height looking
/// down −Z, a 16 × 8 m wall 6 m in front of it, `boxes` boxes of 0.6 m on a square grid 1.2 m
/// apart from 8 m behind the camera onwards (most of them outside the view), and 20 boxes
/// between the camera and the wall. Instances: `boxes` + 22.
pub fn spawn_behind_wall(world: &mut World, boxes: usize) {
    use engine::camera::Camera;
    use engine::material::Material;
    use engine::mesh::{Mesh, shapes};
    use engine::scene::MeshInstance;

    let side = (boxes as f32).sqrt().ceil().max(1.0) as usize;
    let extent = side as f32 * 1.2;
    let (floor, wall, cube) = {
        let mut meshes = world.resource_mut::<Assets<Mesh>>();
        (
            meshes.add(shapes::plane(extent + 40.0, extent + 40.0, 1, 8.0)),
            meshes.add(shapes::cuboid(Vec3::new(16.0, 8.0, 0.5), 1.0)),
            meshes.add(shapes::cuboid(Vec3::splat(0.6), 1.0)),
        )
    };
    let (grey, red) = {
        let mut materials = world.resource_mut::<Assets<Material>>();
        (
            materials.add(Material::from_color(Vec3::splat(0.6).extend(1.0), 0.0, 0.8)),
            materials.add(Material::from_color(Vec3::new(0.8, 0.3, 0.2).extend(1.0), 0.0, 0.5)),
        )
    };
    world.spawn((MeshInstance { mesh: floor, material: grey }, Transform::from_xyz(0.0, 0.0, -extent / 2.0), Static));
    world.spawn((MeshInstance { mesh: wall, material: grey }, Transform::from_xyz(0.0, 4.0, -6.0), Static));
    let grid = (0..boxes).map(|i| {
        let at = Vec3::new(((i % side) as f32 - side as f32 / 2.0) * 1.2, 0.3, -8.0 - (i / side) as f32 * 1.2);
        (MeshInstance { mesh: cube, material: red }, Transform::from_translation(at), Static)
    });
    let front = (0..20).map(|i| {
        let at = Vec3::new((i % 10) as f32 * 0.9 - 4.0, 0.3, -2.5 - (i / 10) as f32 * 1.5);
        (MeshInstance { mesh: cube, material: red }, Transform::from_translation(at), Static)
    });
    world.spawn_batch(grid.chain(front).collect::<Vec<_>>());
    world.spawn((
        DirectionalLight { illuminance: 4.0, ..Default::default() },
        Transform::default().looking_at(Vec3::new(0.3, -1.0, -0.4), Vec3::Z),
    ));
    world.spawn((Camera::default(), Transform::from_xyz(0.0, 1.7, 0.0).looking_at(Vec3::new(0.0, 1.5, -10.0), Vec3::Y)));
}

/// Issue 52's dark corridor, 3 m wide, 3 m high and 24 m long down −Z: eight glowing sigils on
/// its walls that light it (their material's `emits_light`), a 1.2 × 0.4 m rectangle light on its
/// ceiling halfway down and a 0.5 m disk lamp on its end wall; no sun, no sky (the environment
/// resource's source is set to none) and no flat ambient. The camera stands at eye height just
/// inside its open end.
pub fn spawn_corridor(world: &mut World) {
    use engine::camera::Camera;
    use engine::material::Material;
    use engine::mesh::{Mesh, shapes};
    use engine::scene::MeshInstance;

    let (length, width, height) = (24.0f32, 3.0f32, 3.0f32);
    let (floor, side, end) = {
        let mut meshes = world.resource_mut::<Assets<Mesh>>();
        (
            meshes.add(shapes::cuboid(Vec3::new(width + 0.4, 0.2, length), 1.0)),
            meshes.add(shapes::cuboid(Vec3::new(0.2, height, length), 1.0)),
            meshes.add(shapes::cuboid(Vec3::new(width + 0.4, height, 0.2), 1.0)),
        )
    };
    let stone = world.resource_mut::<Assets<Material>>().add(Material::from_color(Vec3::new(0.55, 0.5, 0.45).extend(1.0), 0.0, 0.6));
    let middle = -length / 2.0;
    let pieces = [
        (floor, Vec3::new(0.0, -0.1, middle)),
        (floor, Vec3::new(0.0, height + 0.1, middle)),
        (side, Vec3::new(-(width / 2.0 + 0.1), height / 2.0, middle)),
        (side, Vec3::new(width / 2.0 + 0.1, height / 2.0, middle)),
        (end, Vec3::new(0.0, height / 2.0, -length - 0.1)),
    ];
    world.spawn_batch(pieces.map(|(mesh, at)| (MeshInstance { mesh, material: stone }, Transform::from_translation(at), Static)));
    let sigil = {
        let mut m = decal_textures::decal_material(&decal_textures::sigil(), world);
        // Brighter than the courtyard's sigils: lamps, not marks.
        m.emissive = Some(Vec3::splat(24.0));
        m.emits_light = true;
        world.resource_mut::<Assets<DecalMaterial>>().add(m)
    };
    // On the walls at 1.4 m, alternating sides, each projecting into its wall.
    let sigils = (0..8).map(|i| {
        let left = i % 2 == 0;
        let x = if left { -width / 2.0 } else { width / 2.0 };
        // The box's +Z out of the wall: it projects into it.
        let yaw = if left { std::f32::consts::FRAC_PI_2 } else { -std::f32::consts::FRAC_PI_2 };
        let at = Transform::from_xyz(x, 1.4, -2.5 - i as f32 * 2.5)
            .with_rotation(Quat::from_rotation_y(yaw))
            .with_scale(Vec3::new(0.9, 0.9, 0.3));
        (Decal::new(sigil), at)
    });
    world.spawn_batch(sigils.collect::<Vec<_>>());
    world.spawn((
        RectLight { color: Vec3::new(1.0, 0.9, 0.7), intensity: 3.0, width: 1.2, height: 0.4, range: None },
        Transform::from_xyz(0.0, height - 0.01, middle).looking_at(Vec3::new(0.0, 0.0, middle), Vec3::Z),
    ));
    world.spawn((
        DiskLight { color: Vec3::new(0.6, 0.8, 1.0), intensity: 8.0, radius: 0.25, range: None },
        Transform::from_xyz(0.0, 2.2, -length + 0.01).looking_at(Vec3::new(0.0, 2.2, 0.0), Vec3::Y),
    ));
    world.spawn((Camera::default(), Transform::from_xyz(0.6, 1.6, -0.3).looking_at(Vec3::new(0.0, 1.2, -12.0), Vec3::Y)));
    // Dark but for its own lights: no sky through the open end, no flat ambient.
    if let Some(mut environment) = world.get_resource_mut::<engine::environment::Environment>() {
        environment.source = engine::environment::EnvironmentSource::None;
    }
    if let Some(mut settings) = world.get_resource_mut::<plugins::RenderSettings>() {
        settings.ambient = Vec3::ZERO;
    }
}

/// Particles the particle scene keeps alive when no count is given.
pub const PARTICLES: u32 = 100_000;

/// The particle benchmark: the courtyard, its camera looking at a fountain of `alive`
/// particles in front of it ([`crate::effects::fountain`]). With `decals`, each particle leaves
/// a 5 cm spot where it first lands (GPU-born decals, as many a second as particles land: a
/// fountain of 120,000 leaves about 1,000 a frame at 60 frames a second).
pub fn spawn_particles(world: &mut World, alive: u32, decals: bool) {
    let info = spawn_courtyard(world);
    let camera = *world.get::<Transform>(info.camera).expect("courtyard camera");
    let ahead = camera.forward().with_y(0.0).normalize_or_zero();
    let at = (camera.translation + ahead * 6.0).with_y(0.2);
    let mut fountain = crate::effects::fountain(alive);
    if decals {
        let soot = crate::effects::soot_spot(world);
        fountain.leaves = Some(plugins::particles::LeftDecal::new(soot, 0.05, 10.0));
    }
    world.spawn((fountain, Transform::from_translation(at)));
}

/// Seed 002 §4.2's polygon counts: opaque and transparent triangles.
pub const TRANSPARENCY_TRIANGLES: (usize, usize) = (38_812, 20_832);
/// Spot lights the transparency scene starts with.
pub const TRANSPARENCY_LIGHTS: usize = 32;

/// A spot light of the transparency scene (what [`set_spot_lights`] adds and removes).
#[derive(Component)]
pub struct BenchSpot;

fn spawn_transparency_scene(world: &mut World) {
    use engine::material::{AlphaMode, Material};
    use engine::mesh::{Mesh, shapes};
    use engine::scene::MeshInstance;

    // Its own scene: the courtyard alone has more opaque triangles than the seed's whole scene.
    let ground = shapes::plane(40.0, 40.0, 8, 8.0);
    let courtyard = ground.triangle_count();
    let ball = shapes::uv_sphere(0.45, 32, 16);
    let glass_ball = shapes::uv_sphere(0.8, 48, 24);
    let pane = shapes::cuboid(Vec3::new(3.0, 2.2, 0.04), 1.0);
    let (opaque_balls, glass_balls) = {
        let (opaque, transparent) = TRANSPARENCY_TRIANGLES;
        let panes = 3 * pane.triangle_count();
        (
            opaque.saturating_sub(courtyard).div_ceil(ball.triangle_count()),
            transparent.saturating_sub(panes).div_ceil(glass_ball.triangle_count()),
        )
    };
    let (ground, ball, glass_ball, pane) = {
        let mut meshes = world.resource_mut::<Assets<Mesh>>();
        (meshes.add(ground), meshes.add(ball), meshes.add(glass_ball), meshes.add(pane))
    };
    let mut materials = world.resource_mut::<Assets<Material>>();
    let colours: Vec<_> = [Vec3::new(0.8, 0.3, 0.2), Vec3::new(0.2, 0.6, 0.3), Vec3::new(0.25, 0.35, 0.8), Vec3::new(0.8, 0.75, 0.6)]
        .into_iter()
        .map(|c| materials.add(Material::from_color(c.extend(1.0), 0.0, 0.5)))
        .collect();
    let glass = |tint: Vec3, alpha: f32, thickness: f32| Material {
        alpha_mode: AlphaMode::Blend,
        thickness,
        ..Material::from_color(tint.extend(alpha), 0.0, 0.1)
    };
    let stone = materials.add(Material::from_color(Vec3::splat(0.55).extend(1.0), 0.0, 0.8));
    let ball_glass = materials.add(glass(Vec3::new(0.6, 0.8, 0.9), 0.35, 0.4));
    let pane_glass = materials.add(glass(Vec3::new(0.7, 0.9, 0.8), 0.25, 0.05));
    // A field of balls behind, glass balls in a row and panes nearer the camera.
    let columns = 12;
    let opaque: Vec<_> = (0..opaque_balls)
        .map(|i| {
            let (col, row) = ((i % columns) as f32, (i / columns) as f32);
            let at = Vec3::new(-7.7 + col * 1.4, 0.45, -4.0 + row * 1.4);
            (MeshInstance { mesh: ball, material: colours[i % colours.len()] }, Transform::from_translation(at))
        })
        .collect();
    let transparent: Vec<_> = (0..glass_balls)
        .map(|i| {
            let at = Vec3::new(-7.2 + (i % 10) as f32 * 1.6, 0.8 + 1.7 * (i / 10) as f32, 5.0);
            (MeshInstance { mesh: glass_ball, material: ball_glass }, Transform::from_translation(at))
        })
        .chain((0..3).map(|i| {
            let at = Vec3::new(-3.5 + 3.5 * i as f32, 1.1, 8.5);
            (
                MeshInstance { mesh: pane, material: pane_glass },
                Transform::from_translation(at).with_rotation(Quat::from_rotation_y(0.2 * (i as f32 - 1.0))),
            )
        }))
        .collect();
    world.spawn_batch(opaque);
    world.spawn_batch(transparent);
    world.spawn((MeshInstance { mesh: ground, material: stone }, Transform::default()));
    world.spawn((engine::camera::Camera::default(), Transform::from_xyz(0.0, 3.5, 14.0).looking_at(Vec3::new(0.0, 0.6, 0.0), Vec3::Y)));
    set_spot_lights(world, TRANSPARENCY_LIGHTS);
}

/// Replaces the transparency scene's spot lights by `count` new ones, over the field of balls
/// and pointing down at it (the seed's lights were all spot lights).
pub fn set_spot_lights(world: &mut World, count: usize) {
    let old: Vec<Entity> = world.query_filtered::<Entity, With<BenchSpot>>().iter(world).collect();
    for e in old {
        world.despawn(e);
    }
    let mut rng = SplitMix64::new(11);
    let batch: Vec<_> = (0..count)
        .map(|_| {
            let at = Vec3::new(rng.range_f32(-10.0, 10.0), rng.range_f32(4.0, 6.0), rng.range_f32(-6.0, 9.0));
            let target = at + Vec3::new(rng.range_f32(-3.0, 3.0), -at.y, rng.range_f32(-3.0, 3.0));
            let colour = Vec3::new(rng.range_f32(0.6, 1.0), rng.range_f32(0.6, 1.0), rng.range_f32(0.6, 1.0));
            let light =
                SpotLight { color: colour, intensity: 60.0, range: Some(14.0), inner_angle: 0.3, outer_angle: 0.6, ..Default::default() };
            (light, Transform::from_translation(at).looking_at(target, Vec3::Z), BenchSpot)
        })
        .collect();
    world.spawn_batch(batch);
}

/// Point lights in seed 000 §5.2.5's many-lights scene.
pub const MANY_LIGHTS: usize = 28_587;

fn despawn_local_lights(world: &mut World) {
    let lights: Vec<Entity> = world.query_filtered::<Entity, Or<(With<PointLight>, With<SpotLight>)>>().iter(world).collect();
    for e in lights {
        world.despawn(e);
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn scenes_have_the_seed_scenarios_counts() {
        for (scene, decals, lights) in [
            (BenchScene::FewBlendedDecals, 6, 5),
            (BenchScene::DecalsAndLights, 100, 28),
            (BenchScene::ManyDecals, 100_000, 1),
            (BenchScene::TenPointLights, 0, 10),
            (BenchScene::ManyLights, 0, MANY_LIGHTS + 1),
        ] {
            let mut app = engine::app::App::new();
            app.add_plugins(plugins::RenderPlugin::new(Default::default()));
            spawn_bench_scene(&mut app.world, scene);
            let d = app.world.query::<&Decal>().iter(&app.world).count();
            let l = app.world.query::<&PointLight>().iter(&app.world).count()
                + app.world.query::<&SpotLight>().iter(&app.world).count()
                + app.world.query::<&DirectionalLight>().iter(&app.world).count();
            assert_eq!((d, l), (decals, lights), "{scene:?}");
        }
        assert!(BenchScene::parse("nope").is_err());
    }

    #[test]
    fn transparency_scene_has_the_seeds_polygon_counts_and_only_spot_lights() {
        use engine::material::{AlphaMode, Material};
        use engine::mesh::Mesh;
        use engine::scene::MeshInstance;
        let mut app = engine::app::App::new();
        app.add_plugins(plugins::RenderPlugin::new(Default::default()));
        spawn_bench_scene(&mut app.world, BenchScene::Transparency);
        let world = &mut app.world;
        let (mut opaque, mut transparent) = (0, 0);
        let instances: Vec<MeshInstance> = world.query::<&MeshInstance>().iter(world).copied().collect();
        for i in instances {
            let triangles = world.resource::<Assets<Mesh>>().get(i.mesh).unwrap().triangle_count();
            match world.resource::<Assets<Material>>().get(i.material).unwrap().alpha_mode {
                AlphaMode::Blend => transparent += triangles,
                _ => opaque += triangles,
            }
        }
        let (o, t) = TRANSPARENCY_TRIANGLES;
        // Whole balls: at most one ball's triangles over the seed's counts.
        assert!(
            opaque >= o && opaque < o + 1_000 && transparent >= t && transparent < t + 2_300,
            "{opaque} opaque, {transparent} transparent"
        );
        let spots = world.query::<&SpotLight>().iter(world).count();
        let others = world.query::<&PointLight>().iter(world).count() + world.query::<&DirectionalLight>().iter(world).count();
        assert_eq!((spots, others), (TRANSPARENCY_LIGHTS, 0));
        set_spot_lights(world, 4);
        assert_eq!(world.query::<&SpotLight>().iter(world).count(), 4);
    }
}
