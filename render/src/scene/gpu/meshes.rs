//! The mesh pool on the GPU side: where each mesh lies ([`GpuMesh`]), how the pool grows,
//! repacks and is released, and the mesh table shaders find meshes through.

use super::*;

/// A mesh's place in the mesh pool ([`crate::scene::pool`]): its vertices, then its indices,
/// then (for a skinned mesh) its joints and weights; a posed mesh's vertices, then their
/// previous positions (its indices and skin are its source's).
#[derive(Clone, Copy, Debug)]
pub struct GpuMesh {
    /// Byte offset of the first vertex in the pool buffer.
    pub offset: u64,
    /// Bytes of its range.
    pub bytes: u64,
    /// Number of indices.
    pub index_count: u32,
    /// Number of vertices.
    pub vertex_count: u32,
    /// Whether joints and weights follow the indices.
    pub skinned: bool,
    /// Morph targets (their offsets follow the skin).
    pub morph_targets: u32,
    /// The skinned mesh a posed mesh copies.
    pub source: Option<MeshId>,
    /// Indices of each coarser level of detail (`crate::lod`), which follow level 0's.
    pub lod_counts: [u32; LOD_LEVELS as usize],
    /// Each coarser level's error (a fraction of the mesh's bounds' diagonal).
    pub lod_errors: [f32; LOD_LEVELS as usize],
    /// Bytes of the skinning pass's table of its levels' vertices (`MeshLods::skin_table`),
    /// which follows the skin; 0 without.
    pub skin_table_bytes: u64,
    /// The range its texture coordinates are packed over (`crate::scene::vertex`; a posed
    /// mesh's are its source's).
    pub uv: crate::scene::UvRange,
}

impl GpuMesh {
    /// Byte offset of the first index in the pool buffer (a posed mesh's are its source's).
    pub fn index_offset(&self) -> u64 {
        self.offset + self.vertex_count as u64 * std::mem::size_of::<crate::scene::GpuVertex>() as u64
    }

    /// Indices of every level together (level 0 and the coarser levels after it).
    pub(super) fn all_indices(&self) -> u64 {
        self.index_count as u64 + self.lod_counts.iter().map(|&c| c as u64).sum::<u64>()
    }

    /// Byte offset of the joints and weights of a skinned mesh (after every level's indices).
    pub(super) fn skin_offset(&self) -> u64 {
        (self.index_offset() + self.all_indices() * 4).next_multiple_of(16)
    }

    /// Byte offset of the skinning pass's table of its levels' vertices (after the skin).
    pub(super) fn skin_table_offset(&self) -> u64 {
        let skin = if self.skinned { self.vertex_count as u64 * std::mem::size_of::<GpuSkinVertex>() as u64 } else { 0 };
        (self.skin_offset() + skin).next_multiple_of(16)
    }

    /// Byte offset of the morph targets' offsets (after the skin and its levels' table, if
    /// any).
    pub(super) fn morph_offset(&self) -> u64 {
        (self.skin_table_offset() + self.skin_table_bytes).next_multiple_of(16)
    }

    /// The table entry of a mesh that is not posed.
    pub(super) fn info(&self, pool: vk::DeviceAddress) -> GpuMeshInfo {
        let vertices = pool + self.offset;
        GpuMeshInfo {
            vertices,
            indices: pool + self.index_offset(),
            first_index: (self.index_offset() / 4) as u32,
            index_count: self.index_count,
            vertex_offset: (self.offset / std::mem::size_of::<crate::scene::GpuVertex>() as u64) as u32,
            vertex_count: self.vertex_count,
            rest: vertices,
            skin: if self.skinned { pool + self.skin_offset() } else { 0 },
            morphs: if self.morph_targets > 0 { pool + self.morph_offset() } else { 0 },
            morph_targets: self.morph_targets,
            lod_levels: self.lod_counts.iter().take_while(|&&c| c > 0).count() as u32,
            uv_offset: self.uv.offset,
            uv_scale: self.uv.scale,
            pad: [0; 2],
            lod_first: std::array::from_fn(|level| {
                let before: u64 = self.index_count as u64 + self.lod_counts[..level].iter().map(|&c| c as u64).sum::<u64>();
                (self.index_offset() / 4 + before) as u32
            }),
            lod_count: self.lod_counts,
            lod_error: self.lod_errors.into(),
            vertex_levels: if self.skin_table_bytes > 0 { pool + self.skin_table_offset() } else { 0 },
        }
    }

    /// The table entry of a posed mesh: its own vertices over its source's indices, rest
    /// vertices and skin. Nothing to draw or skin when the source is gone or no longer has its
    /// vertex count (it was replaced).
    pub(super) fn posed_info(&self, pool: vk::DeviceAddress, source: Option<&GpuMesh>) -> GpuMeshInfo {
        let posable = |s: &&GpuMesh| (s.skinned || s.morph_targets > 0) && s.vertex_count == self.vertex_count;
        let Some(source) = source.filter(posable) else { return GpuMeshInfo::default() };
        let vertices = pool + self.offset;
        GpuMeshInfo {
            vertices,
            vertex_offset: (self.offset / std::mem::size_of::<crate::scene::GpuVertex>() as u64) as u32,
            ..source.info(pool)
        }
    }
}

/// The bytes a posed mesh of `vertices` takes: its vertices and, 16-byte aligned after them, a
/// previous position (vec4) each.
pub(super) fn posed_bytes(vertices: u32) -> u64 {
    crate::scene::vertex::previous_positions_offset(vertices) + vertices as u64 * 16
}

/// The skinning pass's table of a skinned mesh's levels (`MeshLods::skin_table`; empty without).
pub(super) fn skin_table(m: &MeshData) -> Vec<u32> {
    match &m.lods {
        Some(lods) if !m.skin.is_empty() => lods.skin_table(m.vertices.len()),
        _ => Vec::new(),
    }
}

/// The bytes a mesh takes in the pool: vertices, indices, then (each 16-byte aligned) its skin
/// and its morph targets.
pub(super) fn mesh_bytes(m: &MeshData) -> u64 {
    let mut bytes = RangeAllocator::mesh_bytes(m.vertices.len(), m.indices.len() + m.lods.as_ref().map_or(0, |l| l.indices.len()));
    if !m.skin.is_empty() {
        bytes = bytes.next_multiple_of(16) + (m.skin.len() * std::mem::size_of::<GpuSkinVertex>()) as u64;
        bytes = bytes.next_multiple_of(16) + skin_table(m).len() as u64 * 4;
    }
    if !m.morphs.is_empty() {
        bytes = bytes.next_multiple_of(16) + std::mem::size_of_val(m.morphs.as_slice()) as u64;
    }
    bytes
}

/// What the mesh pool does this frame.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub(super) enum PoolPlan {
    Keep,
    /// Repack the live meshes into a buffer of this many bytes.
    Repack(u64),
    /// No mesh has been live for a while: the buffer goes.
    Release,
}

impl GpuScene {
    /// Once a frame: returns ranges whose frames have completed, and decides whether the pool
    /// is repacked (to fit `incoming`, or smaller by the shrink rule) or released.
    pub(super) fn plan_pool(&mut self, completed: u64, incoming: &[u64]) -> PoolPlan {
        let ranges = &mut self.ranges;
        self.released_ranges.retain(|&(after, offset, bytes)| {
            let done = after <= completed;
            if done {
                ranges.free(offset, bytes);
            }
            !done
        });
        let live: u64 = self.meshes.iter().flatten().map(|m| footprint(m.bytes)).sum();
        if !incoming.is_empty() {
            let sizes = incoming.iter().copied();
            let mut trial = self.ranges.clone();
            if self.mesh_pool.is_some() && sizes.clone().all(|size| trial.alloc(size).is_some()) {
                return PoolPlan::Keep;
            }
            let need = live + sizes.map(footprint).sum::<u64>();
            return PoolPlan::Repack(need.next_power_of_two().max(POOL_FLOOR).max(self.ranges.capacity()));
        }
        let Some(pool) = self.mesh_pool.as_ref() else { return PoolPlan::Keep };
        if live == 0 {
            return if self.pool_shrink.unused() { PoolPlan::Release } else { PoolPlan::Keep };
        }
        match self.pool_shrink.check(pool.size, live, POOL_FLOOR) {
            Some(capacity) => PoolPlan::Repack(capacity),
            None => PoolPlan::Keep,
        }
    }

    /// Carries out the pool's `plan` (the live meshes copied into a new buffer, back to back),
    /// then places the pending meshes and prepares their copies.
    pub(super) fn prepare_meshes(
        &mut self,
        up: &mut Upload,
        copies: &mut CopyList,
        mirror: &mut SceneMirror,
        plan: PoolPlan,
    ) -> Result<(), RenderError> {
        let ctx = up.ctx;
        match plan {
            PoolPlan::Keep => {}
            PoolPlan::Release => {
                if let Some(old) = self.mesh_pool.take() {
                    up.bury_shrunk(old, 0);
                }
                self.ranges = RangeAllocator::default();
                self.released_ranges.clear();
                self.pool_shrink.reset();
            }
            PoolPlan::Repack(capacity) => {
                let new = Buffer::new(ctx, "mesh pool", capacity, self.mesh_usage, MemoryLocation::GpuOnly)?;
                let mut end = 0u64;
                if let Some(old) = self.mesh_pool.as_ref() {
                    let mut copy = copies.buffer_copy(old.raw, new.raw);
                    for mesh in self.meshes.iter_mut().flatten() {
                        copy.push(mesh.offset, end, mesh.bytes);
                        mesh.offset = end;
                        end += footprint(mesh.bytes);
                    }
                }
                self.refresh_infos(new.address, |_| true);
                if let Some(old) = self.mesh_pool.replace(new) {
                    if capacity < old.size {
                        up.bury_shrunk(old, capacity);
                    } else {
                        up.graveyard.bury(up.frame_value, Retired::Buffer(old));
                    }
                }
                tracing::debug!(bytes = capacity, live = end, "mesh pool repacked");
                self.ranges = RangeAllocator::packed(capacity, end);
                self.released_ranges.clear();
                self.pool_shrink.reset();
            }
        }
        if mirror.pending_meshes.is_empty() && mirror.pending_posed.is_empty() {
            return Ok(());
        }
        let pending = std::mem::take(&mut mirror.pending_meshes);
        let total: u64 = pending.iter().map(|(_, m)| mesh_bytes(m) + 16).sum();
        let pool = self.mesh_pool.as_ref().expect("planned for the pending meshes");
        let pool_address = pool.address;
        let mut placed = Vec::with_capacity(pending.len() + mirror.pending_posed.len());
        if total > 0 {
            let mut staging = Buffer::new(ctx, "mesh staging", total, vk::BufferUsageFlags::TRANSFER_SRC, MemoryLocation::CpuToGpu)?;
            let mut offset = 0u64;
            for (id, data) in &pending {
                let uv = crate::scene::UvRange::of(&data.vertices);
                if uv.scale[0].max(uv.scale[1]) > crate::scene::vertex::WIDE_UV_SPAN {
                    tracing::warn!(
                        mesh = id.0,
                        span = uv.scale[0].max(uv.scale[1]),
                        step = uv.step(),
                        "a mesh's texture coordinates span more than {} tiles: their 16-bit vertex form keeps steps of the span / 65,535",
                        crate::scene::vertex::WIDE_UV_SPAN
                    );
                }
                let vbytes = data.vertices.len() * std::mem::size_of::<crate::scene::GpuVertex>();
                let ibytes: &[u8] = bytemuck::cast_slice(&data.indices);
                let lods = data.lods.clone().unwrap_or_default();
                let lbytes: &[u8] = bytemuck::cast_slice(&lods.indices);
                let size = mesh_bytes(data);
                let table = skin_table(data);
                let place = self.ranges.alloc(size).expect("the plan made room for every pending mesh");
                let mesh = GpuMesh {
                    offset: place,
                    bytes: size,
                    index_count: data.indices.len() as u32,
                    vertex_count: data.vertices.len() as u32,
                    skinned: !data.skin.is_empty(),
                    morph_targets: data.morph_targets,
                    source: None,
                    lod_counts: lods.counts,
                    lod_errors: lods.errors,
                    skin_table_bytes: table.len() as u64 * 4,
                    uv,
                };
                let mapped = staging.mapped();
                let o = offset as usize;
                // Packed straight into the staging memory (`crate::scene::vertex`).
                for (out, v) in mapped[o..o + vbytes].chunks_exact_mut(std::mem::size_of::<crate::scene::GpuVertex>()).zip(&data.vertices) {
                    out.copy_from_slice(bytemuck::bytes_of(&v.pack(&uv)));
                }
                let o = o + vbytes;
                mapped[o..o + ibytes.len()].copy_from_slice(ibytes);
                let o = o + ibytes.len();
                mapped[o..o + lbytes.len()].copy_from_slice(lbytes);
                let o = offset as usize;
                // The skin, its levels' table and the morph targets where the mesh's offsets say
                // (relative to it).
                for (at, bytes) in [
                    (mesh.skin_offset(), bytemuck::cast_slice::<_, u8>(&data.skin)),
                    (mesh.skin_table_offset(), bytemuck::cast_slice(&table)),
                    (mesh.morph_offset(), bytemuck::cast_slice(&data.morphs)),
                ] {
                    let s = o + (at - place) as usize;
                    mapped[s..s + bytes.len()].copy_from_slice(bytes);
                }
                if size > 0 {
                    copies.buffer_copy(staging.raw, pool.raw).push(offset, place, size);
                }
                offset = (offset + size).next_multiple_of(16);
                up.bytes += size;
                placed.push((*id, mesh));
            }
            up.graveyard.bury(up.frame_value, Retired::Buffer(staging));
        }
        for (slot, mesh) in placed.drain(..) {
            self.place(slot, mesh, up.frame_value);
        }
        // Posed meshes: room only (the skinning pass writes them before anything reads them).
        for (id, source) in std::mem::take(&mut mirror.pending_posed) {
            let Some(src) = self.mesh(source).copied() else { continue };
            let size = posed_bytes(src.vertex_count);
            let place = self.ranges.alloc(size).expect("the plan made room for every posed mesh");
            let mesh = GpuMesh {
                offset: place,
                bytes: size,
                index_count: src.index_count,
                vertex_count: src.vertex_count,
                skinned: false,
                morph_targets: 0,
                source: Some(source),
                lod_counts: [0; LOD_LEVELS as usize],
                lod_errors: [0.0; LOD_LEVELS as usize],
                skin_table_bytes: 0,
                uv: src.uv,
            };
            self.place(id, mesh, up.frame_value);
        }
        self.refresh_infos(pool_address, |_| true);
        Ok(())
    }

    /// The pool bytes this frame's new meshes and posed meshes ask for (a posed mesh of a
    /// source not uploaded asks nothing: it is skipped).
    pub(super) fn incoming_sizes(&self, mirror: &SceneMirror) -> Vec<u64> {
        if mirror.pending_meshes.is_empty() && mirror.pending_posed.is_empty() {
            return Vec::new();
        }
        let mut sizes: Vec<u64> = mirror.pending_meshes.iter().map(|(_, m)| mesh_bytes(m)).collect();
        for &(_, source) in &mirror.pending_posed {
            let pending = mirror.pending_meshes.iter().rev().find(|(id, _)| *id == source).map(|(_, m)| m.vertices.len() as u32);
            if let Some(vertices) = pending.or_else(|| self.mesh(source).map(|m| m.vertex_count)) {
                sizes.push(posed_bytes(vertices));
            }
        }
        sizes
    }

    /// Records mesh `id`'s place, releasing the range it replaces.
    pub(super) fn place(&mut self, id: MeshId, mesh: GpuMesh, frame_value: u64) {
        let slot = id.0 as usize;
        if self.meshes.len() <= slot {
            self.meshes.resize_with(slot + 1, || None);
        }
        if self.mesh_info.len() <= slot {
            self.mesh_info.resize(slot + 1, GpuMeshInfo::default());
        }
        if mesh.source.is_some() {
            self.posed_bytes += mesh.bytes;
        }
        if let Some(old) = self.meshes[slot].replace(mesh) {
            self.released_ranges.push((frame_value, old.offset, old.bytes));
            if old.source.is_some() {
                self.posed_bytes -= old.bytes;
            }
        }
    }

    /// Rewrites the table entries of the meshes `which` picks (posed ones from their sources).
    pub(super) fn refresh_infos(&mut self, pool: vk::DeviceAddress, which: impl Fn(&GpuMesh) -> bool) {
        for slot in 0..self.meshes.len() {
            let Some(mesh) = self.meshes[slot].filter(|m| which(m)) else { continue };
            self.mesh_info[slot] = match mesh.source {
                Some(source) => mesh.posed_info(pool, self.mesh(source)),
                None => mesh.info(pool),
            };
        }
        self.mesh_info_dirty = true;
    }

    /// The mesh for `id`, once uploaded.
    pub fn mesh(&self, id: MeshId) -> Option<&GpuMesh> {
        self.meshes.get(id.0 as usize).and_then(Option::as_ref)
    }

    /// The addresses of the vertices and indices of mesh `id` and its vertex count, once
    /// uploaded (acceleration-structure builds read them).
    pub fn mesh_geometry(&self, id: MeshId) -> Option<(vk::DeviceAddress, vk::DeviceAddress, u32)> {
        let (mesh, info) = (self.mesh(id)?, self.mesh_info.get(id.0 as usize)?);
        // A posed mesh's indices are its source's; one whose source went has nothing to build.
        (info.index_count > 0 || mesh.index_count == 0).then_some((info.vertices, info.indices, mesh.vertex_count))
    }

    /// The mesh pool's buffer, which every mesh draw binds as its vertex and index buffer.
    pub fn pool_buffer(&self) -> Option<vk::Buffer> {
        self.mesh_pool.as_ref().map(|b| b.raw)
    }

    /// Bytes of the mesh pool that posed meshes' copies hold (their vertices and previous
    /// positions).
    pub fn posed_bytes(&self) -> u64 {
        self.posed_bytes
    }

    /// Bytes of the mesh pool's buffer (0 without one).
    pub fn pool_bytes(&self) -> u64 {
        self.mesh_pool.as_ref().map_or(0, |b| b.size)
    }
}
