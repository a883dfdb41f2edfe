//! The mesh pool: the vertices and indices of every mesh in one buffer, so that one indirect
//! draw (`vkCmdDrawIndexedIndirectCount`, `crate::culling`) covers every mesh of a batch: each
//! command names its mesh by `firstIndex` and `vertexOffset` into the same bound buffer.
//!
//! - **Ranges**: a mesh takes one range, its vertices (24-byte [`GpuVertex`]es) then its
//!   indices, aligned to [`GRANULE`] bytes so that both offsets are whole vertices and indices.
//!   Ranges come first-fit from a sorted free list that merges neighbours ([`RangeAllocator`]).
//! - **Freeing**: a freed range returns to the free list only once the GPU has finished every
//!   frame that could read it (like bindless texture slots), so an upload never overwrites
//!   geometry a pending frame draws.
//! - **Growth and shrinking**: when a mesh does not fit, the pool is *repacked* into a buffer
//!   of the next power of two that holds everything: the live meshes are copied on the GPU, back
//!   to back, and their offsets change (the mesh table, which every reader goes through, is
//!   uploaded again; acceleration structures keep their own copies of the geometry). When the
//!   bytes in use have stayed at or below a quarter of the buffer for
//!   [`crate::gpu::device::GpuContext::shrink_after_frames`] frames, it is repacked smaller, never below
//!   [`POOL_FLOOR`]; with no mesh at all for as long, the buffer is released. Repacking also
//!   undoes fragmentation.

use crate::scene::GpuVertex;

/// Alignment of a mesh's range: a whole number of vertices (24 bytes) and of indices (4), and
/// 16 bytes.
pub const GRANULE: u64 = 48;
const _: () = assert!(GRANULE.is_multiple_of(std::mem::size_of::<GpuVertex>() as u64) && GRANULE.is_multiple_of(16));

/// The bytes a range asked for `size` takes in the pool: whole granules, at least one.
pub fn footprint(size: u64) -> u64 {
    size.next_multiple_of(GRANULE).max(GRANULE)
}

/// The smallest pool buffer (1 MiB).
pub const POOL_FLOOR: u64 = 1 << 20;

/// Free ranges of a buffer of `capacity` bytes: sorted, never adjacent (neighbours merge).
#[derive(Clone, Debug, Default)]
pub struct RangeAllocator {
    free: Vec<(u64, u64)>,
    capacity: u64,
    used: u64,
}

impl RangeAllocator {
    /// All of `capacity` free.
    pub fn new(capacity: u64) -> Self {
        Self { free: if capacity > 0 { vec![(0, capacity)] } else { Vec::new() }, capacity, used: 0 }
    }

    /// `capacity` bytes of which the first `used` are taken (after a repack).
    pub fn packed(capacity: u64, used: u64) -> Self {
        let free = if used < capacity { vec![(used, capacity - used)] } else { Vec::new() };
        Self { free, capacity, used }
    }

    /// Takes `size` bytes (rounded up to [`GRANULE`]) from the first free range that holds
    /// them; `None` when none does.
    pub fn alloc(&mut self, size: u64) -> Option<u64> {
        let size = footprint(size);
        let i = self.free.iter().position(|&(_, len)| len >= size)?;
        let (start, len) = self.free[i];
        if len == size {
            self.free.remove(i);
        } else {
            self.free[i] = (start + size, len - size);
        }
        self.used += size;
        Some(start)
    }

    /// Returns a range [`RangeAllocator::alloc`] gave out (`size` as asked for then).
    pub fn free(&mut self, offset: u64, size: u64) {
        let size = footprint(size);
        let i = self.free.partition_point(|&(start, _)| start < offset);
        debug_assert!(i == 0 || self.free[i - 1].0 + self.free[i - 1].1 <= offset, "a range freed twice");
        self.free.insert(i, (offset, size));
        if i + 1 < self.free.len() && offset + size == self.free[i + 1].0 {
            self.free[i].1 += self.free[i + 1].1;
            self.free.remove(i + 1);
        }
        if i > 0 && self.free[i - 1].0 + self.free[i - 1].1 == offset {
            self.free[i - 1].1 += self.free[i].1;
            self.free.remove(i);
        }
        self.used -= size;
    }

    /// Bytes taken.
    pub fn used(&self) -> u64 {
        self.used
    }

    /// Bytes of the buffer.
    pub fn capacity(&self) -> u64 {
        self.capacity
    }

    /// The bytes a mesh of `vertices` and `indices` takes: its vertices, then its indices.
    pub fn mesh_bytes(vertices: usize, indices: usize) -> u64 {
        (vertices * std::mem::size_of::<GpuVertex>() + indices * 4) as u64
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn ranges_are_reused_and_merge() {
        let mut a = RangeAllocator::new(10 * GRANULE);
        let x = a.alloc(GRANULE).unwrap();
        let y = a.alloc(2 * GRANULE - 5).unwrap();
        let z = a.alloc(GRANULE).unwrap();
        assert_eq!((x, y, z), (0, GRANULE, 3 * GRANULE), "granule-aligned, first fit");
        assert_eq!(a.used(), 4 * GRANULE);
        assert_eq!(a.alloc(7 * GRANULE), None, "six granules are left");
        a.free(y, 2 * GRANULE - 5);
        assert_eq!(a.alloc(2 * GRANULE).unwrap(), GRANULE, "the hole is reused");
        a.free(x, GRANULE);
        a.free(GRANULE, 2 * GRANULE);
        a.free(z, GRANULE);
        assert_eq!(a.used(), 0);
        assert_eq!(a.alloc(10 * GRANULE), Some(0), "freed neighbours merged back into one range");
    }

    #[test]
    fn a_packed_pool_continues_after_its_meshes() {
        let mut a = RangeAllocator::packed(4 * GRANULE, 3 * GRANULE);
        assert_eq!(a.alloc(GRANULE), Some(3 * GRANULE));
        assert_eq!(a.alloc(1), None);
    }
}
