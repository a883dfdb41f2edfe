//! The engine prelude: the types a game uses every day, plus `bevy_ecs::prelude::*` (and the
//! `bevy_ecs` crate itself, which the ECS derives name) and the common `glam` types, so that
//! `use engine::prelude::*;` is enough for most systems and components.
//!
//! Note that [`Name`] here is the engine's [`crate::scene::Name`], which shadows
//! `bevy_ecs::prelude::Name`.

// The crate itself, so that `#[derive(Component)]` and `#[derive(Resource)]`, which expand to
// `bevy_ecs::…` paths, compile in a game that depends only on `engine`.
pub use bevy_ecs;
pub use bevy_ecs::prelude::*;
pub use glam::{Affine3A, Mat3, Mat4, Quat, Vec2, Vec3, Vec3A, Vec4};

pub use crate::app::{App, AppExit, Plugin, PostUpdate, PreUpdate, Render, Startup, Update};
pub use crate::asset::{AssetEvent, Assets, Handle};
pub use crate::camera::Camera;
pub use crate::defaults::DefaultPlugins;
pub use crate::environment::{Environment, EnvironmentSource, HdrImage};
pub use crate::image::{ColorSpace, Image};
pub use crate::input::{Input, InputPlugin, Key, MouseButton};
pub use crate::light::{DirectionalLight, DiskLight, PointLight, RectLight, SpotLight};
pub use crate::material::{AlphaMode, Material};
pub use crate::mesh::{Mesh, shapes};
pub use crate::scene::{MeshInstance, Name};
pub use crate::time::Time;
pub use crate::transform::{GlobalTransform, Static, Transform, TransformChanges, TransformPlugin, TransformSystems};
