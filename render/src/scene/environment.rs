//! The scene's environment, as the game describes it: what lights the scene from all around
//! (the procedural sky, an HDR map, or a uniform radiance), how bright and how turned. Scene
//! data, which the mirror holds; `crate::environment` filters it into the cubes shading reads.

use std::sync::Arc;

use glam::Vec3;

/// An HDR environment image: linear RGB radiance. Shared, not copied: two maps are the same
/// source when they share their texels.
#[derive(Clone, Debug)]
pub struct EnvironmentMap {
    /// Texels across (longitude; a cube face's side).
    pub width: u32,
    /// Texels down (latitude; six faces' sides).
    pub height: u32,
    /// `width × height` RGB texels, row after row.
    pub texels: Arc<[[f32; 3]]>,
    /// How the texels cover the sphere of directions.
    pub projection: MapProjection,
}

/// How an environment map's texels cover the sphere of directions.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub enum MapProjection {
    /// Equirectangular: rows from the one looking up (+Y) to the one looking down, the middle
    /// column along +X and longitude growing towards +Z.
    #[default]
    Equirectangular,
    /// Six square faces stacked from top to bottom (+X, −X, +Y, −Y, +Z, −Z), each oriented as
    /// Vulkan samples cube maps, rows downwards (as KTX2 stores a cube map).
    CubeFaces,
}

impl EnvironmentMap {
    /// Whether its size, texels and projection agree.
    pub fn is_valid(&self) -> bool {
        let shape = match self.projection {
            MapProjection::Equirectangular => self.width > 0 && self.height > 0,
            MapProjection::CubeFaces => self.width > 0 && self.height == 6 * self.width,
        };
        shape && self.texels.len() == self.width as usize * self.height as usize
    }
}

impl PartialEq for EnvironmentMap {
    /// The same texels (not an equal copy: comparing millions of texels a frame would cost more
    /// than filtering them).
    fn eq(&self, other: &Self) -> bool {
        self.width == other.width
            && self.height == other.height
            && self.projection == other.projection
            && Arc::ptr_eq(&self.texels, &other.texels)
    }
}

/// What lights the scene from all around.
#[derive(Clone, Debug, PartialEq)]
pub enum EnvironmentSource {
    /// The procedural sky, lit by the scene's brightest directional light (a default sun when
    /// there is none).
    Sky,
    /// An HDR map.
    Map(EnvironmentMap),
    /// The same radiance from every direction (a white furnace).
    Uniform(Vec3),
}

/// The environment: its source, intensity and rotation. Without one
/// ([`super::SceneMirror::set_environment`] with `None`), the flat ambient colour lights the scene and
/// the clear colour is drawn behind it.
#[derive(Clone, Debug, PartialEq)]
pub struct Environment {
    /// Where the radiance comes from.
    pub source: EnvironmentSource,
    /// Multiplier of its radiance (applied in shading: changing it refilters nothing).
    pub intensity: f32,
    /// Turn about +Y, in radians (applied in shading; the procedural sky ignores it, since its
    /// sun is the scene's light).
    pub rotation: f32,
}

impl Default for Environment {
    fn default() -> Self {
        Self { source: EnvironmentSource::Sky, intensity: 1.0, rotation: 0.0 }
    }
}
