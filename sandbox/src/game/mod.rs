//! The first-person game on top of the renderer: walk the scene, shoot bullet holes into it,
//! leave footprints, drop coloured lights. It is the reference example of gameplay code driving
//! decals: everything here uses only the public API of `engine` and `plugins`.
//!
//! | module | what it does |
//! | --- | --- |
//! | [`player`] | the first-person controller: mouse look, WASD, floor following, wall sliding |
//! | [`footprints`] | alternating left/right footprint decals that fade out |
//! | [`shooting`] | left click: a bullet-hole decal where the crosshair ray hits |
//! | [`lights`] | key L: a point light of a random vivid colour where the player looks |
//! | [`decal_cap`] | caps on live game decals and lights, recycling the oldest first |
//! | [`script`] | scripted input (`walk forward 2`, `shoot 0.5 0.5`, ...) for headless play |
//! | [`play`] | the headless scripted run: screenshot and per-frame statistics |
//!
//! Setting up a game (after the render plugin, with a scene spawned):
//!
//! ```no_run
//! use engine::prelude::*;
//! use plugins::{RenderPlugin, RenderSettings};
//! use sandbox::game::{GamePlugin, setup_game};
//!
//! let mut app = App::new();
//! app.add_plugins(RenderPlugin::new(RenderSettings::default()));
//! app.add_plugins(GamePlugin);
//! let courtyard = sandbox::scene::spawn_courtyard(&mut app.world);
//! setup_game(&mut app.world, courtyard.camera)?; // the courtyard's camera becomes the player
//! loop {
//!     // The window layer feeds `Input` here (see `engine::input`), then:
//!     app.update();
//! }
//! # Ok::<(), anyhow::Error>(())
//! ```
//!
//! Every frame, in `Update` and in this order ([`GameSystems`]): the player moves, footprints are
//! laid along the path walked, a click shoots, L drops a light, and the caps recycle the oldest
//! decals and lights. In `PostUpdate`, after transform propagation, the raycaster's BVH is
//! rebuilt if the scene's geometry changed. Randomness (bullet-hole rotation, light colours)
//! comes from a seeded [`GameRng`], so scripted runs are reproducible.

pub mod decal_cap;
pub mod footprints;
pub mod lights;
mod markers;
pub mod play;
pub mod player;
pub mod script;
pub mod shooting;

use anyhow::{Result, anyhow, bail};
use bevy_ecs::prelude::*;
use bevy_ecs::system::RunSystemOnce;
use engine::app::{App, Plugin, PreUpdate, Update};
use engine::asset::{Assets, Handle};
use engine::camera::Camera;
use engine::image::Image;
use engine::input::InputPlugin;
use engine::transform::{GlobalTransform, Transform, propagate_transforms};
use glam::{Mat3, Quat, Vec3};
use plugins::decal::{ALL_RECEIVERS, DecalMaterial};
use serde::Serialize;

use crate::scatter::SplitMix64;

pub use decal_cap::{DecalCap, GameDecal, GameLight, LightCap, SpawnOrder};
pub use footprints::{Foot, Footprint, FootprintTrail};
pub use player::{Player, PlayerController, PlayerMotion};
pub use plugins::raycast::{Hit, RaycastIgnore, SceneRaycaster};
pub use script::{Script, ScriptError, ScriptPlayer};
pub use shooting::{BulletHole, Crosshair};

/// The decal receiver layer of the player's own meshes (`DecalReceiver(PLAYER_LAYER)`). Game
/// decals receive on every layer but this one, so they never land on the player.
pub const PLAYER_LAYER: u32 = 1 << 31;

/// The receiver layers of every decal the game spawns: all but [`PLAYER_LAYER`].
pub const GAME_DECAL_RECEIVERS: u32 = ALL_RECEIVERS & !PLAYER_LAYER;

/// Tunables of the game. Insert your own before adding [`GamePlugin`] to change them; most are
/// read every frame, so they may also be changed while playing (`seed` only at plugin build).
#[derive(Resource, Clone, Debug, PartialEq)]
pub struct GameSettings {
    /// Seed of [`GameRng`].
    pub seed: u64,
    /// Distance walked between two footprints, in metres.
    pub stride: f32,
    /// Sideways distance of each footprint from the walking line, in metres.
    pub foot_offset: f32,
    /// Width and length of a footprint decal's box, in metres.
    pub footprint_size: f32,
    /// Seconds a footprint lives, its fade included.
    pub footprint_lifetime: f32,
    /// Seconds over which a footprint fades out at the end of its life.
    pub footprint_fade: f32,
    /// Width and height of a bullet hole's box, in metres.
    pub bullet_hole_size: f32,
    /// Depth of decal boxes (bullet holes and footprints), in metres, centred on the surface.
    pub decal_depth: f32,
    /// Longest shot, in metres.
    pub max_shot_distance: f32,
    /// Sparks a shot throws where it hits (0: none; none either with effects off,
    /// [`crate::effects::Effects`]).
    pub sparks: u32,
    /// Intensity of dropped lights, in candela.
    pub light_intensity: f32,
    /// How far in front of the surface a dropped light floats, in metres.
    pub light_offset: f32,
    /// Where a light goes when the player looks at nothing: this far ahead, in metres.
    pub light_fallback_distance: f32,
}

impl Default for GameSettings {
    fn default() -> Self {
        Self {
            seed: 0x5EED,
            stride: 0.7,
            foot_offset: 0.12,
            footprint_size: 0.32,
            footprint_lifetime: 8.0,
            footprint_fade: 2.0,
            bullet_hole_size: 0.25,
            decal_depth: 0.2,
            max_shot_distance: 200.0,
            sparks: 40,
            light_intensity: 15.0,
            light_offset: 1.0,
            light_fallback_distance: 3.0,
        }
    }
}

/// The game's random numbers, seeded from [`GameSettings::seed`].
#[derive(Resource, Clone, Debug)]
pub struct GameRng(pub SplitMix64);

/// The decal materials the game spawns with, created once by [`GameAssets::init`].
#[derive(Resource, Clone, Copy, Debug, PartialEq, Eq)]
pub struct GameAssets {
    /// The built-in bullet hole ([`crate::decal_textures::bullet_hole`]).
    pub bullet_hole: Handle<DecalMaterial>,
    /// The built-in muddy right-shoe print ([`crate::decal_textures::footprint`]).
    pub footprint: Handle<DecalMaterial>,
}

impl GameAssets {
    /// Generates the built-in bullet-hole and footprint textures into `Assets<Image>` and their
    /// materials into `Assets<DecalMaterial>` (creating either store if missing), inserts the
    /// result as a resource and returns it; if the world already has `GameAssets`, returns
    /// those instead.
    pub fn init(world: &mut World) -> GameAssets {
        if let Some(assets) = world.get_resource::<GameAssets>() {
            return *assets;
        }
        world.init_resource::<Assets<Image>>();
        world.init_resource::<Assets<DecalMaterial>>();
        let mut add = |set| {
            let material = crate::decal_textures::decal_material(&set, world);
            world.resource_mut::<Assets<DecalMaterial>>().add(material)
        };
        let assets =
            GameAssets { bullet_hole: add(crate::decal_textures::bullet_hole()), footprint: add(crate::decal_textures::footprint()) };
        world.insert_resource(assets);
        assets
    }
}

/// Counters of what the game did, for statistics and tests.
#[derive(Resource, Clone, Copy, Debug, Default, PartialEq, Eq, Serialize)]
pub struct GameStats {
    /// Left clicks while there was a player.
    pub shots: u64,
    /// Shots that hit the scene (each spawned a bullet hole).
    pub hits: u64,
    /// Footprints spawned.
    pub footprints: u64,
    /// Lights dropped.
    pub lights: u64,
    /// Game decals despawned by [`DecalCap`].
    pub decals_recycled: u64,
    /// Game lights despawned by [`LightCap`].
    pub lights_recycled: u64,
}

/// The game's system sets in `Update`, run in this order.
#[derive(SystemSet, Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub enum GameSystems {
    /// [`player::move_player`].
    Move,
    /// [`footprints::lay_footprints`], [`shooting::shoot`], [`lights::drop_light`].
    Act,
    /// [`decal_cap::enforce_decal_cap`], [`decal_cap::enforce_light_cap`]. `Act` runs before
    /// and `Recycle` after `plugins::decal::expire_decals`.
    Recycle,
}

/// Adds the game: its resources ([`engine::input::Input`] through [`InputPlugin`],
/// [`GameSettings`], [`GameRng`], [`DecalCap`], [`LightCap`], [`Crosshair`], [`GameStats`],
/// an empty [`SceneRaycaster`]), the gameplay systems in `Update` ([`GameSystems`]), the script
/// player in `PreUpdate` (active while a [`ScriptPlayer`] resource exists) and the raycaster's
/// rebuild in `PostUpdate`. Resources the app already has are kept, so insert custom settings
/// first. Then call [`setup_game`] to make a camera the player.
#[derive(Clone, Copy, Debug, Default)]
pub struct GamePlugin;

impl Plugin for GamePlugin {
    fn build(&self, app: &mut App) {
        app.add_plugins(InputPlugin);
        let world = &mut app.world;
        let seed = world.get_resource_or_init::<GameSettings>().seed;
        if !world.contains_resource::<GameRng>() {
            world.insert_resource(GameRng(SplitMix64::new(seed)));
        }
        world.init_resource::<DecalCap>();
        world.init_resource::<LightCap>();
        world.init_resource::<SpawnOrder<GameDecal>>();
        world.init_resource::<SpawnOrder<GameLight>>();
        world.init_resource::<Crosshair>();
        world.init_resource::<GameStats>();
        app.add_plugins(plugins::raycast::RaycastPlugin);

        app.schedule_mut(Update)
            .configure_sets((GameSystems::Move, GameSystems::Act, GameSystems::Recycle).chain())
            // A decal's lifetime starts counting down in the frame it was spawned, and the caps
            // see the decals whose lifetime ended this frame as gone.
            .configure_sets(GameSystems::Act.before(plugins::decal::expire_decals))
            .configure_sets(GameSystems::Recycle.after(plugins::decal::expire_decals));
        app.add_systems(PreUpdate, script::play_script.run_if(resource_exists::<ScriptPlayer>));
        app.add_systems(Update, player::move_player.in_set(GameSystems::Move));
        app.add_systems(Update, (footprints::lay_footprints, shooting::shoot, lights::drop_light).chain().in_set(GameSystems::Act));
        app.add_systems(Update, (decal_cap::enforce_decal_cap, decal_cap::enforce_light_cap).chain().in_set(GameSystems::Recycle));
        if !app.world.contains_resource::<crate::effects::Effects>() {
            // Headless apps add it with the effects' expiry; a game app alone adds both here.
            app.world.insert_resource(crate::effects::Effects::default());
            app.add_systems(Update, crate::effects::expire_effects);
        }
    }
}

/// Turns the camera entity `camera` into the player: detaches it from its parent (keeping its
/// world position and view direction), adds [`Player`], a [`PlayerController`] looking where
/// the camera looked, [`PlayerMotion`] and a [`FootprintTrail`], creates the [`GameAssets`],
/// builds the [`SceneRaycaster`] and stands the player on the floor below the camera (if any).
///
/// Call it after adding [`GamePlugin`] (and the render plugin) and spawning the scene. Fails,
/// changing nothing, when `camera` does not exist, has no [`Camera`], or `GamePlugin` is
/// missing.
pub fn setup_game(world: &mut World, camera: Entity) -> Result<()> {
    if !world.contains_resource::<GameSettings>() {
        bail!("add GamePlugin to the app before calling setup_game");
    }
    let Ok(entity) = world.get_entity(camera) else {
        bail!("the camera entity {camera} does not exist");
    };
    if !entity.contains::<Camera>() {
        bail!("entity {camera} has no Camera component");
    }
    world.run_system_once(propagate_transforms).map_err(|error| anyhow!("propagating transforms: {error}"))?;
    let global = world.get::<GlobalTransform>(camera).copied().unwrap_or_default();
    let controller = PlayerController::looking_along(global.forward());
    let transform = Transform::from_translation(global.translation()).with_rotation(controller.rotation());
    // A root from now on: its Transform is in world space, which the controller relies on.
    world.entity_mut(camera).remove::<ChildOf>().insert((
        Player,
        RaycastIgnore, // the player never shoots or stands on itself
        controller,
        PlayerMotion::default(),
        FootprintTrail::default(),
        transform,
        GlobalTransform::from(transform),
    ));
    GameAssets::init(world);
    // Built after `RaycastIgnore` is inserted, so that meshes under the camera are left out.
    let raycaster = SceneRaycaster::build(world);
    world.insert_resource(raycaster);
    let feet = global.translation() - Vec3::Y * controller.eye_height;
    teleport(world, camera, feet, global.forward())?;
    Ok(())
}

/// Spawns a player camera standing at `feet` (on the floor below it, if there is one), looking
/// along `forward`, and sets the game up around it with [`setup_game`]. Returns the entity.
pub fn spawn_player(world: &mut World, feet: Vec3, forward: Vec3) -> Result<Entity> {
    if !feet.is_finite() {
        bail!("the player position {feet} is not finite");
    }
    let controller = PlayerController::looking_along(forward);
    let eye = feet + Vec3::Y * controller.eye_height;
    let camera = world
        .spawn((
            Camera::default(),
            Transform::from_translation(eye).with_rotation(controller.rotation()),
            engine::scene::Name::new("Player"),
        ))
        .id();
    if let Err(error) = setup_game(world, camera) {
        world.despawn(camera);
        return Err(error);
    }
    Ok(camera)
}

/// Moves the player entity `player` to stand at `feet` (on the floor below, if any) looking
/// along `forward` (its pitch included), as on a respawn: the controller keeps its other
/// settings, this frame's motion and the footprint trail start afresh. Uses the current
/// [`SceneRaycaster`] to find the floor. Fails when `player` has no [`PlayerController`] or
/// `feet` is not finite.
pub fn teleport(world: &mut World, player: Entity, feet: Vec3, forward: Vec3) -> Result<()> {
    if !feet.is_finite() {
        bail!("the player position {feet} is not finite");
    }
    let Some(mut controller) = world.get::<PlayerController>(player).copied() else {
        bail!("entity {player} is not a player (no PlayerController)");
    };
    let looking = PlayerController::looking_along(forward);
    (controller.yaw, controller.pitch) = (looking.yaw, looking.pitch);
    let eye = feet + Vec3::Y * controller.eye_height;
    let step = controller.walk(&world.get_resource_or_init::<SceneRaycaster>(), eye, Vec3::ZERO);
    world.entity_mut(player).insert((
        controller,
        Transform::from_translation(step.eye).with_rotation(controller.rotation()),
        PlayerMotion::standing(step.feet, step.floor),
        FootprintTrail::default(),
    ));
    Ok(())
}

/// The first active camera in the world, for scenes that do not say which one to play with.
pub fn find_camera(world: &mut World) -> Option<Entity> {
    world.query::<(Entity, &Camera)>().iter(world).find(|(_, camera)| camera.active).map(|(entity, _)| entity)
}

/// A rotation whose local +Z is `normal` and whose local +Y is as close to `up_hint` as the
/// normal allows (any perpendicular direction when they are parallel): the orientation of a
/// decal lying on a surface, projecting along −Z into it. `normal` must be non-zero.
pub fn surface_rotation(normal: Vec3, up_hint: Vec3) -> Quat {
    let z = normal.normalize_or(Vec3::Z);
    let y = (up_hint - z * z.dot(up_hint)).try_normalize().unwrap_or_else(|| z.any_orthonormal_vector());
    let x = y.cross(z);
    Quat::from_mat3(&Mat3::from_cols(x, y, z)).normalize()
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn surface_rotation_puts_z_on_the_normal_and_y_towards_the_hint() {
        for (normal, hint) in [
            (Vec3::Y, Vec3::NEG_Z),
            (Vec3::new(0.3, 0.2, -0.9), Vec3::Y),
            (Vec3::X, Vec3::X), // parallel: any perpendicular Y
        ] {
            let rotation = surface_rotation(normal, hint);
            let n = normal.normalize();
            assert!((rotation * Vec3::Z - n).length() < 1e-5);
            let y = rotation * Vec3::Y;
            assert!(y.dot(n).abs() < 1e-5);
            let projected = (hint - n * n.dot(hint)).normalize_or_zero();
            if projected != Vec3::ZERO {
                assert!((y - projected).length() < 1e-5, "{y} vs {projected}");
            }
            // Right-handed: no mirroring.
            assert!(((rotation * Vec3::X).cross(y) - n).length() < 1e-5);
        }
    }

    #[test]
    fn setup_game_rejects_bad_entities() {
        let mut app = App::new();
        let not_a_camera = app.world.spawn(Transform::IDENTITY).id();
        assert!(setup_game(&mut app.world, not_a_camera).is_err(), "needs GamePlugin");
        app.add_plugins(GamePlugin);
        let error = setup_game(&mut app.world, not_a_camera).unwrap_err();
        assert!(error.to_string().contains("no Camera"), "{error}");
        app.world.despawn(not_a_camera);
        let error = setup_game(&mut app.world, not_a_camera).unwrap_err();
        assert!(error.to_string().contains("does not exist"), "{error}");
        assert!(spawn_player(&mut app.world, Vec3::NAN, Vec3::NEG_Z).is_err());
    }
}
