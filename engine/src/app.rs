//! The application shell: a [`World`], five named schedules run in a fixed order each frame,
//! and [`Plugin`]s that register systems and resources.
//!
//! The shell is deliberately smaller than `bevy_app`: there is no runner, no sub-apps and no
//! extraction world. The game loop (windowed or headless) lives in the sandbox and calls
//! [`App::update`] once per frame. Schedules live in the world's [`Schedules`] resource, so
//! systems may also run them with `World::run_schedule`.
//!
//! This module names no feature plugin, so dependencies point one way: feature modules (such as
//! `transform`) depend on it, never the reverse. [`App::empty`] is the bare shell; [`App::new`]
//! (defined in the `defaults` module) adds the engine's `DefaultPlugins` to it.

use bevy_ecs::prelude::*;
use bevy_ecs::schedule::{ScheduleLabel, Schedules};
use bevy_ecs::system::ScheduleSystem;
use tracing::debug;

use crate::asset::Assets;
use crate::image::Image;
use crate::material::Material;
use crate::mesh::Mesh;
use crate::time::Time;

/// Runs once, before the first frame's [`PreUpdate`].
#[derive(ScheduleLabel, Clone, Debug, PartialEq, Eq, Hash)]
pub struct Startup;

/// Runs every frame after [`Time`] advanced and before [`Update`] (input, event pumping).
#[derive(ScheduleLabel, Clone, Debug, PartialEq, Eq, Hash)]
pub struct PreUpdate;

/// Runs every frame: gameplay systems spawn, move and despawn entities here.
#[derive(ScheduleLabel, Clone, Debug, PartialEq, Eq, Hash)]
pub struct Update;

/// Runs every frame after [`Update`]: transform propagation, visibility, lifetimes.
#[derive(ScheduleLabel, Clone, Debug, PartialEq, Eq, Hash)]
pub struct PostUpdate;

/// Runs every frame last: extraction, preparation and recording of the frame.
#[derive(ScheduleLabel, Clone, Debug, PartialEq, Eq, Hash)]
pub struct Render;

/// A unit of app configuration: registers systems, resources and other plugins.
pub trait Plugin {
    /// Configures `app`.
    fn build(&self, app: &mut App);
}

/// The application: a [`World`] plus the frame schedules stored in it.
pub struct App {
    /// The ECS world holding every entity, component, resource and schedule.
    pub world: World,
    started: bool,
}

impl App {
    /// Creates a bare app: [`Time`], the asset stores `Assets<Mesh>`, `Assets<Material>` and
    /// `Assets<Image>`, and empty frame schedules, without any plugin. Games usually want
    /// [`App::new`], which adds the engine's default plugins (transform propagation) to this.
    pub fn empty() -> Self {
        let mut world = World::new();
        world.init_resource::<Schedules>();
        world.insert_resource(Time::default());
        world.insert_resource(Assets::<Mesh>::default());
        world.insert_resource(Assets::<Material>::default());
        world.insert_resource(Assets::<Image>::default());
        let mut app = App { world, started: false };
        app.schedule_mut(Startup);
        app.schedule_mut(PreUpdate);
        app.schedule_mut(Update);
        app.schedule_mut(PostUpdate);
        app.schedule_mut(Render);
        app
    }

    /// Builds `plugin` into this app.
    pub fn add_plugins(&mut self, plugin: impl Plugin) -> &mut Self {
        plugin.build(self);
        self
    }

    /// Adds `systems` to the schedule `label` (created if missing).
    pub fn add_systems<M>(&mut self, label: impl ScheduleLabel, systems: impl IntoScheduleConfigs<ScheduleSystem, M>) -> &mut Self {
        self.schedule_mut(label).add_systems(systems);
        self
    }

    /// Inserts (or replaces) a resource.
    pub fn insert_resource<R: Resource>(&mut self, resource: R) -> &mut Self {
        self.world.insert_resource(resource);
        self
    }

    /// The schedule `label`, created empty if it does not exist yet.
    pub fn schedule_mut(&mut self, label: impl ScheduleLabel) -> &mut Schedule {
        self.world.get_resource_or_init::<Schedules>().into_inner().entry(label)
    }

    /// Runs one frame: [`Startup`] on the first call only, then advances [`Time`] and runs
    /// [`PreUpdate`], [`Update`], [`PostUpdate`] and [`Render`], and finally clears the change
    /// trackers so that the next frame's `Changed`/`Added` filters see only its own changes.
    pub fn update(&mut self) {
        if !self.started {
            self.started = true;
            debug!("running Startup schedule");
            self.run(Startup);
        }
        self.world.resource_mut::<Time>().advance();
        self.run(PreUpdate);
        self.run(Update);
        self.run(PostUpdate);
        self.run(Render);
        self.world.clear_trackers();
    }

    fn run(&mut self, label: impl ScheduleLabel) {
        // A schedule removed by a user is simply skipped.
        let _ = self.world.try_run_schedule(label);
    }
}
