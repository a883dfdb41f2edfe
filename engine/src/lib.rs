//! The engine layer of the rendering plugin: a small application shell over `bevy_ecs`
//! (schedules, plugins, time), window-independent keyboard and mouse state, transforms and their
//! hierarchy, cameras, lights, generational asset storage, CPU-side meshes, materials and
//! images, and glTF loading.
//!
//! Nothing in this crate knows about Vulkan: the `plugins` crate extracts the data defined here
//! (meshes, materials, images, transforms, lights) into the `render` crate's plain records.
//!
//! Quick start (ECS only; add `plugins::RenderPlugin` and `plugins::GpuPlugin` to draw):
//!
//! ```
//! use engine::prelude::*;
//!
//! #[derive(Component)]
//! struct Bob(f32);
//!
//! fn bob(time: Res<Time>, mut q: Query<(&Bob, &mut Transform)>) {
//!     for (bob, mut t) in &mut q {
//!         t.translation.y = bob.0 * time.elapsed_secs().sin();
//!     }
//! }
//!
//! let mut app = App::new();
//! let cube = app.world.resource_mut::<Assets<Mesh>>().add(shapes::cuboid(Vec3::ONE, 1.0));
//! let red = app.world.resource_mut::<Assets<Material>>().add(Material::from_color(Vec4::new(1.0, 0.0, 0.0, 1.0), 0.0, 0.5));
//! app.world.spawn((MeshInstance { mesh: cube, material: red }, Transform::default(), Bob(0.5)));
//! app.add_systems(Update, bob);
//! app.update(); // Startup, then PreUpdate, Update, PostUpdate (transform propagation), Render
//! assert_eq!(app.world.query::<&GlobalTransform>().iter(&app.world).count(), 1);
//! ```

#![warn(missing_docs)]
// Denied everywhere but in three audited modules (their docs say why): `transform::parallel`,
// `animation::compact::bones` (both fetch entities from parallel tasks), and `gltf::ext_meshopt`,
// which calls meshoptimizer's decoders the `meshopt` crate does not wrap.
#![deny(unsafe_code)]

pub mod animation;
pub mod app;
pub mod asset;
pub mod camera;
pub mod changes;
pub mod defaults;
pub mod environment;
pub mod gltf;
pub mod image;
pub mod input;
pub mod light;
pub mod material;
pub mod mesh;
pub mod prelude;
pub mod scene;
pub mod time;
pub mod transform;
