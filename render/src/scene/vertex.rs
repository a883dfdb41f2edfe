//! Compact vertices: the mesh pool holds each vertex in 24 bytes ([`GpuVertex`]) where the CPU
//! side keeps 48 ([`Vertex`]), halving what every raster pass, the skinning pass and the
//! ray-traced surfaces read per vertex.
//!
//! | attribute | on the CPU | in the pool | precision |
//! | --- | --- | --- | --- |
//! | position | 3 × f32 | 3 × f32, as it is | exact (the acceleration structures build from it) |
//! | normal | 3 × f32 | octahedral, 2 × snorm16 | within 0.004° |
//! | tangent, bitangent sign | 4 × f32 | octahedral, 2 × snorm16, the sign in bit 0 | within 0.008° |
//! | UV | 2 × f32 | 2 × unorm16 over the mesh's UV range | the range / 65,535: 1/65,535 for UVs in [0, 1] (0.03 of a texel at 2048²); a mesh tiling its texture 16 times keeps 1/4,096 of a tile |
//!
//! Octahedral encoding (Meyer et al., "On floating-point normal vectors", 2010; Cigolle et al.,
//! JCGT 2014, "A survey of efficient representations for independent unit vectors") folds the
//! unit sphere onto a square with error spread evenly over directions, where storing X and Y
//! and rebuilding Z loses the sign of Z and precision near the equator. UVs are normalised per
//! mesh (`GpuMeshInfo::uv_offset`, `uv_scale`) rather than stored as half floats: a half's step
//! at UVs in [0.5, 1) is 1/2048, a whole texel of a 2048² texture, where 16 bits over the
//! mesh's own range keep a texture used once within a thirtieth of a texel. The cost falls on
//! meshes that tile a texture many times: precision is the span over 65,535, so a mesh whose UVs
//! span more than [`WIDE_UV_SPAN`] is warned about as it uploads (a terrain tiling a 2048²
//! texture 1,000 times would be off by 31 texels). A zero tangent decodes as +Z (meshes from
//! the engine always carry unit tangents, `engine::mesh`).
//!
//! The packing here and the unpacking in `shaders/include/vertex.glsl` follow GLSL's
//! `packSnorm2x16`/`unpackSnorm2x16` and `packUnorm2x16`/`unpackUnorm2x16` rules; the skinning
//! pass packs its posed vertices with the same functions in GLSL.

use bytemuck::{Pod, Zeroable};

use crate::layout::GpuVertex;

/// A UV span above which 16-bit UVs lose more than 1/4,096 of a tile (half a texel of a 2048²
/// texture): such a mesh is warned about as it uploads.
pub const WIDE_UV_SPAN: f32 = 16.0;

/// Bytes from a posed mesh's first vertex to its previous positions (a vec4 a vertex, read as
/// 16-byte aligned): its vertices, rounded up to 16 bytes (`previous_positions` in
/// `vertex.glsl`). Mesh ranges start 16-byte aligned ([`crate::scene::pool::GRANULE`]).
pub fn previous_positions_offset(vertex_count: u32) -> u64 {
    (vertex_count as u64 * std::mem::size_of::<GpuVertex>() as u64).next_multiple_of(16)
}

/// One vertex as meshes arrive on the CPU: full-precision attributes, packed into a
/// [`GpuVertex`] as the mesh uploads.
#[repr(C)]
#[derive(Clone, Copy, Debug, Default, PartialEq, Pod, Zeroable)]
pub struct Vertex {
    /// Object-space position.
    pub position: [f32; 3],
    /// Object-space normal (unit length).
    pub normal: [f32; 3],
    /// Texture coordinate 0.
    pub uv: [f32; 2],
    /// Object-space tangent (unit length); w is the bitangent sign.
    pub tangent: [f32; 4],
}

/// A mesh's texture coordinates' range: each is stored as `(uv − offset) / scale` in 16 bits.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct UvRange {
    /// The smallest U and V.
    pub offset: [f32; 2],
    /// Their span (1 where they do not vary, so that the division is defined).
    pub scale: [f32; 2],
}

impl UvRange {
    /// The range of `vertices`' texture coordinates (non-finite ones ignored).
    pub fn of(vertices: &[Vertex]) -> UvRange {
        let mut lo = [f32::INFINITY; 2];
        let mut hi = [f32::NEG_INFINITY; 2];
        for v in vertices {
            for c in 0..2 {
                if v.uv[c].is_finite() {
                    lo[c] = lo[c].min(v.uv[c]);
                    hi[c] = hi[c].max(v.uv[c]);
                }
            }
        }
        // A span too wide for f32 (UVs near ±3.4e38) is not packed at all: offset 0, scale 1.
        let usable = |c: usize| lo[c].is_finite() && (hi[c] - lo[c]).is_finite();
        let offset = std::array::from_fn(|c| if usable(c) { lo[c] } else { 0.0 });
        let scale = std::array::from_fn(|c| if usable(c) && hi[c] > lo[c] { hi[c] - lo[c] } else { 1.0 });
        UvRange { offset, scale }
    }

    /// The largest step between two representable UVs: the wider span / 65,535.
    pub fn step(&self) -> f32 {
        self.scale[0].max(self.scale[1]) / 65535.0
    }
}

/// GLSL's `packSnorm2x16`.
fn pack_snorm2x16(v: [f32; 2]) -> u32 {
    let c = |x: f32| ((x.clamp(-1.0, 1.0) * 32767.0).round() as i16) as u16 as u32;
    c(v[0]) | (c(v[1]) << 16)
}

/// GLSL's `unpackSnorm2x16`.
fn unpack_snorm2x16(p: u32) -> [f32; 2] {
    let c = |bits: u32| ((bits as u16 as i16) as f32 / 32767.0).clamp(-1.0, 1.0);
    [c(p & 0xFFFF), c(p >> 16)]
}

/// GLSL's `packUnorm2x16`.
fn pack_unorm2x16(v: [f32; 2]) -> u32 {
    let c = |x: f32| (x.clamp(0.0, 1.0) * 65535.0).round() as u32;
    c(v[0]) | (c(v[1]) << 16)
}

/// GLSL's `unpackUnorm2x16`.
fn unpack_unorm2x16(p: u32) -> [f32; 2] {
    [(p & 0xFFFF) as f32 / 65535.0, (p >> 16) as f32 / 65535.0]
}

/// A unit vector on the octahedron's square, in [−1, 1]² (a zero vector gives straight up).
pub fn oct_encode(n: [f32; 3]) -> [f32; 2] {
    let l1 = n[0].abs() + n[1].abs() + n[2].abs();
    if l1.is_nan() || l1 <= 0.0 || l1.is_infinite() {
        return [0.0, 0.0];
    }
    let (x, y, z) = (n[0] / l1, n[1] / l1, n[2] / l1);
    if z >= 0.0 {
        [x, y]
    } else {
        let sign = |v: f32| if v >= 0.0 { 1.0 } else { -1.0 };
        [(1.0 - y.abs()) * sign(x), (1.0 - x.abs()) * sign(y)]
    }
}

/// The unit vector a point of the octahedron's square stands for (`oct_decode` in
/// `vertex.glsl`).
pub fn oct_decode(e: [f32; 2]) -> [f32; 3] {
    let mut n = [e[0], e[1], 1.0 - e[0].abs() - e[1].abs()];
    let t = (-n[2]).max(0.0);
    n[0] += if n[0] >= 0.0 { -t } else { t };
    n[1] += if n[1] >= 0.0 { -t } else { t };
    let l = (n[0] * n[0] + n[1] * n[1] + n[2] * n[2]).sqrt();
    n.map(|c| c / l)
}

impl Vertex {
    /// The vertex as the mesh pool holds it, its UV normalised over `uv`.
    pub fn pack(&self, uv: &UvRange) -> GpuVertex {
        let tangent = pack_snorm2x16(oct_encode([self.tangent[0], self.tangent[1], self.tangent[2]])) & !1;
        GpuVertex {
            position: self.position,
            normal: pack_snorm2x16(oct_encode(self.normal)),
            tangent: tangent | u32::from(self.tangent[3] < 0.0),
            uv: pack_unorm2x16(std::array::from_fn(|c| (self.uv[c] - uv.offset[c]) / uv.scale[c])),
        }
    }

    /// A packed vertex unpacked as the shaders do (for tests and tools).
    pub fn unpack(v: &GpuVertex, uv: &UvRange) -> Vertex {
        let [tx, ty, tz] = oct_decode(unpack_snorm2x16(v.tangent & !1));
        let e = unpack_unorm2x16(v.uv);
        Vertex {
            position: v.position,
            normal: oct_decode(unpack_snorm2x16(v.normal)),
            uv: std::array::from_fn(|c| uv.offset[c] + e[c] * uv.scale[c]),
            tangent: [tx, ty, tz, if v.tangent & 1 != 0 { -1.0 } else { 1.0 }],
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The angle between two directions in degrees, from the cross and dot products in f64
    /// (an arccosine in f32 cannot resolve a thousandth of a degree).
    fn angle(a: [f32; 3], b: [f32; 3]) -> f32 {
        let (a, b) = (a.map(f64::from), b.map(f64::from));
        let cross = [a[1] * b[2] - a[2] * b[1], a[2] * b[0] - a[0] * b[2], a[0] * b[1] - a[1] * b[0]];
        let sin = (cross[0] * cross[0] + cross[1] * cross[1] + cross[2] * cross[2]).sqrt();
        sin.atan2(a[0] * b[0] + a[1] * b[1] + a[2] * b[2]).to_degrees() as f32
    }

    #[test]
    fn every_direction_round_trips_within_its_stated_angle() {
        // A Fibonacci sphere of 20,000 directions, and the axes (the octahedron's corners).
        let count = 20_000;
        let golden = std::f32::consts::PI * (3.0 - 5f32.sqrt());
        let mut directions: Vec<[f32; 3]> = (0..count)
            .map(|i| {
                let y = 1.0 - 2.0 * (i as f32 + 0.5) / count as f32;
                let r = (1.0 - y * y).sqrt();
                let phi = golden * i as f32;
                [r * phi.cos(), y, r * phi.sin()]
            })
            .collect();
        directions.extend([[1.0, 0.0, 0.0], [-1.0, 0.0, 0.0], [0.0, 1.0, 0.0], [0.0, -1.0, 0.0], [0.0, 0.0, 1.0], [0.0, 0.0, -1.0]]);
        let uv = UvRange { offset: [0.0; 2], scale: [1.0; 2] };
        let (mut normal_worst, mut tangent_worst) = (0.0f32, 0.0f32);
        for (i, &d) in directions.iter().enumerate() {
            let sign = if i % 2 == 0 { 1.0 } else { -1.0 };
            let v = Vertex { position: [1.0, 2.0, 3.0], normal: d, uv: [0.25, 0.75], tangent: [d[1], d[2], d[0], sign] };
            let back = Vertex::unpack(&v.pack(&uv), &uv);
            assert_eq!(back.position, v.position);
            assert_eq!(back.tangent[3], sign, "the bitangent sign survives");
            normal_worst = normal_worst.max(angle(d, back.normal));
            tangent_worst = tangent_worst.max(angle([d[1], d[2], d[0]], [back.tangent[0], back.tangent[1], back.tangent[2]]));
        }
        // The module docs' figures, with room: measured 0.0036° and 0.0074°.
        assert!(normal_worst < 0.005, "normals within {normal_worst}°");
        assert!(tangent_worst < 0.01, "tangents within {tangent_worst}°");
    }

    #[test]
    fn uvs_keep_a_sixty_five_thousandth_of_their_range() {
        let vertices: Vec<Vertex> =
            (0..=1000).map(|i| Vertex { uv: [-3.0 + i as f32 * 0.013, 0.5], normal: [0.0, 0.0, 1.0], ..Default::default() }).collect();
        let range = UvRange::of(&vertices);
        assert_eq!((range.offset, range.scale[1]), ([-3.0, 0.5], 1.0), "a constant V spans 1");
        for v in &vertices {
            let back = Vertex::unpack(&v.pack(&range), &range);
            for c in 0..2 {
                assert!((back.uv[c] - v.uv[c]).abs() <= range.scale[c] / 65535.0, "{:?} came back as {:?}", v.uv, back.uv);
            }
        }
        let nan = [Vertex { uv: [f32::NAN, 0.0], ..Default::default() }];
        assert_eq!(UvRange::of(&nan), UvRange { offset: [0.0, 0.0], scale: [1.0, 1.0] }, "non-finite UVs are ignored");
        let huge = [Vertex { uv: [-3e38, 0.0], ..Default::default() }, Vertex { uv: [3e38, 0.0], ..Default::default() }];
        assert_eq!(UvRange::of(&huge).scale, [1.0, 1.0], "a span past f32's range is not packed");
    }
}
