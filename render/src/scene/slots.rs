//! Records in stable slots ([`SlotTable`]): the tables extraction writes and the uploader
//! drains only where dirty.

use std::cmp::Reverse;
use std::collections::BinaryHeap;

use bytemuck::Pod;

/// Records in stable slots with a free list, plus the set of slots written since the last drain.
///
/// [`SlotTable::insert`] takes the *lowest* free slot (a min-heap of free slots), so under churn
/// live records drift towards the low slots and the high ones empty; [`SlotTable::trim`] then
/// drops the free slots at the end, and the table's slot count (the high-water mark the GPU
/// buffer must hold, and that passes loop over) falls with what is live, where a stack of freed
/// slots would keep it at its peak forever. A live record never moves: extraction keys entities
/// by slot. A slot is dirty from `write` or a release until [`SlotTable::take_dirty`] hands it
/// to the uploader, or until a trim drops it (the slot no longer exists; the uploader re-parks
/// what the GPU holds past the new count where a table needs that, see
/// [`SlotTable::trimmed_tail`]).
#[derive(Clone, Debug)]
pub struct SlotTable<T: Pod> {
    records: Vec<T>,
    live: Vec<bool>,
    /// Free slots below `records.len()`, lowest first.
    free: BinaryHeap<Reverse<u32>>,
    dirty: Vec<u32>,
    is_dirty: Vec<bool>,
    live_count: usize,
    /// The slot count at the last drain: what the GPU buffer was last brought up to.
    synced: u32,
}

impl<T: Pod> Default for SlotTable<T> {
    fn default() -> Self {
        Self {
            records: Vec::new(),
            live: Vec::new(),
            free: BinaryHeap::new(),
            dirty: Vec::new(),
            is_dirty: Vec::new(),
            live_count: 0,
            synced: 0,
        }
    }
}

impl<T: Pod> SlotTable<T> {
    /// Takes the lowest free slot (or appends one) and writes `record` into it.
    pub fn insert(&mut self, record: T) -> u32 {
        let slot = match self.free.pop() {
            Some(Reverse(slot)) => slot,
            None => {
                self.records.push(T::zeroed());
                self.live.push(false);
                self.is_dirty.push(false);
                (self.records.len() - 1) as u32
            }
        };
        debug_assert!(!self.live[slot as usize], "the free list holds only free slots");
        self.live[slot as usize] = true;
        self.live_count += 1;
        self.write(slot, record);
        slot
    }

    /// Overwrites a live slot. Panics on a slot that was never allocated (a bug in the caller).
    pub fn write(&mut self, slot: u32, record: T) {
        let i = slot as usize;
        debug_assert!(self.live[i], "write to a free slot {slot}");
        self.records[i] = record;
        self.mark_dirty(slot);
    }

    /// Releases a slot; its record is zeroed (an empty light, an unused instance) and uploaded.
    pub fn remove(&mut self, slot: u32) {
        self.release_with(slot, T::zeroed());
    }

    /// Releases a slot, leaving `parked` in it (uploaded like any record) until it is reused.
    pub fn release_with(&mut self, slot: u32, parked: T) {
        let i = slot as usize;
        if !self.live.get(i).copied().unwrap_or(false) {
            return;
        }
        self.live[i] = false;
        self.live_count -= 1;
        self.records[i] = parked;
        self.mark_dirty(slot);
        self.free.push(Reverse(slot));
    }

    /// Drops the free slots at the end of the table, so [`SlotTable::slot_count`] is one past
    /// the highest live slot (0 when none is live). Their pending uploads are dropped with them;
    /// live slots and their records are untouched. The renderer calls this once a frame, before
    /// anything reads the slot count; until then a released slot keeps its parked record.
    pub fn trim(&mut self) {
        let count = self.live.iter().rposition(|&live| live).map_or(0, |last| last + 1);
        if count == self.records.len() {
            return;
        }
        self.records.truncate(count);
        self.live.truncate(count);
        self.is_dirty.truncate(count);
        self.dirty.retain(|&slot| (slot as usize) < count);
        self.free.retain(|&Reverse(slot)| (slot as usize) < count);
    }

    /// Slots the GPU buffer was last brought up to that a trim has dropped since: from the slot
    /// count to the count at the last drain (empty when nothing was trimmed). The GPU still holds
    /// whatever was last uploaded there; a table whose readers go past the slot count (the decal
    /// boxes a BLAS build pads with) re-parks them.
    pub fn trimmed_tail(&self) -> std::ops::Range<u32> {
        self.slot_count()..self.synced.max(self.slot_count())
    }

    fn mark_dirty(&mut self, slot: u32) {
        let flag = &mut self.is_dirty[slot as usize];
        if !*flag {
            *flag = true;
            self.dirty.push(slot);
        }
    }

    /// The record in `slot`.
    pub fn get(&self, slot: u32) -> Option<&T> {
        self.live.get(slot as usize).copied().unwrap_or(false).then(|| &self.records[slot as usize])
    }

    /// All slots, live or free, as one contiguous array (what the GPU buffer holds).
    pub fn records(&self) -> &[T] {
        &self.records
    }

    /// One past the highest slot in use since the last [`SlotTable::trim`] (the GPU buffer must
    /// hold this many; passes loop over them).
    pub fn slot_count(&self) -> u32 {
        self.records.len() as u32
    }

    /// Number of live records.
    pub fn len(&self) -> usize {
        self.live_count
    }

    /// True when no record is live.
    pub fn is_empty(&self) -> bool {
        self.live_count == 0
    }

    /// Number of slots written since the last drain.
    pub fn dirty_count(&self) -> usize {
        self.dirty.len()
    }

    /// Sorts the dirty slots, passes them to `f` (which copies them out), then clears them.
    pub fn take_dirty(&mut self, mut f: impl FnMut(&[u32], &[T])) {
        self.dirty.sort_unstable();
        f(&self.dirty, &self.records);
        for &slot in &self.dirty {
            self.is_dirty[slot as usize] = false;
        }
        self.dirty.clear();
        self.synced = self.slot_count();
    }
}
