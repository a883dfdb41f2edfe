//! The environment that lights a scene from all around: a procedural sky (the default, whose
//! sun is the scene's brightest directional light), an equirectangular HDR map loaded from a
//! Radiance `.hdr` file, a uniform radiance, or none (a flat ambient colour). `plugins` hands it
//! to the renderer, which filters a new source once (`render::environment`).

use std::path::Path;
use std::sync::Arc;

use bevy_ecs::prelude::*;
use glam::Vec3;

/// An equirectangular HDR image: linear RGB radiance, rows from the one looking up (+Y) to the
/// one looking down, the middle column along +X and longitude growing towards +Z.
#[derive(Clone, Debug)]
pub struct HdrImage {
    /// Texels across.
    pub width: u32,
    /// Texels down.
    pub height: u32,
    /// `width × height` RGB texels, row after row (shared: cloning the image copies nothing).
    pub texels: Arc<[[f32; 3]]>,
}

/// Why an HDR environment could not be loaded.
#[derive(Debug, thiserror::Error)]
pub enum EnvironmentError {
    /// The file could not be read or decoded.
    #[error("cannot load the environment map {path}: {source}")]
    Load {
        /// The file.
        path: String,
        /// What went wrong.
        #[source]
        source: image::ImageError,
    },
    /// The file decoded, but not as an equirectangular map (twice as wide as high).
    #[error("the environment map {path} is {width}×{height}: an equirectangular map is twice as wide as it is high")]
    NotEquirectangular {
        /// The file.
        path: String,
        /// Its width.
        width: u32,
        /// Its height.
        height: u32,
    },
}

impl HdrImage {
    /// Loads a Radiance `.hdr` (or any format `image` decodes; LDR ones are taken as linear) as an
    /// equirectangular environment.
    pub fn load(path: impl AsRef<Path>) -> Result<HdrImage, EnvironmentError> {
        let path = path.as_ref();
        let name = path.display().to_string();
        let load = |source| EnvironmentError::Load { path: name.clone(), source };
        let image = image::ImageReader::open(path).map_err(|e| load(image::ImageError::IoError(e)))?;
        let image = image.with_guessed_format().map_err(|e| load(image::ImageError::IoError(e)))?.decode().map_err(load)?.into_rgb32f();
        let (width, height) = image.dimensions();
        if width != 2 * height {
            return Err(EnvironmentError::NotEquirectangular { path: name, width, height });
        }
        let texels: Arc<[[f32; 3]]> = image.pixels().map(|p| p.0.map(|c| if c.is_finite() { c.max(0.0) } else { 0.0 })).collect();
        Ok(HdrImage { width, height, texels })
    }
}

/// Where the environment's radiance comes from.
#[derive(Clone, Debug, Default)]
pub enum EnvironmentSource {
    /// No environment: the flat ambient colour lights the scene and the clear colour is drawn
    /// behind it.
    None,
    /// The procedural sky, lit by the scene's brightest directional light.
    #[default]
    Sky,
    /// An HDR map ([`HdrImage::load`]).
    Map(HdrImage),
    /// The same radiance from every direction (a white furnace).
    Uniform(Vec3),
}

/// The environment (a resource; the render plugin inserts the default, the procedural sky).
/// Changing the source filters it once on the GPU; intensity and rotation cost nothing.
#[derive(Resource, Clone, Debug)]
pub struct Environment {
    /// Where the radiance comes from.
    pub source: EnvironmentSource,
    /// Multiplier of its radiance.
    pub intensity: f32,
    /// Turn about +Y in radians (maps and uniform sources; the sky follows its sun).
    pub rotation: f32,
}

impl Default for Environment {
    fn default() -> Self {
        Self { source: EnvironmentSource::Sky, intensity: 1.0, rotation: 0.0 }
    }
}

impl Environment {
    /// The environment of a `--environment` argument: `sky`, `none`, or a path to an HDR map. A
    /// map that cannot be loaded is reported (the error is returned beside the result) and the
    /// procedural sky stands in.
    pub fn from_argument(argument: &str) -> (Environment, Option<EnvironmentError>) {
        match argument {
            "sky" => (Environment::default(), None),
            "none" => (Environment { source: EnvironmentSource::None, ..Default::default() }, None),
            path => match HdrImage::load(path) {
                Ok(map) => (Environment { source: EnvironmentSource::Map(map), ..Default::default() }, None),
                Err(e) => (Environment::default(), Some(e)),
            },
        }
    }
}
