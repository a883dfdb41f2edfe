//! Device-local record tables ([`GpuTable`]) and the arrays the CPU rewrites whole
//! ([`WordArray`], [`SkinInput`]): how the mirror's dirty records reach them through the
//! staging ring.

use super::*;

/// A device-local array of records that grows geometrically and shrinks by the
/// [`Shrink`] rule, never below its initial capacity.
pub struct GpuTable {
    pub(super) name: &'static str,
    pub(super) buffer: Buffer,
    pub(super) capacity: u32,
    /// The initial capacity, which it never shrinks below.
    pub(super) floor: u32,
    pub(super) stride: u64,
    pub(super) extra_usage: vk::BufferUsageFlags,
    /// Fill the slots past the mirror's high-water mark when the buffer is (re)created, and
    /// those a trim drops, for readers that go past it (the decal BLAS build).
    pub(super) fill_tail: bool,
    pub(super) shrink: Shrink,
    /// The capacity this frame replaces the buffer with ([`GpuTable::plan`]).
    pub(super) planned: Option<u32>,
}

impl GpuTable {
    pub(super) fn new<T: Pod>(ctx: &GpuContext, name: &'static str, capacity: u32) -> Result<Self, RenderError> {
        Self::with_usage::<T>(ctx, name, capacity, vk::BufferUsageFlags::empty(), false)
    }

    pub(super) fn with_usage<T: Pod>(
        ctx: &GpuContext,
        name: &'static str,
        capacity: u32,
        extra_usage: vk::BufferUsageFlags,
        fill_tail: bool,
    ) -> Result<Self, RenderError> {
        let stride = std::mem::size_of::<T>() as u64;
        let buffer = Self::create(ctx, name, stride * capacity as u64, extra_usage)?;
        Ok(Self { name, buffer, capacity, floor: capacity, stride, extra_usage, fill_tail, shrink: ctx.shrink_rule(), planned: None })
    }

    pub(super) fn create(ctx: &GpuContext, name: &str, size: u64, extra_usage: vk::BufferUsageFlags) -> Result<Buffer, RenderError> {
        Buffer::of_kind(
            ctx,
            name,
            size,
            vk::BufferUsageFlags::STORAGE_BUFFER
                | vk::BufferUsageFlags::TRANSFER_DST
                | vk::BufferUsageFlags::SHADER_DEVICE_ADDRESS
                | extra_usage,
            MemoryLocation::GpuOnly,
            MemoryKind::Tables,
        )
    }

    /// Number of records the buffer holds.
    pub fn capacity(&self) -> u32 {
        self.capacity
    }

    /// Device address of record 0.
    pub fn address(&self) -> vk::DeviceAddress {
        self.buffer.address
    }

    /// The Vulkan buffer.
    pub fn buffer(&self) -> vk::Buffer {
        self.buffer.raw
    }

    /// Decides, once a frame, whether the buffer is replaced this frame for `slots` records:
    /// grown (geometrically) when they do not fit, shrunk by the [`Shrink`] rule. Returns
    /// true when it will be (every record must then be uploaded again).
    pub(super) fn plan(&mut self, slots: u32) -> bool {
        let smaller = self.shrink.check(self.capacity as u64, slots as u64, self.floor as u64);
        self.planned =
            if slots > self.capacity { Some(slots.next_power_of_two().max(self.capacity * 2)) } else { smaller.map(|c| c as u32) };
        self.planned.is_some()
    }

    /// Replaces the buffer as planned (the old one waits in the graveyard for the frames that
    /// use it). Returns true when it did, in which case every record must be uploaded again.
    pub(super) fn apply(&mut self, up: &mut Upload) -> Result<bool, RenderError> {
        let Some(capacity) = self.planned.take() else { return Ok(false) };
        let size = self.stride * capacity as u64;
        let old = std::mem::replace(&mut self.buffer, Self::create(up.ctx, self.name, size, self.extra_usage)?);
        if capacity < self.capacity {
            tracing::debug!(table = self.name, from = self.capacity, to = capacity, "table shrinks");
            up.bury_shrunk(old, size);
        } else {
            up.graveyard.bury(up.frame_value, Retired::Buffer(old));
        }
        self.shrink.reset();
        self.capacity = capacity;
        Ok(true)
    }

    /// The capacity the buffer has once this frame's plan is applied.
    pub(super) fn planned_capacity(&self) -> u32 {
        self.planned.unwrap_or(self.capacity)
    }
}

/// Fills `out` with records for unused slots from `first` on, made from the live records.
pub(super) type TailFn<T> = fn(&[T], u32, &mut [T]);

pub(super) fn decal_parking(live: &[GpuAabb], first: u32, out: &mut [GpuAabb]) {
    for (slot, parked) in out.iter_mut().zip(GpuAabb::parking(live, first, u32::MAX)) {
        *slot = parked;
    }
}

/// Clean bytes a copy region spans rather than end: two runs of dirty records at most this far
/// apart are copied as one region, the clean records between them included (they are the GPU's
/// already). A region costs the copy about as much as tens of kilobytes: an animation budget
/// that poses a quarter of 10,000 foxes a frame, scattered, left 2,500 one-record regions in the
/// culling table, 7 ms of the H200's upload pass, against one region when every fox moved.
pub(super) const MERGE_GAP_BYTES: u64 = 4096;

/// Clean bytes a frame's merges may copy, per dirty record of the table: what
/// [`staging_need`] reserves for them, so that merging never overruns the staging ring (a
/// merge that would pass it is not made).
pub(super) const MERGE_ALLOWANCE_BYTES: u64 = 512;

/// Copies the dirty records of `table` (or all of them after the buffer was replaced) through
/// the staging ring into `gpu`. Dirty slots at most [`MERGE_GAP_BYTES`] apart become one copy
/// region, within [`MERGE_ALLOWANCE_BYTES`] of clean records a dirty one (`bytes_uploaded`
/// counts the clean records copied with them). With a `tail`,
/// the slots past the table's count are filled with its records when the buffer is replaced,
/// and those a trim dropped are filled again.
pub(super) fn upload_table<T: Pod>(
    up: &mut Upload,
    copies: &mut CopyList,
    table: &mut SlotTable<T>,
    gpu: &mut GpuTable,
    tail: Option<TailFn<T>>,
) -> Result<(), RenderError> {
    let replaced = gpu.apply(up)?;
    let capacity = gpu.capacity;
    let trimmed = table.trimmed_tail();
    let refill = match tail {
        Some(_) if !replaced => trimmed.start.min(capacity)..trimmed.end.min(capacity),
        _ => 0..0,
    };
    if !replaced && table.dirty_count() == 0 && refill.is_empty() {
        return Ok(());
    }
    let stride = gpu.stride;
    let mut copy = copies.buffer_copy(up.staging.buffer(), gpu.buffer());
    let staging = &mut *up.staging;
    table.take_dirty(|dirty, records| {
        // Records `tail` makes for slots `range`, written straight into the staging ring.
        let mut park = |range: std::ops::Range<u32>| {
            let Some(tail) = tail.filter(|_| !range.is_empty()) else { return };
            let len = (range.end - range.start) as u64 * stride;
            let src = staging.push_with(len as usize, |dst| tail(records, range.start, bytemuck::cast_slice_mut(dst)));
            copy.push(src, range.start as u64 * stride, len);
        };
        if replaced {
            park(records.len() as u32..capacity);
            let bytes = bytemuck::cast_slice(records);
            if !bytes.is_empty() {
                copy.push(staging.push(bytes), 0, bytes.len() as u64);
            }
            return;
        }
        park(refill.clone());
        copy_runs(dirty, stride, |first, last| {
            let bytes = bytemuck::cast_slice(&records[first as usize..=last as usize]);
            copy.push(staging.push(bytes), first as u64 * stride, bytes.len() as u64);
        });
    });
    up.bytes += copy.bytes();
    Ok(())
}

/// A [`SlotTable`] of any record type, as the uploader sees it.
pub(super) trait DirtyTable {
    fn upload(&mut self, up: &mut Upload, copies: &mut CopyList, gpu: &mut GpuTable) -> Result<(), RenderError>;
}

impl<T: Pod> DirtyTable for SlotTable<T> {
    fn upload(&mut self, up: &mut Upload, copies: &mut CopyList, gpu: &mut GpuTable) -> Result<(), RenderError> {
        upload_table(up, copies, self, gpu, None)
    }
}

/// Uploads a whole array into `gpu` (replaced first when planned: [`GpuTable::plan`] with the
/// array's length). For small tables that change rarely (the mesh table, the deferred decal
/// order).
pub(super) fn upload_array(up: &mut Upload, copies: &mut CopyList, gpu: &mut GpuTable, bytes: &[u8]) -> Result<(), RenderError> {
    gpu.apply(up)?;
    if !bytes.is_empty() {
        let src = up.staging.push(bytes);
        copies.buffer_copy(up.staging_buffer(), gpu.buffer()).push(src, 0, bytes.len() as u64);
        up.bytes += bytes.len() as u64;
    }
    Ok(())
}

/// An array of 32-bit words the CPU rewrites whole (a draw order, a list of views), uploaded
/// with the next sync only when its contents changed.
pub struct WordArray {
    /// The GPU copy.
    pub table: GpuTable,
    pub(super) cpu: Vec<u32>,
    pub(super) dirty: bool,
}

impl WordArray {
    pub(super) fn new(ctx: &GpuContext, name: &'static str) -> Result<Self, RenderError> {
        Ok(Self { table: GpuTable::new::<u32>(ctx, name, 64)?, cpu: Vec::new(), dirty: false })
    }

    /// Replaces the words; they are uploaded with the next sync if they differ.
    pub fn set(&mut self, words: &[u32]) {
        if self.cpu != words {
            self.cpu.clear();
            self.cpu.extend_from_slice(words);
            self.dirty = true;
        }
    }

    /// The buffer's address.
    pub fn address(&self) -> vk::DeviceAddress {
        self.table.address()
    }

    pub(super) fn plan(&mut self) {
        if self.table.plan(self.cpu.len() as u32) {
            self.dirty = true;
        }
    }

    pub(super) fn staging_need(&self) -> u64 {
        if self.dirty { 2 * (4 * self.cpu.len()) as u64 } else { 0 }
    }
}

/// The skinning pass's input (`crate::skinning`): rewritten whole in each frame that skins,
/// by the pose table straight into the staging memory, so the poses' matrices are copied once on
/// the CPU (10,000 foxes: 11.5 MB a frame).
pub struct SkinInput {
    /// The GPU copy.
    pub table: GpuTable,
    pub(super) words: usize,
    pub(super) dirty: bool,
}

impl SkinInput {
    /// Uploads `words` 32-bit words of input with the next sync (none: nothing to upload).
    pub fn set_len(&mut self, words: usize) {
        self.words = words;
        self.dirty = words > 0;
    }

    /// The buffer's address.
    pub fn address(&self) -> vk::DeviceAddress {
        self.table.address()
    }

    pub(super) fn plan(&mut self) {
        // A replaced buffer needs nothing copied over: the input is this frame's alone.
        self.table.plan(self.words as u32);
    }

    pub(super) fn staging_need(&self) -> u64 {
        if self.dirty { (4 * self.words) as u64 } else { 0 }
    }
}

/// The copy regions of the sorted, distinct `dirty` slots of a table of `stride`-byte records,
/// as inclusive slot ranges handed to `region` in order: runs at most [`MERGE_GAP_BYTES`] apart
/// merge, the clean slots between them included, while the clean bytes copied stay within
/// [`MERGE_ALLOWANCE_BYTES`] a dirty slot.
pub(super) fn copy_runs(dirty: &[u32], stride: u64, mut region: impl FnMut(u32, u32)) {
    let gap = (MERGE_GAP_BYTES / stride.max(1)) as u32;
    let mut allowance = dirty.len() as u64 * MERGE_ALLOWANCE_BYTES;
    let mut i = 0;
    while i < dirty.len() {
        let first = dirty[i];
        let mut last = first;
        while i + 1 < dirty.len() && dirty[i + 1] <= last.saturating_add(1 + gap) {
            let clean = u64::from(dirty[i + 1] - last - 1) * stride;
            if clean > allowance {
                break;
            }
            allowance -= clean;
            i += 1;
            last = dirty[i];
        }
        region(first, last);
        i += 1;
    }
}

/// Bytes the dirty records of `table` need in the staging ring (worst case: all of them), after
/// the frame's [`GpuTable::plan`].
pub(super) fn staging_need<T: Pod>(table: &SlotTable<T>, gpu: &GpuTable) -> u64 {
    let stride = std::mem::size_of::<T>() as u64;
    if gpu.planned.is_some() {
        // The whole new capacity (records plus any tail), in two pieces.
        gpu.planned_capacity() as u64 * stride + 48
    } else {
        // A piece per dirty slot at most (slots close together share one, with the clean
        // records between them, up to the merges' allowance); a trimmed tail to re-park is one
        // more.
        let trimmed = if gpu.fill_tail { table.trimmed_tail() } else { 0..0 };
        table.dirty_count() as u64 * (stride + 16 + MERGE_ALLOWANCE_BYTES) + (trimmed.end - trimmed.start) as u64 * stride + 16
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn runs(dirty: &[u32], stride: u64) -> Vec<(u32, u32)> {
        let mut out = Vec::new();
        copy_runs(dirty, stride, |a, b| out.push((a, b)));
        out
    }

    /// A quarter of 10,000 culling records (32 bytes), scattered, go up as one region; runs
    /// farther apart than the gap stay apart; every dirty slot is covered, and the bytes copied
    /// stay within what the staging ring reserves for them.
    #[test]
    fn scattered_dirty_records_merge_into_few_regions_within_the_staging_reserve() {
        let scattered: Vec<u32> = (0..10_000u32).filter(|i| i.wrapping_mul(0x9E37_79B9) >> 30 == 0).collect();
        assert!((2_000..3_000).contains(&scattered.len()));
        assert_eq!(runs(&scattered, 32), [(scattered[0], *scattered.last().unwrap())], "one region");
        let far = [3u32, 4, 5, 1_000, 5_000];
        assert_eq!(runs(&far, 32), [(3, 5), (1_000, 1_000), (5_000, 5_000)], "128 records of 32 bytes is the gap");
        assert_eq!(runs(&[0, 100], 64), [(0, 0), (100, 100)], "64 records of 64 bytes is the gap");
        for (dirty, stride) in [(&scattered[..], 32u64), (&far[..], 32), (&[0u32, 7, 9, 300][..], 144)] {
            let regions = runs(dirty, stride);
            let covered = |s: &u32| regions.iter().any(|&(a, b)| (a..=b).contains(s));
            assert!(dirty.iter().all(covered));
            let bytes: u64 = regions.iter().map(|&(a, b)| u64::from(b - a + 1) * stride).sum();
            let reserve = dirty.len() as u64 * (stride + MERGE_ALLOWANCE_BYTES);
            assert!(bytes <= reserve, "{bytes} bytes copied, {reserve} reserved");
        }
        // Within the gap, the allowance (512 bytes a dirty record, 1,024 for two) decides.
        assert_eq!(runs(&[0, 30], 32), [(0, 30)], "29 clean records, 928 bytes: merged");
        assert_eq!(runs(&[0, 100], 32), [(0, 0), (100, 100)], "99 clean records, 3,168 bytes: apart");
    }
}
