//! The engine's default configuration: [`DefaultPlugins`], and [`App::new`] (the bare
//! [`App::empty`] plus [`DefaultPlugins`]).
//!
//! This module sits above both [`crate::app`] and the feature modules whose plugins it adds, so
//! that the application shell never names a feature and module dependencies point one way.

use crate::animation::AnimationPlugin;
use crate::app::{App, Plugin};
use crate::transform::TransformPlugin;

/// The plugins every app gets from [`App::new`]: the [`TransformPlugin`] and the
/// [`AnimationPlugin`].
pub struct DefaultPlugins;

impl Plugin for DefaultPlugins {
    fn build(&self, app: &mut App) {
        app.add_plugins(TransformPlugin);
        app.add_plugins(AnimationPlugin);
    }
}

impl App {
    /// Creates an app with [`Time`](crate::time::Time), the asset stores `Assets<Mesh>`,
    /// `Assets<Material>` and `Assets<Image>`, empty frame schedules and the [`DefaultPlugins`]
    /// (transform propagation and animation). [`App::empty`] is the same without plugins.
    pub fn new() -> Self {
        let mut app = App::empty();
        app.add_plugins(DefaultPlugins);
        app
    }
}

impl Default for App {
    fn default() -> Self {
        Self::new()
    }
}
