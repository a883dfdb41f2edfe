//! Hostile input at the boundary between gameplay and the renderer.
//!
//! Gameplay code (or a file, or a physics engine gone wrong) can hand us NaN transforms, negative
//! intensities, meshes whose indices point past their vertices, or a camera with no field of
//! view. None of that may reach the GPU: a NaN in a light record turns every pixel it touches
//! into NaN, an out-of-range index reads another mesh's vertices (or faults), and a NaN box in an
//! acceleration structure makes traversal undefined. Extraction runs every record through this
//! module first:
//!
//! - data that cannot be drawn meaningfully is **skipped** (the entity keeps no slot, so the
//!   rest of the scene renders as if it were absent);
//! - data that is merely out of range where a nearby value is clearly meant (a spot cone wider
//!   than a half-turn, an inner angle past the outer one, a mesh index count that is not a
//!   multiple of three) is **clamped** or trimmed;
//! - either way one warning names the entity or asset and the problem, once: [`WarnOnce`]
//!   remembers who was warned until the data becomes valid again or the entity goes away, so a
//!   NaN that persists for an hour of play logs one line, not one per frame.

use std::collections::HashSet;
use std::hash::Hash;

use engine::image::{Image, MAX_IMAGE_DIMENSION};
use engine::light::{DirectionalLight, DiskLight, PointLight, RectLight, SpotLight};
use engine::material::Material;
use engine::mesh::Mesh;
use glam::{Mat4, Vec3};
use render::scene::{DECAL_CHANNELS, GpuLight, GpuMorphDelta, GpuSkinVertex, MeshData, Vertex};

use crate::decal::Decal;

/// Remembers which keys (entities or asset handles) have been warned about, so each problem is
/// logged once per key rather than once per frame.
pub struct WarnOnce<K>(HashSet<K>);

impl<K> Default for WarnOnce<K> {
    fn default() -> Self {
        Self(HashSet::new())
    }
}

impl<K: Eq + Hash + Copy + std::fmt::Debug> WarnOnce<K> {
    /// Records the outcome of checking `key`: a problem is logged (with `what`, e.g. "light",
    /// and the consequence) unless `key` was already warned about; `None` forgets the key, so a
    /// later relapse warns again.
    pub fn report(&mut self, key: K, what: &str, problem: Option<&str>, consequence: &str) {
        match problem {
            Some(problem) if self.0.insert(key) => {
                tracing::warn!(?key, "{what} {problem}; {consequence}");
            }
            Some(_) => {}
            // Most checks pass and most keys were never warned about: no hashing then.
            None if !self.0.is_empty() => {
                self.0.remove(&key);
            }
            None => {}
        }
    }

    /// Forgets `key` (it was despawned or dropped).
    pub fn forget(&mut self, key: K) {
        if !self.0.is_empty() {
            self.0.remove(&key);
        }
    }

    /// Number of keys currently warned about.
    pub fn len(&self) -> usize {
        self.0.len()
    }

    /// True when no key is currently warned about.
    pub fn is_empty(&self) -> bool {
        self.0.is_empty()
    }
}

/// Spot cones are kept within `(0, π]`; wider makes no sense and zero divides by zero.
const MIN_SPOT_ANGLE: f32 = 1e-4;

fn finite_non_negative(v: Vec3) -> bool {
    v.is_finite() && v.min_element() >= 0.0
}

/// Checks a light's parameters and world placement and builds its GPU record. Returns the
/// record, or why the light cannot be drawn. A spot light whose angles are merely out of range
/// is clamped: the second value then says so (warned once by the caller).
pub fn light_record(
    world: Mat4,
    point: Option<&PointLight>,
    spot: Option<&SpotLight>,
    dir: Option<&DirectionalLight>,
) -> Result<(GpuLight, Option<&'static str>), &'static str> {
    if !world.is_finite() {
        return Err("has a non-finite transform");
    }
    let position = world.w_axis.truncate();
    let direction = world.transform_vector3(Vec3::NEG_Z);
    let direction_ok = direction.length_squared() > 1e-12 && direction.is_finite();
    let range_of = |range: Option<f32>, intensity: f32| match range {
        Some(r) if r.is_nan() || r <= 0.0 => Err("has a zero, negative or NaN range"),
        _ => Ok(if let Some(r) = range { r } else { engine::light::range_from_intensity(intensity) }),
    };
    let intensity_ok = |i: f32| i.is_finite() && i >= 0.0;
    if let Some(l) = spot {
        if !intensity_ok(l.intensity) || !finite_non_negative(l.color) {
            return Err("has a NaN, infinite or negative intensity or colour");
        }
        if !direction_ok {
            return Err("has no direction (zero or degenerate rotation)");
        }
        if l.inner_angle.is_nan() || l.outer_angle.is_nan() {
            return Err("has a NaN cone angle");
        }
        let range = range_of(l.range, l.intensity)?;
        let outer = l.outer_angle.clamp(MIN_SPOT_ANGLE, std::f32::consts::PI);
        let inner = l.inner_angle.clamp(0.0, outer);
        let clamped =
            (outer != l.outer_angle || inner != l.inner_angle).then_some("has cone angles out of range (0 ≤ inner ≤ outer ≤ π); clamped");
        let (radius, bad_radius) = size_or_zero(l.radius);
        let record = GpuLight::spot(position, direction, l.color * l.intensity, range, inner, outer).with_size(radius);
        // Both warnings, where both apply.
        let warning = match (clamped, bad_radius) {
            (Some(_), Some(_)) => Some("has cone angles out of range (clamped) and a negative or non-finite size (0 instead)"),
            (a, b) => a.or(b),
        };
        Ok((record, warning))
    } else if let Some(l) = point {
        if !intensity_ok(l.intensity) || !finite_non_negative(l.color) {
            return Err("has a NaN, infinite or negative intensity or colour");
        }
        let range = range_of(l.range, l.intensity)?;
        let (radius, bad_radius) = size_or_zero(l.radius);
        Ok((GpuLight::point(position, l.color * l.intensity, range).with_size(radius), bad_radius))
    } else if let Some(l) = dir {
        if !intensity_ok(l.illuminance) || !finite_non_negative(l.color) {
            return Err("has a NaN, infinite or negative illuminance or colour");
        }
        if !direction_ok {
            return Err("has no direction (zero or degenerate rotation)");
        }
        let (angle, bad_angle) = size_or_zero(l.angular_diameter);
        let half = (0.5 * angle).min(MAX_SUN_HALF_ANGLE);
        let clamped = bad_angle.or((half < 0.5 * angle).then_some("has an angular diameter above 60°; clamped"));
        Ok((GpuLight::directional(direction, l.color * l.illuminance).with_size(half.tan()), clamped))
    } else {
        Err("has no light component")
    }
}

/// Checks an area light ([`RectLight`] or [`DiskLight`]; a rectangle where an entity holds both)
/// and builds its GPU record: its size is scaled by the transform (a disk by the larger of its X
/// and Y scales) and its range measured from its centre. A zero, negative or non-finite size is
/// an error: such a light emits nothing.
pub fn area_light_record(
    world: Mat4,
    rect: Option<&RectLight>,
    disk: Option<&DiskLight>,
) -> Result<(GpuLight, Option<&'static str>), &'static str> {
    if !world.is_finite() {
        return Err("has a non-finite transform");
    }
    let (color, intensity, range) = match (rect, disk) {
        (Some(l), _) => (l.color, l.intensity, l.range),
        (None, Some(l)) => (l.color, l.intensity, l.range),
        (None, None) => return Err("has no light component"),
    };
    if !(intensity.is_finite() && intensity >= 0.0 && finite_non_negative(color)) {
        return Err("has a NaN, infinite or negative intensity or colour");
    }
    if range.is_some_and(|r| r.is_nan() || r <= 0.0) {
        return Err("has a zero, negative or NaN range");
    }
    let position = world.w_axis.truncate();
    let (x, y) = (world.x_axis.truncate(), world.y_axis.truncate());
    let normal = x.cross(y);
    if normal.length_squared() <= 1e-12 || !normal.is_finite() {
        return Err("has a zero or degenerate scale or rotation");
    }
    // Local −Z in the world, also under a mirroring scale (which turns x × y against z).
    let direction = -normal.normalize() * if normal.dot(world.z_axis.truncate()) < 0.0 { -1.0 } else { 1.0 };
    let good = |size: f32| size.is_finite() && size > 0.0;
    let record = match (rect, disk) {
        (Some(l), _) => {
            if !good(l.width) || !good(l.height) {
                return Err("has a zero, negative or non-finite width or height");
            }
            let scaled = RectLight { width: l.width * x.length(), height: l.height * y.length(), ..*l };
            let right = x.normalize() * (0.5 * scaled.width);
            GpuLight::rect(position, direction, right, 0.5 * scaled.height, color * intensity, scaled.effective_range())
        }
        (None, Some(l)) => {
            if !good(l.radius) {
                return Err("has a zero, negative or non-finite radius");
            }
            let scaled = DiskLight { radius: l.radius * x.length().max(y.length()), ..*l };
            GpuLight::disk(position, direction, x.normalize(), scaled.radius, color * intensity, scaled.effective_range())
        }
        (None, None) => unreachable!("returned above"),
    };
    let scaled_size = record.area_right().length() * record.size;
    if !scaled_size.is_finite() || (range.is_none() && !(intensity * scaled_size).is_finite()) {
        return Err("has a size or intensity too large to light by");
    }
    Ok((record, None))
}

/// The rectangle light an emitting decal makes ([`crate::decal::DecalMaterial::emits_light`]):
/// its box's face at the box's centre, lifted off the surface by 1 % of its shorter side (at
/// least a millimetre) so that the surface it sits on is behind it, looking along the box's +Z,
/// of radiance `radiance`. `None` when it emits nothing or its box is degenerate.
pub fn decal_light_record(world: Mat4, radiance: Vec3) -> Option<GpuLight> {
    if !radiance.is_finite() || radiance.max_element() <= 0.0 {
        return None;
    }
    let (x, y, z) = (world.x_axis.truncate().length(), world.y_axis.truncate().length(), world.z_axis.truncate().length());
    if z <= 0.0 || !z.is_finite() {
        return None;
    }
    let lift = (0.01 * x.min(y)).max(1e-3) / z;
    // Turned half a turn about Y: the light's -Z (where it emits) is the box's +Z.
    let light = world * Mat4::from_translation(Vec3::Z * lift) * Mat4::from_rotation_y(std::f32::consts::PI);
    // The brightest channel as the luminance, so that the range follows the light's power.
    let peak = radiance.max_element();
    let rect = RectLight { color: radiance / peak, intensity: peak, width: 1.0, height: 1.0, range: None };
    area_light_record(light, Some(&rect), None).ok().map(|(record, _)| record)
}

/// The largest half-angle of a directional light's disc (30°): past it a "sun" lights a
/// hemisphere, which its disc sampling does not model.
const MAX_SUN_HALF_ANGLE: f32 = std::f32::consts::FRAC_PI_6;

/// A light's size (a radius or an angle), or 0 and why when it is negative or not finite.
fn size_or_zero(size: f32) -> (f32, Option<&'static str>) {
    if size.is_finite() && size >= 0.0 { (size, None) } else { (0.0, Some("has a negative or non-finite size; 0 (a point) instead")) }
}

/// Why an image asset cannot become a texture, if it cannot: a zero size, a size past
/// [`engine::image::MAX_IMAGE_DIMENSION`], no levels, more levels than its size has, or a level
/// whose byte count does not match its size. (Images decoded by the engine are always valid;
/// this guards images built field by field.)
pub fn image_problem(image: &Image) -> Option<String> {
    let (w, h) = (image.width, image.height);
    if w == 0 || h == 0 || w > MAX_IMAGE_DIMENSION || h > MAX_IMAGE_DIMENSION {
        return Some(format!("has size {w}x{h}, outside 1..={MAX_IMAGE_DIMENSION}"));
    }
    let full_chain = 32 - w.max(h).leading_zeros();
    if image.mips.is_empty() || image.mips.len() as u32 > full_chain {
        return Some(format!("has {} mip levels where a {w}x{h} image has 1..={full_chain}", image.mips.len()));
    }
    for (level, data) in image.mips.iter().enumerate() {
        let (lw, lh) = image.mip_size(level as u32);
        let expected = image.format.level_bytes(lw, lh).unwrap_or(0);
        if data.len() != expected {
            return Some(format!("has {} bytes in mip level {level} where {lw}x{lh} {:?} needs {expected}", data.len(), image.format));
        }
    }
    None
}

/// A material with every factor drawable, and what was repaired: non-finite colour, alpha,
/// metallic, roughness, normal scale, occlusion strength, emission, ior or thickness become the
/// defaults (emission 0), and alpha, metallic, roughness and occlusion strength are clamped to
/// [0, 1] (a NaN alpha would make every pixel behind blended glass NaN).
pub fn material(m: &Material) -> (Material, Option<&'static str>) {
    let d = Material::default();
    let mut out = m.clone();
    let mut repaired = false;
    let mut fix = |value: &mut f32, default: f32, range: Option<(f32, f32)>| {
        let fixed = if !value.is_finite() { default } else { range.map_or(*value, |(lo, hi)| value.clamp(lo, hi)) };
        repaired |= fixed != *value;
        *value = fixed;
    };
    for (c, default) in out.base_color.as_mut().iter_mut().zip(d.base_color.to_array()) {
        fix(c, default, None);
    }
    fix(&mut out.base_color.w, d.base_color.w, Some((0.0, 1.0)));
    fix(&mut out.metallic, d.metallic, Some((0.0, 1.0)));
    fix(&mut out.roughness, d.roughness, Some((0.0, 1.0)));
    fix(&mut out.occlusion_strength, d.occlusion_strength, Some((0.0, 1.0)));
    fix(&mut out.normal_scale, d.normal_scale, None);
    for c in out.emissive.as_mut() {
        fix(c, 0.0, None);
    }
    fix(&mut out.ior, d.ior, None);
    fix(&mut out.thickness, d.thickness, None);
    (out, repaired.then_some("has non-finite or out-of-range factors"))
}

/// Why a decal's parameters cannot be drawn, if they cannot: a NaN, infinite, zero or negative
/// weight, a channel past the last one, a NaN opacity, non-finite UVs or fade angles. (Its
/// transform is checked by `render::scene::DecalDesc::is_valid`.)
pub fn decal_problem(decal: &Decal) -> Option<&'static str> {
    if !(decal.weight.is_finite() && decal.weight > 0.0) {
        Some("has a weight that is NaN, infinite, zero or negative")
    } else if u32::from(decal.channel) >= DECAL_CHANNELS {
        Some("has a blending channel out of range (0..=3)")
    } else if decal.opacity.is_nan() {
        Some("has a NaN opacity")
    } else if !decal.uv.corners().iter().all(|c| c.is_finite()) {
        Some("has non-finite texture coordinates")
    } else if decal.angle_fade.is_some_and(|f| !(f.start.is_finite() && f.end.is_finite())) {
        Some("has non-finite angle-fade angles")
    } else if decal.distance_fade.is_some_and(|f| f.start.is_nan() || f.end.is_nan() || f.start < 0.0 || f.end < f.start) {
        Some("has a distance fade that is NaN, negative or ends before it starts")
    } else {
        None
    }
}

/// Whether a mesh instance's or camera's world matrix can be drawn from: finite and invertible.
pub fn placement_problem(world: Mat4) -> Option<&'static str> {
    let det = world.determinant();
    if !world.is_finite() {
        Some("has a non-finite transform")
    } else if !det.is_finite() || det.abs() < 1e-18 {
        Some("has a singular transform (zero scale or rotation)")
    } else {
        None
    }
}

/// Converts an engine mesh into GPU vertices and indices, repairing what can be repaired:
/// non-finite normals, UVs and tangents become defaults, triangles that reference a missing or
/// non-finite vertex are dropped, a trailing partial triangle is dropped. Returns the data and a
/// description of what was repaired, or an error when no triangle is left to draw.
pub fn mesh_data(mesh: &Mesh) -> Result<(MeshData, Option<String>), String> {
    let n = mesh.positions.len();
    if u32::try_from(n).is_err() {
        return Err(format!("has {n} vertices, more than u32 indices can address"));
    }
    let mut repaired = Vec::new();
    let mut bad_attributes = 0usize;
    let vertices: Vec<Vertex> = (0..n)
        .map(|i| {
            let mut ok = true;
            let mut pick = |v: Option<&[f32; 3]>, default: [f32; 3], unit: bool| match v {
                Some(&v) if Vec3::from(v).is_finite() && (!unit || Vec3::from(v).length_squared() > 1e-12) => v,
                Some(_) => {
                    ok = false;
                    default
                }
                None => default,
            };
            let normal = pick(mesh.normals.get(i), [0.0, 1.0, 0.0], true);
            let uv = match mesh.uvs.get(i) {
                Some(uv) if uv.iter().all(|c| c.is_finite()) => *uv,
                Some(_) => {
                    ok = false;
                    [0.0, 0.0]
                }
                None => [0.0, 0.0],
            };
            let tangent = match mesh.tangents.get(i) {
                Some(t) if t.iter().all(|c| c.is_finite()) && Vec3::new(t[0], t[1], t[2]).length_squared() > 1e-12 => *t,
                Some(_) => {
                    ok = false;
                    [1.0, 0.0, 0.0, 1.0]
                }
                None => [1.0, 0.0, 0.0, 1.0],
            };
            bad_attributes += usize::from(!ok);
            Vertex { position: mesh.positions[i], normal, uv, tangent }
        })
        .collect();
    if bad_attributes > 0 {
        repaired.push(format!("{bad_attributes} vertices with non-finite or zero normals, UVs or tangents (set to defaults)"));
    }
    let whole = mesh.indices.len() / 3 * 3;
    if whole != mesh.indices.len() {
        repaired.push(format!("an index count of {} that is not a multiple of 3 (the last partial triangle dropped)", mesh.indices.len()));
    }
    let usable = |i: u32| (i as usize) < n && Vec3::from(mesh.positions[i as usize]).is_finite();
    let mut indices = Vec::with_capacity(whole);
    let mut dropped = 0usize;
    for tri in mesh.indices[..whole].chunks_exact(3) {
        if tri.iter().all(|&i| usable(i)) {
            indices.extend_from_slice(tri);
        } else {
            dropped += 1;
        }
    }
    if dropped > 0 {
        repaired.push(format!("{dropped} triangles with an index out of range (of {n} vertices) or a non-finite position (dropped)"));
    }
    if indices.is_empty() {
        let why = if mesh.indices.is_empty() || n == 0 {
            "is empty".to_owned()
        } else {
            format!("has no drawable triangle: {}", repaired.join(", "))
        };
        return Err(why);
    }
    // Joints and weights (normalised by the loader) go with the mesh when there is one per vertex.
    let skin = match &mesh.skin {
        Some(s) if s.joints.len() == n && s.weights.len() == n => {
            s.joints.iter().zip(&s.weights).map(|(&j, &w)| GpuSkinVertex::new(j, w)).collect()
        }
        Some(_) => {
            repaired.push("joints or weights not one per vertex (the skin dropped: it draws rigidly)".to_owned());
            Vec::new()
        }
        None => Vec::new(),
    };
    // Morph targets, target after target: position offsets (and normal offsets, when given).
    let complete = mesh.morph_targets.iter().all(|t| t.positions.len() == n && (t.normals.is_empty() || t.normals.len() == n));
    if !complete {
        repaired.push("morph targets without one offset per vertex (dropped)".to_owned());
    }
    let targets = if complete { mesh.morph_targets.as_slice() } else { &[] };
    let morphs = targets
        .iter()
        .flat_map(|t| {
            (0..n).map(move |i| GpuMorphDelta { position: t.positions[i], normal: t.normals.get(i).copied().unwrap_or([0.0; 3]) })
        })
        .map(|d| {
            if Vec3::from(d.position).is_finite() && Vec3::from(d.normal).is_finite() {
                d
            } else {
                GpuMorphDelta { position: [0.0; 3], normal: [0.0; 3] }
            }
        })
        .collect();
    let morph_targets = targets.len() as u32;
    let mut data = MeshData { vertices, indices, skin, morphs, morph_targets, lods: None };
    if mesh.lods.is_empty() {
        data.lods = Some(render::lod::MeshLods::for_mesh(&data));
    } else {
        // Levels made with the mesh (glTF's MSFT_lod), each checked as a mesh of its own.
        let levels: Vec<MeshData> = mesh.lods.iter().filter_map(|level| mesh_data(level).ok().map(|(level, _)| level)).collect();
        if levels.len() < mesh.lods.len() {
            repaired.push(format!(
                "{} of its {} authored levels of detail unusable (left out)",
                mesh.lods.len() - levels.len(),
                mesh.lods.len()
            ));
        }
        data = render::lod::with_authored_levels(data, levels);
    }
    Ok((data, (!repaired.is_empty()).then(|| format!("had {}", repaired.join(", ")))))
}

#[cfg(test)]
mod tests {
    use super::*;

    fn tri_mesh(positions: Vec<[f32; 3]>, indices: Vec<u32>) -> Mesh {
        let n = positions.len();
        Mesh {
            positions,
            normals: vec![[0.0, 0.0, 1.0]; n],
            uvs: vec![[0.0; 2]; n],
            tangents: vec![[1.0, 0.0, 0.0, 1.0]; n],
            indices,
            ..Default::default()
        }
    }

    #[test]
    fn meshes_keep_their_good_triangles() {
        let good = [[0.0, 0.0, 0.0], [1.0, 0.0, 0.0], [0.0, 1.0, 0.0]];
        let mut positions = good.to_vec();
        positions.push([f32::NAN, 0.0, 0.0]);
        // One good triangle, one through the NaN vertex, one out of range, one degenerate
        // (kept: it rasterises to nothing), and a partial triangle.
        let mesh = tri_mesh(positions, vec![0, 1, 2, 0, 1, 3, 0, 1, 9, 0, 0, 0, 1, 2]);
        let (data, repaired) = mesh_data(&mesh).expect("the good triangles remain");
        assert_eq!(data.indices, vec![0, 1, 2, 0, 0, 0]);
        let repaired = repaired.expect("repairs are reported");
        assert!(repaired.contains("2 triangles") && repaired.contains("multiple of 3"), "{repaired}");
        assert!(mesh_data(&tri_mesh(good.to_vec(), vec![0, 1, 2])).unwrap().1.is_none());
    }

    #[test]
    fn meshes_with_nothing_to_draw_are_errors() {
        assert_eq!(mesh_data(&Mesh::default()).unwrap_err(), "is empty");
        let err = mesh_data(&tri_mesh(vec![[0.0; 3]; 3], vec![0, 1, 7])).unwrap_err();
        assert!(err.contains("no drawable triangle"), "{err}");
    }

    #[test]
    fn lights_are_checked_and_spot_cones_clamped() {
        let at = Mat4::from_translation(Vec3::new(1.0, 2.0, 3.0));
        let point = |intensity, range| PointLight { intensity, range, ..Default::default() };
        assert!(light_record(at, Some(&point(10.0, None)), None, None).is_ok());
        assert!(light_record(at, Some(&point(10.0, Some(f32::INFINITY))), None, None).is_ok(), "an unbounded light is valid");
        for bad in [point(f32::NAN, None), point(-1.0, None), point(f32::INFINITY, None), point(1.0, Some(0.0)), point(1.0, Some(f32::NAN))]
        {
            assert!(light_record(at, Some(&bad), None, None).is_err(), "{bad:?}");
        }
        let nan_at = Mat4::from_translation(Vec3::splat(f32::NAN));
        assert!(light_record(nan_at, Some(&point(1.0, None)), None, None).is_err());
        let spot = SpotLight { inner_angle: 2.0, outer_angle: 7.0, ..Default::default() };
        let (record, clamped) = light_record(at, None, Some(&spot), None).unwrap();
        assert!(clamped.is_some() && record.cone_cos.is_finite() && record.spot_scale.is_finite());
        let flat = Mat4::from_scale(Vec3::ZERO);
        let dir = DirectionalLight::default();
        assert!(light_record(flat, None, None, Some(&dir)).is_err(), "a zero rotation has no direction");
    }

    #[test]
    fn area_lights_are_checked_and_scaled_by_their_transform() {
        let at = Mat4::from_scale_rotation_translation(Vec3::new(2.0, 3.0, 1.0), glam::Quat::IDENTITY, Vec3::new(1.0, 2.0, 3.0));
        let rect = RectLight { width: 1.0, height: 0.5, intensity: 4.0, ..Default::default() };
        let (record, warning) = area_light_record(at, Some(&rect), None).unwrap();
        assert_eq!(warning, None);
        assert_eq!(record.kind, render::scene::LightKind::Rect as u32);
        assert_eq!(record.position, Vec3::new(1.0, 2.0, 3.0));
        assert!((record.direction - Vec3::NEG_Z).length() < 1e-6, "emits along local -Z");
        assert!((record.area_right() - Vec3::X).length() < 1e-6, "half of 1 m scaled by 2");
        assert!((record.size - 0.75).abs() < 1e-6, "half of 0.5 m scaled by 3");
        let scaled = RectLight { width: 2.0, height: 1.5, ..rect };
        assert!((record.range - scaled.effective_range()).abs() < 1e-4, "the range of the scaled light");
        let disk = DiskLight { radius: 0.5, ..Default::default() };
        let (record, _) = area_light_record(at, None, Some(&disk)).unwrap();
        assert_eq!(record.kind, render::scene::LightKind::Disk as u32);
        assert!((record.size - 1.5).abs() < 1e-6, "the larger scale");
        for bad in [RectLight { width: 0.0, ..rect }, RectLight { height: f32::NAN, ..rect }, RectLight { intensity: -1.0, ..rect }] {
            assert!(area_light_record(at, Some(&bad), None).is_err(), "{bad:?}");
        }
        assert!(area_light_record(at, None, Some(&DiskLight { radius: -1.0, ..disk })).is_err());
        assert!(area_light_record(at, None, Some(&DiskLight { range: Some(0.0), ..disk })).is_err());
        assert!(area_light_record(Mat4::from_scale(Vec3::new(1.0, 0.0, 1.0)), Some(&rect), None).is_err(), "flattened to a line");
        assert!(area_light_record(at, None, None).is_err());
        let mirrored = Mat4::from_scale(Vec3::new(-1.0, 1.0, 1.0));
        let (record, _) = area_light_record(mirrored, Some(&rect), None).unwrap();
        assert!((record.direction - Vec3::NEG_Z).length() < 1e-6, "a mirroring scale keeps local -Z: {}", record.direction);
        let huge = RectLight { width: 1e30, height: 1e30, ..rect };
        assert!(area_light_record(at, Some(&huge), None).is_err(), "too large to light by");
    }

    #[test]
    fn an_emitting_decal_lights_out_of_its_surface_from_its_face() {
        // A 0.4 × 0.2 m decal on a wall facing +X (the box's +Z turned to +X), 0.1 m deep.
        let wall = Mat4::from_scale_rotation_translation(
            Vec3::new(0.4, 0.2, 0.1),
            glam::Quat::from_rotation_y(std::f32::consts::FRAC_PI_2),
            Vec3::new(2.0, 1.0, 0.0),
        );
        let record = decal_light_record(wall, Vec3::new(3.0, 2.0, 1.0)).expect("an emitting decal is a light");
        assert_eq!(record.kind, render::scene::LightKind::Rect as u32);
        assert!((record.direction - Vec3::X).length() < 1e-5, "looks out of the wall: {}", record.direction);
        assert!((record.position - Vec3::new(2.002, 1.0, 0.0)).length() < 1e-5, "lifted 1 % of 0.2 m: {}", record.position);
        assert!((record.area_right().length() - 0.2).abs() < 1e-5 && (record.size - 0.1).abs() < 1e-5, "the box's face");
        assert_eq!(record.color, Vec3::new(3.0, 2.0, 1.0));
        let face = RectLight { color: Vec3::new(1.0, 2.0 / 3.0, 1.0 / 3.0), intensity: 3.0, width: 0.4, height: 0.2, range: None };
        assert!((record.range - face.effective_range()).abs() < 1e-4, "reaches as a 3-nit panel of its face does: {}", record.range);
        assert!(decal_light_record(wall, Vec3::ZERO).is_none(), "a dark decal is no light");
        assert!(decal_light_record(Mat4::from_scale(Vec3::new(1.0, 1.0, 0.0)), Vec3::ONE).is_none(), "a flat box");
    }

    #[test]
    fn warnings_are_given_once_until_the_problem_goes_away() {
        let mut once = WarnOnce::<u32>::default();
        once.report(1, "light", Some("is bad"), "skipped");
        once.report(1, "light", Some("is bad"), "skipped");
        assert_eq!(once.len(), 1);
        once.report(1, "light", None, "");
        assert!(once.is_empty());
    }

    #[test]
    fn materials_with_non_finite_or_out_of_range_factors_are_repaired_once_and_valid_ones_kept() {
        use glam::Vec4;
        let glass = Material {
            alpha_mode: engine::material::AlphaMode::Blend,
            thickness: 0.1,
            ..Material::from_color(Vec4::new(0.9, 0.1, 0.1, 0.4), 0.0, 0.3)
        };
        let (same, problem) = material(&glass);
        assert_eq!((same, problem), (glass.clone(), None));
        let bad = Material {
            base_color: Vec4::new(f32::NAN, 0.5, f32::INFINITY, f32::NAN),
            metallic: 2.0,
            roughness: -1.0,
            emissive: Vec3::new(f32::NAN, 1.0, 0.0),
            ior: f32::NAN,
            thickness: f32::INFINITY,
            ..glass.clone()
        };
        let (fixed, problem) = material(&bad);
        assert!(problem.is_some());
        assert_eq!(fixed.base_color, Vec4::new(1.0, 0.5, 1.0, 1.0));
        assert_eq!((fixed.metallic, fixed.roughness), (1.0, 0.0));
        assert_eq!(fixed.emissive, Vec3::new(0.0, 1.0, 0.0));
        assert_eq!((fixed.ior, fixed.thickness, fixed.refraction()), (1.5, 0.0, 0.0));
        assert_eq!(material(&fixed).1, None, "a repaired material is valid");
    }
}
