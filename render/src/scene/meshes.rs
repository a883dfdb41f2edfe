//! Meshes and textures waiting for their upload ([`MeshData`], [`TextureData`]), the ids the
//! renderer knows them by, and what it draws for an instance slot ([`DrawItem`]).

use crate::layout::{CULL_DOUBLE_SIDED, CULL_LIVE, CULL_MASKED, CULL_TRANSPARENT, GpuMorphDelta, GpuSkinVertex, LOD_LEVELS};
use crate::scene::Vertex;

/// Geometry to upload: interleaved vertices and a triangle list, and for a skinned mesh its
/// joints and weights.
#[derive(Clone, Debug, Default)]
pub struct MeshData {
    /// Vertices.
    pub vertices: Vec<Vertex>,
    /// Triangle list indices.
    pub indices: Vec<u32>,
    /// Joints and weights, one per vertex, for a mesh that can be posed
    /// ([`SceneMirror::add_posed_mesh`](super::SceneMirror::add_posed_mesh)); empty for a rigid mesh.
    pub skin: Vec<GpuSkinVertex>,
    /// Morph targets' offsets, target after target, one per vertex each (`morph_targets` ×
    /// the vertex count; otherwise they are dropped); empty without morph targets.
    pub morphs: Vec<GpuMorphDelta>,
    /// Number of morph targets in `morphs`.
    pub morph_targets: u32,
    /// Coarser levels of detail over the same vertices: `None` draws the mesh in full; make them
    /// with `MeshLods::for_mesh` (`render/src/lod`) (the ECS plugin does for every mesh it
    /// uploads). Levels that do not fit the mesh are dropped with a warning.
    pub lods: Option<MeshLods>,
}

/// A mesh's coarser levels of detail (level 0 is the mesh's own triangle list), made by
/// `MeshLods::generate` (`render/src/lod`).
#[derive(Clone, Debug, Default, PartialEq)]
pub struct MeshLods {
    /// The coarser levels' indices back to back, level 1 first.
    pub indices: Vec<u32>,
    /// Indices of each coarser level (0 past the last level).
    pub counts: [u32; LOD_LEVELS as usize],
    /// Each coarser level's geometric error as a fraction of the diagonal of the mesh's bounds
    /// (growing with the level).
    pub errors: [f32; LOD_LEVELS as usize],
}

impl MeshLods {
    /// Number of coarser levels.
    pub fn levels(&self) -> usize {
        self.counts.iter().take_while(|&&c| c > 0).count()
    }

    /// The indices of coarser level `level` (1 for the first).
    pub fn level(&self, level: usize) -> &[u32] {
        if level == 0 || level > self.levels() {
            return &[];
        }
        let start: usize = self.counts[..level - 1].iter().map(|&c| c as usize).sum();
        &self.indices[start..start + self.counts[level - 1] as usize]
    }

    /// Whether these levels can be drawn over `vertex_count` vertices: whole triangles, every
    /// index in range, the counts adding up to the indices, errors finite, not negative and not
    /// shrinking with the level.
    pub fn fits(&self, vertex_count: usize) -> bool {
        let levels = self.levels();
        self.counts[levels..].iter().all(|&c| c == 0)
            && self.counts.iter().all(|c| c % 3 == 0)
            && self.counts.iter().map(|&c| c as usize).sum::<usize>() == self.indices.len()
            && self.indices.iter().all(|&i| (i as usize) < vertex_count)
            && self.errors[..levels].iter().all(|e| e.is_finite() && *e >= 0.0)
            && self.errors[..levels].windows(2).all(|w| w[0] <= w[1])
    }

    /// What the skinning pass reads to skin one level's vertices alone (`crate::skinning`), as
    /// 32-bit words: each coarser level's first word (levels 1 to `LOD_LEVELS`), then their
    /// vertex counts, then each vertex's coarsest level ([`MeshLods::vertex_levels`], a byte a
    /// vertex, four to a word), then each coarser level's vertices in order. Empty without levels
    /// or for more vertices than a skinning job can name.
    pub fn skin_table(&self, vertex_count: usize) -> Vec<u32> {
        let levels = self.levels();
        if levels == 0 || vertex_count >= 1 << 24 {
            return Vec::new();
        }
        let of_vertex = self.vertex_levels(vertex_count);
        let header = 2 * LOD_LEVELS as usize;
        let mut table = vec![0u32; header + vertex_count.div_ceil(4)];
        for (v, &level) in of_vertex.iter().enumerate() {
            table[header + v / 4] |= (level as u32) << (8 * (v % 4));
        }
        for level in 1..=levels {
            table[level - 1] = table.len() as u32;
            let before = table.len();
            table.extend((0..vertex_count as u32).filter(|&v| of_vertex[v as usize] as usize >= level));
            table[LOD_LEVELS as usize + level - 1] = (table.len() - before) as u32;
        }
        table
    }

    /// Each of `vertex_count` vertices' coarsest level: the last level whose triangles use it (0
    /// for a vertex only the mesh's own triangles use). A level is simplified from the one
    /// before it over the same vertices, so a vertex belongs to its coarsest level and every
    /// finer one.
    pub fn vertex_levels(&self, vertex_count: usize) -> Vec<u8> {
        let mut levels = vec![0u8; vertex_count];
        for level in 1..=self.levels() {
            for &i in self.level(level) {
                if let Some(v) = levels.get_mut(i as usize) {
                    *v = (*v).max(level as u8);
                }
            }
        }
        levels
    }
}

/// Bytes of one level of `width` × `height` texels of a texture `format` the renderer samples:
/// RGBA8 (UNORM or sRGB), RGBA32F (the renderer's own tables, in built-in slots only), or the block-compressed BC1 (RGB or RGBA), BC3, BC4, BC5 and BC7 (4×4 texels a
/// block). `None` for any other format.
pub fn level_bytes(format: ash::vk::Format, width: u32, height: u32) -> Option<u64> {
    use ash::vk::Format as F;
    let blocks = width.div_ceil(4) as u64 * height.div_ceil(4) as u64;
    match format {
        F::R8G8B8A8_UNORM | F::R8G8B8A8_SRGB => Some(width as u64 * height as u64 * 4),
        F::R32G32B32A32_SFLOAT => Some(width as u64 * height as u64 * 16),
        F::BC1_RGB_UNORM_BLOCK | F::BC1_RGB_SRGB_BLOCK | F::BC1_RGBA_UNORM_BLOCK | F::BC1_RGBA_SRGB_BLOCK | F::BC4_UNORM_BLOCK => {
            Some(blocks * 8)
        }
        F::BC3_UNORM_BLOCK | F::BC3_SRGB_BLOCK | F::BC5_UNORM_BLOCK | F::BC7_UNORM_BLOCK | F::BC7_SRGB_BLOCK => Some(blocks * 16),
        _ => None,
    }
}

/// Pixels to upload: a full or partial mip chain, level 0 first.
#[derive(Clone, Debug)]
pub struct TextureData {
    /// Width of level 0.
    pub width: u32,
    /// Height of level 0.
    pub height: u32,
    /// How the texels are stored (sRGB formats are sampled as linear by the hardware): one that
    /// [`level_bytes`] knows.
    pub format: ash::vk::Format,
    /// One buffer per mip level, of [`level_bytes`] each.
    pub mips: Vec<Vec<u8>>,
}

/// Identifies an uploaded mesh.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash, PartialOrd, Ord)]
pub struct MeshId(pub u32);

/// What the renderer draws for one instance slot.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct DrawItem {
    /// The geometry.
    pub mesh: MeshId,
    /// Alpha-tested in the depth prepass.
    pub alpha_mask: bool,
    /// Drawn without back-face culling.
    pub double_sided: bool,
    /// Blended ([`MATERIAL_BLEND`](crate::layout::MATERIAL_BLEND)): drawn by the transparency passes, never by the opaque ones.
    pub transparent: bool,
}

impl DrawItem {
    /// The opaque passes' draw batch (`2 × masked + double-sided`, below [`CULL_BATCHES`](crate::layout::CULL_BATCHES));
    /// `None` for a blended instance, which the transparency passes draw in their own order.
    pub fn batch(&self) -> Option<usize> {
        (!self.transparent).then_some(2 * usize::from(self.alpha_mask) + usize::from(self.double_sided))
    }

    /// The `CULL_*` flags of a live instance drawn like this.
    pub fn cull_flags(&self) -> u32 {
        let flag = |on: bool, bit: u32| if on { bit } else { 0 };
        CULL_LIVE
            | flag(self.alpha_mask, CULL_MASKED)
            | flag(self.double_sided, CULL_DOUBLE_SIDED)
            | flag(self.transparent, CULL_TRANSPARENT)
    }

    /// Drawn by the opaque passes without an alpha test.
    pub fn is_opaque(&self) -> bool {
        !self.alpha_mask && !self.transparent
    }

    /// Drawn by the opaque passes with an alpha test.
    pub fn is_masked(&self) -> bool {
        self.alpha_mask && !self.transparent
    }
}
