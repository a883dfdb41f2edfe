//! The default scene: a walled courtyard generated entirely in code.
//!
//! A 44 m square stone-tiled ground, four brick walls built from arched wall pieces
//! ([`shapes::arch_wall`]), sandstone columns, a fountain, stacks of wooden crates and a few
//! spheres of different metals and plastics, lit by a low sun, three lamp-post point lights and
//! a spot light on the fountain. Every surface material is textured with procedural images
//! (albedo plus a tangent-space normal map derived from the same height function), generated
//! deterministically from an integer hash, so every run renders the same pixels.
//!
//! Light levels target the renderer's exposure of 1.0: radiance of a Lambertian surface is
//! `albedo / π · E`, so the 4 lux sun gives ~0.4–0.7 on the lit ground and walls, and the 25–40 cd
//! lamps give ~0.3–1.5 within a few metres (`E = I / d²`).

use std::f32::consts::FRAC_PI_2;

use bevy_ecs::prelude::*;
use engine::asset::{Assets, Handle};
use engine::camera::Camera;
use engine::image::Image;
use engine::light::{DirectionalLight, PointLight, SpotLight};
use engine::material::Material;
use engine::mesh::{Mesh, shapes};
use engine::scene::{MeshInstance, Name};
use engine::transform::Transform;
use glam::{Quat, Vec3, Vec4};

/// What [`spawn_courtyard`] created.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct CourtyardInfo {
    /// The camera entity (eye height, in a corner, looking at the fountain).
    pub camera: Entity,
    /// Triangles over all mesh instances (each instance counted).
    pub triangles: usize,
    /// Number of light entities.
    pub lights: usize,
}

/// Side of the procedural textures in pixels.
const TEXTURE_SIZE: u32 = 256;

/// Half the distance between opposite walls, in metres.
pub const HALF_COURT: f32 = 20.0;

/// Where the character walks ([`crate::character`]): centre and radius of its loop, in the open
/// corner in front of the camera.
pub const WALKER_LOOP: (Vec3, f32) = (Vec3::new(-13.0, 0.0, 13.0), 2.0);

/// Spawns the courtyard into `world` (creating the `Assets` resources if missing).
pub fn spawn_courtyard(world: &mut World) -> CourtyardInfo {
    let textures = {
        let mut add = |name: &str, (albedo, normal): (Image, Image)| {
            let albedo = crate::assets::import_generated(world, albedo, engine::image::TextureRole::Color, name);
            let normal = crate::assets::import_generated(world, normal, engine::image::TextureRole::Normal, name);
            let mut images = world.get_resource_or_init::<Assets<Image>>();
            (images.add(albedo), images.add(normal))
        };
        Textures {
            stone: add("stone tiles", textures::stone_tiles(TEXTURE_SIZE)),
            brick: add("bricks", textures::bricks(TEXTURE_SIZE)),
            sandstone: add("sandstone", textures::sandstone(TEXTURE_SIZE)),
            wood: add("crate wood", textures::crate_wood(TEXTURE_SIZE)),
        }
    };
    let materials = {
        let mut assets = world.get_resource_or_init::<Assets<Material>>();
        let textured = |(albedo, normal): (Handle<Image>, Handle<Image>), roughness: f32| Material {
            base_color_texture: Some(albedo),
            normal_texture: Some(normal),
            roughness,
            ..Default::default()
        };
        Materials {
            ground: assets.add(textured(textures.stone, 0.85)),
            wall: assets.add(textured(textures.brick, 0.9)),
            sandstone: assets.add(textured(textures.sandstone, 0.7)),
            wood: assets.add(textured(textures.wood, 0.65)),
            water: assets.add(Material::from_color(Vec4::new(0.05, 0.12, 0.16, 1.0), 0.0, 0.05)),
            // Gold with the sandstone's normal map for a hammered look.
            gold: assets.add(Material {
                base_color: Vec4::new(1.0, 0.78, 0.34, 1.0),
                normal_texture: Some(textures.sandstone.1),
                metallic: 1.0,
                roughness: 0.3,
                ..Default::default()
            }),
            chrome: assets.add(Material::from_color(Vec4::new(0.9, 0.9, 0.92, 1.0), 1.0, 0.08)),
            red_plastic: assets.add(Material::from_color(Vec4::new(0.7, 0.06, 0.05, 1.0), 0.0, 0.35)),
            copper: assets.add(Material::from_color(Vec4::new(0.95, 0.64, 0.54, 1.0), 1.0, 0.45)),
            iron: assets.add(Material::from_color(Vec4::new(0.08, 0.08, 0.09, 1.0), 0.8, 0.5)),
        }
    };

    let mut scene = SceneBuilder { world, triangles: 0, parent: Entity::PLACEHOLDER };
    scene.parent = scene.world.spawn((Transform::IDENTITY, Name::new("Courtyard"))).id();
    build_geometry(&mut scene, &materials);
    let lights = spawn_lights(&mut scene);

    let eye = Vec3::new(-HALF_COURT + 3.0, 1.7, HALF_COURT - 3.0);
    let camera = scene
        .world
        .spawn((
            Camera::default(),
            Transform::from_translation(eye).looking_at(Vec3::new(0.0, 1.2, 0.0), Vec3::Y),
            Name::new("Camera"),
            ChildOf(scene.parent),
        ))
        .id();
    tracing::info!(triangles = scene.triangles, lights, "spawned courtyard");
    CourtyardInfo { camera, triangles: scene.triangles, lights }
}

struct Textures {
    stone: (Handle<Image>, Handle<Image>),
    brick: (Handle<Image>, Handle<Image>),
    sandstone: (Handle<Image>, Handle<Image>),
    wood: (Handle<Image>, Handle<Image>),
}

struct Materials {
    ground: Handle<Material>,
    wall: Handle<Material>,
    sandstone: Handle<Material>,
    wood: Handle<Material>,
    water: Handle<Material>,
    gold: Handle<Material>,
    chrome: Handle<Material>,
    red_plastic: Handle<Material>,
    copper: Handle<Material>,
    iron: Handle<Material>,
}

/// Adds meshes and spawns named instances under the courtyard's root, counting triangles.
struct SceneBuilder<'w> {
    world: &'w mut World,
    triangles: usize,
    parent: Entity,
}

impl SceneBuilder<'_> {
    fn mesh(&mut self, mesh: Mesh) -> (Handle<Mesh>, usize) {
        let triangles = mesh.triangle_count();
        (self.world.get_resource_or_init::<Assets<Mesh>>().add(mesh), triangles)
    }

    fn instance(&mut self, name: &str, (mesh, triangles): (Handle<Mesh>, usize), material: Handle<Material>, transform: Transform) {
        self.triangles += triangles;
        self.world.spawn((transform, MeshInstance { mesh, material }, Name::new(name), ChildOf(self.parent)));
    }
}

fn build_geometry(scene: &mut SceneBuilder<'_>, m: &Materials) {
    // Ground: 44 m so that it runs under the walls; tiles repeat every 2 m.
    let ground = scene.mesh(shapes::plane(2.0 * HALF_COURT + 4.0, 2.0 * HALF_COURT + 4.0, 80, 0.5));
    scene.instance("Ground", ground, m.ground, Transform::IDENTITY);

    // Walls: four arched 10 m pieces per side; the brick texture repeats every 2 m.
    let wall_piece = scene.mesh(scale_uvs(shapes::arch_wall(10.0, 6.5, 0.8, 1.7, 32), 0.5));
    for side in 0..4 {
        let rotation = Quat::from_rotation_y(side as f32 * FRAC_PI_2);
        for k in 0..4 {
            let along = -15.0 + 10.0 * k as f32;
            let position = rotation * Vec3::new(along, 0.0, -HALF_COURT);
            scene.instance(&format!("Wall {side}.{k}"), wall_piece, m.wall, Transform::from_translation(position).with_rotation(rotation));
        }
    }

    // Columns with square capitals and plinths along the two far sides.
    let shaft = scene.mesh(shapes::cylinder(0.35, 4.6, 48, 1.0));
    let block = scene.mesh(shapes::cuboid(Vec3::new(1.0, 0.4, 1.0), 1.0));
    let columns = [-12.0f32, -6.0, 0.0, 6.0, 12.0]
        .iter()
        .map(|&x| Vec3::new(x, 0.0, -HALF_COURT + 4.0))
        .chain([-6.0f32, 0.0, 6.0].iter().map(|&z| Vec3::new(HALF_COURT - 4.0, 0.0, z)));
    for (i, base) in columns.enumerate() {
        scene.instance(&format!("Column {i}"), shaft, m.sandstone, Transform::from_translation(base + Vec3::Y * 2.7));
        scene.instance(&format!("Plinth {i}"), block, m.sandstone, Transform::from_translation(base + Vec3::Y * 0.2));
        scene.instance(&format!("Capital {i}"), block, m.sandstone, Transform::from_translation(base + Vec3::Y * 5.2));
    }

    // Fountain: basin, water, pillar and a chrome ball.
    let basin = scene.mesh(shapes::cylinder(3.0, 0.6, 96, 1.0));
    scene.instance("Fountain basin", basin, m.sandstone, Transform::from_xyz(0.0, 0.3, 0.0));
    let water = scene.mesh(shapes::cylinder(2.7, 0.04, 96, 1.0));
    scene.instance("Fountain water", water, m.water, Transform::from_xyz(0.0, 0.62, 0.0));
    let pillar = scene.mesh(shapes::cylinder(0.3, 1.8, 48, 1.0));
    scene.instance("Fountain pillar", pillar, m.sandstone, Transform::from_xyz(0.0, 1.5, 0.0));
    let ball = scene.mesh(shapes::uv_sphere(0.55, 96, 48));
    scene.instance("Fountain ball", ball, m.chrome, Transform::from_xyz(0.0, 2.95, 0.0));

    // Crates: two stacks, slightly rotated.
    let crate_mesh = scene.mesh(shapes::cuboid(Vec3::ONE, 1.0));
    let crates = [
        (Vec3::new(-11.0, 0.5, -8.0), 0.1),
        (Vec3::new(-9.8, 0.5, -8.3), -0.2),
        (Vec3::new(-10.4, 1.5, -8.1), 0.35),
        (Vec3::new(-10.6, 0.5, -6.8), 0.05),
        (Vec3::new(9.0, 0.5, 9.0), 0.6),
        (Vec3::new(10.2, 0.5, 8.6), 0.3),
        (Vec3::new(9.6, 1.5, 8.9), -0.25),
    ];
    for (i, (position, yaw)) in crates.into_iter().enumerate() {
        scene.instance(
            &format!("Crate {i}"),
            crate_mesh,
            m.wood,
            Transform::from_translation(position).with_rotation(Quat::from_rotation_y(yaw)),
        );
    }

    // Spheres of different materials.
    let sphere = scene.mesh(shapes::uv_sphere(1.0, 64, 32));
    let spheres = [
        ("Gold sphere", Vec3::new(5.0, 0.8, -4.0), 0.8, m.gold),
        ("Red sphere", Vec3::new(-4.5, 0.6, 5.0), 0.6, m.red_plastic),
        ("Copper sphere", Vec3::new(-6.0, 0.7, -3.0), 0.7, m.copper),
        ("Stone sphere", Vec3::new(7.0, 1.0, 5.0), 1.0, m.sandstone),
        ("Wooden sphere", Vec3::new(3.5, 0.45, 6.5), 0.45, m.wood),
    ];
    for (name, centre, radius, material) in spheres {
        scene.instance(name, sphere, material, Transform::from_translation(centre).with_scale(Vec3::splat(radius)));
    }

    // Lamp posts (the lights sit just above their tops, outside any geometry).
    let post = scene.mesh(shapes::cylinder(0.08, 3.0, 24, 1.0));
    for (i, position) in LAMPS.iter().enumerate() {
        scene.instance(&format!("Lamp post {i}"), post, m.iron, Transform::from_xyz(position.x, 1.5, position.z));
    }
}

/// Lamp light positions.
const LAMPS: [Vec3; 3] = [Vec3::new(-12.0, 3.3, -12.0), Vec3::new(12.0, 3.3, -12.0), Vec3::new(12.0, 3.3, 12.0)];

fn spawn_lights(scene: &mut SceneBuilder<'_>) -> usize {
    let parent = scene.parent;
    let world = &mut *scene.world;
    world.spawn((
        DirectionalLight { color: Vec3::new(1.0, 0.95, 0.86), illuminance: 4.0, ..Default::default() },
        Transform::from_xyz(18.0, 25.0, 12.0).looking_at(Vec3::ZERO, Vec3::Y),
        Name::new("Sun"),
        ChildOf(parent),
    ));
    let colours = [Vec3::new(1.0, 0.72, 0.42), Vec3::new(1.0, 0.8, 0.55), Vec3::new(0.75, 0.85, 1.0)];
    let intensities = [30.0, 25.0, 40.0];
    for (i, ((&position, color), intensity)) in LAMPS.iter().zip(colours).zip(intensities).enumerate() {
        world.spawn((
            PointLight { color, intensity, range: None, ..Default::default() },
            Transform::from_translation(position),
            Name::new(format!("Lamp {i}")),
            ChildOf(parent),
        ));
    }
    world.spawn((
        SpotLight {
            color: Vec3::new(1.0, 0.97, 0.9),
            intensity: 60.0,
            range: None,
            inner_angle: 0.25,
            outer_angle: 0.4,
            ..Default::default()
        },
        Transform::from_xyz(-8.0, 7.0, 8.0).looking_at(Vec3::new(0.0, 1.0, 0.0), Vec3::Y),
        Name::new("Fountain spot"),
        ChildOf(parent),
    ));
    1 + LAMPS.len() + 1
}

/// Procedural, tileable, deterministic textures: each returns `(albedo sRGB, normal linear)`.
pub mod textures {
    use engine::image::{ColorSpace, Image};
    use glam::{Vec2, Vec3};

    /// A 32-bit integer hash (lowbias32 finaliser) of a lattice point and seed.
    pub fn hash(x: u32, y: u32, seed: u32) -> u32 {
        let mut h = x.wrapping_mul(0x9E37_79B1) ^ y.wrapping_mul(0x85EB_CA77) ^ seed.wrapping_mul(0xC2B2_AE3D);
        h ^= h >> 16;
        h = h.wrapping_mul(0x7FEB_352D);
        h ^= h >> 15;
        h = h.wrapping_mul(0x846C_A68B);
        h ^ (h >> 16)
    }

    /// The hash as a float in [0, 1).
    pub fn hash01(x: u32, y: u32, seed: u32) -> f32 {
        (hash(x, y, seed) >> 8) as f32 / (1u32 << 24) as f32
    }

    /// Smooth value noise with a lattice of `period`×`period` cells over [0, 1)², tileable.
    pub fn value_noise(p: Vec2, period: u32, seed: u32) -> f32 {
        let q = p * period as f32;
        let (cell, f) = (q.floor(), q - q.floor());
        let s = f * f * (Vec2::splat(3.0) - 2.0 * f);
        let at = |dx: u32, dy: u32| {
            let x = (cell.x as i64).rem_euclid(period as i64) as u32;
            let y = (cell.y as i64).rem_euclid(period as i64) as u32;
            hash01((x + dx) % period, (y + dy) % period, seed)
        };
        let top = at(0, 0) + (at(1, 0) - at(0, 0)) * s.x;
        let bottom = at(0, 1) + (at(1, 1) - at(0, 1)) * s.x;
        top + (bottom - top) * s.y
    }

    /// Four octaves of [`value_noise`], in [0, 1].
    pub fn fbm(p: Vec2, period: u32, seed: u32) -> f32 {
        let (mut sum, mut amplitude, mut total) = (0.0, 0.5, 0.0);
        for octave in 0..4 {
            sum += amplitude * value_noise(p, period << octave, seed + octave);
            total += amplitude;
            amplitude *= 0.5;
        }
        sum / total
    }

    fn srgb_byte(linear: f32) -> u8 {
        let c = linear.clamp(0.0, 1.0);
        let s = if c <= 0.003_130_8 { c * 12.92 } else { 1.055 * c.powf(1.0 / 2.4) - 0.055 };
        (s * 255.0 + 0.5) as u8
    }

    /// Builds the albedo (from linear RGB) and normal map (from height in texels) of a
    /// `size`² texture (`size` at least 1); `sample(uv)` returns `(linear albedo, height)` at
    /// texel centres.
    pub fn build(size: u32, strength: f32, sample: impl Fn(Vec2) -> (Vec3, f32)) -> (Image, Image) {
        let size = size.max(1);
        let n = size as usize;
        let mut albedo = Vec::with_capacity(n * n * 4);
        let mut height = Vec::with_capacity(n * n);
        for y in 0..n {
            for x in 0..n {
                let uv = (Vec2::new(x as f32, y as f32) + 0.5) / size as f32;
                let (color, h) = sample(uv);
                albedo.extend([srgb_byte(color.x), srgb_byte(color.y), srgb_byte(color.z), 255]);
                height.push(h);
            }
        }
        // Tangent-space normals from central differences with wrap-around; +Y is image-up
        // (decreasing V), the engine's glTF convention: n = (-dh/du, +dh/dv, 1).
        let h = |x: usize, y: usize| height[(y % n) * n + (x % n)];
        let mut normal = Vec::with_capacity(n * n * 4);
        for y in 0..n {
            for x in 0..n {
                let dhdu = (h(x + 1, y) - h(x + n - 1, y)) * 0.5 * strength;
                let dhdv = (h(x, y + 1) - h(x, y + n - 1)) * 0.5 * strength;
                let v = Vec3::new(-dhdu, dhdv, 1.0).normalize();
                let encode = |c: f32| ((c * 0.5 + 0.5) * 255.0 + 0.5) as u8;
                normal.extend([encode(v.x), encode(v.y), encode(v.z), 255]);
            }
        }
        (
            Image::from_rgba8(size, size, albedo, ColorSpace::Srgb).expect("size matches"),
            Image::from_rgba8(size, size, normal, ColorSpace::Linear).expect("size matches"),
        )
    }

    /// Distance-to-edge bevel: 0 in the joint, rising to 1 over `bevel` (in cell units).
    fn bevel(d: f32, joint: f32, bevel: f32) -> f32 {
        ((d - joint) / bevel).clamp(0.0, 1.0)
    }

    /// Square stone flags, 4×4 per texture, grey-beige with per-tile tint and mortar joints.
    pub fn stone_tiles(size: u32) -> (Image, Image) {
        build(size, 2.5, |uv| {
            let cells = 4.0;
            let q = uv * cells;
            let (cell, f) = (q.floor(), q - q.floor());
            let edge = f.min(Vec2::ONE - f).min_element();
            let tile = bevel(edge, 0.025, 0.05);
            let (cx, cy) = (cell.x as u32, cell.y as u32);
            let tint = 0.8 + 0.35 * hash01(cx, cy, 1);
            let grain = fbm(uv, 16, 7);
            let stone = Vec3::new(0.42, 0.39, 0.34) * tint * (0.75 + 0.5 * grain);
            let mortar = Vec3::new(0.2, 0.19, 0.18) * (0.8 + 0.4 * grain);
            let color = mortar.lerp(stone, tile);
            (color, tile * 1.2 + grain * 0.8 * tile)
        })
    }

    /// Running-bond bricks (8 courses of 4 bricks per texture) with recessed mortar.
    pub fn bricks(size: u32) -> (Image, Image) {
        build(size, 3.0, |uv| {
            let (courses, per_course) = (8.0, 4.0);
            let row = (uv.y * courses).floor();
            let shift = if (row as u32).is_multiple_of(2) { 0.0 } else { 0.5 };
            let x = uv.x * per_course + shift;
            let (col, fx) = (x.floor(), x - x.floor());
            let fy = uv.y * courses - row;
            // Joint widths equal in texels: bricks are twice as wide as tall.
            let edge = (fx.min(1.0 - fx) * 2.0).min(fy.min(1.0 - fy));
            let brick = bevel(edge, 0.06, 0.08);
            let id_x = (col as i32).rem_euclid(per_course as i32) as u32;
            let shade = hash01(id_x, row as u32, 3);
            let noise = fbm(uv, 32, 11);
            let base = Vec3::new(0.45, 0.16, 0.1).lerp(Vec3::new(0.55, 0.3, 0.2), shade);
            let color = Vec3::new(0.38, 0.36, 0.33).lerp(base * (0.8 + 0.4 * noise), brick);
            (color, brick + 0.3 * noise * brick)
        })
    }

    /// Fine-grained sandstone with faint horizontal strata.
    pub fn sandstone(size: u32) -> (Image, Image) {
        build(size, 4.0, |uv| {
            let noise = fbm(uv, 8, 21);
            let strata = (0.5 + 0.5 * (uv.y * std::f32::consts::TAU * 6.0 + noise * 4.0).sin()) * 0.15;
            let color = Vec3::new(0.62, 0.5, 0.34) * (0.8 + 0.3 * noise + strata);
            (color, noise + strata)
        })
    }

    /// Crate planks: four vertical boards with grain inside a darker frame.
    pub fn crate_wood(size: u32) -> (Image, Image) {
        build(size, 3.0, |uv| {
            let frame_width = 0.1;
            let edge = uv.min(Vec2::ONE - uv).min_element();
            let in_frame = edge < frame_width;
            let boards = 4.0;
            let b = uv.x * boards;
            let board = b.floor();
            let fb = b - board;
            let groove = if in_frame {
                bevel(frame_width - edge, 0.0, 0.02).min(bevel(edge, 0.005, 0.02))
            } else {
                bevel(fb.min(1.0 - fb), 0.02, 0.05)
            };
            // Grain runs along the boards (V), or along U in the horizontal frame parts.
            let along = if in_frame && uv.y.min(1.0 - uv.y) < frame_width { uv.x } else { uv.y };
            let across = if in_frame && uv.y.min(1.0 - uv.y) < frame_width { uv.y } else { uv.x };
            let warp = fbm(Vec2::new(across, along), 8, 31 + board as u32);
            let grain = 0.5 + 0.5 * (across * 180.0 + warp * 12.0).sin();
            let tint = 0.85 + 0.3 * hash01(board as u32, in_frame as u32, 5);
            let wood = Vec3::new(0.45, 0.3, 0.16) * tint * (0.75 + 0.25 * grain);
            let color = if in_frame { wood * 0.7 } else { wood };
            (color * (0.5 + 0.5 * groove), groove + 0.1 * grain)
        })
    }

    #[cfg(test)]
    mod tests {
        use super::*;

        #[test]
        fn textures_are_deterministic_and_tile() {
            let (a1, n1) = stone_tiles(64);
            let (a2, n2) = stone_tiles(64);
            assert!(a1 == a2 && n1 == n2);
            assert_eq!(a1.mip_count(), 7);
            // Value noise wraps: the left edge matches the right edge's neighbour.
            for y in 0..8 {
                let v = y as f32 / 8.0;
                let left = value_noise(Vec2::new(0.0, v), 8, 3);
                let right = value_noise(Vec2::new(1.0, v), 8, 3);
                assert!((left - right).abs() < 1e-5);
            }
        }

        #[test]
        fn normal_maps_are_unit_and_face_outwards() {
            for (albedo, normal) in [stone_tiles(64), bricks(64), sandstone(64), crate_wood(64)] {
                assert_eq!(albedo.color_space, ColorSpace::Srgb);
                assert_eq!(normal.color_space, ColorSpace::Linear);
                let mut bumpy = 0;
                for texel in normal.mips[0].chunks_exact(4) {
                    let n = Vec3::new(texel[0] as f32, texel[1] as f32, texel[2] as f32) / 127.5 - 1.0;
                    assert!((n.length() - 1.0).abs() < 0.02, "{n}");
                    assert!(n.z > 0.2);
                    bumpy += (n.z < 0.99) as u32;
                }
                assert!(bumpy > 64, "normal map is flat");
            }
        }
    }
}

/// Multiplies a mesh's UVs by `scale` (tangents stay valid: only their length would change).
fn scale_uvs(mut mesh: Mesh, scale: f32) -> Mesh {
    for uv in &mut mesh.uvs {
        uv[0] *= scale;
        uv[1] *= scale;
    }
    mesh
}

#[cfg(test)]
mod tests {
    use super::*;
    use engine::image::ColorSpace;
    use engine::transform::GlobalTransform;
    use std::f32::consts::PI;

    /// The courtyard, its generated textures kept RGBA8 (the tests read their texels).
    fn spawn() -> (World, CourtyardInfo) {
        let mut world = World::new();
        let options = engine::gltf::LoadOptions { textures: engine::gltf::TextureImport::Rgba8, ..Default::default() };
        world.insert_resource(crate::assets::ImportOptions(options));
        let info = spawn_courtyard(&mut world);
        (world, info)
    }

    #[test]
    fn courtyard_has_tens_of_thousands_of_triangles() {
        let (mut world, info) = spawn();
        assert!((20_000..200_000).contains(&info.triangles), "{} triangles", info.triangles);
        // The reported count matches the instances actually spawned.
        let mut query = world.query::<&MeshInstance>();
        let meshes = world.resource::<Assets<Mesh>>();
        let counted: usize = query.iter(&world).map(|i| meshes.get(i.mesh).unwrap().triangle_count()).sum();
        assert_eq!(counted, info.triangles);
        for (_, mesh) in meshes.iter() {
            mesh.validate().unwrap();
        }
        assert!(world.query::<&MeshInstance>().iter(&world).count() >= 60);
    }

    #[test]
    fn lights_are_mixed_and_in_range() {
        let (mut world, info) = spawn();
        let suns: Vec<DirectionalLight> = world.query::<&DirectionalLight>().iter(&world).copied().collect();
        let points: Vec<PointLight> = world.query::<&PointLight>().iter(&world).copied().collect();
        let spots: Vec<SpotLight> = world.query::<&SpotLight>().iter(&world).copied().collect();
        assert_eq!(info.lights, suns.len() + points.len() + spots.len());
        assert!(suns.len() == 1 && points.len() >= 2 && !spots.is_empty());
        assert!((3.0..=8.0).contains(&suns[0].illuminance));
        for light in &points {
            assert!((10.0..100.0).contains(&light.intensity));
        }
        // Radiance of the lit ground under the sun alone (Lambert: albedo/π · E · cos θ) lands
        // in the renderer's comfortable range at exposure 1.
        let mut sun_dir = world.query::<(&DirectionalLight, &Transform)>();
        let (_, sun_transform) = sun_dir.iter(&world).next().unwrap();
        let cos = (-sun_transform.forward()).dot(Vec3::Y);
        let mut named = world.query::<(&MeshInstance, &Name)>();
        let images = world.resource::<Assets<Image>>();
        let materials = world.resource::<Assets<Material>>();
        let ground = named.iter(&world).find(|(_, n)| n.0 == "Ground").map(|(i, _)| materials.get(i.material).unwrap().clone()).unwrap();
        let albedo = images.get(ground.base_color_texture.unwrap()).unwrap();
        let top = albedo.mips.last().unwrap();
        let linear = |c: u8| (c as f32 / 255.0).powf(2.2);
        let mean = (linear(top[0]) + linear(top[1]) + linear(top[2])) / 3.0;
        let radiance = mean / PI * suns[0].illuminance * cos;
        assert!((0.2..1.5).contains(&radiance), "ground radiance {radiance}");
    }

    #[test]
    fn camera_looks_into_the_courtyard_at_eye_height() {
        let (world, info) = spawn();
        let transform = *world.get::<Transform>(info.camera).unwrap();
        assert!(world.get::<Camera>(info.camera).unwrap().active);
        assert!((1.4..2.0).contains(&transform.translation.y));
        assert!(transform.translation.x.abs() > 10.0 && transform.translation.z.abs() > 10.0, "in a corner");
        assert!(transform.translation.x.abs() < HALF_COURT && transform.translation.z.abs() < HALF_COURT);
        let to_centre = (-transform.translation).with_y(0.0).normalize();
        assert!(transform.forward().dot(to_centre) > 0.95);
        // Propagation under an App puts the camera where its Transform says.
        let mut app = engine::app::App::new();
        let info = spawn_courtyard(&mut app.world);
        app.update();
        let global = app.world.get::<GlobalTransform>(info.camera).unwrap();
        assert!((global.translation() - transform.translation).length() < 1e-5);
    }

    #[test]
    fn materials_are_textured_and_varied() {
        let (mut world, _) = spawn();
        let mut query = world.query::<&MeshInstance>();
        let materials = world.resource::<Assets<Material>>();
        let used: Vec<&Material> = query.iter(&world).map(|i| materials.get(i.material).unwrap()).collect();
        let textured = used.iter().filter(|m| m.base_color_texture.is_some() && m.normal_texture.is_some()).count();
        assert!(textured * 2 > used.len(), "most instances are textured");
        assert!(used.iter().any(|m| m.metallic == 1.0 && m.roughness < 0.2));
        assert!(used.iter().any(|m| m.metallic == 0.0 && m.roughness > 0.8));
        let images = world.resource::<Assets<Image>>();
        assert_eq!(images.len(), 8);
        assert!(images.iter().all(|(_, i)| i.width == TEXTURE_SIZE && i.mip_count() == 9));
        let srgb = images.iter().filter(|(_, i)| i.color_space == ColorSpace::Srgb).count();
        assert_eq!(srgb, 4, "albedo sRGB, normal maps linear");
    }
}
