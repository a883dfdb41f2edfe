//! Levels of detail: every mesh gets coarser copies of its triangle list when it is first
//! uploaded ([`MeshLods::for_mesh`]; the ECS plugin makes them for every mesh it uploads, a
//! game that fills the scene mirror itself passes them in `MeshData::lods`), and the culling
//! pass picks one per instance each frame by the error it would show on screen. No seed covers this (`../shared/seeds/001` draws every triangle at every
//! distance); the simplifier is meshoptimizer's (the `meshopt` crate: edge collapses ordered by
//! quadric error, Garland and Heckbert 1997, that keep attribute seams and report the
//! geometric error of what they made), and the choice by projected error with a hysteresis band
//! follows what Unreal's and Bevy's mesh LODs do per instance.
//!
//! - **Corners are welded first**: a mesh exported with a vertex per corner (flat shading, as
//!   the shared Fox is) shares no edge until the corners at one position (with the same joints
//!   and weights) are made one; the levels name the first corner of each.
//! - **Levels share the vertices.** A level is a triangle list over the mesh's own vertices,
//!   simplified from the level before it, so a skinned mesh's levels keep its joints and weights
//!   (nothing is re-weighted) and its posed copies move every level with the skeleton; a far
//!   character's skinning writes only its level's vertices (`crate::skinning`). The
//!   levels' indices follow the full list in the mesh pool ([`crate::scene::pool`]), so one
//!   range holds them all and a triangle of any level has one number counted from the start of
//!   the mesh's indices.
//! - **Levels made by the mesh's author** (glTF's `MSFT_lod`, which the engine's loader attaches
//!   to the mesh) are used in place of simplified ones ([`with_authored_levels`]): their vertices
//!   are appended to the mesh's, so a level is still a triangle list over the mesh's vertices,
//!   and their error is measured, the farthest either surface strays from the other, so the
//!   culling pass chooses them by the same rule.
//! - **Meshes with morph targets get none**: their targets move vertices the simplifier never
//!   saw move, so no error it reports would hold.
//! - **Up to [`LOD_LEVELS`] coarser levels**, each with about half the triangles of the one
//!   before, while the simplifier can halve it within [`MAX_LEVEL_ERROR`]; meshes of fewer than
//!   [`MIN_TRIANGLES`] triangles get none.
//! - **The error of a level** is meshoptimizer's estimate of how far its surface strays from the
//!   full mesh's (the errors of the steps added up, so it bounds the distance to level 0), as a
//!   fraction of the diagonal of the mesh's bounds, so the culling pass can scale it by the
//!   instance's world bounds. For a skinned mesh it is the rest pose's: the joints' weights
//!   weigh in (vertices where weights blend collapse last), but a bent joint can show more (the
//!   test's tube, bent by 90°, strays up to 4 pixels from its full silhouette where the stated
//!   error is 1; `tests/tests/suite/lod.rs`).
//! - **The choice** (`shaders/cull.comp`, [`crate::culling`]): the coarsest level whose error,
//!   projected at the nearest point of the instance's world bounds, stays within
//!   `FrameSettings::lod_pixels` (1 pixel by default: below what TAA's reconstruction shows as a
//!   pop). An instance moves to a coarser level only when that level's error is within
//!   [`LOD_HYSTERESIS`] of the limit, so one that sits at a threshold does not flicker between
//!   two levels; it moves to a finer one as soon as its level's error passes the limit.
//! - **Who draws levels**: every raster pass that draws the culled lists (depth prepass,
//!   forward, G-buffer, visibility buffer, shadow maps, glass). The level rides in the draw's
//!   `firstInstance` above the instance slot ([`LOD_LEVEL_SHIFT`]), so the vertex shader learns
//!   it without another buffer and hands the fragment stages the level's first triangle (the
//!   G-buffer and the visibility buffer store triangle numbers). Ray tracing keeps level 0: the
//!   scene's BLASes are built from the full mesh. A coarser level lies up to its limit off that
//!   mesh (inside it, for a convex shape), so every ray that leaves a rasterised surface for the
//!   scene's acceleration structure (shadows, ambient occlusion, reflections: `raster_origin` in
//!   `shaders/include/lighting.glsl`) is lifted by the world size of the limit at the surface's
//!   distance ([`lift`], while some live instance's mesh has levels:
//!   [`crate::scene::SceneMirror::lod_instances`]) on top of the 0.1 % of the distance every ray gets: a level never
//!   shadows or reflects itself, at the cost of contact shadows starting that much later (at
//!   1920×1080 and 60°, 1 px is about 0.1 % of the distance). The shadow rays of `--lights
//!   ray_query` are lifted from primary surfaces, not from reflections' hits
//!   (`shaders/include/light_draw.glsl`).

use glam::Vec3;

use crate::layout::{GpuSkinVertex, LOD_LEVELS};
use crate::scene::MeshData;
pub use crate::scene::MeshLods;
use crate::scene::Vertex;

pub use crate::layout::{LOD_LEVEL_SHIFT, LOD_SLOT_MASK};

pub use crate::settings::{DEFAULT_LOD_PIXELS, LOD_HYSTERESIS};

/// Meshes with fewer triangles get no coarser levels.
pub const MIN_TRIANGLES: usize = 64;

/// The largest error a level may add to the one before it, relative to the mesh's extent (the
/// simplifier's own scale): simplification stops where halving would cost more.
pub const MAX_LEVEL_ERROR: f32 = 0.05;

/// The world size of `pixels` pixels at 1 m from a camera projecting with `proj` onto a target
/// `height` pixels high: how far ray origins are lifted off a surface (per metre of distance,
/// `GpuLighting::lod_lift`) so that a coarser level, which lies up to its limit off the full mesh
/// the rays trace (inside it, for a convex shape), does not shadow or reflect itself. 0 with
/// levels of detail off.
pub fn lift(pixels: f32, proj: glam::Mat4, height: u32) -> f32 {
    let scale = proj.y_axis.y.abs() * height.max(1) as f32;
    if pixels > 0.0 && pixels.is_finite() && scale > 0.0 { 2.0 * pixels / scale } else { 0.0 }
}

impl MeshLods {
    /// The levels of a mesh about to be uploaded: [`MeshLods::generate`] over its vertices,
    /// indices and skin, none for a mesh with morph targets (they move vertices the simplifier
    /// never saw move, so no error it reports would hold).
    pub fn for_mesh(data: &MeshData) -> Self {
        if data.morph_targets > 0 { Self::default() } else { Self::generate(&data.vertices, &data.indices, &data.skin) }
    }

    /// Builds the coarser levels of the triangle list `indices` over `vertices` (with their
    /// joints and weights `skin`, one per vertex, for a skinned mesh; empty otherwise). A mesh
    /// that is too small, or whose indices or positions the simplifier cannot take (an index
    /// out of range, a count that is not whole triangles, a position that is not finite), gets
    /// none.
    pub fn generate(vertices: &[Vertex], indices: &[u32], skin: &[GpuSkinVertex]) -> Self {
        let mut lods = Self::default();
        if indices.len() < MIN_TRIANGLES * 3 || !indices.len().is_multiple_of(3) || !usable(vertices, indices) {
            return lods;
        }
        // The simplifier works on the welded corners alone (a corner at the same position but
        // left out would read to it as a seam it must keep); its indices are mapped back.
        let Welded { originals, corner_of, indices: mut previous } = welded(vertices, indices, skin);
        let compact: Vec<Vertex> = originals.iter().map(|&i| vertices[i as usize]).collect();
        let compact_skin: Vec<GpuSkinVertex> = originals.iter().filter_map(|&i| skin.get(i as usize).copied()).collect();
        let bytes: &[u8] = bytemuck::cast_slice(&compact);
        let Ok(adapter) = meshopt::VertexDataAdapter::new(bytes, std::mem::size_of::<Vertex>(), 0) else { return lods };
        let (lo, hi) = compact.iter().fold((Vec3::INFINITY, Vec3::NEG_INFINITY), |(lo, hi), v| {
            let p = Vec3::from(v.position);
            (lo.min(p), hi.max(p))
        });
        let diagonal = (hi - lo).length();
        if diagonal <= 0.0 {
            return lods;
        }
        // Errors come relative to the simplifier's scale (the largest extent); ours are
        // relative to the diagonal.
        let to_diagonal = meshopt::simplify_scale(&adapter) / diagonal;
        // The normal, the texture coordinate and, for a skinned mesh, where its joints' weights
        // put it weigh in the collapses beside the position, so shading, textures and the
        // bends of a skin hold up as well as the silhouette.
        let attributes = attributes(&compact, &compact_skin);
        // A faceted mesh's welded corners disagree about their normal: the one a corner kept is
        // arbitrary, so normals do not weigh in (the silhouette and the rest still do).
        let faceted = (0..vertices.len()).zip(&corner_of).any(|(i, &c)| {
            let (a, b) = (Vec3::from(vertices[i].normal), Vec3::from(compact[c as usize].normal));
            a.distance_squared(b) > 1e-4
        });
        let mut weights = ATTRIBUTE_WEIGHTS;
        if faceted {
            weights[..3].fill(0.0);
        }
        let locks = vec![false; compact.len()];
        let mut error = 0.0f32;
        for level in 0..LOD_LEVELS as usize {
            let target = (previous.len() / 6 * 3).max(3);
            let mut step = 0.0f32;
            let simplified = meshopt::simplify_with_attributes_and_locks(
                &previous,
                &adapter,
                &attributes,
                &weights,
                ATTRIBUTES * std::mem::size_of::<f32>(),
                &locks,
                target,
                MAX_LEVEL_ERROR,
                meshopt::SimplifyOptions::None,
                Some(&mut step),
            );
            // A level earns its place by saving at least a fifth of the triangles.
            if simplified.len() < 3 || simplified.len() * 5 > previous.len() * 4 || !step.is_finite() {
                break;
            }
            error += step * to_diagonal;
            lods.counts[level] = simplified.len() as u32;
            lods.errors[level] = error;
            lods.indices.extend(simplified.iter().map(|&i| originals[i as usize]));
            previous = simplified;
        }
        lods
    }
}

/// Floats per vertex the simplifier weighs beside the position: the normal, the texture
/// coordinate and the skin's signature.
const ATTRIBUTES: usize = 9;

/// How much each attribute weighs against the position (whose error is relative to the mesh's
/// extent): the normal as much as the position (a mirror shows a bent normal before a moved
/// silhouette; not at all for a faceted mesh, whose corners disagree), the texture coordinate a
/// little, the skin's signature half as much, so that a collapse across a joint's blend costs
/// about what moving the surface would.
const ATTRIBUTE_WEIGHTS: [f32; ATTRIBUTES] = [1.0, 1.0, 1.0, 0.1, 0.1, 0.5, 0.5, 0.5, 0.5];

/// Per vertex: its normal, its texture coordinate and its skin's signature, a point in 4D that
/// each joint pulls towards a fixed direction of its own by the joint's weight. Vertices with
/// the same weights share a signature; a blend between joints moves it, so the simplifier keeps
/// the vertices a bend needs though the rest pose is straight there (zero for a rigid mesh).
fn attributes(vertices: &[Vertex], skin: &[GpuSkinVertex]) -> Vec<f32> {
    let mut out = Vec::with_capacity(vertices.len() * ATTRIBUTES);
    for (i, v) in vertices.iter().enumerate() {
        out.extend_from_slice(&v.normal);
        out.extend_from_slice(&v.uv);
        let mut signature = [0.0f32; 4];
        if let Some(s) = skin.get(i) {
            for (joint, weight) in s.joints().into_iter().zip(s.weights()) {
                let direction = joint_direction(joint);
                for (x, d) in signature.iter_mut().zip(direction) {
                    *x += weight * d;
                }
            }
        }
        out.extend_from_slice(&signature);
    }
    out
}

/// A fixed unit direction in 4D for joint `joint` (a hash of its index: joints of one skin get
/// directions far apart from one another with high probability).
fn joint_direction(joint: u16) -> [f32; 4] {
    let mut h = (joint as u64 + 1).wrapping_mul(0x9E37_79B9_7F4A_7C15);
    let mut d = [0.0f32; 4];
    for x in &mut d {
        h ^= h >> 29;
        h = h.wrapping_mul(0xBF58_476D_1CE4_E5B9);
        *x = (h >> 40) as f32 / (1u64 << 24) as f32 * 2.0 - 1.0;
    }
    let length = d.iter().map(|x| x * x).sum::<f32>().sqrt().max(1e-6);
    d.map(|x| x / length)
}

/// A mesh with its corners welded ([`welded`]).
struct Welded {
    /// The first vertex at each position (with the same joints and weights), in order.
    originals: Vec<u32>,
    /// By vertex: its place in `originals`.
    corner_of: Vec<u32>,
    /// The indices over `originals`.
    indices: Vec<u32>,
}

/// The mesh with its corners welded. A mesh exported with a vertex per corner (flat shading, as
/// the shared Fox is) shares no edge the simplifier could collapse until its corners are welded.
/// A welded corner takes the first corner's normal and texture coordinate, which at the
/// distance a coarser level is drawn is a pixel's worth of shading.
fn welded(vertices: &[Vertex], indices: &[u32], skin: &[GpuSkinVertex]) -> Welded {
    let mut first = std::collections::HashMap::with_capacity(vertices.len());
    let mut originals = Vec::new();
    let corner_of: Vec<u32> = (0..vertices.len())
        .map(|i| {
            let p = vertices[i].position.map(f32::to_bits);
            let s = skin.get(i).map(|s| [s.joints01, s.joints23, s.weights01, s.weights23]);
            *first.entry((p, s)).or_insert_with(|| {
                originals.push(i as u32);
                originals.len() as u32 - 1
            })
        })
        .collect();
    let indices = indices.iter().map(|&i| corner_of[i as usize]).collect();
    Welded { originals, corner_of, indices }
}

/// Whether every index names a vertex and every position is finite.
fn usable(vertices: &[Vertex], indices: &[u32]) -> bool {
    indices.iter().all(|&i| (i as usize) < vertices.len()) && vertices.iter().all(|v| v.position.iter().all(|c| c.is_finite()))
}

/// A mesh with its coarser levels made by its author (glTF's `MSFT_lod`), for the upload: each
/// level's vertices (and joints and weights) are appended to the mesh's, so that a level is a
/// triangle list over the mesh's vertices as a simplified one is, and its error is measured:
/// the farthest a level's surface strays from the full mesh's or the full mesh's from the
/// level's, as a fraction of the diagonal of the mesh's bounds (the distances from sampled
/// vertices to the other surface's triangles, at most [`ERROR_SAMPLES`] of each: a sample of the
/// triangles can only find a farther one, so the error errs on the large side), made to grow
/// with the level. Levels with morph targets, another kind of skin, no triangles or indices out
/// of range, beyond [`LOD_LEVELS`], are left out; with none left the mesh gets no levels.
pub fn with_authored_levels(mut data: MeshData, levels: Vec<MeshData>) -> MeshData {
    let usable = |l: &MeshData| {
        l.morph_targets == 0
            && l.skin.is_empty() == data.skin.is_empty()
            && !l.indices.is_empty()
            && l.indices.len().is_multiple_of(3)
            && l.indices.iter().all(|&i| (i as usize) < l.vertices.len())
    };
    let levels: Vec<MeshData> = levels.into_iter().filter(usable).take(LOD_LEVELS as usize).collect();
    if data.morph_targets > 0 || levels.is_empty() || data.indices.is_empty() {
        data.lods = Some(MeshLods::default());
        return data;
    }
    let positions = |d: &MeshData| d.vertices.iter().map(|v| Vec3::from(v.position)).collect::<Vec<_>>();
    let full = positions(&data);
    let (lo, hi) = full.iter().fold((Vec3::INFINITY, Vec3::NEG_INFINITY), |(lo, hi), &p| (lo.min(p), hi.max(p)));
    let diagonal = (hi - lo).length().max(f32::MIN_POSITIVE);
    let mut lods = MeshLods::default();
    let mut error = 0.0f32;
    for (k, level) in levels.iter().enumerate() {
        let points = positions(level);
        let strays = surface_distance(&points, &full, &data.indices).max(surface_distance(&full, &points, &level.indices));
        error = error.max(strays / diagonal);
        let offset = data.vertices.len() as u32;
        lods.indices.extend(level.indices.iter().map(|&i| i + offset));
        lods.counts[k] = level.indices.len() as u32;
        lods.errors[k] = error;
        data.vertices.extend_from_slice(&level.vertices);
        data.skin.extend_from_slice(&level.skin);
    }
    data.lods = Some(lods);
    data
}

/// Most vertices and triangles of each surface [`with_authored_levels`] measures against the
/// other.
pub const ERROR_SAMPLES: usize = 2048;

/// The farthest any of (a sample of) `points` lies from the triangles `indices` over
/// `vertices` (a sample of them, if many).
fn surface_distance(points: &[Vec3], vertices: &[Vec3], indices: &[u32]) -> f32 {
    let triangles = indices.len() / 3;
    let step = |n: usize| n.div_ceil(ERROR_SAMPLES).max(1);
    let tris: Vec<[Vec3; 3]> =
        (0..triangles).step_by(step(triangles)).map(|t| [0, 1, 2].map(|c| vertices[indices[3 * t + c] as usize])).collect();
    points
        .iter()
        .step_by(step(points.len()))
        .map(|&p| tris.iter().map(|&[a, b, c]| (closest_on_triangle(p, a, b, c) - p).length_squared()).fold(f32::INFINITY, f32::min))
        .fold(0.0f32, f32::max)
        .sqrt()
}

/// The point of triangle `abc` closest to `p` (Ericson, "Real-Time Collision Detection", §5.1.5);
/// a degenerate triangle's first corner when the barycentric solve has no answer.
pub fn closest_on_triangle(p: Vec3, a: Vec3, b: Vec3, c: Vec3) -> Vec3 {
    let (ab, ac, ap) = (b - a, c - a, p - a);
    let (d1, d2) = (ab.dot(ap), ac.dot(ap));
    if d1 <= 0.0 && d2 <= 0.0 {
        return a;
    }
    let bp = p - b;
    let (d3, d4) = (ab.dot(bp), ac.dot(bp));
    if d3 >= 0.0 && d4 <= d3 {
        return b;
    }
    let vc = d1 * d4 - d3 * d2;
    if vc <= 0.0 && d1 >= 0.0 && d3 <= 0.0 {
        return a + ab * (d1 / (d1 - d3));
    }
    let cp = p - c;
    let (d5, d6) = (ab.dot(cp), ac.dot(cp));
    if d6 >= 0.0 && d5 <= d6 {
        return c;
    }
    let vb = d5 * d2 - d1 * d6;
    if vb <= 0.0 && d2 >= 0.0 && d6 <= 0.0 {
        return a + ac * (d2 / (d2 - d6));
    }
    let va = d3 * d6 - d5 * d4;
    if va <= 0.0 && d4 - d3 >= 0.0 && d5 - d6 >= 0.0 {
        return b + (c - b) * ((d4 - d3) / ((d4 - d3) + (d5 - d6)));
    }
    let denom = 1.0 / (va + vb + vc);
    if !denom.is_finite() {
        return a; // a degenerate triangle: its first corner
    }
    a + ab * (vb * denom) + ac * (vc * denom)
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A sphere of `rings` × `segments` quads.
    fn sphere(rings: u32, segments: u32) -> (Vec<Vertex>, Vec<u32>) {
        let mut vertices = Vec::new();
        for r in 0..=rings {
            let theta = std::f32::consts::PI * r as f32 / rings as f32;
            for s in 0..=segments {
                let phi = std::f32::consts::TAU * s as f32 / segments as f32;
                let n = [theta.sin() * phi.cos(), theta.cos(), theta.sin() * phi.sin()];
                vertices.push(Vertex {
                    position: n,
                    normal: n,
                    uv: [s as f32 / segments as f32, r as f32 / rings as f32],
                    tangent: [1.0, 0.0, 0.0, 1.0],
                });
            }
        }
        let mut indices = Vec::new();
        for r in 0..rings {
            for s in 0..segments {
                let a = r * (segments + 1) + s;
                let b = a + segments + 1;
                indices.extend_from_slice(&[a, b, a + 1, a + 1, b, b + 1]);
            }
        }
        (vertices, indices)
    }

    #[test]
    fn levels_halve_the_triangles_with_growing_error_over_the_same_vertices() {
        let (vertices, indices) = sphere(32, 64);
        let lods = MeshLods::generate(&vertices, &indices, &[]);
        assert!(lods.levels() >= 3, "a 4,096-triangle sphere simplifies well: {:?}", lods.counts);
        let mut before = indices.len();
        let mut error = 0.0;
        for level in 1..=lods.levels() {
            let list = lods.level(level);
            assert_eq!(list.len() % 3, 0);
            assert!(list.len() * 5 <= before * 4, "level {level} saves a fifth: {} of {before}", list.len());
            assert!(list.iter().all(|&i| (i as usize) < vertices.len()));
            let e = lods.errors[level - 1];
            assert!(e > error && e < 1.0, "level {level}'s error {e} grows and stays a fraction of the size");
            error = e;
            before = list.len();
        }
        assert_eq!(lods.indices.len(), lods.counts.iter().sum::<u32>() as usize);
        assert!(lods.fits(vertices.len()));
        assert!(!lods.fits(vertices.len() / 2), "indices past the vertices do not fit");
    }

    #[test]
    fn a_faceted_mesh_with_a_vertex_per_corner_is_welded_and_simplified() {
        let (smooth, indices) = sphere(32, 64);
        // Every corner its own vertex with its face's normal, as the shared Fox is exported.
        let mut vertices = Vec::new();
        for t in indices.chunks(3) {
            let p: Vec<Vec3> = t.iter().map(|&i| Vec3::from(smooth[i as usize].position)).collect();
            let n = (p[1] - p[0]).cross(p[2] - p[0]).normalize_or_zero();
            vertices.extend(t.iter().map(|&i| Vertex { normal: n.into(), ..smooth[i as usize] }));
        }
        let corners: Vec<u32> = (0..vertices.len() as u32).collect();
        let lods = MeshLods::generate(&vertices, &corners, &[]);
        assert!(lods.levels() >= 3, "welded, the faceted sphere simplifies as the smooth one: {:?}", lods.counts);
        assert!(lods.fits(vertices.len()));
        assert!(lods.errors[0] < 0.05, "its first level's error {} is small", lods.errors[0]);
    }

    /// The closest point of a triangle: inside it straight below, on an edge, at a corner, and
    /// a degenerate triangle's corner.
    #[test]
    fn the_closest_point_of_a_triangle_is_inside_on_an_edge_or_at_a_corner() {
        let (a, b, c) = (Vec3::ZERO, Vec3::X, Vec3::Y);
        assert_eq!(closest_on_triangle(Vec3::new(0.25, 0.25, 3.0), a, b, c), Vec3::new(0.25, 0.25, 0.0));
        assert_eq!(closest_on_triangle(Vec3::new(0.5, -2.0, 1.0), a, b, c), Vec3::new(0.5, 0.0, 0.0));
        assert_eq!(closest_on_triangle(Vec3::new(2.0, 2.0, 0.0), a, b, c), Vec3::new(0.5, 0.5, 0.0));
        assert_eq!(closest_on_triangle(Vec3::new(-1.0, -1.0, 0.0), a, b, c), a);
        assert_eq!(closest_on_triangle(Vec3::new(3.0, -1.0, 0.0), a, b, c), b);
        assert!(closest_on_triangle(Vec3::ONE, a, a, a).is_finite());
        let points = [Vec3::new(0.2, 0.2, 0.5)];
        assert!((surface_distance(&points, &[a, b, c], &[0, 1, 2]) - 0.5).abs() < 1e-6);
    }

    #[test]
    fn small_or_broken_meshes_get_no_levels() {
        let (vertices, indices) = sphere(4, 8); // 64 triangles: too few to bother
        assert_eq!(MeshLods::generate(&vertices, &indices[..indices.len() - 3], &[]).levels(), 0);
        let (mut vertices, mut indices) = sphere(32, 64);
        assert_eq!(MeshLods::generate(&vertices, &indices[..indices.len() - 1], &[]).levels(), 0, "not whole triangles");
        indices[7] = vertices.len() as u32;
        assert_eq!(MeshLods::generate(&vertices, &indices, &[]).levels(), 0, "an index out of range");
        indices[7] = 0;
        vertices[3].position[1] = f32::NAN;
        assert_eq!(MeshLods::generate(&vertices, &indices, &[]).levels(), 0, "a position that is not finite");
        assert_eq!(MeshLods::default().level(1), &[] as &[u32]);
    }
}
