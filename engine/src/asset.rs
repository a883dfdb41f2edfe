//! Generational asset storage: [`Assets<T>`] hands out copyable [`Handle<T>`]s and records
//! [`AssetEvent`]s that one consumer (the render plugin) drains each frame to mirror the assets
//! on the GPU.
//!
//! Slots are reused after removal with a bumped generation, so a stale handle never aliases a
//! newer asset: it simply returns `None`.

use std::cmp::Ordering;
use std::fmt;
use std::hash::{Hash, Hasher};
use std::marker::PhantomData;

use bevy_ecs::resource::Resource;

/// A typed reference to an asset in [`Assets<T>`].
pub struct Handle<T> {
    index: u32,
    generation: u32,
    _marker: PhantomData<fn() -> T>,
}

impl<T> Handle<T> {
    fn new(index: u32, generation: u32) -> Self {
        Handle { index, generation, _marker: PhantomData }
    }

    /// The slot index: dense and small, suitable for indexing GPU tables.
    pub fn index(&self) -> u32 {
        self.index
    }

    /// The generation of the slot this handle was created for.
    pub fn generation(&self) -> u32 {
        self.generation
    }
}

impl<T> Clone for Handle<T> {
    fn clone(&self) -> Self {
        *self
    }
}

impl<T> Copy for Handle<T> {}

impl<T> PartialEq for Handle<T> {
    fn eq(&self, other: &Self) -> bool {
        self.index == other.index && self.generation == other.generation
    }
}

impl<T> Eq for Handle<T> {}

impl<T> Hash for Handle<T> {
    fn hash<H: Hasher>(&self, state: &mut H) {
        self.index.hash(state);
        self.generation.hash(state);
    }
}

impl<T> PartialOrd for Handle<T> {
    fn partial_cmp(&self, other: &Self) -> Option<Ordering> {
        Some(self.cmp(other))
    }
}

impl<T> Ord for Handle<T> {
    fn cmp(&self, other: &Self) -> Ordering {
        (self.index, self.generation).cmp(&(other.index, other.generation))
    }
}

impl<T> fmt::Debug for Handle<T> {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        let name = std::any::type_name::<T>();
        let short = name.rsplit("::").next().unwrap_or(name);
        write!(f, "Handle<{short}>({}v{})", self.index, self.generation)
    }
}

/// A change to an [`Assets<T>`] store.
pub enum AssetEvent<T> {
    /// An asset was added.
    Added(Handle<T>),
    /// An asset was mutably borrowed through [`Assets::get_mut`].
    Modified(Handle<T>),
    /// An asset was removed; its handle is now stale.
    Removed(Handle<T>),
}

impl<T> AssetEvent<T> {
    /// The handle the event is about.
    pub fn handle(&self) -> Handle<T> {
        match self {
            AssetEvent::Added(h) | AssetEvent::Modified(h) | AssetEvent::Removed(h) => *h,
        }
    }
}

impl<T> Clone for AssetEvent<T> {
    fn clone(&self) -> Self {
        *self
    }
}

impl<T> Copy for AssetEvent<T> {}

impl<T> PartialEq for AssetEvent<T> {
    fn eq(&self, other: &Self) -> bool {
        match (self, other) {
            (AssetEvent::Added(a), AssetEvent::Added(b))
            | (AssetEvent::Modified(a), AssetEvent::Modified(b))
            | (AssetEvent::Removed(a), AssetEvent::Removed(b)) => a == b,
            _ => false,
        }
    }
}

impl<T> Eq for AssetEvent<T> {}

impl<T> fmt::Debug for AssetEvent<T> {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            AssetEvent::Added(h) => write!(f, "Added({h:?})"),
            AssetEvent::Modified(h) => write!(f, "Modified({h:?})"),
            AssetEvent::Removed(h) => write!(f, "Removed({h:?})"),
        }
    }
}

struct Slot<T> {
    generation: u32,
    value: Option<T>,
}

/// Storage for assets of type `T`, addressed by generational [`Handle`]s.
#[derive(Resource)]
pub struct Assets<T: Send + Sync + 'static> {
    slots: Vec<Slot<T>>,
    free: Vec<u32>,
    len: usize,
    events: Vec<AssetEvent<T>>,
}

impl<T: Send + Sync + 'static> Default for Assets<T> {
    fn default() -> Self {
        Assets { slots: Vec::new(), free: Vec::new(), len: 0, events: Vec::new() }
    }
}

impl<T: Send + Sync + 'static> Assets<T> {
    /// Stores `asset` and returns its handle; records [`AssetEvent::Added`].
    pub fn add(&mut self, asset: T) -> Handle<T> {
        let handle = if let Some(index) = self.free.pop() {
            let slot = &mut self.slots[index as usize];
            slot.value = Some(asset);
            Handle::new(index, slot.generation)
        } else {
            let index = u32::try_from(self.slots.len()).expect("more than u32::MAX assets");
            self.slots.push(Slot { generation: 0, value: Some(asset) });
            Handle::new(index, 0)
        };
        self.len += 1;
        self.events.push(AssetEvent::Added(handle));
        handle
    }

    fn slot(&self, handle: Handle<T>) -> Option<&Slot<T>> {
        self.slots.get(handle.index as usize).filter(|slot| slot.generation == handle.generation)
    }

    /// The asset, or `None` if the handle is stale.
    pub fn get(&self, handle: Handle<T>) -> Option<&T> {
        self.slot(handle)?.value.as_ref()
    }

    /// Whether the handle refers to a live asset.
    pub fn contains(&self, handle: Handle<T>) -> bool {
        self.get(handle).is_some()
    }

    /// Mutable access; records [`AssetEvent::Modified`] when the handle is live.
    pub fn get_mut(&mut self, handle: Handle<T>) -> Option<&mut T> {
        let slot = self.slots.get_mut(handle.index as usize).filter(|slot| slot.generation == handle.generation)?;
        let value = slot.value.as_mut()?;
        self.events.push(AssetEvent::Modified(handle));
        Some(value)
    }

    /// Removes and returns the asset, making every copy of `handle` stale; records
    /// [`AssetEvent::Removed`].
    pub fn remove(&mut self, handle: Handle<T>) -> Option<T> {
        let slot = self.slots.get_mut(handle.index as usize).filter(|slot| slot.generation == handle.generation)?;
        let value = slot.value.take()?;
        slot.generation = slot.generation.wrapping_add(1);
        self.free.push(handle.index);
        self.len -= 1;
        self.events.push(AssetEvent::Removed(handle));
        Some(value)
    }

    /// Number of live assets.
    pub fn len(&self) -> usize {
        self.len
    }

    /// Whether no asset is live.
    pub fn is_empty(&self) -> bool {
        self.len == 0
    }

    /// The live assets with their handles, in slot order.
    pub fn iter(&self) -> impl Iterator<Item = (Handle<T>, &T)> + '_ {
        self.slots.iter().enumerate().filter_map(|(index, slot)| {
            let value = slot.value.as_ref()?;
            Some((Handle::new(index as u32, slot.generation), value))
        })
    }

    /// Records [`AssetEvent::Modified`] for every live asset, so that consumers process them all
    /// again (e.g. a renderer that was replaced and must upload everything).
    pub fn touch_all(&mut self) {
        let handles: Vec<_> = self.iter().map(|(h, _)| h).collect();
        self.events.extend(handles.into_iter().map(AssetEvent::Modified));
    }

    /// Events recorded since the last drain, oldest first. Meant for a single consumer.
    pub fn drain_events(&mut self) -> std::vec::Drain<'_, AssetEvent<T>> {
        self.events.drain(..)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn stale_handle_returns_none() {
        let mut assets = Assets::<String>::default();
        let a = assets.add("a".into());
        assert_eq!(assets.remove(a).as_deref(), Some("a"));
        let b = assets.add("b".into());
        assert_eq!(a.index(), b.index(), "slot is reused");
        assert_ne!(a, b);
        assert!(assets.get(a).is_none());
        assert!(assets.get_mut(a).is_none());
        assert!(assets.remove(a).is_none());
        assert_eq!(assets.get(b).map(String::as_str), Some("b"));
        assert_eq!(assets.len(), 1);
    }

    #[test]
    fn events_accumulate_until_drained() {
        let mut assets = Assets::<u32>::default();
        let a = assets.add(1);
        let b = assets.add(2);
        *assets.get_mut(a).unwrap() += 10;
        assets.remove(b);
        let events: Vec<_> = assets.drain_events().collect();
        assert_eq!(events, vec![AssetEvent::Added(a), AssetEvent::Added(b), AssetEvent::Modified(a), AssetEvent::Removed(b),]);
        assert_eq!(assets.drain_events().count(), 0);
        assert_eq!(assets.get(a), Some(&11));
        assert_eq!(assets.iter().map(|(h, v)| (h, *v)).collect::<Vec<_>>(), vec![(a, 11)]);
    }

    #[test]
    fn handles_order_by_index_then_generation() {
        let low = Handle::<u8>::new(1, 5);
        let high = Handle::<u8>::new(2, 0);
        assert!(low < high);
        assert!(Handle::<u8>::new(1, 1) < low);
    }
}
