//! The application shell: a [`World`], five named schedules run in a fixed order each frame,
//! and [`Plugin`]s that register systems and resources.
//!
//! The shell is deliberately smaller than `bevy_app`: there are no sub-apps and no extraction
//! world. [`App::run`] hands the app to its runner, which calls [`App::update`] once per frame:
//! a plugin may set one ([`App::set_runner`]; the window plugin in `plugins` owns the event
//! loop), and without one `run` updates until a system inserts [`AppExit`]. Tests and tools may
//! also call `update` themselves. Schedules live in the world's [`Schedules`] resource, so
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

/// Insert this resource (from any system) to end [`App::run`] after the current frame;
/// [`AppExit::Error`] makes `run` return the error.
#[derive(Resource, Clone, Debug, Default, PartialEq, Eq)]
pub enum AppExit {
    /// The app is done.
    #[default]
    Success,
    /// The app cannot go on (no GPU, a rendering error): why.
    Error(String),
}

/// An error a runner reports.
pub type BoxError = Box<dyn std::error::Error + Send + Sync>;

/// What a runner returns: `Err` when the app could not run to its end (no display, no GPU, a
/// rendering error).
pub type RunResult = Result<(), BoxError>;

/// A runner: owns the app and drives its frames until it exits.
pub type Runner = Box<dyn FnOnce(App) -> RunResult>;

/// A unit of app configuration: registers systems, resources and other plugins.
pub trait Plugin {
    /// Configures `app`.
    fn build(&self, app: &mut App);
}

macro_rules! plugin_tuples {
    ($($name:ident),+) => {
        /// Several plugins at once, built in order: `app.add_plugins((A, B, C))`.
        impl<$($name: Plugin),+> Plugin for ($($name,)+) {
            #[allow(non_snake_case)]
            fn build(&self, app: &mut App) {
                let ($($name,)+) = self;
                $($name.build(app);)+
            }
        }
    };
}
plugin_tuples!(A, B);
plugin_tuples!(A, B, C);
plugin_tuples!(A, B, C, D);
plugin_tuples!(A, B, C, D, E);
plugin_tuples!(A, B, C, D, E, F);
plugin_tuples!(A, B, C, D, E, F, G);
plugin_tuples!(A, B, C, D, E, F, G, H);

/// The application: a [`World`] plus the frame schedules stored in it.
pub struct App {
    /// The ECS world holding every entity, component, resource and schedule.
    pub world: World,
    started: bool,
    runner: Option<Runner>,
}

impl App {
    /// Creates a bare app: [`Time`], the asset stores `Assets<Mesh>`, `Assets<Material>` and
    /// `Assets<Image>`, the change lists of mesh instances and lights
    /// ([`crate::changes::Inserted`]), and empty frame schedules, without any plugin. Games usually want
    /// [`App::new`], which adds the engine's default plugins (transform propagation) to this.
    pub fn empty() -> Self {
        // Parallel queries (animation, skin poses) run on the compute pool; a schedule run by the
        // single-threaded executor would otherwise find it missing.
        bevy_tasks::ComputeTaskPool::get_or_init(bevy_tasks::TaskPool::default);
        let mut world = World::new();
        world.init_resource::<Schedules>();
        world.insert_resource(Time::default());
        world.insert_resource(Assets::<Mesh>::default());
        world.insert_resource(Assets::<Material>::default());
        world.insert_resource(Assets::<Image>::default());
        let mut app = App { world, started: false, runner: None };
        app.schedule_mut(Startup);
        app.schedule_mut(PreUpdate);
        app.schedule_mut(Update);
        app.schedule_mut(PostUpdate);
        app.schedule_mut(Render);
        app.add_message::<crate::changes::Inserted<crate::scene::MeshInstance>>();
        app.add_message::<crate::changes::Inserted<crate::light::PointLight>>();
        app.add_message::<crate::changes::Inserted<crate::light::SpotLight>>();
        app.add_message::<crate::changes::Inserted<crate::light::DirectionalLight>>();
        app.add_message::<crate::changes::Inserted<crate::light::RectLight>>();
        app.add_message::<crate::changes::Inserted<crate::light::DiskLight>>();
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

    /// Sets what [`App::run`] does (the last call wins).
    pub fn set_runner(&mut self, runner: impl FnOnce(App) -> RunResult + 'static) -> &mut Self {
        self.runner = Some(Box::new(runner));
        self
    }

    /// Runs the app to its end with its runner; without one, updates frame after frame until a
    /// system inserts [`AppExit`].
    pub fn run(mut self) -> RunResult {
        match self.runner.take() {
            Some(runner) => runner(self),
            None => {
                while !self.exit_requested() {
                    self.update();
                }
                self.exit_result()
            }
        }
    }

    /// Whether a system asked the app to exit ([`AppExit`]).
    pub fn exit_requested(&self) -> bool {
        self.world.contains_resource::<AppExit>()
    }

    /// What a runner returns once the app exits: the error of an [`AppExit::Error`], else `Ok`.
    pub fn exit_result(&self) -> RunResult {
        match self.world.get_resource::<AppExit>() {
            Some(AppExit::Error(e)) => Err(e.clone().into()),
            _ => Ok(()),
        }
    }

    /// Runs one frame: [`Startup`] on the first call only, then advances [`Time`] and runs
    /// [`PreUpdate`], [`Update`], [`PostUpdate`] and [`Render`], and finally clears the change
    /// trackers so that the next frame's `Changed`/`Added` filters see only its own changes.
    pub fn update(&mut self) {
        if !self.started {
            self.started = true;
            debug!("running Startup schedule");
            self.run_schedule(Startup);
        }
        self.world.resource_mut::<Time>().advance();
        self.run_schedule(PreUpdate);
        self.run_schedule(Update);
        self.run_schedule(PostUpdate);
        self.run_schedule(Render);
        self.world.clear_trackers();
    }

    fn run_schedule(&mut self, label: impl ScheduleLabel) {
        // A schedule removed by a user is simply skipped.
        let _ = self.world.try_run_schedule(label);
    }
}
