//! CPU-side triangle meshes with the vertex layout the renderer consumes (position, normal, UV,
//! tangent; `u32` indices), MikkTSpace tangent generation, and procedural [`shapes`].
//!
//! Tangents come from the `mikktspace` crate (the reference MikkTSpace algorithm that baked
//! normal maps such as glTF's expect), then are Gram–Schmidt orthonormalised against the vertex
//! normal. Tangent-space convention (glTF's): `tangent.xyz` follows +U, and the bitangent
//! `B = w · cross(N, T)` points towards *decreasing* V, i.e. "up" in an image whose first row
//! is V = 0, so a normal map's +Y (green) means image-up. MikkTSpace itself orients the
//! bitangent along +V, so its sign is negated (as three.js' `computeMikkTSpaceTangents` does with
//! `negateSign` for glTF). Shaders use `n = normalize(T·x + B·y + N·z)`. Where the UV mapping is degenerate (no UV gradient, zero-area triangles, unreferenced
//! vertices) the tangent falls back to an arbitrary unit vector perpendicular to the normal, so
//! tangents are always finite, unit length and orthogonal to the normal.

use glam::{Mat3, Mat4, Vec3};
use thiserror::Error;
use tracing::warn;

/// Errors from validating mesh data.
#[derive(Error, Debug, Clone, PartialEq, Eq)]
pub enum MeshError {
    /// A vertex attribute's length differs from the number of positions.
    #[error("attribute {attribute} has {found} elements but there are {expected} positions")]
    AttributeLength {
        /// The attribute (`normals`, `uvs`, `tangents`, skin joints or weights, morph targets).
        attribute: &'static str,
        /// Number of positions.
        expected: usize,
        /// Number of elements of the attribute.
        found: usize,
    },
    /// The index count is not a multiple of three.
    #[error("index count {0} is not a multiple of 3")]
    IndexCount(usize),
    /// An index refers past the last vertex.
    #[error("index #{at} = {index} is out of range for {vertices} vertices")]
    IndexOutOfRange {
        /// Position in the index list.
        at: usize,
        /// The offending index.
        index: u32,
        /// Number of vertices.
        vertices: usize,
    },
    /// More vertices than `u32` indices can address.
    #[error("{0} vertices exceed the u32 index range")]
    TooManyVertices(usize),
}

/// Per-vertex joints and weights of a skinned mesh (glTF `JOINTS_0`/`WEIGHTS_0`): up to four
/// joints per vertex, indices into the skin's joint list, weights normalised to sum to 1.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct SkinWeights {
    /// Joint indices.
    pub joints: Vec<[u16; 4]>,
    /// Their weights.
    pub weights: Vec<[f32; 4]>,
}

/// How many vertices [`SkinWeights::repaired`] repaired.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct WeightRepairs {
    /// Vertices with a weight that is not finite.
    pub non_finite: usize,
    /// Vertices whose weights (negative ones taken as zero) sum to nothing.
    pub zero: usize,
}

impl SkinWeights {
    /// Weights as given, normalised to sum to 1 (files often store sums a little off, and some
    /// well below 1); a vertex whose weights sum to nothing follows its first joint.
    pub fn normalized(joints: Vec<[u16; 4]>, weights: Vec<[f32; 4]>) -> Self {
        Self::repaired(joints, weights).0
    }

    /// [`SkinWeights::normalized`], saying how many vertices it repaired: a vertex with a weight
    /// that is not finite, or whose weights (negative ones taken as zero) sum to nothing, follows
    /// its first joint alone (weight 1), the joint its weights list first: the vertex stays on
    /// the skeleton as it moves, near its neighbours (the mesh's own node would leave it behind
    /// as the skeleton walks away).
    pub fn repaired(joints: Vec<[u16; 4]>, mut weights: Vec<[f32; 4]>) -> (Self, WeightRepairs) {
        let mut repairs = WeightRepairs::default();
        for w in &mut weights {
            if w.iter().any(|x| !x.is_finite()) {
                repairs.non_finite += 1;
                *w = [1.0, 0.0, 0.0, 0.0];
                continue;
            }
            let w4 = w.map(|x| x.max(0.0));
            let sum: f32 = w4.iter().sum();
            *w = if sum > 1e-6 {
                w4.map(|x| x / sum)
            } else {
                repairs.zero += 1;
                [1.0, 0.0, 0.0, 0.0]
            };
        }
        (Self { joints, weights }, repairs)
    }

    /// The largest joint index used (by a vertex with a non-zero weight on it).
    pub fn max_joint(&self) -> Option<u16> {
        self.joints.iter().zip(&self.weights).flat_map(|(j, w)| (0..4).filter(|&i| w[i] > 0.0).map(move |i| j[i])).max()
    }
}

/// A morph target: offsets added to the positions (and normals) in proportion to its weight.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct MorphTarget {
    /// Position offsets, one per vertex.
    pub positions: Vec<[f32; 3]>,
    /// Normal offsets, one per vertex (empty when the target leaves normals alone).
    pub normals: Vec<[f32; 3]>,
}

/// An indexed triangle list. All attribute vectors have one element per position.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct Mesh {
    /// Vertex positions.
    pub positions: Vec<[f32; 3]>,
    /// Unit vertex normals.
    pub normals: Vec<[f32; 3]>,
    /// Texture coordinates (set 0).
    pub uvs: Vec<[f32; 2]>,
    /// Unit tangents with the bitangent sign in `w` (`bitangent = w · cross(normal, tangent)`).
    pub tangents: Vec<[f32; 4]>,
    /// Triangle list indices, counter-clockwise front faces.
    pub indices: Vec<u32>,
    /// Joints and weights, for a skinned mesh.
    pub skin: Option<SkinWeights>,
    /// Morph targets (blend shapes).
    pub morph_targets: Vec<MorphTarget>,
    /// Coarser levels of detail made with the mesh, finest first (glTF's `MSFT_lod`): each a
    /// mesh of its own vertices over the same joints. Empty (the usual case): the renderer makes
    /// its own levels from this mesh.
    pub lods: Vec<Mesh>,
}

impl Mesh {
    /// Validates the attributes and indices and generates tangents.
    pub fn new(positions: Vec<[f32; 3]>, normals: Vec<[f32; 3]>, uvs: Vec<[f32; 2]>, indices: Vec<u32>) -> Result<Mesh, MeshError> {
        let tangents = vec![[0.0; 4]; positions.len()];
        let mut mesh = Mesh::from_parts(positions, normals, uvs, tangents, indices)?;
        mesh.generate_tangents();
        Ok(mesh)
    }

    /// Validates and assembles a mesh whose tangents are already known (e.g. from a glTF file).
    pub fn from_parts(
        positions: Vec<[f32; 3]>,
        normals: Vec<[f32; 3]>,
        uvs: Vec<[f32; 2]>,
        tangents: Vec<[f32; 4]>,
        indices: Vec<u32>,
    ) -> Result<Mesh, MeshError> {
        let mesh = Mesh { positions, normals, uvs, tangents, indices, skin: None, morph_targets: Vec::new(), lods: Vec::new() };
        mesh.validate()?;
        Ok(mesh)
    }

    /// Checks attribute lengths and index ranges.
    pub fn validate(&self) -> Result<(), MeshError> {
        let n = self.positions.len();
        if u32::try_from(n).is_err() {
            return Err(MeshError::TooManyVertices(n));
        }
        let skin = self.skin.as_ref();
        let lengths = [
            ("normals", Some(self.normals.len())),
            ("uvs", Some(self.uvs.len())),
            ("tangents", Some(self.tangents.len())),
            ("skin joints", skin.map(|s| s.joints.len())),
            ("skin weights", skin.map(|s| s.weights.len())),
        ];
        let targets = self.morph_targets.iter().flat_map(|t| {
            [
                ("morph target positions", Some(t.positions.len())),
                ("morph target normals", (!t.normals.is_empty()).then_some(t.normals.len())),
            ]
        });
        for (attribute, found) in lengths.into_iter().chain(targets) {
            if let Some(found) = found.filter(|&found| found != n) {
                return Err(MeshError::AttributeLength { attribute, expected: n, found });
            }
        }
        if !self.indices.len().is_multiple_of(3) {
            return Err(MeshError::IndexCount(self.indices.len()));
        }
        if let Some((at, &index)) = self.indices.iter().enumerate().find(|&(_, &i)| i as usize >= n) {
            return Err(MeshError::IndexOutOfRange { at, index, vertices: n });
        }
        Ok(())
    }

    /// Regenerates [`Mesh::tangents`] with MikkTSpace (see the module docs for the fallback).
    /// An invalid mesh gets fallback tangents only, with a warning.
    pub fn generate_tangents(&mut self) {
        self.tangents.clear();
        self.tangents.resize(self.positions.len(), [0.0; 4]);
        match self.validate() {
            Ok(()) if self.mikktspace_safe() => {
                if !mikktspace::generate_tangents(&mut MikkGeometry(self)) {
                    warn!("MikkTSpace failed; using fallback tangents");
                }
            }
            Ok(()) => {}
            Err(error) => warn!(%error, "invalid mesh; using fallback tangents"),
        }
        self.orthonormalize_tangents();
    }

    /// Makes every tangent unit length and orthogonal to its normal (Gram–Schmidt), with `w`
    /// exactly ±1; degenerate tangents become an arbitrary perpendicular unit vector.
    pub fn orthonormalize_tangents(&mut self) {
        for (i, tangent) in self.tangents.iter_mut().enumerate() {
            let normal = self.normals.get(i).and_then(|&n| Vec3::from(n).try_normalize()).unwrap_or(Vec3::Y);
            *tangent = orthonormal_tangent(normal, *tangent);
        }
    }

    /// Whether the `mikktspace` crate can process this (valid) mesh: it indexes out of bounds
    /// when the referenced positions span no volume on any axis or are not finite, and NaN
    /// normals or UVs would poison its vertex welding.
    fn mikktspace_safe(&self) -> bool {
        let Some(&first) = self.indices.first() else {
            return false;
        };
        let first = Vec3::from(self.positions[first as usize]);
        let (mut min, mut max) = (first, first);
        for &i in &self.indices {
            let i = i as usize;
            let p = Vec3::from(self.positions[i]);
            let finite = p.is_finite() && Vec3::from(self.normals[i]).is_finite() && self.uvs[i].iter().all(|v| v.is_finite());
            if !finite {
                return false;
            }
            (min, max) = (min.min(p), max.max(p));
        }
        (max - min).max_element() > 0.0
    }

    /// The axis-aligned bounds `(min, max)` of the positions (both zero for an empty mesh).
    pub fn aabb(&self) -> (Vec3, Vec3) {
        let mut points = self.positions.iter().map(|&p| Vec3::from(p));
        let Some(first) = points.next() else {
            return (Vec3::ZERO, Vec3::ZERO);
        };
        points.fold((first, first), |(min, max), p| (min.min(p), max.max(p)))
    }

    /// Number of triangles.
    pub fn triangle_count(&self) -> usize {
        self.indices.len() / 3
    }

    /// A copy transformed by `m`: positions by `m`, normals by its inverse transpose, tangents
    /// by its linear part. A mirroring `m` flips the triangle winding and the bitangent sign so
    /// that front faces and normal maps stay correct.
    pub fn transformed(&self, m: Mat4) -> Mesh {
        let linear = Mat3::from_mat4(m);
        let det = linear.determinant();
        let normal_matrix = if det.abs() > f32::MIN_POSITIVE { linear.inverse().transpose() } else { linear };
        let flip = det < 0.0;
        let normals: Vec<[f32; 3]> = self.normals.iter().map(|&n| (normal_matrix * Vec3::from(n)).normalize_or(Vec3::Y).into()).collect();
        let tangents = self
            .tangents
            .iter()
            .zip(&normals)
            .map(|(&t, &n)| {
                let xyz = linear * Vec3::new(t[0], t[1], t[2]);
                let w = if flip { -t[3] } else { t[3] };
                orthonormal_tangent(Vec3::from(n), xyz.extend(w).into())
            })
            .collect();
        let mut indices = self.indices.clone();
        if flip {
            for tri in indices.chunks_exact_mut(3) {
                tri.swap(1, 2);
            }
        }
        Mesh {
            positions: self.positions.iter().map(|&p| m.transform_point3(Vec3::from(p)).into()).collect(),
            normals,
            uvs: self.uvs.clone(),
            tangents,
            indices,
            skin: self.skin.clone(),
            morph_targets: self
                .morph_targets
                .iter()
                .map(|t| MorphTarget {
                    positions: t.positions.iter().map(|&d| (linear * Vec3::from(d)).into()).collect(),
                    normals: t.normals.iter().map(|&d| (normal_matrix * Vec3::from(d)).into()).collect(),
                })
                .collect(),
            lods: self.lods.iter().map(|level| level.transformed(m)).collect(),
        }
    }

    /// Appends `other`'s vertices and triangles to this mesh.
    pub fn merge(&mut self, other: &Mesh) {
        let offset = self.positions.len() as u32;
        self.positions.extend_from_slice(&other.positions);
        self.normals.extend_from_slice(&other.normals);
        self.uvs.extend_from_slice(&other.uvs);
        self.tangents.extend_from_slice(&other.tangents);
        self.indices.extend(other.indices.iter().map(|&i| i + offset));
    }
}

/// Area-weighted smooth vertex normals of an indexed triangle list (unit length; +Y where a
/// vertex touches no non-degenerate triangle). Out-of-range indices are ignored.
pub fn smooth_normals(positions: &[[f32; 3]], indices: &[u32]) -> Vec<[f32; 3]> {
    let mut sums = vec![Vec3::ZERO; positions.len()];
    for tri in indices.chunks_exact(3) {
        let [a, b, c] = [tri[0] as usize, tri[1] as usize, tri[2] as usize];
        if a.max(b).max(c) >= positions.len() {
            continue;
        }
        let (pa, pb, pc) = (Vec3::from(positions[a]), Vec3::from(positions[b]), Vec3::from(positions[c]));
        let area_normal = (pb - pa).cross(pc - pa);
        for i in [a, b, c] {
            sums[i] += area_normal;
        }
    }
    sums.into_iter().map(|n| n.try_normalize().unwrap_or(Vec3::Y).into()).collect()
}

/// Makes `tangent.xyz` a unit vector orthogonal to the unit `normal` (any perpendicular one if
/// it is degenerate) and `w` exactly ±1.
fn orthonormal_tangent(normal: Vec3, tangent: [f32; 4]) -> [f32; 4] {
    let t = Vec3::new(tangent[0], tangent[1], tangent[2]);
    let t = (t - normal * normal.dot(t)).try_normalize().unwrap_or_else(|| normal.any_orthonormal_vector());
    let w = if tangent[3] < 0.0 { -1.0 } else { 1.0 };
    t.extend(w).into()
}

/// Adapter from [`Mesh`] to the `mikktspace` crate (faces are the index triples).
struct MikkGeometry<'a>(&'a mut Mesh);

impl MikkGeometry<'_> {
    fn vertex(&self, face: usize, vert: usize) -> usize {
        self.0.indices[face * 3 + vert] as usize
    }
}

impl mikktspace::Geometry for MikkGeometry<'_> {
    fn num_faces(&self) -> usize {
        self.0.indices.len() / 3
    }

    fn num_vertices_of_face(&self, _face: usize) -> usize {
        3
    }

    fn position(&self, face: usize, vert: usize) -> [f32; 3] {
        self.0.positions[self.vertex(face, vert)]
    }

    fn normal(&self, face: usize, vert: usize) -> [f32; 3] {
        self.0.normals[self.vertex(face, vert)]
    }

    fn tex_coord(&self, face: usize, vert: usize) -> [f32; 2] {
        self.0.uvs[self.vertex(face, vert)]
    }

    fn set_tangent_encoded(&mut self, tangent: [f32; 4], face: usize, vert: usize) {
        let index = self.vertex(face, vert);
        // MikkTSpace's bitangent follows +V; glTF's (and ours) points to image-up, i.e. -V.
        self.0.tangents[index] = [tangent[0], tangent[1], tangent[2], -tangent[3]];
    }
}

/// Procedural meshes: y-up, outward normals, counter-clockwise front faces, UVs in metres
/// (times `uv_scale` where given) so tiling textures keep their real-world size, tangents
/// generated. Sizes are taken by absolute value; segment counts are clamped to sensible minima.
pub mod shapes {
    use std::f32::consts::{PI, TAU};

    use glam::{Vec2, Vec3};

    use super::Mesh;

    /// Accumulates vertices and triangles, orienting every triangle counter-clockwise around its
    /// vertex normals and dropping zero-area ones.
    #[derive(Default)]
    pub(super) struct Builder {
        mesh: Mesh,
    }

    impl Builder {
        pub(super) fn vertex(&mut self, p: Vec3, n: Vec3, uv: Vec2) -> u32 {
            let index = self.mesh.positions.len() as u32;
            self.mesh.positions.push(p.into());
            self.mesh.normals.push(n.normalize_or(Vec3::Y).into());
            self.mesh.uvs.push(uv.into());
            index
        }

        pub(super) fn triangle(&mut self, a: u32, b: u32, c: u32) {
            let p = |i: u32| Vec3::from(self.mesh.positions[i as usize]);
            let n = |i: u32| Vec3::from(self.mesh.normals[i as usize]);
            let geometric = (p(b) - p(a)).cross(p(c) - p(a));
            if geometric.length_squared() <= f32::EPSILON * f32::EPSILON {
                return;
            }
            if geometric.dot(n(a) + n(b) + n(c)) >= 0.0 {
                self.mesh.indices.extend([a, b, c]);
            } else {
                self.mesh.indices.extend([a, c, b]);
            }
        }

        /// Two triangles over the quad `a b c d` (given in order around its boundary).
        pub(super) fn quad(&mut self, [a, b, c, d]: [u32; 4]) {
            self.triangle(a, b, c);
            self.triangle(a, c, d);
        }

        /// A flat quad from four corners in boundary order; UVs from `uv(position)`.
        pub(super) fn flat_quad(&mut self, corners: [Vec3; 4], normal: Vec3, uv: impl Fn(Vec3) -> Vec2) {
            let v = corners.map(|p| self.vertex(p, normal, uv(p)));
            self.quad(v);
        }

        /// A `seg_u`×`seg_v` grid spanning `origin + s·u_axis + t·v_axis`, `s, t ∈ [0, 1]`, with
        /// UV `uv_scale · (s·|u_axis|, t·|v_axis|)`.
        #[allow(clippy::too_many_arguments)]
        pub(super) fn grid(&mut self, origin: Vec3, u_axis: Vec3, v_axis: Vec3, normal: Vec3, seg_u: u32, seg_v: u32, uv_scale: f32) {
            let (seg_u, seg_v) = (seg_u.max(1), seg_v.max(1));
            let base = self.mesh.positions.len() as u32;
            let (len_u, len_v) = (u_axis.length(), v_axis.length());
            for j in 0..=seg_v {
                let t = j as f32 / seg_v as f32;
                for i in 0..=seg_u {
                    let s = i as f32 / seg_u as f32;
                    let p = origin + u_axis * s + v_axis * t;
                    self.vertex(p, normal, Vec2::new(s * len_u, t * len_v) * uv_scale);
                }
            }
            let row = seg_u + 1;
            for j in 0..seg_v {
                for i in 0..seg_u {
                    let a = base + j * row + i;
                    self.quad([a, a + 1, a + row + 1, a + row]);
                }
            }
        }

        pub(super) fn build(mut self) -> Mesh {
            self.mesh.generate_tangents();
            self.mesh
        }
    }

    /// A horizontal plane centred on the origin facing +Y, split into `subdivisions`×
    /// `subdivisions` quads (at least one).
    pub fn plane(size_x: f32, size_z: f32, subdivisions: u32, uv_scale: f32) -> Mesh {
        let (sx, sz) = (size_x.abs(), size_z.abs());
        let mut b = Builder::default();
        b.grid(Vec3::new(-sx / 2.0, 0.0, -sz / 2.0), Vec3::X * sx, Vec3::Z * sz, Vec3::Y, subdivisions, subdivisions, uv_scale);
        b.build()
    }

    /// An axis-aligned box of `size` centred on the origin, one quad per face; vertical faces
    /// have V running downwards so images appear upright.
    pub fn cuboid(size: Vec3, uv_scale: f32) -> Mesh {
        let h = size.abs() / 2.0;
        let mut b = Builder::default();
        // (normal, u axis, v axis) per face, with the axes' half lengths.
        let faces = [
            (Vec3::X, Vec3::NEG_Z * h.z, Vec3::NEG_Y * h.y, h.x),
            (Vec3::NEG_X, Vec3::Z * h.z, Vec3::NEG_Y * h.y, h.x),
            (Vec3::Z, Vec3::X * h.x, Vec3::NEG_Y * h.y, h.z),
            (Vec3::NEG_Z, Vec3::NEG_X * h.x, Vec3::NEG_Y * h.y, h.z),
            (Vec3::Y, Vec3::X * h.x, Vec3::Z * h.z, h.y),
            (Vec3::NEG_Y, Vec3::X * h.x, Vec3::NEG_Z * h.z, h.y),
        ];
        for (normal, u, v, depth) in faces {
            let origin = normal * depth - u - v;
            b.grid(origin, u * 2.0, v * 2.0, normal, 1, 1, uv_scale);
        }
        b.build()
    }

    /// A UV sphere centred on the origin with `sectors` (≥ 3) around and `stacks` (≥ 2) from
    /// pole to pole; U is the arc length around the equator and V from the north pole, in metres.
    pub fn uv_sphere(radius: f32, sectors: u32, stacks: u32) -> Mesh {
        let (r, sectors, stacks) = (radius.abs(), sectors.max(3), stacks.max(2));
        let mut b = Builder::default();
        for i in 0..=stacks {
            let theta = PI * i as f32 / stacks as f32;
            for j in 0..=sectors {
                let phi = TAU * j as f32 / sectors as f32;
                let n = Vec3::new(theta.sin() * phi.cos(), theta.cos(), theta.sin() * phi.sin());
                let uv = Vec2::new(TAU * r * j as f32 / sectors as f32, PI * r * i as f32 / stacks as f32);
                b.vertex(n * r, n, uv);
            }
        }
        let row = sectors + 1;
        for i in 0..stacks {
            for j in 0..sectors {
                let a = i * row + j;
                b.quad([a, a + 1, a + row + 1, a + row]);
            }
        }
        b.build()
    }

    /// A closed cylinder centred on the origin along Y with `segments` (≥ 3) around; the side's
    /// U is the arc length, caps are mapped by their XZ position.
    pub fn cylinder(radius: f32, height: f32, segments: u32, uv_scale: f32) -> Mesh {
        let (r, hh, segments) = (radius.abs(), height.abs() / 2.0, segments.max(3));
        let mut b = Builder::default();
        let ring = |j: u32| {
            let phi = TAU * j as f32 / segments as f32;
            Vec3::new(phi.cos(), 0.0, phi.sin())
        };
        let side = b.mesh.positions.len() as u32;
        for j in 0..=segments {
            let n = ring(j);
            let u = TAU * r * j as f32 / segments as f32;
            b.vertex(n * r + Vec3::Y * hh, n, Vec2::new(u, 0.0) * uv_scale);
            b.vertex(n * r - Vec3::Y * hh, n, Vec2::new(u, 2.0 * hh) * uv_scale);
        }
        for j in 0..segments {
            let a = side + 2 * j;
            b.quad([a, a + 1, a + 3, a + 2]);
        }
        for (y, normal) in [(hh, Vec3::Y), (-hh, Vec3::NEG_Y)] {
            let planar = |p: Vec3| Vec2::new(p.x, p.z) * uv_scale;
            let centre = b.vertex(Vec3::Y * y, normal, Vec2::ZERO);
            let first = b.mesh.positions.len() as u32;
            for j in 0..segments {
                let p = ring(j) * r + Vec3::Y * y;
                b.vertex(p, normal, planar(p));
            }
            for j in 0..segments {
                b.triangle(centre, first + j, first + (j + 1) % segments);
            }
        }
        b.build()
    }

    /// Layout of [`arch_wall`]'s opening: `(radius, spring height)` after clamping. The opening
    /// is `2·radius` wide, its straight jambs rise from the ground to the spring height and the
    /// semicircle's crown stays 20 % of the wall height below the top.
    pub(super) fn arch_layout(width: f32, height: f32, arch_radius: f32) -> (f32, f32) {
        let gap = 0.2 * height;
        let radius = arch_radius.abs().min(0.45 * width).min(height - gap).max(0.0);
        (radius, (height - gap - radius).max(0.0))
    }

    /// A wall slab in the XY plane (`width` along X centred on the origin, `height` up from
    /// y = 0, `thickness` along Z centred) with a semicircular-arched doorway through its centre:
    /// `2·arch_radius` wide, the crown 20 % of the height below the top (the radius is clamped to
    /// fit), the arch split into `segments` (≥ 2) pieces. UVs are in metres.
    pub fn arch_wall(width: f32, height: f32, thickness: f32, arch_radius: f32, segments: u32) -> Mesh {
        let (w, h, t) = (width.abs(), height.abs(), thickness.abs());
        let (r, ys) = arch_layout(w, h, arch_radius);
        let (hw, ht) = (w / 2.0, t / 2.0);
        let mut b = Builder::default();

        // Angles around the arch centre from the left (π) to the right (0), including the ones
        // pointing at the wall's top corners so that radial strips follow the outline exactly.
        let mut angles: Vec<f32> = (0..=segments.max(2)).map(|k| PI * (1.0 - k as f32 / segments.max(2) as f32)).collect();
        angles.push((h - ys).atan2(-hw));
        angles.push((h - ys).atan2(hw));
        angles.sort_by(|a, b| b.total_cmp(a));
        angles.dedup_by(|a, b| (*a - *b).abs() < 1e-5);
        let centre = Vec2::new(0.0, ys);
        let arc = |a: f32| centre + Vec2::new(a.cos(), a.sin()) * r;
        let boundary = |a: f32| {
            let dir = Vec2::new(a.cos(), a.sin());
            let to_side = if dir.x.abs() > 1e-6 { hw / dir.x.abs() } else { f32::INFINITY };
            let to_top = if dir.y > 1e-6 { (h - ys) / dir.y } else { f32::INFINITY };
            centre + dir * to_side.min(to_top)
        };

        for (z, normal) in [(ht, Vec3::Z), (-ht, Vec3::NEG_Z)] {
            let sign = normal.z;
            let uv = move |p: Vec3| Vec2::new(sign * p.x + hw, h - p.y);
            let at = |p: Vec2| Vec3::new(p.x, p.y, z);
            if ys > 0.0 {
                for (x0, x1) in [(-hw, -r), (r, hw)] {
                    let quad = [Vec2::new(x0, 0.0), Vec2::new(x1, 0.0), Vec2::new(x1, ys), Vec2::new(x0, ys)];
                    b.flat_quad(quad.map(at), normal, uv);
                }
            }
            for pair in angles.windows(2) {
                let quad = [arc(pair[0]), arc(pair[1]), boundary(pair[1]), boundary(pair[0])];
                b.flat_quad(quad.map(at), normal, uv);
            }
        }

        // Outer ends, top and the two bottom strips beside the opening.
        let corners = |x0: f32, x1: f32, y0: f32, y1: f32, zs: bool| {
            if zs {
                [Vec3::new(x0, y0, -ht), Vec3::new(x0, y0, ht), Vec3::new(x1, y1, ht), Vec3::new(x1, y1, -ht)]
            } else {
                [Vec3::new(x0, y0, -ht), Vec3::new(x1, y0, -ht), Vec3::new(x1, y1, ht), Vec3::new(x0, y1, ht)]
            }
        };
        b.flat_quad(corners(-hw, -hw, 0.0, h, true), Vec3::NEG_X, |p| Vec2::new(p.z + ht, h - p.y));
        b.flat_quad(corners(hw, hw, 0.0, h, true), Vec3::X, |p| Vec2::new(ht - p.z, h - p.y));
        b.flat_quad(corners(-hw, hw, h, h, false), Vec3::Y, |p| Vec2::new(p.x + hw, p.z + ht));
        for (x0, x1) in [(-hw, -r), (r, hw)] {
            b.flat_quad(corners(x0, x1, 0.0, 0.0, false), Vec3::NEG_Y, |p| Vec2::new(p.x + hw, p.z + ht));
        }

        if r > 0.0 {
            // Jambs face into the opening.
            if ys > 0.0 {
                b.flat_quad(corners(-r, -r, 0.0, ys, true), Vec3::X, |p| Vec2::new(p.z + ht, ys - p.y));
                b.flat_quad(corners(r, r, 0.0, ys, true), Vec3::NEG_X, |p| Vec2::new(p.z + ht, ys - p.y));
            }
            // The intrados: smooth normals pointing at the arch centre, U = arc length.
            for pair in angles.windows(2) {
                let v = [pair[0], pair[1]].map(|a| {
                    let p = arc(a);
                    let n = -Vec3::new(a.cos(), a.sin(), 0.0);
                    let s = (PI - a) * r + ys;
                    [b.vertex(Vec3::new(p.x, p.y, ht), n, Vec2::new(ht * 2.0, s)), b.vertex(Vec3::new(p.x, p.y, -ht), n, Vec2::new(0.0, s))]
                });
                b.quad([v[0][0], v[1][0], v[1][1], v[0][1]]);
            }
        }
        b.build()
    }
}

#[cfg(test)]
mod tests {
    use super::shapes::*;
    use super::*;

    fn all_shapes() -> Vec<(&'static str, Mesh)> {
        vec![
            ("plane", plane(4.0, 3.0, 5, 1.0)),
            ("cuboid", cuboid(Vec3::new(1.0, 2.0, 3.0), 0.5)),
            ("uv_sphere", uv_sphere(1.5, 24, 12)),
            ("cylinder", cylinder(0.5, 2.0, 16, 1.0)),
            ("arch_wall", arch_wall(6.0, 4.0, 0.5, 1.2, 12)),
        ]
    }

    fn tri(mesh: &Mesh, t: usize) -> [usize; 3] {
        let i = &mesh.indices[t * 3..t * 3 + 3];
        [i[0] as usize, i[1] as usize, i[2] as usize]
    }

    #[test]
    fn shapes_are_valid_with_orthonormal_tangents() {
        for (name, mesh) in all_shapes() {
            mesh.validate().unwrap();
            assert!(mesh.triangle_count() > 0, "{name}");
            for (i, (t, n)) in mesh.tangents.iter().zip(&mesh.normals).enumerate() {
                let (t3, n3) = (Vec3::new(t[0], t[1], t[2]), Vec3::from(*n));
                assert!((n3.length() - 1.0).abs() < 1e-4, "{name} normal {i}");
                assert!((t3.length() - 1.0).abs() < 1e-4, "{name} tangent {i} length");
                assert!(t3.dot(n3).abs() < 1e-4, "{name} tangent {i} not orthogonal");
                assert!(t[3] == 1.0 || t[3] == -1.0, "{name} tangent {i} sign");
            }
        }
    }

    #[test]
    fn plane_tangent_follows_u_and_bitangent_points_to_decreasing_v() {
        // U grows along +X and V along +Z on the plane, so MikkTSpace must give tangent +X (not
        // the fallback) and the bitangent w·cross(N, T) must point along -Z (image up).
        let mesh = plane(2.0, 2.0, 2, 1.0);
        for (t, n) in mesh.tangents.iter().zip(&mesh.normals) {
            let tangent = Vec3::new(t[0], t[1], t[2]);
            assert!((tangent - Vec3::X).length() < 1e-4, "{t:?}");
            let bitangent = Vec3::from(*n).cross(tangent) * t[3];
            assert!((bitangent - Vec3::NEG_Z).length() < 1e-4, "{bitangent}");
        }
        // On a box side V runs down the face, so the bitangent points up.
        let cube = cuboid(Vec3::ONE, 1.0);
        for ((t, n), p) in cube.tangents.iter().zip(&cube.normals).zip(&cube.positions) {
            if n[1].abs() < 0.5 {
                let bitangent = Vec3::from(*n).cross(Vec3::new(t[0], t[1], t[2])) * t[3];
                assert!((bitangent - Vec3::Y).length() < 1e-4, "at {p:?}: {bitangent}");
            }
        }
    }

    #[test]
    fn shapes_wind_counter_clockwise_around_their_normals() {
        for (name, mesh) in all_shapes() {
            for t in 0..mesh.triangle_count() {
                let [a, b, c] = tri(&mesh, t);
                let p = |i: usize| Vec3::from(mesh.positions[i]);
                let geometric = (p(b) - p(a)).cross(p(c) - p(a));
                let shading: Vec3 = [a, b, c].iter().map(|&i| Vec3::from(mesh.normals[i])).sum();
                assert!(geometric.dot(shading) > 0.0, "{name} triangle {t} winds backwards");
            }
        }
    }

    #[test]
    fn convex_shapes_have_outward_normals() {
        for (name, mesh) in all_shapes().into_iter().take(4).skip(1) {
            for (p, n) in mesh.positions.iter().zip(&mesh.normals) {
                assert!(Vec3::from(*p).dot(Vec3::from(*n)) > 0.0, "{name}: inward normal at {p:?}");
            }
        }
    }

    /// Möller–Trumbore: whether the ray `origin + s·dir` hits any triangle of `mesh`.
    fn ray_hits(mesh: &Mesh, origin: Vec3, dir: Vec3) -> bool {
        (0..mesh.triangle_count()).any(|t| {
            let [a, b, c] = tri(mesh, t).map(|i| Vec3::from(mesh.positions[i]));
            let (e1, e2) = (b - a, c - a);
            let pv = dir.cross(e2);
            let det = e1.dot(pv);
            if det.abs() < 1e-9 {
                return false;
            }
            let tv = origin - a;
            let u = tv.dot(pv) / det;
            let qv = tv.cross(e1);
            let v = dir.dot(qv) / det;
            let s = e2.dot(qv) / det;
            (0.0..=1.0).contains(&u) && v >= 0.0 && u + v <= 1.0 && s > 0.0
        })
    }

    #[test]
    fn arch_wall_has_an_opening() {
        let (w, h) = (6.0, 4.0);
        let mesh = arch_wall(w, h, 0.5, 1.2, 12);
        let (r, ys) = arch_layout(w, h, 1.2);
        assert!(r > 1.1 && ys > 0.5, "layout r={r} ys={ys}");
        let through = |x: f32, y: f32| ray_hits(&mesh, Vec3::new(x, y, 5.0), Vec3::NEG_Z);
        assert!(!through(0.0, ys), "ray through the arch centre must miss");
        assert!(!through(0.0, 0.1));
        assert!(!through(0.0, ys + r * 0.9));
        assert!(!through(r * 0.6, ys + r * 0.6));
        assert!(through(0.0, ys + r + 0.1), "above the crown is wall");
        assert!(through(-w / 2.0 + 0.1, 0.5), "pier is wall");
        assert!(through(r * 0.8, ys + r * 0.8), "the arch's spandrel is wall");
        let (min, max) = mesh.aabb();
        assert!((min - Vec3::new(-3.0, 0.0, -0.25)).length() < 1e-5);
        assert!((max - Vec3::new(3.0, 4.0, 0.25)).length() < 1e-5);
    }

    #[test]
    fn mesh_new_validates() {
        let p = vec![[0.0; 3]; 3];
        let n = vec![[0.0, 1.0, 0.0]; 3];
        let uv = vec![[0.0; 2]; 3];
        assert_eq!(
            Mesh::new(p.clone(), n.clone(), uv.clone(), vec![0, 1, 3]),
            Err(MeshError::IndexOutOfRange { at: 2, index: 3, vertices: 3 })
        );
        assert_eq!(Mesh::new(p.clone(), n.clone(), uv.clone(), vec![0, 1]), Err(MeshError::IndexCount(2)));
        assert!(matches!(
            Mesh::new(p.clone(), n[..2].to_vec(), uv.clone(), vec![0, 1, 2]),
            Err(MeshError::AttributeLength { attribute: "normals", .. })
        ));
        // Degenerate UVs and a zero-area triangle still give finite, orthonormal tangents.
        let mesh = Mesh::new(p, n, uv, vec![0, 1, 2]).unwrap();
        for t in &mesh.tangents {
            assert!(t.iter().all(|v| v.is_finite()));
            assert!(t[1].abs() < 1e-6);
        }
    }

    #[test]
    fn transform_and_merge() {
        let cube = cuboid(Vec3::ONE, 1.0);
        let mirrored = cube.transformed(Mat4::from_scale(Vec3::new(-2.0, 1.0, 1.0)));
        let (min, max) = mirrored.aabb();
        assert!((min.x + 1.0).abs() < 1e-6 && (max.x - 1.0).abs() < 1e-6);
        for t in 0..mirrored.triangle_count() {
            let [a, b, c] = tri(&mirrored, t);
            let p = |i: usize| Vec3::from(mirrored.positions[i]);
            let geometric = (p(b) - p(a)).cross(p(c) - p(a));
            assert!(geometric.dot(Vec3::from(mirrored.normals[a])) > 0.0, "mirror keeps winding");
            assert!(Vec3::from(mirrored.normals[a]).dot(p(a)) > 0.0, "normals stay outward");
        }
        let mut merged = cube.clone();
        merged.merge(&mirrored);
        merged.validate().unwrap();
        assert_eq!(merged.triangle_count(), 24);
        assert_eq!(merged.indices[36], mirrored.indices[0] + 24);
    }

    #[test]
    fn smooth_normals_average_faces() {
        // Two triangles folded at 90° along the X axis share vertices 0 and 1.
        let positions = [[0.0, 0.0, 0.0], [1.0, 0.0, 0.0], [0.0, 0.0, -1.0], [0.0, 1.0, 0.0]];
        let normals = smooth_normals(&positions, &[0, 1, 2, 0, 1, 3]);
        let expected = Vec3::new(0.0, 1.0, 1.0).normalize();
        assert!((Vec3::from(normals[0]) - expected).length() < 1e-5, "{:?}", normals[0]);
        assert!((Vec3::from(normals[2]) - Vec3::Y).length() < 1e-5);
    }
}
